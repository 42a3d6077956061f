//! What a state of power is asked and what it answers: the limits
//! ([`PowerLimits`]), the horizons and the pulse ([`PowerSettings`]), each
//! horizon's currents and pulse voltage ([`StateOfPower`],
//! [`HorizonPower`]), the report of them all and where its parameters
//! came from ([`PowerReport`], [`SopBasis`]), and a string's report from
//! its cells'. Owns these types; the prediction that fills them is the
//! parent module's ([`super::PulsePredictor`]).

use crate::real::Real;

/// The voltage and current limits the state of power keeps to.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PowerLimits<T> {
    /// The lowest terminal voltage allowed (V).
    pub voltage_min: T,
    /// The highest terminal voltage allowed (V).
    pub voltage_max: T,
    /// The largest current magnitude allowed (A), either way.
    pub current_limit: T,
}

/// The largest constant currents for one horizon.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StateOfPower<T> {
    /// The horizon (samples of the model's period).
    pub steps: usize,
    /// The largest discharge current magnitude (A) whose predicted
    /// voltage stays at or above `voltage_min` for the whole horizon,
    /// capped by `current_limit` (0 when even a rest would cross it).
    pub discharge_a: T,
    /// The same for charge and `voltage_max`.
    pub charge_a: T,
}

/// [`PowerSettings::confidence`] by default: 2 σ.
pub const DEFAULT_CONFIDENCE: f64 = 2.0;

/// A duration of `seconds` (s) as samples of `period_s` (s), rounded to
/// the nearest (half up); `None` unless the duration is finite and not
/// negative and the period finite and positive. The horizons of
/// [`PowerSettings::from_seconds`] and its `carry` are counted so.
///
/// ```
/// use estimator_core::battery::power::samples;
/// assert_eq!(samples(10.0, 1.8), Some(6));
/// assert_eq!(samples(9.0, 2.0), Some(5));
/// assert_eq!(samples(600.0_f32, 2.0), Some(300));
/// assert_eq!(samples(-1.0, 2.0), None);
/// ```
pub fn samples<T: Real>(seconds: T, period_s: T) -> Option<u32> {
    if !(seconds.is_finite()
        && seconds >= T::zero()
        && period_s.is_finite()
        && period_s > T::zero())
    {
        return None;
    }
    // (A count past `u32::MAX` is held there: the cast saturates.)
    Some((seconds / period_s + T::lit(0.5)).to_f64() as u32)
}

/// The most horizons one [`PowerSettings`] asks for.
pub const MAX_HORIZONS: usize = 8;

/// The longest horizon (samples) one [`PowerSettings`] asks for: an hour
/// at a 1 s period. Each sample's state of power runs the model over its
/// longest horizon, so its cost grows with it (a horizon of `u32::MAX`
/// samples would hold the update for good).
pub const MAX_HORIZON_STEPS: u32 = 3_600;

/// What a state-of-power report asks: the limits, up to [`MAX_HORIZONS`]
/// horizons (samples of the model's period) and, optionally, the current
/// of a pulse whose voltage at the end of each horizon is predicted.
///
/// ```
/// use estimator_core::battery::power::{PowerLimits, PowerSettings, MAX_HORIZON_STEPS};
/// let limits = PowerLimits { voltage_min: 2.5, voltage_max: 4.2, current_limit: 50.0 };
/// let s = PowerSettings::new(limits, &[10, 30], Some(-3.0)).unwrap();
/// assert_eq!(s.horizons(), &[10, 30]);
/// assert!(PowerSettings::new(limits, &[0], None).is_none());
/// assert!(PowerSettings::new(limits, &[MAX_HORIZON_STEPS + 1], None).is_none());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PowerSettings<T> {
    /// The limits every horizon keeps to.
    pub limits: PowerLimits<T>,
    horizons: [u32; MAX_HORIZONS],
    count: usize,
    /// The current (A, + charging) of the pulse whose voltage is
    /// predicted at each horizon's end (`None`: none).
    pub pulse_current: Option<T>,
    /// How many samples the polarization may be carried forward from the
    /// last fit without a new one (through a rest) and still be predicted
    /// from (`None`: as far as the cell's window reaches back).
    pub carry: Option<u32>,
    /// How many standard deviations of the predicted voltage
    /// ([`HorizonPower::uncertainty_v`]) the limit currents keep inside
    /// the voltage limits at each horizon's end, when the parameters'
    /// spread is given ([`ParameterSpread`](super::ParameterSpread)): 2 (the default) leaves the
    /// limit voltage at 97.7 % one-sided; 0 derates nothing.
    pub confidence: T,
}

