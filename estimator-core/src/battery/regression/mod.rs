//! The paper's method for the battery (§6.2): a linear regression in θ whose
//! regressors depend on the order, identified by 2S-OP-GI.
//!
//! Writing `Δ^α x(l) = h^(−α)·x(l) + H[x](l)` (the current sample plus the
//! history part `H`, the paper's `Δ^(α)`), the model becomes, with
//! `g = h^(−α)`,
//!
//! ```text
//! U_t(l) = φ(l)ᵀ θ
//! φ(l) = [ I(l),  Δ^α I(l),  −H[U_t](l),  1 ]
//! θ    = [ (R_i+R_ct)/(1+τg),  R_i·τ/(1+τg),  τ/(1+τg),  U_oc·(1 + τ·g·s_M)/(1+τg) ]
//! ```
//!
//! where `s_M = Σ_{j<M} w_j(α)` is the sum of the truncated weights: with
//! memory `M`, `Δ^α` of a constant `c` is the constant `c·g·s_M` once `M`
//! samples have passed, which is why only rows `l ≥ M − 1` are used. (The
//! paper has `h = 1`, `g = 1` and, with unbounded memory, `s_M → 0`.)
//!
//! Back from θ ([`cell_from_theta`]):
//!
//! ```text
//! τ = θ₃ / (1 − θ₃·g),   R_i = θ₂/θ₃,   R_ct = θ₁/(1 − θ₃·g) − R_i,
//! Q = τ/R_ct,            U_oc = θ₄·(1 + τ·g) / (1 + τ·g·s_M)
//! ```
//!
//! One iteration ([`PaperRegressionGi::iterate`]) is a gradient step on θ
//! with exact line search (stage 1) and the safeguarded Gauss–Newton search
//! on α (stage 2), as in 2S-OP-GI. The projected iteration
//! ([`PaperRegressionGi::iterate_projected`]) solves θ by least squares
//! instead and steps α on the cost minimized over θ: the same regression's
//! minimum, in about a dozen iterations where 2S-OP-GI takes hundreds.
//!
//! ## Centred voltage (a rounding measure, same iterates)
//!
//! A cell's residuals are millivolts left over from volts: computed from
//! `U_t ≈ 3.7 V` and `H[U_t] ≈ −3.3 V`, an `f32` residual keeps only three
//! or four digits. So the voltages are stored centred, `v = U_t − vref`
//! (`vref`: the window's mean voltage, renewed when the voltage has moved
//! by more than `|vref|/32 + 1 mV`), and, for the full-memory rows used
//! here, `H[U_t] = H[v] + vref·k` with the constant `k = h^(−α)·Σ_{j≥1} w_j`.
//! The vref terms are gathered into scalars (the residual's constant
//! `θ₄ − θ₃·vref·k − vref`, the gradient's `−vref·k·Σr`, the order
//! derivative's `θ₃·vref·∂k/∂α`), so the algorithm and its iterates are
//! those of the uncentred regression in exact arithmetic; only the rounding
//! changes. After 400 iterations on a 256-sample pulse window (test
//! `f32_paper_method_follows_f64`) the `f32` order is within 9·10⁻⁶ of the
//! `f64` one and R_ct within 1.4·10⁻⁴ (relative); uncentred, 4.4·10⁻⁴ and
//! 6.5·10⁻³.

use super::{current_std, BatterySettings, CellParameters};
use crate::error::Error;
use crate::frac::{DirectSums, GlWeights, TapSums};
use crate::gi::{Iteration, OrderStep, P0};
use crate::real::{dot, norm, Real};
use crate::window::Window;
use rows::{slide_one, store_derivatives, store_regressors};
use trial::order_search;

/// Fewest regression rows an iteration accepts (four parameters and α).
pub const MIN_ROWS: usize = 8;

/// θ of the regression for given cell parameters, sample period `h` and
/// memory `memory` (the forward map; inverse of [`cell_from_theta`]).
///
/// # Errors
/// [`Error::Frac`] for a bad period, order or memory.
pub fn theta_from_cell<T: Real, const MEM: usize>(
    p: &CellParameters<T>,
    h: T,
    memory: usize,
) -> Result<[T; 4], Error> {
    let w = GlWeights::<T, MEM>::new(p.alpha, h, memory)?;
    let g = w.scale();
    let s_m = w.weights().iter().fold(T::zero(), |s, &x| s + x);
    let tau = p.tau();
    let den = T::one() + tau * g;
    Ok([
        (p.r_i + p.r_ct) / den,
        p.r_i * tau / den,
        tau / den,
        p.u_oc * (T::one() + tau * g * s_m) / den,
    ])
}

