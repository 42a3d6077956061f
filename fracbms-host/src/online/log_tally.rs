//! What one log's track published, gathered as it is written
//! ([`FileTally`]): the charge counted, the values its windows identified,
//! the capacity at its end, and whether the log is a capacity check. A
//! life's row ([`super::life::LifeRow`]) is made from it.
//!
//! It owns the tally; it must not change the track or the estimator.

use super::*;
use estimator_core::battery::online::Identification;

/// How close to the voltage limits a capacity check must start and end
/// (V): a log that starts at rest within this of the upper limit and
/// whose load takes the cell within this of the lower limit
/// ([`FileTally::full_discharge`]).
pub const FULL_DISCHARGE_MARGIN_V: f64 = 0.05;

/// Whether a log's own rows `rows` (as logged, before the uniform period)
/// make a capacity check between the voltage limits `limits` (`(lowest,
/// highest)`; `None`: none known, no check): the first row at rest (its
/// current at most 1 % of the largest) within [`FULL_DISCHARGE_MARGIN_V`]
/// of the upper limit, and its last loaded row (above that 1 %) within the
/// margin of the lower limit or below it. The rows, not the uniform samples: a
/// cycler stops the load at the first row past its cut-off, and where that
/// is the log's last row (NASA's B0006, B0007 and B0018 end so, the knee
/// falling 0.2–0.4 V in one 19-s row) the samples of a coarser period hold
/// only the voltage before it.
pub fn capacity_check(rows: &io::BatteryRecord, limits: Option<(f64, f64)>) -> bool {
    let Some((lo, hi)) = limits else {
        return false;
    };
    let peak = rows
        .current
        .iter()
        .filter(|i| i.is_finite())
        .fold(0.0_f64, |m, i| m.max(i.abs()));
    let rest = 0.01 * peak;
    let first = rows
        .current
        .iter()
        .zip(&rows.voltage)
        .find(|(i, v)| i.is_finite() && v.is_finite());
    let starts_full =
        first.is_some_and(|(i, v)| i.abs() <= rest && *v >= hi - FULL_DISCHARGE_MARGIN_V);
    // The last loaded row: where the load stopped (one low row inside the
    // discharge, a glitch, is not a cut-off).
    let last_loaded = rows
        .current
        .iter()
        .zip(&rows.voltage)
        .rev()
        .find(|(i, v)| i.abs() > rest && v.is_finite())
        .map(|(_, v)| *v);
    peak > 0.0 && starts_full && last_loaded.is_some_and(|v| v <= lo + FULL_DISCHARGE_MARGIN_V)
}

