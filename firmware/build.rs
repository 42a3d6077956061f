//! Build script of the firmware.
//!
//! * Writes `config.rs` (window, memory, method, iterations per sample, log
//!   rate) from `FRACBMS_*` environment variables, so that `cargo xtask qemu
//!   --window L` picks the const-generic sizes at build time.
//! * Converts the replay record (`FRACBMS_REPLAY`, a `time_s,current_a,
//!   voltage_v[,temperature_c]` CSV; default `data/cell-pulse.csv`) into
//!   `replay.bin`, 16 bytes per sample period: `u32` flags (1 = the row is
//!   missing: a dropped sample), then current, voltage and temperature as
//!   little-endian `f32`. A gap in the time column becomes dropped samples;
//!   an empty cell becomes NaN.
//! * Reads the cell's OCV table (`FRACBMS_OCV`, a `soc,ocv_v` CSV) and
//!   capacity (`FRACBMS_CAPACITY_AH`), checks the table in `f32` with the
//!   core's own [`OcvTable`](estimator_core::battery::ocv::OcvTable), and
//!   writes it into `config.rs` as two `static` arrays (flash).
//! * Reads the prior's centre (`FRACBMS_PRIOR=r_i,r_ct,q,alpha[,bv_a,bv_i0]`)
//!   and the cell model (`FRACBMS_MODEL=linear|butler-volmer`), the
//!   short-memory correction (`FRACBMS_TAIL=0|1`) and the slow part's
//!   memory (`FRACBMS_SLOW_MEMORY_S`, seconds; 0, the default: off).
//! * Reads the parameter map (`FRACBMS_MAP`, the `--map-out` CSV of
//!   `host-sim identify battery`), keeps its identifiable levels, checks
//!   them with the core's `ParameterMap` in `f32` and writes them as a
//!   `static` table (flash): the prior then follows the map.
//! * For `target_os = "none"` only: puts `memory.x` (which includes
//!   `fracbms-board.x`) and the board's map as `fracbms-board.x` on the link
//!   path and passes `-Tlink.x` and `-Tdefmt.x`.

use std::env;
use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};

fn var(name: &str, default: &str) -> String {
    println!("cargo:rerun-if-env-changed={name}");
    env::var(name).unwrap_or_else(|_| default.to_owned())
}

fn fail(msg: String) -> ! {
    // One clear line; cargo shows it under "error: failed to run custom build command".
    eprintln!("error: {msg}");
    std::process::exit(1)
}

fn number(name: &str, default: usize, lo: usize, hi: usize) -> usize {
    let s = var(name, &default.to_string());
    match s.parse::<usize>() {
        Ok(v) if (lo..=hi).contains(&v) => v,
        _ => fail(format!("{name}={s}: must be an integer in {lo}..={hi}")),
    }
}

fn cell(path: &Path, row: usize, col: &str, s: &str) -> f32 {
    let s = s.trim();
    if s.is_empty() {
        return f32::NAN;
    }
    s.parse::<f32>().unwrap_or_else(|_| {
        fail(format!(
            "{}: row {row}, column {col}: {s:?} is not a number",
            path.display()
        ))
    })
}

/// Opens a CSV file and reads its header (one error line on failure).
fn open_csv(path: &Path) -> (csv::Reader<fs::File>, csv::StringRecord) {
    let mut rd = csv::Reader::from_path(path)
        .unwrap_or_else(|e| fail(format!("{}: cannot read ({e})", path.display())));
    let headers = rd
        .headers()
        .unwrap_or_else(|e| fail(format!("{}: no header ({e})", path.display())))
        .clone();
    (rd, headers)
}

/// One replay record: flags, current, the cell voltages, temperature.
type Record = (u32, f32, Vec<f32>, f32);

