//! Real cells: the estimators on PyBaMM DFN records (data/pybamm), data
//! our own model did not make, against an independent best-achievable
//! reference (bench/reference_fit.py, data/pybamm/reference.json).

use estimator_core::battery::ocv::OcvModel;
use estimator_core::battery::Prior;
use fracbms_host::identify::{battery_identify, BatteryResult, Refine};
use fracbms_host::identify::{BatteryMethod, ModelRequest};
use fracbms_host::io;
use fracbms_host::ocv::CellOcv;
use fracbms_host::online;
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .join("data/pybamm")
        .join(name)
}

fn json(name: &str) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(data(name)).unwrap()).unwrap()
}

/// The record, and its OCV curve with the start SOC read from its rested
/// first rows.
fn record(cell: &str, profile: &str) -> (io::BatteryRecord, CellOcv) {
    let path = data(&format!("{cell}-{profile}.csv"));
    let rec = io::read_battery(&path, None).unwrap();
    let table = io::read_ocv(&data(&format!("{cell}-ocv.csv"))).unwrap();
    let cap = json("meta.json")["ocv"][cell]["capacity_ah"]
        .as_f64()
        .unwrap();
    let model = OcvModel::new(table, cap).unwrap();
    let soc0 = model.soc_at_rest(&rec.current, &rec.voltage).unwrap();
    (rec, CellOcv { model, soc0 })
}

fn fit(cell: &str, profile: &str) -> BatteryResult {
    fit_model(cell, profile, ModelRequest::Linear)
}

fn fit_model(cell: &str, profile: &str, model: ModelRequest) -> BatteryResult {
    let (rec, c) = record(cell, profile);
    let path = data(&format!("{cell}-{profile}.csv"));
    battery_identify(
        &path,
        &rec,
        Some(&c),
        BatteryMethod::Refined,
        None,
        50,
        false,
        Refine {
            model,
            ..Refine::default()
        },
    )
    .unwrap()
}

const RECORDS: [(&str, &str); 4] = [
    ("chen2020", "drive"),
    ("chen2020", "hppc"),
    ("prada2013", "drive"),
    ("prada2013", "hppc"),
];

/// Runs `f` on a thread with the stack the CLI gives its estimators (they
/// hold their windows inline).
fn with_stack(f: impl FnOnce() + Send + 'static) {
    std::thread::Builder::new()
        .stack_size(512 << 20)
        .spawn(f)
        .unwrap()
        .join()
        .unwrap_or_else(|e| std::panic::resume_unwind(e));
}

/// With the OCV table, the whole-record output-error fit reaches the best
/// single-branch fit that an independent multi-start search (scipy, 30
/// starts, full memory) finds on the same record: free-run RMSE within
/// 1.1× (measured: 1.000, 0.999, 1.000, 1.000).
#[test]
fn whole_record_fit_with_the_table_is_the_best_achievable() {
    with_stack(whole_record_fit);
}

fn whole_record_fit() {
    let reference = json("reference.json");
    for (cell, profile) in RECORDS {
        let r = fit(cell, profile);
        let best = reference[format!("{cell}-{profile}")]["cpe"]["rmse_v"]
            .as_f64()
            .unwrap();
        let ratio = r.json.rmse_v / best;
        println!(
            "{cell}-{profile}: RMSE {:.3} mV, reference {:.3} mV, ratio {ratio:.3}",
            1e3 * r.json.rmse_v,
            1e3 * best
        );
        assert!(ratio <= 1.1, "{cell}-{profile}: {ratio}");
        assert!(r.json.converged, "{cell}-{profile}");
    }
}

/// Over a sliding window of 256 samples (memory 64) with a prior from the
/// other record of the same cell (a characterization test): every
/// published R_ct after the first 512 samples lies within [0.5×, 2×] of the
/// record's own whole-record fit with the table, and without the table
/// within 3× of it (no runaway).
#[test]
fn sliding_window_with_a_prior_publishes_no_runaway() {
    with_stack(sliding_window);
}

