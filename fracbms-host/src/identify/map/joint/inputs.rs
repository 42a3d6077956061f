//! What a joint fit was given and what it chose, written for an
//! independent fit of the same objective (`bench/joint_reference.py`).
//!
//! It owns [`JointInputs`] and its files; it must not fit.

use super::{
    knot, unknowns, JointData, JointFit, Layout, BOUNDS, KINETIC_BOUNDS, PARAMETERS, PULL, SCALE,
};
use crate::err;
use crate::error::Result;
use crate::io::BatteryRecord;

/// What a joint fit was given and what it chose, for an independent fit
/// of the same objective (`identify battery --map-method joint
/// --levels-out DIR` writes it as `joint-record.csv` and `joint.json`;
/// `bench/joint_reference.py` fits it with scipy).
#[derive(Clone, Debug)]
pub struct JointInputs {
    /// The record the fit ran on.
    pub record: BatteryRecord,
    /// The counted SOC after each sample.
    pub soc: Vec<f64>,
    /// The OCV at that SOC (V).
    pub ocv_v: Vec<f64>,
    /// Which samples the fit counts.
    pub counted: Vec<bool>,
    /// The knots' SOCs.
    pub knots: Vec<f64>,
    /// Each knot's start `[ln R_i, ln R_ct, ln τ, α, ΔU]` (the pull's
    /// centre; a shared parameter's the knots' mean), as the fit took it.
    pub start: Vec<[f64; 5]>,
    /// The chosen candidate's penalty (V²).
    pub smoothing: f64,
    /// The chosen candidate's varying set.
    pub vary: [bool; 5],
    /// The chosen fit's knots `[ln R_i, ln R_ct, ln τ, α, ΔU]`.
    pub fitted: Vec<[f64; 5]>,
    /// The chosen fit's RMSE over the counted samples (V).
    pub rmse_v: f64,
    /// The Butler–Volmer term `[a, i₀]` the knots share, fitted (none:
    /// the linear model).
    pub butler_volmer: Option<[f64; 2]>,
    /// The term's start `[a, i₀]`, the pull's centre.
    pub butler_volmer_start: Option<[f64; 2]>,
}

impl JointInputs {
    /// The inputs of `d` and the chosen `fit` (its start the pull's
    /// centre).
    pub fn of(d: &JointData<'_>, fit: &JointFit) -> Self {
        let l = Layout::new(
            fit.vary,
            d.knots.len(),
            fit.start.iter().all(|c| c.is_butler_volmer()),
        );
        let theta = unknowns(&fit.start, &l);
        JointInputs {
            record: d.record.clone(),
            soc: d.soc.to_vec(),
            ocv_v: d.soc.iter().map(|&z| d.ocv.model.table.ocv(z)).collect(),
            counted: d.counted.to_vec(),
            knots: d.knots.to_vec(),
            start: (0..d.knots.len()).map(|j| knot(&theta, &l, j)).collect(),
            smoothing: fit.smoothing,
            vary: fit.vary,
            fitted: (0..d.knots.len())
                .map(|j| knot(&fit.theta, &l, j))
                .collect(),
            rmse_v: fit.rmse_v,
            butler_volmer: l.kinetic_of(&fit.theta).map(|(a, i0)| [a, i0]),
            butler_volmer_start: l.kinetic_of(&theta).map(|(a, i0)| [a, i0]),
        }
    }

    /// Writes `joint-record.csv` (`time_s,current_a,voltage_v,counted,soc,ocv_v`)
    /// and `joint.json` (the knots, the start and the fitted knots as
    /// `[ln R_i, ln R_ct, ln τ, α, ΔU]`, the penalty, the varying set, the
    /// scales and bounds of the unknowns, the pull's weight relative to the
    /// penalty's, the RMSE, and `butler_volmer` and `butler_volmer_start`:
    /// the shared term's fitted and start `[a, i₀]` or null, with
    /// `butler_volmer_bounds`, those of `[ln a, ln i₀]`) into `dir`.
    ///
    /// # Errors
    /// [`crate::ErrorKind::Io`] when a file cannot be written.
    pub fn write(&self, dir: &std::path::Path) -> Result<()> {
        let r = &self.record;
        crate::io::write_csv(
            &dir.join("joint-record.csv"),
            &[
                "time_s",
                "current_a",
                "voltage_v",
                "counted",
                "soc",
                "ocv_v",
            ],
            (0..r.time.len()).map(|k| {
                [
                    r.time[k].to_string(),
                    r.current[k].to_string(),
                    r.voltage[k].to_string(),
                    u8::from(self.counted[k]).to_string(),
                    self.soc[k].to_string(),
                    self.ocv_v[k].to_string(),
                ]
            }),
        )?;
        let doc = serde_json::json!({
            "h": r.h,
            "knots": self.knots,
            "parameters": PARAMETERS,
            "start": self.start,
            "fitted": self.fitted,
            "smoothing": self.smoothing,
            "vary": self.vary,
            "scale": SCALE,
            "bounds": BOUNDS,
            "pull": PULL,
            "rmse_v": self.rmse_v,
            "butler_volmer": self.butler_volmer,
            "butler_volmer_start": self.butler_volmer_start,
            "butler_volmer_bounds": KINETIC_BOUNDS,
        });
        let text = serde_json::to_string_pretty(&doc)
            .map_err(|e| err!(Io, "cannot write joint.json: {e}"))?;
        crate::io::write_atomic(&dir.join("joint.json"), |w| {
            w.write_all(text.as_bytes())
                .and_then(|_| w.write_all(b"\n"))
                .map_err(|e| err!(Io, "cannot write joint.json: {e}"))
        })
    }
}
