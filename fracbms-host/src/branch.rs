//! The constant-phase branch solved exactly in `O(N log N)`: the host's
//! [`BranchSolver`] for whole-record fits with the full memory.
//!
//! The recursion `(1 + a)·x(l) = drive(l) − a·Σ_{j=1}^{M−1} w_j·x(l − j)`
//! is the convolution `d ∗ x = drive` with `d = δ + a·w`. Its solution from
//! a history `x[..warm]` is `x = g ∗ f` over the rows `l ≥ warm`, with
//! `g = 1/d` the power series of the inverse (its first `N` coefficients)
//! and `f = drive − a·(w ∗ x_history)`. With the whole memory, `w` is the
//! series of `(1 − z)^α` and `g` that of `1/(1 + a·(1 − z)^α)`, known in
//! closed form on a circle of radius `r` just inside the unit circle
//! (`r^S = 1e−9`, `S` the transform size): a solution from rest is the
//! drive's series there (`f_k·r^k` transformed) times `g`'s, transformed
//! back and unscaled by `r^{−k}`, one transform for `g` where taking its
//! coefficients and their spectrum took two more; the solution's terms
//! from `S` on fold in times `r^S`, and the rounding is unscaled by at
//! most `r^{−S/2}`. A history, a pair of drives or the unit branch convolve
//! with `g`'s coefficients instead (taken from the circle when first
//! needed); with a shorter memory they come from Newton's iteration
//! `g ← g + g·(1 − d·g)` on FFTs of doubling size (about ten transforms).
//! Every transform has a size `S` at least `2N` with no prime factor
//! above 5 ([`realfft`]), so no convolution wraps: the values are those
//! of the direct recursion
//! ([`estimator_core::battery::branch::GlRecursion`]) to within 1e−9 of
//! the largest value (tests, to 65 536 rows, `a` from 1e−4 to 1e4; below
//! 1e−11 in the example). From rest, the history sums `w ∗ x` the
//! refinement reads come from the recursion itself, `x + a·(w ∗ x) =
//! drive`, with no transform, and the sensitivities' sums are taken on the
//! circle too, where `ln(1 − z)` is known (three transforms).
//!
//! The spectra of `w`, `∂w/∂α` and `g` are kept while the order, `a` and
//! the window are unchanged (one refinement iteration changes them once
//! per trial); `w`'s is taken only when a history or a derivative needs
//! it. From rest, a drive that is a multiple of the last one (a fit's
//! `R_ct·I` at each `R_ct` it tries) takes that one's spectrum, scaled:
//! one transform a solution. Below [`DIRECT_TAPS`] taps
//! the direct recursion is cheaper and is used instead. This module owns
//! the transforms only; the model, the search and the weights are
//! `estimator-core`'s. The transforms themselves, their sizes and the
//! spectra kept by value are the `transforms` submodule's, the circle's
//! points the `circle` one's, the working buffers a thread's solvers share
//! the `working` one's, and the paper regression's tap sums by the same
//! transforms the `sums` one's ([`FftSums`]).
//!
//! ```
//! use estimator_core::battery::branch::{BranchSolver, GlRecursion};
//! use estimator_core::frac::GlWeights;
//! use fracbms_host::branch::FftBranch;
//!
//! const N: usize = 2000;
//! let w = GlWeights::<f64, N>::new(0.6, 1.0, N).unwrap();
//! let drive = |l: usize| if (l / 100) % 2 == 0 { 1.0 } else { -1.0 };
//! let (mut direct, mut fast) = (vec![0.0; N], vec![0.0; N]);
//! GlRecursion.filter(w.weights(), 3.0, 0, &mut direct, drive, |_, _, _| {});
//! FftBranch::default().filter(w.weights(), 3.0, 0, &mut fast, drive, |_, _, _| {});
//! let worst = direct.iter().zip(&fast).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
//! // About 1e−11 of the largest value (here 0.91): the rounding of the
//! // circle's points, unscaled by up to r^(−N/2).
//! assert!(worst < 1e-11);
//! ```

use std::fmt;
use std::ops::Range;
use std::sync::Arc;

use estimator_core::battery::branch::{BranchSolver, GlRecursion};
use estimator_core::battery::CellParameters;
use estimator_core::frac::{fill_weights, GlWeights};
use realfft::num_complex::Complex;

