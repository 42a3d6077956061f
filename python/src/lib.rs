//! # fracbms (Python)
//!
//! The extension module `fracbms._fracbms`: the Python face of fracbms, on
//! numpy arrays. It owns the conversion of Python arguments into the
//! host-sim calls the CLI makes and of their results into dicts and arrays;
//! it must not fit, simulate or track anything itself, so that a notebook
//! gets what `host-sim` prints for the same data.
//!
//! | Python | the CLI's function |
//! |---|---|
//! | `identify_battery` | `identify battery --json`, with `map=True` `--map-out` ([`fracbms_host::identify::battery_identify_screened`], [`fracbms_host::identify::map::build_map`]) |
//! | `predict_battery` | `predict battery` ([`fracbms_host::predict::predict`], [`fracbms_host::predict::predict_map`]) |
//! | `simulate_battery` | `simulate battery`'s noise-free voltage ([`fracbms_host::simulate::battery_voltage`]) |
//! | `OnlineCell` | `online battery` ([`fracbms_host::online::Tracker`]; in `online.rs`) |
//! | `identify_files` | `identify battery --input DIR_OR_GLOB --summary-out` ([`fracbms_host::identify::many`]; in `files.rs`) |
//! | `identify_hammerstein` | `identify hammerstein --json` ([`fracbms_host::identify::hammerstein_fit`]) |
//!
//! Errors are the CLI's one-line messages, raised as `ValueError`; the data
//! are named `record` (`ocv` for an OCV table) and rows are numbered as in
//! the CSV file the arrays would be read from: row = index + 2 (the header
//! is row 1). Keyword errors name the keyword (`capacity_ah=0`) where the
//! CLI names its flag (`--capacity-ah 0`).
//!
//! The fits run on a worker thread with the CLI's stack
//! ([`fracbms_host::worker::on_worker`]) and without the GIL.
//!
//! The runnable example is the package's docstring (`python/fracbms/
//! __init__.py`), run by pytest's doctests; the signatures and types are in
//! `python/fracbms/_fracbms.pyi`.

#![forbid(unsafe_code)]

use std::ffi::CString;
use std::path::Path;

use estimator_core::battery::{CellParameters, Start};
use fracbms_host::choice::Choice;
use fracbms_host::cycler;
use fracbms_host::identify::hammerstein::HammersteinOptions;
use fracbms_host::identify::{
    hammerstein_fit, Algorithm, BatteryMethod, HammersteinMethod, ModelRequest, Refine,
    MAX_BATTERY_ROWS, MAX_ROWS,
};
use fracbms_host::io::{self, BatteryRecord, Columns};
use fracbms_host::ocv::{CellOcv, OcvSpec, OcvSpecError};
use fracbms_host::online::{
    read_prior_source, Precision, PriorSource, TrackOptions, TrackRow, Tracker,
};
use fracbms_host::predict;
use fracbms_host::simulate::{battery_voltage, OcvCurve};
use fracbms_host::trust::Limits;
use fracbms_host::worker::on_worker;
use numpy::{AllowTypeChange, PyArray1, PyArrayLike1};
use pyo3::exceptions::{PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

mod files;
mod life;
mod online;
mod pack;
use online::OnlineCell;

/// A 1-D float array argument (lists, tuples and integer arrays are
/// converted, as `numpy.asarray(x, dtype=float)` would).
type Floats<'py> = PyArrayLike1<'py, f64, AllowTypeChange>;

/// The name the data go by in the messages.
const RECORD: &str = "record";
/// The name of an OCV table in the messages.
const OCV: &str = "ocv";

fn value_error(e: fracbms_host::Error) -> PyErr {
    PyValueError::new_err(e.to_string().replace('\n', " "))
}

fn vec(a: &Floats<'_>) -> Vec<f64> {
    a.as_array().iter().copied().collect()
}

/// Parses a keyword's string as the CLI parses its flag.
fn choice<E: Choice>(keyword: &str, value: &str) -> PyResult<E> {
    E::parse(value).ok_or_else(|| {
        let names: Vec<String> = E::names().iter().map(|n| format!("'{n}'")).collect();
        PyValueError::new_err(format!(
            "{keyword}='{value}': must be one of {}",
            names.join(", ")
        ))
    })
}

/// `json.loads` of a value serialized as the CLI writes it.
fn to_dict<'py>(py: Python<'py>, value: &impl serde::Serialize) -> PyResult<Bound<'py, PyDict>> {
    let text = serde_json::to_string(value)
        .map_err(|e| PyValueError::new_err(format!("internal error: {e}")))?;
    py.import("json")?
        .call_method1("loads", (text,))?
        .cast_into::<PyDict>()
        .map_err(PyErr::from)
}

