//! The state-of-power columns of a track (issue 36): for each horizon `H`,
//! `sop_discharge_a_{H}s`, `sop_charge_a_{H}s` and `pulse_v_{H}s`, then
//! `sop_basis` and the pulse voltage's standard deviation
//! (`sop_uncertainty_v`, the longest horizon's, and
//! `sop_uncertainty_v_{H}s`) and the ratio its pulse voltage was corrected
//! by (`pulse_ratio_{H}s`), from the core's
//! [`PulsePredictor`](estimator_core::battery::power::PulsePredictor) on
//! the cell's best parameter set after each sample.
//!
//! Owns the horizons, the limits' defaults and the columns; the prediction
//! is the core's, and so is when there is one: from the best parameter set
//! the cell holds (`sop_basis`: the window's, the prior's, held or stale
//! values; with a prior and no fit yet, from a relaxed cell only).

use crate::bail;
use crate::error::Result;
use crate::ocv::CellOcv;
use estimator_core::battery::online::{CellEstimator, OnlineSettings};
use estimator_core::battery::pack::PackEstimator;
use estimator_core::battery::power::{
    samples, PowerLimits, PowerReport, PowerSettings, MAX_HORIZON_STEPS,
};
use estimator_core::Real;

/// The most horizons a track carries.
pub use estimator_core::battery::power::MAX_HORIZONS;

/// What the state-of-power columns say, as `online battery`'s flags give
/// it. The default: horizons of 10 and 30 s; the voltage limits the OCV
/// table's lowest and highest voltage; no current cap beyond the
/// estimator's plausible current; the pulse a 1C discharge (with a
/// capacity).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PowerOptions {
    horizons_s: [f64; MAX_HORIZONS],
    count: usize,
    /// The lowest voltage a pulse may reach (V; default: the OCV table's
    /// lowest).
    pub voltage_min: Option<f64>,
    /// The highest (V; default: the OCV table's highest).
    pub voltage_max: Option<f64>,
    /// The largest current magnitude (A; default: the estimator's
    /// plausible current, 500 A).
    pub current_limit: Option<f64>,
    /// The current of the `pulse_v_{H}s` columns (A, + charging; default:
    /// a 1C discharge from the capacity).
    pub pulse_current_a: Option<f64>,
    /// How long (s) the prediction may be carried from the last fit
    /// without a new one (default: as far as the window reaches;
    /// [`PowerSettings::carry`]).
    pub carry_s: Option<f64>,
    /// How many standard deviations of the pulse voltage the limit
    /// currents keep inside the voltage limits (default 2:
    /// [`PowerSettings::confidence`]; 0 derates nothing).
    pub confidence: Option<f64>,
    /// Whether the pulse voltage is corrected by the last pulse of its
    /// current's measured over predicted drop (default: yes;
    /// `--no-pulse-correction`; the core's `OnlineSettings::pulse_current`).
    pub pulse_correction: bool,
}

impl Default for PowerOptions {
    fn default() -> Self {
        let mut horizons_s = [0.0; MAX_HORIZONS];
        horizons_s[..2].copy_from_slice(&[10.0, 30.0]);
        Self {
            horizons_s,
            count: 2,
            voltage_min: None,
            voltage_max: None,
            current_limit: None,
            pulse_current_a: None,
            carry_s: None,
            confidence: None,
            pulse_correction: true,
        }
    }
}

impl PowerOptions {
    /// The default with these horizons (s).
    ///
    /// # Errors
    /// None, more than [`MAX_HORIZONS`], one that is not finite and
    /// positive, or one given twice (each names its own columns).
    ///
    /// ```
    /// use fracbms_host::online::power::PowerOptions;
    /// assert_eq!(PowerOptions::default().with_horizons(&[2.0, 10.0])?.horizons(), [2.0, 10.0]);
    /// assert!(PowerOptions::default().with_horizons(&[10.0, 10.0]).is_err());
    /// # Ok::<(), fracbms_host::Error>(())
    /// ```
    pub fn with_horizons(self, horizons_s: &[f64]) -> Result<Self> {
        if horizons_s.is_empty() || horizons_s.len() > MAX_HORIZONS {
            bail!(
                Options,
                "--horizons: give 1 to {MAX_HORIZONS} horizons in seconds (got {})",
                horizons_s.len()
            );
        }
        if let Some(h) = horizons_s.iter().find(|h| !(h.is_finite() && **h > 0.0)) {
            bail!(
                Options,
                "--horizons {h}: a horizon is a positive number of seconds"
            );
        }
        // The columns are named by the horizon as printed (`pulse_v_10s`).
        if let Some(h) = horizons_s
            .iter()
            .enumerate()
            .find(|&(k, h)| {
                horizons_s[..k]
                    .iter()
                    .any(|g| g.to_string() == h.to_string())
            })
            .map(|(_, h)| h)
        {
            bail!(
                Options,
                "--horizons {h}: given twice (each horizon names its own columns)"
            );
        }
        let mut o = self;
        o.horizons_s = [0.0; MAX_HORIZONS];
        o.horizons_s[..horizons_s.len()].copy_from_slice(horizons_s);
        o.count = horizons_s.len();
        Ok(o)
    }

