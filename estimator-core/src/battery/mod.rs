//! The fractional-order battery model of §6.2 (after Tian et al.).
//!
//! ```text
//! U_t(l) = U_oc + R_i·I(l) + a·asinh(I(l)/i₀) + U_p(l),
//! τ·Δ^α U_p(l) + U_p(l) = R_ct·I(l),   τ = R_ct·Q
//! ```
//!
//! `U_t` is the terminal voltage (V), `I` the current (A, **positive when
//! charging**), `R_i` the ohmic resistance (Ω), and the constant-phase branch
//! `R_ct ∥ CPE(Q, α)` carries the polarization voltage `U_p`. With a real
//! sample period `h` (s) the time constant `τ` is in `s^α` and `Q` in
//! `F·s^(α−1)`.
//!
//! The term `a·asinh(I/i₀)` is the Butler–Volmer charge-transfer
//! overpotential (symmetric transfer, `a = 2RT/F` over the number of
//! electrons in the ideal case, `i₀` the exchange current): a static
//! nonlinearity of the current in front of the linear dynamics, the block
//! structure the paper identifies, applied to the cell. The paper's model
//! is its special case `a = 0` ([`CellModel::Linear`]); every simulation
//! and estimator here runs both through one code path. For `|I| ≪ i₀` the
//! term is the resistance `a/i₀`; only a current beyond `i₀` tells `a` and
//! `i₀` apart from `R_i` ([`CellModel`]).
//!
//! * [`simulate`] — the model driven by a current record (the host-sim
//!   presets and the tests use it; a BMS uses it for prediction).
//! * [`regression`] — the paper's method: the linear regression of §6.2 with
//!   the order, identified by 2S-OP-GI ([`regression::PaperRegressionGi`]),
//!   and the algebra from its θ back to `(R_i, R_ct, Q, U_oc)`.
//! * [`output_error`] — ours: a Levenberg–Marquardt output-error refinement
//!   that fits the simulated voltage to the measured one
//!   ([`output_error::OutputErrorRefinement`]).
//! * [`map`] — parameter maps: the cell per SOC level and temperature, and
//!   the cell between levels ([`map::ParameterMap::cell_at`]).
//! * [`ocv`] — the OCV curve `OCV(SOC)` (a piecewise-linear table), coulomb
//!   counting, and the overpotential `U_t − OCV(SOC)` the estimators fit
//!   when the curve is known (`U_oc` becomes a small offset `ΔU`).
//! * [`profile`] — test current profiles (pulse, HPPC, drive) and an OCV
//!   curve.
//! * [`power`] — the state of power: a pulse predicted from the present
//!   state, the largest currents within the voltage limits.
//! * [`soc`] — the SOC observer: the count corrected at rest by the OCV
//!   curve, with the current bias and the capacity as states.
//! * [`online`] — the sliding-window cell estimator a BMS runs per cell:
//!   sample validation, spike and NaN rejection, the "not excited" hold,
//!   either method ([`online::CellEstimator`]).
//! * [`pack`] — every series cell of a pack: the shared current history and
//!   working area, per-cell state, the update schedule and the health flag
//!   ([`pack::PackEstimator`]; a `CellEstimator` is its one-cell case).
//! * `tracker` (private) — one cell's tracker, the part both build on:
//!   settings, per-cell state, the shared working area, the sample guard,
//!   the iterations and the plausibility check. Its items are public as
//!   [`online`]'s. Imports run one way: `online` → `pack` → `tracker`, never
//!   back.

pub mod branch;
pub mod map;
pub mod ocv;
pub mod online;
pub mod output_error;
pub mod pack;
pub mod power;
pub mod profile;
pub mod regression;
pub mod simulate;
pub mod snapshot;
pub mod soc;
mod tracker;

use crate::real::Real;

