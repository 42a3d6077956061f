//! The FFT solver against the direct recursion: the same values within
//! 1e−9 of the largest, from rest and from a history, with the memory the
//! whole window and shorter, and the refinement's fits the same.

use super::*;
use estimator_core::battery::output_error::OutputErrorRefinement;
use estimator_core::battery::BatterySettings;
use estimator_core::window::SampleWindow;

/// A drive with steps, rests and a ramp (not periodic, so nothing cancels).
fn drive(l: usize) -> f64 {
    let phase = (l / 97) % 5;
    [3.0, 0.0, -2.5, 0.0, 1.0][phase] + 1e-4 * (l % 13) as f64
}

/// A rounding of the transforms (`ε` of the largest value) unscaled from
/// the circle by `r^{−S/2}` (`S` the transform size, at least twice the
/// rows): how far two solutions from rest that round differently may lie
/// apart (7·10⁻¹², relative to the largest value).
const UNSCALED_ROUNDING: f64 = f64::EPSILON / CIRCLE_FOLD_SQRT;

/// `√(r^S)`.
const CIRCLE_FOLD_SQRT: f64 = 3.162_277_660_168_379_4e-5;

#[test]
fn the_fold_constant_is_its_square_root() {
    assert!((CIRCLE_FOLD_SQRT * CIRCLE_FOLD_SQRT / super::circle::CIRCLE_FOLD - 1.0).abs() < 1e-15);
}

/// Largest absolute difference over the largest absolute value.
fn relative(a: &[f64], b: &[f64]) -> f64 {
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let worst = a
        .iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    worst / scale
}

/// `n` samples of a solution's history: its first `warm` a scaled
/// [`drive`], the rest zero (to be solved).
fn history(n: usize, warm: usize) -> Vec<f64> {
    (0..n)
        .map(|l| if l < warm { 0.01 * drive(l) } else { 0.0 })
        .collect()
}

/// One solver's run: `x`, `E`, the pair, the order derivative's sums.
type Run<'a> = dyn FnMut(&mut [f64], &mut [f64], &mut [f64], &mut [f64], &mut [f64]) + 'a;

/// Runs both solvers' `filter` (with `seen`) and `filter_pair` on `n` rows,
/// memory `m`, order `alpha`, `a`, history of `warm` rows; returns the
/// worst relative difference over every output.
fn compare<const MEM: usize>(n: usize, m: usize, alpha: f64, a: f64, warm: usize) -> f64 {
    let w = GlWeights::<f64, MEM>::new(alpha, 0.5, m).unwrap();
    let history = history(n, warm);
    let run = |solver: &mut Run| {
        let (mut x, mut e, mut p, mut q, mut d) = (
            history.clone(),
            vec![0.0; n],
            history.clone(),
            history.iter().map(|v| -v).collect::<Vec<_>>(),
            vec![0.0; n],
        );
        solver(&mut x, &mut e, &mut p, &mut q, &mut d);
        [x, e, p, q, d]
    };
    let direct = run(&mut |x, e, p, q, d| {
        let mut s = GlRecursion;
        s.filter(w.weights(), a, warm, x, drive, |l, xv, h| e[l] = xv + h);
        s.filter_pair(w.weights(), a, warm, p, q, |l| (drive(l), -2.0 * drive(l)));
        s.weight_derivative(&w, x, warm..n, |l, v| d[l] = v);
    });
    let mut fft = FftBranch::default();
    let fast = run(&mut |x, e, p, q, d| {
        fft.filter(w.weights(), a, warm, x, drive, |l, xv, h| e[l] = xv + h);
        fft.filter_pair(w.weights(), a, warm, p, q, |l| (drive(l), -2.0 * drive(l)));
        fft.weight_derivative(&w, x, warm..n, |l, v| d[l] = v);
    });
    direct
        .iter()
        .zip(&fast)
        .map(|(a, b)| relative(a, b))
        .fold(0.0, f64::max)
}

