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
    pub fn of_record(rec: &io::BatteryRecord, limits: Option<(f64, f64)>) -> Self {
        let (mut dis, mut ch) = (0.0, 0.0);
        for &i in rec.current.iter().filter(|i| i.is_finite()) {
            if i < 0.0 {
                dis -= i * rec.h / 3600.0;
            } else {
                ch += i * rec.h / 3600.0;
            }
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