/// Cell parameters from θ at order `alpha` (see the module docs). `None`
/// unless the result is physical (positive resistances and `Q`).
pub fn cell_from_theta<T: Real, const MEM: usize>(
    theta: &[T; 4],
    alpha: T,
    h: T,
    memory: usize,
) -> Option<CellParameters<T>> {
    let w = GlWeights::<T, MEM>::new(alpha, h, memory).ok()?;
    cell_from_theta_with(theta, &w)
}

fn cell_from_theta_with<T: Real, const MEM: usize>(
    theta: &[T; 4],
    w: &GlWeights<T, MEM>,
) -> Option<CellParameters<T>> {
    let g = w.scale();
    let s_m = w.weights().iter().fold(T::zero(), |s, &x| s + x);
    let [t1, t2, t3, t4] = *theta;
    let d = T::one() - t3 * g;
    if !(t3 > T::zero() && d > T::zero()) {
        return None;
    }
    let tau = t3 / d;
    let r_i = t2 / t3;
    let r_ct = t1 / d - r_i;
    let p = CellParameters {
        r_i,
        r_ct,
        q: tau / r_ct,
        alpha: w.alpha(),
        u_oc: t4 * (T::one() + tau * g) / (T::one() + tau * g * s_m),
        // The paper's regression is the linear model's.
        bv_a: T::zero(),
        bv_i0: T::one(),
    };
    p.is_physical().then_some(p)
}

/// The paper's 2S-OP-GI on the battery regression, over a window of
/// capacity `N` with memory capacity `MEM`. Its fractional differences are
/// tap sums over the window's rows, computed by `S` ([`TapSums`]): the
/// direct kernels by default, an `O(N log N)` host's over a whole record.
///
/// ```
/// use estimator_core::battery::{regression::PaperRegressionGi, BatterySettings};
/// use estimator_core::window::SampleWindow;
///
/// let s = BatterySettings::<f64>::new(1.0, 16);
/// let mut gi = PaperRegressionGi::<f64, 64, 16>::new(&s, 0.5).unwrap();
/// let mut window = SampleWindow::<f64, 64>::new();
/// // Too few samples: a typed error, no panic.
/// assert!(gi.iterate(&s, &window).is_err());
/// for l in 0..64 {
///     let i = if (l / 8) % 2 == 0 { 2.0 } else { -2.0 };
///     window.push(i, 3.7 + 0.03 * i).unwrap();
/// }
/// let it = gi.iterate(&s, &window).unwrap();
/// assert_eq!((it.k, it.rows), (1, 64 - 15));
/// ```
#[derive(Clone, Debug)]
pub struct PaperRegressionGi<T, const N: usize, const MEM: usize, S = DirectSums> {
    theta: [T; 4],
    k: u32,
    w: GlWeights<T, MEM>,
    /// Window data and regressors at the current order. The voltages are
    /// kept centred, `v = U_t − vref`, and `hv`, `dhv` are the history part
    /// of the centred voltage (module docs).
    i: [T; N],
    v: [T; N],
    vref: Option<T>,
    di: [T; N],
    hv: [T; N],
    /// Their order derivatives, valid only while `derivatives` is set:
    /// computed when the order stage first needs them at this order.
    ddi: [T; N],
    dhv: [T; N],
    derivatives: bool,
    /// How many iterations in a row moved the order. After two, the next
    /// one will probably move it again, so its order stage differentiates
    /// only the combined regressor instead of computing `ddi`, `dhv` to
    /// keep ([`Self::order_gradient`]).
    order_moves: u32,
    /// The regressors `Δ^α I` and `H[U_t]` at a trial order, taken over
    /// when the trial is accepted.
    trial_di: [T; N],
    trial_hv: [T; N],
    res: [T; N],
    n: usize,
    stamp: Option<(u32, usize, T)>,
    /// Who computes the tap sums (no state for the direct ones).
    sums: S,
}

/// The part of [`PaperRegressionGi`] a cell keeps between iterations
/// (small and `Copy`; the rest is working area).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PaperRegressionState<T> {
    theta: [T; 4],
    alpha: T,
    k: u32,
    order_moves: u32,
    vref: Option<T>,
}

