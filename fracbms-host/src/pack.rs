//! `simulate pack` and `online pack`: a series string of cells that share
//! one current.
//!
//! A pack record is `time_s,current_a,cell_1_v,…,cell_N_v` (current positive
//! when charging). `online pack` runs the core's
//! [`estimator_core::battery::pack::PackEstimator`], the same code the
//! firmware runs.

use crate::error::{IoContext, Result};
use crate::io::{self, OCV_POINTS};
use crate::ocv::{CellOcv, OcvOptions};
use crate::online::power::{PowerOptions, PowerRow, ResolvedPower, MAX_HORIZONS};
use crate::online::schema::{self, column, fields, Column, Field, Value};
use crate::online::soc::{SocMode, SocOptions, SocRow, SOC_HEADER};
use crate::online::state::{read_state, record_clock, saved, write_state, StateIn};
use crate::online::TrackOptions;
use crate::online::{Precision, PublicationTally};
use crate::presets;
use crate::simulate::{battery_data, Current, OcvCurve};
use crate::{bail, err};
use estimator_core::battery::ocv::OcvModel;
use estimator_core::battery::online::{OnlineSettings, PublishedParameters};
use estimator_core::battery::pack::{PackEstimator, PackSettings};
use estimator_core::battery::snapshot::{Restoration, RestorePolicy};
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
    /// An OCV table (`soc,ocv_v`) every cell's open-circuit voltage follows
    /// as its charge moves (its own `Q` spread aside, one chemistry);
    /// `None`: the preset's constant `U_oc`.
    #[serde(default)]
    pub ocv: Option<PathBuf>,
    /// Every cell's SOC before the first sample (with `ocv`).
    #[serde(default = "default_soc0")]
    pub soc0: f64,
    /// Capacity (A·h) for the SOC (with `ocv`; default: the preset's).
    #[serde(default)]
    pub capacity_ah: Option<f64>,
    /// Output CSV; the truth goes beside it ([`truth_path`]).
    pub out: PathBuf,
}

fn default_soc0() -> f64 {
    0.9
}

