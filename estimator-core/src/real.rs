//! The scalar type the estimator computes in.
//!
//! Everything in this crate is generic over [`Real`], which is implemented for
//! `f32` (the Cortex-M4F single-precision FPU) and `f64` (the host). The
//! transcendental functions come from `num-traits` with its `libm` backend, so
//! they are the same correctly-rounded-ish `libm` routines on every target.

use core::fmt::Debug;
use num_traits::Float;

/// A floating-point scalar: `f32` or `f64`.
///
/// The trait is sealed: the numerical tolerances inside the algorithms (the
/// smallest accepted step, the excitation threshold) are chosen per type.
pub trait Real: Float + Debug + Default + Send + Sync + 'static + sealed::Sealed {
    /// Zero, usable in `const` contexts (array initialisers).
    const ZERO: Self;
    /// One, usable in `const` contexts.
    const ONE: Self;
    /// Not a number, usable in `const` contexts (an unset value).
    const NAN: Self;
    /// Positive and negative infinity, usable in `const` contexts (an
    /// empty range's ends).
    const INFINITY: Self;
    /// See [`Real::INFINITY`].
    const NEG_INFINITY: Self;
    /// Converts an `f64` constant into this type (rounding for `f32`).
    fn lit(x: f64) -> Self;
    /// Widens to `f64` (exact for both implementations).
    fn to_f64(self) -> f64;

    /// Solves the symmetric positive definite system `a·x = b` by a Cholesky
    /// factorization (nalgebra, on the stack). `None` when `a` is not
    /// positive definite or the result is not finite.
    fn solve_spd<const D: usize>(a: &[[Self; D]; D], b: &[Self; D]) -> Option<[Self; D]>;

    /// The diagonal of `a⁻¹` for a symmetric positive definite `a`, from
    /// one Cholesky factorization (nalgebra, on the stack). `None` when `a`
    /// is not positive definite or the result is not finite.
    fn spd_inverse_diagonal<const D: usize>(a: &[[Self; D]; D]) -> Option<[Self; D]>;

    /// `√x` for the per-sample model terms. `f64`: `libm`'s (the
    /// hardware instruction on x86-64). `f32`: [`root_f32`], plain
    /// arithmetic within 1 ulp of `libm`'s, because `libm`'s `sqrtf` is
    /// integer code on the Cortex-M4F (no stable way to its `VSQRT` without
    /// `unsafe`).
    fn root(self) -> Self;

    /// `asinh(x)` for the Butler–Volmer term: `libm`'s for `f64`,
    /// [`asinh_f32`] for `f32` (a polynomial and a logarithm of its own,
    /// within 2 ulp of the correctly rounded value, tested).
    fn arsinh(self) -> Self;
    /// The value's bits (`to_bits`, widened): equal exactly when two values
    /// are the same bit for bit (`0.0` and `-0.0` differ, a NaN equals
    /// itself).
    fn bits(self) -> u64;
}

/// `√x` in `f32` arithmetic: an exponent-halving first guess (within 4 %)
/// and three Newton steps `y ← (y + x/y)/2` (error 4e−2 → 8e−4 → 3e−7 →
/// rounding), within 1 ulp of the correctly rounded root for every normal
/// positive `x` (test `the_f32_root_is_within_an_ulp`). Zero, subnormals,
/// negatives, ∞ and NaN take `libm`'s answer. On the Cortex-M4F it is about
/// 15 instructions (`VDIV` is one), `libm`'s generic `sqrtf` several times
/// that.
///
/// ```
/// let r = estimator_core::real::root_f32(2.0);
/// assert!((r - core::f32::consts::SQRT_2).abs() <= f32::EPSILON * 1.5);
/// ```
#[inline]
pub fn root_f32(x: f32) -> f32 {
    if !(f32::MIN_POSITIVE..=f32::MAX).contains(&x) {
        return libm::sqrtf(x);
    }
    let mut y = f32::from_bits((x.to_bits() >> 1) + 0x1fbb_4000);
    y = 0.5 * (y + x / y);
    y = 0.5 * (y + x / y);
    0.5 * (y + x / y)
}

