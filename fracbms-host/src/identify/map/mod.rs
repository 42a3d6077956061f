//! Building a parameter map: a record split at its SOC levels, each part
//! fitted by the whole-record fit of [`super::battery`] with its intervals
//! and model choice, and the map model's voltage over a record.
//!
//! It owns the per-level fits ([`build_map`]), the
//! check against the single fit ([`MapFit::check_against`]) and the
//! `--map-out` run ([`battery_file`]); the map model ([`map_voltage`]) is
//! [`model`]'s, the split into levels [`mod@levels`]'s.
//! The map's data and CSV are [`crate::map`]'s.
//!
//! The map model's voltage at a sample is the linear interpolation in SOC,
//! between the two levels around the counted SOC, of the voltages of the
//! two levels' models, each run over the whole record from rest (exact for
//! R_i, ΔU and the OCV, which enter linearly; a gain-scheduled blend for
//! the polarization).

use super::battery::{battery_identify_screened, Refine};
use super::BatteryMethod;
use crate::cycler::resample::Gap;
use crate::error::Result;
use crate::io::BatteryRecord;
use crate::map::{counted_soc, in_gaps, MapJson, MapOptions, MapRow, ParameterMap};
use crate::ocv::OcvSpec;
use crate::trust::Limits;
use crate::{bail, err};
use estimator_core::battery::CellParameters;
pub use levels::{
    level_knots, level_runs, levels, one_level_per_soc, Level, KNOT_SPACING, MIN_EXCITED,
};
use std::path::Path;

/// What [`build_map`] made: the map, the levels it could not fit, and the
/// map model's voltage over the record.
#[derive(Clone, Debug)]
pub struct MapFit {
    /// The map (one temperature).
    pub map: ParameterMap,
    /// Levels not fitted, and why.
    pub skipped: Vec<String>,
    /// The map model's voltage over the whole record.
    pub model_v: Vec<f64>,
    /// Its RMSE against the record (V).
    pub rmse_v: f64,
    /// Each level's own record, as fitted (skipped levels too), in time
    /// order: what [`write_levels`] writes for an independent fit.
    pub parts: Vec<LevelPart>,
    /// The samples of the record with no measurement: inside a gap or a
    /// step's unlogged start ([`not_measured`]); no RMSE counts them.
    pub unmeasured: Vec<bool>,
    /// The record's temperature (°C) the rows carry, if known.
    pub temperature_c: Option<f64>,
    /// What a user should know of the map: a level whose paper regression
    /// stopped (its fit went on from the data alone), no identifiable
    /// level, or the single fit written in its place
    /// ([`MapFit::check_against`]).
    pub warnings: Vec<String>,
    /// The joint fit's candidates, each scored by leaving levels out
    /// (empty for `--map-method levels`).
    pub joint: Vec<joint::Candidate>,
    /// The chosen joint fit's inputs ([`write_levels`] writes them).
    pub joint_inputs: Option<joint::JointInputs>,
}

/// Which samples of `rec` were not measured: inside one of its `gaps`
/// (made up by the resampling) or one of its steps' `unlogged` starts
/// (the current known, not the voltage).
pub fn not_measured(
    rec: &BatteryRecord,
    gaps: &[Gap],
    unlogged: &[crate::cycler::Unlogged],
) -> Vec<bool> {
    let u = crate::cycler::steps::unobserved(unlogged, rec.h, &rec.time);
    in_gaps(rec, gaps)
        .into_iter()
        .zip(u)
        .map(|(a, b)| a || b)
        .collect()
}

/// One level's record as its fit saw it.
#[derive(Clone, Debug)]
pub struct LevelPart {
    /// The uniform record of the level.
    pub record: BatteryRecord,
    /// The level's SOC (the map row's `soc`).
    pub soc: f64,
    /// The SOC before the record's first row's charge.
    pub soc0: f64,
    /// The record's temperature (°C), if known.
    pub temperature_c: Option<f64>,
    /// Whether the level has a row in the map.
    pub fitted: bool,
    /// The samples of `record` its fit rejected (indices from 0): the
    /// rows its `rmse_v` leaves out.
    pub rejected: Vec<usize>,
    /// The samples of `record` with no measured voltage (a step's unlogged
    /// start, indices from 0): no fit counts them, nor its `rmse_v`.
    pub unobserved: Vec<usize>,
}

