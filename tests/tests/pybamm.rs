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
