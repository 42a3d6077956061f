//! The C faces: the host C test program linked against the host
//! `libfracbms.a`, and the C example firmware under QEMU (`cargo xtask
//! c-demo`) against the Rust firmware (`cargo xtask qemu`) on the same
//! record.
//!
//! Needs `cc`, `arm-none-eabi-gcc` and `qemu-system-arm`;
//! `scripts/check.sh` installs them. The two tests run side by side: cargo
//! takes turns on the target directory itself, and each test writes its own
//! files (`cargo xtask qemu` runs a private copy of its image).

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// Runs `cargo ARGS…` at the workspace root; returns stdout's last line
/// (as JSON) and fails with stderr on an error.
fn cargo_json(args: &[&str]) -> serde_json::Value {
    let o = Command::new(env!("CARGO"))
        .current_dir(root())
        .args(args)
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "cargo {args:?} failed:\n{err}");
    let last = out
        .lines()
        .last()
        .unwrap_or_else(|| panic!("no output:\n{err}"));
    serde_json::from_str(last).unwrap_or_else(|e| panic!("{e}: {last}"))
}

/// `key=value` pairs of the line starting with `RESULT`.
fn result_line(text: &str) -> std::collections::BTreeMap<String, f64> {
    let line = text
        .lines()
        .find(|l| l.starts_with("RESULT"))
        .unwrap_or_else(|| panic!("no RESULT line:\n{text}"));
    line.split_whitespace()
        .skip(1)
        .filter_map(|kv| kv.split_once('='))
        .map(|(k, v)| (k.to_string(), v.parse().unwrap()))
        .collect()
}

fn num(j: &serde_json::Value, k: &str) -> f64 {
    j[k].as_f64().unwrap_or_else(|| panic!("no {k} in {j}"))
}

#[test]
fn the_c_example_under_qemu_agrees_with_the_rust_firmware() {
    let input = "firmware/data/cell-pulse.csv";
    let c = cargo_json(&["xtask", "c-demo", "--input", input]);
    // The QEMU tests' profile (tests/firmware_qemu/harness.rs): the same
    // arithmetic as the release image, built in a third of the time.
    let rust = cargo_json(&[
        "xtask",
        "qemu",
        "--profile",
        "firmware-test",
        "--input",
        input,
    ]);
    for k in ["r_i", "r_ct", "q"] {
        let (a, b) = (num(&c, k), num(&rust, k));
        assert!((a / b - 1.0).abs() <= 0.01, "{k}: C {a}, Rust {b}");
    }
    let (a, b) = (num(&c, "alpha"), num(&rust, "alpha"));
    assert!((a - b).abs() <= 0.005, "alpha: C {a}, Rust {b}");
    assert_eq!(c["samples"], rust["samples"]);
    assert_eq!(c["rejected"], rust["rejected"]);
}

#[test]
fn the_host_c_program_runs_the_library_and_checks_its_errors() {
    let root = root();
    // The dev profile: its dependencies are those `cargo test` has just
    // built, where a release build compiles the host library again with
    // whole-program LTO (4 min on 2 cores). Floating point is the same in
    // both (no fast-math), and the check is against the Rust estimate.
    let status = Command::new(env!("CARGO"))
        .current_dir(&root)
        .args(["build", "-q", "-p", "estimator-ffi"])
        .status()
        .unwrap();
    assert!(status.success(), "cargo build -p estimator-ffi");
    let dir = root.join("target").join("c-host");
    std::fs::create_dir_all(&dir).unwrap();
    let exe = dir.join("host_test");
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let o = Command::new(&cc)
        .current_dir(&root)
        .args([
            "-std=c11",
            "-O2",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-Iinclude",
        ])
        .arg("examples/c/host_test.c")
        .arg("target/debug/libfracbms.a")
        .args(["-lpthread", "-ldl", "-lm", "-o"])
        .arg(&exe)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{cc}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let o = Command::new(&exe)
        .arg(root.join("firmware/data/cell-pulse.csv"))
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "host_test failed:\n{out}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // The same library state in Rust, pushed the same samples.
    let r = result_line(&out);
    let rust = rust_cell_estimate();
    for (k, want) in [
        ("r_i", rust.r_i),
        ("r_ct", rust.r_ct),
        ("q", rust.q),
        ("alpha", rust.alpha),
        ("u_oc", rust.u_oc),
    ] {
        let got = r[k];
        assert!(
            (got / f64::from(want) - 1.0).abs() < 1e-5,
            "{k}: C {got}, Rust {want}"
        );
    }
    assert_eq!(r["samples"], 1000.0);
}

/// The estimate of the core's `CellEstimator` with the firmware's defaults
/// on `firmware/data/cell-pulse.csv`.
fn rust_cell_estimate() -> estimator_core::battery::CellParameters<f32> {
    use estimator_core::battery::online::{CellEstimator, OnlineSettings};
    use estimator_core::battery::{CellParameters, Start};
    let mut s = OnlineSettings::new(1.0, 64, CellParameters::<f32>::cell_18650());
    s.battery.start = Start::AtRest;
    let s = s.with_curve::<128>(None);
    let mut cell = Box::new(CellEstimator::<f32, 256, 64>::new(&s).unwrap());
    let text = std::fs::read_to_string(root().join("firmware/data/cell-pulse.csv")).unwrap();
    for l in text.lines().skip(1) {
        let f: Vec<f32> = l.split(',').map(|x| x.parse().unwrap()).collect();
        cell.push(&s, f[1], f[2]);
    }
    cell.estimate().unwrap()
}
