//! How far a whole-record fit (`identify battery`) can be trusted.
//!
//! This module owns two things and nothing else:
//!
//! * **Bad rows, offline as online.** A row whose current or voltage is not
//!   finite, outside the plausible ranges, or (after a first fit) a voltage
//!   further than `max(spike_sigmas·σ, spike_floor)` from the fitted model
//!   is *rejected*, with the online estimator's rules and defaults
//!   ([`OnlineSettings`]); σ is the residuals' robust scale (1.4826 × their
//!   median absolute deviation), since one spike inflates an RMSE. A spike
//!   is short: the row must also be that far from the median residual of
//!   its neighbours ([`SPIKE_RUN`] rows either side), so a run of rows the
//!   model misses alike (model error at a pulse edge) stays. The time
//!   base stays intact: a rejected row keeps its place with a substitute, as
//!   online (its current when plausible, else the last plausible one; its
//!   voltage interpolated from its good neighbours for the first fit, the
//!   model's voltage for the refits), so it adds nothing to the residuals.
//!   The fit is repeated, with the latest model's substitutes, until no new
//!   spike is found and two fits agree ([`settled`]; at most
//!   [`MAX_SPIKE_PASSES`] refits).
//! * **The verdict.** 95 % intervals for R_i, R_ct, Q and α from the
//!   Gauss–Newton information of the published fit at its estimate
//!   ([`FitInformation`]), the residual variance over the accepted rows, and
//!   the residuals' correlation: the variance is inflated by
//!   `(1 + ρ)/(1 − ρ)`, ρ the lag-1 autocorrelation of the residuals (the
//!   AR(1) effective-sample-size correction; model error that is correlated
//!   over time makes the rows worth fewer independent samples). Resistances
//!   and Q are fitted in logarithms, so their intervals are
//!   `p·exp(±1.96·k·se)`; α's is `α ± 1.96·k·se`. The fit is
//!   `identifiable` when no reason against it holds (see [`assess`]). The
//!   Butler–Volmer term's `a` and `i₀`, where fitted, get theirs the same
//!   way, given but not judged ([`Confidence::term_separated`]).
//!
//! It does not fit anything itself: the fits are `crate::identify`'s.

use crate::bail;
use crate::error::Result;
use crate::io::BatteryRecord;
use estimator_core::battery::online::{OnlineSettings, Rejection};
use estimator_core::battery::output_error::FitInformation;
use estimator_core::battery::CellParameters;
use serde::Serialize;
use std::path::Path;

/// The normal quantile of a two-sided 95 % interval.
pub const Z95: f64 = 1.959964;
/// Most refits after rejecting rows.
pub const MAX_SPIKE_PASSES: usize = 6;
/// The longest run of rows that can be a spike: a row is judged against
/// the median residual of the rows this far either side
/// ([`Screened::find_spikes`]).
pub const SPIKE_RUN: usize = 3;

/// Two successive fits agree to 10⁻⁴ (relative on R_i, R_ct, Q; absolute on
/// α): the substitutes no longer move the fit.
pub fn settled(a: &CellParameters<f64>, b: &CellParameters<f64>) -> bool {
    let rel = |x: f64, y: f64| (x / y - 1.0).abs() <= 1e-4;
    rel(a.r_i, b.r_i) && rel(a.r_ct, b.r_ct) && rel(a.q, b.q) && (a.alpha - b.alpha).abs() <= 1e-4
}
/// An interval of R_i, R_ct or Q wider than this factor either way
/// (`1.96·k·se(ln p) > ln 2`) is too wide to call the parameter identified.
pub const MAX_FACTOR: f64 = 2.0;
/// …and one of α wider than this half-width.
pub const MAX_ALPHA_HALF_WIDTH: f64 = 0.1;
/// The model must explain at least this fraction of the voltage's variance
/// over the record (`1 − RSS/TSS`): below, the residuals are as large as
/// the signal and the fit describes the noise.
pub const MIN_EXPLAINED: f64 = 0.5;

