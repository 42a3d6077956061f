//! Simulation of the battery model from a current record.
//!
//! The Grünwald–Letnikov form of `τ·Δ^α U_p + U_p = R_ct·I` at sample `l`,
//! with `a = τ·h^(−α)` and memory `M`, is the implicit recursion
//!
//! ```text
//! (1 + a)·U_p(l) = R_ct·I(l) − a·Σ_{j=1}^{min(l, M−1)} w_j(α)·U_p(l − j)
//! U_t(l)         = U_oc(l) + R_i·I(l) + a·asinh(I(l)/i₀) + U_p(l)
//! ```
//!
//! started from rest (`U_p = 0` before the first sample). It costs `O(M)`
//! per sample. The same recursion, with other inputs, gives the
//! sensitivities of [`super::output_error`].

use super::CellParameters;
use crate::error::Error;
use crate::frac::{row_block, row_block_pair, GlWeights, ROW_BLOCK};
use crate::real::Real;

/// `Σ_{j=1}^{min(l, M−1)} w_j·x(l − j)`: the history part of the unscaled
/// Grünwald–Letnikov sum at index `l` (`x[..l]` must be filled).
#[inline]
pub(crate) fn history<T: Real>(w: &[T], x: &[T], l: usize) -> T {
    let taps = (l + 1).min(w.len());
    // `1 ≤ taps ≤ l + 1` and `l ≤ x.len()` at every caller; NaN if broken.
    let (Some(w), Some(x)) = (w.get(1..taps), x.get(l + 1 - taps..l)) else {
        return T::nan();
    };
    w.iter()
        .zip(x.iter().rev())
        .fold(T::zero(), |s, (&w, &x)| s + w * x)
}

/// Runs the constant-phase recursion over `x[warm..]`: for `l ≥ warm`,
/// `(1 + a)·x(l) = drive(l) − a·H(l)` with the history sum
/// `H(l) = Σ_{j=1}^{min(l, M−1)} w_j·x(l − j)`, and calls `seen(l, x(l),
/// H(l))` in increasing `l`. `x[..warm]` holds a given history (from data,
/// or nothing when starting from rest).
///
/// Rows with the full memory go [`ROW_BLOCK`] at a time: the taps
/// `j ≥ ROW_BLOCK` of a block reach only samples before it, known already,
/// so they are the block kernel of [`crate::frac`] (each weight and sample
/// loaded once for the block); each row then adds its first few taps and is
/// solved in order. The sums are those of [`history`] in another order
/// (equal up to rounding).
#[inline]
pub(crate) fn cpe_filter<T: Real>(
    w: &[T],
    a: T,
    warm: usize,
    x: &mut [T],
    mut drive: impl FnMut(usize) -> T,
    mut seen: impl FnMut(usize, T, T),
) {
    let inv = T::one() / (T::one() + a);
    let (m, n) = (w.len(), x.len());
    let mut l = warm;
    if m > ROW_BLOCK {
        while l < n && l + 1 < m {
            let h = history(w, x, l);
            x[l] = (drive(l) - a * h) * inv;
            seen(l, x[l], h);
            l += 1;
        }
        let (Some(w0), Some(w_far)) = (w.first_chunk::<ROW_BLOCK>(), w.get(ROW_BLOCK..)) else {
            return;
        };
        while l + ROW_BLOCK <= n {
            // l + 1 ≥ m > ROW_BLOCK here: the loop above has run the short rows.
            let Some(past) = x.get(l + 1 - m..l) else {
                break;
            };
            let known = row_block(w_far, past);
            // The block's rows and the ROW_BLOCK − 1 samples before them:
            // t[ROW_BLOCK − 1 + k] is x(l + k).
            let Some(Ok(t)) = x
                .get_mut(l + 1 - ROW_BLOCK..l + ROW_BLOCK)
                .map(<&mut [T; 2 * ROW_BLOCK - 1]>::try_from)
            else {
                break;
            };
            for (k, mut h) in known.into_iter().enumerate() {
                let r = l + k;
                for j in (1..ROW_BLOCK).rev() {
                    h = h + w0[j] * t[ROW_BLOCK - 1 + k - j];
                }
                let xr = (drive(r) - a * h) * inv;
                t[ROW_BLOCK - 1 + k] = xr;
                seen(r, xr, h);
            }
            l += ROW_BLOCK;
        }
    }
    while l < n {
        let h = history(w, x, l);
        x[l] = (drive(l) - a * h) * inv;
        seen(l, x[l], h);
        l += 1;
    }
}

