//! OCV from the test itself: a `soc,ocv_v` table from the rests of a pulse
//! test (`rests`) or from a low-rate charge and discharge (`low-rate`),
//! with the capacity measured from the test when it is not given.
//!
//! It owns the rest and branch detection, the state of charge counted for
//! them and the monotone table. It must not touch the record's reading
//! ([`crate::cycler`]) nor the table's use ([`crate::ocv`]).
//!
//! Conventions: current positive charging (A), SOC in [0, 1], counted as
//! `soc_k = soc_0 + h·Σ_{j<k} I_j / (3600·C)`. When no start SOC is
//! given, SOC 1 is the highest counted charge of the test (a pulse or OCV
//! test starts from a full charge); when no capacity is given, it is the
//! charge between the highest and the lowest counted charge (the test runs
//! between its cut-offs).

use crate::error::Result;
use crate::io::{BatteryRecord, OCV_POINTS};
use crate::{bail, err};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Where the OCV is read from (`--from`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum OcvSource {
    /// The relaxed voltage at the end of each rest of at least
    /// [`OcvExtractionOptions::min_rest_s`].
    #[default]
    Rests,
    /// The mean of a ≤ C/10 charge and discharge over the SOC they share, or
    /// one branch with its IR drop removed.
    LowRate,
}

impl OcvSource {
    /// `rests` or `low-rate`.
    pub fn as_str(self) -> &'static str {
        match self {
            OcvSource::Rests => "rests",
            OcvSource::LowRate => "low-rate",
        }
    }
}

/// How the OCV is extracted.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct OcvExtractionOptions {
    /// Rests or a low-rate test.
    pub from: OcvSource,
    /// Capacity (A·h); default: measured from the test.
    pub capacity_ah: Option<f64>,
    /// SOC at the start of the record; default: SOC 1 at the highest
    /// counted charge.
    pub soc0: Option<f64>,
    /// The shortest rest whose end is an OCV point (s).
    pub min_rest_s: f64,
    /// |I| at or below this is rest (A); default: 1 % of the largest |I|.
    pub rest_current_a: Option<f64>,
}

impl Default for OcvExtractionOptions {
    fn default() -> Self {
        OcvExtractionOptions {
            from: OcvSource::Rests,
            capacity_ah: None,
            soc0: None,
            min_rest_s: 600.0,
            rest_current_a: None,
        }
    }
}

/// One rest of the test: where it ends, its SOC and relaxed voltage.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RestPoint {
    /// Time at the rest's end (s).
    pub end_s: f64,
    /// Its length (s).
    pub length_s: f64,
    /// Counted SOC during the rest.
    pub soc: f64,
    /// Voltage at the rest's last sample (V).
    pub voltage_v: f64,
}

/// A low-rate branch: a long run of one small current.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Branch {
    /// `charge` or `discharge`.
    pub kind: &'static str,
    /// Its mean current (A, + charging).
    pub current_a: f64,
    /// Its C-rate (|I| / capacity).
    pub c_rate: f64,
    /// The SOC it starts and ends at.
    pub soc: (f64, f64),
    /// The IR drop removed when it stands alone (V), else 0.
    pub ir_drop_v: f64,
}

/// The extracted table and how it was made.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OcvExtraction {
    /// `rests` or `low-rate`.
    pub from: &'static str,
    /// The table: SOC and OCV, both increasing.
    pub soc: Vec<f64>,
    /// OCV (V) at each SOC.
    pub ocv_v: Vec<f64>,
    /// Capacity used (A·h).
    pub capacity_ah: f64,
    /// `given` or `measured` (the charge between the extremes of the
    /// coulomb count).
    pub capacity_source: &'static str,
    /// SOC at the record's start.
    pub soc0: f64,
    /// The rests read (for `rests`).
    pub rests: Vec<RestPoint>,
    /// The branches read (for `low-rate`).
    pub branches: Vec<Branch>,
    /// Points pooled to keep the OCV increasing (a rest whose voltage is
    /// below that of a lower SOC: hysteresis, or not yet relaxed).
    pub points_pooled: usize,
    /// Points whose counted SOC fell outside [0, 1], put at the nearer
    /// end.
    pub points_clamped: usize,
    /// How the record was read (set by the caller that read it; the JSON
    /// of `ocv` carries it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub record: Option<crate::cycler::RecordReport>,
}

