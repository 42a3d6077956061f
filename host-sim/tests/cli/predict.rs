//! `predict battery`: a fit validated on a record it never saw.

use super::*;

fn simulate(name: &str, profile: &str, table: &Path, soc0: &str, seed: &str) -> PathBuf {
    let csv = tmp(name);
    let o = run(&[
        "simulate",
        "battery",
        "--preset",
        "cell",
        "--profile",
        profile,
        "--ocv",
        s(table),
        "--soc0",
        soc0,
        "--length",
        "2500",
        "--seed",
        seed,
        "--out",
        s(&csv),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    csv
}

/// A fit on pulses predicts a drive cycle of the same cell to its noise
/// (σ = 1 mV); the output has the contract's columns; the flags that do
/// not go together are one line each.
#[test]
fn a_pulse_fit_predicts_a_drive_cycle() {
    let table = tmp("predict-nmc.csv");
    super::battery::nmc_table(&table);
    let pulse = simulate("predict-pulse.csv", "pulse", &table, "0.8", "11");
    let drive = simulate("predict-drive.csv", "drive", &table, "0.9", "12");
    let fit = tmp("predict-fit.json");
    let o = run(&[
        "identify",
        "battery",
        "--input",
        s(&pulse),
        "--ocv",
        s(&table),
        "--capacity-ah",
        "2.5",
        "--soc0",
        "0.8",
        "--json",
        s(&fit),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let out = tmp("predict-out.csv");
    let json = tmp("predict-out.json");
    let o = run(&[
        "predict",
        "battery",
        "--model",
        s(&fit),
        "--input",
        s(&drive),
        "--ocv",
        s(&table),
        "--capacity-ah",
        "2.5",
        "--soc0",
        "0.9",
        "--out",
        s(&out),
        "--json",
        s(&json),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("RMSE") && stdout.contains("max error"),
        "{stdout}"
    );
    let j = read_json(&json);
    let rmse = j["rmse_v"].as_f64().unwrap();
    // The noise is 1 mV: a model of the cell predicts to it.
    assert!((0.9e-3..1.2e-3).contains(&rmse), "{rmse}");
    assert!(j["max_error_v"].as_f64().unwrap() < 6e-3, "{j}");
    assert_eq!(j["samples"], 2500);
    assert!((j["soc0"].as_f64().unwrap() - 0.9).abs() < 1e-12);
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.starts_with("time_s,current_a,voltage_v,model_v,observed\n"));
    assert!(text.lines().skip(1).all(|l| l.ends_with(",1")));
    assert_eq!(text.lines().count(), 2501);

    // A wrong model predicts worse: the check can fail.
    let wrong = tmp("predict-wrong.json");
    let mut w = read_json(&fit);
    w["r_i"] = serde_json::json!(w["r_i"].as_f64().unwrap() * 2.0);
    std::fs::write(&wrong, w.to_string()).unwrap();
    let o = run(&[
        "predict",
        "battery",
        "--model",
        s(&wrong),
        "--input",
        s(&drive),
        "--ocv",
        s(&table),
        "--capacity-ah",
        "2.5",
        "--soc0",
        "0.9",
        "--out",
        s(&out),
        "--json",
        s(&json),
    ]);
    assert!(o.status.success());
    assert!(read_json(&json)["rmse_v"].as_f64().unwrap() > 5.0 * rmse);

    // A fit made with an OCV table needs one; a file that is no fit.
    for (model, extra, expect) in [
        (s(&fit), vec![], "give --ocv"),
        (
            s(&table),
            vec!["--ocv", s(&table), "--capacity-ah", "2.5"],
            "not JSON",
        ),
    ] {
        let mut a = vec![
            "predict",
            "battery",
            "--model",
            model,
            "--input",
            s(&drive),
            "--out",
            s(&out),
        ];
        a.extend(extra);
        let o = run(&a);
        assert_eq!(o.status.code(), Some(1));
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains(expect), "{err}");
    }
}
