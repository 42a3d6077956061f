//! A rest in progress, as the SOC observer follows it: its length and the
//! means of its recent voltage and current. Owns only that bookkeeping;
//! what a rest observes is the observer's ([`super::SocObserver`]).

use super::SocSettings;
use crate::real::Real;

/// A rest in progress: its length and the mean of its recent voltages.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(super) struct Rest<T> {
    /// Length (s): the rested samples so far times the period.
    pub(super) len: T,
    /// The mean of about the last half minute of the rest: the rested
    /// voltage read. Not extrapolated to the rest's end: a power law's
    /// asymptote from three means (Aitken's Δ²) overshot DFN relaxations,
    /// past their power-law part after minutes, by 13 mV
    /// (docs/bms-states.md).
    pub(super) mean: T,
    /// The mean of the currents over the same half minute (A): the bias
    /// as a rest reads it (NaN until a sample of the rest reads a current,
    /// and for a rest restored from a snapshot of layout version 1, which
    /// did not keep it: that rest gives no reading).
    pub(super) current: T,
    /// Whether the rest has given its early observation (of an unknown
    /// SOC) and its observation.
    pub(super) early: bool,
    pub(super) done: bool,
    /// Whether the rest has given its reading of the bias (one per rest:
    /// the load it stands for is the same at every observation).
    pub(super) bias_read: bool,
}

impl<T: Real> Rest<T> {
    pub(super) fn new(s: &SocSettings<T>, voltage: T, current: T) -> Self {
        Self {
            len: s.h,
            mean: voltage,
            // A current the sensor did not read (NaN, or not finite) starts
            // no mean: the first sample that reads one does.
            current: if current.is_finite() {
                current
            } else {
                T::nan()
            },
            early: false,
            done: false,
            bias_read: false,
        }
    }

    /// One more rested sample: its voltage, and the current the sensor
    /// read (a sample that read none leaves the current's mean as it is;
    /// the first that reads one starts it).
    pub(super) fn push(&mut self, s: &SocSettings<T>, voltage: T, current: T) {
        self.len = self.len + s.h;
        let a = (s.h / T::lit(30.0)).min(T::ONE);
        self.mean = self.mean + a * (voltage - self.mean);
        if current.is_finite() {
            self.current = if self.current.is_finite() {
                self.current + a * (current - self.current)
            } else {
                current
            };
        }
    }
}