fn warn(py: Python<'_>, message: &str) -> PyResult<()> {
    let text = CString::new(message.replace('\0', " "))
        .map_err(|e| PyValueError::new_err(format!("internal error: {e}")))?;
    PyErr::warn(py, &py.get_type::<PyUserWarning>(), &text, 1)
}

/// The state-of-power keywords (`horizons=`, `voltage_min=`, …,
/// `sop_carry_s=`, `sop_confidence=`, `pulse_correction=`) as the CLI's
/// flags, checked as the CLI checks them.
#[allow(clippy::too_many_arguments)]
fn power_options(
    horizons: &[f64],
    voltage_min: Option<f64>,
    voltage_max: Option<f64>,
    current_limit: Option<f64>,
    pulse_current_a: Option<f64>,
    carry_s: Option<f64>,
    confidence: Option<f64>,
    pulse_correction: bool,
) -> PyResult<fracbms_host::online::power::PowerOptions> {
    let mut p = fracbms_host::online::power::PowerOptions::default()
        .with_horizons(horizons)
        .map_err(|e| PyValueError::new_err(format!("{e:#}").replace("--horizons", "horizons=")))?;
    p.voltage_min = voltage_min;
    p.voltage_max = voltage_max;
    p.current_limit = current_limit;
    p.pulse_current_a = pulse_current_a;
    p.carry_s = carry_s;
    p.confidence = confidence;
    p.pulse_correction = pulse_correction;
    Ok(p)
}

/// The OCV curve of the `ocv=(soc, ocv_v)`, `capacity_ah=`, `soc0=`
/// keywords, checked as the CLI checks `--ocv`, `--capacity-ah`, `--soc0`.
fn ocv_spec(
    ocv: Option<(Floats<'_>, Floats<'_>)>,
    capacity_ah: Option<f64>,
    soc0: Option<f64>,
) -> PyResult<Option<OcvSpec>> {
    let Some((soc, v)) = ocv else {
        if capacity_ah.is_some() || soc0.is_some() {
            return Err(PyValueError::new_err(
                "capacity_ah and soc0 go with ocv=(soc, ocv_v)",
            ));
        }
        return Ok(None);
    };
    let cap = capacity_ah.ok_or_else(|| {
        PyValueError::new_err("ocv needs capacity_ah (the cell's capacity in A·h)")
    })?;
    let said = |e| match e {
        OcvSpecError::Capacity(c) => {
            PyValueError::new_err(format!("capacity_ah={c}: must be finite and positive"))
        }
        OcvSpecError::Soc0(z) => PyValueError::new_err(format!("soc0={z}: must be in [0, 1]")),
    };
    OcvSpec::check(cap, soc0).map_err(said)?;
    let table = io::ocv_table(
        Path::new(OCV),
        Columns::from_arrays(vec![vec(&soc), vec(&v)]),
    )
    .map_err(value_error)?;
    OcvSpec::new(table, cap, soc0).map_err(said).map(Some)
}

