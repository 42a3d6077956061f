//! The state of power checked against the pulses that follow it
//! ([`PulseCheck`]): at each clean current step whose predicted drop
//! stands above the voltage's noise, the voltage the state of power's
//! model predicts for a pulse of that step's current is taken at a few
//! durations ([`CHECK_STEPS`]), and while the current holds, the
//! measured voltage at each is set against it. What the last pulse missed
//! by, relative to the drop predicted, at each duration
//! ([`ResponseMiss`]) widens the spread of the states of power that follow
//! ([`super::ParameterSpread::response`]): a parameter's interval is what
//! its window knows of it, and the pulse itself says what the model,
//! carried from a window to the next pulse, missed. On the measured
//! Panasonic HPPC tests the pulses the model missed most are those after a
//! level's largest pulse, or near empty (docs/bms-states.md).
//!
//! It owns the check's state; it must not change the estimate, what is
//! published or the prediction itself (the pack gives it the predicted
//! voltages, [`crate::battery::pack`]).

use crate::battery::tracker::{clean_edge, precise_change};
use crate::real::Real;

/// The durations a pulse is checked at (samples from its start, the step's
/// own sample the first): at most the state of power's longest horizon
/// that is usually asked (30 s at 1 s), log-spaced.
pub const CHECK_STEPS: [u32; 5] = [1, 2, 5, 10, 30];

const CHECKS: usize = CHECK_STEPS.len();

/// The relative miss of the last checked pulse at each of [`CHECK_STEPS`]:
/// `|predicted − measured| / |voltage before − predicted|` (NaN: not yet
/// seen at that duration).
///
/// ```
/// use estimator_core::battery::power::ResponseMiss;
/// let m = ResponseMiss::<f64> { miss: [0.01, 0.02, f64::NAN, 0.10, 0.05] };
/// assert_eq!(m.at(2), 0.02);
/// // Between two durations, the larger miss of the two known around it.
/// assert_eq!(m.at(7), 0.10);
/// assert_eq!(m.at(5), 0.10);
/// // Beyond the last, the last.
/// assert_eq!(m.at(60), 0.05);
/// assert_eq!(ResponseMiss::<f64>::NONE.at(10), 0.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ResponseMiss<T> {
    /// Per duration of [`CHECK_STEPS`].
    pub miss: [T; CHECKS],
}

impl<T: Real> ResponseMiss<T> {
    /// Nothing checked yet: no miss known.
    pub const NONE: Self = Self {
        miss: [T::NAN; CHECKS],
    };

    /// The relative miss for a pulse of `steps` samples: the larger of the
    /// nearest known misses at or below it and at or above it (beyond the
    /// last duration, the last known); 0 when none is known.
    pub fn at(&self, steps: u32) -> T {
        let known = |(c, m): (&u32, &T)| (m.is_finite()).then_some((*c, *m));
        let below = CHECK_STEPS
            .iter()
            .zip(&self.miss)
            .rev()
            .filter_map(known)
            .find(|(c, _)| *c <= steps);
        let above = CHECK_STEPS
            .iter()
            .zip(&self.miss)
            .filter_map(known)
            .find(|(c, _)| *c >= steps);
        match (below, above) {
            (Some((_, a)), Some((_, b))) => a.max(b),
            (a, b) => a.or(b).map_or(T::zero(), |(_, m)| m),
        }
    }

    /// Every miss finite and not negative, or not known (NaN).
    pub fn is_valid(&self) -> bool {
        self.miss.iter().all(|m| m.is_nan() || *m >= T::zero())
    }
}

/// One cell's check of its state of power against the pulses that follow
/// (module docs): the pulse being checked and the last pulse's misses.
/// 72 B in `f32`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PulseCheck<T> {
    /// The pulse being checked: its current as predicted (A; NaN: none),
    /// the current it holds, the voltage before it (V), its samples so
    /// far, the predicted voltages and its first sample's miss (counted
    /// from the second sample on).
    current: T,
    held: T,
    before: T,
    elapsed: u32,
    predicted: [T; CHECKS],
    first: T,
    /// The last pulse's misses.
    missed: ResponseMiss<T>,
    /// The last sample's current and voltage, and the current before it.
    last: (T, T),
    earlier: T,
}

impl<T: Real> Default for PulseCheck<T> {
    fn default() -> Self {
        Self::BLANK
    }
}

