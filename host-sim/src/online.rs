//! `online battery`: the sliding-window estimator, sample by sample, as the
//! firmware runs it (f64 here).

use crate::cli::{BatteryMethod, ModelArg, OnlineBatteryArgs, Precision, StartArg};
use crate::io::OCV_POINTS;
use crate::ocv::CellOcv;
use crate::{io, progress};
use anyhow::{anyhow, bail, Result};
use estimator_core::battery::ocv::OcvModel;
use estimator_core::battery::online::{CellEstimator, Method, OnlineSettings, Rejection};
use estimator_core::battery::output_error::RefinementWork;
use estimator_core::battery::{CellModel, CellParameters, Prior, Start};
use estimator_core::Real;

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
    /// State of charge after this sample (with an OCV curve).
    pub soc: Option<f64>,
    /// The OCV offset ΔU of the estimate (with an OCV curve).
    pub ocv_offset: Option<f64>,
    /// The one-step prediction of this sample's voltage (V) from the
    /// estimate before it (none before the first estimate).
    pub predicted: Option<f64>,
}

/// What a track run did.
#[derive(Clone, Copy, Debug, Default)]
pub struct TrackSummary {
    /// Samples offered.
    pub samples: u64,
    /// Samples rejected (and substituted).
    pub rejected: u32,
    /// What the output-error refinement computed.
    pub work: RefinementWork,
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
    pub start: StartArg,
    /// A prior from a characterization fit (MAP window fits).
    pub prior: Option<&'a Prior<f64>>,
    /// The cell's OCV curve, capacity and start SOC.
    pub cell: Option<&'a CellOcv>,
    /// The cell model (`auto`: the prior's, linear without one).
    pub model: ModelArg,
    /// Add the Grünwald–Letnikov taps beyond the memory (the short-memory
    /// correction, `BatterySettings::tail`).
    pub tail: bool,
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
            start: StartArg::FromData,
            prior: None,
            cell: None,
            model: ModelArg::Linear,
            tail: false,
        }
    }

    /// The model the window fits: `auto` is the prior's (Butler–Volmer when
    /// its centre has the term), linear without a prior.
    pub fn cell_model(&self) -> CellModel {
        match self.model {
            ModelArg::Linear => CellModel::Linear,
            ModelArg::ButlerVolmer => CellModel::ButlerVolmer,
            ModelArg::Auto => match self.prior {
                Some(p) if p.center.is_butler_volmer() => CellModel::ButlerVolmer,
                _ => CellModel::Linear,
            },
        }
    }

    /// The core's settings for sample period `h`.
    pub(crate) fn settings<T: Real>(&self, h: f64) -> Result<OnlineSettings<T, OCV_POINTS>> {
        let mut s = OnlineSettings::new(T::lit(h), self.memory, CellParameters::cell_18650());
        s.battery.start = match self.start {
            StartArg::FromData => Start::FromData,
            StartArg::AtRest => Start::AtRest,
        };
        s.battery.prior = self.prior.map(|p| Prior {
            center: p.center.cast(),
            log_sigma: T::lit(p.log_sigma),
            alpha_sigma: T::lit(p.alpha_sigma),
            noise_v: T::lit(p.noise_v),
        });
        s.battery.model = self.cell_model();
        s.battery.tail = self.tail;
        s.iterations_per_sample = self.iterations_per_sample;
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
                    .map_err(|e| anyhow!("--ocv: in this precision: {e}"))?;
                Some(
                    OcvModel::new(table, T::lit(c.model.capacity_ah))
                        .map_err(|e| anyhow!("--capacity-ah: {e}"))?,
                )
            }
        };
        Ok(s.with_curve(curve))
    }
}