/// [`cpe_filter`] of two sequences with the same weights and `a` at once
/// (`drive(l)` gives both drives), for the sensitivities: each block loads
/// a weight once for both ([`crate::frac`]'s pair kernel). Each sequence
/// gets exactly the values [`cpe_filter`] gives it alone.
#[inline]
pub(crate) fn cpe_filter_pair<T: Real>(
    w: &[T],
    a: T,
    warm: usize,
    x: &mut [T],
    y: &mut [T],
    drive: impl FnMut(usize) -> (T, T),
) {
    cpe_filter_pair_seen(w, a, warm, x, y, drive, |_, _, _| {});
}

/// [`cpe_filter_pair`] that also calls `seen(l, x(l), H_x(l))` for the
/// first sequence, as [`cpe_filter`] does (for the simulation paired with
/// a free response).
#[inline]
pub(crate) fn cpe_filter_pair_seen<T: Real>(
    w: &[T],
    a: T,
    warm: usize,
    x: &mut [T],
    y: &mut [T],
    mut drive: impl FnMut(usize) -> (T, T),
    mut seen: impl FnMut(usize, T, T),
) {
    let inv = T::one() / (T::one() + a);
    let (m, n) = (w.len(), x.len().min(y.len()));
    let mut l = warm;
    let mut solve = |l: usize, hx: T, hy: T| {
        let (dx, dy) = drive(l);
        let (xl, yl) = ((dx - a * hx) * inv, (dy - a * hy) * inv);
        seen(l, xl, hx);
        (xl, yl)
    };
    if m > ROW_BLOCK {
        while l < n && l + 1 < m {
            let (hx, hy) = (history(w, x, l), history(w, y, l));
            let Some((xl, yl)) = x.get_mut(l).zip(y.get_mut(l)) else {
                return;
            };
            (*xl, *yl) = solve(l, hx, hy);
            l += 1;
        }
        let (Some(w0), Some(w_far)) = (w.first_chunk::<ROW_BLOCK>(), w.get(ROW_BLOCK..)) else {
            return;
        };
        while l + ROW_BLOCK <= n {
            // As in `cpe_filter`: l + 1 ≥ m here, and t[ROW_BLOCK − 1 + k] is x(l + k).
            let (Some(px), Some(py)) = (x.get(l + 1 - m..l), y.get(l + 1 - m..l)) else {
                break;
            };
            let (kx, ky) = row_block_pair(w_far, px, py);
            let rows = l + 1 - ROW_BLOCK..l + ROW_BLOCK;
            let (Some(Ok(tx)), Some(Ok(ty))) = (
                x.get_mut(rows.clone())
                    .map(<&mut [T; 2 * ROW_BLOCK - 1]>::try_from),
                y.get_mut(rows).map(<&mut [T; 2 * ROW_BLOCK - 1]>::try_from),
            ) else {
                break;
            };
            for (k, (mut hx, mut hy)) in kx.into_iter().zip(ky).enumerate() {
                for j in (1..ROW_BLOCK).rev() {
                    hx = hx + w0[j] * tx[ROW_BLOCK - 1 + k - j];
                    hy = hy + w0[j] * ty[ROW_BLOCK - 1 + k - j];
                }
                (tx[ROW_BLOCK - 1 + k], ty[ROW_BLOCK - 1 + k]) = solve(l + k, hx, hy);
            }
            l += ROW_BLOCK;
        }
    }
    while l < n {
        let (hx, hy) = (history(w, x, l), history(w, y, l));
        let Some((xl, yl)) = x.get_mut(l).zip(y.get_mut(l)) else {
            return;
        };
        (*xl, *yl) = solve(l, hx, hy);
        l += 1;
    }
}

