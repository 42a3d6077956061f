//! The state of power from the online estimator's model (issue 36, core):
//! a constant-current pulse predicted from the cell's present state
//! against the simulated truth of that pulse, and the limit currents
//! against the limits.

mod common;
use common::{nmc, noisy, truth_voltage};

use estimator_core::battery::online::{CellEstimator, OnlineSettings, Status};
use estimator_core::battery::pack::{PackEstimator, PackSettings};
use estimator_core::battery::power::{
    ParameterSpread, PowerLimits, PowerSettings, PulsePredictor, ResponseMiss, SopBasis,
};
use estimator_core::battery::profile::Profile;
use estimator_core::battery::{CellModel, CellParameters, Prior, Start};
use estimator_core::frac::GlWeights;

/// The `cell` preset through the NMC curve from SOC 0.9 (60 s rest, then
/// the pulse profile on a 1 A mean discharge) for `at` samples, then a
/// constant `pulse` (A) for `k` samples; full-memory simulation, σ = 1 mV
/// on the samples the estimator sees. Returns current, voltage (noisy
/// before `at`, exact after).
fn record(at: usize, pulse: f64, k: usize) -> (Vec<f64>, Vec<f64>) {
    let len = at + k;
    let i: Vec<f64> = (0..len)
        .map(|l| match l {
            l if l < 60 => 0.0,
            l if l < at => Profile::Pulse.current((l - 60) as f64, 5.0) - 1.0,
            _ => pulse,
        })
        .collect();
    let v = noisy(truth_voltage(&CellParameters::cell_18650(), &i), at);
    (i, v)
}

/// Own model, no prior, window 256, memory 64: at several instants of the
/// record, a 5 A discharge pulse of 10 and 30 s predicted from the state
/// then (the estimator's model and its polarization, the OCV curve at the
/// counted SOC) ends within 10 % of the pulse's true voltage drop of its
/// true voltage (measured: 0.04–0.47 %; the rest is the short memory and
/// the fit).
#[test]
fn a_predicted_pulse_ends_where_the_true_one_does() {
    let truth = CellParameters::<f64>::cell_18650();
    let s = OnlineSettings::new(1.0, 64, truth).with_ocv(nmc());
    let mut worst: f64 = 0.0;
    for at in [700, 1100, 1500] {
        for k in [10, 30] {
            let (i, v) = record(at, -5.0, k);
            let mut est = Box::new(CellEstimator::<f64, 256, 64>::new(&s).unwrap());
            for l in 0..at {
                est.push(&s, i[l], v[l]);
            }
            let pred = est
                .pulse_predictor(&s)
                .expect("a model in step with its estimate");
            let got = pred.pulse_voltage(-5.0, k);
            let want = v[at + k - 1];
            let drop = (pred.pulse_voltage(0.0, 0) - want).abs();
            let rel = (got - want).abs() / drop;
            println!(
                "at {at}, {k} s: predicted {got:.5} V, true {want:.5} V, drop {drop:.4} V: {:.2} %",
                100.0 * rel
            );
            worst = worst.max(rel);
        }
    }
    assert!(worst <= 0.10, "{worst}");
}