#[test]
fn from_rest_with_the_full_memory_it_is_the_direct_recursion() {
    for (alpha, a) in [
        (0.6, 3.0),
        (0.95, 40.0),
        (0.2, 0.01),
        (1.0, 1e3),
        (0.5, 1e4),
        (0.3, 1e-4),
    ] {
        let worst = compare::<4096>(4096, 4096, alpha, a, 0);
        assert!(worst < 1e-9, "α {alpha}, a {a}: {worst:e}");
    }
}

#[test]
fn from_a_history_with_a_shorter_memory_it_is_the_direct_recursion() {
    for (n, m, warm) in [(3000, 1000, 999), (2500, 2500, 700), (1500, 200, 0)] {
        let worst = compare::<3000>(n, m, 0.7, 5.0, warm);
        assert!(worst < 1e-9, "n {n}, m {m}, warm {warm}: {worst:e}");
    }
}

#[test]
fn a_long_record_is_the_direct_recursion() {
    // (On the worker thread: the weights of 65 536 taps are built on the
    // stack.)
    let worst = crate::worker::on_worker(|| {
        Ok::<_, crate::Error>(compare::<65536>(65536, 65536, 0.8, 20.0, 0))
    })
    .unwrap();
    assert!(worst < 1e-9, "{worst:e}");
}

#[test]
fn below_the_direct_taps_it_is_the_direct_recursion_bit_for_bit() {
    assert_eq!(compare::<512>(512, DIRECT_TAPS - 1, 0.6, 3.0, 0), 0.0);
    assert_eq!(compare::<512>(DIRECT_TAPS - 1, 512, 0.6, 3.0, 0), 0.0);
}

#[test]
fn the_inverse_series_inverts() {
    let mut s = FftBranch::default();
    let (mut w, mut dw) = (vec![0.0; 1000], vec![0.0; 1000]);
    fill_weights(0.5, &mut w, &mut dw);
    let d: Vec<f64> = w
        .iter()
        .enumerate()
        .map(|(j, v)| 2.0 * v + f64::from(j == 0))
        .collect();
    let g = s.inverse_series(&d, 1000);
    for l in 0..1000 {
        let c: f64 = (0..=l).map(|j| d[j] * g[l - j]).sum();
        let want = f64::from(l == 0);
        assert!((c - want).abs() < 1e-13, "row {l}: {c}");
    }
}

#[test]
fn a_refinement_on_it_fits_as_the_direct_one() {
    crate::worker::on_worker(|| {
        refinement_fits_as_the_direct_one();
        Ok::<_, crate::Error>(())
    })
    .unwrap();
}

fn refinement_fits_as_the_direct_one() {
    const N: usize = 3000;
    let truth = CellParameters::<f64>::cell_18650();
    let current: Vec<f64> = (0..N).map(drive).collect();
    let v = FftBranch::default().simulate(&truth, 1.0, &current);
    let mut win = Box::new(SampleWindow::<f64, N>::new());
    for (l, (&i, &u)) in current.iter().zip(&v).enumerate() {
        win.push(i, u + 1e-3 * ((l * 7919 % 101) as f64 / 50.0 - 1.0))
            .unwrap();
    }
    let s = BatterySettings::new(1.0, N);
    let start = CellParameters {
        r_i: 0.01,
        r_ct: 0.03,
        q: 200.0,
        alpha: 0.6,
        u_oc: 3.6,
        ..truth
    };
    let mut direct = Box::new(OutputErrorRefinement::<f64, N, N>::new(&s, start).unwrap());
    let mut fast = Box::new(OutputErrorRefinement::<f64, N, N, FftBranch>::new(&s, start).unwrap());
    for k in 0..30 {
        let (a, b) = (
            direct.iterate(&s, &*win).unwrap(),
            fast.iterate(&s, &*win).unwrap(),
        );
        assert_eq!(a.accepted, b.accepted, "iteration {k}");
        assert!(
            (a.cost / b.cost - 1.0).abs() < 1e-9,
            "iteration {k}: {} {}",
            a.cost,
            b.cost
        );
        if a.converged && b.converged {
            break;
        }
    }
    let (a, b) = (direct.cell(), fast.cell());
    for (x, y) in [
        (a.r_i, b.r_i),
        (a.r_ct, b.r_ct),
        (a.q, b.q),
        (a.alpha, b.alpha),
    ] {
        assert!((x / y - 1.0).abs() < 1e-7, "{x} {y}");
    }
    assert!((a.r_ct / truth.r_ct - 1.0).abs() < 0.02);
}

