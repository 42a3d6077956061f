//! The C state of power: what a request asks (`FracbmsPowerRequest`) and
//! what it answers (`FracbmsPower`, one `FracbmsHorizonPower` per
//! horizon), and their conversion to and from the core's. This module owns
//! that mapping; it must not hold state.

use estimator_core::battery::power::{samples, PowerLimits, PowerReport, PowerSettings};

/// The most horizons one state-of-power request asks for (the core's
/// `MAX_HORIZONS`).
pub const FRACBMS_HORIZONS_MAX: usize = 8;
const _: () = assert!(FRACBMS_HORIZONS_MAX == estimator_core::battery::power::MAX_HORIZONS);

/// What a state-of-power request asks (`fracbms_cell_state_of_power`,
/// `fracbms_pack_state_of_power`): as `host-sim online battery`'s
/// `--voltage-min`, `--voltage-max`, `--current-limit`, `--horizons` and
/// `--pulse-current-a`. Currents positive when charging.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FracbmsPowerRequest {
    /// The lowest terminal voltage a pulse may reach (V).
    pub voltage_min: f32,
    /// The highest (V).
    pub voltage_max: f32,
    /// The largest current magnitude (A).
    pub current_limit: f32,
    /// The horizons (s), the first `horizon_count` used; each is `H/h`
    /// samples, rounded (at least 1; so is `carry_s`), and at most 3 600
    /// samples (the core's `MAX_HORIZON_STEPS`: an hour at 1 s).
    pub horizons_s: [f32; FRACBMS_HORIZONS_MAX],
    /// Horizons used (1 to `FRACBMS_HORIZONS_MAX`).
    pub horizon_count: u32,
    /// The current (A) of the pulse whose voltage is predicted at each
    /// horizon's end; NaN for none.
    pub pulse_current: f32,
    /// How long (s) the prediction may be carried from the last fit
    /// without a new one (`--sop-carry-s`); NaN: as far as the window
    /// reaches. After a rest the SOC observer reads (its `rest_s`), the
    /// pulse is predicted from rest whatever this says.
    pub carry_s: f32,
    /// How many standard deviations of the pulse voltage
    /// (`FracbmsHorizonPower::uncertainty_v`) the limit currents keep
    /// inside the voltage limits at each horizon's end
    /// (`--sop-confidence`); NaN: the default, 2. 0 derates nothing.
    pub confidence: f32,
}

/// One horizon's state of power, as `host-sim online battery`'s
/// `sop_discharge_a_{H}s`, `sop_charge_a_{H}s`, `pulse_v_{H}s`,
/// `sop_uncertainty_v_{H}s` and `pulse_ratio_{H}s`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FracbmsHorizonPower {
    /// The horizon (s) as asked.
    pub horizon_s: f32,
    /// The largest constant discharge current magnitude (A) that keeps
    /// the predicted voltage at or above the minimum for the horizon.
    pub discharge_a: f32,
    /// The same for charge and the maximum.
    pub charge_a: f32,
    /// The predicted voltage (V) at the end of the request's pulse (NaN
    /// without one); for a pack's string, the sum of its cells'.
    pub pulse_v: f32,
    /// The pulse voltage's standard deviation (V) from the spread of the
    /// parameters it was predicted with, the fit's RMSE and what the last
    /// pulse missed its prediction by, as `host-sim online battery`'s
    /// `sop_uncertainty_v_{H}s` (NaN without a pulse).
    pub uncertainty_v: f32,
    /// The measured over predicted drop of the last pulse of the same
    /// current that `pulse_v` was corrected by
    /// (`FracbmsSettings::pulse_current`), as the track's
    /// `pulse_ratio_{H}s`; NaN: the model's own prediction.
    pub pulse_ratio: f32,
}

/// A state of power: `published` false (and the horizons zero) before
/// every parameter has been published once, or where the cell has no
/// present polarization (carried from a fit, or at rest) yet.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FracbmsPower {
    /// Whether the horizons hold a state of power.
    pub published: bool,
    /// Horizons filled.
    pub horizon_count: u32,
    /// Each horizon's, in the request's order.
    pub horizons: [FracbmsHorizonPower; FRACBMS_HORIZONS_MAX],
    /// Where the parameters it was predicted with came from, as `host-sim
    /// online battery`'s `sop_basis`: 0 `window` (identified by the last
    /// window), 1 `map` (the prior), 2 `held` (an earlier window within
    /// the hold span, or a snapshot), 3 `stale` (the last value, identified
    /// further away). 0 where nothing is published.
    pub basis: u32,
    /// The pulse voltage's standard deviation (V) at the longest horizon
    /// asked, as `host-sim online battery`'s `sop_uncertainty_v` (that
    /// horizon's `FracbmsHorizonPower::uncertainty_v`); NaN without a
    /// pulse, 0 where nothing is published.
    pub uncertainty_v: f32,
}

