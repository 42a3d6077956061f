//! `online battery`: the sliding-window estimator, sample by sample, as the
//! firmware runs it (f64 here).

use crate::cycler::resample::Gap;
use crate::error::Result;
use crate::identify::{BatteryMethod, ModelRequest};
use crate::io::OCV_POINTS;
use crate::ocv::CellOcv;
use crate::{bail, err};
use crate::{io, progress};
use estimator_core::battery::map::MapFollower;
use estimator_core::battery::ocv::OcvModel;
use estimator_core::battery::online::{
    CellEstimator, Method, OnlineSettings, PublishedParameters, Rejection,
};
use estimator_core::battery::output_error::RefinementWork;
use estimator_core::battery::power::VoltageTiming;
use estimator_core::battery::snapshot::{Restoration, RestorePolicy, SnapshotError};
use estimator_core::battery::{CellModel, CellParameters, Prior, Start};
use estimator_core::Real;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

pub use prior::{
    prior_from_fit, prior_source_from_json, read_prior, read_prior_source, PriorMap, PriorSource,
};

mod file;
pub mod life;
mod log_tally;
pub mod power;
mod prior;
pub mod schema;
pub mod soc;
pub mod state;
mod tally;

pub use file::{battery_file, OnlineBatteryOptions, OnlineReport};
pub use tally::PublicationTally;

/// Floating-point precision of an online estimator.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Precision {
    /// Single precision (the Cortex-M4F FPU).
    F32,
    /// Double precision.
    #[default]
    F64,
}

impl Precision {
    /// `"f32"` or `"f64"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        }
    }
}

/// One row of the track.
#[derive(Clone, Copy, Debug)]
pub struct TrackRow {
    /// Time (s).
    pub t: f64,
    /// The estimate after this sample.
    pub estimate: Option<CellParameters<f64>>,
    /// Status name.
    pub status: &'static str,
    /// Why this sample was rejected (and substituted): `non_finite`,
    /// `out_of_range` or `spike`; `None` when it was accepted.
    pub rejected: Option<&'static str>,
    /// The published state of charge after this sample (with an OCV
    /// curve): the observer's, or the count with `--soc coulomb`
    /// ([`TrackOptions::soc`]).
    pub soc: Option<f64>,
    /// The count and the observer's estimate behind `soc`.
    pub soc_detail: soc::SocRow,
    /// The published `R_i` over the prior's or the map's `R_i` at this SOC
    /// and temperature (none without a prior).
    pub soh_r: Option<f64>,
    /// The OCV offset ΔU of the estimate (with an OCV curve).
    pub ocv_offset: Option<f64>,
    /// The one-step prediction of this sample's voltage (V) from the
    /// estimate before it (none before the first estimate).
    pub predicted: Option<f64>,
    /// What is published of `R_i`, `R_ct`, `Q` and α, each with whether
    /// the data identify it (the track's `r_i`… and `*_status` columns).
    pub published: PublishedParameters<f64>,
    /// The resistance of the last precise current step (Ω).
    pub step_resistance: Option<f64>,
    /// The state of power at each of [`TrackOptions::power`]'s horizons
    /// (the rest empty).
    pub power: [power::PowerRow; power::MAX_HORIZONS],
    /// Whether the estimator started from a snapshot (`--state-in`), and
    /// whether its SOC stood against the first rested voltage.
    pub restoration: Restoration,
}

/// What a track run did.
#[derive(Clone, Copy, Debug, Default)]
pub struct TrackSummary {
    /// Samples offered.
    pub samples: u64,
    /// Samples rejected (and substituted).
    pub rejected: u32,
    /// Of which not finite.
    pub non_finite: u32,
    /// Of which out of the plausible range.
    pub out_of_range: u32,
    /// Of which voltage spikes.
    pub spikes: u32,
    /// What the output-error refinement computed.
    pub work: RefinementWork,
    /// What was published, sample by sample.
    pub published: PublicationTally,
}

