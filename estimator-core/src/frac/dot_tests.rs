//! Tests of the tap sums and the block kernels against the plain sums.

use super::kernels::{block_sums_far, block_sums_pair_far, FAR, FAR_SAMPLES};
use super::{
    block_sums, block_sums2, block_sums8, block_sums_lanes, block_sums_pair, block_sums_pair_lanes,
    dot_rev, dot_rev2, BLOCK,
};

#[test]
fn tap_sums_equal_the_plain_sum() {
    for n in 0..14 {
        let w: Vec<f64> = (0..n).map(|k| 1.0 / (k as f64 + 1.5)).collect();
        let dw: Vec<f64> = (0..n).map(|k| (k as f64).sin()).collect();
        // x longer than w: only its last n samples take part.
        let x: Vec<f64> = (0..n + 3).map(|k| (k as f64 * 0.7).cos()).collect();
        let plain = |w: &[f64]| -> f64 { (0..n).map(|k| w[k] * x[n + 2 - k]).sum() };
        assert!((dot_rev(&w, &x) - plain(&w)).abs() < 1e-14, "n = {n}");
        let (a, b) = dot_rev2(&w, &dw, &x);
        assert!(
            (a - plain(&w)).abs() < 1e-14 && (b - plain(&dw)).abs() < 1e-14,
            "n = {n}"
        );
    }
}

#[test]
fn block_sums_are_bit_identical_to_one_row_at_a_time() {
    for m in 1..20 {
        let w: Vec<f64> = (0..m).map(|k| 1.0 / (k as f64 + 1.5)).collect();
        let dw: Vec<f64> = (0..m).map(|k| (k as f64 * 1.3).sin()).collect();
        let xs: Vec<f64> = (0..m + 7)
            .map(|k| (k as f64 * 0.7).cos() * 1e3 + 0.1)
            .collect();
        let ys: Vec<f64> = xs.iter().map(|x| x.sin() - 0.3).collect();
        let s = block_sums(&w, &xs);
        let (s2, d2) = block_sums2(&w, &dw, &xs);
        for b in 0..BLOCK {
            let row = &xs[..m + b];
            assert_eq!(s[b].to_bits(), dot_rev(&w, row).to_bits(), "m {m} row {b}");
            let (a, d) = dot_rev2(&w, &dw, row);
            assert_eq!(s2[b].to_bits(), a.to_bits(), "m {m} row {b}");
            assert_eq!(d2[b].to_bits(), d.to_bits(), "m {m} row {b}");
            let (p, q) = block_sums_pair(&w, &xs, &ys);
            assert_eq!(p[b].to_bits(), dot_rev(&w, row).to_bits(), "m {m} row {b}");
            assert_eq!(
                q[b].to_bits(),
                dot_rev(&w, &ys[..m + b]).to_bits(),
                "m {m} row {b}"
            );
        }
        let (p, q) = block_sums_pair_lanes::<f64, 8>(&w, &xs, &ys);
        let single = block_sums_lanes::<f64, 8>(&w, &xs);
        let eight = block_sums8(&w, &xs);
        for b in 0..8 {
            let row = &xs[..m + b];
            assert_eq!(
                eight[b].to_bits(),
                dot_rev(&w, row).to_bits(),
                "m {m} row {b}"
            );
            assert_eq!(
                single[b].to_bits(),
                dot_rev(&w, row).to_bits(),
                "m {m} row {b}"
            );
            assert_eq!(p[b].to_bits(), dot_rev(&w, row).to_bits(), "m {m} row {b}");
            assert_eq!(
                q[b].to_bits(),
                dot_rev(&w, &ys[..m + b]).to_bits(),
                "m {m} row {b}"
            );
        }
    }
}

