//! One update of a cell: the excitation test, the iterations of the chosen
//! method (the paper's 2S-OP-GI, then the output-error refinement), and the
//! plausibility check before an estimate is published.

use super::*;
use crate::battery::CellParameters;
use crate::error::Error;
use crate::frac::GlWeights;
use crate::real::Real;

impl<T: Real, const N: usize> CellState<T, N> {
    /// One update of the cell once its sample is in the window: the
    /// iterations when `scheduled` (none otherwise), the status set, and
    /// the cell's report.
    pub(crate) fn update<const MEM: usize, const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        history: &CurrentHistory<T, N>,
        work: &mut WorkingArea<T, N, MEM>,
        k: usize,
        scheduled: bool,
    ) -> SampleReport<T> {
        let (status, iterations) = if scheduled {
            self.run(s, history, work, k)
        } else {
            (self.status, 0)
        };
        self.status = status;
        SampleReport {
            status,
            rejected: self.last_rejection,
            iterations,
            rmse: self.rmse,
        }
    }

    /// The iterations of one update (after its sample is in the window).
    pub(super) fn run<const MEM: usize, const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        history: &CurrentHistory<T, N>,
        work: &mut WorkingArea<T, N, MEM>,
        k: usize,
    ) -> (Status, u16) {
        let b = &s.battery;
        // Whether the last window alone identified `R_i` (before `hold`).
        let evidence = self.r_i_evidence(s);
        // No new evidence unless a window's fit says otherwise below.
        self.published.hold();
        let before = self.published.named();
        self.published.expire(self.soc, s.hold_soc_span);
        for ((slot, (_, was)), (_, now)) in self
            .stale
            .iter_mut()
            .zip(before)
            .zip(self.published.named())
        {
            if let (None, Some(v)) = (now.value, was.value) {
                *slot = v;
            }
        }
        // Saturating: `push` may be given other settings than the
        // constructor's (memory 0 or `usize::MAX` then means "never enough").
        // A window begun at a rested cell (after a gap, or at power-up with
        // `Start::AtRest`), once refining and until it slides, is fitted
        // whole from rest, as the refinement fits it (its `warm`;
        // `Window::starts_at_rest`): a pulse in its first `memory − 1`
        // samples is fitted, not taken as the history of the rows after it.
        let len = usize::from(self.len);
        let rested = self.at_rest || b.start == crate::battery::Start::AtRest;
        let from_rest =
            self.refining && rested && !crate::window::Window::has_slid(&self.view(history));
        let warm = if from_rest {
            0
        } else {
            b.memory.saturating_sub(1)
        };
        let need = warm.saturating_add(crate::battery::regression::MIN_ROWS);
        if len < need {
            return (Status::Filling, 0);
        }
        // Current excitation over the fitted part of the window.
        let fitted = len.saturating_sub(warm);
        let count = T::lit(fitted as f64);
        // Newest first, as the window's samples (the same sums to the bit),
        // over the ring's two runs of the last `fitted` currents (fewer
        // when the cell's window holds fewer).
        let (near, far) = history.newest_runs(fitted.min(len));
        let mean = newest_first_fold(near, far, |a, i| a + i) / count;
        let var = newest_first_fold(near, far, |a, i| a + (i - mean) * (i - mean)) / count;
        if var.sqrt() <= b.min_current_std {
            return (Status::NotExcited, 0);
        }
        // Nor, once refining, when the excitation has left the fitted rows
        // for the warm-up: the fit would see its relaxation alone, with the
        // current that drove it outside the rows it fits, and trade the
        // branch's parameters along it. On the measured Panasonic cell the
        // last window of each pulse, its fitted rows holding a partial
        // sample of it, was identified, held through the 20-minute rest and
        // put the next pulse up to 64 % of its drop off
        // (docs/bms-states.md). The paper method's start-up runs as the
        // paper has it.
        if self.refining && !excitation_in_fitted_rows(history, (len, fitted), mean, var) {
            return (Status::NotExcited, 0);
        }
        self.current_std = var.sqrt();
        if work.take(s, k, self).is_err() {
            return (Status::Held, 0);
        }
        work.oe.set_r_i_evidence(evidence);
        let mut status = self.status;
        let mut iterations = 0;
        for _ in 0..s.iterations_per_sample {
            let ok = if self.refining {
                self.step_refined(s, history, work)
            } else {
                self.step_paper(s, history, work)
            };
            iterations += 1;
            match ok {
                Ok(st) => status = st,
                Err(Error::NotExcited) => {
                    status = Status::NotExcited;
                    break;
                }
                Err(_) => {
                    status = Status::Held;
                    break;
                }
            }
        }
        self.gi = work.gi.state();
        self.oe = work.oe.state();
        (status, iterations)
    }

    /// Publishes `p` when it is plausible from a window of `rows` fitted
    /// samples; otherwise says why it is held.
    pub(super) fn publish<const MEM: usize, const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        w: &mut GlWeights<T, MEM>,
        p: CellParameters<T>,
        rmse: T,
        rows: usize,
    ) -> Result<(), Status> {
        if let Some(why) = s.implausible(&p, rows, self.current_std, rmse) {
            return Err(why);
        }
        if w.set_order(p.alpha).is_ok() {
            self.estimate = Some(p);
            self.rmse = rmse;
            Ok(())
        } else {
            Err(Status::Held)
        }
    }

    pub(super) fn step_paper<const MEM: usize, const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        history: &CurrentHistory<T, N>,
        work: &mut WorkingArea<T, N, MEM>,
    ) -> Result<Status, Error> {
        let it = work.gi.iterate(&s.battery, &self.view(history))?;
        let rows = T::lit(it.rows.max(1) as f64);
        let cell = work.gi.cell();
        let mut status = Status::Starting;
        if let Some(p) = cell {
            let rmse = (T::lit(2.0) * it.cost / rows).sqrt();
            status = match self.publish(s, &mut work.pw, p, rmse, it.rows) {
                Ok(()) => Status::Tracking,
                Err(why) => why,
            };
        }
        if s.method == Method::Refined
            && (it.k >= s.paper_budget || (cell.is_some() && it.converged))
        {
            let start = self
                .estimate
                .filter(|p| p.alpha >= s.battery.alpha_min && p.alpha <= s.battery.alpha_max)
                .unwrap_or(s.initial_in_window());
            work.oe.set_cell(&s.battery, start)?;
            self.refining = true;
        }
        Ok(status)
    }

    pub(super) fn step_refined<const MEM: usize, const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        history: &CurrentHistory<T, N>,
        work: &mut WorkingArea<T, N, MEM>,
    ) -> Result<Status, Error> {
        let st = work.oe.iterate(&s.battery, &self.view(history))?;
        let p = work.oe.cell();
        match self.publish(s, &mut work.pw, p, st.rmse, st.rows) {
            Ok(()) => {
                let evidence = work.oe.r_i_evidence().is_some();
                self.judge(s, &p, work.oe.last_information(), evidence);
                Ok(Status::Tracking)
            }
            Err(why) => {
                // Not plausible: held, and the refinement starts again from
                // the last good estimate (or the settings' start), so that
                // it does not wander further from where the window's
                // information is.
                let back = self.estimate.unwrap_or(s.initial_in_window());
                if work.oe.set_cell(&s.battery, back).is_err() {
                    let _ = work.oe.set_cell(&s.battery, s.initial_in_window());
                }
                Ok(why)
            }
        }
    }
}

