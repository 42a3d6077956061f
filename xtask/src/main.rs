//! `cargo xtask`: run the firmware under QEMU on any data file.
//!
//! * `cargo xtask qemu --input FILE.csv [--method paper|refined]
//!   [--algorithm op|kt] [--window L] [--memory M] [--iterations K]` builds
//!   the QEMU firmware for that `time_s,current_a,voltage_v` file, runs it
//!   under `qemu-system-arm -machine mps2-an386` (inside `timeout`), decodes
//!   its defmt log with `defmt-print` (to stderr) and prints the final
//!   estimates as the last line of stdout, one JSON object with the keys
//!   `r_i`, `r_ct`, `q`, `alpha`, `u_oc` (the window's fit), `samples`,
//!   `rejected`, and what the cell publishes: `published_r_i` …
//!   `published_alpha` (null when not identified), `r_i_status` …
//!   `alpha_status` (as the track's `*_status` columns) and
//!   `step_resistance_ohm`; with `--ocv`, the state of charge: `soc` (the
//!   SOC observer's, as the track's `soc`), `soc_coulomb`,
//!   `current_bias_a`, `capacity_ah`, `capacity_sigma_ah`,
//!   `capacity_identified`, `soc_sigma`, `soc_ocv_weight`,
//!   `ocv_offset_v`, and the state of power at the track's default
//!   horizons and limits: `sop_published`, `sop_discharge_a_10s`,
//!   `sop_charge_a_10s`, `pulse_v_10s`, `sop_discharge_a_30s`,
//!   `sop_charge_a_30s`, `pulse_v_30s`, `sop_uncertainty_v` (null where
//!   not published), `pulse_ratio_10s`, `pulse_ratio_30s` (null where the
//!   pulse voltage is the model's own, not corrected). A pack
//!   record (`time_s,current_a,cell_1_v,…,cell_N_v`) builds the pack
//!   firmware for its N cells and prints `{"cells": [{"cell", "r_i",
//!   "r_ct", "q", "alpha", "u_oc", "rejected", "flagged", and the same
//!   published, state-of-charge and state-of-power keys}, …], "samples",
//!   "rejected", "string_sop": {the state-of-power keys of the string: the
//!   weakest cell's currents, the sum of the cells' pulse voltages}}`;
//!   `--cells N` replays a pack of N cells made from a one-cell record.
//!   The build runs under a lock and QEMU runs a copy of the image of
//!   its own, so runs at once do not run each other's record.
//!   Both JSONs also carry the snapshot's keys (`restore_status`,
//!   `snapshot_bytes` …) and the stack's: `stack_init_bytes` (start-up,
//!   the task's initialisation included), `stack_high_water_bytes` (the
//!   sample loop) and `task_bytes`. The exit status is non-zero when the
//!   firmware failed.
//! * `cargo xtask run-elf ELF` runs a built image the same way (the
//!   target's cargo runner).
//! * `cargo xtask bench-target [--window L] [--memory M] [--iterations K]
//!   [--method paper|refined] [--input FILE.csv] [--ocv T.csv
//!   --capacity-ah C]` measures the firmware's
//!   cost under `qemu-system-arm -icount shift=0` (one instruction per ns
//!   of virtual time; the 25 MHz SysTick then counts 40 instructions per
//!   clock) and prints, as the last line, `{"window": L, "memory": M,
//!   "iterations_per_update": K, "instructions_per_update": N,
//!   "instructions_per_update_median": N, "longest_update": N,
//!   "instructions_per_iteration": N}` (means, the median and the longest
//!   over the updates that ran iterations; details on stderr). With `--cells N` it measures a pack of
//!   N cells made from the input record and prints `{"cells", "window",
//!   "memory", "iterations_per_update", "bytes_per_cell", "shared_bytes",
//!   "instructions_per_pack_update", "instructions_per_pack_update_median",
//!   "longest_pack_update", "instructions_per_cell_update"}`.
//! * `cargo xtask panic-sites [--features F] [--elf ELF] [--root NAME]
//!   [--sites] [--deny-reachable]` builds the release firmware and lists
//!   its panic call sites, marking those reachable from the per-sample step
//!   (`EstimatorTask::on_sample`) by the static call graph of the
//!   disassembly (docs/panic-paths.md); the last line is one JSON object.
//!
//! Errors are one line on stderr and exit status 1.

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