/// The limit currents: the model's pulse at the discharge (charge) limit
/// ends on the minimum (maximum) voltage within 1 % of the pulse's drop,
/// and the true cell's pulse at that current within 10 % of it.
#[test]
fn the_state_of_power_reaches_the_limits() {
    let truth = CellParameters::<f64>::cell_18650();
    let s = OnlineSettings::new(1.0, 64, truth).with_ocv(nmc());
    let at = 1100;
    let (i, v) = record(at, 0.0, 1);
    let mut est = Box::new(CellEstimator::<f64, 256, 64>::new(&s).unwrap());
    for l in 0..at {
        est.push(&s, i[l], v[l]);
    }
    let pred = est.pulse_predictor(&s).unwrap();
    let now = pred.pulse_voltage(0.0, 0);
    let limits = PowerLimits {
        voltage_min: now - 0.25,
        voltage_max: now + 0.15,
        current_limit: 50.0,
    };
    for k in [10, 30] {
        let sop = pred.state_of_power(&limits, k);
        for (current, limit) in [
            (-sop.discharge_a, limits.voltage_min),
            (sop.charge_a, limits.voltage_max),
        ] {
            let model = pred.pulse_voltage(current, k);
            let drop = (now - limit).abs();
            assert!(
                (model - limit).abs() <= 0.01 * drop,
                "{k} s, {current} A: {model}"
            );
            let (ti, tv) = record(at, current, k);
            assert_eq!(ti[at], current);
            let real = tv[at + k - 1];
            println!(
                "{k} s at {current:.3} A: model {model:.5} V, true {real:.5} V, limit {limit:.5} V"
            );
            assert!(
                (real - limit).abs() <= 0.10 * drop,
                "{k} s, {current} A: {real} vs {limit}"
            );
        }
    }
}

/// The record of [`record`] with a rest of `rest` samples before the
/// pulse: the polarization relaxes through a rest longer than the window.
fn record_after_rest(at: usize, rest: usize, pulse: f64, k: usize) -> (Vec<f64>, Vec<f64>) {
    let (mut i, _) = record(at, 0.0, rest + k);
    for x in &mut i[at + rest..] {
        *x = pulse;
    }
    let v = noisy(truth_voltage(&CellParameters::cell_18650(), &i), at + rest);
    (i, v)
}

/// Through a rest the polarization is carried sample by sample while the
/// window still reaches back to the fit; after a rest longer than the
/// window (no fit in its last part: the window holds no excitation) the
/// state of power is not published, until the rest has lasted the SOC
/// observer's `rest_s` (600 s): the cell is then taken as relaxed and the
/// pulse is predicted from rest, at the rested voltage. Within the window
/// and from the long rest the 10 s and 30 s pulses are predicted within 2 %
/// of their true drop (0.50 %, 0.05 %, 0.27 %). They were 3.9 %, 3.6 % and
/// 11.05 % while the window was still fitted as the pulse left its fitted
/// rows: that last fit, of the relaxation alone, put 24.5 mΩ in R_ct
/// against the cell's 15 mΩ (docs/bms-states.md).
#[test]
fn a_pulse_is_predicted_through_a_rest_and_from_a_long_one() {
    let truth = CellParameters::<f64>::cell_18650();
    let s = OnlineSettings::new(1.0, 64, truth).with_ocv(nmc());
    let at = 1100;
    let limits = PowerLimits {
        voltage_min: 3.0,
        voltage_max: 4.2,
        current_limit: 50.0,
    };
    for (rest, k) in [(250, 10), (580, 10), (700, 10), (700, 30)] {
        let (i, v) = record_after_rest(at, rest, -5.0, k);
        let mut est = Box::new(CellEstimator::<f64, 256, 64>::new(&s).unwrap());
        let mut carried = 0;
        for l in 0..at + rest {
            est.push(&s, i[l], v[l]);
            if l >= at && est.pulse_predictor(&s).is_some() {
                carried += 1;
            }
        }
        let ps = PowerSettings::new(limits, &[k as u32], Some(-5.0)).unwrap();
        let report = est.state_of_power(&s, &ps);
        if rest == 580 {
            // Past the window, short of `rest_s`: nothing.
            assert!(report.is_none(), "{rest} s of rest");
            assert!(carried < rest, "{carried} of {rest}");
            continue;
        }
        let pred = est.pulse_predictor(&s).expect("carried, or from rest");
        let got = pred.pulse_voltage(-5.0, k);
        let want = v[at + rest + k - 1];
        let drop = (v[at + rest - 1] - want).abs();
        let rel = (got - want).abs() / drop;
        println!(
            "after {rest} s of rest ({carried} samples with a predictor), {k} s at -5 A: \
             predicted {got:.5} V, true {want:.5} V, drop {drop:.4} V: {:.2} %",
            100.0 * rel
        );
        if rest > 256 {
            // From rest: the predictor's voltage now is the rested voltage
            // (the mean of about the rest's last half minute: the 1 mV
            // noise averaged to about 0.13 mV), against the cell's true
            // voltage now.
            let now = pred.pulse_voltage(0.0, 0);
            let clean = truth_voltage(&truth, &i)[at + rest - 1];
            assert!((now - clean).abs() < 1e-3, "{now} vs {clean}");
            // Published from `rest_s` on, not through the whole rest.
            assert!(carried < rest && carried > 0, "{carried} of {rest}");
        } else {
            assert_eq!(carried, rest);
        }
        assert!(rel <= 0.02, "{rest}, {k}: {rel}");
        assert_eq!(report.unwrap().horizons()[0].pulse_v, Some(got));
    }
}