/// The plausibility limits of a row (the online estimator's defaults).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Lowest plausible terminal voltage (V).
    pub voltage_min: f64,
    /// Highest plausible terminal voltage (V).
    pub voltage_max: f64,
    /// Largest plausible |current| (A).
    pub current_limit: f64,
    /// A spike is further than `spike_sigmas` robust σ of the residuals…
    pub spike_sigmas: f64,
    /// …and further than this (V).
    pub spike_floor: f64,
}

impl Default for Limits {
    /// [`OnlineSettings`]' defaults: `U_t ∈ [1.5, 5] V`, `|I| ≤ 500 A`,
    /// spikes beyond `max(8σ, 50 mV)`.
    fn default() -> Self {
        let o = OnlineSettings::<f64>::new(1.0, 1, CellParameters::cell_18650());
        Self {
            voltage_min: o.voltage_min,
            voltage_max: o.voltage_max,
            current_limit: o.current_limit,
            spike_sigmas: o.spike_sigmas,
            spike_floor: o.spike_floor,
        }
    }
}

/// The rejected rows, by reason (JSON `rejected_rows`).
#[derive(Serialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RejectedRows {
    /// Current or voltage NaN or infinite.
    pub non_finite: u32,
    /// Outside the plausible current or voltage range.
    pub out_of_range: u32,
    /// Voltage too far from the fitted model.
    pub spikes: u32,
}

impl RejectedRows {
    /// All rejected rows.
    pub fn total(&self) -> u32 {
        self.non_finite + self.out_of_range + self.spikes
    }
}

/// A record with its rejected rows substituted.
pub struct Screened {
    /// The record the fits see.
    pub record: BatteryRecord,
    /// Per row: why it was rejected, or `None`.
    pub rejected: Vec<Option<Rejection>>,
    /// The measured voltages (for the spike test and the residuals).
    pub measured: Vec<f64>,
    /// Per row: no voltage was measured (a cycler's unlogged step start,
    /// [`crate::cycler::steps`]): substituted as a rejected row is, never
    /// counted as one.
    pub unobserved: Vec<bool>,
}

impl Screened {
    /// A record with every row accepted (nothing screened).
    pub fn accepted(rec: &BatteryRecord) -> Self {
        Self {
            record: BatteryRecord {
                time: rec.time.clone(),
                current: rec.current.clone(),
                voltage: rec.voltage.clone(),
                h: rec.h,
            },
            rejected: vec![None; rec.voltage.len()],
            measured: rec.voltage.clone(),
            unobserved: vec![false; rec.voltage.len()],
        }
    }

    /// Whether row `k` counts in a fit's residuals: measured and not
    /// rejected.
    pub fn counted(&self, k: usize) -> bool {
        self.rejected[k].is_none() && !self.unobserved.get(k).copied().unwrap_or(false)
    }

    /// The RMSE of `model` (V, one value per row) against the measured
    /// voltage over the rows that count (0 when none does; NaN where a
    /// model value there is not finite or missing).
    pub fn counted_rmse(&self, model: &[f64]) -> f64 {
        let (s, n) = (0..self.measured.len())
            .filter(|&k| self.counted(k))
            .map(|k| self.measured[k] - model.get(k).copied().unwrap_or(f64::NAN))
            .fold((0.0, 0usize), |(s, n), e| (s + e * e, n + 1));
        (s / n.max(1) as f64).sqrt()
    }

    /// The rows that do not count (rejected or unobserved).
    pub fn excluded(&self) -> usize {
        (0..self.rejected.len())
            .filter(|&k| !self.counted(k))
            .count()
    }

    /// The counts by reason.
    pub fn counts(&self) -> RejectedRows {
        let mut c = RejectedRows::default();
        for r in self.rejected.iter().flatten() {
            match r {
                Rejection::NonFinite => c.non_finite += 1,
                Rejection::OutOfRange => c.out_of_range += 1,
                Rejection::Spike => c.spikes += 1,
            }
        }
        c
    }