/// How `track` runs the online estimator: the firmware's settings, as the
/// `online battery` flags give them.
#[derive(Clone, Copy, Debug)]
pub struct TrackOptions<'a> {
    /// Window length L (64, 128, 256, 512 or 1024).
    pub window: usize,
    /// Short memory M of the fractional differences, 1..=L−8.
    pub memory: usize,
    /// Refinement iterations per sample.
    pub iterations_per_sample: u16,
    /// The paper's 2S-OP-GI or the output-error refinement.
    pub method: BatteryMethod,
    /// f64 or f32 arithmetic.
    pub precision: Precision,
    /// Where the first window's simulation starts.
    pub start: Start,
    /// A prior from a characterization fit (MAP window fits).
    pub prior: Option<&'a Prior<f64>>,
    /// A prior that follows the counted SOC and the temperature: a
    /// parameter map's cell there (in place of `prior`).
    pub prior_map: Option<&'a PriorMap>,
    /// The cell's OCV curve, capacity and start SOC.
    pub cell: Option<&'a CellOcv>,
    /// The cell model (`auto`: the prior's, linear without one).
    pub model: ModelRequest,
    /// Add the Grünwald–Letnikov taps beyond the memory (the short-memory
    /// correction, `BatterySettings::tail`).
    pub tail: bool,
    /// The state-of-power columns: horizons, limits, pulse.
    pub power: power::PowerOptions,
    /// How the SOC is published (with `cell`).
    pub soc: soc::SocOptions,
    /// The memory (s) of the slow part carried across windows
    /// (`--slow-memory-s`, the core's `OnlineSettings::slow_memory_s`):
    /// the published `R_ct`, `Q` and α are the mean of what the windows
    /// identified. `None`: each window's own.
    pub slow_memory_s: Option<f64>,
    /// The slow part's memory in state of charge (`--slow-memory-soc`,
    /// `OnlineSettings::slow_memory_soc`; `None`: the core's default).
    pub slow_memory_soc: Option<f64>,
    /// Where in its current's period each sample's voltage was taken (the
    /// core's `OnlineSettings::voltage_timing`): at its end for a gauge or
    /// a simulation; `online battery` gives the mean where the resampler
    /// merged rows.
    pub voltage_timing: VoltageTiming,
}

impl TrackOptions<'_> {
    /// Window `window`, memory `memory`, one refinement iteration per
    /// sample in f64, started from the data, no prior, no OCV curve.
    pub fn new(window: usize, memory: usize) -> Self {
        TrackOptions {
            window,
            memory,
            iterations_per_sample: 1,
            method: BatteryMethod::Refined,
            precision: Precision::F64,
            start: Start::FromData,
            prior: None,
            prior_map: None,
            cell: None,
            model: ModelRequest::Linear,
            tail: false,
            power: power::PowerOptions::default(),
            soc: soc::SocOptions::default(),
            slow_memory_s: None,
            slow_memory_soc: None,
            voltage_timing: VoltageTiming::End,
        }
    }

    /// The model the window fits: `auto` is the prior's (Butler–Volmer when
    /// its centre has the term), linear without a prior.
    pub fn cell_model(&self) -> CellModel {
        match self.model {
            ModelRequest::Linear => CellModel::Linear,
            ModelRequest::ButlerVolmer => CellModel::ButlerVolmer,
            ModelRequest::Auto => match (self.prior, self.prior_map) {
                (_, Some(m)) if m.is_butler_volmer() => CellModel::ButlerVolmer,
                (Some(p), None) if p.center.is_butler_volmer() => CellModel::ButlerVolmer,
                _ => CellModel::Linear,
            },
        }
    }

    /// The core's settings for sample period `h`.
    pub(crate) fn settings<T: Real>(&self, h: f64) -> Result<OnlineSettings<T, OCV_POINTS>> {
        let mut s = OnlineSettings::new(T::lit(h), self.memory, CellParameters::cell_18650());
        s.battery.start = self.start;
        let first = self
            .prior_map
            .map(|m| m.prior_at(self.cell.map(|c| c.soc0), None));
        s.battery.prior = first.as_ref().or(self.prior).map(cast_prior);
        s.battery.model = self.cell_model();
        s.battery.tail = self.tail;
        s.iterations_per_sample = self.iterations_per_sample;
        s.pulse_current = self.power.corrected_pulse(self.cell).map(T::lit);
        s.voltage_timing = self.voltage_timing;
        if let Some(m) = self.slow_memory_s {
            if m.is_nan() || m < 0.0 {
                bail!(
                    Options,
                    "--slow-memory-s {m}: must be a number of seconds, 0 or more"
                );
            }
            s.slow_memory_s = T::lit(m);
        }
        if let Some(m) = self.slow_memory_soc {
            if m.is_nan() || m <= 0.0 {
                bail!(
                    Options,
                    "--slow-memory-soc {m}: must be a positive fraction of the state of charge"
                );
            }
            s.slow_memory_soc = T::lit(m);
        }
        s.method = match self.method {
            BatteryMethod::Paper => Method::Paper,
            BatteryMethod::Refined => Method::Refined,
        };
        let curve = match self.cell {
            None => None,
            Some(c) => {
                let table = c
                    .model
                    .table
                    .cast::<T>()
                    .map_err(|e| err!(Options, "--ocv: in this precision: {e}"))?;
                Some(
                    OcvModel::new(table, T::lit(c.model.capacity_ah))
                        .map_err(|e| err!(Options, "--capacity-ah: {e}"))?,
                )
            }
        };
        let mut s = s.with_curve(curve);
        self.soc.apply(&mut s.soc)?;
        Ok(s)
    }
}

