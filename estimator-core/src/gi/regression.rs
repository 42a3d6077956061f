//! The regression workspace both algorithms share: the window's data, the
//! fractional differences of every signal channel at the current order, the
//! residual, and the scratch for line searches. Nothing here allocates.
//!
//! Channels (all indexed by time `l`, oldest sample of the window at 0):
//! `y(l)`, the noise estimate `ê(l)` and the basis outputs `f_j(u(l))`; their
//! fractional differences at order α are kept in a [`Channels`] set. The
//! regressors are lagged reads of these channels, so the information matrix is
//! never materialized.

use core::ops::Range;

use super::{GiSettings, Prehistory};
use crate::error::Error;
use crate::frac::GlWeights;
use crate::model::{Basis, Orders};
use crate::real::Real;
use crate::window::SampleWindow;

/// `x(l − i)` or 0 before the first sample.
#[inline(always)]
pub(crate) fn lag<T: Real>(x: &[T], l: usize, i: usize) -> T {
    if l >= i {
        x[l - i]
    } else {
        T::zero()
    }
}

/// Fractional differences of the channels at one order.
#[derive(Clone, Debug)]
pub(crate) struct Channels<T, const N: usize, const NF: usize> {
    pub y: [T; N],
    pub e: [T; N],
    pub f: [[T; N]; NF],
}

impl<T: Real, const N: usize, const NF: usize> Channels<T, N, NF> {
    const fn zeroed() -> Self {
        Self {
            y: [T::ZERO; N],
            e: [T::ZERO; N],
            f: [[T::ZERO; N]; NF],
        }
    }
}

/// Parameters in the shared (products) form, borrowed.
#[derive(Clone, Copy)]
pub(crate) struct Params<'a, T> {
    pub o: Orders,
    pub a: &'a [T],
    pub c: &'a [T],
    pub p: &'a [T],
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Stamp<T> {
    len: usize,
    r0: usize,
    alpha: T,
    h: T,
    memory: usize,
    m: usize,
}

#[derive(Clone, Debug)]
pub(crate) struct Regression<T, const N: usize, const MEM: usize, const NF: usize> {
    pub w: GlWeights<T, MEM>,
    tw: GlWeights<T, MEM>,
    /// Samples loaded.
    pub n: usize,
    /// First row used.
    pub r0: usize,
    u: [T; N],
    y: [T; N],
    e: [T; N],
    /// ê at the trial order.
    te: [T; N],
    f: [[T; N]; NF],
    pub cur: Channels<T, N, NF>,
    trial: Channels<T, N, NF>,
    /// Residual `y − ŷ` on the rows.
    pub res: [T; N],
    /// Scratch: `Φ g` of a line search, or the trial residual.
    pub q: [T; N],
    /// `∂ŷ/∂α` on the rows.
    pub d: [T; N],
    scratch: [T; N],
    stamp: Option<Stamp<T>>,
}

impl<T: Real, const N: usize, const MEM: usize, const NF: usize> Regression<T, N, MEM, NF> {
    pub fn new(s: &GiSettings<T>, alpha: T) -> Result<Self, Error> {
        let w = GlWeights::new(alpha, s.h, s.memory)?;
        Ok(Self {
            tw: w.clone(),
            w,
            n: 0,
            r0: 0,
            u: [T::ZERO; N],
            y: [T::ZERO; N],
            e: [T::ZERO; N],
            te: [T::ZERO; N],
            f: [[T::ZERO; N]; NF],
            cur: Channels::zeroed(),
            trial: Channels::zeroed(),
            res: [T::ZERO; N],
            q: [T::ZERO; N],
            d: [T::ZERO; N],
            scratch: [T::ZERO; N],
            stamp: None,
        })
    }

    pub fn rows(&self) -> Range<usize> {
        self.r0..self.n
    }

