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
//!    [`Status::NotExcited`].
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
//!    fitted windows, and an open-circuit voltage inside the plausible
//!    voltage range (with a curve: an offset `|ΔU|` at most
//!    [`OnlineSettings::max_ocv_offset`]). Otherwise the last good estimate
//!    is held with a status that says why ([`Status::Unphysical`],
//!    [`Status::AtBound`], [`Status::SlowRelaxation`],
//!    [`Status::OcvImplausible`]), and the refinement restarts from that
//!    estimate. No runaway is ever published.
//!
//! A failing iteration never touches the published estimate.

use super::ocv::OcvModel;
use super::output_error::{OutputErrorRefinement, RefinementState, RefinementWork};
use super::pack::PackEstimator;
use super::regression::{PaperRegressionGi, PaperRegressionState};
use super::{BatterySettings, CellParameters, Start};
use crate::error::Error;
use crate::frac::GlWeights;
use crate::real::Real;
use crate::tail::PastModes;
use crate::window::Window;

/// Leading rested samples (current at most `C/100`) whose mean voltage
/// gives the start state of charge when none is set.
const REST_SAMPLES: u8 = 10;

/// Which identification method runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Method {
    /// The paper's 2S-OP-GI on the §6.2 regression alone.
    Paper,
    /// Output-error refinement started from 2S-OP-GI (the most accurate).
    Refined,
}

/// Settings of the online estimator (one value for all cells of a pack),
/// with room for an OCV curve of `P` points (`P = 0`: no curve, a constant
/// `U_oc` as in §6.2).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OnlineSettings<T, const P: usize = 0> {
    /// The estimators' settings (use [`Start::FromData`] for a sliding
    /// window).
    pub battery: BatterySettings<T>,
    /// Method.
    pub method: Method,
    /// Iterations run after each sample.
    pub iterations_per_sample: u16,
    /// Iterations of 2S-OP-GI after which the refinement starts even if the
    /// paper method's estimate is not physical yet (it then starts from
    /// `initial`).
    pub paper_budget: u32,
    /// Starting order of 2S-OP-GI.
    pub alpha0: T,
    /// Fallback start of the refinement (e.g. the datasheet values).
    pub initial: CellParameters<T>,
    /// Largest plausible `|I|` (A).
    pub current_limit: T,
    /// Plausible terminal voltage range (V).
    pub voltage_min: T,
    /// Upper end of the plausible voltage range (V).
    pub voltage_max: T,
    /// A voltage further than this many model RMSEs from the prediction is a
    /// spike…
    pub spike_sigmas: T,
    /// …and further than this (V) at least.
    pub spike_floor: T,
    /// After this many consecutive spikes the sample is believed.
    pub max_consecutive_spikes: u8,
    /// The cell's OCV curve and capacity (`None`: constant `U_oc`).
    pub ocv: Option<OcvModel<T, P>>,
    /// With a curve, the largest plausible OCV offset `|ΔU|` (V).
    pub max_ocv_offset: T,
    /// The longest relaxation time `τ^(1/α)` a published estimate may have,
    /// in fitted windows (`(L − M + 1)·h`).
    pub max_relaxation_windows: T,
}

impl<T: Real> OnlineSettings<T> {
    /// Defaults for a Li-ion cell sampled every `h` seconds with memory
    /// `memory`: refined method, one iteration per sample, start from data,
    /// no OCV curve (OCV slope fitted),
    /// `|I| ≤ 500 A`, `U_t ∈ [1.5, 5] V`, spikes beyond `max(8·RMSE, 50 mV)`,
    /// 3 consecutive spikes believed; published relaxation times up to one
    /// fitted window, OCV offsets up to 0.15 V.
    pub fn new(h: T, memory: usize, initial: CellParameters<T>) -> Self {
        let mut battery = BatterySettings::new(h, memory);
        battery.start = Start::FromData;
        battery.ocv_slope = true;
        Self {
            battery,
            method: Method::Refined,
            iterations_per_sample: 1,
            paper_budget: 200,
            alpha0: T::lit(0.5),
            initial,
            current_limit: T::lit(500.0),
            voltage_min: T::lit(1.5),
            voltage_max: T::lit(5.0),
            spike_sigmas: T::lit(8.0),
            spike_floor: T::lit(0.05),
            max_consecutive_spikes: 3,
            ocv: None,
            max_ocv_offset: T::lit(0.15),
            max_relaxation_windows: T::one(),
        }
    }
}

