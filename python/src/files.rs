//! `identify_files`: records read from files and fitted on all cores, one
//! summary row per file, as `host-sim identify battery --input DIR_OR_GLOB
//! --summary-out` writes them ([`fracbms_host::identify::many`]). The
//! fleet module (`fracbms/fleet.py`) spreads the same call over a Dask
//! cluster.

use super::{choice, to_dict, value_error};
use fracbms_host::cycler::{ColumnMap, CurrentSign, RecordOptions, StepsMode};
use fracbms_host::identify::many::{self, ManyOptions};
use fracbms_host::identify::record::BatteryFitOptions;
use fracbms_host::identify::{BatteryMethod, ModelRequest};
use fracbms_host::map::{MapMethod, MapOptions};
use fracbms_host::ocv::OcvOptions;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;

/// The files of `paths`: one path (a file, a directory, a glob pattern) is
/// expanded as the CLI's `--input`; a sequence is taken as it is.
pub(crate) fn files(paths: &Bound<'_, PyAny>) -> PyResult<Vec<PathBuf>> {
    if let Ok(one) = paths.extract::<PathBuf>() {
        return many::expand_inputs(&one).map_err(value_error);
    }
    let list: Vec<PathBuf> = paths.extract().map_err(|_| {
        PyValueError::new_err(
            "paths: give a path (a file, a directory or a glob pattern) or a sequence of paths",
        )
    })?;
    Ok(list)
}

/// How a file is read: the keywords `columns=`, `current_sign=`,
/// `period_s=`, `steps=` as the CLI's `--columns`, `--current-sign`,
/// `--period`, `--steps`.
pub(crate) fn record_options(
    columns: Option<&str>,
    current_sign: &str,
    period_s: Option<f64>,
    steps: &str,
) -> PyResult<RecordOptions> {
    Ok(RecordOptions {
        columns: columns
            .map(ColumnMap::parse)
            .transpose()
            .map_err(value_error)?
            .unwrap_or_default(),
        current_sign: choice::<CurrentSign>("current_sign", current_sign)?,
        period: period_s,
        steps: choice::<StepsMode>("steps", steps)?,
        ..RecordOptions::default()
    })
}

/// Raises
/// ------
/// ValueError
///     An option the CLI refuses (before any file is read); a directory or
///     pattern with no record files. A file that cannot be read or fitted
///     is not raised: its row has ``status`` ``"error"``.
#[pyfunction]
#[pyo3(signature = (
    paths, *, ocv = None, capacity_ah = None, soc0 = None, method = "refined", model = "auto",
    iterations = 50, memory = None, map = false, soc_bins = None, min_rest = 600.0,
    map_method = "joint", temperature_c = None, columns = None, current_sign = "charge-positive", period_s = None,
    steps = "auto", voltage_min = None, voltage_max = None, current_limit = None, jobs = None
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn identify_files<'py>(
    py: Python<'py>,
    paths: &Bound<'py, PyAny>,
    ocv: Option<PathBuf>,
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
    temperature_c: Option<f64>,
    columns: Option<&str>,
    current_sign: &str,
    period_s: Option<f64>,
    steps: &str,
    voltage_min: Option<f64>,
    voltage_max: Option<f64>,
    current_limit: Option<f64>,
    jobs: Option<usize>,
) -> PyResult<Bound<'py, PyList>> {
    let o = BatteryFitOptions {
        method: choice::<BatteryMethod>("method", method)?,
        memory,
        iterations: Some(iterations),
        refine_memory: None,
        ocv_slope: false,
        model: choice::<ModelRequest>("model", model)?,
        ocv: OcvOptions {
            ocv,
            capacity_ah,
            soc0,
        },
        voltage_min,
        voltage_max,
        current_limit,
        record: record_options(columns, current_sign, period_s, steps)?,
    };
    let map_method = choice::<MapMethod>("map_method", map_method)?;
    let m = ManyOptions {
        map: map.then(|| MapOptions {
            min_rest_s: min_rest,
            soc_bins,
            temperature_c,
            method: map_method,
            ..MapOptions::default()
        }),
        jobs,
    };
    many::check_options(&o, &m).map_err(|e| {
        PyValueError::new_err(
            e.to_string()
                .replace("--ocv and --capacity-ah", "ocv and capacity_ah")
                .replace("--jobs", "jobs="),
        )
    })?;
    let files = files(paths)?;
    let rows = py.detach(|| many::identify_many(&files, &o, &m, |_| {}));
    let out = PyList::empty(py);
    for r in &rows {
        let d: Bound<'py, PyDict> = to_dict(py, r)?;
        out.append(d)?;
    }
    Ok(out)
}

/// Raises
/// ------
/// ValueError
///     A directory that cannot be read, a pattern that does not parse, or
///     an input that names no file.
#[pyfunction]
pub(crate) fn expand_inputs(path: PathBuf) -> PyResult<Vec<String>> {
    Ok(many::expand_inputs(&path)
        .map_err(value_error)?
        .iter()
        .map(|p| p.display().to_string())
        .collect())
}
