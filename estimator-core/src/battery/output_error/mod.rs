//! Output-error refinement (beyond the paper): fit the *simulated* terminal
//! voltage to the measured one over `x = [ln R_i, ln R_ct, ln Q, α, U_oc]` by
//! Levenberg–Marquardt (and, over a sliding window, the OCV slope β; with
//! [`CellModel::ButlerVolmer`], the kinetic term's `ln a` and `ln i₀`).
//!
//! Why: the paper's regression ([`super::regression`]) carries the measured,
//! noisy voltage history inside its regressor (`−H[U_t]`), an
//! errors-in-variables problem, so its estimates are biased when the noise
//! is not tiny. Here the model is driven by the current alone:
//!
//! ```text
//! (1 + a)·U_p(l) = R_ct·I(l) − a·Σ_{j≥1} w_j·U_p(l−j),   a = R_ct·Q·h^(−α)
//! Û_t(l) = U_oc + R_i·I(l) + η(I(l)) + U_p(l),   minimize ½ Σ (U_t(l) − Û_t(l))²
//! ```
//!
//! with the Butler–Volmer overpotential `η(I) = a·asinh(I/i₀)` (0 in the
//! linear model). `η` is static, so its columns of the Jacobian are its own
//! derivatives `∂η/∂ln a = η` and `∂η/∂ln i₀ = −a·u/√(1+u²)`, `u = I/i₀`
//! (plus, with a history from data, the recursion's free response to their
//! negatives, as for `R_i`).
//!
//! The sensitivities `S = ∂U_p/∂p` follow the same recursion with other
//! drives (`E(l) = U_p(l) + Σ_{j≥1} w_j U_p(l−j)`, `g = h^(−α)`):
//!
//! ```text
//! p = R_ct : drive I(l) − Q·g·E(l)
//! p = Q    : drive −R_ct·g·E(l)
//! p = α    : drive a·ln h·E(l) − a·Σ_{j≥1} (∂w_j/∂α)·U_p(l−j)
//! ```
//!
//! With [`Start::FromData`] the first `M − 1` samples of the window supply
//! the history, `U_p = U_t − U_oc − R_i·I`; that history depends on `R_i` and
//! `U_oc` (and `η`), whose sensitivities are then the recursion's free
//! responses to `−I` and `−1` (and `−∂η`). Resistances and `Q` are searched in logarithms (positive
//! by construction, scale-free steps); the damping is Marquardt's
//! `λ·diag(JᵀJ)`.
//!
//! Over a sliding window the open-circuit voltage drifts with the state of
//! charge; a constant `U_oc` then lets a runaway `R_ct` (a pure constant-phase
//! integrator) mimic the drift. With [`BatterySettings::ocv_slope`] the model
//! carries `U_oc(l) = U_oc − β·c(l)`, `c(l) = h·Σ_{k>l} I(k)` the charge
//! still to flow to the newest sample, so `U_oc` is the value *now* and `β`
//! is `dOCV/dq` (the OCV curve's slope over the cell's capacity). The 8×8
//! system (the columns a setting keeps fixed are zero, with a tiny diagonal)
//! is solved by nalgebra's Cholesky on the stack. One call of [`OutputErrorRefinement::iterate`] is one accepted
//! (or finally rejected) LM step, `O(8·N·M)` (the recursions run in blocks
//! through the block kernels of [`crate::frac`], the six sensitivities two
//! at a time).
//!
//! An iteration does not simulate a trial whose step is below ε, or whose
//! predicted decrease `dxᵀb − ½dxᵀA dx` is below 100 ε of the cost (in
//! `f32` the cost does not resolve less); after an iteration that found no
//! lower cost, later ones on the same window return at once. After an
//! accepted step, the next iteration on the same window first applies that
//! test to the chord step `(J₀ᵀJ₀ + λD)⁻¹J₀ᵀr`, with the Jacobian `J₀` it
//! already has and the new residuals (`O(N)`), and stops there when even
//! that step is negligible: the six recursions of new sensitivities are
//! then not run. The chord step misses the change of the Jacobian over the
//! last step, so the exact step from such a stop is not always below ε, but
//! the decrease it would find is statistically invisible (test
//! `a_stop_on_the_last_jacobian_is_a_minimum`: Bates–Watts relative offset
//! below 0.001); a new sample's first iteration is always exact. Trials whose
//! relaxation time `τ^(1/α)` exceeds ten fitted windows are refused: such a
//! branch is not identifiable from the window, and `R_ct` could otherwise
//! run away along it.
//!
//! A NaN voltage in the window is an *unobserved* sample (a logger's
//! gap, a rejected row): its current still drives the model, but its
//! residual and its row of the Jacobian are zero, and it is not counted in
//! the rows. Such samples belong after the warm-up (a history from data
//! needs measured voltages). [`crate::window::SampleWindow`] refuses NaN;
//! a host's own [`Window`] over a logged record
//! passes them.
//!
//! Bounds are held, not crept up to. A resistance below 10⁻⁶ of
//! `R_i + R_ct` is at its bound 0 (its logarithm has none), and α at
//! `alpha_min` or `alpha_max` is at its bound: where the step would push
//! such a coordinate further out, it is held and the step is solved again
//! over the others. Without this a boundary optimum (R_i → 0 on a measured
//! pulse, α → 1) never converged: each step was clamped to one unit of
//! `ln R_i` while the other coordinates crawled, and a whole-record fit
//! ran out of its 200 iterations at R_i ≈ 10⁻⁸⁹ Ω.

