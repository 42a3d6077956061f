//! How the constant-phase branch's recursion is solved over a window.
//!
//! The output-error refinement ([`super::output_error`]) spends its time in
//! one linear recursion, the Grünwald–Letnikov form of the constant-phase
//! branch with several drives (the simulation and its sensitivities):
//!
//! ```text
//! (1 + a)·x(l) = drive(l) − a·Σ_{j=1}^{min(l, M−1)} w_j·x(l − j),   l ≥ warm
//! ```
//!
//! with `x[..warm]` a given history, and in one tap sum, the order
//! derivative's `h^(−α)·Σ_j (∂w_j/∂α)·x(l − j)`. A [`BranchSolver`] does
//! both. This module owns that interface and its direct solver,
//! [`GlRecursion`]: `O(N·M)` per window, no allocation, the one the
//! microcontroller runs. A host with a heap can supply an exact solver in
//! `O(N log N)` (the host library's FFT solver does, for whole-record fits
//! with the full memory). The module does not touch the model or the
//! search: a solver only computes the sums it is asked for.
//!
//! ```
//! use estimator_core::battery::branch::{BranchSolver, GlRecursion};
//! use estimator_core::frac::GlWeights;
//!
//! let w = GlWeights::<f64, 64>::new(0.6, 1.0, 64).unwrap();
//! let mut x = [0.0; 64];
//! // A unit step drive from rest, a = 2.
//! GlRecursion.solve(w.weights(), 2.0, 0, &mut x, |_| 1.0);
//! assert!((x[0] - 1.0 / 3.0).abs() < 1e-15);
//! assert!(x[63] > x[0] && x[63] < 1.0);
//! ```

use core::ops::Range;

use super::simulate::{cpe_filter, cpe_filter_pair};
use crate::frac::GlWeights;
use crate::real::Real;

/// Solves the constant-phase recursion and the order derivative's tap sum
/// over a window (see the module docs). Every implementation gives the
/// values of [`GlRecursion`] up to rounding.
pub trait BranchSolver<T: Real>: Default {
    /// For `l` in `warm..x.len()`, `(1 + a)·x(l) = drive(l) − a·H(l)` with
    /// `H(l) = Σ_{j=1}^{min(l, M−1)} w_j·x(l − j)` (`M = w.len()`,
    /// `w[0] = 1`), then `seen(l, x(l), H(l))`, in increasing `l`.
    /// `x[..warm]` holds the given history. `drive` is called once per
    /// row, in increasing `l`; it must not depend on `x`.
    fn filter(
        &mut self,
        w: &[T],
        a: T,
        warm: usize,
        x: &mut [T],
        drive: impl FnMut(usize) -> T,
        seen: impl FnMut(usize, T, T),
    );

    /// [`filter`](Self::filter) without `seen`: for a caller that does not
    /// need the history sums (a solver that gets them only at extra cost
    /// skips them).
    fn solve(&mut self, w: &[T], a: T, warm: usize, x: &mut [T], drive: impl FnMut(usize) -> T) {
        self.filter(w, a, warm, x, drive, |_, _, _| {});
    }

    /// [`filter`](Self::filter) of two sequences with the same weights and
    /// `a` (over the shorter of `x` and `y`); `drive(l)` gives both drives.
    fn filter_pair(
        &mut self,
        w: &[T],
        a: T,
        warm: usize,
        x: &mut [T],
        y: &mut [T],
        drive: impl FnMut(usize) -> (T, T),
    );

    /// Calls `f(l, h^(−α)·Σ_{j=0}^{min(l, M−1)} (∂w_j/∂α)·x(l − j))` for
    /// every `l` in `rows` (up to `x.len()`), in increasing `l`: as
    /// [`GlWeights::for_each_weight_derivative`].
    fn weight_derivative<const MEM: usize>(
        &mut self,
        gl: &GlWeights<T, MEM>,
        x: &[T],
        rows: Range<usize>,
        f: impl FnMut(usize, T),
    );
}

/// The direct solver: the recursion row by row (in blocks through the
/// block kernels of [`crate::frac`]), `O(N·M)`, no state and no
/// allocation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GlRecursion;

impl<T: Real> BranchSolver<T> for GlRecursion {
    #[inline]
    fn filter(
        &mut self,
        w: &[T],
        a: T,
        warm: usize,
        x: &mut [T],
        drive: impl FnMut(usize) -> T,
        seen: impl FnMut(usize, T, T),
    ) {
        cpe_filter(w, a, warm, x, drive, seen);
    }

    #[inline]
    fn filter_pair(
        &mut self,
        w: &[T],
        a: T,
        warm: usize,
        x: &mut [T],
        y: &mut [T],
        drive: impl FnMut(usize) -> (T, T),
    ) {
        cpe_filter_pair(w, a, warm, x, y, drive);
    }

    #[inline]
    fn weight_derivative<const MEM: usize>(
        &mut self,
        gl: &GlWeights<T, MEM>,
        x: &[T],
        rows: Range<usize>,
        f: impl FnMut(usize, T),
    ) {
        gl.for_each_weight_derivative(x, rows, f);
    }
}
