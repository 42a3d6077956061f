//! The sensitivities of the simulated voltage to every parameter, the
//! Jacobian's rows and the normal equations `JᵀJ`, `Jᵀr` (see the parent
//! module's docs for the recursions).

use super::*;

/// `J₀ᵀJ₀` of an iteration (its upper triangle by rows) and which columns
/// it had (the columns themselves stay in the sensitivity buffers).
#[derive(Clone, Copy, Debug)]
pub(super) struct Linearization<T> {
    pub(super) a: [T; PACKED],
    pub(super) estimate_order: bool,
    pub(super) ocv_slope: bool,
    pub(super) model: CellModel,
}

impl<T: Real> Linearization<T> {
    pub(super) fn new(s: &BatterySettings<T>, a: &Square<T>) -> Self {
        let mut up = [T::zero(); PACKED];
        let mut k = 0;
        for (r, row) in a.iter().enumerate() {
            for &x in &row[r..] {
                up[k] = x;
                k += 1;
            }
        }
        Self {
            a: up,
            estimate_order: s.estimate_order,
            ocv_slope: s.ocv_slope,
            model: s.model,
        }
    }

    /// True when `s` gives the Jacobian the same columns.
    pub(super) fn fits(&self, s: &BatterySettings<T>) -> bool {
        self.estimate_order == s.estimate_order
            && self.ocv_slope == s.ocv_slope
            && self.model == s.model
    }

