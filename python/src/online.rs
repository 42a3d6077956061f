//! `OnlineCell`: the sliding-window estimator of one cell, sample by sample
//! (`host-sim online battery`), over `fracbms_host::online::Tracker`.

use super::*;
use fracbms_host::online::soc::{SocMode, SocOptions};
use fracbms_host::online::PublicationTally;
use pyo3::types::PyBytes;

/// The online estimator of one cell (`host-sim online battery`).
///
/// A sliding window of `window` samples with a Grünwald–Letnikov memory of
/// `memory` samples, refitted after every sample as the firmware does: the
/// paper's 2S-OP-GI to start, then the output-error refinement. Feed it one
/// sample at a time with `push` or a record at once with `run`; a bad sample
/// (non-finite, out of range, a spike) is rejected, substituted and counted,
/// never raised, and the last good estimate is kept.
///
/// Parameters
/// ----------
/// window : {64, 128, 256, 512, 1024}
///     Window length L.
/// memory : int
///     Short memory M, 1 to L − 8.
/// h : float
///     Sample period (s).
/// ocv : (soc, ocv_v), optional
///     The cell's OCV table; with `capacity_ah` (needed). The start SOC is
///     `soc0`, or read from the first rested samples.
/// capacity_ah : float, optional
///     Capacity (A·h) for coulomb counting.
/// soc0 : float, optional
///     SOC before the first sample.
/// method : {"refined", "paper"}
/// model : {"auto", "linear", "butler-volmer"}
///     `"auto"` is the prior's model, linear without a prior.
/// prior : str, path or dict, optional
///     The window fit's prior (``online battery --prior``): the JSON of
///     ``identify battery`` (one fit) or the dict of ``identify_battery``;
///     or a parameter map CSV (``identify battery --map-out``), whose cell
///     at the counted SOC (and at the temperature given to ``push``/``run``)
///     is the prior's centre as the cell moves; levels not identifiable are
///     left out.
/// map : str, path or dict, optional
///     A parameter map as the prior (instead of ``prior``): its CSV, or the
///     ``map`` of ``identify_battery(..., map=True)`` (that dict, or the
///     whole result).
/// prior_factor, prior_alpha_sigma, prior_noise_mv : float
///     The prior's spreads (``--prior-factor``, ``--prior-alpha-sigma``,
///     ``--prior-noise-mv``).
/// precision : {"f64", "f32"}
///     `"f32"` runs the firmware's arithmetic.
/// start : {"from-data", "at-rest"}
/// iterations_per_sample : int
/// tail : bool
///     The short-memory correction (docs/pack.md).
///
/// Raises
/// ------
/// ValueError
///     A window or memory the estimator does not take, a bad OCV table or
///     keyword.
#[pyclass(module = "fracbms")]
pub(crate) struct OnlineCell {
    tracker: Tracker,
    /// Sample period (s).
    h: f64,
    /// Samples pushed.
    pushed: u64,
    /// The curve, while the start SOC is still to be read (a `run` from
    /// the start reads it from the record's rested start, as the CLI).
    unresolved: Option<OcvSpec>,
    window: usize,
    memory: usize,
    /// The state-of-power horizons (s): their columns follow the track's.
    horizons: Vec<f64>,
}

/// The state-of-power columns of a row, `(name, value)` per horizon `H`:
/// `sop_discharge_a_{H}s`, `sop_charge_a_{H}s`, `pulse_v_{H}s`.
fn power_columns(horizons: &[f64], r: &TrackRow) -> Vec<(String, Option<f64>)> {
    horizons
        .iter()
        .zip(&r.power)
        .flat_map(|(h, p)| {
            [
                (format!("sop_discharge_a_{h}s"), p.discharge_a),
                (format!("sop_charge_a_{h}s"), p.charge_a),
                (format!("pulse_v_{h}s"), p.pulse_v),
            ]
        })
        .collect()
}

/// One numeric column of a track row.
type Column = fn(&TrackRow) -> Option<f64>;

