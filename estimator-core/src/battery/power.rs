//! State of power: from a cell's model and the polarization it carries
//! now, the terminal voltage of a constant-current pulse of a given length
//! ([`PulsePredictor::pulse_voltage`]), and the largest constant currents
//! that keep it within the voltage limits for that long
//! ([`PulsePredictor::state_of_power`], [`StateOfPower`]).
//!
//! The prediction runs the model's own constant-phase recursion forward
//! from the present: the polarization's free response (its history, with
//! the short memory the estimator fits with) plus the response to the
//! pulse's current, the static drop `R_i·I` (and the Butler–Volmer term),
//! and, with an OCV curve, the open-circuit voltage at the charge the
//! pulse moves. Sign convention: current positive when charging; a
//! discharge current limit is returned as a positive magnitude.
//!
//! This module owns that prediction; it must not touch the estimators'
//! state (the caller gives the model, the history and the weights at the
//! model's order).

use super::ocv::OcvModel;
use super::CellParameters;
use crate::frac::GlWeights;
use crate::real::Real;

/// The voltage and current limits the state of power keeps to.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PowerLimits<T> {
    /// The lowest terminal voltage allowed (V).
    pub voltage_min: T,
    /// The highest terminal voltage allowed (V).
    pub voltage_max: T,
    /// The largest current magnitude allowed (A), either way.
    pub current_limit: T,
}

/// The largest constant currents for one horizon.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StateOfPower<T> {
    /// The horizon (samples of the model's period).
    pub steps: usize,
    /// The largest discharge current magnitude (A) whose predicted
    /// voltage stays at or above `voltage_min` for the whole horizon,
    /// capped by `current_limit` (0 when even a rest would cross it).
    pub discharge_a: T,
    /// The same for charge and `voltage_max`.
    pub charge_a: T,
}

/// A cell's model and its present polarization, ready to predict pulses.
///
/// ```
/// use estimator_core::battery::power::{PowerLimits, PulsePredictor};
/// use estimator_core::battery::CellParameters;
/// use estimator_core::frac::GlWeights;
///
/// let p = CellParameters::<f64>::cell_18650();
/// let w = GlWeights::<f64, 64>::new(p.alpha, 1.0, 64).unwrap();
/// // At rest: no polarization.
/// // Without an OCV curve (its table size is then any).
/// let cell = PulsePredictor::<f64, 64, 2>::new(&p, &w, &[0.0; 10], None).unwrap();
/// let limits = PowerLimits { voltage_min: 3.0, voltage_max: 4.2, current_limit: 20.0 };
/// let sop = cell.state_of_power(&limits, 10);
/// // The pulse at the limit current ends on the limit voltage.
/// let v = cell.pulse_voltage(-sop.discharge_a, 10);
/// assert!((v - 3.0).abs() < 1e-6 || sop.discharge_a == 20.0);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct PulsePredictor<'a, T, const MEM: usize, const P: usize> {
    p: CellParameters<T>,
    w: &'a GlWeights<T, MEM>,
    /// The polarization now and before: `past[j]` is `j` samples ago (the
    /// first `M` count).
    past: [T; MEM],
    ocv: Option<(&'a OcvModel<T, P>, T)>,
}

/// Bisection steps of a limit current: its precision is `2⁻⁴⁰` of the
/// current limit.
const BISECTIONS: usize = 40;

