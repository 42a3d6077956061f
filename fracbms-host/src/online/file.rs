//! `online battery` over a file: the CLI's flags as options
//! ([`OnlineBatteryOptions`]) and the run
//! ([`battery_file`]): the record read, the prior and the OCV table
//! resolved, a snapshot restored (`--state-in`) and saved
//! (`--state-out`), the rows written (their columns are
//! [`super::schema::TRACK_COLUMNS`]'s). The estimator and its loop are the
//! parent module's ([`super::Tracker`], [`super::track_with`]).

use super::*;
use crate::io;

/// How `online battery` runs: every flag but the files. The default is the
/// CLI's.
#[derive(Clone, Debug, PartialEq)]
pub struct OnlineBatteryOptions {
    /// Window length L (one of 64, 128, 256, 512, 1024).
    pub window: usize,
    /// Memory M (default L/4).
    pub memory: Option<usize>,
    /// Iterations per sample.
    pub iterations_per_sample: u16,
    /// The paper's 2S-OP-GI or the output-error refinement.
    pub method: BatteryMethod,
    /// f64, or f32 as the firmware runs it.
    pub precision: Precision,
    /// Where the model starts in the window.
    pub start: Start,
    /// A prior: the JSON of `identify battery` (see [`read_prior`]).
    pub prior: Option<PathBuf>,
    /// The prior's spread on R_i, R_ct and Q: a factor at one sigma.
    pub prior_factor: f64,
    /// The prior's spread on α at one sigma.
    pub prior_alpha_sigma: f64,
    /// The residual level (mV) at which the window's data are weighed
    /// against the prior.
    pub prior_noise_mv: f64,
    /// The cell model (`auto`: the prior's, linear without one).
    pub model: ModelRequest,
    /// The short-memory correction.
    pub tail: bool,
    /// The cell's OCV curve, capacity and start SOC.
    pub ocv: crate::ocv::OcvOptions,
    /// How the record is read: columns, current sign, period.
    pub record: crate::cycler::RecordOptions,
    /// The state-of-power columns (`--horizons`, `--voltage-min`,
    /// `--voltage-max`, `--current-limit`, `--pulse-current-a`).
    pub power: power::PowerOptions,
    /// How the SOC is published (`--soc`, `--soc-rest-s`,
    /// `--soc-bias-sigma-a`, `--soc-rest-load-sigma-a`, `--soc-voltage-sigma-v`).
    pub soc: soc::SocOptions,
    /// The slow part's memory (s; `--slow-memory-s`,
    /// [`TrackOptions::slow_memory_s`]).
    pub slow_memory_s: Option<f64>,
    /// The slow part's memory in state of charge (`--slow-memory-soc`).
    pub slow_memory_soc: Option<f64>,
    /// A snapshot to start from (`--state-in`, [`state`]).
    pub state_in: Option<PathBuf>,
    /// Where to save the snapshot after the last sample (`--state-out`).
    pub state_out: Option<PathBuf>,
    /// The record's time 0 as seconds since 1970-01-01 UTC (`--start-time`;
    /// [`super::life::parse_start_time`]): the snapshot's clock is then
    /// this plus the record's time, so that a snapshot carried from one
    /// log to the next is aged by the time between them (a log whose own
    /// time restarts at 0 would otherwise read as older than the
    /// snapshot, and it would be rejected). `None`: the record's own time.
    pub start_time_s: Option<f64>,
}

impl Default for OnlineBatteryOptions {
    fn default() -> Self {
        Self {
            window: 256,
            memory: None,
            iterations_per_sample: 1,
            method: BatteryMethod::Refined,
            precision: Precision::F64,
            start: Start::FromData,
            prior: None,
            prior_factor: 2.0,
            prior_alpha_sigma: 0.1,
            prior_noise_mv: 100.0,
            model: ModelRequest::Auto,
            tail: false,
            ocv: crate::ocv::OcvOptions::default(),
            record: crate::cycler::RecordOptions::default(),
            power: power::PowerOptions::default(),
            soc: soc::SocOptions::default(),
            slow_memory_s: None,
            slow_memory_soc: None,
            state_in: None,
            state_out: None,
            start_time_s: None,
        }
    }
}

/// What [`battery_file`] did.
#[derive(Clone, Debug)]
pub struct OnlineReport {
    /// Samples, rejections and the refinement's work.
    pub summary: TrackSummary,
    /// Wall time of the run (s).
    pub seconds: f64,
    /// The cell model the windows fitted.
    pub model: CellModel,
    /// What was read from the file.
    pub record: crate::cycler::RecordReport,
    /// With a map prior: one line on the levels it follows, and the levels
    /// left out with why.
    pub prior_map: Option<(String, Vec<String>)>,
    /// How the `--state-in` snapshot was taken.
    pub state_in: state::StateIn,
    /// What the track published, for a life's row ([`super::life`]).
    pub life: super::log_tally::FileTally,
}

/// `online battery`: reads the record `input`, runs the online estimator
/// over it as `o` says and writes the track to `out` (columns
/// [`schema::TRACK_COLUMNS`], and [`schema::TRACK_RESTORATION`] with
/// `--state-in`; atomically).
///
/// # Errors
/// A file that cannot be read or written, data or options that are
/// refused.
pub fn battery_file(input: &Path, out: &Path, o: &OnlineBatteryOptions) -> Result<OnlineReport> {
    let state_in = match &o.state_in {
        Some(p) => Some(state::read_state(p)?),
        None => None,
    };
    let (report, saved) = battery_run(input, out, o, state_in.as_deref())?;
    if let Some(p) = &o.state_out {
        state::write_state(p, &saved)?;
    }
    Ok(report)
}