/// The numeric columns of a track row under the names of `online battery
/// --out` (`None`: the CSV's empty cell): `push`'s dict and `run`'s arrays.
/// `r_i`, `r_ct`, `q`, `alpha` are the published values (the last window's
/// that identified each); `window_*` the last good window's fit.
const TRACK_NUMBERS: [(&str, Column); 23] = [
    ("time_s", |r| Some(r.t)),
    ("r_i", |r| r.published.r_i.value),
    ("r_ct", |r| r.published.r_ct.value),
    ("q", |r| r.published.q.value),
    ("alpha", |r| r.published.alpha.value),
    ("u_oc", |r| r.estimate.map(|p| p.u_oc)),
    ("soc", |r| r.soc),
    ("ocv_offset_v", |r| r.estimate.and(r.ocv_offset)),
    ("bv_a_v", |r| butler_volmer(r).map(|p| p.bv_a)),
    ("bv_i0_a", |r| butler_volmer(r).map(|p| p.bv_i0)),
    ("predicted_v", |r| r.predicted),
    ("step_resistance_ohm", |r| r.step_resistance),
    ("window_r_i", |r| r.estimate.map(|p| p.r_i)),
    ("window_r_ct", |r| r.estimate.map(|p| p.r_ct)),
    ("window_q", |r| r.estimate.map(|p| p.q)),
    ("window_alpha", |r| r.estimate.map(|p| p.alpha)),
    ("soc_coulomb", |r| r.soc_detail.columns()[0]),
    ("current_bias_a", |r| r.soc_detail.columns()[1]),
    ("capacity_ah", |r| r.soc_detail.columns()[2]),
    ("capacity_sigma_ah", |r| r.soc_detail.columns()[3]),
    ("soc_sigma", |r| r.soc_detail.columns()[4]),
    ("soc_ocv_weight", |r| r.soc_detail.columns()[5]),
    ("soh_r", |r| r.soh_r),
];

/// One text column of a track row.
type Text = fn(&TrackRow) -> &'static str;

/// The status columns of a track row (`identified`, `held`, `step`,
/// `prior`, `expired`, `restored` or `not_identified`), as in `online
/// battery --out`.
const TRACK_STATUSES: [(&str, Text); 5] = [
    ("r_i_status", |r| r.published.r_i.status.as_str()),
    ("r_ct_status", |r| r.published.r_ct.status.as_str()),
    ("q_status", |r| r.published.q.status.as_str()),
    ("alpha_status", |r| r.published.alpha.status.as_str()),
    ("capacity_status", |r| r.soc_detail.capacity_status()),
];

/// The estimate of a row when it has the Butler–Volmer term.
fn butler_volmer(r: &TrackRow) -> Option<CellParameters<f64>> {
    r.estimate.filter(|p| p.is_butler_volmer())
}

/// A track row as `push` returns it.
fn row_dict<'py>(py: Python<'py>, r: &TrackRow, horizons: &[f64]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (k, f) in TRACK_NUMBERS {
        d.set_item(k, f(r))?;
    }
    for (k, v) in power_columns(horizons, r) {
        d.set_item(k, v)?;
    }
    d.set_item("status", r.status)?;
    for (k, f) in TRACK_STATUSES {
        d.set_item(k, f(r))?;
    }
    d.set_item("rejected", r.rejected)?;
    Ok(d)
}

