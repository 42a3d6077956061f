//! Unit tests of the state of power's check against the pulses that
//! follow ([`super::PulseCheck`]).

use super::*;

/// The drop per ampere `k` samples into a pulse (V/A): 50 mΩ at the
/// step and a growth in `√k`, the shape the check interpolates in.
fn per_amp(k: u32) -> f64 {
    per_amp_at(f64::from(k))
}

/// The same `t` periods after the edge (0 before it).
fn per_amp_at(t: f64) -> f64 {
    if t <= 0.0 {
        0.0
    } else {
        0.05 + 0.01 * t.sqrt()
    }
}

/// Three samples at rest (0 A, 3.7 V).
fn rest(c: &mut PulseCheck<f64>) {
    for _ in 0..3 {
        c.observe(0.0, 3.7, false);
    }
}

/// Every duration's miss within `bound`.
fn assert_misses_within(c: &PulseCheck<f64>, bound: f64) {
    for m in c.missed().miss {
        assert!(m <= bound, "{:?}", c.missed().miss);
    }
}

/// A pulse of −2 A from rest at 3.7 V whose measured drop is 10 %
/// larger than predicted at every duration: each miss is 0.1, and a
/// pulse that stops early leaves the longer durations' misses as they
/// were.
#[test]
fn a_pulse_leaves_its_relative_miss_at_each_duration() {
    let mut c = PulseCheck::<f64>::BLANK;
    for _ in 0..3 {
        assert!(!c.starts_pulse(1e-3, 0.0));
        c.observe(0.0, 3.7, false);
    }
    assert!(c.starts_pulse(1e-3, -2.0));
    let predicted = CHECK_STEPS.map(|k| 3.7 - 0.1 - 0.001 * f64::from(k));
    assert!(c.start(-2.0, predicted, 1e-3, true));
    for k in 1..=40u32 {
        let drop = 0.1 + 0.001 * f64::from(k.min(30));
        c.observe(-2.0, 3.7 - 1.1 * drop, false);
    }
    for m in c.missed().miss {
        assert!((m - 0.1).abs() < 1e-9, "{m}");
    }
    // A second pulse, as predicted, that stops after 5 samples.
    rest(&mut c);
    assert!(c.starts_pulse(1e-3, -2.0));
    assert!(c.start(-2.0, predicted, 1e-3, true));
    for k in 1..=5u32 {
        c.observe(
            -2.0,
            predicted[CHECK_STEPS.iter().position(|&x| x >= k).unwrap()],
            false,
        );
    }
    c.observe(0.0, 3.7, false);
    let m = c.missed().miss;
    assert!(m[0] < 0.1 && m[2] < 1e-12, "{m:?}");
    assert!(
        (m[3] - 0.1).abs() < 1e-9 && (m[4] - 0.1).abs() < 1e-9,
        "{m:?}"
    );
    assert!((c.missed().at(10) - 0.1).abs() < 1e-9);
}

/// A resampled log's first pulse sample averages the current over the
/// edge (−1.2 A of a −2 A pulse: the edge 0.4 of a period into it),
/// and each voltage follows its period's current: the pulse is checked
/// at each duration from its edge, interpolated between the two
/// samples around it, against the prediction for −2 A from the start
/// of a period. A pulse as the model predicts it misses by at most
/// 0.5 % (a straight line between two samples of a response growing
/// in the square root of the time: 0.49 % at the first duration). The
/// pulse's end, into a smaller current, starts no check.
#[test]
fn a_step_averaged_over_its_edge_is_checked_at_its_duration_from_the_edge() {
    let mut c = PulseCheck::<f64>::BLANK;
    c.observe(0.0, 3.7, false);
    c.observe(0.0, 3.7, false);
    assert!(c.starts_pulse(1e-3, -1.2));
    // Predicted for −1.2 A; the first sample held 60 % of the pulse.
    let predicted = CHECK_STEPS.map(|k| 3.7 - 1.2 * per_amp(k));
    assert!(c.start(-1.2, predicted, 1e-3, true));
    c.observe(-1.2, 3.7 - 2.0 * per_amp_at(0.6), false);
    for e in 2..=31u32 {
        c.observe(-2.0, 3.7 - 2.0 * per_amp_at(f64::from(e) - 0.4), false);
    }
    assert_misses_within(&c, 0.005);
    assert!(!c.starts_pulse(1e-3, 0.0), "the pulse's end");
}

