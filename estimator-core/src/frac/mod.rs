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
    /// Weights for order `alpha`, sample period `h` (seconds, or 1 for a
    /// dimensionless sampled system) and memory length `len`.
    ///
    /// # Errors
    /// [`FracError::NonFiniteOrder`] for a NaN/∞ order,
    /// [`FracError::BadSamplePeriod`] unless `h` is finite and positive,
    /// [`FracError::BadMemory`] unless `1 ≤ len ≤ MEM`.
    pub fn new(alpha: T, h: T, len: usize) -> Result<Self, FracError> {
        // The weights of (α, h, len) = (0, 1, 1), so that `set` may keep them.
        let mut w = [T::zero(); MEM];
        if let Some(w0) = w.first_mut() {
            *w0 = T::one();
        }
        let mut me = Self {
            alpha: T::zero(),
            h: T::one(),
            len: 1,
            scale: T::one(),
            ln_h: T::zero(),
            w,
            dw: [T::zero(); MEM],
        };
        me.set(alpha, h, len)?;
        Ok(me)
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

/// Rows of a block kernel.
pub(crate) const BLOCK: usize = 4;

/// The tap sums of [`BLOCK`] consecutive rows with `m = w.len()` taps each:
/// `xs` holds the `m − 1` samples before the first row and then the rows'
/// own samples (`m + 3` in all), and row `b` gets
/// `Σ_j w[j]·xs[m − 1 + b − j]`.
///
/// Each tap loads its weight once for the four rows, and each sample is
/// loaded once and then shifted from row to row in registers: about half
/// the loads of four [`dot_rev`] calls (measured in `docs/performance.md`).
/// Every row still adds its taps in order `j = 0, 1, …`, so the sums are
/// bit-identical to [`dot_rev`].
#[inline]
#[cfg_attr(not(target_arch = "arm"), allow(dead_code))]
fn block_sums<T: Real>(w: &[T], xs: &[T]) -> [T; BLOCK] {
    let m = w.len();
    // Every caller passes exactly `m + 3` samples; the check is for the
    // optimizer, which cannot see it across the call (NaN if ever broken).
    let Some(xs) = xs.get(..m + BLOCK - 1) else {
        return [T::nan(); BLOCK];
    };
    // The samples of rows 1..3 at the current tap.
    let mut xr = [xs[m], xs[m + 1], xs[m + 2]];
    let mut s = [T::zero(); BLOCK];
    // Eight taps at a time, as two runs of four written out (see
    // [`four_taps`]): the samples stay in registers, and only the three
    // carried into the next eight are moved.
    let wc = w.chunks_exact(8);
    let w4 = wc.remainder();
    let xc = xs[..m].rchunks_exact(8);
    let x4 = xc.remainder();
    for (wq, xq) in wc.zip(xc) {
        xr = four_taps(&mut s, &wq[..4], &xq[4..], xr);
        xr = four_taps(&mut s, &wq[4..], &xq[..4], xr);
    }
    let (wc, wr) = w4.as_chunks::<4>();
    let (xt, xc) = x4.as_rchunks::<4>();
    for (wq, xq) in wc.iter().zip(xc.iter().rev()) {
        xr = four_taps(&mut s, wq, xq, xr);
    }
    for (&wj, &x0) in wr.iter().zip(xt.iter().rev()) {
        let [a, b, c] = xr;
        tap(&mut s, wj, [x0, a, b, c]);
        xr = [x0, a, b];
    }
    s
}

/// Four taps `wq` of a block: `xq = [x(l−j−3), …, x(l−j)]` for row 0 at
/// taps `j..j+3` and `xr` the samples of rows 1..3 at tap `j`; returns the
/// samples of rows 1..3 at tap `j + 4`.
#[inline(always)]
#[cfg_attr(not(target_arch = "arm"), allow(dead_code))]
fn four_taps<T: Real>(s: &mut [T; BLOCK], wq: &[T], xq: &[T], xr: [T; 3]) -> [T; 3] {
    let [a, b, c] = xr;
    tap(s, wq[0], [xq[3], a, b, c]);
    tap(s, wq[1], [xq[2], xq[3], a, b]);
    tap(s, wq[2], [xq[1], xq[2], xq[3], a]);
    tap(s, wq[3], [xq[0], xq[1], xq[2], xq[3]]);
    [xq[0], xq[1], xq[2]]
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

/// The block kernel of this target for one sequence: [`block_sums`] on
/// Arm, [`block_sums_lanes`] elsewhere.
#[inline(always)]
pub(crate) fn row_block<T: Real>(w: &[T], xs: &[T]) -> [T; ROW_BLOCK] {
    #[cfg(target_arch = "arm")]
    return block_sums(w, xs);
    #[cfg(not(target_arch = "arm"))]
    return block_sums_lanes::<T, ROW_BLOCK>(w, xs);
}

/// Rows of a block of [`single_sums`] (sums over known samples only): 8
/// on every target.
pub(crate) const SUM_ROWS: usize = 8;

/// The block kernel of [`single_sums`]: [`block_sums8`] on Arm,
/// [`block_sums_lanes`] elsewhere.
#[inline(always)]
fn sum_block<T: Real>(w: &[T], xs: &[T]) -> [T; SUM_ROWS] {
    #[cfg(target_arch = "arm")]
    return block_sums8(w, xs);
    #[cfg(not(target_arch = "arm"))]
    return block_sums_lanes::<T, SUM_ROWS>(w, xs);
}

/// The tap sums of eight consecutive rows, as [`block_sums`] for four:
/// `xs` holds the `m − 1` samples before the first row and then the rows'
/// own samples (`m + 7` in all), and row `b` gets
/// `Σ_j w[j]·xs[m − 1 + b − j]`, its taps added in order (bit-identical to
/// [`dot_rev`]).
///
/// Eight taps at a time: the eight rows read fifteen samples, eight new
/// and seven carried from the last eight taps, so each weight and each
/// sample is loaded once for eight rows (twice the rows of
/// [`block_sums`], for the sums whose rows are all known beforehand:
/// a recursion's block cannot be longer than the taps it leaves out).
#[inline]
#[cfg_attr(not(target_arch = "arm"), allow(dead_code))]
fn block_sums8<T: Real>(w: &[T], xs: &[T]) -> [T; 8] {
    let m = w.len();
    // Every caller passes exactly `m + 7` samples (NaN if ever broken).
    let (Some(x), Some(&hi)) = (
        xs.get(..m),
        xs.get(m..m + 7).and_then(|h| h.first_chunk::<7>()),
    ) else {
        return [T::nan(); 8];
    };
    let mut s = [T::zero(); 8];
    // The samples of rows 1..7 at the current tap.
    let mut hi: [T; 7] = hi;
    let (wc, wr) = w.as_chunks::<8>();
    let (xt, xc) = x.as_rchunks::<8>();
    for (wq, xq) in wc.iter().zip(xc.iter().rev()) {
        // t[7 + b − k]: row b's sample at the chunk's tap k.
        let t: [T; 15] = core::array::from_fn(|k| if k < 8 { xq[k] } else { hi[k - 8] });
        for (k, &wk) in wq.iter().enumerate() {
            for (b, sb) in s.iter_mut().enumerate() {
                *sb = *sb + wk * t[7 + b - k];
            }
        }
        hi = core::array::from_fn(|k| xq[k]);
    }
    // The last taps, one at a time (none when 8 divides m).
    for (&wk, &x0) in wr.iter().zip(xt.iter().rev()) {
        let t: [T; 8] = core::array::from_fn(|b| if b == 0 { x0 } else { hi[b - 1] });
        for (sb, &tb) in s.iter_mut().zip(&t) {
            *sb = *sb + wk * tb;
        }
        hi = core::array::from_fn(|k| t[k]);
    }
    s
}

/// The block kernel of this target for two sequences:
/// [`block_sums_pair`] on Arm, [`block_sums_pair_lanes`] elsewhere.
#[inline(always)]
pub(crate) fn row_block_pair<T: Real>(
    w: &[T],
    xs: &[T],
    ys: &[T],
) -> ([T; ROW_BLOCK], [T; ROW_BLOCK]) {
    #[cfg(target_arch = "arm")]
    return block_sums_pair(w, xs, ys);
    #[cfg(not(target_arch = "arm"))]
    return block_sums_pair_lanes::<T, ROW_BLOCK>(w, xs, ys);
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

/// One tap of a block: `s[b] += w·x[b]`.
#[inline(always)]
fn tap<T: Real>(s: &mut [T; BLOCK], w: T, x: [T; BLOCK]) {
    for b in 0..BLOCK {
        s[b] = s[b] + w * x[b];
    }
}

/// Rows of a block of [`pair_sums`] and of the recursions of
/// `battery::simulate`: 4 on Arm ([`block_sums`], [`block_sums_pair`]),
/// 8 on hosts with vector units ([`block_sums_lanes`],
/// [`block_sums_pair_lanes`]). ([`single_sums`] takes [`SUM_ROWS`].)
#[cfg(target_arch = "arm")]
pub(crate) const ROW_BLOCK: usize = BLOCK;
/// Rows of a block of [`pair_sums`] and of the recursions of
/// `battery::simulate`: 4 on Arm ([`block_sums`], [`block_sums_pair`]),
/// 8 on hosts with vector units ([`block_sums_lanes`],
/// [`block_sums_pair_lanes`]). ([`single_sums`] takes [`SUM_ROWS`].)
#[cfg(not(target_arch = "arm"))]
pub(crate) const ROW_BLOCK: usize = 8;

/// [`block_sums`] of one weight set against two sequences at once, for
/// cores without vector units (the Cortex-M4F).
///
/// Four taps at a time, written out so that the samples stay in registers
/// without moves (the compiler does not unroll the rotating loop of two
/// sequences by itself: measured 21 instead of 11 instructions a tap on the
/// Cortex-M4F).
#[inline]
#[cfg_attr(not(target_arch = "arm"), allow(dead_code))]
fn block_sums_pair<T: Real>(w: &[T], xs: &[T], ys: &[T]) -> ([T; BLOCK], [T; BLOCK]) {
    let m = w.len();
    // As in [`block_sums`]: every caller passes `m + 3` samples of each.
    let (Some(xs), Some(ys)) = (xs.get(..m + BLOCK - 1), ys.get(..m + BLOCK - 1)) else {
        return ([T::nan(); BLOCK], [T::nan(); BLOCK]);
    };
    // x[1..4]: the samples of rows 1..3 at the current tap.
    let mut xr = [xs[m], xs[m + 1], xs[m + 2]];
    let mut yr = [ys[m], ys[m + 1], ys[m + 2]];
    let mut s = [T::zero(); BLOCK];
    let mut d = [T::zero(); BLOCK];
    // Eight taps at a time as in [`block_sums`], then four, then one.
    let (wc, w4) = w.as_chunks::<8>();
    let (x4, xc) = xs[..m].as_rchunks::<8>();
    let (y4, yc) = ys[..m].as_rchunks::<8>();
    for ((wq, xq), yq) in wc.iter().zip(xc.iter().rev()).zip(yc.iter().rev()) {
        // xq = [x(l−j−7), …, x(l−j)] for row 0 at taps j..j+7.
        xr = four_taps(&mut s, &wq[..4], &xq[4..], xr);
        yr = four_taps(&mut d, &wq[..4], &yq[4..], yr);
        xr = four_taps(&mut s, &wq[4..], &xq[..4], xr);
        yr = four_taps(&mut d, &wq[4..], &yq[..4], yr);
    }
    let (wc, wr) = w4.as_chunks::<4>();
    let (xt, xc) = x4.as_rchunks::<4>();
    let (yt, yc) = y4.as_rchunks::<4>();
    for ((wq, xq), yq) in wc.iter().zip(xc.iter().rev()).zip(yc.iter().rev()) {
        xr = four_taps(&mut s, wq, xq, xr);
        yr = four_taps(&mut d, wq, yq, yr);
    }
    for ((&wj, &x0), &y0) in wr.iter().zip(xt.iter().rev()).zip(yt.iter().rev()) {
        let [a, b, c] = xr;
        let [p, q, r] = yr;
        tap(&mut s, wj, [x0, a, b, c]);
        tap(&mut d, wj, [y0, p, q, r]);
        xr = [x0, a, b];
        yr = [y0, p, q];
    }
    (s, d)
}

/// The host version of [`block_sums_pair`] for `K` rows: at tap `j` the
/// samples of the `K` rows are `K` consecutive samples, so each tap is a
/// few vector loads and multiply-adds (SSE2 on any x86-64). Each row still
/// adds its taps in order, so the sums are bit-identical to [`dot_rev`].
#[inline(always)]
#[cfg_attr(target_arch = "arm", allow(dead_code))]
fn block_sums_pair_lanes<T: Real, const K: usize>(w: &[T], xs: &[T], ys: &[T]) -> ([T; K], [T; K]) {
    let m = w.len();
    let (xs, ys) = (&xs[..m + K - 1], &ys[..m + K - 1]);
    let mut s = [T::zero(); K];
    let mut d = [T::zero(); K];
    for ((&wj, xv), yv) in w.iter().zip(xs.windows(K).rev()).zip(ys.windows(K).rev()) {
        for k in 0..K {
            s[k] = s[k] + wj * xv[k];
            d[k] = d[k] + wj * yv[k];
        }
    }
    (s, d)
}

/// The host version of [`block_sums`] for `K` rows, as
/// [`block_sums_pair_lanes`] for one sequence.
#[inline(always)]
#[cfg_attr(target_arch = "arm", allow(dead_code))]
fn block_sums_lanes<T: Real, const K: usize>(w: &[T], xs: &[T]) -> [T; K] {
    let m = w.len();
    let xs = &xs[..m + K - 1];
    let mut s = [T::zero(); K];
    for (&wj, xv) in w.iter().zip(xs.windows(K).rev()) {
        for k in 0..K {
            s[k] = s[k] + wj * xv[k];
        }
    }
    s
}

/// [`block_sums`] of two weight sets against the same samples at once.
#[inline]
fn block_sums2<T: Real>(w: &[T], dw: &[T], xs: &[T]) -> ([T; BLOCK], [T; BLOCK]) {
    let m = w.len();
    let (dw, xs) = (&dw[..m], &xs[..m + BLOCK - 1]);
    let (mut x1, mut x2, mut x3) = (xs[m], xs[m + 1], xs[m + 2]);
    let mut s = [T::zero(); BLOCK];
    let mut d = [T::zero(); BLOCK];
    for ((&wj, &dwj), &x0) in w.iter().zip(dw).zip(xs[..m].iter().rev()) {
        s[0] = s[0] + wj * x0;
        d[0] = d[0] + dwj * x0;
        s[1] = s[1] + wj * x1;
        d[1] = d[1] + dwj * x1;
        s[2] = s[2] + wj * x2;
        d[2] = d[2] + dwj * x2;
        s[3] = s[3] + wj * x3;
        d[3] = d[3] + dwj * x3;
        x3 = x2;
        x2 = x1;
        x1 = x0;
    }
    (s, d)
}

#[cfg(test)]
mod dot_tests;
