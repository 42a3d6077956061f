//! The estimator task: one call per sample period, for every series cell.
//!
//! [`EstimatorTask::on_sample`] takes what the pack sampler returned this
//! period and
//!
//! 1. flags what the sampler itself knows is wrong (converter error,
//!    saturation, a dropped sample) and what only a history shows: a
//!    *stuck* voltage channel of a cell (bit-identical readings while the
//!    current moves) and an implausible temperature;
//! 2. pushes exactly one sample of every cell into the core's
//!    [`PackEstimator`] every period, so the time base the fractional
//!    differences rely on stays uniform: a faulty reading is pushed as NaN,
//!    which the core counts as rejected for that cell alone and replaces by
//!    its one-step prediction (no sample is lost);
//! 3. lets the core run the period's scheduled cell updates
//!    ([`PackSettings::updates_per_period`], each with
//!    [`OnlineSettings::iterations_per_sample`] iterations);
//! 4. with an OCV table, asks the string's state of power
//!    ([`EstimatorTask::power`]: the weakest cell's).
//!
//! One cell is the one-cell pack (the core's `CellEstimator` is the same).
//!
//! Nothing here allocates or panics; settings ([`TaskSettings`]) are kept
//! apart from state ([`EstimatorTask`]). The core's code that the step runs
//! still links panic call sites (index checks the optimizer keeps):
//! `cargo xtask panic-sites` lists them (docs/panic-paths.md).

use crate::sampler::{PackReading, SampleError};
use estimator_core::battery::map::{MapFollower, ParameterMap};
use estimator_core::battery::ocv::{OcvModel, OcvTable};
use estimator_core::battery::online::{CellState, Method, OnlineSettings, SampleCounts};
use estimator_core::battery::pack::{PackEstimator, PackHealth, PackReport, PackSettings};
use estimator_core::battery::power::{PowerLimits, PowerReport, PowerSettings};
use estimator_core::battery::snapshot::{RestorePolicy, SnapshotError};
use estimator_core::battery::{CellParameters, Prior, Start};
use estimator_core::Error;

/// Settings of the task (one value for every cell of a pack).
///
/// Every cell is updated every period by default
/// ([`PackSettings::new`]); set `pack.updates_per_period` to spread the
/// updates over several periods.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaskSettings {
    /// The core's settings: every cell's (method, iterations per update,
    /// ranges, spikes, the build-time OCV table), the schedule and the
    /// health threshold.
    pub pack: PackSettings<f32, { crate::config::OCV_POINTS }>,
    /// A voltage bit-identical over this many consecutive samples while
    /// the current moves is a stuck channel.
    pub stuck_after: u8,
    /// "The current moves": the current spans more than this (A) over the
    /// run of identical voltages.
    pub stuck_current_span: f32,
    /// Plausible temperature range (°C); outside it (or NaN) the sample is
    /// still used (temperature is not in the model) but counted.
    pub temperature_range: (f32, f32),
    /// A parameter map the prior follows (`FRACBMS_MAP`): the map's cell at
    /// the pack's mean counted SOC and the sampled temperature is the
    /// prior's centre ([`Prior::new`]'s spreads), taken again as the core's
    /// [`MapFollower`] says. It takes the place of `pack.cell.battery.prior`.
    pub map: Option<ParameterMap<'static, f32>>,
    /// What the state of power is asked, every period
    /// ([`EstimatorTask::power`]): with the build-time OCV table, the
    /// defaults of `host-sim online battery` ([`POWER_HORIZONS_S`]; the
    /// table's lowest and highest voltage; the plausible current; a 1C
    /// discharge pulse, its voltage corrected by the last pulse of that
    /// current, [`OnlineSettings::pulse_current`]); without one, none.
    pub power: Option<PowerSettings<f32>>,
}

/// The state of power's horizons (s), as `host-sim online battery`'s
/// default `--horizons 10,30`.
pub const POWER_HORIZONS_S: [f32; 2] = [10.0, 30.0];