mod circle;
mod sums;
mod transforms;
mod working;
use circle::Circle;
pub use sums::{FftSums, SUMS_DIRECT_ROWS, SUMS_DIRECT_TAPS};
use transforms::{product, proportion, transform_size, KeptSpectra, Spectrum};

/// Below this many taps (`min(M, N)`) the direct recursion is used: it is
/// cheaper than three transforms there.
pub const DIRECT_TAPS: usize = 128;

/// From this `a` up, [`BranchSolver::filter`] from rest takes the history
/// sums from the recursion itself (`E = (drive − x)/a`, exact up to
/// rounding, which `1/a` scales) instead of a convolution of `x` with the
/// weights.
const RECURSION_SUM_MIN_A: f64 = 0.1;

/// The FFT solver of the constant-phase recursion (see the module docs).
/// It holds the spectra of the last weights; a clone starts with none
/// (they are a cache). Its working buffers are its thread's
/// (`working::Working`) while one of its calls runs.
#[derive(Default)]
pub struct FftBranch {
    /// The working buffers: the thread's (`working::Working`) while a
    /// call runs, empty between calls.
    work: working::Working,
    /// The spectrum of the weights `w`.
    weights: Spectrum,
    /// The spectrum of the weights' order derivatives `∂w/∂α`.
    derivatives: Spectrum,
    /// The spectrum of `g = 1/(δ + a·w)`, and the `a` and rows it is for
    /// (with `weights.of` as its `w`).
    inverse: Spectrum,
    inverse_key: Option<(u64, usize)>,
    /// The circle `g` is evaluated on where `w` is the whole
    /// Grünwald–Letnikov series ([`FftBranch::eval_circle`]).
    circle: Arc<Circle>,
    /// `g` at the circle's points, `G(z_j)`, when `w` is the whole
    /// Grünwald–Letnikov series (else empty): the solutions and sums from
    /// rest are taken there, and `inverse`'s spectrum (then `stale`) from
    /// it only when another path needs it.
    g_circle: Vec<Complex<f64>>,
    /// The spectrum of `ℓ`, the series of `ln(1 − z)` (`−1/k` from
    /// `k = 1`), to the rows of the last unit branch.
    log_series: Spectrum,
    /// The drive of the last solution from rest, and its spectrum: a drive
    /// proportional to it (a fit's `R_ct·I`, at every `R_ct` it tries)
    /// takes that spectrum scaled instead of a transform ([`proportion`]).
    rest_drive: Spectrum,
    /// Where the kept drive's largest value is (the scale is read there).
    rest_peak: usize,
    /// The kept drive's spectrum is taken on the circle (`x_k·r^k`), not
    /// on the unit circle.
    rest_on_circle: bool,
    /// The spectra of the last drives of
    /// [`FftBranch::unit_branch_with_derivatives`] (a joint fit's knots
    /// each run to their own end: one per end), most recent last.
    drives: KeptSpectra,
    /// A call holds the thread's working buffers (`FftBranch::working`).
    in_call: bool,
}

impl Clone for FftBranch {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl fmt::Debug for FftBranch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("FftBranch")
            .field("size", &self.weights.size)
            .field("taps", &self.weights.of.len())
            .finish_non_exhaustive()
    }
}

impl FftBranch {
    /// The spectra of `w` and of `g = 1/(δ + a·w)` (first `n` terms) at
    /// the transform size of `n` rows.
    fn prepare(&mut self, w: &[f64], a: f64, n: usize) -> usize {
        let size = transform_size(n);
        let taps = &w[..w.len().min(n)];
        let wt = &mut self.weights;
        if wt.size != size || wt.of != taps {
            // The weights' own spectrum is taken when a history or a
            // derivative needs it ([`Self::weights_hat`]).
            wt.of.clear();
            wt.of.extend_from_slice(taps);
            wt.size = size;
            wt.stale = true;
            self.inverse_key = None;
        }
        if self.inverse_key != Some((a.to_bits(), n)) {
            match gl_order(taps, n) {
                Some(alpha) => {
                    self.eval_circle(alpha, a, size);
                    self.inverse.stale = true;
                }
                None => {
                    let d: Vec<f64> = taps
                        .iter()
                        .enumerate()
                        .map(|(j, &wj)| a * wj + if j == 0 { 1.0 } else { 0.0 })
                        .collect();
                    let g = self.inverse_series(&d, n);
                    self.work.t.forward(&g, size, &mut self.inverse.hat);
                    self.g_circle.clear();
                    self.inverse.stale = false;
                }
            }
            self.inverse.size = size;
            self.inverse_key = Some((a.to_bits(), n));
        }
        size
    }

