//! How sure a state of power is: the spread of the parameters it is
//! predicted with ([`ParameterSpread`]) and what it does to the predicted
//! pulse (each parameter moved by its own, the shifts of the pulse's own
//! response in quadrature with the voltage's scatter;
//! [`PulsePredictor::power_with_spread`]). Owns the
//! spread and the shifts; the limits' roots that keep the derating are
//! the parent module's, and where a spread comes from is the estimator's
//! ([`crate::battery::online::CellState::sop_spread`]).

use super::{same_order, PowerReport, PowerSettings, PulsePredictor, ResponseMiss, MAX_HORIZONS};
use crate::battery::simulate::cpe_filter;
use crate::battery::CellParameters;
use crate::frac::{GlWeights, ROW_BLOCK};
use crate::real::Real;

/// How far the parameters a state of power is predicted with may be from
/// the cell's: one standard deviation of `ln R_i`, `ln R_ct`, `ln Q` and
/// of α (and of a held Butler–Volmer term's `ln a` and `ln i₀`), and the
/// voltage's own scatter about the model (V). A predicted
/// voltage's standard deviation is the model's answer to each parameter
/// moved by its own (one at a time, added in quadrature with the scatter:
/// the parameters' correlation is not known where the values came from
/// different places), and the pulse's own response moved by what the
/// last pulse showed the model to miss by ([`Self::response`]).
///
/// ```
/// use estimator_core::battery::power::{ParameterSpread, ResponseMiss};
/// let s = ParameterSpread {
///     r_i: 0.05, r_ct: 0.1, q: 0.1, alpha: 0.02, bv_a: 0.0, bv_i0: 0.0, noise_v: 1e-3,
///     response: ResponseMiss::NONE,
/// };
/// assert!(s.is_valid());
/// assert!(!ParameterSpread { noise_v: -1.0, ..s }.is_valid());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ParameterSpread<T> {
    /// Standard deviation of `ln R_i`.
    pub r_i: T,
    /// Standard deviation of `ln R_ct`.
    pub r_ct: T,
    /// Standard deviation of `ln Q`.
    pub q: T,
    /// Standard deviation of α.
    pub alpha: T,
    /// Standard deviation of the Butler–Volmer term's `ln a` when the
    /// term is held, not fitted by the window (a Butler–Volmer prior's
    /// under the linear model, [`crate::battery::CellModel::Linear`]); 0:
    /// not moved (no term, or the window's own fit of it).
    pub bv_a: T,
    /// Standard deviation of the held term's `ln i₀` (as [`Self::bv_a`]).
    pub bv_i0: T,
    /// The measured voltage's scatter about the model (V): the fit's RMSE.
    pub noise_v: T,
    /// The relative miss of the last pulse the cell's state of power was
    /// checked against ([`super::PulseCheck`]), per duration: the pulse's
    /// own response per ampere (`R_i` and the step response) at a horizon
    /// moves by that fraction of itself at one standard deviation.
    /// [`ResponseMiss::NONE`]: none.
    pub response: ResponseMiss<T>,
}

impl<T: Real> ParameterSpread<T> {
    /// Every parameter's spread and the scatter finite and not negative,
    /// and every miss of [`Self::response`] not negative or not known
    /// ([`ResponseMiss::is_valid`]).
    pub fn is_valid(&self) -> bool {
        [
            self.r_i,
            self.r_ct,
            self.q,
            self.alpha,
            self.bv_a,
            self.bv_i0,
            self.noise_v,
        ]
        .iter()
        .all(|x| x.is_finite() && *x >= T::zero())
            && self.response.is_valid()
    }
}

/// Per horizon, `B²`: the squared voltage shifts per ampere of `R_i`,
/// `R_ct`, `Q` and α each moved by its spread, summed.
pub(super) type Shifts<T> = [T; MAX_HORIZONS];

