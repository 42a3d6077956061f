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

use super::simulate::{cpe_filter, cpe_filter_pair, history};
use super::{current_std, BatterySettings, CellModel, CellParameters, Prior, Start};
use crate::error::Error;
use crate::frac::GlWeights;
use crate::real::Real;
use crate::tail::{PastModes, TailKernel, MODES};
use crate::window::Window;

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
    /// Marquardt damping λ after the iteration.
    pub lambda: T,
    /// Number of fitted samples.
    pub rows: usize,
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
/// `N` and memory capacity `MEM`; about `13·N` scalars of state.
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
pub struct OutputErrorRefinement<T, const N: usize, const MEM: usize> {
    p: CellParameters<T>,
    lambda: T,
    k: u32,
    w: GlWeights<T, MEM>,
    i: [T; N],
    v: [T; N],
    up: [T; N],
    e: [T; N],
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
    trial: [T; N],
    /// `E` of the trial simulation.
    trial_e: [T; N],
    n: usize,
    warm: usize,
    /// The modes of the loaded window's past (with `warm > 0`).
    past: Option<PastModes<T>>,
    stamp: Option<u32>,
    /// `up` (and `e`) hold the simulation of `p`, β over the loaded window.
    fresh: bool,
    /// The settings (their [`BatterySettings::fingerprint`]) of the last
    /// iteration when it found no lower cost on the loaded window from the
    /// current estimate (`fresh` then holds).
    stalled: Option<u64>,
    /// The linearization of the last iteration when it accepted a step on
    /// the loaded window (the sensitivities still hold it).
    linear: Option<Linearization<T>>,
    work: RefinementWork,
}

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

/// `J₀ᵀJ₀` of an iteration (its upper triangle by rows), the estimate it
/// was taken at, and which columns it had.
#[derive(Clone, Copy, Debug)]
struct Linearization<T> {
    p: CellParameters<T>,
    a: [T; PACKED],
    estimate_order: bool,
    ocv_slope: bool,
    model: CellModel,
}

impl<T: Real> Linearization<T> {
    fn new(s: &BatterySettings<T>, p: CellParameters<T>, a: &Square<T>) -> Self {
        let mut up = [T::zero(); PACKED];
        let mut k = 0;
        for (r, row) in a.iter().enumerate() {
            for &x in &row[r..] {
                up[k] = x;
                k += 1;
            }
        }
        Self {
            p,
            a: up,
            estimate_order: s.estimate_order,
            ocv_slope: s.ocv_slope,
            model: s.model,
        }
    }

    /// True when `s` gives the Jacobian the same columns.
    fn fits(&self, s: &BatterySettings<T>) -> bool {
        self.estimate_order == s.estimate_order
            && self.ocv_slope == s.ocv_slope
            && self.model == s.model
    }

    /// The full symmetric `J₀ᵀJ₀`.
    fn normal_matrix(&self) -> Square<T> {
        let mut a = [[T::zero(); COLUMNS]; COLUMNS];
        let mut packed = self.a.iter();
        for (r, row) in a.iter_mut().enumerate() {
            for (x, &y) in row[r..].iter_mut().zip(&mut packed) {
                *x = y;
            }
        }
        mirror_upper(&mut a);
        a
    }
}

/// A damped Gauss–Newton step from the normal equations.
enum Proposal<T> {
    /// The damped matrix is not positive definite.
    Singular,
    /// The step leaves the physical region or the identifiable relaxation
    /// times.
    Refused,
    /// The step is below ε, or its predicted decrease below what the cost
    /// resolves.
    Negligible,
    /// A step worth simulating, and its largest relative change.
    Step {
        p: CellParameters<T>,
        beta: T,
        change: T,
    },
}

const LAMBDA0: f64 = 1e-3;
/// A step whose predicted decrease is below this many machine epsilons of
/// the cost is not tried: the cost's rounding (the simulation's, through
/// the recursion) is of that order in `f32`.
const COST_RESOLUTION: f64 = 100.0;
/// Longest relaxation time `τ^(1/α)` a trial may have, in fitted windows.
const MAX_RELAXATION_WINDOWS: f64 = 10.0;

