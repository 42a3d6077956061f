//! Grünwald–Letnikov fractional differences with short (truncated) memory.
//!
//! For an order α, a sample period h and a memory length M,
//!
//! ```text
//! Δ^α x(l) = h^(−α) · Σ_{j=0}^{min(l, M−1)} w_j(α) · x(l − j),
//! w_0 = 1,  w_j = w_{j−1} · (1 − (α + 1)/j)
//! ```
//!
//! with `l` counted from 0 at the first sample and every sample before the
//! first taken as zero (the system starts at rest). `M` is the runtime memory
//! length, at most the const-generic capacity `MEM`.
//!
//! The derivative with respect to the order, which the order search needs,
//! follows from the same recursion,
//!
//! ```text
//! ∂w_0/∂α = 0,  ∂w_j/∂α = ∂w_{j−1}/∂α · (1 − (α + 1)/j) − w_{j−1}/j
//! ∂(Δ^α x)/∂α = h^(−α) · Σ_j (∂w_j/∂α) x(l − j) − ln h · Δ^α x(l).
//! ```

use crate::error::FracError;
use crate::real::Real;
use core::ops::Range;

mod kernels;
mod tap_sums;
#[cfg(test)]
use kernels::{block_sums, block_sums8, block_sums_lanes, block_sums_pair, block_sums_pair_lanes};
use kernels::{block_sums2, sum_block};
pub(crate) use kernels::{row_block, row_block_pair, BLOCK, ROW_BLOCK, SUM_ROWS};
pub use tap_sums::{DirectSums, TapSums};

/// Grünwald–Letnikov weights `w_j(α)` and `∂w_j/∂α` for `j < len ≤ MEM`,
/// together with the scale `h^(−α)`.
#[derive(Clone, Debug)]
pub struct GlWeights<T, const MEM: usize> {
    alpha: T,
    h: T,
    len: usize,
    scale: T,
    ln_h: T,
    w: [T; MEM],
    dw: [T; MEM],
}

impl<T: Real, const MEM: usize> GlWeights<T, MEM> {
    /// The weights of `(α, h, len) = (0, 1, 1)`: `w_0 = 1`, every other
    /// weight and derivative 0. What [`new`](Self::new) starts from, and
    /// the value of a blank estimator built at compile time (a `static`'s)
    /// before [`set`](Self::set) gives it its order.
    pub(crate) const BLANK: Self = {
        let mut w = [T::ZERO; MEM];
        if let Some(w0) = w.first_mut() {
            *w0 = T::ONE;
        }
        Self {
            alpha: T::ZERO,
            h: T::ONE,
            len: 1,
            scale: T::ONE,
            ln_h: T::ZERO,
            w,
            dw: [T::ZERO; MEM],
        }
    };

    /// Weights for order `alpha`, sample period `h` (seconds, or 1 for a
    /// dimensionless sampled system) and memory length `len`.
    ///
    /// # Errors
    /// [`FracError::NonFiniteOrder`] for a NaN/∞ order,
    /// [`FracError::BadSamplePeriod`] unless `h` is finite and positive,
    /// [`FracError::BadMemory`] unless `1 ≤ len ≤ MEM`.
    pub fn new(alpha: T, h: T, len: usize) -> Result<Self, FracError> {
        let mut me = Self::BLANK;
        me.set(alpha, h, len)?;
        Ok(me)
    }

    /// Makes these the weights [`new`](Self::new)`(alpha, h, len)` returns,
    /// in place (every weight beyond `len` 0 again).
    ///
    /// # Errors
    /// As [`GlWeights::new`]; on error the weights are left unchanged.
    pub(crate) fn reset(&mut self, alpha: T, h: T, len: usize) -> Result<(), FracError> {
        // `set` computes the first `len` weights as `new` does (they are a
        // function of the three); beyond them `new`'s are 0.
        self.set(alpha, h, len)?;
        for tail in [self.w.get_mut(len..), self.dw.get_mut(len..)]
            .into_iter()
            .flatten()
        {
            tail.fill(T::ZERO);
        }
        Ok(())
    }