impl<T: Real, const N: usize, const MEM: usize, S: TapSums<T>> PaperRegressionGi<T, N, MEM, S> {
    /// A new estimator with the paper's initial values `θ̂₀ = 1/p₀` and the
    /// initial order `alpha0`.
    ///
    /// # Errors
    /// Any error of [`BatterySettings::check`]; [`Error::BadSetting`] for
    /// an `alpha0` outside the order bounds.
    pub fn new(s: &BatterySettings<T>, alpha0: T) -> Result<Self, Error> {
        s.check::<MEM>()?;
        if !(alpha0.is_finite() && alpha0 >= s.alpha_min && alpha0 <= s.alpha_max) {
            return Err(Error::BadSetting);
        }
        Ok(Self {
            theta: [T::lit(1.0 / P0); 4],
            k: 0,
            w: GlWeights::new(alpha0, s.h, s.memory)?,
            i: [T::ZERO; N],
            v: [T::ZERO; N],
            vref: None,
            di: [T::ZERO; N],
            hv: [T::ZERO; N],
            ddi: [T::ZERO; N],
            dhv: [T::ZERO; N],
            derivatives: false,
            order_moves: 0,
            trial_di: [T::ZERO; N],
            trial_hv: [T::ZERO; N],
            res: [T::ZERO; N],
            n: 0,
            stamp: None,
            sums: S::default(),
        })
    }

    /// Restarts from `θ̂₀ = 1/p₀` and order `alpha0`.
    ///
    /// # Errors
    /// As [`PaperRegressionGi::new`]; on error the state is unchanged.
    pub fn reset(&mut self, s: &BatterySettings<T>, alpha0: T) -> Result<(), Error> {
        s.check::<MEM>()?;
        if !(alpha0.is_finite() && alpha0 >= s.alpha_min && alpha0 <= s.alpha_max) {
            return Err(Error::BadSetting);
        }
        self.w.set(alpha0, s.h, s.memory)?;
        self.theta = [T::lit(1.0 / P0); 4];
        self.k = 0;
        self.stamp = None;
        self.order_moves = 0;
        Ok(())
    }

    /// Starts from given cell parameters (a warm start): θ is set from
    /// them, the counter is kept.
    ///
    /// # Errors
    /// [`Error::BadSetting`] for non-physical parameters or an order outside
    /// the bounds; [`Error::Frac`] for a bad period or memory.
    pub fn set_cell(&mut self, s: &BatterySettings<T>, p: &CellParameters<T>) -> Result<(), Error> {
        s.check::<MEM>()?;
        if !p.is_physical() || p.alpha < s.alpha_min || p.alpha > s.alpha_max {
            return Err(Error::BadSetting);
        }
        self.theta = theta_from_cell::<T, MEM>(p, s.h, s.memory)?;
        self.w.set(p.alpha, s.h, s.memory)?;
        self.stamp = None;
        Ok(())
    }

    /// The [`state`](Self::state) of a new estimator with initial order
    /// `alpha0` (without building one).
    pub fn initial_state(alpha0: T) -> PaperRegressionState<T> {
        PaperRegressionState {
            theta: [T::lit(1.0 / P0); 4],
            alpha: alpha0,
            k: 0,
            order_moves: 0,
            vref: None,
        }
    }

    /// What this estimator carries between samples for one cell: θ̂, α̂,
    /// the counters and the voltage centre. The rest of the type is working
    /// area over the loaded window, which a pack shares between its cells
    /// ([`resume`](Self::resume) reloads it).
    pub fn state(&self) -> PaperRegressionState<T> {
        PaperRegressionState {
            theta: self.theta,
            alpha: self.w.alpha(),
            k: self.k,
            order_moves: self.order_moves,
            vref: self.vref,
        }
    }

    /// Takes up a cell's [`state`](Self::state): the next iteration
    /// continues that cell's iterations on whatever window it is given (the
    /// working area is reloaded from it).
    ///
    /// # Errors
    /// [`Error::Frac`] for a bad period, order or memory; on error nothing
    /// changes.
    pub fn resume(
        &mut self,
        s: &BatterySettings<T>,
        st: &PaperRegressionState<T>,
    ) -> Result<(), Error> {
        self.w.set(st.alpha, s.h, s.memory)?;
        self.theta = st.theta;
        self.k = st.k;
        self.order_moves = st.order_moves;
        self.vref = st.vref;
        self.stamp = None;
        self.derivatives = false;
        Ok(())
    }

