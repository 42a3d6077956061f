//! The circle the branch's inverse series is evaluated on
//! ([`super::FftBranch`] with the whole memory): its points, made once per
//! transform size and shared by a thread's solvers, and the sine and cosine
//! series the evaluation takes instead of libm's. It owns no transform and
//! no series; the solver does.

use std::cell::RefCell;
use std::sync::Arc;

use realfft::num_complex::Complex;

/// The points `z_j = r·e^{−2πij/N}` (`j = 0..=N/2`, the forward
/// transform's sign) of a circle inside
/// the unit circle, for one transform size `N`: `ln|1 − z_j|` and
/// `arg(1 − z_j)` (in `(−π/2, π/2)`: `Re(1 − z) ≥ 1 − r > 0`), and
/// `ln r`. The power series `1/(1 + a·(1 − z)^α)` evaluated there and
/// transformed back gives its coefficients times `r^k`, the terms from
/// `N` on folded in times `r^N` ([`CIRCLE_FOLD`]). Shared by every solver
/// of a thread (a fit's starts each hold one).
#[derive(Default)]
pub(super) struct Circle {
    /// Its points (the transform size).
    pub(super) size: usize,
    /// `ln r`.
    pub(super) ln_r: f64,
    /// `ln|1 − z_j|`.
    pub(super) ln_modulus: Vec<f64>,
    /// `arg(1 − z_j)`.
    pub(super) arg: Vec<f64>,
}

impl Circle {
    fn new(points: usize) -> Self {
        let ln_r = CIRCLE_FOLD.ln() / points as f64;
        let r = ln_r.exp();
        let step = std::f64::consts::TAU / points as f64;
        let (ln_modulus, arg) = (0..=points / 2)
            .map(|j| {
                let l = (Complex::new(1.0, 0.0) - Complex::from_polar(r, -step * j as f64)).ln();
                (l.re, l.im)
            })
            .unzip();
        Self {
            size: points,
            ln_r,
            ln_modulus,
            arg,
        }
    }

    /// The circle of `points` points: this thread's last one when it is
    /// of that size, else made (and kept as the thread's last).
    pub(super) fn of(points: usize) -> Arc<Self> {
        thread_local! {
            static LAST: RefCell<Option<Arc<Circle>>> = const { RefCell::new(None) };
        }
        LAST.with(|last| {
            let mut last = last.borrow_mut();
            match &*last {
                Some(c) if c.size == points => Arc::clone(c),
                _ => {
                    let c = Arc::new(Self::new(points));
                    *last = Some(Arc::clone(&c));
                    c
                }
            }
        })
    }

    /// `1/(1 + a·(1 − z_j)^α)` at every point, for `|α| ≤ 1`, appended to
    /// `out`: `(1 − z)^α = |1 − z|^α·e^{iα·arg}` with the modulus from
    /// [`exp_series`] and the rest from [`sin_cos_half_pi`] (`|α·arg| <
    /// π/2`), so the loop has no call and vectorizes: 4 points at a time
    /// where the processor has AVX2 (checked when called), 2 elsewhere on
    /// x86-64, the same operations in the same order either way, so the same
    /// values to the bit (test `the_circle_is_the_same_with_and_without_avx2`).
    pub(super) fn inverse_at_points(&self, alpha: f64, a: f64, out: &mut Vec<Complex<f64>>) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor running this has AVX2 (just checked),
            // the one feature the function is compiled with beyond the
            // target's.
            unsafe { inverse_at_points_avx2(&self.ln_modulus, &self.arg, alpha, a, out) };
            return;
        }
        inverse_at_points_any(&self.ln_modulus, &self.arg, alpha, a, out);
    }
}

/// [`Circle::inverse_at_points`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn inverse_at_points_avx2(
    ln_modulus: &[f64],
    arg: &[f64],
    alpha: f64,
    a: f64,
    out: &mut Vec<Complex<f64>>,
) {
    inverse_at_points_any(ln_modulus, arg, alpha, a, out);
}

/// [`Circle::inverse_at_points`] on the points `ln|1 − z_j|`, `arg(1 −
/// z_j)`, for the target's own features.
#[inline(always)]
pub(super) fn inverse_at_points_any(
    ln_modulus: &[f64],
    arg: &[f64],
    alpha: f64,
    a: f64,
    out: &mut Vec<Complex<f64>>,
) {
    // Written through a slice (not `extend`, a function of its own that
    // would not take this one's features).
    let from = out.len();
    out.resize(from + ln_modulus.len().min(arg.len()), Complex::default());
    for ((v, &l), &t) in out[from..].iter_mut().zip(ln_modulus).zip(arg) {
        let m = a * exp_series(alpha * l);
        let (sn, cs) = sin_cos_half_pi(alpha * t);
        let (re, im) = (1.0 + m * cs, m * sn);
        let d = 1.0 / (re * re + im * im);
        *v = Complex::new(re * d, -im * d);
    }
}