    /// Recomputes the weights in place for a new order, period and memory.
    /// On error the weights are left unchanged.
    ///
    /// # Errors
    /// As [`GlWeights::new`].
    pub fn set(&mut self, alpha: T, h: T, len: usize) -> Result<(), FracError> {
        if !alpha.is_finite() {
            return Err(FracError::NonFiniteOrder);
        }
        if !(h.is_finite() && h > T::zero()) {
            return Err(FracError::BadSamplePeriod);
        }
        if len == 0 || len > MEM {
            return Err(FracError::BadMemory {
                requested: len,
                capacity: MEM,
            });
        }
        if alpha == self.alpha && h == self.h && len == self.len {
            // Already these weights (a deterministic function of the three).
            return Ok(());
        }
        self.alpha = alpha;
        self.h = h;
        self.len = len;
        self.ln_h = h.ln();
        self.scale = (-alpha * self.ln_h).exp();
        fill_weights(alpha, &mut self.w[..len], &mut self.dw[..len]);
        Ok(())
    }

    /// Re-evaluates the weights for a new order, keeping `h` and the memory.
    ///
    /// # Errors
    /// [`FracError::NonFiniteOrder`] for a NaN/∞ order.
    pub fn set_order(&mut self, alpha: T) -> Result<(), FracError> {
        self.set(alpha, self.h, self.len)
    }

    /// The order α.
    pub fn alpha(&self) -> T {
        self.alpha
    }
    /// The sample period h.
    pub fn h(&self) -> T {
        self.h
    }
    /// The memory length M (number of weights used).
    pub fn len(&self) -> usize {
        self.len
    }
    /// Always false: a memory holds at least the weight `w_0 = 1`.
    pub fn is_empty(&self) -> bool {
        false
    }
    /// `h^(−α)`.
    pub fn scale(&self) -> T {
        self.scale
    }
    /// The weights `w_0 … w_{M−1}`, without the `h^(−α)` scale.
    pub fn weights(&self) -> &[T] {
        &self.w[..self.len.min(MEM)]
    }
    /// The order derivatives `∂w_0/∂α … ∂w_{M−1}/∂α`.
    pub fn weight_derivatives(&self) -> &[T] {
        &self.dw[..self.len.min(MEM)]
    }

    /// `Δ^α x(l)`: the fractional difference of the sequence `x` at index
    /// `l`, counting samples before `x[0]` as zero. Returns zero for an index
    /// past the end of `x`.
    #[inline]
    pub fn difference(&self, x: &[T], l: usize) -> T {
        if l >= x.len() {
            return T::zero();
        }
        let taps = (l + 1).min(self.len);
        self.scale * dot_rev(&self.w[..taps], &x[l + 1 - taps..=l])
    }

    /// `Δ^α x(l)` for a sequence given by a function of the index
    /// (`x(i)` is called for `i = l, l−1, …, max(0, l−M+1)`).
    #[inline]
    pub fn difference_by(&self, l: usize, x: impl Fn(usize) -> T) -> T {
        let taps = (l + 1).min(self.len);
        let s = self.w[..taps]
            .iter()
            .enumerate()
            .fold(T::zero(), |s, (j, &w)| s + w * x(l - j));
        self.scale * s
    }

    /// `(Δ^α x(l), ∂(Δ^α x(l))/∂α)` at index `l`.
    #[inline]
    pub fn difference_with_derivative(&self, x: &[T], l: usize) -> (T, T) {
        if l >= x.len() {
            return (T::zero(), T::zero());
        }
        let taps = (l + 1).min(self.len);
        let (s, ds) = dot_rev2(&self.w[..taps], &self.dw[..taps], &x[l + 1 - taps..=l]);
        let d = self.scale * s;
        (d, self.scale * ds - self.ln_h * d)
    }