impl<T: Real> PowerSettings<T> {
    /// Settings for `horizons` (samples, each 1 to
    /// [`MAX_HORIZON_STEPS`]; 1 to [`MAX_HORIZONS`] of them). `None` for
    /// another count, a horizon of 0 or past [`MAX_HORIZON_STEPS`], or
    /// limits that are not finite with `voltage_min < voltage_max` and a
    /// positive current limit.
    pub fn new(limits: PowerLimits<T>, horizons: &[u32], pulse_current: Option<T>) -> Option<Self> {
        let l = &limits;
        let finite =
            l.voltage_min.is_finite() && l.voltage_max.is_finite() && l.current_limit.is_finite();
        if !(finite && l.voltage_min < l.voltage_max && l.current_limit > T::zero())
            || horizons.is_empty()
            || horizons.len() > MAX_HORIZONS
            || horizons.iter().any(|&h| h == 0 || h > MAX_HORIZON_STEPS)
            || pulse_current.is_some_and(|i| !i.is_finite())
        {
            return None;
        }
        let mut h = [0; MAX_HORIZONS];
        h[..horizons.len()].copy_from_slice(horizons);
        Some(Self {
            limits,
            horizons: h,
            count: horizons.len(),
            pulse_current,
            carry: None,
            confidence: T::lit(DEFAULT_CONFIDENCE),
        })
    }

    /// Settings for horizons given in seconds at the sample period
    /// `period_s` (s): each horizon that many samples, rounded to the
    /// nearest and at least 1 ([`samples`]). `None` where a horizon is not
    /// finite and positive, the period is not, or [`Self::new`] refuses.
    /// Every face that asks in seconds (the CLI, C, the firmware) builds its settings
    /// here, so a horizon is the same number of samples on each.
    ///
    /// ```
    /// use estimator_core::battery::power::{PowerLimits, PowerSettings};
    /// let limits = PowerLimits { voltage_min: 2.5, voltage_max: 4.2, current_limit: 20.0 };
    /// let p = PowerSettings::from_seconds(limits, &[2.0, 10.0, 30.0], 1.8, None).unwrap();
    /// assert_eq!(p.horizons(), [1, 6, 17]);
    /// assert!(PowerSettings::from_seconds(limits, &[0.0], 1.0, None).is_none());
    /// // Past `MAX_HORIZON_STEPS` samples (an hour at 1 s):
    /// assert!(PowerSettings::from_seconds(limits, &[3600.0], 1.0, None).is_some());
    /// assert!(PowerSettings::from_seconds(limits, &[3601.0], 1.0, None).is_none());
    /// ```
    pub fn from_seconds(
        limits: PowerLimits<T>,
        horizons_s: &[T],
        period_s: T,
        pulse_current: Option<T>,
    ) -> Option<Self> {
        let mut steps = [0u32; MAX_HORIZONS];
        if horizons_s.len() > MAX_HORIZONS {
            return None;
        }
        for (k, &h) in steps.iter_mut().zip(horizons_s) {
            if h.is_nan() || h <= T::zero() {
                return None;
            }
            *k = samples(h, period_s)?.max(1);
        }
        Self::new(limits, &steps[..horizons_s.len()], pulse_current)
    }

    /// The horizons (samples), in the order given.
    pub fn horizons(&self) -> &[u32] {
        &self.horizons[..self.count.min(MAX_HORIZONS)]
    }

    /// The longest horizon (samples).
    pub fn longest(&self) -> u32 {
        self.horizons().iter().copied().max().unwrap_or(0)
    }
}

/// One horizon's answer: its state of power and, when asked, the pulse's
/// voltage at its end.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HorizonPower<T> {
    /// The largest constant currents ([`StateOfPower`]).
    pub sop: StateOfPower<T>,
    /// The predicted terminal voltage (V) at the end of
    /// [`PowerSettings::pulse_current`] held for the horizon.
    pub pulse_v: Option<T>,
    /// The pulse voltage's standard deviation (V) from the parameters'
    /// spread ([`ParameterSpread`](super::ParameterSpread)): `None` without a pulse or a spread.
    pub uncertainty_v: Option<T>,
    /// The measured over predicted drop [`Self::pulse_v`] was corrected
    /// by: the last pulse of that current's ([`super::PulseCheck::corrected`]).
    /// `None`: the model's own prediction (none watched, no pulse of the
    /// watched current checked yet, or the cell not settled), and for a
    /// string.
    pub pulse_ratio: Option<T>,
}

/// Where a state of power's parameters (`R_i`, `R_ct`, `Q`, α, as one
/// set) come from, best first: the order a cell's estimator takes them in
/// ([`crate::battery::online::CellState::sop_parameters`]).
///
/// ```
/// use estimator_core::battery::power::SopBasis;
/// assert!(SopBasis::Window < SopBasis::Stale);
/// assert_eq!(SopBasis::Map.max(SopBasis::Held).as_str(), "held");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SopBasis {
    /// Every parameter identified by the last update's window: its
    /// estimate.
    Window,
    /// The map prior's parameters at the present state of charge and
    /// temperature.
    Map,
    /// The last good estimate, while every parameter has a value
    /// identified within
    /// [`OnlineSettings::hold_soc_span`](crate::battery::online::OnlineSettings::hold_soc_span)
    /// of the present state of charge, or restored from a snapshot.
    Held,
    /// The last good estimate, a parameter of it identified further away
    /// than that.
    Stale,
}