/// Builds the map of `rec` (file `path`): splits it into levels, fits each
/// with `ocv` (the OCV table is needed: each level's SOC moves), and runs
/// the map model over the whole record.
///
/// # Errors
/// [`crate::ErrorKind::Data`] when no level can be fitted, or the start
/// SOC cannot be read; [`crate::ErrorKind::Options`] for a bad split.
#[allow(clippy::too_many_arguments)]
pub fn build_map(
    path: &Path,
    rec: &BatteryRecord,
    temperature: Option<&[f64]>,
    limits: &Limits,
    ocv: &OcvSpec,
    method: BatteryMethod,
    iterations: u32,
    refine: Refine,
    o: &MapOptions,
    gaps: &[Gap],
    log: Option<&BatteryRecord>,
    unlogged: &[crate::cycler::Unlogged],
) -> Result<MapFit> {
    if !(o.min_rest_s.is_finite() && o.min_rest_s > 0.0) {
        bail!(
            Options,
            "--min-rest must be positive (got {})",
            o.min_rest_s
        );
    }
    crate::map::check_temperature(o.temperature_c)?;
    if o.soc_bins == Some(0) {
        bail!(Options, "--soc-bins must be at least 1");
    }
    let whole = ocv.resolve(path, rec)?;
    let soc = counted_soc(rec, &whole, gaps);
    let mut parts = levels(rec, &soc, o, &in_gaps(rec, gaps));
    if o.soc_bins.is_none() {
        parts = one_level_per_soc(parts);
    }
    if parts.is_empty() {
        bail!(
            Data,
            "{}: no SOC levels: no rests of at least {} s between pulses (give --soc-bins N)",
            path.display(),
            o.min_rest_s
        );
    }
    // One temperature for the record's levels (they are one slice of a
    // map over temperature): the given one, or the temperature column's
    // mean to 0.1 °C.
    let record_t = o.temperature_c.or_else(|| {
        let ok: Vec<f64> = temperature?
            .iter()
            .copied()
            .filter(|x| x.is_finite())
            .collect();
        (!ok.is_empty()).then(|| (ok.iter().sum::<f64>() / ok.len() as f64 * 10.0).round() / 10.0)
    });
    let mut rows = vec![];
    let mut skipped = vec![];
    // A level's fit whose paper regression stopped: said as a warning.
    let mut notes = vec![];
    let mut kept = vec![];
    for p in &parts {
        // The level at the log's own resolution where it is finer than the
        // whole record's (within o.level_samples), else as resampled.
        let (t0, t1) = (rec.time[p.start], rec.time[p.end - 1]);
        let fine = log
            .map(|r| crate::cycler::part_of(r, rec.h, t0, t1, o.level_samples))
            .filter(|f| f.time.len() >= 2 && f.h < rec.h);
        let part = fine.unwrap_or_else(|| BatteryRecord {
            time: rec.time[p.start..p.end].to_vec(),
            current: rec.current[p.start..p.end].to_vec(),
            voltage: rec.voltage[p.start..p.end].to_vec(),
            h: rec.h,
        });
        let spec = OcvSpec {
            model: ocv.model,
            soc0: Some(soc[p.start].clamp(0.0, 1.0)),
        };
        let at = format!(
            "level at SOC {:.3} ({} s to {} s)",
            p.soc,
            part.time[0],
            part.time[part.time.len() - 1]
        );
        let unobserved = crate::cycler::steps::unobserved(unlogged, part.h, &part.time);
        let fit = battery_identify_screened(
            path,
            &part,
            &unobserved,
            &[],
            limits,
            Some(&spec),
            method,
            None,
            iterations,
            false,
            refine,
        );
        let fitted = fit.is_ok();
        let rejected = fit.as_ref().map_or_else(
            |_| vec![],
            |(_, sc)| {
                (sc.rejected.iter().enumerate())
                    .filter_map(|(k, r)| r.map(|_| k))
                    .collect()
            },
        );
        let unobserved: Vec<usize> = (0..unobserved.len()).filter(|&k| unobserved[k]).collect();
        kept.push(LevelPart {
            record: part.clone(),
            soc: p.soc,
            soc0: soc[p.start].clamp(0.0, 1.0),
            temperature_c: record_t,
            fitted,
            rejected,
            unobserved,
        });
        let (r, _) = match fit {
            Ok(x) => x,
            Err(e) => {
                skipped.push(format!("{at}: {e}"));
                continue;
            }
        };
        let j = &r.json;
        if let Some(note) = &j.start_note {
            notes.push(format!("{at}: {note}"));
        }
        let t = record_t;
        rows.push(MapRow {
            temperature_c: t,
            soc: p.soc,
            r_i: j.r_i,
            r_ct: j.r_ct,
            q: j.q,
            alpha: j.alpha,
            bv_a_v: j.bv_a_v,
            bv_i0_a: j.bv_i0_a,
            ocv_offset_v: j.ocv_offset_v.unwrap_or(0.0),
            rmse_v: j.rmse_v,
            identifiable: j.identifiable,
            identifiable_reason: j.identifiable_reason.clone(),
            confidence: j.confidence.clone(),
            start_s: part.time[0],
            end_s: part.time[part.time.len() - 1],
            samples: part.time.len(),
        });
    }
    if rows.is_empty() {
        bail!(
            Data,
            "{}: none of {} SOC levels could be fitted ({})",
            path.display(),
            parts.len(),
            skipped.join("; ")
        );
    }
    let mut map = ParameterMap { rows };
    map.sort();
    let unmeasured = not_measured(rec, gaps, unlogged);
    let (mut chosen, mut joint_inputs) = (vec![], None);
    if o.method == crate::map::MapMethod::Joint {
        let (m, tried, inputs) =
            joint_map(rec, &whole, gaps, &unmeasured, &parts, &map, record_t, o)?;
        map = m;
        chosen = tried;
        joint_inputs = Some(inputs);
    }
    // The map model runs on the identifiable levels only: without one it
    // has no voltage (NaN), and the check against the single fit
    // ([`MapFit::check_against`]) decides and says so.
    let model_v = match map.usable() {
        (u, _) if u.rows.is_empty() => vec![f64::NAN; rec.time.len()],
        _ => map_voltage(&map, rec, &whole, record_t, gaps)?,
    };
    let rmse_v = rmse(&model_v, &rec.voltage, &unmeasured);
    Ok(MapFit {
        map,
        skipped,
        model_v,
        rmse_v,
        parts: kept,
        unmeasured,
        temperature_c: record_t,
        warnings: notes,
        joint: chosen,
        joint_inputs,
    })
}