    /// The flags that need no table: the pulse's current, the carry and
    /// the confidence.
    ///
    /// # Errors
    /// A pulse current that is not finite, a carry or a confidence that is
    /// negative or not finite.
    pub fn check(&self) -> Result<()> {
        if self.pulse_current_a.is_some_and(|i| !i.is_finite()) {
            bail!(
                Options,
                "--pulse-current-a: must be a finite number of amperes"
            );
        }
        if let Some(c) = self.carry_s.filter(|c| !(c.is_finite() && *c >= 0.0)) {
            bail!(
                Options,
                "--sop-carry-s {c}: must be a number of seconds, 0 or more"
            );
        }
        if let Some(c) = self.confidence.filter(|c| !(c.is_finite() && *c >= 0.0)) {
            bail!(
                Options,
                "--sop-confidence {c}: must be a number of standard deviations, 0 or more"
            );
        }
        Ok(())
    }

    /// The horizons (s).
    pub fn horizons(&self) -> &[f64] {
        &self.horizons_s[..self.count]
    }

    /// The current (A) whose pulse voltage the core corrects
    /// (`OnlineSettings::pulse_current`): the pulse's, given or 1C, when
    /// the correction is on and the state of power is known (limits
    /// given or from a table).
    pub(crate) fn corrected_pulse(&self, cell: Option<&CellOcv>) -> Option<f64> {
        let p = self.resolve(cell)?.pulse_current_a;
        p.filter(|i| self.pulse_correction && i.is_finite() && *i != 0.0)
    }

    /// Whether the state of power is published for a run with an OCV
    /// table (`table`) or without: both voltage limits given or known
    /// from it ([`Self::resolve`]).
    pub(crate) fn published(&self, table: bool) -> bool {
        table || (self.voltage_min.is_some() && self.voltage_max.is_some())
    }

    /// The limits and the pulse for a cell with `cell`'s table and
    /// capacity; `None` where the voltage limits are neither given nor
    /// known from a table.
    pub(crate) fn resolve(&self, cell: Option<&CellOcv>) -> Option<ResolvedPower> {
        let table = cell.map(|c| c.model.table.ocv_points());
        let lowest = table.and_then(|v| v.first().copied());
        let highest = table.and_then(|v| v.last().copied());
        let limits = PowerLimits {
            voltage_min: self.voltage_min.or(lowest)?,
            voltage_max: self.voltage_max.or(highest)?,
            current_limit: self.current_limit.unwrap_or(500.0),
        };
        Some(ResolvedPower {
            limits,
            pulse_current_a: self.pulse_current_a.or(cell.map(|c| -c.model.capacity_ah)),
            options: *self,
        })
    }
}

/// One horizon's columns after a sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PowerRow {
    /// `sop_discharge_a_{H}s` (A, a magnitude).
    pub discharge_a: Option<f64>,
    /// `sop_charge_a_{H}s` (A).
    pub charge_a: Option<f64>,
    /// `pulse_v_{H}s` (V).
    pub pulse_v: Option<f64>,
    /// `sop_basis`: where the parameters came from
    /// ([`estimator_core::battery::power::SopBasis::as_str`]; the same at
    /// every horizon).
    pub basis: Option<&'static str>,
    /// `sop_uncertainty_v_{H}s`: the pulse voltage's standard deviation
    /// (V) from the parameters' spread.
    pub uncertainty_v: Option<f64>,
    /// `pulse_ratio_{H}s`: the measured over predicted drop of the last
    /// pulse of the same current that `pulse_v_{H}s` was corrected by
    /// (empty: the model's own prediction).
    pub pulse_ratio: Option<f64>,
}

/// [`PowerOptions`] with the limits resolved for one cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ResolvedPower {
    limits: PowerLimits<f64>,
    pulse_current_a: Option<f64>,
    options: PowerOptions,
}

impl ResolvedPower {
    /// The limits as the core takes them.
    ///
    /// # Errors
    /// A voltage minimum not below the maximum, a current limit that is not
    /// positive, or a value that is not finite.
    pub(crate) fn check(&self) -> Result<()> {
        let l = &self.limits;
        if !(l.voltage_min.is_finite()
            && l.voltage_max.is_finite()
            && l.voltage_min < l.voltage_max)
        {
            bail!(
                Options,
                "--voltage-min {} --voltage-max {}: the minimum must be below the maximum",
                l.voltage_min,
                l.voltage_max
            );
        }
        if !(l.current_limit.is_finite() && l.current_limit > 0.0) {
            bail!(
                Options,
                "--current-limit {}: must be a positive number of amperes",
                l.current_limit
            );
        }
        if self.pulse_current_a.is_some_and(|i| !i.is_finite()) {
            bail!(
                Options,
                "--pulse-current-a: must be a finite number of amperes"
            );
        }
        Ok(())
    }

