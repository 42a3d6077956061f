//! `OnlineCell`: the sliding-window estimator of one cell, sample by sample
//! (`host-sim online battery`), over `fracbms_host::online::Tracker`.

use super::*;
use estimator_core::battery::power::VoltageTiming;
use fracbms_host::online::schema::{track_fields, Cell, Kind};
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

/// A track row as `push` returns it: the columns of `online battery --out`
/// (`fracbms_host::online::schema::TRACK_COLUMNS`, without `restoration`)
/// under their names, the
/// numbers first (`None`: the CSV's empty cell), then the words.
fn row_dict<'py>(py: Python<'py>, r: &TrackRow, horizons: &[f64]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let fields = track_fields(horizons, false);
    let (numbers, words): (Vec<_>, Vec<_>) = fields.iter().partition(|f| f.is_number());
    for f in numbers.into_iter().chain(words) {
        match f.cell(r) {
            Cell::Index(k) => d.set_item(f.name(), k)?,
            Cell::Flag(b) => d.set_item(f.name(), b)?,
            Cell::Word(w) => d.set_item(f.name(), w)?,
            c => d.set_item(f.name(), c.number())?,
        }
    }
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
        soc_voltage_sigma_v = None, sop_carry_s = None, sop_confidence = None,
        pulse_correction = true, slow_memory_s = None, slow_memory_soc = None, capacity_min_span = None,
        voltage_timing = "end"
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
        sop_confidence: Option<f64>,
        pulse_correction: bool,
        slow_memory_s: Option<f64>,
        slow_memory_soc: Option<f64>,
        capacity_min_span: Option<f64>,
        voltage_timing: &str,
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
                sop_confidence,
                pulse_correction,
            )?,
            soc: SocOptions {
                mode: soc,
                rest_s: soc_rest_s,
                bias_sigma_a: soc_bias_sigma_a,
                rest_load_sigma_a: soc_rest_load_sigma_a,
                voltage_sigma_v: soc_voltage_sigma_v,
                capacity_min_span,
            },
            slow_memory_s,
            slow_memory_soc,
            voltage_timing: match voltage_timing {
                "end" => VoltageTiming::End,
                "mean" => VoltageTiming::Mean,
                "start" => VoltageTiming::Start,
                other => {
                    return Err(PyValueError::new_err(format!(
                        "voltage_timing={other:?}: must be \"end\", \"mean\" or \"start\""
                    )))
                }
            },
        };
        let tracker = py
            .detach(|| on_worker(|| Tracker::new(&o, h, spec.and_then(|s| s.soc0))))
            .map_err(|e| {
                // The CLI's flags are this class's keywords.
                PyValueError::new_err(
                    format!("{e:#}")
                        .replace("--memory ", "memory=")
                        .replace("--window ", "window=")
                        .replace("--horizons ", "horizons="),
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
        // The columns of `row_dict`, each an array (NaN where the CSV is
        // empty, `""` for an empty word); no rows, no state-of-power
        // columns.
        let horizons: &[f64] = if rows.is_empty() { &[] } else { &self.horizons };
        let fields = track_fields(horizons, false);
        let (numbers, words): (Vec<_>, Vec<_>) = fields.iter().partition(|f| f.is_number());
        let d = PyDict::new(py);
        let np = py.import("numpy")?;
        for f in numbers.into_iter().chain(words) {
            let cells = rows.iter().map(|r| f.cell(r));
            match f.kind() {
                Kind::Time | Kind::Number => {
                    let c: Vec<f64> = cells.map(|c| c.number().unwrap_or(f64::NAN)).collect();
                    d.set_item(f.name(), PyArray1::from_vec(py, c))?;
                }
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
                    d.set_item(f.name(), np.call_method1("array", (c, "U16"))?)?;
                }
            }
        }
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

    /// The record resumes after a gap whose charge is known: ``charge_ah``
    /// (A·h, positive when charging) moved through it beyond what the
    /// samples across it counted (a cycler's own charge count over the
    /// gap, less the current held across it). As ``resume_after_gap``,
    /// but the state of charge is counted through the gap, not read again,
    /// so the capacity is learned across it. The CLI does this at every gap
    /// of a file whose export counts its charge (docs/cycler.md).
    fn bridge_gap(&mut self, charge_ah: f64, rested: bool) {
        self.tracker.bridge_gap(charge_ah, rested);
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