impl<T: Real> PulseCheck<T> {
    /// No sample seen, no pulse checked.
    pub const BLANK: Self = Self {
        current: T::NAN,
        held: T::NAN,
        before: T::NAN,
        elapsed: 0,
        predicted: [T::NAN; CHECKS],
        first: T::NAN,
        missed: ResponseMiss::NONE,
        last: (T::NAN, T::NAN),
        earlier: T::NAN,
    };

    /// Whether `current` (A), the next sample's, starts a pulse to check:
    /// a clean edge, as a step resistance is taken
    /// ([`crate::battery::online::StepResistance`]: the current before it
    /// steady, the two samples before within a tenth of the step; the step
    /// at least half of the larger current and a hundred times
    /// `min_current_std`), into a larger current (a pulse, not its end),
    /// with a voltage before it.
    pub fn starts_pulse(&self, min_current_std: T, current: T) -> bool {
        let (prev, v) = self.last;
        v.is_finite()
            && current.abs() > prev.abs()
            && clean_edge(min_current_std, self.earlier, prev, current)
    }

    /// Starts checking a pulse of `current` (A) with the voltages the
    /// state of power predicts for it at each of [`CHECK_STEPS`] (from
    /// the cell as it was before the pulse's first sample), when every
    /// predicted drop from the voltage before it is known to the step
    /// resistance's precision against `noise_v`, the voltage's scatter in
    /// one sample (the window's RMSE): `2·√2·noise_v ≤ 0.25·|drop|`
    /// ([`crate::battery::online::STEP_PRECISION`]). A smaller step's
    /// miss would be the voltage's noise over a drop of a few millivolts,
    /// not the model's. Returns whether the pulse is checked.
    pub fn start(&mut self, current: T, predicted: [T; CHECKS], noise_v: T) -> bool {
        let before = self.last.1;
        let precise = predicted
            .iter()
            .all(|&p| (before - p).is_finite() && precise_change(noise_v, before - p));
        if !precise {
            self.current = T::nan();
            return false;
        }
        self.current = current;
        self.before = before;
        self.held = current;
        self.elapsed = 0;
        self.predicted = predicted;
        self.first = T::nan();
        true
    }

    /// Takes one sample (current in A, voltage in V; `rejected`: the
    /// voltage was not accepted). At each duration of [`CHECK_STEPS`] the
    /// pulse reaches, its miss replaces the last pulse's there: the
    /// measured drop from the voltage before the pulse against the
    /// predicted one, scaled to the current held (a model's response is
    /// linear in the current). The pulse ends when the voltage is not
    /// usable or the current leaves a tenth of what it holds. Its first
    /// sample's miss counts once the second sample holds the same current
    /// (within 2 %); a first sample that averaged the current over the
    /// edge (a resampled log: at least half the current after it, of the
    /// same sign) or a current still settling (within a tenth) leaves the
    /// first duration's miss unknown, and the pulse is checked at the
    /// current it then holds. A pulse that ends before a duration leaves
    /// the last pulse's miss there.
    pub fn observe(&mut self, current: T, voltage: T, rejected: bool) {
        let usable = voltage.is_finite() && !rejected;
        if self.current.is_finite() {
            self.elapsed = self.elapsed.saturating_add(1);
            let held = self.held;
            let goes_on = usable
                && match self.elapsed {
                    1 => {
                        self.held = current;
                        true
                    }
                    2 if (current - held).abs() <= T::lit(0.02) * held.abs() => {
                        if let Some(m) = self.missed.miss.first_mut() {
                            if self.first.is_finite() {
                                *m = self.first;
                            }
                        }
                        true
                    }
                    2 => {
                        // A first sample not at the pulse's current: one
                        // that straddled the edge, or a current still
                        // settling (within a tenth). This pulse goes past
                        // the first duration without telling its miss:
                        // the miss there becomes unknown (an older
                        // pulse's does not stand for a duration a newer
                        // one went past), and the pulse is checked at the
                        // current it now holds.
                        let settling = (current - held).abs() <= T::lit(0.1) * held.abs();
                        let straddled = current * held > T::zero()
                            && current.abs() >= held.abs()
                            && T::lit(2.0) * held.abs() >= current.abs();
                        self.held = current;
                        let goes_on = settling || straddled;
                        if goes_on {
                            if let Some(m) = self.missed.miss.first_mut() {
                                *m = T::nan();
                            }
                        }
                        goes_on
                    }
                    _ => (current - held).abs() <= T::lit(0.1) * held.abs(),
                };
            if !goes_on {
                self.current = T::nan();
            } else {
                let scale = current / self.current;
                for ((&c, &p), m) in CHECK_STEPS
                    .iter()
                    .zip(&self.predicted)
                    .zip(self.missed.miss.iter_mut())
                {
                    let drop = (self.before - p) * scale;
                    if c == self.elapsed && drop.abs() > T::zero() && drop.is_finite() {
                        let miss = ((self.before - voltage) - drop).abs() / drop.abs();
                        // The first sample's waits for the second.
                        if c == 1 {
                            self.first = miss;
                        } else {
                            *m = miss;
                        }
                    }
                }
                if self.elapsed >= CHECK_STEPS[CHECKS - 1] {
                    self.current = T::nan();
                }
            }
        }
        self.earlier = self.last.0;
        self.last = (current, if usable { voltage } else { T::nan() });
    }

