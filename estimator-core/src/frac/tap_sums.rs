//! Who computes the tap sums `Σ_j w_j·x(l − j)` of a weight set over many
//! rows: the paper regression's fractional differences and their order
//! derivatives ([`crate::battery::regression`]).
//!
//! A [`TapSums`] is asked for the sums of one weight set against one or two
//! sequences over a range of rows. [`DirectSums`] runs the block kernels of
//! this module's parent, `O(rows·M)` with no state and no allocation: the
//! one the microcontroller runs, and the default. A host with a heap can
//! supply one in `O(N log N)` (the host library's FFT sums do, for the
//! regression over a whole record). This module owns that interface only:
//! it does not touch the weights, the scale `h^(−α)` or the regression.
//!
//! ```
//! use estimator_core::frac::{DirectSums, GlWeights, TapSums};
//!
//! let w = GlWeights::<f64, 16>::new(0.5, 1.0, 16).unwrap();
//! let x: Vec<f64> = (0..64).map(|l| (0.1 * l as f64).sin()).collect();
//! let mut sums = [0.0; 64];
//! DirectSums.single(w.weights(), &x, 15..64, |l, s| sums[l] = s);
//! // Scaled by h^(−α), the fractional difference of `x` row by row.
//! assert!((w.scale() * sums[40] - w.difference(&x, 40)).abs() < 1e-15);
//! ```

use core::ops::Range;

use super::{pair_sums, single_sums};
use crate::real::Real;

/// Tap sums of a weight set over rows (see the module docs). Every
/// implementation gives the values of [`DirectSums`] up to rounding.
pub trait TapSums<T: Real>: Default {
    /// Calls `f(l, Σ_{j=0}^{min(l, M−1)} w_j·x(l − j))` for every `l` in
    /// `rows` (up to `x.len()`), in increasing `l` (`M = w.len()`).
    fn single(&mut self, w: &[T], x: &[T], rows: Range<usize>, f: impl FnMut(usize, T)) {
        single_sums(w, x, rows, f);
    }

    /// [`single`](Self::single) of two sequences with the same weights
    /// (up to the shorter of `x` and `y`): `f(l, sum of x, sum of y)`.
    fn pair(&mut self, w: &[T], x: &[T], y: &[T], rows: Range<usize>, f: impl FnMut(usize, T, T)) {
        pair_sums(w, x, y, rows, f);
    }
}

/// The direct sums: the block kernels row by row, `O(rows·M)`, no state
/// and no allocation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DirectSums;

impl<T: Real> TapSums<T> for DirectSums {}