impl<T: Real, const N: usize, const MEM: usize> OutputErrorRefinement<T, N, MEM> {
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
            lambda: T::lit(LAMBDA0),
            k: 0,
            w: GlWeights::new(start.alpha, s.h, s.memory)?,
            i: [T::ZERO; N],
            v: [T::ZERO; N],
            up: [T::ZERO; N],
            e: [T::ZERO; N],
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
            trial: [T::ZERO; N],
            trial_e: [T::ZERO; N],
            n: 0,
            warm: 0,
            past: None,
            stamp: None,
            fresh: false,
            stalled: None,
            linear: None,
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
        self.beta = T::zero();
        self.k = 0;
        self.lambda = T::lit(LAMBDA0);
        self.fresh = false;
        self.stalled = None;
        self.linear = None;
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
        self.lambda = st.lambda;
        self.beta = st.beta;
        self.k = st.k;
        self.work = st.work;
        self.stamp = None;
        self.fresh = false;
        self.stalled = None;
        self.linear = None;
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
        (&self.up[..self.n], self.warm)
    }

    /// One-step prediction of the terminal voltage for the *next* sample at
    /// current `current`, from the model state of the last iteration; `None`
    /// before the first iteration. O(M).
    pub fn predict_next(&self, current: T) -> Option<T> {
        if !self.fresh || self.n == 0 || self.n > N {
            return None;
        }
        // U_p(n) from U_p(0..n).
        let h = history(self.w.weights(), &self.up[..self.n], self.n);
        let a = self.p.tau() * self.w.scale();
        let up = (self.p.r_ct * current - a * h) / (T::one() + a);
        Some(self.p.u_oc + self.p.static_voltage(current) + up)
    }

    fn load(&mut self, s: &BatterySettings<T>, win: &impl Window<T>) -> Result<(), Error> {
        if self.w.h() != s.h || self.w.len() != s.memory {
            self.w.set(self.p.alpha, s.h, s.memory)?;
            self.stamp = None;
        }
        let key = win.version();
        if self.stamp != Some(key) || self.n != win.len() {
            self.n = win.copy_into(&mut self.i, &mut self.v);
            self.warm = match s.start {
                Start::AtRest if !win.has_slid() => 0,
                _ => s.memory - 1,
            };
            // From rest there is no past; from data it is the window's.
            self.past = if self.warm > 0 { win.past() } else { None };
            self.stamp = Some(key);
            self.fresh = false;
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

    /// The sensitivities of `U_p` to every parameter, for the simulation
    /// held in `up` and `e`; with `tail`, of the model with the taps beyond
    /// the memory ([`BatterySettings::tail`]).
    fn sensitivities(&mut self, slope: bool, kinetic: bool, tail: bool) {
        let (n, warm) = (self.n, self.warm);
        let wts = self.w.weights();
        let g = self.w.scale();
        let ln_h = self.w.h().ln();
        let p = self.p;
        let tau = p.tau();
        let a = tau * g;
        let memory = wts.len();
        // The tail: coefficients at the estimate's order and the modes of
        // the past (rest without one), for U_p and for each sensitivity's
        // free response (∂U_p(past)/∂R_i = −I, ∂/∂U_oc = −1, ∂/∂β = c).
        let zero = [T::zero(); MODES];
        let kernel = if tail {
            TailKernel::new(p.alpha).ok()
        } else {
            None
        };
        let past = self.past.filter(|_| warm > 0);
        let (c0, h) = (self.c[0], self.w.h());
        let modes = |f: &dyn Fn(&PastModes<T>, usize) -> T| -> [T; MODES] {
            past.map_or(zero, |pm| core::array::from_fn(|k| f(&pm, k)))
        };
        let z_up = past.map_or(zero, |pm| pm.polarization(p.u_oc, p.r_i, self.beta, c0, h));
        let z_ri = modes(&|pm, k| -pm.current[k]);
        let z_uoc = modes(&|pm, k| -pm.one[k]);
        let z_beta = modes(&|pm, k| pm.charge_modes(k, c0, h));
        let tails = kernel.map(|k| {
            (
                Tail {
                    rates: k.rates,
                    c: Tail::scaled(&k, &k.coefficients, memory),
                    z0: zero,
                },
                Tail::scaled(&k, &k.derivatives, memory),
            )
        });
        // h^(−α)·Σ_j (∂w_j/∂α)·U_p(l − j) (the order sensitivity's drive),
        // into the trial buffer, free until the step search; with the tail,
        // its weights' derivatives too: h^(−α)·Σ_k ∂C_k/∂α·Z_k(l − M) over
        // the simulation.
        let dup = &mut self.trial;
        self.w
            .for_each_weight_derivative(&self.up[..n], warm..n, |l, d| dup[l] = d);
        if let Some((t, dc)) = &tails {
            let mut z = z_up;
            for (l, dl) in dup.iter_mut().enumerate().take(n).skip(warm) {
                if l >= memory {
                    let x = self.up[l - memory];
                    for (zk, &r) in z.iter_mut().zip(&t.rates) {
                        *zk = r * *zk + x;
                    }
                }
                let d = dc.iter().zip(&z).fold(T::zero(), |s, (&c, &z)| s + c * z);
                *dl = *dl + g * d;
            }
        }
        let (i, e, dup) = (&self.i, &self.e, &self.trial);
        for x in [
            &mut self.s_rct,
            &mut self.s_q,
            &mut self.s_a,
            &mut self.s_ri,
            &mut self.s_uoc,
            &mut self.s_beta,
            &mut self.s_bva,
            &mut self.s_bvi0,
        ] {
            x[..warm].fill(T::zero());
        }
        // Two recursions at a time through the pair kernel (same weights
        // and `a`): each gets the values it would get alone.
        let rct_q = |l: usize| (i[l] - p.q * g * e[l], -p.r_ct * g * e[l]);
        match &tails {
            Some((t, _)) => cpe_filter_pair_tail(
                wts,
                a,
                warm,
                &mut self.s_rct[..n],
                &mut self.s_q[..n],
                t,
                zero,
                rct_q,
            ),
            None => cpe_filter_pair(
                wts,
                a,
                warm,
                &mut self.s_rct[..n],
                &mut self.s_q[..n],
                rct_q,
            ),
        }
        let order = |l: usize| a * ln_h * e[l] - tau * dup[l];
        if warm == 0 {
            // From rest: no history, so no free responses (and no stale
            // ones from an earlier window).
            match &tails {
                Some((t, _)) => {
                    cpe_filter_tail(wts, a, warm, &mut self.s_a[..n], t, order, |_, _, _| {})
                }
                None => cpe_filter(wts, a, warm, &mut self.s_a[..n], order, |_, _, _| {}),
            }
            self.s_ri[..n].fill(T::zero());
            self.s_uoc[..n].fill(T::zero());
            self.s_beta[..n].fill(T::zero());
            if kinetic {
                // (Read by the Butler–Volmer model's columns only.)
                self.s_bva[..n].fill(T::zero());
                self.s_bvi0[..n].fill(T::zero());
            }
            return;
        }
        if kinetic {
            // The history U_p = U_t − U_oc − R_i·I − η(I) moves with η's
            // parameters: the free responses to −∂η. (No tail: the model
            // with the Butler–Volmer term keeps the truncated sum.)
            for ((sa, si), &il) in self.s_bva[..warm]
                .iter_mut()
                .zip(&mut self.s_bvi0[..warm])
                .zip(&i[..warm])
            {
                let (da, di) = kinetic_derivatives(&p, il);
                *sa = -da;
                *si = -di;
            }
            cpe_filter_pair(
                wts,
                a,
                warm,
                &mut self.s_bva[..n],
                &mut self.s_bvi0[..n],
                |_| (T::zero(), T::zero()),
            );
        }
        for ((sr, su), &il) in self.s_ri[..warm]
            .iter_mut()
            .zip(&mut self.s_uoc[..warm])
            .zip(&i[..warm])
        {
            *sr = -il;
            *su = -T::one();
        }
        let order_ri = |l: usize| (order(l), T::zero());
        match &tails {
            Some((t, _)) => cpe_filter_pair_tail(
                wts,
                a,
                warm,
                &mut self.s_a[..n],
                &mut self.s_ri[..n],
                t,
                z_ri,
                order_ri,
            ),
            None => cpe_filter_pair(
                wts,
                a,
                warm,
                &mut self.s_a[..n],
                &mut self.s_ri[..n],
                order_ri,
            ),
        }
        let free = |_: usize| (T::zero(), T::zero());
        if slope {
            self.s_beta[..warm].copy_from_slice(&self.c[..warm]);
            match &tails {
                Some((t, _)) => cpe_filter_pair_tail(
                    wts,
                    a,
                    warm,
                    &mut self.s_uoc[..n],
                    &mut self.s_beta[..n],
                    &Tail { z0: z_uoc, ..*t },
                    z_beta,
                    free,
                ),
                None => cpe_filter_pair(
                    wts,
                    a,
                    warm,
                    &mut self.s_uoc[..n],
                    &mut self.s_beta[..n],
                    free,
                ),
            }
        } else {
            match &tails {
                Some((t, _)) => cpe_filter_tail(
                    wts,
                    a,
                    warm,
                    &mut self.s_uoc[..n],
                    &Tail { z0: z_uoc, ..*t },
                    |_| T::zero(),
                    |_, _, _| {},
                ),
                None => cpe_filter(
                    wts,
                    a,
                    warm,
                    &mut self.s_uoc[..n],
                    |_| T::zero(),
                    |_, _, _| {},
                ),
            }
        }
    }

    /// Row `l` of the Jacobian of the simulated voltage `Û_t(l)` with
    /// respect to `x = [ln R_i, ln R_ct, ln Q, α, U_oc, β, ln a, ln i₀]`
    /// (zero columns for what the settings keep fixed), from the
    /// sensitivities taken at `p`.
    #[inline]
    fn jacobian_row(
        &self,
        s: &BatterySettings<T>,
        p: &CellParameters<T>,
        l: usize,
    ) -> [T; COLUMNS] {
        let (da, di) = match s.model {
            CellModel::ButlerVolmer => self.kinetic_columns(p, l),
            CellModel::Linear => (T::zero(), T::zero()),
        };
        [
            p.r_i * (self.i[l] + self.s_ri[l]),
            p.r_ct * self.s_rct[l],
            p.q * self.s_q[l],
            if s.estimate_order {
                self.s_a[l]
            } else {
                T::zero()
            },
            T::one() + self.s_uoc[l],
            if s.ocv_slope {
                self.s_beta[l] - self.c[l]
            } else {
                T::zero()
            },
            da,
            di,
        ]
    }

    /// The Butler–Volmer columns of row `l` of the Jacobian. Kept out of
    /// line: inlined, its `asinh` and square root make the compiler outline
    /// the whole row instead, and the linear model's rows then cost 10 %
    /// more on the Cortex-M4 (docs/butler-volmer.md).
    #[inline(never)]
    fn kinetic_columns(&self, p: &CellParameters<T>, l: usize) -> (T, T) {
        let (da, di) = kinetic_derivatives(p, self.i[l]);
        (da + self.s_bva[l], di + self.s_bvi0[l])
    }

    /// The damped step `(A + λ·diag A)⁻¹ b` from the estimate, judged.
    fn propose(
        &self,
        s: &BatterySettings<T>,
        a: &Square<T>,
        b: &[T; COLUMNS],
        cost0: T,
        longest: T,
    ) -> Proposal<T> {
        let p = &self.p;
        let mut m = *a;
        for (k, row) in m.iter_mut().enumerate() {
            row[k] = a[k][k] * (T::one() + self.lambda) + T::min_positive_value().sqrt();
        }
        let Some(dx) = solve_fitted(&m, b, s.model == CellModel::ButlerVolmer) else {
            return Proposal::Singular;
        };
        let max_log = T::lit(MAX_LOG_STEP);
        let clamp = |x: T| x.max(-max_log).min(max_log);
        let trial = CellParameters {
            r_i: p.r_i * clamp(dx[0]).exp(),
            r_ct: p.r_ct * clamp(dx[1]).exp(),
            q: p.q * clamp(dx[2]).exp(),
            alpha: s.clamp_alpha(p.alpha + dx[3]),
            u_oc: p.u_oc + dx[4],
            bv_a: p.bv_a * clamp(dx[6]).exp(),
            bv_i0: p.bv_i0 * clamp(dx[7]).exp(),
        };
        let beta = self.beta + dx[5];
        let relax = trial.tau().powf(T::one() / trial.alpha);
        let within = relax <= longest; // false for NaN
        if !trial.is_physical() || !within {
            return Proposal::Refused;
        }
        let scale = p.u_oc.abs().max(T::one());
        let ch = [
            (trial.r_i / p.r_i).ln().abs(),
            (trial.r_ct / p.r_ct).ln().abs(),
            (trial.q / p.q).ln().abs(),
            (trial.alpha - p.alpha).abs(),
            (trial.u_oc - p.u_oc).abs() / scale,
            (beta - self.beta).abs() * self.c[self.warm].abs() / scale,
            if p.is_butler_volmer() {
                (trial.bv_a / p.bv_a).ln().abs()
            } else {
                T::zero()
            },
            (trial.bv_i0 / p.bv_i0).ln().abs(),
        ];
        let change = ch.iter().fold(T::zero(), |m, &x| m.max(x));
        // The decrease the linear model predicts, dxᵀb − ½dxᵀA dx.
        let mut pred = T::zero();
        for k in 0..COLUMNS {
            let adx = (0..COLUMNS).fold(T::zero(), |acc, q| acc + a[k][q] * dx[q]);
            pred = pred + dx[k] * (b[k] - adx / T::lit(2.0));
        }
        let resolution = T::lit(COST_RESOLUTION) * T::epsilon();
        if change > s.epsilon && pred > resolution * cost0 {
            Proposal::Step {
                p: trial,
                beta,
                change,
            }
        } else {
            // Below the stopping tolerance, or a decrease below what the
            // cost resolves in this precision (also for NaN): a minimum,
            // not worth a simulation.
            Proposal::Negligible
        }
    }

    /// An iteration that stops at the estimate (a minimum); `data0` is the
    /// data's part of the cost `cost0`.
    fn stop(&mut self, cost0: T, data0: T, rows: usize) -> RefinementStep<T> {
        self.k += 1;
        self.work.iterations = self.work.iterations.wrapping_add(1);
        RefinementStep {
            k: self.k,
            cost: cost0,
            rmse: rmse(data0, rows),
            change: T::zero(),
            converged: true,
            accepted: false,
            lambda: self.lambda,
            rows,
        }
    }

    /// One Levenberg–Marquardt iteration over the window.
    ///
    /// # Errors
    /// [`Error::NotEnoughData`] while fewer than `warm-up + MIN_ROWS`
    /// samples are held, [`Error::NotExcited`] for a current whose standard
    /// deviation is below the threshold, [`Error::Diverged`] for a
    /// non-finite cost; settings errors. On error the estimate is unchanged.
    pub fn iterate(
        &mut self,
        s: &BatterySettings<T>,
        win: &impl Window<T>,
    ) -> Result<RefinementStep<T>, Error> {
        s.check::<MEM>()?;
        self.load(s, win)?;
        let (n, warm) = (self.n, self.warm);
        if current_std(&self.i[warm..n]) <= s.min_current_std {
            return Err(Error::NotExcited);
        }
        if self.w.alpha() != self.p.alpha {
            self.w.set_order(self.p.alpha)?;
        }
        if s.model == CellModel::ButlerVolmer && !self.p.is_butler_volmer() {
            // A linear start (the paper method's estimate): the kinetic
            // term with i₀ at the window's RMS current.
            let rms = rms(&self.i[warm..n]).max(T::lit(1e-3));
            self.p = self.p.with_butler_volmer(rms);
            self.fresh = false;
        }
        let data = WindowData {
            i: &self.i[..n],
            v: &self.v[..n],
            c: &self.c[..n],
            warm,
            tail: tail_context(s, self.past.as_ref()),
        };
        // The last iteration on this window left the simulation of the
        // estimate in `up` (its accepted trial, or the kept estimate's).
        let prior_cost = |p: &CellParameters<T>| s.prior.map_or(T::zero(), |pr| pr.cost(p, s));
        let data0 = if self.fresh {
            window_cost(&data, &self.p, self.beta, &self.up[..n])
        } else {
            self.stalled = None;
            self.linear = None;
            self.work.simulations = self.work.simulations.wrapping_add(1);
            simulate_window(
                &self.w,
                &data,
                &self.p,
                self.beta,
                &mut self.up[..n],
                &mut self.e[..n],
            )
        };
        // The cost of the estimate: the data's, plus the prior's.
        let cost0 = data0 + prior_cost(&self.p);
        if !cost0.is_finite() {
            self.fresh = false;
            return Err(Error::Diverged);
        }
        self.fresh = true;
        let rows = n - warm;
        if self.stalled == Some(s.fingerprint()) {
            // The last iteration, from this estimate on this window with
            // these settings, found no lower cost with any damping (and
            // reset λ): this one would repeat it exactly.
            return Ok(self.stop(cost0, data0, rows));
        }
        let longest = T::lit(MAX_RELAXATION_WINDOWS * rows as f64) * s.h;
        if let Some(last) = self.linear.filter(|l| l.fits(s)) {
            // The last iteration on this window accepted a step. Before new
            // sensitivities, its Jacobian J₀ (at the estimate it started
            // from) with the residuals here gives the chord step
            // (J₀ᵀJ₀ + λD)⁻¹J₀ᵀr; when even that is negligible, this is a
            // minimum (to the cost's resolution) and the O(N·M) pass is
            // not needed. Anything else falls through to the exact step.
            let mut b = [T::zero(); COLUMNS];
            for l in warm..n {
                let j = self.jacobian_row(s, &last.p, l);
                let r = residual(
                    self.v[l], &self.p, self.beta, self.c[l], self.i[l], self.up[l],
                );
                for (bb, ja) in b.iter_mut().zip(j) {
                    *bb = *bb + ja * r;
                }
            }
            let mut a = last.normal_matrix();
            add_prior(s, &self.p, &mut a, &mut b);
            if let Proposal::Negligible = self.propose(s, &a, &b, cost0, longest) {
                self.linear = None;
                self.lambda = T::lit(LAMBDA0);
                self.stalled = Some(s.fingerprint());
                return Ok(self.stop(cost0, data0, rows));
            }
        }
        let p = self.p;
        let (mut a, mut b) = self.normal_equations(s);
        self.work.linearizations = self.work.linearizations.wrapping_add(1);
        // The data's J₀ᵀJ₀ is what a chord step reuses; the prior is added
        // there again from the settings of that iteration.
        let data_a = a;
        add_prior(s, &p, &mut a, &mut b);
        let mut step = RefinementStep {
            k: self.k,
            cost: cost0,
            rmse: rmse(data0, rows),
            change: T::zero(),
            converged: false,
            accepted: false,
            lambda: self.lambda,
            rows,
        };
        for _ in 0..MAX_TRIES {
            let (trial, beta, change) = match self.propose(s, &a, &b, cost0, longest) {
                Proposal::Step { p, beta, change } => (p, beta, change),
                Proposal::Singular | Proposal::Refused => {
                    self.lambda = self.lambda * T::lit(10.0);
                    continue;
                }
                // More damping only shrinks the step and its decrease.
                Proposal::Negligible => break,
            };
            self.w.set_order(trial.alpha)?;
            let data = WindowData {
                i: &self.i[..n],
                v: &self.v[..n],
                c: &self.c[..n],
                warm,
                tail: tail_context(s, self.past.as_ref()),
            };
            self.work.simulations = self.work.simulations.wrapping_add(1);
            self.work.trials = self.work.trials.wrapping_add(1);
            let c = simulate_window(
                &self.w,
                &data,
                &trial,
                beta,
                &mut self.trial[..n],
                &mut self.trial_e[..n],
            );
            let c = c + prior_cost(&trial);
            if c.is_finite() && c < cost0 {
                core::mem::swap(&mut self.up, &mut self.trial);
                core::mem::swap(&mut self.e, &mut self.trial_e);
                step.change = change;
                self.p = trial;
                self.beta = beta;
                self.lambda = (self.lambda / T::lit(10.0)).max(T::lit(1e-12));
                step.accepted = true;
                step.cost = c;
                step.rmse = rmse(c - prior_cost(&trial), rows);
                break;
            }
            self.lambda = self.lambda * T::lit(10.0);
        }
        self.linear = step.accepted.then(|| Linearization::new(s, p, &data_a));
        if !step.accepted {
            // Back to the order of the kept estimate; λ is reset so that a
            // later window starts with a fresh trust region.
            self.w.set_order(p.alpha)?;
            self.lambda = T::lit(LAMBDA0);
            self.stalled = Some(s.fingerprint());
        }
        self.k += 1;
        self.work.iterations = self.work.iterations.wrapping_add(1);
        step.k = self.k;
        step.lambda = self.lambda;
        step.converged = !step.accepted || step.change <= s.epsilon;
        Ok(step)
    }

    /// New sensitivities at the estimate (whose simulation `up` holds) and
    /// the data's normal equations `JᵀJ`, `Jᵀr` in `x`.
    fn normal_equations(&mut self, s: &BatterySettings<T>) -> (Square<T>, [T; COLUMNS]) {
        self.sensitivities(
            s.ocv_slope,
            s.model == CellModel::ButlerVolmer,
            s.uses_tail(),
        );
        // The linear model's kinetic columns are zero: not accumulated.
        // (A constant width: the compiler keeps the sums in registers.)
        match s.model {
            CellModel::Linear => self.accumulate::<LINEAR_COLUMNS>(s),
            CellModel::ButlerVolmer => self.accumulate::<COLUMNS>(s),
        }
    }

    /// `JᵀJ` and `Jᵀr` over the first `C` columns of `x` (the rest zero),
    /// from the sensitivities.
    fn accumulate<const C: usize>(&self, s: &BatterySettings<T>) -> (Square<T>, [T; COLUMNS]) {
        let p = self.p;
        let mut a = [[T::zero(); C]; C];
        let mut b = [T::zero(); C];
        for l in self.warm..self.n {
            let full = self.jacobian_row(s, &p, l);
            let j: [T; C] = core::array::from_fn(|k| full[k]);
            let r = residual(self.v[l], &p, self.beta, self.c[l], self.i[l], self.up[l]);
            // The upper triangle; the lower one is filled below.
            for (k, (r_, ja)) in a.iter_mut().zip(j).enumerate() {
                for (x, &jb) in r_[k..].iter_mut().zip(&j[k..]) {
                    *x = *x + ja * jb;
                }
            }
            for (bb, ja) in b.iter_mut().zip(j) {
                *bb = *bb + ja * r;
            }
        }
        let mut wide = [[T::zero(); COLUMNS]; COLUMNS];
        let mut wb = [T::zero(); COLUMNS];
        for (row, src) in wide.iter_mut().zip(&a) {
            row[..C].copy_from_slice(src);
        }
        wb[..C].copy_from_slice(&b);
        mirror_upper(&mut wide);
        (wide, wb)
    }

    /// The Gauss–Newton information of the window at the estimate (for
    /// standard errors and model choice): the data's `JᵀJ` over `x`, its
    /// cost and rows, and which columns `s` fits. One sensitivity pass,
    /// `O(N·M)`; the estimate does not change.
    ///
    /// # Errors
    /// As [`iterate`](Self::iterate).
    pub fn information(
        &mut self,
        s: &BatterySettings<T>,
        win: &impl Window<T>,
    ) -> Result<FitInformation<T>, Error> {
        s.check::<MEM>()?;
        self.load(s, win)?;
        let (n, warm) = (self.n, self.warm);
        if self.w.alpha() != self.p.alpha {
            self.w.set_order(self.p.alpha)?;
        }
        let data = WindowData {
            i: &self.i[..n],
            v: &self.v[..n],
            c: &self.c[..n],
            warm,
            tail: tail_context(s, self.past.as_ref()),
        };
        let cost = if self.fresh {
            window_cost(&data, &self.p, self.beta, &self.up[..n])
        } else {
            self.stalled = None;
            simulate_window(
                &self.w,
                &data,
                &self.p,
                self.beta,
                &mut self.up[..n],
                &mut self.e[..n],
            )
        };
        if !cost.is_finite() {
            self.fresh = false;
            return Err(Error::Diverged);
        }
        self.fresh = true;
        // The sensitivities are now those of the estimate, not of the last
        // accepted step's start: no chord step from them.
        self.linear = None;
        let (jtj, _) = self.normal_equations(s);
        self.work.linearizations = self.work.linearizations.wrapping_add(1);
        let kinetic = s.model == CellModel::ButlerVolmer && self.p.is_butler_volmer();
        Ok(FitInformation {
            jtj,
            cost,
            rows: n - warm,
            fitted: [
                true,
                true,
                true,
                s.estimate_order,
                true,
                s.ocv_slope,
                kinetic,
                kinetic,
            ],
        })
    }
}

/// The Gauss–Newton information of a converged fit
/// ([`OutputErrorRefinement::information`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitInformation<T> {
    /// The data's `JᵀJ` over `x` ([`COLUMN_NAMES`]).
    pub jtj: Square<T>,
    /// `½Σr²` of the data (no prior).
    pub cost: T,
    /// Fitted samples.
    pub rows: usize,
    /// Which columns the fit estimates.
    pub fitted: [bool; COLUMNS],
}