/// Simulates the terminal voltage of a cell with parameters `p` for the
/// current record `current` (A, positive when charging), from rest.
///
/// `w` supplies the sample period and the memory length (its order is set
/// to `p.alpha`); `ocv(l)` is the open-circuit voltage at sample `l` (use
/// `|_| p.u_oc` for a constant one, or an OCV(SOC) curve). `up` receives the
/// polarization voltage `U_p` and `voltage` the terminal voltage `U_t`; both
/// must be at least as long as `current`.
///
/// # Errors
/// [`Error::BadSetting`] for non-physical parameters or short output
/// slices, [`Error::NonFiniteSample`] for a NaN/∞ current.
///
/// ```
/// use estimator_core::battery::{simulate::simulate, CellParameters};
/// use estimator_core::frac::GlWeights;
///
/// let p = CellParameters::<f64>::cell_18650();
/// let mut w = GlWeights::<f64, 512>::new(p.alpha, 1.0, 512).unwrap();
/// let current = [-5.0; 400]; // a 400 s discharge at 5 A
/// let (mut up, mut v) = ([0.0; 400], [0.0; 400]);
/// simulate(&p, &mut w, &current, |_| p.u_oc, &mut up, &mut v).unwrap();
/// // The instant drop is R_i·I; the polarization tends to R_ct·I.
/// assert!((v[0] - (3.7 - 5.0 * 0.020) - up[0]).abs() < 1e-12);
/// assert!((up[399] + 5.0 * 0.015).abs() < 0.01);
/// ```
pub fn simulate<T: Real, const MEM: usize>(
    p: &CellParameters<T>,
    w: &mut GlWeights<T, MEM>,
    current: &[T],
    ocv: impl Fn(usize) -> T,
    up: &mut [T],
    voltage: &mut [T],
) -> Result<(), Error> {
    let n = current.len();
    if !p.is_physical() || up.len() < n || voltage.len() < n {
        return Err(Error::BadSetting);
    }
    if current.iter().any(|i| !i.is_finite()) {
        return Err(Error::NonFiniteSample);
    }
    w.set_order(p.alpha)?;
    let a = p.tau() * w.scale();
    let up = &mut up[..n];
    cpe_filter(w.weights(), a, 0, up, |l| p.r_ct * current[l], |_, _, _| {});
    for l in 0..n {
        voltage[l] = ocv(l) + p.static_voltage(current[l]) + up[l];
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{cpe_filter, cpe_filter_pair, history};

    /// The blocked recursion equals the plain one row by row (up to
    /// rounding: its sums run in another order), for memories below, at and
    /// above the block size, from rest and from a given history, with
    /// lengths that leave partial blocks.
    #[test]
    fn blocked_recursion_equals_the_plain_one() {
        for m in [1, 2, 3, 7, 8, 9, 16, 33, 64] {
            let w: Vec<f64> = (0..m).map(|j| 0.9f64.powi(j as i32) - 0.3).collect();
            for (n, warm) in [(150, 0), (150, m - 1), (151, m + 5), (m + 3, 0), (5, 0)] {
                let a = 1.7;
                let drive = |l: usize| (0.3 * l as f64).sin() + 0.1;
                let history0: Vec<f64> = (0..n).map(|l| 0.5 - 0.01 * l as f64).collect();
                let mut plain = history0.clone();
                let mut sums = vec![f64::NAN; n];
                for l in warm..n {
                    let h = history(&w, &plain, l);
                    sums[l] = h;
                    plain[l] = (drive(l) - a * h) / (1.0 + a);
                }
                let mut x = history0.clone();
                let mut seen = vec![f64::NAN; n];
                let mut order = Vec::new();
                cpe_filter(&w, a, warm, &mut x, drive, |l, xl, h| {
                    order.push(l);
                    seen[l] = xl + h;
                });
                assert_eq!(
                    order,
                    (warm..n).collect::<Vec<_>>(),
                    "m {m} n {n} warm {warm}"
                );
                assert_eq!(x[..warm], history0[..warm]);
                for l in warm..n {
                    let tol = 1e-13 * (1.0 + plain[l].abs());
                    assert!(
                        (x[l] - plain[l]).abs() <= tol,
                        "m {m}, row {l}: {} vs {}",
                        x[l],
                        plain[l]
                    );
                    let e = plain[l] + sums[l];
                    assert!(
                        (seen[l] - e).abs() <= 1e-13 * (1.0 + e.abs()),
                        "m {m}, row {l}"
                    );
                }
                // The pair recursion gives each sequence exactly its single
                // recursion's values.
                let drive2 = |l: usize| (0.7 * l as f64).cos() - 0.2;
                let history1: Vec<f64> = (0..n).map(|l| (0.2 * l as f64).sin()).collect();
                let mut y1 = history1.clone();
                cpe_filter(&w, a, warm, &mut y1, drive2, |_, _, _| {});
                let (mut px, mut py) = (history0.clone(), history1.clone());
                cpe_filter_pair(&w, a, warm, &mut px, &mut py, |l| (drive(l), drive2(l)));
                assert_eq!(px, x, "m {m} n {n} warm {warm}");
                assert_eq!(py, y1, "m {m} n {n} warm {warm}");
            }
        }
    }
}