/// The joint map of `rec` (its levels `parts`, fitted on their own into
/// `levels`): knots at the mean SOCs of the levels' runs of one SOC
/// ([`level_runs`]; each `--soc-bins` bin alone; or `o.knots`), started
/// from the identifiable levels' cells interpolated at each knot (all
/// levels' when none is identifiable), the penalty and the varying set
/// given or chosen by leaving out each run's levels together, and the
/// record's long discharges (over 300 s under one sign of current) as one
/// more fold.
#[allow(clippy::too_many_arguments)]
fn joint_map(
    rec: &BatteryRecord,
    whole: &crate::ocv::CellOcv,
    gaps: &[Gap],
    unmeasured: &[bool],
    parts: &[Level],
    levels: &ParameterMap,
    record_t: Option<f64>,
    o: &MapOptions,
) -> Result<(ParameterMap, Vec<joint::Candidate>, joint::JointInputs)> {
    // Runs of one SOC: each bin alone with --soc-bins.
    let runs: Vec<Vec<usize>> = if o.soc_bins.is_some() {
        (0..parts.len()).map(|k| vec![k]).collect()
    } else {
        levels::level_runs(parts)
    };
    let mut knots: Vec<f64> = o
        .knots
        .clone()
        .unwrap_or_else(|| levels::run_means(parts, &runs));
    knots.sort_by(f64::total_cmp);
    knots.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
    if knots.is_empty() {
        bail!(Data, "the joint map fit needs at least one knot");
    }
    let (usable, _) = levels.usable();
    let from = if usable.rows.is_empty() {
        levels
    } else {
        &usable
    };
    // The levels fitted with the Butler–Volmer term (`--model
    // butler-volmer`): the joint fit shares one term over the knots.
    let kinetic = from
        .rows
        .iter()
        .all(|r| r.bv_a_v.is_some_and(|a| a > 0.0) && r.bv_i0_a.is_some_and(|i| i > 0.0));
    let start: Vec<CellParameters<f64>> = knots
        .iter()
        .map(|&z| {
            let mut c = from
                .cell_at(z, record_t)
                .unwrap_or_else(CellParameters::cell_18650);
            if !(kinetic && c.is_butler_volmer()) {
                c.bv_a = 0.0;
                c.bv_i0 = 1.0;
            }
            c
        })
        .collect();
    let before = counted_soc(rec, whole, gaps);
    let soc: Vec<f64> = before
        .iter()
        .zip(&rec.current)
        .map(|(z, i)| {
            z + if i.is_finite() { *i } else { 0.0 } * rec.h / (3600.0 * whole.model.capacity_ah)
        })
        .collect();
    let counted: Vec<bool> = unmeasured
        .iter()
        .zip(&rec.voltage)
        .map(|(u, v)| !u && v.is_finite())
        .collect();
    let d = joint::JointData {
        record: rec,
        soc: &soc,
        ocv: whole,
        counted: &counted,
        knots: &knots,
    };
    let n = rec.time.len();
    // One fold per run of one SOC: its levels left out together, so that
    // no level is predicted from its twin at the same SOC.
    let mut folds: Vec<Vec<bool>> = runs
        .iter()
        .map(|run| {
            let mut f = vec![false; n];
            for p in run.iter().map(|&k| &parts[k]) {
                for x in &mut f[p.start.min(n)..p.end.min(n)] {
                    *x = true;
                }
            }
            f
        })
        .collect();
    folds.retain(|f| f.iter().any(|x| *x));
    let long = joint::long_discharges(rec, 300.0);
    if long.iter().any(|x| *x) {
        folds.push(long);
    }
    let smoothing = o
        .smoothing
        .map_or(joint::SMOOTHING_GRID.to_vec(), |x| vec![x]);
    let vary = o.vary.map_or(joint::VARY_SETS.to_vec(), |x| vec![x]);
    let (fit, tried) = joint::choose(
        &d,
        &start,
        &folds,
        &smoothing,
        &vary,
        joint::JOINT_ITERATIONS,
    )?;
    let rows = knots
        .iter()
        .enumerate()
        .map(|(j, &z)| {
            let c = fit.cells[j];
            // The samples this knot weighs most: its RMSE and span.
            let near: Vec<usize> = (0..n)
                .filter(|&k| counted[k] && joint::nearest(&knots, soc[k]) == j)
                .collect();
            let err = near
                .iter()
                .map(|&k| (fit.model_v[k] - rec.voltage[k]).powi(2))
                .sum::<f64>();
            let why = &fit.reasons[j];
            MapRow {
                temperature_c: record_t,
                soc: z,
                r_i: c.r_i,
                r_ct: c.r_ct,
                q: c.q,
                alpha: c.alpha,
                bv_a_v: c.is_butler_volmer().then_some(c.bv_a),
                bv_i0_a: c.is_butler_volmer().then_some(c.bv_i0),
                ocv_offset_v: c.u_oc,
                rmse_v: (err / near.len().max(1) as f64).sqrt(),
                identifiable: why.is_empty(),
                identifiable_reason: (!why.is_empty()).then(|| why.join("; ")),
                confidence: fit.confidence[j].clone(),
                start_s: near.first().map_or(f64::NAN, |&k| rec.time[k]),
                end_s: near.last().map_or(f64::NAN, |&k| rec.time[k]),
                samples: near.len(),
            }
        })
        .collect();
    let inputs = joint::JointInputs::of(&d, &fit);
    Ok((ParameterMap { rows }, tried, inputs))
}