    /// Loads the window at order `alpha`: copies the data, evaluates the
    /// basis, and (re)computes the differences of `y` and `f_j` unless the
    /// data, the order and the settings are those they were computed for.
    pub fn load<B: Basis<T>>(
        &mut self,
        s: &GiSettings<T>,
        basis: &B,
        window: &SampleWindow<T, N>,
        alpha: T,
        min_rows: usize,
    ) -> Result<(), Error> {
        let o = s.orders;
        let n = window.len();
        let r0 = match (s.prehistory, window.has_slid()) {
            (Prehistory::AtRest, false) => 0,
            _ => o.max_lag() + s.memory - 1,
        };
        if n < r0 + min_rows {
            return Err(Error::NotEnoughData {
                have: n.saturating_sub(r0),
                need: min_rows,
            });
        }
        let stamp = Stamp {
            len: n,
            r0,
            alpha,
            h: s.h,
            memory: s.memory,
            m: o.m,
        };
        // Copy the window (O(N)) into scratch and compare it with the data the
        // cached differences were computed from.
        window.copy_into(&mut self.q, &mut self.d);
        let same =
            self.stamp == Some(stamp) && self.q[..n] == self.u[..n] && self.d[..n] == self.y[..n];
        if same {
            return Ok(());
        }
        self.stamp = None;
        self.u[..n].copy_from_slice(&self.q[..n]);
        self.y[..n].copy_from_slice(&self.d[..n]);
        let (mut sum, mut sum2) = (T::zero(), T::zero());
        for &u in &self.u[r0..n] {
            sum = sum + u;
            sum2 = sum2 + u * u;
        }
        let rows = T::lit((n - r0) as f64);
        let mean2 = sum2 / rows;
        let var = mean2 - (sum / rows) * (sum / rows);
        if !mean2.is_finite() {
            return Err(Error::NonFiniteSample);
        }
        if !crate::real::positive_finite(var - T::epsilon() * T::lit(64.0) * mean2) {
            return Err(Error::NotExcited);
        }
        for l in 0..n {
            let u = self.u[l];
            for j in 0..o.m {
                let v = basis.eval(j, u);
                if !v.is_finite() {
                    return Err(Error::NonFiniteSample);
                }
                self.f[j][l] = v;
            }
        }
        self.w.set(alpha, s.h, s.memory)?;
        self.tw = self.w.clone();
        self.n = n;
        self.r0 = r0;
        self.w.apply(&self.y[..n], &mut self.cur.y[..n]);
        for j in 0..o.m {
            self.w.apply(&self.f[j][..n], &mut self.cur.f[j][..n]);
        }
        self.stamp = Some(stamp);
        Ok(())
    }

    /// Marks the cached differences stale (after an order change that was
    /// not made through [`Regression::accept_trial`]).
    pub fn invalidate(&mut self) {
        self.stamp = None;
    }

    /// System-part prediction (without the noise terms) at time `l` from a
    /// channel set.
    #[inline]
    fn system_part(ch: &Channels<T, N, NF>, p: &Params<'_, T>, l: usize) -> T {
        let o = p.o;
        let mut s = T::zero();
        for i in 0..o.na {
            s = s - p.a[i] * lag(&ch.y, l, i + 1);
        }
        for i in 0..o.nb {
            for j in 0..o.m {
                s = s + p.p[i * o.m + j] * lag(&ch.f[j], l, i + 1);
            }
        }
        s
    }

    /// ê(l) = y(l) − (system part) with the given parameters at the current
    /// order (the consistent form of eq. 28), then its differences.
    pub fn noise_estimate(&mut self, p: &Params<'_, T>) {
        let n = self.n;
        for l in 0..n {
            self.e[l] = if l < self.r0 {
                T::zero()
            } else {
                self.y[l] - Self::system_part(&self.cur, p, l)
            };
        }
        self.w.apply(&self.e[..n], &mut self.cur.e[..n]);
    }

    /// Writes `y − ŷ` for the rows into `out` from a channel set; returns the
    /// cost `½ Σ out²`.
    fn residual_of(
        y: &[T; N],
        ch: &Channels<T, N, NF>,
        p: &Params<'_, T>,
        rows: Range<usize>,
        out: &mut [T; N],
    ) -> T {
        let mut cost = T::zero();
        for l in rows {
            let mut yh = Self::system_part(ch, p, l);
            for i in 0..p.o.nc {
                yh = yh - p.c[i] * lag(&ch.e, l, i + 1);
            }
            let r = y[l] - yh;
            out[l] = r;
            cost = cost + r * r;
        }
        cost / T::lit(2.0)
    }

    /// Recomputes the residual at the current order; returns the cost.
    pub fn residual(&mut self, p: &Params<'_, T>) -> T {
        let rows = self.rows();
        Self::residual_of(&self.y, &self.cur, p, rows, &mut self.res)
    }

    /// Cost `½ Σ res²` of the current residual.
    pub fn cost(&self) -> T {
        crate::real::dot(&self.res[self.r0..self.n], &self.res[self.r0..self.n]) / T::lit(2.0)
    }