use super::branch::{BranchSolver, GlRecursion};
use super::simulate::history;
use super::{current_std, BatterySettings, CellModel, CellParameters, Prior, Start};
use crate::error::Error;
use crate::frac::GlWeights;
use crate::real::Real;
use crate::tail::{PastModes, TailKernel, MODES};
use crate::window::Window;

mod blank;
mod information;
mod search;
mod sensitivities;
mod simulation;
#[cfg(test)]
mod tests;

pub use information::FitInformation;
use search::*;
pub use search::{AtBounds, LINE_SEARCH_BELOW, RESISTANCE_FLOOR};
use sensitivities::*;
use simulation::*;

/// Fewest fitted samples an iteration accepts.
pub const MIN_ROWS: usize = 8;
/// Largest number of damping increases tried in one iteration.
pub const MAX_TRIES: u8 = 10;
/// Largest step of a logarithmic parameter in one iteration (a factor e).
const MAX_LOG_STEP: f64 = 1.0;
/// Columns of the Jacobian: `x = [ln R_i, ln R_ct, ln Q, α, U_oc, β, ln a,
/// ln i₀]`.
pub const COLUMNS: usize = 8;
/// The names of the columns of `x`, in order (for reports).
pub const COLUMN_NAMES: [&str; COLUMNS] = [
    "ln_r_i", "ln_r_ct", "ln_q", "alpha", "u_oc", "beta", "ln_bv_a", "ln_bv_i0",
];
/// The columns of the linear model (its kinetic columns are zero).
const LINEAR_COLUMNS: usize = 6;
/// Entries of the packed upper triangle of a `COLUMNS × COLUMNS` matrix.
const PACKED: usize = COLUMNS * (COLUMNS + 1) / 2;
/// A square matrix over `x`.
type Square<T> = [[T; COLUMNS]; COLUMNS];

/// What one refinement iteration did.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RefinementStep<T> {
    /// Iteration counter since the last reset.
    pub k: u32,
    /// `½ Σ (U_t − Û_t)²` after the iteration (plus the prior's term when
    /// [`BatterySettings::prior`] is set).
    pub cost: T,
    /// Root-mean-square voltage error over the fitted samples (V).
    pub rmse: T,
    /// Largest relative parameter change (`|Δ ln p|`, `|Δα|`,
    /// `|ΔU_oc|/|U_oc|`).
    pub change: T,
    /// `change ≤ ε`, or a minimum: no damping found a lower cost, or the
    /// step was negligible (below ε or the cost's resolution; after an
    /// accepted step judged on the last Jacobian, see the module docs).
    pub converged: bool,
    /// True when the step was accepted (the cost decreased).
    pub accepted: bool,
    /// Why the iteration reports a minimum (`None` when not `converged`).
    pub stop: Option<StopReason>,
    /// Marquardt damping λ after the iteration.
    pub lambda: T,
    /// Number of fitted samples.
    pub rows: usize,
}