/// The physical parameters of one cell.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CellParameters<T> {
    /// Ohmic resistance `R_i` (Ω).
    pub r_i: T,
    /// Charge-transfer resistance `R_ct` (Ω).
    pub r_ct: T,
    /// Constant-phase-element coefficient `Q` (`F·s^(α−1)`).
    pub q: T,
    /// Fractional order α of the constant-phase element.
    pub alpha: T,
    /// Open-circuit voltage `U_oc` (V).
    pub u_oc: T,
    /// Butler–Volmer coefficient `a` (V) of the charge-transfer
    /// overpotential `a·asinh(I/i₀)`; 0 in the linear model.
    pub bv_a: T,
    /// Butler–Volmer exchange current `i₀` (A), positive (without effect
    /// while `bv_a` is 0).
    pub bv_i0: T,
}

impl<T: Real> CellParameters<T> {
    /// Every parameter 0: the placeholder of a blank estimator built at
    /// compile time, never an estimate (not physical).
    pub(crate) const ZERO: Self = Self {
        r_i: T::ZERO,
        r_ct: T::ZERO,
        q: T::ZERO,
        alpha: T::ZERO,
        u_oc: T::ZERO,
        bv_a: T::ZERO,
        bv_i0: T::ZERO,
    };

    /// The paper's example cell (§6.2): `R_i = 1 mΩ`, `R_ct = 2 mΩ`,
    /// `Q = 320`, `α = 0.7`, `U_oc = 4 V`.
    pub fn paper() -> Self {
        Self {
            r_i: T::lit(0.001),
            r_ct: T::lit(0.002),
            q: T::lit(320.0),
            alpha: T::lit(0.7),
            u_oc: T::lit(4.0),
            bv_a: T::zero(),
            bv_i0: T::one(),
        }
    }

    /// An 18650-like cell: `R_i = 20 mΩ`, `R_ct = 15 mΩ`, `α = 0.75`,
    /// `τ = 8 s^α` (so `Q = τ/R_ct ≈ 533`), `U_oc = 3.7 V`.
    pub fn cell_18650() -> Self {
        Self {
            r_i: T::lit(0.020),
            r_ct: T::lit(0.015),
            q: T::lit(8.0 / 0.015),
            alpha: T::lit(0.75),
            u_oc: T::lit(3.7),
            bv_a: T::zero(),
            bv_i0: T::one(),
        }
    }

    /// `τ = R_ct·Q` (`s^α`).
    pub fn tau(&self) -> T {
        self.r_ct * self.q
    }

    /// The Butler–Volmer overpotential `a·asinh(I/i₀)` (V) at `current`
    /// (A); exactly 0 in the linear model (`bv_a = 0`), without an `asinh`.
    #[inline]
    pub fn kinetic_voltage(&self, current: T) -> T {
        if self.bv_a == T::zero() {
            T::zero()
        } else {
            self.bv_a * (current / self.bv_i0).arsinh()
        }
    }

    /// The part of the terminal voltage that follows the current at once:
    /// `R_i·I + a·asinh(I/i₀)` (V).
    #[inline]
    pub fn static_voltage(&self, current: T) -> T {
        self.r_i * current + self.kinetic_voltage(current)
    }

    /// True when the Butler–Volmer term is present (`bv_a > 0`).
    pub fn is_butler_volmer(&self) -> bool {
        self.bv_a > T::zero()
    }

    /// The Butler–Volmer start from a linear cell: half of `R_i` becomes
    /// the kinetic term with exchange current `i0`, `a = i₀·R_i/2`, so the
    /// two models agree for currents well below `i0` (the start the
    /// nonlinear fit takes from the linear fit). A cell that already has
    /// the term is returned unchanged.
    pub fn with_butler_volmer(&self, i0: T) -> Self {
        if self.is_butler_volmer() {
            return *self;
        }
        let half = self.r_i / T::lit(2.0);
        Self {
            r_i: half,
            bv_a: i0 * half,
            bv_i0: i0,
            ..*self
        }
    }

