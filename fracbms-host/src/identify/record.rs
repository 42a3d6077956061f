//! A battery record fitted as it comes: from a file (`identify battery
//! --input`, [`battery_file`]) or from arrays (Python's `identify_battery`,
//! C's `fracbms_identify_battery`, [`battery_arrays`]), with the options
//! every face shares ([`BatteryFitOptions`]) and the `--fit-out` file.
//!
//! This module owns reading the record, screening its bad rows and
//! handing it to the fit; it must not fit (that is [`super::battery`]'s).

use super::battery::{battery_identify_screened, model_for, BatteryResult, Refine};
use super::{BatteryMethod, ModelRequest, MAX_BATTERY_ROWS};
use crate::error::Result;
use crate::{io, trust};
use serde::Serialize;
use std::path::Path;

/// What [`battery_arrays`] read and fitted.
pub struct BatteryArrays {
    /// The arrays as read (put on a uniform period as a file's rows are).
    pub read: crate::cycler::CyclerRecord,
    /// The fit, its JSON (with the `record` block) and its model voltage.
    pub result: BatteryResult,
    /// The rows rejected and substituted.
    pub screened: trust::Screened,
}

/// `identify battery` on arrays rather than a file, for the faces that get
/// arrays (Python's `identify_battery`, C's `fracbms_identify_battery`):
/// the arrays are read as the file's columns `time_s,current_a,voltage_v`
/// would be ([`crate::cycler::record_from_arrays`]: a non-finite time is an
/// error, a non-uniform one put on a uniform period), then bad rows are
/// rejected, substituted and counted with the default plausibility limits,
/// and the record is fitted, as the CLI does. `unobserved[k]` (empty: none)
/// says row `k`'s voltage was not measured: a sample is unobserved where the
/// row it is held from is, and counted in no fit (as a cycler's unlogged
/// step start is). `name` names the data in the messages (`record`).
///
/// # Errors
/// [`crate::ErrorKind::Data`] for arrays of unequal lengths, a bad time,
/// more than [`MAX_BATTERY_ROWS`] samples, every row rejected; as
/// [`battery_identify_screened`] otherwise.
#[allow(clippy::too_many_arguments)]
pub fn battery_arrays(
    name: &Path,
    time: &[f64],
    current: &[f64],
    voltage: &[f64],
    unobserved: &[bool],
    ocv: Option<&crate::ocv::OcvSpec>,
    method: BatteryMethod,
    model: ModelRequest,
    memory: Option<usize>,
    iterations: u32,
) -> Result<BatteryArrays> {
    if !unobserved.is_empty() && unobserved.len() != time.len() {
        crate::bail!(
            Data,
            "{}: the unobserved mask has {} values, the record {}",
            name.display(),
            unobserved.len(),
            time.len()
        );
    }
    let read = crate::cycler::record_from_arrays(
        name,
        time,
        current,
        voltage,
        &crate::cycler::RecordOptions::default(),
    )?;
    if read.record.time.len() > MAX_BATTERY_ROWS {
        crate::bail!(
            Data,
            "{}: {} rows; at most {MAX_BATTERY_ROWS} are identified (the online estimator tracks longer records)",
            name.display(),
            read.record.time.len()
        );
    }
    let refine = Refine {
        model: model_for(model, method),
        ..Refine::default()
    };
    let gaps = &read.report.resampling.gaps;
    // Inside a gap no voltage was measured either.
    let unobserved: Vec<bool> = held_mask(time, unobserved, &read.record.time)
        .into_iter()
        .zip(crate::map::in_gaps(&read.record, gaps))
        .map(|(a, b)| a || b)
        .collect();
    let (mut result, screened) = battery_identify_screened(
        name,
        &read.record,
        &unobserved,
        gaps,
        &trust::Limits::default(),
        ocv,
        method,
        memory,
        iterations,
        false,
        refine,
    )?;
    result.json.record = Some(read.report.clone());
    Ok(BatteryArrays {
        read,
        result,
        screened,
    })
}

/// A mask of rows (`mask[k]` for the row at `rows[k]`, increasing) on the
/// samples at `at`: each sample takes the mask of the last row at or
/// before it (empty: all false).
fn held_mask(rows: &[f64], mask: &[bool], at: &[f64]) -> Vec<bool> {
    if mask.is_empty() {
        return vec![];
    }
    at.iter()
        .map(|&t| {
            let k = rows.partition_point(|&r| r <= t);
            k > 0 && mask[k - 1]
        })
        .collect()
}

/// How `identify battery` fits a record: every flag but the files and the
/// outputs. The default is the CLI's.
#[derive(Clone, Debug, Default, PartialEq, Serialize, serde::Deserialize)]
#[serde(default)]
pub struct BatteryFitOptions {
    /// The paper's regression, or the refinement started from it.
    pub method: BatteryMethod,
    /// Memory M of the paper regression (default 256).
    pub memory: Option<usize>,
    /// Iterations of 2S-OP-GI (default 50).
    pub iterations: Option<u32>,
    /// Memory of the refinement (default: the whole record).
    pub refine_memory: Option<usize>,
    /// Fit an OCV slope dU_oc/dq (without an OCV curve).
    pub ocv_slope: bool,
    /// The cell model asked for (`auto` by default in the CLI; see
    /// [`model_for`]).
    pub model: ModelRequest,
    /// The cell's OCV curve, capacity and start SOC.
    pub ocv: crate::ocv::OcvOptions,
    /// Lowest plausible voltage (V; default [`trust::Limits`]').
    pub voltage_min: Option<f64>,
    /// Highest plausible voltage (V).
    pub voltage_max: Option<f64>,
    /// Largest plausible |current| (A).
    pub current_limit: Option<f64>,
    /// How the record is read: columns, current sign, period.
    pub record: crate::cycler::RecordOptions,
}