    /// Checks the horizons at the sample period `h` (s): each at most
    /// [`MAX_HORIZON_STEPS`] samples, as the core takes them
    /// ([`PowerSettings::new`]).
    ///
    /// # Errors
    /// The longest horizon past that, named with the longest the period
    /// allows.
    pub(crate) fn check_period(&self, h: f64) -> Result<()> {
        let longest = self.options.horizons().iter().copied().fold(0.0, f64::max);
        if samples(longest, h).is_none_or(|n| n > MAX_HORIZON_STEPS) {
            bail!(
                Options,
                "--horizons {}: at most {MAX_HORIZON_STEPS} samples of the \
                 {h} s period ({} s)",
                crate::error::shown(longest),
                f64::from(MAX_HORIZON_STEPS) * h
            );
        }
        Ok(())
    }

    /// The columns after the cell's last sample (all empty where its
    /// model is not published, or its fit is not the estimate).
    pub(crate) fn rows<T: Real, const N: usize, const P: usize>(
        &self,
        est: &CellEstimator<T, N, N>,
        s: &OnlineSettings<T, P>,
    ) -> [PowerRow; MAX_HORIZONS] {
        let report = self
            .settings(s.battery.h.to_f64())
            .and_then(|settings| est.state_of_power(s, &settings));
        Self::columns(report)
    }

    /// The columns of each of a pack's first `cells` cells, and of the
    /// string (at each horizon the weakest cell's currents and the sum of
    /// the cells' pulse voltages, [`PowerReport::string`], as
    /// [`PackEstimator::pack_state_of_power`] has it; empty while any cell
    /// has none), as [`Self::rows`]: each cell's state of power computed
    /// once.
    pub(crate) fn pack_rows<T: Real, const N: usize, const C: usize, const P: usize>(
        &self,
        pack: &PackEstimator<T, N, N, C>,
        cells: usize,
        s: &OnlineSettings<T, P>,
    ) -> (Vec<[PowerRow; MAX_HORIZONS]>, [PowerRow; MAX_HORIZONS]) {
        let settings = self.settings(s.battery.h.to_f64());
        let reports: Vec<Option<PowerReport<T>>> = (0..cells)
            .map(|k| settings.and_then(|p| pack.state_of_power(k, s, &p)))
            .collect();
        let string = Self::columns(PowerReport::string(reports.iter().copied()));
        (reports.into_iter().map(Self::columns).collect(), string)
    }

    /// A core report as the columns (all empty for `None`).
    fn columns<T: Real>(report: Option<PowerReport<T>>) -> [PowerRow; MAX_HORIZONS] {
        let mut out = [PowerRow::default(); MAX_HORIZONS];
        let Some(report) = report else {
            return out;
        };
        for (row, h) in out.iter_mut().zip(report.horizons()) {
            *row = PowerRow {
                discharge_a: Some(h.sop.discharge_a.to_f64()),
                charge_a: Some(h.sop.charge_a.to_f64()),
                pulse_v: h.pulse_v.map(|v| v.to_f64()),
                basis: Some(report.basis().as_str()),
                uncertainty_v: h.uncertainty_v.map(|v| v.to_f64()),
                pulse_ratio: h.pulse_ratio.map(|v| v.to_f64()),
            };
        }
        out
    }

    /// The core's settings for sample period `h` (s): each horizon `H/h`
    /// samples, rounded (at least 1; `PowerSettings::from_seconds`, as C's).
    fn settings<T: Real>(&self, h: f64) -> Option<PowerSettings<T>> {
        let mut horizons = [T::zero(); MAX_HORIZONS];
        let given = self.options.horizons();
        for (k, &hz) in horizons.iter_mut().zip(given) {
            *k = T::lit(hz);
        }
        let limits = PowerLimits {
            voltage_min: T::lit(self.limits.voltage_min),
            voltage_max: T::lit(self.limits.voltage_max),
            current_limit: T::lit(self.limits.current_limit),
        };
        let period = T::lit(h);
        let mut p = PowerSettings::from_seconds(
            limits,
            &horizons[..given.len()],
            period,
            self.pulse_current_a.map(T::lit),
        )?;
        p.carry = match self.options.carry_s {
            Some(c) => Some(samples(T::lit(c), period)?),
            None => None,
        };
        if let Some(c) = self.options.confidence {
            p.confidence = T::lit(c);
        }
        Some(p)
    }
}