/// Writes each level of `fit` for an independent fit into the folder
/// `dir` (made if missing): `level-NN.csv` (`time_s,current_a,voltage_v,`
/// `observed`: the level's uniform record, `observed` 0 where no voltage
/// was measured), `ocv.csv` (`soc,ocv_v`, the table used)
/// and `levels.json` (the capacity, `model`, and per level its `file`,
/// `soc`, `soc0`, `temperature_c`, `start_s`, `end_s`, `samples`,
/// `fitted`, `rejected`: the samples its fit rejected, from 0;
/// `unobserved`: those with no measured voltage, from 0).
/// `bench/reference_map.py` reads it.
///
/// # Errors
/// [`crate::ErrorKind::Io`] when a file cannot be written.
pub fn write_levels(dir: &Path, fit: &MapFit, ocv: &OcvSpec, model: &str) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| err!(Io, "cannot make {}: {e}", dir.display()))?;
    let t = &ocv.model.table;
    crate::io::write_csv(
        &dir.join("ocv.csv"),
        &["soc", "ocv_v"],
        t.soc_points()
            .iter()
            .zip(t.ocv_points())
            .map(|(z, v)| [z.to_string(), v.to_string()]),
    )?;
    let mut levels = vec![];
    for (k, p) in fit.parts.iter().enumerate() {
        let file = format!("level-{:02}.csv", k + 1);
        let r = &p.record;
        let mut observed = vec![true; r.time.len()];
        for &j in &p.unobserved {
            observed[j] = false;
        }
        crate::io::write_csv(
            &dir.join(&file),
            &["time_s", "current_a", "voltage_v", "observed"],
            (0..r.time.len()).map(|j| {
                [
                    r.time[j].to_string(),
                    r.current[j].to_string(),
                    r.voltage[j].to_string(),
                    u8::from(observed[j]).to_string(),
                ]
            }),
        )?;
        levels.push(serde_json::json!({
            "file": file,
            "soc": p.soc,
            "soc0": p.soc0,
            "temperature_c": p.temperature_c,
            "start_s": r.time[0],
            "end_s": r.time[r.time.len() - 1],
            "samples": r.time.len(),
            "h": r.h,
            "fitted": p.fitted,
            "rejected": p.rejected,
            "unobserved": p.unobserved,
        }));
    }
    let doc = serde_json::json!({
        "capacity_ah": ocv.model.capacity_ah,
        "model": model,
        "levels": levels,
    });
    let text = serde_json::to_string_pretty(&doc)
        .map_err(|e| err!(Io, "cannot write levels.json: {e}"))?;
    crate::io::write_atomic(&dir.join("levels.json"), |w| {
        w.write_all(text.as_bytes())
            .and_then(|_| w.write_all(b"\n"))
            .map_err(|e| err!(Io, "cannot write levels.json: {e}"))
    })?;
    fit.joint_inputs.as_ref().map_or(Ok(()), |j| j.write(dir))
}

