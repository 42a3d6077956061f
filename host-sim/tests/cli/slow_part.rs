//! `online pack --slow-memory-s`: the slow part carried across windows
//! (docs/online-publication.md).

use super::state_of_power::col;
use super::*;

/// `--slow-memory-s` carries the slow part across windows: on docs/pack.md's
/// 8-cell HPPC string (seed 1) the published R_ct and Q of every cell, from
/// its first identified window on, are within ±10 % of its truth at more
/// rows than each window's own values are (measured: Q 88.9 % → 98.8 %,
/// R_ct 95.3 % → 100 %; printed by `cargo test -p host-sim --test cli
/// the_slow_part -- --nocapture`), while the
/// window's fit (`window_*`) and the state of power are the same row for
/// row: only what is published moves.
#[test]
fn the_slow_part_carried_across_windows_keeps_every_cell_in_its_band() {
    let csv = tmp("pack-slow.csv");
    let o = run(&[
        "simulate",
        "pack",
        "--cells",
        "8",
        "--preset",
        "cell",
        "--profile",
        "hppc",
        "--spread",
        "0.1",
        "--aged",
        "3",
        "--sigma",
        "0.001",
        "--length",
        "2400",
        "--seed",
        "1",
        "--out",
        s(&csv),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let truth = read_json(&csv.with_extension("json"));
    let cells = truth["cells"].as_array().unwrap();
    let track = |memory: &str| {
        let out = tmp(&format!("pack-slow-{memory}-track.csv"));
        let o = run(&[
            "online",
            "pack",
            "--input",
            s(&csv),
            "--window",
            "256",
            "--memory",
            "64",
            "--start",
            "at-rest",
            "--tail",
            "--slow-memory-s",
            memory,
            "--out",
            s(&out),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let text = std::fs::read_to_string(&out).unwrap();
        let mut lines = text.lines();
        let head: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
        let rows: Vec<Vec<String>> = lines
            .map(|l| l.split(',').map(String::from).collect())
            .collect();
        (head, rows)
    };
    // Per parameter: the share of rows within ±10 % from each cell's first
    // identified window on (a row publishing nothing counts as outside).
    let within = |head: &[String], rows: &[Vec<String>], key: &str| {
        let (v, st, c) = (
            col(head, key),
            col(head, &format!("{key}_status")),
            col(head, "cell"),
        );
        let mut started = [false; 8];
        let (mut inside, mut n) = (0, 0);
        for r in rows {
            let k: usize = r[c].parse::<usize>().unwrap() - 1;
            started[k] |= r[st] == "identified";
            if started[k] {
                n += 1;
                let t = cells[k][key].as_f64().unwrap();
                inside += usize::from(
                    r[v].parse::<f64>()
                        .is_ok_and(|x| (x / t - 1.0).abs() <= 0.10),
                );
            }
        }
        assert!(
            n > 8 * 1500,
            "{key}: {n} rows after the first identified windows"
        );
        inside as f64 / n as f64
    };
    let (head, own) = track("0");
    let (head_fused, fused) = track("400");
    assert_eq!(head, head_fused);
    let (q0, q1) = (within(&head, &own, "q"), within(&head, &fused, "q"));
    let (r0, r1) = (within(&head, &own, "r_ct"), within(&head, &fused, "r_ct"));
    println!(
        "rows within ±10 % from the first identified window, each window's own -> 400 s: \
         Q {:.1} -> {:.1} %, R_ct {:.1} -> {:.1} %",
        100.0 * q0,
        100.0 * q1,
        100.0 * r0,
        100.0 * r1
    );
    assert!(q0 < 0.95 && q1 >= 0.95 && q1 > q0, "Q {q0} -> {q1}");
    assert!(r1 >= 0.95 && r1 >= r0, "R_ct {r0} -> {r1}");
    // The window's fit and the state of power do not move.
    let same: Vec<usize> = head
        .iter()
        .enumerate()
        .filter(|(_, h)| h.starts_with("window_") || h.contains("sop_") || h.contains("pulse_v"))
        .map(|(i, _)| i)
        .collect();
    assert!(same.len() >= 8, "{head:?}");
    for (a, b) in own.iter().zip(&fused) {
        for &i in &same {
            assert_eq!(a[i], b[i], "{}", head[i]);
        }
    }
    // A negative or not-a-number memory is one line and exit 1 (clap's
    // own parse errors exit 2).
    for bad in ["-1", "nan"] {
        let out = tmp("pack-slow-bad.csv");
        let o = run(&[
            "online",
            "pack",
            "--input",
            s(&csv),
            "--slow-memory-s",
            bad,
            "--out",
            s(&out),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(
            err.contains("--slow-memory-s") && err.trim().lines().count() == 1,
            "{err}"
        );
    }
}
