//! `simulate hammerstein|battery|pack`: the flags, and the line each
//! prints.

use anyhow::Result;
use fracbms_host::pack::{self, SimulatePack};
use fracbms_host::simulate::{self, SimulateBattery, SimulateHammerstein};
use std::path::PathBuf;

/// `simulate hammerstein`.
#[derive(clap::Args, Debug)]
pub struct SimHammersteinArgs {
    /// paper-op (Tables 3–4), paper-kt (Tables 5–6 as printed; its C is
    /// unstable), paper-kt-stable (C sign-flipped, as reproduced), identifiable
    /// (well excited, docs/identification.md).
    #[arg(long, value_parser = ["paper-op", "paper-kt", "paper-kt-stable", "identifiable"])]
    pub preset: String,
    /// Standard deviation of the white noise v(l).
    #[arg(long, default_value_t = 0.5)]
    pub sigma: f64,
    /// Number of samples.
    #[arg(long, default_value_t = 1000)]
    pub length: usize,
    /// Random seed (input and noise).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Memory of the fractional differences (default: the whole record, at most 4096).
    #[arg(long)]
    pub memory: Option<usize>,
    /// Output CSV.
    #[arg(long)]
    pub out: PathBuf,
}

/// `simulate battery`.
#[derive(clap::Args, Debug)]
pub struct SimBatteryArgs {
    /// paper (§6.2, ±150 A) or cell (18650-like, ±6 A).
    #[arg(long, value_parser = ["paper", "cell"])]
    pub preset: String,
    /// Current profile.
    #[arg(long, value_parser = ["pulse", "hppc", "drive"], default_value = "pulse")]
    pub profile: String,
    /// Voltage noise σ (V); default: the preset's (0.1 V paper, 1 mV cell).
    #[arg(long)]
    pub sigma: Option<f64>,
    /// Number of samples.
    #[arg(long, default_value_t = 1000)]
    pub length: usize,
    /// Random seed of the noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Sample period (s).
    #[arg(long, default_value_t = 1.0)]
    pub h: f64,
    /// Open-circuit voltage: `constant` (the preset's U_oc), `nmc` (an NMC
    /// OCV(SOC) curve following the charge) or an OCV table FILE.csv with
    /// header `soc,ocv_v`.
    #[arg(long, default_value = "constant")]
    pub ocv: String,
    /// State of charge before the first sample (the `soc` column counts
    /// from it).
    #[arg(long, default_value_t = 0.9)]
    pub soc0: f64,
    /// Capacity (A·h) for the state of charge (default: the preset's,
    /// 2.5 for cell, 100 for paper).
    #[arg(long)]
    pub capacity_ah: Option<f64>,
    /// Current amplitude A of the profile (A; default: the preset's, 6 for
    /// cell, 150 for paper).
    #[arg(long)]
    pub amplitude: Option<f64>,
    /// A constant current added to the profile (A; negative: a mean
    /// discharge that moves the state of charge).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub mean_current: f64,
    /// Butler–Volmer coefficient a (V) of the overpotential a·asinh(I/i₀)
    /// (default 0: the linear model).
    #[arg(long, default_value_t = 0.0)]
    pub bv_a: f64,
    /// Butler–Volmer exchange current i₀ (A; needed with --bv-a).
    #[arg(long)]
    pub bv_i0: Option<f64>,
    /// Output CSV.
    #[arg(long)]
    pub out: PathBuf,
}