impl FracbmsPowerRequest {
    /// The core's settings for sample period `h` (s); `None` for a request
    /// the core refuses (limits not finite and ordered, no horizon or too
    /// many, a horizon that is not positive or past `MAX_HORIZON_STEPS`
    /// samples).
    pub(crate) fn settings(&self, h: f32) -> Option<PowerSettings<f32>> {
        let n = usize::try_from(self.horizon_count).ok()?;
        let horizons = self.horizons_s.get(..n)?;
        let limits = PowerLimits {
            voltage_min: self.voltage_min,
            voltage_max: self.voltage_max,
            current_limit: self.current_limit,
        };
        let pulse = (!self.pulse_current.is_nan()).then_some(self.pulse_current);
        // Each horizon rounded to the nearest sample, as the CLI's.
        let mut p = PowerSettings::from_seconds(limits, horizons, h, pulse)?;
        if !self.carry_s.is_nan() {
            p.carry = Some(samples(self.carry_s, h)?);
        }
        if !self.confidence.is_nan() {
            if !(self.confidence.is_finite() && self.confidence >= 0.0) {
                return None;
            }
            p.confidence = self.confidence;
        }
        Some(p)
    }

    /// The answer to this request: `report`'s horizons, or none.
    pub(crate) fn answer(&self, report: Option<PowerReport<f32>>) -> FracbmsPower {
        let mut out = FracbmsPower::default();
        if let Some(r) = report {
            out.published = true;
            out.horizon_count = r.horizons().len() as u32;
            out.basis = u32::from(r.basis().code());
            out.uncertainty_v = f32::NAN;
            let mut longest = f32::NEG_INFINITY;
            for ((o, h), &hz) in out
                .horizons
                .iter_mut()
                .zip(r.horizons())
                .zip(&self.horizons_s)
            {
                *o = FracbmsHorizonPower {
                    horizon_s: hz,
                    discharge_a: h.sop.discharge_a,
                    charge_a: h.sop.charge_a,
                    pulse_v: h.pulse_v.unwrap_or(f32::NAN),
                    uncertainty_v: h.uncertainty_v.unwrap_or(f32::NAN),
                    pulse_ratio: h.pulse_ratio.unwrap_or(f32::NAN),
                };
                // The longest horizon's, as the track's
                // `sop_uncertainty_v` (equal horizons give equal values).
                if hz > longest {
                    longest = hz;
                    out.uncertainty_v = o.uncertainty_v;
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request(horizons: &[f32]) -> FracbmsPowerRequest {
        let mut horizons_s = [0.0; FRACBMS_HORIZONS_MAX];
        horizons_s[..horizons.len()].copy_from_slice(horizons);
        FracbmsPowerRequest {
            voltage_min: 3.0,
            voltage_max: 4.2,
            current_limit: 50.0,
            horizons_s,
            horizon_count: horizons.len() as u32,
            pulse_current: f32::NAN,
            carry_s: f32::NAN,
            confidence: f32::NAN,
        }
    }

    /// Each horizon and the carry are counted in samples as the CLI counts
    /// them (the core's `PowerSettings::from_seconds`), and a request the
    /// core cannot take is refused.
    #[test]
    fn a_request_in_seconds_is_counted_in_samples_or_refused() {
        let p = request(&[2.0, 10.0, 30.0]).settings(1.8).unwrap();
        assert_eq!(p.horizons(), [1, 6, 17]);
        assert_eq!(p.carry, None);
        let mut r = request(&[10.0]);
        r.carry_s = 601.0;
        assert_eq!(r.settings(2.0).unwrap().carry, Some(301));
        // (7 202 s at 2 s: 3 601 samples, one past the longest.)
        assert!(request(&[7200.0]).settings(2.0).is_some());
        for bad in [0.0, -10.0, f32::NAN, f32::INFINITY, 7202.0, 1e30] {
            assert!(
                request(&[10.0, bad]).settings(2.0).is_none(),
                "horizon {bad}"
            );
        }
        for bad in [-1.0, f32::INFINITY] {
            let mut r = request(&[10.0]);
            r.carry_s = bad;
            assert!(r.settings(2.0).is_none(), "carry {bad}");
        }
        assert!(request(&[10.0]).settings(0.0).is_none());
    }
}
