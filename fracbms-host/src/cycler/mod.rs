//! Cycler exports read as they come: the columns recognised by their
//! headers (Arbin, Bitrode-style, Maccor, Neware, BioLogic, PyBaMM/PyBOP,
//! ours) or named with a [`ColumnMap`], units converted, the current's sign
//! set, and a log with varying steps, duplicates and gaps put on a uniform
//! period ([`resample`]).
//!
//! This module owns the way from an export's bytes to a
//! [`BatteryRecord`] and the [`RecordReport`] that says what was read. It
//! must not touch the fits (a record it returns is like any other) nor how a
//! face shows the report (the CLI prints [`RecordReport::summary`], the
//! JSON carries the report).
//!
//! ```
//! use fracbms_host::cycler::{read_record_from, RecordOptions};
//! use std::path::Path;
//!
//! // A BioLogic-style log in mA, with a preamble, a duplicate time stamp
//! // and a slower rest.
//! let log = "EC-Lab ASCII FILE\nNb header lines : 3\n\
//!            time/s\tI/mA\tEwe/V\n0\t0\t3.70\n1\t-500\t3.65\n2\t-500\t3.64\n\
//!            2\t0\t3.68\n3\t0\t3.69\n6\t0\t3.70\n";
//! let r = read_record_from(log.as_bytes(), Path::new("log.mpt"), &RecordOptions::default())?;
//! assert_eq!(r.report.columns.current, "I/mA");
//! assert_eq!(r.record.h, 1.0);
//! assert_eq!(r.record.current[1], -0.5); // A, charge-positive
//! assert_eq!(r.report.resampling.duplicate_times, 1);
//! # Ok::<(), fracbms_host::Error>(())
//! ```

pub mod clock;
pub mod date_time;
pub mod headers;
mod mat;
pub mod resample;
pub mod steps;
mod text;

pub use headers::{ColumnMap, Role, Unit};
pub use resample::{Gap, Resampling};
pub use steps::{ChargeCheck, StateReport, StepReport, StepsMode, Unlogged};

use crate::bail;
use crate::error::{IoContext, Result};
use crate::io::BatteryRecord;
use headers::ColumnChoice;
use serde::{Deserialize, Serialize};
use std::io::Read;
use std::path::Path;

/// The sign of the current in the export.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CurrentSign {
    /// Positive when charging (ours, Arbin's, BioLogic's): read as is.
    #[default]
    ChargePositive,
    /// Positive when discharging (PyBaMM's): negated.
    DischargePositive,
    /// A magnitude, signed by the state column (Maccor's `State` C/D/R):
    /// the default when the current never goes negative and the export has
    /// a state column of letters.
    FromState,
}

impl CurrentSign {
    /// `charge-positive` or `discharge-positive`.
    pub fn as_str(self) -> &'static str {
        match self {
            CurrentSign::ChargePositive => "charge-positive",
            CurrentSign::DischargePositive => "discharge-positive",
            CurrentSign::FromState => "from-state",
        }
    }

    /// What an export's current is multiplied by to read positive
    /// charging: 1 or −1 (1 from a state: the state signs it after).
    pub fn factor(self) -> f64 {
        match self {
            CurrentSign::ChargePositive | CurrentSign::FromState => 1.0,
            CurrentSign::DischargePositive => -1.0,
        }
    }
}