/// The prior of `prior=` or `map=` (`keyword`): a file (a map's CSV for
/// `map=`), or a dict (a fit's, a map's `{"levels": …}`, or for `map=` a
/// fit's with its `map`).
fn prior_source(
    py: Python<'_>,
    value: &Bound<'_, PyAny>,
    keyword: &str,
    map_only: bool,
    (factor, alpha_sigma, noise_mv): (f64, f64, f64),
) -> PyResult<PriorSource> {
    let spread = |e: fracbms_host::Error| {
        PyValueError::new_err(
            e.to_string()
                .replace("--prior-factor ", "prior_factor=")
                .replace("--prior-*", "prior_*"),
        )
    };
    if let Ok(path) = value.extract::<std::path::PathBuf>() {
        let is_csv = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
        if map_only && !is_csv {
            return Err(PyValueError::new_err(format!(
                "map={}: give a map's CSV (identify battery --map-out) or the map of identify_battery(..., map=True)",
                path.display()
            )));
        }
        return read_prior_source(&path, factor, alpha_sigma, noise_mv).map_err(spread);
    }
    let Ok(d) = value.cast::<PyDict>() else {
        return Err(PyValueError::new_err(format!(
            "{keyword}=: give a path or a dict"
        )));
    };
    // The numbers only: a result's arrays (`model_v`) are not read.
    let numbers = PyDict::new(py);
    for (k, v) in d.iter() {
        if !v.hasattr("__array__")? {
            numbers.set_item(k, v)?;
        }
    }
    let text: String = py
        .import("json")?
        .call_method1("dumps", (numbers,))?
        .extract()?;
    let mut j: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| PyValueError::new_err(format!("{keyword}=: not JSON ({e})")))?;
    if map_only {
        // The whole result of identify_battery(..., map=True): its map.
        if j.get("levels").is_none() {
            match j.get("map") {
                Some(m) if m.get("levels").is_some() => j = m.clone(),
                _ => {
                    return Err(PyValueError::new_err(format!(
                        "{keyword}=: no levels: give the map of identify_battery(..., map=True)"
                    )))
                }
            }
        }
    }
    fracbms_host::online::prior_source_from_json(
        &j,
        Path::new(keyword),
        factor,
        alpha_sigma,
        noise_mv,
    )
    .map_err(spread)
}

