//! The per-cell state ([`CellState`]) and the working area the cells share
//! one at a time ([`WorkingArea`]): settings, per-cell state and scratch
//! apart, as in the pack.

use super::fusion::SlowFusion;
use super::settings::REST_SAMPLES;
use super::*;
use crate::battery::output_error::{OutputErrorRefinement, RefinementState, RefinementWork};
use crate::battery::regression::{PaperRegressionGi, PaperRegressionState};
use crate::battery::soc::{SocEstimate, SocObserver};
use crate::battery::CellParameters;
use crate::error::Error;
use crate::frac::GlWeights;
use crate::real::Real;
use crate::tail::PastModes;

/// What one cell carries between samples: its voltages (aligned with the
/// pack's [`CurrentHistory`]), its estimate, state of charge, counters and
/// the iteration state of its estimators. Everything an iteration needs
/// beyond this is in the shared [`WorkingArea`].
#[derive(Clone, Debug)]
pub struct CellState<T, const N: usize> {
    /// Voltages in the window's coordinates (the overpotential with an OCV
    /// curve), in the pack's ring.
    pub(super) u: [T; N],
    /// Samples of the ring that belong to this cell's window.
    pub(super) len: u16,
    /// Samples pushed since the window's last restart.
    pub(super) pushed: u64,
    /// Changes with every change of the window (see [`crate::window::Window::version`]).
    pub(super) version: u32,
    pub(super) gi: PaperRegressionState<T>,
    pub(super) oe: RefinementState<T>,
    pub(super) refining: bool,
    /// The last good estimate, in the window's coordinates (`u_oc` is `ΔU`
    /// with an OCV curve).
    pub(super) estimate: Option<CellParameters<T>>,
    /// State of charge after the last sample (with an OCV curve, once known).
    pub(super) soc: Option<T>,
    /// `OCV(SOC)` after the last sample (with a curve; `None` without).
    pub(super) ocv_now: Option<T>,
    /// While the start SOC is read from the leading rested samples: their
    /// number, voltage sum and the start SOC they gave.
    pub(super) rest_start: Option<(u8, T, T)>,
    /// Standard deviation of the current over the window's fitted part (A).
    pub(super) current_std: T,
    pub(super) rmse: T,
    /// The mean absolute one-step innovation `|y − ŷ|` over the accepted
    /// samples at a steady current (V; NaN before the first): the robust
    /// scale the spike test judges such samples by
    /// ([`super::OnlineSettings::spike_sigmas`]). Spikes the window has
    /// accepted inflate its `rmse`, not this.
    pub(super) spike_scale: T,
    /// The last accepted sample's current and voltage (the window's
    /// coordinates), and whether its current was steady against the one
    /// accepted before it: what a voltage jump is judged against before any
    /// estimate (a substitute is no measurement; a sample taken at a
    /// current step may itself be a spike no test saw). `None` after a
    /// restart.
    pub(super) last_good: Option<(T, T, bool)>,
    pub(super) status: Status,
    pub(super) counts: SampleCounts,
    pub(super) spikes_in_row: u8,
    /// Whether the last sample was rejected, and why.
    pub(super) last_rejection: Option<Rejection>,
    /// The modes of the samples that left the window (the past the
    /// refinement's tail needs, [`BatterySettings::tail`]).
    pub(super) past: PastModes<T>,
    /// What is published of each parameter, and whether the data
    /// identify it ([`super::identified`]).
    pub(super) published: PublishedParameters<T>,
    /// The slow part carried across windows ([`super::fusion`]).
    pub(super) slow: SlowFusion<T>,
    /// Each parameter's last published value once it has expired
    /// (`[R_i, R_ct, Q, α]`, NaN: none): what a state of power falls back
    /// on ([`crate::battery::power::SopBasis::Stale`]).
    pub(super) stale: [T; 4],
    /// The last precise current step's resistance.
    pub(super) step: Option<StepResistance<T>>,
    /// The SOC observer beside the count (with a curve).
    pub(super) soc_observer: SocObserver<T>,
    /// Whether the cell started from a snapshot ([`crate::battery::snapshot`]).
    pub(super) restoration: Restoration,
    /// A restored SOC not yet checked against a rested first voltage.
    pub(super) soc_check: bool,
    /// The window began at a rested cell after a gap
    /// ([`Self::resume_after_gap`]): until it slides, the refinement takes
    /// the polarization before its first sample as zero and fits it whole.
    pub(super) at_rest: bool,
}

