//! `simulate pack` and `online pack`: a series string of cells that share
//! one current.
//!
//! A pack record is `time_s,current_a,cell_1_v,…,cell_N_v` (current positive
//! when charging). `online pack` runs the core's
//! [`estimator_core::battery::pack::PackEstimator`], the same code the
//! firmware runs.

use crate::error::{IoContext, Result};
use crate::io::{self, OCV_POINTS};
use crate::online::Precision;
use crate::online::TrackOptions;
use crate::presets;
use crate::simulate::{battery_data, Current, OcvCurve};
use crate::{bail, err};
use estimator_core::battery::online::{OnlineSettings, PublishedParameters};
use estimator_core::battery::pack::{PackEstimator, PackSettings};
use estimator_core::battery::CellParameters;
use estimator_core::Real;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Most cells `online pack` takes (the host's pack capacity).
pub const MAX_CELLS: usize = 256;

/// A pack record.
pub struct PackRecord {
    /// Time (s).
    pub time: Vec<f64>,
    /// The pack current (A, positive when charging).
    pub current: Vec<f64>,
    /// Every cell's terminal voltage (V), cell 1 first.
    pub cells: Vec<Vec<f64>>,
    /// Sample period (s).
    pub h: f64,
}

/// The columns of a pack record with `cells` cells.
pub fn header(cells: usize) -> Vec<String> {
    let mut h = vec!["time_s".to_string(), "current_a".to_string()];
    h.extend((1..=cells).map(|k| format!("cell_{k}_v")));
    h
}

/// Reads a pack record: `time_s`, `current_a` and `cell_1_v`, `cell_2_v`, …
/// (as many as the header has, in order from 1).
pub fn read_pack(path: &Path) -> Result<PackRecord> {
    let first = std::fs::File::open(path)
        .io_context(|| format!("{}: cannot open", path.display()))
        .and_then(|f| {
            let mut line = String::new();
            std::io::BufRead::read_line(&mut std::io::BufReader::new(f), &mut line)
                .io_context(|| format!("{}: cannot read", path.display()))?;
            Ok(line)
        })?;
    let names: Vec<&str> = first.trim().split(',').map(str::trim).collect();
    let cells = (1..)
        .take_while(|k| names.contains(&format!("cell_{k}_v").as_str()))
        .count();
    if cells == 0 {
        bail!(
            Data,
            "{}: row 1: no column `cell_1_v` (expected header time_s,current_a,cell_1_v,…,cell_N_v)",
            path.display()
        );
    }
    let wanted = header(cells);
    let refs: Vec<&str> = wanted.iter().map(String::as_str).collect();
    let mut c = io::read_columns(path, &refs, None)?;
    let volts = c.data.split_off(2);
    let current = c.data.pop().unwrap_or_default();
    let time = c.data.pop().unwrap_or_default();
    let h = io::uniform_step(path, &time)?;
    Ok(PackRecord {
        time,
        current,
        cells: volts,
        h,
    })
}

/// The JSON file written beside `out` (`pack.csv` → `pack.json`).
pub fn truth_path(out: &Path) -> PathBuf {
    out.with_extension("json")
}

/// Each cell's parameters: the preset's `R_i`, `R_ct` and `Q`, each times
/// `1 + u` with `u` uniform in `[−spread, spread]` (seeded), and cell
/// `aged` (1-based) with `R_i`, `R_ct` times `aged_factor` on top.
pub fn pack_cells(
    base: &CellParameters<f64>,
    cells: usize,
    spread: f64,
    aged: Option<usize>,
    aged_factor: f64,
    seed: u64,
) -> Vec<CellParameters<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x005E_ED0F_CE11);
    (1..=cells)
        .map(|k| {
            let mut f = || 1.0 + spread * (2.0 * rng.random::<f64>() - 1.0);
            let mut p = CellParameters {
                r_i: base.r_i * f(),
                r_ct: base.r_ct * f(),
                q: base.q * f(),
                ..*base
            };
            if aged == Some(k) {
                p.r_i *= aged_factor;
                p.r_ct *= aged_factor;
            }
            p
        })
        .collect()
}

