//! The Levenberg–Marquardt search: the damped step, its judgement
//! (refused, negligible, worth a simulation) and one iteration.

use super::*;

/// A damped Gauss–Newton step from the normal equations.
pub(super) enum Proposal<T> {
    /// The damped matrix is not positive definite.
    Singular,
    /// The step leaves the physical region or the identifiable relaxation
    /// times.
    Refused,
    /// The step is below ε, or its predicted decrease below what the cost
    /// resolves.
    Negligible,
    /// A step worth simulating, and its largest relative change.
    Step {
        p: CellParameters<T>,
        beta: T,
        change: T,
    },
}

pub(super) const LAMBDA0: f64 = 1e-3;
/// A step whose predicted decrease is below this many machine epsilons of
/// the cost is not tried: the cost's rounding (the simulation's, through
/// the recursion) is of that order in `f32`.
pub(super) const COST_RESOLUTION: f64 = 100.0;
/// Longest relaxation time `τ^(1/α)` a trial may have, in fitted windows.
pub(super) const MAX_RELAXATION_WINDOWS: f64 = 10.0;
/// A resistance below this fraction of `R_i + R_ct` is at its bound 0: a
/// step that would lower it further holds it instead.
pub const RESISTANCE_FLOOR: f64 = 1e-6;

/// With [`BatterySettings::line_search`], an accepted step whose parabola
/// (the estimate's cost and slope, the step's cost) has its minimum below
/// this fraction of the step is tried at that minimum as well.
pub const LINE_SEARCH_BELOW: f64 = 0.7;
/// The shortest fraction of a step the line search tries.
const LINE_SEARCH_SHORTEST: f64 = 0.1;
/// The line search is tried only near a minimum: on a step that lowered
/// the cost by less than this fraction of it. Far from one a shorter step
/// than the damped search's, though lower, slowed it (a made 50 000-row
/// Butler–Volmer record took 10 iterations where it took 6).
pub const LINE_SEARCH_NEAR: f64 = 1e-3;

/// Which parameters of an estimate sit at a bound of the search: a
/// resistance below [`RESISTANCE_FLOOR`] of `R_i + R_ct` (its bound 0), α
/// at `alpha_min` or `alpha_max`. The search holds such a parameter where
/// its step would push it further out, so a fit that ends with one is a
/// boundary optimum: reported as such, not as an interior estimate.
///
/// ```
/// use estimator_core::battery::output_error::AtBounds;
/// use estimator_core::battery::{BatterySettings, CellParameters};
///
/// let s = BatterySettings::<f64>::new(1.0, 100);
/// let p = CellParameters { r_i: 1e-12, alpha: 1.0, ..CellParameters::cell_18650() };
/// let b = AtBounds::of(&s, &p);
/// assert_eq!(b.names().collect::<Vec<_>>(), ["r_i", "alpha"]);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AtBounds {
    /// `R_i` at its bound 0.
    pub r_i: bool,
    /// `R_ct` at its bound 0.
    pub r_ct: bool,
    /// α at `alpha_min` or `alpha_max`.
    pub alpha: bool,
}

impl AtBounds {
    /// The bounds `p` sits at under the settings `s`.
    pub fn of<T: Real>(s: &BatterySettings<T>, p: &CellParameters<T>) -> Self {
        let floor = T::lit(RESISTANCE_FLOOR) * (p.r_i + p.r_ct);
        Self {
            r_i: p.r_i <= floor,
            r_ct: p.r_ct <= floor,
            alpha: p.alpha >= s.alpha_max || p.alpha <= s.alpha_min,
        }
    }

    /// True when any parameter is at a bound.
    pub fn any(&self) -> bool {
        self.r_i || self.r_ct || self.alpha
    }

    /// The names (`r_i`, `r_ct`, `alpha`) of the parameters at a bound.
    pub fn names(&self) -> impl Iterator<Item = &'static str> {
        [
            (self.r_i, "r_i"),
            (self.r_ct, "r_ct"),
            (self.alpha, "alpha"),
        ]
        .into_iter()
        .filter_map(|(at, name)| at.then_some(name))
    }
}

