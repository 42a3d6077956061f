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
//! 2. **Window.** The sample enters the [`SampleWindow`].
//! 3. **Excitation.** A window whose current barely varies (rest) carries no
//!    information on the resistances: the estimate is held and the status is
//!    [`Status::NotExcited`].
//! 4. **Iterations.** A bounded number of iterations of the chosen
//!    [`Method`] runs. The refined method first runs the paper's 2S-OP-GI
//!    until its estimate is physical (or a budget is spent), then refines
//!    it by output error and keeps refining as the window slides.
//!
//! A failing iteration never touches the published estimate.

use super::output_error::{OutputErrorRefinement, RefinementWork};
use super::regression::PaperRegressionGi;
use super::{BatterySettings, CellParameters, Start};
use crate::error::Error;
use crate::frac::GlWeights;
use crate::real::Real;
use crate::window::SampleWindow;

/// Which identification method runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Method {
    /// The paper's 2S-OP-GI on the §6.2 regression alone.
    Paper,
    /// Output-error refinement started from 2S-OP-GI (the most accurate).
    Refined,
}

/// Settings of the online estimator (one value for all cells of a pack).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OnlineSettings<T> {
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
}

impl<T: Real> OnlineSettings<T> {
    /// Defaults for a Li-ion cell sampled every `h` seconds with memory
    /// `memory`: refined method, one iteration per sample, start from data,
    /// OCV slope fitted,
    /// `|I| ≤ 500 A`, `U_t ∈ [1.5, 5] V`, spikes beyond `max(8·RMSE, 50 mV)`,
    /// 3 consecutive spikes believed.
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
        }
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
        }
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
    window: SampleWindow<T, N>,
    gi: PaperRegressionGi<T, N, MEM>,
    oe: OutputErrorRefinement<T, N, MEM>,
    refining: bool,
    estimate: Option<CellParameters<T>>,
    /// Weights at the estimate's order, for the one-step prediction.
    pw: GlWeights<T, MEM>,
    rmse: T,
    status: Status,
    counts: SampleCounts,
    spikes_in_row: u8,
}

impl<T: Real, const N: usize, const MEM: usize> CellEstimator<T, N, MEM> {
    /// A new estimator with an empty window.
    ///
    /// # Errors
    /// Settings errors ([`BatterySettings::check`], a bad `alpha0` or
    /// `initial`, non-finite limits).
    pub fn new(s: &OnlineSettings<T>) -> Result<Self, Error> {
        let limits_ok = s.current_limit > T::zero()
            && s.current_limit.is_finite()
            && s.voltage_min.is_finite()
            && s.voltage_max.is_finite()
            && s.voltage_min < s.voltage_max
            && s.spike_sigmas > T::zero()
            && s.spike_floor > T::zero()
            && s.spike_floor.is_finite();
        if !limits_ok {
            return Err(Error::BadSetting);
        }
        Ok(Self {
            window: SampleWindow::new(),
            gi: PaperRegressionGi::new(&s.battery, s.alpha0)?,
            oe: OutputErrorRefinement::new(&s.battery, s.initial)?,
            refining: false,
            estimate: None,
            pw: GlWeights::new(s.initial.alpha, s.battery.h, s.battery.memory)?,
            rmse: T::infinity(),
            status: Status::Filling,
            counts: SampleCounts::default(),
            spikes_in_row: 0,
        })
    }

    /// The last good estimate (`None` until the first one).
    pub fn estimate(&self) -> Option<CellParameters<T>> {
        self.estimate
    }

    /// Health after the last sample.
    pub fn status(&self) -> Status {
        self.status
    }

    /// Sample counters.
    pub fn counts(&self) -> SampleCounts {
        self.counts
    }

    /// The window.
    pub fn window(&self) -> &SampleWindow<T, N> {
        &self.window
    }

    /// What the output-error refinement has computed so far (zero while
    /// the paper method runs): simulations, trial steps and sensitivity
    /// passes, the counters behind its cost.
    pub fn refinement_work(&self) -> RefinementWork {
        self.oe.work()
    }

    /// True once the output-error refinement has taken over.
    pub fn is_refining(&self) -> bool {
        self.refining
    }

    /// One-step prediction of the terminal voltage at current `current` from
    /// the estimate, with the polarization history reconstructed from the
    /// window (`U_p = U_t − U_oc − R_i·I`). O(M).
    pub fn predict(&self, current: T) -> Option<T> {
        let p = self.estimate?;
        let wts = self.pw.weights();
        let mut hist = T::zero();
        for (&wj, (i, u)) in wts.iter().skip(1).zip(self.window.recent()) {
            hist = hist + wj * (u - p.u_oc - p.r_i * i);
        }
        let a = p.tau() * self.pw.scale();
        let up = (p.r_ct * current - a * hist) / (T::one() + a);
        Some(p.u_oc + p.r_i * current + up)
    }

    fn classify(&self, s: &OnlineSettings<T>, current: T, voltage: T) -> Option<Rejection> {
        if !(current.is_finite() && voltage.is_finite()) {
            return Some(Rejection::NonFinite);
        }
        if current.abs() > s.current_limit || voltage < s.voltage_min || voltage > s.voltage_max {
            return Some(Rejection::OutOfRange);
        }
        if self.spikes_in_row < s.max_consecutive_spikes && self.is_spike(s, current, voltage) {
            return Some(Rejection::Spike);
        }
        None
    }

