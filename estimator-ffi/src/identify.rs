//! Whole-record identification on the host, as a C call: the host
//! library's function (`fracbms-host`) that `host-sim identify battery`
//! calls too. This module owns the conversion of C arrays into the library's
//! record; it must not fit anything itself.

use std::ffi::c_char;
use std::path::Path;

use fracbms_host::identify::record::battery_arrays;
use fracbms_host::identify::{BatteryMethod, ModelRequest};
use fracbms_host::io::{self, Columns};
use fracbms_host::ocv::{OcvSpec, OcvSpecError};
use fracbms_host::ErrorKind;

use crate::types::{FracbmsCode, FracbmsMethod, FracbmsModel};

/// Options of `fracbms_identify_battery` (`fracbms_identify_options_default`
/// fills the CLI's defaults).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct FracbmsIdentifyOptions {
    /// Method, a `FracbmsMethod` (default refined).
    pub method: i32,
    /// Model, a `FracbmsModel` (default `FRACBMS_MODEL_AUTO`).
    pub model: i32,
    /// Iterations of 2S-OP-GI (default 50).
    pub iterations: u32,
    /// The OCV table's states of charge, or null without a table.
    pub ocv_soc: *const f64,
    /// The OCV table's voltages (V).
    pub ocv_v: *const f64,
    /// Points of the table (0: none).
    pub ocv_points: u32,
    /// Capacity (A·h), with a table.
    pub capacity_ah: f64,
    /// State of charge before the first row, with a table; NaN: read from
    /// the record's rested start (as the CLI without `--soc0`).
    pub soc0: f64,
    /// Per row, nonzero where its voltage was not measured (a cycler's
    /// unlogged step start: the current known, the voltage not), or null:
    /// every row measured. No fit counts an unobserved row.
    pub unobserved: *const u8,
}

/// The result of `fracbms_identify_battery`: the keys of
/// `host-sim identify battery --json`.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct FracbmsFit {
    /// `FRACBMS_MODEL_LINEAR` or `FRACBMS_MODEL_BUTLER_VOLMER`.
    pub model: FracbmsModel,
    /// `R_i` (Ω).
    pub r_i: f64,
    /// `R_ct` (Ω).
    pub r_ct: f64,
    /// `Q` (F·s^(α−1)).
    pub q: f64,
    /// α.
    pub alpha: f64,
    /// `U_oc` (V); with a table `OCV(soc_end) + ΔU`.
    pub u_oc: f64,
    /// Butler–Volmer `a` (V); NaN for the linear model.
    pub bv_a_v: f64,
    /// Butler–Volmer `i₀` (A); NaN for the linear model.
    pub bv_i0_a: f64,
    /// OCV offset `ΔU` (V); NaN without a table.
    pub ocv_offset_v: f64,
    /// SOC before the first row; NaN without a table.
    pub soc0: f64,
    /// SOC after the last row; NaN without a table.
    pub soc_end: f64,
    /// RMSE of the model's free-run voltage against the record (V).
    pub rmse_v: f64,
    /// Iterations run.
    pub iterations: u32,
    /// The fit converged.
    pub converged: bool,
    /// Rows rejected (not finite, out of range, spikes against the model),
    /// substituted and not fitted, as the CLI counts them.
    pub rejected: u32,
    /// The fit can be trusted (the JSON's `identifiable`, docs/trust.md).
    pub identifiable: bool,
    /// On an error: the CLI's one-line message (NUL-terminated).
    pub message: [c_char; 256],
}

impl FracbmsFit {
    fn empty() -> Self {
        Self {
            model: FracbmsModel::FRACBMS_MODEL_LINEAR,
            r_i: f64::NAN,
            r_ct: f64::NAN,
            q: f64::NAN,
            alpha: f64::NAN,
            u_oc: f64::NAN,
            bv_a_v: f64::NAN,
            bv_i0_a: f64::NAN,
            ocv_offset_v: f64::NAN,
            soc0: f64::NAN,
            soc_end: f64::NAN,
            rmse_v: f64::NAN,
            iterations: 0,
            converged: false,
            rejected: 0,
            identifiable: false,
            message: [0; 256],
        }
    }

    fn say(&mut self, text: &str) {
        let n = text.len().min(self.message.len() - 1);
        for (m, b) in self.message.iter_mut().zip(&text.as_bytes()[..n]) {
            *m = *b as c_char;
        }
        self.message[n] = 0;
    }
}

/// The CLI's defaults: refined, auto, 50 iterations, no table.
pub(crate) fn default_options() -> FracbmsIdentifyOptions {
    FracbmsIdentifyOptions {
        method: FracbmsMethod::FRACBMS_METHOD_REFINED as i32,
        model: FracbmsModel::FRACBMS_MODEL_AUTO as i32,
        iterations: 50,
        ocv_soc: core::ptr::null(),
        ocv_v: core::ptr::null(),
        ocv_points: 0,
        capacity_ah: 0.0,
        soc0: f64::NAN,
        unobserved: core::ptr::null(),
    }
}

