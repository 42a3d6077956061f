//! Many records at once: `identify battery --input DIR_OR_GLOB`, and the
//! Python face's files and fleets.
//!
//! This module owns which files an input names ([`expand_inputs`]), the
//! one-row-per-file summary ([`FileSummary`], its CSV
//! [`SUMMARY_HEADER`]) and the pool that fits the files on all cores
//! ([`identify_many`]). Each file is fitted exactly as a single
//! `identify battery` run fits it ([`crate::identify::record::battery_file`],
//! with the map of [`crate::identify::map::battery_file`] when asked), so a
//! file's row does not depend on the other files, on the number of threads
//! or on the machine that fitted it.
//!
//! A file that cannot be read or fitted gives a row with `status` `error`
//! and its one-line message; the other files go on. A panic in one file's
//! fit is caught and reported the same way (kind `internal`).
//!
//! It must not touch the fits themselves (those are
//! [`crate::identify::battery`]'s and [`crate::identify::map`]'s) nor how a
//! face reports progress (the CLI prints a line per file; Python returns
//! rows).
//!
//! ```
//! use fracbms_host::identify::record::BatteryFitOptions;
//! use fracbms_host::identify::many::{expand_inputs, identify_many, ManyOptions};
//!
//! // Two records, one of them not a record at all.
//! let dir = std::env::temp_dir().join(format!("fracbms-many-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir)?;
//! let mut csv = String::from("time_s,current_a,voltage_v\n");
//! for l in 0..400 {
//!     let i = if (l / 25) % 2 == 0 { 2.0 } else { -2.0 };
//!     // A resistive cell: 3.7 V + 50 mΩ·I, with a little relaxation.
//!     let v = 3.7 + 0.05 * i + 0.002 * ((l % 25) as f64 / 25.0) * i;
//!     csv.push_str(&format!("{l},{i},{v}\n"));
//! }
//! std::fs::write(dir.join("a.csv"), &csv)?;
//! std::fs::write(dir.join("b.csv"), "not,a,record\n")?;
//!
//! let files = expand_inputs(&dir)?;
//! assert_eq!(files.len(), 2);
//! let o = ManyOptions { jobs: Some(2), ..ManyOptions::default() };
//! let rows = identify_many(&files, &BatteryFitOptions::default(), &o, |_| {});
//! assert_eq!(rows[0].status, "ok");
//! assert!((rows[0].r_i.unwrap() - 0.05).abs() < 0.01);
//! assert_eq!(rows[1].status, "error");
//! assert!(rows[1].error.as_deref().unwrap().contains("b.csv"));
//! # std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::error::{Error, ErrorKind, Result};
use crate::identify::map::MapFit;
use crate::identify::record::{battery_file, BatteryFile, BatteryFitOptions};
use crate::map::MapOptions;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The extensions (any case) of the files a directory input takes: the
/// formats [`crate::cycler`] reads.
pub const RECORD_EXTENSIONS: [&str; 4] = ["csv", "txt", "tsv", "mat"];

/// Whether `input` is a glob pattern rather than a path: it contains `*`,
/// `?` or `[` and no file of that name exists.
pub fn is_pattern(input: &Path) -> bool {
    !input.exists() && input.to_string_lossy().contains(['*', '?', '['])
}

/// Whether `input` names many files (a directory or a pattern) rather than
/// one record.
pub fn names_many(input: &Path) -> bool {
    input.is_dir() || is_pattern(input)
}

/// The files an input names, sorted by path:
/// - a directory: its files (not its subdirectories') whose extension is one
///   of [`RECORD_EXTENSIONS`];
/// - a glob pattern (`logs/*/cell-*.csv`, `**` for any depth): the files
///   that match it;
/// - a file: itself.
///
/// # Errors
/// [`ErrorKind::Io`] for a directory that cannot be read, a pattern that
/// does not parse, or an input that names no file.
pub fn expand_inputs(input: &Path) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    if input.is_dir() {
        let rd = std::fs::read_dir(input)
            .map_err(|e| Error::new(ErrorKind::Io, format!("{}: {e}", input.display())))?;
        for entry in rd {
            let p = entry
                .map_err(|e| Error::new(ErrorKind::Io, format!("{}: {e}", input.display())))?
                .path();
            let takes = p
                .extension()
                .and_then(|x| x.to_str())
                .is_some_and(|x| RECORD_EXTENSIONS.iter().any(|e| e.eq_ignore_ascii_case(x)));
            if takes && p.is_file() {
                files.push(p);
            }
        }
    } else if is_pattern(input) {
        let pattern = input.to_string_lossy();
        let paths = glob::glob(&pattern).map_err(|e| {
            Error::new(
                ErrorKind::Options,
                format!("{pattern}: not a valid pattern: {e}"),
            )
        })?;
        for p in paths {
            let p = p.map_err(|e| Error::new(ErrorKind::Io, format!("{pattern}: {e}")))?;
            if p.is_file() {
                files.push(p);
            }
        }
    } else {
        files.push(input.to_path_buf());
    }
    files.sort();
    if files.is_empty() {
        return Err(Error::new(
            ErrorKind::Io,
            format!(
                "{}: no record files there (extensions {})",
                input.display(),
                RECORD_EXTENSIONS.join(", ")
            ),
        ));
    }
    Ok(files)
}