    /// Calls `f(l, Δ^α x(l))` for every `l` in `rows` (up to `x.len()`),
    /// in increasing `l`. The same values as [`GlWeights::difference`]
    /// row by row, bit for bit, at about half the loads: rows with the full
    /// memory are summed several at a time, sharing each weight and sample.
    pub fn for_each_difference(&self, x: &[T], rows: Range<usize>, mut f: impl FnMut(usize, T)) {
        let s = self.scale;
        single_sums(&self.w[..self.len.min(MEM)], x, rows, |l, a| f(l, s * a));
    }

    /// Calls `f(l, D x(l))` for every `l` in `rows` (up to `x.len()`), where
    /// `D x(l) = h^(−α)·Σ_j (∂w_j/∂α)·x(l−j)` is the weight part of the
    /// order derivative, `∂(Δ^α x(l))/∂α = D x(l) − ln h · Δ^α x(l)`: one
    /// sequence of [`GlWeights::for_each_weight_derivative_pair`]. Since `D`
    /// is linear, the derivative of a combination `a·Δ^α x + b·Δ^α y` costs
    /// one call on `a·x + b·y` instead of a pair.
    pub fn for_each_weight_derivative(
        &self,
        x: &[T],
        rows: Range<usize>,
        mut f: impl FnMut(usize, T),
    ) {
        let s = self.scale;
        single_sums(&self.dw[..self.len.min(MEM)], x, rows, |l, a| f(l, s * a));
    }

    /// Calls `f(l, Δ^α x(l), ∂(Δ^α x(l))/∂α)` for every `l` in `rows` (up
    /// to `x.len()`), in increasing `l`: [`GlWeights::difference_with_derivative`]
    /// row by row, bit for bit, in blocks as [`GlWeights::for_each_difference`].
    pub fn for_each_difference_with_derivative(
        &self,
        x: &[T],
        rows: Range<usize>,
        mut f: impl FnMut(usize, T, T),
    ) {
        let m = self.len;
        let end = rows.end.min(x.len());
        let mut l = rows.start;
        while l < end && l + 1 < m {
            let (d, dd) = self.difference_with_derivative(x, l);
            f(l, d, dd);
            l += 1;
        }
        while l + BLOCK <= end {
            let (s, ds) = block_sums2(&self.w[..m], &self.dw[..m], &x[l + 1 - m..l + BLOCK]);
            for b in 0..BLOCK {
                let d = self.scale * s[b];
                f(l + b, d, self.scale * ds[b] - self.ln_h * d);
            }
            l += BLOCK;
        }
        while l < end {
            let (d, dd) = self.difference_with_derivative(x, l);
            f(l, d, dd);
            l += 1;
        }
    }

    /// Calls `f(l, Δ^α x(l), Δ^α y(l))` for every `l` in `rows` (up to the
    /// shorter of `x` and `y`): two sequences at once, each weight loaded
    /// once for both. Bit for bit [`GlWeights::difference`] of each.
    pub fn for_each_difference_pair(
        &self,
        x: &[T],
        y: &[T],
        rows: Range<usize>,
        mut f: impl FnMut(usize, T, T),
    ) {
        let s = self.scale;
        pair_sums(&self.w[..self.len.min(MEM)], x, y, rows, |l, a, b| {
            f(l, s * a, s * b)
        });
    }

    /// Calls `f(l, D x(l), D y(l))` for every `l` in `rows` (up to the
    /// shorter of `x` and `y`), where `D x(l) = h^(−α)·Σ_j (∂w_j/∂α)·x(l−j)`
    /// is the weight part of the order derivative:
    /// `∂(Δ^α x(l))/∂α = D x(l) − ln h · Δ^α x(l)`. Bit for bit the
    /// derivative of [`GlWeights::difference_with_derivative`] once the
    /// `ln h` term is subtracted the same way.
    pub fn for_each_weight_derivative_pair(
        &self,
        x: &[T],
        y: &[T],
        rows: Range<usize>,
        mut f: impl FnMut(usize, T, T),
    ) {
        let s = self.scale;
        pair_sums(&self.dw[..self.len.min(MEM)], x, y, rows, |l, a, b| {
            f(l, s * a, s * b)
        });
    }