/// Why a refinement iteration reports a minimum
/// ([`RefinementStep::stop`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StopReason {
    /// An accepted step changed no parameter by more than ε
    /// ([`BatterySettings::epsilon`]).
    SmallStep,
    /// The step is below ε, or the decrease it predicts is below what the
    /// cost resolves (after an accepted step, judged on the last Jacobian:
    /// see the module docs); no simulation was spent on it.
    NegligibleStep,
    /// No damping found a lower cost: Marquardt's λ was raised
    /// [`MAX_TRIES`] times, or the same iteration on the same window would
    /// repeat such a one.
    NoLowerCost,
}

impl StopReason {
    /// The name in reports: `small_step`, `negligible_step` or
    /// `no_lower_cost`.
    pub fn as_str(self) -> &'static str {
        match self {
            StopReason::SmallStep => "small_step",
            StopReason::NegligibleStep => "negligible_step",
            StopReason::NoLowerCost => "no_lower_cost",
        }
    }
}

/// What the refinement has computed since it was made: the counters behind
/// its cost (each simulation and each sensitivity pass is `O(N·M)`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RefinementWork {
    /// Calls of [`OutputErrorRefinement::iterate`] that returned `Ok`.
    pub iterations: u32,
    /// Simulations of the window: of the estimate (after the window moved)
    /// and of trial steps.
    pub simulations: u32,
    /// Of those, the trial steps.
    pub trials: u32,
    /// Sensitivity passes (the Jacobian: six recursions, eight with the
    /// Butler–Volmer model from data, and one tap sum).
    pub linearizations: u32,
}

/// The output-error Levenberg–Marquardt refinement for a window of capacity
/// `N` and memory capacity `MEM`; about `13·N` scalars of state. `K` solves
/// the constant-phase recursion ([`super::branch`]): the direct
/// [`GlRecursion`] by default; a host's `O(N log N)` solver for
/// whole-record fits with the full memory.
///
/// ```
/// use estimator_core::battery::{
///     output_error::OutputErrorRefinement, simulate::simulate, BatterySettings, CellParameters,
/// };
/// use estimator_core::frac::GlWeights;
/// use estimator_core::window::SampleWindow;
///
/// const N: usize = 200;
/// let truth = CellParameters::<f64>::cell_18650();
/// let current: Vec<f64> = (0..N).map(|l| if (l / 20) % 2 == 0 { 3.0 } else { -3.0 }).collect();
/// let (mut up, mut v) = (vec![0.0; N], vec![0.0; N]);
/// let mut w = GlWeights::<f64, N>::new(truth.alpha, 1.0, N).unwrap();
/// simulate(&truth, &mut w, &current, |_| truth.u_oc, &mut up, &mut v).unwrap();
///
/// let mut window = SampleWindow::<f64, N>::new();
/// for (&i, &u) in current.iter().zip(&v) {
///     window.push(i, u).unwrap();
/// }
/// let s = BatterySettings::new(1.0, N);
/// let start = CellParameters { r_i: 0.01, r_ct: 0.03, q: 200.0, alpha: 0.6, u_oc: 3.6, ..truth };
/// let mut oe = OutputErrorRefinement::<f64, N, N>::new(&s, start).unwrap();
/// for _ in 0..50 {
///     if oe.iterate(&s, &window).unwrap().converged {
///         break;
///     }
/// }
/// let p = oe.cell();
/// assert!((p.r_ct / truth.r_ct - 1.0).abs() < 1e-6);
/// assert!((p.alpha - truth.alpha).abs() < 1e-6);
/// ```
#[derive(Clone, Debug)]
pub struct OutputErrorRefinement<T, const N: usize, const MEM: usize, K = GlRecursion> {
    p: CellParameters<T>,
    /// Solves the recursion of the simulation and the sensitivities.
    solver: K,
    lambda: T,
    k: u32,
    w: GlWeights<T, MEM>,
    i: [T; N],
    v: [T; N],
    /// The simulations of the estimate and of the trial (or scratch):
    /// `sims[held]` is the estimate's ([`Simulation`]). Accepting a trial
    /// flips `held` instead of copying three buffers.
    sims: [Simulation<T, N>; 2],
    s_rct: [T; N],
    s_q: [T; N],
    s_a: [T; N],
    s_ri: [T; N],
    s_uoc: [T; N],
    s_beta: [T; N],
    /// Free responses of `U_p` to the history's `−∂η/∂ln a` and
    /// `−∂η/∂ln i₀` (zero from rest and in the linear model).
    s_bva: [T; N],
    s_bvi0: [T; N],
    /// Charge still to flow from sample l to the newest one, `h·Σ_{k>l} I(k)` (A·s).
    c: [T; N],
    /// OCV slope dU_oc/dq inside the window (V/(A·s)); U_oc is the value at
    /// the newest sample.
    beta: T,
    /// `eta[..kinetic_kept]` of the estimate's simulation is the kinetic
    /// voltage of `p` at the loaded window's first currents: the
    /// estimate's simulation computes only the
    /// samples after them (a window slid by one keeps all but its newest:
    /// one `asinh` a sample and update instead of one a sample and
    /// simulation). Zero whenever `p` is set other than by an accepted
    /// trial (whose simulation, `eta` with it, becomes the estimate's).
    kinetic_kept: u32,
    /// Fitted samples (after `warm`) whose voltage is NaN: unobserved,
    /// left out of the cost, the Jacobian and the rows.
    unobserved: u32,
    n: usize,
    warm: usize,
    /// The modes of the loaded window's past (with `warm > 0`).
    past: Option<PastModes<T>>,
    stamp: Option<u32>,
    /// Which of `sims` is the estimate's (0 or 1; the other is the
    /// trial's, and scratch between iterations).
    held: u8,
    /// `sims[held]` holds the simulation of `p`, β over the loaded window.
    fresh: bool,
    /// The settings (their [`BatterySettings::fingerprint`]) of the last
    /// iteration when it found no lower cost on the loaded window from the
    /// current estimate (`fresh` then holds), and why.
    stalled: Option<(u64, StopReason)>,
    /// The linearization of the last iteration when it accepted a step on
    /// the loaded window (the sensitivity buffers still hold its Jacobian's
    /// columns).
    linear: Option<Linearization<T>>,
    /// The information of the last normal equations on the loaded window
    /// (the prior's included), for [`Self::last_information`].
    information: Option<FitInformation<T>>,
    /// `ln R_i` of a model-free measurement of `R_i` weighed with the data
    /// ([`Self::set_r_i_evidence`]).
    evidence: Option<T>,
    work: RefinementWork,
}