/// What one log's track published, gathered as it is written: a life's
/// row ([`super::life::LifeRow`]).
#[derive(Clone, Debug, Default)]
pub struct FileTally {
    /// Samples run.
    pub samples: usize,
    /// The charge the record discharged and charged (A·h, magnitudes).
    pub discharged_ah: f64,
    /// See [`FileTally::discharged_ah`].
    pub charged_ah: f64,
    /// The values of R_i, R_ct and α this log's own windows identified
    /// (status `identified`, or `step` for R_i).
    identified: [Vec<f64>; 3],
    /// Each one's status at the last sample.
    last_status: [Option<Identification>; 3],
    /// The capacity published at the last sample and its status.
    pub(super) capacity: Option<(f64, &'static str)>,
    /// Whether the log is a capacity check: it starts at rest (its first
    /// current at most 1 % of its largest) within
    /// [`FULL_DISCHARGE_MARGIN_V`] of the upper voltage limit, only
    /// discharges (its charge in at most 1 % of its charge out), and its
    /// load takes the cell within that margin of the lower limit. Its
    /// counted discharge is then the capacity at that current, as a
    /// cycler's capacity test measures it.
    pub full_discharge: bool,
}

impl FileTally {
    /// A tally of `rec`'s counted charge (each sample's current held for
    /// its period; a current that is not finite counts nothing), and
    /// whether it is a capacity check between the voltage limits
    /// `limits` (`(lowest, highest)`; `None`: none known, no check),
    /// judged on the log's own rows `rows` (before its uniform period:
    /// [`capacity_check`]).
    ///
    /// Across a gap of the log whose charge the export's own count gives
    /// ([`Gap::charge_ah`]) the gap counts as one net charge, the held
    /// current's count and that charge together: what the estimator
    /// counts there ([`super::Tracker::bridge_gap`]). Across a gap whose
    /// charge is not known, the held current.
    pub fn of_record(
        rec: &io::BatteryRecord,
        rows: &io::BatteryRecord,
        limits: Option<(f64, f64)>,
        gaps: &[Gap],
    ) -> Self {
        let (mut dis, mut ch) = (0.0, 0.0);
        let mut add = |q: f64| {
            if q < 0.0 {
                dis -= q;
            } else {
                ch += q;
            }
        };
        // The gaps with a known charge, in time order: (start, end,
        // charge beyond the held current's count), and the held count
        // of the one open.
        let mut known = gaps
            .iter()
            .filter_map(|g| Some((g.start_s, g.start_s + g.length_s, g.charge_ah?)))
            .peekable();
        let mut open: Option<(f64, f64)> = None;
        for (&t, &i) in rec.time.iter().zip(&rec.current) {
            let q = if i.is_finite() {
                i * rec.h / 3600.0
            } else {
                0.0
            };
            if let Some((end, held)) = open {
                if t < end {
                    open = Some((end, held + q));
                    continue;
                }
                open = None;
                add(held);
            }
            while known.next_if(|&(_, end, _)| end <= t).is_some() {}
            if let Some(&(start, end, c)) = known.peek() {
                if t >= start {
                    known.next();
                    open = Some((end, c + q));
                    continue;
                }
            }
            add(q);
        }
        if let Some((_, held)) = open {
            add(held);
        }
        let full_discharge = ch <= 0.01 * dis && capacity_check(rows, limits);
        Self {
            discharged_ah: dis,
            charged_ah: ch,
            full_discharge,
            ..Self::default()
        }
    }

    /// One row of the track.
    pub fn push(&mut self, r: &TrackRow) {
        self.samples += 1;
        let p = &r.published;
        for (k, x) in [p.r_i, p.r_ct, p.alpha].iter().enumerate() {
            if let (Some(v), Identification::Identified | Identification::Step) =
                (x.value, x.status)
            {
                self.identified[k].push(v);
            }
            self.last_status[k] = Some(x.status);
        }
        self.capacity = r.soc_detail.columns()[2].map(|c| (c, r.soc_detail.capacity_status()));
    }

    /// The median of the values identified in the log, and `identified`;
    /// else nothing, and the status at its end.
    pub(super) fn median(&self, k: usize) -> (Option<f64>, &'static str) {
        let mut v = self.identified[k].clone();
        if v.is_empty() {
            return (
                None,
                self.last_status[k].map_or("not_identified", |s| s.as_str()),
            );
        }
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let m = if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        };
        (Some(m), "identified")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A record of `current`, a sample every 60 s from 0 s.
    fn record(current: &[f64]) -> io::BatteryRecord {
        io::BatteryRecord {
            time: (0..current.len()).map(|k| 60.0 * k as f64).collect(),
            voltage: vec![3.7; current.len()],
            current: current.to_vec(),
            h: 60.0,
        }
    }

