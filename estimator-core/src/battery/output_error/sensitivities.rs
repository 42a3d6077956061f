//! The sensitivities of the simulated voltage to every parameter, the
//! Jacobian's rows and the normal equations `JᵀJ`, `Jᵀr` (see the parent
//! module's docs for the recursions).

use super::*;

/// `J₀ᵀJ₀` of an iteration (its upper triangle by rows), the estimate it
/// was taken at, and which columns it had.
#[derive(Clone, Copy, Debug)]
pub(super) struct Linearization<T> {
    pub(super) p: CellParameters<T>,
    pub(super) a: [T; PACKED],
    pub(super) estimate_order: bool,
    pub(super) ocv_slope: bool,
    pub(super) model: CellModel,
}

impl<T: Real> Linearization<T> {
    pub(super) fn new(s: &BatterySettings<T>, p: CellParameters<T>, a: &Square<T>) -> Self {
        let mut up = [T::zero(); PACKED];
        let mut k = 0;
        for (r, row) in a.iter().enumerate() {
            for &x in &row[r..] {
                up[k] = x;
                k += 1;
            }
        }
        Self {
            p,
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
    /// held in `up` and `e`; with `tail`, of the model with the taps beyond
    /// the memory ([`BatterySettings::tail`]).
    pub(super) fn sensitivities(&mut self, slope: bool, kinetic: bool, tail: bool) {
        let (n, warm) = (self.n, self.warm);
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
        let dup = &mut self.trial;
        self.solver
            .weight_derivative(&self.w, &self.up[..n], warm..n, |l, d| dup[l] = d);
        if let Some((t, dc)) = &tails {
            let mut z = z_up;
            for (l, dl) in dup.iter_mut().enumerate().take(n).skip(warm) {
                if l >= memory {
                    let x = self.up[l - memory];
                    for (zk, &r) in z.iter_mut().zip(&t.rates) {
                        *zk = r * *zk + x;
                    }
                }
                let d = dc.iter().zip(&z).fold(T::zero(), |s, (&c, &z)| s + c * z);
                *dl = *dl + g * d;
            }
        }
        let (i, e, dup) = (&self.i, &self.e, &self.trial);
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
        let rct_q = |l: usize| (i[l] - p.q * g * e[l], -p.r_ct * g * e[l]);
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
        let order = |l: usize| a * ln_h * e[l] - tau * dup[l];
        if warm == 0 {
            // From rest: no history, so no free responses (and no stale
            // ones from an earlier window).
            match &tails {
                Some((t, _)) => {
                    cpe_filter_tail(wts, a, warm, &mut self.s_a[..n], t, order, |_, _, _| {})
                }
                None => self.solver.solve(wts, a, warm, &mut self.s_a[..n], order),
            }
            self.s_ri[..n].fill(T::zero());
            self.s_uoc[..n].fill(T::zero());
            self.s_beta[..n].fill(T::zero());
            if kinetic {
                // (Read by the Butler–Volmer model's columns only.)
                self.s_bva[..n].fill(T::zero());
                self.s_bvi0[..n].fill(T::zero());
            }
            return;
        }
        if kinetic {
            // The history U_p = U_t − U_oc − R_i·I − η(I) moves with η's
            // parameters: the free responses to −∂η. (No tail: the model
            // with the Butler–Volmer term keeps the truncated sum.)
            for ((sa, si), &il) in self.s_bva[..warm]
                .iter_mut()
                .zip(&mut self.s_bvi0[..warm])
                .zip(&i[..warm])
            {
                let (da, di) = kinetic_derivatives(&p, il);
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
                None => self
                    .solver
                    .solve(wts, a, warm, &mut self.s_uoc[..n], |_| T::zero()),
            }
        }
    }

    /// Row `l` of the Jacobian of the simulated voltage `Û_t(l)` with
    /// respect to `x = [ln R_i, ln R_ct, ln Q, α, U_oc, β, ln a, ln i₀]`
    /// (zero columns for what the settings keep fixed), from the
    /// sensitivities taken at `p`.
    #[inline]
    pub(super) fn jacobian_row(
        &self,
        s: &BatterySettings<T>,
        p: &CellParameters<T>,
        l: usize,
    ) -> [T; COLUMNS] {
        let (da, di) = match s.model {
            CellModel::ButlerVolmer => self.kinetic_columns(p, l),
            CellModel::Linear => (T::zero(), T::zero()),
        };
        [
            p.r_i * (self.i[l] + self.s_ri[l]),
            p.r_ct * self.s_rct[l],
            p.q * self.s_q[l],
            if s.estimate_order {
                self.s_a[l]
            } else {
                T::zero()
            },
            T::one() + self.s_uoc[l],
            if s.ocv_slope {
                self.s_beta[l] - self.c[l]
            } else {
                T::zero()
            },
            da,
            di,
        ]
    }

    /// The Butler–Volmer columns of row `l` of the Jacobian. Kept out of
    /// line: inlined, its `asinh` and square root make the compiler outline
    /// the whole row instead, and the linear model's rows then cost 10 %
    /// more on the Cortex-M4 (docs/butler-volmer.md).
    #[inline(never)]
    pub(super) fn kinetic_columns(&self, p: &CellParameters<T>, l: usize) -> (T, T) {
        let (da, di) = kinetic_derivatives(p, self.i[l]);
        (da + self.s_bva[l], di + self.s_bvi0[l])
    }

    /// New sensitivities at the estimate (whose simulation `up` holds) and
    /// the data's normal equations `JᵀJ`, `Jᵀr` in `x`.
    pub(super) fn normal_equations(&mut self, s: &BatterySettings<T>) -> (Square<T>, [T; COLUMNS]) {
        self.sensitivities(
            s.ocv_slope,
            s.model == CellModel::ButlerVolmer,
            s.uses_tail(),
        );
        // The linear model's kinetic columns are zero: not accumulated.
        // (A constant width: the compiler keeps the sums in registers.)
        match s.model {
            CellModel::Linear => self.accumulate::<LINEAR_COLUMNS>(s),
            CellModel::ButlerVolmer => self.accumulate::<COLUMNS>(s),
        }
    }

    /// `JᵀJ` and `Jᵀr` over the first `C` columns of `x` (the rest zero),
    /// from the sensitivities.
    pub(super) fn accumulate<const C: usize>(
        &self,
        s: &BatterySettings<T>,
    ) -> (Square<T>, [T; COLUMNS]) {
        let p = self.p;
        let mut a = [[T::zero(); C]; C];
        let mut b = [T::zero(); C];
        for l in self.warm..self.n {
            let full = self.jacobian_row(s, &p, l);
            let j: [T; C] = core::array::from_fn(|k| full[k]);
            let r = residual(self.v[l], &p, self.beta, self.c[l], self.i[l], self.up[l]);
            // The upper triangle; the lower one is filled below.
            for (k, (r_, ja)) in a.iter_mut().zip(j).enumerate() {
                for (x, &jb) in r_[k..].iter_mut().zip(&j[k..]) {
                    *x = *x + ja * jb;
                }
            }
            for (bb, ja) in b.iter_mut().zip(j) {
                *bb = *bb + ja * r;
            }
        }
        let mut wide = [[T::zero(); COLUMNS]; COLUMNS];
        let mut wb = [T::zero(); COLUMNS];
        for (row, src) in wide.iter_mut().zip(&a) {
            row[..C].copy_from_slice(src);
        }
        wb[..C].copy_from_slice(&b);
        mirror_upper(&mut wide);
        (wide, wb)
    }
}

/// `(∂η/∂ln a, ∂η/∂ln i₀)` of `η = a·asinh(I/i₀)` at `current`:
/// `(η, −a·u/√(1+u²))`, `u = I/i₀`.
#[inline]
pub(super) fn kinetic_derivatives<T: Real>(p: &CellParameters<T>, current: T) -> (T, T) {
    let u = current / p.bv_i0;
    (p.bv_a * u.arsinh(), -p.bv_a * u / (T::one() + u * u).root())
}

/// Copies the upper triangle of a symmetric matrix into the lower one.
pub(super) fn mirror_upper<T: Copy>(a: &mut Square<T>) {
    for (r, c) in (1..COLUMNS).flat_map(|r| (0..r).map(move |c| (r, c))) {
        a[r][c] = a[c][r];
    }
}