/// One simulation of the window: the polarization `U_p`, the history
/// sums `E(l) = U_p(l) + H(l)` the sensitivities' drives read, and the
/// kinetic voltages `η(I(l))` of its parameters.
#[derive(Clone, Debug)]
struct Simulation<T, const N: usize> {
    up: [T; N],
    e: [T; N],
    eta: [T; N],
}

impl<T: Real, const N: usize> Simulation<T, N> {
    const ZERO: Self = Self {
        up: [T::ZERO; N],
        e: [T::ZERO; N],
        eta: [T::ZERO; N],
    };
}

/// The estimate's simulation and the other one (the trial's, or scratch),
/// borrowed apart.
fn estimate_and_spare<T, const N: usize>(
    sims: &mut [Simulation<T, N>; 2],
    held: u8,
) -> (&Simulation<T, N>, &mut Simulation<T, N>) {
    let [a, b] = sims;
    if held & 1 == 0 {
        (a, b)
    } else {
        (b, a)
    }
}

/// The weight of [`OutputErrorRefinement::set_r_i_evidence`]'s term
/// `½·w·(ln R_i − ln R_step)²` in the cost: that of a [`super::Prior::new`]
/// on `R_i` alone (a factor 2 at one sigma with the data weighed at
/// σ_v = 0.1 V), `(0.1/ln 2)²`.
pub const R_I_EVIDENCE_WEIGHT: f64 =
    (0.1 / core::f64::consts::LN_2) * (0.1 / core::f64::consts::LN_2);

/// The part of [`OutputErrorRefinement`] a cell keeps between iterations
/// (small and `Copy`; the rest is working area).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefinementState<T> {
    p: CellParameters<T>,
    lambda: T,
    beta: T,
    k: u32,
    work: RefinementWork,
}