mod c_demo;
mod header;
mod image;
mod panic_sites;
mod summary;

use summary::{
    insert_persist, insert_published, insert_soc, insert_sop, insert_stack, int, number, pack_json,
    Summary,
};

#[derive(Parser)]
#[command(about = "fracbms helper commands", version)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Build the QEMU firmware for a data file, run it, print its estimates
    /// as one JSON line.
    Qemu(QemuArgs),
    /// Measure instructions per sample update and per iteration under QEMU
    /// (`-icount shift=0`); the last line is one JSON object.
    BenchTarget(BenchArgs),
    /// Run a built firmware image under QEMU and decode its log.
    RunElf {
        /// The image.
        elf: PathBuf,
        /// Seconds before QEMU is stopped.
        #[arg(long, default_value_t = 600)]
        timeout: u32,
    },
    /// Build the C example (examples/c/) against libfracbms.a for a data
    /// file, run it under QEMU, print its estimates as one JSON line.
    CDemo(c_demo::CDemoArgs),
    /// Generate the C header include/fracbms.h from estimator-ffi
    /// (cbindgen); `--check` fails when the committed one is stale.
    Header {
        /// Compare with the committed header instead of writing it.
        #[arg(long)]
        check: bool,
    },
    /// List the panic call sites of the release firmware image and those
    /// reachable from the per-sample step (static call graph of the
    /// disassembly); the last line is one JSON object.
    PanicSites(panic_sites::PanicSitesArgs),
}

#[derive(Clone, Copy, ValueEnum)]
enum Method {
    /// The paper's 2S-OP-GI alone.
    Paper,
    /// Output-error refinement started from 2S-OP-GI (most accurate).
    Refined,
}

#[derive(Clone, Copy, ValueEnum)]
enum Algorithm {
    /// 2S-OP-GI.
    Op,
    /// KT-2S-GI (coincides with 2S-OP-GI for the battery regression).
    Kt,
}

#[derive(clap::Args)]
struct QemuArgs {
    /// Record `time_s,current_a,voltage_v[,temperature_c]` (e.g. from
    /// `host-sim simulate battery`); gaps in time are dropped samples,
    /// empty cells NaN.
    #[arg(long)]
    input: PathBuf,
    /// Identification method.
    #[arg(long, value_enum, default_value = "refined")]
    method: Method,
    /// The paper's algorithm for the 2S-GI stage.
    #[arg(long, value_enum, default_value = "op")]
    algorithm: Algorithm,
    /// Sliding-window length L (samples).
    #[arg(long, default_value_t = 256)]
    window: usize,
    /// Grünwald–Letnikov memory M (samples).
    #[arg(long, default_value_t = 64)]
    memory: usize,
    /// Iterations per sample.
    #[arg(long, default_value_t = 1)]
    iterations: u16,
    /// Seconds before QEMU is stopped.
    #[arg(long, default_value_t = 600)]
    timeout: u32,
    /// Inject a fault at start-up (to test that it fails the run).
    #[arg(long, value_parser = ["none", "panic", "hardfault"], default_value = "none")]
    inject: String,
    /// Run QEMU with `-icount shift=0` (one instruction = 1 ns of virtual
    /// time, so the firmware's timer counts instructions).
    #[arg(long)]
    icount: bool,
    /// The cell's OCV table `soc,ocv_v` (built into the image): the
    /// estimator counts the state of charge and fits U_t − OCV(SOC).
    #[arg(long)]
    ocv: Option<PathBuf>,
    /// The cell's capacity (A·h), with --ocv.
    #[arg(long)]
    capacity_ah: Option<f64>,
    /// A prior on R_i, R_ct, Q and α (and a, i₀ of a Butler–Volmer fit):
    /// the JSON of `host-sim identify battery` (built into the image).
    #[arg(long, conflicts_with = "map")]
    prior: Option<PathBuf>,
    /// A parameter map (the `--map-out` CSV of `host-sim identify battery`)
    /// built into the image as a const table: the prior follows the map's
    /// cell at the counted SOC and the sampled temperature. Levels not
    /// identifiable are left out (one warning each).
    #[arg(long)]
    map: Option<PathBuf>,
    /// The cell model built into the image: `linear` or `butler-volmer`
    /// (R_i + a·asinh(I/i₀) + R_ct‖CPE).
    #[arg(long, value_parser = ["linear", "butler-volmer"], default_value = "linear")]
    model: String,
    /// The short-memory correction: the Grünwald–Letnikov taps beyond the
    /// memory (FRACBMS_TAIL=1; docs/pack.md).
    #[arg(long)]
    tail: bool,
    /// The memory (s) of the slow part carried across windows
    /// (FRACBMS_SLOW_MEMORY_S; as `online battery --slow-memory-s`).
    #[arg(long, value_name = "S", default_value_t = 0.0)]
    slow_memory_s: f64,
    /// Reset the board at sample period N (FRACBMS_RESET_AT): the firmware
    /// saves its snapshot into its flash region, resets, restores from it
    /// with the core's judgement and replays on from period N
    /// (docs/persistence.md). The JSON then has `restored_at`.
    #[arg(long, value_name = "N")]
    reset_at: Option<u32>,
    /// Replay a pack of this many cells made from a one-cell input: the
    /// input's voltage for every cell (cell k offset by k − 1 mV), as
    /// `bench-target --cells` (the image is built for N cells; the output
    /// is the pack's JSON for N > 1).
    #[arg(long, value_name = "N")]
    cells: Option<usize>,
    /// The cargo profile the image is built with. `release` (whole-program
    /// LTO) is the image that ships and that `bench-target` measures; the
    /// tests build `firmware-test` (no LTO, 16 codegen units: a third of
    /// the time per image, the same arithmetic).
    #[arg(long, default_value = "release")]
    profile: String,
    /// Build the cost-measurement image (no physical-estimate check).
    #[arg(skip)]
    bench: bool,
}

