//! Validation on another record: an identified model run on a log's
//! current, its voltage beside the measured one.
//!
//! It owns reading a fit (the JSON of `identify battery`), the free run on
//! a new record and the error statistics. It must not fit anything (that
//! is [`crate::identify`]) nor read records itself ([`crate::cycler`]).
//!
//! Conventions: current positive charging (A); the model starts from rest
//! at the record's first sample; with an OCV table, the SOC is counted from
//! `--soc0` (or the rested start) and the model's voltage is
//! `OCV(SOC) + ΔU + R_i·I + a·asinh(I/i₀) + U_p`.

use crate::error::Result;
use crate::identify::battery::model_voltage;
use crate::io::{self, BatteryRecord};
use crate::ocv::{OcvOptions, OcvSpec};
use crate::{bail, err};
use estimator_core::battery::CellParameters;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A fit read from the JSON of `identify battery`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    /// The cell; with an OCV table its `u_oc` is the offset ΔU.
    pub cell: CellParameters<f64>,
    /// Whether the fit was made against an OCV table (`ocv_offset_v`).
    pub with_ocv: bool,
}

/// Reads the JSON of `identify battery` at `path`.
///
/// # Errors
/// [`crate::ErrorKind::Io`] when it cannot be read, [`crate::ErrorKind::Data`]
/// when it is not that JSON or its cell is not physical.
pub fn read_fit(path: &Path) -> Result<Fit> {
    fit_from_json(&crate::identify::battery::read_json_file(path)?, path)
}

/// A fit from the JSON value of `identify battery` (the Python face's
/// dict); `path` names it in errors.
///
/// # Errors
/// [`crate::ErrorKind::Data`] when a number is missing or the cell is not
/// physical.
pub fn fit_from_json(j: &serde_json::Value, path: &Path) -> Result<Fit> {
    let (mut cell, offset) = crate::identify::battery::cell_from_json(j, path)?;
    if let Some(d) = offset {
        cell.u_oc = d;
    }
    if !cell.is_physical() {
        bail!(Data, "{}: the fit's cell is not physical", path.display());
    }
    Ok(Fit {
        cell,
        with_ocv: offset.is_some(),
    })
}

/// The model a prediction runs: a single fit, or a parameter map.
#[derive(Clone, Debug, PartialEq)]
pub enum Model {
    /// The JSON of `identify battery`.
    Fit(Fit),
    /// The CSV of `identify battery --map-out`.
    Map(crate::map::ParameterMap),
}

/// The predictions of several records as one JSON array, each object with
/// its record's path as `input` (`predict battery --json` with several
/// `--input`).
pub fn named(inputs: &[PathBuf], ps: &[Prediction]) -> serde_json::Value {
    inputs
        .iter()
        .zip(ps)
        .map(|(input, p)| {
            let mut v = serde_json::to_value(p).unwrap_or(serde_json::Value::Null);
            if let Some(o) = v.as_object_mut() {
                o.insert("input".into(), input.display().to_string().into());
            }
            v
        })
        .collect()
}

/// Reads a model: the JSON of a fit when the file starts with `{`, a map
/// when its first line is the map's header (`temperature_c,soc,…`) or its
/// name ends in `.csv` (a CSV that is not a map is then refused by the
/// map's reader, naming the columns it lacks), else the JSON of a fit.
///
/// # Errors
/// As [`read_fit`] and [`crate::map::ParameterMap::read_csv`].
pub fn read_model(path: &Path) -> Result<Model> {
    let head = std::fs::read_to_string(path)
        .map_err(|e| err!(Io, "{}: cannot read ({e})", path.display()))?;
    let is_csv = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
    if head.trim_start().starts_with('{') {
        read_fit(path).map(Model::Fit)
    } else if is_csv
        || head
            .lines()
            .next()
            .is_some_and(|l| l.contains("soc") && l.contains("r_i"))
    {
        crate::map::ParameterMap::read_csv(path).map(Model::Map)
    } else {
        read_fit(path).map(Model::Fit)
    }
}