    /// Whether `g` is held on the circle (the whole memory).
    fn on_circle(&self) -> bool {
        !self.g_circle.is_empty()
    }

    /// The spectrum of `g` (its first `n` terms, `n` the rows prepared) on
    /// the unit circle, taken now from the circle's values if it was not:
    /// `G(z_j)` transformed back, unscaled by `r^{−k}` and transformed.
    fn inverse_hat(&mut self, n: usize) {
        if !self.inverse.stale {
            return;
        }
        let size = self.inverse.size;
        self.work.spec.clear();
        self.work.spec.extend_from_slice(&self.g_circle);
        let mut g = Vec::with_capacity(size);
        self.work.t.backward(&mut self.work.spec, size, &mut g);
        g.truncate(n);
        unscale(&mut g, self.circle.ln_r);
        self.work.t.forward(&g, size, &mut self.inverse.hat);
        self.inverse.stale = false;
    }

    /// The spectrum of the weights last prepared, taken now if it was not.
    fn weights_hat(&mut self) {
        let wt = &mut self.weights;
        if wt.stale {
            self.work.t.forward(&wt.of, wt.size, &mut wt.hat);
            wt.stale = false;
        }
    }

    /// `g = 1/(1 + a·(1 − z)^α)`, the inverse series of `δ + a·w` when `w`
    /// is the Grünwald–Letnikov series of order α to all `n` terms, at the
    /// points of the [`Circle`] of transform size `size` (`≥ 2n`), into
    /// `g_circle`: no transform. A product with a sequence's spectrum
    /// there (`x_k·r^k` transformed) transformed back and unscaled by
    /// `r^{−k}` is the convolution with `g` ([`Self::back_from_circle`]),
    /// the terms from `size` on folded in times `r^{size}`.
    fn eval_circle(&mut self, alpha: f64, a: f64, size: usize) {
        if self.circle.size != size {
            self.circle = Circle::of(size);
        }
        let c = &*self.circle;
        let spec = &mut self.g_circle;
        spec.clear();
        if alpha.abs() <= 1.0 {
            c.inverse_at_points(alpha, a, spec);
        } else {
            spec.extend(c.ln_modulus.iter().zip(&c.arg).map(|(&l, &t)| {
                let m = a * (alpha * l).exp();
                let (sn, cs) = (alpha * t).sin_cos();
                (Complex::new(1.0, 0.0) + Complex::new(m * cs, m * sn)).inv()
            }));
        }
    }

    /// `spec` (a product of spectra on the circle, clobbered) transformed
    /// back and unscaled by `r^{−k}`: its first `n` values into `out`.
    fn back_from_circle(&mut self, size: usize, n: usize, out: &mut [f64]) {
        self.work
            .t
            .backward(&mut self.work.spec, size, &mut self.work.y);
        self.work.y.truncate(n);
        unscale(&mut self.work.y, self.circle.ln_r);
        out[..n].copy_from_slice(&self.work.y);
    }

