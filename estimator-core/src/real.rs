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
    /// Converts an `f64` constant into this type (rounding for `f32`).
    fn lit(x: f64) -> Self;
    /// Widens to `f64` (exact for both implementations).
    fn to_f64(self) -> f64;

    /// Solves the symmetric positive definite system `a·x = b` by a Cholesky
    /// factorization (nalgebra, on the stack). `None` when `a` is not
    /// positive definite or the result is not finite.
    fn solve_spd<const D: usize>(a: &[[Self; D]; D], b: &[Self; D]) -> Option<[Self; D]>;
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
    };
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    #[inline]
    fn lit(x: f64) -> Self {
        x as f32
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self as f64
    }
    solve_spd_impl!(f32);
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    #[inline]
    fn lit(x: f64) -> Self {
        x
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
    solve_spd_impl!(f64);
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