#[derive(clap::Args)]
struct BenchArgs {
    /// The record replayed (the cost depends little on the data, but the
    /// order search does depend on it).
    #[arg(long, default_value = "firmware/data/cell-pulse.csv")]
    input: PathBuf,
    /// Identification method: the paper's 2S-OP-GI (whose cost the goal is
    /// about) or the output-error refinement.
    #[arg(long, value_enum, default_value = "paper")]
    method: Method,
    /// Sliding-window length L (samples).
    #[arg(long, default_value_t = 256)]
    window: usize,
    /// Grünwald–Letnikov memory M (samples).
    #[arg(long, default_value_t = 64)]
    memory: usize,
    /// Iterations per sample update.
    #[arg(long, default_value_t = 5)]
    iterations: u16,
    /// Seconds before QEMU is stopped.
    #[arg(long, default_value_t = 1800)]
    timeout: u32,
    /// The cell model: `linear` or `butler-volmer`.
    #[arg(long, value_parser = ["linear", "butler-volmer"], default_value = "linear")]
    model: String,
    /// The short-memory correction (as `qemu --tail`).
    #[arg(long)]
    tail: bool,
    /// The slow part's memory (s; as `qemu --slow-memory-s`).
    #[arg(long, value_name = "S", default_value_t = 0.0)]
    slow_memory_s: f64,
    /// Measure a pack of this many cells: the input's voltage for every
    /// cell (cell k offset by k − 1 mV), all cells updated every period;
    /// the last line then is the pack's JSON.
    #[arg(long)]
    cells: Option<usize>,
    /// The cell's OCV table `soc,ocv_v` (as `qemu --ocv`): the cost with
    /// the count and the SOC observer.
    #[arg(long, requires = "capacity_ah")]
    ocv: Option<PathBuf>,
    /// The cell's capacity (A·h), with `--ocv`.
    #[arg(long, requires = "ocv")]
    capacity_ah: Option<f64>,
}

