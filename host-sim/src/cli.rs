//! The command line: `simulate`, `identify`, `online`, `reproduce`.

use anyhow::{bail, Result};
use clap::{Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

/// Simulate, identify and track fractional-order Hammerstein systems and
/// battery cells (Ji, Wang & Meng), on files.
#[derive(Parser, Debug)]
#[command(name = "host-sim", version, about, propagate_version = true)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Make synthetic data.
    #[command(subcommand)]
    Simulate(SimulateCmd),
    /// Identify a model from a file.
    #[command(subcommand)]
    Identify(IdentifyCmd),
    /// Feed a file sample by sample through the sliding-window estimator.
    #[command(subcommand)]
    Online(OnlineCmd),
    /// Regenerate the paper's tables and figures as a Markdown report with SVG figures.
    Reproduce(ReproduceArgs),
}

#[derive(Subcommand, Debug)]
enum SimulateCmd {
    /// Eq. (4) with the paper's Example 1 values; writes `u,y`.
    Hammerstein(SimHammersteinArgs),
    /// The fractional battery model of §6.2; writes `time_s,current_a,voltage_v,soc`.
    Battery(SimBatteryArgs),
    /// A series pack of cells sharing one current; writes
    /// `time_s,current_a,cell_1_v,…,cell_N_v` and the truth beside it as JSON.
    Pack(SimPackArgs),
}

#[derive(Subcommand, Debug)]
enum IdentifyCmd {
    /// 2S-OP-GI or KT-2S-GI on a `u,y` file.
    Hammerstein(IdHammersteinArgs),
    /// R_i, R_ct, Q, α, U_oc from a `time_s,current_a,voltage_v` file.
    Battery(IdBatteryArgs),
}

#[derive(Subcommand, Debug)]
enum OnlineCmd {
    /// Track a cell's parameters over a sliding window, as the firmware does.
    Battery(OnlineBatteryArgs),
    /// Track every cell of a pack record (`time_s,current_a,cell_1_v,…`),
    /// as the firmware's pack estimator does.
    Pack(OnlinePackArgs),
}

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
    /// Output CSV; the truth goes beside it as FILE.json (`cells`: cell,
    /// r_i, r_ct, q, alpha, u_oc, aged).
    #[arg(long)]
    pub out: PathBuf,
}

/// `online pack`.
#[derive(clap::Args, Debug)]
pub struct OnlinePackArgs {
    /// Input CSV with columns time_s,current_a,cell_1_v,…,cell_N_v.
    #[arg(long)]
    pub input: PathBuf,
    /// Window length L (one of 64, 128, 256, 512, 1024).
    #[arg(long, default_value_t = 256)]
    pub window: usize,
    /// Memory M (default L/4).
    #[arg(long)]
    pub memory: Option<usize>,
    /// Iterations per cell update.
    #[arg(long, default_value_t = 1)]
    pub iterations_per_sample: u16,
    /// Cell updates per sample period, round robin (default: every cell
    /// every period).
    #[arg(long)]
    pub updates_per_period: Option<u16>,
    /// Flag a cell whose R_i or R_ct is above the pack's median by more
    /// than this fraction.
    #[arg(long, default_value_t = 0.3)]
    pub flag_ratio: f64,
    /// Arithmetic of the estimator: `f64`, or `f32` as the firmware runs it.
    #[arg(long, value_enum, default_value = "f64")]
    pub precision: Precision,
    /// Where the model starts in the window (as `online battery`).
    #[arg(long, value_enum, default_value = "from-data")]
    pub start: StartArg,
    /// Add the Grünwald–Letnikov taps beyond the memory: those at lags ≥ M
    /// inside the window and the past before it, carried by 8 exponential
    /// modes per cell (the short-memory correction, docs/pack.md; linear
    /// model, memory ≥ 64).
    #[arg(long)]
    pub tail: bool,
    /// Output CSV in long format, one row per cell and sample:
    /// `time_s,cell,r_i,r_ct,q,alpha,u_oc,status,rejected,flagged` (cell
    /// 1-based; the estimate empty before the cell's first; status as in
    /// `online battery`; rejected 1 when this sample of the cell was
    /// rejected; flagged 1 when the cell stands out from the median).
    #[arg(long)]
    pub out: PathBuf,
}

/// Hammerstein algorithm.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Algorithm {
    /// 2S-OP-GI (over-parameterization).
    Op,
    /// KT-2S-GI (key term separation).
    Kt,
}

/// `identify hammerstein --method`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum HammersteinMethod {
    /// The paper's algorithm (`--algorithm`) alone.
    Paper,
    /// The prediction-error (maximum-likelihood) refinement started from
    /// it, with a global search over the order.
    Refined,
}