    /// `ln h`, the factor of the order derivative's second term.
    pub fn ln_h(&self) -> T {
        self.ln_h
    }

    /// Writes `Δ^α x(l)` for every `l < min(x.len(), out.len())` into `out`.
    pub fn apply(&self, x: &[T], out: &mut [T]) {
        let n = x.len().min(out.len());
        self.for_each_difference(x, 0..n, |l, d| out[l] = d);
    }

    /// Writes `Δ^α x(l)` into `out` and `∂(Δ^α x(l))/∂α` into `dout` for
    /// every `l` covered by all three slices.
    pub fn apply_with_derivative(&self, x: &[T], out: &mut [T], dout: &mut [T]) {
        let n = x.len().min(out.len()).min(dout.len());
        self.for_each_difference_with_derivative(x, 0..n, |l, d, dd| {
            out[l] = d;
            dout[l] = dd;
        });
    }
}

/// Fills `w` with the Grünwald–Letnikov weights `w_j = (−1)^j·C(α, j)` and
/// `dw` with their order derivatives `∂w_j/∂α`, over the shorter of the two
/// (the recursion of [`GlWeights`], for callers that keep their weights
/// elsewhere, e.g. on a host's heap).
///
/// ```
/// let (mut w, mut dw) = ([0.0; 3], [0.0; 3]);
/// estimator_core::frac::fill_weights(0.5, &mut w, &mut dw);
/// assert_eq!(w, [1.0, -0.5, -0.125]);
/// assert_eq!(dw[1], -1.0);
/// ```
pub fn fill_weights<T: Real>(alpha: T, w: &mut [T], dw: &mut [T]) {
    let len = w.len().min(dw.len());
    if len == 0 {
        return;
    }
    w[0] = T::one();
    dw[0] = T::zero();
    let a1 = alpha + T::one();
    for j in 1..len {
        let jj = T::lit(j as f64);
        let r = T::one() - a1 / jj;
        w[j] = w[j - 1] * r;
        dw[j] = dw[j - 1] * r - w[j - 1] / jj;
    }
}

/// `Σ_k w[k]·x[n−1−k]` over the common length `n` (a convolution tap sum
/// with the newest sample last), one running sum in tap order. The block
/// kernels below add in the same order, so a row's value does not depend on
/// whether it was computed alone or in a block.
#[inline]
pub(crate) fn dot_rev<T: Real>(w: &[T], x: &[T]) -> T {
    w.iter()
        .zip(x.iter().rev())
        .fold(T::zero(), |s, (&w, &x)| s + w * x)
}

/// [`dot_rev`] of two weight sets against the same samples at once.
#[inline]
pub(crate) fn dot_rev2<T: Real>(w: &[T], dw: &[T], x: &[T]) -> (T, T) {
    w.iter()
        .zip(dw)
        .zip(x.iter().rev())
        .fold((T::zero(), T::zero()), |(s, d), ((&w, &dw), &x)| {
            (s + w * x, d + dw * x)
        })
}

/// Tap sums of one weight set `w` (`m` taps) against one sequence, row by
/// row over `rows` (up to `x.len()`): `f(l, Σ w_j x(l−j))`, fewer taps
/// before row `m − 1`, in blocks of [`SUM_ROWS`] after it
/// ([`block_sums8`] on Arm, [`block_sums_lanes`] elsewhere).
#[inline]
fn single_sums<T: Real>(w: &[T], x: &[T], rows: Range<usize>, mut f: impl FnMut(usize, T)) {
    host_simd(SingleBlocks {
        w,
        x,
        l: rows.start,
        end: rows.end.min(x.len()),
        f: &mut f,
    });
}

