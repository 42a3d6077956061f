//! `cargo xtask c-demo --input FILE.csv [--ocv OCV.csv --capacity-ah C]
//! [--timeout S]`: the C example `examples/c/` on QEMU.
//!
//! 1. Writes the record (and the OCV table) as `record.h` into
//!    `target/c-demo/`: a gap in time becomes NaN samples, an empty cell
//!    NaN, the sample period is the median time step (as `firmware/build.rs`).
//! 2. Builds the static library `libfracbms.a` for `thumbv7em-none-eabihf`
//!    (`cargo build -p estimator-ffi --release`).
//! 3. Compiles and links the C example with `arm-none-eabi-gcc` against it
//!    and `include/fracbms.h`; prints the image's section sizes (stderr).
//! 4. Runs it under `qemu-system-arm -machine mps2-an386` (inside
//!    `timeout`), echoes its semihosting output to stderr and prints its
//!    `RESULT` line as the last line of stdout, one JSON object with the
//!    keys `r_i`, `r_ct`, `q`, `alpha`, `u_oc`, `samples`, `rejected` (and
//!    `soc`, `ocv_offset_v` with a table), as `cargo xtask qemu`.

use super::{number, qemu_command, root, target_dir, Summary};
use anyhow::{bail, Context, Result};
use estimator_core::battery::ocv::{OcvError, OcvTable};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

const TARGET: &str = "thumbv7em-none-eabihf";
const GCC: &str = "arm-none-eabi-gcc";
const INSTALL_GCC: &str = "apt-get install -y --no-install-recommends gcc-arm-none-eabi";
/// The C sources of the example, in `examples/c/`.
const SOURCES: [&str; 3] = ["startup.c", "semihosting.c", "main.c"];

#[derive(clap::Args)]
pub struct CDemoArgs {
    /// Record `time_s,current_a,voltage_v` (other columns are ignored).
    #[arg(long)]
    input: PathBuf,
    /// The cell's OCV table `soc,ocv_v` (compiled into the image).
    #[arg(long)]
    ocv: Option<PathBuf>,
    /// The cell's capacity (A·h), with --ocv.
    #[arg(long)]
    capacity_ah: Option<f64>,
    /// Seconds before QEMU is stopped.
    #[arg(long, default_value_t = 600)]
    timeout: u32,
}

/// The cell's OCV table and capacity.
struct Ocv {
    soc: Vec<f32>,
    v: Vec<f32>,
    capacity_ah: f32,
}

pub fn run(a: &CDemoArgs) -> Result<()> {
    let ocv = match (&a.ocv, a.capacity_ah) {
        (Some(p), Some(c)) if c.is_finite() && c > 0.0 => {
            let (soc, v) = ocv_table(p)?;
            Some(Ocv {
                soc,
                v,
                capacity_ah: c as f32,
            })
        }
        (Some(_), Some(c)) => bail!("--capacity-ah {c}: must be a positive number of A·h"),
        (Some(_), None) => bail!("--ocv needs --capacity-ah (the cell's capacity in A·h)"),
        (None, Some(_)) => bail!("--capacity-ah goes with --ocv FILE.csv"),
        (None, None) => None,
    };
    if let (Some(o), Some(max)) = (&ocv, ocv_points_max()) {
        if o.soc.len() > max {
            bail!(
                "{}: {} points; the C interface takes at most {max} (FRACBMS_OCV_POINTS_MAX)",
                a.ocv.as_deref().unwrap_or(Path::new("")).display(),
                o.soc.len()
            );
        }
    }
    let (h, current, voltage) = record(&a.input)?;
    let dir = target_dir().join("c-demo");
    std::fs::create_dir_all(&dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    let header = record_h(&a.input, h, &current, &voltage, ocv.as_ref());
    let path = dir.join("record.h");
    std::fs::write(&path, header).with_context(|| format!("{}: cannot write", path.display()))?;

    let lib = build_library()?;
    let elf = compile(&dir, &lib)?;
    sizes(&elf);
    let s = run_qemu(&elf, a.timeout)?;
    let mut out = serde_json::Map::new();
    let mut keys = vec!["r_i", "r_ct", "q", "alpha", "u_oc", "samples", "rejected"];
    if ocv.is_some() {
        keys.extend(["soc", "ocv_offset_v"]);
    }
    for key in keys {
        out.insert(key.into(), number(&s, "RESULT", key)?);
    }
    println!("{}", serde_json::Value::Object(out));
    Ok(())
}

/// A minimal CSV reader for these numeric files: the header's column
/// indices of `names` and the data rows split at commas.
fn read_csv(path: &Path, names: &[&str]) -> Result<(Vec<usize>, Vec<Vec<String>>)> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot open", path.display()))?;
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let head: Vec<&str> = lines
        .next()
        .unwrap_or("")
        .split(',')
        .map(|h| h.trim().trim_start_matches('\u{feff}'))
        .collect();
    let cols = names
        .iter()
        .map(|n| {
            head.iter()
                .position(|h| h == n)
                .with_context(|| format!("{}: no column {n}", path.display()))
        })
        .collect::<Result<Vec<_>>>()?;
    let rows = lines
        .map(|l| l.split(',').map(|f| f.trim().to_owned()).collect())
        .collect();
    Ok((cols, rows))
}