/// `asinh(x)` in `f32`, within 2 ulp of the correctly rounded value
/// (test `the_f32_asinh_is_within_two_ulp_of_the_truth`); odd.
///
/// * `|x| ≤ 1`: `x·P(x²)`, a degree-8 near-minimax polynomial of
///   `asinh(t)/t` in `t²` (relative error 3·10⁻⁹ in exact arithmetic, so
///   the `f32` rounding of Horner's rule dominates);
/// * `1 < |x| < 2¹²`: `ln(|x| + √(x²+1))` with [`root_f32`] and
///   [`ln_f32`] (the argument is above 2.4: no cancellation);
/// * beyond: `ln|x| + ln 2`; below 2⁻¹², `x` itself; NaN stays NaN.
///
/// On the Cortex-M4F a call of the kinetic voltage `a·asinh(I/i₀)` costs 44
/// instructions on average over the firmware's bench record, against 76
/// with `libm`'s `asinhf` and [`root_f32`] (docs/butler-volmer.md).
///
/// ```
/// let y = estimator_core::real::asinh_f32(0.5);
/// assert!((y - 0.481_211_8).abs() < 1e-6);
/// ```
#[inline(always)]
pub fn asinh_f32(x: f32) -> f32 {
    /// `asinh(t)/t ≈ Σ_k P[k]·t^(2k)` on `0 ≤ t ≤ 1`.
    const P: [f32; 9] = [
        1.0,
        -0.166_666_14,
        0.074_984_625,
        -0.044_471_394,
        0.029_400_023,
        -0.019_073_803,
        0.010_312_659,
        -0.003_770_163_5,
        0.000_657_774_74,
    ];
    let t = x.abs();
    let y = if t.is_nan() || t < 1.0 / 4096.0 {
        // Tiny (asinh x = x to f32 precision), or NaN.
        return x;
    } else if t <= 1.0 {
        let z = t * t;
        let p = P[..8].iter().rev().fold(P[8], |acc, &c| acc * z + c);
        t * p
    } else if t < 4096.0 {
        ln_f32(t + root_f32(t * t + 1.0))
    } else {
        ln_f32(t) + core::f32::consts::LN_2
    };
    if x < 0.0 {
        -y
    } else {
        y
    }
}

/// `ln(x)` in `f32` for finite `x ≥ f32::MIN_POSITIVE`: musl's `logf`
/// kernel (`x = 2^k·(1 + f)`, `√½ ≤ 1 + f < √2`, `ln(1 + f)` from
/// `s = f/(2 + f)` and a degree-4 polynomial in `s²`, within 1 ulp),
/// without its checks for zero, negatives, subnormals, ∞ and NaN, which
/// callers exclude.
///
/// ```
/// let y = estimator_core::real::ln_f32(10.0);
/// assert!((y - core::f32::consts::LN_10).abs() <= f32::EPSILON * 2.5);
/// ```
#[inline]
pub fn ln_f32(x: f32) -> f32 {
    const LN2_HI: f32 = 0.693_138_1;
    const LN2_LO: f32 = 9.058_001e-6;
    const LG1: f32 = 0.666_666_6;
    const LG2: f32 = 0.400_009_72;
    const LG3: f32 = 0.284_987_87;
    const LG4: f32 = 0.242_790_79;
    // Reduce to 1 + f in [√½, √2): the exponent k of x·√2.
    let ix = x.to_bits().wrapping_add(0x3f80_0000 - 0x3f35_04f3);
    let k = (ix >> 23) as i32 - 0x7f;
    let f = f32::from_bits((ix & 0x007f_ffff) + 0x3f35_04f3) - 1.0;
    let s = f / (2.0 + f);
    let z = s * s;
    let w = z * z;
    let r = z * (LG1 + w * LG3) + w * (LG2 + w * LG4);
    let hfsq = 0.5 * f * f;
    let dk = k as f32;
    s * (hfsq + r) + dk * LN2_LO - hfsq + f + dk * LN2_HI
}

