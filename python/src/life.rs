//! `life_rows`: a cell's life, its logs run through one estimator in the
//! order they were taken, as `host-sim online battery --input DIR
//! --life-out` runs it ([`fracbms_host::online::life`]). `fracbms.life`
//! (`fracbms/life.py`) makes the rows a DataFrame.

use super::files::{files, record_options};
use super::{value_error, warn};
use fracbms_host::ocv::OcvOptions;
use fracbms_host::online::life::{self, LIFE_HEADER};
use fracbms_host::online::OnlineBatteryOptions;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;

/// Raises
/// ------
/// ValueError
///     No files, a start-time table that does not cover them, an option
///     the CLI refuses. A log that cannot be run is not raised: a warning,
///     and its row's ``error`` says why.
#[pyfunction]
#[pyo3(signature = (
    paths, *, out_dir, start_times = None, ocv = None, capacity_ah = None, soc0 = None,
    window = 256, columns = None, current_sign = "charge-positive", period_s = None,
    steps = "auto", voltage_min = None, voltage_max = None
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn life_rows<'py>(
    py: Python<'py>,
    paths: &Bound<'py, PyAny>,
    out_dir: PathBuf,
    start_times: Option<PathBuf>,
    ocv: Option<PathBuf>,
    capacity_ah: Option<f64>,
    soc0: Option<f64>,
    window: usize,
    columns: Option<&str>,
    current_sign: &str,
    period_s: Option<f64>,
    steps: &str,
    voltage_min: Option<f64>,
    voltage_max: Option<f64>,
) -> PyResult<Bound<'py, PyList>> {
    let mut power = fracbms_host::online::power::PowerOptions::default();
    power.voltage_min = voltage_min;
    power.voltage_max = voltage_max;
    let o = OnlineBatteryOptions {
        power,
        window,
        ocv: OcvOptions {
            ocv,
            capacity_ah,
            soc0,
        },
        record: record_options(columns, current_sign, period_s, steps)?,
        ..OnlineBatteryOptions::default()
    };
    let label = paths
        .extract::<PathBuf>()
        .unwrap_or_else(|_| PathBuf::from("paths"));
    let list = files(paths)?;
    let mut notes = vec![];
    let logs = life::order_logs(list, &label, start_times.as_deref(), &o.record, |l| {
        notes.push(l)
    })
    .map_err(value_error)?;
    let lived = py.detach(|| life::run_life(&logs, &out_dir, &o, None, |l| notes.push(l)));
    for n in notes.iter().filter(|n| n.starts_with("warning: ")) {
        warn(py, n.trim_start_matches("warning: "))?;
    }
    let lived = lived.map_err(value_error)?;
    let out = PyList::empty(py);
    let keys: Vec<&str> = LIFE_HEADER.split(',').collect();
    for r in &lived.rows {
        let d = PyDict::new(py);
        let file = r.file.display().to_string();
        d.set_item(keys[0], file)?;
        d.set_item(keys[1], r.start_time.clone())?;
        d.set_item(keys[2], r.samples)?;
        d.set_item(keys[3], r.discharged_ah)?;
        d.set_item(keys[4], r.charged_ah)?;
        d.set_item(keys[5], r.r_i)?;
        d.set_item(keys[6], r.r_i_status)?;
        d.set_item(keys[7], r.r_ct)?;
        d.set_item(keys[8], r.alpha)?;
        d.set_item(keys[9], r.capacity_ah)?;
        d.set_item(keys[10], r.capacity_status)?;
        d.set_item(keys[11], r.soh_c)?;
        d.set_item(keys[12], r.soh_r)?;
        d.set_item(keys[13], r.error.clone())?;
        d.set_item(keys[14], r.capacity_source)?;
        out.append(d)?;
    }
    Ok(out)
}
