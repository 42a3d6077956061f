//! The state-of-charge observer: coulomb counting corrected at rest by the
//! OCV curve, with the current sensor's bias and the cell's capacity as
//! states of their own ([`SocObserver`]).
//!
//! ```text
//! state      x = (SOC, b, g)     b: current-sensor bias (A), g = C_nominal / C
//! per sample SOC ← SOC + g·(I_measured − b)·h / (3600·C_nominal)
//! at rest    z = OCV⁻¹(U_rested),  σ_z² = (σ_U / |OCV'(SOC)|)² + σ_table²
//!            z_b = Ī_rested,       σ_b = rest_load_sigma_a
//! ```
//!
//! A three-state extended Kalman filter. The count moves the SOC and the
//! covariance between it, the bias and the capacity; an observation comes
//! only from a rested voltage: once per rest, when a rest of at least
//! [`SocSettings::rest_s`] ends (or reaches [`SocSettings::rest_max_s`]),
//! from the mean of its last voltages. Its weight falls where the curve is
//! flat (the observation's spread is the voltage's over the curve's slope),
//! and [`SocEstimate::ocv_weight`] says how much the last one moved the
//! SOC. The same rest reads the bias: a rested cell carries no current,
//! so the mean current the sensor reads over the rest's last half minute
//! observes the bias, give or take a quiescent load
//! ([`SocSettings::rest_load_sigma_a`]). The charge counted between two
//! observations, against the SOC they differ by, then tells the capacity;
//! both start at their priors (zero and the nominal capacity).
//!
//! **The capacity from rests far apart.** The capacity is identified
//! (published as the data's, [`SocEstimate::capacity_identified`]) once its
//! standard deviation is within [`SocSettings::capacity_identify`] of it
//! *and* two rests linked by the count (no gap of unknown charge or SOC
//! set between them) read SOCs at least [`SocSettings::capacity_min_span`]
//! apart through the curve. The filter weighs each rest's reading as
//! independent, though rests near one another read the same stretch of the
//! curve and share its error: many rests within a narrow band would
//! otherwise shrink the capacity's spread below what the curve allows.
//!
//! **Why at rest only.** Under load the terminal voltage is the OCV plus
//! the polarization, and the window's model carries an OCV offset `ΔU`
//! that absorbs any SOC error ([`super::ocv`]): the model cannot tell an
//! SOC error from its own offset. A rested voltage needs no model. The
//! fractional branch relaxes as a power law, so a rest of ten minutes
//! still holds a few millivolts of it; [`SocSettings::voltage_sigma_v`]
//! stands for that.
//!
//! **When the SOC is unknown** (a start given loosely, a gap of unknown
//! charge, [`SocObserver::resume_after_gap`]), its spread is wide, and a
//! rest is read early, after half of [`SocSettings::rest_s`], with the
//! spread of an unrelaxed voltage ([`SocSettings::unrelaxed_sigma_v`]).
//! Without a start SOC the first finite voltage is read as the OCV.
//!
//! **Settings and spreads.** [`SocSettings::check`] refuses a setting that
//! is not finite or out of range (the estimators call it). Each variance
//! stops at what knowing nothing means (the SOC within `±1`, the bias
//! within 1C, the capacity within a factor 5): a wider spread says no
//! more, and in `f32` the count's products of it overflowed. The bias
//! itself stays within 1C, and a count that would leave the finite numbers
//! stops where it is (docs/fuzzing.md).
//!
//! Sign convention: current positive when charging (as [`super::ocv`]).
//! This module owns the published SOC, the bias and the capacity; it must
//! not touch the estimators' window, whose coordinates follow their own
//! count ([`super::ocv::OcvModel::soc_after`]).
//!
//! ```
//! use estimator_core::battery::ocv::OcvTable;
//! use estimator_core::battery::soc::{SocObserver, SocSettings};
//!
//! let table = OcvTable::<f64, 3>::new(&[0.0, 0.5, 1.0], &[3.0, 3.6, 4.2]).unwrap();
//! // A start given loosely (give or take 0.3).
//! let s = SocSettings { soc0_sigma: 0.3, ..SocSettings::new(5.0, 1.0) };
//! // Told 0.5, the cell really at 0.6 and at rest: five minutes of rest
//! // are read early and correct most of the start.
//! let mut soc = SocObserver::new(&s, Some(0.5));
//! let mut e = None;
//! for _ in 0..300 {
//!     e = soc.push(&s, &table, 0.0, table.ocv(0.6));
//! }
//! let e = e.unwrap();
//! assert!((e.soc - 0.6).abs() < 0.01, "{e:?}");
//! assert_eq!(e.observations, 1);
//! ```