    /// The first `n` coefficients of the power series `1/d` (`d[0] ≠ 0`),
    /// by Newton's iteration: from `g` exact to `k` terms,
    /// `g + g·(1 − d·g)` is exact to `2k`. Both products are taken on
    /// cyclic transforms of size `2k`: what wraps lands below `k`, where
    /// the terms are known.
    fn inverse_series(&mut self, d: &[f64], n: usize) -> Vec<f64> {
        let mut g = vec![1.0 / d[0]];
        g.reserve(n);
        let (mut g_hat, mut r) = (
            std::mem::take(&mut self.work.series_hat),
            std::mem::take(&mut self.work.fy),
        );
        let mut k = 1;
        while k < n {
            let k2 = (2 * k).min(n);
            let size = 2 * k;
            self.work.t.forward(&g, size, &mut g_hat);
            let dk = &d[..k2.min(d.len())];
            self.work
                .t
                .convolve(dk, &g_hat, size, &mut self.work.spec, &mut self.work.y);
            r.clear();
            r.resize(size, 0.0);
            for (rj, &y) in r[k..k2].iter_mut().zip(&self.work.y[k..k2]) {
                *rj = -y;
            }
            self.work
                .t
                .convolve(&r, &g_hat, size, &mut self.work.spec, &mut self.work.y);
            g.extend_from_slice(&self.work.y[k..k2]);
            k = k2;
        }
        g.truncate(n);
        self.work.series_hat = g_hat;
        self.work.fy = r;
        g
    }

    /// The spectrum of the solution from rest for the drive in `fx`, the
    /// drive's times `g`'s, into `spec`: the drive's is the kept drive's
    /// scaled when `fx` is a multiple of it, else transformed (and kept).
    fn rest_solution_hat(&mut self, size: usize) {
        let circle = self.on_circle();
        let ln_r = circle.then(|| self.circle.ln_r);
        let kept = &mut self.rest_drive;
        let c = match proportion(&kept.of, self.rest_peak, &self.work.fx) {
            Some(c) if kept.size == size && self.rest_on_circle == circle => c,
            _ => {
                match ln_r {
                    Some(l) => kept.keep_scaled(&mut self.work.t, &self.work.fx, l, size),
                    None => {
                        kept.keep(&mut self.work.t, &self.work.fx, size);
                    }
                }
                self.rest_on_circle = circle;
                self.rest_peak = (0..kept.of.len())
                    .max_by(|&i, &j| kept.of[i].abs().total_cmp(&kept.of[j].abs()))
                    .unwrap_or(0);
                1.0
            }
        };
        let g = if circle {
            &self.g_circle
        } else {
            &self.inverse.hat
        };
        self.work.spec.clear();
        self.work
            .spec
            .extend(kept.hat.iter().zip(g).map(|(&f, &g)| f * g * c));
    }

    /// Solves the recursion for the drive in `f` (rows `warm..`; zero
    /// below), with the history `x[..warm]`, into `x[warm..]`.
    fn solve_into(&mut self, a: f64, warm: usize, x: &mut [f64], pair: bool, size: usize) {
        let n = x.len();
        if warm == 0 && !pair {
            self.rest_solution_hat(size);
            if self.on_circle() {
                self.back_from_circle(size, n, x);
            } else {
                self.work
                    .t
                    .backward(&mut self.work.spec, size, &mut self.work.y);
                x.copy_from_slice(&self.work.y[..n]);
            }
            return;
        }
        self.inverse_hat(n);
        if warm > 0 {
            self.weights_hat();
        }
        let f = if pair {
            &mut self.work.fy
        } else {
            &mut self.work.fx
        };
        if warm > 0 {
            let past = &mut self.work.y;
            self.work.t.convolve(
                &x[..warm],
                &self.weights.hat,
                size,
                &mut self.work.spec,
                past,
            );
            for l in warm..n {
                f[l] -= a * past[l];
            }
        }
        self.work.t.convolve(
            f,
            &self.inverse.hat,
            size,
            &mut self.work.spec,
            &mut self.work.y,
        );
        x[warm..n].copy_from_slice(&self.work.y[warm..n]);
    }

    /// The recursion for `drive` (rows `warm..`) from the history
    /// `x[..warm]`, into `x[warm..]`; returns the transform size.
    fn solve_drive(
        &mut self,
        w: &[f64],
        a: f64,
        warm: usize,
        x: &mut [f64],
        mut drive: impl FnMut(usize) -> f64,
    ) -> usize {
        let n = x.len();
        let size = self.prepare(w, a, n);
        zeroed(&mut self.work.fx, n);
        for (l, fl) in self.work.fx.iter_mut().enumerate().skip(warm) {
            *fl = drive(l);
        }
        self.solve_into(a, warm, x, false, size);
        size
    }