/// Identify a battery cell from a whole record (`host-sim identify battery --json`).
///
/// Fits the fractional-order cell model: `U_t = U_oc + R_i·I + U_p` with
/// `Q·D^α U_p = I − U_p/R_ct`, with the paper's 2S-OP-GI (`method="paper"`)
/// or 2S-OP-GI refined by the output error (`"refined"`, the default and the
/// most accurate), optionally with a Butler–Volmer term `a·asinh(I/i₀)`
/// (`model="auto"` chooses) and an OCV curve `OCV(SOC)` with the SOC counted
/// from the current. Rows with a non-finite or implausible current or
/// voltage, and voltage spikes against the fit, are rejected, substituted and
/// counted (a `UserWarning` names them), as the CLI does.
///
/// Parameters
/// ----------
/// time_s, current_a, voltage_v : array_like, 1-D
///     Time (s), current (A, positive when charging), terminal voltage (V).
///     Uneven steps are put on a uniform period as the CLI does (the
///     current averaged over each period, the voltage at the instants; the
///     dict's ``record`` says how, docs/cycler.md). At most
///     `MAX_BATTERY_ROWS` samples.
/// ocv : (soc, ocv_v), optional
///     The cell's OCV table (SOC in [0, 1] and voltage, both increasing).
/// capacity_ah : float, optional
///     Capacity (A·h) for coulomb counting; needed with `ocv`.
/// soc0 : float, optional
///     SOC before the first row; default: read from the rested start.
/// method : {"refined", "paper"}
/// model : {"auto", "linear", "butler-volmer"}
///     The cell model (`"paper"` fits the linear model).
/// iterations : int
///     Most iterations of the paper regression: 2S-OP-GI's (the paper
///     method, or the refinement's start on fewer than 4 096 rows); from
///     4 096 rows the start's, θ solved by least squares at each order,
///     stops when converged.
/// memory : int, optional
///     Memory M of the paper regression (default 256).
/// map : bool
///     Also the parameter map (``identify battery --map-out``): the record
///     split at its rests of at least ``min_rest`` s (parts within 0.03 of
///     SOC of one another one level), or into ``soc_bins`` SOC bins, each
///     level fitted; the dict's ``map`` holds the levels
///     (the map CSV's columns), the levels skipped and the whole-record
///     RMSE of the map model beside the single fit's. Needs ``ocv``.
/// map_method : {"joint", "levels"}
///     How the map is fitted (``--map-method``): every knot together over
///     the whole record, smooth in SOC (the default), or each level on its
///     own stretch.
/// observed : array_like of 0/1, optional
///     Per row, 1 where the voltage was measured and 0 where it was not (a
///     cycler's unlogged step start: the current known, the voltage not);
///     no fit counts an unobserved row. Default: every row.
///
/// Returns
/// -------
/// dict
///     The keys of `host-sim identify battery --json` (`r_i`, `r_ct`, `q`,
///     `alpha`, `u_oc`, `model`, `bv_a_v`, `bv_i0_a`, `ocv_offset_v`, `soc0`,
///     `soc_end`, `rmse_v`, `confidence`, `identifiable`, `rejected`, ...;
///     docs/python.md lists them), plus `model_v`: the fitted model's
///     free-run voltage over the record (numpy array).
///
/// Raises
/// ------
/// ValueError
///     The CLI's one-line message: a non-finite or non-uniform time, a bad
///     OCV table, every row rejected, a bad keyword.
#[pyfunction]
#[pyo3(signature = (
    time_s, current_a, voltage_v, *, ocv = None, capacity_ah = None, soc0 = None,
    method = "refined", model = "auto", iterations = 50, memory = None,
    map = false, soc_bins = None, min_rest = 600.0, map_method = "joint", observed = None
))]
#[allow(clippy::too_many_arguments)]
fn identify_battery<'py>(
    py: Python<'py>,
    time_s: Floats<'py>,
    current_a: Floats<'py>,
    voltage_v: Floats<'py>,
    ocv: Option<(Floats<'py>, Floats<'py>)>,
    capacity_ah: Option<f64>,
    soc0: Option<f64>,
    method: &str,
    model: &str,
    iterations: u32,
    memory: Option<usize>,
    map: bool,
    soc_bins: Option<usize>,
    min_rest: f64,
    map_method: &str,
    observed: Option<Floats<'py>>,
) -> PyResult<Bound<'py, PyDict>> {
    let method: BatteryMethod = choice("method", method)?;
    let map_method: fracbms_host::map::MapMethod = choice("map_method", map_method)?;
    // `observed`: 1 where the voltage was measured, 0 where not (a cycler's
    // unlogged step start); None: every row.
    let unobserved: Vec<bool> =
        observed.map_or_else(Vec::new, |m| vec(&m).iter().map(|&x| x == 0.0).collect());
    let model: ModelRequest = choice("model", model)?;
    let spec = ocv_spec(ocv, capacity_ah, soc0)?;
    if map && spec.is_none() {
        return Err(PyValueError::new_err(
            "map=True needs ocv and capacity_ah (each level's SOC moves)",
        ));
    }
    // Read as the CLI reads a file: a non-uniform time is put on a uniform
    // period (the dict's `record` says how).
    let name = Path::new(RECORD);
    let (t, i, v) = (vec(&time_s), vec(&current_a), vec(&voltage_v));
    let fracbms_host::identify::record::BatteryArrays {
        read,
        result: r,
        screened: sc,
    } = py
        .detach(|| {
            on_worker(|| {
                fracbms_host::identify::record::battery_arrays(
                    name,
                    &t,
                    &i,
                    &v,
                    &unobserved,
                    spec.as_ref(),
                    method,
                    model,
                    memory,
                    iterations,
                )
            })
        })
        .map_err(|e| {
            PyValueError::new_err(
                e.to_string()
                    .replace('\n', " ")
                    .replace("the online estimator tracks", "OnlineCell tracks"),
            )
        })?;
    let rec = &read.record;
    let refine = Refine {
        model: fracbms_host::identify::model_for(model, method),
        ..Refine::default()
    };
    if let Some(w) = sc.warning(name) {
        warn(py, w.strip_prefix("warning: ").unwrap_or(&w))?;
    }
    if let Some(note) = &r.json.start_note {
        warn(py, &format!("{RECORD}: {note}"))?;
    }
    if let Some(why) = &r.json.identifiable_reason {
        warn(py, &format!("{RECORD}: the fit is not identifiable: {why}"))?;
    }
    let mut json = r.json;
    if let (true, Some(spec)) = (map, spec.as_ref()) {
        let gaps = read.report.resampling.gaps.clone();
        let o = fracbms_host::map::MapOptions {
            min_rest_s: min_rest,
            soc_bins,
            method: map_method,
            ..fracbms_host::map::MapOptions::default()
        };
        let m = py
            .detach(|| {
                on_worker(|| {
                    fracbms_host::identify::map::build_map(
                        name,
                        rec,
                        None,
                        &Limits::default(),
                        spec,
                        method,
                        iterations,
                        refine,
                        &o,
                        &gaps,
                        Some(&read.rows),
                        &read.report.steps.unlogged,
                    )
                })
            })
            .map_err(value_error)?;
        let mut m = m;
        m.check_against(rec, &r.model_voltage, &json);
        for why in m.skipped.iter().chain(&m.warnings) {
            warn(py, &format!("{RECORD}: {why}"))?;
        }
        json.map = Some(m.json(rec, &r.model_voltage));
    }
    json.record = Some(read.report);
    let d = to_dict(py, &json)?;
    d.set_item("model_v", PyArray1::from_vec(py, r.model_voltage))?;
    Ok(d)
}

