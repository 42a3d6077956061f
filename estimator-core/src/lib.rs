//! # estimator-core
//!
//! `no_std`, allocation-free identification of **fractional-order
//! block-oriented (Hammerstein) systems** after Ji, Wang & Meng, *Iterative
//! parameter identification for fractional-order block-oriented nonlinear
//! systems with application to a battery model*.
//!
//! ## Tour
//! * [`frac`] — Grünwald–Letnikov fractional differences `Δ^α` with short
//!   (truncated) memory, and their derivative with respect to the order;
//!   who computes their tap sums over many rows ([`frac::TapSums`]: the
//!   direct kernels, or a host's by FFT).
//! * [`window`] — the sliding data window (`O(1)` push, NaN rejection).
//! * [`model`] — the identification model of eq. (4): orders, basis
//!   functions, a simulator.
//! * [`gi`] — the paper's algorithms: [`gi::over_param`] (2S-OP-GI) and
//!   [`gi::key_term`] (KT-2S-GI), one iteration per call, with the order α
//!   estimated by a safeguarded line search ([`gi::line_search`]).
//! * [`battery`] — the fractional-order battery model of §6.2: simulation,
//!   the paper's regression with 2S-OP-GI, our output-error refinement (with
//!   an optional prior), the OCV curve and coulomb-counted state of charge
//!   ([`battery::ocv`]), the Butler–Volmer overpotential `a·asinh(I/i₀)`
//!   ([`battery::CellModel`]; the linear model is its case `a = 0`), and the
//!   sliding-window cell estimator a BMS runs per cell, with its
//!   plausibility guard ([`battery::online`]), and the pack estimator that
//!   runs it for every series cell: the current kept once, per-cell state
//!   under 2 KiB, one shared working area, a per-period schedule and the
//!   flag of a cell that stands out ([`battery::pack`]).
//! * [`tail`] — the Grünwald–Letnikov weights beyond the memory as a sum of
//!   exponentials with fixed rates (the far past carried by a few
//!   recursions; for reducing the short-memory bias).
//! * [`flops`] — the flop counts of the paper's Tables 1–2.
//! * [`error`] — the typed errors; nothing in this crate panics on bad data.
//!
//! ## What it owns, and must not touch
//! The numerics every face shares: the firmware, the C ABI and the host
//! library (`fracbms-host`, under the CLI and Python) all call these
//! functions. It imports from no other crate of the workspace, and must not
//! touch I/O, the heap, `std` or a clock; records, files and flags belong
//! to `fracbms-host`, hardware to `firmware`. Inside, modules import one way
//! (`scripts/layout_check.py` checks it): e.g. `battery::online` → `pack` →
//! the private per-cell tracker.
//!
//! Sizes are const generics (window `N`, memory `MEM`, order capacities
//! `NA, NB, NC`, basis capacity `NF`, product capacity `NP ≥ n_b·m`); the
//! runtime orders may be smaller. The scalar is `f32` or `f64` ([`Real`]).
//!
//! ## Features
//! * `host-simd` (default) — on x86-64, the fractional-difference kernels
//!   run with AVX2 when the CPU has it (run-time detection by `pulp`, which
//!   holds the `unsafe` code; this crate forbids its own). The values are
//!   bit for bit those of the plain build. No effect on other targets, so
//!   firmware builds do not pull `pulp` in.
//! * `defmt` — `defmt::Format` for the public error and report types.
//!
//! ## Example
//! Identify a Hammerstein system simulated from eq. (4):
//!
//! ```
//! use estimator_core::frac::GlWeights;
//! use estimator_core::gi::{over_param::OverParamGi, GiSettings};
//! use estimator_core::model::{HammersteinSystem, Orders, Polynomial};
//! use estimator_core::window::SampleWindow;
//!
//! const N: usize = 400;
//! const MEM: usize = 32;
//! let sys = HammersteinSystem {
//!     a: &[-0.3, 0.1], b: &[1.0, 0.5], c: &[], gamma: &[1.0, 0.3], alpha: 0.6,
//! };
//! let w = GlWeights::<f64, MEM>::new(sys.alpha, 1.0, MEM).unwrap();
//! // A deterministic, persistently exciting input and no noise.
//! let u: Vec<f64> = (0..N).map(|l| ((l * 7919 % 101) as f64 / 50.0) - 1.0).collect();
//! let v = vec![0.0; N];
//! let (mut y, mut e) = (vec![0.0; N], vec![0.0; N]);
//! sys.simulate(&Polynomial, &w, &u, &v, &mut y, &mut e).unwrap();
//!
//! let orders = Orders { na: 2, nb: 2, nc: 0, m: 2 };
//! let settings = GiSettings::new(orders, MEM);
//! let mut window = SampleWindow::<f64, N>::new();
//! for (&u, &y) in u.iter().zip(&y) {
//!     window.push(u, y).unwrap();
//! }
//! let mut gi = OverParamGi::<f64, N, MEM, 2, 2, 1, 2, 4>::new(&settings, 0.5).unwrap();
//! for _ in 0..500 {
//!     if gi.iterate(&settings, &Polynomial, &window).unwrap().converged {
//!         break;
//!     }
//! }
//! let est = gi.estimate();
//! assert!((est.alpha - 0.6).abs() < 0.01);
//! assert!((est.product(1, 0) - 0.5).abs() < 0.02); // b_2 γ_1
//! ```
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod battery;
pub mod error;
pub mod flops;
pub mod frac;
pub mod gi;
pub mod model;
pub mod real;
pub mod tail;
pub mod window;

pub use error::{Error, FracError};
pub use real::Real;
