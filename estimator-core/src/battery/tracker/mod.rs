//! One cell's tracker: what the online estimator keeps and does for each
//! cell between samples, shared by [`super::online::CellEstimator`] (one
//! cell) and [`super::pack::PackEstimator`] (many).
//!
//! It owns the settings ([`OnlineSettings`]), the per-cell state
//! ([`CellState`]: voltages, estimate, state of charge, counters, the
//! estimators' iteration state), the working area the cells share one at a
//! time ([`WorkingArea`]), the pack's current history and a cell's view of
//! it ([`CurrentHistory`], [`CellWindow`]), the guard that validates and
//! substitutes each sample ([`guard`]), the iterations and the
//! plausibility check before an estimate is published ([`iterate`]), and
//! which parameters the data identify ([`identified`]), and the slow part
//! carried across windows ([`fusion`]). The
//! per-sample flow is described in [`super::online`].
//!
//! It must not touch the pack's schedule or health (which cell updates in
//! which period: [`super::pack`]), and it never imports the one-cell or the
//! pack estimator: both are built on it. Its public items are re-exported
//! from [`super::online`], their public path.

mod fusion;
mod guard;
mod history;
mod identified;
mod iterate;
mod restore;
mod settings;
mod state;
mod status;

pub(crate) use fusion::{plausible_parts, SLOW_PARTS};
pub use history::{CellWindow, CurrentHistory};
pub(crate) use identified::{clean_edge, precise_change};
pub use identified::{
    Identification, PublishedParameter, PublishedParameters, StepResistance, STEP_PRECISION,
};
pub(crate) use restore::CellSnapshot;
pub use restore::Restoration;
pub(crate) use settings::check_limits;
pub use settings::{Method, OnlineSettings};
pub use state::{CellState, WorkingArea};
pub use status::{Rejection, SampleCounts, SampleReport, Status};