/// Writes a pack record of `cells` cells made from the one-cell record
/// `input` (`time_s,current_a,voltage_v`): cell k's voltage is the input's
/// plus (k − 1) mV. Returns its path (under the target directory).
fn pack_record(input: &Path, cells: usize) -> Result<PathBuf> {
    let text = std::fs::read_to_string(input)
        .with_context(|| format!("{}: cannot open", input.display()))?;
    let mut lines = text.lines();
    let head: Vec<&str> = lines
        .next()
        .unwrap_or("")
        .split(',')
        .map(str::trim)
        .collect();
    let col = |name: &str| {
        head.iter()
            .position(|h| *h == name)
            .with_context(|| format!("{}: no column {name}", input.display()))
    };
    let (ct, ci, cv) = (col("time_s")?, col("current_a")?, col("voltage_v")?);
    let mut out = String::from("time_s,current_a");
    for k in 1..=cells {
        out.push_str(&format!(",cell_{k}_v"));
    }
    out.push('\n');
    for (row, line) in lines.enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        let get = |c: usize| f.get(c).copied().unwrap_or("");
        let v: f64 = get(cv)
            .trim()
            .parse()
            .with_context(|| format!("{}: row {}: voltage_v", input.display(), row + 2))?;
        out.push_str(get(ct));
        out.push(',');
        out.push_str(get(ci));
        for k in 0..cells {
            out.push_str(&format!(",{:.9}", v + 1e-3 * k as f64));
        }
        out.push('\n');
    }
    let dir = target_dir().join("xtask");
    std::fs::create_dir_all(&dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    let path = dir.join(format!("pack-{cells}.csv"));
    std::fs::write(&path, out).with_context(|| format!("{}: cannot write", path.display()))?;
    Ok(path)
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives in the workspace")
        .to_path_buf()
}

fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root().join("target"), PathBuf::from)
}

/// Builds the QEMU image for `a`; returns its path.
fn build(a: &QemuArgs) -> Result<PathBuf> {
    let input = a
        .input
        .canonicalize()
        .with_context(|| format!("{}: cannot open", a.input.display()))?;
    let input = match a.cells {
        Some(n) if !(1..=256).contains(&n) => bail!("--cells {n}: must be in 1..=256"),
        Some(n) => pack_record(&input, n)?,
        None => input,
    };
    let ocv = match &a.ocv {
        Some(p) => Some(
            p.canonicalize()
                .with_context(|| format!("{}: cannot open", p.display()))?,
        ),
        None => None,
    };
    let prior = match &a.prior {
        None => String::new(),
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("{}: cannot open", p.display()))?;
            let j: serde_json::Value = serde_json::from_str(&text)
                .with_context(|| format!("{}: not JSON", p.display()))?;
            let mut v = Vec::new();
            for k in ["r_i", "r_ct", "q", "alpha"] {
                v.push(j[k].as_f64().with_context(|| {
                    format!(
                        "{}: no number `{k}` (expected the JSON of host-sim identify battery)",
                        p.display()
                    )
                })?);
            }
            // A Butler–Volmer fit adds a and i₀ (null for a linear one).
            if let (Some(x), Some(i0)) = (j["bv_a_v"].as_f64(), j["bv_i0_a"].as_f64()) {
                v.extend([x, i0]);
            }
            v.iter()
                .map(|x| format!("{x:e}"))
                .collect::<Vec<_>>()
                .join(",")
        }
    };
    let map = match &a.map {
        Some(p) => Some(
            p.canonicalize()
                .with_context(|| format!("{}: cannot open", p.display()))?,
        ),
        None => None,
    };
    match (&a.ocv, a.capacity_ah) {
        (Some(_), None) => bail!("--ocv needs --capacity-ah (the cell's capacity in A·h)"),
        (None, Some(_)) => bail!("--capacity-ah goes with --ocv FILE.csv"),
        _ => {}
    }
    let build = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
        .current_dir(root())
        .args([
            "build",
            "--quiet",
            "--profile",
            &a.profile,
            "-p",
            "firmware",
            "--target",
            "thumbv7em-none-eabihf",
        ])
        .env("FRACBMS_REPLAY", &input)
        .env("FRACBMS_WINDOW", a.window.to_string())
        .env("FRACBMS_MEMORY", a.memory.to_string())
        .env("FRACBMS_ITERATIONS", a.iterations.to_string())
        .env("FRACBMS_INJECT", &a.inject)
        .env("FRACBMS_BENCH", if a.bench { "1" } else { "0" })
        .env("FRACBMS_OCV", ocv.as_deref().unwrap_or(Path::new("")))
        .env("FRACBMS_PRIOR", &prior)
        .env("FRACBMS_MAP", map.as_deref().unwrap_or(Path::new("")))
        .env("FRACBMS_MODEL", &a.model)
        .env("FRACBMS_TAIL", if a.tail { "1" } else { "0" })
        .env("FRACBMS_SLOW_MEMORY_S", a.slow_memory_s.to_string())
        .env("FRACBMS_RESET_AT", a.reset_at.unwrap_or(0).to_string())
        .env(
            "FRACBMS_CAPACITY_AH",
            a.capacity_ah.map(|c| c.to_string()).unwrap_or_default(),
        )
        .env(
            "FRACBMS_METHOD",
            match a.method {
                Method::Paper => "paper",
                Method::Refined => "refined",
            },
        )
        .env(
            "FRACBMS_ALGORITHM",
            match a.algorithm {
                Algorithm::Op => "op",
                Algorithm::Kt => "kt",
            },
        )
        .stderr(Stdio::piped())
        .output()
        .context("cannot run cargo")?;
    if !build.status.success() {
        let err = String::from_utf8_lossy(&build.stderr);
        // build.rs reports a bad record or setting as one `error: …` line;
        // give the user that line alone.
        if let Some(line) = err
            .lines()
            .map(str::trim)
            .find(|l| l.starts_with("error: ") && !l.starts_with("error: failed to run"))
        {
            bail!("{}", line.trim_start_matches("error: "));
        }
        eprint!("{err}");
        bail!(
            "the firmware build failed for {} (see above)",
            input.display()
        );
    }
    // Cargo's `dev` profile builds into `debug/`; every other into its name.
    let dir = if a.profile == "dev" {
        "debug"
    } else {
        &a.profile
    };
    Ok(target_dir()
        .join("thumbv7em-none-eabihf")
        .join(dir)
        .join("firmware"))
}

