//! A cell's life: many logs of one cell through one online estimator, in
//! the order they were taken, its state carried from each to the next
//! exactly as `--state-out` and `--state-in` carry it ([`life()`]), and one
//! row per log of what it published ([`LifeRow`], `--life-out`).
//!
//! The order is the logs' start times (`--start-times FILE.csv`, columns
//! `file,start_time`, ISO 8601), else the date and time of each log's
//! first row where every log has an absolute time column
//! ([`crate::cycler::clock`]), else the files' names. The time between
//! two logs is a gap the cell rested through: the snapshot is aged by it
//! (the core's [`estimator_core::battery::snapshot::RestorePolicy`]), so
//! after more than a minute the state of charge is read again from the
//! next rested voltage (with an OCV table). Without any start time each
//! log is taken to start an hour after the one before ended.
//!
//! It owns the order, the carrying and the rows; it must not change how
//! one log is run ([`super::battery_file`]'s options apply to each).

use super::file::battery_run;
pub use super::log_tally::{capacity_check, FileTally, FULL_DISCHARGE_MARGIN_V};
use super::*;
use crate::identify::many::{expand_inputs, outputs_in};

/// The time assumed between two logs without start times (s).
pub const UNKNOWN_GAP_S: f64 = 3600.0;

use crate::cycler::clock::{log_start, LogStart};
pub use crate::cycler::date_time::parse_start_time;
use crate::cycler::RecordOptions;

/// One log of a life (a row of `--life-out`).
#[derive(Clone, Debug, PartialEq)]
pub struct LifeRow {
    /// The log's path, as listed.
    pub file: PathBuf,
    /// Its start time as the `--start-times` table gave it, or its first
    /// row's date and time (ISO 8601).
    pub start_time: Option<String>,
    /// Samples run.
    pub samples: usize,
    /// The log's counted discharge and charge (A·h).
    pub discharged_ah: Option<f64>,
    /// See [`LifeRow::discharged_ah`].
    pub charged_ah: Option<f64>,
    /// The median R_i its windows identified (Ω), and the status
    /// (`identified`; else the status at its end; `error`).
    pub r_i: Option<f64>,
    /// See [`LifeRow::r_i`].
    pub r_i_status: &'static str,
    /// The median R_ct identified (Ω).
    pub r_ct: Option<f64>,
    /// The median α identified.
    pub alpha: Option<f64>,
    /// The capacity published at the log's end (A·h; with an OCV table).
    pub capacity_ah: Option<f64>,
    /// Its status (`identified`, `not_identified`; empty without a table;
    /// `error`).
    pub capacity_status: &'static str,
    /// Where `capacity_ah` comes from: `full_discharge` (the log is a
    /// capacity check, [`FileTally::full_discharge`]: its counted
    /// discharge), `observer` (the SOC observer's), empty (none).
    pub capacity_source: &'static str,
    /// `capacity_ah` over the first log's that has one.
    pub soh_c: Option<f64>,
    /// `r_i` over the first log's that has one.
    pub soh_r: Option<f64>,
    /// Why the log could not be run (its row is otherwise empty).
    pub error: Option<String>,
}

/// The columns of `--life-out`.
pub const LIFE_HEADER: &str = "file,start_time,samples,discharged_ah,charged_ah,r_i,r_i_status,r_ct,alpha,capacity_ah,capacity_status,soh_c,soh_r,error,capacity_source";

impl LifeRow {
    /// The row's cells in [`LIFE_HEADER`]'s order.
    fn cells(&self) -> Vec<String> {
        let n = |x: Option<f64>| x.map_or(String::new(), |x| format!("{x:.9e}"));
        vec![
            self.file.display().to_string(),
            self.start_time.clone().unwrap_or_default(),
            self.samples.to_string(),
            n(self.discharged_ah),
            n(self.charged_ah),
            n(self.r_i),
            self.r_i_status.to_string(),
            n(self.r_ct),
            n(self.alpha),
            n(self.capacity_ah),
            self.capacity_status.to_string(),
            n(self.soh_c),
            n(self.soh_r),
            self.error.clone().unwrap_or_default(),
            self.capacity_source.to_string(),
        ]
    }
}