    #[test]
    fn a_gap_counts_its_known_charge_not_the_held_current() {
        // Rest, then a gap of 240 s (rows at 120 s and 360 s; the samples
        // between hold the rest) across which the export counted 0.1 A·h
        // of discharge, then 1 A of discharge for two samples.
        let rec = record(&[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0, -1.0]);
        let gap = |charge_ah| Gap {
            start_s: 120.0,
            length_s: 240.0,
            charge_ah,
        };
        let t = FileTally::of_record(&rec, &rec, None, &[gap(Some(-0.1))]);
        let loaded = 2.0 * 60.0 / 3600.0;
        assert!((t.discharged_ah - (0.1 + loaded)).abs() < 1e-12, "{t:?}");
        assert_eq!(t.charged_ah, 0.0);
        // Unknown: the held current alone.
        let t = FileTally::of_record(&rec, &rec, None, &[gap(None)]);
        assert!((t.discharged_ah - loaded).abs() < 1e-12, "{t:?}");
        // A discharge held across a gap that was a charge: the gap's net
        // charge counts as charged, and nothing of the held discharge.
        let rec = record(&[-1.0, -1.0, -1.0, -1.0, -1.0, -1.0, 0.0, 0.0]);
        let held = 4.0 * 60.0 / 3600.0;
        let t = FileTally::of_record(&rec, &rec, None, &[gap(Some(0.5 + held))]);
        assert!((t.charged_ah - 0.5).abs() < 1e-12, "{t:?}");
        assert!(
            (t.discharged_ah - 2.0 * 60.0 / 3600.0).abs() < 1e-12,
            "{t:?}"
        );
    }

    /// A NASA-like discharge: at rest at 4.19 V, 2 A from the second row,
    /// the voltage falling to 2.70 V and then, in the last row 20 s
    /// later, to 2.44 V, past a 2.5 V cut-off; rows every 20.3 s.
    fn discharge_rows(last_v: f64) -> io::BatteryRecord {
        let n = 40;
        let time: Vec<f64> = (0..n).map(|k| 20.3 * k as f64).collect();
        let current: Vec<f64> = (0..n).map(|k| if k == 0 { -0.002 } else { -2.0 }).collect();
        let mut voltage: Vec<f64> = (0..n)
            .map(|k| 4.19 - (4.19 - 2.70) * k as f64 / (n - 2) as f64)
            .collect();
        voltage[n - 1] = last_v;
        io::BatteryRecord {
            time,
            current,
            voltage,
            h: 20.3,
        }
    }

    #[test]
    fn a_log_whose_last_row_passes_the_cut_off_is_a_capacity_check() {
        let rows = discharge_rows(2.44);
        let limits = Some((2.5, 4.2));
        assert!(capacity_check(&rows, limits));
        // On a coarser period the samples end before the last row: their
        // lowest voltage stays 0.2 V above the cut-off, so a check judged
        // on them would not be one.
        let mut r = crate::cycler::resample::Resampling {
            gap_threshold_s: 1e3,
            ..Default::default()
        };
        let keep = crate::cycler::resample::clean(&rows.time, &mut r);
        let u = crate::cycler::resample::to_uniform(
            &rows.time,
            &rows.current,
            &rows.voltage,
            None,
            &keep,
            21.0,
            &mut r,
        );
        let sampled = io::BatteryRecord {
            time: u.time,
            current: u.current,
            voltage: u.voltage,
            h: 21.0,
        };
        let lowest = sampled.voltage.iter().fold(f64::INFINITY, |m, v| m.min(*v));
        assert!(lowest > 2.5 + FULL_DISCHARGE_MARGIN_V, "{lowest}");
        let t = FileTally::of_record(&sampled, &rows, limits, &[]);
        assert!(t.full_discharge, "{t:?}");
        // A log stopped 0.2 V short of the cut-off is not a check, nor one
        // that does not start near the upper limit, nor one without limits.
        assert!(!capacity_check(&discharge_rows(2.70), limits));
        assert!(!capacity_check(&rows, Some((2.5, 4.3))));
        assert!(!capacity_check(&rows, None));
        // One low row inside the discharge, a glitch, is not the cut-off.
        let mut glitch = discharge_rows(2.70);
        glitch.voltage[20] = 2.3;
        assert!(!capacity_check(&glitch, limits));
    }
}