#[test]
fn solve_without_the_history_sums_is_filter() {
    const N: usize = 3000;
    let w = GlWeights::<f64, N>::new(0.65, 1.0, 2000).unwrap();
    let warm = 400;
    let start: Vec<f64> = (0..N)
        .map(|l| if l < warm { 0.02 * drive(l) } else { 0.0 })
        .collect();
    let (mut direct, mut quiet, mut full) = (start.clone(), start.clone(), start);
    GlRecursion.solve(w.weights(), 4.0, warm, &mut direct, drive);
    let mut fft = FftBranch::default();
    fft.solve(w.weights(), 4.0, warm, &mut quiet, drive);
    fft.filter(w.weights(), 4.0, warm, &mut full, drive, |_, _, _| {});
    assert_eq!(quiet, full);
    assert!(relative(&direct, &quiet) < 1e-9);
}

/// The unit branch's derivatives with respect to `ln τ` and α are those
/// of central differences of [`FftBranch::simulate`] (within 1e−6 of the
/// largest, the differences' own error), and the branch is `simulate`'s
/// polarization per ohm.
#[test]
fn the_unit_branch_derivatives_are_central_differences() {
    let n = 3000;
    let h = 2.0;
    let current: Vec<f64> = (0..n).map(drive).collect();
    let (ln_tau, alpha) = (3.0f64, 0.63);
    let unit = |ln_tau: f64, alpha: f64| {
        let cell = CellParameters {
            r_i: 0.0,
            r_ct: 1.0,
            q: ln_tau.exp(),
            alpha,
            u_oc: 0.0,
            bv_a: 0.0,
            bv_i0: 1.0,
        };
        FftBranch::default().simulate(&cell, h, &current)
    };
    let [y, d_tau, d_alpha] =
        FftBranch::default().unit_branch_with_derivatives(ln_tau, alpha, h, &current);
    // `simulate` solves on the circle, the unit branch on the unit circle:
    // the same to the rounding unscaled from the circle.
    let rel = relative(&unit(ln_tau, alpha), &y);
    assert!(rel < UNSCALED_ROUNDING, "{rel:e}");
    let e = 1e-5;
    let central = |plus: Vec<f64>, minus: Vec<f64>| -> Vec<f64> {
        plus.iter()
            .zip(&minus)
            .map(|(p, m)| (p - m) / (2.0 * e))
            .collect()
    };
    let fd_tau = central(unit(ln_tau + e, alpha), unit(ln_tau - e, alpha));
    let fd_alpha = central(unit(ln_tau, alpha + e), unit(ln_tau, alpha - e));
    assert!(
        relative(&fd_tau, &d_tau) < 1e-6,
        "{}",
        relative(&fd_tau, &d_tau)
    );
    assert!(
        relative(&fd_alpha, &d_alpha) < 1e-6,
        "{}",
        relative(&fd_alpha, &d_alpha)
    );
}

