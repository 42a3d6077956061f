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
        "--map-out",
        s(&map),
        "--map-plot",
        s(&svg),
        "--fit-out",
        s(&fit_out),
        "--json",
        s(&json),
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