    /// `∂ŷ/∂α` on the rows into `d`, where ŷ is the prediction of the full
    /// criterion: `ŷ(l) = S(l) − Σ c_i Δ^α ê(l−i)` with `ê = y − S` itself a
    /// function of α (S is the system part). So
    /// `∂ŷ/∂α = ∂S/∂α − Σ c_i [∂_α Δ^α ê − Δ^α ∂_α S](l−i)`.
    pub fn order_derivative(&mut self, p: &Params<'_, T>) {
        let (n, r0, o) = (self.n, self.r0, p.o);
        // d ← ∂S/∂α on every sample (the lags of the noise part need it).
        for x in self.d[..n].iter_mut() {
            *x = T::zero();
        }
        let mut acc = |x: &[T], coef: &dyn Fn(usize) -> T, lags: usize, s: &mut [T; N]| {
            for (l, sl) in s.iter_mut().enumerate().take(n) {
                *sl = self.w.difference_with_derivative(x, l).1;
            }
            for l in 0..n {
                let mut v = T::zero();
                for i in 0..lags {
                    v = v + coef(i) * lag(&s[..], l, i + 1);
                }
                self.d[l] = self.d[l] + v;
            }
        };
        acc(&self.y[..n], &|i| -p.a[i], o.na, &mut self.scratch);
        for j in 0..o.m {
            acc(
                &self.f[j][..n],
                &|i| p.p[i * o.m + j],
                o.nb,
                &mut self.scratch,
            );
        }
        if o.nc == 0 {
            return;
        }
        // scratch ← ∂_α Δ^α ê − Δ^α (∂S/∂α), with ê and ∂ê/∂α zero before r0.
        let w = &self.w;
        let (e, d) = (&self.e, &self.d);
        for l in 0..n {
            let de = w.difference_with_derivative(&e[..n], l).1;
            let taps = (l + 1).min(w.len());
            let mut s = T::zero();
            for (j, &wj) in w.weights()[..taps].iter().enumerate() {
                if l - j >= r0 {
                    s = s + wj * d[l - j];
                }
            }
            self.scratch[l] = de - w.scale() * s;
        }
        for l in (r0..n).rev() {
            let mut v = T::zero();
            for i in 0..o.nc {
                v = v + p.c[i] * lag(&self.scratch[..], l, i + 1);
            }
            self.d[l] = self.d[l] - v;
        }
    }

    /// Evaluates the full criterion at a trial order: differences of `y` and
    /// `f_j` at the trial order, `ê = y − S` recomputed from them, its
    /// differences, and the residual. Leaves everything ready for
    /// `accept_trial`.
    pub fn trial_cost(&mut self, alpha: T, p: &Params<'_, T>) -> Result<T, Error> {
        let n = self.n;
        self.tw.set_order(alpha)?;
        self.tw.apply(&self.y[..n], &mut self.trial.y[..n]);
        for j in 0..p.o.m {
            self.tw.apply(&self.f[j][..n], &mut self.trial.f[j][..n]);
        }
        for l in 0..n {
            self.te[l] = if l < self.r0 {
                T::zero()
            } else {
                self.y[l] - Self::system_part(&self.trial, p, l)
            };
        }
        self.tw.apply(&self.te[..n], &mut self.trial.e[..n]);
        let rows = self.rows();
        Ok(Self::residual_of(
            &self.y,
            &self.trial,
            p,
            rows,
            &mut self.q,
        ))
    }

    /// Makes the last trial order current.
    pub fn accept_trial(&mut self) {
        core::mem::swap(&mut self.cur, &mut self.trial);
        core::mem::swap(&mut self.e, &mut self.te);
        core::mem::swap(&mut self.w, &mut self.tw);
        core::mem::swap(&mut self.res, &mut self.q);
        if let Some(st) = self.stamp.as_mut() {
            st.alpha = self.w.alpha();
        }
    }

    /// Splits the workspace into the (read-only) channels and the residual
    /// and scratch vectors a linear stage updates.
    pub fn split(&mut self) -> (&Channels<T, N, NF>, &mut [T; N], &mut [T; N], Range<usize>) {
        let rows = self.rows();
        (&self.cur, &mut self.res, &mut self.q, rows)
    }
}

/// One block of a linear stage: the parameters it updates, their gradient
/// scratch, and the regressor column `col(k, l)` of parameter `k` at row `l`.
pub(crate) struct Block<'a, T> {
    pub params: &'a mut [T],
    pub grad: &'a mut [T],
    pub col: &'a dyn Fn(usize, usize) -> T,
}

/// One gradient step with exact line search on a stage that is linear in its
/// parameters: with the residual `r` and the stage regressor `Φ`,
/// `g = Φᵀr`, `μ = ‖g‖² / ‖Φg‖²`, `θ ← θ + μ g`, `r ← r − μ Φg`.
/// Returns the step size μ (0 when the stage has no gradient or no
/// excitation).
pub(crate) fn linear_stage<T: Real, const N: usize>(
    blocks: &mut [Block<'_, T>],
    rows: Range<usize>,
    res: &mut [T; N],
    q: &mut [T; N],
) -> T {
    let mut gg = T::zero();
    for b in blocks.iter_mut() {
        for (k, g) in b.grad.iter_mut().enumerate() {
            let mut s = T::zero();
            for l in rows.clone() {
                s = s + (b.col)(k, l) * res[l];
            }
            *g = s;
            gg = gg + s * s;
        }
    }
    if !crate::real::positive_finite(gg) {
        return T::zero();
    }
    let mut qq = T::zero();
    for l in rows.clone() {
        let mut s = T::zero();
        for b in blocks.iter() {
            for (k, &g) in b.grad.iter().enumerate() {
                s = s + (b.col)(k, l) * g;
            }
        }
        q[l] = s;
        qq = qq + s * s;
    }
    if !crate::real::positive_finite(qq) {
        return T::zero();
    }
    let mu = gg / qq;
    for b in blocks.iter_mut() {
        for (p, &g) in b.params.iter_mut().zip(b.grad.iter()) {
            *p = *p + mu * g;
        }
    }
    for l in rows {
        res[l] = res[l] - mu * q[l];
    }
    mu
}