use super::ocv::OcvTable;
use crate::real::Real;

mod settings;
pub use settings::SocSettings;

/// What the observer publishes after a sample.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SocEstimate<T> {
    /// The state of charge (0..1, not clamped: a value outside says the
    /// count or the curve is wrong).
    pub soc: T,
    /// Its standard deviation.
    pub sigma: T,
    /// The current sensor's estimated bias (A): measured − true.
    pub current_bias_a: T,
    /// The published capacity (A·h): the filter's when the data identify
    /// it (`capacity_identified`), else the last value they identified, or
    /// the nominal one before any.
    pub capacity_ah: T,
    /// The filter's standard deviation of the capacity now (A·h).
    pub capacity_sigma_ah: T,
    /// Whether the data identify the capacity now: its standard deviation
    /// is within [`SocSettings::capacity_identify`] of it and relaxed rests
    /// linked by the count have spanned [`SocSettings::capacity_min_span`]
    /// of SOC. A test that
    /// only discharges at an even pace does not tell it from the bias.
    pub capacity_identified: bool,
    /// The gain of the last OCV observation on the SOC, 0..1: near 1 where
    /// the curve is steep and the count uncertain, near 0 on a flat part
    /// of the curve (0 before the first).
    pub ocv_weight: T,
    /// OCV observations so far.
    pub observations: u32,
}

impl<T: Real> SocEstimate<T> {
    /// The estimate in another precision.
    pub fn cast<U: Real>(&self) -> SocEstimate<U> {
        let f = |x: T| U::lit(x.to_f64());
        SocEstimate {
            soc: f(self.soc),
            sigma: f(self.sigma),
            current_bias_a: f(self.current_bias_a),
            capacity_ah: f(self.capacity_ah),
            capacity_sigma_ah: f(self.capacity_sigma_ah),
            capacity_identified: self.capacity_identified,
            ocv_weight: f(self.ocv_weight),
            observations: self.observations,
        }
    }
}

/// What a snapshot keeps of a [`SocObserver`] (its `parts`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ObserverParts<T> {
    pub x: Option<[T; 3]>,
    pub p: [T; 6],
    pub observations: u32,
    pub capacity_held: Option<T>,
    pub ocv_weight: T,
    /// A rest in progress.
    pub rest: Option<RestParts<T>>,
}

/// What a snapshot keeps of a rest in progress: all of it, so that a
/// record resumed in the middle of a rest observes what the whole run does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RestParts<T> {
    /// Length (s).
    pub len: T,
    /// The voltage mean.
    pub mean: T,
    /// The current mean (A; NaN: no sample read one, or a snapshot of
    /// layout version 1, which did not keep it).
    pub current: T,
    /// Whether it has given its early observation, its observation and
    /// its reading of the bias.
    pub early: bool,
    pub done: bool,
    pub bias_read: bool,
}