/// The least standard deviation of the current over a window's fitted rows,
/// as a share of the whole window's (its warm-up included), for the window
/// to be fitted: below it the excitation is in the warm-up. A lone pulse in a
/// window of 256 samples (memory 64) passes while about a fifth of its
/// samples are in the fitted rows.
const FITTED_SHARE: f64 = 0.5;

/// Whether the current's variance over a window's fitted rows (`var`, about
/// their `mean`) is at least [`FITTED_SHARE`]² of its variance over the
/// whole window of `len` samples, the `fitted` newest and the warm-up
/// before them: the warm-up's sums alone are taken (the oldest
/// `len − fitted` samples), and joined to the fitted rows' (Chan, Golub and
/// LeVeque's pairwise update of the sum of squared deviations).
fn excitation_in_fitted_rows<T: Real, const N: usize>(
    history: &CurrentHistory<T, N>,
    (len, fitted): (usize, usize),
    mean: T,
    var: T,
) -> bool {
    let warm = len.saturating_sub(fitted);
    if warm == 0 {
        return true;
    }
    // Newest first the window reads `near` backwards, then `far`: its
    // oldest `warm` samples are the front of `far` and, past `far`, of
    // `near`.
    let (near, far) = history.newest_runs(len);
    let skip_far = fitted.saturating_sub(near.len());
    let near = near
        .get(..near.len().saturating_sub(fitted))
        .unwrap_or_default();
    let far = far
        .get(..far.len().saturating_sub(skip_far))
        .unwrap_or_default();
    let n_w = T::lit(warm as f64);
    let n_f = T::lit(fitted as f64);
    let n = T::lit(len as f64);
    let mean_w = newest_first_fold(near, far, |a, i| a + i) / n_w;
    let m2_w = newest_first_fold(near, far, |a, i| a + (i - mean_w) * (i - mean_w));
    let d = mean_w - mean;
    let whole = (var * n_f + m2_w + d * d * n_f * n_w / n) / n;
    var >= T::lit(FITTED_SHARE * FITTED_SHARE) * whole
}

/// `f` folded from zero over the runs of [`CurrentHistory::newest_runs`],
/// newest first.
#[inline(always)]
fn newest_first_fold<T: Real>(near: &[T], far: &[T], f: impl Fn(T, T) -> T) -> T {
    let s = near.iter().rev().fold(T::zero(), |a, &i| f(a, i));
    far.iter().rev().fold(s, |a, &i| f(a, i))
}
