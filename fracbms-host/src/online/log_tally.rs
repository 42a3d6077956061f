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
    /// `limits` (`(lowest, highest)`; `None`: none known, no check).
    ///
    /// Across a gap of the log whose charge the export's own count gives
    /// ([`Gap::charge_ah`]) the gap counts as one net charge, the held
    /// current's count and that charge together: what the estimator
    /// counts there ([`super::Tracker::bridge_gap`]). Across a gap whose
    /// charge is not known, the held current.
    pub fn of_record(rec: &io::BatteryRecord, limits: Option<(f64, f64)>, gaps: &[Gap]) -> Self {
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
        let full_discharge = limits.is_some_and(|(lo, hi)| {
            let peak = rec
                .current
                .iter()
                .filter(|i| i.is_finite())
                .fold(0.0_f64, |m, i| m.max(i.abs()));
            let rest = 0.01 * peak;
            let first = rec
                .current
                .iter()
                .zip(&rec.voltage)
                .find(|(i, v)| i.is_finite() && v.is_finite());
            let starts_full =
                first.is_some_and(|(i, v)| i.abs() <= rest && *v >= hi - FULL_DISCHARGE_MARGIN_V);
            let lowest_loaded = rec
                .current
                .iter()
                .zip(&rec.voltage)
                .filter(|(i, v)| i.abs() > rest && v.is_finite())
                .fold(f64::INFINITY, |m, (_, v)| m.min(*v));
            peak > 0.0
                && starts_full
                && ch <= 0.01 * dis
                && lowest_loaded <= lo + FULL_DISCHARGE_MARGIN_V
        });
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
        let t = FileTally::of_record(&rec, None, &[gap(Some(-0.1))]);
        let loaded = 2.0 * 60.0 / 3600.0;
        assert!((t.discharged_ah - (0.1 + loaded)).abs() < 1e-12, "{t:?}");
        assert_eq!(t.charged_ah, 0.0);
        // Unknown: the held current alone.
        let t = FileTally::of_record(&rec, None, &[gap(None)]);
        assert!((t.discharged_ah - loaded).abs() < 1e-12, "{t:?}");
        // A discharge held across a gap that was a charge: the gap's net
        // charge counts as charged, and nothing of the held discharge.
        let rec = record(&[-1.0, -1.0, -1.0, -1.0, -1.0, -1.0, 0.0, 0.0]);
        let held = 4.0 * 60.0 / 3600.0;
        let t = FileTally::of_record(&rec, None, &[gap(Some(0.5 + held))]);
        assert!((t.charged_ah - 0.5).abs() < 1e-12, "{t:?}");
        assert!(
            (t.discharged_ah - 2.0 * 60.0 / 3600.0).abs() < 1e-12,
            "{t:?}"
        );
    }
}
