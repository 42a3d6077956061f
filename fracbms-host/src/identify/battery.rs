//! `identify battery`: the paper's §6.2 regression (2S-OP-GI) over a whole
//! record (run by `super::paper`), the output-error refinement from it, the Butler–Volmer choice
//! ([`super::model_choice`]), the OCV curve's overpotential, and the
//! screening and verdict of [`crate::trust`]. The estimators are
//! `estimator-core`'s; this module drives them in `f64` and reports.

use super::model_choice::{choose_model, ModelChoice};
use super::paper::{PaperRun, RegressionRun};
use super::refine::{refine_best, stop_reason_name, FitStop, LoggedWindow, Refinement, Spares};
pub use super::starts::{
    most_excited, rough_starts, PROJECTED_START_ROWS, PROJECTED_START_TOLERANCE,
    START_REGRESSION_ROWS,
};
use super::{BatteryMethod, HistoryEntry, ModelRequest, BAT_MEM, MAX_BATTERY_ROWS};
use crate::branch::FftBranch;
use crate::error::Result;
use crate::{bail, err, io, trust};
use estimator_core::battery::output_error::{AtBounds, FitInformation};
use estimator_core::battery::{BatterySettings, CellModel, CellParameters};
use serde::Serialize;
use std::path::Path;

/// The JSON of `identify battery`.
#[derive(Serialize, Debug, Clone)]
pub struct BatteryJson {
    /// "paper" or "refined".
    pub method: &'static str,
    /// R_i (Ω).
    pub r_i: f64,
    /// R_ct (Ω).
    pub r_ct: f64,
    /// Q (F·s^(α−1)).
    pub q: f64,
    /// α.
    pub alpha: f64,
    /// U_oc (V). With an OCV curve: the model's open-circuit voltage at the
    /// end of the record, `OCV(soc_end) + ΔU`.
    pub u_oc: f64,
    /// With an OCV curve: the offset ΔU (V) the model adds to `OCV(SOC)`
    /// (null without a curve).
    pub ocv_offset_v: Option<f64>,
    /// With an OCV curve: SOC at the start of the record, before the first
    /// row's charge (null without a curve).
    pub soc0: Option<f64>,
    /// With an OCV curve: SOC after the last row,
    /// `soc0 + h·Σ I/(3600·C)` (null without a curve).
    pub soc_end: Option<f64>,
    /// `"linear"` or `"butler-volmer"`: the model of these estimates.
    pub model: &'static str,
    /// Butler–Volmer coefficient a (V) of a·asinh(I/i₀) (null for the
    /// linear model).
    pub bv_a_v: Option<f64>,
    /// Butler–Volmer exchange current i₀ (A) (null for the linear model).
    pub bv_i0_a: Option<f64>,
    /// With `--model auto` or `butler-volmer`: both fits and why the model
    /// was chosen (null for `--model linear`).
    pub model_choice: Option<ModelChoice>,
    /// RMSE of the identified model's simulated voltage against the file (V).
    pub rmse_v: f64,
    /// Iterations (2S-OP-GI + refinement).
    pub iterations: u32,
    /// Converged.
    pub converged: bool,
    /// Why the refinement stopped: `converged` or `iteration_limit`; null
    /// with `--method paper`.
    pub stop: Option<&'static str>,
    /// What ended it: `small_step` (an accepted step changed no parameter
    /// by more than ε), `negligible_step` (the next step is below ε or
    /// below what the cost resolves), `no_lower_cost` (no damping found a
    /// lower cost) or `iteration_limit`; null with `--method paper`.
    pub stop_reason: Option<&'static str>,
    /// The parameters at a bound of the search (`r_i`, `r_ct`: 0; `alpha`:
    /// its bound): the fit is a boundary optimum in those (empty when
    /// none; null with `--method paper`).
    pub held_at_bounds: Option<Vec<&'static str>>,
    /// Per-iteration cost of 2S-OP-GI.
    pub history: Vec<HistoryEntry>,
    /// Whether the refinement started from the paper regression's
    /// estimate as well as from the data's rough starts: `used`;
    /// `outside_bounds` (its α outside the search's bounds);
    /// `no_estimate` (no physical estimate after its iterations);
    /// `regression_failed` (it stopped with an error: `start_note` says
    /// after how many iterations and why); `not_run` (a warm start was given, the only one).
    /// Null with `--method paper`.
    pub paper_start: Option<&'static str>,
    /// Why the paper regression's start is missing, when it stopped with
    /// an error and the fit went on from the data alone (the CLI prints
    /// it on stderr as a note on the file, Python warns with it); null
    /// otherwise.
    pub start_note: Option<String>,
    /// The fit can be trusted: no reason against it holds (see
    /// `identifiable_reason`, docs/trust.md).
    pub identifiable: bool,
    /// Why not, one clause per reason (null when identifiable).
    pub identifiable_reason: Option<String>,
    /// 95 % intervals `[lo, hi]` of `r_i`, `r_ct`, `q`, `alpha`, and of
    /// `bv_a`, `bv_i0` with the Butler–Volmer term (null when the
    /// information matrix is singular).
    pub confidence: Option<trust::Confidence>,
    /// Lag-1 autocorrelation of the residuals over the accepted rows (the
    /// intervals are widened by `√((1+ρ)/(1−ρ))` for it).
    pub residual_lag1_correlation: f64,
    /// `1 − RSS/TSS` of the voltage over the accepted rows.
    pub explained_variance: f64,
    /// Rows rejected (not finite, out of range, spikes against the model),
    /// substituted and not fitted.
    pub rejected: u32,
    /// The rejected rows by reason.
    pub rejected_rows: trust::RejectedRows,
    /// Which columns, units and sign were read, and how the rows were put
    /// on a uniform period (`period_s`, `rows_merged`, `rows_interpolated`,
    /// `gaps`, …; arrays are read as the columns of a file
    /// `time_s,current_a,voltage_v` would be).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub record: Option<crate::cycler::RecordReport>,
    /// With `--map-out`: the parameter map's levels and the whole-record
    /// RMSE of the map model beside the single fit's (absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub map: Option<crate::map::MapJson>,
}