/// Writes the rows of a life (`--life-out`, columns [`LIFE_HEADER`]).
///
/// # Errors
/// A file that cannot be written.
pub fn write_life_csv(path: &Path, rows: &[LifeRow]) -> Result<()> {
    let header: Vec<&str> = LIFE_HEADER.split(',').collect();
    io::write_csv(path, &header, rows.iter().map(LifeRow::cells))
}

/// Draws a life (`--life-plot`): the counted discharge and the capacity
/// published, and R_i, against the log's place in the life (1, 2, …).
///
/// # Errors
/// A file that cannot be written.
pub fn plot_life(path: &Path, rows: &[LifeRow]) -> Result<()> {
    use crate::plot::{panels, Panel, Series};
    let at = |f: fn(&LifeRow) -> Option<f64>| {
        rows.iter()
            .enumerate()
            .filter_map(|(k, r)| f(r).map(|y| ((k + 1) as f64, y)))
            .collect::<Vec<_>>()
    };
    panels(
        path,
        &[
            Panel {
                title: "capacity over life",
                x: "log",
                y: "A·h",
                series: vec![
                    Series {
                        label: "discharged_ah (counted)",
                        points: at(|r| r.discharged_ah),
                        color: 0,
                    },
                    Series {
                        label: "capacity_ah (published at the log's end)",
                        points: at(|r| r.capacity_ah),
                        color: 1,
                    },
                ],
                log_y: false,
            },
            Panel {
                title: "resistance over life",
                x: "log",
                y: "Ω",
                series: vec![
                    Series {
                        label: "r_i (median identified in the log)",
                        points: at(|r| r.r_i),
                        color: 2,
                    },
                    Series {
                        label: "r_ct (median identified in the log)",
                        points: at(|r| r.r_ct),
                        color: 3,
                    },
                ],
                log_y: false,
            },
        ],
    )
}

/// The start times of a `--start-times` table (`file,start_time`, ISO
/// 8601; more columns are ignored), by file name as the table spells it.
///
/// # Errors
/// A table that cannot be read, has no such columns, or a time that does
/// not parse: one line naming the row.
pub fn read_start_times(path: &Path) -> Result<Vec<(String, String, f64)>> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| err!(Io, "--start-times {}: {e}", path.display()))?;
    let mut lines = text.lines().enumerate();
    let header: Vec<String> = lines
        .next()
        .map(|(_, h)| h.split(',').map(|c| c.trim().to_lowercase()).collect())
        .unwrap_or_default();
    let col = |name: &str| header.iter().position(|h| h == name);
    let (Some(fc), Some(tc)) = (col("file"), col("start_time")) else {
        bail!(
            Data,
            "--start-times {}: no `file` and `start_time` columns in its header",
            path.display()
        );
    };
    let mut out = vec![];
    for (k, line) in lines.filter(|(_, l)| !l.trim().is_empty()) {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let (Some(f), Some(t)) = (cells.get(fc), cells.get(tc)) else {
            bail!(
                Data,
                "--start-times {}: row {}: fewer cells than the header",
                path.display(),
                k + 1
            );
        };
        let Some(s) = parse_start_time(t) else {
            bail!(
                Data,
                "--start-times {}: row {}: `{t}` is not an ISO 8601 time (YYYY-MM-DDTHH:MM:SS)",
                path.display(),
                k + 1
            );
        };
        out.push((f.to_string(), t.to_string(), s));
    }
    Ok(out)
}

/// A log and its start time: as the table wrote it (or ISO 8601 of its
/// first row's date and time), and in seconds since 1970 (`None` without
/// either).
pub type TimedLog = (PathBuf, Option<(String, f64)>);

/// The logs of `input` (a directory or a pattern,
/// [`crate::identify::many::expand_inputs`]) in the order they were taken,
/// each with its start time: by the `start_times` table (a file matches a
/// row by its path as listed or by its name), else by the date and time of
/// each log's first row when every log has an absolute time column
/// ([`crate::cycler::clock::log_start`], its header chosen as `record`
/// says), else by name. `note` says which.
///
/// # Errors
/// No files, or a file the table has no time for.
pub fn ordered_logs(
    input: &Path,
    start_times: Option<&Path>,
    record: &RecordOptions,
    note: impl FnMut(String),
) -> Result<Vec<TimedLog>> {
    order_logs(expand_inputs(input)?, input, start_times, record, note)
}

