//! # host-sim
//!
//! The PC side of fracbms: simulate fractional Hammerstein systems and
//! battery cells, identify them from CSV files with `estimator-core` (f64),
//! track a cell online over a sliding window, and reproduce the paper's
//! tables and figures. The binary's commands are in [`cli`]; the library is
//! what they call, for use in tests and notebooks.

pub mod cli;
pub mod identify;
pub mod io;
pub mod ocv;
pub mod online;
pub mod pack;
pub mod plot;
pub mod presets;
pub mod progress;
pub mod reproduce;
pub mod simulate;
pub mod trust;
