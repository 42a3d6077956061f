//! `online_pack`: a series string's record through the pack estimator, as
//! `host-sim online pack` runs it (`fracbms_host::pack::track_pack`). This
//! module only converts: numpy in, the CLI's long-format track out as a
//! dict of columns.

use fracbms_host::ocv::OcvOptions;
use fracbms_host::online::schema::{Cell, Field, Kind};
use fracbms_host::online::soc::SocOptions;
use fracbms_host::online::state::StateIn;
use fracbms_host::pack::{pack_fields, run_pack_with, OnlinePack, PackRecord, PackRow, Snapshots};
use fracbms_host::worker::on_worker;
use numpy::{AllowTypeChange, PyArray1, PyArrayLike2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList, PyTuple};

use crate::{choice, ocv_spec, power_options, vec, Floats};

/// Runs the pack estimator over a series string's record and returns its
/// track, as `host-sim online pack --out` writes it.
///
/// `current_a` is the string's current (A, + charging), one per sample;
/// `cells_v` the cells' voltages (V), shape `(samples, cells)` (the
/// columns `cell_1_v…` of a pack record); samples every `h` seconds. The
/// keywords are the CLI's flags; with `ocv=(soc, ocv_v)` and
/// `capacity_ah` every cell gets a state of charge and a state of power,
/// and the string its state of power. `soc0` sets every cell's start SOC
/// (default: each cell's read from its own first rested voltages).
///
/// Snapshots (docs/persistence.md): `state_in` (bytes: the CLI's
/// `--state-in` file, or an earlier call's) starts every cell from it and
/// adds the column `restoration`; a snapshot the core rejects raises
/// `ValueError` naming why. With `return_state=True` the call returns
/// `(track, snapshot)`, the snapshot after the last sample as the CLI's
/// `--state-out` writes it. `t0` is the first sample's time (s; the
/// samples are at `t0 + k·h`): the snapshot's clock, as the record's
/// `time_s` is the CLI's.
///
/// Returns a dict of the track's columns ([`pack_fields`]), one row
/// per sample and cell (cell 1 first): numbers as float arrays (NaN where
/// the CSV is empty), `time_s` float, `cell` int, `rejected` and
/// `flagged` bool arrays, statuses as lists of str. `pandas.DataFrame(d)`
/// is the CSV.
#[pyfunction]
#[pyo3(signature = (
    current_a, cells_v, h = 1.0, window = 256, memory = None, *, iterations_per_sample = 1,
    updates_per_period = None, flag_ratio = 0.3, precision = "f64", start = "from-data",
    tail = false, ocv = None, capacity_ah = None, soc0 = None, horizons = vec![10.0, 30.0],
    voltage_min = None, voltage_max = None, current_limit = None, pulse_current_a = None,
    sop_carry_s = None, sop_confidence = None, pulse_correction = true, soc = "observer", soc_rest_s = None, soc_bias_sigma_a = None,
    soc_rest_load_sigma_a = None, soc_voltage_sigma_v = None, capacity_min_span = None, t0 = 0.0, state_in = None, return_state = false,
    slow_memory_s = None, slow_memory_soc = None
))]
#[allow(clippy::too_many_arguments)]
pub fn online_pack<'py>(
    py: Python<'py>,
    current_a: Floats<'py>,
    cells_v: PyArrayLike2<'py, f64, AllowTypeChange>,
    h: f64,
    window: usize,
    memory: Option<usize>,
    iterations_per_sample: u16,
    updates_per_period: Option<u16>,
    flag_ratio: f64,
    precision: &str,
    start: &str,
    tail: bool,
    ocv: Option<(Floats<'py>, Floats<'py>)>,
    capacity_ah: Option<f64>,
    soc0: Option<f64>,
    horizons: Vec<f64>,
    voltage_min: Option<f64>,
    voltage_max: Option<f64>,
    current_limit: Option<f64>,
    pulse_current_a: Option<f64>,
    sop_carry_s: Option<f64>,
    sop_confidence: Option<f64>,
    pulse_correction: bool,
    soc: &str,
    soc_rest_s: Option<f64>,
    soc_bias_sigma_a: Option<f64>,
    soc_rest_load_sigma_a: Option<f64>,
    soc_voltage_sigma_v: Option<f64>,
    capacity_min_span: Option<f64>,
    t0: f64,
    state_in: Option<Vec<u8>>,
    return_state: bool,
    slow_memory_s: Option<f64>,
    slow_memory_soc: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    if !(h.is_finite() && h > 0.0) {
        return Err(PyValueError::new_err(format!(
            "h={h}: must be finite and positive"
        )));
    }
    if !t0.is_finite() {
        return Err(PyValueError::new_err(format!("t0={t0}: must be finite")));
    }
    let current = vec(&current_a);
    let v = cells_v.as_array();
    let (samples, cells) = v.dim();
    if samples != current.len() {
        return Err(PyValueError::new_err(format!(
            "cells_v has {samples} rows, current_a {} values (cells_v: shape (samples, cells))",
            current.len()
        )));
    }
    let rec = PackRecord {
        time: (0..samples).map(|k| t0 + k as f64 * h).collect(),
        current,
        cells: (0..cells).map(|c| v.column(c).to_vec()).collect(),
        h,
    };
    let power = power_options(
        &horizons,
        voltage_min,
        voltage_max,
        current_limit,
        pulse_current_a,
        sop_carry_s,
        sop_confidence,
        pulse_correction,
    )?;
    let spec = ocv_spec(ocv, capacity_ah, soc0)?;
    let a = OnlinePack {
        window,
        memory,
        iterations_per_sample,
        updates_per_period,
        flag_ratio,
        precision: choice("precision", precision)?,
        start: choice("start", start)?,
        tail,
        ocv: OcvOptions {
            soc0: spec.and_then(|s| s.soc0),
            ..OcvOptions::default()
        },
        power,
        soc: SocOptions {
            mode: choice("soc", soc)?,
            rest_s: soc_rest_s,
            bias_sigma_a: soc_bias_sigma_a,
            rest_load_sigma_a: soc_rest_load_sigma_a,
            voltage_sigma_v: soc_voltage_sigma_v,
            capacity_min_span,
        },
        slow_memory_s,
        slow_memory_soc,
        state_in: None,
        state_out: None,
    };
    let restoring = state_in.is_some();
    let snapshots = Snapshots {
        state_in: state_in.as_deref(),
        save_state: return_state,
    };
    let (rows, summary) = py
        .detach(|| {
            on_worker(|| {
                let mut rows = Vec::with_capacity(samples * cells);
                run_pack_with(&rec, &a, spec.map(|s| s.model), snapshots, |r| {
                    rows.push(r);
                    Ok(())
                })
                .map(|summary| (rows, summary))
            })
        })
        .map_err(|e| {
            // The CLI's flags are this function's keywords.
            PyValueError::new_err(
                format!("{e:#}")
                    .replace("--memory ", "memory=")
                    .replace("--window ", "window=")
                    .replace("--horizons ", "horizons=")
                    .replace("--soc0 ", "soc0=")
                    .replace("--updates-per-period", "updates_per_period=")
                    .replace("--flag-ratio ", "flag_ratio="),
            )
        })?;
    if let Some(StateIn::Rejected(e)) = summary.state_in {
        return Err(PyValueError::new_err(format!(
            "state_in: snapshot rejected: {e}"
        )));
    }
    let track = columns(py, &pack_fields(power.horizons(), restoring), &rows)?;
    match summary.state_out.filter(|_| return_state) {
        Some(bytes) => Ok(PyTuple::new(
            py,
            [track.into_any(), PyBytes::new(py, &bytes).into_any()],
        )?
        .into_any()),
        None => Ok(track.into_any()),
    }
}