impl<'a, T: Real, const MEM: usize, const P: usize> PulsePredictor<'a, T, MEM, P> {
    /// [`power`](Self::power) with the parameters' `spread`: each
    /// horizon's pulse voltage carries its standard deviation
    /// ([`super::HorizonPower::uncertainty_v`]), and the limit currents keep the
    /// voltage [`PowerSettings::confidence`] standard deviations inside
    /// the limits at each horizon's end. A spread that is not valid
    /// ([`ParameterSpread::is_valid`]) is not used.
    ///
    /// ```
    /// use estimator_core::battery::power::{ParameterSpread, PowerLimits, PowerSettings, PulsePredictor};
    /// use estimator_core::battery::CellParameters;
    /// use estimator_core::frac::GlWeights;
    ///
    /// let p = CellParameters::<f64>::cell_18650();
    /// let w = GlWeights::<f64, 64>::new(p.alpha, 1.0, 64).unwrap();
    /// let cell = PulsePredictor::<f64, 64, 2>::new(&p, &w, &[0.0; 10], None).unwrap();
    /// let limits = PowerLimits { voltage_min: 3.0, voltage_max: 4.2, current_limit: 100.0 };
    /// let s = PowerSettings::new(limits, &[10], Some(-5.0)).unwrap();
    /// let spread = ParameterSpread {
    ///     r_i: 0.1, r_ct: 0.1, q: 0.1, alpha: 0.02, bv_a: 0.0, bv_i0: 0.0, noise_v: 1e-3,
    ///     response: estimator_core::battery::power::ResponseMiss::NONE,
    /// };
    /// let (plain, derated) = (cell.power(&s), cell.power_with_spread(&s, &spread));
    /// let h = derated.horizons()[0];
    /// assert!(h.uncertainty_v.unwrap() > 0.0);
    /// assert!(h.sop.discharge_a < plain.horizons()[0].sop.discharge_a);
    /// ```
    pub fn power_with_spread(
        &self,
        s: &PowerSettings<T>,
        spread: &ParameterSpread<T>,
    ) -> PowerReport<T> {
        let conf = if s.confidence.is_finite() && s.confidence > T::zero() {
            s.confidence
        } else {
            T::zero()
        };
        let spread = spread.is_valid().then_some((spread, conf));
        self.run(&s.limits, s.horizons(), s.pulse_current, spread)
    }

    /// The step response `G_k` (a unit current's polarization from
    /// rest) at each horizon's end (NaN past the horizons): up to `MEM`
    /// steps by the step's own block recursion alone, longer with
    /// [`Self::responses`].
    pub(super) fn step_ends(&self, horizons: &[u32], longest: usize) -> [T; MAX_HORIZONS] {
        let mut out = [T::nan(); MAX_HORIZONS];
        let mut at_end = |k: usize, g: T| {
            for (o, &h) in out.iter_mut().zip(horizons) {
                if h as usize == k {
                    *o = g;
                }
            }
        };
        let wts = self.w.weights();
        let m = wts.len().min(MEM);
        if longest <= MEM && m > 0 {
            let a = self.p.tau() * self.w.scale();
            let rows = longest.div_ceil(ROW_BLOCK) * ROW_BLOCK;
            let mut yb = [[T::zero(); MEM]; 2];
            let ys = yb.as_flattened_mut();
            let n = rows.min(ys.len());
            let (Some(y), Some(w)) = (ys.get_mut(..n), wts.get(..m)) else {
                return out;
            };
            let r_ct = self.p.r_ct;
            cpe_filter(w, a, 0, y, |_| r_ct, |_, _, _| {});
            for (k, &g) in y.iter().take(longest).enumerate() {
                at_end(k + 1, g);
            }
        } else {
            self.responses(longest, |k, _, g| at_end(k, g));
        }
        out
    }

