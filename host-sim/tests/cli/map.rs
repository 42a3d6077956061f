//! The chain on a cycler export: `ocv` from its rests, `identify battery
//! --map-out`, `predict battery --model MAP.csv`.

use super::*;
use estimator_core::battery::profile::ocv_nmc;
use estimator_core::battery::simulate::simulate;
use estimator_core::battery::CellParameters;
use estimator_core::frac::GlWeights;

/// A 2.5 A·h NMC cell through an HPPC-like test, exported Bitrode-style
/// (1 s under current, 10 s at rest; current in mA): 20 min of rest, then per level
/// ±5 A pulses and a 0.25 A·h discharge, then a 20 min rest; R_i and α change with the
/// level. Noise ±0.5 mV.
fn export(path: &Path) {
    let mut t = String::from("Step,Time(s),Current(mA),Voltage(V),Temperature(C)\n");
    let mut z: f64 = 0.95;
    let mut time = 0.0;
    let mut seed = 7u64;
    let mut noise = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 1e-3
    };
    let mut rows = vec![];
    // A rested start at full: the OCV table begins there.
    rows.extend(std::iter::repeat_n((0.0, ocv_nmc::<f64>(z)), 1200));
    for level in 0..5 {
        let x = level as f64;
        let cell = CellParameters {
            r_i: 0.020 + 0.006 * x,
            r_ct: 0.012 + 0.002 * x,
            q: 600.0,
            alpha: 0.70 + 0.03 * x,
            u_oc: 0.0,
            bv_a: 0.0,
            bv_i0: 1.0,
        };
        let mut i = vec![0.0; 60];
        for _ in 0..3 {
            i.extend([-5.0; 10]);
            i.extend([0.0; 40]);
            i.extend([5.0; 10]);
            i.extend([0.0; 40]);
        }
        i.extend([-2.5; 360]);
        i.extend([0.0; 1200]);
        let mut w = Box::new(GlWeights::<f64, 2048>::new(cell.alpha, 1.0, 2048).unwrap());
        let (mut up, mut v) = (vec![0.0; i.len()], vec![0.0; i.len()]);
        simulate(&cell, &mut w, &i, |_| 0.0, &mut up, &mut v).unwrap();
        for (k, &ik) in i.iter().enumerate() {
            z += ik / 3600.0 / 2.5;
            rows.push((ik, ocv_nmc::<f64>(z) + v[k]));
        }
    }
    // Logged every second under current (and the second after), every 10 s
    // at rest.
    for (k, &(i, v)) in rows.iter().enumerate() {
        let busy = i != 0.0
            || (k > 0 && rows[k - 1].0 != 0.0)
            || rows.get(k + 1).is_some_and(|r| r.0 != 0.0);
        if busy || k % 10 == 0 || k + 1 == rows.len() {
            t.push_str(&format!(
                "1,{time},{},{:.5},25.0\n",
                i * 1000.0,
                v + noise()
            ));
        }
        time += 1.0;
    }
    std::fs::write(path, t).unwrap();
}

