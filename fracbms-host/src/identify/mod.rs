//! Whole-record identification: the Hammerstein system of eq. (4)
//! ([`hammerstein`]) and the battery cell of §6.2 ([`battery`], with the
//! Butler–Volmer choice in [`model_choice`], the paper's regression as it
//! runs there in `paper`, the whole-record refinement in [`refine`] and
//! its starts from the data in [`starts`]); a record
//! read from a file or arrays and fitted ([`record`]), many files at once
//! ([`many`]), maps ([`map`]).
//!
//! This module owns the fit options (plain enums and structs, no argument
//! parser), the fits' JSON types and the glue that drives
//! `estimator-core`'s estimators over a whole record in `f64`. It must not
//! touch the estimators' numerics (the core's) nor how a face shows the
//! results (the CLI prints, Python returns dicts, C fills structs).

pub mod battery;
pub mod hammerstein;
pub mod many;
pub mod map;
pub mod model_choice;
mod paper;
pub mod record;
pub mod refine;
pub mod starts;

pub use battery::{
    battery_identify, battery_identify_screened, battery_run, battery_run_with, model_for,
    model_voltage, BatteryJson, BatteryResult, Refine,
};
pub use hammerstein::{hammerstein_fit, hammerstein_json, HammersteinJson, RefineStart};
pub use model_choice::{ModelChoice, AUTO_MIN_CURRENT_OVER_I0, AUTO_Z};

use crate::bail;
use crate::error::Result;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Most rows `identify hammerstein` reads (the rest of a longer file is
/// ignored, with a note; `online` streams files of any length).
pub const MAX_ROWS: usize = 8192;

/// The longest record (samples) a battery fit takes whole: the estimator
/// state is sized to the record in steps of powers of two up to this. The
/// refinement's memory is the whole record ([`crate::branch`]: `O(N log N)`
/// per pass).
pub const MAX_BATTERY_ROWS: usize = 262_144;

/// Memory capacity of the Hammerstein estimators.
pub const HAM_MEM: usize = 4096;
/// Memory capacity of the paper's battery regression (2S-OP-GI, the start
/// of the refinement; its cost is `O(N·M)`). The refinement's memory is the
/// whole record.
pub const BAT_MEM: usize = 4096;

/// The paper's algorithm of a Hammerstein fit (its paper stage).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Algorithm {
    /// 2S-OP-GI (over-parameterization).
    #[default]
    Op,
    /// KT-2S-GI (key term separation).
    Kt,
}

impl Algorithm {
    /// `"op"` or `"kt"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Algorithm::Op => "op",
            Algorithm::Kt => "kt",
        }
    }
}

/// How a Hammerstein record is fitted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum HammersteinMethod {
    /// The paper's algorithm alone.
    Paper,
    /// The prediction-error (maximum-likelihood) refinement started from
    /// it, with a global search over the order.
    #[default]
    Refined,
}

impl HammersteinMethod {
    /// `"paper"` or `"refined"`.
    pub fn as_str(self) -> &'static str {
        match self {
            HammersteinMethod::Paper => "paper",
            HammersteinMethod::Refined => "refined",
        }
    }
}

/// How a battery record is fitted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BatteryMethod {
    /// The paper's §6.2 regression with 2S-OP-GI.
    Paper,
    /// Output-error refinement started from 2S-OP-GI (most accurate).
    #[default]
    Refined,
}

impl BatteryMethod {
    /// `"paper"` or `"refined"`.
    pub fn as_str(self) -> &'static str {
        match self {
            BatteryMethod::Paper => "paper",
            BatteryMethod::Refined => "refined",
        }
    }
}

/// The cell model a fit or a tracker is asked for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ModelRequest {
    /// The paper's linear model, R_i + R_ct‖CPE.
    #[default]
    Linear,
    /// With the Butler–Volmer overpotential a·asinh(I/i₀) in front of it.
    ButlerVolmer,
    /// Identification: the nonlinear model only when the data identify it
    /// (current beyond i₀, a's interval away from 0, a lower BIC), else the
    /// linear one. Online: the model of the prior, linear without one.
    Auto,
}

impl ModelRequest {
    /// `"linear"`, `"butler-volmer"` or `"auto"`.
    pub fn as_str(self) -> &'static str {
        match self {
            ModelRequest::Linear => "linear",
            ModelRequest::ButlerVolmer => "butler-volmer",
            ModelRequest::Auto => "auto",
        }
    }
}

/// The basis of the nonlinearity from its name: `poly:m` means
/// f_j(u) = u^j, j = 1..m (1 ≤ m ≤ 4).
pub fn parse_basis(s: &str) -> Result<usize> {
    match s.strip_prefix("poly:").map(str::parse::<usize>) {
        Some(Ok(m)) if (1..=4).contains(&m) => Ok(m),
        _ => bail!(Options, "--basis `{s}`: expected poly:m with 1 ≤ m ≤ 4"),
    }
}

/// One entry of the iteration history.
#[derive(Serialize, Clone, Copy, Debug)]
pub struct HistoryEntry {
    /// Iteration k.
    pub k: u32,
    /// α̂_k.
    pub alpha: f64,
    /// Cost after iteration k.
    pub cost: f64,
}

/// The note a face shows when a record was cut at [`MAX_ROWS`] rows
/// (`None` when it was not).
pub fn truncation_note(path: &Path, rows: usize) -> Option<String> {
    (rows == MAX_ROWS).then(|| {
        format!(
            "note: {}: only the first {MAX_ROWS} rows are identified (use `online` for longer records)",
            path.display()
        )
    })
}

/// The iterations the CLI's table shows.
fn table_row(k: u32) -> bool {
    k == 1 || k.is_multiple_of(10)
}