fn cast_prior<T: Real>(p: &Prior<f64>) -> Prior<T> {
    Prior {
        center: p.center.cast(),
        log_sigma: T::lit(p.log_sigma),
        alpha_sigma: T::lit(p.alpha_sigma),
        noise_v: T::lit(p.noise_v),
    }
}

/// Runs the online estimator over a record as `o` says, calling `sink`
/// after every sample. With `o.prior_map`, `temperature` (°C, one per
/// sample) picks the map's temperature. At the first sample after each of
/// the log's `gaps` the estimator resumes: counting the gap's charge where
/// the export's own count gives it ([`Tracker::bridge_gap`]), else with
/// the charge unknown ([`Tracker::resume_after_gap`]); rested when the
/// current there is at most C/100.
pub fn track(
    rec: &io::BatteryRecord,
    o: &TrackOptions,
    temperature: Option<&[f64]>,
    gaps: &[Gap],
    sink: impl FnMut(TrackRow) -> Result<()>,
) -> Result<TrackSummary> {
    let mut cell = Tracker::new(o, rec.h, o.cell.map(|c| c.soc0))?;
    track_with(&mut cell, rec, o, temperature, gaps, sink)
}

/// [`track`] with a tracker the caller made (and may have restored, and
/// saves after).
pub fn track_with(
    cell: &mut Tracker,
    rec: &io::BatteryRecord,
    o: &TrackOptions,
    temperature: Option<&[f64]>,
    gaps: &[Gap],
    mut sink: impl FnMut(TrackRow) -> Result<()>,
) -> Result<TrackSummary> {
    let rest = o.cell.map_or(0.0, |c| c.model.capacity_ah / 100.0);
    let mut ends = gaps
        .iter()
        .map(|g| (g.start_s + g.length_s, g.charge_ah))
        .peekable();
    let pb = progress::bar(rec.current.len() as u64, "tracking");
    for (k, ((&t, &i), &v)) in rec
        .time
        .iter()
        .zip(&rec.current)
        .zip(&rec.voltage)
        .enumerate()
    {
        if let Some(t) = temperature.and_then(|x| x.get(k)) {
            cell.set_temperature(*t);
        }
        if let Some((_, charge)) = ends.next_if(|&(end, _)| end <= t) {
            // Gaps that end before this sample, their charges summed (one
            // unknown: unknown).
            let mut charge = charge;
            while let Some((_, c)) = ends.next_if(|&(end, _)| end <= t) {
                charge = charge.zip(c).map(|(a, b)| a + b);
            }
            match charge {
                Some(q) => cell.bridge_gap(q, i.abs() <= rest),
                None => cell.resume_after_gap(i.abs() <= rest),
            }
        }
        sink(cell.push(t, i, v))?;
        if k % 256 == 0 {
            pb.set_position(k as u64);
        }
    }
    pb.finish_and_clear();
    Ok(cell.summary())
}

