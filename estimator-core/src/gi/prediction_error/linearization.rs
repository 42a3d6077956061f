//! The Jacobian of the whitened prediction error, the normal equations,
//! and the step applied to an estimate.

use super::*;

impl<
        T: Real,
        const N: usize,
        const MEM: usize,
        const NA: usize,
        const NB: usize,
        const NC: usize,
        const NF: usize,
        const NP: usize,
        const NQ: usize,
    > PredictionErrorRefinement<T, N, MEM, NA, NB, NC, NF, NP, NQ>
{
    /// `JᵀJ` and `−Jᵀε` over the rows for the first `np` columns; a column
    /// `k` with `!keep(k)`, and every index past `np`, gets a unit row and a
    /// zero right-hand side (its step is 0).
    pub(super) fn normal_equations(
        &self,
        np: usize,
        keep: impl Fn(usize) -> bool,
    ) -> ([[T; NQ]; NQ], [T; NQ]) {
        let rows = self.reg.rows();
        let mut h = [[T::zero(); NQ]; NQ];
        let mut g = [T::zero(); NQ];
        let cols = &self.jac[..np];
        for (a, ca) in cols.iter().enumerate() {
            if !keep(a) {
                continue;
            }
            for (b, cb) in cols.iter().enumerate().take(a + 1) {
                if keep(b) {
                    let v = crate::real::dot(&ca[rows.clone()], &cb[rows.clone()]);
                    h[a][b] = v;
                    h[b][a] = v;
                }
            }
            g[a] = -crate::real::dot(&ca[rows.clone()], &self.reg.res[rows.clone()]);
        }
        for (i, row) in h.iter_mut().enumerate() {
            if i >= np || !keep(i) {
                row[i] = T::one();
            }
        }
        (h, g)
    }

    /// Loads the window at the estimate's order (clamped into the bounds),
    /// computes the residual `ε` and the Jacobian columns; returns the cost.
    pub(super) fn linearize<B: Basis<T>>(
        &mut self,
        s: &PredictionErrorSettings<T>,
        basis: &B,
        window: &SampleWindow<T, N>,
        free_order: bool,
    ) -> Result<T, Error> {
        let alpha = self.est.alpha.max(s.gi.alpha_min).min(s.gi.alpha_max);
        self.reg
            .load(&s.gi, basis, window, alpha, parameters(&s.gi) + 1)?;
        self.est.alpha = alpha;
        let est = self.est;
        let cur = params(&est);
        self.reg.noise_estimate(&cur);
        let cost = self.reg.residual(&cur);
        if !cost.is_finite() {
            self.reg.invalidate();
            return Err(Error::Diverged);
        }
        if free_order {
            self.reg.order_derivative(&cur);
        }
        self.jacobian(&est, free_order);
        Ok(cost)
    }

    /// The Jacobian columns `∂ε/∂p_k` at `est` (the regression holds its
    /// residual, its noise differences and, for a free order, `∂ŷ/∂α`).
    pub(super) fn jacobian(
        &mut self,
        est: &HammersteinEstimate<T, NA, NB, NC, NF, NP>,
        free_order: bool,
    ) {
        let o = est.orders;
        let (n, r0) = (self.reg.n, self.reg.r0);
        let mut col = 0;
        // a_i: (1 + C̃)[Δ^α y(·−i)].
        for i in 1..=o.na {
            for (l, x) in self.jac[col][..n].iter_mut().enumerate() {
                *x = if l >= r0 {
                    lag(&self.reg.cur.y, l, i)
                } else {
                    T::zero()
                };
            }
            col += 1;
        }
        // c_k: Δ^α w(l−k).
        let c_cols = col;
        for k in 1..=o.nc {
            for (l, x) in self.jac[col][..n].iter_mut().enumerate() {
                *x = lag(&self.reg.cur.e, l, k);
            }
            col += 1;
        }
        // b_iγ_j: −(1 + C̃)[Δ^α f_j(u(·−i))].
        for i in 1..=o.nb {
            for j in 0..o.m {
                for (l, x) in self.jac[col][..n].iter_mut().enumerate() {
                    *x = if l >= r0 {
                        -lag(&self.reg.cur.f[j], l, i)
                    } else {
                        T::zero()
                    };
                }
                col += 1;
            }
        }
        let filtered = (0..c_cols).chain(c_cols + o.nc..col);
        if o.nc > 0 {
            for k in filtered {
                self.reg.w.apply(&self.jac[k][..n], &mut self.tmp[..n]);
                for l in (r0..n).rev() {
                    let mut v = T::zero();
                    for (q, &cq) in est.c[..o.nc].iter().enumerate() {
                        v = v + cq * lag(&self.tmp[..n], l, q + 1);
                    }
                    self.jac[k][l] = self.jac[k][l] + v;
                }
            }
        }
        if free_order {
            for l in 0..n {
                self.jac[col][l] = -self.reg.d[l];
            }
        }
    }
}

pub(super) fn params<
    T: Real,
    const NA: usize,
    const NB: usize,
    const NC: usize,
    const NF: usize,
    const NP: usize,
>(
    e: &HammersteinEstimate<T, NA, NB, NC, NF, NP>,
) -> Params<'_, T> {
    Params {
        o: e.orders,
        a: &e.a,
        c: &e.c,
        p: &e.products,
    }
}

/// Adds the step (ordered `[a, c, products, α]`) to the estimate.
pub(super) fn apply_step<
    T: Real,
    const NA: usize,
    const NB: usize,
    const NC: usize,
    const NF: usize,
    const NP: usize,
>(
    e: &mut HammersteinEstimate<T, NA, NB, NC, NF, NP>,
    step: &[T],
    free_order: bool,
) {
    let o = e.orders;
    let mut it = step.iter();
    for x in e.a[..o.na]
        .iter_mut()
        .chain(e.c[..o.nc].iter_mut())
        .chain(e.products[..o.products()].iter_mut())
    {
        if let Some(&d) = it.next() {
            *x = *x + d;
        }
    }
    if free_order {
        if let Some(&d) = it.next() {
            e.alpha = e.alpha + d;
        }
    }
}

/// `‖p − q‖` over `[a, c, products, α]`.
pub(super) fn distance<
    T: Real,
    const NA: usize,
    const NB: usize,
    const NC: usize,
    const NF: usize,
    const NP: usize,
>(
    p: &HammersteinEstimate<T, NA, NB, NC, NF, NP>,
    q: &HammersteinEstimate<T, NA, NB, NC, NF, NP>,
) -> T {
    let o = p.orders;
    let mut s = (p.alpha - q.alpha) * (p.alpha - q.alpha);
    for (x, y) in p.a[..o.na]
        .iter()
        .zip(&q.a[..o.na])
        .chain(p.c[..o.nc].iter().zip(&q.c[..o.nc]))
        .chain(
            p.products[..o.products()]
                .iter()
                .zip(&q.products[..o.products()]),
        )
    {
        s = s + (*x - *y) * (*x - *y);
    }
    s.sqrt()
}
