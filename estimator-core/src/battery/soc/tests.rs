//! The observer's unit tests.

use super::*;
use crate::error::Error;

fn table() -> OcvTable<f64, 5> {
    OcvTable::new(&[0.0, 0.25, 0.5, 0.75, 1.0], &[3.0, 3.5, 3.7, 3.9, 4.2]).unwrap()
}

#[test]
fn at_rest_an_uncertain_start_is_read_after_five_minutes_and_only_once() {
    let s = SocSettings {
        soc0_sigma: 0.3,
        ..SocSettings::new(5.0, 1.0)
    };
    let t = table();
    let mut o = SocObserver::new(&s, Some(0.3));
    let v = t.ocv(0.6);
    for _ in 0..299 {
        let e = o.push(&s, &t, 0.0, v).unwrap();
        assert_eq!(e.observations, 0, "the first five minutes are not read");
    }
    let e = o.push(&s, &t, 0.0, v).unwrap();
    // Weighed against the start's spread: most of the way.
    assert!(e.ocv_weight > 0.85 && (e.soc - 0.6).abs() < 0.04, "{e:?}");
    assert_eq!(e.observations, 1);
    for _ in 0..300 {
        let e = o.push(&s, &t, 0.0, v + 0.01).unwrap();
        assert_eq!(e.observations, 1, "a known SOC waits for the rest's end");
    }
}

/// Rests of 15 min between `steps` of 10 min at the given currents,
/// the sensor reading `bias` high: the observer's last estimate, the
/// true SOC and the plain count's.
fn cycle(steps: &[f64], rounds: usize, bias: f64) -> (SocEstimate<f64>, f64, f64) {
    let s = SocSettings::new(5.0, 1.0);
    let t = table();
    let mut o = SocObserver::new(&s, Some(0.9));
    let (mut soc, mut counted, mut last) = (0.9, 0.9, None);
    for _ in 0..rounds {
        for &i in steps {
            for (n, i) in [(900, 0.0), (600, i)] {
                for _ in 0..n {
                    soc += i / 3600.0 / 5.0;
                    counted += (i + bias) / 3600.0 / 5.0;
                    last = o.push(&s, &t, i + bias, t.ocv(soc));
                }
            }
        }
    }
    (last.unwrap(), soc, counted)
}

#[test]
fn the_rests_correct_a_drifting_count() {
    // 1 C discharges, a sensor 1 % of 1 C high: the count drifts by
    // 0.4 % of SOC per round; the rests take it out (and read the bias,
    // `a_rest_reads_the_bias`). SOC swings of 0.13 do not pin the
    // capacity to 2 %.
    let (e, soc, counted) = cycle(&[-5.0], 4, 0.05);
    assert!(e.observations >= 4, "{e:?}");
    assert!((counted - soc).abs() > 0.015, "{counted} vs {soc}");
    assert!((e.soc - soc).abs() < 0.004, "{} vs {soc}", e.soc);
    // Not the capacity: it is published as the nominal one.
    assert!(!e.capacity_identified && e.capacity_ah == 5.0, "{e:?}");
}

/// A rested cell carries no current: what the sensor reads in a rest is
/// its bias, and the first rest reads it (`SocSettings::rest_load_sigma_a`).
/// Without that reading discharges alone cannot tell the bias from the
/// capacity (before: the bias stayed near its prior 0 here).
#[test]
fn a_rest_reads_the_bias() {
    let (e, soc, _) = cycle(&[-5.0], 4, 0.05);
    assert!((e.current_bias_a - 0.05).abs() < 0.002, "{e:?}");
    assert!((e.soc - soc).abs() < 0.002, "{} vs {soc}", e.soc);
}

/// `n` samples of a true current `i` (A) read `bias` high, the cell's
/// true SOC followed; the last estimate.
fn feed(o: &mut SocObserver<f64>, soc: &mut f64, n: usize, i: f64, bias: f64) -> SocEstimate<f64> {
    let (s, t) = (SocSettings::new(5.0, 1.0), table());
    let mut e = None;
    for _ in 0..n {
        *soc += i / 3600.0 / 5.0;
        e = o.push(&s, &t, i + bias, t.ocv(*soc)).or(e);
    }
    e.unwrap()
}

