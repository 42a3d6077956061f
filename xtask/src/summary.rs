//! The firmware's final report as JSON: the `KEY k=v …` lines of its
//! decoded log ([`Summary`]) read into the keys `cargo xtask qemu`
//! prints. Owns the names of those keys; must not run anything.

use anyhow::{Context, Result};
use std::collections::BTreeMap;

/// What a firmware run printed: the `KEY a=b …` summary lines by key.
pub(crate) type Summary = BTreeMap<String, BTreeMap<String, String>>;

pub(crate) fn number(s: &Summary, line: &str, key: &str) -> Result<serde_json::Value> {
    let v = s
        .get(line)
        .and_then(|m| m.get(key))
        .with_context(|| format!("the firmware printed no {line} {key}="))?;
    if let Ok(n) = v.parse::<u64>() {
        return Ok(n.into());
    }
    let x: f64 = v
        .parse()
        .with_context(|| format!("{line} {key}={v}: not a number"))?;
    Ok(serde_json::Number::from_f64(x)
        .with_context(|| format!("{line} {key}={v}: not finite"))?
        .into())
}

/// A line's value of `key` as a JSON number; null where it is missing or
/// not a finite number (a NaN the firmware printed for "none").
fn number_or_null(m: &BTreeMap<String, String>, key: &str) -> serde_json::Value {
    m.get(key)
        .and_then(|v| v.parse::<f64>().ok())
        .and_then(serde_json::Number::from_f64)
        .map_or(serde_json::Value::Null, serde_json::Value::Number)
}

/// What cell `k` (1-based) publishes, into `out`: `published_r_i` …
/// `published_alpha` (null when nothing is published), `r_i_status` …
/// `alpha_status` and `step_resistance_ohm` (null before a step).
pub(crate) fn insert_published(
    s: &Summary,
    k: u64,
    out: &mut serde_json::Map<String, serde_json::Value>,
) {
    let Some(m) = s.get(&format!("PUBLISHED{k}")) else {
        return;
    };
    let num = |key: &str| number_or_null(m, key);
    for key in ["r_i", "r_ct", "q", "alpha"] {
        out.insert(format!("published_{key}"), num(key));
        let status = m.get(&format!("{key}_status")).cloned().unwrap_or_default();
        out.insert(format!("{key}_status"), status.into());
    }
    out.insert("step_resistance_ohm".into(), num("step_resistance_ohm"));
}

/// What cell `k` says of its state of charge (its `SOC` line, with an OCV
/// table): `soc` (the observer's, published), `soc_coulomb`,
/// `current_bias_a`, `capacity_ah`, `capacity_sigma_ah`,
/// `capacity_identified` (a boolean), `soc_sigma`, `soc_ocv_weight`,
/// `ocv_offset_v` (null where not a number; nothing without the line).
pub(crate) fn insert_soc(
    s: &Summary,
    k: u64,
    out: &mut serde_json::Map<String, serde_json::Value>,
) {
    let Some(m) = s.get(&format!("SOC{k}")) else {
        return;
    };
    for key in [
        "soc",
        "soc_coulomb",
        "current_bias_a",
        "capacity_ah",
        "capacity_sigma_ah",
        "soc_sigma",
        "soc_ocv_weight",
        "ocv_offset_v",
    ] {
        out.insert(key.into(), number_or_null(m, key));
    }
    let identified = m.get("capacity_identified").map(String::as_str) == Some("true");
    out.insert("capacity_identified".into(), identified.into());
}

/// The keys of a `SOP` line (the track's state-of-power columns at the
/// firmware's horizons).
pub(crate) const SOP_KEYS: [&str; 9] = [
    "sop_discharge_a_10s",
    "sop_charge_a_10s",
    "pulse_v_10s",
    "sop_discharge_a_30s",
    "sop_charge_a_30s",
    "pulse_v_30s",
    "sop_uncertainty_v",
    "pulse_ratio_10s",
    "pulse_ratio_30s",
];

/// What cell `k` (1-based; 0 the string) says of its state of power (its
/// `SOP` line, with an OCV table): `sop_published` (a boolean) and
/// [`SOP_KEYS`] (null where not published); nothing without the line.
pub(crate) fn insert_sop(
    s: &Summary,
    k: u64,
    out: &mut serde_json::Map<String, serde_json::Value>,
) {
    let Some(m) = s.get(&format!("SOP{k}")) else {
        return;
    };
    out.insert(
        "sop_published".into(),
        (m.get("published").map(String::as_str) == Some("true")).into(),
    );
    for key in SOP_KEYS {
        out.insert(key.into(), number_or_null(m, key));
    }
}