/// [`ordered_logs`] of the files listed (`input` names them in `note`).
///
/// # Errors
/// A file the table has no time for, a table that cannot be read.
pub fn order_logs(
    files: Vec<PathBuf>,
    input: &Path,
    start_times: Option<&Path>,
    record: &RecordOptions,
    mut note: impl FnMut(String),
) -> Result<Vec<TimedLog>> {
    let Some(table) = start_times else {
        return Ok(by_absolute_time(files, input, record, note));
    };
    let times = read_start_times(table)?;
    let mut out = vec![];
    for f in files {
        let name = f.file_name().map(|n| n.to_string_lossy().into_owned());
        let hit = times
            .iter()
            .find(|(t, _, _)| Path::new(t) == f.as_path() || name.as_deref() == Some(t.as_str()));
        let Some((_, iso, s)) = hit else {
            bail!(
                Data,
                "--start-times {}: no start time for {}",
                table.display(),
                f.display()
            );
        };
        out.push((f, Some((iso.clone(), *s))));
    }
    by_start(&mut out);
    note(format!(
        "{}: {} logs in the order of their start times ({})",
        input.display(),
        out.len(),
        table.display()
    ));
    Ok(out)
}

/// Sorts logs by their start times (then by path, for equal times).
fn by_start(logs: &mut [TimedLog]) {
    logs.sort_by(|a, b| {
        let ta = a.1.as_ref().map_or(f64::NAN, |t| t.1);
        let tb = b.1.as_ref().map_or(f64::NAN, |t| t.1);
        ta.total_cmp(&tb).then_with(|| a.0.cmp(&b.0))
    });
}

/// The logs in the order of their first rows' date and time when every
/// one has an absolute time column, else in the order given (file names);
/// `note` says which, and names a log without one when others have it.
fn by_absolute_time(
    files: Vec<PathBuf>,
    input: &Path,
    record: &RecordOptions,
    mut note: impl FnMut(String),
) -> Vec<TimedLog> {
    // A log that cannot be read has no time here; its run says why.
    let starts: Vec<Option<LogStart>> = files
        .iter()
        .map(|f| log_start(f, record).ok().flatten())
        .collect();
    let missing = starts.iter().position(Option::is_none);
    let Some(missing) = missing else {
        let column = starts
            .first()
            .and_then(|s| s.as_ref())
            .map_or(String::new(), |s| s.column.clone());
        let mut out: Vec<TimedLog> = files
            .into_iter()
            .zip(starts)
            .map(|(f, s)| (f, s.map(|s| (s.iso, s.utc_s))))
            .collect();
        by_start(&mut out);
        note(format!(
            "{}: {} logs in the order of their first rows' date and time (`{column}`; no --start-times)",
            input.display(),
            out.len(),
        ));
        return out;
    };
    let why = if starts.iter().any(Option::is_some) {
        format!(
            "; {} has no date and time in its first row",
            files[missing].display()
        )
    } else {
        String::new()
    };
    note(format!(
        "{}: {} logs in file name order (no --start-times{why}): each taken to start {:.0} s after the one before ended",
        input.display(),
        files.len(),
        UNKNOWN_GAP_S
    ));
    files.into_iter().map(|f| (f, None)).collect()
}

/// What a life did: its rows and the snapshot after the last log.
#[derive(Clone, Debug)]
pub struct Life {
    /// One per log, in the order run.
    pub rows: Vec<LifeRow>,
    /// The snapshot after the last log that ran (`--state-out`).
    pub snapshot: Option<Vec<u8>>,
}

/// Runs the logs of `input` ([`ordered_logs`]) through one estimator as
/// `o` says, each log's track written into `out_dir` (its name without the
/// extension, then `-track.csv`), the state carried from each log to the
/// next as `--state-out`/`--state-in` carry it (`snapshot`: one to start
/// from). A log that cannot be run (unreadable, no current) is one
/// warning through `note` and a row with its `error`; the state goes on
/// from the log before, across it, as a gap.
///
/// # Errors
/// No logs, a start-time table that does not cover them, or an output
/// directory that cannot be made.
pub fn life(
    input: &Path,
    out_dir: &Path,
    o: &OnlineBatteryOptions,
    start_times: Option<&Path>,
    snapshot: Option<Vec<u8>>,
    mut note: impl FnMut(String),
) -> Result<Life> {
    let logs = ordered_logs(input, start_times, &o.record, &mut note)?;
    run_life(&logs, out_dir, o, snapshot, note)
}