/// The working area a pack's cells share, one cell at a time: the two
/// estimators' window-length arrays and caches, and the weights of the
/// one-step prediction. It belongs to the last cell iterated; another
/// cell's iteration first loads that cell's state into it.
#[derive(Clone, Debug)]
pub struct WorkingArea<T, const N: usize, const MEM: usize> {
    pub(super) gi: PaperRegressionGi<T, N, MEM>,
    pub(super) oe: OutputErrorRefinement<T, N, MEM>,
    /// Weights at the order of the cell being predicted.
    pub(super) pw: GlWeights<T, MEM>,
    pub(super) owner: Option<usize>,
}

impl<T: Real, const N: usize, const MEM: usize> WorkingArea<T, N, MEM> {
    /// Cell `k`'s estimate `p` (window coordinates) with its simulated
    /// polarization, the window version it was simulated on, and the
    /// weights at its order, when the area is that cell's and the last
    /// iteration left them in step with `p`.
    pub(crate) fn polarization_of(
        &self,
        k: usize,
        p: &CellParameters<T>,
    ) -> Option<(&[T], u32, &GlWeights<T, MEM>)> {
        let (q, up, stamp) = self.oe.simulated()?;
        (self.owner == Some(k) && q == *p && self.pw.alpha() == p.alpha)
            .then_some((up, stamp, &self.pw))
    }

    /// The one-step prediction's weights (at the order of the cell last
    /// predicted or published).
    pub(crate) fn weights(&self) -> &GlWeights<T, MEM> {
        &self.pw
    }

    pub(crate) fn new<const P: usize>(s: &OnlineSettings<T, P>) -> Result<Self, Error> {
        Ok(Self {
            gi: PaperRegressionGi::new(&s.battery, s.alpha0)?,
            oe: OutputErrorRefinement::new(&s.battery, s.initial_in_window())?,
            pw: GlWeights::new(s.initial.alpha, s.battery.h, s.battery.memory)?,
            owner: None,
        })
    }

    /// A working area built at compile time: its estimators' blank values
    /// (every window array 0), no cell's; [`init`](Self::init) before use.
    pub(crate) const BLANK: Self = Self {
        gi: PaperRegressionGi::BLANK,
        oe: OutputErrorRefinement::BLANK,
        pw: GlWeights::BLANK,
        owner: None,
    };

    /// Makes this area, whatever it held, the one [`new`](Self::new)
    /// returns, in place (no copy of its arrays on the stack).
    ///
    /// # Errors
    /// As [`new`](Self::new); on error the area is no cell's and must be
    /// initialised again before use.
    pub(crate) fn init<const P: usize>(&mut self, s: &OnlineSettings<T, P>) -> Result<(), Error> {
        self.owner = None;
        self.gi.init(&s.battery, s.alpha0)?;
        self.oe.init(&s.battery, s.initial_in_window())?;
        self.pw
            .reset(s.initial.alpha, s.battery.h, s.battery.memory)?;
        Ok(())
    }

    /// The area is no cell's: the next iteration loads its cell's state
    /// (after the cells were replaced, by a restore).
    pub(crate) fn release(&mut self) {
        self.owner = None;
    }

    /// Loads cell `k`'s iteration state unless the area is already its.
    pub(super) fn take<const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        k: usize,
        cell: &CellState<T, N>,
    ) -> Result<(), Error> {
        if self.owner != Some(k) {
            self.owner = None;
            self.gi.resume(&s.battery, &cell.gi)?;
            self.oe.resume(&s.battery, &cell.oe)?;
            self.owner = Some(k);
        }
        Ok(())
    }
}

impl<T: Real, const N: usize> CellState<T, N> {
    /// A cell with an empty window: its estimators' states are those of a
    /// new working area ([`WorkingArea::new`]; test
    /// `a_new_cell_holds_a_new_working_area_state`).
    pub(crate) fn new<const MEM: usize, const P: usize>(s: &OnlineSettings<T, P>) -> Self {
        let mut cell = Self::BLANK;
        cell.reset::<MEM, P>(s);
        cell
    }

    /// A cell built at compile time: every number 0, nothing known;
    /// [`reset`](Self::reset) before use.
    pub(crate) const BLANK: Self = Self {
        u: [T::ZERO; N],
        len: 0,
        pushed: 0,
        version: 0,
        gi: PaperRegressionState::BLANK,
        oe: RefinementState::BLANK,
        refining: false,
        estimate: None,
        soc: None,
        ocv_now: None,
        rest_start: None,
        current_std: T::ZERO,
        rmse: T::ZERO,
        spike_scale: T::ZERO,
        last_good: None,
        status: Status::Filling,
        counts: SampleCounts {
            samples: 0,
            non_finite: 0,
            out_of_range: 0,
            spikes: 0,
        },
        spikes_in_row: 0,
        last_rejection: None,
        past: PastModes::new(),
        published: PublishedParameters::NONE,
        slow: SlowFusion::EMPTY,
        stale: [T::NAN; 4],
        soc_observer: SocObserver::BLANK,
        step: None,
        restoration: Restoration::Clean,
        soc_check: false,
        at_rest: false,
    };

