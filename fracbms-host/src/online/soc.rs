//! The state-of-charge columns of a track (issue 36): `soc` (the published
//! value), `soc_coulomb`, `current_bias_a`, `capacity_ah`, `soc_sigma`,
//! `soc_ocv_weight` (and `capacity_sigma_ah`), from the core's observer in each cell's state
//! ([`estimator_core::battery::soc`]).
//!
//! Owns the choice between the observer and plain counting (`--soc`) and
//! the observer's settings from the flags; the observer is the core's.

use crate::bail;
use crate::error::Result;
use estimator_core::battery::soc::{SocEstimate, SocSettings};
use estimator_core::Real;
use serde::{Deserialize, Serialize};

/// What the track publishes as `soc`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SocMode {
    /// The observer: the count corrected at rest by the OCV curve, with
    /// the current bias and the capacity estimated (the default with a
    /// curve).
    #[default]
    Observer,
    /// Plain coulomb counting from the start SOC (the estimator's own).
    Coulomb,
}

impl SocMode {
    /// `"observer"` or `"coulomb"`.
    pub fn as_str(self) -> &'static str {
        match self {
            SocMode::Observer => "observer",
            SocMode::Coulomb => "coulomb",
        }
    }
}

/// How the SOC is published, as `online battery`'s flags give it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SocOptions {
    /// Observer or plain counting.
    pub mode: SocMode,
    /// The shortest rest that corrects the SOC (s; default 600).
    pub rest_s: Option<f64>,
    /// The prior spread of the current sensor's bias (A; default C/50;
    /// 0: a calibrated sensor, no bias estimated).
    pub bias_sigma_a: Option<f64>,
    /// The spread of the load a rest carries (A; default C/1000): how
    /// closely a rest's mean measured current reads the bias. A pack with
    /// a quiescent draw it does not know sets it larger.
    pub rest_load_sigma_a: Option<f64>,
    /// The spread of a rested voltage as the OCV (V; default 5 mV): the
    /// table's own error in volts (its test, hysteresis, temperature) and
    /// the polarization a rest of `rest_s` still holds. On a flat curve it
    /// sets how little a rest weighs (docs/soc-observer.md).
    pub voltage_sigma_v: Option<f64>,
    /// The SOC span (0 to 1) two rests linked by the count must read
    /// before the capacity is identified (default 0.3; 0: none asked).
    pub capacity_min_span: Option<f64>,
}

impl Default for SocOptions {
    fn default() -> Self {
        Self {
            mode: SocMode::Observer,
            rest_s: None,
            bias_sigma_a: None,
            rest_load_sigma_a: None,
            voltage_sigma_v: None,
            capacity_min_span: None,
        }
    }
}

impl SocOptions {
    /// Sets the observer's settings `s` (the core's defaults for the
    /// curve's capacity) as the flags say.
    ///
    /// # Errors
    /// A rest that is not finite and positive, a spread that is not finite
    /// and not negative, a span outside `[0, 1]`.
    pub(crate) fn apply<T: Real>(&self, s: &mut SocSettings<T>) -> Result<()> {
        if let Some(r) = self.rest_s {
            if !(r.is_finite() && r > 0.0) {
                bail!(Options, "--soc-rest-s {r}: must be finite and positive");
            }
            s.rest_s = T::lit(r);
            s.rest_max_s = s.rest_max_s.max(T::lit(r));
        }
        if let Some(b) = spread("--soc-bias-sigma-a", self.bias_sigma_a)? {
            s.bias_sigma_a = T::lit(b);
            if b == 0.0 {
                s.bias_walk_a = T::ZERO;
            }
        }
        if let Some(l) = spread("--soc-rest-load-sigma-a", self.rest_load_sigma_a)? {
            s.rest_load_sigma_a = T::lit(l);
        }
        if let Some(v) = spread("--soc-voltage-sigma-v", self.voltage_sigma_v)? {
            s.voltage_sigma_v = T::lit(v);
        }
        if let Some(z) = self.capacity_min_span {
            if !(0.0..=1.0).contains(&z) {
                bail!(
                    Options,
                    "--capacity-min-span {z}: must be a fraction of SOC in [0, 1]"
                );
            }
            s.capacity_min_span = T::lit(z);
        }
        Ok(())
    }
}

/// A spread flag's value, refused unless finite and not negative.
fn spread(flag: &str, x: Option<f64>) -> Result<Option<f64>> {
    match x {
        Some(v) if !(v.is_finite() && v >= 0.0) => {
            bail!(Options, "{flag} {v}: must be finite and not negative")
        }
        _ => Ok(x),
    }
}

/// The SOC columns of one track row.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SocRow {
    /// The estimator's own count (`soc_coulomb`).
    pub coulomb: Option<f64>,
    /// The observer's estimate (none with `--soc coulomb`).
    pub observer: Option<SocEstimate<f64>>,
}

impl SocRow {
    /// The row as `mode` publishes it: with [`SocMode::Coulomb`] no
    /// observer.
    pub(crate) fn in_mode(self, mode: SocMode) -> Self {
        match mode {
            SocMode::Observer => self,
            SocMode::Coulomb => Self {
                observer: None,
                ..self
            },
        }
    }

    /// The published SOC: the observer's, else the count.
    pub fn published(&self) -> Option<f64> {
        self.observer.map(|e| e.soc).or(self.coulomb)
    }

    /// The columns after the track's `soc` ([`super::schema::TRACK_COLUMNS`]), in
    /// [`SOC_HEADER`]'s order.
    pub fn columns(&self) -> [Option<f64>; 6] {
        let e = self.observer;
        [
            self.coulomb,
            e.map(|e| e.current_bias_a),
            e.map(|e| e.capacity_ah),
            e.map(|e| e.capacity_sigma_ah),
            e.map(|e| e.sigma),
            e.map(|e| e.ocv_weight),
        ]
    }
}

impl SocRow {
    /// `capacity_status`: `identified` or `not_identified` (the capacity
    /// published is then the last identified, or the nominal), empty
    /// without the observer.
    pub fn capacity_status(&self) -> &'static str {
        match self.observer {
            Some(e) if e.capacity_identified => "identified",
            Some(_) => "not_identified",
            None => "",
        }
    }
}

/// The SOC columns the track carries after the estimator's (empty without
/// an OCV curve; all but `soc_coulomb` empty with `--soc coulomb`).
pub const SOC_HEADER: [&str; 6] = [
    "soc_coulomb",
    "current_bias_a",
    "capacity_ah",
    "capacity_sigma_ah",
    "soc_sigma",
    "soc_ocv_weight",
];