/// How `simulate pack` makes a pack record: every flag of the command.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimulatePack {
    /// Cells in series.
    pub cells: usize,
    /// `paper` (§6.2, ±150 A) or `cell` (18650-like, ±6 A).
    pub preset: String,
    /// Current profile: `pulse`, `hppc` or `drive`.
    pub profile: String,
    /// Spread of R_i, R_ct and Q between cells: each is the preset's times
    /// 1 + u, u uniform in [−S, S].
    pub spread: f64,
    /// An aged cell (1-based): its R_i and R_ct times `aged_factor`.
    pub aged: Option<usize>,
    /// How much larger the aged cell's R_i and R_ct are.
    pub aged_factor: f64,
    /// Voltage noise σ (V) of every cell; default: the preset's.
    pub sigma: Option<f64>,
    /// Current amplitude of the profile (A; default: the preset's).
    pub amplitude: Option<f64>,
    /// Number of samples.
    pub length: usize,
    /// Random seed (the spread and every cell's noise).
    pub seed: u64,
    /// Sample period (s).
    pub h: f64,
    /// Output CSV; the truth goes beside it ([`truth_path`]).
    pub out: PathBuf,
}

/// `simulate pack`: writes the pack record `a.out` and the truth beside it
/// ([`truth_path`]: `cells`: cell, r_i, r_ct, q, alpha, u_oc, aged).
pub fn simulate_file(a: &SimulatePack) -> Result<()> {
    let preset = presets::battery(&a.preset).ok_or_else(|| err!(Options, "unknown preset"))?;
    let profile = presets::profile(&a.profile).ok_or_else(|| err!(Options, "unknown profile"))?;
    if a.cells == 0 || a.cells > MAX_CELLS {
        bail!(Options, "--cells {}: must be in 1..={MAX_CELLS}", a.cells);
    }
    if a.length < 2 {
        bail!(Options, "--length must be at least 2");
    }
    if !(a.spread.is_finite() && (0.0..0.5).contains(&a.spread)) {
        bail!(Options, "--spread {}: must be in [0, 0.5)", a.spread);
    }
    if a.aged.is_some_and(|k| k == 0 || k > a.cells) {
        bail!(
            Options,
            "--aged {}: must be a cell in 1..={}",
            a.aged.unwrap_or(0),
            a.cells
        );
    }
    if !(a.aged_factor.is_finite() && a.aged_factor >= 1.0) {
        bail!(
            Options,
            "--aged-factor {}: must be at least 1",
            a.aged_factor
        );
    }
    let sigma = a.sigma.unwrap_or(preset.sigma);
    let amplitude = a.amplitude.unwrap_or(preset.amplitude);
    if !(amplitude.is_finite() && amplitude >= 0.0) {
        bail!(Options, "--amplitude {amplitude}: must be finite and ≥ 0");
    }
    let cells = pack_cells(
        &preset.cell,
        a.cells,
        a.spread,
        a.aged,
        a.aged_factor,
        a.seed,
    );
    let drive = Current {
        profile,
        amplitude,
        mean: 0.0,
    };
    let mut volts = Vec::with_capacity(a.cells);
    let mut current = Vec::new();
    for (k, p) in cells.iter().enumerate() {
        // Each cell its own noise.
        let seed = a.seed.wrapping_mul(1_000).wrapping_add(k as u64 + 1);
        let d = battery_data(p, drive, sigma, a.length, seed, a.h, OcvCurve::Constant)?;
        current = d.current;
        volts.push(d.voltage);
    }
    io::write_csv(
        &a.out,
        &header(a.cells)
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
        (0..a.length).map(|l| {
            let mut row = vec![format!("{}", l as f64 * a.h), format!("{}", current[l])];
            row.extend(volts.iter().map(|v| format!("{:.9}", v[l])));
            row
        }),
    )?;
    let truth = serde_json::json!({
        "cells": cells.iter().enumerate().map(|(k, p)| serde_json::json!({
            "cell": k + 1,
            "r_i": p.r_i,
            "r_ct": p.r_ct,
            "q": p.q,
            "alpha": p.alpha,
            "u_oc": p.u_oc,
            "aged": a.aged == Some(k + 1),
        })).collect::<Vec<_>>(),
        "preset": a.preset,
        "profile": a.profile,
        "spread": a.spread,
        "aged": a.aged,
        "aged_factor": a.aged_factor,
        "sigma": sigma,
        "length": a.length,
        "h": a.h,
        "seed": a.seed,
    });
    let json = truth_path(&a.out);
    io::write_atomic(&json, |w| {
        writeln!(w, "{}", serde_json::to_string_pretty(&truth)?)?;
        Ok(())
    })
}