/// The image built for `a`, copied to a path of this run's own
/// ([`image::own_copy`]).
fn built_image(a: &QemuArgs) -> Result<image::PrivateImage> {
    image::own_copy(&target_dir().join("qemu-images"), || build(a))
}

/// `timeout T qemu-system-arm` on the mps2-an386 board (Cortex-M4F) with
/// semihosting and no serial or monitor: add `-kernel ELF` (the Rust
/// firmware and the C example run on the same command line).
fn qemu_command(timeout: u32) -> Command {
    let mut qemu = Command::new("timeout");
    qemu.arg(timeout.to_string()).args([
        "qemu-system-arm",
        "-machine",
        "mps2-an386",
        "-cpu",
        "cortex-m4",
        "-nographic",
        "-monitor",
        "none",
        "-serial",
        "none",
        "-semihosting-config",
        "enable=on,target=native",
    ]);
    qemu
}

/// Runs `elf` under QEMU, echoes the decoded log to stderr, returns the
/// summary lines; fails when QEMU fails or times out.
fn run_elf(elf: &Path, timeout: u32, icount: bool) -> Result<Summary> {
    if !elf.exists() {
        bail!("{}: no such firmware image", elf.display());
    }
    let mut qemu = qemu_command(timeout);
    if icount {
        qemu.args(["-icount", "shift=0"]);
    }
    let mut qemu = qemu
        .arg("-kernel")
        .arg(elf)
        .stdout(Stdio::piped())
        .spawn()
        .context("cannot start qemu-system-arm (apt-get install qemu-system-arm)")?;
    let frames = qemu.stdout.take().context("qemu stdout")?;
    let mut print = Command::new("defmt-print")
        .arg("-e")
        .arg(elf)
        .args(["--log-format", "{L} {s}"])
        .stdin(Stdio::from(frames))
        .stdout(Stdio::piped())
        .spawn()
        .context("cannot start defmt-print (cargo install defmt-print --locked)")?;
    let mut summary = Summary::new();
    // A bench build prints one UPDATE line per timed update: gathered
    // (in order, comma-separated under UPDATE clocks), not echoed.
    let mut updates: Vec<String> = Vec::new();
    for line in BufReader::new(print.stdout.take().context("defmt-print stdout")?).lines() {
        let line = line.context("reading the decoded log")?;
        if let Some(v) = line.trim_start().strip_prefix("UPDATE clocks=") {
            updates.push(v.trim().to_owned());
            continue;
        }
        eprintln!("{line}");
        let mut words = line.split_whitespace();
        // println! lines carry no level; "{L} " leaves a leading space.
        if let Some(key) = words
            .next()
            .filter(|k| k.chars().all(|c| c.is_ascii_uppercase()))
        {
            let kv: BTreeMap<String, String> = words
                .filter_map(|w| w.split_once('='))
                .map(|(k, v)| (k.to_owned(), v.to_owned()))
                .collect();
            // A pack prints one CELL line per cell: keyed CELL1, CELL2, …
            let key = match (key, kv.get("cell")) {
                ("CELL", Some(n)) => format!("CELL{n}"),
                ("PUBLISHED", Some(n)) => format!("PUBLISHED{n}"),
                ("SOC", Some(n)) => format!("SOC{n}"),
                ("SOP", Some(n)) => format!("SOP{n}"),
                _ => key.to_owned(),
            };
            summary.insert(key, kv);
        }
    }
    if !updates.is_empty() {
        summary.insert(
            "UPDATE".into(),
            BTreeMap::from([("clocks".to_owned(), updates.join(","))]),
        );
    }
    let st = qemu.wait().context("waiting for qemu")?;
    let _ = print.wait();
    match st.code() {
        Some(0) => Ok(summary),
        Some(124) => bail!("QEMU was stopped after {timeout} s (timeout)"),
        Some(c) => bail!("the firmware failed under QEMU (exit status {c}; log above)"),
        None => bail!("QEMU was killed by a signal"),
    }
}