impl<T: Real, const P: usize> OnlineSettings<T, P> {
    /// The same settings with the cell's OCV curve and capacity: the
    /// estimator counts the state of charge and fits the overpotential
    /// `U_t − OCV(SOC)`, so the OCV slope is no longer fitted.
    pub fn with_ocv<const Q: usize>(self, ocv: OcvModel<T, Q>) -> OnlineSettings<T, Q> {
        self.with_curve(Some(ocv))
    }

    /// [`with_ocv`](Self::with_ocv) for a curve that may be absent: `None`
    /// gives the same settings without a curve, in the type that has room
    /// for `Q` points (one settings type whether or not a file names a
    /// curve).
    pub fn with_curve<const Q: usize>(self, ocv: Option<OcvModel<T, Q>>) -> OnlineSettings<T, Q> {
        let mut battery = self.battery;
        if ocv.is_some() {
            battery.ocv_slope = false;
        }
        OnlineSettings {
            battery,
            method: self.method,
            iterations_per_sample: self.iterations_per_sample,
            paper_budget: self.paper_budget,
            alpha0: self.alpha0,
            initial: self.initial,
            current_limit: self.current_limit,
            voltage_min: self.voltage_min,
            voltage_max: self.voltage_max,
            spike_sigmas: self.spike_sigmas,
            spike_floor: self.spike_floor,
            max_consecutive_spikes: self.max_consecutive_spikes,
            ocv,
            max_ocv_offset: self.max_ocv_offset,
            max_relaxation_windows: self.max_relaxation_windows,
        }
    }

    /// The refinement's fallback start in the window's coordinates: with a
    /// curve, [`initial`](Self::initial) with `U_oc` replaced by `ΔU = 0`.
    pub fn initial_in_window(&self) -> CellParameters<T> {
        // With a prior, its centre is the better start.
        let start = match &self.battery.prior {
            Some(pr) => CellParameters {
                u_oc: self.initial.u_oc,
                ..pr.center
            },
            None => self.initial,
        };
        match self.ocv {
            Some(_) => CellParameters {
                u_oc: T::zero(),
                ..start
            },
            None => start,
        }
    }

    /// Why `p` (in the estimator's coordinates: `u_oc` is `ΔU` with a
    /// curve) may not be published from a window of `rows` fitted samples
    /// whose current has standard deviation `current_std` (A), fitted to
    /// `rmse` (V), or `None` when it may.
    pub fn implausible(
        &self,
        p: &CellParameters<T>,
        rows: usize,
        current_std: T,
        rmse: T,
    ) -> Option<Status> {
        let b = &self.battery;
        let pos = |x: T| x.is_finite() && x > T::zero();
        if !(pos(p.r_i) && pos(p.r_ct) && pos(p.q) && pos(p.alpha) && p.alpha <= T::one()) {
            return Some(Status::Unphysical);
        }
        if !(p.bv_a.is_finite() && p.bv_a >= T::zero() && pos(p.bv_i0)) {
            return Some(Status::Unphysical);
        }
        let ocv_ok = match self.ocv {
            Some(_) => p.u_oc.abs() <= self.max_ocv_offset,
            None => p.u_oc >= self.voltage_min && p.u_oc <= self.voltage_max,
        };
        if !ocv_ok {
            return Some(Status::OcvImplausible);
        }
        let tol = T::lit(1e-3);
        if p.alpha <= b.alpha_min + tol || (b.alpha_max < T::one() && p.alpha >= b.alpha_max - tol)
        {
            return Some(Status::AtBound);
        }
        // R_ct at its lower bound, 0: a branch whose voltage swing is below
        // the fit's residual is not seen by the window (nor are its Q, α).
        let swing = p.r_ct * current_std;
        if swing.is_nan() || rmse.is_nan() || swing < rmse {
            return Some(Status::AtBound);
        }
        let relax = p.tau().powf(T::one() / p.alpha);
        let longest = self.max_relaxation_windows * T::lit(rows as f64) * b.h;
        if relax.is_nan() || relax > longest {
            return Some(Status::SlowRelaxation);
        }
        None
    }
}