/// [`life()`] over logs already in order ([`order_logs`]).
///
/// # Errors
/// Two logs of one name, or an output directory that cannot be made.
pub fn run_life(
    logs: &[TimedLog],
    out_dir: &Path,
    o: &OnlineBatteryOptions,
    snapshot: Option<Vec<u8>>,
    mut note: impl FnMut(String),
) -> Result<Life> {
    let files: Vec<PathBuf> = logs.iter().map(|(f, _)| f.clone()).collect();
    let outs = outputs_in(out_dir, &files, "-track.csv")?;
    std::fs::create_dir_all(out_dir)
        .map_err(|e| err!(Io, "--out {}: cannot make it: {e}", out_dir.display()))?;
    let mut carried = snapshot;
    // Without start times: the clock of the one before's end, plus the gap.
    let mut next_clock = 0.0;
    let mut rows: Vec<LifeRow> = Vec::with_capacity(logs.len());
    for ((file, start), out) in logs.iter().zip(&outs) {
        let clock = start.as_ref().map_or(next_clock, |s| s.1);
        let run = OnlineBatteryOptions {
            start_time_s: Some(clock),
            state_in: None,
            state_out: None,
            ..o.clone()
        };
        let row = match battery_run(file, out, &run, carried.as_deref()) {
            Ok((rep, saved)) => {
                carried = Some(saved);
                let t = &rep.life;
                let last = rep.record.samples.saturating_sub(1) as f64 * rep.record.period_s;
                next_clock = clock + last + UNKNOWN_GAP_S;
                let (r_i, r_i_status) = t.median(0);
                LifeRow {
                    file: file.clone(),
                    start_time: start.as_ref().map(|s| s.0.clone()),
                    samples: t.samples,
                    discharged_ah: Some(t.discharged_ah),
                    charged_ah: Some(t.charged_ah),
                    r_i,
                    r_i_status,
                    r_ct: t.median(1).0,
                    alpha: t.median(2).0,
                    capacity_ah: if t.full_discharge {
                        Some(t.discharged_ah)
                    } else {
                        t.capacity.map(|c| c.0)
                    },
                    capacity_status: if t.full_discharge {
                        "identified"
                    } else {
                        t.capacity.map_or("", |c| c.1)
                    },
                    capacity_source: if t.full_discharge {
                        "full_discharge"
                    } else if t.capacity.is_some() {
                        "observer"
                    } else {
                        ""
                    },
                    soh_c: None,
                    soh_r: None,
                    error: None,
                }
            }
            Err(e) => {
                // The reason, without the file's name the error may start
                // with (the row names the file).
                let e = e.to_string();
                let named = format!("{}: ", file.display());
                let e = e.strip_prefix(&named).unwrap_or(&e).to_string();
                note(format!(
                    "warning: {}: {e}; the life goes on across it as a gap",
                    file.display()
                ));
                LifeRow {
                    file: file.clone(),
                    start_time: start.as_ref().map(|s| s.0.clone()),
                    samples: 0,
                    discharged_ah: None,
                    charged_ah: None,
                    r_i: None,
                    r_i_status: "error",
                    r_ct: None,
                    alpha: None,
                    capacity_ah: None,
                    capacity_status: "error",
                    capacity_source: "",
                    soh_c: None,
                    soh_r: None,
                    error: Some(e),
                }
            }
        };
        rows.push(row);
    }
    let r0 = rows.iter().find_map(|r| r.r_i);
    let c0 = rows.iter().find_map(|r| r.capacity_ah);
    for r in &mut rows {
        r.soh_r = r.r_i.zip(r0).map(|(x, x0)| x / x0);
        r.soh_c = r.capacity_ah.zip(c0).map(|(x, x0)| x / x0);
    }
    Ok(Life {
        rows,
        snapshot: carried,
    })
}