    /// The same cell with the Butler–Volmer term removed (`bv_a = 0`) and
    /// its small-current resistance `a/i₀` added to `R_i`.
    pub fn linearized(&self) -> Self {
        if !self.is_butler_volmer() {
            return *self;
        }
        Self {
            r_i: self.r_i + self.bv_a / self.bv_i0,
            bv_a: T::zero(),
            ..*self
        }
    }

    /// True when every value is finite, the resistances and `Q` are
    /// positive and α lies in `(0, 2)`: a model that can be simulated.
    pub fn is_physical(&self) -> bool {
        let pos = |x: T| x.is_finite() && x > T::zero();
        pos(self.r_i)
            && pos(self.r_ct)
            && pos(self.q)
            && self.alpha.is_finite()
            && self.alpha > T::zero()
            && self.alpha < T::lit(2.0)
            && self.u_oc.is_finite()
            && self.bv_a.is_finite()
            && self.bv_a >= T::zero()
            && pos(self.bv_i0)
    }

    /// The paper's error measure of Table 7,
    /// `δ = ‖[R̂_i, R̂_ct, Q̂, Û_oc] − [R_i, R_ct, Q, U_oc]‖ / ‖[R_i, R_ct, Q, U_oc]‖`.
    pub fn delta(&self, truth: &Self) -> T {
        let e = [
            self.r_i - truth.r_i,
            self.r_ct - truth.r_ct,
            self.q - truth.q,
            self.u_oc - truth.u_oc,
        ];
        let t = [truth.r_i, truth.r_ct, truth.q, truth.u_oc];
        crate::real::norm(&e) / crate::real::norm(&t)
    }

    /// Converts to another scalar type (e.g. the host's `f64` estimate into
    /// the firmware's `f32`).
    pub fn cast<U: Real>(&self) -> CellParameters<U> {
        CellParameters {
            r_i: U::lit(self.r_i.to_f64()),
            r_ct: U::lit(self.r_ct.to_f64()),
            q: U::lit(self.q.to_f64()),
            alpha: U::lit(self.alpha.to_f64()),
            u_oc: U::lit(self.u_oc.to_f64()),
            bv_a: U::lit(self.bv_a.to_f64()),
            bv_i0: U::lit(self.bv_i0.to_f64()),
        }
    }
}

/// Settings shared by the battery estimators (kept apart from their state,
/// so one value drives the estimators of every cell of a pack).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BatterySettings<T> {
    /// Sample period h (s).
    pub h: T,
    /// Memory length M of the fractional differences (`1 ≤ M ≤ MEM`).
    pub memory: usize,
    /// The order is kept inside `[alpha_min, alpha_max] ⊂ (0, 2)`.
    pub alpha_min: T,
    /// Upper bound of α.
    pub alpha_max: T,
    /// Stopping tolerance: converged when the relative parameter change of
    /// an iteration is at most ε.
    pub epsilon: T,
    /// Stopping tolerance on the cost: the output-error refinement's next
    /// step is negligible (a minimum, `negligible_step`) when the decrease
    /// it predicts is below `cost_tolerance` times the cost (scipy's
    /// `ftol`). 0 (the default): below what the cost resolves in `T`.
    pub cost_tolerance: T,
    /// Near a minimum (an accepted output-error step that lowered the cost
    /// by less than 10⁻³ of it), the cost
    /// along the step is modelled by the parabola through the estimate's
    /// cost, its slope there and the step's cost; when that parabola's
    /// minimum lies short of the step (below
    /// [`output_error::LINE_SEARCH_BELOW`] of it: a Gauss–Newton step that
    /// overshoots, as on a measured record whose residuals are large and
    /// correlated), the shorter step is simulated too and kept when it is
    /// lower. One more simulation on such steps, where the damped search
    /// alone zig-zags across the valley (the Panasonic HPPC test's
    /// overpotential: 13 iterations where it took 18). `false` (the
    /// default): the full step, as the MCU runs.
    pub line_search: bool,
    /// Largest number of halvings of the paper method's order step.
    pub max_halvings: u8,
    /// Trust radius of the paper method's order step.
    pub max_order_step: T,
    /// Estimate α (true) or keep it fixed (false).
    pub estimate_order: bool,
    /// How the output-error model starts inside the window.
    pub start: Start,
    /// Let the output-error model's open-circuit voltage follow the charge
    /// through the window with a fitted slope `dU_oc/dq` (for a sliding
    /// window over a cell whose state of charge moves).
    pub ocv_slope: bool,
    /// A window whose current has a standard deviation below this (A) is
    /// "not excited": the estimate is held.
    pub min_current_std: T,
    /// A prior on the cell's parameters for the output-error refinement
    /// (`None`: the window's data alone).
    pub prior: Option<Prior<T>>,
    /// Which cell model the output-error refinement fits.
    pub model: CellModel,
    /// The output-error refinement adds the Grünwald–Letnikov taps beyond
    /// the memory ([`crate::tail`]: the lags ≥ `M` inside the window and
    /// the past before it, from the window's [`crate::tail::PastModes`]),
    /// which removes the short-memory bias on data with a longer memory.
    /// For the linear model with `memory ≥ 64` and orders up to 1; ignored
    /// otherwise.
    pub tail: bool,
}

