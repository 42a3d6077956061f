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

use super::simulate::{cpe_filter, cpe_filter_pair, cpe_filter_pair_seen};
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

    /// [`filter`](Self::filter) of `x` and, with the same weights and `a`,
    /// [`solve`](Self::solve) of `y` with a zero drive (the free response
    /// of its history `y[..warm]`): each gets the values it gets alone.
    /// A solver may run both in one pass.
    #[allow(clippy::too_many_arguments)]
    fn filter_with_free(
        &mut self,
        w: &[T],
        a: T,
        warm: usize,
        x: &mut [T],
        y: &mut [T],
        drive: impl FnMut(usize) -> T,
        seen: impl FnMut(usize, T, T),
    ) {
        self.filter(w, a, warm, x, drive, seen);
        self.solve(w, a, warm, y, |_| T::zero());
    }

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

    /// From rest, with `x` the solution [`filter`](Self::filter) gave for
    /// the weights `w` and `a` (no history): `y = g ∗ E` and `z = ℓ ∗ y`,
    /// with `E = w ∗ x` the history sums, `g` the recursion's inverse
    /// (`g ∗ (δ + a·w) = δ`) and `ℓ` the series of `ln(1 − z)` (so that
    /// `g ∗ (∂w/∂α ∗ x) = ℓ ∗ y` when `w` is the whole Grünwald–Letnikov
    /// series, `∂w/∂α = ℓ ∗ w`). The refinement's sensitivities from rest
    /// are sums of `x`, `y` and `z`. A solver that takes them for less
    /// than the three recursions they replace fills `y` and `z` (over
    /// `x.len()`) and returns true; the default returns false and leaves
    /// them, and the caller runs the recursions.
    fn rest_sums(&mut self, w: &[T], a: T, x: &[T], y: &mut [T], z: &mut [T]) -> bool {
        let _ = (w, a, x, y, z);
        false
    }

    /// Makes this solver compute what a new one
    /// ([`Default::default`]) would, from its next call: a refinement
    /// started again in place
    /// ([`OutputErrorRefinement::init`](super::output_error::OutputErrorRefinement::init))
    /// resets its solver. A solver that keeps buffers (a cache of spectra)
    /// may keep their allocations and forget their contents; the default
    /// is a new solver.
    fn reset(&mut self) {
        *self = Self::default();
    }
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
    fn filter_with_free(
        &mut self,
        w: &[T],
        a: T,
        warm: usize,
        x: &mut [T],
        y: &mut [T],
        mut drive: impl FnMut(usize) -> T,
        seen: impl FnMut(usize, T, T),
    ) {
        if x.len() != y.len() {
            // (Never here: both are the window's.)
            self.filter(w, a, warm, x, drive, seen);
            self.solve(w, a, warm, y, |_| T::zero());
            return;
        }
        cpe_filter_pair_seen(w, a, warm, x, y, |l| (drive(l), T::zero()), seen);
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

#[cfg(test)]
mod tests {
    use super::{BranchSolver, GlRecursion};
    use core::ops::Range;

    use crate::frac::GlWeights;

    /// A solver with only the required methods (the trait's defaults for
    /// the rest), through the direct recursion.
    #[derive(Default)]
    struct Defaults;

    impl BranchSolver<f64> for Defaults {
        fn filter(
            &mut self,
            w: &[f64],
            a: f64,
            warm: usize,
            x: &mut [f64],
            drive: impl FnMut(usize) -> f64,
            seen: impl FnMut(usize, f64, f64),
        ) {
            GlRecursion.filter(w, a, warm, x, drive, seen);
        }
        fn filter_pair(
            &mut self,
            w: &[f64],
            a: f64,
            warm: usize,
            x: &mut [f64],
            y: &mut [f64],
            drive: impl FnMut(usize) -> (f64, f64),
        ) {
            GlRecursion.filter_pair(w, a, warm, x, y, drive);
        }
        fn weight_derivative<const MEM: usize>(
            &mut self,
            gl: &GlWeights<f64, MEM>,
            x: &[f64],
            rows: Range<usize>,
            f: impl FnMut(usize, f64),
        ) {
            GlRecursion.weight_derivative(gl, x, rows, f);
        }
    }

    /// The simulation with a free response in one pass gives each sequence,
    /// and every history sum seen, exactly what the two recursions give
    /// alone: the direct solver's pair kernel and the trait's default.
    #[test]
    fn a_free_response_run_with_the_simulation_is_the_same() {
        let w = GlWeights::<f64, 64>::new(0.63, 1.0, 64).unwrap();
        for (n, warm) in [(256, 63), (200, 63), (70, 63), (100, 10), (40, 0)] {
            let a = 2.3;
            let drive = |l: usize| (0.3 * l as f64).sin() - 0.4;
            let x0: Vec<f64> = (0..n).map(|l| 0.2 - 0.003 * l as f64).collect();
            let y0: Vec<f64> = (0..n).map(|l| if l < warm { -1.0 } else { 7.0 }).collect();
            let (mut x, mut y) = (x0.clone(), y0.clone());
            let mut seen = vec![f64::NAN; n];
            GlRecursion.filter(w.weights(), a, warm, &mut x, drive, |l, xl, h| {
                seen[l] = xl + h
            });
            GlRecursion.solve(w.weights(), a, warm, &mut y, |_| 0.0);
            for solver in 0..2 {
                let (mut px, mut py) = (x0.clone(), y0.clone());
                let mut ps = vec![f64::NAN; n];
                let store = |l: usize, xl: f64, h: f64| ps[l] = xl + h;
                if solver == 0 {
                    GlRecursion.filter_with_free(
                        w.weights(),
                        a,
                        warm,
                        &mut px,
                        &mut py,
                        drive,
                        store,
                    );
                } else {
                    Defaults.filter_with_free(w.weights(), a, warm, &mut px, &mut py, drive, store);
                }
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&px), bits(&x), "n {n} warm {warm} solver {solver}");
                assert_eq!(bits(&py), bits(&y), "n {n} warm {warm} solver {solver}");
                assert_eq!(bits(&ps), bits(&seen), "n {n} warm {warm} solver {solver}");
            }
        }
    }
}