/// Runs the online estimator over a record as `o` says, calling `sink`
/// after every sample.
pub fn track(
    rec: &io::BatteryRecord,
    o: &TrackOptions,
    mut sink: impl FnMut(TrackRow) -> Result<()>,
) -> Result<TrackSummary> {
    let mut cell = Tracker::new(o, rec.h, o.cell.map(|c| c.soc0))?;
    let pb = progress::bar(rec.current.len() as u64, "tracking");
    for (k, ((&t, &i), &v)) in rec
        .time
        .iter()
        .zip(&rec.current)
        .zip(&rec.voltage)
        .enumerate()
    {
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
}

/// [`Tracker`]'s estimator behind one type for every window and precision.
trait Step: Send + Sync {
    fn push(&mut self, t: f64, current: f64, voltage: f64) -> TrackRow;
    fn summary(&self) -> TrackSummary;
    fn set_state_of_charge(&mut self, soc: f64);
}

/// The core's single-cell estimator with its settings.
struct Sized<T: Real, const N: usize> {
    s: OnlineSettings<T, OCV_POINTS>,
    est: Box<CellEstimator<T, N, N>>,
}

impl<T: Real + Send + Sync + 'static, const N: usize> Sized<T, N> {
    fn boxed(s: OnlineSettings<T, OCV_POINTS>, soc0: Option<f64>) -> Result<Box<dyn Step>> {
        let mut est = Box::new(CellEstimator::<T, N, N>::new(&s).map_err(|e| anyhow!("{e}"))?);
        if let Some(z) = soc0 {
            est.set_state_of_charge(T::lit(z));
        }
        Ok(Box::new(Self { s, est }))
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
            ocv_offset: est.ocv_offset().map(|d| d.to_f64()),
        }
    }

    fn set_state_of_charge(&mut self, soc: f64) {
        self.est.set_state_of_charge(T::lit(soc));
    }

    fn summary(&self) -> TrackSummary {
        let c = self.est.counts();
        TrackSummary {
            samples: c.samples,
            rejected: c.rejected(),
            work: self.est.refinement_work(),
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
        let (window, memory) = (o.window, o.memory);
        if memory == 0 || memory + 8 > window {
            bail!(
                "--memory {memory}: must be in 1..={}",
                window.saturating_sub(8)
            );
        }
        let cell = match o.precision {
            Precision::F64 => sized(o.settings::<f64>(h)?, soc0, window)?,
            Precision::F32 => sized(o.settings::<f32>(h)?, soc0, window)?,
        };
        Ok(Self { cell })
    }

    /// Feeds the sample at time `t` (s): current (A, positive when
    /// charging) and terminal voltage (V). Never fails: a bad sample is
    /// rejected, counted and substituted by the core.
    pub fn push(&mut self, t: f64, current: f64, voltage: f64) -> TrackRow {
        self.cell.push(t, current, voltage)
    }

    /// What the estimator has seen and computed so far.
    pub fn summary(&self) -> TrackSummary {
        self.cell.summary()
    }

    /// Sets the state of charge now (with a curve; a non-finite value is
    /// ignored), as [`CellEstimator::set_state_of_charge`].
    pub fn set_state_of_charge(&mut self, soc: f64) {
        self.cell.set_state_of_charge(soc);
    }
}

fn sized<T: Real + Send + Sync + 'static>(
    s: OnlineSettings<T, OCV_POINTS>,
    soc0: Option<f64>,
    window: usize,
) -> Result<Box<dyn Step>> {
    match window {
        64 => Sized::<T, 64>::boxed(s, soc0),
        128 => Sized::<T, 128>::boxed(s, soc0),
        256 => Sized::<T, 256>::boxed(s, soc0),
        512 => Sized::<T, 512>::boxed(s, soc0),
        1024 => Sized::<T, 1024>::boxed(s, soc0),
        _ => bail!("--window {window}: must be one of 64, 128, 256, 512, 1024"),
    }
}

