//! The free-run simulation of the window (with the modes of its past beyond
//! the memory) and its cost.

use super::*;
use crate::battery::simulate::{cpe_filter, cpe_filter_pair};

/// Root mean square of a slice (0 for an empty one).
pub(super) fn rms<T: Real>(x: &[T]) -> T {
    let sum = x.iter().fold(T::zero(), |acc, &v| acc + v * v);
    (sum / T::lit(x.len().max(1) as f64)).sqrt()
}

/// The loaded window: current, voltage, charge still to flow, and the
/// number of warm-up samples.
#[derive(Clone, Copy)]
pub(super) struct WindowData<'a, T> {
    pub(super) i: &'a [T],
    pub(super) v: &'a [T],
    pub(super) c: &'a [T],
    pub(super) warm: usize,
    /// The taps beyond the memory ([`BatterySettings::tail`]), if added.
    pub(super) tail: Option<TailContext<'a, T>>,
}

/// What the tail beyond the memory needs from a window: its past's modes
/// (`None`: rest), the sample period and the memory.
#[derive(Clone, Copy)]
pub(super) struct TailContext<'a, T> {
    pub(super) past: Option<&'a PastModes<T>>,
    pub(super) h: T,
    pub(super) memory: usize,
}

/// The tail of one recursion: `Σ_{j≥M} ŵ_j·x(l − j) = Σ_k C_k·Z_k(l − M)`
/// with `C_k = c_k·r_k^M` and `Z_k(n) = r_k·Z_k(n − 1) + x(n)` from
/// `Z_k(−1) = z0_k`, the modes of the past.
#[derive(Clone, Copy)]
pub(super) struct Tail<T> {
    pub(super) rates: [T; MODES],
    pub(super) c: [T; MODES],
    pub(super) z0: [T; MODES],
}

impl<T: Real> Tail<T> {
    /// `C_k = x_k·r_k^M` for coefficients `x` (`c_k` or `∂c_k/∂α`).
    pub(super) fn scaled(kernel: &TailKernel<T>, x: &[T; MODES], memory: usize) -> [T; MODES] {
        core::array::from_fn(|k| x[k] * power(kernel.rates[k], memory))
    }
}

/// The tail context of settings `s` for a window with past `past` (`None`
/// when the settings add no tail).
pub(super) fn tail_context<'a, T: Real>(
    s: &BatterySettings<T>,
    past: Option<&'a PastModes<T>>,
) -> Option<TailContext<'a, T>> {
    s.uses_tail().then_some(TailContext {
        past,
        h: s.h,
        memory: s.memory,
    })
}

/// `x^n` by squaring (`powi` is a general `pow` call on some targets).
pub(super) fn power<T: Real>(mut x: T, mut n: usize) -> T {
    let mut y = T::one();
    while n > 0 {
        if n & 1 == 1 {
            y = y * x;
        }
        x = x * x;
        n >>= 1;
    }
    y
}

/// Rows of a chunk: the tail of a row reaches only rows at least `M` back,
/// so a chunk of at most `M` rows has all of its tails from rows solved
/// before it.
pub(super) const CHUNK: usize = 64;

/// [`cpe_filter`] with the tail `t` of `x` added to every row's history:
/// chunks of at most `min(M, CHUNK)` rows, each row's tail from the modes
/// of the rows before the chunk. The history passed to `seen` includes the
/// tail.
#[inline]
pub(super) fn cpe_filter_tail<T: Real>(
    w: &[T],
    a: T,
    warm: usize,
    x: &mut [T],
    t: &Tail<T>,
    mut drive: impl FnMut(usize) -> T,
    mut seen: impl FnMut(usize, T, T),
) {
    let (m, n) = (w.len(), x.len());
    let mut z = t.z0;
    let mut start = warm;
    while start < n {
        let end = (start + CHUNK.min(m)).min(n);
        let mut tb = [T::zero(); CHUNK];
        for (l, tl) in (start..end).zip(tb.iter_mut()) {
            // The sample leaving the memory, when there is one (l − m < l < n).
            if let Some(&xn) = l.checked_sub(m).and_then(|k| x.get(k)) {
                for (zk, &r) in z.iter_mut().zip(&t.rates) {
                    *zk = r * *zk + xn;
                }
            }
            *tl = t.c.iter().zip(&z).fold(T::zero(), |s, (&c, &z)| s + c * z);
        }
        // The filter calls back with start ≤ l < end ≤ start + CHUNK.
        let tail_at = |l: usize| tb.get(l.wrapping_sub(start)).map_or(T::nan(), |&t| t);
        cpe_filter(
            w,
            a,
            start,
            x.get_mut(..end).unwrap_or_default(),
            |l| drive(l) - a * tail_at(l),
            |l, xv, h| seen(l, xv, h + tail_at(l)),
        );
        start = end;
    }
}