    /// θ̂ of the regression.
    pub fn theta(&self) -> &[T; 4] {
        &self.theta
    }

    /// α̂.
    pub fn alpha(&self) -> T {
        self.w.alpha()
    }

    /// Iterations since the last reset.
    pub fn iterations(&self) -> u32 {
        self.k
    }

    /// The cell parameters recovered from θ̂ and α̂, or `None` while they are
    /// not physical (e.g. in the first iterations from `1/p₀`).
    pub fn cell(&self) -> Option<CellParameters<T>> {
        cell_from_theta_with(&self.theta, &self.w)
    }

    fn rows(&self) -> core::ops::Range<usize> {
        // n ≤ N always (`load`); the clamps let the optimizer see it.
        let n = self.n.min(N);
        (self.w.len() - 1).min(n)..n
    }

    /// Whether a voltage `u` is too far from the centre `c` to be kept
    /// centred on it: further than `|c|/32 + 1 mV` (0.12 V for a Li-ion
    /// cell). The regressors are then recomputed around a new centre.
    fn off_centre(c: T, u: T) -> bool {
        // Window samples are finite, so the comparison is never with a NaN.
        (u - c).abs() > c.abs() / T::lit(32.0) + T::lit(1e-3)
    }

    /// The history part of a unit constant on a full-memory row,
    /// `k = H[1] = h^(−α)·Σ_{1≤j<M} w_j`, and its order derivative
    /// `∂k/∂α = h^(−α)·Σ_j ∂w_j/∂α − ln h·k`: `H[U_t] = H[v] + vref·k`.
    fn unit_history(w: &GlWeights<T, MEM>) -> (T, T) {
        let g = w.scale();
        let k = g * w.weights().iter().skip(1).fold(T::zero(), |s, &x| s + x);
        let dk = g * w.weight_derivatives().iter().fold(T::zero(), |s, &x| s + x) - w.ln_h() * k;
        (k, dk)
    }

    /// The constant a parameter vector `th` adds to the centred prediction
    /// `th₁·I + th₂·Δ^α I − th₃·H[v] + b` at an order whose unit history is
    /// `k`, with `shift` = `vref` for a residual against the centred
    /// voltage and 0 for a plain prediction: `b = th₄ − th₃·vref·k − shift`.
    fn centred_constant(&self, th: &[T; 4], k: T, shift: T) -> T {
        let c = self.vref.unwrap_or(T::zero());
        th[3] - th[2] * c * k - shift
    }

    /// Copies the window and computes the regressors at the current order,
    /// unless they are already known for this window and order.
    ///
    /// The regressors of a row depend only on the `M` samples up to it, all
    /// inside the window (rows start at `M − 1`). So when exactly one sample
    /// was pushed since the last load (the window's version moved by one) and α is unchanged, the known rows are
    /// shifted by one (if the window slid) and only the newest row is
    /// computed: `O(N + M)` instead of `O(N·M)`, with bit-identical values.
    fn load(&mut self, s: &BatterySettings<T>, win: &impl Window<T>) -> Result<(), Error> {
        if self.w.h() != s.h || self.w.len() != s.memory {
            self.w.set(self.w.alpha(), s.h, s.memory)?;
            self.stamp = None;
        }
        let key = (win.version(), win.len(), self.w.alpha());
        if self.stamp == Some(key) {
            return Ok(());
        }
        let need = s.memory - 1 + MIN_ROWS;
        let n = win.len().min(N);
        if let (Some((version, n0, alpha)), Some((i, v)), Some(c)) =
            (self.stamp, win.recent().next(), self.vref)
        {
            let one_more = version.wrapping_add(1) == key.0 && alpha == key.2 && n >= need;
            if one_more && (n == n0 || n == n0 + 1) && !Self::off_centre(c, v) {
                if n == n0 {
                    for x in [&mut self.i, &mut self.v, &mut self.di, &mut self.hv] {
                        slide_one(&mut x[..n]);
                    }
                    if self.derivatives {
                        slide_one(&mut self.ddi[..n]);
                        slide_one(&mut self.dhv[..n]);
                    }
                }
                // n ≥ need ≥ 1 here.
                let last = n.saturating_sub(1);
                self.i[last] = i;
                self.v[last] = v - c;
                self.n = n;
                self.regressor_row(last);
                self.stamp = Some(key);
                return Ok(());
            }
        }
        self.n = win.copy_into(&mut self.i, &mut self.v).min(N);
        if self.n < need {
            self.stamp = None;
            return Err(Error::NotEnoughData { have: self.n, need });
        }
        let v = &mut self.v[..self.n];
        let c = match self.vref {
            Some(c) if !v.last().is_some_and(|&u| Self::off_centre(c, u)) => c,
            _ => v.iter().fold(T::zero(), |s, &x| s + x) / T::lit(self.n as f64),
        };
        for x in v.iter_mut() {
            *x = *x - c;
        }
        self.vref = Some(c);
        self.regressors();
        self.stamp = Some(key);
        Ok(())
    }