impl<T: Real> FitInformation<T> {
    /// Number of fitted parameters.
    pub fn parameters(&self) -> usize {
        self.fitted.iter().filter(|&&f| f).count()
    }

    /// The residual variance `2·cost/(rows − parameters)` (V²).
    pub fn residual_variance(&self) -> T {
        let dof = self.rows.saturating_sub(self.parameters()).max(1);
        T::lit(2.0) * self.cost / T::lit(dof as f64)
    }

    /// Bayesian information criterion `rows·ln(RSS/rows) + k·ln(rows)`.
    pub fn bic(&self) -> T {
        let rows = T::lit(self.rows.max(1) as f64);
        let rss = T::lit(2.0) * self.cost;
        rows * (rss / rows).ln() + T::lit(self.parameters() as f64) * rows.ln()
    }

    /// Standard errors of the fitted coordinates of `x` (`None` for the
    /// columns not fitted, or all when `JᵀJ` is singular): the square roots
    /// of the diagonal of `σ²·(JᵀJ)⁻¹` over the fitted columns.
    pub fn standard_errors(&self) -> [Option<T>; COLUMNS] {
        // The columns not fitted become identity rows and columns.
        let mut m = self.jtj;
        for (r, row) in m.iter_mut().enumerate() {
            for (c, x) in row.iter_mut().enumerate() {
                if !(self.fitted[r] && self.fitted[c]) {
                    *x = if r == c { T::one() } else { T::zero() };
                }
            }
        }
        let var = self.residual_variance();
        let mut out = [None; COLUMNS];
        for k in (0..COLUMNS).filter(|&k| self.fitted[k]) {
            let mut e = [T::zero(); COLUMNS];
            e[k] = T::one();
            match T::solve_spd(&m, &e) {
                Some(x) if x[k] > T::zero() => out[k] = Some((var * x[k]).sqrt()),
                _ => return [None; COLUMNS],
            }
        }
        out
    }
}