/// One row of a pack track: a cell after a sample.
#[derive(Clone, Copy, Debug)]
pub struct PackRow {
    /// Time (s).
    pub t: f64,
    /// Cell (1-based).
    pub cell: usize,
    /// Its estimate after this sample (the window's fit).
    pub estimate: Option<CellParameters<f64>>,
    /// What it publishes, each parameter with its status.
    pub published: PublishedParameters<f64>,
    /// Its status name.
    pub status: &'static str,
    /// Its sample of this period was rejected.
    pub rejected: bool,
    /// It stands out from the pack's median (after this sample).
    pub flagged: bool,
}

/// What a pack run ended with: per cell, samples rejected.
#[derive(Clone, Debug, Default)]
pub struct PackSummary {
    /// Samples (periods).
    pub samples: u64,
    /// Rejected samples per cell.
    pub rejected: Vec<u32>,
    /// Iterations run (all cells).
    pub iterations: u64,
}

/// How `online pack` runs: the cell settings of `online battery` and the
/// schedule.
#[derive(Clone, Copy, Debug)]
pub struct PackOptions<'a> {
    /// The per-cell settings.
    pub track: TrackOptions<'a>,
    /// Cell updates per sample period.
    pub updates_per_period: u16,
    /// The flag threshold (fraction above the median).
    pub flag_ratio: f64,
}

/// Runs the pack estimator over `rec`, calling `sink` for every cell after
/// every sample.
pub fn track_pack(
    rec: &PackRecord,
    o: &PackOptions,
    sink: impl FnMut(PackRow) -> Result<()>,
) -> Result<PackSummary> {
    let (window, memory) = (o.track.window, o.track.memory);
    if memory == 0 || memory + 8 > window {
        bail!(
            Options,
            "--memory {memory}: must be in 1..={}",
            window.saturating_sub(8)
        );
    }
    if rec.cells.len() > MAX_CELLS {
        bail!(Data, "{} cells: at most {MAX_CELLS}", rec.cells.len());
    }
    if o.updates_per_period == 0 {
        bail!(Options, "--updates-per-period must be at least 1");
    }
    if !(o.flag_ratio.is_finite() && o.flag_ratio > 0.0) {
        bail!(Options, "--flag-ratio {}: must be positive", o.flag_ratio);
    }
    match o.track.precision {
        Precision::F64 => sized(&o.track.settings::<f64>(rec.h)?, o, rec, sink),
        Precision::F32 => sized(&o.track.settings::<f32>(rec.h)?, o, rec, sink),
    }
}

fn sized<T: Real>(
    s: &OnlineSettings<T, OCV_POINTS>,
    o: &PackOptions,
    rec: &PackRecord,
    sink: impl FnMut(PackRow) -> Result<()>,
) -> Result<PackSummary> {
    let mut ps = PackSettings::new(*s);
    ps.updates_per_period = o.updates_per_period;
    ps.flag_ratio = T::lit(o.flag_ratio);
    match o.track.window {
        64 => run::<T, 64>(&ps, rec, sink),
        128 => run::<T, 128>(&ps, rec, sink),
        256 => run::<T, 256>(&ps, rec, sink),
        512 => run::<T, 512>(&ps, rec, sink),
        1024 => run::<T, 1024>(&ps, rec, sink),
        w => bail!(
            Options,
            "--window {w}: must be one of 64, 128, 256, 512, 1024"
        ),
    }
}

fn run<T: Real, const N: usize>(
    s: &PackSettings<T, OCV_POINTS>,
    rec: &PackRecord,
    mut sink: impl FnMut(PackRow) -> Result<()>,
) -> Result<PackSummary> {
    let cells = rec.cells.len();
    let mut pack =
        Box::new(PackEstimator::<T, N, N, MAX_CELLS>::new(s, cells).map_err(crate::Error::from)?);
    let mut volts = vec![T::zero(); cells];
    let mut iterations = 0u64;
    for (l, (&t, &i)) in rec.time.iter().zip(&rec.current).enumerate() {
        for (v, c) in volts.iter_mut().zip(&rec.cells) {
            *v = T::lit(c[l]);
        }
        let r = pack
            .push(s, T::lit(i), &volts)
            .map_err(crate::Error::from)?;
        iterations += u64::from(r.iterations);
        let health = pack.health();
        for k in 0..cells {
            let c = pack.cell(k).ok_or_else(|| err!(Internal, "cell index"))?;
            sink(PackRow {
                t,
                cell: k + 1,
                estimate: c.estimate().map(|p| p.cast()),
                published: c.published().map(|v| v.to_f64()),
                status: c.status().as_str(),
                rejected: c.last_rejection().is_some(),
                flagged: health.is_some_and(|h| pack.is_flagged(s, &h, k)),
            })?;
        }
    }
    Ok(PackSummary {
        samples: rec.time.len() as u64,
        rejected: (0..cells)
            .map(|k| pack.cell(k).map_or(0, |c| c.counts().rejected()))
            .collect(),
        iterations,
    })
}