impl OcvExtraction {
    /// One line: points, SOC range, capacity and where it came from.
    pub fn summary(&self, out: &Path) -> String {
        let n = self.soc.len();
        let what = match self.from {
            "rests" => format!("{} rests", self.rests.len()),
            _ => self
                .branches
                .iter()
                .map(|b| format!("a C/{:.0} {}", 1.0 / b.c_rate, b.kind))
                .collect::<Vec<_>>()
                .join(" and "),
        };
        let mut pooled = match self.points_pooled {
            0 => String::new(),
            p => format!("; {p} points pooled to keep the OCV increasing"),
        };
        if self.points_clamped > 0 {
            pooled += &format!(
                "; {} points counted outside SOC [0, 1] put at the nearer end",
                self.points_clamped
            );
        }
        format!(
            "wrote {}: {n} points from {what}, SOC {:.3}–{:.3}, OCV {:.4}–{:.4} V; capacity {:.4} A·h ({}), start SOC {:.4}{pooled}",
            out.display(),
            self.soc[0],
            self.soc[n - 1],
            self.ocv_v[0],
            self.ocv_v[n - 1],
            self.capacity_ah,
            self.capacity_source,
            self.soc0
        )
    }
}

/// Writes the table as `soc,ocv_v` (atomically).
///
/// # Errors
/// [`crate::ErrorKind::Io`] when the file cannot be written.
pub fn write_table(path: &Path, x: &OcvExtraction) -> Result<()> {
    crate::io::write_csv(
        path,
        &["soc", "ocv_v"],
        x.soc
            .iter()
            .zip(&x.ocv_v)
            .map(|(z, v)| [z.to_string(), v.to_string()]),
    )
}

/// An SVG of the table over the points it was read from.
///
/// # Errors
/// [`crate::ErrorKind::Io`] or [`crate::ErrorKind::Data`] when it cannot be
/// drawn.
pub fn plot(path: &Path, x: &OcvExtraction) -> Result<()> {
    use crate::plot::{panels, Panel, Series};
    let mut series = vec![Series {
        label: "OCV table",
        points: x.soc.iter().copied().zip(x.ocv_v.iter().copied()).collect(),
        color: 0,
    }];
    if !x.rests.is_empty() {
        series.push(Series {
            label: "rest ends",
            points: x.rests.iter().map(|r| (r.soc, r.voltage_v)).collect(),
            color: 1,
        });
    }
    panels(
        path,
        &[Panel {
            title: "Open-circuit voltage from the test",
            x: "state of charge",
            y: "OCV (V)",
            series,
            log_y: false,
        }],
    )
}