/// Health of the estimate after a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Status {
    /// The window does not yet hold enough samples.
    Filling,
    /// 2S-OP-GI is running but its estimate is not physical yet.
    Starting,
    /// The estimate was updated from this window.
    Tracking,
    /// The window's current carries no excitation: estimate held.
    NotExcited,
    /// The iteration failed (non-finite values): estimate held.
    Held,
    /// The window's estimate is not physical (a resistance or `Q` not
    /// positive, α outside `(0, 1]`): the last good estimate is held.
    Unphysical,
    /// The window's estimate has a parameter at its bound: α at the
    /// search's bound, or `R_ct` so small (towards 0) that the branch's
    /// swing `R_ct·σ_I` is below the fit's RMSE. Not identified; the last
    /// good estimate is held.
    AtBound,
    /// The window's estimate relaxes slower than the window can see
    /// (`τ^(1/α)` beyond [`OnlineSettings::max_relaxation_windows`]): the
    /// branch would be imitating a drift; the last good estimate is held.
    SlowRelaxation,
    /// The window's open-circuit voltage is outside the plausible voltage
    /// range (with a curve: `|ΔU|` above [`OnlineSettings::max_ocv_offset`]):
    /// the last good estimate is held.
    OcvImplausible,
}

impl Status {
    /// A short lower-case name (for logs and CSV files).
    pub fn as_str(&self) -> &'static str {
        match self {
            Status::Filling => "filling",
            Status::Starting => "starting",
            Status::Tracking => "tracking",
            Status::NotExcited => "not_excited",
            Status::Held => "held",
            Status::Unphysical => "unphysical",
            Status::AtBound => "at_bound",
            Status::SlowRelaxation => "slow_relaxation",
            Status::OcvImplausible => "ocv_implausible",
        }
    }

    /// Every status, in the order of the enum (for documentation and
    /// tests).
    pub const ALL: [Status; 9] = [
        Status::Filling,
        Status::Starting,
        Status::Tracking,
        Status::NotExcited,
        Status::Held,
        Status::Unphysical,
        Status::AtBound,
        Status::SlowRelaxation,
        Status::OcvImplausible,
    ];

    /// True when the estimate was held because the window's estimate was
    /// not plausible.
    pub fn is_implausible(&self) -> bool {
        matches!(
            self,
            Status::Unphysical | Status::AtBound | Status::SlowRelaxation | Status::OcvImplausible
        )
    }
}

/// Why a sample was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Rejection {
    /// NaN or infinite.
    NonFinite,
    /// Outside the plausible current or voltage range.
    OutOfRange,
    /// Too far from the model's prediction.
    Spike,
}

/// What one sample did.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SampleReport<T> {
    /// Health of the estimate.
    pub status: Status,
    /// `Some` when the sample was rejected (and substituted).
    pub rejected: Option<Rejection>,
    /// Iterations run for this sample.
    pub iterations: u16,
    /// The fit's RMSE (V) after the last successful iteration.
    pub rmse: T,
}

/// Counters of everything the estimator has seen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SampleCounts {
    /// Samples offered to [`CellEstimator::push`].
    pub samples: u64,
    /// Rejected as NaN/∞.
    pub non_finite: u32,
    /// Rejected as out of range.
    pub out_of_range: u32,
    /// Rejected as spikes.
    pub spikes: u32,
}

