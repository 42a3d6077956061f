//! The Butler–Volmer fit from a linear one and the choice `--model auto`
//! makes between them: published only when the data identify the term
//! (current beyond i₀, a's 95 % interval away from 0, the other
//! parameters identified, a lower BIC), with the reason in one sentence.

use super::refine::{refine_best, Fit, SingleFit, Spares};
use super::ModelRequest;
use estimator_core::battery::output_error::{FitInformation, COLUMN_NAMES};
use estimator_core::battery::{BatterySettings, CellModel};
use estimator_core::window::Window;
use serde::Serialize;

/// Both fits of `--model auto` (or `butler-volmer`) and the choice.
#[derive(Serialize, Debug, Clone)]
pub struct ModelChoice {
    /// The `--model` asked for.
    pub requested: &'static str,
    /// The model of the published estimates.
    pub chosen: &'static str,
    /// Why, in one sentence.
    pub reason: String,
    /// Free-run RMSE of the linear fit (V).
    pub rmse_linear_v: f64,
    /// Free-run RMSE of the Butler–Volmer fit (V).
    pub rmse_butler_volmer_v: f64,
    /// BIC `n·ln(RSS/n) + k·ln n` of the linear fit.
    pub bic_linear: f64,
    /// BIC of the Butler–Volmer fit.
    pub bic_butler_volmer: f64,
    /// a (V) of the Butler–Volmer fit.
    pub bv_a_v: f64,
    /// i₀ (A) of the Butler–Volmer fit.
    pub bv_i0_a: f64,
    /// Lower end of a's 95 % interval, `a·exp(−1.96·se(ln a))` (V); null
    /// when the information matrix is singular.
    pub bv_a_low_v: Option<f64>,
    /// Upper end of a's 95 % interval (V).
    pub bv_a_high_v: Option<f64>,
    /// The standard error of `ln a` from the Gauss–Newton information with
    /// white residuals (a lower bound for correlated model error).
    pub bv_a_log_se: Option<f64>,
    /// `max|I| / i₀`: above 1 the record reaches the nonlinear part of the
    /// term.
    pub max_current_over_i0: f64,
    /// Standard errors of the Butler–Volmer fit's coordinates (`ln_r_i`,
    /// `ln_r_ct`, `ln_q`, `alpha`, `u_oc`, `ln_bv_a`, `ln_bv_i0`, …; white
    /// residuals assumed), null where not identified.
    pub butler_volmer_standard_errors: std::collections::BTreeMap<&'static str, Option<f64>>,
}

/// The Butler–Volmer fit is published under `--model auto` only when the
/// record's largest current is at least this many `i₀`: below, the term is
/// a resistance `a/i₀` and `a`, `i₀` are not told apart.
pub const AUTO_MIN_CURRENT_OVER_I0: f64 = 1.0;
/// …when the 95 % intervals (`±1.96` standard errors) of `ln a` and of the
/// other logarithmic parameters of the fit are narrower than `±1` (a factor
/// e; so `a`'s interval is away from 0)…
pub const AUTO_Z: f64 = 1.96;

/// The fit `--model auto` (or `butler-volmer`) publishes, and its
/// information at the estimate in the chosen model (for its intervals).
pub(super) struct ChosenFit {
    /// How it ended; its iterations are the Butler–Volmer race's, all
    /// starts.
    pub(super) fit: SingleFit,
    /// The information of the output-error criterion at the estimate.
    pub(super) information: FitInformation<f64>,
}