impl TaskSettings {
    /// Every cell's core settings.
    pub fn online(&self) -> &OnlineSettings<f32, { crate::config::OCV_POINTS }> {
        &self.pack.cell
    }

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
        online.battery.tail = crate::config::TAIL;
        online.slow_memory_s = crate::config::SLOW_MEMORY_S;
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
        let curve = configured_ocv();
        let power = curve.as_ref().and_then(|m| {
            let v = m.table.ocv_points();
            let limits = PowerLimits {
                voltage_min: *v.first()?,
                voltage_max: *v.last()?,
                current_limit: online.current_limit,
            };
            // Each horizon rounded to the nearest sample, as on the host.
            PowerSettings::from_seconds(limits, &POWER_HORIZONS_S, h, Some(-m.capacity_ah))
        });
        // The pulse voltage corrected by the last pulse of its current, as
        // `host-sim online battery` has it by default.
        online.pulse_current = power.as_ref().and_then(|p| p.pulse_current);
        Self {
            pack: PackSettings::new(online.with_curve(curve)),
            stuck_after: 4,
            stuck_current_span: 0.5,
            temperature_range: (-40.0, 85.0),
            // build.rs checked the same f32 levels with the same code.
            map: ParameterMap::new(&crate::config::MAP).ok(),
            power,
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
    /// A cell's voltage channel is stuck.
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
    /// Saturated readings (periods; a saturated cell of a pack reading is
    /// counted by the core as that cell's non-finite sample).
    pub saturated: u32,
    /// Dropped samples.
    pub dropped: u32,
    /// Stuck voltage readings (all cells).
    pub stuck: u32,
    /// Implausible temperatures.
    pub temperature: u32,
}

/// What one sample period did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaskReport {
    /// The core's report (cells rejected, updated, iterations).
    pub core: PackReport,
    /// The fault the task found, if any (the period's, else the first
    /// stuck cell's).
    pub fault: Option<Fault>,
}

/// The run of bit-identical voltages of a cell: (bits, length, current
/// min, max).
type Run = Option<(u32, u8, f32, f32)>;

/// The estimator task of a pack of up to `C` series cells: window `N`,
/// memory capacity `MEM` (f32).
#[derive(Clone, Debug)]
pub struct EstimatorTask<const N: usize, const MEM: usize, const C: usize> {
    pack: PackEstimator<f32, N, MEM, C>,
    faults: FaultCounts,
    runs: [Run; C],
    volts: [f32; C],
    /// The map's prior now, and where it was taken.
    map_prior: Option<Prior<f32>>,
    follower: MapFollower<f32>,
    /// The string's state of power after the last period.
    power: Option<PowerReport<f32>>,
}

impl<const N: usize, const MEM: usize, const C: usize> EstimatorTask<N, MEM, C> {
    /// The task built at compile time, with no cells: the value of the
    /// board's `static` task, which [`init`](Self::init) then makes a task
    /// for `C` cells in place. So the task (tens of KiB: every cell's state
    /// and the core's working area) is never built on the stack and moved
    /// into its static; the start-up stack stays the same whatever the
    /// cells (docs/firmware.md, "Measured").
    pub const EMPTY: Self = Self {
        pack: PackEstimator::EMPTY,
        faults: FaultCounts {
            adc: 0,
            saturated: 0,
            dropped: 0,
            stuck: 0,
            temperature: 0,
        },
        runs: [None; C],
        volts: [f32::NAN; C],
        map_prior: None,
        follower: MapFollower::new(),
        power: None,
    };

    /// A task for `C` cells with empty windows; fails on inconsistent
    /// settings. Built by value: on the target, take the static
    /// [`EMPTY`](Self::EMPTY) and [`init`](Self::init) it instead.
    pub fn new(s: &TaskSettings) -> Result<Self, Error> {
        let mut task = Self::EMPTY;
        task.init(s)?;
        Ok(task)
    }

