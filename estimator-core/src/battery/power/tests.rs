//! Unit tests of the state of power: the prediction against the
//! simulator, the roots against a bisection, one pass against each
//! horizon alone.

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

/// The 18650 cell, linear or with a Butler–Volmer term, and its weights
/// (memory 64, 1 s).
fn cell(bv: bool) -> (CellParameters<f64>, GlWeights<f64, 64>) {
    let mut p = CellParameters::<f64>::cell_18650();
    if bv {
        p = p.with_butler_volmer(2.0);
    }
    let w = GlWeights::<f64, 64>::new(p.alpha, 1.0, 64).unwrap();
    (p, w)
}

/// The prediction is the simulator's continuation, to rounding: with
/// and without an OCV curve, linear and with the Butler–Volmer term.
#[test]
fn a_predicted_pulse_is_the_models_continuation() {
    let m = table();
    for bv in [false, true] {
        let (p, w) = cell(bv);
        // 150 samples: longer than the memory (the recursion's chunks).
        for (ocv, k) in [(false, 30), (true, 30), (true, 150)] {
            let (at, i) = (200, -5.0);
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
            let pred = PulsePredictor::new(&q, &w, &up[..at], ocv.then_some((&m, soc))).unwrap();
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

/// The largest `x` in `[0, bound]` that `passes` (monotone), by 200
/// bisections: the reference of the roots.
fn bisect(bound: f64, passes: impl Fn(f64) -> bool) -> f64 {
    let (mut lo, mut hi) = (0.0, bound);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if passes(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// One pass answers every horizon as each alone does (to the roots'
/// precision, `1e−7` A here), and each answer is the largest safe
/// current, within a horizon of the memory and beyond it: a bisection of 200 steps (a reference
/// independent of the regula falsi) agrees to `1e−9` of the limit, and
/// the answer itself is never past the limit.
#[test]
fn one_pass_answers_every_horizon_as_each_alone() {
    let m = table();
    for bv in [false, true] {
        let (p, w) = cell(bv);
        let (_, up) = truth(&p, 200, 0.0, 1, true);
        let q = CellParameters { u_oc: 0.0, ..p };
        let pred = PulsePredictor::new(&q, &w, &up[..200], Some((&m, 0.7))).unwrap();
        let rest = pred.pulse_voltage(0.0, 0);
        let limits = PowerLimits {
            voltage_min: rest - 0.3,
            voltage_max: rest + 0.2,
            current_limit: 100.0,
        };
        // 100 samples: longer than the memory, sample by sample.
        let ps = PowerSettings::new(limits, &[30, 2, 10, 30], Some(-4.0)).unwrap();
        let long = pred.power(&PowerSettings::new(limits, &[100], None).unwrap());
        let long = (100, long.horizons()[0]);
        let r = pred.power(&ps);
        let each = r
            .horizons()
            .iter()
            .zip(ps.horizons())
            .map(|(h, &k)| (k as usize, *h));
        for (k, h) in each.chain([long]) {
            if k <= 64 {
                // Alone, the root is solved from another bracket: the
                // same within the roots' precision.
                let alone = pred.state_of_power(&limits, k);
                assert_eq!(alone.steps, k);
                assert!((h.sop.discharge_a - alone.discharge_a).abs() <= 1e-7);
                assert!((h.sop.charge_a - alone.charge_a).abs() <= 1e-7);
                assert_eq!(h.pulse_v, Some(pred.pulse_voltage(-4.0, k)));
            }
            // Reference: bisection on "every sample within the limit".
            let passes = |x: f64| (1..=k).all(|j| pred.pulse_voltage(-x, j) >= limits.voltage_min);
            let lo = bisect(100.0, passes);
            assert!(
                (h.sop.discharge_a - lo).abs() <= 1e-7,
                "bv {bv} {k}: {h:?} vs {lo}"
            );
            assert!(passes(h.sop.discharge_a), "bv {bv} {k}");
            let passes = |x: f64| (1..=k).all(|j| pred.pulse_voltage(x, j) <= limits.voltage_max);
            let lo = bisect(100.0, passes);
            assert!(
                (h.sop.charge_a - lo).abs() <= 1e-7,
                "bv {bv} {k}: {h:?} vs {lo}"
            );
            assert!(passes(h.sop.charge_a), "bv {bv} {k}");
        }
    }
}

/// A sample before the horizon's end can be the one that binds: a cell
/// relaxing from a deep discharge polarization has its lowest voltage
/// under a small current at the pulse's first sample, not its last.
/// Every sample is checked (the end's answer alone would cross the limit
/// there), linear and with the Butler–Volmer term, and the answer is the
/// bisection's on "every sample within the limits".
#[test]
fn a_sample_before_the_end_can_bind() {
    let m = table();
    for bv in [false, true] {
        let (p, w) = cell(bv);
        let q = CellParameters { u_oc: 0.0, ..p };
        // 120 mV of discharge polarization (−100 mV for charge), relaxing.
        for (history, margin) in [(-0.12f64, -0.004f64), (0.10, 0.004)] {
            let pred = PulsePredictor::new(&q, &w, &[history; 100], Some((&m, 0.5))).unwrap();
            let first = pred.pulse_voltage(0.0, 1);
            // 4 mV from the first sample's voltage at rest on the side
            // that binds, a volt on the other.
            let limits = PowerLimits {
                voltage_min: first + if margin < 0.0 { margin } else { -1.0 },
                voltage_max: first + if margin > 0.0 { margin } else { 1.0 },
                current_limit: 100.0,
            };
            let k = 30;
            let sop = pred.state_of_power(&limits, k);
            // Discharge (a current drawn, the lower limit) or charge.
            let discharge = margin < 0.0;
            let x = if discharge {
                sop.discharge_a
            } else {
                sop.charge_a
            };
            let within = |x: f64, j: usize| {
                let v = pred.pulse_voltage(if discharge { -x } else { x }, j);
                if discharge {
                    v >= limits.voltage_min
                } else {
                    v <= limits.voltage_max
                }
            };
            let at_end = |x: f64| within(x, k);
            let all = |x: f64| (1..=k).all(|j| within(x, j));
            let (end_only, every) = (bisect(100.0, at_end), bisect(100.0, all));
            assert!(
                end_only > 1.5 * every,
                "bv {bv} {history}: the end alone allows {end_only} A, every sample {every} A"
            );
            assert!(
                (x - every).abs() <= 1e-7,
                "bv {bv} {history}: {x} vs {every}"
            );
            assert!(all(x), "bv {bv} {history}: {x} crosses");
        }
    }
}

/// The responses' rows are the same to the bit at every length asked (a
/// pulse's prediction does not depend on what else is asked with it):
/// every row is summed by the block recursion alike, up to the memory.
#[test]
fn the_responses_do_not_depend_on_the_length_asked() {
    for alpha in [0.55, 0.85] {
        let p = CellParameters::<f64> {
            alpha,
            ..CellParameters::cell_18650()
        };
        let w = GlWeights::<f64, 64>::new(p.alpha, 1.0, 64).unwrap();
        let (_, up) = truth(&p, 200, 0.0, 1, true);
        let pred = PulsePredictor::<f64, 64, 2>::new(&p, &w, &up[..200], None).unwrap();
        let mut all = vec![];
        pred.responses(64, |_, f, g| all.push((f.to_bits(), g.to_bits())));
        assert_eq!(all.len(), 64);
        for steps in 1..64 {
            let mut some = vec![];
            pred.responses(steps, |k, f, g| {
                assert_eq!(k, some.len() + 1);
                some.push((f.to_bits(), g.to_bits()));
            });
            assert_eq!(some[..], all[..steps], "alpha {alpha}, {steps} steps");
        }
    }
}

/// A pulse voltage's standard deviation is each parameter's shift of the
/// pulse's own response (the model with that parameter moved by its
/// spread; the polarization already carried is not moved), added in
/// quadrature with the scatter; the derated currents keep the voltage
/// `confidence` standard deviations inside the limits at the horizon's
/// end, and 0 derates nothing. Short (block) and long (chunked)
/// horizons alike; linear, and with a Butler–Volmer term whose `ln a` and
/// `ln i₀` are moved by their own spreads (the term's shift at the current
/// itself; a linear cell has no term to move).
#[test]
fn the_derated_limits_keep_the_pulse_voltages_spread_inside() {
    for bv in [false, true] {
        derated_limits_keep_the_spread_inside(bv);
    }
}

fn derated_limits_keep_the_spread_inside(bv: bool) {
    let m = table();
    let (p, w) = cell(bv);
    let (_, up) = truth(&p, 150, 0.0, 1, true);
    let p = CellParameters { u_oc: 0.0, ..p };
    let limits = PowerLimits {
        voltage_min: 3.4,
        voltage_max: 4.1,
        current_limit: 200.0,
    };
    let spread = ParameterSpread::<f64> {
        r_i: 0.1,
        r_ct: 0.2,
        q: 0.15,
        alpha: 0.03,
        bv_a: 0.2,
        bv_i0: 0.3,
        noise_v: 2e-3,
        response: ResponseMiss::NONE,
    };
    for horizon in [10u32, 100] {
        let base =
            PulsePredictor::<f64, 64, 101>::new(&p, &w, &up[..150], Some((&m, 0.7))).unwrap();
        let pulse = -5.0;
        let mut s = PowerSettings::new(limits, &[horizon], Some(pulse)).unwrap();
        let k = horizon as usize;
        // Each parameter moved alone, as the predictor moves it.
        let moved = [
            CellParameters {
                r_i: p.r_i * spread.r_i.exp(),
                ..p
            },
            CellParameters {
                r_ct: p.r_ct * spread.r_ct.exp(),
                ..p
            },
            CellParameters {
                q: p.q * spread.q.exp(),
                ..p
            },
            CellParameters {
                alpha: p.alpha + spread.alpha,
                ..p
            },
            CellParameters {
                bv_a: p.bv_a * spread.bv_a.exp(),
                ..p
            },
            CellParameters {
                bv_i0: p.bv_i0 * (-spread.bv_i0).exp(),
                ..p
            },
        ];
        // The pulse's own response (the voltage at `i` less at rest),
        // moved: the polarization already carried is not.
        let own = |c: &PulsePredictor<f64, 64, 101>, i: f64| {
            c.pulse_voltage(i, k) - c.pulse_voltage(0.0, k)
        };
        let sigma_at = |i: f64| {
            let v0 = own(&base, i);
            let mut var = spread.noise_v * spread.noise_v;
            for q in &moved {
                let wq = GlWeights::<f64, 64>::new(q.alpha, 1.0, 64).unwrap();
                let other =
                    PulsePredictor::<f64, 64, 101>::new(q, &wq, &up[..150], Some((&m, 0.7)))
                        .unwrap();
                var += (own(&other, i) - v0).powi(2);
            }
            var.sqrt()
        };
        let plain = base.power(&s).horizons()[0];
        let r = base.power_with_spread(&s, &spread).horizons()[0];
        let sd = r.uncertainty_v.unwrap();
        assert!(
            (sd - sigma_at(pulse)).abs() < 1e-9,
            "{sd} {}",
            sigma_at(pulse)
        );
        assert!(sd > spread.noise_v);
        // At 2 σ (the default): the discharge current ends on the
        // limit less two of its own standard deviations.
        let d = r.sop.discharge_a;
        assert!(d < plain.sop.discharge_a, "{d} {}", plain.sop.discharge_a);
        let end = base.pulse_voltage(-d, k) - 2.0 * sigma_at(-d);
        assert!(
            end >= limits.voltage_min - 1e-9 && end < limits.voltage_min + 1e-6,
            "{end}"
        );
        let c = r.sop.charge_a;
        let top = base.pulse_voltage(c, k) + 2.0 * sigma_at(c);
        assert!(c < plain.sop.charge_a, "{c} {} {top}", plain.sop.charge_a);
        assert!(
            top <= limits.voltage_max + 1e-9 && top > limits.voltage_max - 1e-6,
            "{top}"
        );
        // The last pulse's miss moves the linear response per ampere (R_i
        // and the step response); a term's share is not in it.
        if !bv {
            // The pulse's own response (its static drop
            // and step response, not the open-circuit voltage's part) moved by
            // that fraction of itself, in quadrature.
            let missed = ParameterSpread {
                response: ResponseMiss { miss: [0.3; 5] },
                ..spread
            };
            let no_ocv = PulsePredictor::<f64, 64, 101>::new(&p, &w, &up[..150], None).unwrap();
            let own_response =
                (no_ocv.pulse_voltage(pulse, k) - no_ocv.pulse_voltage(0.0, k)).abs();
            let wide = base.power_with_spread(&s, &missed).horizons()[0];
            let expect = (sd * sd + (0.3 * own_response).powi(2)).sqrt();
            assert!(
                (wide.uncertainty_v.unwrap() - expect).abs() < 1e-9,
                "{:?} {expect}",
                wide.uncertainty_v
            );
            assert!(wide.sop.discharge_a < d, "derated further");
        }
        // A miss that is not a fraction is not a spread.
        let bad = ParameterSpread {
            response: ResponseMiss { miss: [-0.1; 5] },
            ..spread
        };
        assert!(!bad.is_valid());
        // Zero confidence: the plain limits, the spread still reported.
        s.confidence = 0.0;
        let z = base.power_with_spread(&s, &spread).horizons()[0];
        assert_eq!(z.sop, plain.sop);
        assert_eq!(z.uncertainty_v, r.uncertainty_v);
        // A spread that is not valid is not used.
        let bad = ParameterSpread {
            r_i: f64::NAN,
            ..spread
        };
        assert_eq!(
            base.power_with_spread(&s, &bad).horizons()[0].uncertainty_v,
            None
        );
    }
}