/// The cell model the output-error refinement fits.
///
/// One code path: the linear model is the Butler–Volmer model with its
/// kinetic parameters not fitted (held at the start's values, `a = 0` for a
/// linear start).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CellModel {
    /// The paper's model: `U_t = U_oc + R_i·I + U_p`.
    Linear,
    /// With the Butler–Volmer overpotential: `U_t = U_oc + R_i·I +
    /// a·asinh(I/i₀) + U_p`, `a` and `i₀` fitted (in logarithms). A linear
    /// start is first given the term ([`CellParameters::with_butler_volmer`],
    /// `i₀` the RMS current of the fitted window).
    ButlerVolmer,
}

impl CellModel {
    /// `"linear"` or `"butler-volmer"` (the host's `--model` values and
    /// JSON `model`).
    pub fn as_str(&self) -> &'static str {
        match self {
            CellModel::Linear => "linear",
            CellModel::ButlerVolmer => "butler-volmer",
        }
    }
}

/// A Gaussian prior on the cell's parameters (maximum a posteriori over a
/// window): what the BMS knows before the window, e.g. the whole-record fit
/// of a characterization test or the datasheet.
///
/// The refinement then minimizes
/// `½Σ r² + ½·σ_v²·Σ_k ((x_k − c_k)/σ_k)²` over
/// `x = [ln R_i, ln R_ct, ln Q, α]` (and, fitting the Butler–Volmer model
/// with a centre that has the term, `ln a` and `ln i₀` with the spread of
/// the logarithms): the window's data where they carry
/// information, the prior where they do not (a window far shorter than the
/// cell's slowest relaxation cannot tell a long constant-phase tail from a
/// drift, and without a prior its fit wanders there).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Prior<T> {
    /// The prior's centre (its `u_oc` is not used).
    pub center: CellParameters<T>,
    /// Standard deviation of `ln R_i`, `ln R_ct` and `ln Q` (`ln 2`: a
    /// factor 2 at one sigma).
    pub log_sigma: T,
    /// Standard deviation of α.
    pub alpha_sigma: T,
    /// The residual level σ_v (V) at which the window's data are weighed
    /// against the prior. Not the measurement noise: a real cell's model
    /// error is correlated over the whole window, which is then worth far
    /// fewer independent samples than it holds, and σ_v says how many
    /// (`σ_v²/σ_noise²` samples count as one).
    pub noise_v: T,
}

impl<T: Real> Prior<T> {
    /// A prior at `center`, a factor 2 on the resistances and `Q` and 0.1
    /// on α at one sigma, the data weighed at σ_v = 0.1 V: on the PyBaMM
    /// DFN records (docs/real-cells.md) the value that keeps every
    /// published `R_ct` of a 256-sample window within a factor 2 of the
    /// whole-record fit with a prior from another record of the same cell
    /// (50 mV does not).
    pub fn new(center: CellParameters<T>) -> Self {
        Self {
            center,
            log_sigma: T::lit(core::f64::consts::LN_2),
            alpha_sigma: T::lit(0.1),
            noise_v: T::lit(0.1),
        }
    }