/// Every transform holds a linear convolution of two `n`-value sequences
/// (at least `2n`), is even with no prime factor above 5, and is never
/// longer than the power of two; and it is the least such size.
#[test]
fn transform_sizes_are_five_smooth_and_least() {
    let smooth = |mut m: usize| {
        for p in [2, 3, 5] {
            while m.is_multiple_of(p) {
                m /= p;
            }
        }
        m == 1
    };
    for n in (1..5000).chain([24_400, 48_800, 65_536, 100_000]) {
        let s = transform_size(n);
        assert!(s >= 2 * n && s.is_multiple_of(2) && smooth(s), "{n}: {s}");
        assert!(s <= (2 * n).next_power_of_two(), "{n}: {s}");
        assert!(
            !(2 * n..s).any(|m| m.is_multiple_of(2) && smooth(m)),
            "{n}: {s} is not the least"
        );
    }
    // The Panasonic test's 48 800 samples: 98 304 = 2^15·3, not 131 072.
    assert_eq!(transform_size(48_800), 98_304);
}

/// From rest with the whole memory, `rest_sums` gives `g ∗ E` and
/// `ℓ ∗ (g ∗ E)` as the direct recursion and the direct sum do; with a
/// shorter memory it declines.
#[test]
fn the_rest_sums_are_the_recursions_they_replace() {
    const N: usize = 2000;
    let (alpha, a) = (0.7, 5.0);
    let w = GlWeights::<f64, N>::new(alpha, 1.0, N).unwrap();
    let (mut x, mut e) = (vec![0.0; N], vec![0.0; N]);
    GlRecursion.filter(w.weights(), a, 0, &mut x, drive, |l, xl, h| e[l] = xl + h);
    let mut y_ref = vec![0.0; N];
    GlRecursion.solve(w.weights(), a, 0, &mut y_ref, |l| e[l]);
    let z_ref: Vec<f64> = (0..N)
        .map(|l| (1..=l).map(|k| -y_ref[l - k] / k as f64).sum())
        .collect();
    let mut fft = FftBranch::default();
    let mut xf = vec![0.0; N];
    fft.filter(w.weights(), a, 0, &mut xf, drive, |_, _, _| {});
    let (mut y, mut z) = (vec![0.0; N], vec![0.0; N]);
    assert!(fft.rest_sums(w.weights(), a, &xf, &mut y, &mut z));
    assert!(relative(&y_ref, &y) < 1e-9, "{:e}", relative(&y_ref, &y));
    assert!(relative(&z_ref, &z) < 1e-9, "{:e}", relative(&z_ref, &z));
    let short = GlWeights::<f64, N>::new(alpha, 1.0, N / 2).unwrap();
    assert!(!fft.rest_sums(short.weights(), a, &xf, &mut y, &mut z));
}

/// The series sine and cosine of the circle's evaluation against libm's,
/// over `|x| ≤ π/2`: within an ulp of each value (relative; cos near π/2
/// is small and must not lose digits to cancellation).
#[test]
fn the_series_sine_is_libms() {
    let mut worst = 0.0f64;
    let n = 200_001;
    for k in 0..n {
        let x = std::f64::consts::FRAC_PI_2 * (2.0 * k as f64 / (n - 1) as f64 - 1.0);
        let (s, c) = super::circle::sin_cos_half_pi(x);
        let (ls, lc) = x.sin_cos();
        for (a, b) in [(s, ls), (c, lc)] {
            if b != 0.0 {
                worst = worst.max(((a - b) / b).abs());
            }
        }
    }
    assert!(worst <= 2.0 * f64::EPSILON, "{worst:e}");
}

/// The series exponential of the circle's evaluation against libm's,
/// over `|x| ≤ 700`: within 2 ulp of each value (relative).
#[test]
fn the_series_exponential_is_libms() {
    let mut worst = 0.0f64;
    let n = 400_001;
    for k in 0..n {
        let x = 700.0 * (2.0 * k as f64 / (n - 1) as f64 - 1.0);
        let (a, b) = (super::circle::exp_series(x), x.exp());
        worst = worst.max(((a - b) / b).abs());
    }
    assert!(worst <= 2.0 * f64::EPSILON, "{worst:e}");
}