impl<T: Copy> RefinementState<T> {
    /// The counters of the work done for this cell.
    pub fn work(&self) -> RefinementWork {
        self.work
    }
}
impl<T: Real, const N: usize, const MEM: usize, K: BranchSolver<T>>
    OutputErrorRefinement<T, N, MEM, K>
{
    /// A refinement started from `start` (usually the paper method's
    /// estimate, or a cell's datasheet values).
    ///
    /// # Errors
    /// Settings errors; [`Error::BadSetting`] for a non-physical start or
    /// one whose order is outside the bounds.
    pub fn new(s: &BatterySettings<T>, start: CellParameters<T>) -> Result<Self, Error> {
        // `set_cell`'s checks and state, built in the return value (a
        // refinement built first and then set would be one more copy of
        // its arrays on the stack).
        s.check::<MEM>()?;
        if !start.is_physical() || start.alpha < s.alpha_min || start.alpha > s.alpha_max {
            return Err(Error::BadSetting);
        }
        Ok(Self {
            p: start,
            solver: K::default(),
            lambda: T::lit(LAMBDA0),
            k: 0,
            w: GlWeights::new(start.alpha, s.h, s.memory)?,
            i: [T::ZERO; N],
            v: [T::ZERO; N],
            sims: [Simulation::ZERO, Simulation::ZERO],
            s_rct: [T::ZERO; N],
            s_q: [T::ZERO; N],
            s_a: [T::ZERO; N],
            s_ri: [T::ZERO; N],
            s_uoc: [T::ZERO; N],
            s_beta: [T::ZERO; N],
            s_bva: [T::ZERO; N],
            s_bvi0: [T::ZERO; N],
            c: [T::ZERO; N],
            beta: T::ZERO,
            kinetic_kept: 0,
            unobserved: 0,
            n: 0,
            warm: 0,
            past: None,
            stamp: None,
            held: 0,
            fresh: false,
            stalled: None,
            linear: None,
            information: None,
            evidence: None,
            work: RefinementWork::default(),
        })
    }

    /// Restarts from `p` (keeps the window cache, resets k and λ).
    ///
    /// # Errors
    /// As [`OutputErrorRefinement::new`]; on error nothing changes.
    pub fn set_cell(&mut self, s: &BatterySettings<T>, p: CellParameters<T>) -> Result<(), Error> {
        s.check::<MEM>()?;
        if !p.is_physical() || p.alpha < s.alpha_min || p.alpha > s.alpha_max {
            return Err(Error::BadSetting);
        }
        self.w.set(p.alpha, s.h, s.memory)?;
        self.p = p;
        self.kinetic_kept = 0;
        self.beta = T::zero();
        self.k = 0;
        self.lambda = T::lit(LAMBDA0);
        self.fresh = false;
        self.stalled = None;
        self.linear = None;
        self.information = None;
        Ok(())
    }

    /// The [`state`](Self::state) of a new refinement started from
    /// `start` (without building one).
    pub fn initial_state(start: CellParameters<T>) -> RefinementState<T> {
        RefinementState {
            p: start,
            lambda: T::lit(LAMBDA0),
            beta: T::zero(),
            k: 0,
            work: RefinementWork::default(),
        }
    }

    /// What this refinement carries between samples for one cell: the
    /// estimate, the damping, the OCV slope and the counters. The rest of
    /// the type is working area over the loaded window (and caches of it),
    /// which a pack shares between its cells ([`resume`](Self::resume)
    /// reloads it).
    pub fn state(&self) -> RefinementState<T> {
        RefinementState {
            p: self.p,
            lambda: self.lambda,
            beta: self.beta,
            k: self.k,
            work: self.work,
        }
    }

    /// Takes up a cell's [`state`](Self::state): the next iteration
    /// continues that cell's refinement on whatever window it is given (the
    /// working area is reloaded and resimulated).
    ///
    /// # Errors
    /// [`Error::Frac`] for a bad period, order or memory; on error nothing
    /// changes.
    pub fn resume(&mut self, s: &BatterySettings<T>, st: &RefinementState<T>) -> Result<(), Error> {
        self.w.set(st.p.alpha, s.h, s.memory)?;
        self.p = st.p;
        self.kinetic_kept = 0;
        self.lambda = st.lambda;
        self.beta = st.beta;
        self.k = st.k;
        self.work = st.work;
        self.stamp = None;
        self.fresh = false;
        self.stalled = None;
        self.linear = None;
        self.information = None;
        Ok(())
    }

    /// The current estimate.
    pub fn cell(&self) -> CellParameters<T> {
        self.p
    }

    /// The OCV slope `dU_oc/dq` (V per A·s) identified inside the window
    /// when [`BatterySettings::ocv_slope`] is set (zero otherwise).
    pub fn ocv_slope(&self) -> T {
        self.beta
    }

    /// Iterations since the last [`set_cell`](Self::set_cell).
    pub fn iterations(&self) -> u32 {
        self.k
    }

    /// What has been computed since [`new`](Self::new) (wrapping counters).
    pub fn work(&self) -> RefinementWork {
        self.work
    }

    /// The simulated polarization voltage `U_p` of the current estimate over
    /// the loaded window (after an iteration), and the index of the first
    /// fitted sample.
    pub fn polarization(&self) -> (&[T], usize) {
        (&self.sims[self.est()].up[..self.n], self.warm)
    }

    /// The estimate and its simulated polarization over the loaded window
    /// (the last value is that window's newest sample's), with the
    /// window's [`Window::version`] when it was loaded, when the last
    /// iteration left them in step; `None` otherwise.
    pub fn simulated(&self) -> Option<(CellParameters<T>, &[T], u32)> {
        let stamp = self.stamp?;
        (self.fresh && self.n > 0 && self.n <= N)
            .then(|| (self.p, &self.sims[self.est()].up[..self.n], stamp))
    }

    /// The information of the last iteration's normal equations on the
    /// loaded window (`JᵀJ` of the data with the prior's, the data's cost
    /// at the estimate they were taken at, the fitted rows and columns),
    /// for the standard errors of what the window identifies; `None` before
    /// one on this window.
    pub fn last_information(&self) -> Option<&FitInformation<T>> {
        self.information.as_ref()
    }

    /// Weighs the window's data with a model-free measurement of `R_i`
    /// (Ω; `None`: none): the cost gains `½·w·(ln R_i − ln ohm)²` with
    /// `w =` [`R_I_EVIDENCE_WEIGHT`], as a prior on `R_i` alone would. For
    /// a window whose data do not separate `R_i` from the branch's fastest
    /// part (sampled slower than that part answers), the voltage step over
    /// a current step does. [`Self::last_information`] stays the data's
    /// (with the settings' prior): what the window alone identifies.
    /// A value that is not finite and positive is ignored.
    pub fn set_r_i_evidence(&mut self, ohm: Option<T>) {
        let ln = ohm
            .filter(|&r| r.is_finite() && r > T::zero())
            .map(|r| r.ln());
        if ln != self.evidence {
            // Another cost: what the last iteration found says nothing of it.
            self.stalled = None;
            self.linear = None;
            self.evidence = ln;
        }
    }

    /// The step resistance set by [`Self::set_r_i_evidence`] (Ω).
    pub fn r_i_evidence(&self) -> Option<T> {
        self.evidence.map(|c| c.exp())
    }

    /// The evidence's cost at `p` (zero without).
    pub(super) fn evidence_cost(evidence: Option<T>, p: &CellParameters<T>) -> T {
        evidence.map_or(T::zero(), |c| {
            let d = p.r_i.ln() - c;
            T::lit(R_I_EVIDENCE_WEIGHT) * d * d / T::lit(2.0)
        })
    }

    /// Adds the evidence's part to the normal equations at `p`.
    pub(super) fn add_evidence(
        &self,
        p: &CellParameters<T>,
        a: &mut Square<T>,
        b: &mut [T; COLUMNS],
    ) {
        if let Some(c) = self.evidence {
            let w = T::lit(R_I_EVIDENCE_WEIGHT);
            a[0][0] = a[0][0] + w;
            b[0] = b[0] + w * (c - p.r_i.ln());
        }
    }

    /// One-step prediction of the terminal voltage for the *next* sample at
    /// current `current`, from the model state of the last iteration; `None`
    /// before the first iteration. O(M).
    pub fn predict_next(&self, current: T) -> Option<T> {
        if !self.fresh || self.n == 0 || self.n > N {
            return None;
        }
        // U_p(n) from U_p(0..n).
        let h = history(
            self.w.weights(),
            &self.sims[self.est()].up[..self.n],
            self.n,
        );
        let a = self.p.tau() * self.w.scale();
        let up = (self.p.r_ct * current - a * h) / (T::one() + a);
        Some(self.p.u_oc + self.p.static_voltage(current) + up)
    }

    /// The index in `sims` of the estimate's simulation.
    #[inline(always)]
    fn est(&self) -> usize {
        usize::from(self.held & 1)
    }

    /// The index in `sims` of the other simulation (the trial's, or
    /// scratch).
    #[inline(always)]
    fn spare(&self) -> usize {
        1 - self.est()
    }

    fn load(&mut self, s: &BatterySettings<T>, win: &impl Window<T>) -> Result<(), Error> {
        if self.w.h() != s.h || self.w.len() != s.memory {
            self.w.set(self.p.alpha, s.h, s.memory)?;
            self.stamp = None;
        }
        let key = win.version();
        if self.stamp != Some(key) || self.n != win.len() {
            if self.p.bv_a != T::zero() && self.kinetic_kept > 0 {
                // The new currents into the trial buffer (free between
                // iterations) first: the kinetic voltages of the old ones
                // that the new window still holds are kept.
                let old = self.n.min(N);
                let (es, ts) = (self.est(), self.spare());
                let n = win.copy_into(&mut self.sims[ts].up, &mut self.v).min(N);
                let pushed = self.stamp.map(|st| key.wrapping_sub(st) as usize);
                let (dropped, kept) = kept_after_slide(
                    &self.i[..old],
                    &self.sims[ts].up[..n],
                    pushed,
                    self.kinetic_kept as usize,
                );
                // (`dropped + kept ≤ old ≤ N`: the test lets the optimizer
                // see it.)
                let kept = if kept > 0 && kept <= N && dropped <= N - kept {
                    self.sims[es].eta.copy_within(dropped..dropped + kept, 0);
                    kept
                } else {
                    0
                };
                self.kinetic_kept = kept as u32;
                self.i[..n].copy_from_slice(&self.sims[ts].up[..n]);
                self.n = n;
            } else {
                // (The linear model's kinetic voltages are zeros, written
                // whole by every simulation.)
                self.n = win.copy_into(&mut self.i, &mut self.v);
                self.kinetic_kept = 0;
            }
            self.warm = match s.start {
                _ if win.has_slid() => s.memory - 1,
                Start::AtRest => 0,
                Start::FromData if win.starts_at_rest() => 0,
                Start::FromData => s.memory - 1,
            };
            // From rest there is no past; from data it is the window's.
            self.past = if self.warm > 0 { win.past() } else { None };
            let fitted = self.v.get(self.warm..self.n.min(N)).unwrap_or(&[]);
            let unobserved = fitted.iter().filter(|v| v.is_nan()).count();
            self.unobserved = u32::try_from(unobserved).unwrap_or(u32::MAX);
            self.stamp = Some(key);
            self.fresh = false;
            self.information = None;
            if self.n > 0 {
                self.c[self.n - 1] = T::zero();
                for l in (0..self.n - 1).rev() {
                    self.c[l] = self.c[l + 1] + s.h * self.i[l + 1];
                }
            }
        }
        let need = self.warm + MIN_ROWS;
        if self.n < need {
            self.stamp = None;
            return Err(Error::NotEnoughData { have: self.n, need });
        }
        Ok(())
    }
}

