//! Measured cycler data as they come (data/panasonic-18650pf, MAT-files):
//! the OCV from the test.

use super::*;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data")
        .join(name)
}

fn table(path: &Path) -> Vec<(f64, f64)> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let (a, b) = l.split_once(',').unwrap();
            (a.parse().unwrap(), b.parse().unwrap())
        })
        .collect()
}

fn at(t: &[(f64, f64)], z: f64) -> f64 {
    let j = t
        .iter()
        .rposition(|p| p.0 <= z)
        .unwrap_or(0)
        .min(t.len() - 2);
    let (a, b) = (t[j], t[j + 1]);
    a.1 + (z - a.0) / (b.0 - a.0) * (b.1 - a.1)
}

/// The C/20 test: the mean of the charge and discharge branches; the
/// capacity measured as the dataset states it (2.995 A·h out).
#[test]
fn panasonic_c20_gives_the_ocv_and_the_capacity() {
    let (out, json) = (tmp("pan-c20.csv"), tmp("pan-c20.json"));
    let o = run(&[
        "ocv",
        "--input",
        s(&data(
            "panasonic-18650pf/05-08-17_13.26 C20 OCV Test_C20_25dC.mat",
        )),
        "--from",
        "low-rate",
        "--out",
        s(&out),
        "--json",
        s(&json),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j = read_json(&json);
    let c = j["capacity_ah"].as_f64().unwrap();
    assert!((c - 2.995).abs() < 0.01, "{c}");
    assert_eq!(j["branches"].as_array().unwrap().len(), 2);
    let t = table(&out);
    assert!(t.len() > 80 && t.windows(2).all(|w| w[1].0 > w[0].0 && w[1].1 > w[0].1));
    // The range the two branches share (the charge has no CV phase: it
    // stops short of full).
    assert!(
        t[0].0 < 0.02 && t[t.len() - 1].0 > 0.85,
        "{:?}",
        (t[0], t[t.len() - 1])
    );
}

/// The 25 °C HPPC test's rests: the table passes within 2 mV of the rest
/// voltages at the rest points, but where points were pooled to keep it
/// increasing.
#[test]
fn panasonic_hppc_rests_give_the_ocv_within_2_mv() {
    let (out, json) = (tmp("pan-hppc.csv"), tmp("pan-hppc.json"));
    let o = run(&[
        "ocv",
        "--input",
        s(&data(
            "panasonic-18650pf/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat",
        )),
        "--min-rest",
        "1000",
        "--out",
        s(&out),
        "--json",
        s(&json),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j = read_json(&json);
    let t = table(&out);
    let rests = j["rests"].as_array().unwrap();
    let pooled = j["points_pooled"].as_u64().unwrap() as usize;
    let far = rests
        .iter()
        .filter(|r| {
            let (z, v) = (r["soc"].as_f64().unwrap(), r["voltage_v"].as_f64().unwrap());
            (at(&t, z) - v).abs() > 2e-3
        })
        .count();
    assert!(rests.len() > 50, "{}", rests.len());
    assert!(
        far <= pooled,
        "{far} rest points off by more than 2 mV, {pooled} pooled"
    );
}