    /// Makes this cell, whatever it held, a cell with an empty window
    /// ([`new`](Self::new)'s), in place.
    pub(crate) fn reset<const MEM: usize, const P: usize>(&mut self, s: &OnlineSettings<T, P>) {
        self.u.fill(T::ZERO);
        self.len = 0;
        self.pushed = 0;
        self.version = 0;
        self.gi = PaperRegressionGi::<T, N, MEM>::initial_state(s.alpha0);
        self.oe = OutputErrorRefinement::<T, N, MEM>::initial_state(s.initial_in_window());
        self.refining = s.method == Method::Refined && s.battery.prior.is_some();
        self.estimate = None;
        self.soc = None;
        self.ocv_now = None;
        self.rest_start = None;
        self.current_std = T::zero();
        self.rmse = T::infinity();
        self.spike_scale = T::nan();
        self.last_good = None;
        self.status = Status::Filling;
        self.counts = SampleCounts::default();
        self.spikes_in_row = 0;
        self.last_rejection = None;
        self.past = PastModes::new();
        self.published = PublishedParameters::NONE;
        self.slow = SlowFusion::EMPTY;
        self.stale = [T::NAN; 4];
        self.soc_observer = SocObserver::new(&s.soc, None);
        self.step = None;
        self.restoration = Restoration::Clean;
        self.soc_check = false;
        self.at_rest = false;
    }

    /// With a prior the refinement starts at its centre, and from a
    /// restored estimate at that estimate: the paper method's start-up is
    /// not needed.
    fn starts_refining<const P: usize>(&self, s: &OnlineSettings<T, P>) -> bool {
        s.method == Method::Refined && (s.battery.prior.is_some() || self.estimate.is_some())
    }

