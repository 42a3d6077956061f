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

    // `--json` alone is an output: the same errors, no CSV needed. With no
    // output at all the command says so and exits non-zero.
    let only = tmp("predict-only.json");
    let base = [
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
    ];
    let mut a = base.to_vec();
    a.extend(["--json", s(&only)]);
    let o = run(&a);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(read_json(&only)["rmse_v"].as_f64().unwrap(), rmse);
    let o = run(&base);
    assert_ne!(o.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--out"));

    // A fit made with an OCV table needs one; a file that is no fit.
    for (model, extra, expect) in [
        (s(&fit), vec![], "give --ocv"),
        (
            s(&table),
            vec!["--ocv", s(&table), "--capacity-ah", "2.5"],
            // A CSV is read as a map, which says what it lacks.
            "missing column `temperature_c` (a map of identify battery --map-out)",
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

/// `--report DIR` on two records: one table row, figure and CSV each, the
/// errors inside the OCV table as the one-record runs give them; `--out`
/// with two records is one line.
#[test]
fn the_report_validates_several_records() {
    let table = tmp("report-nmc.csv");
    super::battery::nmc_table(&table);
    let pulse = simulate("report-pulse.csv", "pulse", &table, "0.9", "21");
    let drive = simulate("report-drive.csv", "drive", &table, "0.9", "22");
    let fit = tmp("report-fit.json");
    let ocv = ["--ocv", s(&table), "--capacity-ah", "2.5", "--soc0", "0.9"];
    let mut a = vec![
        "identify",
        "battery",
        "--input",
        s(&pulse),
        "--json",
        s(&fit),
    ];
    a.extend(ocv);
    let o = run(&a);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let dir = tmp("report-dir");
    let _ = std::fs::remove_dir_all(&dir);
    let named = tmp("report-named.json");
    let mut a = vec!["predict", "battery", "--model", s(&fit)];
    a.extend(["--input", s(&pulse), s(&drive), "--report", s(&dir)]);
    a.extend(["--json", s(&named)]);
    a.extend(ocv);
    let o = run(&a);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // --json with several records: each named by its --input.
    let named = read_json(&named);
    let inputs: Vec<&str> = named
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["input"].as_str().unwrap())
        .collect();
    assert_eq!(inputs, [s(&pulse), s(&drive)]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        stdout.matches("inside the OCV table").count(),
        2,
        "{stdout}"
    );
    let page = std::fs::read_to_string(dir.join("report.md")).unwrap();
    let rows: Vec<&str> = page.lines().filter(|l| l.starts_with("| `")).collect();
    assert_eq!(rows.len(), 2, "{page}");
    let j = read_json(&dir.join("report.json"));
    let j = j.as_array().unwrap();
    assert_eq!(j.len(), 2);
    for (k, (e, rec)) in j.iter().zip([&pulse, &drive]).enumerate() {
        let svg = std::fs::read_to_string(dir.join(e["figure"].as_str().unwrap())).unwrap();
        assert!(svg.contains("<svg"), "{k}");
        let csv = std::fs::read_to_string(dir.join(e["csv"].as_str().unwrap())).unwrap();
        assert!(csv.starts_with("time_s,current_a,voltage_v,model_v,observed\n"));
        assert_eq!(csv.lines().count(), 2501);
        // The same numbers as a run on the record alone.
        let (out, json) = (tmp("report-one.csv"), tmp("report-one.json"));
        let mut a = vec!["predict", "battery", "--model", s(&fit), "--input", s(rec)];
        a.extend(["--out", s(&out), "--json", s(&json)]);
        a.extend(ocv);
        assert!(run(&a).status.success());
        let one = read_json(&json);
        assert_eq!(e["rmse_v"], one["rmse_v"], "{k}");
        let t = &e["in_table"];
        assert_eq!(t, &one["in_table"], "{k}");
        // Every sample of a simulated record lies inside the table here.
        assert_eq!(t["samples"], 2500, "{t}");
        assert!(t["rmse_v"].as_f64().unwrap() < 1.5e-3, "{t}");
        let shown = format!("{:.2}", 1e3 * t["rmse_v"].as_f64().unwrap());
        assert!(rows[k].contains(&shown), "{} vs {shown}", rows[k]);
    }
    // --out takes one record.
    let x = tmp("report-x.csv");
    let mut a = vec!["predict", "battery", "--model", s(&fit)];
    a.extend(["--input", s(&pulse), s(&drive), "--out", s(&x)]);
    a.extend(ocv);
    let o = run(&a);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("--report"), "{err}");
    // A bad record after a good one: one line, and no file written.
    let bad = tmp("report-bad.csv");
    std::fs::write(&bad, "time_s,current_a\n0,1\n").unwrap();
    let dir = tmp("report-dir-bad");
    let _ = std::fs::remove_dir_all(&dir);
    let mut a = vec!["predict", "battery", "--model", s(&fit)];
    a.extend(["--input", s(&pulse), s(&bad), "--report", s(&dir)]);
    a.extend(ocv);
    let o = run(&a);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("report-bad.csv"), "{err}");
    assert!(!dir.exists(), "{}", dir.display());
}