/// Solves the damped normal equations `m·x = b` over the fitted columns:
/// all with the Butler–Volmer term, the first [`LINEAR_COLUMNS`] in the
/// linear model (the rest of `x` is then 0, as the full system with its
/// zero columns and tiny diagonal gives, at a third less work).
fn solve_fitted<T: Real>(m: &Square<T>, b: &[T; COLUMNS], kinetic: bool) -> Option<[T; COLUMNS]> {
    if kinetic {
        return T::solve_spd(m, b);
    }
    let mut m6 = [[T::zero(); LINEAR_COLUMNS]; LINEAR_COLUMNS];
    let mut b6 = [T::zero(); LINEAR_COLUMNS];
    for ((row6, row), (b6k, &bk)) in m6.iter_mut().zip(m).zip(b6.iter_mut().zip(b)) {
        row6.copy_from_slice(&row[..LINEAR_COLUMNS]);
        *b6k = bk;
    }
    let x6 = T::solve_spd(&m6, &b6)?;
    let mut x = [T::zero(); COLUMNS];
    x[..LINEAR_COLUMNS].copy_from_slice(&x6);
    Some(x)
}

/// `(∂η/∂ln a, ∂η/∂ln i₀)` of `η = a·asinh(I/i₀)` at `current`:
/// `(η, −a·u/√(1+u²))`, `u = I/i₀`.
#[inline]
fn kinetic_derivatives<T: Real>(p: &CellParameters<T>, current: T) -> (T, T) {
    let u = current / p.bv_i0;
    (p.bv_a * u.asinh(), -p.bv_a * u / (T::one() + u * u).sqrt())
}