    /// True when every value is finite and positive where it must be.
    pub fn is_valid(&self) -> bool {
        let c = &self.center;
        let pos = |x: T| x.is_finite() && x > T::zero();
        pos(c.r_i)
            && pos(c.r_ct)
            && pos(c.q)
            && c.alpha.is_finite()
            && c.bv_a.is_finite()
            && c.bv_a >= T::zero()
            && pos(c.bv_i0)
            && pos(self.log_sigma)
            && pos(self.alpha_sigma)
            && pos(self.noise_v)
    }

    /// Weights `σ_v²/σ_k²` and centres of the prior's coordinates
    /// `[ln R_i, ln R_ct, ln Q, α, ln a, ln i₀]` (the last two are
    /// meaningless for a centre without the Butler–Volmer term).
    pub(crate) fn terms(&self) -> ([T; 6], [T; 6]) {
        let wl = (self.noise_v / self.log_sigma).powi(2);
        let wa = (self.noise_v / self.alpha_sigma).powi(2);
        let c = &self.center;
        (
            [wl, wl, wl, wa, wl, wl],
            [
                c.r_i.ln(),
                c.r_ct.ln(),
                c.q.ln(),
                c.alpha,
                c.bv_a.ln(),
                c.bv_i0.ln(),
            ],
        )
    }

    /// Which of the prior's coordinates act under settings `s`: α when the
    /// order is estimated, `ln a` and `ln i₀` when the Butler–Volmer model
    /// is fitted and the centre has the term.
    pub(crate) fn active(&self, s: &BatterySettings<T>) -> [bool; 6] {
        let kinetic = s.model == CellModel::ButlerVolmer && self.center.is_butler_volmer();
        [true, true, true, s.estimate_order, kinetic, kinetic]
    }

    /// The prior's coordinates at `p`.
    pub(crate) fn coordinates(p: &CellParameters<T>) -> [T; 6] {
        [
            p.r_i.ln(),
            p.r_ct.ln(),
            p.q.ln(),
            p.alpha,
            p.bv_a.ln(),
            p.bv_i0.ln(),
        ]
    }

    /// `½·Σ w_k (x_k − c_k)²` at `p` (over the coordinates active under
    /// `s`).
    pub(crate) fn cost(&self, p: &CellParameters<T>, s: &BatterySettings<T>) -> T {
        let (w, c) = self.terms();
        let x = Self::coordinates(p);
        let mut sum = T::zero();
        for (k, on) in self.active(s).into_iter().enumerate() {
            if on {
                sum = sum + w[k] * (x[k] - c[k]) * (x[k] - c[k]);
            }
        }
        sum / T::lit(2.0)
    }
}

/// Where the output-error simulation of a window starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Start {
    /// The data start from rest (`U_p = 0` before the first sample): every
    /// sample is fitted. Right for a whole recording that begins after a
    /// rest; once a window slides it behaves like `FromData`.
    AtRest,
    /// The polarization of the first `M − 1` samples of the window is taken
    /// from the data (`U_p = U_t − U_oc − R_i·I`), the model runs freely
    /// from there on and only those later samples are fitted. Right for a
    /// sliding window over a cell that is never at rest.
    FromData,
}

impl<T: Real> BatterySettings<T> {
    /// Defaults for sample period `h` and memory `memory`: α in
    /// `[0.05, 1.0]` (a constant-phase element), ε = 1e−7, 12 halvings, order
    /// steps of at most 0.05, order estimated, start from rest, constant OCV, excitation
    /// threshold 1 mA.
    pub fn new(h: T, memory: usize) -> Self {
        Self {
            h,
            memory,
            alpha_min: T::lit(0.05),
            alpha_max: T::lit(1.0),
            epsilon: T::lit(1e-7),
            cost_tolerance: T::zero(),
            line_search: false,
            max_halvings: 12,
            max_order_step: T::lit(0.05),
            estimate_order: true,
            start: Start::AtRest,
            ocv_slope: false,
            min_current_std: T::lit(1e-3),
            prior: None,
            model: CellModel::Linear,
            tail: false,
        }
    }