/// [`battery_file`] with the snapshot given and returned as bytes (`o`'s
/// `state_in` and `state_out` are not read): what a life carries from
/// one log to the next ([`super::life`]), the same bytes as the files.
///
/// # Errors
/// As [`battery_file`].
pub(crate) fn battery_run(
    input: &Path,
    out: &Path,
    o: &OnlineBatteryOptions,
    snapshot: Option<&[u8]>,
) -> Result<(OnlineReport, Vec<u8>)> {
    let t0 = std::time::Instant::now();
    // A period chosen from the data past the log's own step is raised to
    // divide the horizons where the state of power is published
    // (`cycler::resample::chosen_period`): `pulse_v_10s` is then 10 s of
    // samples, not the nearest whole number of them.
    let divide_s = if o.power.published(o.ocv.ocv.is_some()) {
        o.power.horizons().to_vec()
    } else {
        Vec::new()
    };
    let record = crate::cycler::RecordOptions {
        capacity_ah: o.record.capacity_ah.or(o.ocv.capacity_ah),
        divide_s,
        ..o.record.clone()
    };
    let read = crate::cycler::read_record(input, &record)?;
    let rec = read.record;
    let cell = match (snapshot, o.ocv.soc0) {
        // From a snapshot the start SOC is the snapshot's: the record need
        // not start at rest (the core reads the SOC from the first sample
        // if the snapshot is rejected).
        (Some(_), None) => crate::ocv::model(&o.ocv)?.map(|model| crate::ocv::CellOcv {
            soc0: model
                .soc_at_rest(&rec.current, &rec.voltage)
                .unwrap_or(f64::NAN),
            model,
        }),
        _ => crate::ocv::resolve(&o.ocv, input, &rec)?,
    };
    let source = match &o.prior {
        Some(p) => Some(read_prior_source(
            p,
            o.prior_factor,
            o.prior_alpha_sigma,
            o.prior_noise_mv,
        )?),
        None => None,
    };
    let (prior, prior_map) = match &source {
        Some(PriorSource::Fit(p)) => (Some(p), None),
        Some(PriorSource::Map(m)) => {
            if cell.is_none() {
                bail!(
                    Options,
                    "--prior {}: a parameter map needs --ocv and --capacity-ah (its prior follows the counted SOC)",
                    o.prior.as_deref().unwrap_or(Path::new("")).display()
                );
            }
            (None, Some(m))
        }
        None => (None, None),
    };
    let memory = o.memory.unwrap_or(o.window / 4);
    let t = TrackOptions {
        window: o.window,
        memory,
        iterations_per_sample: o.iterations_per_sample,
        method: o.method,
        precision: o.precision,
        start: o.start,
        prior,
        prior_map,
        cell: cell.as_ref(),
        model: o.model,
        tail: o.tail,
        power: o.power,
        soc: o.soc,
        slow_memory_s: o.slow_memory_s,
        slow_memory_soc: o.slow_memory_soc,
        voltage_timing: read.report.resampling.voltage_timing(),
    };
    let mut tracker = Tracker::new(&t, rec.h, t.cell.map(|c| c.soc0))?;
    let clock = o.start_time_s.unwrap_or(0.0);
    let first_t = rec.time.first().copied().unwrap_or(f64::NAN);
    let state_in = match snapshot {
        Some(bytes) => state::StateIn::of(tracker.restore_state(bytes, first_t + clock)),
        None => state::StateIn::NotGiven,
    };
    let fields = schema::track_fields(o.power.horizons(), snapshot.is_some());
    let limits = {
        let table = cell.as_ref().map(|c| c.model.table.ocv_points());
        let lo = o
            .power
            .voltage_min
            .or(table.and_then(|v| v.first().copied()));
        let hi = o
            .power
            .voltage_max
            .or(table.and_then(|v| v.last().copied()));
        lo.zip(hi)
    };
    let mut life = super::log_tally::FileTally::of_record(
        &rec,
        &read.rows,
        limits,
        &read.report.resampling.gaps,
    );
    let summary = {
        let mut res = Ok(TrackSummary::default());
        io::write_atomic(out, |w| {
            writeln!(w, "{}", schema::header(&fields))?;
            let gaps = &read.report.resampling.gaps;
            let temperature = read.temperature.as_deref();
            // A sample inside a step's unlogged start has no voltage: the
            // estimator takes it as a missing reading (its current counted,
            // its voltage substituted, never in the window's cost), and the
            // track says `unobserved`.
            let unobserved = read.report.unobserved(rec.h, &rec.time);
            let fed = io::BatteryRecord {
                voltage: (rec.voltage.iter().zip(&unobserved))
                    .map(|(&v, &u)| if u { f64::NAN } else { v })
                    .collect(),
                ..rec.clone()
            };
            let mut k = 0usize;
            res = track_with(&mut tracker, &fed, &t, temperature, gaps, |mut r| {
                if unobserved.get(k).copied().unwrap_or(false) {
                    r.rejected = Some("unobserved");
                }
                k += 1;
                life.push(&r);
                schema::write_row(w, &fields, &r)?;
                Ok(())
            });
            res.clone().map(|_| ())
        })?;
        res?
    };
    let last_t = rec.time.last().copied().unwrap_or(f64::NAN);
    let saved = tracker.save_state(last_t + clock);
    let report = OnlineReport {
        summary,
        seconds: t0.elapsed().as_secs_f64(),
        model: t.cell_model(),
        record: read.report,
        prior_map: prior_map.map(|m| (m.describe(), m.left_out.clone())),
        state_in,
        life,
    };
    Ok((report, saved))
}
