//! Tests of the §6.2 regression and its 2S-OP-GI iteration.

use super::projected::solve3;
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

/// The projected iteration (θ by least squares, the order by a Gauss–Newton
/// step on the cost minimized over θ) ends at the regression's minimum:
/// the cost with θ solved is no lower a step of the order either side,
/// no lower than the paper's gradient iteration gets in 2000 iterations,
/// and it gets there in a few iterations.
#[test]
fn the_projected_iteration_reaches_the_regressions_minimum() {
    const N: usize = 256;
    const M: usize = 20;
    let s = BatterySettings::<f64>::new(1.0, M);
    // The model's own voltage with memory M, and a millivolt of
    // deterministic noise: the minimum is inside the order's bounds.
    let p = crate::battery::CellParameters::<f64>::cell_18650();
    let mut w = GlWeights::<f64, M>::new(p.alpha, 1.0, M).unwrap();
    let current: [f64; N] = core::array::from_fn(|l| sample(l).0);
    let (mut up, mut v) = ([0.0; N], [0.0; N]);
    crate::battery::simulate::simulate(&p, &mut w, &current, |_| p.u_oc, &mut up, &mut v).unwrap();
    let mut win = SampleWindow::<f64, N>::new();
    for l in 0..N {
        let noise = 1e-3 * ((l as f64 * 12.9898).sin() * 43_758.545).fract();
        win.push(current[l], v[l] + noise).unwrap();
    }
    let mut gi = PaperRegressionGi::<f64, N, M>::new(&s, 0.5).unwrap();
    let mut last = None;
    for _ in 0..30 {
        let it = gi.iterate_projected(&s, &win).unwrap();
        last = Some(it);
        if it.converged {
            break;
        }
    }
    let last = last.unwrap();
    assert!(last.converged, "not converged after {} iterations", last.k);
    assert!(last.k <= 15, "{} iterations", last.k);
    let profiled = |alpha: f64| {
        let mut g = gi.clone();
        g.w.set_order(alpha).unwrap();
        g.regressors();
        let (k, _) = PaperRegressionGi::<f64, N, M>::unit_history(&g.w);
        g.project(&g.di, &g.hv, k).unwrap().cost
    };
    let alpha = gi.alpha();
    assert!(
        alpha > s.alpha_min + 0.01 && alpha < s.alpha_max - 0.01,
        "α {alpha}"
    );
    let here = profiled(alpha);
    assert!(
        ((here - last.cost) / here).abs() < 1e-12,
        "{here} vs {}",
        last.cost
    );
    for d in [-1e-2, -1e-3, 1e-3, 1e-2] {
        assert!(profiled(alpha + d) >= here, "lower at α {alpha} + {d}");
    }
    // θ is the least-squares one: no gradient step lowers the cost.
    let (k, _) = PaperRegressionGi::<f64, N, M>::unit_history(&gi.w);
    let mut stepped = gi.clone();
    stepped.gradient_step(k, gi.vref.unwrap());
    assert!(stepped.residual(k) >= here * (1.0 - 1e-9));
    // The paper's iteration from the same start stays above it.
    let mut paper = PaperRegressionGi::<f64, N, M>::new(&s, 0.5).unwrap();
    let mut cost = f64::INFINITY;
    for _ in 0..2000 {
        cost = paper.iterate(&s, &win).unwrap().cost;
    }
    assert!(cost >= here * (1.0 - 1e-9), "{cost} below {here}");
}

/// The projection's 3×3 solve: exact on a regular matrix, `None` on a
/// singular one (then the iteration takes the gradient step instead).
#[test]
fn the_projections_solve_refuses_a_singular_matrix() {
    let a: [[f64; 3]; 3] = [[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [3.0, 6.0, 10.0]];
    assert!(solve3(a, [1.0, 2.0, 3.0]).is_none());
    let a: [[f64; 3]; 3] = [[4.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 2.0]];
    let x = solve3(a, [1.0, 2.0, 3.0]).unwrap();
    for (row, want) in a.iter().zip([1.0f64, 2.0, 3.0]) {
        let b = row[0] * x[0] + row[1] * x[1] + row[2] * x[2];
        assert!((b - want).abs() < 1e-14, "{x:?}");
    }
}
