//! The harness of the QEMU tests: paths, the host-sim and `cargo xtask
//! qemu` runs, and reading their results. Owns no check of its own. The
//! runs go side by side: `cargo xtask qemu` builds under a lock of its own
//! and runs a private copy of its image, so one test's QEMU run overlaps
//! another's build.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub(crate) fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

pub(crate) fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fracbms-fw-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// docs/pack.md's 8-cell string (preset `cell`, ±10 % spread, cell 3
/// aged 1.5×, σ 1 mV, seed 1) with `profile` over `length` samples, made
/// by `host-sim simulate pack` into `name` (its truth beside it as JSON).
pub(crate) fn pack8(name: &str, profile: &str, length: usize) -> PathBuf {
    let csv = tmp(name);
    host_sim(&[
        "simulate",
        "pack",
        "--cells",
        "8",
        "--preset",
        "cell",
        "--profile",
        profile,
        "--spread",
        "0.1",
        "--aged",
        "3",
        "--sigma",
        "0.001",
        "--length",
        &length.to_string(),
        "--seed",
        "1",
        "--out",
        csv.to_str().unwrap(),
    ]);
    csv
}

/// `host-sim online pack` over `csv` as the QEMU pack tests run the
/// firmware (window 256, memory 64, from rest, the short-memory
/// correction) with `extra` flags: the track's text.
pub(crate) fn online_pack8(csv: &Path, track_name: &str, extra: &[&str]) -> String {
    let track = tmp(track_name);
    let mut args = vec![
        "online",
        "pack",
        "--input",
        csv.to_str().unwrap(),
        "--window",
        "256",
        "--memory",
        "64",
        "--start",
        "at-rest",
        "--tail",
    ];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--out", track.to_str().unwrap()]);
    host_sim(&args);
    std::fs::read_to_string(&track).unwrap()
}

/// The truth `host-sim simulate` wrote beside `csv` (`FILE.json`).
pub(crate) fn truth_of(csv: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(csv.with_extension("json")).unwrap()).unwrap()
}

/// Runs the host-sim command line (`cargo run -p host-sim`: the binary
/// `cargo test --workspace` has built, or built now).
pub(crate) fn host_sim(args: &[&str]) {
    let o = Command::new(env!("CARGO"))
        .current_dir(root())
        .args(["run", "--quiet", "-p", "host-sim", "--"])
        .args(args)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "host-sim {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// The cargo profile of the tests' images: the release profile's
/// optimisation without its whole-program LTO (each configuration is a
/// new image, and the LTO tripled each one's build).
pub(crate) const PROFILE: &str = "firmware-test";

/// Runs `cargo xtask qemu --input FILE ARGS…`.
pub(crate) fn xtask_qemu(input: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO"))
        .current_dir(root())
        .args(["xtask", "qemu", "--profile", PROFILE, "--input"])
        .arg(input)
        .args(args)
        .output()
        .unwrap()
}

/// Runs `cargo xtask qemu --input FILE ARGS…`; returns the last stdout line
/// as JSON.
pub(crate) fn firmware(input: &Path, args: &[&str]) -> serde_json::Value {
    let o = xtask_qemu(input, args);
    let out = String::from_utf8_lossy(&o.stdout);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "cargo xtask qemu failed:\n{err}");
    let last = out
        .lines()
        .last()
        .unwrap_or_else(|| panic!("no output:\n{err}"));
    serde_json::from_str(last).unwrap_or_else(|e| panic!("{e}: {last:?}"))
}

pub(crate) fn simulate(out: &Path, profile: &str, seed: &str) {
    host_sim(&[
        "simulate",
        "battery",
        "--preset",
        "cell",
        "--profile",
        profile,
        "--sigma",
        "0.001",
        "--length",
        "1000",
        "--seed",
        seed,
        "--out",
        out.to_str().unwrap(),
    ]);
}

pub(crate) fn f(j: &serde_json::Value, k: &str) -> f64 {
    j[k].as_f64().unwrap_or_else(|| panic!("key {k} in {j}"))
}

/// The stated tolerance of the firmware (f32, online) against host-sim
/// (f64, batch): R_i, R_ct, Q within 1 %, α within 0.005, U_oc within 1 mV.
pub(crate) fn assert_agree(fw: &serde_json::Value, host: &serde_json::Value) {
    for k in ["r_i", "r_ct", "q"] {
        let r = (f(fw, k) / f(host, k) - 1.0).abs();
        assert!(r < 0.01, "{k}: firmware {fw} host {host}");
    }
    assert!(
        (f(fw, "alpha") - f(host, "alpha")).abs() < 0.005,
        "{fw} {host}"
    );
    assert!(
        (f(fw, "u_oc") - f(host, "u_oc")).abs() < 1e-3,
        "{fw} {host}"
    );
}

/// The last row of an `online battery` track (with an OCV curve) as the
/// firmware's JSON keys; it must be a tracked estimate. The window's fit
/// (`window_r_i`…), identified or not: what the firmware logs.
pub(crate) fn last_estimate(track: &Path) -> serde_json::Value {
    let t = std::fs::read_to_string(track).unwrap();
    let header: Vec<&str> = t.lines().next().unwrap().split(',').collect();
    let last: Vec<&str> = t.lines().last().unwrap().split(',').collect();
    assert_eq!(last[6], "tracking", "{last:?}");
    let num = |name: &str| -> f64 {
        let k = header.iter().position(|h| *h == name).unwrap();
        last[k].parse().unwrap()
    };
    let mut out = serde_json::json!({
        "r_i": num("window_r_i"), "r_ct": num("window_r_ct"), "q": num("window_q"),
        "alpha": num("window_alpha"), "u_oc": num("u_oc"), "soc": num("soc"),
    });
    // The state of power at the firmware's horizons (null where empty).
    for key in SOP_KEYS {
        if let Some(k) = header.iter().position(|h| *h == key) {
            out[key] = last[k]
                .parse::<f64>()
                .map_or(serde_json::Value::Null, serde_json::Value::from);
        }
    }
    out
}

/// The state-of-power keys of the firmware's JSON and the track's columns.
pub(crate) const SOP_KEYS: [&str; 7] = [
    "sop_discharge_a_10s",
    "sop_charge_a_10s",
    "pulse_v_10s",
    "sop_discharge_a_30s",
    "sop_charge_a_30s",
    "pulse_v_30s",
    "sop_uncertainty_v",
];

/// The firmware's state of power is host-sim's: both unpublished (the
/// firmware's `sop_published` false, the track's columns empty), or the
/// currents within 0.2 %, the pulse voltages within 1 mV and their
/// standard deviation within 0.1 mV (f32 against f64 on the same
/// estimate; measured on the DFN drive cycle: 1e−6 and 1 µV).
pub(crate) fn assert_same_power(fw: &serde_json::Value, host: &serde_json::Value) {
    let published = fw["sop_published"].as_bool() == Some(true);
    for key in SOP_KEYS {
        assert_eq!(
            published,
            !host[key].is_null(),
            "{key}: firmware {fw} host {host}"
        );
        if !published {
            assert!(fw[key].is_null(), "{key}: {fw}");
            continue;
        }
        let (a, b) = (f(fw, key), f(host, key));
        let ok = if key.starts_with("pulse_v") {
            (a - b).abs() < 1e-3
        } else if key == "sop_uncertainty_v" {
            (a - b).abs() < 1e-4
        } else {
            (a / b - 1.0).abs() < 2e-3
        };
        assert!(ok, "{key}: firmware {a}, host-sim {b}");
    }
}