/// How a record is read: the columns, the current's sign, the period.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RecordOptions {
    /// Columns named by their headers; roles left out are recognised.
    pub columns: ColumnMap,
    /// The sign of the export's current (default charge-positive).
    pub current_sign: CurrentSign,
    /// The uniform period (s) the record is put on. Default: a uniform log
    /// is kept as it is; a non-uniform one is resampled at
    /// [`resample::default_period`] (at most [`MAX_SAMPLES`] samples).
    pub period: Option<f64>,
    /// Steps longer than this (s) are reported as gaps (default
    /// max(10 periods, 300 s)).
    pub max_gap: Option<f64>,
    /// In a MAT-file: the struct holding the columns, as a dot path
    /// (`T25.SoC5.Cell1.data`); default: the one struct whose fields name a
    /// time, a current and a voltage. Several, comma-separated, are joined
    /// in that order into one record, each after a gap of at least
    /// 600 s (the pulse records of one test, each at its own
    /// SOC: the SOC is read again from the rested voltage after each gap).
    pub table: Option<String>,
    /// The most samples the caller takes (None: no limit). A uniform log
    /// longer than this is resampled at the period
    /// [`resample::default_period`] chooses for it; a `period` that gives
    /// more is refused. A whole-record fit sets [`MAX_SAMPLES`].
    #[serde(skip)]
    pub max_samples: Option<usize>,
    /// Durations (s) a period chosen from the data is raised to divide,
    /// by at most a quarter ([`resample::dividing_period`]), where it was
    /// raised past the log's own median step to keep within the sample
    /// budget: the state of power's horizons, so that each is whole
    /// samples. A given or uniform period, or a log's own step, is kept.
    #[serde(skip)]
    pub divide_s: Vec<f64>,
    /// Step starts from the step-time column, or without one from the
    /// export's charge count beyond the log's rhythm (`auto`, default);
    /// the count placing every change it dates (`count`); or each row's
    /// current held to the next row (`ignore`).
    pub steps: StepsMode,
    /// The cell's capacity (A·h), if known: the export's charge count is
    /// compared with ours to 0.5 % of it (else to 0.02 A·h).
    pub capacity_ah: Option<f64>,
}

/// The most samples a non-uniform log is resampled to when no period is
/// given (the period is raised to keep within it).
pub const MAX_SAMPLES: usize = 50_000;

/// Lines searched for the header (a BioLogic export has a preamble).
const HEADER_SEARCH_LINES: usize = 200;

/// The columns read, by their headers.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RoleColumns<T> {
    /// The time.
    pub time: T,
    /// The current.
    pub current: T,
    /// The voltage.
    pub voltage: T,
    /// The temperature (null if none).
    pub temperature: Option<T>,
}

/// What [`read_record`] read, and what it did to the rows.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RecordReport {
    /// The row of the header (1-based, as a spreadsheet shows it).
    pub header_row: usize,
    /// The headers of the columns read.
    pub columns: RoleColumns<String>,
    /// Their units.
    pub units: RoleColumns<Unit>,
    /// The sign the current was read with.
    pub current_sign: CurrentSign,
    /// Data rows read.
    pub rows_read: usize,
    /// Samples of the record returned.
    pub samples: usize,
    /// Its period (s).
    pub period_s: f64,
    /// `uniform` (the log's own step), `given` (`--period`) or `chosen`
    /// (from the data: [`resample::default_period`]).
    pub period_source: &'static str,
    /// Whether the rows were resampled.
    pub resampled: bool,
    /// The counts of duplicate, backward, merged and interpolated rows, and
    /// the gaps.
    #[serde(flatten)]
    pub resampling: Resampling,
    /// A warning when the voltage falls where the current rises at most
    /// current steps: the sign is likely the other one.
    pub sign_warning: Option<String>,
    /// For a MAT-file: the struct read (its dot path).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub table: Option<String>,
    /// What the step columns did: where each step began.
    pub steps: StepReport,
    /// Samples inside a step's unlogged start (longer than a period):
    /// their current is known, their voltage is not; no fit counts them.
    pub unobserved_samples: usize,
    /// How the state column signed the current, if there is one.
    pub state: Option<StateReport>,
    /// A warning when the current's sign and the state disagree on more
    /// than 1 % of the loaded rows.
    pub state_warning: Option<String>,
    /// The export's own charge count against ours, if it has one.
    pub charge_check: Option<ChargeCheck>,
    /// A warning when the two counts part by more than 0.5 % of the
    /// capacity (0.02 A·h without one).
    pub charge_warning: Option<String>,
    /// Headers of the load's or the charger's columns, not read (NASA
    /// PCoE's `Current_load`, `Voltage_load`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub not_the_cell: Vec<String>,
}