/// The same with the Butler–Volmer term: after 700 s of rest its pulse is
/// predicted from rest too, and its state-of-power currents stay capped at
/// the largest current of the window the estimate was fitted on, which the
/// rest has emptied (the term is not extrapolated; docs/bms-states.md).
#[test]
fn a_butler_volmer_pulse_is_predicted_from_a_long_rest_within_the_currents_it_saw() {
    let truth = CellParameters::<f64>::cell_18650().with_butler_volmer(2.0);
    let mut s = OnlineSettings::new(1.0, 64, truth).with_ocv(nmc());
    s.battery.model = CellModel::ButlerVolmer;
    let (at, rest, k) = (1100, 700, 10);
    let (mut i, _) = record(at, 0.0, rest + k);
    for x in &mut i[at + rest..] {
        *x = -5.0;
    }
    let v = noisy(truth_voltage(&truth, &i), at + rest);
    let mut est = Box::new(CellEstimator::<f64, 256, 64>::new(&s).unwrap());
    for l in 0..at + rest {
        est.push(&s, i[l], v[l]);
    }
    let p = est.estimate().expect("an estimate");
    assert!(p.is_butler_volmer(), "{p:?}");
    let limits = PowerLimits {
        voltage_min: 3.0,
        voltage_max: 4.2,
        current_limit: 50.0,
    };
    let ps = PowerSettings::new(limits, &[k as u32], Some(-5.0)).unwrap();
    let report = est.state_of_power(&s, &ps).expect("from rest");
    let h = report.horizons()[0];
    // The pulse profile's largest current before the rest.
    let seen = i[..at].iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let got = h.pulse_v.unwrap();
    let want = v[at + rest + k - 1];
    let drop = (v[at + rest - 1] - want).abs();
    let rel = (got - want).abs() / drop;
    println!(
        "Butler–Volmer, after {rest} s of rest, {k} s at -5 A: predicted {got:.5} V, true \
         {want:.5} V, drop {drop:.4} V: {:.2} %; state of power {:.3} A discharge, \
         {:.3} A charge, the window's largest current {seen:.3} A",
        100.0 * rel,
        h.sop.discharge_a,
        h.sop.charge_a
    );
    assert!(rel <= 0.10, "{rel}");
    assert!(
        h.sop.discharge_a > 0.0 && h.sop.discharge_a <= seen + 1e-9,
        "{h:?}"
    );
    assert!(
        h.sop.charge_a > 0.0 && h.sop.charge_a <= seen + 1e-9,
        "{h:?}"
    );
}