/// `identify battery --map-out` on the file `input`: the whole-record fit
/// of [`crate::identify::record::battery_file`], then the map of the
/// record, in the fit's JSON (`map`) too. The OCV options are checked
/// before the file is read.
///
/// # Errors
/// As [`crate::identify::record::battery_file`] and [`build_map`];
/// [`crate::ErrorKind::Options`] without an OCV table.
pub fn battery_file(
    input: &Path,
    o: &crate::identify::record::BatteryFitOptions,
    m: &MapOptions,
    print_table: bool,
) -> Result<(crate::identify::record::BatteryFile, MapFit)> {
    let Some(spec) = OcvSpec::from_options(&o.ocv)? else {
        bail!(
            Options,
            "a parameter map needs --ocv and --capacity-ah (each level's SOC moves; `host-sim ocv` reads the table from the test)"
        );
    };
    let mut f = crate::identify::record::battery_file(input, o, print_table)?;
    let limits = Limits::checked(o.voltage_min, o.voltage_max, o.current_limit)?;
    let refine = Refine {
        memory: o.refine_memory,
        ocv_slope: o.ocv_slope,
        model: crate::identify::battery::model_for(o.model, o.method),
        ..Refine::default()
    };
    let map = build_map(
        input,
        &f.record,
        f.temperature.as_deref(),
        &limits,
        &spec,
        o.method,
        o.iterations
            .unwrap_or(crate::identify::record::DEFAULT_ITERATIONS),
        refine,
        m,
        &f.report.resampling.gaps,
        Some(&f.rows),
        &f.report.steps.unlogged,
    )?;
    let mut map = map;
    map.check_against(&f.record, &f.result.model_voltage, &f.result.json);
    f.result.json.map = Some(map.json(&f.record, &f.result.model_voltage));
    Ok((f, map))
}