/// Cell `col` of data row `k` (row k + 2 of the file) as `f32`; empty is NaN.
fn cell(path: &Path, k: usize, name: &str, row: &[String], col: usize) -> Result<f32> {
    let s = row.get(col).map_or("", String::as_str);
    if s.is_empty() {
        return Ok(f32::NAN);
    }
    s.parse().with_context(|| {
        format!(
            "{}: row {}, column {name}: {s:?} is not a number",
            path.display(),
            k + 2
        )
    })
}

/// Reads the record: the sample period (the median time step) and the
/// current and voltage of every period, NaN for the periods of a gap.
fn record(path: &Path) -> Result<(f64, Vec<f32>, Vec<f32>)> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot open", path.display()))?;
    if text.lines().next().is_some_and(|h| h.contains("cell_1_v")) {
        bail!(
            "{}: a pack record; the C example estimates one cell (time_s,current_a,voltage_v)",
            path.display()
        );
    }
    let (c, rows) = read_csv(path, &["time_s", "current_a", "voltage_v"])?;
    let mut t = Vec::with_capacity(rows.len());
    for (k, r) in rows.iter().enumerate() {
        let s = r.get(c[0]).map_or("", String::as_str);
        t.push(s.parse::<f64>().with_context(|| {
            format!(
                "{}: row {}, column time_s: {s:?} is not a number",
                path.display(),
                k + 2
            )
        })?);
    }
    if t.len() < 2 {
        bail!("{}: needs at least 2 data rows", path.display());
    }
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    if steps.iter().any(|d| !(d.is_finite() && *d > 0.0)) {
        bail!("{}: the time column must increase strictly", path.display());
    }
    steps.sort_by(f64::total_cmp);
    let h = steps[steps.len() / 2];
    let (mut current, mut voltage) = (Vec::new(), Vec::new());
    for (k, r) in rows.iter().enumerate() {
        if k > 0 {
            let gap = (t[k] - t[k - 1]) / h;
            if (gap - gap.round()).abs() > 0.1 {
                bail!(
                    "{}: row {}: time step {} s is not a multiple of the sample period {h} s",
                    path.display(),
                    k + 2,
                    t[k] - t[k - 1]
                );
            }
            for _ in 1..gap.round() as usize {
                current.push(f32::NAN);
                voltage.push(f32::NAN);
            }
        }
        current.push(cell(path, k, "current_a", r, c[1])?);
        voltage.push(cell(path, k, "voltage_v", r, c[2])?);
    }
    Ok((h, current, voltage))
}

/// Reads the OCV table `soc,ocv_v` and checks it in `f32` with the core's
/// own [`OcvTable`] (as `firmware/build.rs`).
fn ocv_table(path: &Path) -> Result<(Vec<f32>, Vec<f32>)> {
    let (c, rows) = read_csv(path, &["soc", "ocv_v"])?;
    let (mut soc, mut ocv) = (Vec::new(), Vec::new());
    for (k, r) in rows.iter().enumerate() {
        soc.push(cell(path, k, "soc", r, c[0])?);
        ocv.push(cell(path, k, "ocv_v", r, c[1])?);
    }
    if let Err(e) = OcvTable::<f32, 4096>::new(&soc, &ocv) {
        let at = match e {
            OcvError::NonFinite { index }
            | OcvError::SocOutOfRange { index }
            | OcvError::NotIncreasing { index } => format!("row {}: ", index + 2),
            _ => String::new(),
        };
        bail!("{}: {at}{e} (in f32)", path.display());
    }
    Ok((soc, ocv))
}

