//! Tests of the §6.2 regression and its 2S-OP-GI iteration.

use super::*;
use crate::window::SampleWindow;

/// A pulse current and a made-up voltage with memory: enough to excite
/// every regressor.
fn sample(l: usize) -> (f64, f64) {
    let i = if (l / 7).is_multiple_of(2) { 2.0 } else { -1.5 } + 0.1 * (l as f64 * 0.37).sin();
    let v = 3.7 + 0.02 * i + 0.01 * (l as f64 * 0.05).cos();
    (i, v)
}

#[test]
fn sliding_cache_is_bit_identical_to_a_full_reload() {
    const N: usize = 48;
    let mut s = BatterySettings::<f64>::new(1.0, 16);
    s.estimate_order = false; // α fixed: every load after the first is incremental
    let mut gi = PaperRegressionGi::<f64, N, 16>::new(&s, 0.6).unwrap();
    let mut win = SampleWindow::<f64, N>::new();
    let mut incremental = 0;
    for l in 0..150 {
        let (i, v) = sample(l);
        win.push(i, v).unwrap();
        let before = gi.stamp;
        match gi.iterate(&s, &win) {
            Ok(_) | Err(Error::NotExcited) => {}
            Err(Error::NotEnoughData { .. }) => continue,
            Err(e) => panic!("{e:?}"),
        }
        incremental += usize::from(before.is_some());
        // Derivatives kept from the last sample are slid with the
        // values; compute them now so that the next slide carries them.
        let slid_derivatives = gi.derivatives;
        gi.derivatives();
        let mut fresh = gi.clone();
        fresh.stamp = None;
        fresh.load(&s, &win).unwrap();
        assert!(!fresh.derivatives);
        fresh.derivatives();
        assert!(
            slid_derivatives || before.is_none(),
            "derivatives not slid at {l}"
        );
        for (a, b) in [
            (&gi.i, &fresh.i),
            (&gi.v, &fresh.v),
            (&gi.di, &fresh.di),
            (&gi.ddi, &fresh.ddi),
            (&gi.hv, &fresh.hv),
            (&gi.dhv, &fresh.dhv),
        ] {
            let r = gi.rows();
            assert_eq!(a[r.clone()], b[r], "row values differ after sample {l}");
        }
    }
    assert!(incremental > 100, "the cache path ran {incremental} times");
}

#[test]
fn combined_order_gradient_equals_the_kept_derivatives() {
    const N: usize = 64;
    let s = BatterySettings::<f64>::new(0.5, 20); // ln h ≠ 0
    let mut gi = PaperRegressionGi::<f64, N, 20>::new(&s, 0.7).unwrap();
    let mut win = SampleWindow::<f64, N>::new();
    for l in 0..N {
        let (i, v) = sample(l);
        win.push(i, v).unwrap();
    }
    gi.theta = [0.03, 0.004, 0.2, 3.1];
    gi.load(&s, &win).unwrap();
    assert!(gi.vref.unwrap() > 3.0, "the test needs a centred voltage");
    let (k, dk) = PaperRegressionGi::<f64, N, 20>::unit_history(&gi.w);
    gi.residual(k);
    let vref = gi.vref.unwrap();
    gi.order_moves = 2;
    let (dd_z, dr_z) = gi.order_gradient(vref, dk);
    assert!(!gi.derivatives, "the combined path keeps no derivatives");
    gi.order_moves = 0;
    let (dd, dr) = gi.order_gradient(vref, dk);
    assert!(gi.derivatives);
    assert!(dd > 0.0 && dr != 0.0);
    assert!(((dd_z - dd) / dd).abs() < 1e-12, "{dd_z} vs {dd}");
    assert!(((dr_z - dr) / dr).abs() < 1e-10, "{dr_z} vs {dr}");
}

#[test]
fn trial_cost_at_the_current_order_is_the_residual_cost() {
    const N: usize = 64;
    let s = BatterySettings::<f64>::new(1.0, 20);
    let mut gi = PaperRegressionGi::<f64, N, 20>::new(&s, 0.7).unwrap();
    let mut win = SampleWindow::<f64, N>::new();
    for l in 0..N {
        let (i, v) = sample(l);
        win.push(i, v).unwrap();
    }
    gi.theta = [0.03, 0.004, 0.2, 3.1];
    gi.load(&s, &win).unwrap();
    let direct = gi.residual(PaperRegressionGi::<f64, N, 20>::unit_history(&gi.w).0);
    let alpha = gi.w.alpha();
    let trial = gi.trial_cost(alpha).unwrap();
    assert!(
        ((trial - direct) / direct).abs() < 1e-12,
        "{trial} vs {direct}"
    );
    // And at another order, against regressors recomputed there.
    let other = gi.trial_cost(0.55).unwrap();
    gi.w.set_order(0.55).unwrap();
    gi.regressors();
    let there = gi.residual(PaperRegressionGi::<f64, N, 20>::unit_history(&gi.w).0);
    assert!(
        ((other - there) / there).abs() < 1e-12,
        "{other} vs {there}"
    );
}
