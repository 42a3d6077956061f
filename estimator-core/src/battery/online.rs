//! The sliding-window cell estimator a BMS runs for each cell.
//!
//! Every sample goes through [`CellEstimator::push`]:
//!
//! 1. **Validation.** A NaN/∞ sample, a current or voltage outside the
//!    settings' range, or (once a model exists) a voltage further than
//!    `max(spike_sigmas·RMSE, spike_floor)` from the model's one-step
//!    prediction is *rejected*: counted, never learned. So that the time base
//!    stays uniform (the fractional differences assume it) a substitute takes
//!    its place: the measured current when it is plausible (else the last
//!    one) and the model's voltage for it (or the last voltage). After `max_consecutive_spikes` rejected spikes in a row the
//!    sample is believed (a real step, e.g. a contactor closing, a
//!    recalibrated sensor): the window restarts from it, since no model
//!    fits across the step, and spike checks pause until the model is
//!    refitted.
//! 2. **Window.** The sample enters the cell's window ([`CellWindow`]: the
//!    pack's current history with the cell's voltages). With an OCV curve
//!    ([`OnlineSettings::with_ocv`]) the state of charge is counted first
//!    and the window holds the overpotential `U_t − OCV(SOC)`: the model's
//!    `U_oc` is then the small offset `ΔU` ([`super::ocv`]). The start SOC
//!    is [`CellEstimator::set_state_of_charge`]'s, or else read through the
//!    inverse curve from the mean voltage of the leading rested samples
//!    (current at most `C/100`, up to 10; a cell that is not at rest at the
//!    first sample starts from that sample's voltage, and the offset `ΔU`
//!    absorbs the error).
//! 3. **Excitation.** A window whose current barely varies (rest) carries no
//!    information on the resistances: the estimate is held and the status is
//!    [`Status::NotExcited`]. So is, once the output-error refinement runs,
//!    one whose excitation has left the rows it fits for its warm-up (the
//!    current's standard deviation over the fitted rows under half the
//!    whole window's): the fit would see a relaxation without the current
//!    that drove it, and trade the branch's parameters along it
//!    (docs/bms-states.md).
//! 4. **Iterations.** A bounded number of iterations of the chosen
//!    [`Method`] runs. The refined method first runs the paper's 2S-OP-GI
//!    until its estimate is physical (or a budget is spent), then refines
//!    it by output error and keeps refining as the window slides.
//! 5. **Plausibility.** An estimate is published only when it is physical
//!    and identifiable from the window: positive, finite resistances and
//!    `Q`, α in `(0, 1]` and not at the search's lower bound (nor at a
//!    user-set upper bound below 1; α = 1 is a plain RC branch), `R_ct`
//!    not at its bound 0 (a branch swing `R_ct·σ_I` above the fit's RMSE), a
//!    relaxation time `τ^(1/α)` within [`OnlineSettings::max_relaxation_windows`]
//!    fitted windows (or within the prior's own relaxation,
//!    [`OnlineSettings::prior_relaxation`]), and an open-circuit voltage inside the plausible
//!    voltage range (with a curve: an offset `|ΔU|` at most
//!    [`OnlineSettings::max_ocv_offset`]). Otherwise the last good estimate
//!    is held with a status that says why ([`Status::Unphysical`],
//!    [`Status::AtBound`], [`Status::SlowRelaxation`],
//!    [`Status::OcvImplausible`]), and the refinement restarts from that
//!    estimate. No runaway is ever published.
//!
//! A failing iteration never touches the published estimate.

use super::output_error::RefinementWork;
use super::pack::PackEstimator;
use super::power::{PowerReport, PowerSettings, PulsePredictor};
use super::snapshot::{RestorePolicy, SnapshotError};
use super::CellParameters;
use crate::error::Error;
use crate::frac::GlWeights;
use crate::real::Real;

pub use super::tracker::{
    CellState, CellWindow, CurrentHistory, Identification, Method, OnlineSettings,
    PublishedParameter, PublishedParameters, Rejection, SampleCounts, SampleReport, Status,
    StepResistance, WorkingArea, STEP_PRECISION,
};

