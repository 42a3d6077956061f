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
//! damping; the data and the differences are the private `Regression`'s, shared with the
//! paper algorithms, and it never changes the paper stage it started from.

use super::regression::{lag, Params, Regression};
use super::{GiSettings, HammersteinEstimate};
use crate::error::Error;
use crate::model::Basis;
use crate::real::Real;
use crate::window::SampleWindow;

mod linearization;
mod search;
#[cfg(test)]
mod tests;

use linearization::*;
pub use search::{LinearStart, Phase, WinningStart};

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