impl<T: Real, const N: usize, const MEM: usize, K: BranchSolver<T>>
    OutputErrorRefinement<T, N, MEM, K>
{
    /// The damped step `(A + λ·diag A)⁻¹ b` from the estimate, judged.
    pub(super) fn propose(
        &self,
        s: &BatterySettings<T>,
        a: &Square<T>,
        b: &[T; COLUMNS],
        cost0: T,
        longest: T,
    ) -> Proposal<T> {
        let p = &self.p;
        let mut m = *a;
        for (k, row) in m.iter_mut().enumerate() {
            row[k] = a[k][k] * (T::one() + self.lambda) + T::min_positive_value().sqrt();
        }
        let kinetic = s.model == CellModel::ButlerVolmer;
        let Some(mut dx) = solve_fitted(&m, b, kinetic) else {
            return Proposal::Singular;
        };
        // Active bounds: a resistance already negligible beside the other
        // (its logarithm has no bound, so the search would slide it down
        // for ever, one clamped step at a time, while the rest crawls),
        // and α at a bound, where the step would push them further out,
        // are held; the step is solved again over the other coordinates.
        // Held coordinates only grow, so this settles within as many
        // rounds as there are boundable ones (R_i, R_ct, α).
        let floor = T::lit(RESISTANCE_FLOOR) * (p.r_i + p.r_ct);
        let mut held = [false; 4];
        for _ in 0..3 {
            let out = [
                p.r_i <= floor && dx[0] < T::zero(),
                p.r_ct <= floor && dx[1] < T::zero(),
                false,
                (p.alpha >= s.alpha_max && dx[3] > T::zero())
                    || (p.alpha <= s.alpha_min && dx[3] < T::zero()),
            ];
            if !out.iter().zip(&held).any(|(&o, &h)| o && !h) {
                break;
            }
            for (h, o) in held.iter_mut().zip(out) {
                *h = *h || o;
            }
            let mut mh = m;
            let mut bh = *b;
            for (k, _) in held.iter().enumerate().filter(|(_, &h)| h) {
                for row in mh.iter_mut() {
                    row[k] = T::zero();
                }
                mh[k] = [T::zero(); COLUMNS];
                mh[k][k] = T::one();
                bh[k] = T::zero();
            }
            let Some(d) = solve_fitted(&mh, &bh, kinetic) else {
                return Proposal::Singular;
            };
            dx = d;
        }
        let max_log = T::lit(MAX_LOG_STEP);
        let clamp = |x: T| x.max(-max_log).min(max_log);
        let trial = CellParameters {
            r_i: p.r_i * clamp(dx[0]).exp(),
            r_ct: p.r_ct * clamp(dx[1]).exp(),
            q: p.q * clamp(dx[2]).exp(),
            alpha: s.clamp_alpha(p.alpha + dx[3]),
            u_oc: p.u_oc + dx[4],
            bv_a: p.bv_a * clamp(dx[6]).exp(),
            bv_i0: p.bv_i0 * clamp(dx[7]).exp(),
        };
        let beta = self.beta + dx[5];
        let relax = trial.tau().powf(T::one() / trial.alpha);
        let within = relax <= longest; // false for NaN
        if !trial.is_physical() || !within {
            return Proposal::Refused;
        }
        let scale = p.u_oc.abs().max(T::one());
        let ch = [
            (trial.r_i / p.r_i).ln().abs(),
            (trial.r_ct / p.r_ct).ln().abs(),
            (trial.q / p.q).ln().abs(),
            (trial.alpha - p.alpha).abs(),
            (trial.u_oc - p.u_oc).abs() / scale,
            // (warm < n ≤ N: the charge at the first fitted sample.)
            (beta - self.beta).abs() * self.c.get(self.warm).map_or(T::zero(), |c| c.abs()) / scale,
            if p.is_butler_volmer() {
                (trial.bv_a / p.bv_a).ln().abs()
            } else {
                T::zero()
            },
            (trial.bv_i0 / p.bv_i0).ln().abs(),
        ];
        let change = ch.iter().fold(T::zero(), |m, &x| m.max(x));
        // The decrease the linear model predicts, dxᵀb − ½dxᵀA dx.
        let mut pred = T::zero();
        for k in 0..COLUMNS {
            let adx = (0..COLUMNS).fold(T::zero(), |acc, q| acc + a[k][q] * dx[q]);
            pred = pred + dx[k] * (b[k] - adx / T::lit(2.0));
        }
        let resolution = (T::lit(COST_RESOLUTION) * T::epsilon()).max(s.cost_tolerance);
        if change > s.epsilon && pred > resolution * cost0 {
            Proposal::Step {
                p: trial,
                beta,
                change,
            }
        } else {
            // Below the stopping tolerance, or a decrease below what the
            // cost resolves in this precision (also for NaN): a minimum,
            // not worth a simulation.
            Proposal::Negligible
        }
    }

    /// An iteration that stops at the estimate (a minimum) for `why`;
    /// `data0` is the data's part of the cost `cost0`.
    pub(super) fn stop(
        &mut self,
        cost0: T,
        data0: T,
        rows: usize,
        why: StopReason,
    ) -> RefinementStep<T> {
        self.k += 1;
        self.work.iterations = self.work.iterations.wrapping_add(1);
        RefinementStep {
            k: self.k,
            cost: cost0,
            rmse: rmse(data0, rows),
            change: T::zero(),
            converged: true,
            accepted: false,
            stop: Some(why),
            lambda: self.lambda,
            rows,
        }
    }

    /// One Levenberg–Marquardt iteration over the window.
    ///
    /// # Errors
    /// [`Error::NotEnoughData`] while fewer than `warm-up + MIN_ROWS`
    /// samples are held, [`Error::NotExcited`] for a current whose standard
    /// deviation is below the threshold, [`Error::Diverged`] for a
    /// non-finite cost; settings errors. On error the estimate is unchanged.
    pub fn iterate(
        &mut self,
        s: &BatterySettings<T>,
        win: &impl Window<T>,
    ) -> Result<RefinementStep<T>, Error> {
        s.check::<MEM>()?;
        self.load(s, win)?;
        // `load` keeps warm < n ≤ N; the clamps let the optimizer see it.
        let n = self.n.min(N);
        let warm = self.warm.min(n);
        if current_std(&self.i[warm..n]) <= s.min_current_std {
            return Err(Error::NotExcited);
        }
        if self.w.alpha() != self.p.alpha {
            self.w.set_order(self.p.alpha)?;
        }
        if s.model == CellModel::ButlerVolmer && !self.p.is_butler_volmer() {
            // A linear start (the paper method's estimate): the kinetic
            // term with i₀ at the window's RMS current.
            let rms = rms(&self.i[warm..n]).max(T::lit(1e-3));
            self.p = self.p.with_butler_volmer(rms);
            self.kinetic_kept = 0;
            self.fresh = false;
        }
        let data = WindowData {
            i: &self.i[..n],
            v: &self.v[..n],
            c: &self.c[..n],
            warm,
            tail: tail_context(s, self.past.as_ref()),
        };
        // The last iteration on this window left the simulation of the
        // estimate in its `sims` slot (its accepted trial, or the kept
        // estimate's).
        let evidence = self.evidence;
        let prior_cost = |p: &CellParameters<T>| {
            s.prior.map_or(T::zero(), |pr| pr.cost(p, s)) + Self::evidence_cost(evidence, p)
        };
        // Whether `s_uoc` now holds ∂U_p/∂U_oc at this estimate (run with
        // its simulation, below): handed to the normal equations of this
        // iteration only, so it cannot outlive the simulation it came with.
        let mut uoc_done = false;
        let data0 = if self.fresh {
            let sim = &self.sims[self.est()];
            window_cost(&data, &self.p, self.beta, &sim.eta[..n], &sim.up[..n])
        } else {
            self.stalled = None;
            self.linear = None;
            self.work.simulations = self.work.simulations.wrapping_add(1);
            let es = self.est();
            // Without the OCV slope and the tail, `∂U_p/∂U_oc` is one
            // recursion alone (the history's free response to −1, at these
            // weights and `a`): run with the simulation, through the pair
            // kernel (the same values).
            let free = if !s.ocv_slope && !s.uses_tail() && warm > 0 {
                // Its history: −1 (warm < n).
                if let Some(h) = self.s_uoc.get_mut(..warm) {
                    h.fill(-T::one());
                }
                self.s_uoc.get_mut(..n)
            } else {
                None
            };
            let kept = take_kinetic(&mut self.kinetic_kept, n);
            let sim = &mut self.sims[es];
            let (cost, filled) = simulate_window_with_free(
                &mut self.solver,
                &self.w,
                &data,
                &self.p,
                self.beta,
                &mut sim.up[..n],
                &mut sim.e[..n],
                &mut sim.eta[..n],
                kept,
                free,
            );
            uoc_done = filled;
            cost
        };
        // The cost of the estimate: the data's, plus the prior's.
        let cost0 = data0 + prior_cost(&self.p);
        if !cost0.is_finite() {
            self.fresh = false;
            return Err(Error::Diverged);
        }
        self.fresh = true;
        let rows = (n - warm).saturating_sub(self.unobserved as usize);
        if let Some((_, why)) = self.stalled.filter(|&(f, _)| f == s.fingerprint()) {
            // The last iteration, from this estimate on this window with
            // these settings, found no lower cost with any damping, or no
            // step worth trying (and reset λ): this one would repeat it
            // exactly.
            return Ok(self.stop(cost0, data0, rows, why));
        }
        let longest = T::lit(MAX_RELAXATION_WINDOWS * rows as f64) * s.h;
        if let Some(last) = self.linear.filter(|l| l.fits(s)) {
            // The last iteration on this window accepted a step. Before new
            // sensitivities, its Jacobian J₀ (at the estimate it started
            // from, still in the columns) with the residuals here gives the
            // chord step
            // (J₀ᵀJ₀ + λD)⁻¹J₀ᵀr; when even that is negligible, this is a
            // minimum (to the cost's resolution) and the O(N·M) pass is
            // not needed. Anything else falls through to the exact step.
            let mut b = [T::zero(); COLUMNS];
            let sim = &self.sims[self.est()];
            for l in warm..n {
                let j = self.jacobian_row(s, l);
                let r = residual(
                    self.v[l], &self.p, self.beta, self.c[l], self.i[l], sim.eta[l], sim.up[l],
                );
                if self.v[l].is_nan() {
                    // An unobserved sample (its Jacobian row is zero).
                    continue;
                }
                for (bb, ja) in b.iter_mut().zip(j) {
                    *bb = *bb + ja * r;
                }
            }
            let mut a = last.normal_matrix();
            add_prior(s, &self.p, &mut a, &mut b);
            self.add_evidence(&self.p, &mut a, &mut b);
            if let Proposal::Negligible = self.propose(s, &a, &b, cost0, longest) {
                self.linear = None;
                self.lambda = T::lit(LAMBDA0);
                self.stalled = Some((s.fingerprint(), StopReason::NegligibleStep));
                return Ok(self.stop(cost0, data0, rows, StopReason::NegligibleStep));
            }
        }
        let p = self.p;
        let (mut a, mut b) = self.normal_equations(s, uoc_done);
        self.work.linearizations = self.work.linearizations.wrapping_add(1);
        // The data's J₀ᵀJ₀ is what a chord step reuses; the prior is added
        // there again from the settings of that iteration.
        let data_a = a;
        add_prior(s, &p, &mut a, &mut b);
        // (The estimate has the kinetic term whenever the model does.)
        self.information = Some(self.fit_information(s, a, data0, true));
        // What the window alone identifies is judged without the evidence.
        self.add_evidence(&p, &mut a, &mut b);
        let mut step = RefinementStep {
            k: self.k,
            cost: cost0,
            rmse: rmse(data0, rows),
            change: T::zero(),
            converged: false,
            accepted: false,
            stop: None,
            lambda: self.lambda,
            rows,
        };
        let mut why = StopReason::NoLowerCost;
        for _ in 0..MAX_TRIES {
            let (trial, beta, change) = match self.propose(s, &a, &b, cost0, longest) {
                Proposal::Step { p, beta, change } => (p, beta, change),
                Proposal::Singular | Proposal::Refused => {
                    self.lambda = self.lambda * T::lit(10.0);
                    continue;
                }
                // More damping only shrinks the step and its decrease.
                Proposal::Negligible => {
                    why = StopReason::NegligibleStep;
                    break;
                }
            };
            self.w.set_order(trial.alpha)?;
            let data = WindowData {
                i: &self.i[..n],
                v: &self.v[..n],
                c: &self.c[..n],
                warm,
                tail: tail_context(s, self.past.as_ref()),
            };
            self.work.simulations = self.work.simulations.wrapping_add(1);
            self.work.trials = self.work.trials.wrapping_add(1);
            let ts = self.spare();
            let trial_sim = &mut self.sims[ts];
            let c = simulate_window(
                &mut self.solver,
                &self.w,
                &data,
                &trial,
                beta,
                &mut trial_sim.up[..n],
                &mut trial_sim.e[..n],
                &mut trial_sim.eta[..n],
            );
            let c = c + prior_cost(&trial);
            if c.is_finite() && c < cost0 {
                let (trial, beta, c, change) = if s.line_search {
                    self.shorter_step(s, &b, cost0, longest, (trial, beta, c, change))
                } else {
                    (trial, beta, c, change)
                };
                // The trial's simulation is now the estimate's.
                self.held ^= 1;
                self.kinetic_kept = u32::try_from(n).unwrap_or(u32::MAX);
                step.change = change;
                self.p = trial;
                self.beta = beta;
                self.lambda = (self.lambda / T::lit(10.0)).max(T::lit(1e-12));
                step.accepted = true;
                step.cost = c;
                step.rmse = rmse(c - prior_cost(&trial), rows);
                break;
            }
            self.lambda = self.lambda * T::lit(10.0);
        }
        self.linear = step.accepted.then(|| Linearization::new(s, &data_a));
        if !step.accepted {
            // Back to the order of the kept estimate; λ is reset so that a
            // later window starts with a fresh trust region.
            self.w.set_order(p.alpha)?;
            self.lambda = T::lit(LAMBDA0);
            self.stalled = Some((s.fingerprint(), why));
        }
        self.k += 1;
        self.work.iterations = self.work.iterations.wrapping_add(1);
        step.k = self.k;
        step.lambda = self.lambda;
        step.converged = !step.accepted || step.change <= s.epsilon;
        step.stop = match (step.converged, step.accepted) {
            (false, _) => None,
            (true, true) => Some(StopReason::SmallStep),
            (true, false) => Some(why),
        };
        Ok(step)
    }
}

