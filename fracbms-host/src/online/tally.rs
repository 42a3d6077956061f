//! What a track published, counted: per parameter (`r_i`, `r_ct`, `q`,
//! `alpha`, the track's column names), the samples of each identification
//! status, and the samples that carried a state of power. `online battery`
//! and `online pack` print it after the track ([`PublicationTally::lines`]),
//! so that a run without a prior says at once which parameters the data
//! identified and for how much of the record.
//!
//! It owns the counting and its wording; it must not judge anything: the
//! statuses are the core's, counted as they are.

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

/// The track's names of the four published parameters, in
/// [`PublishedParameters::named`]'s order.
const NAMES: [&str; 4] = ["r_i", "r_ct", "q", "alpha"];

/// Samples per status for each published parameter, and samples with a
/// state of power (a pack counts each cell's sample).
///
/// ```
/// use estimator_core::battery::online::{Identification, PublishedParameters};
/// use fracbms_host::online::PublicationTally;
///
/// let mut t = PublicationTally::default();
/// let none = PublishedParameters::<f64>::NONE;
/// t.add(&none, false);
/// assert_eq!(t.samples(), 1);
/// assert_eq!(t.count(1, Identification::NotIdentified), 1);
/// assert_eq!(t.published(1), 0);
/// assert_eq!(t.lines()[0], "published: nothing (1 samples); state of power on 0.0 % of them");
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PublicationTally {
    samples: u64,
    counts: [[u64; STATUSES.len()]; NAMES.len()],
    state_of_power: u64,
}

impl PublicationTally {
    /// Counts one sample's published parameters, and whether it carried a
    /// state of power.
    pub fn add(&mut self, published: &PublishedParameters<f64>, state_of_power: bool) {
        self.samples += 1;
        self.state_of_power += u64::from(state_of_power);
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

    /// The track's names of the parameters, in the order of `parameter`.
    pub const NAMES: [&'static str; 4] = NAMES;

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
        let part = |j: usize, published: bool| {
            let total: u64 = STATUSES
                .iter()
                .filter(|s| s.is_published() == published)
                .map(|&s| self.count(j, s))
                .sum();
            (total > 0).then(|| {
                let by: Vec<String> = STATUSES
                    .iter()
                    .filter(|s| s.is_published() == published)
                    .filter(|&&s| self.count(j, s) > 0)
                    .map(|&s| format!("{} {}", s.as_str(), pct(self.count(j, s))))
                    .collect();
                format!("{} {} ({})", NAMES[j], pct(total), by.join(", "))
            })
        };
        let list = |published: bool| -> Vec<String> {
            (0..NAMES.len())
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
        }
    }

    #[test]
    fn each_status_is_counted_for_its_parameter() {
        let mut t = PublicationTally::default();
        let mut p = PublishedParameters::<f64>::NONE;
        p.r_i = with(Identification::Identified);
        p.r_ct = with(Identification::Held);
        t.add(&p, true);
        p.r_ct = with(Identification::Expired);
        t.add(&p, false);
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
