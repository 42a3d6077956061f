//! A record's SOC levels: the parts between its long rests, or bins of
//! its counted SOC ([`levels`]), the pulses of one SOC joined
//! ([`one_level_per_soc`]), and the joint map's knots from them
//! ([`level_knots`]).
//!
//! It owns how a record is split; it must not fit (that is
//! [`super::build_map`]'s).

use crate::io::BatteryRecord;
use crate::map::MapOptions;

/// A part of a record: samples `start..end`, its SOC level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Level {
    /// First sample.
    pub start: usize,
    /// One past the last.
    pub end: usize,
    /// The level's SOC.
    pub soc: f64,
}

/// Splits `rec` into its SOC levels: between its rests of at least
/// `o.min_rest_s` (each part from `o.lead_s` before its pulses to the end
/// of the rest after them), or into `o.soc_bins` equal bins of the counted
/// SOC. A part without excitation (fewer than [`MIN_EXCITED`] samples
/// whose current is beyond 1 % of the record's largest: a rest alone) is
/// not a level.
pub fn levels(rec: &BatteryRecord, soc: &[f64], o: &MapOptions, gap: &[bool]) -> Vec<Level> {
    let big = rec
        .current
        .iter()
        .filter(|x| x.is_finite())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    let excited = |l: &Level| {
        rec.current[l.start..l.end]
            .iter()
            .filter(|i| i.is_finite() && i.abs() > 0.01 * big)
            .count()
            >= MIN_EXCITED
    };
    split(rec, soc, o, gap)
        .into_iter()
        .filter(excited)
        .collect()
}

/// The levels split by rests, with each run of levels that follow one
/// another without a gap and whose SOCs lie within [`KNOT_SPACING`] of the
/// first of them taken as one level (from the first one's start to the
/// last one's end, at the first one's SOC): the pulses of one level of an
/// HPPC test, parted by rests shorter than the test's rests between levels
/// but longer than `--min-rest` (the Panasonic test's five pulses, 10
/// minutes apart, with the default 600 s).
pub fn one_level_per_soc(parts: Vec<Level>) -> Vec<Level> {
    let mut out: Vec<Level> = Vec::with_capacity(parts.len());
    for p in parts {
        match out.last_mut() {
            Some(l) if p.start <= l.end && (p.soc - l.soc).abs() <= KNOT_SPACING => {
                l.end = l.end.max(p.end);
            }
            _ => out.push(p),
        }
    }
    out
}

/// The fewest samples under current that make a part of a record a level.
pub const MIN_EXCITED: usize = 2;