/// The circle's `1/(1 + a·(1 − z)^α)` is the same to the bit with the
/// processor's AVX2 as without it, and within 4 ulp of the values libm's
/// `exp` and `sin_cos` give, at orders from 0.05 to 1 and `a` from
/// 2.5·10⁻³ to 40.
#[test]
fn the_circle_is_the_same_with_and_without_avx2() {
    let c = super::Circle::of(1 << 16);
    let mut worst = 0.0f64;
    for alpha in [0.05, 0.3, 0.589, 0.97, 1.0] {
        for a in [2.5e-3, 0.7, 40.0] {
            let (mut dispatched, mut plain) = (Vec::new(), Vec::new());
            c.inverse_at_points(alpha, a, &mut dispatched);
            super::circle::inverse_at_points_any(&c.ln_modulus, &c.arg, alpha, a, &mut plain);
            assert_eq!(dispatched.len(), c.ln_modulus.len());
            assert!(
                dispatched
                    .iter()
                    .zip(&plain)
                    .all(|(x, y)| x.re.to_bits() == y.re.to_bits()
                        && x.im.to_bits() == y.im.to_bits())
            );
            for ((v, &l), &t) in dispatched.iter().zip(&c.ln_modulus).zip(&c.arg) {
                let m = a * (alpha * l).exp();
                let (sn, cs) = (alpha * t).sin_cos();
                let libm = (Complex::new(1.0, 0.0) + Complex::new(m * cs, m * sn)).inv();
                worst = worst.max((v - libm).norm() / libm.norm());
            }
        }
    }
    assert!(worst <= 4.0 * f64::EPSILON, "{worst:e}");
}

#[test]
fn a_drive_proportional_to_the_last_takes_its_spectrum_and_the_same_values() {
    const N: usize = 3000;
    let w = GlWeights::<f64, N>::new(0.7, 1.0, N).unwrap();
    let alone = |scale: f64| {
        let mut x = vec![0.0; N];
        FftBranch::default().solve(w.weights(), 2.0, 0, &mut x, |l| scale * drive(l));
        x
    };
    // One solver through R_ct·I at three R_ct, then a drive of another
    // shape: each as a fresh solver gives it (to the transforms' rounding,
    // unscaled from the circle).
    let mut kept = FftBranch::default();
    for scale in [0.031, 0.0457, -2.0e-3] {
        let mut x = vec![0.0; N];
        kept.solve(w.weights(), 2.0, 0, &mut x, |l| scale * drive(l));
        let fresh = alone(scale);
        assert!(
            relative(&fresh, &x) < UNSCALED_ROUNDING,
            "{scale}: {:e}",
            relative(&fresh, &x)
        );
        assert_eq!(
            kept.rest_drive.of[7],
            0.031 * drive(7),
            "the first drive is kept"
        );
    }
    let other = |l: usize| drive(l) + if l > 1000 { 0.5 } else { 0.0 };
    let mut x = vec![0.0; N];
    kept.solve(w.weights(), 2.0, 0, &mut x, other);
    let mut fresh = vec![0.0; N];
    FftBranch::default().solve(w.weights(), 2.0, 0, &mut fresh, other);
    assert_eq!(x, fresh, "a drive of another shape is transformed");
    assert_eq!(kept.rest_drive.of[1001], other(1001));
}