/// Reads the replay CSV (`time_s,current_a,voltage_v` for one cell, or
/// `time_s,current_a,cell_1_v,…,cell_N_v` for a pack; `temperature_c`
/// optional); returns (h, records).
fn replay(path: &Path) -> (f64, Vec<Record>) {
    let (mut rd, headers) = open_csv(path);
    let find = |name: &str| headers.iter().position(|h| h.trim() == name);
    let pack: Vec<usize> = (1..).map_while(|k| find(&format!("cell_{k}_v"))).collect();
    let (Some(ct), Some(ci)) = (find("time_s"), find("current_a")) else {
        fail(format!(
            "{}: the header must have time_s,current_a,voltage_v (one cell) or time_s,current_a,cell_1_v,…,cell_N_v (a pack)",
            path.display()
        ))
    };
    let (cols, names): (Vec<usize>, Vec<String>) = match (find("voltage_v"), pack.is_empty()) {
        (Some(cv), true) => (vec![cv], vec!["voltage_v".to_owned()]),
        (None, false) => (
            pack.clone(),
            (1..=pack.len()).map(|k| format!("cell_{k}_v")).collect(),
        ),
        _ => fail(format!(
            "{}: the header must have voltage_v (one cell) or cell_1_v,…,cell_N_v (a pack), not both or neither",
            path.display()
        )),
    };
    let ctemp = find("temperature_c");
    let mut rows: Vec<(f64, f32, Vec<f32>, f32)> = Vec::new();
    for (k, rec) in rd.records().enumerate() {
        let row = k + 2;
        let rec = rec.unwrap_or_else(|e| fail(format!("{}: row {row}: {e}", path.display())));
        let get = |c: usize| rec.get(c).unwrap_or("");
        let t: f64 = get(ct).trim().parse().unwrap_or_else(|_| {
            fail(format!(
                "{}: row {row}, column time_s: {:?} is not a number",
                path.display(),
                get(ct)
            ))
        });
        let temp = ctemp.map_or(25.0, |c| cell(path, row, "temperature_c", get(c)));
        let volts = cols
            .iter()
            .zip(&names)
            .map(|(&c, name)| cell(path, row, name, get(c)))
            .collect();
        rows.push((t, cell(path, row, "current_a", get(ci)), volts, temp));
    }
    if rows.len() < 2 {
        fail(format!("{}: needs at least 2 data rows", path.display()));
    }
    let mut steps: Vec<f64> = rows.windows(2).map(|w| w[1].0 - w[0].0).collect();
    if steps.iter().any(|d| !(d.is_finite() && *d > 0.0)) {
        fail(format!(
            "{}: the time column must increase strictly",
            path.display()
        ));
    }
    steps.sort_by(f64::total_cmp);
    let h = steps[steps.len() / 2];
    let mut out = Vec::with_capacity(rows.len());
    for (k, r) in rows.iter().enumerate() {
        if k > 0 {
            let gap = (r.0 - rows[k - 1].0) / h;
            if (gap - gap.round()).abs() > 0.1 {
                fail(format!(
                    "{}: row {}: time step {} s is not a multiple of the sample period {h} s",
                    path.display(),
                    k + 2,
                    r.0 - rows[k - 1].0
                ));
            }
            for _ in 1..gap.round() as usize {
                out.push((1, f32::NAN, vec![f32::NAN; r.2.len()], f32::NAN));
            }
        }
        out.push((0, r.1, r.2.clone(), r.3));
    }
    (h, out)
}

/// Reads and checks the OCV table `path` in `f32`; returns its columns.
fn ocv_table(path: &Path) -> (Vec<f32>, Vec<f32>) {
    let (mut rd, headers) = open_csv(path);
    let find = |name: &str| headers.iter().position(|h| h.trim() == name);
    let (Some(cz), Some(cv)) = (find("soc"), find("ocv_v")) else {
        fail(format!(
            "{}: the header must have soc,ocv_v",
            path.display()
        ))
    };
    let (mut soc, mut ocv) = (Vec::new(), Vec::new());
    for (k, rec) in rd.records().enumerate() {
        let row = k + 2;
        let rec = rec.unwrap_or_else(|e| fail(format!("{}: row {row}: {e}", path.display())));
        soc.push(cell(path, row, "soc", rec.get(cz).unwrap_or("")));
        ocv.push(cell(path, row, "ocv_v", rec.get(cv).unwrap_or("")));
    }
    use estimator_core::battery::ocv::{OcvError, OcvTable};
    if let Err(e) = OcvTable::<f32, 4096>::new(&soc, &ocv) {
        let at = match e {
            OcvError::NonFinite { index }
            | OcvError::SocOutOfRange { index }
            | OcvError::NotIncreasing { index } => format!("row {}: ", index + 2),
            _ => String::new(),
        };
        fail(format!("{}: {at}{e} (in f32)", path.display()))
    }
    (soc, ocv)
}