// Not inlined into `cli::run`: the estimators are built on the stack before
// boxing, and an inlined frame of every command would be probed (page
// faults over megabytes) even for the command that does not run.
#[inline(never)]
pub(crate) fn battery(a: &OnlineBatteryArgs) -> Result<()> {
    let t0 = std::time::Instant::now();
    let rec = io::read_battery(&a.input, None)?;
    let cell = crate::ocv::resolve(&a.cell, &a.input, &rec)?;
    let prior = match &a.prior {
        Some(p) => Some(read_prior(p, a)?),
        None => None,
    };
    let memory = a.memory.unwrap_or(a.window / 4);
    let f = |x: f64| format!("{x:.9e}");
    let g = |x: Option<f64>| x.map(|x| format!("{x:.9e}")).unwrap_or_default();
    let o = TrackOptions {
        window: a.window,
        memory,
        iterations_per_sample: a.iterations_per_sample,
        method: a.method,
        precision: a.precision,
        start: a.start,
        prior: prior.as_ref(),
        cell: cell.as_ref(),
        model: a.model,
        tail: a.tail,
    };
    let summary = {
        let mut res = Ok(TrackSummary::default());
        io::write_atomic(&a.out, |w| {
            writeln!(
                w,
                "time_s,r_i,r_ct,q,alpha,u_oc,status,soc,ocv_offset_v,bv_a_v,bv_i0_a,predicted_v"
            )?;
            res = track(&rec, &o, |r| {
                let bv = r.estimate.filter(|p| p.is_butler_volmer());
                match r.estimate {
                    Some(p) => writeln!(
                        w,
                        "{},{},{},{},{},{},{},{},{},{},{},{}",
                        r.t,
                        f(p.r_i),
                        f(p.r_ct),
                        f(p.q),
                        f(p.alpha),
                        f(p.u_oc),
                        r.status,
                        g(r.soc),
                        g(r.ocv_offset),
                        g(bv.map(|p| p.bv_a)),
                        g(bv.map(|p| p.bv_i0)),
                        g(r.predicted)
                    )?,
                    None => writeln!(
                        w,
                        "{},,,,,,{},{},,,,{}",
                        r.t,
                        r.status,
                        g(r.soc),
                        g(r.predicted)
                    )?,
                }
                Ok(())
            });
            res.as_ref().map(|_| ()).map_err(|e| anyhow!("{e:#}"))
        })?;
        res?
    };
    let secs = t0.elapsed().as_secs_f64();
    let TrackSummary {
        samples,
        rejected,
        work,
    } = summary;
    eprintln!(
        "wrote {} ({samples} samples, {rejected} rejected, {:.0} samples/s, model {})",
        a.out.display(),
        samples as f64 / secs.max(1e-9),
        o.cell_model().as_str()
    );
    if work.iterations > 0 {
        // The refinement's cost drivers: each simulation and each
        // sensitivity pass is O(L·M).
        eprintln!(
            "refinement: {} iterations, {} window simulations ({} trial steps), {} sensitivity passes",
            work.iterations, work.simulations, work.trials, work.linearizations
        );
    }
    Ok(())
}

/// Reads `--prior FIT.json` (the JSON of `identify battery`) with the
/// spreads of the other `--prior-*` flags.
fn read_prior(path: &std::path::Path, a: &OnlineBatteryArgs) -> Result<Prior<f64>> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| anyhow!("{}: cannot read ({e})", path.display()))?;
    let j: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| anyhow!("{}: not JSON ({e})", path.display()))?;
    let get = |k: &str| {
        j[k].as_f64().ok_or_else(|| {
            anyhow!(
                "{}: no number `{k}` (expected the JSON of identify battery)",
                path.display()
            )
        })
    };
    // A linear fit has null (or, from before the Butler–Volmer model, no)
    // bv_a_v and bv_i0_a.
    let (bv_a, bv_i0) = match (j["bv_a_v"].as_f64(), j["bv_i0_a"].as_f64()) {
        (Some(x), Some(i0)) => (x, i0),
        _ => (0.0, 1.0),
    };
    let center = CellParameters {
        r_i: get("r_i")?,
        r_ct: get("r_ct")?,
        q: get("q")?,
        alpha: get("alpha")?,
        u_oc: get("u_oc")?,
        bv_a,
        bv_i0,
    };
    if !(a.prior_factor.is_finite() && a.prior_factor > 1.0) {
        bail!("--prior-factor {}: must be above 1", a.prior_factor);
    }
    let p = Prior {
        center,
        log_sigma: a.prior_factor.ln(),
        alpha_sigma: a.prior_alpha_sigma,
        noise_v: a.prior_noise_mv * 1e-3,
    };
    if !p.is_valid() {
        bail!(
            "{}: the prior is not physical, or a --prior-* spread is not positive",
            path.display()
        );
    }
    Ok(p)
}