/// How `predict battery` runs: the model file, the OCV and the record.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PredictOptions {
    /// The model: the JSON of `identify battery`, or its map CSV.
    pub model: PathBuf,
    /// The record's temperature (°C) for a map over temperature (default:
    /// the temperature column's mean, else the map's first temperature).
    pub temperature_c: Option<f64>,
    /// The OCV table, capacity and start SOC (needed when the fit was made
    /// with a table).
    pub ocv: OcvOptions,
    /// How the record is read.
    pub record: crate::cycler::RecordOptions,
}

/// The model's voltage beside the record's, and how far apart they are.
#[derive(Clone, Debug, Serialize)]
pub struct Prediction {
    /// RMSE of the model's voltage against the measured one (V), over the
    /// samples with a finite voltage that are the log's (not inside a gap).
    pub rmse_v: f64,
    /// The largest |model − measured| (V).
    pub max_error_v: f64,
    /// Where it is (s).
    pub max_error_time_s: f64,
    /// Samples compared.
    pub samples: usize,
    /// Samples whose voltage was not finite (not compared).
    pub voltages_skipped: usize,
    /// Samples inside the record's gaps (made up by the resampling; not
    /// compared).
    pub samples_in_gaps: usize,
    /// Samples inside a step's unlogged start (no measured voltage; not
    /// compared; `observed` 0 in the output).
    pub unobserved_samples: usize,
    /// Samples whose current was not finite (the one before held).
    pub currents_held: usize,
    /// SOC at the start (null without an OCV table).
    pub soc0: Option<f64>,
    /// SOC after the last sample (null without an OCV table).
    pub soc_end: Option<f64>,
    /// How the record was read.
    pub record: Option<crate::cycler::RecordReport>,
    /// The errors over the measured samples whose counted SOC lies inside
    /// the OCV table (null without a table): where the model is defined.
    pub in_table: Option<InTable>,
    /// What a map model used (null for a fit): rows left out, the
    /// temperature rule, the map's activation energies.
    pub map: Option<crate::identify::map::MapUse>,
    /// The model's voltage at each sample (V).
    #[serde(skip)]
    pub model_v: Vec<f64>,
    /// Whether each sample's voltage is a measurement (not inside a gap
    /// nor a step's unlogged start): the RMSE's samples.
    #[serde(skip)]
    pub observed: Vec<bool>,
}

/// The errors of a prediction over the measured samples inside the OCV
/// table's SOC range.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct InTable {
    /// Samples compared.
    pub samples: usize,
    /// RMSE (V).
    pub rmse_v: f64,
    /// The largest |model − measured| (V).
    pub max_error_v: f64,
    /// Where it is (s).
    pub max_error_time_s: f64,
    /// The table's SOC range.
    pub soc_range: [f64; 2],
}

/// Runs `fit` on `rec`'s current (file `path`, named in errors) with the
/// OCV `ocv` if the fit was made with a table: the SOC counted from its
/// start and, after each of the record's `gaps`, read again at rest as
/// `identify battery` reads it (the charge of a gap is not in the log).
///
/// # Errors
/// [`crate::ErrorKind::Options`] when the fit needs an OCV table and none
/// is given (or the reverse); [`crate::ErrorKind::Data`] for a record that
/// does not start at rest when its start SOC must be read.
pub fn predict(
    path: &Path,
    rec: &BatteryRecord,
    fit: &Fit,
    ocv: Option<&OcvSpec>,
    gaps: &[crate::cycler::resample::Gap],
) -> Result<Prediction> {
    let mut current = rec.current.clone();
    let mut currents_held = 0;
    let mut last = 0.0;
    for i in &mut current {
        if i.is_finite() {
            last = *i;
        } else {
            *i = last;
            currents_held += 1;
        }
    }
    let (model_v, soc0, soc_end) = match (ocv, fit.with_ocv) {
        (Some(spec), true) => {
            let held = BatteryRecord {
                current: current.clone(),
                ..rec.clone()
            };
            let c = spec.resolve(path, &held)?;
            let mut end = c.soc0;
            let minus_ocv: Vec<f64> = c
                .counted_soc(&held, gaps)
                .iter()
                .zip(&current)
                .map(|(&z, &i)| {
                    end = c.model.soc_after(z, i, rec.h);
                    c.model.overpotential(end, 0.0)
                })
                .collect();
            let up = model_voltage(&fit.cell, rec.h, &current)?;
            let v = up.iter().zip(&minus_ocv).map(|(m, o)| m - o).collect();
            (v, Some(c.soc0), Some(end))
        }
        (None, false) => (model_voltage(&fit.cell, rec.h, &current)?, None, None),
        (None, true) => bail!(
            Options,
            "the fit was made with an OCV table (its ocv_offset_v): give --ocv and --capacity-ah"
        ),
        (Some(_), false) => bail!(
            Options,
            "the fit was made without an OCV table (no ocv_offset_v): leave out --ocv"
        ),
    };
    let mut p = errors(path, rec, model_v, &[], &[])?;
    p.currents_held = currents_held;
    p.soc0 = soc0;
    p.soc_end = soc_end;
    Ok(p)
}