/// A pack's cell has the state of power it has alone (bit for bit: the
/// same tail, carried the same way, whichever cell the working area
/// holds), and the string's is the weakest cell's at every horizon.
#[test]
fn the_string_has_its_weakest_cells_state_of_power() {
    let base = CellParameters::<f64>::cell_18650();
    let cells = [
        base,
        CellParameters {
            r_i: 1.6 * base.r_i,
            r_ct: 1.4 * base.r_ct,
            ..base
        },
    ];
    let at = 1100 + 300;
    let (i, _) = record_after_rest(1100, 300, 0.0, 1);
    let volts: Vec<Vec<f64>> = cells.iter().map(|p| truth_voltage(p, &i)).collect();
    let s = OnlineSettings::new(1.0, 64, base).with_ocv(nmc());
    let ps = PackSettings::new(s);
    let mut pack = Box::new(PackEstimator::<f64, 256, 64, 2>::new(&ps, 2).unwrap());
    let mut alone: Vec<_> = (0..2)
        .map(|_| Box::new(CellEstimator::<f64, 256, 64>::new(&s).unwrap()))
        .collect();
    // Both cells rest at the end: the tail of the cell the area does not
    // hold is carried by the pack alone.
    for l in 0..at {
        pack.push(&ps, i[l], &[volts[0][l], volts[1][l]]).unwrap();
        for (k, est) in alone.iter_mut().enumerate() {
            est.push(&s, i[l], volts[k][l]);
        }
    }
    let limits = PowerLimits {
        voltage_min: 3.3,
        voltage_max: 4.2,
        current_limit: 50.0,
    };
    let power = PowerSettings::new(limits, &[2, 10, 30], Some(-5.0)).unwrap();
    let each: Vec<_> = (0..2)
        .map(|k| {
            // At rest, no fit: the tails were carried, not taken.
            assert_eq!(pack.cell(k).unwrap().status(), Status::NotExcited);
            let r = pack.state_of_power(k, &s, &power).expect("published");
            assert_eq!(Some(r), alone[k].state_of_power(&s, &power), "cell {k}");
            r
        })
        .collect();
    let string = pack.pack_state_of_power(&s, &power).unwrap();
    for (j, h) in string.horizons().iter().enumerate() {
        let (a, b) = (each[0].horizons()[j], each[1].horizons()[j]);
        println!(
            "{} s: discharge {:.3} / {:.3} A, charge {:.3} / {:.3} A, string {:.3} / {:.3} A",
            h.sop.steps,
            a.sop.discharge_a,
            b.sop.discharge_a,
            a.sop.charge_a,
            b.sop.charge_a,
            h.sop.discharge_a,
            h.sop.charge_a
        );
        // The resistive cell limits the string.
        assert!(b.sop.discharge_a < a.sop.discharge_a);
        assert_eq!(h.sop.discharge_a, b.sop.discharge_a);
        assert_eq!(h.sop.charge_a, a.sop.charge_a.min(b.sop.charge_a));
        assert_eq!(h.pulse_v, Some(a.pulse_v.unwrap() + b.pulse_v.unwrap()));
    }
}

