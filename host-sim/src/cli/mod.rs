//! The command line: `simulate`, `identify`, `online`, `predict`, `ocv`,
//! `reproduce`.
//!
//! Only arguments: each command's module is a table of flags (clap) that
//! turns them into `fracbms-host`'s options, calls one library function
//! and prints. Nothing here computes; a new capability goes into
//! `fracbms-host` first, so that the C and Python faces get it too.

mod identify;
mod online;
mod predict;
mod reproduce;
mod simulate;

use anyhow::Result;
use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use estimator_core::battery::Start;
use fracbms_host::cycler::{ColumnMap, CurrentSign, RecordOptions, StepsMode};
use fracbms_host::identify::{Algorithm, BatteryMethod, HammersteinMethod, ModelRequest};
use fracbms_host::online::soc::SocMode;
use fracbms_host::online::Precision;
use fracbms_host::reproduce::ReproducePart;

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
    /// Run an identified model on another record and compare.
    #[command(subcommand)]
    Predict(PredictCmd),
    /// An OCV table (`soc,ocv_v`) from a test's rests or low-rate branches.
    Ocv(ocv::OcvArgs),
    /// Regenerate the paper's tables and figures as a Markdown report with SVG figures.
    Reproduce(reproduce::ReproduceArgs),
}

#[derive(Subcommand, Debug)]
enum SimulateCmd {
    /// Eq. (4) with the paper's Example 1 values; writes `u,y`.
    Hammerstein(simulate::SimHammersteinArgs),
    /// The fractional battery model of §6.2; writes `time_s,current_a,voltage_v,soc`.
    Battery(simulate::SimBatteryArgs),
    /// A series pack of cells sharing one current; writes
    /// `time_s,current_a,cell_1_v,…,cell_N_v` and the truth beside it as JSON.
    Pack(simulate::SimPackArgs),
}

#[derive(Subcommand, Debug)]
enum IdentifyCmd {
    /// 2S-OP-GI or KT-2S-GI on a `u,y` file.
    Hammerstein(identify::IdHammersteinArgs),
    /// R_i, R_ct, Q, α, U_oc from a `time_s,current_a,voltage_v` file.
    Battery(Box<identify::IdBatteryArgs>),
}

#[derive(Subcommand, Debug)]
enum PredictCmd {
    /// The model of `identify battery` on a record's current: writes
    /// `time_s,current_a,voltage_v,model_v` and prints the RMSE and the
    /// largest error against the measured voltage.
    Battery(predict::PredictBatteryArgs),
}

#[derive(Subcommand, Debug)]
enum OnlineCmd {
    /// Track a cell's parameters over a sliding window, as the firmware does.
    Battery(Box<online::OnlineBatteryArgs>),
    /// Track every cell of a pack record (`time_s,current_a,cell_1_v,…`),
    /// as the firmware's pack estimator does.
    Pack(Box<online::OnlinePackArgs>),
}