/// A log's instants put on a period whose current holds exactly
/// through it: each voltage is taken at the start of the period whose
/// current its sample holds ([`VoltageTiming::Start`]), so the step's
/// own sample shows none of the pulse (or, resampled, a mean over the
/// edge). The check reads the voltages a sample later, where read as
/// taken at the period's end the first durations would miss by 8 % and
/// more: a 10 s pulse on 1 s periods, its edge 0.4 s into one, is
/// checked at every duration it reaches, the 10th carried on from the
/// last two samples it holds by 1.4 periods.
#[test]
fn a_record_whose_voltages_lead_is_read_a_sample_later() {
    let lead = |c: &mut PulseCheck<f64>, i: f64, v: f64| {
        c.observe_watching(i, v, false, None, VoltageTiming::Start);
    };
    let mut c = PulseCheck::<f64>::BLANK;
    rest(&mut c);
    let predicted = CHECK_STEPS.map(|k| 3.7 - 1.2 * per_amp(k));
    assert!(c.start(-1.2, predicted, 1e-3, true));
    // The step's own sample: a mean over the edge.
    lead(&mut c, -1.2, 3.7 - 0.6 * 2.0 * per_amp_at(0.3));
    for e in 2..=10u32 {
        lead(&mut c, -2.0, 3.7 - 2.0 * per_amp_at(f64::from(e) - 1.4));
    }
    // The pulse's last 0.4 s: again a mean over the edge.
    lead(&mut c, -0.8, 3.7 - 0.4 * 2.0 * per_amp_at(9.8));
    lead(&mut c, 0.0, 3.69);
    let m = c.missed().miss;
    assert!(m[..4].iter().all(|m| *m <= 0.005), "{m:?}");
    assert!(m[4].is_nan(), "30 s not reached: {m:?}");
    // Read as taken at the period's end, the second sample's voltage
    // (0.6 periods in) would stand for a full period.
    let early = per_amp_at(0.6) / per_amp(1) - 1.0;
    assert!(early < -0.03, "{early}");
    // A pulse whose edge is the period's start: each duration from
    // the sample after the step.
    rest(&mut c);
    let predicted = CHECK_STEPS.map(|k| 3.7 - 2.0 * per_amp(k));
    assert!(c.start(-2.0, predicted, 1e-3, true));
    lead(&mut c, -2.0, 3.7);
    for e in 2..=31u32 {
        lead(&mut c, -2.0, 3.7 - 2.2 * per_amp(e - 1));
    }
    for m in c.missed().miss {
        assert!((m - 0.1).abs() < 1e-9, "{:?}", c.missed().miss);
    }
}

/// A measured log put on a coarser period: each sample holds the mean
/// voltage over the period of its mean current ([`VoltageTiming::Mean`],
/// `fracbms-host`'s resampler). A pulse as the model predicts it, its
/// edge 0.4 of a period into its first sample, misses by nothing at
/// every duration (the response grows in the square root of the time,
/// as the check interpolates it: to 10⁻⁹), the 10th carried on from the
/// last two samples of a 10 s pulse by 0.9 of a period; read as taken
/// at the period's start it would miss by 3.8 % at the first.
#[test]
fn a_resampled_record_holds_each_periods_mean_voltage() {
    // The drop per ampere averaged over `[s, s + 1]` periods after the
    // edge.
    let mean = |s: f64| 0.05 + 0.01 * (2.0 / 3.0) * ((s + 1.0).powf(1.5) - s.powf(1.5));
    let run = |timing: VoltageTiming| {
        let mut c = PulseCheck::<f64>::BLANK;
        rest(&mut c);
        let predicted = CHECK_STEPS.map(|k| 3.7 - 1.2 * per_amp(k));
        assert!(c.start(-1.2, predicted, 1e-3, true));
        c.observe_watching(-1.2, 3.7 - 2.0 * 0.6 * mean(0.0), false, None, timing);
        for e in 2..=10u32 {
            let v = 3.7 - 2.0 * mean(f64::from(e) - 1.4);
            c.observe_watching(-2.0, v, false, None, timing);
        }
        c.observe_watching(-0.8, 3.69, false, None, timing);
        c.observe_watching(0.0, 3.69, false, None, timing);
        c.missed().miss
    };
    let m = run(VoltageTiming::Mean);
    assert!(m[..4].iter().all(|m| *m < 1e-9), "{m:?}");
    assert!(m[4].is_nan(), "30 s not reached: {m:?}");
    let start = run(VoltageTiming::Start);
    assert!(start[0] > 0.035, "{start:?}");
}