/// The online estimator of one cell at the window length and precision
/// [`TrackOptions`] choose, fed one sample at a time: the loop of
/// [`track`] (`online battery`), and what the Python `OnlineCell` holds.
pub struct Tracker {
    cell: Box<dyn Step>,
    /// The map the prior follows, the temperature now, and where the
    /// prior was last taken (the core's follower, as in the firmware).
    map: Option<PriorMap>,
    temperature: Option<f64>,
    /// The follower in the estimator's precision: an `f32` estimator
    /// follows the map in `f32`, as the C ABI and the firmware do.
    follower: Follower,
    /// What `soc` publishes.
    soc_mode: soc::SocMode,
    /// The prior's `R_i`, or the map's where the prior was last taken:
    /// `soh_r`'s reference.
    reference_r_i: Option<f64>,
    /// What has been published so far.
    tally: PublicationTally,
}

/// Where a map prior was last taken, in the estimator's precision.
enum Follower {
    F64(MapFollower<f64>),
    F32(MapFollower<f32>),
}

/// [`Tracker`]'s estimator behind one type for every window and precision.
trait Step: Send + Sync {
    fn push(&mut self, t: f64, current: f64, voltage: f64) -> TrackRow;
    fn summary(&self) -> TrackSummary;
    fn set_state_of_charge(&mut self, soc: f64);
    fn resume_after_gap(&mut self, rested: bool);
    fn bridge_gap(&mut self, charge_ah: f64, rested: bool);
    /// The SOC `mode` publishes now.
    fn published_soc(&self, mode: soc::SocMode) -> Option<f64>;
    fn set_prior(&mut self, p: &Prior<f64>);
    /// The core's snapshot ([`estimator_core::battery::snapshot`]).
    fn save(&self, saved_at_s: Option<u32>) -> Vec<u8>;
    fn restore(
        &mut self,
        bytes: &[u8],
        now_s: Option<u32>,
    ) -> std::result::Result<(), SnapshotError>;
    fn restoration(&self) -> Restoration;
}

/// The core's single-cell estimator with its settings.
struct Sized<T: Real, const N: usize> {
    s: OnlineSettings<T, OCV_POINTS>,
    est: Box<CellEstimator<T, N, N>>,
    power: Option<power::ResolvedPower>,
}

impl<T: Real + Send + Sync + 'static, const N: usize> Sized<T, N> {
    fn boxed(
        s: OnlineSettings<T, OCV_POINTS>,
        soc0: Option<f64>,
        power: Option<power::ResolvedPower>,
    ) -> Result<Box<dyn Step>> {
        let mut est =
            Box::new(CellEstimator::<T, N, N>::new(&s).map_err(|e| err!(Options, "{e}"))?);
        if let Some(z) = soc0 {
            est.set_state_of_charge(T::lit(z));
        }
        Ok(Box::new(Self { s, est, power }))
    }
}

impl<T: Real + Send + Sync, const N: usize> Step for Sized<T, N> {
    fn push(&mut self, t: f64, current: f64, voltage: f64) -> TrackRow {
        let (s, est) = (&self.s, &mut self.est);
        let predicted = est.predict(s, T::lit(current)).map(|y| y.to_f64());
        let r = est.push(s, T::lit(current), T::lit(voltage));
        TrackRow {
            t,
            estimate: est.estimate().map(|p| p.cast()),
            predicted,
            status: r.status.as_str(),
            rejected: r.rejected.map(|why| match why {
                Rejection::NonFinite => "non_finite",
                Rejection::OutOfRange => "out_of_range",
                Rejection::Spike => "spike",
            }),
            soc: est.state_of_charge().map(|z| z.to_f64()),
            soc_detail: soc::SocRow {
                coulomb: est.state_of_charge().map(|z| z.to_f64()),
                observer: est.soc_estimate(s).map(|e| e.cast()),
            },
            soh_r: None,
            ocv_offset: est.ocv_offset().map(|d| d.to_f64()),
            published: est.published().map(|v| v.to_f64()),
            step_resistance: est.cell_state().step_resistance().map(|st| st.ohm.to_f64()),
            power: self
                .power
                .map_or([power::PowerRow::default(); power::MAX_HORIZONS], |p| {
                    p.rows(est, s)
                }),
            restoration: est.cell_state().restoration(),
        }
    }

    fn save(&self, saved_at_s: Option<u32>) -> Vec<u8> {
        state::saved(self.est.snapshot_size(), |buf| {
            self.est.save(&self.s, saved_at_s, buf)
        })
    }

    fn restore(
        &mut self,
        bytes: &[u8],
        now_s: Option<u32>,
    ) -> std::result::Result<(), SnapshotError> {
        let policy = RestorePolicy {
            now_s,
            ..RestorePolicy::default()
        };
        self.est.restore(&self.s, bytes, &policy)
    }

