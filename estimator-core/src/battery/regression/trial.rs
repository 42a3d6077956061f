//! The order stage's search ([`order_search`]) and its trials: the
//! regression's cost at a trial order, with or without its regressors
//! there, and their taking over on acceptance.
//! They read the loaded window and θ, and write only the trial regressors
//! and the residual buffer; the order itself changes only in
//! `accept_trial_regressors`.

use super::PaperRegressionGi;
use crate::battery::BatterySettings;
use crate::error::Error;
use crate::frac::TapSums;
use crate::gi::OrderStep;
use crate::real::Real;

impl<T: Real, const N: usize, const MEM: usize, S: TapSums<T>> PaperRegressionGi<T, N, MEM, S> {
    /// ½Σ residual² at a trial order, without touching the stored
    /// regressors. θ₂ and θ₃ multiply differences of the same order, so
    /// the residual needs one fractional difference per row, of the
    /// combined signal `z = θ₂·I − θ₃·U_t` (kept in `res`, which the order
    /// stage no longer needs):
    ///
    /// ```text
    /// r(l) = U_t(l) − θ₁·I(l) − θ₃·g·U_t(l) − θ₄ − Δ^α z(l)
    /// ```
    ///
    /// (on the centred voltage `v`, with `z = θ₂·I − θ₃·v` and the constant
    /// `θ₄ − θ₃·vref·k − vref`).
    pub(super) fn trial_cost(&mut self, alpha: T) -> Result<T, Error> {
        let mut w = self.w.clone();
        w.set_order(alpha)?;
        let g = w.scale();
        let th = self.theta;
        let n = self.n.min(N);
        let (k, _) = Self::unit_history(&w);
        let b = self.centred_constant(&th, k, self.vref.unwrap_or(T::zero()));
        for l in 0..n {
            self.res[l] = th[1] * self.i[l] - th[2] * self.v[l];
        }
        let mut c = T::zero();
        let rows = self.rows();
        let (i, v, z) = (&self.i, &self.v, &self.res[..n]);
        self.sums.single(w.weights(), z, rows, |l, dz| {
            let dz = g * dz;
            // (l is a row: l < n ≤ N.)
            if let (Some(&vl), Some(&il)) = (v.get(l), i.get(l)) {
                let r = vl - th[0] * il - th[2] * g * vl - b - dz;
                c = c + r * r;
            }
        });
        Ok(c / T::lit(2.0))
    }

    /// ½Σ residual² at a trial order, computing the regressors there into
    /// `trial_di`/`trial_hv` (taken over by [`Self::accept_trial_regressors`]
    /// if the trial is accepted), and the unit history `k` there. Costs two
    /// fractional differences per row where [`Self::trial_cost`] costs one,
    /// but saves recomputing the regressors on acceptance.
    pub(super) fn trial_cost_with_regressors(&mut self, alpha: T) -> Result<(T, T), Error> {
        let mut w = self.w.clone();
        w.set_order(alpha)?;
        let th = self.theta;
        let rows = self.rows();
        let (k, _) = Self::unit_history(&w);
        let b = self.centred_constant(&th, k, self.vref.unwrap_or(T::zero()));
        let Self {
            i,
            v,
            trial_di,
            trial_hv,
            n,
            sums,
            ..
        } = self;
        let n = (*n).min(N);
        let (g, i, v) = (w.scale(), &i[..n], &v[..n]);
        let mut c = T::zero();
        sums.pair(w.weights(), i, v, rows, |l, d, dv| {
            let (d, dv) = (g * d, g * dv);
            // (l is a row: l < n ≤ N.)
            let (Some(&vl), Some(&il), Some(tdi), Some(thv)) =
                (v.get(l), i.get(l), trial_di.get_mut(l), trial_hv.get_mut(l))
            else {
                return;
            };
            let hv = dv - g * vl;
            *tdi = d;
            *thv = hv;
            let r = vl - (th[0] * il + th[1] * d - th[2] * hv + b);
            c = c + r * r;
        });
        Ok((c / T::lit(2.0), k))
    }

    /// Makes the regressors of the last [`Self::trial_cost_with_regressors`]
    /// at `alpha` current.
    pub(super) fn accept_trial_regressors(&mut self, alpha: T) -> Result<(), Error> {
        self.w.set_order(alpha)?;
        core::mem::swap(&mut self.di, &mut self.trial_di);
        core::mem::swap(&mut self.hv, &mut self.trial_hv);
        self.derivatives = false;
        Ok(())
    }
}

/// The order stage's safeguarded Gauss–Newton search from `alpha0`, with
/// `dd`, `dr` the model of the cost along α: `cost(α₀ + δ) ≈ cost − dr·δ +
/// ½·dd·δ²` predicts a decrease of `dr·δ − ½·dd·δ²` for a step δ. A trial
/// whose predicted decrease is below the rounding error of the cost
/// (`noise`, about ε·cost·√rows) could not show it, so it is not run: none
/// at all (`BelowRounding`), or no further halving. `trial(α, halvings)`
/// runs one and says whether it was accepted (and taken over).
pub(super) fn order_search<T: Real>(
    s: &BatterySettings<T>,
    alpha0: T,
    dd: T,
    dr: T,
    noise: T,
    mut trial: impl FnMut(T, u8) -> Result<bool, Error>,
) -> Result<OrderStep, Error> {
    if !(dd > T::zero() && dr.is_finite()) || dr.is_zero() {
        return Ok(OrderStep::Flat);
    }
    let decrease = |delta: T| dr * delta - dd * delta * delta / T::lit(2.0);
    let step = (dr / dd).max(-s.max_order_step).min(s.max_order_step);
    let mut t = T::one();
    for halvings in 0..=s.max_halvings {
        let alpha = s.clamp_alpha(alpha0 + t * step);
        if alpha == alpha0 {
            break;
        }
        let m = decrease(alpha - alpha0);
        if m.is_nan() || m <= noise {
            if halvings == 0 {
                return Ok(OrderStep::BelowRounding);
            }
            break;
        }
        if trial(alpha, halvings)? {
            return Ok(OrderStep::Accepted { halvings });
        }
        t = t / T::lit(2.0);
    }
    Ok(OrderStep::NoDecrease)
}
