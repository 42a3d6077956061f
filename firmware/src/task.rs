//! The estimator task: one call per sample period.
//!
//! [`EstimatorTask::on_sample`] takes what the sampler returned this period
//! and
//!
//! 1. flags what the sampler itself knows is wrong (converter error,
//!    saturation, a dropped sample) and what only a history shows: a
//!    *stuck* voltage channel (bit-identical readings while the current
//!    moves) and an implausible temperature;
//! 2. pushes exactly one sample into the core's [`CellEstimator`] every
//!    period, so the time base the fractional differences rely on stays
//!    uniform: a faulty sample is pushed as NaN, which the core counts as
//!    rejected and replaces by its one-step prediction (no sample is lost);
//! 3. lets the core run its bounded number of iterations
//!    ([`OnlineSettings::iterations_per_sample`]).
//!
//! Nothing here allocates or panics; settings ([`TaskSettings`]) are kept
//! apart from state ([`EstimatorTask`]).

use crate::sampler::{Sample, SampleError};
use estimator_core::battery::ocv::{OcvModel, OcvTable};
use estimator_core::battery::online::{
    CellEstimator, Method, OnlineSettings, SampleCounts, SampleReport,
};
use estimator_core::battery::{CellParameters, Prior, Start};
use estimator_core::Error;

/// Settings of the task (one value for every cell of a pack).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaskSettings {
    /// The core's settings (method, iterations per sample, ranges, spikes,
    /// the build-time OCV table).
    pub online: OnlineSettings<f32, { crate::config::OCV_POINTS }>,
    /// A voltage bit-identical over this many consecutive samples while
    /// the current moves is a stuck channel.
    pub stuck_after: u8,
    /// "The current moves": the current spans more than this (A) over the
    /// run of identical voltages.
    pub stuck_current_span: f32,
    /// Plausible temperature range (°C); outside it (or NaN) the sample is
    /// still used (temperature is not in the model) but counted.
    pub temperature_range: (f32, f32),
}

impl TaskSettings {
    /// Settings for sample period `h` (s), GL memory `memory`, `method` and
    /// `iterations` per sample, for an 18650-class Li-ion cell.
    ///
    /// The estimator starts [`Start::AtRest`]: a BMS powers up with its
    /// cells at rest, so until the window first slides the polarization
    /// starts from zero; afterwards the core takes it from the data. With
    /// the build-time OCV table (`FRACBMS_OCV`, [`crate::config::OCV_SOC`])
    /// the core counts the state of charge from the first sample's rested
    /// voltage and fits `U_t − OCV(SOC)`; without one the OCV slope (state
    /// of charge drift inside the window) is fitted. With a build-time
    /// prior (`FRACBMS_PRIOR`) the window fit is maximum a posteriori
    /// ([`Prior::new`]'s spreads). The cell model is `FRACBMS_MODEL`'s
    /// (linear, or with the Butler–Volmer term).
    pub fn new(h: f32, memory: usize, method: Method, iterations: u16) -> Self {
        let mut online = OnlineSettings::new(h, memory, CellParameters::cell_18650());
        online.battery.start = Start::AtRest;
        online.method = method;
        online.iterations_per_sample = iterations;
        online.battery.model = crate::config::MODEL;
        if let Some([r_i, r_ct, q, alpha, bv_a, bv_i0]) = crate::config::PRIOR {
            online.battery.prior = Some(Prior::new(CellParameters {
                r_i,
                r_ct,
                q,
                alpha,
                u_oc: online.initial.u_oc,
                bv_a,
                bv_i0,
            }));
        }
        Self {
            online: online.with_curve(configured_ocv()),
            stuck_after: 4,
            stuck_current_span: 0.5,
            temperature_range: (-40.0, 85.0),
        }
    }
}

/// The build-time OCV table and capacity, if any (build.rs checked the
/// same `f32` values with the same code, so this is `Some` whenever a table
/// was given).
pub fn configured_ocv() -> Option<OcvModel<f32, { crate::config::OCV_POINTS }>> {
    use crate::config::{CAPACITY_AH, OCV_SOC, OCV_V};
    let table = OcvTable::new(&OCV_SOC, &OCV_V).ok()?;
    OcvModel::new(table, CAPACITY_AH).ok()
}