/// The SOC observer of one cell (module docs). State only: the settings
/// and the curve are given with every sample. 92 B in f32.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SocObserver<T> {
    /// `(SOC, b, g)`; `None` until the start SOC is known.
    x: Option<[T; 3]>,
    /// The covariance's upper triangle: `P00 P01 P02 P11 P12 P22`.
    p: [T; 6],
    /// The rest so far.
    rest: Option<Rest<T>>,
    ocv_weight: T,
    observations: u32,
    /// The last capacity the data identified (A·h).
    capacity_held: Option<T>,
    /// The lowest and highest SOC a relaxed rest read since the last gap
    /// of unknown charge or SOC set (`[∞, −∞]` before the first).
    rest_span: [T; 2],
    /// Two rests linked by the count have read SOCs
    /// [`SocSettings::capacity_min_span`] apart.
    span_reached: bool,
    /// A state of charge set, and a gap, to be taken at the next sample
    /// (with the settings it brings).
    set: Option<T>,
    gap: bool,
}

impl<T: Real> SocObserver<T> {
    /// No rest read yet: the empty range.
    const NO_SPAN: [T; 2] = [T::INFINITY, T::NEG_INFINITY];
    /// An observer not started (`new(s, None)`, whatever `s`).
    pub(crate) const BLANK: Self = Self {
        x: None,
        p: [T::ZERO; 6],
        rest: None,
        ocv_weight: T::ZERO,
        observations: 0,
        capacity_held: None,
        rest_span: Self::NO_SPAN,
        span_reached: false,
        set: None,
        gap: false,
    };

    /// An observer started at `soc0` with spread
    /// [`SocSettings::soc0_sigma`]; with `None`, at the first finite
    /// voltage read through the curve, with the same spread.
    pub fn new(s: &SocSettings<T>, soc0: Option<T>) -> Self {
        let mut o = Self::BLANK;
        if let Some(z) = soc0.filter(|z| z.is_finite()) {
            o.start(s, z);
        }
        o
    }

    fn start(&mut self, s: &SocSettings<T>, soc: T) {
        self.x = Some([soc, T::ZERO, T::ONE]);
        let c = s.capacity_sigma;
        self.p = [
            s.soc0_sigma * s.soc0_sigma,
            T::ZERO,
            T::ZERO,
            s.bias_sigma_a * s.bias_sigma_a,
            T::ZERO,
            c * c,
        ];
        self.condition(s);
    }

    /// Keeps the covariance a covariance whatever the settings and the
    /// data did to it: each variance within [`SocSettings::variance_caps`]
    /// (a non-finite one is taken as knowing nothing), never negative, and
    /// each covariance within `√(Pᵢᵢ·Pⱼⱼ)` (0 when not finite). Without it
    /// an overflow in `f32` made `P₀₀` NaN, and the SOC was published with
    /// a spread of 0 while no rest was observed again.
    fn condition(&mut self, s: &SocSettings<T>) {
        let caps = s.variance_caps();
        let [p00, p01, p02, p11, p12, p22] = self.p;
        let var = |v: T, cap: T| {
            if v.is_nan() {
                cap
            } else {
                v.max(T::ZERO).min(cap)
            }
        };
        let d = [var(p00, caps[0]), var(p11, caps[1]), var(p22, caps[2])];
        let cov = |c: T, a: T, b: T| {
            let m = (a * b).sqrt();
            if c.is_finite() {
                c.max(-m).min(m)
            } else {
                T::ZERO
            }
        };
        self.p = [
            d[0],
            cov(p01, d[0], d[1]),
            cov(p02, d[0], d[2]),
            d[1],
            cov(p12, d[1], d[2]),
            d[2],
        ];
    }

    /// What a snapshot keeps of the observer ([`crate::battery::snapshot`]):
    /// the state `(SOC, b, g)` (`None` before the start), its covariance,
    /// the observations so far, the last identified capacity, the last
    /// observation's weight and a rest in progress. A pending set is not
    /// kept, nor is the span of the rests read
    /// ([`SocSettings::capacity_min_span`]): restored, the span counts as
    /// reached when a capacity had been identified.
    pub(crate) fn parts(&self) -> ObserverParts<T> {
        ObserverParts {
            x: self.x,
            p: self.p,
            observations: self.observations,
            capacity_held: self.capacity_held,
            ocv_weight: self.ocv_weight,
            rest: self.rest.map(|r| RestParts {
                len: r.len,
                mean: r.mean,
                current: r.current,
                early: r.early,
                done: r.done,
                bias_read: r.bias_read,
            }),
        }
    }

