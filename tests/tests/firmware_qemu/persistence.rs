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
    let src = root().join("data/pybamm/chen2020-hppc.csv");
    let ocv = root().join("data/pybamm/chen2020-ocv.csv");
    let text = std::fs::read_to_string(&src).unwrap();
    let head: Vec<&str> = text.lines().take(2001).collect();
    let csv = tmp("hppc-2000.csv");
    std::fs::write(&csv, head.join("\n") + "\n").unwrap();
    let args = ["--ocv", ocv.to_str().unwrap(), "--capacity-ah", "5.153198"];
    let whole = firmware(&csv, &args);
    let reset = firmware(&csv, &[&args[..], &["--reset-at", "1000"]].concat());
    eprintln!("without reset {whole}\nwith a reset at 1000 {reset}");
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
