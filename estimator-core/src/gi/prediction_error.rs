//! The prediction-error refinement: beyond the paper, the Gaussian
//! maximum-likelihood estimate of the model of eq. (4), started from
//! 2S-OP-GI or KT-2S-GI.
//!
//! # The criterion
//! Under eq. (4)/(5) the equation error of the system part,
//!
//! ```text
//! w(l) = y(l) + Σ_i a_i Δ^α y(l−i) − Σ_i Σ_j b_iγ_j Δ^α f_j(u(l−i)),
//! ```
//!
//! is the coloured noise `e(l)` itself, and `e(l) + Σ_k c_k Δ^α e(l−k) = v(l)`
//! is white. So the one-step prediction error, whitened by the noise model,
//!
//! ```text
//! ε(l) = w(l) + Σ_k c_k Δ^α w(l−k)      (w = 0 before the first row used)
//! ```
//!
//! equals `v(l)` at the true parameters, and minimizing `V = ½ Σ ε(l)²`
//! jointly over `p = [a, c, b_iγ_j, α]` is maximum likelihood for Gaussian
//! `v`. This is the "full criterion" the paper algorithms evaluate too (their
//! cost with `ê` recomputed from the current parameters), but they descend it
//! with `ê` frozen in each linear stage, which has a biased fixed point
//! (docs/identification.md). Here every parameter moves at once by
//! Levenberg–Marquardt with the exact Jacobian:
//!
//! ```text
//! ∂ε/∂a_i   =  (1 + C̃)[Δ^α y(·−i)]          C̃x(l) = Σ_k c_k Δ^α x(l−k)
//! ∂ε/∂b_iγ_j = −(1 + C̃)[Δ^α f_j(u(·−i))]     (the sequences masked before the first row)
//! ∂ε/∂c_k   =  Δ^α w(l−k)
//! ∂ε/∂α     =  −∂ŷ/∂α                        (the paper algorithms' order derivative)
//! ```
//!
//! # A global search: the order and the colour of the noise
//! The cost in α has several local minima on weakly excited data, and a
//! descent from the paper stage's α̂ can stop in the wrong one. At a fixed
//! order, too, the criterion can have two minima: the colour of the output
//! explained by the noise model C (small a) or by the autoregression A
//! (small c); the paper stage often ends in the wrong one (on
//! `paper-kt-stable` at σ = 1, a ≈ [−0.49, 0.53] and c ≈ [0.05, 0] against
//! a ≈ [−0.02, −0.01] and c ≈ [−0.35, 0.61]). So the refinement first fits
//! `[a, c, b_iγ_j]` at fixed orders, the start's own α̂ (start 0) and
//! `grid_points` orders spread evenly over `(grid_low, grid_high)` (starts
//! 1…), each from three [`LinearStart`]s (the start's own parameters, the
//! noise-model least squares, the equation-error least squares) for at most
//! `grid_iterations` iterations. Then it descends all parameters, α
//! included, from the start of lowest cost
//! ([`PredictionErrorRefinement::winning_start`] says which one won).
//!
//! One call of [`PredictionErrorRefinement::iterate`] is one
//! Levenberg–Marquardt iteration (one accepted step, or no decrease at any
//! damping). The module owns the refinement's state, its Jacobian and its
//! damping; the data and the differences are [`Regression`]'s, shared with the
//! paper algorithms, and it never changes the paper stage it started from.

use super::regression::{lag, Params, Regression};
use super::{GiSettings, HammersteinEstimate};
use crate::error::Error;
use crate::model::Basis;
use crate::real::Real;
use crate::window::SampleWindow;

/// Settings of the refinement (apart from its state, like [`GiSettings`],
/// which it contains: orders, memory, period, order bounds, ε, whether α is
/// estimated, the prehistory).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PredictionErrorSettings<T> {
    /// The model and search settings shared with the paper algorithms. Its
    /// `epsilon` is the refinement's stopping tolerance on the step
    /// `‖Δp‖`; its `max_order_step` and `max_halvings` are not used.
    pub gi: GiSettings<T>,
    /// Number of fixed orders of the global search besides the start's own
    /// (0: descend from the start only).
    pub grid_points: u8,
    /// Lower end of the interval the grid orders are spread over.
    pub grid_low: T,
    /// Upper end of that interval.
    pub grid_high: T,
    /// Largest number of iterations at one fixed order.
    pub grid_iterations: u8,
    /// Largest number of damping increases in one iteration before it
    /// reports no decrease.
    pub max_damping_trials: u8,
}