/// Identifies a whole record (see `fracbms_identify_battery`).
pub(crate) fn identify(
    time: &[f64],
    current: &[f64],
    voltage: &[f64],
    unobserved: &[bool],
    ocv: Option<(&[f64], &[f64])>,
    o: &FracbmsIdentifyOptions,
    out: &mut FracbmsFit,
) -> FracbmsCode {
    *out = FracbmsFit::empty();
    let name = Path::new("record");
    let spec = match ocv {
        None => None,
        Some((soc, v)) => {
            let table = match io::ocv_table(
                Path::new("ocv"),
                Columns::from_arrays(vec![soc.to_vec(), v.to_vec()]),
            ) {
                Ok(t) => t,
                Err(e) => {
                    out.say(&format!("{e:#}"));
                    return FracbmsCode::FRACBMS_ERROR_OCV;
                }
            };
            let soc0 = (!o.soc0.is_nan()).then_some(o.soc0);
            match OcvSpec::new(table, o.capacity_ah, soc0) {
                Ok(s) => Some(s),
                Err(OcvSpecError::Capacity(c)) => {
                    out.say(&format!("capacity {c} A·h: not a positive capacity"));
                    return FracbmsCode::FRACBMS_ERROR_OCV;
                }
                Err(OcvSpecError::Soc0(z)) => {
                    out.say(&format!("soc0 {z}: must be in [0, 1]"));
                    return FracbmsCode::FRACBMS_ERROR_OCV;
                }
            }
        }
    };
    let method = match FracbmsMethod::from_i32(o.method) {
        Some(FracbmsMethod::FRACBMS_METHOD_PAPER) => BatteryMethod::Paper,
        Some(FracbmsMethod::FRACBMS_METHOD_REFINED) => BatteryMethod::Refined,
        None => {
            out.say(&format!("method {}: not a FracbmsMethod", o.method));
            return FracbmsCode::FRACBMS_ERROR_SETTINGS;
        }
    };
    let model = match (FracbmsModel::from_i32(o.model), method) {
        (Some(FracbmsModel::FRACBMS_MODEL_AUTO), BatteryMethod::Paper) => ModelRequest::Linear,
        (Some(FracbmsModel::FRACBMS_MODEL_AUTO), _) => ModelRequest::Auto,
        (Some(FracbmsModel::FRACBMS_MODEL_LINEAR), _) => ModelRequest::Linear,
        (Some(FracbmsModel::FRACBMS_MODEL_BUTLER_VOLMER), _) => ModelRequest::ButlerVolmer,
        (None, _) => {
            out.say(&format!("model {}: not a FracbmsModel", o.model));
            return FracbmsCode::FRACBMS_ERROR_SETTINGS;
        }
    };
    let run = std::panic::catch_unwind(|| {
        battery_arrays(
            name,
            time,
            current,
            voltage,
            unobserved,
            spec.as_ref(),
            method,
            model,
            None,
            o.iterations,
        )
    });
    let r = match run {
        Ok(Ok(r)) => r.result,
        // What the data are refused for (a bad time, too many rows, every
        // row rejected, a record that does not start at rest): data.
        Ok(Err(e)) if e.kind() == ErrorKind::Data => {
            out.say(&format!("{e:#}"));
            return FracbmsCode::FRACBMS_ERROR_DATA;
        }
        Ok(Err(e)) => {
            out.say(&format!("{e:#}"));
            return FracbmsCode::FRACBMS_ERROR_FIT;
        }
        Err(_) => {
            out.say("the fit failed (internal error)");
            return FracbmsCode::FRACBMS_ERROR_FIT;
        }
    };
    let j = &r.json;
    out.model = if j.model == "butler-volmer" {
        FracbmsModel::FRACBMS_MODEL_BUTLER_VOLMER
    } else {
        FracbmsModel::FRACBMS_MODEL_LINEAR
    };
    out.r_i = j.r_i;
    out.r_ct = j.r_ct;
    out.q = j.q;
    out.alpha = j.alpha;
    out.u_oc = j.u_oc;
    out.bv_a_v = j.bv_a_v.unwrap_or(f64::NAN);
    out.bv_i0_a = j.bv_i0_a.unwrap_or(f64::NAN);
    out.ocv_offset_v = j.ocv_offset_v.unwrap_or(f64::NAN);
    out.soc0 = j.soc0.unwrap_or(f64::NAN);
    out.soc_end = j.soc_end.unwrap_or(f64::NAN);
    out.rmse_v = j.rmse_v;
    out.iterations = j.iterations;
    out.converged = j.converged;
    out.rejected = j.rejected;
    out.identifiable = j.identifiable;
    FracbmsCode::FRACBMS_OK
}