/// The cell model of the battery fit (`--model`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum ModelArg {
    /// The paper's linear model, R_i + R_ct‖CPE.
    #[default]
    Linear,
    /// With the Butler–Volmer overpotential a·asinh(I/i₀) in front of it.
    ButlerVolmer,
    /// `identify`: the nonlinear model only when the data identify it
    /// (current beyond i₀, a's interval away from 0, a lower BIC), else the
    /// linear one. `online`: the model of the `--prior` fit, linear without
    /// one.
    Auto,
}

/// Battery method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum BatteryMethod {
    /// The paper's §6.2 regression with 2S-OP-GI.
    Paper,
    /// Output-error refinement started from 2S-OP-GI (most accurate).
    Refined,
}

/// `identify hammerstein`.
#[derive(clap::Args, Debug)]
pub struct IdHammersteinArgs {
    /// Input CSV with columns u,y.
    #[arg(long)]
    pub input: PathBuf,
    #[command(flatten)]
    pub fit: HammersteinOptions,
    /// Write the estimates as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// How `identify hammerstein` fits (every flag but the files; the Python
/// face fills it from its keywords).
#[derive(clap::Args, Debug, Clone)]
pub struct HammersteinOptions {
    /// Method: `paper` (the algorithm alone) or `refined` (the
    /// prediction-error refinement started from it: maximum likelihood,
    /// the most accurate; docs/identification.md).
    #[arg(long, value_enum, default_value = "refined")]
    pub method: HammersteinMethod,
    /// Algorithm of the paper stage (the whole method with `--method paper`,
    /// the start of the refinement with `refined`).
    #[arg(long, value_enum, default_value = "op")]
    pub algorithm: Algorithm,
    /// Order of A(z).
    #[arg(long, default_value_t = 2)]
    pub na: usize,
    /// Order of B(z).
    #[arg(long, default_value_t = 3)]
    pub nb: usize,
    /// Order of the noise polynomial C(z).
    #[arg(long, default_value_t = 2)]
    pub nc: usize,
    /// Basis of the nonlinearity: poly:m means f_j(u) = u^j, j = 1..m.
    #[arg(long, default_value = "poly:2")]
    pub basis: String,
    /// Memory of the fractional differences (default: all rows, at most 4096).
    #[arg(long)]
    pub memory: Option<usize>,
    /// Iterations of the paper stage.
    #[arg(long, default_value_t = 100)]
    pub iterations: u32,
    /// Most iterations of the refinement (its global search over the order
    /// included).
    #[arg(long, default_value_t = 400)]
    pub refine_iterations: u32,
    /// Initial order α̂₀.
    #[arg(long, default_value_t = 0.45)]
    pub alpha0: f64,
}

/// `identify battery`.
#[derive(clap::Args, Debug)]
pub struct IdBatteryArgs {
    /// Input CSV with columns time_s,current_a,voltage_v.
    #[arg(long)]
    pub input: PathBuf,
    /// Method (default: refined, the most accurate).
    #[arg(long, value_enum, default_value = "refined")]
    pub method: BatteryMethod,
    /// Algorithm of the paper stage (the battery regression has no b·γ
    /// products to separate, so kt runs the same iteration as op).
    #[arg(long, value_enum, default_value = "op")]
    pub algorithm: Algorithm,
    /// Memory M of the paper regression (default 256); the refinement uses
    /// the whole record (at most 4096).
    #[arg(long)]
    pub memory: Option<usize>,
    /// Iterations of 2S-OP-GI (paper method, or the start of the refinement).
    #[arg(long, default_value_t = 50)]
    pub iterations: u32,
    /// Memory of the refinement (default: the whole record, at most 4096;
    /// give the firmware's memory to compare with it).
    #[arg(long)]
    pub refine_memory: Option<usize>,
    /// Fit an OCV slope dU_oc/dq (the state of charge drifting through the
    /// record; without --ocv).
    #[arg(long)]
    pub ocv_slope: bool,
    /// Cell model: `linear` (R_i + R_ct‖CPE), `butler-volmer` (plus
    /// a·asinh(I/i₀), started from the linear fit) or `auto` (the nonlinear
    /// model only when the data identify it: current beyond i₀, a's 95 %
    /// interval away from 0, those of R_i, R_ct, Q and i₀ within a factor
    /// e, and a lower BIC; the JSON's `model_choice` says why).
    #[arg(long, value_enum, default_value = "auto")]
    pub model: ModelArg,
    #[command(flatten)]
    pub cell: OcvArgs,
    /// Lowest plausible voltage (V; default 1.5, as online): rows below are
    /// rejected, substituted and counted in the JSON's `rejected`, as are
    /// non-finite rows and voltage spikes against the fitted model
    /// (beyond max(8 robust σ, 50 mV); docs/trust.md).
    #[arg(long)]
    pub voltage_min: Option<f64>,
    /// Highest plausible voltage (V; default 5).
    #[arg(long)]
    pub voltage_max: Option<f64>,
    /// Largest plausible |current| (A; default 500).
    #[arg(long)]
    pub current_limit: Option<f64>,
    /// Write the estimates as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write `time_s,voltage_v,model_v`: the identified model's free-run
    /// simulation from the current alone (OCV, ΔU and all) beside the data.
    #[arg(long)]
    pub fit_out: Option<PathBuf>,
    /// Write Figures 8–11 for this file (SVG) into this directory.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// `online battery`.
#[derive(clap::Args, Debug)]
pub struct OnlineBatteryArgs {
    /// Input CSV with columns time_s,current_a,voltage_v.
    #[arg(long)]
    pub input: PathBuf,
    /// Window length L (one of 64, 128, 256, 512, 1024).
    #[arg(long, default_value_t = 256)]
    pub window: usize,
    /// Memory M (default L/4).
    #[arg(long)]
    pub memory: Option<usize>,
    /// Iterations per sample.
    #[arg(long, default_value_t = 1)]
    pub iterations_per_sample: u16,
    /// Method.
    #[arg(long, value_enum, default_value = "refined")]
    pub method: BatteryMethod,
    /// Arithmetic of the estimator: `f64`, or `f32` as the firmware runs it.
    #[arg(long, value_enum, default_value = "f64")]
    pub precision: Precision,
    /// Where the model starts in the window: `from-data` (the polarization
    /// of the first M − 1 samples from the data: a cell that is never at
    /// rest) or `at-rest` (from rest until the window first slides, as the
    /// firmware starts after power-up).
    #[arg(long, value_enum, default_value = "from-data")]
    pub start: StartArg,
    /// A prior on R_i, R_ct, Q and α: the JSON of `identify battery` (e.g.
    /// of a characterization record of the same cell). The window's fit
    /// is then maximum a posteriori: the data where they are informative,
    /// the prior where a window is too short to tell (the refinement starts
    /// at the prior, without the paper method's start-up).
    #[arg(long)]
    pub prior: Option<PathBuf>,
    /// The prior's spread on R_i, R_ct and Q: a factor at one sigma.
    #[arg(long, default_value_t = 2.0)]
    pub prior_factor: f64,
    /// The prior's spread on α at one sigma.
    #[arg(long, default_value_t = 0.1)]
    pub prior_alpha_sigma: f64,
    /// The residual level (mV) at which the window's data are weighed
    /// against the prior (not the noise: model error correlated over the
    /// window makes it worth fewer independent samples; see
    /// docs/real-cells.md).
    #[arg(long, default_value_t = 100.0)]
    pub prior_noise_mv: f64,
    /// Cell model: `linear`, `butler-volmer` (plus a·asinh(I/i₀); a linear
    /// start is given the term with i₀ at the window's RMS current) or
    /// `auto` (the model of the `--prior` fit; linear without a prior).
    #[arg(long, value_enum, default_value = "auto")]
    pub model: ModelArg,
    /// Add the Grünwald–Letnikov taps beyond the memory: those at lags ≥ M
    /// inside the window and the past before it, carried by 8 exponential
    /// modes per cell (the short-memory correction, docs/pack.md; linear
    /// model, memory ≥ 64).
    #[arg(long)]
    pub tail: bool,
    #[command(flatten)]
    pub cell: OcvArgs,
    /// Output CSV `time_s,r_i,r_ct,q,alpha,u_oc,status,soc,ocv_offset_v,
    /// bv_a_v,bv_i0_a,predicted_v` (u_oc: the open-circuit voltage now,
    /// OCV(SOC) + ΔU with --ocv; soc and ocv_offset_v empty without --ocv;
    /// bv_a_v and bv_i0_a empty for the linear model; predicted_v: the
    /// one-step prediction of this row's voltage from the estimate before
    /// it, empty before the first estimate). The status after each sample:
    /// filling (the window is not full enough yet), starting (2S-OP-GI runs,
    /// no physical estimate yet), tracking (updated from this window),
    /// not_excited (the current barely varies: held), held (an iteration
    /// failed: held), unphysical (the window's estimate has a non-positive
    /// resistance or Q, or α outside (0, 1]: held), at_bound (α at the
    /// search's bound, or R_ct so small that its branch swing R_ct·σ_I is
    /// below the fit's RMSE: held), slow_relaxation (the branch relaxes slower
    /// than the window can see, τ^(1/α) beyond the fitted window: held),
    /// ocv_implausible (U_oc outside the plausible voltage range, or |ΔU|
    /// above 0.15 V with --ocv: held). "Held" keeps the last good estimate.
    #[arg(long, verbatim_doc_comment)]
    pub out: PathBuf,
}

/// The cell's open-circuit voltage curve and state of charge.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct OcvArgs {
    /// OCV table CSV with header `soc,ocv_v` (soc in [0, 1], both columns
    /// increasing): the model fits U_t − OCV(SOC) with the SOC counted from
    /// the current, and its U_oc becomes a small offset ΔU.
    #[arg(long)]
    pub ocv: Option<PathBuf>,
    /// Capacity (A·h) for coulomb counting (needed with --ocv).
    #[arg(long)]
    pub capacity_ah: Option<f64>,
    /// State of charge at the start of the record, before the first row's
    /// charge (default: read from the first rows' voltage through the
    /// inverse OCV; the record must then start at rest).
    #[arg(long)]
    pub soc0: Option<f64>,
}

/// Where the output-error model starts in the window.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum StartArg {
    /// The polarization of the first M − 1 samples from the data.
    FromData,
    /// From rest until the window first slides.
    AtRest,
}