/// The Butler–Volmer fit from the linear one `lin` (the best of starts
/// with i₀ at 0.1, 0.3 and 1 times the largest current), and the model
/// `requested` (`butler-volmer` or `auto`) publishes, with the reason.
/// The linear fit's information is taken first, and its refinement then
/// serves a Butler–Volmer start (from `spares`, with the linear race's
/// others).
pub(super) fn choose_model<const N: usize>(
    s: &BatterySettings<f64>,
    mut lin: Fit<N>,
    win: &impl Window<f64>,
    current: &[f64],
    requested: ModelRequest,
    spares: &mut Spares<N>,
) -> std::result::Result<(ChosenFit, ModelChoice), estimator_core::Error> {
    let sb = BatterySettings {
        model: CellModel::ButlerVolmer,
        ..*s
    };
    let info_lin = lin.oe.information(s, win)?;
    let i_max = current.iter().fold(0.0f64, |m, i| m.max(i.abs())).max(1e-6);
    // A start that does not run (e.g. not excited) is passed over; the
    // linear fit ran on the same window, so one of them does.
    let starts = [0.1, 0.3, 1.0].map(|f| lin.cell.with_butler_volmer(f * i_max));
    let lin_fit = lin.single();
    spares.keep(lin.oe);
    let (mut bv, iterations) = refine_best::<N>(&sb, &starts, win, spares)?;
    let info_bv = bv.oe.information(&sb, win)?;
    let bv_chosen = ChosenFit {
        fit: SingleFit {
            iterations,
            ..bv.single()
        },
        information: info_bv,
    };
    let ses = info_bv.standard_errors();
    let se = ses[6];
    let p = bv.cell;
    let ratio = i_max / p.bv_i0;
    let mut choice = ModelChoice {
        requested: match requested {
            ModelRequest::Auto => "auto",
            _ => CellModel::ButlerVolmer.as_str(),
        },
        chosen: CellModel::ButlerVolmer.as_str(),
        reason: String::new(),
        rmse_linear_v: lin_fit.rmse_v,
        rmse_butler_volmer_v: bv.rmse,
        bic_linear: info_lin.bic(),
        bic_butler_volmer: info_bv.bic(),
        bv_a_v: p.bv_a,
        bv_i0_a: p.bv_i0,
        bv_a_low_v: se.map(|e| p.bv_a * (-AUTO_Z * e).exp()),
        bv_a_high_v: se.map(|e| p.bv_a * (AUTO_Z * e).exp()),
        bv_a_log_se: se,
        max_current_over_i0: ratio,
        butler_volmer_standard_errors: COLUMN_NAMES
            .iter()
            .zip(ses)
            .zip(info_bv.fitted)
            .filter(|(_, fitted)| *fitted)
            .map(|((&name, e), _)| (name, e))
            .collect(),
    };
    if requested == ModelRequest::ButlerVolmer {
        choice.reason = "asked for (--model butler-volmer)".into();
        return Ok((bv_chosen, choice));
    }
    let mut against = Vec::new();
    // (NaN counts against it.)
    if ratio.is_nan() || ratio < AUTO_MIN_CURRENT_OVER_I0 {
        against.push(format!(
            "the largest current is {ratio:.2} i₀ (below {AUTO_MIN_CURRENT_OVER_I0} i₀ the term is a resistance)"
        ));
    }
    // In ln a, the 95 % interval a·exp(±1.96·se) excludes 0 always; it is
    // away from 0 when the linear interval a ± 1.96·a·se is. The same for
    // every positive parameter of the fit: a Butler–Volmer term that
    // leaves R_i (or another) unidentified (e.g. R_i → 0 on a record of a
    // few current levels, where a·asinh(I/i₀) takes over the ohmic drop)
    // is not what the data identify.
    match se {
        Some(e) if AUTO_Z * e < 1.0 => {}
        Some(e) => against.push(format!(
            "a's 95 % interval reaches 0 (a = {:.2} mV ± {:.0} %)",
            p.bv_a * 1e3,
            100.0 * AUTO_Z * e
        )),
        None => against.push("a is not identified (singular information)".into()),
    }
    let loose: Vec<&str> = [(0, "R_i"), (1, "R_ct"), (2, "Q"), (7, "i₀")]
        .into_iter()
        .filter(|&(k, _)| se.is_some() && !ses[k].is_some_and(|e| AUTO_Z * e < 1.0))
        .map(|(_, name)| name)
        .collect();
    if !loose.is_empty() {
        against.push(format!(
            "with it, {} not identified (95 % interval wider than a factor e)",
            loose.join(", ")
        ));
    }
    let bic_lower = info_bv.bic() < info_lin.bic();
    if !bic_lower {
        against.push(format!(
            "its BIC {:.1} is not below the linear {:.1}",
            info_bv.bic(),
            info_lin.bic()
        ));
    }
    if against.is_empty() {
        choice.reason = format!(
            "the data identify it: current to {ratio:.1} i₀, a = {:.2} mV ± {:.0} % (95 %), BIC {:.1} below the linear {:.1}",
            p.bv_a * 1e3,
            100.0 * AUTO_Z * se.unwrap_or(f64::NAN),
            info_bv.bic(),
            info_lin.bic()
        );
        Ok((bv_chosen, choice))
    } else {
        choice.chosen = CellModel::Linear.as_str();
        choice.reason = format!("linear: {}", against.join("; "));
        let fit = SingleFit {
            iterations,
            ..lin_fit
        };
        Ok((
            ChosenFit {
                fit,
                information: info_lin,
            },
            choice,
        ))
    }
}