/// Runs the map `map` on `rec` (file `path`) with the OCV `spec` at the
/// temperature `t` ([`crate::identify::map::map_voltage`]: its
/// identifiable rows, Arrhenius between temperatures).
///
/// # Errors
/// As [`predict`].
pub fn predict_map(
    path: &Path,
    rec: &BatteryRecord,
    map: &crate::map::ParameterMap,
    spec: &OcvSpec,
    t: Option<f64>,
    gaps: &[crate::cycler::resample::Gap],
) -> Result<Prediction> {
    let c = spec.resolve(path, rec)?;
    let model_v = crate::identify::map::map_voltage(map, rec, &c, t, gaps)?;
    let used = crate::identify::map::map_use(map, t);
    let soc = crate::map::counted_soc(rec, &c, gaps);
    let end = soc.last().copied().unwrap_or(c.soc0)
        + rec
            .current
            .last()
            .copied()
            .filter(|i| i.is_finite())
            .unwrap_or(0.0)
            * rec.h
            / (3600.0 * c.model.capacity_ah);
    let mut p = errors(path, rec, model_v, &crate::map::in_gaps(rec, gaps), &[])?;
    p.soc0 = Some(c.soc0);
    p.soc_end = Some(end);
    p.currents_held = rec.current.iter().filter(|i| !i.is_finite()).count();
    p.map = Some(used);
    Ok(p)
}

/// The error statistics of `model_v` against `rec`'s voltage, over the
/// samples that are the log's measurements: not those made up inside a gap
/// (`gap[k]`) nor those inside a step's unlogged start (`unobserved[k]`;
/// an empty mask: none).
fn errors(
    path: &Path,
    rec: &BatteryRecord,
    model_v: Vec<f64>,
    gap: &[bool],
    unobserved: &[bool],
) -> Result<Prediction> {
    let (mut sum, mut n, mut worst, mut at) = (0.0, 0usize, 0.0f64, 0.0);
    let is = |m: &[bool], k: usize| m.get(k).copied().unwrap_or(false);
    let in_gap = (0..rec.time.len()).filter(|&k| is(gap, k)).count();
    let unobs = (0..rec.time.len())
        .filter(|&k| !is(gap, k) && is(unobserved, k))
        .count();
    for (k, ((m, v), t)) in model_v.iter().zip(&rec.voltage).zip(&rec.time).enumerate() {
        if is(gap, k) || is(unobserved, k) {
            continue;
        }
        if v.is_finite() {
            let e = m - v;
            sum += e * e;
            n += 1;
            if e.abs() > worst {
                worst = e.abs();
                at = *t;
            }
        }
    }
    if n == 0 {
        bail!(Data, "{}: no finite voltage to compare", path.display());
    }
    Ok(Prediction {
        rmse_v: (sum / n as f64).sqrt(),
        max_error_v: worst,
        max_error_time_s: at,
        samples: n,
        voltages_skipped: rec.voltage.len() - n - in_gap - unobs,
        samples_in_gaps: in_gap,
        unobserved_samples: unobs,
        currents_held: 0,
        soc0: None,
        soc_end: None,
        record: None,
        in_table: None,
        map: None,
        model_v,
        observed: vec![],
    })
}

/// The model of a JSON value: a map when it has `levels` (the `map` of
/// `identify battery`), else a fit; `path` names it in errors.
///
/// # Errors
/// [`crate::ErrorKind::Data`] when it is neither.
pub fn model_from_json(j: &serde_json::Value, path: &Path) -> Result<Model> {
    match j.get("levels") {
        Some(levels) => crate::map::ParameterMap::from_json_levels(levels, path).map(Model::Map),
        None => fit_from_json(j, path).map(Model::Fit),
    }
}

