//! # fracbms-host
//!
//! The host library of fracbms: everything the PC does with records, in one
//! place under every face. The `host-sim` command line, the C ABI
//! (`estimator-ffi`, whole-record identification on the host) and the
//! Python package (`python/`) are thin adapters over these functions, so
//! one change here reaches all three.
//!
//! | module | owns |
//! |---|---|
//! | [`cycler`] | cycler exports as they come: columns recognised by their headers or named, units, the current's sign, non-uniform logs put on a uniform period |
//! | [`io`] | CSV records and OCV tables in, CSV and JSON out (atomic writes), one-line errors that name the file, row and column |
//! | [`ocv`] | a cell's OCV curve, capacity and start SOC, checked ([`ocv::OcvSpec`]) |
//! | [`ocv_extraction`] | the OCV table read from a test: the rests' relaxed voltages or a low-rate charge and discharge, against the counted SOC, the capacity measured |
//! | [`branch`] | the constant-phase recursion of whole-record fits solved exactly by FFT in O(N log N), with the full memory |
//! | [`identify`] | whole-record fits: the Hammerstein system (2S-OP-GI / KT-2S-GI and the prediction-error refinement) and the battery cell (the paper's regression, the output-error refinement, the Butler–Volmer choice) |
//! | [`predict`] | validation on another record: a fit run on a log's current, RMSE and largest error against the measured voltage |
//! | [`map`] | parameter maps: the rows per SOC level and temperature, their CSV, the cell at a SOC, the plot (built by [`identify::map`]) |
//! | [`trust`] | rows rejected before a fit, 95 % intervals and the identifiability verdict |
//! | [`online`] | the sliding-window cell estimator run over a record ([`online::Tracker`]) |
//! | [`pack`] | the pack estimator over a pack record, and pack simulation |
//! | [`simulate`] | synthetic Hammerstein and battery records |
//! | [`plot`], [`reproduce`] | SVG figures, and the paper's tables and figures |
//! | [`error`] | the typed [`Error`] every function returns |
//! | [`choice`] | the names of the option enums, as every face spells them |
//! | [`worker`] | the worker thread with the stack the estimators need |
//!
//! What it must not touch: argument parsing (clap lives in `host-sim`
//! only), Python or C types (those live in their faces), and the numerics
//! of the estimators (those are `estimator-core`'s; this crate drives them
//! in `f64`, or `f32` as the firmware does).
//!
//! Conventions, stated once: current in A, positive when **charging**;
//! voltages in V; time in s; SOC in [0, 1]; capacity in A·h.
//!
//! ```
//! use fracbms_host::identify::{battery_identify, BatteryMethod, ModelRequest, Refine};
//! use fracbms_host::io::BatteryRecord;
//! use fracbms_host::simulate::{battery_voltage, OcvCurve};
//! use estimator_core::battery::CellParameters;
//! use std::path::Path;
//!
//! // A cell's voltage over a square-wave current, identified back.
//! let cell = CellParameters::cell_18650();
//! let current: Vec<f64> = (0..400).map(|l| if (l / 25) % 2 == 0 { 3.0 } else { -3.0 }).collect();
//! let v = battery_voltage(&cell, &current, 1.0, OcvCurve::Constant)?;
//! let rec = BatteryRecord {
//!     time: (0..400).map(f64::from).collect(),
//!     current,
//!     voltage: v.clean,
//!     h: 1.0,
//! };
//! let refine = Refine { model: ModelRequest::Linear, ..Refine::default() };
//! let fit = fracbms_host::worker::on_worker(|| {
//!     battery_identify(Path::new("example"), &rec, None, BatteryMethod::Refined, None, 50, false, refine)
//! })?;
//! assert!((fit.cell.r_i / cell.r_i - 1.0).abs() < 0.01);
//! # Ok::<(), fracbms_host::Error>(())
//! ```

#![deny(missing_docs)]

pub mod branch;
pub mod choice;
pub mod cycler;
pub mod error;
pub mod identify;
pub mod io;
pub mod map;
pub mod ocv;
pub mod ocv_extraction;
pub mod online;
pub mod pack;
pub mod plot;
pub mod predict;
pub mod presets;
pub mod progress;
pub mod reproduce;
pub mod simulate;
pub mod trust;
pub mod worker;

pub use error::{Error, ErrorKind, Result};