impl MapFit {
    /// The map against the single whole-record fit `j` of the same record
    /// `rec` (its model voltage `single_v`): a map whose whole-record RMSE
    /// (its identifiable levels, over the measured samples) is above the
    /// single fit's, or that has no identifiable level, is replaced by the
    /// single fit as its one row when that fit is identifiable, and a
    /// warning says so; otherwise a warning says what is left.
    pub fn check_against(
        &mut self,
        rec: &BatteryRecord,
        single_v: &[f64],
        j: &crate::identify::battery::BatteryJson,
    ) {
        let single = rmse(single_v, &rec.voltage, &self.unmeasured);
        // A NaN map RMSE (no identifiable level) is worse too.
        if self.rmse_v.is_finite() && self.rmse_v <= single {
            return;
        }
        let why = if self.rmse_v.is_finite() {
            format!(
                "the map's whole-record RMSE {:.2} mV is above the single fit's {:.2} mV",
                self.rmse_v * 1e3,
                single * 1e3
            )
        } else {
            "the map has no identifiable level".to_owned()
        };
        let cell_ok = CellParameters {
            r_i: j.r_i,
            r_ct: j.r_ct,
            q: j.q,
            alpha: j.alpha,
            u_oc: j.ocv_offset_v.unwrap_or(j.u_oc),
            bv_a: j.bv_a_v.unwrap_or(0.0),
            bv_i0: j.bv_i0_a.unwrap_or(1.0),
        }
        .is_physical();
        let Some(d) = j.ocv_offset_v.filter(|_| j.identifiable && cell_ok) else {
            self.warnings.push(format!(
                "{why}, and the single fit is not identifiable either: the map is written as fitted; `predict` and `online --prior` use only its identifiable levels"
            ));
            return;
        };
        let soc = match (j.soc0, j.soc_end) {
            (Some(a), Some(b)) => (0.5 * (a + b)).clamp(0.0, 1.0),
            _ => 0.5,
        };
        self.map = ParameterMap {
            rows: vec![MapRow {
                temperature_c: self.temperature_c,
                soc,
                r_i: j.r_i,
                r_ct: j.r_ct,
                q: j.q,
                alpha: j.alpha,
                bv_a_v: j.bv_a_v,
                bv_i0_a: j.bv_i0_a,
                ocv_offset_v: d,
                rmse_v: j.rmse_v,
                identifiable: true,
                identifiable_reason: None,
                confidence: j.confidence.clone(),
                start_s: rec.time[0],
                end_s: rec.time[rec.time.len() - 1],
                samples: rec.time.len(),
            }],
        };
        self.model_v = single_v.to_vec();
        self.rmse_v = single;
        self.warnings.push(format!(
            "{why}: the single fit is written as the map's one row"
        ));
    }

    /// The map in the JSON of `identify battery`: its levels, those
    /// skipped, and the whole-record RMSE of the map model beside that of
    /// the single fit `single_v`, over `rec`'s measured samples (not
    /// [`MapFit::unmeasured`]).
    pub fn json(&self, rec: &BatteryRecord, single_v: &[f64]) -> MapJson {
        MapJson {
            levels: self.map.rows.clone(),
            skipped: self.skipped.clone(),
            map_rmse_v: self.rmse_v,
            single_rmse_v: rmse(single_v, &rec.voltage, &self.unmeasured),
            joint: self.joint.clone(),
        }
    }
}

pub mod joint;
pub mod levels;
pub mod model;
pub use model::{map_use, map_voltage, rmse, MapUse};

#[cfg(test)]
mod tests;