    /// Makes this task, whatever it held, a task for `C` cells with empty
    /// windows (the one [`new`](Self::new) returns), in place: no copy of
    /// the task on the stack.
    ///
    /// # Errors
    /// Inconsistent settings (the core's
    /// [`PackEstimator::init`]); the task then has no cells and takes no
    /// sample until an `init` succeeds.
    pub fn init(&mut self, s: &TaskSettings) -> Result<(), Error> {
        self.pack.init(&s.pack, C)?;
        self.faults = FaultCounts::default();
        self.runs = [None; C];
        self.volts = [f32::NAN; C];
        self.map_prior = None;
        self.follower = MapFollower::new();
        self.power = None;
        Ok(())
    }

    /// Handles this period's sample: the sampler's result and the cell
    /// voltages it wrote (cell 1 first; missing cells are NaN). `None` at
    /// [`SampleError::EndOfStream`] (nothing is pushed).
    ///
    /// Never inlined: the per-sample step is one function in the image, the
    /// root of `cargo xtask panic-sites`' call graph (docs/panic-paths.md).
    #[inline(never)]
    pub fn on_sample(
        &mut self,
        s: &TaskSettings,
        sample: Result<PackReading, SampleError>,
        volts: &[f32],
    ) -> Option<TaskReport> {
        let temperature = sample.as_ref().map_or(f32::NAN, |x| x.temperature_c);
        let (current, fault) = match sample {
            Err(SampleError::EndOfStream) => return None,
            Err(e) => {
                let (f, c) = match e {
                    SampleError::Adc => (Fault::Adc, &mut self.faults.adc),
                    SampleError::Saturated => (Fault::Saturated, &mut self.faults.saturated),
                    _ => (Fault::Dropped, &mut self.faults.dropped),
                };
                *c += 1;
                self.volts = [f32::NAN; C];
                (f32::NAN, Some(f))
            }
            Ok(x) => (x.current_a, self.check(s, &x, volts)),
        };
        // Cannot fail: the task holds one voltage per cell.
        let core = match self.follow_map(s, temperature) {
            Some(prior) => {
                let mut pack = s.pack;
                pack.cell.battery.prior = Some(prior);
                self.pack.push(&pack, current, &self.volts)
            }
            None => self.pack.push(&s.pack, current, &self.volts),
        }
        .unwrap_or_default();
        // The state of power every period (the weakest cell's): part of
        // the period's cost.
        self.power = s
            .power
            .as_ref()
            .and_then(|p| self.pack.pack_state_of_power(&s.pack.cell, p));
        Some(TaskReport { core, fault })
    }

    /// With a map: the prior at the pack's mean published SOC (the
    /// observer's, else the count; the middle
    /// level's before any SOC is known) and `temperature` (NaN: the last
    /// one), taken again when either moved by its step.
    fn follow_map(&mut self, s: &TaskSettings, temperature: f32) -> Option<Prior<f32>> {
        let map = s.map.as_ref()?;
        let (mut sum, mut n) = (0.0f32, 0u32);
        for k in 0..C {
            let z = self
                .pack
                .cell(k)
                .and_then(|c| c.published_state_of_charge(&s.pack.cell));
            if let Some(z) = z {
                sum += z;
                n += 1;
            }
        }
        let soc = if n > 0 { sum / n as f32 } else { f32::NAN };
        if let Some(mut cell) = self.follower.follow(map, soc, temperature) {
            if s.pack.cell.ocv.is_none() {
                // The map's u_oc is an offset from the OCV curve; without
                // a curve the start's own U_oc stands.
                cell.u_oc = s.pack.cell.initial.u_oc;
            }
            self.map_prior = Some(Prior::new(cell));
        }
        self.map_prior
    }

    /// The map's prior now (its centre is the map's cell at the SOC and
    /// temperature it was last taken at), if the task follows a map.
    pub fn map_prior(&self) -> Option<Prior<f32>> {
        self.map_prior
    }