    /// One line naming the rejected rows (file rows: the header is row 1),
    /// or `None` when there are none.
    pub fn warning(&self, path: &Path) -> Option<String> {
        let c = self.counts();
        if c.total() == 0 {
            return None;
        }
        let rows: Vec<String> = self
            .rejected
            .iter()
            .enumerate()
            .filter(|(_, r)| r.is_some())
            .map(|(l, _)| (l + 2).to_string())
            .collect();
        let shown = if rows.len() > 12 {
            format!("{}, … ({} more)", rows[..12].join(", "), rows.len() - 12)
        } else {
            rows.join(", ")
        };
        Some(format!(
            "warning: {}: {} rows rejected ({} not finite, {} out of range, {} spikes against the model) and \
             substituted, as the online estimator does; the fit goes on without them: rows {shown}",
            path.display(),
            c.total(),
            c.non_finite,
            c.out_of_range,
            c.spikes
        ))
    }

    /// Gives every rejected row the model's voltage (a substitute that adds
    /// nothing to the residuals).
    pub fn substitute_model(&mut self, model: &[f64]) {
        for (k, (v, &m)) in self.record.voltage.iter_mut().zip(model).enumerate() {
            if (self.unobserved.get(k).copied().unwrap_or(false) || self.rejected[k].is_some())
                && m.is_finite()
            {
                *v = m;
            }
        }
    }

    /// Marks the accepted rows whose measured voltage is a spike against
    /// `model` (see the module docs); returns how many new ones.
    ///
    /// A spike is short: its residual is beyond the limit both from zero
    /// and from the median of the accepted residuals within
    /// [`SPIKE_RUN`] rows either side (a Hampel identifier on the
    /// residuals). A run of more than [`SPIKE_RUN`] rows that the model
    /// misses alike is model error (the first fit at a pulse edge, a
    /// cycler's interpolated relaxation), not bad data: rejecting it would
    /// take away the rows that could correct the model.
    pub fn find_spikes(&mut self, model: &[f64], limits: &Limits) -> usize {
        let res: Vec<Option<f64>> = (0..self.measured.len())
            .map(|k| self.counted(k).then(|| self.measured[k] - model[k]))
            .collect();
        let accepted: Vec<f64> = res.iter().flatten().copied().collect();
        let sigma = robust_scale(&accepted);
        if !sigma.is_finite() {
            return 0;
        }
        let limit = (limits.spike_sigmas * sigma).max(limits.spike_floor);
        let mut spikes = Vec::new();
        let mut window = Vec::with_capacity(2 * SPIKE_RUN + 1);
        for (k, r) in res.iter().enumerate() {
            let Some(r) = *r else { continue };
            if r.is_nan() || r.abs() <= limit {
                continue;
            }
            window.clear();
            // Cut short at the record's ends (there a burst of 3 rows is
            // half its window and stays: a record starts and ends at rest
            // in practice, and moving the window inwards rejected the
            // first loaded rows of the LG M50 pulse records).
            let lo = k.saturating_sub(SPIKE_RUN);
            let hi = (k + SPIKE_RUN + 1).min(res.len());
            window.extend(res[lo..hi].iter().flatten().copied());
            if (r - median(&mut window)).abs() > limit {
                spikes.push(k);
            }
        }
        for &k in &spikes {
            self.rejected[k] = Some(Rejection::Spike);
        }
        spikes.len()
    }
}

/// The median of `v` (reordered in place); NaN for no data.
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    // The value a sort would put in the middle, found without sorting
    // (O(n): on a 200 000-row record the sort was 2 % of the command), and
    // for an even count the largest below it.
    let n = v.len();
    let (below, &mut mid, _) = v.select_nth_unstable_by(n / 2, f64::total_cmp);
    if n % 2 == 1 {
        mid
    } else {
        let low = below.iter().copied().max_by(f64::total_cmp).unwrap_or(mid);
        (low + mid) / 2.0
    }
}

