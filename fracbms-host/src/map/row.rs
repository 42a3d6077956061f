//! A parameter map's row, its columns and the options of its split: plain
//! data, shared with the JSON of `identify battery` (which must not
//! depend on how a map is built).

use crate::trust::Confidence;
use estimator_core::battery::CellParameters;
use serde::{Deserialize, Serialize};

/// How a record is split into SOC levels.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MapOptions {
    /// Split at the rests of at least this long (s) between pulse groups.
    pub min_rest_s: f64,
    /// Or split the counted SOC range into this many equal bins (a record
    /// without rests: a drive cycle).
    pub soc_bins: Option<usize>,
    /// The temperature of the record (°C); default: the mean of its
    /// temperature column over the record (to 0.1 °C), or unknown.
    pub temperature_c: Option<f64>,
    /// Seconds of the rest before a level's pulses that its part starts
    /// with (the model starts from rest there).
    pub lead_s: f64,
    /// The most samples a level is fitted on: a level is put on its own
    /// period from the log's rows (the median step there, raised to keep
    /// within this), finer than the whole record's where the log is.
    pub level_samples: usize,
    /// How the map is fitted: `levels` (each level on its own) or `joint`
    /// (every knot together over the whole record).
    pub method: MapMethod,
    /// The joint fit's knots (SOCs); default: the levels' SOCs, runs within
    /// 0.03 of SOC one knot at their mean
    /// ([`crate::identify::map::level_knots`]).
    pub knots: Option<Vec<f64>>,
    /// The joint fit's smoothing penalty λ (V²); default: chosen by
    /// leaving levels out.
    pub smoothing: Option<f64>,
    /// Which of `r_i, r_ct, tau, alpha, du` vary with SOC in the joint
    /// fit; default: chosen by leaving levels out.
    pub vary: Option<[bool; 5]>,
}

/// How a map is fitted (`--map-method`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MapMethod {
    /// Each level fitted on its own stretch.
    Levels,
    /// The default: every knot fitted together over the whole record,
    /// smooth in SOC (it predicts records it was not fitted on better,
    /// and serves as the online prior as well; docs/maps.md).
    #[default]
    Joint,
}

impl Default for MapOptions {
    fn default() -> Self {
        MapOptions {
            min_rest_s: 600.0,
            soc_bins: None,
            temperature_c: None,
            lead_s: 60.0,
            level_samples: 8192,
            method: MapMethod::Joint,
            knots: None,
            smoothing: None,
            vary: None,
        }
    }
}

/// One level of a map: where it is and what was fitted there.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MapRow {
    /// Temperature (°C), if known.
    pub temperature_c: Option<f64>,
    /// SOC where the level's pulses start.
    pub soc: f64,
    /// R_i (Ω).
    pub r_i: f64,
    /// R_ct (Ω).
    pub r_ct: f64,
    /// Q (F·s^(α−1)).
    pub q: f64,
    /// α.
    pub alpha: f64,
    /// Butler–Volmer a (V), null for a linear level.
    pub bv_a_v: Option<f64>,
    /// Butler–Volmer i₀ (A), null for a linear level.
    pub bv_i0_a: Option<f64>,
    /// The offset ΔU the level's model adds to OCV(SOC) (V).
    pub ocv_offset_v: f64,
    /// The level's free-run RMSE over its part (V).
    pub rmse_v: f64,
    /// The level's fit can be trusted (docs/trust.md).
    pub identifiable: bool,
    /// Why not (null when identifiable).
    #[serde(default)]
    pub identifiable_reason: Option<String>,
    /// 95 % intervals (null when the information matrix is singular); the
    /// Butler–Volmer term's with it (a joint map's: the shared term's, in
    /// every row).
    #[serde(default)]
    pub confidence: Option<Confidence>,
    /// The part's first sample's time (s).
    pub start_s: f64,
    /// Its last sample's time (s).
    pub end_s: f64,
    /// Its samples.
    pub samples: usize,
}

impl MapRow {
    /// The level's cell, its `u_oc` the offset ΔU.
    pub fn cell(&self) -> CellParameters<f64> {
        CellParameters {
            r_i: self.r_i,
            r_ct: self.r_ct,
            q: self.q,
            alpha: self.alpha,
            u_oc: self.ocv_offset_v,
            bv_a: self.bv_a_v.unwrap_or(0.0),
            bv_i0: self.bv_i0_a.unwrap_or(1.0),
        }
    }
}

/// The map in the JSON of `identify battery`.
#[derive(Serialize, Debug, Clone)]
pub struct MapJson {
    /// One per SOC level, as the map's CSV rows (with the reasons).
    pub levels: Vec<MapRow>,
    /// Levels that could not be fitted, and why.
    pub skipped: Vec<String>,
    /// The map model's RMSE over the whole record (V), over the log's own
    /// samples (not those made up inside gaps).
    pub map_rmse_v: f64,
    /// The single fit's RMSE over the same samples (V).
    pub single_rmse_v: f64,
    /// The joint fit's candidates (`--map-method joint`): per candidate
    /// `smoothing`, `vary`, `rmse_v`, `left_out_rmse_v` (each level left
    /// out, predicted) and `iterations`; the map is the one with the least
    /// `left_out_rmse_v`. Empty for the per-level fits.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub joint: Vec<JointCandidate>,
}

/// The five parameters of a joint map's knot, in the order of its
/// unknowns (`--map-vary` names them).
pub const JOINT_PARAMETERS: [&str; 5] = ["r_i", "r_ct", "tau", "alpha", "du"];

/// What the joint map fit (`crate::identify::map::joint::choose`) tried: per candidate its penalty, varying set, fit
/// RMSE and the RMSE of the folds left out (over all their samples).
#[derive(Clone, Debug)]
pub struct JointCandidate {
    /// λ (V²).
    pub smoothing: f64,
    /// The varying set.
    pub vary: [bool; 5],
    /// RMSE over every counted sample (V).
    pub rmse_v: f64,
    /// RMSE of the folds' samples predicted with each fold left out (V).
    pub left_out_rmse_v: f64,
    /// Levenberg–Marquardt iterations run.
    pub iterations: usize,
}

impl serde::Serialize for JointCandidate {
    fn serialize<S: serde::Serializer>(&self, s: S) -> core::result::Result<S::Ok, S::Error> {
        let vary: Vec<&str> = (0..5)
            .filter(|&i| self.vary[i])
            .map(|i| JOINT_PARAMETERS[i])
            .collect();
        serde_json::json!({
            "smoothing": self.smoothing,
            "vary": vary,
            "rmse_v": self.rmse_v,
            "left_out_rmse_v": self.left_out_rmse_v,
            "iterations": self.iterations,
        })
        .serialize(s)
    }
}