/// The cell of a JSON value of `identify battery` (a file's, or the
/// Python face's dict), with `u_oc` as written, and its `ocv_offset_v` when
/// the fit was made against an OCV table; `path` names it in errors. A
/// linear fit has null (or, from before the Butler–Volmer model, no)
/// `bv_a_v` and `bv_i0_a`.
///
/// # Errors
/// [`crate::ErrorKind::Data`] when one of the numbers is missing.
pub fn cell_from_json(
    j: &serde_json::Value,
    path: &Path,
) -> Result<(CellParameters<f64>, Option<f64>)> {
    let get = |k: &str| {
        j[k].as_f64().ok_or_else(|| {
            err!(
                Data,
                "{}: no number `{k}` (expected the JSON of identify battery)",
                path.display()
            )
        })
    };
    let (bv_a, bv_i0) = match (j["bv_a_v"].as_f64(), j["bv_i0_a"].as_f64()) {
        (Some(a), Some(i0)) => (a, i0),
        _ => (0.0, 1.0),
    };
    let cell = CellParameters {
        r_i: get("r_i")?,
        r_ct: get("r_ct")?,
        q: get("q")?,
        alpha: get("alpha")?,
        u_oc: get("u_oc")?,
        bv_a,
        bv_i0,
    };
    Ok((cell, j["ocv_offset_v"].as_f64()))
}

/// Reads a JSON file (the JSON of `identify battery`, as `--prior` and
/// `predict battery --model` take it).
///
/// # Errors
/// [`crate::ErrorKind::Io`] when it cannot be read, [`crate::ErrorKind::Data`]
/// when it is not JSON.
pub fn read_json_file(path: &Path) -> Result<serde_json::Value> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| err!(Io, "{}: cannot read ({e})", path.display()))?;
    serde_json::from_str(&text).map_err(|e| err!(Data, "{}: not JSON ({e})", path.display()))
}

