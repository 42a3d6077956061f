//! Grünwald–Letnikov differences: against the direct formula, closed forms,
//! the continuous limit, the order derivative and the truncation error.

use estimator_core::frac::GlWeights;
use estimator_core::FracError;
use proptest::prelude::*;

/// |a − b| ≤ atol + rtol·|b|.
fn close(a: f64, b: f64, rtol: f64, atol: f64) -> bool {
    (a - b).abs() <= atol + rtol * b.abs()
}

/// The direct formula with generalized binomials, w_j = (−1)^j C(α, j).
fn direct(alpha: f64, h: f64, mem: usize, x: &[f64], l: usize) -> f64 {
    let mut s = 0.0;
    for j in 0..=l.min(mem - 1) {
        let mut binom = 1.0;
        for i in 0..j {
            binom *= (alpha - i as f64) / (i as f64 + 1.0);
        }
        let sign = if j % 2 == 0 { 1.0 } else { -1.0 };
        s += sign * binom * x[l - j];
    }
    h.powf(-alpha) * s
}

#[test]
fn matches_direct_formula() {
    let x: Vec<f64> = (0..60)
        .map(|i| ((i * 37 % 17) as f64 - 8.0) / 3.0)
        .collect();
    for &alpha in &[0.1, 0.5, 0.7, 1.0, 1.3, 1.9] {
        for &(h, mem) in &[(1.0, 64), (0.1, 10), (2.5, 1), (0.01, 33)] {
            let w = GlWeights::<f64, 64>::new(alpha, h, mem).unwrap();
            for l in 0..x.len() {
                let a = w.difference(&x, l);
                let b = direct(alpha, h, mem, &x, l);
                assert!(
                    close(a, b, 1e-12, 1e-12),
                    "α={alpha} h={h} M={mem} l={l}: {a} vs {b}"
                );
            }
        }
    }
}

#[test]
fn integer_orders_are_backward_differences() {
    let x = [1.0, 4.0, 9.0, 16.0, 25.0];
    let d1 = GlWeights::<f64, 8>::new(1.0, 1.0, 8).unwrap();
    let d2 = GlWeights::<f64, 8>::new(2.0, 0.5, 8).unwrap();
    for l in 1..5 {
        assert!(close(d1.difference(&x, l), x[l] - x[l - 1], 1e-14, 1e-14));
    }
    for l in 2..5 {
        let second = (x[l] - 2.0 * x[l - 1] + x[l - 2]) / 0.25;
        assert!(close(d2.difference(&x, l), second, 1e-13, 1e-13));
    }
}

#[test]
fn unit_step_closed_form() {
    // Σ_{j=0}^{n} w_j(α) = w_n(α − 1): the GL difference of a unit step.
    let step = [1.0; 200];
    for &alpha in &[0.2, 0.5, 0.9, 1.5] {
        let w = GlWeights::<f64, 200>::new(alpha, 1.0, 200).unwrap();
        let wm1 = GlWeights::<f64, 200>::new(alpha - 1.0, 1.0, 200).unwrap();
        for n in 0..200 {
            let lhs = w.difference(&step, n);
            let rhs = wm1.weights()[n];
            assert!(
                close(lhs, rhs, 1e-11, 1e-14),
                "α={alpha} n={n}: {lhs} vs {rhs}"
            );
        }
    }
}

#[test]
fn continuous_limit_first_order() {
    // Δ^α t^p → Γ(p+1)/Γ(p+1−α) t^(p−α) at t = 1, with error O(h).
    const MEM: usize = 1601;
    for &(alpha, p) in &[(0.5, 1.0), (0.7, 2.0), (1.3, 2.0)] {
        let exact = libm::tgamma(p + 1.0) / libm::tgamma(p + 1.0 - alpha);
        let mut errs = Vec::new();
        for &n in &[100usize, 200, 400, 800, 1600] {
            let h = 1.0 / n as f64;
            let x: Vec<f64> = (0..=n).map(|l| (l as f64 * h).powf(p)).collect();
            let w = GlWeights::<f64, MEM>::new(alpha, h, MEM).unwrap();
            errs.push((w.difference(&x, n) - exact).abs());
        }
        for pair in errs.windows(2) {
            let ratio = pair[0] / pair[1];
            // First order: halving h halves the error (ratio → 2).
            assert!(
                (1.8..2.2).contains(&ratio),
                "α={alpha} p={p}: errors {errs:?}"
            );
        }
        assert!(errs[4] < 2e-3, "α={alpha} p={p}: {errs:?}");
    }
}

#[test]
fn order_derivative_matches_finite_difference() {
    let x: Vec<f64> = (0..80)
        .map(|i| (0.3 * i as f64).sin() + 0.1 * i as f64)
        .collect();
    for &alpha in &[0.2, 0.6, 1.1, 1.7] {
        for &(h, mem) in &[(1.0, 80), (0.1, 40), (3.0, 16)] {
            let w = GlWeights::<f64, 80>::new(alpha, h, mem).unwrap();
            let eps = 1e-6;
            let wp = GlWeights::<f64, 80>::new(alpha + eps, h, mem).unwrap();
            let wm = GlWeights::<f64, 80>::new(alpha - eps, h, mem).unwrap();
            for l in 0..x.len() {
                let (d, dd) = w.difference_with_derivative(&x, l);
                assert!(close(d, w.difference(&x, l), 1e-14, 1e-14));
                let fd = (wp.difference(&x, l) - wm.difference(&x, l)) / (2.0 * eps);
                assert!(
                    close(dd, fd, 1e-6, 1e-7),
                    "α={alpha} h={h} l={l}: {dd} vs {fd}"
                );
            }
        }
    }
}

