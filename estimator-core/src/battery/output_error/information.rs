//! The Gauss–Newton information of a fit: standard errors, BIC, the
//! residual variance.

use super::*;

impl<T: Real, const N: usize, const MEM: usize, K: BranchSolver<T>>
    OutputErrorRefinement<T, N, MEM, K>
{
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
            let sim = &self.sims[self.est()];
            window_cost(&data, &self.p, self.beta, &sim.eta[..n], &sim.up[..n])
        } else {
            self.stalled = None;
            let kept = take_kinetic(&mut self.kinetic_kept, n);
            let es = self.est();
            let sim = &mut self.sims[es];
            simulate_window_with_free(
                &mut self.solver,
                &self.w,
                &data,
                &self.p,
                self.beta,
                &mut sim.up[..n],
                &mut sim.e[..n],
                &mut sim.eta[..n],
                kept,
                None,
            )
            .0
        };
        if !cost.is_finite() {
            self.fresh = false;
            return Err(Error::Diverged);
        }
        self.fresh = true;
        // The sensitivities are now those of the estimate, not of the last
        // accepted step's start: no chord step from them.
        self.linear = None;
        let (jtj, _) = self.normal_equations(s, false);
        self.work.linearizations = self.work.linearizations.wrapping_add(1);
        let kinetic = self.p.is_butler_volmer();
        Ok(self.fit_information(s, jtj, cost, kinetic))
    }

    /// The [`FitInformation`] of the normal equations just formed: `jtj`
    /// (the prior's added or not, as the caller wants), the data's `cost`,
    /// the fitted rows and columns (the kinetic ones when `kinetic` and the
    /// settings fit the Butler–Volmer model) and the residuals' lag-1
    /// autocorrelation.
    pub(super) fn fit_information(
        &self,
        s: &BatterySettings<T>,
        jtj: Square<T>,
        cost: T,
        kinetic: bool,
    ) -> FitInformation<T> {
        let kinetic = kinetic && s.model == CellModel::ButlerVolmer;
        FitInformation {
            jtj,
            cost,
            rows: (self.n - self.warm).saturating_sub(self.unobserved as usize),
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
            lag1: self.residual_lag1(),
        }
    }

    /// The lag-1 autocorrelation `Σ r(l)·r(l−1) / Σ r(l)²` of the
    /// residuals the last normal equations left in the trial buffer (0
    /// for fewer than two rows or zero residuals).
    pub(super) fn residual_lag1(&self) -> T {
        let n = self.n.min(N);
        let r = &self.sims[self.spare()].up[self.warm.min(n)..n];
        let (mut num, mut den) = (T::zero(), T::zero());
        let mut previous = None;
        for &x in r {
            den = den + x * x;
            if let Some(before) = previous {
                num = num + x * before;
            }
            previous = Some(x);
        }
        if den > T::zero() {
            num / den
        } else {
            T::zero()
        }
    }
}

/// The finest voltage a cell's record resolves (V): no cycler or BMS
/// front end measures below it, so a fit's residuals smaller than it are
/// rounding ([`FitInformation::bic`]).
pub const VOLTAGE_RESOLUTION_V: f64 = 1e-6;

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
    /// The lag-1 autocorrelation of the residuals over the fitted rows
    /// (for [`Self::correlated_standard_errors`]).
    pub lag1: T,
}

impl<T: Real> FitInformation<T> {
    /// The information of the window's data alone, from that of normal
    /// equations that hold the prior of `s` (as
    /// [`OutputErrorRefinement::last_information`] does): `jtj` without the
    /// prior's weights on its diagonal. With a prior, `jtj`'s intervals are
    /// the prior's as much as the data's (the prior weighs as a residual
    /// of [`crate::battery::Prior`]'s `noise_v`, the intervals are scaled
    /// by the window's residual), so a parameter the data say nothing of
    /// would pass as known. The same information without a prior.
    pub fn without_prior(&self, s: &BatterySettings<T>) -> Self {
        let mut out = *self;
        for (k, w) in prior_diagonal(s).into_iter().enumerate() {
            out.jtj[k][k] = out.jtj[k][k] - w;
        }
        out
    }

    /// [`Self::standard_errors`] widened for residuals that follow each
    /// other (an AR(1) process with the residuals' lag-1 autocorrelation
    /// ρ, clamped to `[0, 0.999]`): each times `√((1 + ρ)/(1 − ρ))`, the
    /// square root of the samples one independent sample is worth. Model
    /// error on a measured cell makes the residuals of a window follow each
    /// other closely; white-noise intervals are then far too narrow.
    pub fn correlated_standard_errors(&self) -> [Option<T>; COLUMNS] {
        let rho = self.lag1.max(T::zero()).min(T::lit(0.999));
        let widen = ((T::one() + rho) / (T::one() - rho)).sqrt();
        self.standard_errors().map(|e| e.map(|e| e * widen))
    }

    /// Number of fitted parameters.
    pub fn parameters(&self) -> usize {
        self.fitted.iter().filter(|&&f| f).count()
    }

    /// The residual variance `2·cost/(rows − parameters)` (V²).
    pub fn residual_variance(&self) -> T {
        let dof = self.rows.saturating_sub(self.parameters()).max(1);
        T::lit(2.0) * self.cost / T::lit(dof as f64)
    }

    /// Bayesian information criterion `rows·ln(RSS/rows) + k·ln(rows)`,
    /// the mean square residual taken no lower than
    /// the record's resolution squared, (1 µV)² (below it two fits differ by rounding,
    /// not by what the data say: on a record without noise the model with
    /// more parameters would otherwise win on rounding alone).
    pub fn bic(&self) -> T {
        let rows = T::lit(self.rows.max(1) as f64);
        let rss = T::lit(2.0) * self.cost;
        let floor = T::lit(VOLTAGE_RESOLUTION_V * VOLTAGE_RESOLUTION_V);
        let ms = if rss / rows > floor {
            rss / rows
        } else {
            floor
        };
        rows * ms.ln() + T::lit(self.parameters() as f64) * rows.ln()
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
        let Some(d) = T::spd_inverse_diagonal(&m) else {
            return [None; COLUMNS];
        };
        let mut out = [None; COLUMNS];
        for k in (0..COLUMNS).filter(|&k| self.fitted[k]) {
            if d[k] <= T::zero() {
                return [None; COLUMNS];
            }
            out[k] = Some((var * d[k]).sqrt());
        }
        out
    }
}
