//! Row writes of the regression's windows: the slide by one sample and the
//! stores the difference kernels call back with a row index. They own no
//! state; each writes only the slots of the row it is given, and nothing
//! past the arrays (the kernels call back with rows `l < n ≤ N`, so the
//! checks that stand for the bounds never fail; they keep the sample step
//! free of panic paths, see `docs/panic-paths.md`).

use crate::real::Real;

/// Drops the oldest sample of a window: `x[k − 1] = x[k]` for `k ≥ 1` (what
/// `x.copy_within(1.., 0)` does, without its out-of-line range checks).
#[inline]
pub(super) fn slide_one<T: Copy>(x: &mut [T]) {
    for k in 1..x.len() {
        x[k - 1] = x[k];
    }
}

/// The regressors of row `l` from its fractional differences `d` (of I)
/// and `dv` (of v): `di[l] = d`, `hv[l] = dv − g·v[l]`. The kernels call
/// back with rows `l < n`; past the arrays nothing is written.
#[inline(always)]
pub(super) fn store_regressors<T: Real>(
    di: &mut [T],
    hv: &mut [T],
    v: &[T],
    g: T,
    l: usize,
    d: T,
    dv: T,
) {
    if let (Some(di), Some(hv), Some(&vl)) = (di.get_mut(l), hv.get_mut(l), v.get(l)) {
        *di = d;
        *hv = dv - g * vl;
    }
}

/// The order derivatives of row `l`'s regressors from the weight-derivative
/// sums `a` (of I) and `b` (of v), as [`store_regressors`].
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn store_derivatives<T: Real>(
    ddi: &mut [T],
    dhv: &mut [T],
    di: &[T],
    hv: &[T],
    ln_h: T,
    l: usize,
    a: T,
    b: T,
) {
    if let (Some(x), Some(y), Some(&dl), Some(&hl)) =
        (ddi.get_mut(l), dhv.get_mut(l), di.get(l), hv.get(l))
    {
        *x = a - ln_h * dl;
        *y = b - ln_h * hl;
    }
}