#[test]
fn truncation_error_shrinks_with_memory() {
    // Short memory on a smooth signal: the error against full memory falls
    // monotonically as M grows (numbers reported by `--example truncation`).
    let n = 1000;
    let x: Vec<f64> = (0..n).map(|l| 1.0 + (0.01 * l as f64).sin()).collect();
    let full = GlWeights::<f64, 1000>::new(0.7, 1.0, 1000).unwrap();
    let mut last = f64::INFINITY;
    for &m in &[8usize, 16, 32, 64, 128, 256, 512] {
        let w = GlWeights::<f64, 1000>::new(0.7, 1.0, m).unwrap();
        let err = (500..n)
            .map(|l| (w.difference(&x, l) - full.difference(&x, l)).abs())
            .fold(0.0, f64::max);
        assert!(err < last, "M={m}: {err} !< {last}");
        last = err;
    }
    // The tail of Σ w_j decays like M^(−α): at M = 512 it is below 1 %.
    assert!(last < 0.01, "{last}");
}

#[test]
fn bad_settings_are_typed_errors() {
    assert_eq!(
        GlWeights::<f64, 8>::new(f64::NAN, 1.0, 4).unwrap_err(),
        FracError::NonFiniteOrder
    );
    assert_eq!(
        GlWeights::<f64, 8>::new(0.5, 0.0, 4).unwrap_err(),
        FracError::BadSamplePeriod
    );
    assert_eq!(
        GlWeights::<f64, 8>::new(0.5, -1.0, 4).unwrap_err(),
        FracError::BadSamplePeriod
    );
    assert_eq!(
        GlWeights::<f64, 8>::new(0.5, 1.0, 9).unwrap_err(),
        FracError::BadMemory {
            requested: 9,
            capacity: 8
        }
    );
    assert!(GlWeights::<f64, 8>::new(0.5, 1.0, 0).is_err());
    let mut w = GlWeights::<f32, 8>::new(0.5, 1.0, 4).unwrap();
    assert!(w.set_order(f32::INFINITY).is_err());
    assert_eq!(
        w.alpha(),
        0.5,
        "a failed update leaves the weights unchanged"
    );
    // Out-of-range index: zero, not a panic.
    assert_eq!(w.difference(&[1.0, 2.0], 5), 0.0);
}

#[test]
fn f32_agrees_with_f64() {
    let x64: Vec<f64> = (0..256)
        .map(|i| ((i * 13 % 29) as f64 - 14.0) / 7.0)
        .collect();
    let x32: Vec<f32> = x64.iter().map(|&v| v as f32).collect();
    let w64 = GlWeights::<f64, 64>::new(0.7, 1.0, 64).unwrap();
    let w32 = GlWeights::<f32, 64>::new(0.7, 1.0, 64).unwrap();
    for l in 0..256 {
        let a = w32.difference(&x32, l) as f64;
        let b = w64.difference(&x64, l);
        assert!(close(a, b, 1e-5, 1e-5), "l={l}: {a} vs {b}");
    }
}

proptest! {
    #[test]
    fn weights_obey_recursion_and_sum(alpha in 0.01f64..1.99, mem in 1usize..128) {
        let w = GlWeights::<f64, 128>::new(alpha, 1.0, mem).unwrap();
        let wt = w.weights();
        prop_assert_eq!(wt.len(), mem);
        prop_assert_eq!(wt[0], 1.0);
        // For 0 < α < 1 all w_j (j ≥ 1) are negative and Σ w_j > 0.
        if alpha < 1.0 {
            prop_assert!(wt[1..].iter().all(|&x| x < 0.0));
            prop_assert!(wt.iter().sum::<f64>() > 0.0);
        }
        let wm1 = GlWeights::<f64, 128>::new(alpha - 1.0, 1.0, mem).unwrap();
        let s: f64 = wt.iter().sum();
        prop_assert!((s - wm1.weights()[mem - 1]).abs() < 1e-10);
    }

    #[test]
    fn difference_is_linear(alpha in 0.05f64..1.95, a in -3.0f64..3.0, l in 0usize..40) {
        let x: Vec<f64> = (0..40).map(|i| (i as f64 * 0.37).cos()).collect();
        let z: Vec<f64> = (0..40).map(|i| (i as f64 * 0.11).sin()).collect();
        let xz: Vec<f64> = x.iter().zip(&z).map(|(p, q)| a * p + q).collect();
        let w = GlWeights::<f64, 16>::new(alpha, 0.5, 16).unwrap();
        let lhs = w.difference(&xz, l);
        let rhs = a * w.difference(&x, l) + w.difference(&z, l);
        prop_assert!((lhs - rhs).abs() < 1e-10 * (1.0 + rhs.abs()));
    }
}
