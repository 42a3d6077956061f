//! The paper's regression (2S-OP-GI) as `identify battery` runs it
//! ([`RegressionRun`]): over the whole record as the paper's method, over
//! the record's most excited stretch as the refinement's first start, in a
//! window sized to those rows, with its history and table of estimates
//! ([`PaperRun`]).
//!
//! As the start on [`PROJECTED_START_ROWS`] rows or more, each iteration
//! solves θ by least squares at the current order
//! ([`PaperRegressionGi::iterate_projected`]) instead of 2S-OP-GI's one
//! gradient step: it reaches the regression's minimum in about a dozen
//! iterations, where 2S-OP-GI's 50 stop part of the way there and were
//! half of `identify battery` on an 8 000-row record (docs/performance.md).
//!
//! It owns that loop; it must not choose the stretch
//! ([`super::starts::most_excited`]) nor refine ([`super::refine`]).

use super::starts::{PROJECTED_START_ROWS, PROJECTED_START_TOLERANCE};
use super::{table_row, BatteryMethod, HistoryEntry};
use crate::branch::FftSums;
use crate::err;
use crate::error::Result;
use estimator_core::battery::regression::PaperRegressionGi;
use estimator_core::battery::{BatterySettings, CellParameters};
use estimator_core::window::SampleWindow;
use std::path::Path;

/// One run of the paper's regression over a record's rows: as the
/// paper's method over all of them, as the refinement's start over its
/// most excited stretch.
pub(super) struct RegressionRun<'a> {
    pub(super) path: &'a Path,
    pub(super) current: &'a [f64],
    /// The voltage with every sample filled (the regression needs one at
    /// each).
    pub(super) measured: &'a [f64],
    pub(super) settings: &'a BatterySettings<f64>,
    pub(super) iterations: u32,
    pub(super) method: BatteryMethod,
    pub(super) print_table: bool,
}

/// What the paper's regression left.
pub(super) struct PaperRun {
    pub(super) history: Vec<HistoryEntry>,
    /// Its estimate after each iteration.
    pub(super) track: Vec<Option<CellParameters<f64>>>,
    pub(super) converged: bool,
    /// Why it stopped before its iterations, as the refinement's start
    /// (which then starts from the data alone).
    pub(super) failed: Option<String>,
    /// Its last estimate, when physical.
    pub(super) estimate: Option<CellParameters<f64>>,
}

impl RegressionRun<'_> {
    /// Runs the regression on `rows` with a window of `NR` rows and
    /// memories up to `MEM`: the refinement's start holds no more than its
    /// stretch (on a 200 000-row record 0.7 MB instead of 23 MB, every
    /// page of which was touched).
    #[inline(never)]
    pub(super) fn run<const NR: usize, const MEM: usize>(
        &self,
        rows: std::ops::Range<usize>,
    ) -> Result<PaperRun> {
        let path = self.path;
        let ctx = |e: estimator_core::Error| err!(Estimator, "{}: {e}", path.display());
        let projected = self.method == BatteryMethod::Refined && rows.len() >= PROJECTED_START_ROWS;
        let Ok(mut win) = crate::worker::boxed(|| {
            Ok::<_, std::convert::Infallible>(SampleWindow::<f64, NR>::new())
        });
        for (&i, &v) in self.current[rows.clone()].iter().zip(&self.measured[rows]) {
            win.push(i, v).map_err(ctx)?;
        }
        // As a start the projected regression stops once an iteration moves
        // θ and α by less than `PROJECTED_START_TOLERANCE`: the refinement
        // takes it from there.
        let start_settings = BatterySettings {
            epsilon: PROJECTED_START_TOLERANCE,
            ..*self.settings
        };
        let sg = if projected {
            &start_settings
        } else {
            self.settings
        };
        let mut gi =
            crate::worker::boxed(|| PaperRegressionGi::<f64, NR, MEM, FftSums>::new(sg, 0.5))
                .map_err(ctx)?;
        let mut out = PaperRun {
            history: Vec::new(),
            track: Vec::new(),
            converged: false,
            failed: None,
            estimate: None,
        };
        if self.print_table {
            println!(
                "{:>5} {:>10} {:>10} {:>10} {:>8} {:>9} {:>12}",
                "k", "R_i", "R_ct", "Q", "alpha", "U_oc", "cost"
            );
        }
        // As the refinement's start the regression is one start of several:
        // when it fails (its rows past the memory carry no excitation, or a
        // non-finite value), the refinement starts from the data alone.
        // The note goes with the result (`start_note`), for the face to show:
        // when the refinement fails as well, its error is the one line.
        for _ in 0..self.iterations {
            let step = if projected {
                gi.iterate_projected(sg, &*win)
            } else {
                gi.iterate(sg, &*win)
            };
            let it = match step {
                Ok(it) => it,
                Err(e) if self.method == BatteryMethod::Refined => {
                    out.failed = Some(format!(
                        "2S-OP-GI stopped after {} iterations ({e}); the refinement starts from the data alone",
                        out.history.len()
                    ));
                    break;
                }
                Err(e) => return Err(ctx(e)),
            };
            out.history.push(HistoryEntry {
                k: it.k,
                alpha: it.alpha,
                cost: it.cost,
            });
            let cell = gi.cell();
            out.track.push(cell);
            out.converged = it.converged;
            if self.print_table && (table_row(it.k) || it.converged) {
                match cell {
                    Some(c) => println!(
                        "{:>5} {:>10.6} {:>10.6} {:>10.3} {:>8.4} {:>9.5} {:>12.5e}",
                        it.k, c.r_i, c.r_ct, c.q, c.alpha, c.u_oc, it.cost
                    ),
                    None => println!(
                        "{:>5} {:>10} {:>10} {:>10} {:>8.4} {:>9} {:>12.5e}",
                        it.k, "-", "-", "-", it.alpha, "-", it.cost
                    ),
                }
            }
            if it.converged {
                break;
            }
        }
        out.estimate = gi.cell();
        Ok(out)
    }
}