/// A record that resumes after a gap (a logger stopped while the cell
/// rested, and the cell changed meanwhile: both resistances 1.5 times
/// what they were, as a colder cell's) with a short pulse a few samples
/// later: the restarted window begins at a rested cell
/// ([`CellEstimator::resume_after_gap`] with `rested`), so that pulse is
/// fitted from rest, not taken as the history of the rows after it, and
/// the next pulse, 200 s later (inside the window, short of the SOC
/// observer's 600 s rest), is predicted from that fit: within 5 % of its
/// true drop (measured 0.94 %). Before, the pulse sat in the restarted
/// window's first `memory − 1` samples, no window was fitted before the
/// next pulse (no sample `tracking`), and the next pulse was predicted
/// from the estimate held from before the gap: 27.4 % of the drop off.
#[test]
fn a_pulse_right_after_a_gap_is_fitted_from_rest() {
    let before_gap = CellParameters::<f64>::cell_18650();
    let after_gap = CellParameters {
        r_i: 1.5 * before_gap.r_i,
        r_ct: 1.5 * before_gap.r_ct,
        ..before_gap
    };
    let s = OnlineSettings::new(1.0, 64, before_gap).with_ocv(nmc());
    // The profile to 1100 s, a rest of 1500 s the log does not hold (the
    // gap), 5 s of it logged, a 10 s pulse of −2 A, 185 s of rest, then
    // the −5 A pulse predicted.
    let (at, gap, rested, small, after, k) = (1100, 1500, 5, 10, 185, 10);
    let resume = at + gap;
    let next = resume + rested + small + after;
    let (mut i, _) = record(at, 0.0, next + k - at);
    for (l, x) in i.iter_mut().enumerate().skip(resume + rested) {
        *x = if l < resume + rested + small {
            -2.0
        } else if l >= next {
            -5.0
        } else {
            0.0
        };
    }
    // Each part the voltage of its own cell (after 1500 s of rest the
    // two differ by their relaxed polarizations, under a millivolt).
    let mut v = truth_voltage(&before_gap, &i);
    v[resume..].copy_from_slice(&truth_voltage(&after_gap, &i)[resume..]);
    let v = noisy(v, next);
    let mut est = Box::new(CellEstimator::<f64, 256, 64>::new(&s).unwrap());
    for l in 0..at {
        est.push(&s, i[l], v[l]);
    }
    est.resume_after_gap(true);
    let mut tracking = 0;
    for l in resume..next {
        if est.push(&s, i[l], v[l]).status == Status::Tracking {
            tracking += 1;
        }
    }
    let pred = est.pulse_predictor(&s).expect("a model");
    let got = pred.pulse_voltage(-5.0, k);
    let want = v[next + k - 1];
    let drop = (v[next - 1] - want).abs();
    let rel = (got - want).abs() / drop;
    println!(
        "after the gap: {tracking} samples tracking; {k} s at -5 A predicted {got:.5} V, \
         true {want:.5} V, drop {drop:.4} V: {:.2} %",
        100.0 * rel
    );
    assert!(tracking > 0);
    assert!(rel <= 0.05, "{rel}");
}

/// `Start::AtRest` at power-up, with a prior (the refinement runs from the
/// first sample): the cell rested, then a 10 s pulse of −2 A in the
/// window's first `memory − 1` samples, then rest. The refinement fits
/// that window whole from rest, as the setting says, and the tracker
/// judges the same rows: the pulse excites them, so the window is fitted
/// (`tracking`) and its `R_i` is the cell's. Before, the tracker counted a
/// warm-up of `memory − 1` samples as `FromData` does: it saw no current
/// in the rows after it, and no window was fitted until one slid (no
/// sample `tracking` in these 200).
#[test]
fn at_power_up_from_rest_a_first_pulse_is_fitted() {
    let truth = CellParameters::<f64>::cell_18650();
    let mut s = OnlineSettings::new(1.0, 64, truth).with_ocv(nmc());
    s.battery.start = Start::AtRest;
    s.battery.prior = Some(Prior::new(truth));
    let i: Vec<f64> = (0..200)
        .map(|l| if (5..15).contains(&l) { -2.0 } else { 0.0 })
        .collect();
    let v = noisy(truth_voltage(&truth, &i), i.len());
    let mut est = Box::new(CellEstimator::<f64, 256, 64>::new(&s).unwrap());
    let mut tracking = 0;
    for l in 0..i.len() {
        if est.push(&s, i[l], v[l]).status == Status::Tracking {
            tracking += 1;
        }
    }
    let r_i = est.estimate().expect("a fit").r_i;
    println!(
        "from rest at power-up: {tracking} samples tracking, R_i {r_i:.5} Ohm (truth {:.5})",
        truth.r_i
    );
    assert!(tracking > 100, "{tracking}");
    assert!((r_i / truth.r_i - 1.0).abs() < 0.05, "{r_i}");
}

/// Where [`gap_then_pulse`] stops logging (sample), for how long (s), how
/// long it is logged at rest after the gap and how long its pulse runs.
const GAP_AT: usize = 1100;
const GAP_S: usize = 1500;
const GAP_RESTED: usize = 5;
const GAP_PULSE: usize = 10;