impl<T: Real> PredictionErrorSettings<T> {
    /// Defaults: the given [`GiSettings`] with `ε = 1e−7`, 8 grid orders over
    /// `(0, 1.5)` (0.094, 0.28, …, 1.41), 12 iterations at each, 12 damping
    /// trials.
    pub fn new(gi: GiSettings<T>) -> Self {
        Self {
            gi: GiSettings {
                epsilon: T::lit(1e-7),
                ..gi
            },
            grid_points: 8,
            grid_low: T::zero(),
            grid_high: T::lit(1.5),
            grid_iterations: 12,
            max_damping_trials: 12,
        }
    }

    /// The fixed order of start `start` (0: the start's own `alpha0`), inside
    /// the order bounds.
    pub fn start_order(&self, start: u8, alpha0: T) -> T {
        let a = if start == 0 || self.grid_points == 0 {
            alpha0
        } else {
            let width = (self.grid_high - self.grid_low) / T::lit(f64::from(self.grid_points));
            self.grid_low + (T::lit(f64::from(start)) - T::lit(0.5)) * width
        };
        a.max(self.gi.alpha_min).min(self.gi.alpha_max)
    }

    /// Validates the settings against the capacities of a refinement.
    ///
    /// # Errors
    /// Those of [`GiSettings::check`], [`Error::ParameterCapacity`] when
    /// `NQ < n_a + n_c + n_b·m + 1`, [`Error::BadSetting`] for a grid
    /// interval that is not finite and increasing or no damping trial.
    pub fn check<
        const MEM: usize,
        const NA: usize,
        const NB: usize,
        const NC: usize,
        const NF: usize,
        const NP: usize,
        const NQ: usize,
    >(
        &self,
    ) -> Result<(), Error> {
        self.gi.check::<MEM, NA, NB, NC, NF, NP>()?;
        let needed = parameters(&self.gi) + 1;
        if needed > NQ {
            return Err(Error::ParameterCapacity {
                needed,
                capacity: NQ,
            });
        }
        let grid_ok = self.grid_points == 0
            || (self.grid_low.is_finite()
                && self.grid_high.is_finite()
                && self.grid_low < self.grid_high);
        if !grid_ok || self.max_damping_trials == 0 {
            return Err(Error::BadSetting);
        }
        Ok(())
    }
}

/// Number of linear parameters `n_a + n_c + n_b·m`.
fn parameters<T>(s: &GiSettings<T>) -> usize {
    s.orders.na + s.orders.nc + s.orders.products()
}

/// Where the linear parameters `[a, c, b_iγ_j]` of a start of the search
/// come from. At a fixed order the criterion can have a minimum for each way
/// of explaining the colour of the output: by the noise model C (small a) or
/// by the autoregression A (small c); each start below leads into one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LinearStart {
    /// The start estimate's (the paper stage's).
    Given,
    /// `a = 0`: least squares for `b_iγ_j`, then least squares for the
    /// noise model `c` on the equation error it leaves.
    NoiseModel,
    /// `c = 0`: least squares for `a` and `b_iγ_j` together (the
    /// equation-error fit).
    EquationError,
}

impl LinearStart {
    /// The starts in the order the search visits them at each order.
    pub const ALL: [LinearStart; 3] = [
        LinearStart::Given,
        LinearStart::NoiseModel,
        LinearStart::EquationError,
    ];

    fn next(self) -> Option<Self> {
        match self {
            LinearStart::Given => Some(LinearStart::NoiseModel),
            LinearStart::NoiseModel => Some(LinearStart::EquationError),
            LinearStart::EquationError => None,
        }
    }
}

/// Where the refinement is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Phase {
    /// The global search: the linear parameters at the fixed order of start
    /// `start` (0: the start's own order, then the grid).
    Search {
        /// Index of the start's order.
        start: u8,
        /// Where its linear parameters start.
        linear: LinearStart,
    },
    /// The descent of every parameter, α included, from the winning start.
    Descent,
}

/// The start of the order search the descent began from.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WinningStart<T> {
    /// 0: the start estimate's own order; `g ≥ 1`: grid order `g`.
    pub index: u8,
    /// Where its linear parameters started.
    pub linear: LinearStart,
    /// The fixed order of that start.
    pub alpha: T,
    /// The criterion after the fit of the linear parameters at that order.
    pub cost: T,
}

/// What one iteration did.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PredictionErrorIteration<T> {
    /// Iteration counter (1 for the first call).
    pub k: u32,
    /// The phase this iteration ran in.
    pub phase: Phase,
    /// α̂ after the iteration.
    pub alpha: T,
    /// `V = ½ Σ ε(l)²` after the iteration.
    pub cost: T,
    /// `‖Δp‖` of the accepted step (0 when none was).
    pub change: T,
    /// A step lowered the cost (false: no damping did, so the estimate is a
    /// minimum to rounding).
    pub accepted: bool,
    /// The damping λ of the accepted (or last tried) step.
    pub damping: T,
    /// The descent has converged: a step `‖Δp‖ ≤ ε`, or no decrease.
    /// Never true during the search.
    pub converged: bool,
    /// Number of rows of the criterion.
    pub rows: usize,
}