/// 1.4826 × the median absolute deviation from the median (the normal σ
/// of clean residuals, unmoved by a few outliers). NaN for no data.
fn robust_scale(x: &[f64]) -> f64 {
    let mut v = x.to_vec();
    let med = median(&mut v);
    let mut dev: Vec<f64> = x.iter().map(|r| (r - med).abs()).collect();
    1.4826 * median(&mut dev)
}

/// Rejects the non-finite and implausible rows of `rec` and substitutes
/// them (see the module docs).
///
/// # Errors
/// When no row has a plausible voltage, or none a plausible current: there
/// is nothing to fit.
pub fn screen(path: &Path, rec: &BatteryRecord, limits: &Limits) -> Result<Screened> {
    screen_observed(path, rec, limits, &[])
}

/// [`screen`] on a record some of whose rows have no measured voltage
/// (`unobserved[k]`; empty: every row measured): they are substituted as
/// rejected rows are, and counted apart.
///
/// # Errors
/// As [`screen`].
pub fn screen_observed(
    path: &Path,
    rec: &BatteryRecord,
    limits: &Limits,
    unobserved: &[bool],
) -> Result<Screened> {
    let n = rec.current.len();
    let unobserved: Vec<bool> = (0..n)
        .map(|k| unobserved.get(k).copied().unwrap_or(false))
        .collect();
    let mut rejected = vec![None; n];
    let plausible_i = |i: f64| i.is_finite() && i.abs() <= limits.current_limit;
    let plausible_v = |v: f64| v.is_finite() && v >= limits.voltage_min && v <= limits.voltage_max;
    for (l, r) in rejected.iter_mut().enumerate() {
        let (i, v) = (rec.current[l], rec.voltage[l]);
        if !(i.is_finite() && v.is_finite()) {
            *r = Some(Rejection::NonFinite);
        } else if !(plausible_i(i) && plausible_v(v)) {
            *r = Some(Rejection::OutOfRange);
        }
    }
    let Some(first_i) = rec.current.iter().copied().find(|&i| plausible_i(i)) else {
        bail!(
            Data,
            "{}: every row is rejected: no current is finite and within ±{} A",
            path.display(),
            limits.current_limit
        );
    };
    let good: Vec<usize> = (0..n)
        .filter(|&l| rejected[l].is_none() && !unobserved[l])
        .collect();
    if good.is_empty() {
        bail!(
            Data,
            "{}: every row is rejected: no voltage is finite and within [{}, {}] V (set --voltage-min/--voltage-max)",
            path.display(),
            limits.voltage_min,
            limits.voltage_max
        );
    }
    let mut out = BatteryRecord {
        time: rec.time.clone(),
        current: rec.current.clone(),
        voltage: rec.voltage.clone(),
        h: rec.h,
    };
    // Currents: the measured one when plausible, else the last plausible one
    // (the first plausible one before it).
    let mut last = first_i;
    for i in out.current.iter_mut() {
        if plausible_i(*i) {
            last = *i;
        } else {
            *i = last;
        }
    }
    // Voltages of rejected rows: linear between the good neighbours.
    let mut k = 0; // index into `good` of the next good row at or after l
    for (l, r) in rejected.iter().enumerate() {
        while k < good.len() && good[k] < l {
            k += 1;
        }
        if r.is_none() && !unobserved[l] {
            continue;
        }
        let before = k.checked_sub(1).map(|j| good[j]);
        let after = good.get(k).copied();
        out.voltage[l] = match (before, after) {
            (Some(a), Some(b)) => {
                let t = (l - a) as f64 / (b - a) as f64;
                rec.voltage[a] + t * (rec.voltage[b] - rec.voltage[a])
            }
            (Some(a), None) => rec.voltage[a],
            (None, Some(b)) => rec.voltage[b],
            // `good` is not empty, so every row has a good neighbour.
            (None, None) => f64::NAN,
        };
    }
    Ok(Screened {
        record: out,
        rejected,
        measured: rec.voltage.clone(),
        unobserved,
    })
}