/// Once the bias is known, a rest that carries a real load (here 0.08 A,
/// inside the rest's C/50 but 13 standard deviations from the bias
/// expected) is a load, not the bias: it is not read (before the gate,
/// the bias moved most of the way to the load's reading).
#[test]
fn a_rest_with_a_load_is_not_read_as_the_bias() {
    let s = SocSettings::new(5.0, 1.0);
    let mut o = SocObserver::new(&s, Some(0.9));
    let mut soc = 0.9;
    feed(&mut o, &mut soc, 900, 0.0, 0.05);
    let e = feed(&mut o, &mut soc, 600, -5.0, 0.05);
    assert!((e.current_bias_a - 0.05).abs() < 0.002, "{e:?}");
    feed(&mut o, &mut soc, 900, -0.08, 0.05);
    let e = feed(&mut o, &mut soc, 10, -5.0, 0.05);
    assert!(e.observations >= 2, "{e:?}");
    assert!((e.current_bias_a - 0.05).abs() < 0.002, "{e:?}");
}

/// A rest that first reads an unknown SOC early reads the bias then, and
/// not again at its end: the load its spread stands for is the same. A
/// second reading would halve the bias's variance again.
#[test]
fn a_rest_reads_the_bias_once() {
    let s = SocSettings {
        soc0_sigma: 0.3,
        ..SocSettings::new(5.0, 1.0)
    };
    let t = table();
    let mut o = SocObserver::new(&s, Some(0.5));
    // 20 minutes at rest: the early reading at 5 minutes, the rest's own
    // at its end.
    for _ in 0..1200 {
        o.push(&s, &t, 0.05, t.ocv(0.6));
    }
    // Read at 5 minutes: the variance of one reading, and the bias's walk
    // over the 15 minutes since (a quarter more).
    let early = o.p[3];
    let r = s.rest_load_sigma_a * s.rest_load_sigma_a;
    assert!(early < 1.3 * r, "read early: {early} vs {r}");
    let e = o.push(&s, &t, -5.0, t.ocv(0.6)).unwrap();
    assert_eq!(e.observations, 2, "{e:?}");
    assert!(o.p[3] > 0.9 * early, "read again: {} vs {early}", o.p[3]);
}

#[test]
fn charge_and_discharge_tell_the_bias_from_the_capacity() {
    let (e, soc, counted) = cycle(&[-5.0, 5.0], 4, 0.05);
    assert!((counted - soc).abs() > 0.03, "{counted} vs {soc}");
    assert!((e.soc - soc).abs() < 0.004, "{} vs {soc}", e.soc);
    assert!((e.current_bias_a - 0.05).abs() < 0.01, "{e:?}");
    assert!((e.capacity_ah - 5.0).abs() < 0.25, "{e:?}");
    // SOC swings of 0.17 do not pin the capacity to 2 % (nor span the
    // rests' 0.3): the nominal one is published, and said to be.
    assert!(e.capacity_sigma_ah > 0.02 * e.capacity_ah, "{e:?}");
    assert!(!e.capacity_identified, "{e:?}");
}

#[test]
fn a_flat_curve_weighs_the_observation_little() {
    // A start known to 0.05: not read at once.
    let s = SocSettings {
        soc0_sigma: 0.05,
        ..SocSettings::new(5.0, 1.0)
    };
    let flat = OcvTable::<f64, 5>::new(
        &[0.0, 0.25, 0.5, 0.75, 1.0],
        &[3.3, 3.3005, 3.301, 3.3015, 3.302],
    )
    .unwrap();
    let steep = table();
    let run = |t: &OcvTable<f64, 5>| {
        let mut o = SocObserver::new(&s, Some(0.5));
        // A 15-minute rest.
        let mut e = None;
        for _ in 0..900 {
            e = o.push(&s, t, 0.0, t.ocv(0.55));
        }
        o.push(&s, t, -1.0, t.ocv(0.55)).or(e).unwrap()
    };
    let (f, st) = (run(&flat), run(&steep));
    assert!(f.ocv_weight < 0.05, "{f:?}");
    assert!(st.ocv_weight > 0.9, "{st:?}");
    assert!((st.soc - 0.55).abs() < 0.005);
}

#[test]
fn bad_samples_neither_count_nor_observe() {
    let s = SocSettings::new(5.0, 1.0);
    let t = table();
    let mut o = SocObserver::new(&s, None);
    assert!(o.push(&s, &t, 0.0, f64::NAN).is_none());
    let e = o.push(&s, &t, f64::NAN, t.ocv(0.4)).unwrap();
    assert!((e.soc - 0.4).abs() < 1e-9);
    let e = o.push(&s, &t, f64::INFINITY, f64::NAN).unwrap();
    assert!(e.soc.is_finite() && (e.soc - 0.4).abs() < 1e-9);
}

#[test]
fn after_a_gap_the_soc_is_read_again_after_five_minutes_of_rest() {
    let s = SocSettings::new(5.0, 1.0);
    let t = table();
    let mut o = SocObserver::new(&s, Some(0.8));
    o.push(&s, &t, -5.0, t.ocv(0.8));
    o.resume_after_gap();
    let mut e = None;
    for _ in 0..300 {
        e = o.push(&s, &t, 0.0, t.ocv(0.45));
    }
    let e = e.unwrap();
    assert!((e.soc - 0.45).abs() < 0.01, "{e:?}");
}