/// [`cpe_filter_pair`] with tails `tx`, `ty` (same rates and coefficients,
/// their own past modes), as [`cpe_filter_tail`].
#[inline]
#[allow(clippy::too_many_arguments)]
pub(super) fn cpe_filter_pair_tail<T: Real>(
    w: &[T],
    a: T,
    warm: usize,
    x: &mut [T],
    y: &mut [T],
    tx: &Tail<T>,
    zy: [T; MODES],
    mut drive: impl FnMut(usize) -> (T, T),
) {
    let (m, n) = (w.len(), x.len().min(y.len()));
    let (mut px, mut py) = (tx.z0, zy);
    let mut start = warm;
    while start < n {
        let end = (start + CHUNK.min(m)).min(n);
        let (mut bx, mut by) = ([T::zero(); CHUNK], [T::zero(); CHUNK]);
        for (l, (bxl, byl)) in (start..end).zip(bx.iter_mut().zip(by.iter_mut())) {
            // The samples leaving the memory, as in `cpe_filter_tail`.
            let leaving = l.checked_sub(m);
            if let Some((&xn, &yn)) = leaving.and_then(|k| x.get(k).zip(y.get(k))) {
                for k in 0..MODES {
                    px[k] = tx.rates[k] * px[k] + xn;
                    py[k] = tx.rates[k] * py[k] + yn;
                }
            }
            let (mut sx, mut sy) = (T::zero(), T::zero());
            for k in 0..MODES {
                sx = sx + tx.c[k] * px[k];
                sy = sy + tx.c[k] * py[k];
            }
            *bxl = sx;
            *byl = sy;
        }
        let (Some(xe), Some(ye)) = (x.get_mut(..end), y.get_mut(..end)) else {
            return;
        };
        cpe_filter_pair(w, a, start, xe, ye, |l| {
            let (dx, dy) = drive(l);
            let k = l.wrapping_sub(start);
            let (tx, ty) = (bx.get(k), by.get(k));
            (
                dx - a * tx.map_or(T::nan(), |&t| t),
                dy - a * ty.map_or(T::nan(), |&t| t),
            )
        });
        start = end;
    }
}

/// Simulates `p` over a window into `buf` (weights already at `p.alpha`),
/// with the open-circuit voltage `U_oc − β·c(l)` (`c` the charge still to
/// flow), the first `warm` samples of `U_p` taken from the data, and returns
/// ½Σr² over the fitted samples `warm..`. `e` receives
/// `E(l) = Σ_{j≥0} w_j·U_p(l − j)` for the fitted samples, and `eta` the
/// kinetic voltage `η(I(l))` of `p` at every sample (see [`fill_kinetic`]).
#[allow(clippy::too_many_arguments)]
pub(super) fn simulate_window<T: Real, const MEM: usize>(
    solver: &mut impl BranchSolver<T>,
    w: &GlWeights<T, MEM>,
    data: &WindowData<'_, T>,
    p: &CellParameters<T>,
    beta: T,
    buf: &mut [T],
    e: &mut [T],
    eta: &mut [T],
) -> T {
    simulate_window_with_free(solver, w, data, p, beta, buf, e, eta, 0, None).0
}

/// [`simulate_window`], and with `free` (a sequence holding its history
/// in its first `warm` samples) the recursion's free response from that
/// history in the same pass ([`BranchSolver::filter_with_free`]): the
/// second value says whether `free` was filled (not with the tail's
/// modes, whose filters run one sequence).
#[allow(clippy::too_many_arguments)]
pub(super) fn simulate_window_with_free<T: Real, const MEM: usize>(
    solver: &mut impl BranchSolver<T>,
    w: &GlWeights<T, MEM>,
    data: &WindowData<'_, T>,
    p: &CellParameters<T>,
    beta: T,
    buf: &mut [T],
    e: &mut [T],
    eta: &mut [T],
    kept: usize,
    free: Option<&mut [T]>,
) -> (T, bool) {
    let mut filled = false;
    let WindowData {
        i,
        v,
        c,
        warm,
        tail,
        ..
    } = *data;
    fill_kinetic(p, i, eta, kept);
    let given = buf.iter_mut().zip(v).zip(c).zip(i).zip(eta.iter());
    for ((((b, &v), &c), &i), &eta) in given.take(warm) {
        *b = residual(v, p, beta, c, i, eta, T::zero());
    }
    let a = p.tau() * w.scale();
    match tail.and_then(|t| Some((t, TailKernel::new(p.alpha).ok()?))) {
        Some((t, kernel)) => {
            let z0 = match (t.past, c.first()) {
                (Some(past), Some(&c0)) => past.polarization(p.u_oc, p.r_i, beta, c0, t.h),
                _ => [T::zero(); MODES],
            };
            let tl = Tail {
                rates: kernel.rates,
                c: Tail::scaled(&kernel, &kernel.coefficients, t.memory),
                z0,
            };
            cpe_filter_tail(
                w.weights(),
                a,
                warm,
                buf,
                &tl,
                |l| drive_of(p, i, l),
                |l, x, h| store_sum(e, l, x, h),
            );
        }
        None => match free {
            Some(y) => {
                solver.filter_with_free(
                    w.weights(),
                    a,
                    warm,
                    buf,
                    y,
                    |l| drive_of(p, i, l),
                    |l, x, h| store_sum(e, l, x, h),
                );
                filled = true;
            }
            None => solver.filter(
                w.weights(),
                a,
                warm,
                buf,
                |l| drive_of(p, i, l),
                |l, x, h| store_sum(e, l, x, h),
            ),
        },
    }
    (window_cost(data, p, beta, eta, buf), filled)
}