impl SampleCounts {
    /// All rejected samples.
    pub fn rejected(&self) -> u32 {
        self.non_finite + self.out_of_range + self.spikes
    }
}

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
    /// Settings errors ([`BatterySettings::check`], a bad `alpha0` or
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

    /// The OCV offset `ΔU` (V) of the last good estimate (with an OCV
    /// curve).
    pub fn ocv_offset(&self) -> Option<T> {
        self.state().ocv_offset()
    }

    /// The coulomb-counted state of charge after the last sample (with an
    /// OCV curve, once known).
    pub fn state_of_charge(&self) -> Option<T> {
        self.state().soc
    }

    /// Sets the state of charge now (before the next sample), e.g. from the
    /// BMS's own SOC estimate or a rested voltage. Without a call the first
    /// sample's voltage is read through the inverse OCV curve.
    pub fn set_state_of_charge(&mut self, soc: T) {
        self.pack.cells[0].set_state_of_charge(soc);
    }

    /// Health after the last sample.
    pub fn status(&self) -> Status {
        self.state().status
    }

    /// Sample counters.
    pub fn counts(&self) -> SampleCounts {
        self.state().counts
    }

    /// The window: the current history with this cell's voltages.
    pub fn window(&self) -> CellWindow<'_, T, N> {
        self.pack.window(0)
    }

    /// What the output-error refinement has computed so far (zero while
    /// the paper method runs): simulations, trial steps and sensitivity
    /// passes, the counters behind its cost.
    pub fn refinement_work(&self) -> RefinementWork {
        self.state().oe.work()
    }

    /// True once the output-error refinement has taken over.
    pub fn is_refining(&self) -> bool {
        self.state().refining
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

/// The current history a pack keeps once for all its cells: the last `N`
/// currents (A), in a ring aligned with every cell's voltages.
#[derive(Clone, Debug)]
pub struct CurrentHistory<T, const N: usize> {
    i: [T; N],
    /// Where the next current goes.
    head: usize,
    /// Currents held (at most `N`).
    count: usize,
}

impl<T: Real, const N: usize> CurrentHistory<T, N> {
    /// An empty history.
    pub fn new() -> Self {
        Self {
            i: [T::ZERO; N],
            head: 0,
            count: 0,
        }
    }

    /// The newest current, if any.
    pub fn newest(&self) -> Option<T> {
        (self.count > 0).then(|| self.i[(self.head + N - 1) % N])
    }

    /// Currents held.
    pub fn len(&self) -> usize {
        self.count
    }

    /// True when no current is held.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The ring slot the next current (and every cell's next voltage) goes
    /// to.
    fn slot(&self) -> usize {
        self.head
    }

    fn push(&mut self, current: T) {
        self.i[self.head] = current;
        self.head = (self.head + 1) % N;
        self.count = (self.count + 1).min(N);
    }
}

impl<T: Real, const N: usize> Default for CurrentHistory<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

/// One cell's window: the pack's current history with the cell's own
/// voltages (the last [`len`](Window::len) samples of the ring, which may be
/// fewer than the pack's after the cell's window restarted).
#[derive(Clone, Copy, Debug)]
pub struct CellWindow<'a, T, const N: usize> {
    history: &'a CurrentHistory<T, N>,
    cell: &'a CellState<T, N>,
}

impl<'a, T: Real, const N: usize> CellWindow<'a, T, N> {
    pub(super) fn new(history: &'a CurrentHistory<T, N>, cell: &'a CellState<T, N>) -> Self {
        Self { history, cell }
    }

    /// Samples held.
    pub fn len(&self) -> usize {
        usize::from(self.cell.len)
    }

    /// True when no sample is held.
    pub fn is_empty(&self) -> bool {
        self.cell.len == 0
    }

    /// The held pairs `(I, U)`, newest first ([`Window::recent`] for the
    /// view's whole lifetime).
    pub fn newest_first(self) -> impl Iterator<Item = (T, T)> + 'a {
        let head = self.history.head;
        let (i, u) = (&self.history.i, &self.cell.u);
        let currents = i[..head].iter().rev().chain(i[head..].iter().rev());
        let voltages = u[..head].iter().rev().chain(u[head..].iter().rev());
        currents
            .zip(voltages)
            .take(usize::from(self.cell.len))
            .map(|(&i, &u)| (i, u))
    }

    /// Samples accepted into this window since its last restart (substitutes
    /// of rejected samples included).
    pub fn pushed(&self) -> u64 {
        self.cell.pushed
    }
}

impl<T: Real, const N: usize> Window<T> for CellWindow<'_, T, N> {
    fn len(&self) -> usize {
        usize::from(self.cell.len)
    }
    fn version(&self) -> u32 {
        self.cell.version
    }
    fn has_slid(&self) -> bool {
        self.cell.pushed > u64::from(self.cell.len)
    }
    fn recent(&self) -> impl Iterator<Item = (T, T)> + '_ {
        self.newest_first()
    }
    fn past(&self) -> Option<PastModes<T>> {
        (self.cell.past.count > 0).then_some(self.cell.past)
    }
    fn copy_into(&self, u: &mut [T], y: &mut [T]) -> usize {
        let len = usize::from(self.cell.len).min(u.len()).min(y.len());
        let head = self.history.head;
        let (si, sv) = (&self.history.i, &self.cell.u);
        // The oldest `len` of the held samples are the ones copied when
        // the slices are short (as `SampleWindow::copy_into`).
        let held = usize::from(self.cell.len);
        let start = (head + N - held) % N;
        for k in 0..len {
            let j = (start + k) % N;
            u[k] = si[j];
            y[k] = sv[j];
        }
        len
    }
}

