//! `online battery --input DIR|PATTERN`: a cell's life, its logs run
//! through one estimator in the order they were taken.

use super::*;

/// Four of B0005's discharges (docs: data/nasa-pcoe-b0005) in a directory
/// of their own, with their start times; `extra` adds files.
fn logs(name: &str, extra: &[(&str, &str, &str)]) -> (PathBuf, PathBuf) {
    let dir = tmp(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut times = String::from("file,start_time\n");
    // Listed out of order: the table's times give the order.
    for (f, t) in [
        ("05126.csv", "2008-04-03T00:01:06.687"),
        ("05122.csv", "2008-04-02T15:25:41.593"),
        ("05128.csv", "2008-04-03T04:16:37.375"),
        ("05124.csv", "2008-04-02T19:43:48.406"),
    ] {
        std::fs::copy(data(&format!("nasa-pcoe-b0005/discharge/{f}")), dir.join(f)).unwrap();
        times.push_str(&format!("{f},{t}\n"));
    }
    for (f, t, text) in extra {
        std::fs::write(dir.join(f), text).unwrap();
        times.push_str(&format!("{f},{t}\n"));
    }
    let table = tmp(&format!("{name}-start_times.csv"));
    std::fs::write(&table, times).unwrap();
    (dir, table)
}

fn life_rows(p: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(p).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "file,start_time,samples,discharged_ah,charged_ah,r_i,r_i_status,r_ct,alpha,capacity_ah,capacity_status,soh_c,soh_r,error,capacity_source"
    );
    lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

#[test]
fn a_life_in_one_command_is_its_logs_run_one_by_one_with_the_state_carried() {
    let (dir, table) = logs("life-same", &[]);
    let out = tmp("life-same-tracks");
    let rows = tmp("life-same.csv");
    let last = tmp("life-same-last.bin");
    let svg = tmp("life-same.svg");
    let o = run(&[
        "online",
        "battery",
        "--input",
        s(&dir),
        "--start-times",
        s(&table),
        "--window",
        "64",
        "--out",
        s(&out),
        "--life-out",
        s(&rows),
        "--state-out",
        s(&last),
        "--life-plot",
        s(&svg),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let figure = std::fs::read_to_string(&svg).unwrap();
    assert!(figure.contains("<svg") && figure.contains("capacity over life"));
    assert!(
        err.contains("4 logs in the order of their start times"),
        "{err}"
    );
    let r = life_rows(&rows);
    let names: Vec<&str> = r.iter().map(|x| x[0].rsplit('/').next().unwrap()).collect();
    assert_eq!(names, ["05122.csv", "05124.csv", "05126.csv", "05128.csv"]);
    // Each discharge's count: NASA's measured capacity within 1 %
    // (metadata.csv: 1.856, 1.846, 1.835, 1.835 A·h).
    for (x, c) in r.iter().zip([1.856_487, 1.846_327, 1.835_349, 1.835_263]) {
        let ah: f64 = x[3].parse().unwrap();
        assert!((ah / c - 1.0).abs() < 0.01, "{x:?}");
        // No voltage limits, no table: no capacity.
        assert_eq!((x[9].as_str(), x[14].as_str()), ("", ""), "{x:?}");
    }
    // The same logs one by one, each from the snapshot the one before
    // saved, at its start time: the same tracks, bit for bit.
    let mut snap: Option<PathBuf> = None;
    for (k, (f, t)) in [
        ("05122", "2008-04-02T15:25:41.593"),
        ("05124", "2008-04-02T19:43:48.406"),
        ("05126", "2008-04-03T00:01:06.687"),
        ("05128", "2008-04-03T04:16:37.375"),
    ]
    .iter()
    .enumerate()
    {
        let track = tmp(&format!("life-one-{f}.csv"));
        let next = tmp(&format!("life-one-{k}.bin"));
        let input = dir.join(format!("{f}.csv"));
        let mut args = vec![
            "online",
            "battery",
            "--input",
            s(&input),
            "--start-time",
            t,
            "--window",
            "64",
            "--out",
            s(&track),
            "--state-out",
            s(&next),
        ];
        if let Some(p) = &snap {
            args.extend(["--state-in", s(p)]);
        }
        let o = run(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let one = std::fs::read(&track).unwrap();
        let whole = std::fs::read(out.join(format!("{f}-track.csv"))).unwrap();
        assert!(
            one == whole,
            "{f}: the life's track differs from the one run alone"
        );
        if k > 0 {
            // Carried: the snapshot was restored, not refused as stale.
            let text = String::from_utf8(one).unwrap();
            assert!(text.lines().next().unwrap().ends_with(",restoration"));
            assert!(!text.contains(",clean\n"), "{f}: snapshot rejected");
        }
        snap = Some(next);
    }
    assert_eq!(
        std::fs::read(snap.unwrap()).unwrap(),
        std::fs::read(&last).unwrap()
    );
}

#[test]
fn a_log_that_cannot_be_run_is_one_warning_and_a_row_and_the_life_goes_on() {
    let bad = "Voltage_measured,Temperature_measured,Time\n4.19,24.3,0\n4.18,24.3,10\n";
    let (dir, table) = logs("life-bad", &[("05125.csv", "2008-04-02T22:00:00", bad)]);
    let out = tmp("life-bad-tracks");
    let rows = tmp("life-bad.csv");
    let o = run(&[
        "online",
        "battery",
        "--input",
        s(&dir),
        "--start-times",
        s(&table),
        "--window",
        "64",
        "--out",
        s(&out),
        "--life-out",
        s(&rows),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let warnings: Vec<&str> = err.lines().filter(|l| l.starts_with("warning:")).collect();
    assert_eq!(warnings.len(), 1, "{err}");
    assert!(
        warnings[0].contains("05125.csv") && warnings[0].contains("no current column"),
        "{err}"
    );
    // The file named once: the warning's own name, not the error's again.
    assert_eq!(warnings[0].matches("05125.csv").count(), 1, "{err}");
    let r = life_rows(&rows);
    assert_eq!(r.len(), 5);
    let b = &r[2];
    assert!(b[0].ends_with("05125.csv"), "{b:?}");
    assert_eq!((b[6].as_str(), b[10].as_str()), ("error", "error"));
    assert!(b[13].contains("no current column"), "{b:?}");
    assert!(!b[13].contains("05125.csv"), "{b:?}");
    // The next log starts from the state of the one before the bad one.
    let next = std::fs::read_to_string(out.join("05126-track.csv")).unwrap();
    assert!(
        next.lines().nth(1).unwrap().ends_with(",restored"),
        "{next:.300}"
    );
}

#[test]
fn without_start_times_the_logs_run_in_name_order_and_stderr_says_so() {
    let (dir, _) = logs("life-names", &[]);
    let out = tmp("life-names-tracks");
    let rows = tmp("life-names.csv");
    let pattern = format!("{}/0512*.csv", s(&dir));
    let o = run(&[
        "online",
        "battery",
        "--input",
        &pattern,
        "--window",
        "64",
        "--out",
        s(&out),
        "--life-out",
        s(&rows),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("4 logs in file name order (no --start-times)"),
        "{err}"
    );
    let r = life_rows(&rows);
    assert!(r.iter().all(|x| x[1].is_empty()));
    assert!(r[0][0].ends_with("05122.csv") && r[3][0].ends_with("05128.csv"));
}

#[test]
fn life_flags_on_one_file_and_bad_start_times_are_one_line() {
    let one = data("nasa-pcoe-b0005/discharge/05122.csv");
    let out = tmp("life-flags.csv");
    let o = run(&[
        "online",
        "battery",
        "--input",
        s(&one),
        "--out",
        s(&out),
        "--life-out",
        s(&out),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("--life-out"), "{err}");
    let o = run(&[
        "online",
        "battery",
        "--input",
        s(&one),
        "--out",
        s(&out),
        "--start-time",
        "yesterday",
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("--start-time yesterday"), "{err}");
    let (dir, _) = logs("life-flags-dir", &[]);
    let table = tmp("life-flags-times.csv");
    std::fs::write(&table, "file,start_time\n05122.csv,2008-04-02T15:25:41\n").unwrap();
    let o = run(&[
        "online",
        "battery",
        "--input",
        s(&dir),
        "--out",
        s(&tmp("life-flags-tracks")),
        "--start-times",
        s(&table),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no start time for"), "{err}");
    // A life's outputs in a folder that is not there: one line before
    // any log is run; an input that is not there: said so.
    let tracks = tmp("life-flags-nodir-tracks");
    let o = run(&[
        "online",
        "battery",
        "--input",
        s(&dir),
        "--out",
        s(&tracks),
        "--life-out",
        s(&tmp("life-flags-no-such-dir").join("life.csv")),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("--life-out") && err.contains("no such directory"),
        "{err}"
    );
    assert!(!tracks.exists(), "no log was run");
    // Inside --out, which the run makes, it is written.
    let o = run(&[
        "online",
        "battery",
        "--input",
        s(&dir),
        "--out",
        s(&tracks),
        "--window",
        "64",
        "--life-out",
        s(&tracks.join("life.csv")),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(life_rows(&tracks.join("life.csv")).len(), 4);
    let o = run(&[
        "online",
        "battery",
        "--input",
        s(&tmp("life-flags-no-such-input")),
        "--out",
        s(&out),
        "--life-out",
        s(&out),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.to_lowercase().contains("no such file or directory"),
        "{err}"
    );
}

/// A discharge from rest at the upper limit to the lower one is a capacity
/// check: its counted discharge is the capacity, and `soh_c` follows it.
#[test]
fn discharges_between_the_voltage_limits_are_capacity_checks() {
    let (dir, table) = logs("life-capacity", &[]);
    let rows = tmp("life-capacity.csv");
    let tracks = tmp("life-capacity-tracks");
    let run_with = |limits: &[&str]| {
        let mut args = vec![
            "online",
            "battery",
            "--input",
            s(&dir),
            "--start-times",
            s(&table),
            "--out",
            s(&tracks),
            "--life-out",
            s(&rows),
        ];
        args.extend(limits);
        let o = run(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        life_rows(&rows)
    };
    // B0005: charged to 4.2 V, discharged to 2.7 V.
    let r = run_with(&["--voltage-min", "2.7", "--voltage-max", "4.2"]);
    let first: f64 = r[0][3].parse().unwrap();
    for x in &r {
        assert_eq!(
            (x[10].as_str(), x[14].as_str()),
            ("identified", "full_discharge"),
            "{x:?}"
        );
        assert_eq!(x[9], x[3], "{x:?}");
        let soh: f64 = x[11].parse().unwrap();
        let ah: f64 = x[3].parse().unwrap();
        assert!((soh - ah / first).abs() < 1e-9, "{x:?}");
    }
    // A lower limit the load never comes near: not a check.
    let r = run_with(&["--voltage-min", "2.0", "--voltage-max", "4.2"]);
    assert!(
        r.iter().all(|x| x[14].is_empty() && x[9].is_empty()),
        "{r:?}"
    );
}

/// B0005's first discharge with a `Date_Time` column (its first row's
/// `first`, the rows after a second later each, as a cycler writes them).
fn dated_log(first: &str) -> String {
    let text = std::fs::read_to_string(data("nasa-pcoe-b0005/discharge/05122.csv")).unwrap();
    let mut lines = text.lines();
    let mut out = format!("{},Date_Time\n", lines.next().unwrap());
    for (k, l) in lines.enumerate() {
        let cell = if k == 0 {
            first.to_string()
        } else {
            format!("later {k}")
        };
        out.push_str(&format!("{l},{cell}\n"));
    }
    out
}

#[test]
fn without_start_times_the_logs_own_date_and_time_give_the_order() {
    let dir = tmp("life-dated");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // Name order a, b, c; time order b, c, a (the US form, then ISO).
    for (f, t) in [
        ("a.csv", "4/3/2008 12:01:06 AM"),
        ("b.csv", "4/2/2008 3:25:41 PM"),
        ("c.csv", "2008-04-02 19:43:48"),
    ] {
        std::fs::write(dir.join(f), dated_log(t)).unwrap();
    }
    let life = |name: &str| {
        let rows = tmp(&format!("{name}.csv"));
        let o = run(&[
            "online",
            "battery",
            "--input",
            s(&dir),
            "--window",
            "64",
            "--out",
            s(&tmp(&format!("{name}-tracks"))),
            "--life-out",
            s(&rows),
        ]);
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{err}");
        (life_rows(&rows), err)
    };
    let (r, err) = life("life-dated");
    assert!(
        err.contains("3 logs in the order of their first rows' date and time (`Date_Time`; no --start-times)"),
        "{err}"
    );
    let got: Vec<(&str, &str)> = r
        .iter()
        .map(|x| (x[0].rsplit('/').next().unwrap(), x[1].as_str()))
        .collect();
    assert_eq!(
        got,
        [
            ("b.csv", "2008-04-02T15:25:41"),
            ("c.csv", "2008-04-02T19:43:48"),
            ("a.csv", "2008-04-03T00:01:06"),
        ]
    );
    // One log without a date: name order, and that log named.
    std::fs::copy(
        data("nasa-pcoe-b0005/discharge/05124.csv"),
        dir.join("d.csv"),
    )
    .unwrap();
    let (r, err) = life("life-dated-one-without");
    assert!(
        err.contains("4 logs in file name order (no --start-times; ")
            && err.contains("d.csv has no date and time in its first row"),
        "{err}"
    );
    let names: Vec<&str> = r.iter().map(|x| x[0].rsplit('/').next().unwrap()).collect();
    assert_eq!(names, ["a.csv", "b.csv", "c.csv", "d.csv"]);
    assert!(r.iter().all(|x| x[1].is_empty()));
}