/// `simulate pack`.
#[derive(clap::Args, Debug)]
pub struct SimPackArgs {
    /// Cells in series.
    #[arg(long)]
    pub cells: usize,
    /// paper (§6.2, ±150 A) or cell (18650-like, ±6 A).
    #[arg(long, value_parser = ["paper", "cell"], default_value = "cell")]
    pub preset: String,
    /// Current profile.
    #[arg(long, value_parser = ["pulse", "hppc", "drive"], default_value = "pulse")]
    pub profile: String,
    /// Spread of R_i, R_ct and Q between cells: each is the preset's times
    /// 1 + u, u uniform in [−S, S] (0.1: ±10 %).
    #[arg(long, default_value_t = 0.0)]
    pub spread: f64,
    /// An aged cell (1-based): its R_i and R_ct times --aged-factor.
    #[arg(long)]
    pub aged: Option<usize>,
    /// How much larger the aged cell's R_i and R_ct are.
    #[arg(long, default_value_t = 1.5)]
    pub aged_factor: f64,
    /// Voltage noise σ (V) of every cell; default: the preset's.
    #[arg(long)]
    pub sigma: Option<f64>,
    /// Current amplitude of the profile (A; default: the preset's).
    #[arg(long)]
    pub amplitude: Option<f64>,
    /// Number of samples.
    #[arg(long, default_value_t = 1000)]
    pub length: usize,
    /// Random seed (the spread and every cell's noise).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Sample period (s).
    #[arg(long, default_value_t = 1.0)]
    pub h: f64,
    /// An OCV table FILE.csv (`soc,ocv_v`) every cell's open-circuit
    /// voltage follows as its charge moves (default: the preset's constant
    /// U_oc).
    #[arg(long)]
    pub ocv: Option<PathBuf>,
    /// Every cell's state of charge before the first sample (with --ocv).
    #[arg(long, default_value_t = 0.9)]
    pub soc0: f64,
    /// Capacity (A·h) for the state of charge (with --ocv; default: the
    /// preset's, 2.5 for cell, 100 for paper).
    #[arg(long)]
    pub capacity_ah: Option<f64>,
    /// Output CSV; the truth goes beside it as FILE.json (`cells`: cell,
    /// r_i, r_ct, q, alpha, u_oc, aged).
    #[arg(long)]
    pub out: PathBuf,
}

// Not inlined into `cli::run`: the simulators build their weights on the
// stack before boxing, and an inlined frame of every command would be
// probed (page faults over megabytes) even for the command that does not
// run.
#[inline(never)]
pub(super) fn hammerstein(a: SimHammersteinArgs) -> Result<()> {
    simulate::hammerstein_file(&SimulateHammerstein {
        preset: a.preset,
        sigma: a.sigma,
        length: a.length,
        seed: a.seed,
        memory: a.memory,
        out: a.out.clone(),
    })?;
    eprintln!("wrote {} rows to {}", a.length, a.out.display());
    Ok(())
}

#[inline(never)]
pub(super) fn battery(a: SimBatteryArgs) -> Result<()> {
    let t0 = std::time::Instant::now();
    simulate::battery_file(&SimulateBattery {
        preset: a.preset,
        profile: a.profile,
        sigma: a.sigma,
        length: a.length,
        seed: a.seed,
        h: a.h,
        ocv: a.ocv,
        soc0: a.soc0,
        capacity_ah: a.capacity_ah,
        amplitude: a.amplitude,
        mean_current: a.mean_current,
        bv_a: a.bv_a,
        bv_i0: a.bv_i0,
        out: a.out.clone(),
    })?;
    eprintln!(
        "wrote {} rows to {} ({:.0} rows/s)",
        a.length,
        a.out.display(),
        a.length as f64 / t0.elapsed().as_secs_f64().max(1e-9)
    );
    Ok(())
}

#[inline(never)]
pub(super) fn pack(a: SimPackArgs) -> Result<()> {
    let o = SimulatePack {
        cells: a.cells,
        preset: a.preset,
        profile: a.profile,
        spread: a.spread,
        aged: a.aged,
        aged_factor: a.aged_factor,
        sigma: a.sigma,
        amplitude: a.amplitude,
        length: a.length,
        seed: a.seed,
        h: a.h,
        ocv: a.ocv,
        soc0: a.soc0,
        capacity_ah: a.capacity_ah,
        out: a.out,
    };
    pack::simulate_file(&o)?;
    eprintln!(
        "wrote {} rows of {} cells to {} (truth: {})",
        o.length,
        o.cells,
        o.out.display(),
        pack::truth_path(&o.out).display()
    );
    Ok(())
}
