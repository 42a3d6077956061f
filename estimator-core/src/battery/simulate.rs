//! Simulation of the battery model from a current record.
//!
//! The Grünwald–Letnikov form of `τ·Δ^α U_p + U_p = R_ct·I` at sample `l`,
//! with `a = τ·h^(−α)` and memory `M`, is the implicit recursion
//!
//! ```text
//! (1 + a)·U_p(l) = R_ct·I(l) − a·Σ_{j=1}^{min(l, M−1)} w_j(α)·U_p(l − j)
//! U_t(l)         = U_oc(l) + R_i·I(l) + U_p(l)
//! ```
//!
//! started from rest (`U_p = 0` before the first sample). It costs `O(M)`
//! per sample. The same recursion, with other inputs, gives the
//! sensitivities of [`super::output_error`].

use super::CellParameters;
use crate::error::Error;
use crate::frac::GlWeights;
use crate::real::Real;

/// `Σ_{j=1}^{min(l, M−1)} w_j·x(l − j)`: the history part of the unscaled
/// Grünwald–Letnikov sum at index `l` (`x[..l]` must be filled).
#[inline]
pub(crate) fn history<T: Real>(w: &[T], x: &[T], l: usize) -> T {
    let taps = (l + 1).min(w.len());
    w[1..taps]
        .iter()
        .zip(x[l + 1 - taps..l].iter().rev())
        .fold(T::zero(), |s, (&w, &x)| s + w * x)
}

/// Runs the constant-phase recursion over `x[warm..]`: for `l ≥ warm`,
/// `(1 + a)·x(l) = drive(l) − a·Σ_{j≥1} w_j·x(l − j)`. `x[..warm]` holds a
/// given history (from data, or nothing when starting from rest).
#[inline]
pub(crate) fn cpe_filter<T: Real>(
    w: &[T],
    a: T,
    warm: usize,
    x: &mut [T],
    mut drive: impl FnMut(usize, &[T]) -> T,
) {
    let inv = T::one() / (T::one() + a);
    for l in warm..x.len() {
        let h = history(w, x, l);
        let d = drive(l, x);
        x[l] = (d - a * h) * inv;
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
    cpe_filter(w.weights(), a, 0, up, |l, _| p.r_ct * current[l]);
    for l in 0..n {
        voltage[l] = ocv(l) + p.r_i * current[l] + up[l];
    }
    Ok(())
}