/// A map of two temperatures predicts between them by Arrhenius (said in
/// the JSON, the activation energies printed) and holds the nearest beyond
/// them with a warning; a row that is not identifiable is left out and
/// counted.
#[test]
fn a_map_over_temperature_predicts_between_and_holds_beyond() {
    let table = tmp("tmap-nmc.csv");
    super::battery::nmc_table(&table);
    let drive = simulate("tmap-drive.csv", "drive", &table, "0.9", "23");
    let map = tmp("tmap.csv");
    std::fs::write(
        &map,
        "temperature_c,soc,r_i,r_ct,q,alpha,bv_a_v,bv_i0_a,ocv_offset_v,rmse_v,identifiable,identifiable_reason\n\
         10,0.2,0.040,0.030,900,0.7,,,0,0.001,true,\n\
         10,0.9,0.036,0.028,900,0.7,,,0,0.001,true,\n\
         10,0.5,0.900,0.978,900,0.7,,,0,0.001,false,R_ct at its bound\n\
         40,0.2,0.020,0.012,900,0.7,,,0,0.001,true,\n\
         40,0.9,0.018,0.011,900,0.7,,,0,0.001,true,\n",
    )
    .unwrap();
    let out = tmp("tmap.out.csv");
    let json_at = |t: &str| tmp(&format!("tmap-{t}.json"));
    let predict_at = |t: &str| {
        let json = json_at(t);
        let mut a = vec!["predict", "battery", "--model", s(&map)];
        a.extend(["--input", s(&drive), "--ocv", s(&table)]);
        a.extend(["--capacity-ah", "2.5", "--soc0", "0.9"]);
        a.extend(["--temperature-c", t, "--out", s(&out), "--json", s(&json)]);
        run(&a)
    };
    let rmse_at = |t: &str| {
        let o = predict_at(t);
        let json = json_at(t);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        (read_json(&json), o)
    };
    let (j25, o) = rmse_at("25");
    let m = &j25["map"];
    assert_eq!(m["temperature_rule"], "arrhenius", "{m}");
    assert_eq!(m["left_out"].as_array().unwrap().len(), 1, "{m}");
    assert!(m["activation"]["r_i_j_mol"].as_f64().unwrap() > 10e3, "{m}");
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("activation energy"), "{stdout}");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("1 map level(s) not used"), "{stderr}");
    let (j10, _) = rmse_at("10");
    let (j40, _) = rmse_at("40");
    assert_eq!(j10["map"]["temperature_rule"], "at");
    // Between the two temperatures' predictions: not either one.
    let r = |j: &serde_json::Value| j["rmse_v"].as_f64().unwrap();
    assert!(r(&j25) != r(&j10) && r(&j25) != r(&j40));
    let (j60, o) = rmse_at("60");
    assert_eq!(j60["map"]["temperature_rule"], "held");
    assert_eq!(r(&j60), r(&j40));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("outside the map's 10–40 °C"), "{stderr}");
    // Below 0 °C: the negative number is the flag's value (clap read it as
    // an unknown flag), held at the map's coldest.
    let (jm10, _) = rmse_at("-10");
    assert_eq!(jm10["map"]["temperature_rule"], "held");
    assert_eq!(r(&jm10), r(&j10));
    // Below absolute zero or not a number: one line naming the flag.
    for bad in ["-300", "nan", "inf"] {
        assert_one_line_error(&predict_at(bad), &["--temperature-c"], bad);
    }
}