/// `simulate pack`: writes the pack record `a.out` and the truth beside it
/// ([`truth_path`]: `cells`: cell, r_i, r_ct, q, alpha, u_oc, aged).
pub fn simulate_file(a: &SimulatePack) -> Result<()> {
    let preset = presets::battery(&a.preset).ok_or_else(|| err!(Options, "unknown preset"))?;
    let profile = presets::profile(&a.profile).ok_or_else(|| err!(Options, "unknown profile"))?;
    if a.cells == 0 || a.cells > MAX_CELLS {
        bail!(Options, "--cells {}: must be in 1..={MAX_CELLS}", a.cells);
    }
    crate::simulate::check_length(a.length, 2)?;
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
    let capacity_ah =
        crate::simulate::state_of_charge_options(a.soc0, a.capacity_ah, preset.capacity_ah)?;
    let table = a.ocv.as_deref().map(io::read_ocv).transpose()?;
    let curve = match &table {
        Some(table) => OcvCurve::Table {
            table,
            soc0: a.soc0,
            capacity_ah,
        },
        None => OcvCurve::Constant,
    };
    let mut volts = Vec::with_capacity(a.cells);
    let mut current = Vec::new();
    for (k, p) in cells.iter().enumerate() {
        // Each cell its own noise.
        let seed = a.seed.wrapping_mul(1_000).wrapping_add(k as u64 + 1);
        let d = battery_data(p, drive, sigma, a.length, seed, a.h, curve)?;
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
        "ocv": a.ocv,
        "soc0": table.as_ref().map(|_| a.soc0),
        "capacity_ah": table.as_ref().map(|_| capacity_ah),
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
    /// Its state of charge (with an OCV table): the count and the
    /// observer's, as `--soc` publishes them.
    pub soc: SocRow,
    /// Its state of power at each horizon (empty where its model is not
    /// published, or without voltage limits).
    pub power: [PowerRow; MAX_HORIZONS],
    /// The string's state of power after this sample (the same for every
    /// cell of the sample): the weakest cell's currents, the sum of the
    /// cells' pulse voltages; empty while any cell has none.
    pub string_power: [PowerRow; MAX_HORIZONS],
    /// Whether the cell started from a snapshot (`--state-in`).
    pub restoration: Restoration,
}

/// The columns of the long-format track `online pack` writes (`--out`)
/// and Python's `online_pack` returns, one row per cell and sample.
///
/// As `online battery`'s track ([`crate::online::schema::TRACK_COLUMNS`]):
/// `r_i, r_ct, q, alpha` are what the cell publishes (only what the data
/// identify; empty otherwise), each with its `*_status`; `window_*` is the
/// window's fit, identified or not; `rejected` and `flagged` are 0 or 1.
/// Then the cell's state of charge as `online battery`'s (`soc`, then
/// [`SOC_HEADER`], `capacity_status`; empty without `--ocv`), the cell's
/// state of power (`sop_discharge_a_{H}s`, `sop_charge_a_{H}s`,
/// `pulse_v_{H}s` for each of the run's horizons, then `sop_basis`,
/// `sop_uncertainty_v` and `sop_uncertainty_v_{H}s`) and
/// the string's (`pack_sop_discharge_a_{H}s`, `pack_sop_charge_a_{H}s`,
/// `pack_pulse_v_{H}s`: the weakest cell's currents and the sum of the
/// cells' pulse voltages, the same on every cell's row of a sample; then
/// `pack_sop_basis`, the least known cell's).
pub const PACK_COLUMNS: [Column<PackRow>; 28] = {
    use Value::{Flag, Index, Number, Power, Time, Word};
    [
        column("time_s", Time(|r| r.t)),
        column("cell", Index(|r| r.cell)),
        column("r_i", Number(|r| r.published.r_i.value)),
        column("r_ct", Number(|r| r.published.r_ct.value)),
        column("q", Number(|r| r.published.q.value)),
        column("alpha", Number(|r| r.published.alpha.value)),
        column("u_oc", Number(|r| r.estimate.map(|p| p.u_oc))),
        column("status", Word(|r| Some(r.status))),
        column("rejected", Flag(|r| r.rejected)),
        column("flagged", Flag(|r| r.flagged)),
        column(
            "r_i_status",
            Word(|r| Some(r.published.r_i.status.as_str())),
        ),
        column(
            "r_ct_status",
            Word(|r| Some(r.published.r_ct.status.as_str())),
        ),
        column("q_status", Word(|r| Some(r.published.q.status.as_str()))),
        column(
            "alpha_status",
            Word(|r| Some(r.published.alpha.status.as_str())),
        ),
        column("window_r_i", Number(|r| r.estimate.map(|p| p.r_i))),
        column("window_r_ct", Number(|r| r.estimate.map(|p| p.r_ct))),
        column("window_q", Number(|r| r.estimate.map(|p| p.q))),
        column("window_alpha", Number(|r| r.estimate.map(|p| p.alpha))),
        column("soc", Number(|r| r.soc.published())),
        column(SOC_HEADER[0], Number(|r| r.soc.columns()[0])),
        column(SOC_HEADER[1], Number(|r| r.soc.columns()[1])),
        column(SOC_HEADER[2], Number(|r| r.soc.columns()[2])),
        column(SOC_HEADER[3], Number(|r| r.soc.columns()[3])),
        column(SOC_HEADER[4], Number(|r| r.soc.columns()[4])),
        column(SOC_HEADER[5], Number(|r| r.soc.columns()[5])),
        column("capacity_status", Word(|r| Some(r.soc.capacity_status()))),
        column("", Power(|r| &r.power)),
        column("pack_", Power(|r| &r.string_power)),
    ]
};

/// The pack track's last column with `--state-in`: how the cell started
/// (`restored`, `soc_reread` or `clean`).
pub const PACK_RESTORATION: Column<PackRow> =
    column("restoration", Value::Word(|r| Some(r.restoration.as_str())));

/// The columns of `online pack`'s track at `horizons` (s): [`PACK_COLUMNS`],
/// and [`PACK_RESTORATION`] when `restoration`.
pub fn pack_fields(horizons: &[f64], restoration: bool) -> Vec<Field<PackRow>> {
    let mut out = fields(&PACK_COLUMNS, horizons);
    if restoration {
        out.extend(fields(&[PACK_RESTORATION], horizons));
    }
    out
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
    /// How [`PackOptions::state_in`]'s snapshot was taken.
    pub state_in: Option<StateIn>,
    /// The snapshot after the last sample ([`PackOptions::save_state`]).
    pub state_out: Option<Vec<u8>>,
    /// What the cells published, each cell's sample counted.
    pub published: PublicationTally,
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
    /// Every cell's SOC at the start (with an OCV table in `track.cell`;
    /// `None`: each cell's read by the core from its own first rested
    /// voltages, as the firmware does).
    pub soc0: Option<f64>,
    /// A snapshot to start from (the core's bytes; it overrides `soc0`).
    pub state_in: Option<&'a [u8]>,
    /// Save the snapshot after the last sample into the summary.
    pub save_state: bool,
}

/// Runs the pack estimator over `rec`, calling `sink` for every cell after
/// every sample.
pub fn track_pack(
    rec: &PackRecord,
    o: &PackOptions,
    sink: impl FnMut(PackRow) -> Result<()>,
) -> Result<PackSummary> {
    crate::online::check_window(o.track.window, o.track.memory)?;
    if rec.cells.len() > MAX_CELLS {
        bail!(Data, "{} cells: at most {MAX_CELLS}", rec.cells.len());
    }
    if o.updates_per_period == 0 {
        bail!(Options, "--updates-per-period must be at least 1");
    }
    if !(o.flag_ratio.is_finite() && o.flag_ratio > 0.0) {
        bail!(Options, "--flag-ratio {}: must be positive", o.flag_ratio);
    }
    if let Some(z) = o.soc0.filter(|z| !(0.0..=1.0).contains(z)) {
        bail!(Options, "--soc0 {z}: must be in [0, 1]");
    }
    o.track.power.check()?;
    let power = o.track.power.resolve(o.track.cell);
    if let Some(p) = &power {
        p.check()?;
        p.check_period(rec.h)?;
    }
    let states = States {
        power,
        soc: o.track.soc.mode,
        soc0: o.soc0.filter(|_| o.track.cell.is_some()),
        state_in: o.state_in,
        save_state: o.save_state,
    };
    match o.track.precision {
        Precision::F64 => sized(&o.track.settings::<f64>(rec.h)?, o, states, rec, sink),
        Precision::F32 => sized(&o.track.settings::<f32>(rec.h)?, o, states, rec, sink),
    }
}

/// What a pack run publishes beside the parameters: its state of power's
/// limits, how its SOC is published, and the start SOC.
#[derive(Clone, Copy)]
struct States<'a> {
    power: Option<ResolvedPower>,
    soc: SocMode,
    soc0: Option<f64>,
    state_in: Option<&'a [u8]>,
    save_state: bool,
}