impl SopBasis {
    /// A short lower-case name (the track's `sop_basis` column).
    pub fn as_str(&self) -> &'static str {
        match self {
            SopBasis::Window => "window",
            SopBasis::Map => "map",
            SopBasis::Held => "held",
            SopBasis::Stale => "stale",
        }
    }

    /// A small number for binary faces (C, the firmware's line): 0
    /// window, 1 map, 2 held, 3 stale.
    pub fn code(&self) -> u8 {
        *self as u8
    }
}

/// The answer to a [`PowerSettings`]: one [`HorizonPower`] per horizon, in
/// its order, and where its parameters came from ([`SopBasis`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PowerReport<T> {
    pub(super) horizons: [HorizonPower<T>; MAX_HORIZONS],
    pub(super) count: usize,
    pub(super) basis: SopBasis,
}

impl<T: Real> PowerReport<T> {
    /// Each horizon's answer, in the settings' order.
    pub fn horizons(&self) -> &[HorizonPower<T>] {
        &self.horizons[..self.count.min(MAX_HORIZONS)]
    }

    /// Where the parameters it was predicted with came from
    /// ([`SopBasis::Window`] for a predictor's own report).
    pub fn basis(&self) -> SopBasis {
        self.basis
    }

    /// The same report, its parameters from `basis`.
    pub fn with_basis(mut self, basis: SopBasis) -> Self {
        self.basis = basis;
        self
    }

    /// The same report with each horizon's pulse voltage corrected by
    /// `check`'s last watched pulse ([`super::PulseCheck::corrected`]),
    /// where it has a ratio for that horizon and the cell is settled over
    /// it ([`super::SETTLED_DRIFT`]: the ratios were measured on pulses
    /// from a settled cell, and do not hold for one still relaxing from
    /// the last). `now` is the voltage the model predicts now, `free[j]`
    /// at the `j`-th horizon's end at no current.
    pub fn with_pulse_corrected(
        mut self,
        check: &super::PulseCheck<T>,
        now: T,
        free: &[T],
    ) -> Self {
        for (h, &f) in self.horizons.iter_mut().take(self.count).zip(free) {
            let steps = u32::try_from(h.sop.steps).unwrap_or(u32::MAX);
            let Some((v, r)) = h.pulse_v.zip(check.ratio(steps)).and_then(|(v, r)| {
                let settled = super::check::settled_at(now, v, f);
                Some((check.corrected(steps, v, f).filter(|_| settled)?, r))
            }) else {
                continue;
            };
            h.pulse_v = Some(v);
            h.pulse_ratio = Some(r);
        }
        self
    }

    /// The weaker of two cells' reports for the same settings, as a series
    /// string has it: at each horizon the smaller discharge and charge
    /// currents (the string's current is every cell's), the pulse voltage
    /// the sum of the cells' (the string's terminal voltage; `None` where
    /// either has none), its uncertainty their root sum of squares.
    pub fn series(&self, other: &Self) -> Self {
        let mut out = *self;
        for (a, b) in out
            .horizons
            .iter_mut()
            .take(self.count)
            .zip(other.horizons())
        {
            a.sop.discharge_a = a.sop.discharge_a.min(b.sop.discharge_a);
            a.sop.charge_a = a.sop.charge_a.min(b.sop.charge_a);
            a.pulse_v = a.pulse_v.zip(b.pulse_v).map(|(x, y)| x + y);
            a.pulse_ratio = None;
            // The cells' errors are taken as independent.
            a.uncertainty_v = a
                .uncertainty_v
                .zip(b.uncertainty_v)
                .map(|(x, y)| (x * x + y * y).sqrt());
        }
        out.basis = self.basis.max(other.basis);
        out
    }

    /// A series string's report from its cells' ([`series`](Self::series)
    /// of them all): `None` for no cells, or while any cell has none (a
    /// string is only as known as its least known cell).
    ///
    /// ```
    /// use estimator_core::battery::power::PowerReport;
    /// assert_eq!(PowerReport::<f32>::string([]), None);
    /// assert_eq!(PowerReport::<f32>::string([None]), None);
    /// ```
    pub fn string(cells: impl IntoIterator<Item = Option<Self>>) -> Option<Self> {
        let mut cells = cells.into_iter();
        let mut out = cells.next()??;
        for c in cells {
            out = out.series(&c?);
        }
        Some(out)
    }
}