/// What one cell carries between samples: its voltages (aligned with the
/// pack's [`CurrentHistory`]), its estimate, state of charge, counters and
/// the iteration state of its estimators. Everything an iteration needs
/// beyond this is in the shared [`WorkingArea`].
#[derive(Clone, Debug)]
pub struct CellState<T, const N: usize> {
    /// Voltages in the window's coordinates (the overpotential with an OCV
    /// curve), in the pack's ring.
    u: [T; N],
    /// Samples of the ring that belong to this cell's window.
    len: u16,
    /// Samples pushed since the window's last restart.
    pushed: u64,
    /// Changes with every change of the window (see [`Window::version`]).
    version: u32,
    gi: PaperRegressionState<T>,
    oe: RefinementState<T>,
    refining: bool,
    /// The last good estimate, in the window's coordinates (`u_oc` is `ΔU`
    /// with an OCV curve).
    estimate: Option<CellParameters<T>>,
    /// State of charge after the last sample (with an OCV curve, once known).
    soc: Option<T>,
    /// `OCV(SOC)` after the last sample (with a curve; `None` without).
    ocv_now: Option<T>,
    /// While the start SOC is read from the leading rested samples: their
    /// number, voltage sum and the start SOC they gave.
    rest_start: Option<(u8, T, T)>,
    /// Standard deviation of the current over the window's fitted part (A).
    current_std: T,
    rmse: T,
    status: Status,
    counts: SampleCounts,
    spikes_in_row: u8,
    /// Whether the last sample was rejected, and why.
    last_rejection: Option<Rejection>,
    /// The modes of the samples that left the window (the past the
    /// refinement's tail needs, [`BatterySettings::tail`]).
    past: PastModes<T>,
}

/// The working area a pack's cells share, one cell at a time: the two
/// estimators' window-length arrays and caches, and the weights of the
/// one-step prediction. It belongs to the last cell iterated; another
/// cell's iteration first loads that cell's state into it.
#[derive(Clone, Debug)]
pub struct WorkingArea<T, const N: usize, const MEM: usize> {
    gi: PaperRegressionGi<T, N, MEM>,
    oe: OutputErrorRefinement<T, N, MEM>,
    /// Weights at the order of the cell being predicted.
    pw: GlWeights<T, MEM>,
    owner: Option<usize>,
}

impl<T: Real, const N: usize, const MEM: usize> WorkingArea<T, N, MEM> {
    fn new<const P: usize>(s: &OnlineSettings<T, P>) -> Result<Self, Error> {
        Ok(Self {
            gi: PaperRegressionGi::new(&s.battery, s.alpha0)?,
            oe: OutputErrorRefinement::new(&s.battery, s.initial_in_window())?,
            pw: GlWeights::new(s.initial.alpha, s.battery.h, s.battery.memory)?,
            owner: None,
        })
    }