/// A cell of 4.5 A·h (the observer told 5) swung `rounds` times between
/// SOC `hi` and `lo` at 1 C, resting 15 min at each end, the curve and the
/// count exact: the observer's last estimate.
fn swing(
    s: &SocSettings<f64>,
    o: &mut SocObserver<f64>,
    hi: f64,
    lo: f64,
    rounds: usize,
) -> SocEstimate<f64> {
    let t = table();
    let mut soc = hi;
    let mut last = None;
    for _ in 0..rounds {
        for i in [-4.5, 4.5] {
            for _ in 0..900 {
                last = o.push(s, &t, 0.0, t.ocv(soc));
            }
            let steps = ((hi - lo) * 3600.0).round() as usize;
            for _ in 0..steps {
                soc += i / 3600.0 / 4.5;
                last = o.push(s, &t, i, t.ocv(soc));
            }
        }
    }
    last.unwrap()
}

/// Rests read to 2.5·10⁻³ of SOC each, but all within 0.15 of SOC: the
/// filter's capacity spread falls below 2 %, yet the rests never span
/// `capacity_min_span` (0.3), so the capacity is not identified (the
/// nominal 5 A·h is published, and a restored observer stays so); asked
/// for 0.1, it is, and it is the cell's 4.5 A·h.
#[test]
fn rests_within_a_narrow_band_do_not_identify_the_capacity() {
    let s = SocSettings {
        voltage_sigma_v: 0.001,
        table_sigma_soc: 0.002,
        bias_sigma_a: 0.0,
        bias_walk_a: 0.0,
        ..SocSettings::new(5.0, 1.0)
    };
    let mut o = SocObserver::new(&s, Some(0.6));
    let e = swing(&s, &mut o, 0.6, 0.45, 8);
    assert!(e.capacity_sigma_ah < 0.02 * 4.5, "{e:?}");
    assert!(!e.capacity_identified && e.capacity_ah == 5.0, "{e:?}");
    let back = SocObserver::from_parts(&o.parts(), false);
    assert_eq!(
        back.estimate(&s).map(|e| e.capacity_identified),
        Some(false)
    );
    let narrow = SocSettings {
        capacity_min_span: 0.1,
        ..s
    };
    let mut o = SocObserver::new(&narrow, Some(0.6));
    let e = swing(&narrow, &mut o, 0.6, 0.45, 8);
    assert!(
        e.capacity_identified && (e.capacity_ah - 4.5).abs() < 0.05,
        "{e:?}"
    );
    // A wider swing reaches the default span.
    let mut o = SocObserver::new(&s, Some(0.8));
    let e = swing(&s, &mut o, 0.8, 0.45, 4);
    assert!(
        e.capacity_identified && (e.capacity_ah - 4.5).abs() < 0.05,
        "{e:?}"
    );
    // Restored, an identified capacity stays identified.
    let back = SocObserver::from_parts(&o.parts(), false);
    assert_eq!(back.estimate(&s).map(|e| e.capacity_identified), Some(true));
}

/// A rest read early, before it relaxed (the SOC loosely known), and
/// again at its end is one rest: its early reading widens no span. Two
/// observers told different start SOCs, equal but for the span.
#[test]
fn a_rest_read_early_widens_no_span() {
    let s = SocSettings::new(5.0, 1.0);
    let t = table();
    let mut o = SocObserver::new(&s, Some(0.9));
    // Told 0.9 (spread 0.1), at 0.5 and relaxing from 40 mV below its
    // OCV: read early (about 22 mV low, 0.027 of SOC), then at the rest's
    // end.
    for k in 0..700 {
        let relaxing = 0.04 * (1.0 - f64::from(k) / 700.0);
        o.push(&s, &t, 0.0, t.ocv(0.5) - relaxing);
    }
    o.push(&s, &t, -5.0, t.ocv(0.49));
    assert_eq!(o.estimate(&s).map(|e| e.observations), Some(2));
    // Only the relaxed reading: a span of nothing, where the early one
    // would have widened it by about 0.027.
    assert!(
        (o.rest_span[1] - o.rest_span[0]).abs() < 1e-12,
        "{:?}",
        o.rest_span
    );
    assert_eq!(
        SocObserver::<f64>::new(&s, None),
        SocObserver::new(&s, None)
    );
}