fn sized<T: Real>(
    s: &OnlineSettings<T, OCV_POINTS>,
    o: &PackOptions,
    states: States<'_>,
    rec: &PackRecord,
    sink: impl FnMut(PackRow) -> Result<()>,
) -> Result<PackSummary> {
    let mut ps = PackSettings::new(*s);
    ps.updates_per_period = o.updates_per_period;
    ps.flag_ratio = T::lit(o.flag_ratio);
    match o.track.window {
        64 => run::<T, 64>(&ps, states, rec, sink),
        128 => run::<T, 128>(&ps, states, rec, sink),
        256 => run::<T, 256>(&ps, states, rec, sink),
        512 => run::<T, 512>(&ps, states, rec, sink),
        1024 => run::<T, 1024>(&ps, states, rec, sink),
        w => bail!(
            Options,
            "--window {w}: must be one of 64, 128, 256, 512, 1024"
        ),
    }
}

fn run<T: Real, const N: usize>(
    s: &PackSettings<T, OCV_POINTS>,
    states: States<'_>,
    rec: &PackRecord,
    mut sink: impl FnMut(PackRow) -> Result<()>,
) -> Result<PackSummary> {
    let cells = rec.cells.len();
    let mut pack =
        Box::new(PackEstimator::<T, N, N, MAX_CELLS>::new(s, cells).map_err(crate::Error::from)?);
    if let Some(z) = states.soc0 {
        for k in 0..cells {
            if let Some(c) = pack.cell_mut(k) {
                c.set_state_of_charge(T::lit(z));
            }
        }
    }
    let state_in = states.state_in.map(|bytes| {
        let policy = RestorePolicy {
            now_s: rec.time.first().and_then(|t| record_clock(*t)),
            ..RestorePolicy::default()
        };
        StateIn::of(pack.restore(&s.cell, bytes, &policy))
    });
    let no_power = [PowerRow::default(); MAX_HORIZONS];
    let mut volts = vec![T::zero(); cells];
    let mut iterations = 0u64;
    let mut published = PublicationTally::default();
    for (l, (&t, &i)) in rec.time.iter().zip(&rec.current).enumerate() {
        for (v, c) in volts.iter_mut().zip(&rec.cells) {
            *v = T::lit(c[l]);
        }
        let r = pack
            .push(s, T::lit(i), &volts)
            .map_err(crate::Error::from)?;
        iterations += u64::from(r.iterations);
        let health = pack.health();
        let (cell_power, string_power) = match &states.power {
            Some(p) => p.pack_rows(&pack, cells, &s.cell),
            None => (vec![no_power; cells], no_power),
        };
        for (k, power) in cell_power.into_iter().enumerate() {
            let c = pack.cell(k).ok_or_else(|| err!(Internal, "cell index"))?;
            let soc = SocRow {
                coulomb: c.state_of_charge().map(|z| z.to_f64()),
                observer: c.soc_estimate(&s.cell).map(|e| e.cast()),
            };
            let cell_published = c.published().map(|v| v.to_f64());
            published.add(&cell_published, &power);
            sink(PackRow {
                t,
                cell: k + 1,
                estimate: c.estimate().map(|p| p.cast()),
                published: cell_published,
                status: c.status().as_str(),
                rejected: c.last_rejection().is_some(),
                flagged: health.is_some_and(|h| pack.is_flagged(s, &h, k)),
                soc: soc.in_mode(states.soc),
                power,
                string_power,
                restoration: c.restoration(),
            })?;
        }
    }
    Ok(PackSummary {
        samples: rec.time.len() as u64,
        rejected: (0..cells)
            .map(|k| pack.cell(k).map_or(0, |c| c.counts().rejected()))
            .collect(),
        iterations,
        state_in,
        state_out: states.save_state.then(|| {
            let at = rec.time.last().and_then(|t| record_clock(*t));
            saved(pack.snapshot_size(), |buf| pack.save(&s.cell, at, buf))
        }),
        published,
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
    /// The cells' OCV curve and capacity (one chemistry), and the start SOC
    /// of every cell (`--soc0`; default: each cell's read by the core from
    /// its own first rested voltages).
    pub ocv: OcvOptions,
    /// Each cell's and the string's state of power (`--horizons`,
    /// `--voltage-min`, … as `online battery`).
    pub power: PowerOptions,
    /// How each cell's SOC is published (`--soc`, `--soc-rest-s`,
    /// `--soc-bias-sigma-a`, `--soc-rest-load-sigma-a`, `--soc-voltage-sigma-v`,
    /// `--capacity-min-span`).
    pub soc: SocOptions,
    /// The slow part's memory (s; `--slow-memory-s`,
    /// [`TrackOptions::slow_memory_s`]).
    pub slow_memory_s: Option<f64>,
    /// The slow part's memory in state of charge (`--slow-memory-soc`).
    pub slow_memory_soc: Option<f64>,
    /// A snapshot to start from (`--state-in`, docs/persistence.md).
    pub state_in: Option<PathBuf>,
    /// Where to save the snapshot after the last sample (`--state-out`).
    pub state_out: Option<PathBuf>,
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
            ocv: OcvOptions::default(),
            power: PowerOptions::default(),
            soc: SocOptions::default(),
            slow_memory_s: None,
            slow_memory_soc: None,
            state_in: None,
            state_out: None,
        }
    }
}