/// After `pushed` samples (`None`: unknown) took the window from `old` to
/// `new`, the samples it dropped, `old + pushed − new`, and how many of
/// the first `valid` of `old` that it kept start `new`, checked bit for
/// bit (0 when they do not: then nothing is kept).
#[inline(never)]
fn kept_after_slide<T: Real>(
    old: &[T],
    new: &[T],
    pushed: Option<usize>,
    valid: usize,
) -> (usize, usize) {
    let Some(dropped) = pushed
        .and_then(|p| old.len().checked_add(p))
        .and_then(|all| all.checked_sub(new.len()))
    else {
        return (0, 0);
    };
    let kept = valid.min(old.len()).saturating_sub(dropped);
    // Any differing bit of any pair (no early exit: a branch a sample
    // costs more than the rare mismatch saves).
    let differ = |o: &[T], w: &[T]| {
        o.iter()
            .zip(w)
            .fold(0, |d, (&a, &b)| d | (a.bits() ^ b.bits()))
    };
    match (old.get(dropped..dropped + kept), new.get(..kept)) {
        (Some(o), Some(w)) if differ(o, w) == 0 => (dropped, kept),
        _ => (0, 0),
    }
}

/// How many of the loaded window's first kinetic voltages (`eta`, the
/// estimate's for its first `kept` samples) a simulation of the estimate
/// over `n` samples keeps; then records that all `n` are.
pub(super) fn take_kinetic(kept: &mut u32, n: usize) -> usize {
    let k = (*kept as usize).min(n);
    *kept = u32::try_from(n).unwrap_or(u32::MAX);
    k
}