    /// An observer from a snapshot's [`parts`](Self::parts); with `gap`,
    /// resumed as after a gap ([`resume_after_gap`](Self::resume_after_gap)):
    /// the charge while the estimator was off is unknown.
    pub(crate) fn from_parts(parts: &ObserverParts<T>, gap: bool) -> Self {
        let mut o = Self {
            x: parts.x,
            p: parts.p,
            rest: parts.rest.map(|r| Rest {
                len: r.len,
                mean: r.mean,
                current: r.current,
                early: r.early,
                done: r.done,
                bias_read: r.bias_read,
            }),
            ocv_weight: parts.ocv_weight,
            observations: parts.observations,
            capacity_held: parts.capacity_held,
            rest_span: Self::NO_SPAN,
            span_reached: parts.capacity_held.is_some(),
            set: None,
            gap: false,
        };
        if gap {
            o.resume_after_gap();
        }
        o
    }

    /// The SOC is unknown again (a gap of unknown charge in the record, a
    /// reset): at the next sample its spread widens by
    /// [`SocSettings::gap_soc_sigma`]; any rest restarts now. The bias and
    /// capacity are kept; the rests before it no longer span SOC with
    /// those after ([`SocSettings::capacity_min_span`]).
    pub fn resume_after_gap(&mut self) {
        self.gap = true;
        self.rest = None;
        self.rest_span = Self::NO_SPAN;
    }

    /// A gap whose charge is known (A·h, + charging, beyond what the
    /// samples across it counted): counted as one step of that charge,
    /// the SOC moving by it over the capacity and its spread with the
    /// capacity's, so the charge between the rests on either side still
    /// tells the capacity. Any rest restarts. A charge that is not finite
    /// is a gap of unknown charge ([`resume_after_gap`](Self::resume_after_gap)).
    ///
    /// ```
    /// use estimator_core::battery::soc::{SocObserver, SocSettings};
    /// let s = SocSettings::new(5.0, 1.0);
    /// let mut soc = SocObserver::new(&s, Some(0.8));
    /// soc.bridge_gap(&s, -1.0);
    /// // The next sample takes it: 1 A·h of 5 out.
    /// let table = estimator_core::battery::ocv::OcvTable::<f64, 2>::new(&[0.0, 1.0], &[3.0, 4.2]).unwrap();
    /// let e = soc.push(&s, &table, 0.0, f64::NAN).unwrap();
    /// assert!((e.soc - 0.6).abs() < 1e-12);
    /// ```
    pub fn bridge_gap(&mut self, s: &SocSettings<T>, charge_ah: T) {
        if !charge_ah.is_finite() {
            self.resume_after_gap();
            return;
        }
        self.rest = None;
        self.count(s, T::ZERO, charge_ah / s.capacity_ah, T::ZERO);
    }

    /// Sets the SOC (a value the caller knows better): from the next
    /// sample on, with spread [`SocSettings::soc0_sigma`] (the estimate
    /// shows it at once), and the rests before it no longer span SOC with
    /// those after. A non-finite value is ignored.
    pub fn set_state_of_charge(&mut self, soc: T) {
        if soc.is_finite() {
            self.set = Some(soc);
            self.rest_span = Self::NO_SPAN;
            if let Some(x) = &mut self.x {
                x[0] = soc;
            }
        }
    }

    /// Takes a gap and a set SOC (in that order) with the settings.
    fn take_pending(&mut self, s: &SocSettings<T>) {
        if core::mem::take(&mut self.gap) {
            self.p[0] = self.p[0] + s.gap_soc_sigma * s.gap_soc_sigma;
            self.condition(s);
        }
        if let Some(soc) = self.set.take() {
            match &mut self.x {
                Some(x) => {
                    x[0] = soc;
                    self.p[0] = s.soc0_sigma * s.soc0_sigma;
                    self.p[1] = T::ZERO;
                    self.p[2] = T::ZERO;
                }
                None => self.start(s, soc),
            }
            self.condition(s);
        }
    }