macro_rules! solve_spd_impl {
    ($t:ty) => {
        fn solve_spd<const D: usize>(a: &[[$t; D]; D], b: &[$t; D]) -> Option<[$t; D]> {
            let m = nalgebra::SMatrix::<$t, D, D>::from_fn(|i, j| a[i][j]);
            let v = nalgebra::SVector::<$t, D>::from_fn(|i, _| b[i]);
            let x = m.cholesky()?.solve(&v);
            let mut out = [0.0; D];
            for (o, &xi) in out.iter_mut().zip(x.iter()) {
                if !xi.is_finite() {
                    return None;
                }
                *o = xi;
            }
            Some(out)
        }

        fn spd_inverse_diagonal<const D: usize>(a: &[[$t; D]; D]) -> Option<[$t; D]> {
            let m = nalgebra::SMatrix::<$t, D, D>::from_fn(|i, j| a[i][j]);
            let inv = m.cholesky()?.inverse();
            let mut out = [0.0; D];
            for (k, o) in out.iter_mut().enumerate() {
                let x = inv[(k, k)];
                if !x.is_finite() {
                    return None;
                }
                *o = x;
            }
            Some(out)
        }
    };
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const NAN: Self = f32::NAN;
    const INFINITY: Self = f32::INFINITY;
    const NEG_INFINITY: Self = f32::NEG_INFINITY;
    #[inline]
    fn lit(x: f64) -> Self {
        x as f32
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self as f64
    }
    solve_spd_impl!(f32);
    #[inline]
    fn root(self) -> Self {
        root_f32(self)
    }
    #[inline(always)]
    fn arsinh(self) -> Self {
        asinh_f32(self)
    }
    #[inline]
    fn bits(self) -> u64 {
        u64::from(self.to_bits())
    }
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const NAN: Self = f64::NAN;
    const INFINITY: Self = f64::INFINITY;
    const NEG_INFINITY: Self = f64::NEG_INFINITY;
    #[inline]
    fn lit(x: f64) -> Self {
        x
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
    solve_spd_impl!(f64);
    #[inline]
    fn root(self) -> Self {
        libm::sqrt(self)
    }
    #[inline]
    fn arsinh(self) -> Self {
        libm::asinh(self)
    }
    #[inline]
    fn bits(self) -> u64 {
        self.to_bits()
    }
}

mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

/// Dot product of two equally long slices (extra elements of the longer one
/// are ignored).
#[inline]
pub(crate) fn dot<T: Real>(a: &[T], b: &[T]) -> T {
    a.iter().zip(b).fold(T::zero(), |s, (&x, &y)| s + x * y)
}

/// Euclidean norm of a slice.
#[inline]
pub(crate) fn norm<T: Real>(a: &[T]) -> T {
    dot(a, a).sqrt()
}

/// Euclidean norm of the difference of two slices.
#[inline]
pub(crate) fn dist<T: Real>(a: &[T], b: &[T]) -> T {
    a.iter()
        .zip(b)
        .fold(T::zero(), |s, (&x, &y)| s + (x - y) * (x - y))
        .sqrt()
}

/// True for a finite, strictly positive value (false for NaN).
#[inline]
pub(crate) fn positive_finite<T: Real>(x: T) -> bool {
    x.is_finite() && x > T::zero()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units in the last place (same sign).
    fn ulps(a: f32, b: f32) -> u32 {
        (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs() as u32
    }

    /// Every 97th f32 bit pattern over the positive normals, and around
    /// the powers of two.
    fn samples() -> impl Iterator<Item = f32> {
        let step = (0..u32::MAX / 2 / 97).map(|k| f32::from_bits(k * 97));
        let edges = (-126..127).flat_map(|e| {
            let p = libm::exp2f(e as f32);
            [p, p * (1.0 - f32::EPSILON), p * (1.0 + f32::EPSILON)]
        });
        step.chain(edges).filter(|x| x.is_normal() && *x > 0.0)
    }

    #[test]
    fn the_f32_logarithm_is_within_an_ulp_of_the_truth() {
        let worst = samples()
            .filter(|x| *x < f32::MAX)
            .map(|x| ulps(ln_f32(x), libm::log(x as f64) as f32))
            .max()
            .unwrap();
        assert!(worst <= 1, "{worst} ulp");
    }

    #[test]
    fn the_f32_root_is_within_an_ulp() {
        let worst = samples()
            .map(|x| ulps(root_f32(x), libm::sqrtf(x)))
            .max()
            .unwrap();
        assert!(worst <= 1, "{worst} ulp");
        for x in [0.0, -0.0, -1.0, f32::INFINITY, f32::NAN, 1e-40] {
            let (a, b) = (root_f32(x), libm::sqrtf(x));
            assert!(
                a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                "{x}"
            );
        }
    }

    #[test]
    fn the_f32_asinh_is_within_two_ulp_of_the_truth() {
        let worst = samples()
            .filter(|x| *x < 1e30)
            .map(|x| {
                assert_eq!(asinh_f32(-x), -asinh_f32(x));
                ulps(asinh_f32(x), libm::asinh(x as f64) as f32)
            })
            .max()
            .unwrap();
        assert!(worst <= 2, "{worst} ulp");
        assert!(asinh_f32(f32::NAN).is_nan());
        assert_eq!(asinh_f32(0.0), 0.0);
    }
}