/// A map runs on the OCV table: refused without one (before a record is
/// read).
///
/// # Errors
/// [`crate::ErrorKind::Options`] for a map without `spec`.
pub fn check_model_ocv(model: &Model, spec: Option<&OcvSpec>) -> Result<()> {
    if matches!(model, Model::Map(_)) && spec.is_none() {
        bail!(
            Options,
            "a parameter map runs on the OCV table: give --ocv and --capacity-ah"
        );
    }
    Ok(())
}

/// Runs `model` on the record `read` (file `path`): a fit by [`predict`],
/// a map by [`predict_map`] at the temperature `t` (default: the record's
/// temperature column's mean); the report of the reading attached.
///
/// # Errors
/// As [`predict`], [`predict_map`] and [`check_model_ocv`].
pub fn run_model(
    path: &Path,
    read: &crate::cycler::CyclerRecord,
    model: &Model,
    spec: Option<&OcvSpec>,
    t: Option<f64>,
) -> Result<Prediction> {
    check_model_ocv(model, spec)?;
    crate::map::check_temperature(t)?;
    let gap = crate::map::in_gaps(&read.record, &read.report.resampling.gaps);
    let unobserved = read.report.unobserved(read.record.h, &read.record.time);
    let mut p = match (model, spec) {
        (Model::Fit(fit), spec) => {
            predict(path, &read.record, fit, spec, &read.report.resampling.gaps)?
        }
        (Model::Map(map), Some(spec)) => {
            let t = t.or_else(|| {
                let col = read.temperature.as_deref()?;
                let ok: Vec<f64> = col.iter().copied().filter(|x| x.is_finite()).collect();
                (!ok.is_empty()).then(|| ok.iter().sum::<f64>() / ok.len() as f64)
            });
            predict_map(
                path,
                &read.record,
                map,
                spec,
                t,
                &read.report.resampling.gaps,
            )?
        }
        (Model::Map(_), None) => bail!(Internal, "a map without an OCV table"),
    };
    // Compared over the log's measured samples, a fit as a map.
    let e = errors(
        path,
        &read.record,
        std::mem::take(&mut p.model_v),
        &gap,
        &unobserved,
    )?;
    let mut p = Prediction {
        currents_held: p.currents_held,
        soc0: p.soc0,
        soc_end: p.soc_end,
        map: p.map,
        ..e
    };
    p.record = Some(read.report.clone());
    p.observed = (0..read.record.time.len())
        .map(|k| !gap[k] && !unobserved.get(k).copied().unwrap_or(false))
        .collect();
    if let Some(spec) = spec {
        p.in_table = Some(in_table(path, read, spec, &p)?);
    }
    Ok(p)
}

/// The errors of `p` over its measured samples whose counted SOC (from
/// `spec`'s start, read again after each gap) is inside the table.
fn in_table(
    path: &Path,
    read: &crate::cycler::CyclerRecord,
    spec: &OcvSpec,
    p: &Prediction,
) -> Result<InTable> {
    let rec = &read.record;
    let held = BatteryRecord {
        current: rec
            .current
            .iter()
            .scan(0.0, |last, i| {
                if i.is_finite() {
                    *last = *i;
                }
                Some(*last)
            })
            .collect(),
        ..rec.clone()
    };
    let c = spec.resolve(path, &held)?;
    let soc = crate::map::counted_soc(&held, &c, &read.report.resampling.gaps);
    let t = &c.model.table;
    let (lo, hi) = (
        t.soc_points().first().copied().unwrap_or(0.0),
        t.soc_points().last().copied().unwrap_or(1.0),
    );
    let (mut sum, mut n, mut worst, mut at) = (0.0, 0usize, 0.0f64, f64::NAN);
    let samples = (rec.time.iter().zip(&rec.voltage))
        .zip(p.model_v.iter().zip(&p.observed))
        .zip(&soc);
    for (((t, v), (m, seen)), z) in samples {
        if !(*seen && v.is_finite() && *z >= lo && *z <= hi) {
            continue;
        }
        let e = m - v;
        sum += e * e;
        n += 1;
        if e.abs() > worst {
            worst = e.abs();
            at = *t;
        }
    }
    Ok(InTable {
        samples: n,
        rmse_v: if n > 0 {
            (sum / n as f64).sqrt()
        } else {
            f64::NAN
        },
        max_error_v: if n > 0 { worst } else { f64::NAN },
        max_error_time_s: at,
        soc_range: [lo, hi],
    })
}