    /// Stuck-voltage checks of every cell and the temperature check of a
    /// reading the sampler believed; fills the voltages to push. Returns
    /// the period's fault.
    fn check(&mut self, s: &TaskSettings, x: &PackReading, volts: &[f32]) -> Option<Fault> {
        let i = x.current_a;
        let mut fault = None;
        for (k, (run, out)) in self.runs.iter_mut().zip(self.volts.iter_mut()).enumerate() {
            let v = volts.get(k).copied().unwrap_or(f32::NAN);
            let bits = v.to_bits();
            let r = match *run {
                Some((b, n, lo, hi)) if b == bits && v.is_finite() && i.is_finite() => {
                    (b, n.saturating_add(1), lo.min(i), hi.max(i))
                }
                _ => (bits, 1, i, i),
            };
            *run = Some(r);
            *out = if r.1 >= s.stuck_after && r.3 - r.2 > s.stuck_current_span {
                self.faults.stuck += 1;
                fault = fault.or(Some(Fault::Stuck));
                f32::NAN
            } else {
                v
            };
        }
        let (tlo, thi) = s.temperature_range;
        if !(x.temperature_c >= tlo && x.temperature_c <= thi) {
            self.faults.temperature += 1;
            fault = Some(Fault::Temperature);
        }
        fault
    }

    /// Cells of the pack.
    pub fn cells(&self) -> usize {
        C
    }

    /// Cell `k`'s last good estimate (0-based), if any.
    pub fn estimate_of(&self, k: usize) -> Option<CellParameters<f32>> {
        self.pack.cell(k).and_then(|c| c.estimate())
    }

    /// The first cell's last good estimate (the one cell of a one-cell
    /// pack).
    pub fn estimate(&self) -> Option<CellParameters<f32>> {
        self.estimate_of(0)
    }

    /// Cell `k`'s state (status, counters, state of charge; 0-based).
    pub fn cell(&self, k: usize) -> Option<&CellState<f32, N>> {
        self.pack.cell(k)
    }

    /// The first cell's core counters (every period is pushed into every
    /// cell, so its `samples` counts the periods).
    pub fn counts(&self) -> SampleCounts {
        self.pack.cell(0).map(|c| c.counts()).unwrap_or_default()
    }

    /// Samples rejected over all cells.
    pub fn rejected(&self) -> u32 {
        (0..C)
            .filter_map(|k| self.pack.cell(k))
            .map(|c| c.counts().rejected())
            .sum()
    }

    /// The task's fault counters.
    pub fn faults(&self) -> FaultCounts {
        self.faults
    }

    /// The pack's medians (`None` before any cell has an estimate).
    pub fn health(&self) -> Option<PackHealth<f32>> {
        self.pack.health()
    }

    /// True when cell `k` stands out from the pack's median.
    pub fn is_flagged(&self, s: &TaskSettings, health: &PackHealth<f32>, k: usize) -> bool {
        self.pack.is_flagged(&s.pack, health, k)
    }

    /// The string's state of power after the last period (the weakest
    /// cell's at each horizon; `None` without [`TaskSettings::power`] or
    /// while a cell's model is not published).
    pub fn power(&self) -> Option<PowerReport<f32>> {
        self.power
    }

    /// Cell `k`'s state of power now (0-based), as [`TaskSettings::power`]
    /// asks.
    pub fn cell_power(&self, s: &TaskSettings, k: usize) -> Option<PowerReport<f32>> {
        self.pack.state_of_power(k, &s.pack.cell, s.power.as_ref()?)
    }

    /// Writes the pack's snapshot into `buf` (the core's
    /// [`PackEstimator::save`], no clock); returns the bytes written.
    ///
    /// # Errors
    /// [`SnapshotError::TooShort`] when `buf` is shorter than
    /// [`PackEstimator::snapshot_size`].
    pub fn save(&self, s: &TaskSettings, buf: &mut [u8]) -> Result<usize, SnapshotError> {
        self.pack.save(&s.pack.cell, None, buf)
    }

    /// Restores the pack from a snapshot (the core's
    /// [`PackEstimator::restore`] with its default policy, no clock); on an
    /// error nothing changes.
    ///
    /// # Errors
    /// The first of the core's checks that fails.
    pub fn restore(&mut self, s: &TaskSettings, buf: &[u8]) -> Result<(), SnapshotError> {
        self.pack
            .restore(&s.pack.cell, buf, &RestorePolicy::default())
    }

    /// The core pack estimator.
    pub fn pack(&self) -> &PackEstimator<f32, N, MEM, C> {
        &self.pack
    }
}