/// `FRACBMS_OCV_POINTS_MAX` of `include/fracbms.h` (None if unreadable).
fn ocv_points_max() -> Option<usize> {
    let text = std::fs::read_to_string(root().join("include/fracbms.h")).ok()?;
    text.lines().find_map(|l| {
        l.trim()
            .strip_prefix("#define FRACBMS_OCV_POINTS_MAX")?
            .trim()
            .parse()
            .ok()
    })
}

/// A C `float` literal of `x`.
fn literal(x: f32) -> String {
    if x.is_nan() {
        "RECORD_NAN".into()
    } else if x.is_infinite() {
        format!("{}__builtin_inff()", if x < 0.0 { "-" } else { "" })
    } else {
        // Debug prints the shortest decimal that reads back to the same f32.
        format!("{x:?}f")
    }
}

fn array(out: &mut String, name: &str, len: &str, x: &[f32]) {
    let _ = writeln!(out, "static const float {name}[{len}] = {{");
    for chunk in x.chunks(8) {
        let items: Vec<String> = chunk.iter().map(|&v| literal(v)).collect();
        let _ = writeln!(out, "    {},", items.join(", "));
    }
    let _ = writeln!(out, "}};");
}

/// The text of `record.h`.
fn record_h(input: &Path, h: f64, current: &[f32], voltage: &[f32], ocv: Option<&Ocv>) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "/* Generated by `cargo xtask c-demo` from {} (do not edit). */\n\
         #ifndef FRACBMS_RECORD_H_INCLUDED\n\
         #define FRACBMS_RECORD_H_INCLUDED\n\n\
         #define RECORD_NAN __builtin_nanf(\"\")\n\
         /* Sample period (s). */\n\
         #define RECORD_H {}\n\
         /* Sample periods (a gap in the record's time is NaN samples). */\n\
         #define RECORD_ROWS {}u\n",
        input.display(),
        literal(h as f32),
        current.len()
    );
    array(&mut out, "RECORD_CURRENT_A", "RECORD_ROWS", current);
    array(&mut out, "RECORD_VOLTAGE_V", "RECORD_ROWS", voltage);
    if let Some(ocv) = ocv {
        let _ = writeln!(
            out,
            "\n/* The cell's OCV table and capacity (A h). */\n\
             #define RECORD_OCV_POINTS {}u\n\
             #define RECORD_CAPACITY_AH {}",
            ocv.soc.len(),
            literal(ocv.capacity_ah)
        );
        array(&mut out, "RECORD_OCV_SOC", "RECORD_OCV_POINTS", &ocv.soc);
        array(&mut out, "RECORD_OCV_V", "RECORD_OCV_POINTS", &ocv.v);
    }
    out.push_str("\n#endif\n");
    out
}

/// Builds `libfracbms.a` for the Cortex-M4F; returns its path.
fn build_library() -> Result<PathBuf> {
    let build = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
        .current_dir(root())
        .args([
            "build",
            "--quiet",
            "--release",
            "-p",
            "estimator-ffi",
            "--target",
            TARGET,
        ])
        .stderr(Stdio::piped())
        .output()
        .context("cannot run cargo")?;
    if !build.status.success() {
        eprint!("{}", String::from_utf8_lossy(&build.stderr));
        bail!("building the static library (cargo build -p estimator-ffi --release --target {TARGET}) failed (see above)");
    }
    let lib = target_dir().join(TARGET).join("release/libfracbms.a");
    if !lib.exists() {
        bail!("{}: not built", lib.display());
    }
    Ok(lib)
}