    /// The regressors of every row, in blocks of rows (the same values as
    /// [`Self::regressor_row`] row by row, bit for bit). Their order
    /// derivatives are left for [`Self::derivatives`].
    fn regressors(&mut self) {
        let rows = self.rows();
        let Self {
            w,
            i,
            v,
            di,
            hv,
            n,
            sums,
            ..
        } = self;
        let n = (*n).min(N);
        let (g, v) = (w.scale(), &v[..n]);
        sums.pair(w.weights(), &i[..n], v, rows, |l, a, b| {
            store_regressors(di, hv, v, g, l, g * a, g * b);
        });
        self.derivatives = false;
    }

    /// The order derivatives of the regressors on every row, unless known:
    /// `∂Δ^α I/∂α = D I − ln h·Δ^α I` and, since `∂g/∂α = −ln h·g`,
    /// `∂H[U_t]/∂α = D U_t − ln h·H[U_t]` (`D`: the weight-derivative sum,
    /// [`GlWeights::for_each_weight_derivative_pair`]).
    fn derivatives(&mut self) {
        if self.derivatives {
            return;
        }
        let rows = self.rows();
        let Self {
            w,
            i,
            v,
            di,
            hv,
            ddi,
            dhv,
            n,
            sums,
            ..
        } = self;
        let (s, ln_h) = (w.scale(), w.ln_h());
        let n = (*n).min(N);
        sums.pair(w.weight_derivatives(), &i[..n], &v[..n], rows, |l, a, b| {
            store_derivatives(ddi, dhv, di, hv, ln_h, l, s * a, s * b);
        });
        self.derivatives = true;
    }

    /// `(Σd², Σd·r)` over the rows, for the order derivative of the
    /// prediction `d = ∂(φᵀθ)/∂α = θ₂·∂Δ^α I/∂α − θ₃·∂H[U_t]/∂α` and the
    /// residuals in `res`. `dk` is the order derivative of the unit history
    /// ([`Self::unit_history`]): `∂H[U_t]/∂α = ∂H[v]/∂α + vref·∂k/∂α`.
    ///
    /// With the derivatives kept ([`Self::derivatives`]), or unless the
    /// order moved in each of the last two iterations, `d` comes from the
    /// kept `ddi`, `dhv` (computed if need be, to serve again while the
    /// order stays and, in a sliding window, to be slid row by row). While
    /// the order is travelling they would serve once: `D` being linear,
    /// `d = D z − ln h·(θ₂·Δ^α I − θ₃·H[v])` with `z = θ₂·I − θ₃·v` then
    /// costs one tap sum per row instead of two (`z` is kept in `trial_di`,
    /// free until the order trial). Two moves rather than one: measured in
    /// `docs/performance.md`, a single move is often the last in a sliding
    /// window, where the kept derivatives are worth their second sum.
    fn order_gradient(&mut self, vref: T, dk: T) -> (T, T) {
        let th = self.theta;
        let rows = self.rows();
        let shift = th[2] * vref * dk;
        let (mut dd, mut dr) = (T::zero(), T::zero());
        if self.derivatives || self.order_moves < 2 {
            self.derivatives();
            let (ddi, dhv) = (&self.ddi[rows.clone()], &self.dhv[rows.clone()]);
            for ((&a, &b), &r) in ddi.iter().zip(dhv).zip(&self.res[rows]) {
                let d = th[1] * a - th[2] * b - shift;
                dd = dd + d * d;
                dr = dr + d * r;
            }
        } else {
            let Self {
                w,
                i,
                v,
                di,
                hv,
                trial_di: z,
                res,
                n,
                sums,
                ..
            } = self;
            let (s, ln_h) = (w.scale(), w.ln_h());
            let n = (*n).min(N);
            for ((z, &i), &v) in z.iter_mut().zip(i.iter()).zip(v.iter()).take(n) {
                *z = th[1] * i - th[2] * v;
            }
            sums.single(w.weight_derivatives(), &z[..n], rows, |l, a| {
                let a = s * a;
                // (l is a row: l < n ≤ N.)
                if let (Some(&dl), Some(&hl), Some(&rl)) = (di.get(l), hv.get(l), res.get(l)) {
                    let d = a - ln_h * (th[1] * dl - th[2] * hl) - shift;
                    dd = dd + d * d;
                    dr = dr + d * rl;
                }
            });
        }
        (dd, dr)
    }