/// How [`identify_many`] runs, beside each file's fit options.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ManyOptions {
    /// Also a parameter map per file (needs the OCV table and capacity).
    pub map: Option<MapOptions>,
    /// Threads (default: every core the process may use).
    pub jobs: Option<usize>,
}

/// The summary CSV's header, one column per [`FileSummary`] field in
/// order. An empty cell is a value the file does not have (a failed file's
/// parameters, a linear fit's Butler–Volmer term, a record without an OCV
/// table's SOC).
pub const SUMMARY_HEADER: [&str; 43] = [
    "file",
    "status",
    "error_kind",
    "error",
    "samples",
    "period_s",
    "method",
    "model",
    "r_i",
    "r_ct",
    "q",
    "alpha",
    "u_oc",
    "ocv_offset_v",
    "bv_a_v",
    "bv_i0_a",
    "rmse_v",
    "r_i_lo",
    "r_i_hi",
    "r_ct_lo",
    "r_ct_hi",
    "q_lo",
    "q_hi",
    "alpha_lo",
    "alpha_hi",
    "identifiable",
    "identifiable_reason",
    "converged",
    "stop_reason",
    "held_at_bounds",
    "rejected",
    "soc0",
    "soc_end",
    "temperature_c",
    "map_levels",
    "map_not_identifiable",
    "map_rmse_v",
    "fit_s",
    "paper_start",
    "bv_a_lo",
    "bv_a_hi",
    "bv_i0_lo",
    "bv_i0_hi",
];

/// One file's row of the summary: its fit, or why there is none.
///
/// Units and signs as everywhere in this crate (Ω, F·s^(α−1), V, s, °C,
/// current positive when charging). The intervals are the fit's 95 %
/// intervals (docs/trust.md).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct FileSummary {
    /// The file, as named by the input.
    pub file: String,
    /// `ok`, or `error` when the file gave no fit.
    pub status: &'static str,
    /// The error's kind (`io`, `data`, `options`, `estimator`,
    /// `internal`), or none.
    pub error_kind: Option<&'static str>,
    /// The one-line error, or none.
    pub error: Option<String>,
    /// Samples of the uniform record fitted.
    pub samples: Option<usize>,
    /// Its period (s).
    pub period_s: Option<f64>,
    /// `paper` or `refined`.
    pub method: Option<&'static str>,
    /// `linear` or `butler-volmer`: the model of the estimates.
    pub model: Option<&'static str>,
    /// R_i (Ω).
    pub r_i: Option<f64>,
    /// R_ct (Ω).
    pub r_ct: Option<f64>,
    /// Q (F·s^(α−1)).
    pub q: Option<f64>,
    /// α.
    pub alpha: Option<f64>,
    /// U_oc (V).
    pub u_oc: Option<f64>,
    /// The OCV offset ΔU (V), with an OCV table.
    pub ocv_offset_v: Option<f64>,
    /// Butler–Volmer a (V).
    pub bv_a_v: Option<f64>,
    /// Butler–Volmer i₀ (A).
    pub bv_i0_a: Option<f64>,
    /// RMSE of the model's free run against the record (V).
    pub rmse_v: Option<f64>,
    /// R_i's 95 % interval, low end.
    pub r_i_lo: Option<f64>,
    /// R_i's 95 % interval, high end.
    pub r_i_hi: Option<f64>,
    /// R_ct's 95 % interval, low end.
    pub r_ct_lo: Option<f64>,
    /// R_ct's 95 % interval, high end.
    pub r_ct_hi: Option<f64>,
    /// Q's 95 % interval, low end.
    pub q_lo: Option<f64>,
    /// Q's 95 % interval, high end.
    pub q_hi: Option<f64>,
    /// α's 95 % interval, low end.
    pub alpha_lo: Option<f64>,
    /// α's 95 % interval, high end.
    pub alpha_hi: Option<f64>,
    /// The fit can be trusted (docs/trust.md).
    pub identifiable: Option<bool>,
    /// Why not.
    pub identifiable_reason: Option<String>,
    /// The refinement converged.
    pub converged: Option<bool>,
    /// What ended the refinement.
    pub stop_reason: Option<&'static str>,
    /// Parameters at a bound of the search, `;`-separated.
    pub held_at_bounds: Option<String>,
    /// Rows rejected and substituted.
    pub rejected: Option<u32>,
    /// SOC at the start (with an OCV table).
    pub soc0: Option<f64>,
    /// SOC at the end (with an OCV table).
    pub soc_end: Option<f64>,
    /// The record's temperature (°C): the temperature column's mean, or
    /// the map's.
    pub temperature_c: Option<f64>,
    /// With a map: its levels.
    pub map_levels: Option<usize>,
    /// With a map: the levels not identifiable.
    pub map_not_identifiable: Option<usize>,
    /// With a map: the map model's RMSE over the whole record (V); none
    /// when no level is identifiable.
    pub map_rmse_v: Option<f64>,
    /// Wall time of this file's read and fit (s); the only field that
    /// depends on the machine.
    pub fit_s: f64,
    /// What became of the paper regression's start (the JSON's
    /// `paper_start`: `used`, `outside_bounds`, `no_estimate`,
    /// `regression_failed`, `not_run`; empty with `--method paper`).
    pub paper_start: Option<&'static str>,
    /// The Butler–Volmer term's `a`, 95 % interval, low end (V; given,
    /// not judged: docs/trust.md).
    pub bv_a_lo: Option<f64>,
    /// The term's `a`, 95 % interval, high end (V).
    pub bv_a_hi: Option<f64>,
    /// The term's `i₀`, 95 % interval, low end (A).
    pub bv_i0_lo: Option<f64>,
    /// The term's `i₀`, 95 % interval, high end (A).
    pub bv_i0_hi: Option<f64>,
}