    /// The rest in progress, if any: its length (s) and the mean of about
    /// its last half minute of voltage (V), the voltage a rest reads.
    ///
    /// ```
    /// use estimator_core::battery::ocv::OcvTable;
    /// use estimator_core::battery::soc::{SocObserver, SocSettings};
    /// let table = OcvTable::<f64, 2>::new(&[0.0, 1.0], &[3.0, 4.2]).unwrap();
    /// let s = SocSettings::new(5.0, 1.0);
    /// let mut soc = SocObserver::new(&s, Some(0.5));
    /// for _ in 0..10 {
    ///     soc.push(&s, &table, 0.0, 3.6);
    /// }
    /// let (len, v) = soc.rest().unwrap();
    /// assert_eq!(len, 10.0);
    /// assert!((v - 3.6).abs() < 1e-12);
    /// soc.push(&s, &table, -5.0, 3.5);
    /// assert!(soc.rest().is_none());
    /// ```
    pub fn rest(&self) -> Option<(T, T)> {
        self.rest.map(|r| (r.len, r.mean))
    }

    /// The estimate now (`None` before the start SOC is known).
    pub fn estimate(&self, s: &SocSettings<T>) -> Option<SocEstimate<T>> {
        let [soc, b, _] = self.x?;
        let (c, sd, identified) = self.capacity(s)?;
        Some(SocEstimate {
            soc,
            sigma: self.p[0].max(T::ZERO).sqrt(),
            current_bias_a: b,
            capacity_ah: if identified {
                c
            } else {
                self.capacity_held.unwrap_or(s.capacity_ah)
            },
            capacity_sigma_ah: sd,
            capacity_identified: identified,
            ocv_weight: self.ocv_weight,
            observations: self.observations,
        })
    }

    /// The filter's capacity, its standard deviation, and whether that is
    /// within [`SocSettings::capacity_identify`] of it with the rests'
    /// span reached ([`SocSettings::capacity_min_span`]).
    fn capacity(&self, s: &SocSettings<T>) -> Option<(T, T, bool)> {
        let g = self.x?[2];
        let c = s.capacity_ah / g;
        // d(C/g) = −C/g² dg
        let sd = c / g * self.p[5].max(T::ZERO).sqrt();
        let spanned = self.span_reached || s.capacity_min_span <= T::ZERO;
        Some((c, sd, spanned && sd <= s.capacity_identify * c))
    }

    /// Widens the span of the rests read with `z`, a relaxed rest's SOC
    /// through the curve.
    fn span_with(&mut self, s: &SocSettings<T>, z: T) {
        let [lo, hi] = self.rest_span;
        let (lo, hi) = (z.min(lo), z.max(hi));
        self.rest_span = [lo, hi];
        if hi - lo >= s.capacity_min_span {
            self.span_reached = true;
        }
    }