impl<'a, T: Real, const MEM: usize, const P: usize> PulsePredictor<'a, T, MEM, P> {
    /// The cell `p` (its `u_oc`: the OCV offset `ΔU` with a curve, the
    /// open-circuit voltage without) with weights `w` at `p`'s order and
    /// the model's period, its polarization `history` (oldest first, the
    /// last is now; only the last `M − 1` count) and, with a curve, the
    /// curve and the state of charge now. `None` for a model that is not
    /// physical or weights at another order.
    pub fn new(
        p: &CellParameters<T>,
        w: &'a GlWeights<T, MEM>,
        history: &'a [T],
        ocv: Option<(&'a OcvModel<T, P>, T)>,
    ) -> Option<Self> {
        let same_order = (w.alpha() - p.alpha).abs() <= T::lit(1e-9) * p.alpha.abs().max(T::one());
        if !(p.is_physical() && same_order && history.iter().all(|x| x.is_finite())) {
            return None;
        }
        let mut past = [T::zero(); MEM];
        for (x, &h) in past.iter_mut().zip(history.iter().rev()) {
            *x = h;
        }
        Some(Self {
            p: *p,
            w,
            past,
            ocv,
        })
    }

    /// Carries the polarization one sample forward through a sample of
    /// `current` (A) that happened (the charge it moved is the caller's
    /// state of charge, already counted).
    pub fn advance(&mut self, current: T) {
        let wts = self.w.weights();
        let m = wts.len().min(MEM);
        let a = self.p.tau() * self.w.scale();
        let h = wts[1..m]
            .iter()
            .zip(&self.past)
            .fold(T::zero(), |s, (&w, &x)| s + w * x);
        let x = (self.p.r_ct * current - a * h) / (T::one() + a);
        for j in (1..MEM).rev() {
            self.past[j] = self.past[j - 1];
        }
        self.past[0] = x;
    }

    /// Runs the recursion `steps` samples forward and calls `seen(k, F_k,
    /// G_k)` for `k = 1…steps`: `F_k` the polarization's free response
    /// from the history, `G_k` its response to a unit current from rest,
    /// so that a constant current `I` gives `U_p = F_k + I·G_k`.
    fn responses(&self, steps: usize, mut seen: impl FnMut(usize, T, T)) {
        let wts = self.w.weights();
        let m = wts.len().min(MEM);
        let a = self.p.tau() * self.w.scale();
        // past[j]: the value j + 1 samples before the one computed next.
        let mut free = self.past;
        let mut step = [T::zero(); MEM];
        for k in 1..=steps {
            let mut hf = T::zero();
            let mut hg = T::zero();
            for j in 1..m {
                hf = hf + wts[j] * free[j - 1];
                hg = hg + wts[j] * step[j - 1];
            }
            let f = (-(a * hf)) / (T::one() + a);
            let g = (self.p.r_ct - a * hg) / (T::one() + a);
            for j in (1..m).rev() {
                free[j] = free[j - 1];
                step[j] = step[j - 1];
            }
            if m > 0 {
                free[0] = f;
                step[0] = g;
            }
            seen(k, f, g);
        }
    }

    /// The open-circuit voltage after `charge` (A·s, + charging) from now.
    fn open_circuit(&self, charge: T) -> T {
        match self.ocv {
            Some((m, soc)) => {
                let z = soc + charge / (T::lit(3600.0) * m.capacity_ah);
                m.table.ocv(z) + self.p.u_oc
            }
            None => self.p.u_oc,
        }
    }

    /// The terminal voltage after `k` samples of `current` from now, given
    /// the free and step responses there.
    fn voltage(&self, current: T, k: usize, f: T, g: T) -> T {
        let charge = current * T::lit(k as f64) * self.w.h();
        self.open_circuit(charge) + self.p.static_voltage(current) + f + current * g
    }

    /// The predicted terminal voltage at the end of a constant `current`
    /// (A, + charging) held for `steps` samples from now (the present
    /// voltage's model value for `steps = 0`, at no current).
    pub fn pulse_voltage(&self, current: T, steps: usize) -> T {
        let mut v = self.voltage(T::zero(), 0, self.past[0], T::zero());
        self.responses(steps, |k, f, g| {
            if k == steps {
                v = self.voltage(current, k, f, g);
            }
        });
        v
    }

    /// The largest constant discharge and charge currents that keep the
    /// predicted voltage within `limits` at every sample of a horizon of
    /// `steps` samples. Each sample's voltage falls (rises) monotonically
    /// with the discharge (charge) current, so each sample's bound is found
    /// by bisection to `2⁻⁴⁰` of the current limit, and the horizon's is
    /// the least.
    pub fn state_of_power(&self, limits: &PowerLimits<T>, steps: usize) -> StateOfPower<T> {
        let cap = limits.current_limit;
        let mut out = StateOfPower {
            steps,
            discharge_a: cap,
            charge_a: cap,
        };
        self.responses(steps, |k, f, g| {
            // The largest x in [0, bound] with ok(x), ok monotone.
            let largest = |bound: T, ok: &dyn Fn(T) -> bool| {
                if ok(bound) {
                    return bound;
                }
                if !ok(T::zero()) {
                    return T::zero();
                }
                let (mut lo, mut hi) = (T::zero(), bound);
                for _ in 0..BISECTIONS {
                    let mid = (lo + hi) / T::lit(2.0);
                    if ok(mid) {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                lo
            };
            let d = largest(out.discharge_a, &|x: T| {
                self.voltage(-x, k, f, g) >= limits.voltage_min
            });
            let c = largest(out.charge_a, &|x: T| {
                self.voltage(x, k, f, g) <= limits.voltage_max
            });
            out.discharge_a = d;
            out.charge_a = c;
        });
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::battery::ocv::OcvTable;
    use crate::battery::profile::{ocv_nmc, Profile};
    use crate::battery::simulate::simulate;

    const N: usize = 400;

    fn table() -> OcvModel<f64, 101> {
        let soc: [f64; 101] = core::array::from_fn(|k| k as f64 / 100.0);
        let ocv: [f64; 101] = core::array::from_fn(|k| ocv_nmc(soc[k]));
        OcvModel::new(OcvTable::new(&soc, &ocv).unwrap(), 2.5).unwrap()
    }

    /// A pulse record to sample `at`, then a constant `i` for `k`
    /// samples, simulated whole (memory 64, as the predictor): the
    /// voltage after the pulse, and the polarization history at `at`.
    fn truth(p: &CellParameters<f64>, at: usize, i: f64, k: usize, ocv: bool) -> (f64, [f64; N]) {
        let mut current = [0.0; N];
        for (l, c) in current.iter_mut().enumerate() {
            *c = if l < at {
                Profile::Pulse.current(l as f64, 4.0)
            } else {
                i
            };
        }
        let m = table();
        let mut soc = [0.0; N];
        let mut z = 0.7;
        for l in 0..N {
            z += current[l] / (3600.0 * m.capacity_ah);
            soc[l] = z;
        }
        let mut w = GlWeights::<f64, 64>::new(p.alpha, 1.0, 64).unwrap();
        let (mut up, mut v) = ([0.0; N], [0.0; N]);
        let u = |l: usize| if ocv { m.table.ocv(soc[l]) } else { p.u_oc };
        simulate(p, &mut w, &current, u, &mut up, &mut v).unwrap();
        (v[at + k - 1], up)
    }

    /// The prediction is the simulator's continuation, to rounding: with
    /// and without an OCV curve, linear and with the Butler–Volmer term.
    #[test]
    fn a_predicted_pulse_is_the_models_continuation() {
        let m = table();
        for bv in [false, true] {
            let mut p = CellParameters::<f64>::cell_18650();
            if bv {
                p = p.with_butler_volmer(2.0);
            }
            let w = GlWeights::<f64, 64>::new(p.alpha, 1.0, 64).unwrap();
            for ocv in [false, true] {
                let (at, i, k) = (200, -5.0, 30);
                let (want, up) = truth(&p, at, i, k, ocv);
                // SOC at `at − 1` (after its sample), as the estimator counts.
                let soc = 0.7
                    + (0..at)
                        .map(|l| Profile::Pulse.current(l as f64, 4.0))
                        .sum::<f64>()
                        / (3600.0 * 2.5);
                let q = CellParameters {
                    u_oc: if ocv { 0.0 } else { p.u_oc },
                    ..p
                };
                let pred =
                    PulsePredictor::new(&q, &w, &up[..at], ocv.then_some((&m, soc))).unwrap();
                let got = pred.pulse_voltage(i, k);
                assert!(
                    (got - want).abs() < 1e-9,
                    "bv {bv} ocv {ocv}: {got} vs {want}"
                );
            }
        }
    }

    /// Carried forward through the samples since, an older state predicts
    /// what the present one does.
    #[test]
    fn an_older_state_carried_forward_is_the_present_one() {
        let p = CellParameters::<f64>::cell_18650();
        let w = GlWeights::<f64, 64>::new(p.alpha, 1.0, 64).unwrap();
        let (_, up) = truth(&p, 250, 0.0, 1, false);
        let now = PulsePredictor::<f64, 64, 101>::new(&p, &w, &up[..250], None).unwrap();
        let mut old = PulsePredictor::<f64, 64, 101>::new(&p, &w, &up[..230], None).unwrap();
        for l in 230..250 {
            old.advance(Profile::Pulse.current(l as f64, 4.0));
        }
        for k in [1, 10, 30] {
            let (a, b) = (old.pulse_voltage(-3.0, k), now.pulse_voltage(-3.0, k));
            assert!((a - b).abs() < 1e-12, "{k}: {a} vs {b}");
        }
    }

    /// The state of power is consistent: its pulse reaches the limit within
    /// 1 % of the pulse's drop (here to 1e−9 V), and the limit current is
    /// capped where the voltage allows more.
    #[test]
    fn the_limit_currents_reach_the_limits() {
        let m = table();
        let p = CellParameters::<f64>::cell_18650();
        let w = GlWeights::<f64, 64>::new(p.alpha, 1.0, 64).unwrap();
        let (_, up) = truth(&p, 200, 0.0, 1, true);
        let soc = 0.7;
        let q = CellParameters { u_oc: 0.0, ..p };
        let pred = PulsePredictor::new(&q, &w, &up[..200], Some((&m, soc))).unwrap();
        let rest = pred.pulse_voltage(0.0, 0);
        let limits = PowerLimits {
            voltage_min: rest - 0.3,
            voltage_max: rest + 0.2,
            current_limit: 100.0,
        };
        for steps in [2, 10, 30] {
            let sop = pred.state_of_power(&limits, steps);
            assert!(sop.discharge_a > 0.0 && sop.discharge_a < 100.0, "{sop:?}");
            assert!(sop.charge_a > 0.0 && sop.charge_a < 100.0, "{sop:?}");
            // A discharge from rest falls monotonically: the end is the limit.
            let v = pred.pulse_voltage(-sop.discharge_a, steps);
            assert!((v - limits.voltage_min).abs() < 1e-9, "{steps}: {v}");
            let v = pred.pulse_voltage(sop.charge_a, steps);
            assert!((v - limits.voltage_max).abs() < 1e-9, "{steps}: {v}");
        }
        // Longer pulses allow less current.
        let (s2, s30) = (
            pred.state_of_power(&limits, 2),
            pred.state_of_power(&limits, 30),
        );
        assert!(s30.discharge_a < s2.discharge_a && s30.charge_a < s2.charge_a);
        // A generous window: capped by the current limit.
        let wide = PowerLimits {
            voltage_min: 0.0,
            voltage_max: 10.0,
            current_limit: 7.5,
        };
        let sop = pred.state_of_power(&wide, 10);
        assert_eq!((sop.discharge_a, sop.charge_a), (7.5, 7.5));
        // Already below the minimum: no discharge at all.
        let low = PowerLimits {
            voltage_min: rest + 0.01,
            ..limits
        };
        assert_eq!(pred.state_of_power(&low, 10).discharge_a, 0.0);
    }
}
