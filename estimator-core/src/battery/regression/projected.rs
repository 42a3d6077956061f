//! The projected iteration's parts ([`PaperRegressionGi::iterate_projected`]):
//! θ solved by least squares at one order ([`Projection`]) and the order
//! step on the cost minimized over θ. They read the loaded window and its
//! regressors; the order stage writes the trial regressors and takes them
//! over on acceptance, as 2S-OP-GI's does (`trial`).

use super::trial::order_search;
use super::PaperRegressionGi;
use crate::battery::BatterySettings;
use crate::error::Error;
use crate::frac::TapSums;
use crate::gi::OrderStep;
use crate::real::Real;

impl<T: Real, const N: usize, const MEM: usize, S: TapSums<T>> PaperRegressionGi<T, N, MEM, S> {
    /// θ minimizing the regression's cost at the order whose regressors
    /// are `di`, `hv` and unit history `k`, by the normal equations of the
    /// centred columns `[I, Δ^α I, −H[v]]` and the constant from their
    /// means (`v = θ₁·I + θ₂·Δ^α I − θ₃·H[v] + b`, so
    /// `θ₄ = b + θ₃·vref·k + vref`), with its cost `½Σr²`. `None` when the
    /// normal matrix is singular to rounding or a result not finite.
    pub(super) fn project(&self, di: &[T; N], hv: &[T; N], k: T) -> Option<Projection<T>> {
        let rows = self.rows();
        if rows.is_empty() {
            return None;
        }
        let m = T::lit(rows.len() as f64);
        let col = |l: usize| [self.i[l], di[l], T::zero() - hv[l]];
        let mut mean = [T::zero(); 3];
        let mut mv = T::zero();
        for l in rows.clone() {
            for (s, x) in mean.iter_mut().zip(col(l)) {
                *s = *s + x;
            }
            mv = mv + self.v[l];
        }
        for s in mean.iter_mut() {
            *s = *s / m;
        }
        mv = mv / m;
        let mut a = [[T::zero(); 3]; 3];
        let mut rhs = [T::zero(); 3];
        for l in rows.clone() {
            let x = col(l);
            let d = [x[0] - mean[0], x[1] - mean[1], x[2] - mean[2]];
            let y = self.v[l] - mv;
            for r in 0..3 {
                for c in r..3 {
                    a[r][c] = a[r][c] + d[r] * d[c];
                }
                rhs[r] = rhs[r] + d[r] * y;
            }
        }
        (a[1][0], a[2][0], a[2][1]) = (a[0][1], a[0][2], a[1][2]);
        let t = solve3(a, rhs)?;
        let b = mv - t[0] * mean[0] - t[1] * mean[1] - t[2] * mean[2];
        let mut cost = T::zero();
        for l in rows {
            let x = col(l);
            let r = self.v[l] - (t[0] * x[0] + t[1] * x[1] + t[2] * x[2] + b);
            cost = cost + r * r;
        }
        let vref = self.vref.unwrap_or(T::zero());
        let theta = [t[0], t[1], t[2], b + t[2] * vref * k + vref];
        let cost = cost / T::lit(2.0);
        (theta.iter().all(|x| x.is_finite()) && cost.is_finite()).then_some(Projection {
            theta,
            cost,
            normal: a,
            mean,
        })
    }

    /// The order stage with θ projected out: a Gauss–Newton step on the
    /// cost minimized over θ (variable projection, Kaufman's Jacobian: the
    /// order derivative `d` of the prediction less its projection on the
    /// columns), each trial order's cost with θ solved there. `fit` is the
    /// projection at the current order, `res` its residual. Returns the
    /// step and the cost after it.
    pub(super) fn projected_order(
        &mut self,
        s: &BatterySettings<T>,
        vref: T,
        dk: T,
        fit: &Projection<T>,
    ) -> Result<(OrderStep, T), Error> {
        self.derivatives();
        let th = self.theta;
        let rows = self.rows();
        let m = T::lit(rows.len() as f64);
        let shift = th[2] * vref * dk;
        let (mut dd, mut dr, mut sd) = (T::zero(), T::zero(), T::zero());
        let mut g = [T::zero(); 3];
        for l in rows.clone() {
            let d = th[1] * self.ddi[l] - th[2] * self.dhv[l] - shift;
            dd = dd + d * d;
            dr = dr + d * self.res[l];
            sd = sd + d;
            let x = [self.i[l], self.di[l], T::zero() - self.hv[l]];
            for j in 0..3 {
                g[j] = g[j] + (x[j] - fit.mean[j]) * d;
            }
        }
        let Some(y) = solve3(fit.normal, g) else {
            return Ok((OrderStep::Flat, fit.cost));
        };
        let perp = dd - sd * sd / m - (g[0] * y[0] + g[1] * y[1] + g[2] * y[2]);
        let mut cost = fit.cost;
        let noise = T::epsilon() * cost * m.sqrt();
        let step = order_search(s, self.w.alpha(), perp, dr, noise, |trial, _| {
            let (_, k) = self.trial_cost_with_regressors(trial)?;
            match self.project(&self.trial_di, &self.trial_hv, k) {
                Some(p) if p.cost < cost => {
                    self.accept_trial_regressors(trial)?;
                    self.theta = p.theta;
                    cost = p.cost;
                    Ok(true)
                }
                _ => Ok(false),
            }
        })?;
        Ok((step, cost))
    }
}

/// θ solved at one order ([`PaperRegressionGi::project`]): with its cost,
/// and the centred normal matrix and column means its order step needs.
#[derive(Clone, Copy, Debug)]
pub(super) struct Projection<T> {
    pub(super) theta: [T; 4],
    pub(super) cost: T,
    normal: [[T; 3]; 3],
    mean: [T; 3],
}

/// The solution of the symmetric 3×3 system `a·x = b` by Gaussian
/// elimination with partial pivoting; `None` when a pivot is below
/// `ε·|a|` (singular to rounding).
pub(super) fn solve3<T: Real>(mut a: [[T; 3]; 3], mut b: [T; 3]) -> Option<[T; 3]> {
    let scale = a
        .iter()
        .flatten()
        .fold(T::zero(), |s, &x| if x.abs() > s { x.abs() } else { s });
    let tiny = T::epsilon() * scale * T::lit(16.0);
    for c in 0..3 {
        let p = (c..3).fold(c, |p, r| if a[r][c].abs() > a[p][c].abs() { r } else { p });
        let pivot = a[p][c].abs();
        if pivot.is_nan() || pivot <= tiny {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in c + 1..3 {
            let f = a[r][c] / a[c][c];
            let top = a[c];
            for (x, &y) in a[r][c..].iter_mut().zip(&top[c..]) {
                *x = *x - f * y;
            }
            b[r] = b[r] - f * b[c];
        }
    }
    let mut x = [T::zero(); 3];
    for c in (0..3).rev() {
        let mut s = b[c];
        for k in c + 1..3 {
            s = s - a[c][k] * x[k];
        }
        x[c] = s / a[c][c];
    }
    Some(x)
}