/// What `identify battery` computed, for the plots and the report.
pub struct BatteryResult {
    /// The JSON summary.
    pub json: BatteryJson,
    /// The identified cell.
    pub cell: CellParameters<f64>,
    /// Estimates of 2S-OP-GI per iteration (None while not physical).
    pub paper_track: Vec<Option<CellParameters<f64>>>,
    /// The identified model's voltage over the record.
    pub model_voltage: Vec<f64>,
    /// The Gauss–Newton information of the published fit at its estimate
    /// (None when it could not be computed).
    pub information: Option<FitInformation<f64>>,
    /// The order bounds of the fit.
    pub alpha_bounds: [f64; 2],
    /// With an OCV table: the OCV the fit took from the voltage at each
    /// sample (the SOC counted, read again after each gap); `None` without.
    pub ocv_v: Option<Vec<f64>>,
}

/// Simulates `cell` over a current record from rest, with the full memory
/// (by FFT, [`crate::branch`]).
///
/// # Errors
/// A non-physical cell, a bad period or a NaN/∞ current.
pub fn model_voltage(cell: &CellParameters<f64>, h: f64, current: &[f64]) -> Result<Vec<f64>> {
    if !(cell.is_physical() && h.is_finite() && h > 0.0) {
        bail!(
            Data,
            "cannot simulate the cell {cell:?} at the period {h} s"
        );
    }
    if current.iter().any(|i| !i.is_finite()) {
        bail!(Data, "cannot simulate a current with NaN or ∞ samples");
    }
    Ok(FftBranch::default().simulate(cell, h, current))
}

/// The RMSE of `a` against the measured `b` over the samples measured (a
/// NaN in `b` is an unobserved one).
fn rmse(a: &[f64], b: &[f64]) -> f64 {
    let (s, k) = a
        .iter()
        .zip(b)
        .filter(|(_, y)| !y.is_nan())
        .fold((0.0, 0usize), |(s, k), (x, y)| {
            (s + (x - y) * (x - y), k + 1)
        });
    (s / k.max(1) as f64).sqrt()
}

/// `v` with each run of NaN (unobserved samples) filled by the straight
/// line between its measured neighbours (held at the record's ends): the
/// paper's regression and the rough starts need a voltage at every
/// sample; the refinement leaves these out.
pub fn filled(v: &[f64]) -> Vec<f64> {
    let mut out = v.to_vec();
    let mut last: Option<usize> = None;
    let mut l = 0;
    while l < out.len() {
        if !out[l].is_nan() {
            last = Some(l);
            l += 1;
            continue;
        }
        let end = (l..out.len()).find(|&k| !out[k].is_nan());
        for k in l..end.unwrap_or(out.len()) {
            out[k] = match (last, end) {
                (Some(a), Some(b)) => out[a] + (out[b] - out[a]) * (k - a) as f64 / (b - a) as f64,
                (Some(a), None) => out[a],
                (None, Some(b)) => out[b],
                (None, None) => 0.0,
            };
        }
        l = end.unwrap_or(out.len());
    }
    out
}

/// Identifies a battery record (`method` paper or refined), printing the
/// 2S-OP-GI table of estimates versus k when `print_table` is set.
pub fn battery_run(
    path: &Path,
    rec: &io::BatteryRecord,
    method: BatteryMethod,
    memory: Option<usize>,
    iterations: u32,
    print_table: bool,
) -> Result<BatteryResult> {
    battery_run_with(
        path,
        rec,
        method,
        memory,
        iterations,
        print_table,
        Refine::default(),
    )
}

/// Options of the output-error refinement.
#[derive(Clone, Copy, Debug, Default)]
pub struct Refine {
    /// Memory (default: the whole record).
    pub memory: Option<usize>,
    /// Fit the OCV slope.
    pub ocv_slope: bool,
    /// The cell model (default linear: the paper's).
    pub model: ModelRequest,
    /// A warm start for `--method refined` (an earlier fit of nearly the
    /// same record, in the fitted record's own terms): when set, the
    /// paper's regression and the rough starts are passed over and the
    /// refinement starts from it alone. `None` (the default): every start.
    pub start: Option<CellParameters<f64>>,
}