impl<T: Real, const N: usize, const MEM: usize, K: BranchSolver<T>>
    OutputErrorRefinement<T, N, MEM, K>
{
    /// The line search of [`BatterySettings::line_search`]: `full` is the
    /// accepted step (its estimate, β, cost and largest change), simulated
    /// in the spare slot; `b` is `−∇cost` at the estimate. Returns the
    /// step to take, its simulation in the spare slot and the weights at
    /// its order.
    fn shorter_step(
        &mut self,
        s: &BatterySettings<T>,
        b: &[T; COLUMNS],
        cost0: T,
        longest: T,
        full: (CellParameters<T>, T, T, T),
    ) -> (CellParameters<T>, T, T, T) {
        let (trial, beta, c1, change) = full;
        // (Both costs are finite here: the step was accepted.)
        if cost0 - c1 >= T::lit(LINE_SEARCH_NEAR) * cost0 {
            return full;
        }
        let p = self.p;
        let ln = |a: T, b: T| {
            if a > T::zero() && b > T::zero() {
                (a / b).ln()
            } else {
                T::zero()
            }
        };
        // The step taken, in the search's coordinates.
        let dx = [
            ln(trial.r_i, p.r_i),
            ln(trial.r_ct, p.r_ct),
            ln(trial.q, p.q),
            trial.alpha - p.alpha,
            trial.u_oc - p.u_oc,
            beta - self.beta,
            ln(trial.bv_a, p.bv_a),
            ln(trial.bv_i0, p.bv_i0),
        ];
        // cost(t) ≈ cost0 + slope·t + curve·t² along the step.
        let slope = -dx
            .iter()
            .zip(b)
            .fold(T::zero(), |acc, (&d, &g)| acc + d * g);
        let curve = c1 - cost0 - slope;
        if !(slope < T::zero() && curve > T::zero()) {
            return full;
        }
        let t = -slope / (T::lit(2.0) * curve);
        // (Finite: the slope is negative and the curvature positive.)
        if t >= T::lit(LINE_SEARCH_BELOW) {
            return full;
        }
        let t = t.max(T::lit(LINE_SEARCH_SHORTEST));
        let along = |x: T, d: T| x * (t * d).exp();
        let short = CellParameters {
            r_i: along(p.r_i, dx[0]),
            r_ct: along(p.r_ct, dx[1]),
            q: along(p.q, dx[2]),
            alpha: p.alpha + t * dx[3],
            u_oc: p.u_oc + t * dx[4],
            bv_a: along(p.bv_a, dx[6]),
            bv_i0: along(p.bv_i0, dx[7]),
        };
        let short_beta = self.beta + t * dx[5];
        let within = short.tau().powf(T::one() / short.alpha) <= longest;
        if !short.is_physical() || !within || self.w.set_order(short.alpha).is_err() {
            let _ = self.w.set_order(trial.alpha);
            return full;
        }
        let evidence = self.evidence;
        let n = self.n.min(N);
        let data = WindowData {
            i: &self.i[..n],
            v: &self.v[..n],
            c: &self.c[..n],
            warm: self.warm.min(n),
            tail: tail_context(s, self.past.as_ref()),
        };
        let ts = self.spare();
        let sim = &mut self.sims[ts];
        // Sliced here, where `n ≤ N` is known: no bounds check inside.
        let (up, e, eta) = (&mut sim.up[..n], &mut sim.e[..n], &mut sim.eta[..n]);
        let mut simulate = |q: &CellParameters<T>, bq: T, solver: &mut K, w: &GlWeights<T, MEM>| {
            simulate_window(solver, w, &data, q, bq, up, e, eta)
                + s.prior.map_or(T::zero(), |pr| pr.cost(q, s))
                + Self::evidence_cost(evidence, q)
        };
        self.work.simulations = self.work.simulations.wrapping_add(1);
        let cs = simulate(&short, short_beta, &mut self.solver, &self.w);
        if cs.is_finite() && cs < c1 {
            return (short, short_beta, cs, t * change);
        }
        // The full step was lower after all: its simulation again.
        self.work.simulations = self.work.simulations.wrapping_add(1);
        let _ = self.w.set_order(trial.alpha);
        let _ = simulate(&trial, beta, &mut self.solver, &self.w);
        full
    }
}