    /// Each horizon's `B²`: the sum over `R_i`, `R_ct`, `Q` and α, each
    /// moved by its spread alone, of the squared shift of the pulse's own
    /// response per ampere (the static drop's and the step response's),
    /// from `base`, the step response at each horizon's end
    /// ([`Self::step_ends`]), and of that response times the last
    /// pulse's relative miss at the horizon ([`ParameterSpread::response`]). A current `I` then moves the voltage by
    /// `|I|·B` at one standard deviation. The polarization the cell
    /// already carries is taken as known (its decay is not moved). `None`
    /// when a moved model cannot be predicted with.
    pub(super) fn shifts(
        &self,
        horizons: &[u32],
        longest: usize,
        spread: &ParameterSpread<T>,
        base: &[T; MAX_HORIZONS],
    ) -> Option<Shifts<T>> {
        let p = self.p;
        // `R_i`: the static drop only (a held kinetic term is moved apart,
        // at the current itself: `kinetic_shift`).
        let dri = p.r_i * (spread.r_i.exp() - T::one());
        let mut out = [dri * dri; MAX_HORIZONS];
        // α moved up, or down where up leaves the model's range.
        let up = CellParameters {
            alpha: p.alpha + spread.alpha,
            ..p
        };
        let alpha = if up.is_physical() {
            up.alpha
        } else {
            p.alpha - spread.alpha
        };
        let moved = [
            (
                spread.r_ct,
                CellParameters {
                    r_ct: p.r_ct * spread.r_ct.exp(),
                    ..p
                },
            ),
            (
                spread.q,
                CellParameters {
                    q: p.q * spread.q.exp(),
                    ..p
                },
            ),
            (spread.alpha, CellParameters { alpha, ..p }),
        ];
        for (by, m) in moved.iter() {
            if *by == T::zero() {
                continue;
            }
            let w = if m.alpha == p.alpha {
                self.w.clone()
            } else {
                GlWeights::new(m.alpha, self.w.h(), self.w.len()).ok()?
            };
            if !(m.is_physical() && same_order(&w, m)) {
                return None;
            }
            let other = Self {
                p: *m,
                w,
                past: self.past,
                ocv: self.ocv,
            };
            let e = other.step_ends(horizons, longest);
            for (o, (x, b)) in out.iter_mut().zip(e.iter().zip(base)) {
                let d = *x - *b;
                *o = *o + d * d;
            }
        }
        // What the last pulse showed the model to miss by: the pulse's own
        // response per ampere moved by that fraction of itself.
        for ((o, &h), b) in out.iter_mut().zip(horizons).zip(base) {
            let r = spread.response.at(h);
            if r > T::zero() && b.is_finite() {
                let own = (p.r_i + *b).abs() * r;
                *o = *o + own * own;
            }
        }
        Some(out)
    }
}

/// A horizon's pulse voltage's standard deviation at current `i`:
/// `√(σ_v² + I²·B² + K²)` with the horizon's `B²`
/// ([`PulsePredictor::shifts`]) and `K` a held Butler–Volmer term's shift
/// at `i` ([`kinetic_shift`]; 0 without one).
pub(super) fn sigma_at<T: Real>(b2: T, noise_v: T, i: T, k: T) -> T {
    (noise_v * noise_v + i * i * b2 + k * k).sqrt()
}

/// Whether `spread` moves `p`'s Butler–Volmer term: `p` has one and
/// [`ParameterSpread::bv_a`] or [`ParameterSpread::bv_i0`] is not 0.
pub(super) fn moves_kinetic<T: Real>(p: &CellParameters<T>, spread: &ParameterSpread<T>) -> bool {
    p.is_butler_volmer() && (spread.bv_a != T::zero() || spread.bv_i0 != T::zero())
}

/// The held Butler–Volmer term's shift (V) at current `i`: `a·asinh(I/i₀)`
/// with `ln a` moved up by [`ParameterSpread::bv_a`] and, apart, `ln i₀`
/// down by [`ParameterSpread::bv_i0`] (each the way that deepens the
/// drop, as the resistances are moved), the two shifts in quadrature (their
/// correlation is not known: the term came from another record). The
/// term's overpotential is not linear in the current, so it is not in the
/// per-ampere `B²`.
pub(super) fn kinetic_shift<T: Real>(
    p: &CellParameters<T>,
    spread: &ParameterSpread<T>,
    i: T,
) -> T {
    let eta = p.kinetic_voltage(i);
    let by_a = eta * (spread.bv_a.exp() - T::one());
    let moved = CellParameters {
        bv_i0: p.bv_i0 * (-spread.bv_i0).exp(),
        ..*p
    };
    let by_i0 = moved.kinetic_voltage(i) - eta;
    (by_a * by_a + by_i0 * by_i0).sqrt()
}