/// The verdict on a fit (JSON `confidence`, `identifiable`,
/// `identifiable_reason`).
#[derive(Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Confidence {
    /// 95 % interval of R_i (Ω).
    pub r_i: [f64; 2],
    /// 95 % interval of R_ct (Ω).
    pub r_ct: [f64; 2],
    /// 95 % interval of Q (F·s^(α−1)).
    pub q: [f64; 2],
    /// 95 % interval of α.
    pub alpha: [f64; 2],
    /// 95 % interval of the Butler–Volmer term's `a` (V); none without
    /// the term.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bv_a: Option<[f64; 2]>,
    /// 95 % interval of the Butler–Volmer term's `i₀` (A); none without
    /// the term.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bv_i0: Option<[f64; 2]>,
}

impl Confidence {
    /// The names of the parameters whose 95 % interval is wider than a
    /// factor [`MAX_FACTOR`] either way, of R_i, R_ct and Q: what a fit or
    /// a map row is judged by.
    pub fn too_wide(&self) -> Vec<&'static str> {
        [("R_i", self.r_i), ("R_ct", self.r_ct), ("Q", self.q)]
            .into_iter()
            .filter(|(_, [lo, hi])| hi / lo > MAX_FACTOR * MAX_FACTOR)
            .map(|(name, _)| name)
            .collect()
    }

    /// Whether the Butler–Volmer term's `a` and `i₀` are each known
    /// within a factor [`MAX_FACTOR`] either way (`None` without the
    /// term). Not part of the verdict: below the exchange current the
    /// two trade along `a/i₀`, the term's slope at rest, which the data
    /// can pin while neither alone is; a model run within the currents it
    /// was fitted on is then as good, one run beyond them is not.
    pub fn term_separated(&self) -> Option<bool> {
        let [a, i0] = [self.bv_a?, self.bv_i0?];
        let within = |[lo, hi]: [f64; 2]| hi / lo <= MAX_FACTOR * MAX_FACTOR;
        Some(within(a) && within(i0))
    }
}

/// What [`assess`] concluded.
#[derive(Clone, Debug, PartialEq)]
pub struct Assessment {
    /// The intervals (`None` when the information matrix is singular).
    pub confidence: Option<Confidence>,
    /// No reason against the fit holds.
    pub identifiable: bool,
    /// Why not (empty when identifiable), one clause per reason.
    pub reasons: Vec<String>,
    /// The lag-1 autocorrelation ρ of the residuals over accepted rows.
    pub residual_correlation: f64,
    /// `1 − RSS/TSS` of the voltage over accepted rows.
    pub explained: f64,
}