/// Extracts the OCV table of `rec` (read from `path`, named in errors).
///
/// # Errors
/// [`crate::ErrorKind::Options`] for a capacity or start SOC out of range;
/// [`crate::ErrorKind::Data`] when the test has no current, fewer than two
/// rests (or no low-rate branch), or its table would not fit
/// [`OCV_POINTS`] rows.
pub fn extract_ocv(
    path: &Path,
    rec: &BatteryRecord,
    o: &OcvExtractionOptions,
) -> Result<OcvExtraction> {
    if let Some(c) = o.capacity_ah {
        if !(c.is_finite() && c > 0.0) {
            bail!(Options, "--capacity-ah must be positive (got {c})");
        }
    }
    if let Some(z) = o.soc0 {
        if !(0.0..=1.0).contains(&z) {
            bail!(Options, "--soc0 must be in [0, 1] (got {z})");
        }
    }
    if !(o.min_rest_s.is_finite() && o.min_rest_s > 0.0) {
        bail!(
            Options,
            "--min-rest must be positive (got {})",
            o.min_rest_s
        );
    }
    let n = rec.current.len();
    // Counted charge (A·h) at each sample instant, before that sample's.
    let mut q = Vec::with_capacity(n);
    let mut acc = 0.0;
    for &i in &rec.current {
        q.push(acc);
        if i.is_finite() {
            acc += i * rec.h / 3600.0;
        }
    }
    let (qmin, qmax) = q
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let (capacity_ah, capacity_source) = match o.capacity_ah {
        Some(c) => (c, "given"),
        None => {
            let c = qmax - qmin;
            if c <= 0.0 {
                bail!(
                    Data,
                    "{}: no charge flows in the record: the capacity cannot be measured (give --capacity-ah)",
                    path.display()
                );
            }
            (c, "measured")
        }
    };
    let soc0 = o.soc0.unwrap_or(1.0 - qmax / capacity_ah);
    let soc: Vec<f64> = q.iter().map(|x| soc0 + x / capacity_ah).collect();
    let big = rec
        .current
        .iter()
        .filter(|x| x.is_finite())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    if big <= 0.0 {
        bail!(
            Data,
            "{}: the current is zero throughout: no OCV can be read",
            path.display()
        );
    }
    let mut out = OcvExtraction {
        from: o.from.as_str(),
        soc: vec![],
        ocv_v: vec![],
        capacity_ah,
        capacity_source,
        soc0,
        rests: vec![],
        branches: vec![],
        points_pooled: 0,
        points_clamped: 0,
        record: None,
    };
    let points = match o.from {
        OcvSource::Rests => {
            let rest_a = o.rest_current_a.unwrap_or(0.01 * big);
            out.rests = rests(rec, &soc, rest_a, o.min_rest_s);
            if out.rests.len() < 2 {
                bail!(
                    Data,
                    "{}: {} rests of at least {} s (|I| <= {rest_a:.3} A): at least 2 are needed (--min-rest to shorten)",
                    path.display(),
                    out.rests.len(),
                    o.min_rest_s
                );
            }
            out.rests.iter().map(|r| (r.soc, r.voltage_v)).collect()
        }
        OcvSource::LowRate => {
            let (pts, branches) = low_rate(path, rec, &soc, capacity_ah)?;
            out.branches = branches;
            pts
        }
    };
    // A count that runs past full or empty (a start SOC of 1 given to a
    // test that charges a little first) is no SOC: the table stays in
    // [0, 1], as every command that reads it requires.
    out.points_clamped = points
        .iter()
        .filter(|(z, _)| !(0.0..=1.0).contains(z))
        .count();
    let points: Points = points
        .into_iter()
        .map(|(z, v)| (z.clamp(0.0, 1.0), v))
        .collect();
    let (s, v, pooled) = monotone(points);
    if s.len() > OCV_POINTS {
        bail!(
            Data,
            "{}: {} OCV points; a table holds at most {OCV_POINTS}",
            path.display(),
            s.len()
        );
    }
    if s.len() < 2 {
        bail!(
            Data,
            "{}: the OCV points collapse to one (their SOC is the same)",
            path.display()
        );
    }
    out.soc = s;
    out.ocv_v = v;
    out.points_pooled = pooled;
    Ok(out)
}

/// The rests of at least `min_s`: runs of samples with |I| ≤ `rest_a`.
fn rests(rec: &BatteryRecord, soc: &[f64], rest_a: f64, min_s: f64) -> Vec<RestPoint> {
    let n = rec.current.len();
    let mut out = vec![];
    let at_rest = |i: f64| i.abs() <= rest_a;
    let mut k = 0;
    while k < n {
        if !at_rest(rec.current[k]) {
            k += 1;
            continue;
        }
        let start = k;
        while k < n && at_rest(rec.current[k]) {
            k += 1;
        }
        let last = k - 1;
        let length_s = (k - start) as f64 * rec.h;
        if length_s >= min_s && rec.voltage[last].is_finite() {
            out.push(RestPoint {
                end_s: rec.time[last],
                length_s,
                soc: soc[last],
                voltage_v: rec.voltage[last],
            });
        }
    }
    out
}

/// (SOC, OCV) points before they are made monotone.
type Points = Vec<(f64, f64)>;