/// `predict battery` on the file `input`: reads it, runs the fit of
/// `o.model` and writes `time_s,current_a,voltage_v,model_v,observed` to
/// `out` (`observed` 0 where the sample's voltage was not measured: a
/// step's unlogged start, or inside a gap; an RMSE is taken where it is 1).
///
/// # Errors
/// As [`read_fit`], [`crate::cycler::read_record`] and [`predict`]; the
/// options are checked before the record is read.
pub fn battery_file(input: &Path, out: &Path, o: &PredictOptions) -> Result<Prediction> {
    let mut v = battery_files(&[input.to_path_buf()], Some(out), None, o)?;
    v.pop()
        .ok_or_else(|| err!(Internal, "no prediction for {}", input.display()))
}

/// `predict battery` on several records: each read and run as
/// [`battery_file`]; with one record its CSV goes to `out`; with `report`,
/// the validation page of [`report::write`] and each record's CSV go into
/// that folder; with neither, only the returned predictions (the CLI's
/// `--json`). Every record is read and run before any file is written, so
/// a record that fails leaves none.
///
/// # Errors
/// As [`battery_file`]; [`crate::ErrorKind::Options`] for `out` with
/// several records.
pub fn battery_files(
    inputs: &[PathBuf],
    out: Option<&Path>,
    report: Option<&Path>,
    o: &PredictOptions,
) -> Result<Vec<Prediction>> {
    if inputs.is_empty() {
        bail!(Options, "give a record to predict (--input)");
    }
    if out.is_some() && inputs.len() > 1 {
        bail!(
            Options,
            "--out takes one --input; with {} give --report DIR (each record's CSV goes there)",
            inputs.len()
        );
    }
    let model = read_model(&o.model)?;
    let spec = OcvSpec::from_options(&o.ocv)?;
    check_model_ocv(&model, spec.as_ref())?;
    // Every record read and run before anything is written: a bad later
    // --input leaves no file of the ones before it.
    let mut done = vec![];
    for input in inputs {
        let read = crate::cycler::read_record(input, &o.record)?;
        let p = run_model(input, &read, &model, spec.as_ref(), o.temperature_c)?;
        done.push((read.record, p));
    }
    if let (Some(out), Some((record, p))) = (out, done.first()) {
        write_csv(out, record, p)?;
    }
    if let Some(dir) = report {
        std::fs::create_dir_all(dir).map_err(|e| err!(Io, "cannot make {}: {e}", dir.display()))?;
        for (k, (input, (record, p))) in inputs.iter().zip(&done).enumerate() {
            let csv = dir.join(format!("{}.csv", report::stem(k + 1, input)));
            write_csv(&csv, record, p)?;
        }
        let entries: Vec<report::Entry<'_>> = inputs
            .iter()
            .zip(&done)
            .map(|(input, (record, prediction))| report::Entry {
                input,
                record,
                prediction,
            })
            .collect();
        report::write(dir, &o.model, &entries)?;
    }
    Ok(done.into_iter().map(|(_, p)| p).collect())
}

/// Writes `time_s,current_a,voltage_v,model_v,observed` of `p` on `rec`.
fn write_csv(out: &Path, rec: &BatteryRecord, p: &Prediction) -> Result<()> {
    io::write_csv(
        out,
        &["time_s", "current_a", "voltage_v", "model_v", "observed"],
        (0..rec.time.len()).map(|k| {
            [
                format!("{}", rec.time[k]),
                format!("{}", rec.current[k]),
                format!("{}", rec.voltage[k]),
                format!("{:.9}", p.model_v[k]),
                u8::from(p.observed.get(k).copied().unwrap_or(true)).to_string(),
            ]
        }),
    )
}

pub mod report;

#[cfg(test)]
mod tests {
    use super::*;