/// A record of `truth` (noise seen until the pulse) that stops being
/// logged at [`GAP_AT`], resumes at rest [`GAP_S`] samples later, and
/// [`GAP_RESTED`] samples on takes a −5 A pulse of [`GAP_PULSE`]
/// samples; and the state of power asked at that pulse.
fn gap_then_pulse(truth: &CellParameters<f64>) -> (Vec<f64>, Vec<f64>, PowerSettings<f64>) {
    let resume = GAP_AT + GAP_S;
    let (mut i, _) = record(GAP_AT, 0.0, resume + GAP_RESTED + GAP_PULSE - GAP_AT);
    for x in i.iter_mut().skip(resume + GAP_RESTED) {
        *x = -5.0;
    }
    let v = noisy(truth_voltage(truth, &i), resume + GAP_RESTED);
    let limits = PowerLimits {
        voltage_min: 2.5,
        voltage_max: 4.2,
        current_limit: 50.0,
    };
    let power = PowerSettings::new(limits, &[GAP_PULSE as u32], Some(-5.0)).unwrap();
    (i, v, power)
}

/// A state of power at every sample once every parameter has been
/// published, with its basis: across a gap that resumes at rest (the
/// window restarts, so no fit's polarization is carried; the rested
/// voltages are only 5 s long, far from the SOC observer's 600 s) the
/// pulse is predicted from the relaxed cell with the estimate held from
/// before the gap (`held`), or with the prior's parameters where one is
/// set (`map`). Before, the state of power was empty from the gap until
/// the next fit: on the Panasonic HPPC test, the first pulse of every
/// level (docs/bms-states.md).
#[test]
fn after_a_gap_at_rest_the_state_of_power_comes_from_what_is_held() {
    let truth = CellParameters::<f64>::cell_18650();
    let (at, resume, rested, k) = (GAP_AT, GAP_AT + GAP_S, GAP_RESTED, GAP_PULSE);
    let (i, v, power) = gap_then_pulse(&truth);
    let plain = OnlineSettings::new(1.0, 64, truth).with_ocv(nmc());
    let mut with_prior = plain;
    with_prior.battery.prior = Some(Prior::new(CellParameters {
        r_i: 1.2 * truth.r_i,
        ..truth
    }));
    for (s, want_basis) in [(&plain, SopBasis::Held), (&with_prior, SopBasis::Map)] {
        let mut est = Box::new(CellEstimator::<f64, 256, 64>::new(s).unwrap());
        let mut first = None;
        let mut bases = Vec::new();
        for l in 0..at {
            est.push(s, i[l], v[l]);
            // (With the prior, a state of power also comes from the
            // record's first rest, before any fit: then none while the
            // first pulses run unfitted.)
            match est.state_of_power(s, &power) {
                Some(r) => {
                    if est.estimate().is_some() {
                        first.get_or_insert(l);
                    }
                    bases.push(r.basis());
                }
                None => assert!(first.is_none(), "no state of power at {l} after {first:?}"),
            }
        }
        assert!(first.is_some());
        assert!(bases.contains(&SopBasis::Window), "{bases:?}");
        est.resume_after_gap(true);
        for l in resume..resume + rested {
            est.push(s, i[l], v[l]);
        }
        let r = est
            .state_of_power(s, &power)
            .expect("a state of power after the gap");
        assert_eq!(r.basis(), want_basis);
        let got = r.horizons()[0].pulse_v.unwrap();
        let want = v[resume + rested + k - 1];
        let drop = v[resume + rested - 1] - want;
        let rel = (got - want).abs() / drop;
        println!(
            "{want_basis:?}: first state of power at sample {first:?}; after the gap \
             {got:.5} V against {want:.5} V, {:.2} % of the drop",
            100.0 * rel
        );
        if want_basis == SopBasis::Held {
            // The cell itself (the estimate of a noisy window).
            assert!(rel <= 0.05, "{rel}");
        } else {
            // The prior's: `R_i` 20 % high, so the pulse ends
            // `0.2·R_i·5 A` = 20 mV low, give or take the estimate's `ΔU`.
            let short = want - got;
            assert!((short - 0.2 * truth.r_i * 5.0).abs() < 0.003, "{short}");
        }
    }
}