/// Root mean square of a slice (0 for an empty one).
fn rms<T: Real>(x: &[T]) -> T {
    let sum = x.iter().fold(T::zero(), |acc, &v| acc + v * v);
    (sum / T::lit(x.len().max(1) as f64)).sqrt()
}

/// The column of `x` of each of the prior's coordinates.
const PRIOR_COLUMNS: [usize; 6] = [0, 1, 2, 3, 6, 7];

/// Adds the prior's part to the normal equations at `p`: its weights `w_k`
/// to the diagonal of `JᵀJ` and `w_k·(c_k − x_k)` to `Jᵀr` (nothing without
/// a prior).
fn add_prior<T: Real>(
    s: &BatterySettings<T>,
    p: &CellParameters<T>,
    a: &mut Square<T>,
    b: &mut [T; COLUMNS],
) {
    if let Some(pr) = &s.prior {
        let (w, c) = pr.terms();
        let x = Prior::coordinates(p);
        for (k, on) in pr.active(s).into_iter().enumerate() {
            if on {
                let col = PRIOR_COLUMNS[k];
                a[col][col] = a[col][col] + w[k];
                b[col] = b[col] + w[k] * (c[k] - x[k]);
            }
        }
    }
}

/// Copies the upper triangle of a symmetric matrix into the lower one.
fn mirror_upper<T: Copy>(a: &mut Square<T>) {
    for (r, c) in (1..COLUMNS).flat_map(|r| (0..r).map(move |c| (r, c))) {
        a[r][c] = a[c][r];
    }
}

/// Root-mean-square residual of cost `½Σr²` over `rows` samples.
fn rmse<T: Real>(cost: T, rows: usize) -> T {
    (T::lit(2.0) * cost / T::lit(rows as f64)).sqrt()
}

/// The loaded window: current, voltage, charge still to flow, and the
/// number of warm-up samples.
#[derive(Clone, Copy)]
struct WindowData<'a, T> {
    i: &'a [T],
    v: &'a [T],
    c: &'a [T],
    warm: usize,
    /// The taps beyond the memory ([`BatterySettings::tail`]), if added.
    tail: Option<TailContext<'a, T>>,
}

/// What the tail beyond the memory needs from a window: its past's modes
/// (`None`: rest), the sample period and the memory.
#[derive(Clone, Copy)]
struct TailContext<'a, T> {
    past: Option<&'a PastModes<T>>,
    h: T,
    memory: usize,
}

/// The tail of one recursion: `Σ_{j≥M} ŵ_j·x(l − j) = Σ_k C_k·Z_k(l − M)`
/// with `C_k = c_k·r_k^M` and `Z_k(n) = r_k·Z_k(n − 1) + x(n)` from
/// `Z_k(−1) = z0_k`, the modes of the past.
#[derive(Clone, Copy)]
struct Tail<T> {
    rates: [T; MODES],
    c: [T; MODES],
    z0: [T; MODES],
}

impl<T: Real> Tail<T> {
    /// `C_k = x_k·r_k^M` for coefficients `x` (`c_k` or `∂c_k/∂α`).
    fn scaled(kernel: &TailKernel<T>, x: &[T; MODES], memory: usize) -> [T; MODES] {
        core::array::from_fn(|k| x[k] * power(kernel.rates[k], memory))
    }
}

/// The tail context of settings `s` for a window with past `past` (`None`
/// when the settings add no tail).
fn tail_context<'a, T: Real>(
    s: &BatterySettings<T>,
    past: Option<&'a PastModes<T>>,
) -> Option<TailContext<'a, T>> {
    s.uses_tail().then_some(TailContext {
        past,
        h: s.h,
        memory: s.memory,
    })
}

/// `x^n` by squaring (`powi` is a general `pow` call on some targets).
fn power<T: Real>(mut x: T, mut n: usize) -> T {
    let mut y = T::one();
    while n > 0 {
        if n & 1 == 1 {
            y = y * x;
        }
        x = x * x;
        n >>= 1;
    }
    y
}

/// Rows of a chunk: the tail of a row reaches only rows at least `M` back,
/// so a chunk of at most `M` rows has all of its tails from rows solved
/// before it.
const CHUNK: usize = 64;

/// [`cpe_filter`] with the tail `t` of `x` added to every row's history:
/// chunks of at most `min(M, CHUNK)` rows, each row's tail from the modes
/// of the rows before the chunk. The history passed to `seen` includes the
/// tail.
#[inline]
fn cpe_filter_tail<T: Real>(
    w: &[T],
    a: T,
    warm: usize,
    x: &mut [T],
    t: &Tail<T>,
    mut drive: impl FnMut(usize) -> T,
    mut seen: impl FnMut(usize, T, T),
) {
    let (m, n) = (w.len(), x.len());
    let mut z = t.z0;
    let mut start = warm;
    while start < n {
        let end = (start + CHUNK.min(m)).min(n);
        let mut tb = [T::zero(); CHUNK];
        for l in start..end {
            if l >= m {
                let xn = x[l - m];
                for (zk, &r) in z.iter_mut().zip(&t.rates) {
                    *zk = r * *zk + xn;
                }
            }
            tb[l - start] = t.c.iter().zip(&z).fold(T::zero(), |s, (&c, &z)| s + c * z);
        }
        cpe_filter(
            w,
            a,
            start,
            &mut x[..end],
            |l| drive(l) - a * tb[l - start],
            |l, xv, h| seen(l, xv, h + tb[l - start]),
        );
        start = end;
    }
}

/// [`cpe_filter_pair`] with tails `tx`, `ty` (same rates and coefficients,
/// their own past modes), as [`cpe_filter_tail`].
#[inline]
#[allow(clippy::too_many_arguments)]
fn cpe_filter_pair_tail<T: Real>(
    w: &[T],
    a: T,
    warm: usize,
    x: &mut [T],
    y: &mut [T],
    tx: &Tail<T>,
    zy: [T; MODES],
    mut drive: impl FnMut(usize) -> (T, T),
) {
    let (m, n) = (w.len(), x.len().min(y.len()));
    let (mut px, mut py) = (tx.z0, zy);
    let mut start = warm;
    while start < n {
        let end = (start + CHUNK.min(m)).min(n);
        let (mut bx, mut by) = ([T::zero(); CHUNK], [T::zero(); CHUNK]);
        for l in start..end {
            if l >= m {
                let (xn, yn) = (x[l - m], y[l - m]);
                for k in 0..MODES {
                    px[k] = tx.rates[k] * px[k] + xn;
                    py[k] = tx.rates[k] * py[k] + yn;
                }
            }
            let (mut sx, mut sy) = (T::zero(), T::zero());
            for k in 0..MODES {
                sx = sx + tx.c[k] * px[k];
                sy = sy + tx.c[k] * py[k];
            }
            bx[l - start] = sx;
            by[l - start] = sy;
        }
        cpe_filter_pair(w, a, start, &mut x[..end], &mut y[..end], |l| {
            let (dx, dy) = drive(l);
            (dx - a * bx[l - start], dy - a * by[l - start])
        });
        start = end;
    }
}