    /// A fit run on a record its own model made gives that record back.
    #[test]
    fn the_model_of_a_record_predicts_it_exactly() {
        let cell = CellParameters::<f64>::cell_18650();
        let current: Vec<f64> = (0..600)
            .map(|k| if (k / 50) % 2 == 0 { -5.0 } else { 2.0 })
            .collect();
        let v = model_voltage(&cell, 1.0, &current).unwrap();
        let rec = BatteryRecord {
            time: (0..600).map(f64::from).collect(),
            current,
            voltage: v,
            h: 1.0,
        };
        let fit = Fit {
            cell,
            with_ocv: false,
        };
        let p = predict(Path::new("r.csv"), &rec, &fit, None, &[]).unwrap();
        assert!(p.rmse_v < 1e-12 && p.max_error_v < 1e-12, "{}", p.rmse_v);
        assert_eq!(p.samples, 600);
        let e = predict(
            Path::new("r.csv"),
            &rec,
            &Fit {
                cell,
                with_ocv: true,
            },
            None,
            &[],
        )
        .unwrap_err();
        assert!(e.to_string().contains("give --ocv"), "{e}");
    }

    /// A fit with an OCV table run on a log with a gap (a discharge of
    /// 0.5 A·h the log left out, resumed at rest): the SOC is read again at
    /// rest after the gap, as the fit read it, so the model's own record
    /// comes back; counted through the gap it would be 0.2 SOC high.
    #[test]
    fn a_fit_reads_the_soc_again_after_a_gap() {
        use crate::io::HostOcvTable;
        use estimator_core::battery::profile::ocv_nmc;
        let cap = 2.5;
        let z: Vec<f64> = (0..=50).map(|k| k as f64 / 50.0).collect();
        let v: Vec<f64> = z.iter().map(|&z| ocv_nmc::<f64>(z)).collect();
        let spec = OcvSpec::new(HostOcvTable::new(&z, &v).unwrap(), cap, Some(0.9)).unwrap();
        // With a table, U_oc is the offset ΔU from it.
        let cell = CellParameters {
            u_oc: 0.0,
            ..CellParameters::<f64>::cell_18650()
        };
        // 600 s of pulses, a gap of 1 000 s (logged as a rest: the
        // resampler's held current), then 900 s at rest and 600 s of pulses.
        let pulses = |n: usize| -> Vec<f64> {
            (0..n)
                .map(|k| if (k / 50) % 2 == 0 { -2.0 } else { 0.0 })
                .collect()
        };
        let mut current = pulses(600);
        current.extend(vec![0.0; 1000 + 900]);
        current.extend(pulses(600));
        let n = current.len();
        let up = model_voltage(&cell, 1.0, &current).unwrap();
        // The true SOC: counted, with 0.5 A·h taken inside the gap.
        let mut soc = 0.9;
        let mut voltage = Vec::with_capacity(n);
        for (k, (&i, &u)) in current.iter().zip(&up).enumerate() {
            if k == 600 {
                soc -= 0.5 / cap;
            }
            soc += i / (3600.0 * cap);
            voltage.push(ocv_nmc::<f64>(soc) + u);
        }
        let rec = BatteryRecord {
            time: (0..n).map(|k| k as f64).collect(),
            current,
            voltage,
            h: 1.0,
        };
        let gap = crate::cycler::resample::Gap {
            start_s: 599.0,
            length_s: 1001.0,
            charge_ah: None,
        };
        let fit = Fit {
            cell,
            with_ocv: true,
        };
        let across = predict(Path::new("r.csv"), &rec, &fit, Some(&spec), &[gap]).unwrap();
        let through = predict(Path::new("r.csv"), &rec, &fit, Some(&spec), &[]).unwrap();
        // After the gap (inside it no voltage was measured; `run_model`
        // leaves those samples out) the polarization left at the anchor,
        // 1 900 s after the last pulse, is the only error.
        let worst = |p: &Prediction| {
            (1600..n).fold(0.0f64, |m, k| m.max((p.model_v[k] - rec.voltage[k]).abs()))
        };
        assert!(worst(&across) < 2e-3, "{} V", worst(&across));
        assert!(worst(&through) > 20e-3, "{} V", worst(&through));
        assert!((across.soc_end.unwrap() - soc).abs() < 0.01);
    }
}