/// A rejected or missing voltage, or a current that moves, ends the
/// check without a miss; a step from a current that was not steady, or
/// from before a restart, starts none.
#[test]
fn a_pulse_that_does_not_hold_leaves_no_miss() {
    let mut c = PulseCheck::<f64>::BLANK;
    c.observe(0.0, 3.7, false);
    c.observe(-0.5, 3.69, false);
    assert!(!c.starts_pulse(1e-3, -2.0), "not steady before");
    c.observe(-0.5, 3.69, false);
    assert!(c.starts_pulse(1e-3, -2.0));
    assert!(c.start(-2.0, [3.6; 5], 1e-3, true));
    c.observe(-2.0, f64::NAN, false);
    assert!(c.missed().miss.iter().all(|m| m.is_nan()));
    c.observe(-0.5, 3.69, false);
    c.observe(-0.5, 3.69, false);
    assert!(c.start(-2.0, [3.6; 5], 1e-3, true));
    c.observe(-2.0, 3.5, true);
    c.observe(-1.0, 3.5, false);
    assert!(c.missed().miss.iter().all(|m| m.is_nan()));
    assert!(!c.starts_pulse(1e-3, -1.0 + 1e-6), "no step");
    // After a restart, the samples before it start no pulse.
    c.observe(0.0, 3.7, false);
    c.observe(0.0, 3.7, false);
    c.restart();
    assert!(!c.starts_pulse(1e-3, -2.0));
    c.observe(0.0, 3.7, false);
    assert!(!c.starts_pulse(1e-3, -2.0), "one sample is not steady");
    c.observe(0.0, 3.7, false);
    assert!(c.starts_pulse(1e-3, -2.0));
}

/// A step whose predicted drop is within the voltage's noise is not
/// checked; a pulse of one sample keeps the last pulse's first miss;
/// a current that settles within a tenth after its first sample is
/// checked from the second duration on at the current it holds, and
/// leaves the first duration's miss unknown.
#[test]
fn a_small_step_is_not_checked_and_a_short_one_keeps_the_last_miss() {
    let mut c = PulseCheck::<f64>::BLANK;
    let predicted = CHECK_STEPS.map(|k| 3.7 - 0.1 - 0.001 * f64::from(k));
    // Within the noise: 2·√2·10 mV > 0.25·100 mV.
    rest(&mut c);
    assert!(c.starts_pulse(1e-3, -2.0));
    assert!(!c.start(-2.0, predicted, 0.01, true));
    c.observe(-2.0, 3.5, false);
    c.observe(-2.0, 3.5, false);
    assert!(c.missed().miss.iter().all(|m| m.is_nan()));
    // A pulse 10 % deeper than predicted at its first two samples.
    rest(&mut c);
    assert!(c.start(-2.0, predicted, 1e-3, true));
    for k in 1..=2u32 {
        c.observe(-2.0, 3.7 - 1.1 * (0.1 + 0.001 * f64::from(k)), false);
    }
    c.observe(0.0, 3.7, false);
    let first = c.missed().miss[0];
    assert!((first - 0.1).abs() < 1e-9, "{first}");
    // One sample, then back to rest: the first miss stays.
    rest(&mut c);
    assert!(c.start(-2.0, predicted, 1e-3, true));
    c.observe(-2.0, 3.0, false);
    c.observe(0.0, 3.7, false);
    assert_eq!(c.missed().miss[0], first);
    // A current 5 % below its first sample's after it: checked on at
    // −1.9 A, each duration missed by no more than the first sample's
    // excess current adds (0.1 A over 1.9 A at the first, less after).
    rest(&mut c);
    let predicted = CHECK_STEPS.map(|k| 3.7 - 2.0 * per_amp(k));
    assert!(c.start(-2.0, predicted, 1e-3, true));
    let drop = |k: u32| 1.9 * per_amp(k) + 0.1 * (per_amp(k) - per_amp(k - 1));
    c.observe(-2.0, 3.7 - drop(1), false);
    for k in 2..=31u32 {
        c.observe(-1.9, 3.7 - drop(k), false);
    }
    assert_misses_within(&c, 0.1 / 1.9 + 1e-9);
    assert!(c.missed().miss[1] < 0.004, "{:?}", c.missed().miss);
}