/// The prediction-error refinement for a window of capacity `N`, memory
/// capacity `MEM`, order capacities `NA, NB, NC`, basis capacity `NF`,
/// product capacity `NP ≥ n_b·m` and parameter capacity
/// `NQ ≥ n_a + n_c + n_b·m + 1` (the Jacobian holds `NQ` columns of `N`).
///
/// ```
/// use estimator_core::gi::{over_param::OverParamGi, GiSettings};
/// use estimator_core::gi::prediction_error::{PredictionErrorRefinement, PredictionErrorSettings};
/// use estimator_core::model::{Orders, Polynomial};
/// use estimator_core::window::SampleWindow;
///
/// let gi = GiSettings::<f64>::new(Orders::PAPER, 32);
/// let mut paper = OverParamGi::<f64, 96, 32, 2, 3, 2, 2, 6>::new(&gi, 0.5).unwrap();
/// let mut window = SampleWindow::<f64, 96>::new();
/// for l in 0..96 {
///     let u = ((l * 7919) % 13) as f64 / 6.0 - 1.0;
///     window.push(u, 0.3 * u).unwrap();
/// }
/// for _ in 0..5 {
///     paper.iterate(&gi, &Polynomial, &window).unwrap();
/// }
/// let s = PredictionErrorSettings::new(gi);
/// let mut pem =
///     PredictionErrorRefinement::<f64, 96, 32, 2, 3, 2, 2, 6, 11>::new(&s, paper.estimate()).unwrap();
/// let first = pem.iterate(&s, &Polynomial, &window).unwrap();
/// assert!(first.cost.is_finite());
/// ```
#[derive(Clone, Debug)]
pub struct PredictionErrorRefinement<
    T,
    const N: usize,
    const MEM: usize,
    const NA: usize,
    const NB: usize,
    const NC: usize,
    const NF: usize,
    const NP: usize,
    const NQ: usize,
> {
    est: HammersteinEstimate<T, NA, NB, NC, NF, NP>,
    start: HammersteinEstimate<T, NA, NB, NC, NF, NP>,
    best: HammersteinEstimate<T, NA, NB, NC, NF, NP>,
    best_cost: T,
    best_start: (u8, LinearStart),
    phase: Phase,
    at_start: u8,
    damping: T,
    k: u32,
    reg: Regression<T, N, MEM, NF>,
    /// Columns `∂ε/∂p_k` on the rows.
    jac: [[T; N]; NQ],
    /// Scratch: the differences of one column's sequence.
    tmp: [T; N],
}

/// The refinement sized for the paper's Example 1 orders (2/3/2, m = 2, 11
/// parameters).
pub type PaperPredictionError<T, const N: usize, const MEM: usize> =
    PredictionErrorRefinement<T, N, MEM, 2, 3, 2, 2, 6, 11>;

const DAMPING0: f64 = 1e-3;