    /// Loads cell `k`'s iteration state unless the area is already its.
    fn take<const P: usize>(
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
    fn new<const MEM: usize, const P: usize>(s: &OnlineSettings<T, P>) -> Self {
        Self {
            u: [T::ZERO; N],
            len: 0,
            pushed: 0,
            version: 0,
            gi: PaperRegressionGi::<T, N, MEM>::initial_state(s.alpha0),
            oe: OutputErrorRefinement::<T, N, MEM>::initial_state(s.initial_in_window()),
            // With a prior the refinement starts at its centre: the paper
            // method's start-up is not needed.
            refining: s.method == Method::Refined && s.battery.prior.is_some(),
            estimate: None,
            soc: None,
            ocv_now: None,
            rest_start: None,
            current_std: T::zero(),
            rmse: T::infinity(),
            status: Status::Filling,
            counts: SampleCounts::default(),
            spikes_in_row: 0,
            last_rejection: None,
            past: PastModes::new(),
        }
    }

    fn view<'a>(&'a self, history: &'a CurrentHistory<T, N>) -> CellWindow<'a, T, N> {
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

    /// See [`CellEstimator::set_state_of_charge`].
    pub fn set_state_of_charge(&mut self, soc: T) {
        if soc.is_finite() {
            self.soc = Some(soc);
            self.rest_start = None;
        }
    }

    /// Restarts the window (the pack's ring keeps the currents); its past
    /// is forgotten.
    fn clear_window(&mut self) {
        self.len = 0;
        self.pushed = 0;
        self.version = self.version.wrapping_add(1);
        self.past = PastModes::new();
    }

    /// Writes `u` into the ring slot the pack's next current goes to and
    /// counts it: the window is whole again once the pack has pushed that
    /// current. A full window's oldest sample, in that slot, leaves into the
    /// past's modes (the value the window held: a substitute for a rejected
    /// sample).
    fn push_voltage(&mut self, history: &CurrentHistory<T, N>, u: T) {
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

    /// [`CellEstimator::predict`] with the prediction weights `w` (set to
    /// the estimate's order here).
    fn predict<const MEM: usize, const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
        history: &CurrentHistory<T, N>,
        w: &mut GlWeights<T, MEM>,
        current: T,
    ) -> Option<T> {
        let y = self.predict_window(history, w, current)?;
        Some(match (&s.ocv, self.soc) {
            (Some(m), Some(z)) => y + m.table.ocv(m.soc_after(z, current, s.battery.h)),
            _ => y,
        })
    }

    /// The one-step prediction in the window's coordinates (the
    /// overpotential with an OCV curve).
    fn predict_window<const MEM: usize>(
        &self,
        history: &CurrentHistory<T, N>,
        w: &mut GlWeights<T, MEM>,
        current: T,
    ) -> Option<T> {
        let p = self.estimate?;
        if w.alpha() != p.alpha {
            w.set_order(p.alpha).ok()?;
        }
        let wts = w.weights();
        let mut hist = T::zero();
        for (&wj, (i, u)) in wts.iter().skip(1).zip(self.view(history).newest_first()) {
            hist = hist + wj * ((u - p.u_oc) - p.static_voltage(i));
        }
        let a = p.tau() * w.scale();
        let up = (p.r_ct * current - a * hist) / (T::one() + a);
        Some(p.u_oc + p.static_voltage(current) + up)
    }

    /// The state of charge after a sample of `current` (with a curve and a
    /// known SOC).
    fn soc_after<const P: usize>(&self, s: &OnlineSettings<T, P>, current: T) -> Option<T> {
        let m = s.ocv.as_ref()?;
        Some(m.soc_after(self.soc?, current, s.battery.h))
    }

    /// A terminal voltage in the window's coordinates, for a sample of
    /// `current`: the overpotential `U_t − OCV(SOC)` with a curve.
    fn to_window<const P: usize>(&self, s: &OnlineSettings<T, P>, current: T, voltage: T) -> T {
        match (&s.ocv, self.soc_after(s, current)) {
            (Some(m), Some(z)) => m.overpotential(z, voltage),
            _ => voltage,
        }
    }

    fn classify<const MEM: usize, const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
        history: &CurrentHistory<T, N>,
        w: &mut GlWeights<T, MEM>,
        current: T,
        voltage: T,
    ) -> Option<Rejection> {
        if !(current.is_finite() && voltage.is_finite()) {
            return Some(Rejection::NonFinite);
        }
        if current.abs() > s.current_limit || voltage < s.voltage_min || voltage > s.voltage_max {
            return Some(Rejection::OutOfRange);
        }
        let y = self.to_window(s, current, voltage);
        if self.spikes_in_row < s.max_consecutive_spikes && self.is_spike(s, history, w, current, y)
        {
            return Some(Rejection::Spike);
        }
        None
    }

    /// True when `y` (in the window's coordinates) is further than
    /// `max(spike_sigmas·RMSE, spike_floor)` from the model's prediction
    /// for `current`.
    fn is_spike<const MEM: usize, const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
        history: &CurrentHistory<T, N>,
        w: &mut GlWeights<T, MEM>,
        current: T,
        y: T,
    ) -> bool {
        if !self.rmse.is_finite() {
            return false;
        }
        self.predict_window(history, w, current)
            .is_some_and(|pred| {
                let limit = (s.spike_sigmas * self.rmse).max(s.spike_floor);
                (y - pred).abs() > limit
            })
    }

