//! The pack firmware with the cells' OCV table (issue 36): each cell's
//! state of charge and state of power, and the string's, against
//! `host-sim online pack` with the same table.

use super::harness::*;

/// A simulated 4-cell string (HPPC, the Chen2020 table, SOC 0.7 at the
/// start, ±10 % spread, cell 3 aged 1.5x, 3000 s, σ = 1 mV), from its first
/// rest (the rows before t = 10 s are a pulse: both faces then read each
/// cell's start SOC from the same rested voltages, as the firmware must,
/// having no `--soc0`). The QEMU pack firmware (f32, window 256, memory 64,
/// the tail) and `host-sim online pack --ocv` (f64, same settings) end with
/// the same SOC per cell (within 1e-4), the same state of power per cell
/// and for the string (the firmware's `string_sop` is the track's `pack_*`
/// columns, within `assert_same_power`'s tolerance), and the aged cell
/// limits the string.
#[test]
fn qemu_pack_firmware_with_an_ocv_table_agrees_with_host_sim_on_soc_and_power() {
    let full = tmp("pack4-ocv-full.csv");
    let ocv = root().join("data/pybamm/chen2020-ocv.csv");
    let s = |p: &std::path::Path| p.to_str().unwrap().to_owned();
    host_sim(&[
        "simulate",
        "pack",
        "--cells",
        "4",
        "--profile",
        "hppc",
        "--spread",
        "0.1",
        "--aged",
        "3",
        "--sigma",
        "0.001",
        "--length",
        "3000",
        "--seed",
        "1",
        "--ocv",
        &s(&ocv),
        "--soc0",
        "0.7",
        "--out",
        &s(&full),
    ]);
    let text = std::fs::read_to_string(&full).unwrap();
    let mut lines = text.lines();
    let mut cut = vec![lines.next().unwrap()];
    cut.extend(lines.filter(|l| l.split(',').next().unwrap().parse::<f64>().unwrap() >= 10.0));
    let csv = tmp("pack4-ocv.csv");
    std::fs::write(&csv, cut.join("\n") + "\n").unwrap();
    let track = tmp("pack4-ocv-track.csv");
    let common = [
        "--window",
        "256",
        "--memory",
        "64",
        "--tail",
        "--ocv",
        &s(&ocv),
        "--capacity-ah",
        "2.5",
    ];
    let mut args = vec!["online", "pack", "--input", csv.to_str().unwrap()];
    args.extend(common);
    args.extend(["--start", "at-rest", "--out", track.to_str().unwrap()]);
    host_sim(&args);
    let fw = firmware(&csv, &common);
    eprintln!("firmware {fw}");
    assert_eq!(fw["samples"].as_u64(), Some(2990), "{fw}");
    assert_eq!(fw["rejected"].as_u64(), Some(0), "{fw}");

    let t = std::fs::read_to_string(&track).unwrap();
    let header: Vec<&str> = t.lines().next().unwrap().split(',').collect();
    let rows: Vec<Vec<&str>> = t.lines().skip(1).map(|l| l.split(',').collect()).collect();
    let last = &rows[rows.len() - 4..];
    // A track row's columns as the firmware's JSON keys (`prefix`: the
    // string's `pack_` columns), null where empty.
    let as_json = |row: &[&str], prefix: &str, keys: &[&str]| {
        let mut out = serde_json::Map::new();
        for key in keys {
            let k = header
                .iter()
                .position(|h| *h == format!("{prefix}{key}"))
                .unwrap_or_else(|| panic!("no column {prefix}{key}"));
            let v = row[k]
                .parse::<f64>()
                .map_or(serde_json::Value::Null, serde_json::Value::from);
            out.insert((*key).to_owned(), v);
        }
        serde_json::Value::Object(out)
    };
    let cells = fw["cells"].as_array().expect("a pack JSON");
    assert_eq!(cells.len(), 4);
    for (k, (c, row)) in cells.iter().zip(last).enumerate() {
        assert_eq!(row[1], (k + 1).to_string());
        let host = as_json(row, "", &["soc"]);
        assert!(
            (f(c, "soc") - f(&host, "soc")).abs() < 1e-4,
            "cell {}: {c} {host}",
            k + 1
        );
        let host = as_json(row, "", &SOP_KEYS);
        assert_eq!(
            c["sop_published"].as_bool(),
            Some(true),
            "cell {}: {c}",
            k + 1
        );
        assert_same_power(c, &host);
    }
    let string = &fw["string_sop"];
    assert_same_power(string, &as_json(&last[0], "pack_", &SOP_KEYS));
    // The aged cell limits the string's discharge.
    let d = |c: &serde_json::Value| f(c, "sop_discharge_a_10s");
    assert_eq!(d(string), d(&cells[2]), "{fw}");
    assert!(cells
        .iter()
        .enumerate()
        .all(|(k, c)| k == 2 || d(c) > d(&cells[2])));
}