/// Run an identified model on another record (`host-sim predict battery`).
///
/// The model of `identify_battery` (its dict), or its parameter map (the
/// dict's ``map``, from ``identify_battery(..., map=True)``), run on the
/// record's current from rest; its voltage beside the measured one.
///
/// Parameters
/// ----------
/// time_s, current_a, voltage_v : array_like, 1-D
///     The record to validate on (uneven steps put on a uniform period as
///     ``identify_battery`` does).
/// model : dict
///     The dict of ``identify_battery``, or its ``map``.
/// ocv, capacity_ah, soc0 :
///     As for ``identify_battery``; needed when the model was fitted with
///     an OCV table, and for a map.
/// temperature_c : float, optional
///     The record's temperature (°C) for a map over temperature: Arrhenius
///     between the map's temperatures, the nearest held beyond them
///     (default: the map's first).
///
/// Returns
/// -------
/// dict
///     ``rmse_v``, ``max_error_v``, ``max_error_time_s``, ``samples``,
///     ``voltages_skipped``, ``samples_in_gaps``, ``unobserved_samples``,
///     ``currents_held``, ``soc0``, ``soc_end``, ``record``, ``in_table``
///     (the errors over the samples inside the OCV table), ``map`` (for a
///     map: the rows left out, the temperature rule, the activation
///     energies), ``model_v``
///     (numpy array, V) and ``observed`` (numpy array of 0/1: 1 where the
///     voltage is a measurement, the samples the RMSE is taken over).
///
/// Examples
/// --------
/// >>> import numpy as np, fracbms
/// >>> t = np.arange(600.0); i = np.where((t // 50) % 2 == 0, -2.0, 1.0)
/// >>> cell = dict(r_i=0.02, r_ct=0.015, q=500.0, alpha=0.7, u_oc=3.7)
/// >>> v = fracbms.simulate_battery(t, i, **cell)
/// >>> p = fracbms.predict_battery(t, i, v, model=cell)
/// >>> bool(p["rmse_v"] < 1e-9)
/// True
#[pyfunction]
#[pyo3(signature = (time_s, current_a, voltage_v, *, model, ocv=None, capacity_ah=None, soc0=None, temperature_c=None))]
#[allow(clippy::too_many_arguments)]
fn predict_battery<'py>(
    py: Python<'py>,
    time_s: Floats<'py>,
    current_a: Floats<'py>,
    voltage_v: Floats<'py>,
    model: Bound<'py, PyDict>,
    ocv: Option<(Floats<'py>, Floats<'py>)>,
    capacity_ah: Option<f64>,
    soc0: Option<f64>,
    temperature_c: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let spec = ocv_spec(ocv, capacity_ah, soc0)?;
    let text: String = py
        .import("json")?
        .call_method1("dumps", (model,))?
        .extract()?;
    let j: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| PyValueError::new_err(format!("model: not a fit ({e})")))?;
    let name = Path::new(RECORD);
    let read = cycler::record_from_arrays(
        name,
        &vec(&time_s),
        &vec(&current_a),
        &vec(&voltage_v),
        &cycler::RecordOptions::default(),
    )
    .map_err(value_error)?;
    let model = predict::model_from_json(&j, Path::new("model")).map_err(value_error)?;
    let mut p =
        predict::run_model(name, &read, &model, spec.as_ref(), temperature_c).map_err(|e| {
            // The CLI's flags are keywords here.
            let m = e
                .to_string()
                .replace("give --ocv and --capacity-ah", "give ocv and capacity_ah")
                .replace("leave out --ocv", "leave out ocv")
                .replace("--temperature-c ", "temperature_c=");
            PyValueError::new_err(m)
        })?;
    let model_v = std::mem::take(&mut p.model_v);
    let d = to_dict(py, &p)?;
    d.set_item("model_v", PyArray1::from_vec(py, model_v))?;
    // 1 where the sample's voltage is a measurement (the RMSE's samples),
    // as `predict battery`'s `observed` column.
    let unmeasured = fracbms_host::identify::map::not_measured(
        &read.record,
        &read.report.resampling.gaps,
        &read.report.steps.unlogged,
    );
    let observed: Vec<u8> = unmeasured.iter().map(|&u| u8::from(!u)).collect();
    d.set_item("observed", PyArray1::from_vec(py, observed))?;
    Ok(d)
}