    /// The full symmetric `J₀ᵀJ₀`.
    pub(super) fn normal_matrix(&self) -> Square<T> {
        let mut a = [[T::zero(); COLUMNS]; COLUMNS];
        let mut packed = self.a.iter();
        for (r, row) in a.iter_mut().enumerate() {
            for (x, &y) in row[r..].iter_mut().zip(&mut packed) {
                *x = y;
            }
        }
        mirror_upper(&mut a);
        a
    }
}
impl<T: Real, const N: usize, const MEM: usize, K: BranchSolver<T>>
    OutputErrorRefinement<T, N, MEM, K>
{
    /// The sensitivities of `U_p` to every parameter, for the simulation
    /// held in the estimate's [`Simulation`]; with `tail`, of the model
    /// with the taps beyond the memory ([`BatterySettings::tail`]).
    /// With `uoc_done`, `s_uoc` already holds the free response from the
    /// history `−1` at this estimate's weights and `a` ([`Self::iterate`]
    /// ran it with the simulation), and is not run again.
    pub(super) fn sensitivities(&mut self, slope: bool, kinetic: bool, tail: bool, uoc_done: bool) {
        // `load` keeps warm < n ≤ N; the clamps let the optimizer see it.
        let n = self.n.min(N);
        let warm = self.warm.min(n);
        let wts = self.w.weights();
        let g = self.w.scale();
        let ln_h = self.w.h().ln();
        let p = self.p;
        let tau = p.tau();
        let a = tau * g;
        let memory = wts.len();
        // The tail: coefficients at the estimate's order and the modes of
        // the past (rest without one), for U_p and for each sensitivity's
        // free response (∂U_p(past)/∂R_i = −I, ∂/∂U_oc = −1, ∂/∂β = c).
        let zero = [T::zero(); MODES];
        let kernel = if tail {
            TailKernel::new(p.alpha).ok()
        } else {
            None
        };
        let past = self.past.filter(|_| warm > 0);
        let (c0, h) = (self.c[0], self.w.h());
        let modes = |f: &dyn Fn(&PastModes<T>, usize) -> T| -> [T; MODES] {
            past.map_or(zero, |pm| core::array::from_fn(|k| f(&pm, k)))
        };
        let z_up = past.map_or(zero, |pm| pm.polarization(p.u_oc, p.r_i, self.beta, c0, h));
        let z_ri = modes(&|pm, k| -pm.current[k]);
        let z_uoc = modes(&|pm, k| -pm.one[k]);
        let z_beta = modes(&|pm, k| pm.charge_modes(k, c0, h));
        let tails = kernel.map(|k| {
            (
                Tail {
                    rates: k.rates,
                    c: Tail::scaled(&k, &k.coefficients, memory),
                    z0: zero,
                },
                Tail::scaled(&k, &k.derivatives, memory),
            )
        });
        // h^(−α)·Σ_j (∂w_j/∂α)·U_p(l − j) (the order sensitivity's drive),
        // into the trial buffer, free until the step search; with the tail,
        // its weights' derivatives too: h^(−α)·Σ_k ∂C_k/∂α·Z_k(l − M) over
        // the simulation.
        let (est, spare) = estimate_and_spare(&mut self.sims, self.held);
        if warm == 0
            && tails.is_none()
            && p.r_ct > T::zero()
            && self
                .solver
                .rest_sums(wts, a, &est.up[..n], &mut self.s_q[..n], &mut self.s_a[..n])
        {
            // From rest the three recursions' solutions are sums of
            // U_p = g ∗ (R_ct·I), y = g ∗ E and z = ℓ ∗ y
            // ([`BranchSolver::rest_sums`]): g ∗ I = U_p/R_ct, and the
            // order's drive h^(−α)·∂w/∂α ∗ U_p gives h^(−α)·z.
            let (q_g, rct_g, a_ln_h, tau_g) = (p.q * g, p.r_ct * g, a * ln_h, tau * g);
            let inv_rct = T::one() / p.r_ct;
            for (((rct, sq), sa), &up) in self.s_rct[..n]
                .iter_mut()
                .zip(&mut self.s_q[..n])
                .zip(&mut self.s_a[..n])
                .zip(&est.up[..n])
            {
                let (y, z) = (*sq, *sa);
                *rct = up * inv_rct - q_g * y;
                *sq = -rct_g * y;
                *sa = a_ln_h * y - tau_g * z;
            }
            self.zero_direct_columns(n, kinetic);
            return;
        }
        let dup = &mut spare.up;
        self.solver
            .weight_derivative(&self.w, &est.up[..n], warm..n, |l, d| {
                if let Some(x) = dup.get_mut(l) {
                    *x = d;
                }
            });
        if let Some((t, dc)) = &tails {
            let mut z = z_up;
            for (l, dl) in dup.iter_mut().enumerate().take(n).skip(warm) {
                // The sample leaving the memory, when there is one.
                if let Some(&x) = l.checked_sub(memory).and_then(|k| est.up.get(k)) {
                    for (zk, &r) in z.iter_mut().zip(&t.rates) {
                        *zk = r * *zk + x;
                    }
                }
                let d = dc.iter().zip(&z).fold(T::zero(), |s, (&c, &z)| s + c * z);
                *dl = *dl + g * d;
            }
        }
        let (i, e, dup) = (&self.i, &est.e, &spare.up);
        for x in [
            &mut self.s_rct,
            &mut self.s_q,
            &mut self.s_a,
            &mut self.s_ri,
            &mut self.s_uoc,
            &mut self.s_beta,
            &mut self.s_bva,
            &mut self.s_bvi0,
        ] {
            x[..warm].fill(T::zero());
        }
        // Two recursions at a time through the pair kernel (same weights
        // and `a`): each gets the values it would get alone.
        // (The filters call back with l < n ≤ N: NaN past it, never read.)
        let rct_q = |l: usize| match (i.get(l), e.get(l)) {
            (Some(&il), Some(&el)) => (il - p.q * g * el, -p.r_ct * g * el),
            _ => (T::nan(), T::nan()),
        };
        match &tails {
            Some((t, _)) => cpe_filter_pair_tail(
                wts,
                a,
                warm,
                &mut self.s_rct[..n],
                &mut self.s_q[..n],
                t,
                zero,
                rct_q,
            ),
            None => self.solver.filter_pair(
                wts,
                a,
                warm,
                &mut self.s_rct[..n],
                &mut self.s_q[..n],
                rct_q,
            ),
        }
        let order = |l: usize| match (e.get(l), dup.get(l)) {
            (Some(&el), Some(&dl)) => a * ln_h * el - tau * dl,
            _ => T::nan(),
        };
        if warm == 0 {
            // From rest: no history, so no free responses (and no stale
            // ones from an earlier window).
            match &tails {
                Some((t, _)) => {
                    cpe_filter_tail(wts, a, warm, &mut self.s_a[..n], t, order, |_, _, _| {})
                }
                None => self.solver.solve(wts, a, warm, &mut self.s_a[..n], order),
            }
            self.zero_direct_columns(n, kinetic);
            return;
        }
        // A history at rest (every current exactly 0, as a rest longer than
        // the window's history rows gives): the free responses to −I and
        // to −∂η are those of a zero history, zero at every row, and are
        // not run.
        let rested = i[..warm].iter().all(|&il| il == T::zero());
        if kinetic && rested {
            self.s_bva[..n].fill(T::zero());
            self.s_bvi0[..n].fill(T::zero());
        } else if kinetic {
            // The history U_p = U_t − U_oc − R_i·I − η(I) moves with η's
            // parameters: the free responses to −∂η. (No tail: the model
            // with the Butler–Volmer term keeps the truncated sum.)
            for (((sa, si), &il), &eta) in self.s_bva[..warm]
                .iter_mut()
                .zip(&mut self.s_bvi0[..warm])
                .zip(&i[..warm])
                .zip(&est.eta[..warm])
            {
                let (da, di) = kinetic_derivatives(&p, il, eta);
                *sa = -da;
                *si = -di;
            }
            self.solver.filter_pair(
                wts,
                a,
                warm,
                &mut self.s_bva[..n],
                &mut self.s_bvi0[..n],
                |_| (T::zero(), T::zero()),
            );
        }
        for ((sr, su), &il) in self.s_ri[..warm]
            .iter_mut()
            .zip(&mut self.s_uoc[..warm])
            .zip(&i[..warm])
        {
            *sr = -il;
            *su = -T::one();
        }
        let order_ri = |l: usize| (order(l), T::zero());
        match &tails {
            // The order's sensitivity alone (the pair kernel gives each
            // sequence what it would get alone).
            None if rested => {
                self.s_ri[..n].fill(T::zero());
                self.solver.solve(wts, a, warm, &mut self.s_a[..n], order);
            }
            Some((t, _)) => cpe_filter_pair_tail(
                wts,
                a,
                warm,
                &mut self.s_a[..n],
                &mut self.s_ri[..n],
                t,
                z_ri,
                order_ri,
            ),
            None => self.solver.filter_pair(
                wts,
                a,
                warm,
                &mut self.s_a[..n],
                &mut self.s_ri[..n],
                order_ri,
            ),
        }
        let free = |_: usize| (T::zero(), T::zero());
        if slope {
            self.s_beta[..warm].copy_from_slice(&self.c[..warm]);
            match &tails {
                Some((t, _)) => cpe_filter_pair_tail(
                    wts,
                    a,
                    warm,
                    &mut self.s_uoc[..n],
                    &mut self.s_beta[..n],
                    &Tail { z0: z_uoc, ..*t },
                    z_beta,
                    free,
                ),
                None => self.solver.filter_pair(
                    wts,
                    a,
                    warm,
                    &mut self.s_uoc[..n],
                    &mut self.s_beta[..n],
                    free,
                ),
            }
        } else {
            match &tails {
                Some((t, _)) => cpe_filter_tail(
                    wts,
                    a,
                    warm,
                    &mut self.s_uoc[..n],
                    &Tail { z0: z_uoc, ..*t },
                    |_| T::zero(),
                    |_, _, _| {},
                ),
                // Run already, with this estimate's simulation (`iterate`).
                None if uoc_done => {}
                None => self
                    .solver
                    .solve(wts, a, warm, &mut self.s_uoc[..n], |_| T::zero()),
            }
        }
    }

    /// From rest (no history) the history's free responses, which the
    /// columns of R_i, U_oc, β and the kinetic a and i₀ start from, are
    /// zero over the first `n` rows (and no stale ones from an earlier
    /// window are left); the kinetic ones are read by the Butler–Volmer
    /// model's columns only.
    fn zero_direct_columns(&mut self, n: usize, kinetic: bool) {
        self.s_ri[..n].fill(T::zero());
        self.s_uoc[..n].fill(T::zero());
        self.s_beta[..n].fill(T::zero());
        if kinetic {
            self.s_bva[..n].fill(T::zero());
            self.s_bvi0[..n].fill(T::zero());
        }
    }

    /// Turns the sensitivities, taken at the estimate `p` (whose
    /// [`Simulation`] holds), into the columns of the Jacobian of
    /// the simulated voltage `Û_t(l)` with respect to
    /// `x = [ln R_i, ln R_ct, ln Q, α, U_oc, β, ln a, ln i₀]`, in place
    /// (zero columns for what the settings keep fixed; the kinetic columns
    /// only for the Butler–Volmer model), and writes the residuals at `p`
    /// into the trial buffer (free until the step search).
    pub(super) fn jacobian_columns(&mut self, s: &BatterySettings<T>) {
        let p = self.p;
        let n = self.n.min(N);
        let r = self.warm.min(n)..n;
        // One column at a time, each loop without branches (the settings'
        // tests would otherwise run at every row); each value computed as
        // before, so the same bits.
        let i = &self.i[r.clone()];
        for (x, &il) in self.s_ri[r.clone()].iter_mut().zip(i) {
            *x = p.r_i * (il + *x);
        }
        for x in &mut self.s_rct[r.clone()] {
            *x = p.r_ct * *x;
        }
        for x in &mut self.s_q[r.clone()] {
            *x = p.q * *x;
        }
        if !s.estimate_order {
            self.s_a[r.clone()].fill(T::zero());
        }
        for x in &mut self.s_uoc[r.clone()] {
            *x = T::one() + *x;
        }
        let c = &self.c[r.clone()];
        if s.ocv_slope {
            for (x, &cl) in self.s_beta[r.clone()].iter_mut().zip(c) {
                *x = *x - cl;
            }
        } else {
            self.s_beta[r.clone()].fill(T::zero());
        }
        let (est, spare) = estimate_and_spare(&mut self.sims, self.held);
        let eta = &est.eta[r.clone()];
        if s.model == CellModel::ButlerVolmer {
            for (((sa, si), &il), &el) in self.s_bva[r.clone()]
                .iter_mut()
                .zip(&mut self.s_bvi0[r.clone()])
                .zip(i)
                .zip(eta)
            {
                let (da, di) = kinetic_derivatives(&p, il, el);
                *sa = da + *sa;
                *si = di + *si;
            }
        }
        let rows = self.v[r.clone()].iter().zip(c).zip(i).zip(eta);
        for ((x, &up), (((&v, &cl), &il), &el)) in
            spare.up[r.clone()].iter_mut().zip(&est.up[r]).zip(rows)
        {
            *x = residual(v, &p, self.beta, cl, il, el, up);
        }
        if self.unobserved > 0 {
            self.mask_unobserved();
        }
    }

    /// Zeroes the residual and the Jacobian's row at every unobserved
    /// sample (a NaN voltage) of the fitted rows: they add nothing to
    /// `JᵀJ`, `Jᵀr` or a chord step.
    fn mask_unobserved(&mut self) {
        let n = self.n.min(N);
        let warm = self.warm.min(n);
        let spare = self.spare();
        for l in warm..n {
            if self.v[l].is_nan() {
                for col in [
                    &mut self.s_ri,
                    &mut self.s_rct,
                    &mut self.s_q,
                    &mut self.s_a,
                    &mut self.s_uoc,
                    &mut self.s_beta,
                    &mut self.s_bva,
                    &mut self.s_bvi0,
                ] {
                    col[l] = T::zero();
                }
                self.sims[spare].up[l] = T::zero();
            }
        }
    }

    /// Row `l` of the Jacobian left by [`Self::jacobian_columns`] (the
    /// kinetic columns zero in the linear model).
    #[inline]
    pub(super) fn jacobian_row(&self, s: &BatterySettings<T>, l: usize) -> [T; COLUMNS] {
        let (da, di) = match s.model {
            CellModel::ButlerVolmer => (self.s_bva[l], self.s_bvi0[l]),
            CellModel::Linear => (T::zero(), T::zero()),
        };
        [
            self.s_ri[l],
            self.s_rct[l],
            self.s_q[l],
            self.s_a[l],
            self.s_uoc[l],
            self.s_beta[l],
            da,
            di,
        ]
    }

    /// New sensitivities at the estimate (whose [`Simulation`] is held), the
    /// Jacobian's columns from them, and the data's normal equations
    /// `JᵀJ`, `Jᵀr` in `x`.
    /// (`uoc_done`: see [`Self::sensitivities`].)
    pub(super) fn normal_equations(
        &mut self,
        s: &BatterySettings<T>,
        uoc_done: bool,
    ) -> (Square<T>, [T; COLUMNS]) {
        self.sensitivities(
            s.ocv_slope,
            s.model == CellModel::ButlerVolmer,
            s.uses_tail(),
            uoc_done,
        );
        self.jacobian_columns(s);
        // The linear model's kinetic columns are zero: not accumulated.
        match s.model {
            // Without the OCV slope its column is zero, and so are its
            // sums: not accumulated either.
            CellModel::Linear if s.ocv_slope => self.accumulate::<LINEAR_COLUMNS, true>(),
            CellModel::Linear => self.accumulate::<LINEAR_COLUMNS, false>(),
            CellModel::ButlerVolmer if s.ocv_slope => self.accumulate::<COLUMNS, true>(),
            CellModel::ButlerVolmer => self.accumulate::<COLUMNS, false>(),
        }
    }

    /// `JᵀJ` and `Jᵀr` over the first `C` columns of `x` (the rest zero),
    /// from the columns and residuals of [`Self::jacobian_columns`].
    ///
    /// The 44 sums of the Butler–Volmer model (27 of the linear one) do
    /// not fit the Cortex-M4F's 32 registers with the row's values, so they
    /// go in passes over the rows that each keep at most 20 sums in
    /// registers. Every sum still adds its rows in order:
    /// the same values as one pass. Without `SLOPE` the sums of the OCV
    /// slope's column (index 5, zero when the slope is not fitted) are
    /// left at zero, the value they would add up to: 35 sums in two passes
    /// (20 in one for the linear model) instead of 44 in three.
    pub(super) fn accumulate<const C: usize, const SLOPE: bool>(
        &self,
    ) -> (Square<T>, [T; COLUMNS]) {
        let n = self.n.min(N);
        let warm = self.warm.min(n);
        let cols: [&[T]; COLUMNS + 1] = [
            &self.s_ri[warm..n],
            &self.s_rct[warm..n],
            &self.s_q[warm..n],
            &self.s_a[warm..n],
            &self.s_uoc[warm..n],
            &self.s_beta[warm..n],
            &self.s_bva[warm..n],
            &self.s_bvi0[warm..n],
            &self.sims[self.spare()].up[warm..n],
        ];
        let len = n - warm;
        // Opaque column addresses: otherwise the compiler addresses every
        // column from one base at offsets past the load's immediate range
        // (a `movw` and an `add` per load on the Cortex-M4F).
        let cs = cols.map(|c| core::hint::black_box(&c[..len]));
        // (Their lengths are `len`; the minimum lets the optimizer see it.)
        let len = cs.iter().fold(len, |m, c| m.min(c.len()));
        let mut a = [[T::zero(); COLUMNS]; COLUMNS];
        let mut b = [T::zero(); COLUMNS];
        // One pass over the rows for the listed sums `(x, y)`: into
        // `a[x][y]`, or into `b[x]` for `y = 8` (the residuals). Written
        // out with constant indices, so that the sums stay in registers.
        macro_rules! pass {
            ($(($x:literal, $y:literal)),* $(,)?) => {{
                const P: usize = [$($x),*].len();
                let pairs: [(usize, usize); P] = [$(($x, $y)),*];
                let mut sums = [T::zero(); P];
                for l in 0..len {
                    let mut k = 0;
                    $(
                        sums[k] = sums[k] + cs[$x][l] * cs[$y][l];
                        k += 1;
                    )*
                    debug_assert_eq!(k, P);
                }
                // (x < COLUMNS and y ≤ COLUMNS: the literals above.)
                for (&(x, y), v) in pairs.iter().zip(sums) {
                    let slot = if y == COLUMNS {
                        b.get_mut(x)
                    } else {
                        a.get_mut(x).and_then(|row| row.get_mut(y))
                    };
                    if let Some(slot) = slot {
                        *slot = v;
                    }
                }
            }};
        }
        if C == COLUMNS && !SLOPE {
            // Jᵀr, the diagonal and six others; the other fifteen.
            pass!(
                (0, 8),
                (1, 8),
                (2, 8),
                (3, 8),
                (4, 8),
                (6, 8),
                (7, 8),
                (0, 0),
                (1, 1),
                (2, 2),
                (3, 3),
                (4, 4),
                (6, 6),
                (7, 7),
                (0, 1),
                (0, 2),
                (1, 3),
                (2, 3),
                (4, 6),
                (6, 7),
            );
            pass!(
                (0, 3),
                (0, 4),
                (0, 6),
                (0, 7),
                (1, 2),
                (1, 4),
                (1, 6),
                (1, 7),
                (2, 4),
                (2, 6),
                (2, 7),
                (3, 4),
                (3, 6),
                (3, 7),
                (4, 7),
            );
        } else if C != COLUMNS && !SLOPE {
            // Jᵀr and the five columns' fifteen sums, in one pass.
            pass!(
                (0, 8),
                (1, 8),
                (2, 8),
                (3, 8),
                (4, 8),
                (0, 0),
                (1, 1),
                (2, 2),
                (3, 3),
                (4, 4),
                (0, 1),
                (0, 2),
                (0, 3),
                (0, 4),
                (1, 2),
                (1, 3),
                (1, 4),
                (2, 3),
                (2, 4),
                (3, 4),
            );
        } else if C == COLUMNS {
            // Jᵀr, the diagonal and four neighbours; rows 0 and 1 of the
            // rest; rows 2 to 5 of the rest.
            pass!(
                (0, 8),
                (1, 8),
                (2, 8),
                (3, 8),
                (4, 8),
                (5, 8),
                (6, 8),
                (7, 8),
                (0, 0),
                (1, 1),
                (2, 2),
                (3, 3),
                (4, 4),
                (5, 5),
                (6, 6),
                (7, 7),
                (0, 1),
                (2, 3),
                (4, 5),
                (6, 7),
            );
            pass!(
                (0, 2),
                (0, 3),
                (0, 4),
                (0, 5),
                (0, 6),
                (0, 7),
                (1, 2),
                (1, 3),
                (1, 4),
                (1, 5),
                (1, 6),
                (1, 7),
            );
            pass!(
                (2, 4),
                (2, 5),
                (2, 6),
                (2, 7),
                (3, 4),
                (3, 5),
                (3, 6),
                (3, 7),
                (4, 6),
                (4, 7),
                (5, 6),
                (5, 7),
            );
        } else {
            // The same for six columns.
            pass!(
                (0, 8),
                (1, 8),
                (2, 8),
                (3, 8),
                (4, 8),
                (5, 8),
                (0, 0),
                (1, 1),
                (2, 2),
                (3, 3),
                (4, 4),
                (5, 5),
                (0, 1),
                (2, 3),
                (4, 5),
            );
            pass!(
                (0, 2),
                (0, 3),
                (0, 4),
                (0, 5),
                (1, 2),
                (1, 3),
                (1, 4),
                (1, 5),
                (2, 4),
                (2, 5),
                (3, 4),
                (3, 5),
            );
        }
        mirror_upper(&mut a);
        (a, b)
    }
}

/// `(∂η/∂ln a, ∂η/∂ln i₀)` of `η = a·asinh(I/i₀)` at `current`, given
/// `eta = η(current)` ([`CellParameters::kinetic_voltage`]):
/// `(η, −a·u/√(1+u²))`, `u = I/i₀`.
#[inline]
pub(super) fn kinetic_derivatives<T: Real>(p: &CellParameters<T>, current: T, eta: T) -> (T, T) {
    let u = current / p.bv_i0;
    (eta, -p.bv_a * u / (T::one() + u * u).root())
}

/// Copies the upper triangle of a symmetric matrix into the lower one.
pub(super) fn mirror_upper<T: Copy>(a: &mut Square<T>) {
    for (r, c) in (1..COLUMNS).flat_map(|r| (0..r).map(move |c| (r, c))) {
        a[r][c] = a[c][r];
    }
}