/// Simulates `p` over a window into `buf` (weights already at `p.alpha`),
/// with the open-circuit voltage `U_oc − β·c(l)` (`c` the charge still to
/// flow), the first `warm` samples of `U_p` taken from the data, and returns
/// ½Σr² over the fitted samples `warm..`. `e` receives
/// `E(l) = Σ_{j≥0} w_j·U_p(l − j)` for the fitted samples.
fn simulate_window<T: Real, const MEM: usize>(
    w: &GlWeights<T, MEM>,
    data: &WindowData<'_, T>,
    p: &CellParameters<T>,
    beta: T,
    buf: &mut [T],
    e: &mut [T],
) -> T {
    let WindowData {
        i,
        v,
        c,
        warm,
        tail,
        ..
    } = *data;
    for l in 0..warm {
        buf[l] = residual(v[l], p, beta, c[l], i[l], T::zero());
    }
    let a = p.tau() * w.scale();
    match tail.and_then(|t| Some((t, TailKernel::new(p.alpha).ok()?))) {
        Some((t, kernel)) => {
            let z0 = match (t.past, c.first()) {
                (Some(past), Some(&c0)) => past.polarization(p.u_oc, p.r_i, beta, c0, t.h),
                _ => [T::zero(); MODES],
            };
            let tl = Tail {
                rates: kernel.rates,
                c: Tail::scaled(&kernel, &kernel.coefficients, t.memory),
                z0,
            };
            cpe_filter_tail(
                w.weights(),
                a,
                warm,
                buf,
                &tl,
                |l| p.r_ct * i[l],
                |l, x, h| e[l] = x + h,
            );
        }
        None => cpe_filter(
            w.weights(),
            a,
            warm,
            buf,
            |l| p.r_ct * i[l],
            |l, x, h| e[l] = x + h,
        ),
    }
    window_cost(data, p, beta, buf)
}

/// The voltage residual `U_t − (U_oc − β·c + R_i·I + η(I) + U_p)` of one
/// sample.
/// `U_t − U_oc` comes first: the two are close (exact by Sterbenz's lemma
/// within a factor 2), so the rounding is that of the small remaining terms,
/// not of the 3–4 V terminal voltage. In `f32` this is the difference
/// between a cost that resolves a step's decrease and one whose rounding
/// (ulp(3.7 V) ≈ 2.4e−7 V against millivolt residuals) hides it.
#[inline]
fn residual<T: Real>(v: T, p: &CellParameters<T>, beta: T, c: T, i: T, up: T) -> T {
    (v - p.u_oc) + beta * c - p.static_voltage(i) - up
}