    /// Counts one sample (current in A, positive when charging; terminal
    /// voltage in V, read at the end of the sample) and observes the SOC
    /// when a rest gives it. A non-finite current counts as the bias (no
    /// charge); a non-finite voltage observes nothing and breaks a rest.
    pub fn push<const P: usize>(
        &mut self,
        s: &SocSettings<T>,
        table: &OcvTable<T, P>,
        current: T,
        voltage: T,
    ) -> Option<SocEstimate<T>> {
        self.take_pending(s);
        if self.x.is_none() && voltage.is_finite() {
            self.start(s, table.soc_from_ocv(voltage));
        }
        let x = self.x?;
        // What the sensor read (NaN when it read nothing: no bias reading).
        let read = current;
        let current = if current.is_finite() { current } else { x[1] };
        self.predict(s, current);
        let rested = (current - x[1]).abs() <= s.rest_current_a && voltage.is_finite();
        if rested {
            let mut rest = match self.rest {
                None => Rest::new(s, voltage, read),
                Some(mut r) => {
                    r.push(s, voltage, read);
                    r
                }
            };
            let unknown =
                self.p[0].sqrt() * T::lit(0.25) > self.spread(s, table, s.unrelaxed_sigma_v);
            if unknown && !rest.early && rest.len >= s.rest_s / T::lit(2.0) {
                if self.observe(s, table, rest.mean, false) {
                    self.observe_bias(s, &mut rest);
                }
                rest.early = true;
            } else if !rest.done && rest.len >= s.rest_max_s {
                if self.observe(s, table, rest.mean, true) {
                    self.observe_bias(s, &mut rest);
                }
                rest.done = true;
            }
            self.rest = Some(rest);
        } else {
            if let Some(mut r) = self.rest.filter(|r| !r.done && r.len >= s.rest_s) {
                if self.observe(s, table, r.mean, true) {
                    self.observe_bias(s, &mut r);
                }
            }
            self.rest = None;
        }
        self.estimate(s)
    }

    /// The spread of an SOC read through the curve at the SOC now from a
    /// voltage of spread `sigma_v`.
    fn spread<const P: usize>(&self, s: &SocSettings<T>, table: &OcvTable<T, P>, sigma_v: T) -> T {
        let soc = self.x.map_or(T::lit(0.5), |x| x[0]);
        sigma_v / table.slope(soc).abs().max(s.min_slope)
    }

    /// The count of one sample: the state and its covariance forward.
    fn predict(&mut self, s: &SocSettings<T>, current: T) {
        let Some([_, b, g]) = self.x else { return };
        let k = s.h / (T::lit(3600.0) * s.capacity_ah);
        let walk = s.bias_walk_a * s.bias_walk_a * s.h / T::lit(3600.0);
        self.count(s, -g * k, (current - b) * k, walk);
    }

    /// One step of the count, `F = [[1, fb, fg], [0, 1, 0], [0, 0, 1]]`:
    /// the SOC moves by `g·fg` (a charge over the nominal capacity) and
    /// the covariance with it, the bias's variance grows by `walk`.
    fn count(&mut self, s: &SocSettings<T>, fb: T, fg: T, walk: T) {
        let Some(x) = &mut self.x else { return };
        // A count that would leave the finite numbers (a current far
        // beyond the capacity's scale, sample after sample) stops where
        // it is: the estimate stays the last finite one.
        let counted = x[0] + x[2] * fg;
        if counted.is_finite() {
            x[0] = counted;
        }
        let [p00, p01, p02, p11, p12, p22] = self.p;
        // Row 0 of F·P.
        let r0 = [
            p00 + fb * p01 + fg * p02,
            p01 + fb * p11 + fg * p12,
            p02 + fb * p12 + fg * p22,
        ];
        self.p = [
            r0[0] + fb * r0[1] + fg * r0[2],
            r0[1],
            r0[2],
            p11 + walk,
            p12,
            p22,
        ];
        self.condition(s);
    }

