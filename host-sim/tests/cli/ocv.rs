//! `ocv`: the table read from a test's rests, as it comes from a cycler.

use super::*;
use estimator_core::battery::profile::ocv_nmc;

/// A 3 A·h NMC cell from full: ten 0.3 A·h discharges at 1C, each followed
/// by a 1 h rest in which the voltage relaxes, logged at 1 s under load
/// and 60 s at rest (Bitrode-style headers, the current in mA).
fn hppc_export(path: &Path) -> Vec<(f64, f64)> {
    let mut t = String::from("Step,Mode,Time(s),Current(mA),Voltage(V),Loop\n");
    let mut time = 0.0;
    let mut z: f64 = 1.0;
    let mut ends = vec![];
    let row = |t: &mut String, time: f64, i: f64, v: f64| {
        t.push_str(&format!("1,CC,{time},{},{v:.5},1\n", i * 1000.0));
    };
    for level in 0..=10 {
        // Rest: 1 h at 60 s, relaxing by 10 mV·e^(−t/600 s).
        for k in 0..=60 {
            let v = ocv_nmc::<f64>(z)
                - 0.010 * (-(k as f64) * 60.0 / 600.0).exp() * (level > 0) as u8 as f64;
            row(&mut t, time, 0.0, v);
            time += 60.0;
        }
        ends.push((z, ocv_nmc::<f64>(z)));
        if level == 10 {
            break;
        }
        // 1C (3 A) for 360 s at 1 s: 0.3 A·h.
        for _ in 0..360 {
            row(&mut t, time, -3.0, ocv_nmc::<f64>(z) - 3.0 * 0.03);
            z -= 3.0 / 3600.0 / 3.0;
            time += 1.0;
        }
    }
    std::fs::write(path, t).unwrap();
    ends
}

#[test]
fn rests_give_a_table_through_the_rest_voltages() {
    let log = tmp("ocv-hppc.csv");
    let ends = hppc_export(&log);
    let out = tmp("ocv-table.csv");
    let json = tmp("ocv-table.json");
    let svg = tmp("ocv-table.svg");
    let o = run(&[
        "ocv",
        "--input",
        s(&log),
        "--out",
        s(&out),
        "--json",
        s(&json),
        "--plot",
        s(&svg),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("11 points from 11 rests") && err.contains("(measured)"),
        "{err}"
    );
    let j = read_json(&json);
    // 3 A·h out of the ten pulses, measured between the highest and the
    // lowest counted charge.
    assert!(
        (j["capacity_ah"].as_f64().unwrap() - 3.0).abs() < 1e-6,
        "{j}"
    );
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("soc,ocv_v"));
    let rows: Vec<(f64, f64)> = lines
        .map(|l| {
            let (a, b) = l.split_once(',').unwrap();
            (a.parse().unwrap(), b.parse().unwrap())
        })
        .collect();
    assert_eq!(rows.len(), 11);
    assert!(rows.windows(2).all(|w| w[1].0 > w[0].0 && w[1].1 > w[0].1));
    // Through the rest voltages within 2 mV (here within 0.1 mV: the
    // rests relax to 0.03 mV of the OCV and the log keeps 10 µV).
    let mut ends = ends;
    ends.sort_by(|a, b| a.0.total_cmp(&b.0));
    for ((z, v), (tz, tv)) in rows.iter().zip(&ends) {
        assert!((z - tz).abs() < 1e-6, "{z} vs {tz}");
        assert!((v - tv).abs() < 1e-4, "{z}: {v} vs {tv}");
    }
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));

    // A capacity given and a start SOC: the SOC column follows them.
    let o = run(&[
        "ocv",
        "--input",
        s(&log),
        "--out",
        s(&out),
        "--capacity-ah",
        "6",
        "--soc0",
        "0.9",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let first = std::fs::read_to_string(&out).unwrap();
    let z0: f64 = first
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!((z0 - 0.4).abs() < 1e-6, "{z0}");

    // No rest as long as asked: one line, exit 1, nothing written.
    let none = tmp("ocv-none.csv");
    let o = run(&[
        "ocv",
        "--input",
        s(&log),
        "--out",
        s(&none),
        "--min-rest",
        "7200",
    ]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(
        err.lines().filter(|l| l.starts_with("error:")).count(),
        1,
        "{err}"
    );
    assert!(err.contains("0 rests of at least 7200 s"), "{err}");
    assert!(!none.exists());
}

/// Every table `ocv` writes from the records in `data/` (rests and low-rate
/// tests, measured and simulated) is one that `identify battery`, `online
/// battery` and `predict battery` accept: they all read it with
/// `fracbms_host::ocv::OcvSpec::from_options`, SOC in [0, 1].
#[test]
fn every_table_ocv_writes_from_data_is_accepted() {
    let pan = "panasonic-18650pf";
    let cases: Vec<(&str, PathBuf, Vec<&str>, f64)> = vec![
        (
            "pan-c20",
            data(&format!("{pan}/05-08-17_13.26 C20 OCV Test_C20_25dC.mat")),
            vec!["--from", "low-rate"],
            2.9,
        ),
        (
            "pan-c20-rests",
            data(&format!("{pan}/05-08-17_13.26 C20 OCV Test_C20_25dC.mat")),
            vec!["--from", "rests", "--soc0", "1.0"],
            2.9,
        ),
        (
            "pan-hppc-25",
            data(&format!(
                "{pan}/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat"
            )),
            vec!["--from", "rests", "--soc0", "1.0"],
            2.9,
        ),
        (
            "pan-hppc-10",
            data(&format!(
                "{pan}/03-27-17_09.06 10degC_5Pulse_HPPC_Pan18650PF.mat"
            )),
            vec!["--from", "rests", "--soc0", "1.0"],
            2.9,
        ),
        (
            "lgm50-c10",
            data("lg-m50/LGM50_5Ah_RateTest.mat"),
            vec![
                "--from",
                "low-rate",
                "--table",
                "LGM50_5Ah_RateTest.T25.cRate_0p1C",
                "--columns",
                "time=timeVec,current=currVec,voltage=volVec,temperature=cellTemp_mid",
            ],
            5.0,
        ),
        (
            "chen2020-hppc",
            data("pybamm/chen2020-hppc.csv"),
            vec!["--from", "rests", "--soc0", "0.9", "--min-rest", "300"],
            5.0,
        ),
        (
            "prada2013-hppc",
            data("pybamm/prada2013-hppc.csv"),
            vec!["--from", "rests", "--soc0", "1.0", "--min-rest", "300"],
            2.3,
        ),
    ];
    for (name, input, extra, cap) in cases {
        let out = tmp(&format!("ocv-data-{name}.csv"));
        let c = cap.to_string();
        let mut args = vec![
            "ocv",
            "--input",
            s(&input),
            "--out",
            s(&out),
            "--capacity-ah",
            &c,
        ];
        args.extend_from_slice(&extra);
        let o = run(&args);
        assert!(
            o.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let spec = fracbms_host::ocv::OcvSpec::from_options(&fracbms_host::ocv::OcvOptions {
            ocv: Some(out.clone()),
            capacity_ah: Some(cap),
            soc0: None,
        });
        assert!(
            matches!(spec, Ok(Some(_))),
            "{name}: the table ocv wrote is refused: {:?}",
            spec.err()
        );
    }
}