/// The intervals and the verdict of the fit of `cell` (see the module
/// docs). `info` is the Gauss–Newton information at the estimate (None
/// when it could not be computed), `alpha_bounds` the fit's order bounds,
/// `model` the model's voltage over the record, `current` the record's.
///
/// Reasons against: the information is singular or not available (no
/// excitation, or the fit diverged); an interval of R_i, R_ct or Q wider
/// than a factor [`MAX_FACTOR`] either way (the Butler–Volmer term's
/// intervals are given, not judged: [`Confidence::term_separated`]), or of α wider than
/// ±[`MAX_ALPHA_HALF_WIDTH`]; α at a bound of its search; a resistance
/// collapsed to 0 (below 10⁻⁶ of the other); the current does not vary;
/// the model explains less than [`MIN_EXPLAINED`] of the voltage's
/// variance (the residuals are as large as the signal).
pub fn assess(
    sc: &Screened,
    cell: &CellParameters<f64>,
    info: Option<&FitInformation<f64>>,
    alpha_bounds: [f64; 2],
    model: &[f64],
) -> Assessment {
    let res: Vec<f64> = (0..sc.measured.len())
        .filter(|&k| sc.counted(k))
        .map(|k| sc.measured[k] - model[k])
        .collect();
    let good_v: Vec<f64> = (0..sc.measured.len())
        .filter(|&k| sc.counted(k))
        .map(|k| sc.measured[k])
        .collect();
    let n = res.len().max(1) as f64;
    let rss: f64 = res.iter().map(|r| r * r).sum();
    let mean_v = good_v.iter().sum::<f64>() / n;
    let tss: f64 = good_v.iter().map(|v| (v - mean_v) * (v - mean_v)).sum();
    let explained = if tss > 0.0 { 1.0 - rss / tss } else { 0.0 };
    let lag: f64 = res.windows(2).map(|w| w[0] * w[1]).sum();
    let rho = if rss > 0.0 { lag / rss } else { 0.0 };
    let inflation = {
        let r = rho.clamp(0.0, 0.995);
        ((1.0 + r) / (1.0 - r)).sqrt()
    };
    let mut reasons = Vec::new();
    let current_varies = {
        let c = &sc.record.current;
        let m = c.iter().sum::<f64>() / c.len().max(1) as f64;
        c.iter().any(|i| (i - m).abs() > 1e-9 * m.abs().max(1e-3))
    };
    if !current_varies {
        reasons.push("no excitation: the current does not vary".to_owned());
    }
    let confidence = info.and_then(|info| {
        let se = info.standard_errors();
        let k = info.parameters() as f64;
        let var_fit = info.residual_variance();
        let var = rss / (n - k).max(1.0);
        let scale = if var_fit > 0.0 {
            (var / var_fit).sqrt() * inflation
        } else {
            f64::NAN
        };
        let half = |j: usize| se[j].map(|e| Z95 * e * scale).filter(|h| h.is_finite());
        let log_interval = |p: f64, j: usize| half(j).map(|h| [p * (-h).exp(), p * h.exp()]);
        // The term's columns (`ln a`, `ln i₀`), where it was fitted (not
        // judged; none when an end is not finite, which JSON cannot hold).
        let term = |p: f64, j: usize| {
            info.fitted[j]
                .then(|| log_interval(p, j))
                .flatten()
                .filter(|x| x.iter().all(|e| e.is_finite()))
        };
        Some(Confidence {
            r_i: log_interval(cell.r_i, 0)?,
            r_ct: log_interval(cell.r_ct, 1)?,
            q: log_interval(cell.q, 2)?,
            alpha: half(3).map(|h| [cell.alpha - h, cell.alpha + h])?,
            bv_a: term(cell.bv_a, 6),
            bv_i0: term(cell.bv_i0, 7),
        })
    });
    match &confidence {
        None => reasons.push(
            "the information matrix is singular or not available: the parameters are not determined"
                .to_owned(),
        ),
        Some(c) => {
            let wide = c.too_wide();
            if !wide.is_empty() {
                reasons.push(format!(
                    "95 % intervals too wide: {} beyond a factor {MAX_FACTOR} either way",
                    wide.join(", ")
                ));
            }
            if c.alpha[1] - c.alpha[0] > 2.0 * MAX_ALPHA_HALF_WIDTH {
                reasons.push(format!(
                    "95 % interval of α too wide (±{:.3})",
                    (c.alpha[1] - c.alpha[0]) / 2.0
                ));
            }
        }
    }
    let [lo, hi] = alpha_bounds;
    if cell.alpha <= lo + 1e-3 || cell.alpha >= hi - 1e-3 {
        reasons.push(format!(
            "α = {:.4} at a bound of its search [{lo}, {hi}]",
            cell.alpha
        ));
    }
    if cell.r_i < 1e-6 * cell.r_ct || cell.r_ct < 1e-6 * cell.r_i {
        reasons.push(format!(
            "a resistance at its bound 0 (R_i = {:.3e} Ω, R_ct = {:.3e} Ω)",
            cell.r_i, cell.r_ct
        ));
    }
    // (NaN counts against it.)
    if explained.is_nan() || explained < MIN_EXPLAINED {
        reasons.push(format!(
            "the model explains {:.0} % of the voltage's variation: the residuals are as large as the signal",
            100.0 * explained.max(0.0)
        ));
    }
    Assessment {
        confidence,
        identifiable: reasons.is_empty(),
        reasons,
        residual_correlation: rho,
        explained,
    }
}