fn cell(x: Option<f64>) -> String {
    x.map_or_else(String::new, |v| format!("{v}"))
}

impl FileSummary {
    /// A failed file's row.
    pub fn failed(file: &Path, e: &Error, fit_s: f64) -> Self {
        FileSummary {
            file: file.display().to_string(),
            status: "error",
            error_kind: Some(e.kind().as_str()),
            error: Some(e.to_string()),
            fit_s,
            ..FileSummary::default()
        }
    }

    /// The row of a fitted file (and its map, if any).
    pub fn fitted(file: &Path, f: &BatteryFile, map: Option<&MapFit>, fit_s: f64) -> Self {
        let j = &f.result.json;
        let c = j.confidence.as_ref();
        let temperature_c = map
            .and_then(|m| m.map.rows.first().and_then(|r| r.temperature_c))
            .or_else(|| {
                f.temperature.as_deref().and_then(|t| {
                    let n = t.iter().filter(|x| x.is_finite()).count();
                    (n > 0).then(|| {
                        let mean = t.iter().filter(|x| x.is_finite()).sum::<f64>() / n as f64;
                        (mean * 10.0).round() / 10.0
                    })
                })
            });
        FileSummary {
            file: file.display().to_string(),
            status: "ok",
            error_kind: None,
            error: None,
            samples: Some(f.record.time.len()),
            period_s: Some(f.record.h),
            method: Some(j.method),
            model: Some(j.model),
            r_i: Some(j.r_i),
            r_ct: Some(j.r_ct),
            q: Some(j.q),
            alpha: Some(j.alpha),
            u_oc: Some(j.u_oc),
            ocv_offset_v: j.ocv_offset_v,
            bv_a_v: j.bv_a_v,
            bv_i0_a: j.bv_i0_a,
            rmse_v: Some(j.rmse_v),
            r_i_lo: c.map(|c| c.r_i[0]),
            r_i_hi: c.map(|c| c.r_i[1]),
            r_ct_lo: c.map(|c| c.r_ct[0]),
            r_ct_hi: c.map(|c| c.r_ct[1]),
            q_lo: c.map(|c| c.q[0]),
            q_hi: c.map(|c| c.q[1]),
            alpha_lo: c.map(|c| c.alpha[0]),
            alpha_hi: c.map(|c| c.alpha[1]),
            identifiable: Some(j.identifiable),
            identifiable_reason: j.identifiable_reason.clone(),
            converged: Some(j.converged),
            stop_reason: j.stop_reason,
            held_at_bounds: j.held_at_bounds.as_ref().map(|b| b.join(";")),
            rejected: Some(j.rejected),
            soc0: j.soc0,
            soc_end: j.soc_end,
            temperature_c,
            map_levels: map.map(|m| m.map.rows.len()),
            map_not_identifiable: map
                .map(|m| m.map.rows.iter().filter(|r| !r.identifiable).count()),
            // None without an identifiable level (no map model to run).
            map_rmse_v: map.map(|m| m.rmse_v).filter(|x| x.is_finite()),
            fit_s,
            paper_start: j.paper_start,
            bv_a_lo: c.and_then(|c| c.bv_a).map(|x| x[0]),
            bv_a_hi: c.and_then(|c| c.bv_a).map(|x| x[1]),
            bv_i0_lo: c.and_then(|c| c.bv_i0).map(|x| x[0]),
            bv_i0_hi: c.and_then(|c| c.bv_i0).map(|x| x[1]),
        }
    }