    /// The unit branch (`R_ct = 1`: the polarization per ohm) of time
    /// constant `τ = e^{ln τ}` (`τ^α = R_ct·Q`) and order α over `current`
    /// from rest with the full memory, and its exact derivatives with
    /// respect to `ln τ` and α: `[y, ∂y/∂ln τ, ∂y/∂α]`.
    ///
    /// With `a = τ·h^(−α)` and `g = 1/(δ + a·w)`, `y = g ∗ I`,
    /// `∂y/∂ln τ = −a·g ∗ (w ∗ y)` and
    /// `∂y/∂α = −a·g ∗ (∂w/∂α ∗ y) − ln h·∂y/∂ln τ`. The weights are the
    /// series of `(1 − z)^α`, so `a·w ∗ g = δ − g` and `∂w/∂α = ℓ ∗ w`
    /// with `ℓ` the series of `ln(1 − z)`: `∂y/∂ln τ = g ∗ y − y` and
    /// `∂y/∂α = ℓ ∗ ∂y/∂ln τ − ln h·∂y/∂ln τ`. One inverse series and five
    /// transforms for all three (where finite differences take three
    /// series).
    pub fn unit_branch_with_derivatives(
        &mut self,
        ln_tau: f64,
        alpha: f64,
        h: f64,
        current: &[f64],
    ) -> [Vec<f64>; 3] {
        self.working(|b| {
            let n = current.len();
            let (mut w, mut dw) = (vec![0.0; n], vec![0.0; n]);
            fill_weights(alpha, &mut w, &mut dw);
            let a = (ln_tau - alpha * h.ln()).exp();
            let size = b.prepare(&w, a, n);
            b.inverse_hat(n);
            let (mut y, mut d_tau, mut d_alpha) = (vec![], vec![], vec![]);
            let t = &mut b.work.t;
            // The current's spectrum is kept (a fit drives every branch with
            // the same current), and so is ℓ's.
            let drive = b.drives.at(t, current, size, KEPT_DRIVES);
            let spec = &mut b.work.spec;
            product(b.drives.hat(drive), &b.inverse.hat, spec);
            t.backward(spec, size, &mut y);
            y.truncate(n);
            t.convolve(&y, &b.inverse.hat, size, spec, &mut d_tau);
            d_tau.truncate(n);
            d_tau.iter_mut().zip(&y).for_each(|(d, &yl)| *d -= yl);
            b.log_series_hat(n, size);
            let (t, spec) = (&mut b.work.t, &mut b.work.spec);
            t.convolve(&d_tau, &b.log_series.hat, size, spec, &mut d_alpha);
            d_alpha.truncate(n);
            let ln_h = h.ln();
            for (x, &dt) in d_alpha.iter_mut().zip(&d_tau) {
                *x -= ln_h * dt;
            }
            [y, d_tau, d_alpha]
        })
    }

    /// The spectrum of `ℓ` (the series of `ln(1 − z)`, `−1/k` from
    /// `k = 1`) to `n` terms at transform size `size`, kept.
    fn log_series_hat(&mut self, n: usize, size: usize) {
        if self.log_series.size != size || self.log_series.of.len() != n {
            let l: Vec<f64> = (0..n)
                .map(|k| if k == 0 { 0.0 } else { -1.0 / k as f64 })
                .collect();
            self.log_series.keep(&mut self.work.t, &l, size);
        }
    }

    /// The voltage of `cell` over a current record from rest with the full
    /// memory (`U_oc + R_i·I + η(I) + U_p`), the period `h` in s.
    pub fn simulate(&mut self, cell: &CellParameters<f64>, h: f64, current: &[f64]) -> Vec<f64> {
        let n = current.len();
        let (mut w, mut dw) = (vec![0.0; n], vec![0.0; n]);
        fill_weights(cell.alpha, &mut w, &mut dw);
        let a = cell.tau() * (-cell.alpha * h.ln()).exp();
        let mut up = vec![0.0; n];
        self.solve(&w, a, 0, &mut up, |l| cell.r_ct * current[l]);
        up.iter()
            .zip(current)
            .map(|(&u, &i)| cell.u_oc + cell.static_voltage(i) + u)
            .collect()
    }
}

/// How many drives' spectra [`FftBranch`] keeps.
const KEPT_DRIVES: usize = 32;