impl Limits {
    /// The default limits with the voltage range and current limit given,
    /// checked: `voltage_min < voltage_max` and a positive current limit.
    pub fn checked(
        voltage_min: Option<f64>,
        voltage_max: Option<f64>,
        current_limit: Option<f64>,
    ) -> Result<Self> {
        let defaults = Self::default();
        let limits = Self {
            voltage_min: voltage_min.unwrap_or(defaults.voltage_min),
            voltage_max: voltage_max.unwrap_or(defaults.voltage_max),
            current_limit: current_limit.unwrap_or(defaults.current_limit),
            ..defaults
        };
        if !(limits.voltage_min < limits.voltage_max && limits.current_limit > 0.0) {
            bail!(
                Options,
                "--voltage-min {} --voltage-max {} --current-limit {}: need voltage-min < voltage-max and a positive current limit",
                limits.voltage_min,
                limits.voltage_max,
                limits.current_limit
            );
        }
        Ok(limits)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The median is the middle of the sorted values (the mean of the two
    /// middle ones for an even count), to the bit, with ties, signed zeros
    /// and every count from 1 to 40.
    #[test]
    fn the_median_is_the_sorted_middle() {
        let mut x = 0x2545_f491_4f6c_dd1du64;
        for n in 1..=40usize {
            for _ in 0..20 {
                let v: Vec<f64> = (0..n)
                    .map(|_| {
                        x ^= x << 13;
                        x ^= x >> 7;
                        x ^= x << 17;
                        // Few distinct values, so ties are common.
                        [(x % 9) as f64 - 4.0, -0.0, 0.0, 0.1][(x >> 40) as usize % 4]
                    })
                    .collect();
                let mut sorted = v.clone();
                sorted.sort_by(f64::total_cmp);
                let want = if n % 2 == 1 {
                    sorted[n / 2]
                } else {
                    (sorted[n / 2 - 1] + sorted[n / 2]) / 2.0
                };
                let got = median(&mut v.clone());
                assert_eq!(got.to_bits(), want.to_bits(), "{v:?}");
            }
        }
        assert!(median(&mut []).is_nan());
    }

    /// An isolated spike and short bursts (one of 2 rows at the record's
    /// start) are rejected; a run of rows the model misses alike (longer than
    /// `SPIKE_RUN`) is model error and stays.
    #[test]
    fn a_spike_is_short_and_a_long_misfit_is_not_one() {
        let n = 200;
        let model = vec![3.7; n];
        let mut voltage: Vec<f64> = (0..n)
            .map(|k| 3.7 + 1e-3 * ((k % 7) as f64 - 3.0))
            .collect();
        voltage[20] += 0.3;
        // A burst of 2 rows at the record's start (its window cut short).
        for v in &mut voltage[0..2] {
            *v += 0.2;
        }
        for v in &mut voltage[60..63] {
            *v -= 0.3;
        }
        for v in &mut voltage[100..110] {
            *v += 0.3;
        }
        let rec = BatteryRecord {
            time: (0..n).map(|k| k as f64).collect(),
            current: vec![1.0; n],
            voltage,
            h: 1.0,
        };
        let mut sc = screen(Path::new("t.csv"), &rec, &Limits::default()).unwrap();
        let new = sc.find_spikes(&model, &Limits::default());
        let spikes: Vec<usize> = (0..n).filter(|&k| sc.rejected[k].is_some()).collect();
        assert_eq!(spikes, vec![0, 1, 20, 60, 61, 62]);
        assert_eq!(new, 6);
    }
}
