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

pub mod headers;
mod mat;
pub mod resample;

pub use headers::{ColumnMap, Role, Unit};
pub use resample::{Gap, Resampling};

use crate::error::{IoContext, Result};
use crate::io::{shown, BatteryRecord, LineCounter};
use crate::{bail, err};
use headers::{ChoiceError, Chosen, ColumnChoice};
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
}

impl CurrentSign {
    /// `charge-positive` or `discharge-positive`.
    pub fn as_str(self) -> &'static str {
        match self {
            CurrentSign::ChargePositive => "charge-positive",
            CurrentSign::DischargePositive => "discharge-positive",
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
    /// time, a current and a voltage.
    pub table: Option<String>,
    /// The most samples the caller takes (None: no limit). A uniform log
    /// longer than this is resampled at the period
    /// [`resample::default_period`] chooses for it; a `period` that gives
    /// more is refused. A whole-record fit sets [`MAX_SAMPLES`].
    #[serde(skip)]
    pub max_samples: Option<usize>,
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
            Some(t) => format!("MAT table `{t}`"),
            None => format!("row {}", self.header_row + 1),
        };
        format!(
            "read {}: {} rows from {at}: time {}, current {} {}, voltage {}{temp}",
            path.display(),
            self.rows_read,
            col(&self.columns.time, self.units.time),
            col(&self.columns.current, self.units.current),
            self.current_sign.as_str(),
            col(&self.columns.voltage, self.units.voltage),
        )
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
    read_record_from(std::io::BufReader::new(file), path, o)
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
    let (header_row, start, delimiter, choice) = find_header(&bytes, path, &o.columns)?;
    let raw = read_rows(
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
/// assert_eq!(r.report.rows_interpolated, 1);
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
    let s = match o.current_sign {
        CurrentSign::ChargePositive => 1.0,
        CurrentSign::DischargePositive => -1.0,
    };
    let raw = RawRows {
        time: time.to_vec(),
        current: current.iter().map(|i| s * i).collect(),
        voltage: voltage.to_vec(),
        temperature: None,
        rows: (2..time.len() + 2).collect(),
        clock_time: false,
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
    };
    finish(raw, 1, &choice, path, o)
}

fn check_options(o: &RecordOptions) -> Result<()> {
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
}

type HeaderFound = (usize, usize, u8, ColumnChoice);

/// The header line: the first of the first lines whose cells (split at
/// `,`, tab or `;`) name the columns. Returns its row, the byte after it,
/// the delimiter and the choice.
fn find_header(bytes: &[u8], path: &Path, map: &ColumnMap) -> Result<HeaderFound> {
    let mut first: Option<(usize, Vec<String>, ChoiceError)> = None;
    let mut at = 0usize;
    let mut row = 0usize;
    while at < bytes.len() && row < HEADER_SEARCH_LINES {
        row += 1;
        let end = bytes[at..]
            .iter()
            .position(|&c| c == b'\n' || c == b'\r')
            .map_or(bytes.len(), |p| at + p);
        let line = &bytes[at..end];
        // The next line starts after "\n", "\r\n" or a lone "\r".
        let mut next = end;
        if next < bytes.len() && bytes[next] == b'\r' {
            next += 1;
        }
        if next < bytes.len() && bytes[next] == b'\n' {
            next += 1;
        }
        let line = line.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(line);
        if !line.iter().all(u8::is_ascii_whitespace) {
            let mut best: Option<(Vec<String>, ChoiceError)> = None;
            for delimiter in [b',', b'\t', b';'] {
                let cells = split_line(line, delimiter);
                match headers::choose(&cells, map) {
                    Ok(choice) => return Ok((row, next, delimiter, choice)),
                    Err(e @ ChoiceError::Ambiguous { .. }) => {
                        bail!(
                            Data,
                            "{}: row {row}: {e} (header: {})",
                            path.display(),
                            listed(&cells)
                        )
                    }
                    Err(e) => {
                        if best.as_ref().is_none_or(|(c, _)| cells.len() > c.len()) {
                            best = Some((cells, e));
                        }
                    }
                }
            }
            if first
                .as_ref()
                .is_none_or(|(_, c, _)| best.as_ref().is_some_and(|(b, _)| b.len() > c.len()))
            {
                first = Some(match best {
                    Some((c, e)) => (row, c, e),
                    None => (
                        row,
                        split_line(line, b','),
                        ChoiceError::Missing {
                            role: Role::Time,
                            asked: None,
                        },
                    ),
                });
            }
        }
        at = next;
    }
    match first {
        Some((row, cells, e)) => bail!(
            Data,
            "{}: row {row}: {e} (header: {})",
            path.display(),
            listed(&cells)
        ),
        None => bail!(Data, "{}: the file is empty", path.display()),
    }
}

/// The cells of one line, unquoted and trimmed.
fn split_line(line: &[u8], delimiter: u8) -> Vec<String> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .delimiter(delimiter)
        .flexible(true)
        .from_reader(line);
    let mut rec = csv::ByteRecord::new();
    match rdr.read_byte_record(&mut rec) {
        Ok(true) => rec
            .iter()
            .map(|c| String::from_utf8_lossy(c).trim().to_string())
            .collect(),
        _ => Vec::new(),
    }
}