fn sliding_window() {
    for (cell, profile) in RECORDS {
        let other = if profile == "drive" { "hppc" } else { "drive" };
        let whole = fit(cell, profile).cell.r_ct;
        let p = fit(cell, other).cell;
        let prior = Prior::new(p);
        let (rec, c) = record(cell, profile);
        for with_table in [true, false] {
            let mut rows = Vec::new();
            online::track(
                &rec,
                &online::TrackOptions {
                    prior: Some(&prior),
                    cell: with_table.then_some(&c),
                    ..online::TrackOptions::new(256, 64)
                },
                None,
                &[],
                |r| {
                    rows.push(r);
                    Ok(())
                },
            )
            .unwrap();
            let ratios: Vec<f64> = rows[512..]
                .iter()
                .filter_map(|r| r.estimate.map(|e| e.r_ct / whole))
                .collect();
            assert_eq!(ratios.len(), rows.len() - 512);
            let lo = ratios.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = ratios.iter().copied().fold(0.0, f64::max);
            println!("{cell}-{profile} table {with_table}: R_ct / whole-record {lo:.2}..{hi:.2}");
            if with_table {
                assert!(lo >= 0.5 && hi <= 2.0, "{cell}-{profile}: {lo} {hi}");
            } else {
                assert!(hi <= 3.0, "{cell}-{profile}: {hi}");
            }
        }
    }
}

/// The Butler–Volmer model on the DFN records: its whole-record fit
/// reaches the independent reference's fit of the same model (`cpe_bv` of
/// bench/reference_fit.py) within 1.02× (measured 1.000, 0.996, 1.000,
/// 1.000), below the linear fit's RMSE on every record (3.8× on the LG M50
/// drive cycle); `auto` takes it on the two drive cycles (current to 4–7
/// i₀, every parameter identified) and keeps the linear model on the two
/// HPPC records, whose few current levels leave R_i unidentified beside
/// the term.
#[test]
fn butler_volmer_fit_reaches_the_reference_and_auto_takes_it_where_identified() {
    with_stack(butler_volmer_fit);
}

fn butler_volmer_fit() {
    let reference = json("reference.json");
    for (cell, profile) in RECORDS {
        let name = format!("{cell}-{profile}");
        // `auto` fits both models (the Butler–Volmer one from the linear
        // fit) and reports both.
        let auto = fit_model(cell, profile, ModelRequest::Auto);
        let c = auto.json.model_choice.as_ref().unwrap();
        let best = reference[&name]["cpe_bv"]["rmse_v"].as_f64().unwrap();
        let ratio = c.rmse_butler_volmer_v / best;
        println!(
            "{name}: BV {:.3} mV, reference BV {:.3} mV, ratio {ratio:.3}; linear {:.3} mV; auto: {}",
            1e3 * c.rmse_butler_volmer_v,
            1e3 * best,
            1e3 * c.rmse_linear_v,
            c.reason
        );
        assert!(ratio <= 1.02, "{name}: {ratio}");
        assert!(c.rmse_butler_volmer_v < c.rmse_linear_v, "{name}");
        if cell == "chen2020" && profile == "drive" {
            let gain = c.rmse_linear_v / c.rmse_butler_volmer_v;
            assert!(gain > 3.5, "{gain}");
        }
        let want = if profile == "drive" {
            "butler-volmer"
        } else {
            "linear"
        };
        assert_eq!(auto.json.model, want, "{name}: {}", c.reason);
        assert_eq!(c.chosen, want);
    }
}

/// The voltage limit `bench/sop_dfn.py` gave `--voltage-min` on a cell.
fn sop_limit(cell: &str) -> f64 {
    if cell == "chen2020" {
        3.3
    } else {
        2.9
    }
}

/// State of power against the DFN (issue 36): `data/pybamm/sop-truth.csv`
/// (bench/sop_dfn.py, PyBaMM continued from row t0 with a constant pulse).
/// From the same history, `online battery`'s library (window 256, OCV
/// table; on the drive cycles the HPPC record's fit as prior) predicts the
/// pulse:
/// * a 1C discharge for 10 and 30 s: the error over the pulse's true drop
///   is printed; on the HPPC records its median is within the 10 %
///   (asserted), the worst is not (14.4 %; 19–20 % on the drive cycle,
///   docs/state-of-power-accuracy.md);
/// * at the state-of-power current (the track's own
///   `sop_discharge_a_{H}s` for that limit, reproduced here to 1e−6) the
///   true cell stays above the limit: the prediction errs on the safe side
///   (asserted within 1 % of the drop), but by up to half the drop at 10 s
///   (the linear model's drop is steeper than the DFN's at 4–5C).
#[test]
fn state_of_power_against_the_dfn_continued() {
    with_stack(sop_against_dfn);
}