/// One cell's online estimator: window capacity `N`, memory capacity `MEM`.
///
/// It is the one-cell case of [`PackEstimator`]: the same per-cell state,
/// working area and code, with the cell updated at every sample.
///
/// ```
/// use estimator_core::battery::online::{CellEstimator, OnlineSettings, Status};
/// use estimator_core::battery::CellParameters;
///
/// let s = OnlineSettings::new(1.0, 16, CellParameters::<f32>::cell_18650());
/// let mut cell = CellEstimator::<f32, 64, 16>::new(&s).unwrap();
/// assert_eq!(cell.push(&s, 0.0, 3.7).status, Status::Filling);
/// let r = cell.push(&s, f32::NAN, 3.7);
/// assert!(r.rejected.is_some());
/// assert_eq!(cell.counts().non_finite, 1);
/// assert!(cell.estimate().is_none());
/// ```
#[derive(Clone, Debug)]
pub struct CellEstimator<T, const N: usize, const MEM: usize> {
    pack: PackEstimator<T, N, MEM, 1>,
}

impl<T: Real, const N: usize, const MEM: usize> CellEstimator<T, N, MEM> {
    /// A new estimator with an empty window.
    ///
    /// # Errors
    /// Settings errors ([`BatterySettings::check`](super::BatterySettings::check), a bad `alpha0` or
    /// `initial`, non-finite limits).
    pub fn new<const P: usize>(s: &OnlineSettings<T, P>) -> Result<Self, Error> {
        Ok(Self {
            pack: PackEstimator::with_cells(s, 1)?,
        })
    }

    fn state(&self) -> &CellState<T, N> {
        &self.pack.cells[0]
    }

    /// The cell's state, as a pack's cell (its estimate, counters, last
    /// rejection and fit RMSE).
    pub fn cell_state(&self) -> &CellState<T, N> {
        self.state()
    }

    /// The last good estimate (`None` until the first one). With an OCV
    /// curve its `u_oc` is the open-circuit voltage now, `OCV(SOC) + ΔU`.
    pub fn estimate(&self) -> Option<CellParameters<T>> {
        self.state().estimate()
    }

    /// What is published of `R_i`, `R_ct`, `Q` and α, each with whether
    /// the data identify it ([`CellState::published`]).
    pub fn published(&self) -> PublishedParameters<T> {
        self.state().published()
    }

    /// The OCV offset `ΔU` (V) of the last good estimate (with an OCV
    /// curve).
    pub fn ocv_offset(&self) -> Option<T> {
        self.state().ocv_offset()
    }

    /// The coulomb-counted state of charge after the last sample (with an
    /// OCV curve, once known).
    pub fn state_of_charge(&self) -> Option<T> {
        self.state().state_of_charge()
    }

    /// Sets the state of charge now (before the next sample), e.g. from the
    /// BMS's own SOC estimate or a rested voltage: the count's and the
    /// observer's. Without a call the first sample's voltage is read
    /// through the inverse OCV curve.
    pub fn set_state_of_charge(&mut self, soc: T) {
        self.pack.cells[0].set_state_of_charge(soc);
    }

    /// The size of this cell's snapshot (B, [`crate::battery::snapshot`]).
    pub fn snapshot_size(&self) -> usize {
        self.pack.snapshot_size()
    }