impl RecordReport {
    /// One line: which columns, units and sign were read.
    pub fn summary(&self, path: &Path) -> String {
        let col = |h: &str, u: Unit| format!("`{h}` ({u})");
        let temp = match (&self.columns.temperature, self.units.temperature) {
            (Some(h), Some(u)) => format!(", temperature {}", col(h, u)),
            _ => ", no temperature".to_string(),
        };
        let at = match &self.table {
            Some(t) if t.contains(',') => format!(
                "{} MAT tables joined in this order, each after a gap of at least {:.0} s (rest assumed, the SOC read again after it): `{}`",
                t.split(',').count(),
                mat::JOIN_GAP_S,
                t.replace(',', "`, `")
            ),
            Some(t) => format!("MAT table `{t}`"),
            None => format!("row {}", self.header_row + 1),
        };
        let sign = match &self.state {
            Some(s) if s.signs_current => format!("from-state `{}`", s.column),
            _ => self.current_sign.as_str().to_string(),
        };
        let steps = self.steps.read_line(self.unobserved_samples);
        let others = match self.not_the_cell.as_slice() {
            [] => String::new(),
            h => {
                let whose = if h.iter().all(|h| h.to_lowercase().contains("load")) {
                    "the load's"
                } else if h.iter().all(|h| h.to_lowercase().contains("charge")) {
                    "the charger's"
                } else {
                    "the load's and the charger's"
                };
                format!(
                    "; {}: {whose}, not the cell's (not read)",
                    h.iter()
                        .map(|h| format!("`{h}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            }
        };
        format!(
            "read {}: {} rows from {at}: time {}, current {} {sign}, voltage {}{temp}{steps}{others}",
            path.display(),
            self.rows_read,
            col(&self.columns.time, self.units.time),
            col(&self.columns.current, self.units.current),
            col(&self.columns.voltage, self.units.voltage),
        )
    }

    /// Which samples at `time` (period `h`) are unobserved: inside a step's
    /// unlogged start longer than `h` ([`steps::unobserved`]).
    pub fn unobserved(&self, h: f64, time: &[f64]) -> Vec<bool> {
        steps::unobserved(&self.steps.unlogged, h, time)
    }

    /// The warnings on the record, one line each: the sign, the state,
    /// the charge count.
    pub fn warnings(&self) -> impl Iterator<Item = &String> {
        [
            &self.sign_warning,
            &self.state_warning,
            &self.charge_warning,
        ]
        .into_iter()
        .flatten()
    }

    /// One line on the period and the rows merged, interpolated and
    /// dropped, when the log was not uniform (None otherwise).
    pub fn resampling_line(&self) -> Option<String> {
        let r = &self.resampling;
        if !self.resampled && r.duplicate_times == 0 && r.backward_times == 0 {
            return None;
        }
        let how = match self.period_source {
            "chosen" => " (chosen from the data; --period to set it)",
            "given" => " (--period)",
            _ => "",
        };
        let mut s = format!(
            "resampled at {} s{how}: {} samples; {} rows merged, {} samples interpolated, {} duplicate and {} backward time stamps dropped",
            self.period_s,
            self.samples,
            r.rows_merged,
            r.rows_interpolated,
            r.duplicate_times,
            r.backward_times
        );
        if !r.gaps.is_empty() {
            let g = r.gaps.iter().map(|g| g.length_s).fold(0.0, f64::max);
            s += &format!(
                "; {} gaps over {} s (longest {g} s)",
                r.gaps.len(),
                r.gap_threshold_s
            );
        }
        Some(s)
    }
}

/// A record read from a cycler export.
#[derive(Debug)]
pub struct CyclerRecord {
    /// Time, current (A, + charging), voltage (V) on a uniform period.
    pub record: BatteryRecord,
    /// The temperature (°C) at each sample, if the export has it.
    pub temperature: Option<Vec<f64>>,
    /// What was read, and what was done to the rows.
    pub report: RecordReport,
    /// The log's own rows (time order, duplicates and backward rows
    /// dropped; SI, the sign applied), before the uniform period: a part
    /// of the record can be put on a finer period than the whole
    /// ([`CyclerRecord::part`]).
    pub rows: BatteryRecord,
}

impl CyclerRecord {
    /// The log's rows from `t0` to `t1` (s) on their own uniform period
    /// ([`part_of`]).
    pub fn part(&self, t0: f64, t1: f64, max_samples: usize) -> BatteryRecord {
        part_of(&self.rows, self.record.h, t0, t1, max_samples)
    }
}

/// A log's `rows` from `t0` to `t1` (s) on their own uniform period: the
/// median step there, raised to keep within `max_samples` (as
/// [`resample::default_period`] chooses), at most `h_max`; the current
/// charge-preserving, the voltage at the instants, as a whole record's.
/// Empty when fewer than two rows fall in the range.
pub fn part_of(
    rows: &BatteryRecord,
    h_max: f64,
    t0: f64,
    t1: f64,
    max_samples: usize,
) -> BatteryRecord {
    let keep: Vec<usize> = (0..rows.time.len())
        .filter(|&i| rows.time[i] >= t0 && rows.time[i] <= t1)
        .collect();
    if keep.len() < 2 {
        return BatteryRecord {
            time: vec![],
            current: vec![],
            voltage: vec![],
            h: h_max,
        };
    }
    let t: Vec<f64> = keep.iter().map(|&i| rows.time[i]).collect();
    let h = resample::default_period(&t, max_samples).min(h_max);
    let mut scratch = Resampling {
        gap_threshold_s: f64::INFINITY,
        ..Resampling::default()
    };
    let u = resample::to_uniform(
        &rows.time,
        &rows.current,
        &rows.voltage,
        None,
        &keep,
        h,
        &mut scratch,
    );
    BatteryRecord {
        time: u.time,
        current: u.current,
        voltage: u.voltage,
        h,
    }
}

/// Reads a cycler export (CSV, or tab- or semicolon-separated text) as `o`
/// says.
///
/// # Errors
/// [`crate::ErrorKind::Io`] when the file cannot be read;
/// [`crate::ErrorKind::Data`] with one line naming the file, the row and
/// the column (and, for a missing or ambiguous column, the header found);
/// [`crate::ErrorKind::Options`] for a period that is not positive.
pub fn read_record(path: &Path, o: &RecordOptions) -> Result<CyclerRecord> {
    let file =
        std::fs::File::open(path).io_context(|| format!("{}: cannot open", path.display()))?;
    // A file reads whole into a buffer of its length (`File::read_to_end`).
    read_record_from(file, path, o)
}

/// [`read_record`] on any reader; `path` only names the data in the
/// errors.
pub fn read_record_from(
    mut reader: impl Read,
    path: &Path,
    o: &RecordOptions,
) -> Result<CyclerRecord> {
    check_options(o)?;
    let mut bytes = Vec::new();
    reader
        .read_to_end(&mut bytes)
        .io_context(|| format!("{}: cannot read", path.display()))?;
    if bytes.starts_with(mat::MAGIC) {
        return mat::read(&bytes, path, o);
    }
    text::refuse_binary(&bytes, path)?;
    let (header_row, start, delimiter, choice) = text::find_header(&bytes, path, &o.columns)?;
    let raw = text::read_rows(
        &bytes[start..],
        header_row,
        delimiter,
        &choice,
        path,
        o.current_sign,
    )?;
    finish(raw, header_row, &choice, path, o)
}

/// The columns as read, in SI units, with the spreadsheet row of each.
/// A record given as arrays (the Python and C faces): read as a file
/// `time_s,current_a,voltage_v` with its header on row 1 would be, so that
/// a non-uniform time is put on a uniform period the same way and the
/// report is the same. `path` names the record in errors.
///
/// # Errors
/// [`crate::ErrorKind::Data`] for arrays of different lengths, a time that
/// is not finite, fewer than 2 rows, a time going backwards; as
/// [`read_record_from`] for the options.
///
/// ```
/// use fracbms_host::cycler::{record_from_arrays, RecordOptions};
/// use std::path::Path;
///
/// // 1 s steps with one row missing: put on 1 s, the charge kept.
/// let t = [0.0, 1.0, 2.0, 4.0, 5.0];
/// let r = record_from_arrays(Path::new("record"), &t, &[1.0; 5], &[3.7; 5], &RecordOptions::default())?;
/// assert_eq!(r.record.time, vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
/// assert_eq!(r.report.resampling.rows_interpolated, 1);
/// # Ok::<(), fracbms_host::Error>(())
/// ```
pub fn record_from_arrays(
    path: &Path,
    time: &[f64],
    current: &[f64],
    voltage: &[f64],
    o: &RecordOptions,
) -> Result<CyclerRecord> {
    check_options(o)?;
    if time.len() != current.len() || time.len() != voltage.len() {
        bail!(
            Data,
            "{}: columns time_s, current_a, voltage_v have {}, {}, {} values",
            path.display(),
            time.len(),
            current.len(),
            voltage.len()
        );
    }
    if let Some(k) = time.iter().position(|t| !t.is_finite()) {
        bail!(
            Data,
            "{}: row {}, column `time_s`: `{}` is not finite",
            path.display(),
            k + 2,
            time[k]
        );
    }
    let s = o.current_sign.factor();
    let raw = RawRows {
        time: time.to_vec(),
        current: current.iter().map(|i| s * i).collect(),
        voltage: voltage.to_vec(),
        temperature: None,
        rows: (2..time.len() + 2).collect(),
        clock_time: false,
        extra: steps::Extra::default(),
    };
    let chosen = |index: usize, header: &str, unit: Unit| headers::Chosen {
        index,
        header: header.to_string(),
        unit,
        unit_stated: true,
    };
    let choice = ColumnChoice {
        time: chosen(0, "time_s", Unit::Second),
        current: chosen(1, "current_a", Unit::Ampere),
        voltage: chosen(2, "voltage_v", Unit::Volt),
        temperature: None,
        step: None,
        step_time: None,
        state: None,
        charge: None,
        discharge_charge: None,
        not_the_cell: vec![],
    };
    finish(raw, 1, &choice, path, o)
}

fn check_options(o: &RecordOptions) -> Result<()> {
    if let Some(c) = o.capacity_ah {
        if !(c.is_finite() && c > 0.0) {
            bail!(Options, "--capacity-ah must be positive (got {c})");
        }
    }
    if let Some(h) = o.period {
        if !(h.is_finite() && h > 0.0) {
            bail!(Options, "--period must be positive and finite (got {h})");
        }
    }
    if let Some(g) = o.max_gap {
        if g.is_nan() || g <= 0.0 {
            bail!(Options, "--max-gap must be positive (got {g})");
        }
    }
    Ok(())
}

struct RawRows {
    time: Vec<f64>,
    current: Vec<f64>,
    voltage: Vec<f64>,
    temperature: Option<Vec<f64>>,
    rows: Vec<usize>,
    clock_time: bool,
    extra: steps::Extra,
}

/// Cleans the rows, decides the period and resamples when needed.
fn finish(
    mut raw: RawRows,
    header_row: usize,
    c: &ColumnChoice,
    path: &Path,
    o: &RecordOptions,
) -> Result<CyclerRecord> {
    let n = raw.time.len();
    if n < 2 {
        bail!(
            Data,
            "{}: {n} data rows; at least 2 are needed",
            path.display()
        );
    }
    let mut r = Resampling::default();
    let keep = resample::clean(&raw.time, &mut r);
    // A few rows out of order are a logger's hiccup; many are a time that
    // restarts (a step time, files joined): not to be dropped silently.
    if r.backward_times > n / 100 {
        let first = (1..n)
            .find(|&i| raw.time[i] < raw.time[..i].iter().copied().fold(f64::MIN, f64::max))
            .unwrap_or(1);
        bail!(
            Data,
            "{}: row {}, column `{}`: time goes back at {} of {n} rows ({} after {}); is it the test's time? Name it with --columns time=COL",
            path.display(),
            raw.rows[first],
            c.time.header,
            r.backward_times,
            raw.time[first],
            raw.time[..first].iter().copied().fold(f64::MIN, f64::max)
        );
    }
    if keep.len() < 2 {
        bail!(
            Data,
            "{}: column `{}`: all {n} rows have one time stamp",
            path.display(),
            c.time.header
        );
    }
    // The current signed by the state, then the step starts put in.
    let state = match &c.state {
        Some(ch) => steps::sign_from_state(
            &mut raw,
            &ch.header,
            o.current_sign == CurrentSign::FromState,
            path,
        )?,
        None => None,
    };
    if o.current_sign == CurrentSign::FromState && state.is_none() {
        bail!(
            Options,
            "{}: --current-sign from-state: no state column of letters (C/D/R) found; name it with --columns state=COL",
            path.display()
        );
    }
    let (mut raw, mut step_report) = steps::place_starts(raw, &keep, o.steps, c, path)?;
    let keep: Vec<usize> = (0..raw.time.len()).collect();
    let kept_uniform = resample::uniform(&raw.time, &keep);
    let span = raw.time[keep[keep.len() - 1]] - raw.time[keep[0]];
    let limit = o.max_samples.unwrap_or(usize::MAX);
    let chosen = || {
        let t: Vec<f64> = keep.iter().map(|&i| raw.time[i]).collect();
        let h = resample::chosen_period(&t, limit.min(MAX_SAMPLES), &o.divide_s);
        (h, "chosen")
    };
    let (h, source) = match (o.period, kept_uniform) {
        (Some(h), Some(u)) if (h - u).abs() <= 1e-6 * u => (u, "uniform"),
        (Some(h), _) => (h, "given"),
        (None, Some(_)) if keep.len() > limit => chosen(),
        (None, Some(u)) => (u, "uniform"),
        (None, None) => chosen(),
    };
    // A chosen period keeps within the limit (to one sample, where span/h
    // is whole); a given one may not.
    if source == "given" {
        resample::check_given_period(h, span, limit)?;
    }
    r.gap_threshold_s = o.max_gap.unwrap_or((10.0 * h).max(300.0));
    let resampled = source != "uniform";
    if let (true, "rows", Some(ch)) = (resampled, step_report.starts_from, &c.charge) {
        let everywhere = o.steps == StepsMode::Count;
        let limits = (h, r.gap_threshold_s);
        steps::place_starts_from_count(&mut raw, limits, everywhere, &ch.header, &mut step_report);
    }
    let keep: Vec<usize> = (0..raw.time.len()).collect();
    let (time, current, voltage, temperature) = if resampled {
        let u = resample::to_uniform(
            &raw.time,
            &raw.current,
            &raw.voltage,
            raw.temperature.as_deref(),
            &keep,
            h,
            &mut r,
        );
        if u.time.len() < 2 {
            bail!(
                Data,
                "{}: the record spans {} s: less than one period of {h} s",
                path.display(),
                raw.time[keep[keep.len() - 1]] - raw.time[keep[0]]
            );
        }
        (u.time, u.current, u.voltage, u.temperature)
    } else {
        let pick = |col: &[f64]| keep.iter().map(|&i| col[i]).collect::<Vec<f64>>();
        (
            pick(&raw.time),
            pick(&raw.current),
            pick(&raw.voltage),
            raw.temperature.as_deref().map(pick),
        )
    };
    let magnitude = !state.as_ref().is_some_and(|s| s.signs_current)
        && raw.current.iter().all(|&i| i >= 0.0 || i.is_nan());
    let sign_warning = sign_warning(&current, &voltage, o.current_sign);
    if let (true, Some(w), CurrentSign::ChargePositive) = (magnitude, &sign_warning, o.current_sign)
    {
        bail!(
            Data,
            "{}: column `{}`: the current is never negative and {w}; a magnitude needs a state column (--columns state=COL, --current-sign from-state)",
            path.display(),
            c.current.header
        );
    }
    let state_warning = state.as_ref().and_then(|s| {
        (!s.signs_current && s.disagreeing_rows * 100 > s.loaded_rows).then(|| {
            format!(
                "the current's sign and the state `{}` disagree at {} of {} loaded rows (a charge with a negative current or a discharge with a positive one); is the current a magnitude? (--current-sign from-state)",
                s.column, s.disagreeing_rows, s.loaded_rows
            )
        })
    });
    let charge_check = c.charge.as_ref().and_then(|ch| {
        let name = match &c.discharge_charge {
            Some(d) => format!("{} − {}", ch.header, d.header),
            None => ch.header.clone(),
        };
        steps::charge_check(&raw, &name, r.gap_threshold_s)
    });
    let resets = charge_check.as_ref().map_or(usize::MAX, |k| k.resets);
    let charges = steps::gap_charges(&raw, &r.gaps, resets);
    for (g, q) in r.gaps.iter_mut().zip(charges) {
        g.charge_ah = q;
    }
    let charge_warning = charge_check.as_ref().and_then(|k| {
        let (limit, of) = match o.capacity_ah {
            Some(q) => (0.005 * q, format!("0.5 % of the capacity {q} A·h")),
            None => (0.02, "0.02 A·h (no capacity given)".to_string()),
        };
        // Where the count could date the changes within the log's rhythm.
        let steps = match (o.steps, &step_report.charge_column) {
            (StepsMode::Auto, Some(_)) => "--steps count",
            _ => "--steps",
        };
        (k.max_gap_ah > limit).then(|| {
            format!(
                "the export's own charge `{}` and ours part by up to {:.4} A·h (over the record: ours {:.4} A·h, theirs {:.4} A·h), more than {of}: are the step starts or the current's sign read right? ({steps}, --current-sign)",
                k.column, k.max_gap_ah, k.ours_ah, k.theirs_ah
            )
        })
    });
    let unobserved_samples = steps::unobserved(&step_report.unlogged, h, &time)
        .iter()
        .filter(|&&u| u)
        .count();
    let mut units = RoleColumns {
        time: c.time.unit,
        current: c.current.unit,
        voltage: c.voltage.unit,
        temperature: c.temperature.as_ref().map(|t| t.unit),
    };
    if raw.clock_time {
        units.time = Unit::Clock;
    }
    let report = RecordReport {
        header_row,
        columns: RoleColumns {
            time: c.time.header.clone(),
            current: c.current.header.clone(),
            voltage: c.voltage.header.clone(),
            temperature: c.temperature.as_ref().map(|t| t.header.clone()),
        },
        units,
        current_sign: match &state {
            Some(s) if s.signs_current => CurrentSign::FromState,
            _ => o.current_sign,
        },
        rows_read: n,
        samples: time.len(),
        period_s: h,
        period_source: source,
        resampled,
        resampling: r,
        sign_warning,
        table: None,
        steps: step_report,
        unobserved_samples,
        state,
        state_warning,
        charge_check,
        charge_warning,
        not_the_cell: c.not_the_cell.clone(),
    };
    let pick = |col: &[f64]| keep.iter().map(|&i| col[i]).collect::<Vec<f64>>();
    let rows = BatteryRecord {
        time: pick(&raw.time),
        current: pick(&raw.current),
        voltage: pick(&raw.voltage),
        h,
    };
    Ok(CyclerRecord {
        record: BatteryRecord {
            time,
            current,
            voltage,
            h,
        },
        temperature,
        report,
        rows,
    })
}

/// A warning when, at most of the record's current steps (a change of at
/// least a tenth of the largest |I| from one sample to the next), the
/// voltage moves against the current: with the sign read, a cell's
/// voltage rises with a charging current.
fn sign_warning(current: &[f64], voltage: &[f64], sign: CurrentSign) -> Option<String> {
    let big = current
        .iter()
        .filter(|x| x.is_finite())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    if big <= 0.0 {
        return None;
    }
    let (mut with, mut against) = (0usize, 0usize);
    for k in 1..current.len() {
        let di = current[k] - current[k - 1];
        let dv = voltage[k] - voltage[k - 1];
        if di.is_finite() && dv.is_finite() && di.abs() >= 0.1 * big && dv != 0.0 {
            if di * dv > 0.0 {
                with += 1;
            } else {
                against += 1;
            }
        }
    }
    (against >= 3 && against > 2 * with).then(|| {
        let other = match sign {
            CurrentSign::ChargePositive | CurrentSign::FromState => "discharge-positive",
            CurrentSign::DischargePositive => "charge-positive",
        };
        format!(
            "the voltage moves against the current at {against} of {} current steps: is the export's current {other}? (--current-sign {other})",
            against + with
        )
    })
}

#[cfg(test)]
mod tests;