/// Tap sums of one weight set `w` (`m` taps) against two sequences, row by
/// row over `rows` (up to the shorter sequence): `f(l, Σ w_j x(l−j),
/// Σ w_j y(l−j))`, fewer taps before row `m − 1`, in blocks after it.
#[inline]
fn pair_sums<T: Real>(
    w: &[T],
    x: &[T],
    y: &[T],
    rows: Range<usize>,
    mut f: impl FnMut(usize, T, T),
) {
    host_simd(PairBlocks {
        w,
        x,
        y,
        l: rows.start,
        end: rows.end.min(x.len()).min(y.len()),
        f: &mut f,
    });
}

/// The rows `l..end` of [`single_sums`]: in blocks where they fill one,
/// one at a time otherwise; `run` returns `end`.
struct SingleBlocks<'a, T, F> {
    w: &'a [T],
    x: &'a [T],
    l: usize,
    end: usize,
    f: &'a mut F,
}

impl<T: Real, F: FnMut(usize, T)> SingleBlocks<'_, T, F> {
    #[inline(always)]
    fn run(self) -> usize {
        let Self {
            w,
            x,
            mut l,
            end,
            f,
        } = self;
        let m = w.len();
        // Rows with fewer than m taps: a block of rows l..l+K shares its
        // first l + 1 taps; each row then adds its own few last taps, still
        // in tap order.
        while l < end && l + 1 < m {
            if l + SUM_ROWS <= end && l + SUM_ROWS <= m {
                let taps = l + 1;
                let s = sum_block(&w[..taps], &x[..l + SUM_ROWS]);
                for (k, mut a) in s.into_iter().enumerate() {
                    let r = l + k;
                    // Taps `taps..=r` against x[r − taps], …, x[0] (k of each).
                    let (wt, xt) = (
                        w.get(taps..=r).unwrap_or_default(),
                        x.get(..k).unwrap_or_default(),
                    );
                    for (&wj, &xj) in wt.iter().zip(xt.iter().rev()) {
                        a = a + wj * xj;
                    }
                    f(r, a);
                }
                l += SUM_ROWS;
            } else {
                f(l, dot_rev(&w[..=l], &x[..=l]));
                l += 1;
            }
        }
        while l + SUM_ROWS <= end {
            // l + 1 ≥ m here: the loop above has run the short rows.
            let Some(xs) = x.get(l + 1 - m..l + SUM_ROWS) else {
                break;
            };
            let s = sum_block(w, xs);
            for (k, sk) in s.into_iter().enumerate() {
                f(l + k, sk);
            }
            l += SUM_ROWS;
        }
        while l < end {
            let Some(xs) = x.get(l + 1 - m..=l) else {
                break;
            };
            f(l, dot_rev(w, xs));
            l += 1;
        }
        l
    }
}

/// The rows `l..end` of [`pair_sums`]: in blocks where they fill one,
/// one at a time otherwise; `run` returns `end`.
struct PairBlocks<'a, T, F> {
    w: &'a [T],
    x: &'a [T],
    y: &'a [T],
    l: usize,
    end: usize,
    f: &'a mut F,
}