impl<
        T: Real,
        const N: usize,
        const MEM: usize,
        const NA: usize,
        const NB: usize,
        const NC: usize,
        const NF: usize,
        const NP: usize,
        const NQ: usize,
    > PredictionErrorRefinement<T, N, MEM, NA, NB, NC, NF, NP, NQ>
{
    /// A refinement started from `start` (a paper-stage estimate, in the
    /// products form; [`KeyTermGi::products`](super::key_term::KeyTermGi::products)
    /// gives it for KT-2S-GI).
    ///
    /// # Errors
    /// Those of [`PredictionErrorSettings::check`]; [`Error::BadSetting`]
    /// for a start of other orders, with non-finite entries or an order
    /// outside the bounds.
    pub fn new(
        s: &PredictionErrorSettings<T>,
        start: &HammersteinEstimate<T, NA, NB, NC, NF, NP>,
    ) -> Result<Self, Error> {
        s.check::<MEM, NA, NB, NC, NF, NP, NQ>()?;
        check_start(s, start)?;
        let mut me = Self {
            est: *start,
            start: *start,
            best: *start,
            best_cost: T::infinity(),
            best_start: (0, LinearStart::Given),
            phase: Phase::Descent,
            at_start: 0,
            damping: T::lit(DAMPING0),
            k: 0,
            reg: Regression::new(&s.gi, start.alpha)?,
            jac: [[T::ZERO; N]; NQ],
            tmp: [T::ZERO; N],
        };
        me.begin(s);
        Ok(me)
    }

    /// Restarts from another start estimate (the working arrays kept).
    ///
    /// # Errors
    /// As [`PredictionErrorRefinement::new`]; on error the state is
    /// unchanged.
    pub fn restart(
        &mut self,
        s: &PredictionErrorSettings<T>,
        start: &HammersteinEstimate<T, NA, NB, NC, NF, NP>,
    ) -> Result<(), Error> {
        s.check::<MEM, NA, NB, NC, NF, NP, NQ>()?;
        check_start(s, start)?;
        self.est = *start;
        self.start = *start;
        self.best = *start;
        self.best_cost = T::infinity();
        self.best_start = (0, LinearStart::Given);
        self.k = 0;
        self.reg.invalidate();
        self.begin(s);
        Ok(())
    }

    fn begin(&mut self, s: &PredictionErrorSettings<T>) {
        self.at_start = 0;
        self.damping = T::lit(DAMPING0);
        self.phase = if s.gi.estimate_order {
            Phase::Search {
                start: 0,
                linear: LinearStart::Given,
            }
        } else {
            Phase::Descent
        };
    }

    /// The current estimate (the last accepted step; during the search, the
    /// fit at the current start's order).
    pub fn estimate(&self) -> &HammersteinEstimate<T, NA, NB, NC, NF, NP> {
        &self.est
    }

    /// The phase the next iteration runs in.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Iterations run since the start.
    pub fn iterations(&self) -> u32 {
        self.k
    }

    /// The start the descent began from, once the search is over. `None`
    /// during the search, and when the order is not estimated (no search).
    pub fn winning_start(&self, s: &PredictionErrorSettings<T>) -> Option<WinningStart<T>> {
        match self.phase {
            Phase::Descent if s.gi.estimate_order => Some(WinningStart {
                index: self.best_start.0,
                linear: self.best_start.1,
                alpha: s.start_order(self.best_start.0, self.start.alpha),
                cost: self.best_cost,
            }),
            _ => None,
        }
    }

    /// The criterion `V = ½ Σ ε(l)²` of any estimate on the window (for
    /// example the true parameters of a simulated record). The refinement's
    /// estimate is not changed.
    ///
    /// # Errors
    /// [`Error::BadSetting`] for other orders, non-finite entries or an order
    /// outside the bounds, and the window errors of
    /// [`PredictionErrorRefinement::iterate`].
    pub fn cost_at<B: Basis<T>>(
        &mut self,
        s: &PredictionErrorSettings<T>,
        basis: &B,
        window: &SampleWindow<T, N>,
        est: &HammersteinEstimate<T, NA, NB, NC, NF, NP>,
    ) -> Result<T, Error> {
        s.check::<MEM, NA, NB, NC, NF, NP, NQ>()?;
        check_start(s, est)?;
        let alpha = self.est.alpha.max(s.gi.alpha_min).min(s.gi.alpha_max);
        self.reg
            .load(&s.gi, basis, window, alpha, parameters(&s.gi) + 1)?;
        self.reg.trial_cost(est.alpha, &params(est))
    }

    /// Runs one Levenberg–Marquardt iteration on the window.
    ///
    /// # Errors
    /// Settings errors, [`Error::NotEnoughData`], [`Error::NotExcited`],
    /// [`Error::NonFiniteSample`] or [`Error::Diverged`] (the criterion at
    /// the current estimate is not finite). On any error the estimate is
    /// unchanged.
    pub fn iterate<B: Basis<T>>(
        &mut self,
        s: &PredictionErrorSettings<T>,
        basis: &B,
        window: &SampleWindow<T, N>,
    ) -> Result<PredictionErrorIteration<T>, Error> {
        s.check::<MEM, NA, NB, NC, NF, NP, NQ>()?;
        if s.gi.orders != self.est.orders {
            return Err(Error::BadSetting);
        }
        let phase = self.phase;
        let free_order = phase == Phase::Descent && s.gi.estimate_order;
        let np = parameters(&s.gi) + usize::from(free_order);
        if let Phase::Search { linear, .. } = phase {
            if self.at_start == 0 && linear != LinearStart::Given {
                let before = self.est;
                if let Err(e) = self.linear_start(s, basis, window, linear) {
                    self.est = before;
                    return Err(e);
                }
            }
        }
        let cost0 = self.linearize(s, basis, window, free_order)?;
        let rows = self.reg.rows();
        let (h, g) = self.normal_equations(np, |_| true);
        let mut scale = [T::one(); NQ];
        for (i, sc) in scale.iter_mut().enumerate().take(np) {
            if crate::real::positive_finite(h[i][i]) {
                *sc = h[i][i];
            }
        }

        let mut accepted = false;
        let mut change = T::zero();
        let mut cost = cost0;
        for _ in 0..s.max_damping_trials {
            let mut m = h;
            for i in 0..NQ {
                if i < np {
                    m[i][i] = h[i][i] + self.damping * scale[i];
                } else {
                    m[i][i] = T::one();
                }
            }
            let Some(step) = T::solve_spd(&m, &g) else {
                self.damping = self.damping * T::lit(10.0);
                continue;
            };
            let mut trial = self.est;
            apply_step(&mut trial, &step[..np], free_order);
            trial.alpha = trial.alpha.max(s.gi.alpha_min).min(s.gi.alpha_max);
            let c = self.reg.trial_cost(trial.alpha, &params(&trial));
            match c {
                Ok(c) if c.is_finite() && c < cost0 => {
                    self.reg.accept_trial();
                    change = distance(&trial, &self.est);
                    self.est = trial;
                    cost = c;
                    accepted = true;
                    self.damping = (self.damping / T::lit(10.0)).max(T::lit(1e-12));
                    break;
                }
                _ => self.damping = self.damping * T::lit(10.0),
            }
        }
        let step_done = !accepted || change <= s.gi.epsilon;
        self.k += 1;
        let report = PredictionErrorIteration {
            k: self.k,
            phase,
            alpha: self.est.alpha,
            cost,
            change,
            accepted,
            damping: self.damping,
            converged: phase == Phase::Descent && step_done,
            rows: rows.len(),
        };
        if let Phase::Search { start, linear } = phase {
            self.at_start = self.at_start.saturating_add(1);
            if step_done || self.at_start >= s.grid_iterations {
                self.next_start(s, (start, linear), cost);
            }
        }
        Ok(report)
    }

    /// `JᵀJ` and `−Jᵀε` over the rows for the first `np` columns; a column
    /// `k` with `!keep(k)`, and every index past `np`, gets a unit row and a
    /// zero right-hand side (its step is 0).
    fn normal_equations(
        &self,
        np: usize,
        keep: impl Fn(usize) -> bool,
    ) -> ([[T; NQ]; NQ], [T; NQ]) {
        let rows = self.reg.rows();
        let mut h = [[T::zero(); NQ]; NQ];
        let mut g = [T::zero(); NQ];
        let cols = &self.jac[..np];
        for (a, ca) in cols.iter().enumerate() {
            if !keep(a) {
                continue;
            }
            for (b, cb) in cols.iter().enumerate().take(a + 1) {
                if keep(b) {
                    let v = crate::real::dot(&ca[rows.clone()], &cb[rows.clone()]);
                    h[a][b] = v;
                    h[b][a] = v;
                }
            }
            g[a] = -crate::real::dot(&ca[rows.clone()], &self.reg.res[rows.clone()]);
        }
        for (i, row) in h.iter_mut().enumerate() {
            if i >= np || !keep(i) {
                row[i] = T::one();
            }
        }
        (h, g)
    }

    /// Builds the linear parameters of a start at the current order from
    /// zero by exact least squares on the parameters the criterion is
    /// linear in (the others held).
    fn linear_start<B: Basis<T>>(
        &mut self,
        s: &PredictionErrorSettings<T>,
        basis: &B,
        window: &SampleWindow<T, N>,
        linear: LinearStart,
    ) -> Result<(), Error> {
        let o = s.gi.orders;
        let alpha = self.est.alpha;
        self.est = HammersteinEstimate {
            orders: o,
            a: [T::zero(); NA],
            c: [T::zero(); NC],
            products: [T::zero(); NP],
            alpha,
        };
        let (na, nc) = (o.na, o.nc);
        match linear {
            LinearStart::Given => Ok(()),
            LinearStart::NoiseModel => {
                self.least_squares(s, basis, window, |k| k >= na + nc)?;
                self.least_squares(s, basis, window, |k| k >= na && k < na + nc)
            }
            LinearStart::EquationError => {
                self.least_squares(s, basis, window, |k| k < na || k >= na + nc)
            }
        }
    }

    /// One Gauss–Newton step without damping on the linear parameters with
    /// `keep(k)` (exact least squares when the criterion is linear in them);
    /// the estimate is kept when the system is singular.
    fn least_squares<B: Basis<T>>(
        &mut self,
        s: &PredictionErrorSettings<T>,
        basis: &B,
        window: &SampleWindow<T, N>,
        keep: impl Fn(usize) -> bool,
    ) -> Result<(), Error> {
        self.linearize(s, basis, window, false)?;
        let np = parameters(&s.gi);
        let (h, g) = self.normal_equations(np, keep);
        if let Some(step) = T::solve_spd(&h, &g) {
            apply_step(&mut self.est, &step[..np], false);
        }
        Ok(())
    }

    /// Iterates until the descent converges or `max_iterations` calls have
    /// run; returns the last iteration (`None` for `max_iterations = 0`).
    ///
    /// # Errors
    /// The first error of [`PredictionErrorRefinement::iterate`].
    pub fn run<B: Basis<T>>(
        &mut self,
        s: &PredictionErrorSettings<T>,
        basis: &B,
        window: &SampleWindow<T, N>,
        max_iterations: u32,
    ) -> Result<Option<PredictionErrorIteration<T>>, Error> {
        let mut last = None;
        for _ in 0..max_iterations {
            let it = self.iterate(s, basis, window)?;
            last = Some(it);
            if it.converged {
                break;
            }
        }
        Ok(last)
    }

    /// Loads the window at the estimate's order (clamped into the bounds),
    /// computes the residual `ε` and the Jacobian columns; returns the cost.
    fn linearize<B: Basis<T>>(
        &mut self,
        s: &PredictionErrorSettings<T>,
        basis: &B,
        window: &SampleWindow<T, N>,
        free_order: bool,
    ) -> Result<T, Error> {
        let alpha = self.est.alpha.max(s.gi.alpha_min).min(s.gi.alpha_max);
        self.reg
            .load(&s.gi, basis, window, alpha, parameters(&s.gi) + 1)?;
        self.est.alpha = alpha;
        let est = self.est;
        let cur = params(&est);
        self.reg.noise_estimate(&cur);
        let cost = self.reg.residual(&cur);
        if !cost.is_finite() {
            self.reg.invalidate();
            return Err(Error::Diverged);
        }
        if free_order {
            self.reg.order_derivative(&cur);
        }
        self.jacobian(&est, free_order);
        Ok(cost)
    }

    /// Ends the fit at start `start` (cost `cost`) and moves to the next
    /// start, or to the descent from the best.
    fn next_start(&mut self, s: &PredictionErrorSettings<T>, at: (u8, LinearStart), cost: T) {
        if cost < self.best_cost {
            self.best_cost = cost;
            self.best = self.est;
            self.best_start = at;
        }
        self.at_start = 0;
        self.damping = T::lit(DAMPING0);
        let next = match at.1.next() {
            Some(linear) => Some((at.0, linear)),
            None if at.0 < s.grid_points => Some((at.0 + 1, LinearStart::Given)),
            None => None,
        };
        if let Some((start, linear)) = next {
            self.phase = Phase::Search { start, linear };
            self.est = self.start;
            self.est.alpha = s.start_order(start, self.start.alpha);
        } else {
            self.phase = Phase::Descent;
            self.est = self.best;
        }
    }

    /// The Jacobian columns `∂ε/∂p_k` at `est` (the regression holds its
    /// residual, its noise differences and, for a free order, `∂ŷ/∂α`).
    fn jacobian(&mut self, est: &HammersteinEstimate<T, NA, NB, NC, NF, NP>, free_order: bool) {
        let o = est.orders;
        let (n, r0) = (self.reg.n, self.reg.r0);
        let mut col = 0;
        // a_i: (1 + C̃)[Δ^α y(·−i)].
        for i in 1..=o.na {
            for (l, x) in self.jac[col][..n].iter_mut().enumerate() {
                *x = if l >= r0 {
                    lag(&self.reg.cur.y, l, i)
                } else {
                    T::zero()
                };
            }
            col += 1;
        }
        // c_k: Δ^α w(l−k).
        let c_cols = col;
        for k in 1..=o.nc {
            for (l, x) in self.jac[col][..n].iter_mut().enumerate() {
                *x = lag(&self.reg.cur.e, l, k);
            }
            col += 1;
        }
        // b_iγ_j: −(1 + C̃)[Δ^α f_j(u(·−i))].
        for i in 1..=o.nb {
            for j in 0..o.m {
                for (l, x) in self.jac[col][..n].iter_mut().enumerate() {
                    *x = if l >= r0 {
                        -lag(&self.reg.cur.f[j], l, i)
                    } else {
                        T::zero()
                    };
                }
                col += 1;
            }
        }
        let filtered = (0..c_cols).chain(c_cols + o.nc..col);
        if o.nc > 0 {
            for k in filtered {
                self.reg.w.apply(&self.jac[k][..n], &mut self.tmp[..n]);
                for l in (r0..n).rev() {
                    let mut v = T::zero();
                    for (q, &cq) in est.c[..o.nc].iter().enumerate() {
                        v = v + cq * lag(&self.tmp[..n], l, q + 1);
                    }
                    self.jac[k][l] = self.jac[k][l] + v;
                }
            }
        }
        if free_order {
            for l in 0..n {
                self.jac[col][l] = -self.reg.d[l];
            }
        }
    }
}