    fn restoration(&self) -> Restoration {
        self.est.cell_state().restoration()
    }

    fn set_state_of_charge(&mut self, soc: f64) {
        self.est.set_state_of_charge(T::lit(soc));
    }

    fn resume_after_gap(&mut self, rested: bool) {
        self.est.resume_after_gap(rested);
    }

    fn bridge_gap(&mut self, charge_ah: f64, rested: bool) {
        self.est.bridge_gap(&self.s, T::lit(charge_ah), rested);
    }

    fn published_soc(&self, mode: soc::SocMode) -> Option<f64> {
        match mode {
            soc::SocMode::Observer => self.est.published_state_of_charge(&self.s),
            soc::SocMode::Coulomb => self.est.state_of_charge(),
        }
        .map(|z| z.to_f64())
    }

    fn set_prior(&mut self, p: &Prior<f64>) {
        self.s.battery.prior = Some(cast_prior(p));
    }

    fn summary(&self) -> TrackSummary {
        let c = self.est.counts();
        TrackSummary {
            samples: c.samples,
            rejected: c.rejected(),
            non_finite: c.non_finite,
            out_of_range: c.out_of_range,
            spikes: c.spikes,
            work: self.est.refinement_work(),
            published: PublicationTally::default(),
        }
    }
}

impl Tracker {
    /// The estimator `o` describes for sample period `h` (s), its SOC set
    /// to `soc0` (with `o.cell`'s curve; `None`: read by the core from the
    /// first rested samples, as the firmware does).
    ///
    /// # Errors
    /// A window that is not 64, 128, 256, 512 or 1024, a memory outside
    /// `1..=window − 8`, or settings the core refuses.
    pub fn new(o: &TrackOptions, h: f64, soc0: Option<f64>) -> Result<Self> {
        let window = o.window;
        check_window(window, o.memory)?;
        o.power.check()?;
        let power = o.power.resolve(o.cell);
        if let Some(p) = &power {
            p.check()?;
            p.check_period(h)?;
        }
        let reference_r_i = match (o.prior_map, o.prior) {
            (Some(m), _) => Some(m.prior_at(soc0, None).center.r_i),
            (None, Some(p)) => Some(p.center.r_i),
            (None, None) => None,
        };
        let cell = match o.precision {
            Precision::F64 => sized(o.settings::<f64>(h)?, soc0, window, power)?,
            Precision::F32 => sized(o.settings::<f32>(h)?, soc0, window, power)?,
        };
        Ok(Self {
            cell,
            map: o.prior_map.cloned(),
            temperature: None,
            follower: match o.precision {
                Precision::F64 => Follower::F64(MapFollower::new()),
                Precision::F32 => Follower::F32(MapFollower::new()),
            },
            soc_mode: o.soc.mode,
            reference_r_i,
            tally: PublicationTally::default(),
        })
    }

    /// The record resumes after a gap of unknown charge: the window
    /// restarts and, when `rested`, the state of charge is read again
    /// from the next rested voltages and the restarted window is fitted
    /// from rest until it slides
    /// ([`estimator_core::battery::online::CellEstimator::resume_after_gap`]).
    pub fn resume_after_gap(&mut self, rested: bool) {
        self.cell.resume_after_gap(rested);
    }

    /// The record resumes after a gap whose charge is known (`charge_ah`,
    /// A·h, + charging, beyond what the samples across it counted): as
    /// [`resume_after_gap`](Self::resume_after_gap), but the state of
    /// charge is counted through it, not read again
    /// ([`estimator_core::battery::online::CellEstimator::bridge_gap`]).
    pub fn bridge_gap(&mut self, charge_ah: f64, rested: bool) {
        self.cell.bridge_gap(charge_ah, rested);
    }

    /// The cell's temperature now (°C): the map's temperature the prior is
    /// taken at (with a map prior; a non-finite value is ignored).
    pub fn set_temperature(&mut self, t: f64) {
        if t.is_finite() {
            self.temperature = Some(t);
        }
    }