    /// The record starts again (a gap, a restarted window): the samples
    /// before it say nothing of a step after it, and a pulse being checked
    /// ends. The misses are kept (they are the model's).
    pub fn restart(&mut self) {
        self.current = T::nan();
        self.last = (T::nan(), T::nan());
        self.earlier = T::nan();
    }

    /// What the last pulses missed by at each duration.
    pub fn missed(&self) -> ResponseMiss<T> {
        self.missed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three samples at rest (0 A, 3.7 V).
    fn rest(c: &mut PulseCheck<f64>) {
        for _ in 0..3 {
            c.observe(0.0, 3.7, false);
        }
    }

    /// A pulse checked from the second duration on, as predicted: the
    /// first duration's miss unknown, every other none.
    fn assert_only_the_first_unknown(c: &PulseCheck<f64>) {
        let m = c.missed().miss;
        assert!(m[0].is_nan(), "gone past, not told: {m:?}");
        for m in &m[1..] {
            assert!(*m < 1e-12, "{m}");
        }
    }

    /// A pulse of −2 A from rest at 3.7 V whose measured drop is 10 %
    /// larger than predicted at every duration: each miss is 0.1, and a
    /// pulse that stops early leaves the longer durations' misses as they
    /// were.
    #[test]
    fn a_pulse_leaves_its_relative_miss_at_each_duration() {
        let mut c = PulseCheck::<f64>::BLANK;
        for _ in 0..3 {
            assert!(!c.starts_pulse(1e-3, 0.0));
            c.observe(0.0, 3.7, false);
        }
        assert!(c.starts_pulse(1e-3, -2.0));
        let predicted = CHECK_STEPS.map(|k| 3.7 - 0.1 - 0.001 * f64::from(k));
        assert!(c.start(-2.0, predicted, 1e-3));
        for k in 1..=40u32 {
            let drop = 0.1 + 0.001 * f64::from(k.min(30));
            c.observe(-2.0, 3.7 - 1.1 * drop, false);
        }
        for m in c.missed().miss {
            assert!((m - 0.1).abs() < 1e-9, "{m}");
        }
        // A second pulse, as predicted, that stops after 5 samples.
        rest(&mut c);
        assert!(c.starts_pulse(1e-3, -2.0));
        assert!(c.start(-2.0, predicted, 1e-3));
        for k in 1..=5u32 {
            c.observe(
                -2.0,
                predicted[CHECK_STEPS.iter().position(|&x| x >= k).unwrap()],
                false,
            );
        }
        c.observe(0.0, 3.7, false);
        let m = c.missed().miss;
        assert!(m[0] < 0.1 && m[2] < 1e-12, "{m:?}");
        assert!(
            (m[3] - 0.1).abs() < 1e-9 && (m[4] - 0.1).abs() < 1e-9,
            "{m:?}"
        );
        assert!((c.missed().at(10) - 0.1).abs() < 1e-9);
    }

    /// A resampled log's first pulse sample averages the current over the
    /// edge (−1.9 A of a −2 A pulse): it gives no miss, and the prediction
    /// for it, scaled to the −2 A held after, is what the pulse is checked
    /// against; a pulse as predicted at −2 A misses by nothing. The
    /// pulse's end, into a smaller current, starts no check.
    #[test]
    fn a_step_averaged_over_its_edge_is_checked_at_the_full_current() {
        let mut c = PulseCheck::<f64>::BLANK;
        c.observe(0.0, 3.7, false);
        c.observe(0.0, 3.7, false);
        assert!(c.starts_pulse(1e-3, -1.9));
        // Predicted for −1.9 A: 0.19 V of drop and 1.9 mV a sample more.
        let predicted = CHECK_STEPS.map(|k| 3.7 - 1.9 * (0.1 + 0.001 * f64::from(k)));
        assert!(c.start(-1.9, predicted, 1e-3));
        c.observe(-1.9, predicted[0], false);
        for k in 2..=30u32 {
            c.observe(-2.0, 3.7 - 2.0 * (0.1 + 0.001 * f64::from(k)), false);
        }
        // The straddled first sample tells nothing of the first duration.
        assert_only_the_first_unknown(&c);
        assert!(!c.starts_pulse(1e-3, 0.0), "the pulse's end");
    }

    /// A rejected or missing voltage, or a current that moves, ends the
    /// check without a miss; a step from a current that was not steady, or
    /// from before a restart, starts none.
    #[test]
    fn a_pulse_that_does_not_hold_leaves_no_miss() {
        let mut c = PulseCheck::<f64>::BLANK;
        c.observe(0.0, 3.7, false);
        c.observe(-0.5, 3.69, false);
        assert!(!c.starts_pulse(1e-3, -2.0), "not steady before");
        c.observe(-0.5, 3.69, false);
        assert!(c.starts_pulse(1e-3, -2.0));
        assert!(c.start(-2.0, [3.6; 5], 1e-3));
        c.observe(-2.0, f64::NAN, false);
        assert!(c.missed().miss.iter().all(|m| m.is_nan()));
        c.observe(-0.5, 3.69, false);
        c.observe(-0.5, 3.69, false);
        assert!(c.start(-2.0, [3.6; 5], 1e-3));
        c.observe(-2.0, 3.5, true);
        c.observe(-1.0, 3.5, false);
        assert!(c.missed().miss.iter().all(|m| m.is_nan()));
        assert!(!c.starts_pulse(1e-3, -1.0 + 1e-6), "no step");
        // After a restart, the samples before it start no pulse.
        c.observe(0.0, 3.7, false);
        c.observe(0.0, 3.7, false);
        c.restart();
        assert!(!c.starts_pulse(1e-3, -2.0));
        c.observe(0.0, 3.7, false);
        assert!(!c.starts_pulse(1e-3, -2.0), "one sample is not steady");
        c.observe(0.0, 3.7, false);
        assert!(c.starts_pulse(1e-3, -2.0));
    }

    /// A step whose predicted drop is within the voltage's noise is not
    /// checked; a pulse of one sample keeps the last pulse's first miss;
    /// a current that settles within a tenth after its first sample is
    /// checked from the second duration on at the current it holds, and
    /// leaves the first duration's miss unknown.
    #[test]
    fn a_small_step_is_not_checked_and_a_short_one_keeps_the_last_miss() {
        let mut c = PulseCheck::<f64>::BLANK;
        let predicted = CHECK_STEPS.map(|k| 3.7 - 0.1 - 0.001 * f64::from(k));
        // Within the noise: 2·√2·10 mV > 0.25·100 mV.
        rest(&mut c);
        assert!(c.starts_pulse(1e-3, -2.0));
        assert!(!c.start(-2.0, predicted, 0.01));
        c.observe(-2.0, 3.5, false);
        c.observe(-2.0, 3.5, false);
        assert!(c.missed().miss.iter().all(|m| m.is_nan()));
        // A pulse 10 % deeper than predicted at its first two samples.
        rest(&mut c);
        assert!(c.start(-2.0, predicted, 1e-3));
        for k in 1..=2u32 {
            c.observe(-2.0, 3.7 - 1.1 * (0.1 + 0.001 * f64::from(k)), false);
        }
        c.observe(0.0, 3.7, false);
        let first = c.missed().miss[0];
        assert!((first - 0.1).abs() < 1e-9, "{first}");
        // One sample, then back to rest: the first miss stays.
        rest(&mut c);
        assert!(c.start(-2.0, predicted, 1e-3));
        c.observe(-2.0, 3.0, false);
        c.observe(0.0, 3.7, false);
        assert_eq!(c.missed().miss[0], first);
        // A current 5 % below its first sample's after it: checked on,
        // as predicted, at −1.9 A.
        rest(&mut c);
        assert!(c.start(-2.0, predicted, 1e-3));
        c.observe(-2.0, 3.0, false);
        for k in 2..=30u32 {
            c.observe(-1.9, 3.7 - 0.95 * (0.1 + 0.001 * f64::from(k)), false);
        }
        assert_only_the_first_unknown(&c);
    }
}
