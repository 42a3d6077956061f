//! The pack's part in checking each cell's state of power against the
//! pulse that follows ([`PulseCheck`](crate::battery::power::PulseCheck)):
//! the voltages a clean step's pulse is predicted with, and for a pulse
//! that nothing predicts yet, whether to keep its drops and the first
//! model's drops for it from rest. The check itself is
//! [`crate::battery::power`]'s; this must not change what a cell
//! publishes.

use super::PackEstimator;
use crate::battery::power::{same_pulse, settled, PulsePredictor, CHECK_STEPS};
use crate::battery::tracker::OnlineSettings;
use crate::real::Real;

impl<T: Real, const N: usize, const MEM: usize, const CELLS: usize>
    PackEstimator<T, N, MEM, CELLS>
{
    /// The voltages cell `k`'s state of power predicts for a pulse of
    /// `current` (A) at each of [`CHECK_STEPS`], from the set it would be
    /// asked with now ([`state_of_power`](Self::state_of_power)) and the
    /// polarization carried as far as the window reaches (the state of
    /// power's default carry), at the step's own current (no cap of a
    /// Butler–Volmer term's currents); `None` when it has none. With a
    /// watched pulse current ([`OnlineSettings::pulse_current`]), also
    /// whether the cell is settled (its drift at no current small beside
    /// the pulse, [`settled`]; without one, `false`: no ratio is kept).
    pub(super) fn check_predictions<const P: usize>(
        &self,
        k: usize,
        s: &OnlineSettings<T, P>,
        current: T,
    ) -> Option<([T; CHECK_STEPS.len()], bool)> {
        let (q, _) = self.cell(k)?.sop_parameters(s)?;
        let pred = self.predictor_within(k, s, None, Some(&q))?;
        let predicted = pred.pulse_voltages(current, &CHECK_STEPS);
        let settled = s.pulse_current.is_some()
            && settled(
                pred.pulse_voltage(T::zero(), 0),
                &predicted,
                &pred.pulse_voltages(T::zero(), &CHECK_STEPS),
            );
        Some((predicted, settled))
    }

    /// Whether a pulse of `current` (A) on cell `k` is one to measure for
    /// the first model ([`PulseCheck::start_unpredicted`]): at the watched
    /// current ([`OnlineSettings::pulse_current`]), from a relaxed cell
    /// ([`CellState::relaxed_voltage`]), with no parameter set to predict
    /// it from yet (no estimate, no prior).
    pub(super) fn unpredicted_from_rest<const P: usize>(
        &self,
        k: usize,
        s: &OnlineSettings<T, P>,
        current: T,
    ) -> bool {
        let Some(c) = self.cell(k) else {
            return false;
        };
        s.pulse_current.is_some_and(|w| same_pulse(w, current))
            && c.sop_parameters(s).is_none()
            && c.relaxed_voltage(s).is_some()
    }

    /// Cell `k`'s model's drops for a pulse of `current` (A) from rest at
    /// each of [`CHECK_STEPS`] (its voltage at no current less the
    /// pulse's), with the set its state of power would be asked with now
    /// ([`CellState::sop_parameters`]); with a curve, at the state of
    /// charge now. `None` without a set.
    pub(super) fn drops_from_rest<const P: usize>(
        &self,
        k: usize,
        s: &OnlineSettings<T, P>,
        current: T,
    ) -> Option<[T; CHECK_STEPS.len()]> {
        let c = self.cell(k)?;
        let (q, _) = c.sop_parameters(s)?;
        let w = self.weights_at(&q, s)?;
        let ocv = match (&s.ocv, c.state_of_charge()) {
            (Some(m), Some(z)) => Some((m, z)),
            _ => None,
        };
        let pred = PulsePredictor::new(&q, &w, &[], ocv)?;
        let rest = pred.pulse_voltages(T::zero(), &CHECK_STEPS);
        let loaded = pred.pulse_voltages(current, &CHECK_STEPS);
        Some(core::array::from_fn(|j| rest[j] - loaded[j]))
    }
}