    /// With a map prior: the prior at the published SOC and the
    /// temperature now, taken again when the SOC has moved by 0.001 or the temperature
    /// by 0.5 °C (the core's [`MapFollower`]; nothing before the SOC is
    /// known: the prior of [`TrackOptions::settings`] stands).
    fn follow_map(&mut self) {
        let (Some(m), Some(z)) = (&self.map, self.cell.published_soc(self.soc_mode)) else {
            return;
        };
        let t = self.temperature.unwrap_or(f64::NAN);
        let taken = match &mut self.follower {
            Follower::F64(f) => m.follow(f, z, t),
            Follower::F32(f) => m.follow_f32(f, z as f32, t as f32),
        };
        if let Some(c) = taken {
            self.reference_r_i = Some(c.center.r_i);
            self.cell.set_prior(&c);
        }
    }

    /// Feeds the sample at time `t` (s): current (A, positive when
    /// charging) and terminal voltage (V). Never fails: a bad sample is
    /// rejected, counted and substituted by the core.
    pub fn push(&mut self, t: f64, current: f64, voltage: f64) -> TrackRow {
        self.follow_map();
        let mut r = self.cell.push(t, current, voltage);
        r.soc_detail = r.soc_detail.in_mode(self.soc_mode);
        r.soc = r.soc_detail.published();
        r.soh_r = r
            .published
            .r_i
            .value
            .zip(self.reference_r_i)
            .map(|(r, reference)| r / reference);
        self.tally.add(&r.published, &r.power);
        r
    }

    /// What the estimator has seen, computed and published so far.
    pub fn summary(&self) -> TrackSummary {
        TrackSummary {
            published: self.tally,
            ..self.cell.summary()
        }
    }

    /// The snapshot of what the cell has learned
    /// ([`estimator_core::battery::snapshot`]), saved at record time
    /// `saved_at_s` (s; judged for its age at restore).
    pub fn save_state(&self, saved_at_s: f64) -> Vec<u8> {
        self.cell.save(state::record_clock(saved_at_s))
    }

    /// Restores the cell from a snapshot before its first sample, the
    /// record's time now being `now_s`. A rejected snapshot leaves the
    /// cell clean.
    ///
    /// # Errors
    /// Why the snapshot was rejected.
    pub fn restore_state(
        &mut self,
        bytes: &[u8],
        now_s: f64,
    ) -> std::result::Result<(), SnapshotError> {
        self.cell.restore(bytes, state::record_clock(now_s))
    }

    /// How the cell started: clean, from a snapshot, or from one whose SOC
    /// the first rested voltage contradicted.
    pub fn restoration(&self) -> Restoration {
        self.cell.restoration()
    }

    /// Sets the state of charge now (with a curve; a non-finite value is
    /// ignored), as [`CellEstimator::set_state_of_charge`].
    pub fn set_state_of_charge(&mut self, soc: f64) {
        self.cell.set_state_of_charge(soc);
    }
}

/// The windows an estimator is built for (the core's const generic).
pub const WINDOWS: [usize; 5] = [64, 128, 256, 512, 1024];

/// Checks `--window` and then `--memory` against it: a window that is not
/// one of [`WINDOWS`], or a memory outside `1..=window − 8`, with the flag
/// the user gave named first.
///
/// # Errors
/// [`Options`](crate::error::ErrorKind::Options), naming the flag.
pub fn check_window(window: usize, memory: usize) -> Result<()> {
    if !WINDOWS.contains(&window) {
        bail!(
            Options,
            "--window {window}: must be one of 64, 128, 256, 512, 1024"
        );
    }
    if memory == 0 || memory + 8 > window {
        bail!(Options, "--memory {memory}: must be in 1..={}", window - 8);
    }
    Ok(())
}

fn sized<T: Real + Send + Sync + 'static>(
    s: OnlineSettings<T, OCV_POINTS>,
    soc0: Option<f64>,
    window: usize,
    power: Option<power::ResolvedPower>,
) -> Result<Box<dyn Step>> {
    match window {
        64 => Sized::<T, 64>::boxed(s, soc0, power),
        128 => Sized::<T, 128>::boxed(s, soc0, power),
        256 => Sized::<T, 256>::boxed(s, soc0, power),
        512 => Sized::<T, 512>::boxed(s, soc0, power),
        1024 => Sized::<T, 1024>::boxed(s, soc0, power),
        _ => bail!(
            Options,
            "--window {window}: must be one of 64, 128, 256, 512, 1024"
        ),
    }
}
