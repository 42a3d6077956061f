//! What a track published, counted: per parameter (`r_i`, `r_ct`, `q`,
//! `alpha`, the track's column names), the samples of each identification
//! status, and the samples that carried a state of power. `online battery`
//! and `online pack` print it after the track ([`PublicationTally::lines`]),
//! so that a run without a prior says at once which parameters the data
//! identified and for how much of the record.
//!
//! It owns the counting and its wording; it must not judge anything: the
//! statuses are the core's, counted as they are.

use super::power::PowerRow;
use estimator_core::battery::online::{Identification, PublishedParameters};

/// The statuses in the order they are printed: the published ones first.
const STATUSES: [Identification; 7] = [
    Identification::Identified,
    Identification::Step,
    Identification::Prior,
    Identification::Restored,
    Identification::Held,
    Identification::Expired,
    Identification::NotIdentified,
];

/// Samples per status for each published parameter, and samples with a
/// state of power (a pack counts each cell's sample).
///
/// ```
/// use estimator_core::battery::online::{Identification, PublishedParameters};
/// use fracbms_host::online::PublicationTally;
///
/// let mut t = PublicationTally::default();
/// let none = PublishedParameters::<f64>::NONE;
/// t.add(&none, &[]);
/// assert_eq!(t.samples(), 1);
/// assert_eq!(t.count(1, Identification::NotIdentified), 1);
/// assert_eq!(t.published(1), 0);
/// assert_eq!(t.lines()[0], "published: nothing (1 samples); state of power on 0.0 % of them");
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PublicationTally {
    samples: u64,
    counts: [[u64; STATUSES.len()]; 4],
    state_of_power: u64,
}

impl PublicationTally {
    /// Counts one sample's published parameters and its state of power
    /// (carried when any horizon has a discharge current).
    pub fn add(&mut self, published: &PublishedParameters<f64>, power: &[PowerRow]) {
        self.samples += 1;
        self.state_of_power += u64::from(power.iter().any(|p| p.discharge_a.is_some()));
        for (row, (_, p)) in self.counts.iter_mut().zip(published.named()) {
            if let Some(k) = STATUSES.iter().position(|&s| s == p.status) {
                row[k] += 1;
            }
        }
    }

    /// Samples counted.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// Samples whose parameter `parameter` (0 `r_i`, 1 `r_ct`, 2 `q`, 3
    /// `alpha`) had `status` (0 for another index).
    pub fn count(&self, parameter: usize, status: Identification) -> u64 {
        let k = STATUSES.iter().position(|&s| s == status);
        self.counts
            .get(parameter)
            .zip(k)
            .and_then(|(row, k)| row.get(k))
            .copied()
            .unwrap_or(0)
    }

    /// Each status with its samples for parameter `parameter` (all
    /// zero for another index), the published statuses first.
    pub fn statuses(&self, parameter: usize) -> [(Identification, u64); STATUSES.len()] {
        STATUSES.map(|s| (s, self.count(parameter, s)))
    }

    /// The track's names of the four published parameters, in
    /// [`PublishedParameters::named`]'s order: the index `parameter`.
    pub const NAMES: [&'static str; 4] = ["r_i", "r_ct", "q", "alpha"];

    /// Samples on which parameter `parameter` had a published value.
    pub fn published(&self, parameter: usize) -> u64 {
        STATUSES
            .iter()
            .filter(|s| s.is_published())
            .map(|&s| self.count(parameter, s))
            .sum()
    }

    /// Samples that carried a state of power.
    pub fn state_of_power(&self) -> u64 {
        self.state_of_power
    }

    /// Two lines: what was published, parameter by parameter with its
    /// statuses, and the state of power's share; then what was not, and
    /// why (`not_identified`: no window's data identified it yet;
    /// `expired`: the state of charge moved too far from where it was).
    /// Shares are of the samples counted.
    pub fn lines(&self) -> [String; 2] {
        let n = self.samples.max(1) as f64;
        let pct = |x: u64| format!("{:.1} %", 100.0 * x as f64 / n);
        // One parameter's statuses on one side (published or not), or
        // none when it has no sample there.
        let part = |j: usize, published: bool| {
            let side: Vec<(Identification, u64)> = self
                .statuses(j)
                .into_iter()
                .filter(|&(s, n)| s.is_published() == published && n > 0)
                .collect();
            let total: u64 = side.iter().map(|&(_, n)| n).sum();
            let by: Vec<String> = side
                .iter()
                .map(|&(s, n)| format!("{} {}", s.as_str(), pct(n)))
                .collect();
            (total > 0).then(|| format!("{} {} ({})", Self::NAMES[j], pct(total), by.join(", ")))
        };
        let list = |published: bool| -> Vec<String> {
            (0..Self::NAMES.len())
                .filter_map(|j| part(j, published))
                .collect()
        };
        let sop = format!("state of power on {} of them", pct(self.state_of_power));
        let (yes, no) = (list(true), list(false));
        let first = if yes.is_empty() {
            format!("published: nothing ({} samples); {sop}", self.samples)
        } else {
            format!(
                "published, of {} samples: {}; {sop}",
                self.samples,
                yes.join(", ")
            )
        };
        let second = if no.is_empty() {
            "not published: none".to_string()
        } else {
            format!("not published: {}", no.join(", "))
        };
        [first, second]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use estimator_core::battery::online::PublishedParameter;

    fn with(status: Identification) -> PublishedParameter<f64> {
        PublishedParameter {
            value: status.is_published().then_some(0.01),
            status,
            soc: None,
            sigma: None,
        }
    }

    #[test]
    fn each_status_is_counted_for_its_parameter() {
        let mut t = PublicationTally::default();
        let mut p = PublishedParameters::<f64>::NONE;
        p.r_i = with(Identification::Identified);
        p.r_ct = with(Identification::Held);
        let sop = PowerRow {
            discharge_a: Some(3.0),
            ..PowerRow::default()
        };
        t.add(&p, &[PowerRow::default(), sop]);
        p.r_ct = with(Identification::Expired);
        t.add(&p, &[PowerRow::default()]);
        assert_eq!(t.samples(), 2);
        assert_eq!(t.count(0, Identification::Identified), 2);
        assert_eq!(t.published(0), 2);
        assert_eq!(t.count(1, Identification::Held), 1);
        assert_eq!(t.count(1, Identification::Expired), 1);
        assert_eq!(t.published(1), 1);
        assert_eq!(t.published(2), 0);
        assert_eq!(t.state_of_power(), 1);
        assert_eq!(t.count(9, Identification::Held), 0);
        let r_ct = t.statuses(1);
        assert_eq!(r_ct.iter().map(|(_, n)| n).sum::<u64>(), 2);
        assert!(r_ct.contains(&(Identification::Expired, 1)));
        let [yes, no] = t.lines();
        assert_eq!(
            yes,
            "published, of 2 samples: r_i 100.0 % (identified 100.0 %), \
             r_ct 50.0 % (held 50.0 %); state of power on 50.0 % of them"
        );
        assert_eq!(
            no,
            "not published: r_ct 50.0 % (expired 50.0 %), \
             q 100.0 % (not_identified 100.0 %), alpha 100.0 % (not_identified 100.0 %)"
        );
    }
}