/// ½Σr² over the fitted samples of the simulation `up` of `p`, β.
#[inline]
fn window_cost<T: Real>(data: &WindowData<'_, T>, p: &CellParameters<T>, beta: T, up: &[T]) -> T {
    let WindowData { i, v, c, warm, .. } = *data;
    let mut cost = T::zero();
    for l in warm..up.len() {
        let r = residual(v[l], p, beta, c[l], i[l], up[l]);
        cost = cost + r * r;
    }
    cost / T::lit(2.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::window::SampleWindow;

    /// The simulated terminal voltage of `p`, β over the loaded window.
    fn predicted<const N: usize, const MEM: usize>(
        s: &BatterySettings<f64>,
        oe: &OutputErrorRefinement<f64, N, MEM>,
        p: &CellParameters<f64>,
        beta: f64,
    ) -> Vec<f64> {
        let n = oe.n;
        let mut w = oe.w.clone();
        w.set_order(p.alpha).unwrap();
        let data = WindowData {
            i: &oe.i[..n],
            v: &oe.v[..n],
            c: &oe.c[..n],
            warm: oe.warm,
            tail: tail_context(s, oe.past.as_ref()),
        };
        let (mut up, mut e) = (vec![0.0; n], vec![0.0; n]);
        simulate_window(&w, &data, p, beta, &mut up, &mut e);
        (0..n)
            .map(|l| p.u_oc - beta * oe.c[l] + p.static_voltage(oe.i[l]) + up[l])
            .collect()
    }

    /// A pulse record of the 18650 cell with a little deterministic "noise"
    /// (a few tenths of a millivolt) and an OCV drift.
    fn noisy_record(len: usize) -> (Vec<f64>, Vec<f64>) {
        let truth = CellParameters::<f64>::cell_18650();
        let current: Vec<f64> = (0..len)
            .map(|l| 3.0 * (0.21 * l as f64).sin() + if (l / 15) % 2 == 0 { 2.0 } else { -2.0 })
            .collect();
        let (mut up, mut v) = (vec![0.0; len], vec![0.0; len]);
        let mut w = GlWeights::<f64, 24>::new(truth.alpha, 1.0, 24).unwrap();
        super::super::simulate::simulate(&truth, &mut w, &current, |_| truth.u_oc, &mut up, &mut v)
            .unwrap();
        for (l, x) in v.iter_mut().enumerate() {
            *x += 3e-4 * (1.7 * l as f64).sin() * (0.37 * l as f64).cos() - 2e-6 * l as f64;
        }
        (current, v)
    }

    /// After a window restart the refinement computes exactly what a new
    /// one does: no sensitivity of an earlier (slid) window survives into a
    /// window that starts from rest.
    #[test]
    fn a_restarted_window_forgets_the_earlier_one() {
        const N: usize = 80;
        let (current, v) = noisy_record(2 * N);
        let mut s = BatterySettings::new(1.0, 24);
        s.ocv_slope = true;
        let mut win = SampleWindow::<f64, N>::new();
        for l in 0..N + 20 {
            win.push(current[l], v[l]).unwrap();
        }
        let start = CellParameters::<f64>::cell_18650();
        let mut used = OutputErrorRefinement::<f64, N, 24>::new(&s, start).unwrap();
        for _ in 0..3 {
            used.iterate(&s, &win).unwrap();
        }
        assert_eq!(used.warm, 23, "the window has slid: history from data");
        win.clear();
        for l in N + 20..2 * N {
            win.push(current[l], v[l]).unwrap();
        }
        used.set_cell(&s, start).unwrap();
        let mut new = OutputErrorRefinement::<f64, N, 24>::new(&s, start).unwrap();
        for _ in 0..3 {
            let a = used.iterate(&s, &win).unwrap();
            let b = new.iterate(&s, &win).unwrap();
            assert_eq!(used.warm, 0);
            assert_eq!(a, b);
            assert_eq!(used.cell(), new.cell());
        }
    }

    /// An iteration that stops on the last iteration's Jacobian (no new
    /// sensitivities) stops at a minimum: the exact Levenberg–Marquardt step
    /// from there leaves a Bates–Watts relative offset
    /// `√((ΔC/6)/(C/(n−6)))` below their recommended 0.001 (the decrease
    /// it finds is statistically invisible). From a distant start the test
    /// must also say "go on" (and new sensitivities are taken).
    #[test]
    fn a_stop_on_the_last_jacobian_is_a_minimum() {
        const N: usize = 100;
        let (current, v) = noisy_record(N + 40);
        let mut s = BatterySettings::new(1.0, 24);
        s.ocv_slope = true;
        s.start = Start::FromData;
        let mut win = SampleWindow::<f64, N>::new();
        for l in 0..N {
            win.push(current[l], v[l]).unwrap();
        }
        let truth = CellParameters::<f64>::cell_18650();
        let start = CellParameters {
            r_ct: 2.0 * truth.r_ct,
            q: 0.5 * truth.q,
            alpha: truth.alpha - 0.1,
            ..truth
        };
        let mut oe = OutputErrorRefinement::<f64, N, 24>::new(&s, start).unwrap();
        let (mut stops, mut go_ons) = (0, 0);
        let (mut worst_offset, mut worst_change) = (0.0f64, 0.0f64);
        for l in N..N + 40 {
            win.push(current[l], v[l]).unwrap();
            let mut accepted_before = false;
            for _ in 0..5 {
                let lin = oe.work().linearizations;
                let step = oe.iterate(&s, &win).unwrap();
                let linearized = oe.work().linearizations > lin;
                if accepted_before && linearized {
                    go_ons += 1;
                }
                if accepted_before && !linearized {
                    stops += 1;
                    assert!(step.converged && !step.accepted);
                    let mut exact =
                        OutputErrorRefinement::<f64, N, 24>::new(&s, oe.cell()).unwrap();
                    exact.beta = oe.beta;
                    let e = exact.iterate(&s, &win).unwrap();
                    let rows = step.rows as f64;
                    let decrease = (step.cost - e.cost).max(0.0);
                    let offset = (decrease * (rows - 6.0) / (6.0 * step.cost)).sqrt();
                    assert!(
                        offset < 1e-3,
                        "sample {l}: relative offset {offset:e} ({e:?})"
                    );
                    worst_offset = worst_offset.max(offset);
                    if e.accepted {
                        worst_change = worst_change.max(e.change);
                    }
                }
                accepted_before = step.accepted;
                if step.converged {
                    break;
                }
            }
        }
        // Quoted in docs/performance.md (run with --nocapture).
        std::println!(
            "{stops} chord stops, {go_ons} go-ons; exact step from a stop at most \
             {worst_change:.2e} (epsilon {:e}), relative offset at most {worst_offset:.2e}",
            s.epsilon
        );
        assert!(stops >= 10, "only {stops} stops without sensitivities");
        assert!(go_ons >= 1, "the last Jacobian never said go on");
    }

    /// Once an iteration finds no lower cost on a window, further iterations
    /// on it change nothing and say converged; a new sample starts the
    /// search again.
    #[test]
    fn a_converged_window_is_not_searched_again() {
        const N: usize = 120;
        let truth = CellParameters::<f64>::cell_18650();
        let s = BatterySettings::new(1.0, 24);
        let current: Vec<f64> = (0..N + 1)
            .map(|l| 3.0 * (0.21 * l as f64).sin() + if (l / 15) % 2 == 0 { 2.0 } else { -2.0 })
            .collect();
        let (mut up, mut v) = (vec![0.0; N + 1], vec![0.0; N + 1]);
        let mut w = GlWeights::<f64, 24>::new(truth.alpha, 1.0, 24).unwrap();
        super::super::simulate::simulate(&truth, &mut w, &current, |_| truth.u_oc, &mut up, &mut v)
            .unwrap();
        let mut win = SampleWindow::<f64, N>::new();
        for l in 0..N {
            win.push(current[l], v[l]).unwrap();
        }
        let start = CellParameters {
            r_ct: 0.02,
            q: 400.0,
            ..truth
        };
        let mut oe = OutputErrorRefinement::<f64, N, 24>::new(&s, start).unwrap();
        let mut k = 0;
        while oe.iterate(&s, &win).unwrap().accepted {
            k += 1;
            assert!(k < 100, "no minimum after 100 iterations");
        }
        let at_min = oe.cell();
        assert!((at_min.r_ct / truth.r_ct - 1.0).abs() < 1e-6, "{at_min:?}");
        for _ in 0..3 {
            let step = oe.iterate(&s, &win).unwrap();
            assert!(step.converged && !step.accepted && step.change == 0.0);
            assert_eq!(oe.cell(), at_min);
        }
        // One more (noisy) sample: the window changed, the search runs.
        win.push(current[N], v[N] + 0.01).unwrap();
        let step = oe.iterate(&s, &win).unwrap();
        assert!(step.accepted, "{step:?}");
        assert_ne!(oe.cell(), at_min);
    }

    /// With a prior the refinement converges to the minimum of the data's
    /// cost plus the prior's: there the gradient of that sum (central
    /// differences of the simulation, not the code's normal equations) is
    /// below 1e-4 of its value at the start, and no coordinate move lowers
    /// the sum. A heavy prior holds the
    /// estimate near its centre, a light one lets the data move it.
    #[test]
    fn a_prior_moves_the_minimum_to_the_posterior() {
        const N: usize = 120;
        let (current, v) = noisy_record(N);
        let mut win = SampleWindow::<f64, N>::new();
        for l in 0..N {
            win.push(current[l], v[l]).unwrap();
        }
        let truth = CellParameters::<f64>::cell_18650();
        let center = CellParameters {
            r_ct: 2.0 * truth.r_ct,
            q: 0.5 * truth.q,
            alpha: 0.6,
            ..truth
        };
        let mut rct = vec![];
        for noise_v in [1e-4, 0.03, 10.0] {
            let mut s = BatterySettings::new(1.0, 24);
            s.prior = Some(super::super::Prior {
                noise_v,
                ..super::super::Prior::new(center)
            });
            let mut oe = OutputErrorRefinement::<f64, N, 24>::new(&s, truth).unwrap();
            let total = |oe: &OutputErrorRefinement<f64, N, 24>, p: &CellParameters<f64>| {
                let pred = predicted(&s, oe, p, 0.0);
                let data: f64 = (oe.warm..oe.n)
                    .map(|l| (v[l] - pred[l]).powi(2))
                    .sum::<f64>()
                    / 2.0;
                data + s.prior.unwrap().cost(p, &s)
            };
            let grad = |oe: &OutputErrorRefinement<f64, N, 24>, p: CellParameters<f64>| {
                let d = 1e-6;
                let mut g = 0.0f64;
                for k in 0..5 {
                    let moved = |sign: f64| {
                        let mut q = p;
                        match k {
                            0 => q.r_i *= (sign * d).exp(),
                            1 => q.r_ct *= (sign * d).exp(),
                            2 => q.q *= (sign * d).exp(),
                            3 => q.alpha += sign * d,
                            _ => q.u_oc += sign * d,
                        }
                        total(oe, &q)
                    };
                    g = g.max(((moved(1.0) - moved(-1.0)) / (2.0 * d)).abs());
                }
                g
            };
            oe.iterate(&s, &win).unwrap();
            let g0 = grad(&oe, truth);
            for _ in 0..200 {
                if oe.iterate(&s, &win).unwrap().converged {
                    break;
                }
            }
            let g1 = grad(&oe, oe.cell());
            // Stopped at ε = 1e-7 in the parameters: the gradient left is
            // of the order of the curvature times ε.
            assert!(g1 < 1e-4 * g0, "{noise_v}: {g1:e} vs {g0:e}");
            // …and no move of 1e-3 along any coordinate lowers the sum.
            let at = oe.cell();
            let c0 = total(&oe, &at);
            for k in 0..5 {
                for sign in [-1.0, 1.0] {
                    let mut q = at;
                    let d: f64 = sign * 1e-3;
                    match k {
                        0 => q.r_i *= d.exp(),
                        1 => q.r_ct *= d.exp(),
                        2 => q.q *= d.exp(),
                        3 => q.alpha += d,
                        _ => q.u_oc += 1e-3 * d,
                    }
                    assert!(
                        total(&oe, &q) >= c0 * (1.0 - 1e-9),
                        "{noise_v}: coordinate {k}"
                    );
                }
            }
            rct.push(oe.cell().r_ct);
        }
        // Light prior: the data's R_ct; heavy prior: the centre's.
        assert!((rct[0] / truth.r_ct - 1.0).abs() < 0.05, "{rct:?}");
        assert!((rct[2] / center.r_ct - 1.0).abs() < 0.05, "{rct:?}");
        assert!(rct[1] > rct[0] && rct[1] < rct[2], "{rct:?}");
    }

    /// The Jacobian from the sensitivity recursions equals central finite
    /// differences of the simulation, column by column, on a slid window
    /// (history from data, OCV slope fitted), and with a start from rest;
    /// for the linear model and with the Butler–Volmer term (whose columns
    /// are zero in the linear model).
    #[test]
    fn jacobian_equals_finite_differences() {
        const N: usize = 160;
        const MEM: usize = 32;
        let models = [CellModel::Linear, CellModel::ButlerVolmer];
        for (start, model) in [Start::FromData, Start::AtRest]
            .into_iter()
            .flat_map(|st| models.map(|m| (st, m)))
        {
            let mut s = BatterySettings::new(0.5, MEM);
            s.start = start;
            s.ocv_slope = true;
            s.model = model;
            let mut win = SampleWindow::<f64, N>::new();
            // A window that has slid (FromData) or not (AtRest).
            let len = if start == Start::FromData {
                N + 37
            } else {
                N - 20
            };
            for l in 0..len {
                let x = l as f64;
                let i = 3.0 * (0.11 * x).sin() + 2.0 * (0.037 * x).cos() - 0.5;
                let v = 3.7 + 0.02 * i + 0.004 * (0.05 * x).sin() - 1e-5 * x;
                win.push(i, v).unwrap();
            }
            let p = CellParameters {
                r_i: 0.018,
                r_ct: 0.013,
                q: 430.0,
                alpha: 0.71,
                u_oc: 3.69,
                bv_a: if model == CellModel::ButlerVolmer {
                    0.021
                } else {
                    0.0
                },
                bv_i0: 1.3,
            };
            let mut oe = OutputErrorRefinement::<f64, N, MEM>::new(&s, p).unwrap();
            oe.beta = 2e-6;
            oe.load(&s, &win).unwrap();
            oe.w.set_order(p.alpha).unwrap();
            let n = oe.n;
            let data = WindowData {
                i: &oe.i[..n],
                v: &oe.v[..n],
                c: &oe.c[..n],
                warm: oe.warm,
                tail: tail_context(&s, oe.past.as_ref()),
            };
            simulate_window(&oe.w, &data, &p, oe.beta, &mut oe.up[..n], &mut oe.e[..n]);
            oe.sensitivities(true, s.model == CellModel::ButlerVolmer, s.uses_tail());
            // Central differences in x = [ln R_i, ln R_ct, ln Q, α, U_oc, β,
            // ln a, ln i₀].
            let step = [1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-9, 1e-5, 1e-5];
            for (k, &d) in step.iter().enumerate() {
                if k >= 6 && model == CellModel::Linear {
                    for l in oe.warm..n {
                        assert_eq!(oe.jacobian_row(&s, &oe.p, l)[k], 0.0);
                    }
                    continue;
                }
                let moved = |sign: f64| {
                    let mut q = p;
                    let mut beta = oe.beta;
                    match k {
                        0 => q.r_i *= (sign * d).exp(),
                        1 => q.r_ct *= (sign * d).exp(),
                        2 => q.q *= (sign * d).exp(),
                        3 => q.alpha += sign * d,
                        4 => q.u_oc += sign * d,
                        5 => beta += sign * d,
                        6 => q.bv_a *= (sign * d).exp(),
                        _ => q.bv_i0 *= (sign * d).exp(),
                    }
                    predicted(&s, &oe, &q, beta)
                };
                let (hi, lo) = (moved(1.0), moved(-1.0));
                let fd: Vec<f64> = (0..n).map(|l| (hi[l] - lo[l]) / (2.0 * d)).collect();
                let scale = fd[oe.warm..].iter().fold(0.0f64, |m, x| m.max(x.abs()));
                assert!(scale > 0.0, "column {k} is zero");
                for (l, &f) in fd.iter().enumerate().skip(oe.warm) {
                    let j = oe.jacobian_row(&s, &oe.p, l)[k];
                    assert!(
                        (j - f).abs() <= 1e-6 * scale,
                        "{start:?} {model:?}: column {k}, row {l}: {j} vs {f}"
                    );
                }
            }
        }
    }

    /// A window with the modes of a past (what a pack's cell window gives).
    struct WithPast<'a, const N: usize> {
        win: &'a SampleWindow<f64, N>,
        past: PastModes<f64>,
    }

    impl<const N: usize> Window<f64> for WithPast<'_, N> {
        fn len(&self) -> usize {
            self.win.len()
        }
        fn version(&self) -> u32 {
            self.win.version()
        }
        fn has_slid(&self) -> bool {
            true
        }
        fn recent(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
            self.win.recent()
        }
        fn copy_into(&self, u: &mut [f64], y: &mut [f64]) -> usize {
            self.win.copy_into(u, y)
        }
        fn past(&self) -> Option<PastModes<f64>> {
            Some(self.past)
        }
    }

    /// With the tail beyond the memory (taps at lags ≥ M inside the window
    /// and a past before it), the Jacobian from the sensitivity recursions
    /// still equals central finite differences of the simulation, column by
    /// column (h = 0.5, α = 0.71 inside a segment of the coefficient table,
    /// OCV slope fitted).
    #[test]
    fn jacobian_with_the_tail_equals_finite_differences() {
        const N: usize = 200;
        const MEM: usize = 64;
        let mut s = BatterySettings::new(0.5, MEM);
        s.start = Start::FromData;
        s.ocv_slope = true;
        s.tail = true;
        assert!(s.uses_tail());
        let sample = |l: usize| {
            let x = l as f64;
            let i = 3.0 * (0.11 * x).sin() + 2.0 * (0.037 * x).cos() - 0.5;
            (i, 3.7 + 0.02 * i + 0.004 * (0.05 * x).sin() - 1e-5 * x)
        };
        // 300 samples left before the window's 200.
        let mut past = PastModes::new();
        for l in 0..300 {
            let (i, v) = sample(l);
            past.leave(i, v, sample(l + 1).0);
        }
        let mut win = SampleWindow::<f64, N>::new();
        for l in 300..500 {
            let (i, v) = sample(l);
            win.push(i, v).unwrap();
        }
        let view = WithPast { win: &win, past };
        let p = CellParameters {
            r_i: 0.018,
            r_ct: 0.013,
            q: 430.0,
            alpha: 0.71,
            u_oc: 3.69,
            bv_a: 0.0,
            bv_i0: 1.3,
        };
        let mut oe = OutputErrorRefinement::<f64, N, MEM>::new(&s, p).unwrap();
        oe.beta = 2e-6;
        oe.load(&s, &view).unwrap();
        assert!(oe.past.is_some() && oe.warm == MEM - 1);
        oe.w.set_order(p.alpha).unwrap();
        let n = oe.n;
        let data = WindowData {
            i: &oe.i[..n],
            v: &oe.v[..n],
            c: &oe.c[..n],
            warm: oe.warm,
            tail: tail_context(&s, oe.past.as_ref()),
        };
        simulate_window(&oe.w, &data, &p, oe.beta, &mut oe.up[..n], &mut oe.e[..n]);
        oe.sensitivities(true, false, true);
        // The tail changes the simulation: the test sees it.
        let mut plain = s;
        plain.tail = false;
        let without = predicted(&plain, &oe, &p, oe.beta);
        let with = predicted(&s, &oe, &p, oe.beta);
        let moved = (0..n).fold(0.0f64, |m, l| m.max((with[l] - without[l]).abs()));
        assert!(moved > 1e-4, "the tail moves the simulation by {moved} V");
        let step = [1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-9];
        for (k, &d) in step.iter().enumerate() {
            let moved = |sign: f64| {
                let mut q = p;
                let mut beta = oe.beta;
                match k {
                    0 => q.r_i *= (sign * d).exp(),
                    1 => q.r_ct *= (sign * d).exp(),
                    2 => q.q *= (sign * d).exp(),
                    3 => q.alpha += sign * d,
                    4 => q.u_oc += sign * d,
                    _ => beta += sign * d,
                }
                predicted(&s, &oe, &q, beta)
            };
            let (hi, lo) = (moved(1.0), moved(-1.0));
            let fd: Vec<f64> = (0..n).map(|l| (hi[l] - lo[l]) / (2.0 * d)).collect();
            let scale = fd[oe.warm..].iter().fold(0.0f64, |m, x| m.max(x.abs()));
            assert!(scale > 0.0, "column {k} is zero");
            for (l, &f) in fd.iter().enumerate().skip(oe.warm) {
                let j = oe.jacobian_row(&s, &oe.p, l)[k];
                assert!(
                    (j - f).abs() <= 1e-6 * scale,
                    "column {k}, row {l}: {j} vs {f}"
                );
            }
        }
    }
}