    /// True when `voltage` is further than `max(spike_sigmas·RMSE,
    /// spike_floor)` from the model's prediction for `current`.
    fn is_spike(&self, s: &OnlineSettings<T>, current: T, voltage: T) -> bool {
        if !self.rmse.is_finite() {
            return false;
        }
        self.predict(current).is_some_and(|pred| {
            let limit = (s.spike_sigmas * self.rmse).max(s.spike_floor);
            (voltage - pred).abs() > limit
        })
    }

    /// Feeds one sample (current in A, positive when charging; terminal
    /// voltage in V) and runs the iterations for it. Never panics; never
    /// loses a sample (a rejected one is counted and substituted).
    pub fn push(&mut self, s: &OnlineSettings<T>, current: T, voltage: T) -> SampleReport<T> {
        self.counts.samples += 1;
        let rejected = self.classify(s, current, voltage);
        let sample = match rejected {
            None => {
                if self.spikes_in_row >= s.max_consecutive_spikes
                    && self.is_spike(s, current, voltage)
                {
                    // A step believed after max_consecutive_spikes
                    // rejections (a recalibrated sensor, a contactor): the
                    // samples before it belong to another regime, which no
                    // model of the window can fit across the step. The
                    // window restarts here; the estimate is kept, but no
                    // sample is judged by it until it has been refitted.
                    self.window.clear();
                    self.rmse = T::infinity();
                }
                self.spikes_in_row = 0;
                Some((current, voltage))
            }
            Some(why) => {
                match why {
                    Rejection::NonFinite => self.counts.non_finite += 1,
                    Rejection::OutOfRange => self.counts.out_of_range += 1,
                    Rejection::Spike => {
                        self.counts.spikes += 1;
                        self.spikes_in_row = self.spikes_in_row.saturating_add(1);
                    }
                }
                // Substitute. The current: the measured one when it is
                // itself plausible (only the voltage was bad), else the last
                // one. The voltage: the model's prediction for that current
                // (or the last voltage before a model exists).
                let plausible = current.is_finite() && current.abs() <= s.current_limit;
                self.window.recent().next().map(|(last_i, u)| {
                    let i = if plausible { current } else { last_i };
                    (i, self.predict(i).unwrap_or(u))
                })
            }
        };
        if let Some((i, u)) = sample {
            // Cannot fail: both values are finite here.
            let _ = self.window.push(i, u);
        }
        let mut report = SampleReport {
            status: self.status,
            rejected,
            iterations: 0,
            rmse: self.rmse,
        };
        self.run(s, &mut report);
        self.status = report.status;
        report.rmse = self.rmse;
        report
    }

    fn run(&mut self, s: &OnlineSettings<T>, report: &mut SampleReport<T>) {
        let b = &s.battery;
        let need = b.memory - 1 + super::regression::MIN_ROWS;
        if self.window.len() < need {
            report.status = Status::Filling;
            return;
        }
        // Current excitation over the fitted part of the window.
        let fitted = self.window.len() + 1 - b.memory;
        let count = T::lit(fitted as f64);
        let recent = || self.window.recent().take(fitted).map(|(i, _)| i);
        let mean = recent().fold(T::zero(), |a, i| a + i) / count;
        let var = recent().fold(T::zero(), |a, i| a + (i - mean) * (i - mean)) / count;
        if var.sqrt() <= b.min_current_std {
            report.status = Status::NotExcited;
            return;
        }
        for _ in 0..s.iterations_per_sample {
            let ok = if self.refining {
                self.step_refined(s)
            } else {
                self.step_paper(s)
            };
            report.iterations += 1;
            match ok {
                Ok(status) => report.status = status,
                Err(Error::NotExcited) => {
                    report.status = Status::NotExcited;
                    return;
                }
                Err(_) => {
                    report.status = Status::Held;
                    return;
                }
            }
        }
    }

    fn publish(&mut self, p: CellParameters<T>, rmse: T) {
        if self.pw.set_order(p.alpha).is_ok() {
            self.estimate = Some(p);
            self.rmse = rmse;
        }
    }

    fn step_paper(&mut self, s: &OnlineSettings<T>) -> Result<Status, Error> {
        let it = self.gi.iterate(&s.battery, &self.window)?;
        let rows = T::lit(it.rows.max(1) as f64);
        let cell = self.gi.cell();
        if let Some(p) = cell {
            self.publish(p, (T::lit(2.0) * it.cost / rows).sqrt());
        }
        if s.method == Method::Refined
            && (it.k >= s.paper_budget || (cell.is_some() && it.converged))
        {
            let start = cell
                .filter(|p| p.alpha >= s.battery.alpha_min && p.alpha <= s.battery.alpha_max)
                .unwrap_or(s.initial);
            self.oe.set_cell(&s.battery, start)?;
            self.refining = true;
        }
        Ok(if cell.is_some() {
            Status::Tracking
        } else {
            Status::Starting
        })
    }

    fn step_refined(&mut self, s: &OnlineSettings<T>) -> Result<Status, Error> {
        let st = self.oe.iterate(&s.battery, &self.window)?;
        self.publish(self.oe.cell(), st.rmse);
        Ok(Status::Tracking)
    }
}