#[test]
fn an_hppc_export_gives_a_map_that_beats_one_fit() {
    let log = tmp("map-hppc.csv");
    export(&log);
    let ocv = tmp("map-ocv.csv");
    let o = run(&[
        "ocv",
        "--input",
        s(&log),
        "--capacity-ah",
        "2.5",
        "--soc0",
        "0.95",
        "--out",
        s(&ocv),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let (map, json, fit_out, svg) = (
        tmp("map.csv"),
        tmp("map.json"),
        tmp("map-fit.csv"),
        tmp("map.svg"),
    );
    // Each level's record for an independent fit, written by the same run.
    let ldir = tmp("map-levels");
    let _ = std::fs::remove_dir_all(&ldir);
    let o = run(&[
        "identify",
        "battery",
        "--input",
        s(&log),
        "--ocv",
        s(&ocv),
        "--capacity-ah",
        "2.5",
        "--soc0",
        "0.95",
        "--model",
        "linear",
        // Each level on its own: the levels' steps in R_i are recovered
        // level by level (the joint map blends them between knots).
        "--map-method",
        "levels",
        "--map-out",
        s(&map),
        "--map-plot",
        s(&svg),
        "--fit-out",
        s(&fit_out),
        "--json",
        s(&json),
        "--levels-out",
        s(&ldir),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(stdout.contains("map: 5 levels"), "{stdout}");
    let text = std::fs::read_to_string(&map).unwrap();
    assert!(text.starts_with(
        "temperature_c,soc,r_i,r_ct,q,alpha,bv_a_v,bv_i0_a,ocv_offset_v,rmse_v,identifiable"
    ));
    let j = read_json(&json);
    let m = &j["map"];
    let levels = m["levels"].as_array().unwrap();
    assert_eq!(levels.len(), 5);
    // Sorted by SOC: the emptiest level (level 4) first.
    for (k, l) in levels.iter().rev().enumerate() {
        let r_i = 0.020 + 0.006 * k as f64;
        let got = l["r_i"].as_f64().unwrap();
        assert!(
            (got / r_i - 1.0).abs() < 0.05,
            "level {k}: r_i {got} vs {r_i}"
        );
        assert_eq!(l["temperature_c"], 25.0);
        assert!(l["rmse_v"].as_f64().unwrap() < 1e-3, "{l}");
    }
    let (map_rmse, single) = (
        m["map_rmse_v"].as_f64().unwrap(),
        m["single_rmse_v"].as_f64().unwrap(),
    );
    assert!(map_rmse < 0.7 * single, "map {map_rmse} vs single {single}");
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));

    // The map run on the record it was made from, by predict, gives the
    // map's own whole-record RMSE.
    let (pred, pj) = (tmp("map-pred.csv"), tmp("map-pred.json"));
    let o = run(&[
        "predict",
        "battery",
        "--model",
        s(&map),
        "--input",
        s(&log),
        "--ocv",
        s(&ocv),
        "--capacity-ah",
        "2.5",
        "--soc0",
        "0.95",
        "--out",
        s(&pred),
        "--json",
        s(&pj),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let p = read_json(&pj)["rmse_v"].as_f64().unwrap();
    assert!((p / map_rmse - 1.0).abs() < 1e-9, "{p} vs {map_rmse}");

    // Each level's record, as its row was fitted.
    let lj = read_json(&ldir.join("levels.json"));
    let parts = lj["levels"].as_array().unwrap();
    assert_eq!(parts.len(), 5);
    assert_eq!(lj["capacity_ah"], 2.5);
    for (p, l) in parts.iter().zip(levels.iter().rev()) {
        let csv = std::fs::read_to_string(ldir.join(p["file"].as_str().unwrap())).unwrap();
        assert!(csv.starts_with("time_s,current_a,voltage_v,observed\n"));
        assert_eq!(
            csv.lines().count() - 1,
            p["samples"].as_u64().unwrap() as usize
        );
        // The level's record is the one its map row was fitted on.
        assert_eq!(p["start_s"], l["start_s"]);
        assert_eq!(p["samples"], l["samples"]);
        assert_eq!(p["fitted"], true);
    }
    let table = std::fs::read_to_string(ldir.join("ocv.csv")).unwrap();
    assert_eq!(
        table,
        std::fs::read_to_string(&ocv).unwrap().replace("\r", "")
    );

    // The map as the online prior: it follows the counted SOC.
    online_with_the_map(&log, &ocv, &map, &json);

    // A map without an OCV table: one line.
    let o = run(&[
        "identify",
        "battery",
        "--input",
        s(&log),
        "--map-out",
        s(&map),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("needs --ocv") && err.trim_end().lines().count() == 1,
        "{err}"
    );
}

/// `online battery --prior MAP.csv` on the export: the prior is the map's
/// cell at the counted SOC, so under a tight prior the published R_i is
/// the map's at the SOC, where the single fit's prior stays put; a map none
/// of whose levels is identifiable is refused in one line.
fn online_with_the_map(log: &Path, ocv: &Path, map: &Path, fit: &Path) {
    let track = tmp("map-online.csv");
    let args = |prior: &Path, out: &Path| {
        run(&[
            "online",
            "battery",
            "--input",
            s(log),
            "--ocv",
            s(ocv),
            "--capacity-ah",
            "2.5",
            "--soc0",
            "0.95",
            "--prior",
            s(prior),
            // A tight prior: the published cell is the prior's centre
            // nearly, so the track shows where the prior sits.
            "--prior-factor",
            "1.02",
            "--prior-alpha-sigma",
            "0.005",
            "--out",
            s(out),
        ])
    };
    // |R_i/map R_i(SOC) − 1| over the published samples of a track.
    let m = fracbms_host::map::ParameterMap::read_csv(map).unwrap();
    let deviations = |text: &str| {
        let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
        let col = |name: &str| head.iter().position(|c| *c == name).unwrap();
        let (ri, soc, status) = (col("r_i"), col("soc"), col("status"));
        let mut errs = vec![];
        for line in text.lines().skip(1) {
            let f: Vec<&str> = line.split(',').collect();
            if f[status] != "tracking" {
                continue;
            }
            let (Ok(r), Ok(z)) = (f[ri].parse::<f64>(), f[soc].parse::<f64>()) else {
                continue;
            };
            errs.push((r / m.cell_at(z, None).unwrap().r_i - 1.0).abs());
        }
        errs.sort_by(f64::total_cmp);
        errs
    };
    let o = args(map, &track);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("prior from the map: 5 levels"), "{err}");
    let with_map = deviations(&std::fs::read_to_string(&track).unwrap());
    // The same with the single whole-record fit as the prior.
    let single_track = tmp("map-online-single.csv");
    let o = args(fit, &single_track);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let with_fit = deviations(&std::fs::read_to_string(&single_track).unwrap());
    let q = |e: &[f64], p: usize| e[e.len() * p / 100];
    eprintln!(
        "published {} / {}: |R_i/map − 1| median {:.3} / {:.3}, 90th {:.3} / {:.3} (map prior / single-fit prior)",
        with_map.len(),
        with_fit.len(),
        q(&with_map, 50),
        q(&with_fit, 50),
        q(&with_map, 90),
        q(&with_fit, 90)
    );
    assert!(with_map.len() > 1000, "{} published", with_map.len());
    // With the map, R_i sits on the map's value at the counted SOC (90 %
    // within 1 %); one fit's prior cannot follow it (the cell's R_i moves
    // by 2.2× over the test).
    assert!(q(&with_map, 90) < 0.01, "90th {}", q(&with_map, 90));
    assert!(q(&with_fit, 50) > 0.1, "median {}", q(&with_fit, 50));

    // Not one level identifiable: refused, in one line.
    let bad = tmp("map-none-identifiable.csv");
    let t = std::fs::read_to_string(map).unwrap();
    let mut lines = t.lines();
    let header = lines.next().unwrap();
    let k = header.split(',').position(|c| c == "identifiable").unwrap();
    let mut out = format!("{header}\n");
    for l in lines {
        let mut f: Vec<&str> = l.split(',').collect();
        f[k] = "false";
        out.push_str(&f.join(","));
        out.push('\n');
    }
    std::fs::write(&bad, out).unwrap();
    let o = args(&bad, &tmp("map-online-bad.csv"));
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("no level of the map can be a prior") && err.trim_end().lines().count() == 1,
        "{err}"
    );
}

/// `--map-method joint` with its penalty and varying set given: one row
/// per level, fitted together (R_i varying, the slow part shared), closer
/// in-sample than the single fit, the candidate in the JSON; bad joint
/// flags are one line each.
#[test]
fn a_joint_map_with_given_flags() {
    let log = tmp("jmap-hppc.csv");
    export(&log);
    let ocv = tmp("jmap-ocv.csv");
    let o = run(&[
        "ocv",
        "--input",
        s(&log),
        "--capacity-ah",
        "2.5",
        "--soc0",
        "0.95",
        "--out",
        s(&ocv),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (map, json) = (tmp("jmap.csv"), tmp("jmap.json"));
    let base = [
        "identify",
        "battery",
        "--input",
        s(&log),
        "--ocv",
        s(&ocv),
        "--capacity-ah",
        "2.5",
        "--soc0",
        "0.95",
        "--model",
        "linear",
        "--map-out",
        s(&map),
        "--json",
        s(&json),
        "--map-method",
        "joint",
    ];
    let levels = tmp("jmap-levels");
    let mut a = base.to_vec();
    a.extend(["--map-smoothing", "1e-5", "--map-vary", "r_i,du"]);
    a.extend(["--levels-out", s(&levels)]);
    let o = run(&a);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("joint map: smoothing 1e-5 V², varying r_i,du"),
        "{stdout}"
    );
    let j = read_json(&json);
    let m = &j["map"];
    let cands = m["joint"].as_array().unwrap();
    assert_eq!(cands.len(), 1);
    assert_eq!(cands[0]["vary"], serde_json::json!(["r_i", "du"]));
    let rows = m["levels"].as_array().unwrap();
    assert_eq!(rows.len(), 5, "{m}");
    // The slow part is shared: one τ = R_ct·Q and one α at every knot.
    let tau = |r: &serde_json::Value| r["r_ct"].as_f64().unwrap() * r["q"].as_f64().unwrap();
    for r in rows {
        assert!((tau(r) / tau(&rows[0]) - 1.0).abs() < 1e-9, "{r}");
        assert_eq!(r["alpha"], rows[0]["alpha"]);
    }
    // R_i rises as the cell empties (0.020 at SOC 0.95 … 0.044 at 0.55).
    let r_i: Vec<f64> = rows.iter().map(|r| r["r_i"].as_f64().unwrap()).collect();
    assert!(r_i.windows(2).all(|w| w[1] < w[0]), "{r_i:?}");
    let (mr, sr) = (
        m["map_rmse_v"].as_f64().unwrap(),
        m["single_rmse_v"].as_f64().unwrap(),
    );
    assert!(mr < sr, "map {mr} single {sr}");
    // The joint fit's inputs for an independent fit: the knots' unknowns,
    // the shared ones alike at every knot, and the record.
    let inputs = read_json(&levels.join("joint.json"));
    assert_eq!(
        inputs["vary"],
        serde_json::json!([true, false, false, false, true])
    );
    assert_eq!(inputs["smoothing"].as_f64(), Some(1e-5));
    let fitted = inputs["fitted"].as_array().unwrap();
    assert_eq!(fitted.len(), 5);
    for (k, r) in fitted.iter().zip(rows) {
        let ln_r_i = k[0].as_f64().unwrap();
        assert!(
            (ln_r_i - r["r_i"].as_f64().unwrap().ln()).abs() < 1e-9,
            "{k} {r}"
        );
        assert_eq!(k[3], fitted[0][3]);
    }
    let record = std::fs::read_to_string(levels.join("joint-record.csv")).unwrap();
    assert!(record.starts_with("time_s,current_a,voltage_v,counted,soc,ocv_v\n"));
    for (flag, value, expect) in [
        ("--map-vary", "r_i,foo", "`foo` is not one of"),
        ("--map-smoothing", "nan", "give a non-negative number"),
        ("--soc-knots", "0.5,1.5", "give SOCs in [0, 1]"),
    ] {
        let mut a = base.to_vec();
        a.extend([flag, value]);
        let o = run(&a);
        assert_eq!(o.status.code(), Some(1), "{flag}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains(expect), "{err}");
    }
}

/// On the DFN's LFP HPPC record the Butler–Volmer term takes the whole
/// instantaneous drop: the joint map's `R_i` sits at or just above the
/// search's lower bound (10 µΩ) at every knot. A knot nearer the bound
/// than its 95 % interval reaches is at the bound, not identifiable, and
/// no face takes the map as a prior.
#[test]
fn a_knot_within_its_interval_of_a_bound_is_not_identifiable() {
    let (map, json) = (tmp("bvmap-prada.csv"), tmp("bvmap-prada.json"));
    let summary = tmp("bvmap-prada-summary.csv");
    let rec = data("pybamm/prada2013-hppc.csv");
    let ocv = data("pybamm/prada2013-ocv.csv");
    // The record, its OCV table and its capacity, as each command reads it.
    let cell = [
        "--input",
        s(&rec),
        "--ocv",
        s(&ocv),
        "--capacity-ah",
        "2.3034509907239076",
    ];
    let mut args = vec!["identify", "battery"];
    args.extend(cell);
    args.extend([
        "--min-rest",
        "250",
        "--model",
        "butler-volmer",
        "--map-method",
        "joint",
        "--map-smoothing",
        "1e-7",
        "--map-vary",
        "r_i,r_ct,du",
        "--map-out",
        s(&map),
        "--json",
        s(&json),
    ]);
    let o = run(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("map none (no identifiable level)"),
        "{stdout}"
    );
    // The same as a summary's row (`--summary-out`): ten levels, none
    // identifiable, no map RMSE.
    let mut with_summary = args.clone();
    with_summary.extend(["--summary-out", s(&summary)]);
    assert!(run(&with_summary).status.success());
    let mut rd = csv::Reader::from_path(&summary).unwrap();
    let h = rd.headers().unwrap().clone();
    let row = rd.records().next().unwrap().unwrap();
    let at = |name: &str| &row[h.iter().position(|x| x == name).unwrap()];
    assert_eq!(at("map_levels"), "10");
    assert_eq!(at("map_not_identifiable"), "10");
    assert_eq!(at("map_rmse_v"), "");
    let rows = read_json(&json)["map"]["levels"]
        .as_array()
        .unwrap()
        .clone();
    assert_eq!(rows.len(), 10);
    let bound = (-11.5f64).exp();
    let mut inside = 0;
    for r in &rows {
        let why = r["identifiable_reason"].as_str().unwrap();
        assert_eq!(r["identifiable"], false, "{r}");
        assert!(why.contains("R_i at a bound of the joint search"), "{r}");
        // Above the bound by more than the search's tolerance, with an
        // interval narrower than a factor 2: judged by its interval alone.
        let r_i = r["r_i"].as_f64().unwrap();
        if (r_i / bound).ln() > 1e-3 && !why.contains("too wide") {
            inside += 1;
        }
    }
    assert!(inside >= 3, "{rows:?}");
    let track = tmp("bvmap-prada-track.csv");
    let mut online = vec!["online", "battery"];
    online.extend(cell);
    online.extend(["--prior", s(&map), "--out", s(&track)]);
    let o = run(&online);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("no level of the map can be a prior"), "{err}");
}