/// `e^x` for `|x| ≤ 700`: `x = k·ln 2 + r` with `|r| ≤ ln 2/2` (`k` by
/// rounding with a shifter constant, `ln 2` in two parts so `r` is exact),
/// `e^r` by its Taylor series to `r¹³` (the first term left out is below
/// 5·10⁻¹⁸) in Horner's form, and `2^k` made from its bits: no call and no
/// branch, so a loop of them vectorizes, where libm's `exp` was a third of
/// the circle's evaluation. Within 2 ulp of libm (test
/// `the_series_exponential_is_libms`).
#[inline(always)]
pub(super) fn exp_series(x: f64) -> f64 {
    /// `1/k!`, `k = 0..=13`.
    const E: [f64; 14] = [
        1.0,
        1.0,
        1.0 / 2.0,
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 120.0,
        1.0 / 720.0,
        1.0 / 5040.0,
        1.0 / 40_320.0,
        1.0 / 362_880.0,
        1.0 / 3_628_800.0,
        1.0 / 39_916_800.0,
        1.0 / 479_001_600.0,
        1.0 / 6_227_020_800.0,
    ];
    /// 1.5·2⁵²: `y + SHIFTER − SHIFTER` is `y` rounded to an integer, and
    /// `y + SHIFTER`'s bits are `SHIFTER`'s plus that integer.
    const SHIFTER: f64 = 6_755_399_441_055_744.0;
    /// `ln 2 = LN2_HI + LN2_LO`, `LN2_HI` with its last 21 bits zero, so
    /// `k·LN2_HI` is exact for `|k| < 2²¹` (fdlibm's split).
    const LN2_HI: f64 = 6.931_471_803_691_238e-1;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    let t = x * std::f64::consts::LOG2_E + SHIFTER;
    let k = t - SHIFTER;
    let r = (x - k * LN2_HI) - k * LN2_LO;
    let p = E.iter().rev().fold(0.0, |acc, &c| acc * r + c);
    // 2^k: k's two's complement is the low bits of t's less SHIFTER's.
    let k_bits = t.to_bits().wrapping_sub(SHIFTER.to_bits());
    p * f64::from_bits(k_bits.wrapping_add(1023) << 52)
}

/// `(sin x, cos x)` for `|x| ≤ π/2`, by their Taylor series to `y²¹`
/// and `y²²` on `|y| ≤ π/4` (the first terms left out are below 10⁻²⁰
/// there; above π/4 from `π/2 − |x|`, with π/2 in two parts so the
/// difference is exact, as cos near π/2 must not cancel) in Horner's form:
/// no call, so a loop of them vectorizes, where libm's `sincos` was a third
/// of the circle's evaluation. Within an ulp of libm (test
/// `the_series_sine_is_libms`): the branch's inverse series unscales the
/// rounding by up to `r^{−N/2}`.
#[inline(always)]
pub(super) fn sin_cos_half_pi(x: f64) -> (f64, f64) {
    // sin: y·Σ (−y²)^k/(2k+1)!, cos: Σ (−y²)^k/(2k)!, k ≤ 10 and 11.
    const S: [f64; 11] = [
        1.0,
        -1.0 / 6.0,
        1.0 / 120.0,
        -1.0 / 5040.0,
        1.0 / 362_880.0,
        -1.0 / 39_916_800.0,
        1.0 / 6_227_020_800.0,
        -1.0 / 1_307_674_368_000.0,
        1.0 / 355_687_428_096_000.0,
        -1.0 / 121_645_100_408_832_000.0,
        1.0 / 51_090_942_171_709_440_000.0,
    ];
    const C: [f64; 12] = [
        1.0,
        -1.0 / 2.0,
        1.0 / 24.0,
        -1.0 / 720.0,
        1.0 / 40_320.0,
        -1.0 / 3_628_800.0,
        1.0 / 479_001_600.0,
        -1.0 / 87_178_291_200.0,
        1.0 / 20_922_789_888_000.0,
        -1.0 / 6_402_373_705_728_000.0,
        1.0 / 2_432_902_008_176_640_000.0,
        -1.0 / 1_124_000_727_777_607_680_000.0,
    ];
    /// π/2 = HI + LO, HI the f64 nearest.
    const HI: f64 = std::f64::consts::FRAC_PI_2;
    const LO: f64 = 6.123_233_995_736_766e-17;
    let ax = x.abs();
    let swap = ax > std::f64::consts::FRAC_PI_4;
    // HI − ax is exact for ax in [π/4, π/2] (Sterbenz).
    let y = if swap { (HI - ax) + LO } else { ax };
    let y2 = y * y;
    let s = y * S.iter().rev().fold(0.0, |acc, &c| acc * y2 + c);
    let c = C.iter().rev().fold(0.0, |acc, &c| acc * y2 + c);
    let (sin_ax, cos_x) = if swap { (c, s) } else { (s, c) };
    (sin_ax.copysign(x), cos_x)
}

/// `r^N` of [`Circle`]: how much of a series' terms from `N` on folds
/// onto the first `N` (`g`'s, or a solution's from rest taken on the
/// circle; it also scales the rounding of the `k`-th term by at most
/// `r^{−N/2}`, 3·10⁴, since at most the first `N/2` are kept).
pub(super) const CIRCLE_FOLD: f64 = 1e-9;