    /// The regressors of the newest row `l` after a one-sample slide, and
    /// their derivatives if those are kept.
    fn regressor_row(&mut self, l: usize) {
        let Self {
            w,
            i,
            v,
            di,
            hv,
            ddi,
            dhv,
            n,
            ..
        } = self;
        let n = (*n).min(N);
        let (g, ln_h, v) = (w.scale(), w.ln_h(), &v[..n]);
        w.for_each_difference_pair(&i[..n], v, l..l + 1, |l, d, dv| {
            store_regressors(di, hv, v, g, l, d, dv);
        });
        if self.derivatives {
            w.for_each_weight_derivative_pair(&i[..n], v, l..l + 1, |l, a, b| {
                store_derivatives(ddi, dhv, di, hv, ln_h, l, a, b);
            });
        }
    }

    /// The centred prediction with constant `b` (see
    /// [`Self::centred_constant`]).
    #[inline]
    fn predict(&self, th: &[T; 4], b: T, l: usize) -> T {
        th[0] * self.i[l] + th[1] * self.di[l] - th[2] * self.hv[l] + b
    }

    /// `r = U_t − φᵀθ` on the rows into `res`; returns `½Σr²`. `k` is
    /// the unit history at the current order ([`Self::unit_history`]).
    fn residual(&mut self, k: T) -> T {
        let b = self.centred_constant(&self.theta, k, self.vref.unwrap_or(T::zero()));
        let mut c = T::zero();
        for l in self.rows() {
            let r = self.v[l] - self.predict(&self.theta, b, l);
            self.res[l] = r;
            c = c + r * r;
        }
        c / T::lit(2.0)
    }

    /// Stage 1 of 2S-OP-GI: `θ ← θ + μ Φᵀr` with `μ = ‖g‖²/‖Φg‖²`. With
    /// the voltage centred, `H[U_t] = H[v] + vref·k`, so the gradient's
    /// third entry gains `−vref·k·Σr` and `Φg` the constant `−g₃·vref·k`.
    fn gradient_step(&mut self, k: T, vref: T) {
        let rows = self.rows();
        self.residual(k);
        let mut grad = [T::zero(); 4];
        for l in rows.clone() {
            let r = self.res[l];
            grad[0] = grad[0] + self.i[l] * r;
            grad[1] = grad[1] + self.di[l] * r;
            grad[2] = grad[2] - self.hv[l] * r;
            grad[3] = grad[3] + r;
        }
        grad[2] = grad[2] - vref * k * grad[3];
        let gg = dot(&grad, &grad);
        let mut pg = T::zero();
        let b = self.centred_constant(&grad, k, T::zero());
        for l in rows.clone() {
            let x = self.predict(&grad, b, l);
            pg = pg + x * x;
        }
        if gg > T::zero() && pg > T::zero() {
            let mu = gg / pg;
            for (t, g) in self.theta.iter_mut().zip(grad) {
                *t = *t + mu * g;
            }
        }
    }

    /// One 2S-OP-GI iteration over the window: a gradient step on θ with
    /// exact line search, then the order search. Returns what it did.
    ///
    /// # Errors
    /// [`Error::NotEnoughData`] while the window holds fewer than
    /// `M − 1 + MIN_ROWS` samples, [`Error::NotExcited`] for a constant
    /// current, [`Error::Diverged`] if a non-finite value appeared (the
    /// previous estimate is kept), settings errors. On error θ and α are
    /// unchanged.
    pub fn iterate(
        &mut self,
        s: &BatterySettings<T>,
        win: &impl Window<T>,
    ) -> Result<Iteration<T>, Error> {
        self.iterate_with(s, win, ThetaStage::Gradient)
    }

