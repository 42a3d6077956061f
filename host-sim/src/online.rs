//! `online battery`: the sliding-window estimator, sample by sample, as the
//! firmware runs it (f64 here).

use crate::cli::{BatteryMethod, OnlineBatteryArgs};
use crate::{io, progress};
use anyhow::{anyhow, bail, Result};
use estimator_core::battery::online::{CellEstimator, Method, OnlineSettings};
use estimator_core::battery::CellParameters;

/// One row of the track.
#[derive(Clone, Copy, Debug)]
pub struct TrackRow {
    /// Time (s).
    pub t: f64,
    /// The estimate after this sample.
    pub estimate: Option<CellParameters<f64>>,
    /// Status name.
    pub status: &'static str,
}

fn run<const N: usize>(
    s: &OnlineSettings<f64>,
    rec: &io::BatteryRecord,
    mut sink: impl FnMut(TrackRow) -> Result<()>,
) -> Result<(u64, u32)> {
    let mut est = Box::new(CellEstimator::<f64, N, N>::new(s).map_err(|e| anyhow!("{e}"))?);
    let pb = progress::bar(rec.current.len() as u64, "tracking");
    for (k, ((&t, &i), &v)) in rec
        .time
        .iter()
        .zip(&rec.current)
        .zip(&rec.voltage)
        .enumerate()
    {
        let r = est.push(s, i, v);
        sink(TrackRow {
            t,
            estimate: est.estimate(),
            status: r.status.as_str(),
        })?;
        if k % 256 == 0 {
            pb.set_position(k as u64);
        }
    }
    pb.finish_and_clear();
    let c = est.counts();
    Ok((c.samples, c.rejected()))
}

/// Runs the online estimator over a record with window `window`, calling
/// `sink` after every sample. Returns (samples, rejected).
pub fn track(
    rec: &io::BatteryRecord,
    window: usize,
    memory: usize,
    k: u16,
    method: BatteryMethod,
    sink: impl FnMut(TrackRow) -> Result<()>,
) -> Result<(u64, u32)> {
    let mut s = OnlineSettings::new(rec.h, memory, CellParameters::cell_18650());
    s.iterations_per_sample = k;
    s.method = match method {
        BatteryMethod::Paper => Method::Paper,
        BatteryMethod::Refined => Method::Refined,
    };
    if memory == 0 || memory + 8 > window {
        bail!(
            "--memory {memory}: must be in 1..={}",
            window.saturating_sub(8)
        );
    }
    match window {
        64 => run::<64>(&s, rec, sink),
        128 => run::<128>(&s, rec, sink),
        256 => run::<256>(&s, rec, sink),
        512 => run::<512>(&s, rec, sink),
        1024 => run::<1024>(&s, rec, sink),
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
    let memory = a.memory.unwrap_or(a.window / 4);
    let f = |x: f64| format!("{x:.9e}");
    let (samples, rejected) = {
        let mut res = Ok((0, 0));
        io::write_atomic(&a.out, |w| {
            writeln!(w, "time_s,r_i,r_ct,q,alpha,u_oc,status")?;
            res = track(
                &rec,
                a.window,
                memory,
                a.iterations_per_sample,
                a.method,
                |r| {
                    match r.estimate {
                        Some(p) => writeln!(
                            w,
                            "{},{},{},{},{},{},{}",
                            r.t,
                            f(p.r_i),
                            f(p.r_ct),
                            f(p.q),
                            f(p.alpha),
                            f(p.u_oc),
                            r.status
                        )?,
                        None => writeln!(w, "{},,,,,,{}", r.t, r.status)?,
                    }
                    Ok(())
                },
            );
            res.as_ref().map(|_| ()).map_err(|e| anyhow!("{e:#}"))
        })?;
        res?
    };
    let secs = t0.elapsed().as_secs_f64();
    eprintln!(
        "wrote {} ({samples} samples, {rejected} rejected, {:.0} samples/s)",
        a.out.display(),
        samples as f64 / secs.max(1e-9)
    );
    Ok(())
}