fn sop_against_dfn() {
    let text = std::fs::read_to_string(data("sop-truth.csv")).unwrap();
    let meta = json("meta.json");
    let mut hppc_errors = Vec::new();
    let mut tracks = std::collections::HashMap::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (rec, t0, current, steps) = (
            f[0],
            f[1].parse::<usize>().unwrap(),
            f[2].parse::<f64>().unwrap(),
            f[3].parse::<usize>().unwrap(),
        );
        let (v_end, v_min): (f64, f64) = (f[4].parse().unwrap(), f[5].parse().unwrap());
        let (cell, profile) = rec.split_once('-').unwrap();
        let cap = meta["records"][rec]["capacity_ah"].as_f64().unwrap();
        let prior = (profile == "drive").then(|| Prior::new(fit(cell, "hppc").cell));
        let (r, c) = record(cell, profile);
        let v0 = r.voltage[t0];
        let mut power = online::power::PowerOptions::default()
            .with_horizons(&[steps as f64])
            .unwrap();
        power.pulse_current_a = Some(current);
        power.voltage_min = Some(sop_limit(cell));
        power.current_limit = Some(5.0 * cap);
        // The model's own limit, not derated by its spread: the rows of
        // `sop-truth.csv` were made at that current.
        power.confidence = Some(0.0);
        let row = tracks
            .entry((rec.to_owned(), t0, current.to_bits(), steps))
            .or_insert_with(|| {
                let mut at = None;
                online::track(
                    &r,
                    &online::TrackOptions {
                        prior: prior.as_ref(),
                        cell: Some(&c),
                        power,
                        ..online::TrackOptions::new(256, 64)
                    },
                    None,
                    &[],
                    |row| {
                        if (row.t - t0 as f64).abs() < 0.5 {
                            at = Some(row.power[0]);
                        }
                        Ok(())
                    },
                )
                .unwrap();
                at.unwrap()
            })
            .to_owned();
        let predicted = row
            .pulse_v
            .unwrap_or_else(|| panic!("{line}: nothing published"));
        let sop = row.discharge_a.unwrap();
        let is_sop = (sop + current).abs() <= 1e-6 * sop;
        if is_sop {
            let drop = v0 - v_min;
            println!("{rec} t0 {t0}: SOP {sop:.2} A for {steps} s: the DFN's lowest {v_min:.4} V, limit {}", sop_limit(cell));
            assert!(
                v_min >= sop_limit(cell) - 0.01 * drop,
                "{line}: the true cell crosses the limit"
            );
            // Consistent: the model's own pulse at its SOP current ends on
            // the limit within 1 % of the drop to it, or above it where the
            // current limit (5C) binds.
            let limit = sop_limit(cell);
            let capped = (sop - 5.0 * cap).abs() <= 1e-6 * sop;
            println!("  the model's pulse at it ends at {predicted:.4} V ({:+.2} % of the drop from the limit{})",
                100.0 * (predicted - limit) / (v0 - limit), if capped { ", at the 5C cap" } else { "" });
            if capped {
                assert!(
                    predicted >= limit,
                    "{line}: the model's pulse crosses the limit"
                );
            } else {
                assert!(
                    (predicted - limit).abs() <= 0.01 * (v0 - limit),
                    "{line}: the model's pulse at its SOP current ends at {predicted}, not on {limit}"
                );
            }
        } else {
            let e = (predicted - v_end).abs() / (v0 - v_end);
            println!("{rec} t0 {t0}: {current:.2} A for {steps} s: predicted {predicted:.4} V, DFN {v_end:.4} V, {:.1} % of the drop", 100.0 * e);
            if profile == "hppc" {
                hppc_errors.push(e);
            }
        }
    }
    hppc_errors.sort_by(f64::total_cmp);
    assert!(!hppc_errors.is_empty());
    let median = hppc_errors[hppc_errors.len() / 2];
    assert!(median <= 0.10, "median {median}");
}

#[test]
fn the_butler_volmer_model_predicts_the_drive_cycles_pulses() {
    with_stack(butler_volmer_pulses);
}