/// The low-rate branches (runs of at least 20 % of SOC at one current of
/// at most C/10) and their OCV points on a 1 % SOC grid.
fn low_rate(
    path: &Path,
    rec: &BatteryRecord,
    soc: &[f64],
    capacity_ah: f64,
) -> Result<(Points, Vec<Branch>)> {
    let n = rec.current.len();
    let limit = 0.105 * capacity_ah;
    // Runs of one sign and a current within 5 % of the run's first.
    let mut runs: Vec<(usize, usize)> = vec![];
    let mut k = 0;
    while k < n {
        let i0 = rec.current[k];
        if !(i0.is_finite() && i0 != 0.0 && i0.abs() <= limit) {
            k += 1;
            continue;
        }
        let start = k;
        while k < n && (rec.current[k] - i0).abs() <= 0.05 * i0.abs() {
            k += 1;
        }
        if (soc[k - 1] - soc[start]).abs() >= 0.2 {
            runs.push((start, k));
        }
    }
    let pick = |sign: f64| {
        runs.iter()
            .copied()
            .filter(|&(a, _)| rec.current[a] * sign > 0.0)
            .max_by(|x, y| (x.1 - x.0).cmp(&(y.1 - y.0)))
    };
    let (charge, discharge) = (pick(1.0), pick(-1.0));
    if charge.is_none() && discharge.is_none() {
        bail!(
            Data,
            "{}: no low-rate branch (a run of at most C/10 = {limit:.3} A over at least 20 % of SOC); use --from rests",
            path.display()
        );
    }
    let branch = |(a, b): (usize, usize), ir: f64| {
        let i = rec.current[a..b].iter().sum::<f64>() / (b - a) as f64;
        Branch {
            kind: if i > 0.0 { "charge" } else { "discharge" },
            current_a: i,
            c_rate: i.abs() / capacity_ah,
            soc: (soc[a], soc[b - 1]),
            ir_drop_v: ir,
        }
    };
    // The voltage of a run at SOC z, linear between its samples.
    let at = |(a, b): (usize, usize), z: f64| -> Option<f64> {
        (a + 1..b).find_map(|k| {
            let (z0, z1) = (soc[k - 1], soc[k]);
            let inside = (z0 <= z && z <= z1) || (z1 <= z && z <= z0);
            (inside && z0 != z1).then(|| {
                let w = (z - z0) / (z1 - z0);
                rec.voltage[k - 1] + w * (rec.voltage[k] - rec.voltage[k - 1])
            })
        })
    };
    let span = |(a, b): (usize, usize)| {
        let (x, y) = (soc[a], soc[b - 1]);
        (x.min(y), x.max(y))
    };
    let grid = |lo: f64, hi: f64| {
        let a = (lo * 100.0).ceil() as i64;
        let b = (hi * 100.0).floor() as i64;
        (a..=b).map(|j| j as f64 / 100.0).collect::<Vec<f64>>()
    };
    match (charge, discharge) {
        (Some(c), Some(d)) => {
            let (lo, hi) = (span(c).0.max(span(d).0), span(c).1.min(span(d).1));
            let mut pts: Vec<(f64, f64)> = grid(lo, hi)
                .into_iter()
                .filter_map(|z| Some((z, 0.5 * (at(c, z)? + at(d, z)?))))
                .collect();
            if pts.len() < 2 {
                bail!(
                    Data,
                    "{}: the low-rate charge and discharge share no SOC range",
                    path.display()
                );
            }
            // Beyond the shared range (a charge without its CV phase stops
            // short of full), the one branch there, moved onto the mean by
            // the median half-gap (IR drop and hysteresis) over the shared
            // range: not the gap at its edge, where the branch that stops
            // is already rising to its cut-off.
            let mut half: Vec<f64> = grid(lo, hi)
                .into_iter()
                .filter_map(|z| Some(0.5 * (at(c, z)? - at(d, z)?)))
                .collect();
            half.sort_by(f64::total_cmp);
            let g = half[half.len() / 2];
            let (first, last) = (pts[0].0, pts[pts.len() - 1].0);
            let (all_lo, all_hi) = (span(c).0.min(span(d).0), span(c).1.max(span(d).1));
            for z in grid(all_lo, all_hi) {
                if (first..=last).contains(&z) {
                    continue;
                }
                let beyond = at(d, z).map(|v| v + g).or_else(|| at(c, z).map(|v| v - g));
                if let Some(v) = beyond {
                    pts.push((z, v));
                }
            }
            Ok((pts, vec![branch(c, 0.0), branch(d, 0.0)]))
        }
        (Some(r), None) | (None, Some(r)) => {
            // The IR drop: the voltage step where the branch's current
            // starts, over that current; where the record starts inside the
            // branch (no step to see), the step where it ends.
            let (a, b) = r;
            let step = |k: usize| {
                let di = rec.current[k] - rec.current[k - 1];
                let dv = rec.voltage[k] - rec.voltage[k - 1];
                (di != 0.0 && dv.is_finite()).then(|| (dv / di).max(0.0) * rec.current[a])
            };
            let ir = if a > 0 {
                step(a)
            } else if b < rec.current.len() {
                step(b)
            } else {
                None
            }
            .unwrap_or(0.0);
            let (lo, hi) = span(r);
            let pts = grid(lo, hi)
                .into_iter()
                .filter_map(|z| Some((z, at(r, z)? - ir)))
                .collect();
            Ok((pts, vec![branch(r, ir)]))
        }
        (None, None) => Err(err!(Internal, "no branch")),
    }
}