#[pymethods]
impl OnlineCell {
    #[new]
    #[pyo3(signature = (
        window = 256, memory = 64, h = 1.0, ocv = None, capacity_ah = None, *, soc0 = None,
        method = "refined", model = "auto", precision = "f64", start = "from-data",
        iterations_per_sample = 1, tail = false, prior = None, map = None, prior_factor = 2.0,
        prior_alpha_sigma = 0.1, prior_noise_mv = 100.0, horizons = vec![10.0, 30.0],
        voltage_min = None, voltage_max = None, current_limit = None, pulse_current_a = None,
        soc = "observer", soc_rest_s = None, soc_bias_sigma_a = None, soc_rest_load_sigma_a = None,
        soc_voltage_sigma_v = None, sop_carry_s = None
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        window: usize,
        memory: usize,
        h: f64,
        ocv: Option<(Floats<'_>, Floats<'_>)>,
        capacity_ah: Option<f64>,
        soc0: Option<f64>,
        method: &str,
        model: &str,
        precision: &str,
        start: &str,
        iterations_per_sample: u16,
        tail: bool,
        prior: Option<Bound<'_, PyAny>>,
        map: Option<Bound<'_, PyAny>>,
        prior_factor: f64,
        prior_alpha_sigma: f64,
        prior_noise_mv: f64,
        horizons: Vec<f64>,
        voltage_min: Option<f64>,
        voltage_max: Option<f64>,
        current_limit: Option<f64>,
        pulse_current_a: Option<f64>,
        soc: &str,
        soc_rest_s: Option<f64>,
        soc_bias_sigma_a: Option<f64>,
        soc_rest_load_sigma_a: Option<f64>,
        soc_voltage_sigma_v: Option<f64>,
        sop_carry_s: Option<f64>,
    ) -> PyResult<Self> {
        if !(h.is_finite() && h > 0.0) {
            return Err(PyValueError::new_err(format!(
                "h={h}: must be finite and positive"
            )));
        }
        let method: BatteryMethod = choice("method", method)?;
        let model: ModelRequest = choice("model", model)?;
        let precision: Precision = choice("precision", precision)?;
        let start: Start = choice("start", start)?;
        let soc: SocMode = choice("soc", soc)?;
        let spec = ocv_spec(ocv, capacity_ah, soc0)?;
        let cell = spec.map(|s| CellOcv {
            model: s.model,
            soc0: s.soc0.unwrap_or(f64::NAN),
        });
        let spreads = (prior_factor, prior_alpha_sigma, prior_noise_mv);
        let source = match (prior, map) {
            (Some(_), Some(_)) => {
                return Err(PyValueError::new_err(
                    "prior= and map=: give one (a map is a prior that follows the SOC)",
                ))
            }
            (Some(p), None) => Some(prior_source(py, &p, "prior", false, spreads)?),
            (None, Some(m)) => Some(prior_source(py, &m, "map", true, spreads)?),
            (None, None) => None,
        };
        if let Some(PriorSource::Map(m)) = &source {
            for why in &m.left_out {
                let msg = CString::new(format!("prior map: {why} (left out)"))
                    .map_err(|e| PyValueError::new_err(e.to_string()))?;
                PyErr::warn(py, &py.get_type::<PyUserWarning>(), &msg, 1)?;
            }
        }
        let o = TrackOptions {
            window,
            memory,
            iterations_per_sample,
            method,
            precision,
            start,
            prior: match &source {
                Some(PriorSource::Fit(p)) => Some(p),
                _ => None,
            },
            prior_map: match &source {
                Some(PriorSource::Map(m)) => Some(m),
                _ => None,
            },
            cell: cell.as_ref(),
            model,
            tail,
            power: power_options(
                &horizons,
                voltage_min,
                voltage_max,
                current_limit,
                pulse_current_a,
                sop_carry_s,
            )?,
            soc: SocOptions {
                mode: soc,
                rest_s: soc_rest_s,
                bias_sigma_a: soc_bias_sigma_a,
                rest_load_sigma_a: soc_rest_load_sigma_a,
                voltage_sigma_v: soc_voltage_sigma_v,
            },
        };
        let tracker = py
            .detach(|| on_worker(|| Tracker::new(&o, h, spec.and_then(|s| s.soc0))))
            .map_err(|e| {
                // The CLI's flags are this class's keywords.
                PyValueError::new_err(
                    format!("{e:#}")
                        .replace("--memory ", "memory=")
                        .replace("--window ", "window="),
                )
            })?;
        Ok(Self {
            tracker,
            h,
            pushed: 0,
            unresolved: spec.filter(|s| s.soc0.is_none()),
            window,
            memory,
            horizons,
        })
    }

    /// Feed one sample: current (A, positive when charging) and voltage (V).
    ///
    /// Returns None while the window is filling, else a dict: `time_s`
    /// (`k·h`), `r_i`, `r_ct`, `q`, `alpha` (None until the data identify
    /// each; `r_i_status`, `r_ct_status`, `q_status`, `alpha_status` say
    /// `"identified"`, `"held"`, `"step"` (R_i from the step resistance), `"prior"` (a prior holds it, the data alone do not identify it), `"expired"`, `"restored"` or `"not_identified"`), `u_oc` (None until
    /// the first physical estimate), `window_r_i`, `window_r_ct`,
    /// `window_q`, `window_alpha` (that estimate's fit, identified or
    /// not), `step_resistance_ohm`, `status` (`"starting"`, `"tracking"`, or why the
    /// estimate is held: `"not_excited"`, `"held"`, `"unphysical"`,
    /// `"at_bound"`, `"slow_relaxation"`, `"ocv_implausible"`), `soc`,
    /// `ocv_offset_v`, `bv_a_v`, `bv_i0_a`, `predicted_v` (this sample's
    /// voltage predicted from the estimate before it) and `rejected` (None,
    /// `"non_finite"`, `"out_of_range"` or `"spike"`). Never raises on data.
    /// `temperature_c` (°C) picks a map prior's temperature (a non-finite
    /// value is ignored).
    #[pyo3(signature = (current_a, voltage_v, temperature_c = None))]
    fn push<'py>(
        &mut self,
        py: Python<'py>,
        current_a: f64,
        voltage_v: f64,
        temperature_c: Option<f64>,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        if let Some(t) = temperature_c {
            self.tracker.set_temperature(t);
        }
        // From here on the core reads the start SOC from the stream.
        self.unresolved = None;
        let t = self.pushed as f64 * self.h;
        let r = self.tracker.push(t, current_a, voltage_v);
        self.pushed += 1;
        if r.status == "filling" {
            return Ok(None);
        }
        row_dict(py, &r, &self.horizons).map(Some)
    }

    /// Feed a whole record; return the track as a dict of numpy arrays.
    ///
    /// The columns of `host-sim online battery --out`: `time_s`, `r_i`,
    /// `r_ct`, `q`, `alpha` (each published only once the data identify
    /// it; `r_i_status`… say `identified`, `held`, `step`, `prior`, `expired`, `restored` or `not_identified`),
    /// `u_oc`, `status`, `soc`, `ocv_offset_v`, `bv_a_v`, `bv_i0_a`,
    /// `predicted_v`, `step_resistance_ohm`, `window_r_i`, `window_r_ct`,
    /// `window_q`, `window_alpha` (the last good window's fit, identified
    /// or not; NaN where the CSV is empty), plus `rejected` (`""` for an
    /// accepted sample). On a fresh cell with an OCV
    /// table and no `soc0`, the start SOC is read from the record's rested
    /// start, as the CLI reads it (a ValueError when it does not start at
    /// rest). Goes on from the samples pushed before. `temperature_c` (°C,
    /// one per sample) picks a map prior's temperature.
    #[pyo3(signature = (current_a, voltage_v, temperature_c = None))]
    fn run<'py>(
        &mut self,
        py: Python<'py>,
        current_a: Floats<'py>,
        voltage_v: Floats<'py>,
        temperature_c: Option<Floats<'py>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let temperature = temperature_c.as_ref().map(vec);
        if let Some(t) = &temperature {
            if t.len() != current_a.as_array().len() {
                return Err(PyValueError::new_err(format!(
                    "temperature_c has {} values, current_a {}",
                    t.len(),
                    current_a.as_array().len()
                )));
            }
        }
        let cols = Columns::from_arrays(vec![vec(&current_a), vec(&voltage_v)]);
        io::same_lengths(Path::new(RECORD), &cols, &["current_a", "voltage_v"])
            .map_err(value_error)?;
        let [current, voltage]: [Vec<f64>; 2] = cols
            .data
            .try_into()
            .map_err(|_| PyValueError::new_err("internal error: two columns expected"))?;
        if let Some(spec) = self.unresolved.take() {
            // A fresh cell with a curve and no soc0: as `online battery`,
            // the start SOC from the record's rested start.
            let rec = BatteryRecord {
                time: (0..current.len()).map(|k| k as f64 * self.h).collect(),
                current: current.clone(),
                voltage: voltage.clone(),
                h: self.h,
            };
            let c = spec.resolve(Path::new(RECORD), &rec).map_err(|e| {
                self.unresolved = Some(spec);
                value_error(e)
            })?;
            self.tracker.set_state_of_charge(c.soc0);
        }
        let (h, first) = (self.h, self.pushed);
        let tracker = &mut self.tracker;
        let rows: Vec<TrackRow> = py.detach(|| {
            current
                .iter()
                .zip(&voltage)
                .enumerate()
                .map(|(k, (&i, &v))| {
                    if let Some(t) = temperature.as_ref().and_then(|t| t.get(k)) {
                        tracker.set_temperature(*t);
                    }
                    tracker.push((first + k as u64) as f64 * h, i, v)
                })
                .collect()
        });
        self.pushed += rows.len() as u64;
        let d = PyDict::new(py);
        for (k, f) in TRACK_NUMBERS {
            let column: Vec<f64> = rows.iter().map(|r| f(r).unwrap_or(f64::NAN)).collect();
            d.set_item(k, PyArray1::from_vec(py, column))?;
        }
        for (j, (k, _)) in rows
            .first()
            .map(|r| power_columns(&self.horizons, r))
            .unwrap_or_default()
            .into_iter()
            .enumerate()
        {
            let column: Vec<f64> = rows
                .iter()
                .map(|r| power_columns(&self.horizons, r)[j].1.unwrap_or(f64::NAN))
                .collect();
            d.set_item(k, PyArray1::from_vec(py, column))?;
        }
        let np = py.import("numpy")?;
        let strings = |f: &dyn Fn(&TrackRow) -> &'static str| -> PyResult<Bound<'py, PyAny>> {
            let list: Vec<&str> = rows.iter().map(f).collect();
            np.call_method1("array", (list, "U16"))
        };
        d.set_item("status", strings(&|r| r.status)?)?;
        for (k, f) in TRACK_STATUSES {
            d.set_item(k, strings(&f)?)?;
        }
        d.set_item("rejected", strings(&|r| r.rejected.unwrap_or(""))?)?;
        Ok(d)
    }

    /// The record resumes after a gap of unknown charge (a logger that
    /// stopped): the window restarts and, when ``rested`` (the cell at rest
    /// where it resumes), the state of charge is read again from the next
    /// rested voltages through the OCV table, as at the start, and the
    /// restarted window is fitted from rest until it slides (a pulse right
    /// after the gap is fitted). What is published stays, held. The CLI
    /// does this at every gap of a file.
    fn resume_after_gap(&mut self, rested: bool) {
        self.tracker.resume_after_gap(rested);
    }

    /// The snapshot of what the cell has learned, as bytes
    /// (docs/persistence.md): the bytes of ``host-sim online battery
    /// --state-out`` and of the C ABI's ``fracbms_cell_snapshot_save``.
    /// ``saved_at_s`` is the caller's clock (s; ``None``: unknown), judged
    /// for the snapshot's age at a restore.
    #[pyo3(signature = (saved_at_s = None))]
    fn save_state<'py>(&self, py: Python<'py>, saved_at_s: Option<f64>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.tracker.save_state(saved_at_s.unwrap_or(f64::NAN)))
    }

    /// Restore the cell from a snapshot (``save_state``'s bytes), before
    /// its first sample: the parameters, SOC, current bias and capacity it
    /// had learned, published with status ``restored`` until a window
    /// identifies them; the SOC is read again from the OCV table when the
    /// first rested voltage contradicts it (``restoration``). ``now_s`` is
    /// the caller's clock (s; ``None``: the age is not judged).
    ///
    /// Raises
    /// ------
    /// ValueError
    ///     The snapshot was rejected (corrupt, stale, from another layout
    ///     version or other settings, implausible values); the cell stays
    ///     clean.
    #[pyo3(signature = (snapshot, now_s = None))]
    fn restore_state(&mut self, snapshot: &[u8], now_s: Option<f64>) -> PyResult<()> {
        self.tracker
            .restore_state(snapshot, now_s.unwrap_or(f64::NAN))
            .map_err(|e| PyValueError::new_err(format!("snapshot rejected: {e}")))?;
        // The snapshot's SOC, not the record's rested start.
        self.unresolved = None;
        Ok(())
    }

    /// How the cell started: ``"clean"``, ``"restored"`` (from a snapshot)
    /// or ``"soc_reread"`` (a snapshot whose SOC the first rested voltage
    /// contradicted).
    #[getter]
    fn restoration(&self) -> &'static str {
        self.tracker.restoration().as_str()
    }

    /// Samples offered so far.
    #[getter]
    fn samples(&self) -> u64 {
        self.tracker.summary().samples
    }

    /// Samples rejected (and substituted) so far.
    #[getter]
    fn rejected(&self) -> u32 {
        self.tracker.summary().rejected
    }

    /// What has been published so far, as ``online battery`` says after
    /// its track: ``{"samples": n, "state_of_power": n, "r_i": {"identified":
    /// n, "held": n, …}, "r_ct": …, "q": …, "alpha": …}``, each parameter
    /// with the samples of every status (``identified``, ``step``,
    /// ``prior``, ``restored``, ``held``: a value published; ``expired``,
    /// ``not_identified``: none).
    #[getter]
    fn published<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let t = self.tracker.summary().published;
        let d = PyDict::new(py);
        d.set_item("samples", t.samples())?;
        d.set_item("state_of_power", t.state_of_power())?;
        for (j, name) in PublicationTally::NAMES.into_iter().enumerate() {
            let by = PyDict::new(py);
            for (status, n) in t.statuses(j) {
                by.set_item(status.as_str(), n)?;
            }
            d.set_item(name, by)?;
        }
        Ok(d)
    }

    /// The window length L.
    #[getter]
    fn window(&self) -> usize {
        self.window
    }

    /// The short memory M.
    #[getter]
    fn memory(&self) -> usize {
        self.memory
    }

    /// The sample period (s).
    #[getter]
    fn h(&self) -> f64 {
        self.h
    }

    fn __repr__(&self) -> String {
        format!(
            "OnlineCell(window={}, memory={}, h={}, samples={})",
            self.window, self.memory, self.h, self.pushed
        )
    }
}