impl<T: Real, F: FnMut(usize, T, T)> PairBlocks<'_, T, F> {
    #[inline(always)]
    fn run(self) -> usize {
        let Self {
            w,
            x,
            y,
            mut l,
            end,
            f,
        } = self;
        let m = w.len();
        // Rows with fewer than m taps, as in `SingleBlocks::run`.
        while l < end && l + 1 < m {
            if l + ROW_BLOCK <= end && l + ROW_BLOCK <= m {
                let taps = l + 1;
                let (s, d) = row_block_pair(&w[..taps], &x[..l + ROW_BLOCK], &y[..l + ROW_BLOCK]);
                for k in 0..ROW_BLOCK {
                    let r = l + k;
                    let (mut a, mut b) = (s[k], d[k]);
                    // Taps `taps..=r` against x[r − taps], …, x[0] (and y).
                    let (xt, yt) = (
                        x.get(..k).unwrap_or_default(),
                        y.get(..k).unwrap_or_default(),
                    );
                    let xy = xt.iter().rev().zip(yt.iter().rev());
                    for (&wj, (&xj, &yj)) in w.get(taps..=r).unwrap_or_default().iter().zip(xy) {
                        a = a + wj * xj;
                        b = b + wj * yj;
                    }
                    f(r, a, b);
                }
                l += ROW_BLOCK;
            } else {
                f(l, dot_rev(&w[..=l], &x[..=l]), dot_rev(&w[..=l], &y[..=l]));
                l += 1;
            }
        }
        while l + ROW_BLOCK <= end {
            // l + 1 ≥ m here, as in `SingleBlocks::run`.
            let (Some(xs), Some(ys)) = (
                x.get(l + 1 - m..l + ROW_BLOCK),
                y.get(l + 1 - m..l + ROW_BLOCK),
            ) else {
                break;
            };
            let (a, b) = row_block_pair(w, xs, ys);
            for k in 0..ROW_BLOCK {
                f(l + k, a[k], b[k]);
            }
            l += ROW_BLOCK;
        }
        while l < end {
            let (Some(xs), Some(ys)) = (x.get(l + 1 - m..=l), y.get(l + 1 - m..=l)) else {
                break;
            };
            f(l, dot_rev(w, xs), dot_rev(w, ys));
            l += 1;
        }
        l
    }
}

/// Runs a block loop compiled for the widest vector unit of this x86-64
/// CPU (AVX2 when present, detected once at run time by
/// `pulp`; SSE2 otherwise), so that the `*_lanes` kernels inlined into it
/// use wide vectors. Each row's sum keeps its order (no fused multiply-add:
/// Rust never contracts `a * b + c`), so the values do not depend on the
/// CPU (checked by `dot_tests::row_sums_are_bit_identical_to_one_row_at_a_time`).
#[cfg(all(target_arch = "x86_64", feature = "host-simd"))]
#[inline(always)]
fn host_simd<Op: pulp::WithSimd<Output = usize>>(op: Op) -> usize {
    pulp::Arch::new().dispatch(op)
}

#[cfg(all(target_arch = "x86_64", feature = "host-simd"))]
impl<T: Real, F: FnMut(usize, T)> pulp::WithSimd for SingleBlocks<'_, T, F> {
    type Output = usize;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> usize {
        self.run()
    }
}

#[cfg(all(target_arch = "x86_64", feature = "host-simd"))]
impl<T: Real, F: FnMut(usize, T, T)> pulp::WithSimd for PairBlocks<'_, T, F> {
    type Output = usize;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> usize {
        self.run()
    }
}

/// Runs a block loop (no run-time dispatch on this target or without the
/// `host-simd` feature).
#[cfg(not(all(target_arch = "x86_64", feature = "host-simd")))]
#[inline(always)]
fn host_simd<Op: BlockLoop>(op: Op) -> usize {
    op.run_loop()
}

/// A block loop, for [`host_simd`] without dispatch.
#[cfg(not(all(target_arch = "x86_64", feature = "host-simd")))]
trait BlockLoop {
    fn run_loop(self) -> usize;
}

#[cfg(not(all(target_arch = "x86_64", feature = "host-simd")))]
impl<T: Real, F: FnMut(usize, T)> BlockLoop for SingleBlocks<'_, T, F> {
    #[inline(always)]
    fn run_loop(self) -> usize {
        self.run()
    }
}

#[cfg(not(all(target_arch = "x86_64", feature = "host-simd")))]
impl<T: Real, F: FnMut(usize, T, T)> BlockLoop for PairBlocks<'_, T, F> {
    #[inline(always)]
    fn run_loop(self) -> usize {
        self.run()
    }
}

#[cfg(test)]
mod dot_tests;