/// Rests on either side of a gap of unknown charge, or of a set SOC, are
/// not linked by the count: they do not span SOC together.
#[test]
fn a_gap_or_a_set_soc_starts_the_span_again() {
    let s = SocSettings::new(5.0, 1.0);
    let t = table();
    for cut in [0, 1] {
        let mut o = SocObserver::new(&s, Some(0.8));
        for _ in 0..900 {
            o.push(&s, &t, 0.0, t.ocv(0.8));
        }
        o.push(&s, &t, -5.0, t.ocv(0.7));
        assert!((o.rest_span[0] - 0.8).abs() < 0.01 && o.rest_span[1] == o.rest_span[0]);
        if cut == 0 {
            o.resume_after_gap();
        } else {
            o.set_state_of_charge(0.4);
        }
        for _ in 0..900 {
            o.push(&s, &t, 0.0, t.ocv(0.4));
        }
        o.push(&s, &t, -5.0, t.ocv(0.3));
        assert!(!o.span_reached, "{cut}: {:?}", o.rest_span);
        assert!((o.rest_span[0] - 0.4).abs() < 0.01 && o.rest_span[1] == o.rest_span[0]);
    }
}

#[test]
fn the_observer_is_small() {
    // 6 + 3 variances and states, the rest (len, means, flags), the last
    // weight, counters, the held capacity, the rests' span and a pending
    // set: docs/soc-observer.md.
    let n = core::mem::size_of::<SocObserver<f32>>();
    println!("size_of::<SocObserver<f32>>() = {n} B");
    assert_eq!(n, 92);
}

#[test]
fn settings_that_are_not_finite_or_out_of_range_are_refused() {
    let base = SocSettings::<f32>::new(5.0, 1.0);
    assert_eq!(base.check(), Ok(()));
    for bad in [
        SocSettings {
            capacity_ah: 0.0,
            ..base
        },
        SocSettings { h: -1.0, ..base },
        SocSettings {
            min_slope: 0.0,
            ..base
        },
        SocSettings {
            bias_sigma_a: f32::INFINITY,
            ..base
        },
        SocSettings {
            soc0_sigma: f32::NAN,
            ..base
        },
        SocSettings {
            table_sigma_soc: -0.01,
            ..base
        },
        SocSettings {
            rest_load_sigma_a: f32::NAN,
            ..base
        },
        SocSettings {
            capacity_ah: 1e20,
            ..base
        },
    ] {
        assert_eq!(bad.check(), Err(Error::BadSetting), "{bad:?}");
    }
}

/// Spreads far beyond what any data could mean, in `f32`: the
/// covariance overflowed (NaN), the published SOC claimed a spread of
/// 0 or ∞ and no rest was observed again. Now each variance stops at
/// knowing nothing: every estimate's spread is finite and at most 1,
/// and every 15-minute rest is observed (before: none).
#[test]
fn spreads_beyond_any_information_stop_at_knowing_nothing() {
    let t: OcvTable<f32, 5> =
        OcvTable::new(&[0.0, 0.25, 0.5, 0.75, 1.0], &[3.0, 3.5, 3.7, 3.9, 4.2]).unwrap();
    let base = SocSettings::<f32>::new(5.0, 1.0);
    for s in [
        SocSettings {
            bias_sigma_a: 1e20,
            ..base
        },
        SocSettings {
            capacity_sigma: 1e20,
            ..base
        },
        SocSettings {
            bias_walk_a: 1e20,
            ..base
        },
        SocSettings {
            rest_load_sigma_a: 1e20,
            ..base
        },
        SocSettings {
            soc0_sigma: 1e20,
            ..base
        },
        SocSettings {
            gap_soc_sigma: 1e30,
            ..base
        },
    ] {
        assert_eq!(s.check(), Ok(()));
        let mut o = SocObserver::new(&s, Some(0.9));
        let mut soc = 0.9f32;
        let mut last = None;
        for round in 0..6 {
            let i = if round % 2 == 0 { -5.0 } else { 5.0 };
            if round == 3 {
                o.resume_after_gap();
            }
            for (n, i) in [(900, 0.0f32), (600, i)] {
                for _ in 0..n {
                    soc += i / 3600.0 / 5.0;
                    let e = o.push(&s, &t, i + 0.05, t.ocv(soc)).unwrap();
                    assert!(e.sigma.is_finite() && e.sigma <= 1.0, "{s:?}: {e:?}");
                    assert!(
                        e.soc.is_finite() && e.capacity_sigma_ah.is_finite(),
                        "{s:?}: {e:?}"
                    );
                    last = Some(e);
                }
            }
        }
        let e = last.unwrap();
        // Each rest observed (an uncertain SOC also early, at half a
        // rest).
        assert!(e.observations >= 6, "{s:?}: {e:?}");
        assert!((e.soc - soc).abs() < 0.02, "{s:?}: {e:?} vs {soc}");
    }
}