/// Sorted by SOC, equal SOCs merged, and the OCV made increasing by
/// pooling adjacent violators (each pool one point at its mean SOC and
/// voltage). Returns the table and how many points were pooled.
fn monotone(mut p: Vec<(f64, f64)>) -> (Vec<f64>, Vec<f64>, usize) {
    p.retain(|(z, v)| z.is_finite() && v.is_finite());
    p.sort_by(|a, b| a.0.total_cmp(&b.0));
    // (sum soc, sum v, count) blocks.
    let mut blocks: Vec<(f64, f64, usize)> = vec![];
    let mut pooled = 0;
    for (z, v) in p {
        blocks.push((z, v, 1));
        loop {
            let m = blocks.len();
            if m < 2 {
                break;
            }
            let (a, b) = (blocks[m - 2], blocks[m - 1]);
            let same_soc = (b.0 / b.2 as f64 - a.0 / a.2 as f64).abs() < 1e-6;
            if b.1 / b.2 as f64 > a.1 / a.2 as f64 && !same_soc {
                break;
            }
            pooled += b.2;
            blocks.pop();
            let last = blocks.last_mut().expect("two blocks");
            *last = (last.0 + b.0, last.1 + b.1, last.2 + b.2);
        }
    }
    let soc = blocks.iter().map(|b| b.0 / b.2 as f64).collect();
    let v = blocks.iter().map(|b| b.1 / b.2 as f64).collect();
    (soc, v, pooled)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ocv(z: f64) -> f64 {
        3.4 + 0.7 * z + 0.05 * (6.0 * z).sin()
    }

    /// A 5 A·h cell through a pulse test: 1 A·h discharges then 1 h rests
    /// from full, the voltage relaxing to the OCV; R = 20 mΩ.
    fn pulse_test() -> BatteryRecord {
        let h = 10.0;
        let (mut t, mut i, mut v) = (vec![], vec![], vec![]);
        let mut z: f64 = 1.0;
        let mut time = 0.0;
        let mut push = |cur: f64, z: &mut f64, relax: f64| {
            t.push(time);
            i.push(cur);
            v.push(ocv(*z) + 0.02 * cur - relax);
            *z += cur * h / 3600.0 / 5.0;
            time += h;
        };
        for _ in 0..360 {
            push(0.0, &mut z, 0.0);
        }
        for _ in 0..4 {
            for _ in 0..360 {
                push(-1.0, &mut z, 0.0);
            }
            for k in 0..360 {
                push(0.0, &mut z, 0.01 * (-(k as f64) / 30.0).exp());
            }
        }
        BatteryRecord {
            time: t,
            current: i,
            voltage: v,
            h,
        }
    }

    #[test]
    fn rests_give_the_relaxed_voltage_at_the_counted_soc() {
        let rec = pulse_test();
        let o = OcvExtractionOptions::default();
        let x = extract_ocv(Path::new("t.csv"), &rec, &o).unwrap();
        // 4 A·h out of a measured 4 A·h: SOC 1 to 0.
        assert!((x.capacity_ah - 4.0).abs() < 1e-9);
        assert_eq!(x.capacity_source, "measured");
        assert_eq!(x.soc.len(), 5);
        for (z, v) in x.soc.iter().zip(&x.ocv_v) {
            // The counted SOC is of a 4 A·h cell; the curve is of SOC of 5.
            let true_z = 1.0 - (1.0 - z) * 4.0 / 5.0;
            assert!((v - ocv(true_z)).abs() < 2e-6, "{z}: {v}");
        }
        let o = OcvExtractionOptions {
            capacity_ah: Some(5.0),
            ..o
        };
        let x = extract_ocv(Path::new("t.csv"), &rec, &o).unwrap();
        assert!((x.soc[0] - 0.2).abs() < 1e-9 && (x.soc[4] - 1.0).abs() < 1e-9);
        for (z, v) in x.soc.iter().zip(&x.ocv_v) {
            assert!((v - ocv(*z)).abs() < 2e-6, "{z}: {v}");
        }
    }

    /// A C/20 discharge of a 5 A·h cell from full to empty, then a C/20
    /// charge of `charge_steps` minutes (1200: back to full); R = 20 mΩ and
    /// a hysteresis of ±`hysteresis_v`. Its low-rate OCV, from SOC 1.
    fn low_rate_test(charge_steps: usize, hysteresis_v: f64) -> OcvExtraction {
        low_rate_record(0.25, charge_steps, hysteresis_v)
    }

    /// The discharge of [`low_rate_test`], then `after_steps` minutes at
    /// `after_a` (A; 0 for a rest, whose voltage is the OCV).
    fn low_rate_record(after_a: f64, after_steps: usize, hysteresis_v: f64) -> OcvExtraction {
        let h = 60.0;
        let (mut t, mut i, mut v) = (vec![], vec![], vec![]);
        let mut z = 1.0;
        for (k, cur) in std::iter::repeat_n(-0.25, 1200)
            .chain(std::iter::repeat_n(after_a, after_steps))
            .enumerate()
        {
            let hysteresis = if cur == 0.0 {
                0.0
            } else {
                hysteresis_v * f64::signum(cur)
            };
            t.push(k as f64 * h);
            i.push(cur);
            v.push(ocv(z) + 0.02 * cur + hysteresis);
            z += cur * h / 3600.0 / 5.0;
        }
        let rec = BatteryRecord {
            time: t,
            current: i,
            voltage: v,
            h,
        };
        let o = OcvExtractionOptions {
            from: OcvSource::LowRate,
            capacity_ah: Some(5.0),
            soc0: Some(1.0),
            ..OcvExtractionOptions::default()
        };
        extract_ocv(Path::new("t.csv"), &rec, &o).unwrap()
    }

    /// A record that starts inside its C/20 discharge (no rest before it)
    /// takes the IR drop from the step where the discharge ends.
    #[test]
    fn a_branch_without_its_start_takes_the_drop_where_it_ends() {
        let x = low_rate_record(0.0, 30, 0.0);
        assert_eq!(x.branches.len(), 1);
        // R·I = 0.02 Ω · −0.25 A, within the OCV's move over the one step
        // the drop is read across (ΔSOC 0.25·60/3600/5, slope ≤ 1 V).
        let move_v = 0.25 * 60.0 / 3600.0 / 5.0 * 1.0;
        let ir = x.branches[0].ir_drop_v;
        assert!((ir + 0.005).abs() <= move_v, "{ir}");
        for (z, v) in x.soc.iter().zip(&x.ocv_v) {
            assert!((v - ocv(*z)).abs() <= move_v, "{z}: {v} vs {}", ocv(*z));
        }
    }

    #[test]
    fn a_low_rate_pair_averages_out_the_drop() {
        let x = low_rate_test(1200, 0.0);
        assert_eq!(x.branches.len(), 2);
        assert!(x.soc.len() > 90, "{}", x.soc.len());
        for (z, v) in x.soc.iter().zip(&x.ocv_v) {
            assert!((v - ocv(*z)).abs() < 2e-4, "{z}: {v} vs {}", ocv(*z));
        }
    }

    #[test]
    fn a_charge_that_stops_short_is_extended_by_the_discharge() {
        // The charge stops at SOC 0.85 (no CV phase); ±5 mV hysteresis.
        let x = low_rate_test(1020, 0.005);
        // The table reaches full from the discharge, on the mean curve.
        assert!(x.soc[x.soc.len() - 1] > 0.99, "{:?}", x.soc.last());
        assert!(x.soc[0] < 0.01, "{:?}", x.soc.first());
        for (z, v) in x.soc.iter().zip(&x.ocv_v) {
            assert!((v - ocv(*z)).abs() < 2e-4, "{z}: {v} vs {}", ocv(*z));
        }
    }

    #[test]
    fn a_falling_point_is_pooled_not_kept() {
        let (s, v, pooled) = monotone(vec![(0.1, 3.5), (0.3, 3.6), (0.2, 3.62), (0.5, 3.7)]);
        assert_eq!(pooled, 1);
        assert_eq!(s.len(), 3);
        assert!(v.windows(2).all(|w| w[1] > w[0]));
        assert!(s.windows(2).all(|w| w[1] > w[0]));
    }

    #[test]
    fn a_test_without_rests_is_one_line() {
        let rec = BatteryRecord {
            time: (0..100).map(f64::from).collect(),
            current: vec![-1.0; 100],
            voltage: vec![3.7; 100],
            h: 1.0,
        };
        let e = extract_ocv(Path::new("t.csv"), &rec, &OcvExtractionOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("0 rests of at least 600 s"), "{e}");
    }
}