    /// Validates one sample, substitutes it when rejected and writes it
    /// into ring slot `slot` (the pack then pushes `stored`, the current of
    /// that slot: the measured one when plausible, else the last one).
    /// Counts it. The window is read before the slot is written.
    #[allow(clippy::too_many_arguments)]
    fn accept<const MEM: usize, const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        history: &CurrentHistory<T, N>,
        w: &mut GlWeights<T, MEM>,
        stored: Option<T>,
        current: T,
        voltage: T,
    ) -> Option<Rejection> {
        self.counts.samples += 1;
        let rejected = self.classify(s, history, w, current, voltage);
        if let (Some(m), None) = (&s.ocv, rejected) {
            let rest = current.abs() <= m.capacity_ah / T::lit(100.0);
            match (self.soc, self.rest_start) {
                (None, _) => {
                    // The first good sample with a curve and no SOC given:
                    // the cell is taken to be at rest, its voltage the OCV.
                    let soc0 = m.table.soc_from_ocv(voltage);
                    self.soc = Some(soc0);
                    self.rest_start = rest.then_some((1, voltage, soc0));
                }
                (Some(z), Some((n, sum, soc0))) if rest && n < REST_SAMPLES => {
                    // Still at rest: the start SOC from the mean of the
                    // rested voltages so far (as `OcvModel::soc_at_rest`
                    // reads a record), the charge since kept.
                    let sum = sum + voltage;
                    let better = m.table.soc_from_ocv(sum / T::lit(f64::from(n + 1)));
                    self.soc = Some(z + (better - soc0));
                    self.rest_start = Some((n + 1, sum, better));
                }
                _ => self.rest_start = None,
            }
        }
        let sample = match (rejected, stored) {
            (None, Some(i)) => {
                // Not the `y` that `classify` judged: at a rested start the
                // SOC was just refined from this very sample.
                let y = self.to_window(s, i, voltage);
                if self.spikes_in_row >= s.max_consecutive_spikes
                    && self.is_spike(s, history, w, i, y)
                {
                    // A step believed after max_consecutive_spikes
                    // rejections (a recalibrated sensor, a contactor): the
                    // samples before it belong to another regime, which no
                    // model of the window can fit across the step. The
                    // window restarts here; the estimate is kept, but no
                    // sample is judged by it until it has been refitted.
                    self.clear_window();
                    self.rmse = T::infinity();
                }
                self.spikes_in_row = 0;
                Some((i, y))
            }
            (why, stored) => {
                match why {
                    Some(Rejection::NonFinite) => self.counts.non_finite += 1,
                    Some(Rejection::OutOfRange) => self.counts.out_of_range += 1,
                    Some(Rejection::Spike) => {
                        self.counts.spikes += 1;
                        self.spikes_in_row = self.spikes_in_row.saturating_add(1);
                    }
                    // Accepted but nothing to store it with: cannot happen
                    // (an accepted sample has a plausible current).
                    None => {}
                }
                // Substitute. The current: the measured one when it is
                // itself plausible (only the voltage was bad), else the last
                // one (the pack's `stored`). The voltage: the model's
                // prediction for that current (or the last voltage before a
                // model exists). An empty window takes no substitute.
                let last = self.view(history).newest_first().next();
                match (stored, last) {
                    (Some(i), Some((_, u))) => {
                        Some((i, self.predict_window(history, w, i).unwrap_or(u)))
                    }
                    _ => None,
                }
            }
        };
        match sample {
            Some((i, u)) => {
                if stored.is_some() {
                    self.push_voltage(history, u);
                }
                if let Some(m) = &s.ocv {
                    // The charge of the sample as it entered the window (the
                    // substitute's current for a rejected one).
                    self.soc = self.soc_after(s, i);
                    self.ocv_now = self.soc.map(|z| m.table.ocv(z));
                }
            }
            None => {
                // Nothing stored for this cell while the pack stores a
                // current: the window restarts after the gap.
                if stored.is_some() && self.len > 0 {
                    self.clear_window();
                }
            }
        }
        self.last_rejection = rejected;
        rejected
    }

    /// The iterations of one update (after its sample is in the window).
    fn run<const MEM: usize, const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        history: &CurrentHistory<T, N>,
        work: &mut WorkingArea<T, N, MEM>,
        k: usize,
    ) -> (Status, u16) {
        let b = &s.battery;
        // Saturating: `push` may be given other settings than the
        // constructor's (memory 0 or `usize::MAX` then means "never enough").
        let need = b
            .memory
            .saturating_sub(1)
            .saturating_add(super::regression::MIN_ROWS);
        let len = usize::from(self.len);
        if len < need {
            return (Status::Filling, 0);
        }
        // Current excitation over the fitted part of the window.
        let fitted = (len + 1).saturating_sub(b.memory);
        let count = T::lit(fitted as f64);
        let recent = || {
            self.view(history)
                .newest_first()
                .take(fitted)
                .map(|(i, _)| i)
        };
        let mean = recent().fold(T::zero(), |a, i| a + i) / count;
        let var = recent().fold(T::zero(), |a, i| a + (i - mean) * (i - mean)) / count;
        if var.sqrt() <= b.min_current_std {
            return (Status::NotExcited, 0);
        }
        self.current_std = var.sqrt();
        if work.take(s, k, self).is_err() {
            return (Status::Held, 0);
        }
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
    fn publish<const MEM: usize, const P: usize>(
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

    fn step_paper<const MEM: usize, const P: usize>(
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

    fn step_refined<const MEM: usize, const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        history: &CurrentHistory<T, N>,
        work: &mut WorkingArea<T, N, MEM>,
    ) -> Result<Status, Error> {
        let st = work.oe.iterate(&s.battery, &self.view(history))?;
        match self.publish(s, &mut work.pw, work.oe.cell(), st.rmse, st.rows) {
            Ok(()) => Ok(Status::Tracking),
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

/// Checks the limits of the online settings (the rest is checked by the
/// estimators).
fn check_limits<T: Real, const P: usize>(s: &OnlineSettings<T, P>) -> Result<(), Error> {
    let limits_ok = s.current_limit > T::zero()
        && s.current_limit.is_finite()
        && s.voltage_min.is_finite()
        && s.voltage_max.is_finite()
        && s.voltage_min < s.voltage_max
        && s.spike_sigmas > T::zero()
        && s.spike_floor > T::zero()
        && s.spike_floor.is_finite()
        && s.max_ocv_offset > T::zero()
        && s.max_relaxation_windows > T::zero();
    if !limits_ok {
        return Err(Error::BadSetting);
    }
    if let Some(m) = &s.ocv {
        m.check()?;
    }
    Ok(())
}

/// The pack estimator's per-sample flow for cells `0..cells`, shared with
/// [`CellEstimator`] (the one-cell pack). See [`PackEstimator::push`].
impl<T: Real, const N: usize, const MEM: usize, const CELLS: usize>
    PackEstimator<T, N, MEM, CELLS>
{
    /// A pack of `cells` cells (at most `CELLS`), every one with an empty
    /// window.
    ///
    /// # Errors
    /// [`Error::CellCount`] for 0 or more than `CELLS` cells; the settings
    /// errors of [`CellEstimator::new`].
    pub fn with_cells<const P: usize>(
        s: &OnlineSettings<T, P>,
        cells: usize,
    ) -> Result<Self, Error> {
        if cells == 0 || cells > CELLS || cells > usize::from(u16::MAX) {
            return Err(Error::CellCount {
                given: cells,
                expected: CELLS,
            });
        }
        if N > usize::from(u16::MAX) {
            return Err(Error::BadSetting);
        }
        check_limits(s)?;
        let cell = CellState::new::<MEM, P>(s);
        // The working area is built in the return value: a local moved in
        // would be one more copy of its arrays on the (start-up) stack.
        Ok(Self {
            history: CurrentHistory::new(),
            cells: core::array::from_fn(|_| cell.clone()),
            active: cells,
            work: WorkingArea::new(s)?,
            next: 0,
        })
    }

    /// Pushes one sample period (the pack's current and one voltage per
    /// cell), then runs `updates` cell updates, round robin from where the
    /// last period stopped; `report(k, r)` hears every cell's report.
    pub(crate) fn push_with<const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        updates: usize,
        current: T,
        voltages: &[T],
        mut report: impl FnMut(usize, SampleReport<T>),
    ) -> Result<(), Error> {
        let cells = self.active;
        if voltages.len() != cells {
            return Err(Error::CellCount {
                given: voltages.len(),
                expected: cells,
            });
        }
        // The current the ring stores for this period: the measured one
        // when plausible, else the last one (none before the first).
        let plausible = current.is_finite() && current.abs() <= s.current_limit;
        let stored = if plausible {
            Some(current)
        } else {
            self.history.newest()
        };
        let Self {
            history,
            cells: states,
            work,
            ..
        } = self;
        for (cell, &v) in states[..cells].iter_mut().zip(voltages) {
            cell.accept(s, history, &mut work.pw, stored, current, v);
        }
        if let Some(i) = stored {
            history.push(i);
        }
        let updates = updates.min(cells);
        let first = self.next;
        for k in 0..cells {
            let cell = &mut self.cells[k];
            let scheduled = (k + cells - first) % cells < updates;
            let (status, iterations) = if scheduled {
                cell.run(s, &self.history, &mut self.work, k)
            } else {
                (cell.status, 0)
            };
            cell.status = status;
            report(
                k,
                SampleReport {
                    status,
                    rejected: cell.last_rejection,
                    iterations,
                    rmse: cell.rmse,
                },
            );
        }
        self.next = (first + updates) % cells;
        Ok(())
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
