//! The safeguarded one-dimensional search for the order α (eqs. 19–20 and
//! 44–45).
//!
//! α enters the regressors nonlinearly, so the argmin of eqs. (14)/(20)/(45)
//! has no closed form. The search takes the Gauss–Newton step along the
//! gradient of eq. (19), `δ = (∂ŷ/∂α)ᵀ r / ‖∂ŷ/∂α‖²` (the gradient step with
//! the step size of the local quadratic model), clamps the trial order into
//! `[alpha_min, alpha_max]`, and halves the step until the cost decreases. A
//! step that does not lower the cost is never accepted: α then stays put.

use super::regression::{Params, Regression};
use super::GiSettings;
use crate::error::Error;
use crate::real::Real;

/// Outcome of one order search.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OrderStep {
    /// A lower cost was found after this many halvings of the Gauss–Newton
    /// step.
    Accepted {
        /// Number of halvings.
        halvings: u8,
    },
    /// No trial order lowered the cost; α kept.
    NoDecrease,
    /// The cost does not depend on α here (zero derivative); α kept.
    Flat,
    /// The Gauss–Newton model predicts a decrease below the rounding error
    /// of the cost, which no trial could verify; α kept without a trial.
    BelowRounding,
    /// Order estimation is switched off; α kept.
    Fixed,
}

/// Runs the order search on the regression; on acceptance the regression is
/// left at the new order with its residual.
pub(crate) fn order_search<T: Real, const N: usize, const MEM: usize, const NF: usize>(
    reg: &mut Regression<T, N, MEM, NF>,
    s: &GiSettings<T>,
    p: &Params<'_, T>,
) -> Result<OrderStep, Error> {
    if !s.estimate_order {
        return Ok(OrderStep::Fixed);
    }
    // The criterion of this stage: ê re-estimated with the fresh linear
    // parameters, so that the cost compared below is the true one.
    reg.noise_estimate(p);
    reg.residual(p);
    reg.order_derivative(p);
    let rows = reg.rows();
    let dd = crate::real::dot(&reg.d[rows.clone()], &reg.d[rows.clone()]);
    let dr = crate::real::dot(&reg.d[rows.clone()], &reg.res[rows]);
    if !crate::real::positive_finite(dd) || !dr.is_finite() || dr.is_zero() {
        return Ok(OrderStep::Flat);
    }
    let alpha0 = reg.w.alpha();
    let cost0 = reg.cost();
    let step = (dr / dd).max(-s.max_order_step).min(s.max_order_step);
    let mut t = T::one();
    for halvings in 0..=s.max_halvings {
        let trial = (alpha0 + t * step).max(s.alpha_min).min(s.alpha_max);
        if trial == alpha0 {
            break;
        }
        let cost = reg.trial_cost(trial, p)?;
        if cost.is_finite() && cost < cost0 {
            reg.accept_trial();
            return Ok(OrderStep::Accepted { halvings });
        }
        t = t / T::lit(2.0);
    }
    Ok(OrderStep::NoDecrease)
}
