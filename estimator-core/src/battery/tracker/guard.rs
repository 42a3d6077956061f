//! The guard in front of the window: each sample is validated (finite, in
//! range, not a spike against the model's one-step prediction), substituted
//! when rejected so that the time base stays uniform, and written into the
//! cell's window; the state of charge is counted on the way.

use super::settings::REST_SAMPLES;
use super::*;
use crate::frac::GlWeights;
use crate::real::Real;

impl<T: Real, const N: usize> CellState<T, N> {
    /// [`CellEstimator::predict`](crate::battery::online::CellEstimator::predict) with the prediction weights `w` (set to
    /// the estimate's order here).
    pub(crate) fn predict<const MEM: usize, const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
        history: &CurrentHistory<T, N>,
        w: &mut GlWeights<T, MEM>,
        current: T,
    ) -> Option<T> {
        let y = self.predict_window(history, w, current)?;
        Some(match (&s.ocv, self.soc) {
            (Some(m), Some(z)) => y + m.table.ocv(m.soc_after(z, current, s.battery.h)),
            _ => y,
        })
    }

    /// The one-step prediction in the window's coordinates (the
    /// overpotential with an OCV curve); `None` without an estimate, or
    /// when the prediction is not finite.
    pub(super) fn predict_window<const MEM: usize>(
        &self,
        history: &CurrentHistory<T, N>,
        w: &mut GlWeights<T, MEM>,
        current: T,
    ) -> Option<T> {
        let p = self.estimate?;
        if w.alpha() != p.alpha {
            w.set_order(p.alpha).ok()?;
        }
        let wts = w.weights();
        let mut hist = T::zero();
        for (&wj, (i, u)) in wts.iter().skip(1).zip(self.view(history).newest_first()) {
            hist = hist + wj * ((u - p.u_oc) - p.static_voltage(i));
        }
        let a = p.tau() * w.scale();
        let up = (p.r_ct * current - a * hist) / (T::one() + a);
        let y = p.u_oc + p.static_voltage(current) + up;
        // An estimate far from the data can overflow here in f32 (a large
        // current through the kinetic term, a large `a`; fuzz case
        // `cell:1:127963`). Such a prediction is no prediction: it judges no
        // sample as a spike, and a rejected sample's substitute is then the
        // last window value, so the window only ever holds finite values.
        y.is_finite().then_some(y)
    }

    pub(super) fn classify<const MEM: usize, const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
        history: &CurrentHistory<T, N>,
        w: &mut GlWeights<T, MEM>,
        current: T,
        voltage: T,
    ) -> Option<Rejection> {
        if !(current.is_finite() && voltage.is_finite()) {
            return Some(Rejection::NonFinite);
        }
        if current.abs() > s.current_limit || voltage < s.voltage_min || voltage > s.voltage_max {
            return Some(Rejection::OutOfRange);
        }
        let y = self.to_window(s, current, voltage);
        if self.spikes_in_row < s.max_consecutive_spikes && self.is_spike(s, history, w, current, y)
        {
            return Some(Rejection::Spike);
        }
        None
    }

    /// True when `y` (in the window's coordinates) is further than
    /// `max(spike_sigmas·RMSE, spike_floor)` from the model's prediction
    /// for `current`.
    pub(super) fn is_spike<const MEM: usize, const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
        history: &CurrentHistory<T, N>,
        w: &mut GlWeights<T, MEM>,
        current: T,
        y: T,
    ) -> bool {
        if !self.rmse.is_finite() {
            return false;
        }
        self.predict_window(history, w, current)
            .is_some_and(|pred| {
                let limit = (s.spike_sigmas * self.rmse).max(s.spike_floor);
                (y - pred).abs() > limit
            })
    }

    /// Validates one sample, substitutes it when rejected and writes it
    /// into ring slot `slot` (the pack then pushes `stored`, the current of
    /// that slot: the measured one when plausible, else the last one).
    /// Counts it. The window is read before the slot is written.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn accept<const MEM: usize, const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        history: &CurrentHistory<T, N>,
        work: &mut WorkingArea<T, N, MEM>,
        stored: Option<T>,
        current: T,
        voltage: T,
    ) -> Option<Rejection> {
        let w = &mut work.pw;
        self.counts.samples += 1;
        let rejected = self.classify(s, history, w, current, voltage);
        if let (Some(m), None) = (&s.ocv, rejected) {
            let rest = current.abs() <= m.capacity_ah / T::lit(100.0);
            match (self.soc, self.rest_start) {
                (None, _) => {
                    // The first good sample with a curve and no SOC given:
                    // the cell is taken to be at rest, its voltage the OCV.
                    let soc0 = m.table.soc_from_ocv(voltage);
                    self.soc = Some(soc0);
                    self.rest_start = rest.then_some((1, voltage, soc0));
                    // The observer starts where the count does.
                    self.soc_observer.set_state_of_charge(soc0);
                }
                (Some(z), Some((n, sum, soc0))) if rest && n < REST_SAMPLES => {
                    // Still at rest: the start SOC from the mean of the
                    // rested voltages so far (as `OcvModel::soc_at_rest`
                    // reads a record), the charge since kept.
                    let sum = sum + voltage;
                    let better = m.table.soc_from_ocv(sum / T::lit(f64::from(n + 1)));
                    self.soc = Some(z + (better - soc0));
                    self.rest_start = Some((n + 1, sum, better));
                    self.soc_observer.set_state_of_charge(z + (better - soc0));
                }
                _ => self.rest_start = None,
            }
        }
        let sample = match (rejected, stored) {
            (None, Some(i)) => {
                // Not the `y` that `classify` judged: at a rested start the
                // SOC was just refined from this very sample.
                let y = self.to_window(s, i, voltage);
                if self.spikes_in_row >= s.max_consecutive_spikes
                    && self.is_spike(s, history, w, i, y)
                {
                    // A step believed after max_consecutive_spikes
                    // rejections (a recalibrated sensor, a contactor): the
                    // samples before it belong to another regime, which no
                    // model of the window can fit across the step. The
                    // window restarts here; the estimate is kept, but no
                    // sample is judged by it until it has been refitted.
                    self.clear_window();
                    self.rmse = T::infinity();
                }
                self.spikes_in_row = 0;
                let two = {
                    let mut last = self.view(history).newest_first();
                    (last.next(), last.next())
                };
                if let (Some(prev), Some((before, _))) = two {
                    self.observe_step(s.battery.min_current_std, before, prev, i, y);
                }
                Some((i, y))
            }
            (why, stored) => {
                match why {
                    Some(Rejection::NonFinite) => self.counts.non_finite += 1,
                    Some(Rejection::OutOfRange) => self.counts.out_of_range += 1,
                    Some(Rejection::Spike) => {
                        self.counts.spikes += 1;
                        self.spikes_in_row = self.spikes_in_row.saturating_add(1);
                    }
                    // Accepted but nothing to store it with: cannot happen
                    // (an accepted sample has a plausible current).
                    None => {}
                }
                // Substitute. The current: the measured one when it is
                // itself plausible (only the voltage was bad), else the last
                // one (the pack's `stored`). The voltage: the model's
                // prediction for that current (or the last voltage before a
                // model exists). An empty window takes no substitute.
                let last = self.view(history).newest_first().next();
                match (stored, last) {
                    (Some(i), Some((_, u))) => {
                        Some((i, self.predict_window(history, w, i).unwrap_or(u)))
                    }
                    _ => None,
                }
            }
        };
        if let Some(m) = &s.ocv {
            // The observer counts the stored current (the count's) and
            // reads only an accepted voltage.
            let v = if rejected.is_none() {
                voltage
            } else {
                T::nan()
            };
            self.soc_observer
                .push(&s.soc, &m.table, stored.unwrap_or(T::nan()), v);
        }
        match sample {
            Some((i, u)) => {
                if stored.is_some() {
                    self.push_voltage(history, u);
                }
                if let Some(m) = &s.ocv {
                    // The charge of the sample as it entered the window (the
                    // substitute's current for a rejected one).
                    self.soc = self.soc_after(s, i);
                    self.ocv_now = self.soc.map(|z| m.table.ocv(z));
                }
            }
            None => {
                // Nothing stored for this cell while the pack stores a
                // current: the window restarts after the gap.
                if stored.is_some() && self.len > 0 {
                    self.clear_window();
                }
            }
        }
        self.last_rejection = rejected;
        rejected
    }
}