    /// Validates the settings against a memory capacity `MEM`.
    ///
    /// # Errors
    /// [`crate::Error::Frac`] for a bad period or memory,
    /// [`crate::Error::BadSetting`] for order bounds outside `(0, 2)`, a
    /// negative or non-finite ε, cost tolerance, trust radius or excitation
    /// threshold.
    pub fn check<const MEM: usize>(&self) -> Result<(), crate::Error> {
        crate::gi::check_search::<T, MEM>(
            self.h,
            self.memory,
            [self.alpha_min, self.alpha_max],
            self.epsilon,
            self.max_order_step,
        )?;
        if self.prior.is_some_and(|p| !p.is_valid()) {
            return Err(crate::Error::BadSetting);
        }
        if !(self.cost_tolerance.is_finite() && self.cost_tolerance >= T::zero()) {
            return Err(crate::Error::BadSetting);
        }
        if self.min_current_std.is_finite() && self.min_current_std >= T::zero() {
            Ok(())
        } else {
            Err(crate::Error::BadSetting)
        }
    }

    /// True when the output-error refinement adds the tail beyond the
    /// memory ([`Self::tail`], the linear model, `memory ≥ 64`).
    pub fn uses_tail(&self) -> bool {
        self.tail
            && self.model == CellModel::Linear
            && self.memory >= crate::tail::MIN_MEMORY
            && self.alpha_max <= T::one()
    }

    /// A 64-bit FNV-1a hash of every setting (bit patterns of the reals):
    /// the key under which the refinement remembers that a window is
    /// searched out, in 8 bytes instead of a copy of the settings.
    pub fn fingerprint(&self) -> u64 {
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        let mut eat = |x: u64| {
            for byte in x.to_le_bytes() {
                h = (h ^ u64::from(byte)).wrapping_mul(0x0100_0000_01b3);
            }
        };
        for x in [
            self.h,
            self.alpha_min,
            self.alpha_max,
            self.epsilon,
            self.cost_tolerance,
            self.max_order_step,
            self.min_current_std,
        ] {
            eat(x.to_f64().to_bits());
        }
        eat(self.memory as u64);
        eat(u64::from(self.max_halvings));
        eat(u64::from(self.estimate_order)
            | u64::from(self.ocv_slope) << 1
            | u64::from(self.tail) << 2
            | u64::from(self.line_search) << 3);
        eat(match self.start {
            Start::AtRest => 0,
            Start::FromData => 1,
        });
        eat(match self.model {
            CellModel::Linear => 0,
            CellModel::ButlerVolmer => 1,
        });
        match &self.prior {
            None => eat(0),
            Some(p) => {
                let c = &p.center;
                for x in [
                    c.r_i,
                    c.r_ct,
                    c.q,
                    c.alpha,
                    c.u_oc,
                    c.bv_a,
                    c.bv_i0,
                    p.log_sigma,
                    p.alpha_sigma,
                    p.noise_v,
                ] {
                    eat(x.to_f64().to_bits());
                }
            }
        }
        h
    }

    pub(crate) fn clamp_alpha(&self, a: T) -> T {
        a.max(self.alpha_min).min(self.alpha_max)
    }
}

/// Standard deviation of the current over a slice (population form).
pub(crate) fn current_std<T: Real>(i: &[T]) -> T {
    if i.is_empty() {
        return T::zero();
    }
    let n = T::lit(i.len() as f64);
    let mean = i.iter().fold(T::zero(), |s, &x| s + x) / n;
    (i.iter()
        .fold(T::zero(), |s, &x| s + (x - mean) * (x - mean))
        / n)
        .sqrt()
}