    /// The row's cells in [`SUMMARY_HEADER`]'s order (floats in Rust's
    /// shortest round-trip form, so a reader gets the very `f64`).
    pub fn csv_cells(&self) -> Vec<String> {
        let s = |x: Option<&str>| x.unwrap_or("").to_owned();
        let b = |x: Option<bool>| x.map_or_else(String::new, |v| v.to_string());
        let n = |x: Option<usize>| x.map_or_else(String::new, |v| v.to_string());
        vec![
            self.file.clone(),
            self.status.to_owned(),
            s(self.error_kind),
            s(self.error.as_deref()),
            n(self.samples),
            cell(self.period_s),
            s(self.method),
            s(self.model),
            cell(self.r_i),
            cell(self.r_ct),
            cell(self.q),
            cell(self.alpha),
            cell(self.u_oc),
            cell(self.ocv_offset_v),
            cell(self.bv_a_v),
            cell(self.bv_i0_a),
            cell(self.rmse_v),
            cell(self.r_i_lo),
            cell(self.r_i_hi),
            cell(self.r_ct_lo),
            cell(self.r_ct_hi),
            cell(self.q_lo),
            cell(self.q_hi),
            cell(self.alpha_lo),
            cell(self.alpha_hi),
            b(self.identifiable),
            s(self.identifiable_reason.as_deref()),
            b(self.converged),
            s(self.stop_reason),
            s(self.held_at_bounds.as_deref()),
            self.rejected.map_or_else(String::new, |v| v.to_string()),
            cell(self.soc0),
            cell(self.soc_end),
            cell(self.temperature_c),
            n(self.map_levels),
            n(self.map_not_identifiable),
            cell(self.map_rmse_v),
            format!("{:.3}", self.fit_s),
            s(self.paper_start),
            cell(self.bv_a_lo),
            cell(self.bv_a_hi),
            cell(self.bv_i0_lo),
            cell(self.bv_i0_hi),
        ]
    }
}

/// Writes the summary CSV: [`SUMMARY_HEADER`], then one row per file.
///
/// # Errors
/// [`ErrorKind::Io`] when the file cannot be written.
pub fn write_summary_csv(path: &Path, rows: &[FileSummary]) -> Result<()> {
    crate::io::write_csv(
        path,
        &SUMMARY_HEADER,
        rows.iter().map(FileSummary::csv_cells),
    )
}

/// One file's fit: the record and fit, the map when `map` is given.
///
/// # Errors
/// As [`battery_file`] and [`crate::identify::map::battery_file`].
pub fn identify_file(
    file: &Path,
    o: &BatteryFitOptions,
    map: Option<&MapOptions>,
) -> Result<(BatteryFile, Option<MapFit>)> {
    match map {
        Some(m) => crate::identify::map::battery_file(file, o, m, false).map(|(f, m)| (f, Some(m))),
        None => battery_file(file, o, false).map(|f| (f, None)),
    }
}

/// One file's summary row: [`identify_file`] with its errors and panics
/// caught into the row. `then` sees the fit (to write a file's map or
/// JSON); an error it returns makes the row an error.
pub fn summarize_file(
    file: &Path,
    o: &BatteryFitOptions,
    map: Option<&MapOptions>,
    then: impl FnOnce(&BatteryFile, Option<&MapFit>) -> Result<()>,
) -> FileSummary {
    let start = Instant::now();
    let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let (f, m) = identify_file(file, o, map)?;
        then(&f, m.as_ref())?;
        Ok::<_, Error>(FileSummary::fitted(file, &f, m.as_ref(), 0.0))
    }));
    let fit_s = start.elapsed().as_secs_f64();
    match run {
        Ok(Ok(row)) => FileSummary { fit_s, ..row },
        Ok(Err(e)) => FileSummary::failed(file, &e, fit_s),
        Err(_) => FileSummary::failed(
            file,
            &Error::new(
                ErrorKind::Internal,
                format!("{}: internal error (please report it)", file.display()),
            ),
            fit_s,
        ),
    }
}