/// A solver reset after use (`BranchSolver::reset`, as a refinement
/// started again in place resets it) gives what a new one does, bit for
/// bit, though its drive, weights and inverse were kept: a drive
/// proportional to the forgotten one is transformed, not scaled; and it
/// keeps its buffers' allocations.
#[test]
fn a_reset_solver_computes_what_a_new_one_does() {
    const N: usize = 3000;
    let w = GlWeights::<f64, N>::new(0.7, 1.0, N).unwrap();
    let u = GlWeights::<f64, N>::new(0.55, 1.0, N).unwrap();
    let run = |b: &mut FftBranch, w: &GlWeights<f64, N>, scale: f64| {
        let (mut x, mut e) = (vec![0.0; N], vec![0.0; N]);
        b.filter(
            w.weights(),
            2.0,
            0,
            &mut x,
            |l| scale * drive(l),
            |l, xl, h| e[l] = xl + h,
        );
        let (mut y, mut z) = (vec![0.0; N], vec![0.0; N]);
        assert!(b.rest_sums(w.weights(), 2.0, &x, &mut y, &mut z));
        [x, e, y, z]
    };
    let mut used = FftBranch::default();
    run(&mut used, &w, 0.031);
    let capacity = used.rest_drive.hat.capacity();
    assert!(capacity > 0 && !used.rest_drive.of.is_empty());
    used.reset();
    assert!(used.rest_drive.of.is_empty() && used.inverse_key.is_none());
    assert_eq!(
        used.rest_drive.hat.capacity(),
        capacity,
        "the allocation is kept"
    );
    for (weights, scale) in [(&w, 0.0457), (&u, 0.0457)] {
        assert_eq!(
            run(&mut used, weights, scale),
            run(&mut FftBranch::default(), weights, scale)
        );
        used.reset();
    }
}

#[test]
fn proportion_is_a_multiple_within_a_few_roundings_or_none() {
    let d: Vec<f64> = (0..500).map(drive).collect();
    let peak = (0..500)
        .max_by(|&i, &j| d[i].abs().total_cmp(&d[j].abs()))
        .unwrap();
    let r = [0.0123, 0.0456];
    let x: Vec<f64> = d.iter().map(|v| r[1] * v).collect();
    let of: Vec<f64> = d.iter().map(|v| r[0] * v).collect();
    let c = proportion(&of, peak, &x).expect("a multiple");
    assert!((c - r[1] / r[0]).abs() <= 2.0 * f64::EPSILON * c);
    let mut off = x.clone();
    off[250] *= 1.0 + 1e-12;
    assert_eq!(proportion(&of, peak, &off), None, "one value off the line");
    off[250] = f64::NAN;
    assert_eq!(proportion(&of, peak, &off), None, "a NaN");
    assert_eq!(proportion(&of, peak, &x[..499]), None, "another length");
    assert_eq!(proportion(&of, 500, &x[..]), None, "no peak");
    assert_eq!(
        proportion(&vec![0.0; 500], peak, &x),
        None,
        "a zero drive kept"
    );
    assert_eq!(
        proportion(&of, peak, &vec![0.0; 500]),
        Some(0.0),
        "a zero drive"
    );
}