/// True when the direct recursion is the cheaper way for `n` rows and `m`
/// taps.
fn direct(n: usize, m: usize) -> bool {
    n.min(m) < DIRECT_TAPS
}

/// The order α of `taps` when they are the first `n` Grünwald–Letnikov
/// weights of order α (`w₀ = 1`, `w₁ = −α`, `w₂ = w₁·(1 − (α + 1)/2)`), all
/// `n` of them (the whole memory): then `δ + a·w` is `1 + a·(1 − z)^α` to
/// `n` terms ([`FftBranch::eval_circle`]).
fn gl_order(taps: &[f64], n: usize) -> Option<f64> {
    if taps.len() < n.max(3) || taps[0] != 1.0 {
        return None;
    }
    let alpha = -taps[1];
    let w2 = taps[1] * (1.0 - (alpha + 1.0) / 2.0);
    ((taps[2] - w2).abs() <= 1e-12 * w2.abs().max(1e-300) && alpha > 0.0 && alpha <= 1.0)
        .then_some(alpha)
}

/// `x_k·r^{−k}` (`ln r` given) for each `k`: a sequence taken back from
/// the circle. `r^{−k}` is a product from 1 (its rounding grows as `k·ε`,
/// far below the folding).
fn unscale(x: &mut [f64], ln_r: f64) {
    let up = (-ln_r).exp();
    let mut scale = 1.0;
    for v in x {
        *v *= scale;
        scale *= up;
    }
}

/// `buf` as `n` zeros.
fn zeroed(buf: &mut Vec<f64>, n: usize) {
    buf.clear();
    buf.resize(n, 0.0);
}

impl BranchSolver<f64> for FftBranch {
    /// Forgets every kept spectrum, as a new solver has none, but keeps
    /// the buffers' allocations: a refinement started again in place
    /// (`identify battery`'s Butler–Volmer starts run on the linear race's
    /// refinements) then writes its spectra where the last ones were
    /// instead of into fresh pages. The circle is kept: it depends on the
    /// transform size alone (`Circle::of`).
    fn reset(&mut self) {
        for s in [
            &mut self.weights,
            &mut self.derivatives,
            &mut self.inverse,
            &mut self.log_series,
            &mut self.rest_drive,
        ] {
            s.forget();
        }
        self.inverse_key = None;
        self.g_circle.clear();
        self.rest_peak = 0;
        self.rest_on_circle = false;
        self.drives = KeptSpectra::default();
    }

    fn filter(
        &mut self,
        w: &[f64],
        a: f64,
        warm: usize,
        x: &mut [f64],
        drive: impl FnMut(usize) -> f64,
        mut seen: impl FnMut(usize, f64, f64),
    ) {
        self.working(|b| {
            let n = x.len();
            if warm >= n || direct(n, w.len()) {
                return GlRecursion.filter(w, a, warm, x, drive, seen);
            }
            let size = b.solve_drive(w, a, warm, x, drive);
            if warm == 0 && a >= RECURSION_SUM_MIN_A {
                // E = w ∗ x from the recursion itself, `x + a·E = drive`: no
                // transform (`fx` still holds the drive: nothing was taken
                // off it for a history).
                let ia = 1.0 / a;
                for (l, (&xl, &f)) in x.iter().zip(&b.work.fx).enumerate() {
                    seen(l, xl, (f - xl) * ia - xl);
                }
                return;
            }
            // E = w ∗ x, and H = E − x (w₀ = 1).
            b.weights_hat();
            b.work
                .t
                .convolve(x, &b.weights.hat, size, &mut b.work.spec, &mut b.work.y);
            for (l, (&xl, &e)) in x.iter().zip(&b.work.y).enumerate().skip(warm) {
                seen(l, xl, e - xl);
            }
        });
    }

    fn filter_with_free(
        &mut self,
        w: &[f64],
        a: f64,
        warm: usize,
        x: &mut [f64],
        y: &mut [f64],
        drive: impl FnMut(usize) -> f64,
        seen: impl FnMut(usize, f64, f64),
    ) {
        self.filter(w, a, warm, x, drive, seen);
        if warm == 0 {
            // No history: the free response is zero (two transforms of
            // zeros saved).
            y.iter_mut().for_each(|v| *v = 0.0);
        } else {
            self.solve(w, a, warm, y, |_| 0.0);
        }
    }