/// Solves the damped normal equations `m·x = b` over the fitted columns:
/// all with the Butler–Volmer term, the first [`LINEAR_COLUMNS`] in the
/// linear model (the rest of `x` is then 0, as the full system with its
/// zero columns and tiny diagonal gives, at a third less work).
pub(super) fn solve_fitted<T: Real>(
    m: &Square<T>,
    b: &[T; COLUMNS],
    kinetic: bool,
) -> Option<[T; COLUMNS]> {
    if kinetic {
        return T::solve_spd(m, b);
    }
    let mut m6 = [[T::zero(); LINEAR_COLUMNS]; LINEAR_COLUMNS];
    let mut b6 = [T::zero(); LINEAR_COLUMNS];
    for ((row6, row), (b6k, &bk)) in m6.iter_mut().zip(m).zip(b6.iter_mut().zip(b)) {
        row6.copy_from_slice(&row[..LINEAR_COLUMNS]);
        *b6k = bk;
    }
    let x6 = T::solve_spd(&m6, &b6)?;
    let mut x = [T::zero(); COLUMNS];
    x[..LINEAR_COLUMNS].copy_from_slice(&x6);
    Some(x)
}

/// The column of `x` of each of the prior's coordinates.
pub(super) const PRIOR_COLUMNS: [usize; 6] = [0, 1, 2, 3, 6, 7];