/// Reads the parameter map `path` (the `--map-out` CSV of `host-sim
/// identify battery`), keeps its identifiable levels (each level left out
/// is one `cargo:warning`), sorts them and checks them in `f32` with the
/// core's own [`ParameterMap`](estimator_core::battery::map::ParameterMap).
/// Returns the levels as Rust expressions.
fn parameter_map(path: &Path) -> Vec<String> {
    use estimator_core::battery::map::{MapLevel, ParameterMap};
    use estimator_core::battery::CellParameters;
    let (mut rd, headers) = open_csv(path);
    let find = |name: &str| headers.iter().position(|h| h.trim() == name);
    let need = [
        "temperature_c",
        "soc",
        "r_i",
        "r_ct",
        "q",
        "alpha",
        "bv_a_v",
        "bv_i0_a",
        "ocv_offset_v",
        "identifiable",
    ];
    let cols: Vec<usize> = need
        .iter()
        .map(|n| {
            find(n).unwrap_or_else(|| {
                fail(format!(
                    "{}: no column {n} (a map has {}; found {})",
                    path.display(),
                    need.join(","),
                    headers.iter().collect::<Vec<_>>().join(",")
                ))
            })
        })
        .collect();
    let mut levels: Vec<MapLevel<f32>> = Vec::new();
    for (k, rec) in rd.records().enumerate() {
        let row = k + 2;
        let rec = rec.unwrap_or_else(|e| fail(format!("{}: row {row}: {e}", path.display())));
        let v = |j: usize| cell(path, row, need[j], rec.get(cols[j]).unwrap_or(""));
        let identifiable = rec.get(cols[9]).unwrap_or("").trim();
        let t = v(0);
        let bv_a = v(6);
        let level = MapLevel {
            temperature_c: (!t.is_nan()).then_some(t),
            soc: v(1),
            cell: CellParameters {
                r_i: v(2),
                r_ct: v(3),
                q: v(4),
                alpha: v(5),
                u_oc: if v(8).is_nan() { 0.0 } else { v(8) },
                // A linear level: no Butler–Volmer term.
                bv_a: if bv_a.is_nan() { 0.0 } else { bv_a },
                bv_i0: if bv_a.is_nan() { 1.0 } else { v(7) },
            },
        };
        if identifiable != "true" {
            println!(
                "cargo:warning={}: row {row} (SOC {}) left out: not identifiable",
                path.display(),
                level.soc
            );
        } else if !level.cell.is_physical() {
            println!(
                "cargo:warning={}: row {row} (SOC {}) left out: not a physical cell",
                path.display(),
                level.soc
            );
        } else {
            levels.push(level);
        }
    }
    let key = |l: &MapLevel<f32>| l.temperature_c.unwrap_or(f32::NEG_INFINITY);
    levels.sort_by(|a, b| key(a).total_cmp(&key(b)).then(a.soc.total_cmp(&b.soc)));
    if let Err(e) = ParameterMap::new(&levels) {
        fail(format!(
            "{}: {e} (identifiable levels, in f32)",
            path.display()
        ))
    }
    levels
        .iter()
        .map(|l| {
            let c = &l.cell;
            format!(
                "estimator_core::battery::map::MapLevel {{ temperature_c: {:?}, soc: {:?}, cell: estimator_core::battery::CellParameters {{ r_i: {:?}, r_ct: {:?}, q: {:?}, alpha: {:?}, u_oc: {:?}, bv_a: {:?}, bv_i0: {:?} }} }}",
                l.temperature_c, l.soc, c.r_i, c.r_ct, c.q, c.alpha, c.u_oc, c.bv_a, c.bv_i0
            )
        })
        .collect()
}