/// The terminal voltage of a cell over a current record, from rest.
///
/// The noise-free voltage `host-sim simulate battery` writes (memory: the
/// whole record, at most 4096 samples of Grünwald–Letnikov history).
///
/// Parameters
/// ----------
/// time_s, current_a : array_like, 1-D
///     Time (s, uniform steps) and current (A, positive when charging).
/// r_i, r_ct : float
///     Ohmic and charge-transfer resistances (Ω).
/// q : float
///     The constant-phase element's Q (F·s^(α−1)).
/// alpha : float
///     Fractional order α in (0, 1].
/// u_oc : float
///     Open-circuit voltage (V); without `ocv` only.
/// bv_a_v, bv_i0_a : float
///     Butler–Volmer term `a·asinh(I/i₀)` (V, A); `bv_a_v=0`: linear.
/// ocv : (soc, ocv_v), optional
///     An OCV table: the open-circuit voltage follows `OCV(SOC)`, with
///     `capacity_ah` and `soc0` (both needed), plus `ocv_offset_v`.
///
/// Returns
/// -------
/// numpy.ndarray
///     The terminal voltage (V) after each sample.
///
/// Raises
/// ------
/// ValueError
///     A non-finite time or current, non-uniform time, a cell that is not
///     physical, `u_oc` missing without `ocv` (or given with it).
#[pyfunction]
#[pyo3(signature = (
    time_s, current_a, *, r_i, r_ct, q, alpha, u_oc = None, bv_a_v = 0.0, bv_i0_a = 1.0,
    ocv = None, capacity_ah = None, soc0 = None, ocv_offset_v = 0.0
))]
#[allow(clippy::too_many_arguments)]
fn simulate_battery<'py>(
    py: Python<'py>,
    time_s: Floats<'py>,
    current_a: Floats<'py>,
    r_i: f64,
    r_ct: f64,
    q: f64,
    alpha: f64,
    u_oc: Option<f64>,
    bv_a_v: f64,
    bv_i0_a: f64,
    ocv: Option<(Floats<'py>, Floats<'py>)>,
    capacity_ah: Option<f64>,
    soc0: Option<f64>,
    ocv_offset_v: f64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let spec = ocv_spec(ocv, capacity_ah, soc0)?;
    let cols = Columns::from_arrays(vec![vec(&time_s), vec(&current_a)]);
    let name = Path::new(RECORD);
    io::same_lengths(name, &cols, &["time_s", "current_a"]).map_err(value_error)?;
    io::require_finite(name, &cols, &["time_s", "current_a"], &[0, 1]).map_err(value_error)?;
    let (time, current) = (&cols.data[0], &cols.data[1]);
    let h = io::uniform_step(name, time).map_err(value_error)?;
    let u_oc = match (&spec, u_oc) {
        (None, Some(u)) => u,
        (None, None) => return Err(PyValueError::new_err("u_oc is needed without ocv")),
        (Some(_), Some(_)) => {
            return Err(PyValueError::new_err(
                "u_oc goes without ocv (with a curve the open-circuit voltage is OCV(SOC) + ocv_offset_v)",
            ))
        }
        (Some(_), None) => 0.0,
    };
    let cell = CellParameters {
        r_i,
        r_ct,
        q,
        alpha,
        u_oc,
        bv_a: bv_a_v,
        bv_i0: bv_i0_a,
    };
    if !(cell.is_physical() && u_oc.is_finite() && ocv_offset_v.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "r_i={r_i}, r_ct={r_ct}, q={q}, alpha={alpha}, u_oc={u_oc}, bv_a_v={bv_a_v}, bv_i0_a={bv_i0_a}, ocv_offset_v={ocv_offset_v}: \
             the cell is not physical (a resistance, Q, i₀ not positive or not finite, α outside (0, 1], a < 0)"
        )));
    }
    let curve = match &spec {
        None => OcvCurve::Constant,
        Some(s) => OcvCurve::Table {
            table: &s.model.table,
            soc0: s.soc0.ok_or_else(|| {
                PyValueError::new_err("ocv needs soc0 (the state of charge before the first row)")
            })?,
            capacity_ah: s.model.capacity_ah,
        },
    };
    let v = py
        .detach(|| on_worker(|| battery_voltage(&cell, current, h, curve)))
        .map_err(value_error)?;
    let offset = if spec.is_some() { ocv_offset_v } else { 0.0 };
    Ok(PyArray1::from_vec(
        py,
        v.clean.into_iter().map(|x| x + offset).collect(),
    ))
}