/// The state of power checked against the pulse that follows it
/// (`PulseCheck`): after a 30 s pulse at −5 A from a short rest, each
/// horizon's pulse-voltage variance is the parameters' alone (the same
/// spread, the same predictor) plus, squared, the pulse's own response
/// (its static drop and step response) times the fraction that pulse
/// missed its prediction by at that duration, the fraction measured here
/// from the prediction made before the pulse; the derated currents are
/// the lower for it.
#[test]
fn the_next_pulse_widens_the_state_of_power_by_what_it_missed() {
    let truth = CellParameters::<f64>::cell_18650();
    let s = OnlineSettings::new(1.0, 64, truth).with_ocv(nmc());
    let (at, rest, k, after) = (1100, 250, 30, 20);
    let (mut i, _) = record(at, 0.0, rest + k + after);
    for x in &mut i[at + rest..at + rest + k] {
        *x = -5.0;
    }
    let v = noisy(truth_voltage(&truth, &i), at + rest);
    let mut est = Box::new(CellEstimator::<f64, 256, 64>::new(&s).unwrap());
    for l in 0..at + rest {
        est.push(&s, i[l], v[l]);
    }
    // What the check predicts the pulse with: the state of power's set
    // and polarization now.
    let before = est.pulse_predictor(&s).expect("carried through the rest");
    let v0 = v[at + rest - 1];
    let miss = |h: usize| {
        let p = before.pulse_voltage(-5.0, h);
        (p - v[at + rest + h - 1]).abs() / (v0 - p).abs()
    };
    let missed: Vec<f64> = [2, 10, 30].iter().map(|&h| miss(h)).collect();
    for l in at + rest..at + rest + k + after {
        est.push(&s, i[l], v[l]);
    }
    let limits = PowerLimits {
        voltage_min: 3.0,
        voltage_max: 4.2,
        current_limit: 50.0,
    };
    let ps = PowerSettings::new(limits, &[2, 10, 30], Some(-5.0)).unwrap();
    let full = est.state_of_power(&s, &ps).expect("a state of power");
    let c = est.cell_state();
    let (q, basis) = c.sop_parameters(&s).unwrap();
    let e = est.estimate().unwrap();
    assert_eq!(
        (q.r_i, q.r_ct, q.q, q.alpha),
        (e.r_i, e.r_ct, e.q, e.alpha),
        "the estimate's set ({basis:?})"
    );
    let pred = est.pulse_predictor(&s).unwrap();
    let plain = pred.power_with_spread(&ps, &c.sop_spread(&s, basis, &q, ResponseMiss::NONE));
    // The pulse's own response per ampere, from a cell without
    // polarization or curve.
    let w = GlWeights::<f64, 64>::new(q.alpha, 1.0, 64).unwrap();
    let bare = PulsePredictor::<f64, 64, 0>::new(&q, &w, &[], None).unwrap();
    for (j, &h) in [2usize, 10, 30].iter().enumerate() {
        let own = (bare.pulse_voltage(-5.0, h) - bare.pulse_voltage(0.0, h)).abs();
        let (f, p) = (full.horizons()[j], plain.horizons()[j]);
        let (sf, sp) = (f.uncertainty_v.unwrap(), p.uncertainty_v.unwrap());
        let widened = (sp * sp + (missed[j] * own).powi(2)).sqrt();
        println!(
            "{h} s: missed by {:.2} % of the predicted drop; sigma {:.3} mV, {:.3} mV with it",
            100.0 * missed[j],
            1e3 * sp,
            1e3 * sf
        );
        assert!(missed[j] > 1e-4, "{missed:?}");
        assert!((sf - widened).abs() <= 1e-9 * widened, "{sf} {widened}");
        assert!(f.sop.discharge_a < p.sop.discharge_a, "{f:?} {p:?}");
    }
}