/// [`battery_run`] with refinement options.
pub fn battery_run_with(
    path: &Path,
    rec: &io::BatteryRecord,
    method: BatteryMethod,
    memory: Option<usize>,
    iterations: u32,
    print_table: bool,
    refine: Refine,
) -> Result<BatteryResult> {
    // Estimator state sized to the record (a 1 000-row file does not
    // allocate and clear the state of an 8 192-row one).
    let run = match rec.current.len() {
        0..=1024 => battery_run_sized::<1024, 1024>,
        1025..=2048 => battery_run_sized::<2048, 2048>,
        2049..=4096 => battery_run_sized::<4096, BAT_MEM>,
        4097..=8192 => battery_run_sized::<8192, BAT_MEM>,
        8193..=16384 => battery_run_sized::<16384, BAT_MEM>,
        16385..=32768 => battery_run_sized::<32768, BAT_MEM>,
        32769..=65536 => battery_run_sized::<65536, BAT_MEM>,
        65537..=131072 => battery_run_sized::<131072, BAT_MEM>,
        131073..=MAX_BATTERY_ROWS => battery_run_sized::<MAX_BATTERY_ROWS, BAT_MEM>,
        n => bail!(
            Data,
            "{}: {n} samples; a fit takes at most {MAX_BATTERY_ROWS} (put the record on a longer period: --period)",
            path.display()
        ),
    };
    run(path, rec, method, memory, iterations, print_table, refine)
}