/// Iterations of 2S-OP-GI when [`BatteryFitOptions::iterations`] is not
/// given.
pub const DEFAULT_ITERATIONS: u32 = 50;

/// What [`battery_file`] read and fitted.
pub struct BatteryFile {
    /// The record as read (at most [`MAX_BATTERY_ROWS`] samples).
    pub record: io::BatteryRecord,
    /// What was read from the file, and how the rows were put on a
    /// uniform period.
    pub report: crate::cycler::RecordReport,
    /// The fit, its JSON and its model voltage.
    pub result: BatteryResult,
    /// The rows rejected and substituted.
    pub screened: trust::Screened,
    /// The temperature column (°C) on the record's samples, if any.
    pub temperature: Option<Vec<f64>>,
    /// The log's own rows before the uniform period
    /// ([`crate::cycler::CyclerRecord::rows`]).
    pub rows: io::BatteryRecord,
}

/// `identify battery` on the file `input`: reads the whole record (a log
/// longer than [`MAX_BATTERY_ROWS`] samples is put on a longer period, a
/// non-uniform one resampled to at most [`crate::cycler::MAX_SAMPLES`]
/// unless `--period` says otherwise, as its `record` block says), checks
/// the options before the file is read where it can, screens the bad rows
/// and fits as `o` says. With `print_table`, the 2S-OP-GI table of
/// estimates versus k goes to stdout, as the CLI shows it.
///
/// # Errors
/// A file that cannot be read, data or options that are refused, or an
/// estimator that stops.
pub fn battery_file(input: &Path, o: &BatteryFitOptions, print_table: bool) -> Result<BatteryFile> {
    // The whole record: a longer uniform log is put on a longer period.
    let record = crate::cycler::RecordOptions {
        max_samples: Some(MAX_BATTERY_ROWS),
        capacity_ah: o.record.capacity_ah.or(o.ocv.capacity_ah),
        ..o.record.clone()
    };
    let read = crate::cycler::read_record(input, &record)?;
    let rec = read.record;
    let refine = Refine {
        memory: o.refine_memory,
        ocv_slope: o.ocv_slope,
        model: model_for(o.model, o.method),
        ..Refine::default()
    };
    let limits = trust::Limits::checked(o.voltage_min, o.voltage_max, o.current_limit)?;
    let ocv = crate::ocv::OcvSpec::from_options(&o.ocv)?;
    // Inside a step's unlogged start or a gap, no voltage was measured.
    let gaps = &read.report.resampling.gaps;
    let unobserved: Vec<bool> = read
        .report
        .unobserved(rec.h, &rec.time)
        .into_iter()
        .zip(crate::map::in_gaps(&rec, gaps))
        .map(|(a, b)| a || b)
        .collect();
    let (result, screened) = battery_identify_screened(
        input,
        &rec,
        &unobserved,
        gaps,
        &limits,
        ocv.as_ref(),
        o.method,
        o.memory,
        o.iterations.unwrap_or(DEFAULT_ITERATIONS),
        print_table,
        refine,
    )?;
    let mut result = result;
    result.json.record = Some(read.report.clone());
    Ok(BatteryFile {
        record: rec,
        report: read.report,
        result,
        screened,
        temperature: read.temperature,
        rows: read.rows,
    })
}

/// Writes the `--fit-out` file: `time_s,voltage_v,model_v` (the identified
/// model's free-run voltage beside the record's), then `current_a`,
/// `fitted` (1 where the fit counted the sample's voltage: measured, not
/// rejected) and, with an OCV table, `ocv_v` (the OCV the fit took away at
/// each sample: `voltage_v − ocv_v` is the overpotential it fitted).
pub fn write_fit_csv(
    path: &Path,
    rec: &io::BatteryRecord,
    model_v: &[f64],
    counted: impl Fn(usize) -> bool,
    ocv_v: Option<&[f64]>,
) -> Result<()> {
    let mut head = vec!["time_s", "voltage_v", "model_v", "current_a", "fitted"];
    if ocv_v.is_some() {
        head.push("ocv_v");
    }
    io::write_csv(
        path,
        &head,
        (0..rec.time.len()).map(|k| {
            let mut row = vec![
                format!("{}", rec.time[k]),
                format!("{:.9}", rec.voltage[k]),
                format!("{:.9}", model_v[k]),
                format!("{}", rec.current[k]),
                u8::from(counted(k)).to_string(),
            ];
            if let Some(o) = ocv_v {
                row.push(format!("{:.9}", o[k]));
            }
            row
        }),
    )
}