/// Compiles and links the C example into `dir`; returns the image's path.
fn compile(dir: &Path, lib: &Path) -> Result<PathBuf> {
    let root = root();
    let include = root.join("include");
    if !include.join("fracbms.h").exists() {
        bail!(
            "{}: missing (the C header of estimator-ffi)",
            include.join("fracbms.h").display()
        );
    }
    let src = root.join("examples/c");
    let elf = dir.join("fracbms-c-demo.elf");
    let mut gcc = Command::new(GCC);
    gcc.args([
        "-mcpu=cortex-m4",
        "-mthumb",
        "-mfloat-abi=hard",
        "-mfpu=fpv4-sp-d16",
        "-Os",
        "-g",
        "-Wall",
        "-Wextra",
        "-Werror",
        "-ffreestanding",
        "-ffunction-sections",
        "-fdata-sections",
        "-nostdlib",
        "-nostartfiles",
        "-Wl,--gc-sections",
        // The Rust objects carry .note.GNU-stack, the C ones not: without
        // this ld warns about an executable stack (meaningless here).
        "-Wl,-z,noexecstack",
    ])
    .arg("-I")
    .arg(&include)
    .arg("-I")
    .arg(dir)
    .arg("-T")
    .arg(src.join("link.ld"));
    for s in SOURCES {
        gcc.arg(src.join(s));
    }
    gcc.arg(lib).arg("-lgcc").arg("-o").arg(&elf);
    let out = match gcc.output() {
        Ok(o) => o,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            bail!("{GCC} not found (install it: {INSTALL_GCC})")
        }
        Err(e) => bail!("cannot run {GCC}: {e}"),
    };
    eprint!("{}", String::from_utf8_lossy(&out.stderr));
    if !out.status.success() {
        bail!("compiling the C example failed (see above)");
    }
    Ok(elf)
}

/// Prints the image's section sizes to stderr (best effort).
fn sizes(elf: &Path) {
    let Ok(out) = Command::new("arm-none-eabi-size")
        .arg("-A")
        .arg(elf)
        .output()
    else {
        eprintln!("c-demo: arm-none-eabi-size not found; no section sizes");
        return;
    };
    let text = String::from_utf8_lossy(&out.stdout);
    let size = |name: &str| -> u64 {
        text.lines()
            .filter_map(|l| {
                let mut w = l.split_whitespace();
                if w.next() == Some(name) {
                    w.next()?.parse::<u64>().ok()
                } else {
                    None
                }
            })
            .sum()
    };
    eprintln!(
        "c-demo: {}: text {} B (flash, with the record), data {} B, bss {} B (the cell state buffer), stack {} B",
        elf.display(),
        size(".text") + size(".ARM.exidx"),
        size(".data"),
        size(".bss"),
        size(".stack")
    );
}

/// Runs `elf` under QEMU, echoes its output to stderr and returns its
/// `KEY a=b …` lines by key.
fn run_qemu(elf: &Path, timeout: u32) -> Result<Summary> {
    let mut qemu = qemu_command(timeout)
        .arg("-kernel")
        .arg(elf)
        // Semihosting console output (SYS_WRITE0) goes to QEMU's stderr.
        .stdout(Stdio::from(std::io::stderr()))
        .stderr(Stdio::piped())
        .spawn()
        .context("cannot start qemu-system-arm (apt-get install qemu-system-arm)")?;
    let mut summary = Summary::new();
    let mut error = None;
    let output = qemu.stderr.take().context("qemu stderr")?;
    for line in BufReader::new(output).lines() {
        let line = line.context("reading the C example's output")?;
        eprintln!("{line}");
        if line.starts_with("error: ") || line.starts_with("fault: ") {
            error.get_or_insert(line.clone());
        }
        let mut words = line.split_whitespace();
        if let Some(key) = words
            .next()
            .filter(|k| k.chars().all(|c| c.is_ascii_uppercase()))
        {
            let kv: BTreeMap<String, String> = words
                .filter_map(|w| w.split_once('='))
                .map(|(k, v)| (k.to_owned(), v.to_owned()))
                .collect();
            summary.insert(key.to_owned(), kv);
        }
    }
    let st = qemu.wait().context("waiting for qemu")?;
    match (st.code(), error) {
        (Some(0), _) => Ok(summary),
        (Some(124), _) => bail!("QEMU was stopped after {timeout} s (timeout)"),
        (Some(c), Some(e)) => bail!("the C example failed under QEMU (exit status {c}): {e}"),
        (Some(c), None) => bail!("the C example failed under QEMU (exit status {c}; output above)"),
        (None, _) => bail!("QEMU was killed by a signal"),
    }
}