/// [`battery_run_with`] for records of at most `N` rows: the paper's
/// regression with memories up to `MEM = min(N, BAT_MEM)`, the refinement
/// with any memory up to the whole record.
fn battery_run_sized<const N: usize, const MEM: usize>(
    path: &Path,
    rec: &io::BatteryRecord,
    method: BatteryMethod,
    memory: Option<usize>,
    iterations: u32,
    print_table: bool,
    refine: Refine,
) -> Result<BatteryResult> {
    let n = rec.current.len();
    let mem = memory.unwrap_or(256.min(n / 2).max(1));
    let need = mem - 1 + estimator_core::battery::regression::MIN_ROWS;
    if mem == 0 || mem > BAT_MEM {
        bail!(Options, "--memory {mem}: must be in 1..={BAT_MEM}");
    }
    if n < need {
        bail!(
            Data,
            "{}: {n} data rows; memory {mem} needs at least {need}",
            path.display()
        );
    }
    let ctx = |e: estimator_core::Error| err!(Estimator, "{}: {e}", path.display());
    // The regression needs a voltage at every sample; the refinement
    // leaves the unobserved ones (NaN) out.
    let measured = filled(&rec.voltage);
    let logged = LoggedWindow {
        current: &rec.current,
        voltage: &rec.voltage,
    };
    let sg = BatterySettings::new(rec.h, mem);
    // A warm start needs no regression to start from.
    let warm = refine.start.filter(|_| method == BatteryMethod::Refined);
    let paper_iterations = if warm.is_some() { 0 } else { iterations };
    // As the refinement's start, the regression runs on the record's most
    // excited stretch (its cost grows with the rows times the memory),
    // sized to that stretch; as the paper's method, on the whole record.
    let regression = RegressionRun {
        path,
        current: &rec.current,
        measured: &measured,
        settings: &sg,
        iterations: paper_iterations,
        method,
        print_table,
    };
    let PaperRun {
        history,
        track,
        mut converged,
        failed: regression_failed,
        estimate,
    } = match method {
        BatteryMethod::Refined if N > START_REGRESSION_ROWS => {
            let rows = most_excited(&rec.current, &rec.voltage, START_REGRESSION_ROWS);
            regression.run::<START_REGRESSION_ROWS, MEM>(rows)?
        }
        BatteryMethod::Refined => {
            let rows = most_excited(&rec.current, &rec.voltage, START_REGRESSION_ROWS);
            regression.run::<N, MEM>(rows)?
        }
        BatteryMethod::Paper => regression.run::<N, MEM>(0..n)?,
    };
    let mut stop = None;
    let mut stop_reason = None;
    let mut paper_start = None;
    let mut iters = history.len() as u32;
    let mut choice = None;
    if method == BatteryMethod::Paper && refine.model == ModelRequest::ButlerVolmer {
        bail!(
            Options,
            "--model butler-volmer needs --method refined (the paper's regression is linear)"
        );
    }
    let (cell, rmse_v, information, alpha_bounds) = match method {
        BatteryMethod::Paper => {
            let cell = estimate.ok_or_else(|| {
                err!(
                    Data,
                    "{}: 2S-OP-GI has no physical estimate after {iters} iterations (try more --iterations, or --method refined)",
                    path.display()
                )
            })?;
            // The information of the output-error criterion at the paper's
            // estimate (for its intervals; nothing is refitted).
            let si = BatterySettings::new(rec.h, n);
            let info = crate::worker::boxed(|| Refinement::<N>::new(&si, cell))
                .and_then(|mut oe| oe.information(&si, &logged))
                .ok();
            // The RMSE of the model voltage, computed below.
            (cell, None, info, [si.alpha_min, si.alpha_max])
        }
        BatteryMethod::Refined => {
            let rm = refine.memory.unwrap_or(n);
            if rm == 0 || rm > n {
                bail!(
                    Options,
                    "--refine-memory {rm}: must be in 1..={n} for {n} rows"
                );
            }
            let mut so = BatterySettings::new(rec.h, rm);
            so.ocv_slope = refine.ocv_slope;
            so.cost_tolerance = super::refine::WHOLE_RECORD_COST_TOLERANCE;
            so.line_search = true;
            // Several starts, the best fit kept: the paper's estimate (when
            // it is physical) and the rough ones from the data alone. On a
            // measured pulse they can end in different basins (the LG M50
            // at 10 °C, SOC 0.2: 36 mV from the even split, 3.4 mV from the
            // charge-transfer one; docs/measured-cells.md). A start whose
            // search fails is passed over; the fit fails only when all do.
            let used = match (&warm, &regression_failed, &estimate) {
                (Some(_), _, _) => "not_run",
                (None, Some(_), _) => "regression_failed",
                (None, None, None) => "no_estimate",
                (None, None, Some(c)) if c.alpha < so.alpha_min || c.alpha > so.alpha_max => {
                    "outside_bounds"
                }
                _ => "used",
            };
            paper_start = Some(used);
            let paper = estimate.filter(|_| used == "used");
            let starts: Vec<CellParameters<f64>> = match warm {
                Some(w) => vec![w.linearized()],
                None => paper
                    .into_iter()
                    .chain(rough_starts(&rec.current, &measured))
                    .collect(),
            };
            // The linear race's refinements given back serve the
            // Butler–Volmer race.
            let mut spares = Spares::new();
            let (mut lin, run) =
                refine_best::<N>(&so, &starts, &logged, &mut spares).map_err(ctx)?;
            iters += run;
            let bounds = [so.alpha_min, so.alpha_max];
            if refine.model == ModelRequest::Linear {
                converged = lin.converged();
                stop = Some(lin.stop.as_str());
                stop_reason = Some(stop_reason_name(lin.stop, lin.reason));
                let info = lin.oe.information(&so, &logged).ok();
                (lin.cell, Some(lin.rmse), info, bounds)
            } else {
                let (chosen, why) =
                    choose_model(&so, lin, &logged, &rec.current, refine.model, &mut spares)
                        .map_err(ctx)?;
                let fit = chosen.fit;
                iters += fit.iterations;
                converged = fit.stop == FitStop::Converged;
                stop = Some(fit.stop.as_str());
                stop_reason = Some(stop_reason_name(fit.stop, fit.reason));
                choice = Some(why);
                (fit.cell, Some(fit.rmse_v), Some(chosen.information), bounds)
            }
        }
    };
    let model = model_voltage(&cell, rec.h, &rec.current)?;
    let rmse_v = rmse_v.unwrap_or_else(|| rmse(&model, &rec.voltage));
    Ok(BatteryResult {
        json: BatteryJson {
            method: method.as_str(),
            r_i: cell.r_i,
            r_ct: cell.r_ct,
            q: cell.q,
            alpha: cell.alpha,
            u_oc: cell.u_oc,
            ocv_offset_v: None,
            soc0: None,
            soc_end: None,
            model: if cell.is_butler_volmer() {
                CellModel::ButlerVolmer.as_str()
            } else {
                CellModel::Linear.as_str()
            },
            bv_a_v: cell.is_butler_volmer().then_some(cell.bv_a),
            bv_i0_a: cell.is_butler_volmer().then_some(cell.bv_i0),
            model_choice: choice,
            rmse_v,
            iterations: iters,
            converged,
            stop,
            stop_reason,
            held_at_bounds: stop.map(|_| {
                let s = BatterySettings {
                    alpha_min: alpha_bounds[0],
                    alpha_max: alpha_bounds[1],
                    ..BatterySettings::new(rec.h, 1)
                };
                AtBounds::of(&s, &cell).names().collect()
            }),
            history,
            paper_start,
            start_note: regression_failed,
            identifiable: false,
            identifiable_reason: None,
            confidence: None,
            residual_lag1_correlation: f64::NAN,
            explained_variance: f64::NAN,
            rejected: 0,
            rejected_rows: trust::RejectedRows::default(),
            record: None,
            map: None,
        },
        cell,
        paper_track: track,
        model_voltage: model,
        ocv_v: None,
        information,
        alpha_bounds,
    })
}