/// A header as an error lists it: at most 24 cells, each quoted.
fn listed(cells: &[String]) -> String {
    let mut s: Vec<String> = cells
        .iter()
        .take(24)
        .map(|c| format!("`{}`", shown(c)))
        .collect();
    if cells.len() > 24 {
        s.push(format!("… ({} columns)", cells.len()));
    }
    s.join(", ")
}

/// The data rows below the header, the chosen columns parsed and
/// converted to SI (°C for the temperature).
fn read_rows(
    data: &[u8],
    header_row: usize,
    delimiter: u8,
    c: &ColumnChoice,
    path: &Path,
    sign: CurrentSign,
) -> Result<RawRows> {
    let mut lines = LineCounter::new(data);
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .delimiter(delimiter)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(data);
    let mut out = RawRows {
        time: Vec::new(),
        current: Vec::new(),
        voltage: Vec::new(),
        temperature: c.temperature.as_ref().map(|_| Vec::new()),
        rows: Vec::new(),
        clock_time: false,
    };
    let s = match sign {
        CurrentSign::ChargePositive => 1.0,
        CurrentSign::DischargePositive => -1.0,
    };
    let mut rec = csv::ByteRecord::new();
    loop {
        let row = match rdr.read_byte_record(&mut rec) {
            Ok(false) => break,
            Ok(true) => header_row + lines.row(rec.position()),
            Err(e) => bail!(
                Data,
                "{}: row {}: malformed CSV ({e})",
                path.display(),
                header_row + lines.row(e.position())
            ),
        };
        let cell = |ch: &Chosen| -> Result<&str> {
            let b = rec.get(ch.index).ok_or_else(|| {
                err!(
                    Data,
                    "{}: row {row}: {} cells; column `{}` is cell {}",
                    path.display(),
                    rec.len(),
                    ch.header,
                    ch.index + 1
                )
            })?;
            std::str::from_utf8(b).map_err(|_| {
                err!(
                    Data,
                    "{}: row {row}, column `{}`: not UTF-8 text",
                    path.display(),
                    ch.header
                )
            })
        };
        let not_a_number = |ch: &Chosen, x: &str| {
            err!(
                Data,
                "{}: row {row}, column `{}`: `{}` is not a number",
                path.display(),
                ch.header,
                shown(x)
            )
        };
        let number = |ch: &Chosen| -> Result<f64> {
            let x = cell(ch)?;
            x.parse::<f64>()
                .map(|v| ch.unit.to_si(v))
                .map_err(|_| not_a_number(ch, x))
        };
        let tx = cell(&c.time)?;
        let t = headers::parse_time(tx, c.time.unit).ok_or_else(|| not_a_number(&c.time, tx))?;
        if !t.is_finite() {
            bail!(
                Data,
                "{}: row {row}, column `{}`: `{t}` is not finite",
                path.display(),
                c.time.header,
            );
        }
        if out.rows.is_empty() && tx.parse::<f64>().is_err() {
            out.clock_time = true;
        }
        out.time.push(t);
        out.current.push(s * number(&c.current)?);
        out.voltage.push(number(&c.voltage)?);
        if let (Some(ch), Some(v)) = (&c.temperature, out.temperature.as_mut()) {
            // An empty temperature cell is a missing reading, not an error.
            let x = cell(ch)?;
            v.push(if x.is_empty() {
                f64::NAN
            } else {
                x.parse::<f64>()
                    .map(|v| ch.unit.to_si(v))
                    .map_err(|_| not_a_number(ch, x))?
            });
        }
        out.rows.push(row);
    }
    Ok(out)
}

/// Cleans the rows, decides the period and resamples when needed.
fn finish(
    raw: RawRows,
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
    let kept_uniform = resample::uniform(&raw.time, &keep);
    let span = raw.time[keep[keep.len() - 1]] - raw.time[keep[0]];
    let limit = o.max_samples.unwrap_or(usize::MAX);
    let chosen = || {
        let t: Vec<f64> = keep.iter().map(|&i| raw.time[i]).collect();
        (
            resample::default_period(&t, limit.min(MAX_SAMPLES)),
            "chosen",
        )
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
    let samples = (span / h) as usize + 1;
    if source == "given" && samples > limit {
        bail!(
            Options,
            "--period {h}: {samples} samples over the record's {span} s; at most {limit} are taken (a longer period)"
        );
    }
    r.gap_threshold_s = o.max_gap.unwrap_or((10.0 * h).max(300.0));
    let resampled = source != "uniform";
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
    let sign_warning = sign_warning(&current, &voltage, o.current_sign);
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
        current_sign: o.current_sign,
        rows_read: n,
        samples: time.len(),
        period_s: h,
        period_source: source,
        resampled,
        resampling: r,
        sign_warning,
        table: None,
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
            CurrentSign::ChargePositive => "discharge-positive",
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