/// A flag's values (clap) for one of the library's option enums, with the
/// conversion: the variants' docs are the flag's help.
macro_rules! value_enum {
    ($(#[$m:meta])* $arg:ident => $lib:ident { $($(#[$vm:meta])* $v:ident),+ $(,)? }) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
        pub enum $arg {
            $($(#[$vm])* $v),+
        }

        impl From<$arg> for $lib {
            fn from(a: $arg) -> Self {
                match a {
                    $($arg::$v => $lib::$v),+
                }
            }
        }
    };
}

// After the macro: its flags use it.
mod ocv;

value_enum! {
    /// Hammerstein algorithm.
    AlgorithmArg => Algorithm {
        /// 2S-OP-GI (over-parameterization).
        Op,
        /// KT-2S-GI (key term separation).
        Kt,
    }
}

value_enum! {
    /// `identify hammerstein --method`.
    HammersteinMethodArg => HammersteinMethod {
        /// The paper's algorithm (`--algorithm`) alone.
        Paper,
        /// The prediction-error (maximum-likelihood) refinement started from
        /// it, with a global search over the order.
        Refined,
    }
}

value_enum! {
    /// The cell model of the battery fit (`--model`).
    ModelArg => ModelRequest {
        /// The paper's linear model, R_i + R_ct‖CPE.
        Linear,
        /// With the Butler–Volmer overpotential a·asinh(I/i₀) in front of it.
        ButlerVolmer,
        /// `identify`: the nonlinear model only when the data identify it
        /// (current beyond i₀, a's interval away from 0, a lower BIC), else the
        /// linear one. `online`: the model of the `--prior` fit, linear without
        /// one.
        Auto,
    }
}

value_enum! {
    /// Battery method.
    BatteryMethodArg => BatteryMethod {
        /// The paper's §6.2 regression with 2S-OP-GI.
        Paper,
        /// Output-error refinement started from 2S-OP-GI (most accurate).
        Refined,
    }
}

value_enum! {
    /// Where the output-error model starts in the window.
    StartArg => Start {
        /// The polarization of the first M − 1 samples from the data.
        FromData,
        /// From rest until the window first slides.
        AtRest,
    }
}

value_enum! {
    /// Floating-point precision of the estimator.
    PrecisionArg => Precision {
        /// Single precision (the Cortex-M4F FPU).
        F32,
        /// Double precision.
        F64,
    }
}

value_enum! {
    /// What `online battery` publishes as `soc` (`--soc`).
    SocArg => SocMode {
        /// The count corrected at rest by the OCV curve, with the current
        /// bias and the capacity estimated.
        Observer,
        /// Plain coulomb counting from the start SOC.
        Coulomb,
    }
}

value_enum! {
    /// The sign of an export's current (`--current-sign`).
    CurrentSignArg => CurrentSign {
        /// Positive when charging (ours, Arbin's, BioLogic's).
        ChargePositive,
        /// Positive when discharging (PyBaMM's): negated on reading.
        DischargePositive,
        /// A magnitude signed by the state column (Maccor's `State`
        /// C/D/R): the default when the current never goes negative and
        /// the export has a state column of letters.
        FromState,
    }
}

value_enum! {
    /// Where a cycler's step began (`--steps`).
    StepsArg => StepsMode {
        /// From the step-time column, where there is one.
        Auto,
        /// Each row's current held to the next row.
        Ignore,
        /// As `auto`, and without a step time every change of the current
        /// the export's charge count dates is placed by it, within the
        /// log's rhythm too.
        Count,
    }
}

/// How a record is read, on every command that reads one (docs/cycler.md).
#[derive(clap::Args, Debug, Clone)]
pub struct RecordArgs {
    /// Columns by their headers: `time=COL,current=COL,voltage=COL[,temperature=COL]`
    /// and the optional `step=COL,step_time=COL,state=COL,charge=COL`
    /// (`temperature=none`, `step_time=none`…: none). Roles left out are
    /// recognised from the header (Arbin, Bitrode, Maccor, Neware,
    /// BioLogic, Digatron, PyBaMM/PyBOP and ours, units included: ms, min,
    /// h, mA, mV, K, mAh).
    #[arg(long, value_parser = parse_columns)]
    pub columns: Option<ColumnMap>,
    /// The sign of the file's current.
    #[arg(long, value_enum, default_value = "charge-positive")]
    pub current_sign: CurrentSignArg,
    /// Put the record on this uniform period (s). Default: a uniform log as
    /// it is; a non-uniform one at its median step, raised to keep it
    /// within 50 000 samples (printed); so raised, for `online battery`
    /// with a state of power, raised again by at most a quarter to divide
    /// every `--horizons` (1.8 s → 2 s for 10 and 30 s). The current is the mean over each
    /// period (the charge is kept), the voltage taken at the instants.
    #[arg(long)]
    pub period: Option<f64>,
    /// Report steps longer than this (s) as gaps (default max(10 periods, 300 s)).
    #[arg(long)]
    pub max_gap: Option<f64>,
    /// In a MAT-file: the struct holding the columns, as a dot path
    /// (`T25.SoC5.Cell1.data`); default: the one struct whose fields name a
    /// time, a current and a voltage. Several, comma-separated: joined in
    /// that order into one record, each after a gap of at least 600 s (rest
    /// assumed; the SOC read again from the rested voltage after it): the
    /// one-pulse records of a test, each at its own SOC, as one map's levels
    #[arg(long)]
    pub table: Option<String>,
    /// Where each step began: `auto` from the step-time column (a step
    /// whose first row is logged late began at its row's time less its
    /// step time; the stretch before its first row is unobserved), or
    /// without one from the export's own charge count where rows further
    /// apart than the log's rhythm change the current; `count`: as `auto`,
    /// the count placing every change it dates; or `ignore`: each row's
    /// current held to the next row.
    #[arg(long, value_enum, default_value = "auto")]
    pub steps: StepsArg,
}

fn parse_columns(s: &str) -> std::result::Result<ColumnMap, String> {
    ColumnMap::parse(s).map_err(|e| e.to_string())
}

impl From<&RecordArgs> for RecordOptions {
    fn from(a: &RecordArgs) -> Self {
        Self {
            columns: a.columns.clone().unwrap_or_default(),
            current_sign: a.current_sign.into(),
            period: a.period,
            max_gap: a.max_gap,
            table: a.table.clone(),
            max_samples: None,
            divide_s: Vec::new(),
            steps: a.steps.into(),
            capacity_ah: None,
        }
    }
}

/// Prints what [`RecordArgs`] read: the columns line, the resampling line
/// and the sign warning (stderr).
pub fn print_record(path: &std::path::Path, r: &fracbms_host::cycler::RecordReport) {
    eprintln!("{}", r.summary(path));
    if let Some(l) = r.resampling_line() {
        eprintln!("{l}");
    }
    for w in r.warnings() {
        eprintln!("warning: {}: {w}", path.display());
    }
}

value_enum! {
    /// The parts of `reproduce`.
    ReproducePartArg => ReproducePart {
        /// Both parts.
        All,
        /// §6.1 Example 1: Tables 3–6, Figures 2–5.
        Example1,
        /// §6.2 battery: Figure 6, Table 7, Figures 7–11, our refinement and tracking.
        Battery,
    }
}

/// `cmd` with every flag that takes a value, in every subcommand, also
/// taking a negative number (`--soc0 -0.1`, `--sop-confidence -1`): the
/// value's own check then says what is wrong with it, where clap would
/// call it an unexpected argument.
fn negative_numbers(cmd: clap::Command) -> clap::Command {
    let cmd = cmd.mut_args(|a| {
        if a.get_action().takes_values() {
            a.allow_negative_numbers(true)
        } else {
            a
        }
    });
    let names: Vec<String> = cmd
        .get_subcommands()
        .map(|c| c.get_name().to_string())
        .collect();
    names
        .iter()
        .fold(cmd, |cmd, name| cmd.mut_subcommand(name, negative_numbers))
}

/// Parses the arguments, runs the command and returns the exit status;
/// errors are printed as one line.
pub fn main() -> i32 {
    let parsed = negative_numbers(Cli::command())
        .try_get_matches()
        .and_then(|m| Cli::from_arg_matches(&m));
    let cli = match parsed {
        Ok(c) => c,
        Err(e) if !e.use_stderr() => {
            // --help, --version.
            let _ = e.print();
            return 0;
        }
        Err(e) => {
            // A bad flag is one line, as bad data are (clap adds a usage
            // hint below it; `--help` shows the flags).
            let text = e.render().to_string();
            let said: Vec<&str> = text
                .lines()
                .map(str::trim)
                .filter(|l| {
                    !l.is_empty()
                        && !l.starts_with("Usage:")
                        && !l.starts_with("For more information")
                })
                .collect();
            eprintln!("{} (see --help)", said.join(" "));
            return 2;
        }
    };
    match fracbms_host::worker::on_worker(move || run(cli)) {
        Ok(()) => 0,
        Err(e) => {
            let msg = format!("{e:#}").replace('\n', " ");
            eprintln!("error: {msg}");
            1
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Simulate(SimulateCmd::Hammerstein(a)) => simulate::hammerstein(a),
        Command::Simulate(SimulateCmd::Battery(a)) => simulate::battery(a),
        Command::Simulate(SimulateCmd::Pack(a)) => simulate::pack(a),
        Command::Identify(IdentifyCmd::Hammerstein(a)) => identify::hammerstein(a),
        Command::Identify(IdentifyCmd::Battery(a)) => identify::battery(*a),
        Command::Online(OnlineCmd::Battery(a)) => online::battery(*a),
        Command::Online(OnlineCmd::Pack(a)) => online::pack(*a),
        Command::Predict(PredictCmd::Battery(a)) => predict::battery(a),
        Command::Ocv(a) => ocv::run(a),
        Command::Reproduce(a) => reproduce::run(a),
    }
}