    /// Writes what the cell has learned into `buf`
    /// ([`PackEstimator::save`]); returns the bytes written.
    ///
    /// # Errors
    /// [`SnapshotError::TooShort`] when `buf` is too short.
    pub fn save<const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
        saved_at_s: Option<u32>,
        buf: &mut [u8],
    ) -> Result<usize, SnapshotError> {
        self.pack.save(s, saved_at_s, buf)
    }

    /// Restores the cell from a snapshot ([`PackEstimator::restore`]); on
    /// an error nothing is changed.
    ///
    /// # Errors
    /// The first check that fails ([`SnapshotError`]).
    pub fn restore<const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        buf: &[u8],
        policy: &RestorePolicy,
    ) -> Result<(), SnapshotError> {
        self.pack.restore(s, buf, policy)
    }

    /// The SOC observer's estimate after the last sample (with an OCV
    /// curve, once the start is known): the count corrected at rest by the
    /// curve, with the current sensor's bias and the capacity
    /// ([`crate::battery::soc`]; [`OnlineSettings::soc`]).
    pub fn soc_estimate<const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
    ) -> Option<crate::battery::soc::SocEstimate<T>> {
        self.state().soc_estimate(s)
    }

    /// The published state of charge: the observer's once it has started,
    /// the count ([`state_of_charge`](Self::state_of_charge)) before.
    pub fn published_state_of_charge<const P: usize>(&self, s: &OnlineSettings<T, P>) -> Option<T> {
        self.state().published_state_of_charge(s)
    }

    /// The model and the polarization the cell carries now, to predict a
    /// constant-current pulse and the state of power from
    /// ([`PackEstimator::pulse_predictor`]).
    pub fn pulse_predictor<'a, const P: usize>(
        &self,
        s: &'a OnlineSettings<T, P>,
    ) -> Option<PulsePredictor<'a, T, MEM, P>> {
        self.pack.pulse_predictor(0, s)
    }

    /// The state of power now for `power`'s horizons, when every
    /// parameter of the model is published, or a prior gives them
    /// ([`PackEstimator::state_of_power`]).
    pub fn state_of_power<const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
        power: &PowerSettings<T>,
    ) -> Option<PowerReport<T>> {
        self.pack.state_of_power(0, s, power)
    }

    /// The record resumes after a gap of unknown charge
    /// ([`CellState::resume_after_gap`]).
    pub fn resume_after_gap(&mut self, rested: bool) {
        self.pack.cells[0].resume_after_gap(rested);
    }

    /// The record resumes after a gap whose charge is known
    /// ([`CellState::bridge_gap`]).
    pub fn bridge_gap<const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        charge_ah: T,
        rested: bool,
    ) {
        self.pack.cells[0].bridge_gap(s, charge_ah, rested);
    }

    /// Health after the last sample.
    pub fn status(&self) -> Status {
        self.state().status()
    }

    /// Sample counters.
    pub fn counts(&self) -> SampleCounts {
        self.state().counts()
    }

    /// The window: the current history with this cell's voltages.
    pub fn window(&self) -> CellWindow<'_, T, N> {
        self.pack.window(0)
    }

    /// What the output-error refinement has computed so far (zero while
    /// the paper method runs): simulations, trial steps and sensitivity
    /// passes, the counters behind its cost.
    pub fn refinement_work(&self) -> RefinementWork {
        self.state().refinement_work()
    }

    /// True once the output-error refinement has taken over.
    pub fn is_refining(&self) -> bool {
        self.state().is_refining()
    }

    /// One-step prediction of the terminal voltage for the next sample at
    /// current `current` from the estimate, with the polarization history
    /// reconstructed from the window (`U_p = U_t − U_oc − R_i·I − η(I)`) and, with
    /// an OCV curve, the OCV at the state of charge after that sample. O(M).
    pub fn predict<const P: usize>(&self, s: &OnlineSettings<T, P>, current: T) -> Option<T> {
        let mut w =
            GlWeights::<T, MEM>::new(s.initial.alpha, s.battery.h, s.battery.memory).ok()?;
        self.state().predict(s, &self.pack.history, &mut w, current)
    }

    /// Feeds one sample (current in A, positive when charging; terminal
    /// voltage in V) and runs the iterations for it. Never panics; never
    /// loses a sample (a rejected one is counted and substituted).
    pub fn push<const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        current: T,
        voltage: T,
    ) -> SampleReport<T> {
        let mut report = None;
        // One cell, one voltage: the count cannot mismatch.
        let _ = self
            .pack
            .push_with(s, 1, current, &[voltage], |_, r| report = Some(r));
        report.unwrap_or(SampleReport {
            status: self.status(),
            rejected: None,
            iterations: 0,
            rmse: T::infinity(),
        })
    }
}