/// The kernels written out for the default memory's [`FAR`] taps give
/// the loops' sums, bit for bit, in f32 and f64 (and so each row's
/// [`dot_rev`]): a group of taps out of place or out of order fails.
#[test]
fn the_written_out_kernels_are_the_loops() {
    fn check<T: crate::real::Real + core::fmt::Debug>(cast: impl Fn(f64) -> T) {
        let w: [T; FAR] = core::array::from_fn(|k| cast(1.0 / (k as f64 + 1.5) - 0.01 * k as f64));
        let xs: [T; FAR_SAMPLES] =
            core::array::from_fn(|k| cast((k as f64 * 0.7).cos() * 1e3 + 0.1 * k as f64));
        let ys: [T; FAR_SAMPLES] = core::array::from_fn(|k| cast((k as f64 * 0.37).sin() - 0.3));
        let s = block_sums_far(&w, &xs);
        let (p, q) = block_sums_pair_far(&w, &xs, &ys);
        let (a, b) = block_sums_pair(&w, &xs, &ys);
        assert_eq!(s, block_sums(&w, &xs));
        assert_eq!((p, q), (a, b));
        for k in 0..BLOCK {
            assert_eq!(s[k], dot_rev(&w, &xs[..FAR + k]), "row {k}");
            assert_eq!(q[k], dot_rev(&w, &ys[..FAR + k]), "row {k}");
        }
    }
    check::<f64>(|v| v);
    check::<f32>(|v| v as f32);
}

/// The public block paths (dispatched to AVX2 on x86-64 hosts
/// that have them) against [`GlWeights::difference`] and
/// [`GlWeights::difference_with_derivative`] row by row, bit for bit,
/// over the short first rows, whole blocks and a ragged tail, in f64 and
/// f32.
#[test]
fn row_sums_are_bit_identical_to_one_row_at_a_time() {
    use super::GlWeights;
    fn check<T: crate::real::Real + core::fmt::Debug>(cast: impl Fn(f64) -> T) {
        for (m, n) in [
            (1, 9),
            (5, 40),
            (16, 61),
            (37, 150),
            (64, 40),
            (64, 64 + 3 * 16 + 5),
        ] {
            let w = GlWeights::<T, 64>::new(cast(0.63), cast(0.5), m).unwrap();
            let x: Vec<T> = (0..n)
                .map(|k| cast((k as f64 * 0.7).cos() * 3.0 + 0.1))
                .collect();
            let y: Vec<T> = (0..n).map(|k| cast((k as f64 * 0.3).sin() - 0.2)).collect();
            let ln_h = w.ln_h();
            let mut seen = 0;
            w.for_each_difference_pair(&x, &y, 2..n, |l, a, b| {
                assert_eq!(a, w.difference(&x, l), "pair x, m {m} row {l}");
                assert_eq!(b, w.difference(&y, l), "pair y, m {m} row {l}");
                seen += 1;
            });
            w.for_each_difference(&x, 2..n, |l, a| {
                assert_eq!(a, w.difference(&x, l), "single, m {m} row {l}");
                seen += 1;
            });
            w.for_each_weight_derivative_pair(&x, &y, 2..n, |l, a, b| {
                let (dx, dy) = (w.difference(&x, l), w.difference(&y, l));
                assert_eq!(
                    a - ln_h * dx,
                    w.difference_with_derivative(&x, l).1,
                    "m {m} row {l}"
                );
                assert_eq!(
                    b - ln_h * dy,
                    w.difference_with_derivative(&y, l).1,
                    "m {m} row {l}"
                );
                seen += 1;
            });
            w.for_each_weight_derivative(&y, 2..n, |l, a| {
                let dy = w.difference(&y, l);
                assert_eq!(
                    a - ln_h * dy,
                    w.difference_with_derivative(&y, l).1,
                    "m {m} row {l}"
                );
                seen += 1;
            });
            assert_eq!(seen, 4 * (n - 2), "m {m}: every row once");
        }
    }
    check::<f64>(|v| v);
    check::<f32>(|v| v as f32);
}