fn params<
    T: Real,
    const NA: usize,
    const NB: usize,
    const NC: usize,
    const NF: usize,
    const NP: usize,
>(
    e: &HammersteinEstimate<T, NA, NB, NC, NF, NP>,
) -> Params<'_, T> {
    Params {
        o: e.orders,
        a: &e.a,
        c: &e.c,
        p: &e.products,
    }
}

fn check_start<
    T: Real,
    const NA: usize,
    const NB: usize,
    const NC: usize,
    const NF: usize,
    const NP: usize,
>(
    s: &PredictionErrorSettings<T>,
    e: &HammersteinEstimate<T, NA, NB, NC, NF, NP>,
) -> Result<(), Error> {
    let finite =
        e.a.iter()
            .chain(&e.c)
            .chain(&e.products)
            .all(|x| x.is_finite());
    if e.orders != s.gi.orders || !finite {
        return Err(Error::BadSetting);
    }
    s.gi.check_alpha(e.alpha)
}

/// Adds the step (ordered `[a, c, products, α]`) to the estimate.
fn apply_step<
    T: Real,
    const NA: usize,
    const NB: usize,
    const NC: usize,
    const NF: usize,
    const NP: usize,
>(
    e: &mut HammersteinEstimate<T, NA, NB, NC, NF, NP>,
    step: &[T],
    free_order: bool,
) {
    let o = e.orders;
    let mut it = step.iter();
    for x in e.a[..o.na]
        .iter_mut()
        .chain(e.c[..o.nc].iter_mut())
        .chain(e.products[..o.products()].iter_mut())
    {
        if let Some(&d) = it.next() {
            *x = *x + d;
        }
    }
    if free_order {
        if let Some(&d) = it.next() {
            e.alpha = e.alpha + d;
        }
    }
}