/// Floating-point precision of the estimator.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// Single precision (the Cortex-M4F FPU).
    F32,
    /// Double precision.
    F64,
}

/// `reproduce`.
#[derive(clap::Args, Debug)]
pub struct ReproduceArgs {
    /// Output directory (report.md and SVG figures).
    #[arg(long)]
    pub out: PathBuf,
    /// Seeds per table (the paper's tables: 10).
    #[arg(long, default_value_t = 10)]
    pub seeds: u64,
    /// Which part: `all`, `example1` (Tables 3–6, Figures 2–5, about 5 min
    /// on 2 cores) or `battery` (Figure 6, Table 7, Figures 7–11, seconds).
    #[arg(long, value_enum, default_value = "all")]
    pub part: ReproducePart,
}

/// The parts of `reproduce`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReproducePart {
    /// Both parts.
    All,
    /// §6.1 Example 1: Tables 3–6, Figures 2–5.
    Example1,
    /// §6.2 battery: Figure 6, Table 7, Figures 7–11, our refinement and tracking.
    Battery,
}

/// Parses the arguments, runs the command and returns the exit status;
/// errors are printed as one line.
pub fn main() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return code;
        }
    };
    match on_worker(move || run(cli)) {
        Ok(()) => 0,
        Err(e) => {
            let msg = format!("{e:#}").replace('\n', " ");
            eprintln!("error: {msg}");
            1
        }
    }
}