fn main() {
    let manifest = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("cargo sets this"));
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets this"));

    // ---- configuration ----
    let window = number("FRACBMS_WINDOW", 256, 16, 4096);
    let memory = number("FRACBMS_MEMORY", 64, 2, 1024);
    if memory + 8 > window + 1 {
        fail(format!(
            "FRACBMS_MEMORY={memory} needs a window of at least {} (FRACBMS_WINDOW={window})",
            memory + 7
        ));
    }
    let iterations = number("FRACBMS_ITERATIONS", 1, 1, 1000);
    let log_every = number("FRACBMS_LOG_EVERY", 100, 1, 1_000_000);
    let method = match var("FRACBMS_METHOD", "refined").as_str() {
        "refined" => "Method::Refined",
        "paper" => "Method::Paper",
        m => fail(format!("FRACBMS_METHOD={m}: must be paper or refined")),
    };
    let algorithm = match var("FRACBMS_ALGORITHM", "op").as_str() {
        a @ ("op" | "kt") => a.to_owned(),
        a => fail(format!("FRACBMS_ALGORITHM={a}: must be op or kt")),
    };
    let inject = match var("FRACBMS_INJECT", "none").as_str() {
        i @ ("none" | "panic" | "hardfault") => i.to_owned(),
        i => fail(format!(
            "FRACBMS_INJECT={i}: must be none, panic or hardfault"
        )),
    };
    let tail = match var("FRACBMS_TAIL", "0").as_str() {
        "0" => false,
        "1" => true,
        t => fail(format!("FRACBMS_TAIL={t}: must be 0 or 1")),
    };
    let slow_memory_s = var("FRACBMS_SLOW_MEMORY_S", "0");
    let slow_memory_s: f32 = match slow_memory_s.parse() {
        Ok(s) if s >= 0.0 && f32::is_finite(s) => s,
        _ => fail(format!(
            "FRACBMS_SLOW_MEMORY_S={slow_memory_s}: must be a number of seconds, 0 or more"
        )),
    };
    let bench = match var("FRACBMS_BENCH", "0").as_str() {
        "0" => false,
        "1" => true,
        b => fail(format!("FRACBMS_BENCH={b}: must be 0 or 1")),
    };
    let reset_at = var("FRACBMS_RESET_AT", "0");
    let reset_at: usize = reset_at.parse().unwrap_or_else(|_| {
        fail(format!(
            "FRACBMS_RESET_AT={reset_at}: must be a sample number"
        ))
    });
    let default_replay = manifest.join("data/cell-pulse.csv");
    let replay_path = PathBuf::from(var(
        "FRACBMS_REPLAY",
        default_replay.to_str().expect("UTF-8 path"),
    ));
    println!("cargo:rerun-if-changed={}", replay_path.display());
    let (h, records) = replay(&replay_path);
    let replay_cells = records.first().map_or(1, |r| r.2.len());
    let cells = number("FRACBMS_CELLS", replay_cells, 1, 256);
    if cells != replay_cells && env::var("CARGO_FEATURE_BOARD_QEMU").is_ok() {
        fail(format!(
            "FRACBMS_CELLS={cells}: the QEMU board replays {} with {replay_cells} cell(s)",
            replay_path.display()
        ));
    }
    if reset_at > 0 && reset_at >= records.len() {
        fail(format!(
            "FRACBMS_RESET_AT={reset_at}: the replay has {} sample periods",
            records.len()
        ));
    }
    println!("cargo:rerun-if-env-changed=FRACBMS_PERIOD_S");
    let period = match env::var("FRACBMS_PERIOD_S") {
        Err(_) => h,
        Ok(s) => match s.parse::<f64>() {
            Ok(p) if (1e-3..=3600.0).contains(&p) => p,
            _ => fail(format!(
                "FRACBMS_PERIOD_S={s}: must be a number of seconds in 0.001..=3600"
            )),
        },
    };

    let ocv_path = var("FRACBMS_OCV", "");
    let capacity = var("FRACBMS_CAPACITY_AH", "");
    let (ocv_soc, ocv_v, capacity_ah) = match (ocv_path.is_empty(), capacity.is_empty()) {
        (true, true) => (Vec::new(), Vec::new(), f32::NAN),
        (false, false) => {
            let p = PathBuf::from(&ocv_path);
            println!("cargo:rerun-if-changed={}", p.display());
            let c = match capacity.parse::<f32>() {
                Ok(c) if c.is_finite() && c > 0.0 => c,
                _ => fail(format!(
                    "FRACBMS_CAPACITY_AH={capacity}: must be a positive number of A·h"
                )),
            };
            let (z, v) = ocv_table(&p);
            (z, v, c)
        }
        (false, true) => fail("FRACBMS_OCV needs FRACBMS_CAPACITY_AH (A·h)".into()),
        (true, false) => fail("FRACBMS_CAPACITY_AH goes with FRACBMS_OCV=FILE.csv".into()),
    };

    // The prior (FRACBMS_PRIOR="r_i,r_ct,q,alpha[,bv_a,bv_i0]", e.g. from
    // the JSON of `host-sim identify battery` through `cargo xtask qemu
    // --prior`).
    let prior_s = var("FRACBMS_PRIOR", "");
    let prior = if prior_s.trim().is_empty() {
        "None".to_owned()
    } else {
        let v: Vec<f32> = prior_s
            .split(',')
            .map(|x| x.trim().parse::<f32>())
            .collect::<Result<_, _>>()
            .unwrap_or_else(|_| {
                fail(format!(
                    "FRACBMS_PRIOR={prior_s}: expected r_i,r_ct,q,alpha[,bv_a,bv_i0]"
                ))
            });
        let mut v = v;
        if v.len() == 4 {
            // A linear prior: no Butler–Volmer term.
            v.extend([0.0, 1.0]);
        }
        let ok = v.len() == 6
            && v.iter().all(|x| x.is_finite())
            && v[0] > 0.0
            && v[1] > 0.0
            && v[2] > 0.0
            && v[3] > 0.0
            && v[3] <= 1.0
            && v[4] >= 0.0
            && v[5] > 0.0;
        if !ok {
            fail(format!(
                "FRACBMS_PRIOR={prior_s}: expected four numbers r_i,r_ct,q,alpha (positive, alpha in (0, 1]) or six with bv_a ≥ 0, bv_i0 > 0"
            ));
        }
        format!(
            "Some([{:?}, {:?}, {:?}, {:?}, {:?}, {:?}])",
            v[0], v[1], v[2], v[3], v[4], v[5]
        )
    };
    // The parameter map (FRACBMS_MAP=map.csv, from `host-sim identify
    // battery --map-out` through `cargo xtask qemu --map`): the prior
    // follows the cell at the counted SOC and the sampled temperature.
    let map_path = var("FRACBMS_MAP", "");
    let map = if map_path.trim().is_empty() {
        Vec::new()
    } else {
        if prior != "None" {
            fail("FRACBMS_MAP and FRACBMS_PRIOR: give one prior, a map or a fit".into());
        }
        let p = PathBuf::from(&map_path);
        println!("cargo:rerun-if-changed={}", p.display());
        parameter_map(&p)
    };
    let model = match var("FRACBMS_MODEL", "linear").as_str() {
        "linear" => "Linear",
        "butler-volmer" => "ButlerVolmer",
        m => fail(format!(
            "FRACBMS_MODEL={m}: must be linear or butler-volmer"
        )),
    };

    let mut cfg = String::new();
    let _ = writeln!(
        cfg,
        "// Generated by build.rs from FRACBMS_* (do not edit).\n\
         /// Samples in the sliding window (`FRACBMS_WINDOW`).\n\
         pub const WINDOW: usize = {window};\n\
         /// Grünwald–Letnikov memory in samples (`FRACBMS_MEMORY`).\n\
         pub const MEMORY: usize = {memory};\n\
         /// Iterations run after each sample (`FRACBMS_ITERATIONS`).\n\
         pub const ITERATIONS_PER_SAMPLE: u16 = {iterations};\n\
         /// Log the estimate every this many samples (`FRACBMS_LOG_EVERY`).\n\
         pub const LOG_EVERY: u32 = {log_every};\n\
         /// Identification method (`FRACBMS_METHOD`).\n\
         pub const METHOD: estimator_core::battery::online::Method = estimator_core::battery::online::{method};\n\
         /// The paper's algorithm requested (`FRACBMS_ALGORITHM`); for the battery\n\
         /// regression KT-2S-GI and 2S-OP-GI coincide (docs/firmware.md).\n\
         pub const ALGORITHM: &str = \"{algorithm}\";\n\
         /// A fault injected at start-up to test the fault exits (`FRACBMS_INJECT`:\n\
         /// none, panic, hardfault).\n\
         pub const INJECT: &str = \"{inject}\";\n\
         /// Cost measurement (`FRACBMS_BENCH=1`, `cargo xtask bench-target`): the\n\
         /// end-of-run check asks only that every sample period was pushed, not\n\
         /// for a physical estimate.\n\
         pub const BENCH: bool = {bench};\n\
         /// Sample period of the replay record (s).\n\
         pub const REPLAY_PERIOD_S: f32 = {h:?};\n\
         /// Sample period of the estimator and of a live board's timer (s):\n\
         /// `FRACBMS_PERIOD_S`, default the replay record's period.\n\
         pub const SAMPLE_PERIOD_S: f32 = {period:?};\n\
         /// Sample periods in the replay record (dropped rows included).\n\
         pub const REPLAY_LEN: usize = {};\n\
         /// Series cells the firmware estimates: `FRACBMS_CELLS`, default the\n\
         /// replay record's (`voltage_v`: 1; `cell_1_v,…,cell_N_v`: N).\n\
         pub const CELLS: usize = {cells};\n\
         /// Cells in the replay record.\n\
         pub const REPLAY_CELLS: usize = {replay_cells};\n\
         /// The QEMU board saves its snapshot and resets at this sample\n\
         /// period, then restores and replays on from it (`FRACBMS_RESET_AT`,\n\
         /// `cargo xtask qemu --reset-at N`; `None`: no reset).\n\
         pub const RESET_AT: Option<usize> = {reset_at};\n",
        records.len(),
        reset_at = if reset_at == 0 {
            "None".to_owned()
        } else {
            format!("Some({reset_at})")
        }
    );
    let list = |x: &[f32]| {
        x.iter()
            .map(|v| format!("{v:?}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let _ = writeln!(
        cfg,
        "/// Points of the cell's OCV table (`FRACBMS_OCV`; 0: none, constant U_oc).\n\
         pub const OCV_POINTS: usize = {n};\n\
         /// The OCV table's state-of-charge column (flash).\n\
         pub static OCV_SOC: [f32; {n}] = [{}];\n\
         /// The OCV table's voltage column (V, flash).\n\
         pub static OCV_V: [f32; {n}] = [{}];\n\
         /// The cell's capacity (A·h, `FRACBMS_CAPACITY_AH`; NaN without a table).\n\
         pub const CAPACITY_AH: f32 = {};\n\
         /// The prior's centre `[R_i, R_ct, Q, α, a, i₀]` (`FRACBMS_PRIOR`; `None`: no\n\
         /// prior; `a = 0` for a linear one).\n\
         pub const PRIOR: Option<[f32; 6]> = {prior};\n\
         /// The parameter map's identifiable levels (`FRACBMS_MAP`; empty: no map),\n\
         /// sorted by temperature, then SOC (flash).\n\
         pub static MAP: [estimator_core::battery::map::MapLevel<f32>; {m}] = [{map_list}];\n\
         /// The short-memory correction: the taps beyond the memory\n\
         /// (`FRACBMS_TAIL=1`, `BatterySettings::tail`).\n\
         pub const TAIL: bool = {tail};\n\
         /// The memory (s) of the slow part carried across windows\n\
         /// (`FRACBMS_SLOW_MEMORY_S`, `OnlineSettings::slow_memory_s`; 0: off).\n\
         pub const SLOW_MEMORY_S: f32 = {slow_memory_s:?};\n\
         /// The cell model the window fits (`FRACBMS_MODEL`).\n\
         pub const MODEL: estimator_core::battery::CellModel = estimator_core::battery::CellModel::{model};",
        list(&ocv_soc),
        list(&ocv_v),
        if capacity_ah.is_nan() {
            "f32::NAN".to_owned()
        } else {
            format!("{capacity_ah:?}")
        },
        n = ocv_soc.len(),
        m = map.len(),
        map_list = map.join(", "),
    );
    fs::write(out.join("config.rs"), cfg).expect("write config.rs");
    let mut bin = Vec::with_capacity((12 + 4 * replay_cells) * records.len());
    for (flags, i, v, t) in &records {
        bin.extend_from_slice(&flags.to_le_bytes());
        bin.extend_from_slice(&i.to_le_bytes());
        for x in v {
            bin.extend_from_slice(&x.to_le_bytes());
        }
        bin.extend_from_slice(&t.to_le_bytes());
    }
    fs::write(out.join("replay.bin"), bin).expect("write replay.bin");

    // ---- linking (the target only) ----
    println!("cargo:rerun-if-changed=build.rs");
    if env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        let board = if env::var_os("CARGO_FEATURE_BOARD_STM32L452").is_some() {
            manifest.join("boards/stm32l452.x")
        } else {
            manifest.join("boards/mps2-an386.x")
        };
        let root = manifest.join("../memory.x");
        println!("cargo:rerun-if-changed={}", board.display());
        println!("cargo:rerun-if-changed={}", root.display());
        fs::copy(&board, out.join("fracbms-board.x")).expect("copy the board's memory map");
        fs::copy(&root, out.join("memory.x")).expect("copy memory.x");
        println!("cargo:rustc-link-search={}", out.display());
        println!("cargo:rustc-link-arg-bins=--nmagic");
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    }
}