/// Identify a fractional-order Hammerstein system (`host-sim identify hammerstein --json`).
///
/// The paper's model: `A(z) Δ^α y = B(z) f(u) + C(z) Δ^α v` with
/// `f(u) = Σ γ_j u^j`, identified with 2S-OP-GI (`algorithm="op"`) or
/// KT-2S-GI (`"kt"`), then (`method="refined"`, the default) the
/// prediction-error refinement: maximum likelihood, started from a global
/// search over the order (docs/identification.md).
///
/// Parameters
/// ----------
/// u, y : array_like, 1-D
///     Input and output, finite, at most `MAX_ROWS` samples.
/// na, nb, nc : int
///     Orders of A(z), B(z), C(z).
/// basis : str
///     `"poly:m"`: `f_j(u) = u^j`, j = 1..m.
/// algorithm : {"op", "kt"}
/// method : {"refined", "paper"}
/// memory : int, optional
///     Memory of the fractional differences (default: all rows, at most 4096).
/// iterations, refine_iterations : int
///     Most iterations of the paper stage and of the refinement.
/// alpha0 : float
///     Initial order.
///
/// Returns
/// -------
/// dict
///     The keys of `host-sim identify hammerstein --json`: `a`, `b`, `c`,
///     `gamma`, `alpha`, `theta_products`, `cost`, `paper_cost`,
///     `iterations`, `converged`, `refine_*`, `history`, ...
///
/// Raises
/// ------
/// ValueError
///     A non-finite sample, unequal lengths, orders or basis out of range.
#[pyfunction]
#[pyo3(signature = (
    u, y, *, na, nb, nc, basis = "poly:2", algorithm = "op", method = "refined",
    memory = None, iterations = 100, refine_iterations = 400, alpha0 = 0.45
))]
#[allow(clippy::too_many_arguments)]
fn identify_hammerstein<'py>(
    py: Python<'py>,
    u: Floats<'py>,
    y: Floats<'py>,
    na: usize,
    nb: usize,
    nc: usize,
    basis: &str,
    algorithm: &str,
    method: &str,
    memory: Option<usize>,
    iterations: u32,
    refine_iterations: u32,
    alpha0: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let o = HammersteinOptions {
        method: choice::<HammersteinMethod>("method", method)?,
        algorithm: choice::<Algorithm>("algorithm", algorithm)?,
        na,
        nb,
        nc,
        basis: basis.to_string(),
        memory,
        iterations,
        refine_iterations,
        alpha0,
    };
    let cols = Columns::from_arrays(vec![vec(&u), vec(&y)]);
    let j = py
        .detach(|| on_worker(|| hammerstein_fit(Path::new(RECORD), &cols, &o, false)))
        .map_err(value_error)?;
    to_dict(py, &j)
}

/// The module `fracbms._fracbms` (re-exported by `fracbms`).
#[pymodule]
fn _fracbms(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(identify_battery, m)?)?;
    m.add_function(wrap_pyfunction!(predict_battery, m)?)?;
    m.add_function(wrap_pyfunction!(simulate_battery, m)?)?;
    m.add_function(wrap_pyfunction!(identify_hammerstein, m)?)?;
    m.add_function(wrap_pyfunction!(files::identify_files, m)?)?;
    m.add_function(wrap_pyfunction!(files::expand_inputs, m)?)?;
    m.add_function(wrap_pyfunction!(life::life_rows, m)?)?;
    m.add(
        "LIFE_COLUMNS",
        fracbms_host::online::life::LIFE_HEADER
            .split(',')
            .collect::<Vec<_>>(),
    )?;
    m.add_function(wrap_pyfunction!(pack::online_pack, m)?)?;
    m.add_class::<OnlineCell>()?;
    m.add(
        "SUMMARY_COLUMNS",
        fracbms_host::identify::many::SUMMARY_HEADER.to_vec(),
    )?;
    m.add("MAX_ROWS", MAX_ROWS)?;
    m.add("MAX_BATTERY_ROWS", MAX_BATTERY_ROWS)?;
    Ok(())
}