/// Adds the prior's part to the normal equations at `p`: its weights `w_k`
/// to the diagonal of `JᵀJ` and `w_k·(c_k − x_k)` to `Jᵀr` (nothing without
/// a prior).
pub(super) fn add_prior<T: Real>(
    s: &BatterySettings<T>,
    p: &CellParameters<T>,
    a: &mut Square<T>,
    b: &mut [T; COLUMNS],
) {
    if let Some(pr) = &s.prior {
        let (w, c) = pr.terms();
        let x = Prior::coordinates(p);
        for (k, on) in pr.active(s).into_iter().enumerate() {
            if on {
                let col = PRIOR_COLUMNS[k];
                a[col][col] = a[col][col] + w[k];
                b[col] = b[col] + w[k] * (c[k] - x[k]);
            }
        }
    }
}

/// The weights [`add_prior`] adds to the diagonal of `JᵀJ`, by column of
/// `x` (zero where the prior has no term, and everywhere without one).
pub(super) fn prior_diagonal<T: Real>(s: &BatterySettings<T>) -> [T; COLUMNS] {
    let mut d = [T::zero(); COLUMNS];
    if let Some(pr) = &s.prior {
        let (w, _) = pr.terms();
        for (k, on) in pr.active(s).into_iter().enumerate() {
            if on {
                d[PRIOR_COLUMNS[k]] = w[k];
            }
        }
    }
    d
}

/// Root-mean-square residual of cost `½Σr²` over `rows` samples.
pub(super) fn rmse<T: Real>(cost: T, rows: usize) -> T {
    (T::lit(2.0) * cost / T::lit(rows as f64)).sqrt()
}