/// `‖p − q‖` over `[a, c, products, α]`.
fn distance<
    T: Real,
    const NA: usize,
    const NB: usize,
    const NC: usize,
    const NF: usize,
    const NP: usize,
>(
    p: &HammersteinEstimate<T, NA, NB, NC, NF, NP>,
    q: &HammersteinEstimate<T, NA, NB, NC, NF, NP>,
) -> T {
    let o = p.orders;
    let mut s = (p.alpha - q.alpha) * (p.alpha - q.alpha);
    for (x, y) in p.a[..o.na]
        .iter()
        .zip(&q.a[..o.na])
        .chain(p.c[..o.nc].iter().zip(&q.c[..o.nc]))
        .chain(
            p.products[..o.products()]
                .iter()
                .zip(&q.products[..o.products()]),
        )
    {
        s = s + (*x - *y) * (*x - *y);
    }
    s.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frac::GlWeights;
    use crate::gi::Prehistory;
    use crate::model::{HammersteinSystem, Orders, Polynomial};

    const N: usize = 160;
    const MEM: usize = 40;
    type Pem = PaperPredictionError<f64, N, MEM>;

    /// A record of eq. (4) with a deterministic pseudo-random input and
    /// noise.
    fn record(memory: usize) -> SampleWindow<f64, N> {
        let sys = HammersteinSystem {
            a: &[-0.3, 0.1],
            b: &[1.0, 0.4, -0.2],
            c: &[0.3, -0.2],
            gamma: &[0.8, 0.3],
            alpha: 0.6,
        };
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let u: [f64; N] = core::array::from_fn(|_| rnd());
        let v: [f64; N] = core::array::from_fn(|_| 0.1 * rnd());
        let (mut y, mut e) = ([0.0; N], [0.0; N]);
        let w = GlWeights::<f64, MEM>::new(sys.alpha, 1.0, memory).unwrap();
        sys.simulate(&Polynomial, &w, &u, &v, &mut y, &mut e)
            .unwrap();
        let mut win = SampleWindow::new();
        for (&u, &y) in u.iter().zip(&y) {
            win.push(u, y).unwrap();
        }
        win
    }

    /// An estimate away from the truth (so no column vanishes).
    fn away() -> HammersteinEstimate<f64, 2, 3, 2, 2, 6> {
        HammersteinEstimate {
            orders: Orders::PAPER,
            a: [-0.2, 0.05],
            c: [0.25, -0.1],
            products: [0.7, 0.2, 0.35, 0.15, -0.1, -0.05],
            alpha: 0.55,
        }
    }

    /// The analytic Jacobian equals central differences of the criterion's
    /// residual, with the sequences masked before the first row (unknown
    /// prehistory) and without (from rest).
    #[test]
    fn jacobian_matches_central_differences() {
        for prehistory in [Prehistory::AtRest, Prehistory::Unknown] {
            let mut gi = GiSettings::new(Orders::PAPER, MEM);
            gi.prehistory = prehistory;
            let s = PredictionErrorSettings::new(gi);
            let win = record(MEM);
            let mut pem = Box::new(Pem::new(&s, &away()).unwrap());
            pem.phase = Phase::Descent;
            pem.linearize(&s, &Polynomial, &win, true).unwrap();
            let rows = pem.reg.rows();
            assert_eq!(rows.start == 0, prehistory == Prehistory::AtRest);
            let jac = pem.jac;
            let base = away();
            let residual_at = |pem: &mut Pem, k: usize, h: f64| -> [f64; N] {
                let mut e = base;
                let mut step = [0.0; 11];
                step[k] = h;
                apply_step(&mut e, &step, true);
                pem.reg.trial_cost(e.alpha, &params(&e)).unwrap();
                pem.reg.q
            };
            for (k, column) in jac.iter().enumerate() {
                let h = 1e-6;
                let plus = residual_at(&mut pem, k, h);
                let minus = residual_at(&mut pem, k, -h);
                let mut worst: f64 = 0.0;
                let mut size: f64 = 0.0;
                for l in rows.clone() {
                    let fd = (plus[l] - minus[l]) / (2.0 * h);
                    worst = worst.max((fd - column[l]).abs());
                    size = size.max(fd.abs());
                }
                assert!(size > 1e-3, "column {k} vanishes");
                assert!(
                    worst <= 1e-6 * size,
                    "{prehistory:?} column {k}: |FD − analytic| {worst:e} of {size:e}"
                );
            }
        }
    }

    /// Each iteration lowers the criterion or reports no decrease, the
    /// search visits the start and every grid order, then the descent
    /// converges below the start's cost.
    #[test]
    fn search_then_descent_lowers_the_cost() {
        let s = PredictionErrorSettings::new(GiSettings::new(Orders::PAPER, MEM));
        let win = record(MEM);
        let mut pem = Box::new(Pem::new(&s, &away()).unwrap());
        let start_cost = pem.cost_at(&s, &Polynomial, &win, &away()).unwrap();
        let mut visited = [false; 27];
        let mut last = None;
        for _ in 0..800 {
            if let Phase::Search { start, linear } = pem.phase() {
                let l = LinearStart::ALL.iter().position(|&x| x == linear).unwrap();
                visited[3 * usize::from(start) + l] = true;
            }
            let before = pem.phase();
            let it = pem.iterate(&s, &Polynomial, &win).unwrap();
            assert_eq!(it.phase, before);
            if before == Phase::Descent {
                if let Some(prev) = last {
                    assert!(it.cost <= prev, "{} > {prev}", it.cost);
                }
                last = Some(it.cost);
            }
            if it.converged {
                break;
            }
        }
        assert!(visited.iter().all(|&v| v), "{visited:?}");
        let won = pem.winning_start(&s).unwrap();
        let end = last.unwrap();
        assert!(
            end <= won.cost && end < start_cost,
            "{end} {won:?} {start_cost}"
        );
        assert!(
            (pem.estimate().alpha - 0.6).abs() < 0.1,
            "{}",
            pem.estimate().alpha
        );
    }

    /// Errors leave the estimate as it was; a wrong start is refused.
    #[test]
    fn errors_keep_the_estimate() {
        let s = PredictionErrorSettings::new(GiSettings::new(Orders::PAPER, MEM));
        let mut pem = Box::new(Pem::new(&s, &away()).unwrap());
        let mut short = SampleWindow::<f64, N>::new();
        for l in 0..5 {
            short.push(l as f64, 1.0).unwrap();
        }
        assert!(matches!(
            pem.iterate(&s, &Polynomial, &short),
            Err(Error::NotEnoughData { .. })
        ));
        assert_eq!(*pem.estimate(), away());
        let mut bad = away();
        bad.c[0] = f64::NAN;
        assert_eq!(pem.restart(&s, &bad).unwrap_err(), Error::BadSetting);
        assert_eq!(*pem.estimate(), away());
        let mut few = s;
        few.gi.orders.nb = 3;
        assert!(matches!(
            PredictionErrorRefinement::<f64, N, MEM, 2, 3, 2, 2, 6, 10>::new(&few, &away()),
            Err(Error::ParameterCapacity {
                needed: 11,
                capacity: 10
            })
        ));
    }
}