    /// Takes the start again from the settings, before the first sample:
    /// a prior set after the cell was built (the C ABI's
    /// `fracbms_cell_set_prior`, a map followed before the first push, as
    /// the firmware and `fracbms_cell_follow_map` do) then starts the
    /// refinement at its centre, as a prior given at construction does
    /// (`host-sim online battery --prior`). A cell restored from a
    /// snapshot starts from its restored estimate.
    pub(super) fn take_start<const MEM: usize, const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
    ) {
        let start = self.estimate.unwrap_or(s.initial_in_window());
        self.oe = OutputErrorRefinement::<T, N, MEM>::initial_state(start);
        self.refining = self.starts_refining(s);
    }

    pub(super) fn view<'a>(&'a self, history: &'a CurrentHistory<T, N>) -> CellWindow<'a, T, N> {
        CellWindow {
            history,
            cell: self,
        }
    }

    /// The last good estimate (`None` until the first one). With an OCV
    /// curve its `u_oc` is the open-circuit voltage now, `OCV(SOC) + ΔU`.
    pub fn estimate(&self) -> Option<CellParameters<T>> {
        self.estimate.map(|p| CellParameters {
            u_oc: p.u_oc + self.ocv_now.unwrap_or(T::zero()),
            ..p
        })
    }

    /// The last good estimate in the window's coordinates (`u_oc` is `ΔU`
    /// with an OCV curve).
    pub(crate) fn window_estimate(&self) -> Option<&CellParameters<T>> {
        self.estimate.as_ref()
    }

    /// The window's version (it changes with every sample pushed and every
    /// restart).
    pub(crate) fn window_version(&self) -> u32 {
        self.version
    }

    /// What is published of `R_i`, `R_ct`, `Q` and α: for each, the value
    /// of the last window whose data identified it and whether that is the
    /// last window ([`Identification`]); nothing before the first. The
    /// [`estimate`](Self::estimate) is the window's fit, identified or not.
    pub fn published(&self) -> PublishedParameters<T> {
        self.published
    }

    /// Every parameter of the model has a published value (identified,
    /// from the step, held, restored or the prior's).
    pub fn model_published(&self) -> bool {
        self.published
            .named()
            .iter()
            .all(|(_, x)| x.value.is_some())
    }

    /// The resistance of the last current step precise enough to judge
    /// `R_i` by ([`StepResistance`]).
    pub fn step_resistance(&self) -> Option<StepResistance<T>> {
        self.step
    }

    /// The OCV offset `ΔU` (V) of the last good estimate (with an OCV
    /// curve).
    pub fn ocv_offset(&self) -> Option<T> {
        self.ocv_now.and(self.estimate).map(|p| p.u_oc)
    }

    /// The coulomb-counted state of charge after the last sample (with an
    /// OCV curve, once known).
    pub fn state_of_charge(&self) -> Option<T> {
        self.soc
    }

    /// Whether the last sample was a rested one (the SOC observer's rest
    /// is in progress; always false without an OCV curve).
    pub(crate) fn resting(&self) -> bool {
        self.soc_observer.rest().is_some()
    }

    /// The voltage of a rest that has lasted at least
    /// [`SocSettings::rest_s`](crate::battery::soc::SocSettings::rest_s)
    /// and goes on (the mean of about its last half minute, as the SOC
    /// observer reads it): the cell is relaxed, its polarization gone.
    /// `None` without an OCV curve (no observer runs), and while the cell
    /// is not at rest or has rested less.
    pub fn rested_voltage<const P: usize>(&self, s: &OnlineSettings<T, P>) -> Option<T> {
        s.ocv.as_ref()?;
        let (len, v) = self.soc_observer.rest()?;
        (len >= s.soc.rest_s && v.is_finite()).then_some(v)
    }

    /// The voltage of a cell known to be relaxed now: the
    /// [`rested_voltage`](Self::rested_voltage), or that of a rest the
    /// cell has been in ever since the record began (the first sample this
    /// state counted: a new cell's, or a restored one's; once the start
    /// SOC has been read from it, over its first `REST_SAMPLES` samples), or
    /// since a window begun at a rested cell after a gap
    /// ([`Self::resume_after_gap`]). A record begun or resumed at rest is
    /// read as relaxed: its start SOC is read from it too.
    pub(crate) fn relaxed_voltage<const P: usize>(&self, s: &OnlineSettings<T, P>) -> Option<T> {
        if let Some(v) = self.rested_voltage(s) {
            return Some(v);
        }
        s.ocv.as_ref()?;
        let (len, v) = self.soc_observer.rest()?;
        // Every sample of the window, or of the record, in the rest (half a
        // period's slack).
        let slack = T::lit(0.5) * s.battery.h;
        let window = T::lit(f64::from(self.len)) * s.battery.h;
        let whole = self.at_rest && self.len > 0 && len + slack >= window;
        #[allow(clippy::cast_precision_loss)]
        let record = T::lit(self.counts.samples as f64) * s.battery.h;
        let ever = self.counts.samples >= u64::from(REST_SAMPLES) && len + slack >= record;
        ((whole || ever) && v.is_finite()).then_some(v)
    }

    /// Health after the last update.
    pub fn status(&self) -> Status {
        self.status
    }

    /// Sample counters.
    pub fn counts(&self) -> SampleCounts {
        self.counts
    }

    /// Why the last sample was rejected (`None`: it was accepted).
    pub fn last_rejection(&self) -> Option<Rejection> {
        self.last_rejection
    }

    /// The fit's RMSE (V) of the last published estimate.
    pub fn rmse(&self) -> T {
        self.rmse
    }

    /// True once the output-error refinement has taken over.
    pub fn is_refining(&self) -> bool {
        self.refining
    }

    /// What the output-error refinement has computed for this cell.
    pub fn refinement_work(&self) -> RefinementWork {
        self.oe.work()
    }

    /// See [`CellEstimator::set_state_of_charge`](crate::battery::online::CellEstimator::set_state_of_charge).
    pub fn set_state_of_charge(&mut self, soc: T) {
        if soc.is_finite() {
            self.soc = Some(soc);
            self.rest_start = None;
            self.soc_observer.set_state_of_charge(soc);
        }
    }

    /// The SOC observer's estimate (with a curve, once the start is
    /// known): the count corrected at rest, the current bias and the
    /// capacity ([`crate::battery::soc`]). [`state_of_charge`](Self::state_of_charge)
    /// is the count the window follows.
    pub fn soc_estimate<const P: usize>(&self, s: &OnlineSettings<T, P>) -> Option<SocEstimate<T>> {
        s.ocv.as_ref()?;
        self.soc_observer.estimate(&s.soc)
    }

    /// The published state of charge: the observer's once it has started,
    /// the count before (what a map prior follows on every face).
    pub fn published_state_of_charge<const P: usize>(&self, s: &OnlineSettings<T, P>) -> Option<T> {
        self.soc_estimate(s)
            .map(|e| e.soc)
            .or(self.state_of_charge())
    }

    /// The record resumes after a gap of unknown charge (a logger that
    /// stopped, a cell stored): the window restarts (no model runs across
    /// the gap) and, when `rested` (the cell at rest where the record
    /// resumes, its polarization relaxed through the gap), the state of
    /// charge is read again from the next rested voltages through the OCV
    /// curve, as at the start, and the refinement fits the restarted
    /// window from rest until it slides: a pulse in its first
    /// `memory − 1` samples is fitted, not taken as the history of the
    /// rows after it ([`crate::window::Window::starts_at_rest`]; on the
    /// Panasonic test each level's first pulse comes seconds after a gap,
    /// docs/bms-states.md). What is published stays, held (and expires by
    /// state of charge, [`super::OnlineSettings::hold_soc_span`]).
    pub fn resume_after_gap(&mut self, rested: bool) {
        self.restart_after_gap(rested);
        self.soc_observer.resume_after_gap();
        if rested {
            self.soc = None;
            self.rest_start = None;
        }
    }

    /// The record resumes after a gap whose charge is known: `charge_ah`
    /// (A·h, + charging) moved through it beyond what the samples across
    /// it counted (a cycler export's own charge count over the gap, less
    /// the current held across it). As
    /// [`resume_after_gap`](Self::resume_after_gap) the window restarts
    /// and, when `rested`, is fitted from rest until it slides; but the
    /// state of charge is counted through the gap, not read again, and
    /// the SOC observer counts it too ([`crate::battery::soc::SocObserver::bridge_gap`]):
    /// a capacity is then learned across gaps. A charge that is not
    /// finite is a gap of unknown charge.
    pub fn bridge_gap<const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        charge_ah: T,
        rested: bool,
    ) {
        if !charge_ah.is_finite() {
            self.resume_after_gap(rested);
            return;
        }
        self.restart_after_gap(rested);
        if let (Some(z), Some(m)) = (self.soc, s.ocv.as_ref()) {
            self.soc = Some(z + charge_ah / m.capacity_ah);
        }
        self.soc_observer.bridge_gap(&s.soc, charge_ah);
    }

    /// What every gap does to the window: it restarts (no model runs
    /// across a gap), begun at rest when `rested`, with no fit's RMSE or
    /// innovation scale to judge spikes by yet.
    fn restart_after_gap(&mut self, rested: bool) {
        self.clear_window();
        self.at_rest = rested;
        self.rmse = T::infinity();
        self.spike_scale = T::nan();
    }

    /// Restarts the window (the pack's ring keeps the currents); its past
    /// is forgotten.
    pub(super) fn clear_window(&mut self) {
        self.last_good = None;
        self.len = 0;
        self.pushed = 0;
        self.version = self.version.wrapping_add(1);
        self.past = PastModes::new();
        self.at_rest = false;
    }

    /// Writes `u` into the ring slot the pack's next current goes to and
    /// counts it: the window is whole again once the pack has pushed that
    /// current. A full window's oldest sample, in that slot, leaves into the
    /// past's modes (the value the window held: a substitute for a rejected
    /// sample).
    pub(super) fn push_voltage(&mut self, history: &CurrentHistory<T, N>, u: T) {
        let slot = history.slot();
        if usize::from(self.len) == N {
            let next = history.i[(slot + 1) % N];
            self.past.leave(history.i[slot], self.u[slot], next);
        }
        self.u[slot] = u;
        self.len = (usize::from(self.len) + 1).min(N) as u16;
        self.pushed += 1;
        self.version = self.version.wrapping_add(1);
    }

    /// The state of charge after a sample of `current` (with a curve and a
    /// known SOC).
    pub(super) fn soc_after<const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
        current: T,
    ) -> Option<T> {
        let m = s.ocv.as_ref()?;
        Some(m.soc_after(self.soc?, current, s.battery.h))
    }

    /// A terminal voltage in the window's coordinates, for a sample of
    /// `current`: the overpotential `U_t − OCV(SOC)` with a curve.
    pub(super) fn to_window<const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
        current: T,
        voltage: T,
    ) -> T {
        match (&s.ocv, self.soc_after(s, current)) {
            (Some(m), Some(z)) => m.overpotential(z, voltage),
            _ => voltage,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_new_cell_holds_a_new_working_area_state() {
        let mut s = OnlineSettings::new(1.0f32, 64, CellParameters::cell_18650());
        for alpha0 in [0.3f32, 0.5, 0.9] {
            s.alpha0 = alpha0;
            let work = WorkingArea::<f32, 256, 64>::new(&s).unwrap();
            let cell = CellState::<f32, 256>::new::<64, 0>(&s);
            assert_eq!(cell.gi, work.gi.state());
            assert_eq!(cell.oe, work.oe.state());
        }
    }
}