/// [`levels`] before the parts without excitation are left out.
pub(super) fn split(rec: &BatteryRecord, soc: &[f64], o: &MapOptions, gap: &[bool]) -> Vec<Level> {
    let n = rec.current.len();
    if gap.iter().any(|&g| g) {
        // Each stretch between gaps apart: no level spans a gap.
        let mut out = vec![];
        let mut k = 0;
        while k < n {
            if gap[k] {
                k += 1;
                continue;
            }
            let a = k;
            while k < n && !gap[k] {
                k += 1;
            }
            let part = BatteryRecord {
                time: rec.time[a..k].to_vec(),
                current: rec.current[a..k].to_vec(),
                voltage: rec.voltage[a..k].to_vec(),
                h: rec.h,
            };
            let mut inner = levels(&part, &soc[a..k], o, &vec![false; k - a]);
            if inner.is_empty() {
                // A stretch without a long rest: one level.
                inner.push(Level {
                    start: 0,
                    end: k - a,
                    soc: soc[a],
                });
            }
            let moving = |l: &Level| part.current[l.start..l.end].iter().any(|i| *i != 0.0);
            out.extend(inner.into_iter().filter(moving).map(|l| Level {
                start: l.start + a,
                end: l.end + a,
                soc: l.soc,
            }));
        }
        return out;
    }
    if let Some(bins) = o.soc_bins {
        let (lo, hi) = soc
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &z| {
                (a.min(z), b.max(z))
            });
        let width = (hi - lo) / bins.max(1) as f64;
        if width.is_nan() || width <= 0.0 {
            return vec![];
        }
        let bin = |z: f64| (((z - lo) / width) as usize).min(bins - 1);
        let mut out: Vec<Level> = vec![];
        let mut start = 0;
        for k in 1..=n {
            if k == n || bin(soc[k]) != bin(soc[start]) {
                let b = bin(soc[start]);
                out.push(Level {
                    start,
                    end: k,
                    soc: lo + (b as f64 + 0.5) * width,
                });
                start = k;
            }
        }
        return out;
    }
    let big = rec
        .current
        .iter()
        .filter(|x| x.is_finite())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    let at_rest = |i: f64| i.abs() <= 0.01 * big;
    // Long rests: (first, one past the last).
    let mut rests = vec![];
    let mut k = 0;
    while k < n {
        if !at_rest(rec.current[k]) {
            k += 1;
            continue;
        }
        let s = k;
        while k < n && at_rest(rec.current[k]) {
            k += 1;
        }
        if (k - s) as f64 * rec.h >= o.min_rest_s {
            rests.push((s, k));
        }
    }
    let lead = (o.lead_s / rec.h).round() as usize;
    let mut out = vec![];
    // Pulses before the first rest, if any.
    if let Some(&(s, _)) = rests.first() {
        if s > 0 {
            out.push(Level {
                start: 0,
                end: rests[0].1,
                soc: soc[0],
            });
        }
    }
    for (j, &(s, e)) in rests.iter().enumerate() {
        let end = rests.get(j + 1).map_or(n, |r| r.1);
        if end <= e {
            continue;
        }
        let start = e.saturating_sub(lead).max(s);
        out.push(Level {
            start,
            end,
            soc: soc[e.min(n - 1)],
        });
    }
    out
}

/// Levels whose SOCs lie within this of the first of them make one knot
/// of the joint map, at their mean SOC: the pulses of one level of an HPPC
/// test taken apart by shorter rests (the Panasonic test's five pulses
/// span 0.021 of SOC with `--min-rest 600`, its levels are 0.039–0.11
/// apart).
pub const KNOT_SPACING: f64 = 0.03;

/// The levels in runs of one SOC (indices into `parts`): by SOC, those
/// within [`KNOT_SPACING`] of the first of a run taken together (a level
/// whose SOC is not finite alone). The joint map's knots sit at the runs'
/// mean SOCs ([`level_knots`]) and each run is left out together when the
/// penalty is chosen.
pub fn level_runs(parts: &[Level]) -> Vec<Vec<usize>> {
    let mut order: Vec<usize> = (0..parts.len()).collect();
    order.sort_by(|&a, &b| parts[a].soc.total_cmp(&parts[b].soc));
    let mut runs: Vec<Vec<usize>> = Vec::new();
    for k in order {
        let z = parts[k].soc;
        match runs.last_mut() {
            Some(run) if z.is_finite() && z - parts[run[0]].soc <= KNOT_SPACING => run.push(k),
            _ => runs.push(vec![k]),
        }
    }
    runs
}

/// The joint map's knots from the levels: the mean SOC of each run of
/// [`level_runs`] (runs without a finite SOC left out), in order.
pub fn level_knots(parts: &[Level]) -> Vec<f64> {
    run_means(parts, &level_runs(parts))
}

/// The mean SOC of each of `runs` (indices into `parts`), runs without a
/// finite one left out.
pub fn run_means(parts: &[Level], runs: &[Vec<usize>]) -> Vec<f64> {
    runs.iter()
        .map(|run| run.iter().map(|&k| parts[k].soc).sum::<f64>() / run.len() as f64)
        .filter(|z| z.is_finite())
        .collect()
}