/// The FFT tap sums against the direct kernels: single and pair, rows from
/// the first (fewer taps) and from the full memory, weights and sequences
/// changed between calls (no spectrum reused for other values), within
/// 1e−13 of the largest sum; and the direct fallbacks bit for bit.
#[test]
fn fft_sums_are_the_direct_sums() {
    use estimator_core::frac::{DirectSums, TapSums};
    let mut fast = FftSums::default();
    for (n, m, alpha, start) in [
        (4000, 256, 0.6, 255),
        (4000, 256, 0.61, 255),
        (4000, 256, 0.6, 0),
        (8192, 256, 0.17, 255),
        (3000, 64, 0.9, 100),
        (3000, 4096, 0.5, 0),
        (1000, 999, 0.3, 998),
    ] {
        let w = GlWeights::<f64, 4096>::new(alpha, 2.0, m).unwrap();
        let x: Vec<f64> = (0..n).map(drive).collect();
        let y: Vec<f64> = (0..n).map(|l| 0.05 * drive(l + 31) - 0.02).collect();
        for taps in [w.weights(), w.weight_derivatives()] {
            let (mut d, mut f) = (vec![0.0; n], vec![0.0; n]);
            let (mut dy, mut fy) = (vec![0.0; n], vec![0.0; n]);
            DirectSums.pair(taps, &x, &y, start..n, |l, a, b| (d[l], dy[l]) = (a, b));
            fast.pair(taps, &x, &y, start..n, |l, a, b| (f[l], fy[l]) = (a, b));
            assert!(relative(&d, &f) < 1e-13, "pair x n {n} m {m} α {alpha}");
            assert!(relative(&dy, &fy) < 1e-13, "pair y n {n} m {m} α {alpha}");
            let mut s = vec![0.0; n];
            fast.single(taps, &y, start..n, |l, a| s[l] = a);
            assert!(relative(&dy, &s) < 1e-13, "single n {n} m {m} α {alpha}");
        }
    }
    // Few taps, few rows, a value not finite: the direct kernels, bit for bit.
    let w = GlWeights::<f64, 256>::new(0.5, 1.0, 256).unwrap();
    let short = GlWeights::<f64, 256>::new(0.5, 1.0, 16).unwrap();
    let mut x: Vec<f64> = (0..2000).map(drive).collect();
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let mut check = |taps: &[f64], x: &[f64], rows: Range<usize>| {
        let (mut d, mut f) = (vec![0.0; x.len()], vec![0.0; x.len()]);
        DirectSums.single(taps, x, rows.clone(), |l, a| d[l] = a);
        fast.single(taps, x, rows, |l, a| f[l] = a);
        assert_eq!(bits(&d), bits(&f));
    };
    check(short.weights(), &x, 15..2000);
    check(w.weights(), &x, 255..(255 + SUMS_DIRECT_ROWS - 1));
    x[1000] = f64::NAN;
    check(w.weights(), &x, 255..2000);
}

/// Solvers of one thread share its working buffers ([`working`]): two of
/// them called in turn, each with its own weights, drives and history,
/// give bit for bit what each gives called alone, and a solver used inside
/// another's drive (a nested call) as well.
#[test]
fn solvers_sharing_a_threads_buffers_give_what_each_gives_alone() {
    const N: usize = 3000;
    let (wa, wb) = (
        GlWeights::<f64, N>::new(0.6, 1.0, N).unwrap(),
        GlWeights::<f64, N>::new(0.85, 0.5, N).unwrap(),
    );
    let alone = |w: &GlWeights<f64, N>, a: f64, warm: usize, k: f64| {
        let mut s = FftBranch::default();
        let mut runs = Vec::new();
        for r in 0..3 {
            let mut x = history(N, warm);
            s.solve(w.weights(), a, warm, &mut x, |l| {
                k * (r + 1) as f64 * drive(l)
            });
            runs.push(x);
        }
        runs
    };
    let (ra, rb) = (alone(&wa, 2.0, 0, 1.0), alone(&wb, 0.3, 400, -0.5));
    let (mut sa, mut sb) = (FftBranch::default(), FftBranch::default());
    for r in 0..3 {
        let mut xa = vec![0.0; N];
        let mut xb = history(N, 400);
        sa.solve(wa.weights(), 2.0, 0, &mut xa, |l| (r + 1) as f64 * drive(l));
        sb.solve(wb.weights(), 0.3, 400, &mut xb, |l| {
            -0.5 * (r + 1) as f64 * drive(l)
        });
        assert_eq!(xa, ra[r], "first solver, run {r}");
        assert_eq!(xb, rb[r], "second solver, run {r}");
    }
    // A solver called inside another's call runs on buffers of its own.
    let mut inner_done = false;
    let mut xa = vec![0.0; N];
    let mut inner = FftBranch::default();
    sa.solve(wa.weights(), 2.0, 0, &mut xa, |l| {
        if !inner_done {
            inner_done = true;
            let mut xb = history(N, 400);
            inner.solve(wb.weights(), 0.3, 400, &mut xb, |l| -0.5 * drive(l));
            assert_eq!(xb, rb[0], "nested solver");
        }
        drive(l)
    });
    assert_eq!(xa, ra[0], "the outer solver, with a call inside its drive");
}