/// How `online pack` runs: every flag but the files. The default is the
/// CLI's.
#[derive(Clone, Debug, PartialEq)]
pub struct OnlinePack {
    /// Window length L (one of 64, 128, 256, 512, 1024).
    pub window: usize,
    /// Memory M (default L/4).
    pub memory: Option<usize>,
    /// Iterations per cell update.
    pub iterations_per_sample: u16,
    /// Cell updates per sample period, round robin (default: every cell
    /// every period).
    pub updates_per_period: Option<u16>,
    /// Flag a cell whose R_i or R_ct is above the pack's median by more
    /// than this fraction.
    pub flag_ratio: f64,
    /// f64, or f32 as the firmware runs it.
    pub precision: Precision,
    /// Where the model starts in the window.
    pub start: estimator_core::battery::Start,
    /// The short-memory correction.
    pub tail: bool,
}

impl Default for OnlinePack {
    fn default() -> Self {
        Self {
            window: 256,
            memory: None,
            iterations_per_sample: 1,
            updates_per_period: None,
            flag_ratio: 0.3,
            precision: Precision::F64,
            start: estimator_core::battery::Start::FromData,
            tail: false,
        }
    }
}

/// The header of the long-format track CSV `online pack` writes.
///
/// As `online battery`'s track: `r_i, r_ct, q, alpha` are what the cell
/// publishes (only what the data identify; empty otherwise), each with its
/// `*_status`; `window_*` is the window's fit, identified or not.
pub const PACK_TRACK_HEADER: &str = "time_s,cell,r_i,r_ct,q,alpha,u_oc,status,rejected,flagged,r_i_status,r_ct_status,q_status,alpha_status,window_r_i,window_r_ct,window_q,window_alpha";

/// `online pack`: reads the pack record `input`, runs the pack estimator
/// over it as `a` says and writes the long-format track to `out` (columns
/// [`PACK_TRACK_HEADER`], one row per cell and sample). Returns the
/// summary and the number of cells.
pub fn online_file(input: &Path, out: &Path, a: &OnlinePack) -> Result<(PackSummary, usize)> {
    let rec = read_pack(input)?;
    let memory = a.memory.unwrap_or(a.window / 4);
    let mut track = TrackOptions::new(a.window, memory);
    track.iterations_per_sample = a.iterations_per_sample;
    track.precision = a.precision;
    track.start = a.start;
    track.tail = a.tail;
    let o = PackOptions {
        track,
        updates_per_period: a.updates_per_period.unwrap_or(u16::MAX),
        flag_ratio: a.flag_ratio,
    };
    let f = |x: f64| format!("{x:.9e}");
    let mut res = Ok(PackSummary::default());
    io::write_atomic(out, |w| {
        writeln!(w, "{PACK_TRACK_HEADER}")?;
        res = track_pack(&rec, &o, |r| {
            let g = |x: Option<f64>| x.map(f).unwrap_or_default();
            let pb = &r.published;
            let statuses = pb.named().map(|(_, x)| x.status.as_str()).join(",");
            let e = r.estimate;
            writeln!(
                w,
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                r.t,
                r.cell,
                g(pb.r_i.value),
                g(pb.r_ct.value),
                g(pb.q.value),
                g(pb.alpha.value),
                g(e.map(|p| p.u_oc)),
                r.status,
                u8::from(r.rejected),
                u8::from(r.flagged),
                statuses,
                g(e.map(|p| p.r_i)),
                g(e.map(|p| p.r_ct)),
                g(e.map(|p| p.q)),
                g(e.map(|p| p.alpha)),
            )?;
            Ok(())
        });
        res.clone().map(|_| ())
    })?;
    Ok((res?, rec.cells.len()))
}