/// The rows as a dict of `fields`' columns: an `int64` array of `cell`, a
/// `bool` array of a flag, a list of words, else a `float64` array (NaN
/// where the CSV is empty); without rows, every column a `float64` array.
fn columns<'py>(
    py: Python<'py>,
    fields: &[Field<PackRow>],
    rows: &[PackRow],
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for f in fields {
        let cells = rows.iter().map(|r| f.cell(r));
        let kind = if rows.is_empty() {
            Kind::Number
        } else {
            f.kind()
        };
        match kind {
            Kind::Index => {
                let c: Vec<i64> = cells
                    .map(|c| match c {
                        Cell::Index(k) => k as i64,
                        _ => 0,
                    })
                    .collect();
                d.set_item(f.name(), PyArray1::from_vec(py, c))?;
            }
            Kind::Flag => {
                let c: Vec<bool> = cells.map(|c| c == Cell::Flag(true)).collect();
                d.set_item(f.name(), PyArray1::from_vec(py, c))?;
            }
            Kind::Word => {
                let c: Vec<&str> = cells
                    .map(|c| match c {
                        Cell::Word(w) => w.unwrap_or(""),
                        _ => "",
                    })
                    .collect();
                d.set_item(f.name(), PyList::new(py, c)?)?;
            }
            Kind::Time | Kind::Number => {
                let c: Vec<f64> = cells.map(|c| c.number().unwrap_or(f64::NAN)).collect();
                d.set_item(f.name(), PyArray1::from_vec(py, c))?;
            }
        }
    }
    Ok(d)
}