/// Checks the options every file shares once, before any file is read, so
/// that a wrong option is one error and not one per file.
///
/// # Errors
/// [`ErrorKind::Options`] (or [`ErrorKind::Io`], [`ErrorKind::Data`] for
/// the OCV table) as a single fit would report it.
pub fn check_options(o: &BatteryFitOptions, m: &ManyOptions) -> Result<()> {
    crate::trust::Limits::checked(o.voltage_min, o.voltage_max, o.current_limit)?;
    let spec = crate::ocv::OcvSpec::from_options(&o.ocv)?;
    if m.map.is_some() && spec.is_none() {
        return Err(Error::new(
            ErrorKind::Options,
            "a parameter map needs --ocv and --capacity-ah (each level's SOC moves; `host-sim ocv` reads the table from the test)",
        ));
    }
    if m.jobs == Some(0) {
        return Err(Error::new(
            ErrorKind::Options,
            "--jobs 0: must be at least 1",
        ));
    }
    Ok(())
}

/// Fits every file on a pool of [`ManyOptions::jobs`] threads (each with
/// the [`crate::worker::WORKER_STACK`] the estimators need) and returns
/// one row per file, in the order of `files`. `done` is called with each
/// row as its file finishes (from the pool's threads, in the order they
/// finish).
///
/// The rows do not depend on the number of threads: each file's fit is the
/// single-file fit.
pub fn identify_many(
    files: &[PathBuf],
    o: &BatteryFitOptions,
    m: &ManyOptions,
    done: impl Fn(&FileSummary) + Sync,
) -> Vec<FileSummary> {
    identify_many_with(files, o, m, |_, _, _, _| Ok(()), done)
}

/// [`identify_many`] with `then` called on each fitted file (its index in
/// `files`, path, fit and map) on the pool's thread, to write what the file
/// gives: the CLI's per-file JSON and maps.
pub fn identify_many_with(
    files: &[PathBuf],
    o: &BatteryFitOptions,
    m: &ManyOptions,
    then: impl Fn(usize, &Path, &BatteryFile, Option<&MapFit>) -> Result<()> + Sync,
    done: impl Fn(&FileSummary) + Sync,
) -> Vec<FileSummary> {
    use rayon::prelude::*;
    let threads = m
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .clamp(1, files.len().max(1));
    let one = |(k, f): (usize, &PathBuf)| {
        let row = summarize_file(f, o, m.map.as_ref(), |fit, map| then(k, f, fit, map));
        done(&row);
        row
    };
    match rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .stack_size(crate::worker::WORKER_STACK)
        .thread_name(|k| format!("fracbms-fit-{k}"))
        .build()
    {
        Ok(pool) => pool.install(|| files.par_iter().enumerate().map(one).collect()),
        // No pool (threads refused): one file after another on a worker.
        Err(_) => files
            .iter()
            .enumerate()
            .map(|(k, f)| {
                crate::worker::on_worker(|| Ok::<_, Error>(one((k, f)))).unwrap_or_else(|e| {
                    let row = FileSummary::failed(f, &e, 0.0);
                    done(&row);
                    row
                })
            })
            .collect(),
    }
}

/// The file each of `files` writes its per-file output to in `dir`: its
/// name without the extension, then `suffix` (`.json`, `-map.csv`).
///
/// # Errors
/// [`ErrorKind::Options`] when two files would write the same output (the
/// same name in two directories).
pub fn outputs_in(dir: &Path, files: &[PathBuf], suffix: &str) -> Result<Vec<PathBuf>> {
    let mut out: Vec<PathBuf> = Vec::with_capacity(files.len());
    for f in files {
        let stem = f
            .file_stem()
            .map_or_else(|| "record".into(), |s| s.to_string_lossy().into_owned());
        let p = dir.join(format!("{stem}{suffix}"));
        if let Some(k) = out.iter().position(|q| *q == p) {
            return Err(Error::new(
                ErrorKind::Options,
                format!(
                    "{} and {} would both write {}: give files with different names",
                    files[k].display(),
                    f.display(),
                    p.display()
                ),
            ));
        }
        out.push(p);
    }
    Ok(out)
}