    fn solve(
        &mut self,
        w: &[f64],
        a: f64,
        warm: usize,
        x: &mut [f64],
        drive: impl FnMut(usize) -> f64,
    ) {
        self.working(|b| {
            let n = x.len();
            if warm >= n || direct(n, w.len()) {
                return GlRecursion.solve(w, a, warm, x, drive);
            }
            b.solve_drive(w, a, warm, x, drive);
        });
    }

    fn filter_pair(
        &mut self,
        w: &[f64],
        a: f64,
        warm: usize,
        x: &mut [f64],
        y: &mut [f64],
        mut drive: impl FnMut(usize) -> (f64, f64),
    ) {
        self.working(|b| {
            let n = x.len().min(y.len());
            let (x, y) = (&mut x[..n], &mut y[..n]);
            if warm >= n || direct(n, w.len()) {
                return GlRecursion.filter_pair(w, a, warm, x, y, drive);
            }
            let size = b.prepare(w, a, n);
            zeroed(&mut b.work.fx, n);
            zeroed(&mut b.work.fy, n);
            for l in warm..n {
                (b.work.fx[l], b.work.fy[l]) = drive(l);
            }
            b.solve_into(a, warm, x, false, size);
            b.solve_into(a, warm, y, true, size);
        });
    }

    fn rest_sums(&mut self, w: &[f64], a: f64, x: &[f64], y: &mut [f64], z: &mut [f64]) -> bool {
        self.working(|b| {
            let n = x.len();
            if y.len() < n
                || z.len() < n
                || direct(n, w.len())
                || a < RECURSION_SUM_MIN_A
                || gl_order(&w[..w.len().min(n)], n).is_none()
            {
                return false;
            }
            let size = b.prepare(w, a, n);
            // y = g ∗ E = (x − g ∗ x)/a, from E = (R_ct·I − x)/a and
            // x = g ∗ (R_ct·I); z = ℓ ∗ y. On the circle (the whole memory,
            // which `gl_order` checked) y's spectrum is x's times `(1 − G)/a`
            // and ℓ's is `ln(1 − z_j)`: three transforms and no series.
            let ln_r = b.circle.ln_r;
            let mut xh = std::mem::take(&mut b.work.series_hat);
            b.work.t.forward_scaled(x, ln_r, size, &mut xh);
            b.work.spec.clear();
            b.work
                .spec
                .extend(xh.iter().zip(&b.g_circle).map(|(&f, &g)| f * g));
            b.work.t.backward(&mut b.work.spec, size, &mut b.work.y);
            b.work.y.truncate(n);
            unscale(&mut b.work.y, ln_r);
            let ia = 1.0 / a;
            for ((yl, &xl), &gx) in y.iter_mut().zip(x).zip(&b.work.y) {
                *yl = (xl - gx) * ia;
            }
            let c = &*b.circle;
            b.work.spec.clear();
            b.work.spec.extend(
                xh.iter()
                    .zip(&b.g_circle)
                    .zip(c.ln_modulus.iter().zip(&c.arg))
                    .map(|((&f, &g), (&lm, &ar))| (f - f * g) * ia * Complex::new(lm, ar)),
            );
            b.work.series_hat = xh;
            b.back_from_circle(size, n, z);
            true
        })
    }

    fn weight_derivative<const MEM: usize>(
        &mut self,
        gl: &GlWeights<f64, MEM>,
        x: &[f64],
        rows: Range<usize>,
        mut f: impl FnMut(usize, f64),
    ) {
        self.working(|b| {
            let n = x.len();
            if direct(n, gl.len()) {
                return gl.for_each_weight_derivative(x, rows, f);
            }
            let size = transform_size(n);
            let dw = gl.weight_derivatives();
            b.derivatives
                .keep(&mut b.work.t, &dw[..dw.len().min(n)], size);
            b.work
                .t
                .convolve(x, &b.derivatives.hat, size, &mut b.work.spec, &mut b.work.y);
            let s = gl.scale();
            for l in rows.start..rows.end.min(n) {
                f(l, s * b.work.y[l]);
            }
        });
    }
}

#[cfg(test)]
mod tests;