/// Runs `f` on a worker thread with the stack the commands need (the
/// estimators hold their windows inline, and are built on the stack before
/// boxing): how the CLI runs every command, and the Python face every fit.
/// A panic comes back as an error.
pub fn on_worker<R: Send>(f: impl FnOnce() -> Result<R> + Send) -> Result<R> {
    std::thread::scope(|scope| {
        match std::thread::Builder::new()
            .stack_size(512 << 20)
            .spawn_scoped(scope, f)
        {
            Ok(h) => h
                .join()
                .unwrap_or_else(|_| Err(anyhow::anyhow!("internal error (please report it)"))),
            Err(e) => Err(anyhow::anyhow!("cannot start the worker thread: {e}")),
        }
    })
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Simulate(SimulateCmd::Hammerstein(a)) => crate::simulate::hammerstein(&a),
        Command::Simulate(SimulateCmd::Battery(a)) => crate::simulate::battery(&a),
        Command::Identify(IdentifyCmd::Hammerstein(a)) => crate::identify::hammerstein(&a),
        Command::Identify(IdentifyCmd::Battery(a)) => crate::identify::battery(&a),
        Command::Online(OnlineCmd::Battery(a)) => crate::online::battery(&a),
        Command::Simulate(SimulateCmd::Pack(a)) => crate::pack::simulate(&a),
        Command::Online(OnlineCmd::Pack(a)) => crate::pack::online(&a),
        Command::Reproduce(a) => crate::reproduce::run(&a),
    }
}

/// Parses `poly:m`.
pub fn parse_basis(s: &str) -> Result<usize> {
    match s.strip_prefix("poly:").map(str::parse::<usize>) {
        Some(Ok(m)) if (1..=4).contains(&m) => Ok(m),
        _ => bail!("--basis `{s}`: expected poly:m with 1 ≤ m ≤ 4"),
    }
}