fn qemu(a: &QemuArgs) -> Result<()> {
    let elf = built_image(a)?;
    let s = run_elf(elf.path(), a.timeout, a.icount)?;
    if a.reset_at.is_some() {
        let restored = s
            .get("RESTORE")
            .and_then(|r| r.get("status"))
            .map(String::as_str);
        if restored != Some("restored") {
            bail!(
                "--reset-at: the firmware did not restore its snapshot after the reset (RESTORE status={})",
                restored.unwrap_or("missing")
            );
        }
    }
    if s.contains_key("PACK") {
        println!("{}", pack_json(&s)?);
        return Ok(());
    }
    let mut out = serde_json::Map::new();
    for key in ["r_i", "r_ct", "q", "alpha", "u_oc", "samples", "rejected"] {
        out.insert(key.into(), number(&s, "RESULT", key)?);
    }
    if a.ocv.is_some() {
        insert_soc(&s, 1, &mut out);
        insert_sop(&s, 1, &mut out);
    }
    if a.map.is_some() {
        for (key, name) in [
            ("levels", "map_levels"),
            ("prior_r_i", "map_prior_r_i"),
            ("prior_r_ct", "map_prior_r_ct"),
        ] {
            out.insert(name.into(), number(&s, "MAP", key)?);
        }
    }
    insert_published(&s, 1, &mut out);
    if a.reset_at.is_some() {
        out.insert("restored_at".into(), number(&s, "RESTORE", "resumed_at")?);
    }
    insert_persist(&s, &mut out);
    insert_stack(&s, &mut out);
    out.insert("model".into(), a.model.clone().into());
    for key in ["bv_a_v", "bv_i0_a"] {
        let v = if s.contains_key("BV") {
            number(&s, "BV", key)?
        } else {
            serde_json::Value::Null
        };
        out.insert(key.into(), v);
    }
    println!("{}", serde_json::Value::Object(out));
    Ok(())
}