/// A map fitted with the Butler–Volmer term (`identify battery --model
/// butler-volmer --map-method joint`) as the prior of the linear online
/// model, which holds the prior's term and never fits it: its `map` basis
/// predicts with the map's `R_i` and that term, from a rest that has
/// emptied the window, whose largest current is then unknown (the term is
/// the map's, fitted over its test's currents, not capped at the
/// window's). The term is `a·asinh(5/i₀)` = 16.5 mV of the pulse's drop;
/// with the term treated as the window's, the pulse was 5 mV off.
#[test]
fn a_butler_volmer_maps_term_is_its_state_of_power() {
    let truth = CellParameters::<f64> {
        r_i: 0.012,
        bv_a: 0.01,
        bv_i0: 2.0,
        ..CellParameters::cell_18650()
    };
    let (at, resume, rested, k) = (GAP_AT, GAP_AT + GAP_S, GAP_RESTED, GAP_PULSE);
    let (i, v, power) = gap_then_pulse(&truth);
    let mut s = OnlineSettings::new(1.0, 64, truth.linearized()).with_ocv(nmc());
    s.battery.prior = Some(Prior::new(truth));
    let mut est = Box::new(CellEstimator::<f64, 256, 64>::new(&s).unwrap());
    for l in 0..at {
        est.push(&s, i[l], v[l]);
    }
    est.resume_after_gap(true);
    for l in resume..resume + rested {
        est.push(&s, i[l], v[l]);
    }
    let r = est
        .state_of_power(&s, &power)
        .expect("a state of power after the gap");
    assert_eq!(r.basis(), SopBasis::Map);
    let got = r.horizons()[0].pulse_v.unwrap();
    let want = v[resume + rested + k - 1];
    let term = truth.bv_a * (5.0 / truth.bv_i0).asinh();
    println!(
        "map basis: {got:.5} V against {want:.5} V (the term {:.1} mV)",
        1e3 * term
    );
    assert!(term > 0.015);
    assert!((got - want).abs() < 0.003, "{got} vs {want}");
    // The held term is a map value: its `ln a` and `ln i₀` have the map's
    // bound, and the pulse voltage's σ carries the term's shift at the
    // pulse's current (in quadrature with the rest).
    let c = est.cell_state();
    let (q, basis) = c.sop_parameters(&s).unwrap();
    let bound = s.identify_factor.ln() / 1.96;
    let spread = c.sop_spread(&s, basis, &q, ResponseMiss::NONE);
    assert_eq!((spread.bv_a, spread.bv_i0), (bound, bound));
    let none = ParameterSpread {
        bv_a: 0.0,
        bv_i0: 0.0,
        ..spread
    };
    // (The σ is the pulse's own response moved: the polarization carried
    // and the curve do not enter it.)
    let w = GlWeights::<f64, 64>::new(q.alpha, 1.0, 64).unwrap();
    let pred = PulsePredictor::<f64, 64, 101>::new(&q, &w, &[], None).unwrap();
    let sd = |sp: &ParameterSpread<f64>| {
        pred.power_with_spread(&power, sp).horizons()[0]
            .uncertainty_v
            .unwrap()
    };
    let by_a = term * (bound.exp() - 1.0);
    let by_i0 = truth.bv_a * (5.0 / (truth.bv_i0 * (-bound).exp())).asinh() - term;
    let kinetic = by_a.hypot(by_i0);
    let (with, without) = (sd(&spread), sd(&none));
    println!(
        "sigma {:.2} mV with the term's spread, {:.2} mV without (its shift {:.2} mV)",
        1e3 * with,
        1e3 * without,
        1e3 * kinetic
    );
    assert!(
        (with - without.hypot(kinetic)).abs() < 1e-9,
        "{with} {without} {kinetic}"
    );
    // The Butler–Volmer model fits its own term: not moved.
    let mut fitted = s;
    fitted.battery.model = CellModel::ButlerVolmer;
    let own = c.sop_spread(&fitted, basis, &q, ResponseMiss::NONE);
    assert_eq!((own.bv_a, own.bv_i0), (0.0, 0.0));
}
