//! The block kernels: the tap sums `Σ_j w_j·x(l − j)` of several
//! consecutive rows at once, each weight and each sample loaded once for
//! the rows of a block. One set per target: on the Cortex-M4F, kernels
//! written out for its 32 single-precision registers ([`block_sums`],
//! [`block_sums_pair`], [`block_sums8`]); on hosts, kernels over lanes
//! that the compiler vectorizes ([`block_sums_lanes`],
//! [`block_sums_pair_lanes`]). Every row adds its taps in order
//! `j = 0, 1, …`, so a kernel's sums are bit-identical to one row at a time
//! ([`dot_rev`](super::dot_rev); `dot_tests`).
//!
//! This module owns the kernels and the block sizes; the loops over a
//! record's rows (the short rows, the blocks, the last rows) and the
//! recursions that use the kernels are the parent's and
//! `battery::simulate`'s.

use crate::real::Real;

/// Rows of a block kernel.
pub(crate) const BLOCK: usize = 4;

/// The tap sums of [`BLOCK`] consecutive rows with `m = w.len()` taps each:
/// `xs` holds the `m − 1` samples before the first row and then the rows'
/// own samples (`m + 3` in all), and row `b` gets
/// `Σ_j w[j]·xs[m − 1 + b − j]`.
///
/// Each tap loads its weight once for the four rows, and each sample is
/// loaded once and then shifted from row to row in registers: about half
/// the loads of four [`dot_rev`](super::dot_rev) calls (measured in `docs/performance.md`).
/// Every row still adds its taps in order `j = 0, 1, …`, so the sums are
/// bit-identical to [`dot_rev`](super::dot_rev).
#[inline]
#[cfg_attr(not(target_arch = "arm"), allow(dead_code))]
pub(super) fn block_sums<T: Real>(w: &[T], xs: &[T]) -> [T; BLOCK] {
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

/// The block kernel of this target for one sequence: [`block_sums`] on
/// Arm ([`block_sums_far`] at the default memory), [`block_sums_lanes`]
/// elsewhere.
#[inline(always)]
pub(crate) fn row_block<T: Real>(w: &[T], xs: &[T]) -> [T; ROW_BLOCK] {
    #[cfg(target_arch = "arm")]
    if w.len() == FAR {
        if let (Some(w), Some(xs)) = (w.first_chunk::<FAR>(), xs.first_chunk::<FAR_SAMPLES>()) {
            return block_sums_far(w, xs);
        }
    }
    #[cfg(target_arch = "arm")]
    return block_sums(w, xs);
    #[cfg(not(target_arch = "arm"))]
    return block_sums_lanes::<T, ROW_BLOCK>(w, xs);
}

/// Rows of a block of [`single_sums`](super::single_sums) (sums over known samples only): 8
/// on every target.
pub(crate) const SUM_ROWS: usize = 8;

/// The block kernel of [`single_sums`](super::single_sums): [`block_sums8`] on Arm,
/// [`block_sums_lanes`] elsewhere.
#[inline(always)]
pub(super) fn sum_block<T: Real>(w: &[T], xs: &[T]) -> [T; SUM_ROWS] {
    #[cfg(target_arch = "arm")]
    return block_sums8(w, xs);
    #[cfg(not(target_arch = "arm"))]
    return block_sums_lanes::<T, SUM_ROWS>(w, xs);
}

/// The tap sums of eight consecutive rows, as [`block_sums`] for four:
/// `xs` holds the `m − 1` samples before the first row and then the rows'
/// own samples (`m + 7` in all), and row `b` gets
/// `Σ_j w[j]·xs[m − 1 + b − j]`, its taps added in order (bit-identical to
/// [`dot_rev`](super::dot_rev)).
///
/// Eight taps at a time: the eight rows read fifteen samples, eight new
/// and seven carried from the last eight taps, so each weight and each
/// sample is loaded once for eight rows (twice the rows of
/// [`block_sums`], for the sums whose rows are all known beforehand:
/// a recursion's block cannot be longer than the taps it leaves out).
#[inline]
#[cfg_attr(not(target_arch = "arm"), allow(dead_code))]
pub(super) fn block_sums8<T: Real>(w: &[T], xs: &[T]) -> [T; 8] {
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
    if w.len() == FAR {
        if let (Some(w), Some(xs), Some(ys)) = (
            w.first_chunk::<FAR>(),
            xs.first_chunk::<FAR_SAMPLES>(),
            ys.first_chunk::<FAR_SAMPLES>(),
        ) {
            return block_sums_pair_far(w, xs, ys);
        }
    }
    #[cfg(target_arch = "arm")]
    return block_sums_pair(w, xs, ys);
    #[cfg(not(target_arch = "arm"))]
    return block_sums_pair_lanes::<T, ROW_BLOCK>(w, xs, ys);
}

/// One tap of a block: `s[b] += w·x[b]`.
#[inline(always)]
fn tap<T: Real>(s: &mut [T; BLOCK], w: T, x: [T; BLOCK]) {
    for b in 0..BLOCK {
        s[b] = s[b] + w * x[b];
    }
}

/// Rows of a block of [`pair_sums`](super::pair_sums) and of the recursions of
/// `battery::simulate`: 4 on Arm ([`block_sums`], [`block_sums_pair`]),
/// 8 on hosts with vector units ([`block_sums_lanes`],
/// [`block_sums_pair_lanes`]). ([`single_sums`](super::single_sums) takes [`SUM_ROWS`].)
#[cfg(target_arch = "arm")]
pub(crate) const ROW_BLOCK: usize = BLOCK;
/// Rows of a block of [`pair_sums`](super::pair_sums) and of the recursions of
/// `battery::simulate`: 4 on Arm ([`block_sums`], [`block_sums_pair`]),
/// 8 on hosts with vector units ([`block_sums_lanes`],
/// [`block_sums_pair_lanes`]). ([`single_sums`](super::single_sums) takes [`SUM_ROWS`].)
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
pub(super) fn block_sums_pair<T: Real>(w: &[T], xs: &[T], ys: &[T]) -> ([T; BLOCK], [T; BLOCK]) {
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

/// The taps of a block's far part at the default memory of 64 samples
/// (`BatterySettings::memory`): the taps `j ≥ BLOCK`.
pub(crate) const FAR: usize = 64 - BLOCK;
/// The samples a far part of [`FAR`] taps reads for a block.
pub(crate) const FAR_SAMPLES: usize = FAR + BLOCK - 1;

/// [`four_taps`] of the `g`-th group of four taps of a far part of
/// [`FAR`] taps: weights `w[4g..4g + 4]`, samples `xs[FAR − 4 − 4g..FAR − 4g]`
/// (the order of [`block_sums`]' loops: every row adds its taps in order).
macro_rules! far_groups {
    ($w:ident, $($x:ident, $s:ident, $r:ident);+) => {
        far_group!(0, $w, $($x, $s, $r);+);
        far_group!(1, $w, $($x, $s, $r);+);
        far_group!(2, $w, $($x, $s, $r);+);
        far_group!(3, $w, $($x, $s, $r);+);
        far_group!(4, $w, $($x, $s, $r);+);
        far_group!(5, $w, $($x, $s, $r);+);
        far_group!(6, $w, $($x, $s, $r);+);
        far_group!(7, $w, $($x, $s, $r);+);
        far_group!(8, $w, $($x, $s, $r);+);
        far_group!(9, $w, $($x, $s, $r);+);
        far_group!(10, $w, $($x, $s, $r);+);
        far_group!(11, $w, $($x, $s, $r);+);
        far_group!(12, $w, $($x, $s, $r);+);
        far_group!(13, $w, $($x, $s, $r);+);
        far_group!(14, $w, $($x, $s, $r);+);
    };
}

/// One group of [`far_groups`], for each sequence in turn.
macro_rules! far_group {
    ($g:literal, $w:ident, $($x:ident, $s:ident, $r:ident);+) => {
        $(
            $r = four_taps(&mut $s, &$w[4 * $g..4 * $g + 4], &$x[FAR - 4 - 4 * $g..FAR - 4 * $g], $r);
        )+
    };
}

/// [`block_sums`] with exactly [`FAR`] taps, written out in full: the
/// memory of 64 of every default setting. The same sums in the same order
/// (bit-identical, `dot_tests`), without the loops' counters and the
/// tail's branches: about a tenth fewer instructions a block on the
/// Cortex-M4F (docs/performance.md).
#[inline]
#[cfg_attr(not(target_arch = "arm"), allow(dead_code))]
// (The last group's carried samples are not read.)
#[allow(unused_assignments)]
pub(super) fn block_sums_far<T: Real>(w: &[T; FAR], xs: &[T; FAR_SAMPLES]) -> [T; BLOCK] {
    let mut xr = [xs[FAR], xs[FAR + 1], xs[FAR + 2]];
    let mut s = [T::zero(); BLOCK];
    far_groups!(w, xs, s, xr);
    s
}

/// [`block_sums_pair`] with exactly [`FAR`] taps, written out in full as
/// [`block_sums_far`].
#[inline]
#[cfg_attr(not(target_arch = "arm"), allow(dead_code))]
// (The last group's carried samples are not read.)
#[allow(unused_assignments)]
pub(super) fn block_sums_pair_far<T: Real>(
    w: &[T; FAR],
    xs: &[T; FAR_SAMPLES],
    ys: &[T; FAR_SAMPLES],
) -> ([T; BLOCK], [T; BLOCK]) {
    let mut xr = [xs[FAR], xs[FAR + 1], xs[FAR + 2]];
    let mut yr = [ys[FAR], ys[FAR + 1], ys[FAR + 2]];
    let mut s = [T::zero(); BLOCK];
    let mut d = [T::zero(); BLOCK];
    far_groups!(w, xs, s, xr; ys, d, yr);
    (s, d)
}

/// The host version of [`block_sums_pair`] for `K` rows: at tap `j` the
/// samples of the `K` rows are `K` consecutive samples, so each tap is a
/// few vector loads and multiply-adds (SSE2 on any x86-64). Each row still
/// adds its taps in order, so the sums are bit-identical to [`dot_rev`](super::dot_rev).
#[inline(always)]
#[cfg_attr(target_arch = "arm", allow(dead_code))]
pub(super) fn block_sums_pair_lanes<T: Real, const K: usize>(
    w: &[T],
    xs: &[T],
    ys: &[T],
) -> ([T; K], [T; K]) {
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
pub(super) fn block_sums_lanes<T: Real, const K: usize>(w: &[T], xs: &[T]) -> [T; K] {
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
pub(super) fn block_sums2<T: Real>(w: &[T], dw: &[T], xs: &[T]) -> ([T; BLOCK], [T; BLOCK]) {
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