    /// One iteration with θ projected out: θ by exact least squares at the
    /// current order (instead of 2S-OP-GI's one gradient step), then the
    /// same order stage. The cost is that of the same regression, so its
    /// minimum is the paper's estimate's limit; it gets there in far fewer
    /// iterations, the gradient step being steepest descent on a badly
    /// conditioned θ (`identify battery` starts its refinement from it).
    /// When the rows leave θ undetermined (a singular normal matrix) the
    /// iteration takes the gradient step instead.
    ///
    /// # Errors
    /// As [`Self::iterate`].
    pub fn iterate_projected(
        &mut self,
        s: &BatterySettings<T>,
        win: &impl Window<T>,
    ) -> Result<Iteration<T>, Error> {
        self.iterate_with(s, win, ThetaStage::LeastSquares)
    }

    fn iterate_with(
        &mut self,
        s: &BatterySettings<T>,
        win: &impl Window<T>,
        stage: ThetaStage,
    ) -> Result<Iteration<T>, Error> {
        s.check::<MEM>()?;
        self.load(s, win)?;
        let rows = self.rows();
        if current_std(&self.i[rows.clone()]) <= s.min_current_std {
            return Err(Error::NotExcited);
        }
        let theta0 = self.theta;
        let alpha0 = self.w.alpha();

        // Stage 1: θ.
        let vref = self.vref.unwrap_or(T::zero());
        let (k, dk) = Self::unit_history(&self.w);
        let fit = match stage {
            ThetaStage::LeastSquares => self.project(&self.di, &self.hv, k),
            ThetaStage::Gradient => None,
        };
        match &fit {
            Some(p) => self.theta = p.theta,
            None => self.gradient_step(k, vref),
        }
        let mut cost = self.residual(k);

        // Stage 2: the order.
        let order_step = if !s.estimate_order {
            OrderStep::Fixed
        } else if let Some(fit) = fit {
            let (step, c) = self.projected_order(s, vref, dk, &fit)?;
            if matches!(step, OrderStep::Accepted { .. }) {
                self.stamp = Some((win.version(), win.len(), self.w.alpha()));
            }
            cost = c;
            step
        } else {
            let (dd, dr) = self.order_gradient(vref, dk);
            // The cost's rounding error, below which no trial is run
            // (`order_search`).
            let noise = T::epsilon() * cost * T::lit(rows.len() as f64).sqrt();
            let stamp = (win.version(), win.len());
            order_search(s, alpha0, dd, dr, noise, |trial, halvings| {
                // The full step is usually accepted: its trial computes
                // the regressors there at once. A halved step's trial
                // computes only the residual, and the regressors on
                // acceptance.
                let c = if halvings == 0 {
                    self.trial_cost_with_regressors(trial)?.0
                } else {
                    self.trial_cost(trial)?
                };
                if !(c.is_finite() && c < cost) {
                    return Ok(false);
                }
                if halvings == 0 {
                    self.accept_trial_regressors(trial)?;
                } else {
                    self.w.set_order(trial)?;
                    self.regressors();
                }
                self.stamp = Some((stamp.0, stamp.1, trial));
                cost = c;
                Ok(true)
            })?
        };
        self.order_moves = if matches!(order_step, OrderStep::Accepted { .. }) {
            self.order_moves.saturating_add(1)
        } else {
            0
        };

        if !(cost.is_finite() && self.theta.iter().all(|x| x.is_finite())) {
            self.theta = theta0;
            self.w.set_order(alpha0)?;
            self.stamp = None;
            self.order_moves = 0;
            return Err(Error::Diverged);
        }
        self.k += 1;
        let mut dtheta = [T::zero(); 4];
        for (d, (a, b)) in dtheta.iter_mut().zip(self.theta.iter().zip(&theta0)) {
            *d = *a - *b;
        }
        let change = norm(&dtheta) / norm(&theta0).max(T::min_positive_value())
            + (self.w.alpha() - alpha0).abs();
        Ok(Iteration {
            k: self.k,
            alpha: self.w.alpha(),
            cost,
            change,
            converged: change <= s.epsilon,
            order_step,
            rows: rows.len(),
        })
    }
}

/// How an iteration moves θ before its order stage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ThetaStage {
    /// 2S-OP-GI's gradient step with exact line search.
    Gradient,
    /// Exact least squares at the current order (variable projection).
    LeastSquares,
}

mod blank;
mod projected;
mod rows;
#[cfg(test)]
mod tests;
mod trial;