/// A watched pulse 20 % deeper than predicted at every duration leaves
/// the ratio 1.2 there; one that stops after 5 samples, as predicted,
/// leaves 1 up to 5 and the earlier 1.2 beyond; a pulse of another
/// current leaves the ratios as they were (its misses still count), and
/// a watched pulse whose first sample holds 60 % of its current (a
/// resampled edge) is watched from its second on, and one from a cell
/// still drifting is not; between durations the ratio is
/// interpolated, below them the first, beyond them none (but beyond
/// the longest duration checked, its).
#[test]
fn a_watched_pulse_leaves_its_signed_ratio() {
    let mut c = PulseCheck::<f64>::BLANK;
    let watch = Some(-2.0);
    // Predicted for −2 A.
    let drop = |k: u32| 2.0 * per_amp(k);
    let predicted = CHECK_STEPS.map(|k| 3.7 - drop(k));
    let pulse = |c: &mut PulseCheck<f64>, i: f64, deeper: f64, samples: u32| {
        rest(c);
        let scale = i / -2.0;
        assert!(c.start(i, predicted.map(|p| 3.7 - scale * (3.7 - p)), 1e-3, true));
        for k in 1..=samples {
            c.observe_watching(
                i,
                3.7 - deeper * scale * drop(k),
                false,
                watch,
                VoltageTiming::End,
            );
        }
        rest(c);
    };
    assert_eq!(c.ratio(10), None);
    pulse(&mut c, -2.0, 1.2, 30);
    for k in CHECK_STEPS {
        let r = c.ratio(k).unwrap();
        assert!((r - 1.2).abs() < 2.5e-4, "{k}: {r}");
    }
    // From a cell that would rest at 3.7 V.
    let v = c.corrected(10, 3.7 - drop(10), 3.7).unwrap();
    assert!((v - (3.7 - 1.2 * drop(10))).abs() < 1e-4, "{v}");
    // A watched pulse as predicted, 5 samples long.
    pulse(&mut c, -2.0, 1.0, 5);
    for (k, want) in [
        (1, 1.0),
        (2, 1.0),
        (5, 1.0),
        (10, 1.2),
        (30, 1.2),
        (60, 1.2),
    ] {
        let r = c.ratio(k).unwrap();
        assert!((r - want).abs() < 2.5e-4, "{k}: {r}");
    }
    // Halfway between 5 and 10 samples, halfway between the ratios.
    assert!((c.ratio(7).unwrap() - 1.08).abs() < 2.5e-4);
    // A −3 A pulse 50 % deeper: its misses, not its ratios.
    pulse(&mut c, -3.0, 1.5, 30);
    assert!((c.missed().at(10) - 0.5).abs() < 1e-9);
    assert!((c.ratio(30).unwrap() - 1.2).abs() < 2.5e-4);
    // A watched pulse 10 % deeper whose first sample averaged 60 % of
    // it over the edge: watched at −2 A, each duration from the edge.
    rest(&mut c);
    let part = predicted.map(|p| 3.7 - 0.6 * (3.7 - p));
    assert!(c.start(-1.2, part, 1e-3, true));
    for e in 1..=31u32 {
        let i = if e == 1 { -1.2 } else { -2.0 };
        let v = 3.7 - 1.1 * 2.0 * per_amp_at(f64::from(e) - 0.4);
        c.observe_watching(i, v, false, watch, VoltageTiming::End);
    }
    rest(&mut c);
    assert!((c.ratio(10).unwrap() - 1.1).abs() < 2.5e-4);
    assert!((c.ratio(1).unwrap() - 1.1).abs() < 1.1 * 0.005);
    // A watched pulse from a cell still drifting: its misses count,
    // not its ratios.
    rest(&mut c);
    assert!(c.start(-2.0, predicted, 1e-3, false));
    for k in 1..=30u32 {
        c.observe_watching(-2.0, 3.7 - 1.5 * drop(k), false, watch, VoltageTiming::End);
    }
    rest(&mut c);
    assert!((c.missed().at(10) - 0.5).abs() < 1e-9);
    assert!((c.ratio(10).unwrap() - 1.1).abs() < 2.5e-4);
    // A check whose only watched pulse lasted 5 samples: no ratio
    // beyond them.
    let mut short = PulseCheck::<f64>::BLANK;
    pulse(&mut short, -2.0, 1.2, 5);
    assert!((short.ratio(1).unwrap() - 1.2).abs() < 2.5e-4);
    assert!((short.ratio(5).unwrap() - 1.2).abs() < 2.5e-4);
    assert_eq!(short.ratio(10), None);
    assert_eq!(short.corrected(30, 3.6, 3.7), None);
}

#[test]
fn the_same_pulse_is_within_a_tenth_of_the_same_sign() {
    assert!(same_pulse(-17.4, -17.0));
    assert!(!same_pulse(-17.4, -11.6));
    assert!(!same_pulse(2.0, -2.0));
    assert!(!same_pulse(0.0, 0.0));
}
