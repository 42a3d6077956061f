//! `identify battery --input DIR_OR_GLOB`: every file of a directory or a
//! pattern fitted on the pool, one summary row per file, a bad file
//! reported while the others go on, and each file's fit the single-file
//! fit.

use super::*;

/// A directory with the two Chen2020 DFN records and, when `bad`, a file
/// that is not a record.
fn folder(name: &str, bad: bool) -> PathBuf {
    let d = tmp(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    for f in ["chen2020-hppc.csv", "chen2020-drive.csv"] {
        std::fs::copy(data(&format!("pybamm/{f}")), d.join(f)).unwrap();
    }
    if bad {
        std::fs::write(d.join("broken.csv"), "a,b\n1,2\n").unwrap();
    }
    // Not a record's extension: left out of a directory input.
    std::fs::write(d.join("notes.md"), "# notes\n").unwrap();
    d
}

fn cell_args() -> Vec<String> {
    vec![
        "--ocv".into(),
        s(&data("pybamm/chen2020-ocv.csv")).into(),
        "--capacity-ah".into(),
        "5.153198".into(),
    ]
}

/// The summary CSV as rows of (header → cell), without the wall time.
fn summary(p: &Path) -> Vec<std::collections::BTreeMap<String, String>> {
    let mut r = csv::Reader::from_path(p).unwrap();
    let h: Vec<String> = r.headers().unwrap().iter().map(str::to_owned).collect();
    r.records()
        .map(|row| {
            h.iter()
                .zip(row.unwrap().iter())
                .filter(|(k, _)| k.as_str() != "fit_s")
                .map(|(k, v)| (k.clone(), v.to_owned()))
                .collect()
        })
        .collect()
}

fn many(input: &Path, extra: &[&str]) -> Output {
    let mut args: Vec<String> = vec!["identify".into(), "battery".into(), "--input".into()];
    args.push(s(input).into());
    args.extend(cell_args());
    args.extend(extra.iter().map(|x| (*x).to_owned()));
    bin().args(&args).output().unwrap()
}

#[test]
fn a_directory_gives_one_row_per_file_and_a_bad_file_does_not_stop_the_others() {
    let d = folder("many-dir", true);
    let sum = tmp("many-dir-summary.csv");
    let json = tmp("many-dir-json");
    let out = many(
        &d,
        &["--summary-out", s(&sum), "--json", s(&json), "--jobs", "2"],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    // One failed file: exit 1, one line saying so.
    assert_eq!(out.status.code(), Some(1), "{stdout}\n{stderr}");
    assert!(stdout.contains("3 files: 2 fitted, 1 failed"), "{stdout}");
    assert_eq!(
        stderr.lines().filter(|l| l.starts_with("error:")).count(),
        1,
        "{stderr}"
    );
    let rows = summary(&sum);
    let names: Vec<&str> = rows
        .iter()
        .map(|r| r["file"].rsplit('/').next().unwrap())
        .collect();
    assert_eq!(
        names,
        ["broken.csv", "chen2020-drive.csv", "chen2020-hppc.csv"]
    );
    assert_eq!(rows[0]["status"], "error");
    assert_eq!(rows[0]["error_kind"], "data");
    assert!(
        rows[0]["error"].contains("no time column"),
        "{}",
        rows[0]["error"]
    );
    assert_eq!(rows[0]["r_i"], "");
    // Each fitted row is the single-file fit, to the last bit.
    for (row, name) in rows[1..].iter().zip(["chen2020-drive", "chen2020-hppc"]) {
        assert_eq!(row["status"], "ok");
        let single_json = tmp(&format!("many-dir-single-{name}.json"));
        let single = run(&[
            "identify",
            "battery",
            "--input",
            s(&d.join(format!("{name}.csv"))),
            "--ocv",
            s(&data("pybamm/chen2020-ocv.csv")),
            "--capacity-ah",
            "5.153198",
            "--json",
            s(&single_json),
        ]);
        assert!(single.status.success());
        let one = read_json(&single_json);
        assert_eq!(read_json(&json.join(format!("{name}.json"))), one, "{name}");
        for key in [
            "r_i", "r_ct", "q", "alpha", "u_oc", "rmse_v", "soc0", "soc_end",
        ] {
            let x: f64 = row[key].parse().unwrap();
            assert_eq!(x, one[key].as_f64().unwrap(), "{name} {key}");
        }
        assert_eq!(row["model"], one["model"].as_str().unwrap());
        assert_eq!(row["identifiable"], one["identifiable"].to_string());
        let c = &one["confidence"];
        let lo: f64 = row["r_i_lo"].parse().unwrap();
        assert_eq!(lo, c["r_i"][0].as_f64().unwrap());
        let hi: f64 = row["alpha_hi"].parse().unwrap();
        assert_eq!(hi, c["alpha"][1].as_f64().unwrap());
        assert_eq!(row["samples"], one["record"]["samples"].to_string());
        assert_eq!(row["paper_start"], one["paper_start"].as_str().unwrap());
        // The Butler–Volmer term's intervals: the fit's, or empty for a
        // linear fit.
        for (key, col, end) in [
            ("bv_a", "bv_a_lo", 0),
            ("bv_a", "bv_a_hi", 1),
            ("bv_i0", "bv_i0_lo", 0),
            ("bv_i0", "bv_i0_hi", 1),
        ] {
            match c[key][end].as_f64() {
                Some(x) => assert_eq!(row[col].parse::<f64>().unwrap(), x, "{name} {col}"),
                None => assert_eq!(row[col], "", "{name} {col}"),
            }
        }
        assert_eq!(
            row["bv_a_lo"].is_empty(),
            one["model"] == "linear",
            "{name}: {}",
            one["model"]
        );
    }
    assert_eq!(rows[0]["paper_start"], "");
}

#[test]
fn a_pattern_and_one_thread_give_the_same_rows_as_the_pool_with_maps_per_file() {
    let d = folder("many-glob", false);
    let (sum1, sum2) = (tmp("many-glob-1.csv"), tmp("many-glob-2.csv"));
    let (maps1, maps2) = (tmp("many-glob-maps-1"), tmp("many-glob-maps-2"));
    let pattern = format!("{}/chen*.csv", s(&d));
    for (sum, maps, jobs) in [(&sum1, &maps1, "1"), (&sum2, &maps2, "2")] {
        let out = many(
            Path::new(&pattern),
            &[
                "--summary-out",
                s(sum),
                "--map-out",
                s(maps),
                "--soc-bins",
                "3",
                "--jobs",
                jobs,
            ],
        );
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let rows = summary(&sum1);
    assert_eq!(rows.len(), 2);
    assert_eq!(rows, summary(&sum2));
    for r in &rows {
        assert_eq!(r["status"], "ok");
        // Three levels, or the single fit as the map's one row where the
        // three would fit the record worse than it (docs/maps.md).
        let f = |k: &str| r[k].parse::<f64>().unwrap();
        let (map, single) = (f("map_rmse_v"), f("rmse_v"));
        assert!(map <= single * (1.0 + 1e-9), "{r:?}");
        match r["map_levels"].as_str() {
            "3" => {}
            "1" => assert!((map - single).abs() <= 1e-9 * single, "{r:?}"),
            x => panic!("{x} levels: {r:?}"),
        }
    }

    // The map of each file is the single-file run's.
    let one = tmp("many-glob-single-map.csv");
    let single = run(&[
        "identify",
        "battery",
        "--input",
        s(&d.join("chen2020-hppc.csv")),
        "--ocv",
        s(&data("pybamm/chen2020-ocv.csv")),
        "--capacity-ah",
        "5.153198",
        "--map-out",
        s(&one),
        "--soc-bins",
        "3",
    ]);
    assert!(single.status.success());
    let expect = std::fs::read_to_string(&one).unwrap();
    for maps in [&maps1, &maps2] {
        assert_eq!(
            std::fs::read_to_string(maps.join("chen2020-hppc-map.csv")).unwrap(),
            expect
        );
    }
}

#[test]
fn many_file_inputs_refuse_what_they_cannot_do_in_one_line() {
    let d = folder("many-refuse", false);
    // Nothing matches.
    let out = many(&d.join("nothing-*.csv"), &[]);
    assert_eq!(out.status.code(), Some(1));
    let e = String::from_utf8_lossy(&out.stderr);
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.contains("no record files there"), "{e}");
    // A single-record output with many files.
    let out = many(&d, &["--fit-out", s(&tmp("many-refuse-fit.csv"))]);
    assert_eq!(out.status.code(), Some(1));
    let e = String::from_utf8_lossy(&out.stderr);
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.contains("--fit-out is for one record"), "{e}");
    // A map without a table: refused before any file is read.
    let out = run(&[
        "identify",
        "battery",
        "--input",
        s(&d),
        "--map-out",
        s(&tmp("many-refuse-maps")),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let e = String::from_utf8_lossy(&out.stderr);
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(out.stdout.is_empty());
    // Zero jobs.
    let out = many(&d, &["--jobs", "0"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--jobs 0"));
}

#[test]
fn one_file_with_a_summary_keeps_its_outputs_as_files() {
    let d = folder("many-one", false);
    let (sum, json) = (tmp("many-one.csv"), tmp("many-one.json"));
    let out = many(
        &d.join("chen2020-drive.csv"),
        &["--summary-out", s(&sum), "--json", s(&json)],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows = summary(&sum);
    assert_eq!(rows.len(), 1);
    let r_i: f64 = rows[0]["r_i"].parse().unwrap();
    assert_eq!(r_i, read_json(&json)["r_i"].as_f64().unwrap());
}