/// The JSON of a pack image's final report: `{"cells": [{"cell", "r_i",
/// "r_ct", "q", "alpha", "u_oc", "rejected", "flagged", and what the cell
/// publishes ([`insert_published`])}, …], "samples", "rejected"}` and the
/// snapshot's and the stack's keys ([`insert_persist`], [`insert_stack`];
/// a cell without an estimate has null parameters; `r_i` … are the
/// window's fit).
pub(crate) fn pack_json(s: &Summary) -> Result<serde_json::Value> {
    let cells = int(s, "PACK", "cells")?;
    let mut list = Vec::new();
    for k in 1..=cells {
        let line = format!("CELL{k}");
        let mut c = serde_json::Map::new();
        c.insert("cell".into(), k.into());
        let has = s.get(&line).is_some_and(|m| m.contains_key("r_i"));
        for key in ["r_i", "r_ct", "q", "alpha", "u_oc"] {
            let v = if has {
                number(s, &line, key)?
            } else {
                serde_json::Value::Null
            };
            c.insert(key.into(), v);
        }
        c.insert("rejected".into(), number(s, &line, "rejected")?);
        let flagged = s.get(&line).and_then(|m| m.get("flagged"));
        c.insert(
            "flagged".into(),
            (flagged.map(String::as_str) == Some("true")).into(),
        );
        insert_published(s, k, &mut c);
        insert_soc(s, k, &mut c);
        insert_sop(s, k, &mut c);
        list.push(serde_json::Value::Object(c));
    }
    let mut string = serde_json::Map::new();
    insert_sop(s, 0, &mut string);
    let mut out = serde_json::json!({
        "cells": list,
        "samples": number(s, "PACK", "samples")?,
        "rejected": number(s, "PACK", "rejected")?,
        "string_sop": string,
    });
    if let Some(m) = out.as_object_mut() {
        insert_persist(s, m);
        insert_stack(s, m);
    }
    Ok(out)
}

pub(crate) fn int(s: &Summary, line: &str, key: &str) -> Result<u64> {
    number(s, line, key)?
        .as_u64()
        .with_context(|| format!("{line} {key}: not an integer"))
}

/// The stack's part of a run (its `STACK` line, when printed):
/// `stack_init_bytes` (the deepest stack before the sample loop: the
/// board's start-up and the task's initialisation in its static),
/// `stack_high_water_bytes` (the deepest since, the sample loop's) and
/// `task_bytes` (the task's static).
pub(crate) fn insert_stack(s: &Summary, out: &mut serde_json::Map<String, serde_json::Value>) {
    for (key, name) in [
        ("init_bytes", "stack_init_bytes"),
        ("high_water_bytes", "stack_high_water_bytes"),
        ("task_bytes", "task_bytes"),
    ] {
        if let Ok(v) = number(s, "STACK", key) {
            out.insert(name.into(), v);
        }
    }
}

/// The snapshot's part of a run (its `RESTORE` and `PERSIST` lines):
/// `restore_status` (`restored`, `none`, `rejected`, `no_store`),
/// `last_save_clocks`, `snapshot_bytes`, `snapshot_saves` (this boot's),
/// `save_clocks_max` and `restore_clocks` (timer clocks; 40 instructions
/// each under `--icount`), `save_min_interval_s` (the save policy's
/// shortest interval, scaled to the region and the snapshot).
pub(crate) fn insert_persist(s: &Summary, out: &mut serde_json::Map<String, serde_json::Value>) {
    if let Some(status) = s.get("RESTORE").and_then(|m| m.get("status")) {
        out.insert("restore_status".into(), status.clone().into());
    }
    // The last save's cost (before a reset, the first boot's).
    if let Ok(v) = number(s, "SAVED", "clocks") {
        out.insert("last_save_clocks".into(), v);
    }
    let Some(m) = s.get("PERSIST") else {
        return;
    };
    for (key, name) in [
        ("bytes", "snapshot_bytes"),
        ("saves", "snapshot_saves"),
        ("save_clocks_max", "save_clocks_max"),
        ("restore_clocks", "restore_clocks"),
        ("min_interval_s", "save_min_interval_s"),
    ] {
        let v = number(s, "PERSIST", key).unwrap_or_else(|_| number_or_null(m, key));
        out.insert(name.into(), v);
    }
}