fn bench_target(b: &BenchArgs) -> Result<()> {
    let input = if b.input.is_absolute() {
        b.input.clone()
    } else {
        root().join(&b.input)
    };
    let a = QemuArgs {
        input,
        cells: b.cells,
        method: b.method,
        algorithm: Algorithm::Op,
        window: b.window,
        memory: b.memory,
        iterations: b.iterations,
        timeout: b.timeout,
        inject: "none".into(),
        icount: true,
        ocv: b.ocv.clone(),
        capacity_ah: b.capacity_ah,
        prior: None,
        map: None,
        model: b.model.clone(),
        tail: b.tail,
        slow_memory_s: b.slow_memory_s,
        reset_at: None,
        // The cost is the shipped image's.
        profile: "release".into(),
        bench: true,
    };
    let elf = built_image(&a)?;
    let s = run_elf(elf.path(), a.timeout, true)?;
    let updates = int(&s, "COST", "updates")?;
    let iterations = int(&s, "COST", "iterations")?;
    let clocks = int(&s, "COST", "clocks")?;
    let max_clocks = int(&s, "COST", "max_clocks")?;
    let hz = int(&s, "COST", "clock_hz")?;
    if updates == 0 || iterations == 0 || hz == 0 {
        bail!("no sample update ran an iteration (record shorter than the memory?)");
    }
    // -icount shift=0: one instruction per ns of virtual time.
    let per_clock = 1e9 / hz as f64;
    let per_update = clocks as f64 * per_clock / updates as f64;
    let per_iteration = clocks as f64 * per_clock / iterations as f64;
    // The median update (of those that ran iterations), from each update's
    // clocks.
    let mut each: Vec<u64> = s
        .get("UPDATE")
        .and_then(|m| m.get("clocks"))
        .map(|v| v.split(',').filter_map(|x| x.parse().ok()).collect())
        .unwrap_or_default();
    each.sort_unstable();
    let median = match each.len() {
        0 => bail!("the firmware printed no UPDATE clocks= lines"),
        n if n % 2 == 1 => each[n / 2] as f64,
        n => (each[n / 2 - 1] + each[n / 2]) as f64 / 2.0,
    } * per_clock;
    let rows = b.window + 1 - b.memory;
    let flops = estimator_core::flops::battery_regression(rows, 1).total();
    eprintln!(
        "bench-target: method {}, {updates} updates, {iterations} iterations; \
         mean {per_update:.0} instructions per update, median {median:.0}, longest {:.0}; \
         {per_iteration:.0} per iteration (push included) = {:.1} instructions per \
         Table-1 flop ({flops} flops per 2S-OP-GI iteration over {rows} rows)",
        match b.method {
            Method::Paper => "paper (2S-OP-GI)",
            Method::Refined => "refined (output error)",
        },
        max_clocks as f64 * per_clock,
        per_iteration / flops as f64,
    );
    if matches!(b.method, Method::Refined) {
        let w = |k| int(&s, "WORK", k);
        let refined = w("updates")?.max(1) as f64;
        eprintln!(
            "bench-target: {} updates ran the refinement: {} iterations, {} window simulations \
             ({} trial steps), {} sensitivity passes; per update {:.2} simulations and {:.2} \
             sensitivity passes",
            w("updates")?,
            w("iterations")?,
            w("simulations")?,
            w("trials")?,
            w("linearizations")?,
            w("simulations")? as f64 / refined,
            w("linearizations")? as f64 / refined,
        );
    }
    if let Some(cells) = b.cells {
        let cell_updates = int(&s, "COST", "cell_updates")?.max(1);
        eprintln!(
            "bench-target: {cells} cells, {cell_updates} cell updates; {:.0} instructions per cell update",
            clocks as f64 * per_clock / cell_updates as f64
        );
        println!(
            "{}",
            serde_json::json!({
                "cells": cells,
                "window": b.window,
                "memory": b.memory,
                "iterations_per_update": b.iterations,
                "bytes_per_cell": int(&s, "MEM", "bytes_per_cell")?,
                "shared_bytes": int(&s, "MEM", "shared_bytes")?,
                "instructions_per_pack_update": per_update.round() as u64,
                "instructions_per_pack_update_median": median.round() as u64,
                "longest_pack_update": (max_clocks as f64 * per_clock).round() as u64,
                "instructions_per_cell_update": (clocks as f64 * per_clock / cell_updates as f64).round() as u64,
            })
        );
        return Ok(());
    }
    println!(
        "{}",
        serde_json::json!({
            "window": b.window,
            "memory": b.memory,
            "iterations_per_update": b.iterations,
            "instructions_per_update": per_update.round() as u64,
            "instructions_per_update_median": median.round() as u64,
            "longest_update": (max_clocks as f64 * per_clock).round() as u64,
            "instructions_per_iteration": per_iteration.round() as u64,
        })
    );
    Ok(())
}

fn main() {
    let cli = Cli::parse();
    let r = match &cli.cmd {
        Cmd::Qemu(a) => qemu(a),
        Cmd::BenchTarget(b) => bench_target(b),
        Cmd::RunElf { elf, timeout } => run_elf(elf, *timeout, false).map(|_| ()),
        Cmd::CDemo(a) => c_demo::run(a),
        Cmd::Header { check } => header::header(&root(), *check),
        Cmd::PanicSites(a) => panic_sites::run(a),
    };
    if let Err(e) = r {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
