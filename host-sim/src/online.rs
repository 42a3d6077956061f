//! `online battery`: the sliding-window estimator, sample by sample, as the
//! firmware runs it (f64 here).

use crate::cli::{BatteryMethod, ModelArg, OnlineBatteryArgs, Precision, StartArg};
use crate::io::OCV_POINTS;
use crate::ocv::CellOcv;
use crate::{io, progress};
use anyhow::{anyhow, bail, Result};
use estimator_core::battery::ocv::OcvModel;
use estimator_core::battery::online::{CellEstimator, Method, OnlineSettings};
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

fn run<T: Real, const N: usize>(
    s: &OnlineSettings<T, OCV_POINTS>,
    soc0: Option<f64>,
    rec: &io::BatteryRecord,
    mut sink: impl FnMut(TrackRow) -> Result<()>,
) -> Result<TrackSummary> {
    let mut est = Box::new(CellEstimator::<T, N, N>::new(s).map_err(|e| anyhow!("{e}"))?);
    if let Some(z) = soc0 {
        est.set_state_of_charge(T::lit(z));
    }
    let pb = progress::bar(rec.current.len() as u64, "tracking");
    for (k, ((&t, &i), &v)) in rec
        .time
        .iter()
        .zip(&rec.current)
        .zip(&rec.voltage)
        .enumerate()
    {
        let predicted = est.predict(s, T::lit(i)).map(|y| y.to_f64());
        let r = est.push(s, T::lit(i), T::lit(v));
        sink(TrackRow {
            t,
            estimate: est.estimate().map(|p| p.cast()),
            predicted,
            status: r.status.as_str(),
            soc: est.state_of_charge().map(|z| z.to_f64()),
            ocv_offset: est.ocv_offset().map(|d| d.to_f64()),
        })?;
        if k % 256 == 0 {
            pb.set_position(k as u64);
        }
    }
    pb.finish_and_clear();
    let c = est.counts();
    Ok(TrackSummary {
        samples: c.samples,
        rejected: c.rejected(),
        work: est.refinement_work(),
    })
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
    sink: impl FnMut(TrackRow) -> Result<()>,
) -> Result<TrackSummary> {
    let (window, memory) = (o.window, o.memory);
    if memory == 0 || memory + 8 > window {
        bail!(
            "--memory {memory}: must be in 1..={}",
            window.saturating_sub(8)
        );
    }
    let soc0 = o.cell.map(|c| c.soc0);
    match o.precision {
        Precision::F64 => sized(&o.settings::<f64>(rec.h)?, soc0, window, rec, sink),
        Precision::F32 => sized(&o.settings::<f32>(rec.h)?, soc0, window, rec, sink),
    }
}

fn sized<T: Real>(
    s: &OnlineSettings<T, OCV_POINTS>,
    soc0: Option<f64>,
    window: usize,
    rec: &io::BatteryRecord,
    sink: impl FnMut(TrackRow) -> Result<()>,
) -> Result<TrackSummary> {
    match window {
        64 => run::<T, 64>(s, soc0, rec, sink),
        128 => run::<T, 128>(s, soc0, rec, sink),
        256 => run::<T, 256>(s, soc0, rec, sink),
        512 => run::<T, 512>(s, soc0, rec, sink),
        1024 => run::<T, 1024>(s, soc0, rec, sink),
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