/// The drive `R_ct·I(l)` of the constant-phase recursion (NaN past the
/// window: the filters call back with `l < n ≤ i.len()`).
#[inline(always)]
fn drive_of<T: Real>(p: &CellParameters<T>, i: &[T], l: usize) -> T {
    i.get(l).map_or(T::nan(), |&i| p.r_ct * i)
}

/// `e[l] = x + h` (nothing past `e`: the filters call back with `l < n`).
#[inline(always)]
fn store_sum<T: Real>(e: &mut [T], l: usize, x: T, h: T) {
    if let Some(e) = e.get_mut(l) {
        *e = x + h;
    }
}

/// `eta[l] = η(I(l))`, the kinetic voltage of `p` at each sample of `i`
/// (zeros in the linear model). The residuals, the kinetic columns of the
/// Jacobian and the history's kinetic free responses at the estimate all
/// read it: one `asinh` per sample and simulation, not one per use. The
/// first `kept` are `p`'s already and are not computed again.
#[inline]
pub(super) fn fill_kinetic<T: Real>(p: &CellParameters<T>, i: &[T], eta: &mut [T], kept: usize) {
    if p.bv_a != T::zero() {
        for (e, &il) in eta.iter_mut().zip(i).skip(kept) {
            // `kinetic_voltage` with `a ≠ 0` known, written out so that
            // the loop holds it; a rested sample (`asinh(±0) = ±0`) takes
            // no `asinh`.
            let x = il / p.bv_i0;
            *e = p.bv_a * if il == T::zero() { x } else { x.arsinh() };
        }
    } else {
        eta.iter_mut().zip(i).for_each(|(e, _)| *e = T::zero());
    }
}

/// The voltage residual `U_t − (U_oc − β·c + R_i·I + η + U_p)` of one
/// sample, with `eta` the kinetic voltage `η(I)` of `p` at its current
/// ([`CellParameters::kinetic_voltage`]).
/// `U_t − U_oc` comes first: the two are close (exact by Sterbenz's lemma
/// within a factor 2), so the rounding is that of the small remaining terms,
/// not of the 3–4 V terminal voltage. In `f32` this is the difference
/// between a cost that resolves a step's decrease and one whose rounding
/// (ulp(3.7 V) ≈ 2.4e−7 V against millivolt residuals) hides it.
#[inline]
pub(super) fn residual<T: Real>(
    v: T,
    p: &CellParameters<T>,
    beta: T,
    c: T,
    i: T,
    eta: T,
    up: T,
) -> T {
    (v - p.u_oc) + beta * c - (p.r_i * i + eta) - up
}

/// ½Σr² over the fitted samples of the simulation `up` of `p`, β, with
/// `eta` its kinetic voltages ([`fill_kinetic`]).
#[inline]
pub(super) fn window_cost<T: Real>(
    data: &WindowData<'_, T>,
    p: &CellParameters<T>,
    beta: T,
    eta: &[T],
    up: &[T],
) -> T {
    let WindowData { i, v, c, warm, .. } = *data;
    let n = up
        .len()
        .min(v.len())
        .min(c.len())
        .min(i.len())
        .min(eta.len());
    let mut cost = T::zero();
    // The fitted rows as equally long slices (one index for all five: the
    // loop keeps its pointers in registers), summed in order.
    if let (Some(up), Some(v), Some(c), Some(i), Some(eta)) = (
        up.get(warm..n),
        v.get(warm..n),
        c.get(warm..n),
        i.get(warm..n),
        eta.get(warm..n),
    ) {
        // Four rows a chunk: each slice's pointer moves once a chunk, and
        // the rows' loads take immediate offsets (the Cortex-M4F's `VLDR`
        // has no register offset). The rows are still added in order.
        const ROWS: usize = 4;
        let chunks = up
            .chunks_exact(ROWS)
            .zip(v.chunks_exact(ROWS))
            .zip(c.chunks_exact(ROWS))
            .zip(i.chunks_exact(ROWS))
            .zip(eta.chunks_exact(ROWS));
        for ((((u4, v4), c4), i4), e4) in chunks {
            for k in 0..ROWS {
                let r = residual(v4[k], p, beta, c4[k], i4[k], e4[k], u4[k]);
                cost = cost + r * r;
            }
        }
        for l in up.len() - up.len() % ROWS..up.len() {
            let r = residual(v[l], p, beta, c[l], i[l], eta[l], up[l]);
            cost = cost + r * r;
        }
        if cost.is_nan() {
            // Unobserved samples (NaN voltages) are left out: summed again
            // without them (only on such windows; the loop above stays
            // branch-free).
            cost = T::zero();
            for l in 0..up.len() {
                if !v[l].is_nan() {
                    let r = residual(v[l], p, beta, c[l], i[l], eta[l], up[l]);
                    cost = cost + r * r;
                }
            }
        }
    }
    cost / T::lit(2.0)
}
