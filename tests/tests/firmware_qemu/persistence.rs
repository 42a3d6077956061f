//! The snapshot on the board (issue 38, docs/persistence.md): the QEMU
//! firmware saves into its flash region, resets (`cargo xtask qemu
//! --reset-at N`), restores with the core's judgement and replays on; its
//! final estimate is the run's without the reset.

use super::harness::*;

/// The first 2000 s of the DFN HPPC record (PyBaMM, not our model) with
/// its OCV table, reset at period 1000: the firmware restores (148 B), the
/// second boot pushes the last 1000 periods, and the final published
/// parameters, SOC and window estimate equal the uninterrupted run's within
/// 1e-4 (f32; the window refilled long before the end).
#[test]
fn qemu_firmware_resumes_from_its_snapshot_after_a_reset() {
    let (whole, reset) = with_and_without_a_reset(&[]);
    assert_eq!(whole["samples"].as_u64(), Some(2000), "{whole}");
    assert_eq!(whole["restore_status"], "none", "{whole}");
    assert_eq!(reset["restore_status"], "restored", "{reset}");
    assert_eq!(reset["restored_at"].as_u64(), Some(1000), "{reset}");
    assert_eq!(reset["samples"].as_u64(), Some(1000), "{reset}");
    assert_eq!(reset["snapshot_bytes"].as_u64(), Some(148), "{reset}");
    assert!(reset["last_save_clocks"].as_u64().is_some(), "{reset}");
    let mut compared = 0;
    for k in [
        "r_i",
        "r_ct",
        "q",
        "alpha",
        "published_r_i",
        "published_r_ct",
        "published_q",
        "published_alpha",
        "soc",
    ] {
        match (whole[k].as_f64(), reset[k].as_f64()) {
            (Some(a), Some(b)) => {
                assert!(
                    (b / a - 1.0).abs() < 1e-4,
                    "{k}: {b} after the reset, {a} without"
                );
                compared += 1;
            }
            (None, None) => {}
            other => panic!("{k}: {other:?}"),
        }
        let status = k.strip_prefix("published_").map(|p| format!("{p}_status"));
        if let Some(st) = status {
            assert_eq!(whole[&st], reset[&st], "{st}");
        }
    }
    assert!(compared >= 6, "{compared} values compared");
}

/// The firmware's runs of the first 2000 s of the DFN HPPC record with its
/// OCV table and `extra` flags, without a reset and with one at period
/// 1000: their JSON lines.
fn with_and_without_a_reset(extra: &[&str]) -> (serde_json::Value, serde_json::Value) {
    let src = root().join("data/pybamm/chen2020-hppc.csv");
    let ocv = root().join("data/pybamm/chen2020-ocv.csv");
    let text = std::fs::read_to_string(&src).unwrap();
    let head: Vec<&str> = text.lines().take(2001).collect();
    // (One file per test: the tests run at once.)
    let csv = tmp(&format!("hppc-2000{}.csv", extra.join("_")));
    std::fs::write(&csv, head.join("\n") + "\n").unwrap();
    let ocv = ocv.to_str().unwrap();
    let args = [&["--ocv", ocv, "--capacity-ah", "5.153198"][..], extra].concat();
    let whole = firmware(&csv, &args);
    let reset = firmware(&csv, &[&args[..], &["--reset-at", "1000"]].concat());
    eprintln!("without reset {whole}\nwith a reset at 1000 {reset}");
    (whole, reset)
}

/// An image that carries the slow part across windows
/// (`FRACBMS_SLOW_MEMORY_S`, `--slow-memory-s 600`) saves it in its
/// snapshot (188 B) and restores it: 1000 periods after the reset the
/// published `R_ct`, `Q` and α are within 0.5 % of the uninterrupted
/// run's (measured 2.1e-3, 3.2e-4, 3.4e-4: the windows fitted while the
/// window refilled stay in the mean; the host's `bench/resume_halves.py`
/// on the same excerpt gives 2.0e-3, and 3.4e-3 with the mean started
/// again).
#[test]
fn qemu_firmware_keeps_the_slow_part_across_a_reset() {
    let (whole, reset) = with_and_without_a_reset(&["--slow-memory-s", "600"]);
    assert_eq!(reset["restore_status"], "restored", "{reset}");
    assert_eq!(reset["snapshot_bytes"].as_u64(), Some(188), "{reset}");
    for k in ["published_r_ct", "published_q", "published_alpha"] {
        let (a, b) = (f(&whole, k), f(&reset, k));
        let off = (b / a - 1.0).abs();
        eprintln!("{k}: {b} after the reset, {a} without ({off:.2e})");
        assert!(off < 5e-3, "{k}: {b} after the reset, {a} without");
        let st = k.replace("published_", "") + "_status";
        assert_eq!(whole[&st], reset[&st], "{st}");
    }
}