/// The 1C rows of the committed truth on the drive cycles, predicted by the
/// online Butler–Volmer model with the HPPC record's Butler–Volmer fit as
/// prior (docs/state-of-power-accuracy.md, `bench/sop_truth.py --model butler-volmer`):
/// within 10 % of the DFN's drop at every Chen2020 instant. The prior's
/// R_i (the term took its place in the HPPC fit) is published as the
/// prior's, never as identified; the linear run's R_ct is mostly the
/// prior's too, where the same windows without a prior identify none.
fn butler_volmer_pulses() {
    let text = std::fs::read_to_string(data("sop-truth.csv")).unwrap();
    let meta = json("meta.json");
    for (cell, within) in [("chen2020", 6), ("prada2013", 5)] {
        let rec = format!("{cell}-drive");
        let cap = meta["records"][&rec]["capacity_ah"].as_f64().unwrap();
        let (r, c) = record(cell, "drive");
        let rows: Vec<(usize, usize, f64)> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').collect::<Vec<_>>())
            .filter(|f| f[0] == rec && (f[2].parse::<f64>().unwrap() + cap).abs() <= 1e-6 * cap)
            .map(|f| {
                (
                    f[1].parse().unwrap(),
                    f[3].parse().unwrap(),
                    f[4].parse().unwrap(),
                )
            })
            .collect();
        assert_eq!(rows.len(), 6, "{rec}");
        let run = |model: ModelRequest, prior: Option<&Prior<f64>>| {
            let mut power = online::power::PowerOptions::default()
                .with_horizons(&[10.0, 30.0])
                .unwrap();
            power.pulse_current_a = Some(-cap);
            power.voltage_min = Some(sop_limit(cell));
            power.current_limit = Some(5.0 * cap);
            let mut track = Vec::new();
            online::track(
                &r,
                &online::TrackOptions {
                    prior,
                    cell: Some(&c),
                    model,
                    power,
                    ..online::TrackOptions::new(256, 64)
                },
                None,
                &[],
                |row| {
                    track.push(row);
                    Ok(())
                },
            )
            .unwrap();
            track
        };
        let bv_prior = Prior::new(fit_model(cell, "hppc", ModelRequest::ButlerVolmer).cell);
        let bv = run(ModelRequest::ButlerVolmer, Some(&bv_prior));
        let mut good = 0;
        for &(t0, steps, v_end) in &rows {
            let row = &bv[t0];
            let k = if steps == 10 { 0 } else { 1 };
            let p = row.power[k]
                .pulse_v
                .unwrap_or_else(|| panic!("{rec} {t0}: nothing published"));
            let e = (p - v_end).abs() / (r.voltage[t0] - v_end);
            println!(
                "{rec} t0 {t0} {steps} s: Butler–Volmer {:.1} % of the drop",
                100.0 * e
            );
            good += usize::from(e <= 0.10);
        }
        assert!(good >= within, "{rec}: {good} of 6 within 10 %");
        // At its state-of-power currents (capped at the largest current of
        // the window: the term is not extrapolated) the DFN stays above the
        // limit: data/pybamm/sop-truth-bv.csv, PyBaMM continued at them.
        let bv_truth = std::fs::read_to_string(data("sop-truth-bv.csv")).unwrap();
        let mut judged = 0;
        for f in bv_truth
            .lines()
            .skip(1)
            .map(|l| l.split(',').collect::<Vec<_>>())
            .filter(|f| f[0] == rec)
        {
            let (t0, current, steps) = (
                f[1].parse::<usize>().unwrap(),
                f[2].parse::<f64>().unwrap(),
                f[3].parse::<usize>().unwrap(),
            );
            let k = if steps == 10 { 0 } else { 1 };
            let Some(sop) = bv[t0].power[k].discharge_a else {
                continue;
            };
            if (sop + current).abs() > 1e-6 * sop {
                continue;
            }
            let v_min: f64 = f[5].parse().unwrap();
            println!("{rec} t0 {t0}: SOP {sop:.2} A for {steps} s: the DFN's lowest {v_min:.4} V");
            assert!(
                v_min >= sop_limit(cell),
                "{rec} {t0}: the true cell crosses the limit"
            );
            judged += 1;
        }
        assert_eq!(
            judged, 6,
            "{rec}: the truth's state-of-power rows are this estimator's"
        );
        use estimator_core::battery::online::Identification as Id;
        assert!(bv
            .iter()
            .all(|row| row.published.r_i.status != Id::Identified
                || row.published.r_i.value.is_some_and(|x| x > 1e-4)));
        assert!(
            bv.iter()
                .filter(|row| row.published.r_i.status == Id::Prior)
                .count()
                > 2500
        );
        // The linear model: R_ct identified by the data only where the
        // windows without the prior identify it.
        let lin_prior = Prior::new(fit(cell, "hppc").cell);
        let count = |t: &[online::TrackRow], s: Id| {
            t.iter()
                .filter(|row| row.published.r_ct.status == s)
                .count()
        };
        let (with, without) = (
            run(ModelRequest::Linear, Some(&lin_prior)),
            run(ModelRequest::Linear, None),
        );
        println!(
            "{rec}: R_ct identified {} and the prior's {} with the prior, identified {} without",
            count(&with, Id::Identified),
            count(&with, Id::Prior),
            count(&without, Id::Identified)
        );
        assert!(count(&with, Id::Prior) > 2500);
        assert!(count(&with, Id::Identified) <= count(&without, Id::Identified) + 200);
    }
}