/// Runs the pack estimator over `rec` as `a` says (the CLI's flags), with
/// the cells' curve and capacity `model` (the CLI reads it from `a.ocv`;
/// Python's `online_pack` gives it as arrays); `a.ocv.soc0` sets every
/// cell's start SOC. Calls `sink` for every cell after every sample.
pub fn run_pack(
    rec: &PackRecord,
    a: &OnlinePack,
    model: Option<OcvModel<f64, OCV_POINTS>>,
    sink: impl FnMut(PackRow) -> Result<()>,
) -> Result<PackSummary> {
    let state_in = a.state_in.as_deref().map(read_state).transpose()?;
    let snapshot = Snapshots {
        state_in: state_in.as_deref(),
        save_state: a.state_out.is_some(),
    };
    run_pack_with(rec, a, model, snapshot, sink)
}

/// Where a pack run's snapshots come from and go ([`run_pack_with`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct Snapshots<'a> {
    /// The core's bytes to start from ([`PackOptions::state_in`]).
    pub state_in: Option<&'a [u8]>,
    /// Save the snapshot after the last sample into the summary.
    pub save_state: bool,
}

/// [`run_pack`] with the snapshot as bytes (Python's `online_pack`);
/// `a.state_in` and `a.state_out` are not read.
pub fn run_pack_with(
    rec: &PackRecord,
    a: &OnlinePack,
    model: Option<OcvModel<f64, OCV_POINTS>>,
    snapshot: Snapshots,
    sink: impl FnMut(PackRow) -> Result<()>,
) -> Result<PackSummary> {
    let memory = a.memory.unwrap_or(a.window / 4);
    // The curve and capacity; the start SOC is per cell (`PackOptions::soc0`).
    let cell = model.map(|model| CellOcv {
        model,
        soc0: a.ocv.soc0.unwrap_or(f64::NAN),
    });
    let mut track = TrackOptions::new(a.window, memory);
    track.iterations_per_sample = a.iterations_per_sample;
    track.precision = a.precision;
    track.start = a.start;
    track.tail = a.tail;
    track.cell = cell.as_ref();
    track.power = a.power;
    track.soc = a.soc;
    track.slow_memory_s = a.slow_memory_s;
    track.slow_memory_soc = a.slow_memory_soc;
    let o = PackOptions {
        track,
        updates_per_period: a.updates_per_period.unwrap_or(u16::MAX),
        flag_ratio: a.flag_ratio,
        soc0: a.ocv.soc0,
        state_in: snapshot.state_in,
        save_state: snapshot.save_state,
    };
    track_pack(rec, &o, sink)
}

/// `online pack`: reads the pack record `input`, runs the pack estimator
/// over it as `a` says and writes the long-format track to `out` (columns
/// [`pack_fields`], one row per cell and sample). Returns the
/// summary and the number of cells.
pub fn online_file(input: &Path, out: &Path, a: &OnlinePack) -> Result<(PackSummary, usize)> {
    let rec = read_pack(input)?;
    let model = crate::ocv::model(&a.ocv)?;
    let fields = pack_fields(a.power.horizons(), a.state_in.is_some());
    let mut res = Ok(PackSummary::default());
    io::write_atomic(out, |w| {
        writeln!(w, "{}", schema::header(&fields))?;
        res = run_pack(&rec, a, model, |r| Ok(schema::write_row(w, &fields, &r)?));
        res.clone().map(|_| ())
    })?;
    let summary = res?;
    if let (Some(p), Some(bytes)) = (&a.state_out, &summary.state_out) {
        write_state(p, bytes)?;
    }
    Ok((summary, rec.cells.len()))
}
