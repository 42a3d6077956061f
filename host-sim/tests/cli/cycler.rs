//! Cycler exports as they come: recognised headers and units, the sign,
//! `--columns`, and non-uniform logs put on a uniform period.

use super::*;

/// The rows of a `simulate battery` record: (t, I, V).
fn simulated(name: &str) -> (PathBuf, Vec<(f64, f64, f64)>) {
    let csv = tmp(name);
    let o = run(&[
        "simulate",
        "battery",
        "--preset",
        "cell",
        "--profile",
        "pulse",
        "--sigma",
        "0.001",
        "--length",
        "1500",
        "--seed",
        "5",
        "--out",
        s(&csv),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rows = std::fs::read_to_string(&csv)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (f[0], f[1], f[2])
        })
        .collect();
    (csv, rows)
}

fn fit(input: &Path, extra: &[&str], json: &str) -> (Output, serde_json::Value) {
    let json = tmp(json);
    let mut args = vec![
        "identify",
        "battery",
        "--input",
        s(input),
        "--json",
        s(&json),
    ];
    args.extend_from_slice(extra);
    let o = run(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    (o, read_json(&json))
}

fn same_fit(a: &serde_json::Value, b: &serde_json::Value) {
    for k in ["r_i", "r_ct", "q", "alpha", "u_oc"] {
        let (x, y) = (a[k].as_f64().unwrap(), b[k].as_f64().unwrap());
        assert!((x / y - 1.0).abs() < 1e-6, "{k}: {x} vs {y}");
    }
}

/// An Arbin-style export (extra columns, a doubled header, the current in
/// mA and discharge-positive, rows at uneven steps with duplicates) gives
/// the same fit as the plain record it was made from, read as it comes.
#[test]
fn an_uneven_vendor_export_fits_as_its_plain_record() {
    let (plain, rows) = simulated("cycler-plain.csv");
    let (_, reference) = fit(&plain, &[], "cycler-plain.json");

    let mut t = String::from(
        "Data_Point,Test_Time(s),Step_Time(s),Step_Index,Current(mA),Voltage(V),Loop,Loop\n",
    );
    let mut point = 0;
    let mut row = |t: &mut String, time: f64, i: f64, v: f64| {
        point += 1;
        t.push_str(&format!(
            "{point},{time},{time},1,{},{v},1,1\n",
            -1000.0 * i
        ));
    };
    for (k, &(time, i, v)) in rows.iter().enumerate() {
        row(&mut t, time, i, v);
        if k % 4 == 1 && k + 1 < rows.len() {
            // A half-step row inside the held current, the voltage on the
            // line between the samples; and now and then a duplicate.
            row(&mut t, time + 0.5, i, 0.5 * (v + rows[k + 1].2));
            if k % 20 == 1 {
                row(&mut t, time + 0.5, i, 0.5 * (v + rows[k + 1].2));
            }
        }
    }
    let arbin = tmp("cycler-arbin.csv");
    std::fs::write(&arbin, t).unwrap();

    let (o, j) = fit(
        &arbin,
        &["--current-sign", "discharge-positive"],
        "cycler-arbin.json",
    );
    same_fit(&j, &reference);
    let r = &j["record"];
    assert_eq!(r["columns"]["time"], "Test_Time(s)");
    assert_eq!(r["columns"]["current"], "Current(mA)");
    assert_eq!(r["units"]["current"], "mA");
    assert_eq!(r["current_sign"], "discharge-positive");
    assert_eq!(r["period_s"], 1.0);
    assert_eq!(r["period_source"], "chosen");
    assert_eq!(r["samples"].as_u64().unwrap() as usize, rows.len());
    assert!(r["rows_merged"].as_u64().unwrap() > 300, "{r}");
    assert!(r["duplicate_times"].as_u64().unwrap() > 10, "{r}");
    assert!(r["sign_warning"].is_null(), "{r}");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("time `Test_Time(s)` (s), current `Current(mA)` (mA) discharge-positive, voltage `Voltage(V)` (V)"), "{err}");
    assert!(
        err.contains("resampled at 1 s (chosen from the data"),
        "{err}"
    );

    // Read with the wrong sign, the export says so in one line.
    let (o, j) = fit(&arbin, &[], "cycler-arbin-wrong.json");
    assert!(j["record"]["sign_warning"].is_string(), "{}", j["record"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(
        err.lines()
            .filter(|l| l.contains("--current-sign discharge-positive"))
            .count(),
        1,
        "{err}"
    );
}

/// Columns no reader knows are named with `--columns`; without it the
/// error lists the header found and says how to name them.
#[test]
fn columns_are_named_when_not_recognised() {
    let (plain, rows) = simulated("cycler-plain2.csv");
    let (_, reference) = fit(&plain, &[], "cycler-plain2.json");
    let mut t = String::from("Messung von Zelle 7\nzeit;strom;spannung;temp_zelle\n");
    for &(time, i, v) in &rows {
        t.push_str(&format!("{time};{i};{v};25.5\n"));
    }
    let odd = tmp("cycler-odd.csv");
    std::fs::write(&odd, t).unwrap();

    let o = run(&["identify", "battery", "--input", s(&odd)]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.contains("--columns time=COL")
            && err.contains("`zeit`, `strom`, `spannung`, `temp_zelle`"),
        "{err}"
    );

    let (_, j) = fit(
        &odd,
        &["--columns", "time=zeit,current=strom,voltage=spannung"],
        "cycler-odd.json",
    );
    same_fit(&j, &reference);
    assert_eq!(j["record"]["header_row"], 2);
    assert_eq!(j["record"]["columns"]["temperature"], "temp_zelle");
    assert_eq!(j["record"]["period_source"], "uniform");

    // A column the file lacks is bad data (exit 1); a flag that names no
    // role is a usage error (exit 2).
    for (flag, expect, code) in [
        ("time=zeit,current=amps,voltage=spannung", "`amps`", 1),
        ("time=zeit,speed=strom", "speed", 2),
    ] {
        let o = run(&["identify", "battery", "--input", s(&odd), "--columns", flag]);
        assert_eq!(o.status.code(), Some(code), "{flag}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains(expect), "{flag}: {err}");
    }
}

/// `--period` resamples a uniform log: the mean current over each period
/// keeps the charge counted.
#[test]
fn a_given_period_keeps_the_charge() {
    let (plain, rows) = simulated("cycler-plain3.csv");
    let (_, j) = fit(&plain, &["--period", "2"], "cycler-period.json");
    let r = &j["record"];
    assert_eq!(r["period_s"], 2.0);
    assert_eq!(r["period_source"], "given");
    assert_eq!(
        r["samples"].as_u64().unwrap() as usize,
        (rows.len() - 1) / 2 + 1
    );
    assert!(j["rmse_v"].as_f64().unwrap() < 0.02, "{j}");
}

/// No row cap: a record longer than the old 8 192 rows is fitted whole
/// (a uniform log longer than 50 000 samples is put on a longer period:
/// `fracbms-host/src/cycler/tests.rs`).
#[test]
fn a_long_record_is_fitted_whole() {
    let csv = tmp("cycler-long.csv");
    let o = run(&[
        "simulate",
        "battery",
        "--preset",
        "cell",
        "--profile",
        "hppc",
        "--length",
        "10000",
        "--seed",
        "4",
        "--out",
        s(&csv),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (o, j) = fit(&csv, &[], "cycler-long.json");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("only the first"), "{err}");
    assert_eq!(j["record"]["samples"], 10000);
    assert_eq!(j["record"]["period_source"], "uniform");
    assert!(
        (j["r_i"].as_f64().unwrap() / 0.020 - 1.0).abs() < 0.02,
        "{j}"
    );
    assert!(j["rmse_v"].as_f64().unwrap() < 1.1e-3, "{j}");
}