/// [`battery_run_with`] on a record with or without the cell's OCV curve:
/// with one, the estimators fit the overpotential `U_t − OCV(SOC)` (the
/// fitted `U_oc` is the offset ΔU) and the result is mapped back to
/// terminal voltages (`u_oc` at the end of the record, the model voltage
/// with the OCV along the record).
#[allow(clippy::too_many_arguments)]
pub fn battery_identify(
    path: &Path,
    rec: &io::BatteryRecord,
    cell_ocv: Option<&crate::ocv::CellOcv>,
    method: BatteryMethod,
    memory: Option<usize>,
    iterations: u32,
    print_table: bool,
    refine: Refine,
) -> Result<BatteryResult> {
    let mut r = battery_identify_unassessed(
        path,
        rec,
        &[],
        cell_ocv.map(|c| (c, &[][..])),
        method,
        memory,
        iterations,
        print_table,
        refine,
    )?;
    apply_assessment(&mut r, &trust::Screened::accepted(rec));
    Ok(r)
}

/// The model `--model` asks for under `--method`: the paper's regression
/// is linear, so `auto` has nothing to choose there.
pub fn model_for(model: ModelRequest, method: BatteryMethod) -> ModelRequest {
    match (model, method) {
        (ModelRequest::Auto, BatteryMethod::Paper) => ModelRequest::Linear,
        (m, _) => m,
    }
}

/// Writes the verdict of [`trust::assess`] into the JSON.
fn apply_assessment(r: &mut BatteryResult, sc: &trust::Screened) {
    let a = trust::assess(
        sc,
        &r.cell,
        r.information.as_ref(),
        r.alpha_bounds,
        &r.model_voltage,
    );
    let j = &mut r.json;
    j.identifiable = a.identifiable;
    j.identifiable_reason = (!a.identifiable).then(|| a.reasons.join("; "));
    j.confidence = a.confidence;
    j.residual_lag1_correlation = a.residual_correlation;
    j.explained_variance = a.explained;
    let counts = sc.counts();
    j.rejected = counts.total();
    j.rejected_rows = counts;
    if sc.excluded() > 0 {
        j.rmse_v = sc.counted_rmse(&r.model_voltage);
    }
}