    /// One observation of the SOC: the curve's inverse of `voltage`, with
    /// spread `sigma_v` over the curve's slope there. A voltage outside
    /// the curve's range tells only that the SOC is past its end: nothing
    /// is observed. True when it observed. A `relaxed` rest's voltage has
    /// the spread [`SocSettings::voltage_sigma_v`] and widens the span of
    /// the rests read; one read early, before it relaxed,
    /// [`SocSettings::unrelaxed_sigma_v`] and no span (its reading is the
    /// same rest's as the relaxed one after it).
    fn observe<const P: usize>(
        &mut self,
        s: &SocSettings<T>,
        table: &OcvTable<T, P>,
        voltage: T,
        relaxed: bool,
    ) -> bool {
        let sigma_v = if relaxed {
            s.voltage_sigma_v
        } else {
            s.unrelaxed_sigma_v
        };
        let Some(x) = self.x else { return false };
        let v = table.ocv_points();
        let inside = v
            .first()
            .zip(v.last())
            .is_some_and(|(&lo, &hi)| voltage > lo && voltage < hi);
        if !inside {
            return false;
        }
        let z = table.soc_from_ocv(voltage);
        let r = {
            let sd = sigma_v / table.slope(z).abs().max(s.min_slope);
            sd * sd + s.table_sigma_soc * s.table_sigma_soc
        };
        let sum = self.p[0] + r;
        if sum.is_nan() || sum <= T::ZERO || !sum.is_finite() {
            return false;
        }
        let innovation = z - x[0];
        if relaxed {
            self.span_with(s, z);
        }
        let gain = self.measure(s, Measured::Soc, innovation, sum);
        self.ocv_weight = gain;
        self.observations = self.observations.saturating_add(1);
        true
    }

    /// One observation of the bias, once per rest and only with its SOC
    /// observation: the rest's mean measured current is the bias, give or
    /// take [`SocSettings::rest_load_sigma_a`]. Without it a record that
    /// only discharges, at an even pace, cannot tell a bias from a
    /// capacity (docs/bms-states.md). A reading more than three standard
    /// deviations from the bias expected (the bias's own spread and the
    /// load's) is a load the rest carries, not the bias: it is not taken.
    /// Nor is a current that is not finite (no sample of the rest read
    /// one).
    fn observe_bias(&mut self, s: &SocSettings<T>, rest: &mut Rest<T>) {
        if core::mem::replace(&mut rest.bias_read, true) {
            return;
        }
        let current = rest.current;
        let Some(x) = self.x else { return };
        let sum = self.p[3] + s.rest_load_sigma_a * s.rest_load_sigma_a;
        if !current.is_finite() || !sum.is_finite() || sum <= T::ZERO {
            return;
        }
        let innovation = current - x[1];
        if innovation * innovation > T::lit(9.0) * sum {
            return;
        }
        self.measure(s, Measured::Bias, innovation, sum);
    }

    /// The Kalman update of one scalar measurement of the SOC or of the
    /// bias, with innovation `innovation` and innovation variance `sum`
    /// (finite and positive): the state and covariance updated and kept in
    /// range, the capacity held when identified. Returns the gain on the
    /// SOC.
    fn measure(&mut self, s: &SocSettings<T>, of: Measured, innovation: T, sum: T) -> T {
        let Some(x) = &mut self.x else {
            return T::ZERO;
        };
        let [p00, p01, p02, p11, p12, p22] = self.p;
        // P[:, j], the measured state's column.
        let c = match of {
            Measured::Soc => [p00, p01, p02],
            Measured::Bias => [p01, p11, p12],
        };
        let gain = c.map(|ci| ci / sum);
        for (xi, ki) in x.iter_mut().zip(gain) {
            *xi = *xi + ki * innovation;
        }
        // Keep the capacity positive: g within (0.2, 5); and the bias
        // within 1C (what its spread is capped at, `variance_caps`).
        x[2] = x[2].max(T::lit(0.2)).min(T::lit(5.0));
        x[1] = x[1].max(-s.capacity_ah).min(s.capacity_ah);
        // P − K·P[j,:] (P symmetric: P[j,:] is the column).
        self.p = [
            p00 - gain[0] * c[0],
            p01 - gain[0] * c[1],
            p02 - gain[0] * c[2],
            p11 - gain[1] * c[1],
            p12 - gain[1] * c[2],
            p22 - gain[2] * c[2],
        ];
        self.condition(s);
        if let Some((c, _, true)) = self.capacity(s) {
            self.capacity_held = Some(c);
        }
        gain[0]
    }
}

/// Which state a scalar measurement observes ([`SocObserver::measure`]).
#[derive(Clone, Copy)]
enum Measured {
    Soc,
    Bias,
}

mod rest;
use rest::Rest;

#[cfg(test)]
mod tests;
