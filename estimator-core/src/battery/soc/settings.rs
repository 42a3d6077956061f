//! The SOC observer's settings ([`SocSettings`]): what it assumes about
//! the sensors, the cell and its rests, their defaults and their check.
//! Owns no state; the observer's is [`super::SocObserver`]'s.

use crate::error::Error;
use crate::real::Real;

/// What the observer assumes about the sensors, the cell and its rests.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SocSettings<T> {
    /// The nominal capacity (A·h): the count's scale and the capacity's
    /// prior.
    pub capacity_ah: T,
    /// Sample period (s).
    pub h: T,
    /// A sample is rested when its current, less the estimated bias, is at
    /// most this (A). Default C/50.
    pub rest_current_a: T,
    /// The shortest rest that gives an observation (s). Default 600.
    pub rest_s: T,
    /// A rest this long gives its observation without waiting for its end
    /// (s). Default 3600.
    pub rest_max_s: T,
    /// The spread of a rested voltage as the OCV (V): the table's error and
    /// the polarization left after [`SocSettings::rest_s`]. Default 5 mV.
    pub voltage_sigma_v: T,
    /// The spread of a voltage read at once, not yet relaxed (V). Default
    /// 30 mV.
    pub unrelaxed_sigma_v: T,
    /// The spread of the curve itself in SOC (its test's error, hysteresis,
    /// temperature), added to every observation's: where the curve is
    /// steep a rest reads no better than this. Default 0.01.
    pub table_sigma_soc: T,
    /// The spread of a start SOC (given, or read from the first voltage).
    /// Default 0.1. A spread beyond four times an unrelaxed reading's
    /// (a start given loosely, a gap) has the next rest read early.
    pub soc0_sigma: T,
    /// The prior spread of the current sensor's bias (A). Default C/50.
    pub bias_sigma_a: T,
    /// How far the bias may wander in an hour (A). Default C/1000.
    pub bias_walk_a: T,
    /// The spread of the true current in a rest (A): a quiescent load the
    /// sensor cannot tell from its own bias. Each rest's mean current
    /// observes the bias with this spread (a rested cell carries no
    /// current, so what the sensor reads there is its bias). Default
    /// C/1000.
    pub rest_load_sigma_a: T,
    /// The prior spread of the capacity, relative. Default 0.15.
    pub capacity_sigma: T,
    /// The capacity is published as identified when its standard deviation
    /// is at most this fraction of it. Default 0.02.
    pub capacity_identify: T,
    /// The capacity is identified only once two rests linked by the count
    /// have also read SOCs at least this far apart through the curve
    /// ([`super`]'s module docs); 0: no span asked. Default 0.3.
    pub capacity_min_span: T,
    /// The spread added to the SOC by a gap of unknown charge. Default 0.5.
    pub gap_soc_sigma: T,
    /// The smallest slope `|OCV'|` (V per unit SOC) an observation is
    /// weighed with; a flatter curve counts as this flat. Default 10⁻³.
    pub min_slope: T,
}

impl<T: Real> SocSettings<T> {
    /// The defaults for a cell of nominal capacity `capacity_ah` (A·h)
    /// sampled every `h` seconds.
    pub fn new(capacity_ah: T, h: T) -> Self {
        Self {
            capacity_ah,
            h,
            rest_current_a: capacity_ah / T::lit(50.0),
            rest_s: T::lit(600.0),
            rest_max_s: T::lit(3600.0),
            voltage_sigma_v: T::lit(0.005),
            unrelaxed_sigma_v: T::lit(0.03),
            table_sigma_soc: T::lit(0.01),
            soc0_sigma: T::lit(0.1),
            bias_sigma_a: capacity_ah / T::lit(50.0),
            bias_walk_a: capacity_ah / T::lit(1000.0),
            rest_load_sigma_a: capacity_ah / T::lit(1000.0),
            capacity_sigma: T::lit(0.15),
            capacity_identify: T::lit(0.02),
            capacity_min_span: T::lit(0.3),
            gap_soc_sigma: T::lit(0.5),
            min_slope: T::lit(1e-3),
        }
    }

    /// Checks the settings: every one finite, the capacity, the period and
    /// the smallest slope positive, the rest not negative, the span asked
    /// of the rests ([`SocSettings::capacity_min_span`]) at most 1, and the
    /// capacity's square finite (the bias's variance is capped at it, and
    /// the capacity estimate is up to five times the nominal).
    ///
    /// # Errors
    /// [`Error::BadSetting`] otherwise.
    pub fn check(&self) -> Result<(), Error> {
        let all = [
            self.capacity_ah,
            self.h,
            self.rest_current_a,
            self.rest_s,
            self.rest_max_s,
            self.voltage_sigma_v,
            self.unrelaxed_sigma_v,
            self.table_sigma_soc,
            self.soc0_sigma,
            self.bias_sigma_a,
            self.bias_walk_a,
            self.rest_load_sigma_a,
            self.capacity_sigma,
            self.capacity_identify,
            self.capacity_min_span,
            self.gap_soc_sigma,
            self.min_slope,
        ];
        let positive = [self.capacity_ah, self.h, self.min_slope];
        if all.iter().all(|x| x.is_finite() && *x >= T::ZERO)
            && positive.iter().all(|x| *x > T::ZERO)
            && self.capacity_min_span <= T::ONE
            && (self.capacity_ah * self.capacity_ah).is_finite()
        {
            Ok(())
        } else {
            Err(Error::BadSetting)
        }
    }

    /// The largest variances the filter keeps, `(SOC, bias, g)`: what
    /// knowing nothing means (the SOC anywhere in `±1`, the bias up to 1C,
    /// the capacity anywhere from a fifth to five times the nominal). A
    /// wider spread says no more, and in `f32` the count's products of it
    /// would overflow.
    pub(super) fn variance_caps(&self) -> [T; 3] {
        [T::ONE, self.capacity_ah * self.capacity_ah, T::ONE]
    }
}