/// [`battery_identify`] on a record whose bad rows are rejected first,
/// then refitted without the spikes against the model (docs/trust.md): the
/// rows rejected are substituted and counted (`rejected`, `rejected_rows`),
/// and the verdict is computed over the accepted rows. The rows marked in
/// `unobserved` (a cycler's unlogged step starts; empty: none) are
/// substituted the same way and counted in none of it.
///
/// # Errors
/// As [`battery_identify`], and when every row is rejected.
#[allow(clippy::too_many_arguments)]
pub fn battery_identify_screened(
    path: &Path,
    rec: &io::BatteryRecord,
    unobserved: &[bool],
    gaps: &[crate::cycler::resample::Gap],
    limits: &trust::Limits,
    ocv: Option<&crate::ocv::OcvSpec>,
    method: BatteryMethod,
    memory: Option<usize>,
    iterations: u32,
    print_table: bool,
    refine: Refine,
) -> Result<(BatteryResult, trust::Screened)> {
    let mut sc = trust::screen_observed(path, rec, limits, unobserved)?;
    let cell_ocv = ocv.map(|o| o.resolve(path, &sc.record)).transpose()?;
    let fit = |sc: &trust::Screened, print_table: bool, start| {
        // The rows that do not count are left out of the fit (not fitted
        // to substitutes, which would pull it towards the fit they came
        // from).
        let left_out: Vec<bool> = (0..sc.measured.len()).map(|k| !sc.counted(k)).collect();
        battery_identify_unassessed(
            path,
            &sc.record,
            &left_out,
            cell_ocv.as_ref().map(|c| (c, gaps)),
            method,
            memory,
            iterations,
            print_table,
            Refine { start, ..refine },
        )
    };
    let mut r = fit(&sc, print_table, refine.start)?;
    for _ in 0..trust::MAX_SPIKE_PASSES {
        let (rejected, substituted) = (sc.rejected.clone(), sc.record.voltage.clone());
        if sc.find_spikes(&r.model_voltage, limits) == 0 {
            break;
        }
        sc.substitute_model(&r.model_voltage);
        // The refit without the new spikes starts from the fit it
        // corrects; the regression's history and what became of its
        // start stay the first fit's.
        let mut next = fit(&sc, false, Some(r.cell))?;
        // A refit that fits the rows it counts worse than the fit it
        // corrects does is not taken, nor are the spikes that fit found:
        // the Butler–Volmer refit starts from the linear model of the fit
        // it corrects, `R_i + a/i₀`, which for an `i₀` run towards 0 is
        // no resistance a refinement comes back from (a 10 °C Panasonic
        // excerpt near empty: 10.6 mV, then 7e22 V).
        let (refit, before) = (
            sc.counted_rmse(&next.model_voltage),
            sc.counted_rmse(&r.model_voltage),
        );
        if refit.is_nan() || refit > before {
            sc.rejected = rejected;
            sc.record.voltage = substituted;
            break;
        }
        next.json.iterations += r.json.iterations;
        next.json.history = std::mem::take(&mut r.json.history);
        next.json.paper_start = r.json.paper_start;
        next.json.start_note = r.json.start_note.take();
        next.paper_track = std::mem::take(&mut r.paper_track);
        r = next;
    }
    apply_assessment(&mut r, &sc);
    Ok((r, sc))
}

/// [`battery_identify`] without the verdict; the rows marked in
/// `left_out` (empty: none) are unobserved to the fit.
#[allow(clippy::too_many_arguments)]
fn battery_identify_unassessed(
    path: &Path,
    rec: &io::BatteryRecord,
    left_out: &[bool],
    cell_ocv: Option<(&crate::ocv::CellOcv, &[crate::cycler::resample::Gap])>,
    method: BatteryMethod,
    memory: Option<usize>,
    iterations: u32,
    print_table: bool,
    refine: Refine,
) -> Result<BatteryResult> {
    let masked = |v: &mut [f64]| {
        for (x, _) in v.iter_mut().zip(left_out).filter(|(_, &out)| out) {
            *x = f64::NAN;
        }
    };
    let Some((c, gaps)) = cell_ocv else {
        let mut y = rec.clone();
        masked(&mut y.voltage);
        return battery_run_with(path, &y, method, memory, iterations, print_table, refine);
    };
    if refine.ocv_slope {
        bail!(
            Options,
            "--ocv-slope goes without --ocv (the OCV curve carries the drift)"
        );
    }
    let (mut y, soc_end) = c.overpotential_record_across(rec, gaps);
    // The OCV along the record, before the rows left out are masked.
    let ocv: Vec<f64> = rec
        .voltage
        .iter()
        .zip(&y.voltage)
        .map(|(v, yv)| v - yv)
        .collect();
    masked(&mut y.voltage);
    let mut r = battery_run_with(path, &y, method, memory, iterations, print_table, refine)?;
    let offset = r.cell.u_oc;
    for (m, o) in r.model_voltage.iter_mut().zip(&ocv) {
        // The overpotential model plus the OCV it was taken from.
        *m += o;
    }
    r.json.u_oc = c.model.table.ocv(soc_end) + offset;
    r.json.ocv_offset_v = Some(offset);
    r.json.soc0 = Some(c.soc0);
    r.json.soc_end = Some(soc_end);
    r.ocv_v = Some(ocv);
    Ok(r)
}