/// A fault the task found in one sample period.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Fault {
    /// The sampler failed ([`SampleError::Adc`]).
    Adc,
    /// A raw reading at the end of the converter's range.
    Saturated,
    /// No sample this period.
    Dropped,
    /// The voltage channel is stuck.
    Stuck,
    /// The temperature is NaN or out of range (sample still used).
    Temperature,
}

/// Counters of every fault the task has seen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct FaultCounts {
    /// Converter errors.
    pub adc: u32,
    /// Saturated readings.
    pub saturated: u32,
    /// Dropped samples.
    pub dropped: u32,
    /// Stuck voltage readings.
    pub stuck: u32,
    /// Implausible temperatures.
    pub temperature: u32,
}

/// What one sample period did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaskReport {
    /// The core's report (status, rejection, iterations, RMSE).
    pub core: SampleReport<f32>,
    /// The fault the task found, if any.
    pub fault: Option<Fault>,
}

/// One cell's estimator task: window `N`, memory capacity `MEM` (f32).
#[derive(Clone, Debug)]
pub struct EstimatorTask<const N: usize, const MEM: usize> {
    cell: CellEstimator<f32, N, MEM>,
    faults: FaultCounts,
    /// The run of bit-identical voltages: (bits, length, current min, max).
    run: Option<(u32, u8, f32, f32)>,
}

impl<const N: usize, const MEM: usize> EstimatorTask<N, MEM> {
    /// A task with an empty window; fails on inconsistent settings.
    pub fn new(s: &TaskSettings) -> Result<Self, Error> {
        Ok(Self {
            cell: CellEstimator::new(&s.online)?,
            faults: FaultCounts::default(),
            run: None,
        })
    }

    /// Handles this period's sample; `None` at [`SampleError::EndOfStream`]
    /// (nothing is pushed).
    pub fn on_sample(
        &mut self,
        s: &TaskSettings,
        sample: Result<Sample, SampleError>,
    ) -> Option<TaskReport> {
        let (current, voltage, fault) = match sample {
            Err(SampleError::EndOfStream) => return None,
            Err(e) => {
                let (f, c) = match e {
                    SampleError::Adc => (Fault::Adc, &mut self.faults.adc),
                    SampleError::Saturated => (Fault::Saturated, &mut self.faults.saturated),
                    _ => (Fault::Dropped, &mut self.faults.dropped),
                };
                *c += 1;
                (f32::NAN, f32::NAN, Some(f))
            }
            Ok(x) => self.check(s, &x),
        };
        let core = self.cell.push(&s.online, current, voltage);
        Some(TaskReport { core, fault })
    }

    /// Stuck-voltage and temperature checks of a sample the sampler
    /// believed: (current, voltage to push, fault).
    fn check(&mut self, s: &TaskSettings, x: &Sample) -> (f32, f32, Option<Fault>) {
        let bits = x.voltage_v.to_bits();
        let i = x.current_a;
        let run = match self.run {
            Some((b, n, lo, hi)) if b == bits && x.voltage_v.is_finite() && i.is_finite() => {
                (b, n.saturating_add(1), lo.min(i), hi.max(i))
            }
            _ => (bits, 1, i, i),
        };
        self.run = Some(run);
        if run.1 >= s.stuck_after && run.3 - run.2 > s.stuck_current_span {
            self.faults.stuck += 1;
            return (i, f32::NAN, Some(Fault::Stuck));
        }
        let (tlo, thi) = s.temperature_range;
        let fault = if x.temperature_c >= tlo && x.temperature_c <= thi {
            None
        } else {
            self.faults.temperature += 1;
            Some(Fault::Temperature)
        };
        (x.current_a, x.voltage_v, fault)
    }

    /// The last good estimate, if any.
    pub fn estimate(&self) -> Option<CellParameters<f32>> {
        self.cell.estimate()
    }

    /// The core's counters (every period pushed, and the rejected ones).
    pub fn counts(&self) -> SampleCounts {
        self.cell.counts()
    }

    /// The task's fault counters.
    pub fn faults(&self) -> FaultCounts {
        self.faults
    }

    /// The core estimator (window, status, prediction).
    pub fn cell(&self) -> &CellEstimator<f32, N, MEM> {
        &self.cell
    }
}
