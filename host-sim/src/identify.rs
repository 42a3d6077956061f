//! `identify hammerstein` and `identify battery`.

use crate::cli::{
    parse_basis, Algorithm, BatteryMethod, HammersteinMethod, IdBatteryArgs, IdHammersteinArgs,
    ModelArg,
};
use crate::{io, plot, trust};
use anyhow::{anyhow, bail, Context, Result};
use estimator_core::battery::output_error::{FitInformation, OutputErrorRefinement, COLUMN_NAMES};
use estimator_core::battery::regression::PaperRegressionGi;
use estimator_core::battery::simulate::simulate;
use estimator_core::battery::{BatterySettings, CellModel, CellParameters};
use estimator_core::frac::GlWeights;
use estimator_core::gi::key_term::KeyTermGi;
use estimator_core::gi::over_param::OverParamGi;
use estimator_core::gi::prediction_error::{
    LinearStart, PredictionErrorRefinement, PredictionErrorSettings,
};
use estimator_core::gi::{GiSettings, HammersteinEstimate, Normalization};
use estimator_core::model::{Orders, Polynomial};
use estimator_core::window::SampleWindow;
use serde::Serialize;
use std::path::Path;

/// Most rows `identify` reads (the rest of a longer file is ignored, with a
/// note; `online` streams files of any length).
pub const MAX_ROWS: usize = 8192;
/// Memory capacity of the Hammerstein estimators.
pub const HAM_MEM: usize = 4096;
/// Memory capacity of the battery estimators.
pub const BAT_MEM: usize = 4096;

type OpGi = OverParamGi<f64, MAX_ROWS, HAM_MEM, 4, 4, 4, 4, 16>;
type KtGi = KeyTermGi<f64, MAX_ROWS, HAM_MEM, 4, 4, 4, 4, 16>;
type Refinement = PredictionErrorRefinement<f64, MAX_ROWS, HAM_MEM, 4, 4, 4, 4, 16, 25>;
type Estimate = HammersteinEstimate<f64, 4, 4, 4, 4, 16>;

/// One entry of the iteration history.
#[derive(Serialize, Clone, Copy, Debug)]
pub struct HistoryEntry {
    /// Iteration k.
    pub k: u32,
    /// α̂_k.
    pub alpha: f64,
    /// Cost after iteration k.
    pub cost: f64,
}

/// The start the refinement's descent began from.
#[derive(Serialize, Clone, Copy, Debug)]
pub struct RefineStart {
    /// 0: the paper stage's own order; `g ≥ 1`: grid order g.
    pub index: u8,
    /// `"paper"` or `"grid"`.
    pub kind: &'static str,
    /// Where its linear parameters started: `"paper"` (the paper stage's),
    /// `"noise_model"` (a = 0, least squares for b·γ then c) or
    /// `"equation_error"` (c = 0, least squares for a and b·γ).
    pub linear: &'static str,
    /// The fixed order of that start.
    pub alpha: f64,
    /// The criterion there after the fit of the linear parameters.
    pub cost: f64,
}

/// The JSON of `identify hammerstein`.
#[derive(Serialize, Debug)]
pub struct HammersteinJson {
    /// "paper" or "refined".
    pub method: &'static str,
    /// "op" or "kt": the paper stage.
    pub algorithm: &'static str,
    /// â.
    pub a: Vec<f64>,
    /// b̂.
    pub b: Vec<f64>,
    /// ĉ.
    pub c: Vec<f64>,
    /// γ̂.
    pub gamma: Vec<f64>,
    /// α̂.
    pub alpha: f64,
    /// b̂_i γ̂_j, i-major.
    pub theta_products: Vec<f64>,
    /// Iterations of the paper stage.
    pub iterations: u32,
    /// The paper stage converged (step 6 of the paper).
    pub converged: bool,
    /// The criterion `½ Σ ε(l)²` at the published estimate (the whitened
    /// one-step prediction error; the paper stage's cost with `--method
    /// paper`).
    pub cost: f64,
    /// The criterion at the paper stage's estimate.
    pub paper_cost: f64,
    /// Refinement iterations (null with `--method paper`).
    pub refine_iterations: Option<u32>,
    /// The refinement's final cost (null with `--method paper`).
    pub refine_cost: Option<f64>,
    /// The refinement converged (null with `--method paper`).
    pub refine_converged: Option<bool>,
    /// The start of the order search that won (null with `--method paper`).
    pub refine_start: Option<RefineStart>,
    /// Per-iteration α̂ and cost of the paper stage.
    pub history: Vec<HistoryEntry>,
}

/// What the refinement gave.
struct Refined {
    est: Estimate,
    iterations: u32,
    cost: f64,
    converged: bool,
    start: RefineStart,
}

/// Runs the prediction-error refinement from `start` (in a thread with a
/// stack for its working arrays).
fn refine_hammerstein(
    s: &GiSettings<f64>,
    win: &SampleWindow<f64, MAX_ROWS>,
    start: &Estimate,
    max_iterations: u32,
) -> Result<Refined> {
    let ps = PredictionErrorSettings::new(*s);
    std::thread::scope(|sc| {
        std::thread::Builder::new()
            .stack_size(64 << 20)
            .spawn_scoped(sc, || -> Result<Refined, estimator_core::Error> {
                let mut r = Box::new(Refinement::new(&ps, start)?);
                let last = r.run(&ps, &Polynomial, win, max_iterations)?;
                let won = r.winning_start(&ps);
                Ok(Refined {
                    est: *r.estimate(),
                    iterations: r.iterations(),
                    cost: last.map_or(f64::NAN, |it| it.cost),
                    converged: last.is_some_and(|it| it.converged),
                    start: RefineStart {
                        index: won.map_or(0, |w| w.index),
                        kind: match won {
                            Some(w) if w.index > 0 => "grid",
                            _ => "paper",
                        },
                        linear: match won.map(|w| w.linear) {
                            Some(LinearStart::NoiseModel) => "noise_model",
                            Some(LinearStart::EquationError) => "equation_error",
                            _ => "paper",
                        },
                        alpha: won.map_or(start.alpha, |w| w.alpha),
                        cost: won.map_or(f64::NAN, |w| w.cost),
                    },
                })
            })
            .map_err(|e| anyhow!("refinement thread: {e}"))?
            .join()
            .map_err(|_| anyhow!("the refinement thread panicked"))?
            .map_err(|e| anyhow!("refinement: {e}"))
    })
}

fn note_truncation(path: &Path, rows: usize) {
    if rows == MAX_ROWS {
        eprintln!(
            "note: {}: only the first {MAX_ROWS} rows are identified (use `online` for longer records)",
            path.display()
        );
    }
}

fn table_row(k: u32) -> bool {
    k == 1 || k % 10 == 0
}

/// Runs `identify hammerstein` and returns the JSON value.
pub fn hammerstein_json(a: &IdHammersteinArgs) -> Result<HammersteinJson> {
    // The flags are checked before the file is read.
    parse_basis(&a.fit.basis)?;
    let cols = io::read_columns(&a.input, &["u", "y"], Some(MAX_ROWS))?;
    note_truncation(&a.input, cols.data[0].len());
    hammerstein_fit(&a.input, &cols, &a.fit, true)
}

/// Identifies the Hammerstein system of columns `u,y` (as read by
/// `identify hammerstein`, or [`io::Columns::from_arrays`]) as `a` says;
/// `path` names the data in the errors. With `print`, the table of
/// estimates versus k and a progress bar go to the terminal, as the CLI
/// shows them. At most [`MAX_ROWS`] rows.
pub fn hammerstein_fit(
    path: &Path,
    cols: &io::Columns,
    a: &crate::cli::HammersteinOptions,
    print: bool,
) -> Result<HammersteinJson> {
    let m = parse_basis(&a.basis)?;
    io::same_lengths(path, cols, &["u", "y"])?;
    io::require_finite(path, cols, &["u", "y"], &[0, 1])?;
    let (u, y) = (&cols.data[0], &cols.data[1]);
    if u.len() > MAX_ROWS {
        bail!(
            "{}: {} rows; at most {MAX_ROWS} are identified",
            path.display(),
            u.len()
        );
    }
    let orders = Orders {
        na: a.na,
        nb: a.nb,
        nc: a.nc,
        m,
    };
    let memory = a.memory.unwrap_or(u.len().clamp(1, HAM_MEM));
    let s = GiSettings::new(orders, memory);
    let mut win = Box::new(SampleWindow::<f64, MAX_ROWS>::new());
    for (&ui, &yi) in u.iter().zip(y) {
        win.push(ui, yi)
            .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    }
    let ctx = |e: estimator_core::Error| anyhow!("{}: {e}", path.display());
    let mut history = Vec::new();
    let mut converged = false;
    let mut cost = f64::NAN;
    let pb = if print {
        crate::progress::bar(u64::from(a.iterations), "identifying")
    } else {
        indicatif::ProgressBar::hidden()
    };
    // The CLI's terminal output; nothing without `print`.
    let say = |text: String| {
        if print {
            pb.suspend(|| println!("{text}"));
        }
    };
    let header = |est: &HammersteinEstimate<f64, 4, 4, 4, 4, 16>| {
        let mut h = String::from("    k");
        for i in 0..est.orders.na {
            h += &format!(" {:>10}", format!("a{}", i + 1));
        }
        for i in 0..est.orders.nc {
            h += &format!(" {:>10}", format!("c{}", i + 1));
        }
        for i in 0..est.orders.nb {
            for j in 0..est.orders.m {
                h += &format!(" {:>10}", format!("b{}g{}", i + 1, j + 1));
            }
        }
        h + &format!(" {:>10} {:>12}", "alpha", "cost")
    };
    let line = |k: u32, est: &HammersteinEstimate<f64, 4, 4, 4, 4, 16>, cost: f64| {
        let mut v = vec![0.0; 32];
        let n = est.parameter_vector(&mut v);
        let mut s = format!("{k:>5}");
        for x in &v[..n - 1] {
            s += &format!(" {x:>10.5}");
        }
        s + &format!(" {:>10.5} {:>12.5e}", est.alpha, cost)
    };
    let (est, b, gamma) = match a.algorithm {
        Algorithm::Op => {
            let mut gi = Box::new(OpGi::new(&s, a.alpha0).map_err(ctx)?);
            say(header(gi.estimate()));
            for _ in 0..a.iterations {
                let it = gi.iterate(&s, &Polynomial, &win).map_err(ctx)?;
                history.push(HistoryEntry {
                    k: it.k,
                    alpha: it.alpha,
                    cost: it.cost,
                });
                (converged, cost) = (it.converged, it.cost);
                if table_row(it.k) {
                    say(line(it.k, gi.estimate(), it.cost));
                }
                pb.inc(1);
                if converged {
                    break;
                }
            }
            let est = *gi.estimate();
            let (b, g) = est
                .factor(Normalization::UnitGamma)
                .map(|(b, g)| (b[..a.nb].to_vec(), g[..m].to_vec()))
                .unwrap_or_default();
            (est, b, g)
        }
        Algorithm::Kt => {
            let mut gi = Box::new(KtGi::new(&s, a.alpha0).map_err(ctx)?);
            say(header(&gi.products()));
            for _ in 0..a.iterations {
                let it = gi.iterate(&s, &Polynomial, &win).map_err(ctx)?;
                history.push(HistoryEntry {
                    k: it.k,
                    alpha: it.alpha,
                    cost: it.cost,
                });
                (converged, cost) = (it.converged, it.cost);
                if table_row(it.k) {
                    say(line(it.k, &gi.products(), it.cost));
                }
                pb.inc(1);
                if converged {
                    break;
                }
            }
            let kt = gi.estimate();
            (gi.products(), kt.b[..a.nb].to_vec(), kt.gamma[..m].to_vec())
        }
    };
    pb.finish_and_clear();
    let paper_cost = cost;
    let (est, b, gamma, refined) = match a.method {
        HammersteinMethod::Paper => (est, b, gamma, None),
        HammersteinMethod::Refined => {
            let r = refine_hammerstein(&s, &win, &est, a.refine_iterations)
                .map_err(|e| anyhow!("{}: {e}", path.display()))?;
            let norm = match a.algorithm {
                Algorithm::Op => Normalization::UnitGamma,
                Algorithm::Kt => Normalization::UnitB1,
            };
            let (b, g) = r
                .est
                .factor(norm)
                .map(|(b, g)| (b[..a.nb].to_vec(), g[..m].to_vec()))
                .unwrap_or_default();
            say(format!(
                "refined: {} iterations from the {} start (α = {:.4}, {} linear start, cost {:.6e}), α̂ = {:.5}, cost {:.6e}{}",
                r.iterations,
                r.start.kind,
                r.start.alpha,
                r.start.linear,
                r.start.cost,
                r.est.alpha,
                r.cost,
                if r.converged { ", converged" } else { "" }
            ));
            (r.est, b, g, Some(r))
        }
    };
    let mut products = Vec::new();
    for i in 0..a.nb {
        for j in 0..m {
            products.push(est.product(i, j));
        }
    }
    Ok(HammersteinJson {
        method: match a.method {
            HammersteinMethod::Paper => "paper",
            HammersteinMethod::Refined => "refined",
        },
        algorithm: match a.algorithm {
            Algorithm::Op => "op",
            Algorithm::Kt => "kt",
        },
        a: est.a[..a.na].to_vec(),
        b,
        c: est.c[..a.nc].to_vec(),
        gamma,
        alpha: est.alpha,
        theta_products: products,
        iterations: history.len() as u32,
        converged,
        cost: refined.as_ref().map_or(paper_cost, |r| r.cost),
        paper_cost,
        refine_iterations: refined.as_ref().map(|r| r.iterations),
        refine_cost: refined.as_ref().map(|r| r.cost),
        refine_converged: refined.as_ref().map(|r| r.converged),
        refine_start: refined.as_ref().map(|r| r.start),
        history,
    })
}

// Not inlined into `cli::run`: the estimators are built on the stack before
// boxing, and an inlined frame of every command would be probed (page
// faults over megabytes) even for the command that does not run.
#[inline(never)]
pub(crate) fn hammerstein(a: &IdHammersteinArgs) -> Result<()> {
    let j = hammerstein_json(a)?;
    println!(
        "alpha = {:.5}, iterations = {}, converged = {}, cost = {:.6e}",
        j.alpha, j.iterations, j.converged, j.cost
    );
    if let Some(p) = &a.json {
        io::write_json(p, &j)?;
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}

/// The JSON of `identify battery`.
#[derive(Serialize, Debug, Clone)]
pub struct BatteryJson {
    /// "paper" or "refined".
    pub method: &'static str,
    /// R_i (Ω).
    pub r_i: f64,
    /// R_ct (Ω).
    pub r_ct: f64,
    /// Q (F·s^(α−1)).
    pub q: f64,
    /// α.
    pub alpha: f64,
    /// U_oc (V). With an OCV curve: the model's open-circuit voltage at the
    /// end of the record, `OCV(soc_end) + ΔU`.
    pub u_oc: f64,
    /// With an OCV curve: the offset ΔU (V) the model adds to `OCV(SOC)`
    /// (null without a curve).
    pub ocv_offset_v: Option<f64>,
    /// With an OCV curve: SOC at the start of the record, before the first
    /// row's charge (null without a curve).
    pub soc0: Option<f64>,
    /// With an OCV curve: SOC after the last row,
    /// `soc0 + h·Σ I/(3600·C)` (null without a curve).
    pub soc_end: Option<f64>,
    /// `"linear"` or `"butler-volmer"`: the model of these estimates.
    pub model: &'static str,
    /// Butler–Volmer coefficient a (V) of a·asinh(I/i₀) (null for the
    /// linear model).
    pub bv_a_v: Option<f64>,
    /// Butler–Volmer exchange current i₀ (A) (null for the linear model).
    pub bv_i0_a: Option<f64>,
    /// With `--model auto` or `butler-volmer`: both fits and why the model
    /// was chosen (null for `--model linear`).
    pub model_choice: Option<ModelChoice>,
    /// RMSE of the identified model's simulated voltage against the file (V).
    pub rmse_v: f64,
    /// Iterations (2S-OP-GI + refinement).
    pub iterations: u32,
    /// Converged.
    pub converged: bool,
    /// Per-iteration cost of 2S-OP-GI.
    pub history: Vec<HistoryEntry>,
    /// The fit can be trusted: no reason against it holds (see
    /// `identifiable_reason`, docs/trust.md).
    pub identifiable: bool,
    /// Why not, one clause per reason (null when identifiable).
    pub identifiable_reason: Option<String>,
    /// 95 % intervals `[lo, hi]` of `r_i`, `r_ct`, `q`, `alpha` (null when
    /// the information matrix is singular).
    pub confidence: Option<trust::Confidence>,
    /// Lag-1 autocorrelation of the residuals over the accepted rows (the
    /// intervals are widened by `√((1+ρ)/(1−ρ))` for it).
    pub residual_lag1_correlation: f64,
    /// `1 − RSS/TSS` of the voltage over the accepted rows.
    pub explained_variance: f64,
    /// Rows rejected (not finite, out of range, spikes against the model),
    /// substituted and not fitted.
    pub rejected: u32,
    /// The rejected rows by reason.
    pub rejected_rows: trust::RejectedRows,
}

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

/// What `identify battery` computed, for the plots and the report.
pub struct BatteryResult {
    /// The JSON summary.
    pub json: BatteryJson,
    /// The identified cell.
    pub cell: CellParameters<f64>,
    /// Estimates of 2S-OP-GI per iteration (None while not physical).
    pub paper_track: Vec<Option<CellParameters<f64>>>,
    /// The identified model's voltage over the record.
    pub model_voltage: Vec<f64>,
    /// The Gauss–Newton information of the published fit at its estimate
    /// (None when it could not be computed).
    pub information: Option<FitInformation<f64>>,
    /// The order bounds of the fit.
    pub alpha_bounds: [f64; 2],
}

/// Simulates `cell` over a current record from rest (memory ≤ 4096).
pub fn model_voltage(cell: &CellParameters<f64>, h: f64, current: &[f64]) -> Result<Vec<f64>> {
    let mem = current.len().clamp(1, BAT_MEM);
    let mut w = Box::new(GlWeights::<f64, BAT_MEM>::new(cell.alpha, h, mem)?);
    let (mut up, mut v) = (vec![0.0; current.len()], vec![0.0; current.len()]);
    simulate(cell, &mut w, current, |_| cell.u_oc, &mut up, &mut v)?;
    Ok(v)
}

fn rmse(a: &[f64], b: &[f64]) -> f64 {
    let s: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
    (s / a.len().max(1) as f64).sqrt()
}

/// A rough physical start from the data alone: least squares of U on
/// [1, I] gives U_oc and R_i + R_ct; split evenly, α = 0.7, τ = 5 s^α.
fn rough_start(current: &[f64], voltage: &[f64]) -> CellParameters<f64> {
    let n = current.len() as f64;
    let mi = current.iter().sum::<f64>() / n;
    let mv = voltage.iter().sum::<f64>() / n;
    let sii: f64 = current.iter().map(|i| (i - mi) * (i - mi)).sum();
    let siv: f64 = current
        .iter()
        .zip(voltage)
        .map(|(i, v)| (i - mi) * (v - mv))
        .sum();
    let r = if sii > 0.0 {
        (siv / sii).abs().max(1e-5)
    } else {
        0.01
    };
    CellParameters {
        r_i: r / 2.0,
        r_ct: r / 2.0,
        q: 5.0 / (r / 2.0),
        alpha: 0.7,
        u_oc: mv - r * mi,
        bv_a: 0.0,
        bv_i0: 1.0,
    }
}

/// Identifies a battery record (`method` paper or refined), printing the
/// 2S-OP-GI table of estimates versus k when `print_table` is set.
pub fn battery_run(
    path: &Path,
    rec: &io::BatteryRecord,
    method: BatteryMethod,
    memory: Option<usize>,
    iterations: u32,
    print_table: bool,
) -> Result<BatteryResult> {
    battery_run_with(
        path,
        rec,
        method,
        memory,
        iterations,
        print_table,
        Refine::default(),
    )
}

/// Options of the output-error refinement.
#[derive(Clone, Copy, Debug, Default)]
pub struct Refine {
    /// Memory (default: the whole record, at most [`BAT_MEM`]).
    pub memory: Option<usize>,
    /// Fit the OCV slope.
    pub ocv_slope: bool,
    /// The cell model (default linear: the paper's).
    pub model: ModelArg,
}

/// [`battery_run`] with refinement options.
pub fn battery_run_with(
    path: &Path,
    rec: &io::BatteryRecord,
    method: BatteryMethod,
    memory: Option<usize>,
    iterations: u32,
    print_table: bool,
    refine: Refine,
) -> Result<BatteryResult> {
    // Estimator state sized to the record (a 1 000-row file does not
    // allocate and clear the state of an 8 192-row one).
    let run = match rec.current.len() {
        0..=1024 => battery_run_sized::<1024, 1024>,
        1025..=2048 => battery_run_sized::<2048, 2048>,
        2049..=4096 => battery_run_sized::<4096, BAT_MEM>,
        _ => battery_run_sized::<MAX_ROWS, BAT_MEM>,
    };
    run(path, rec, method, memory, iterations, print_table, refine)
}

/// [`battery_run_with`] for records of at most `N` rows, memories up to
/// `MEM = min(N, BAT_MEM)`.
fn battery_run_sized<const N: usize, const MEM: usize>(
    path: &Path,
    rec: &io::BatteryRecord,
    method: BatteryMethod,
    memory: Option<usize>,
    iterations: u32,
    print_table: bool,
    refine: Refine,
) -> Result<BatteryResult> {
    let n = rec.current.len();
    let mem = memory.unwrap_or(256.min(n / 2).max(1));
    let need = mem - 1 + estimator_core::battery::regression::MIN_ROWS;
    if mem == 0 || mem > BAT_MEM {
        bail!("--memory {mem}: must be in 1..={BAT_MEM}");
    }
    if n < need {
        bail!(
            "{}: {n} data rows; memory {mem} needs at least {need}",
            path.display()
        );
    }
    let ctx = |e: estimator_core::Error| anyhow!("{}: {e}", path.display());
    let mut win = Box::new(SampleWindow::<f64, N>::new());
    for (&i, &v) in rec.current.iter().zip(&rec.voltage) {
        win.push(i, v).map_err(ctx)?;
    }
    let sg = BatterySettings::new(rec.h, mem);
    let mut gi = Box::new(PaperRegressionGi::<f64, N, MEM>::new(&sg, 0.5).map_err(ctx)?);
    let mut history = Vec::new();
    let mut track = Vec::new();
    let mut converged = false;
    if print_table {
        println!(
            "{:>5} {:>10} {:>10} {:>10} {:>8} {:>9} {:>12}",
            "k", "R_i", "R_ct", "Q", "alpha", "U_oc", "cost"
        );
    }
    for _ in 0..iterations {
        let it = gi.iterate(&sg, &*win).map_err(ctx)?;
        history.push(HistoryEntry {
            k: it.k,
            alpha: it.alpha,
            cost: it.cost,
        });
        let cell = gi.cell();
        track.push(cell);
        converged = it.converged;
        if print_table && (table_row(it.k) || it.converged) {
            match cell {
                Some(c) => println!(
                    "{:>5} {:>10.6} {:>10.6} {:>10.3} {:>8.4} {:>9.5} {:>12.5e}",
                    it.k, c.r_i, c.r_ct, c.q, c.alpha, c.u_oc, it.cost
                ),
                None => println!(
                    "{:>5} {:>10} {:>10} {:>10} {:>8.4} {:>9} {:>12.5e}",
                    it.k, "-", "-", "-", it.alpha, "-", it.cost
                ),
            }
        }
        if it.converged {
            break;
        }
    }
    let mut iters = history.len() as u32;
    let mut choice = None;
    if method == BatteryMethod::Paper && refine.model == ModelArg::ButlerVolmer {
        bail!("--model butler-volmer needs --method refined (the paper's regression is linear)");
    }
    let (cell, rmse_v, information, alpha_bounds) = match method {
        BatteryMethod::Paper => {
            let cell = gi.cell().ok_or_else(|| {
                anyhow!(
                    "{}: 2S-OP-GI has no physical estimate after {iters} iterations (try more --iterations, or --method refined)",
                    path.display()
                )
            })?;
            // The information of the output-error criterion at the paper's
            // estimate (for its intervals; nothing is refitted).
            let si = BatterySettings::new(rec.h, n.min(BAT_MEM));
            let info = OutputErrorRefinement::<f64, N, MEM>::new(&si, cell)
                .and_then(|mut oe| oe.information(&si, &*win))
                .ok();
            // The RMSE of the model voltage, computed below.
            (cell, None, info, [si.alpha_min, si.alpha_max])
        }
        BatteryMethod::Refined => {
            let rm = refine.memory.unwrap_or(n.min(BAT_MEM));
            if rm == 0 || rm > BAT_MEM.min(n) {
                bail!(
                    "--refine-memory {rm}: must be in 1..={} for {n} rows",
                    BAT_MEM.min(n)
                );
            }
            let mut so = BatterySettings::new(rec.h, rm);
            so.ocv_slope = refine.ocv_slope;
            let start = gi
                .cell()
                .filter(|c| c.alpha >= so.alpha_min && c.alpha <= so.alpha_max)
                .unwrap_or_else(|| rough_start(&rec.current, &rec.voltage));
            let mut lin = refine_fit::<N, MEM>(&so, start, &win).map_err(ctx)?;
            iters += lin.iterations;
            let bounds = [so.alpha_min, so.alpha_max];
            if refine.model == ModelArg::Linear {
                converged = lin.converged;
                let info = lin.oe.information(&so, &*win).ok();
                (lin.cell, Some(lin.rmse), info, bounds)
            } else {
                let (mut fit, why) =
                    choose_model(&so, &lin, &win, &rec.current, refine.model).map_err(ctx)?;
                iters += fit.iterations;
                converged = fit.converged;
                choice = Some(why);
                let sf = BatterySettings {
                    model: if fit.cell.is_butler_volmer() {
                        CellModel::ButlerVolmer
                    } else {
                        CellModel::Linear
                    },
                    ..so
                };
                let info = fit.oe.information(&sf, &*win).ok();
                (fit.cell, Some(fit.rmse), info, bounds)
            }
        }
    };
    let model = model_voltage(&cell, rec.h, &rec.current)?;
    let rmse_v = rmse_v.unwrap_or_else(|| rmse(&model, &rec.voltage));
    Ok(BatteryResult {
        json: BatteryJson {
            method: match method {
                BatteryMethod::Paper => "paper",
                BatteryMethod::Refined => "refined",
            },
            r_i: cell.r_i,
            r_ct: cell.r_ct,
            q: cell.q,
            alpha: cell.alpha,
            u_oc: cell.u_oc,
            ocv_offset_v: None,
            soc0: None,
            soc_end: None,
            model: if cell.is_butler_volmer() {
                CellModel::ButlerVolmer.as_str()
            } else {
                CellModel::Linear.as_str()
            },
            bv_a_v: cell.is_butler_volmer().then_some(cell.bv_a),
            bv_i0_a: cell.is_butler_volmer().then_some(cell.bv_i0),
            model_choice: choice,
            rmse_v,
            iterations: iters,
            converged,
            history,
            identifiable: false,
            identifiable_reason: None,
            confidence: None,
            residual_lag1_correlation: f64::NAN,
            explained_variance: f64::NAN,
            rejected: 0,
            rejected_rows: trust::RejectedRows::default(),
        },
        cell,
        paper_track: track,
        model_voltage: model,
        information,
        alpha_bounds,
    })
}

/// A converged whole-record output-error fit.
struct Fit<const N: usize, const MEM: usize> {
    oe: Box<OutputErrorRefinement<f64, N, MEM>>,
    cell: CellParameters<f64>,
    rmse: f64,
    iterations: u32,
    converged: bool,
}

/// Refines `start` over the window until converged (at most 200
/// iterations).
fn refine_fit<const N: usize, const MEM: usize>(
    s: &BatterySettings<f64>,
    start: CellParameters<f64>,
    win: &SampleWindow<f64, N>,
) -> std::result::Result<Fit<N, MEM>, estimator_core::Error> {
    let mut oe = Box::new(OutputErrorRefinement::<f64, N, MEM>::new(s, start)?);
    let (mut rmse, mut iterations, mut converged) = (f64::NAN, 0, false);
    for _ in 0..200 {
        let st = oe.iterate(s, win)?;
        iterations += 1;
        rmse = st.rmse;
        if st.converged {
            converged = true;
            break;
        }
    }
    Ok(Fit {
        cell: oe.cell(),
        oe,
        rmse,
        iterations,
        converged,
    })
}

/// The Butler–Volmer fit from the linear one `lin` (the best of starts
/// with i₀ at 0.1, 0.3 and 1 times the largest current), and the model
/// `requested` (`butler-volmer` or `auto`) publishes, with the reason.
fn choose_model<const N: usize, const MEM: usize>(
    s: &BatterySettings<f64>,
    lin: &Fit<N, MEM>,
    win: &SampleWindow<f64, N>,
    current: &[f64],
    requested: ModelArg,
) -> std::result::Result<(Fit<N, MEM>, ModelChoice), estimator_core::Error> {
    let sb = BatterySettings {
        model: CellModel::ButlerVolmer,
        ..*s
    };
    let i_max = current.iter().fold(0.0f64, |m, i| m.max(i.abs())).max(1e-6);
    let mut best: Option<Fit<N, MEM>> = None;
    let mut iterations = 0;
    for f in [0.1, 0.3, 1.0] {
        let start = lin.cell.with_butler_volmer(f * i_max);
        // A start that does not run (e.g. not excited) is skipped; the
        // linear fit ran on the same window, so one of them does.
        let Ok(fit) = refine_fit::<N, MEM>(&sb, start, win) else {
            continue;
        };
        iterations += fit.iterations;
        if best.as_ref().is_none_or(|b| fit.rmse < b.rmse) {
            best = Some(fit);
        }
    }
    let mut bv = best.ok_or(estimator_core::Error::Diverged)?;
    bv.iterations = iterations;
    let info_bv = bv.oe.information(&sb, win)?;
    let mut lin_oe = lin.oe.clone();
    let info_lin = lin_oe.information(s, win)?;
    let ses = info_bv.standard_errors();
    let se = ses[6];
    let p = bv.cell;
    let ratio = i_max / p.bv_i0;
    let mut choice = ModelChoice {
        requested: match requested {
            ModelArg::Auto => "auto",
            _ => CellModel::ButlerVolmer.as_str(),
        },
        chosen: CellModel::ButlerVolmer.as_str(),
        reason: String::new(),
        rmse_linear_v: lin.rmse,
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
    if requested == ModelArg::ButlerVolmer {
        choice.reason = "asked for (--model butler-volmer)".into();
        return Ok((bv, choice));
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
        Ok((bv, choice))
    } else {
        choice.chosen = CellModel::Linear.as_str();
        choice.reason = format!("linear: {}", against.join("; "));
        let lin = Fit {
            oe: lin_oe,
            cell: lin.cell,
            rmse: lin.rmse,
            iterations: bv.iterations,
            converged: lin.converged,
        };
        Ok((lin, choice))
    }
}

/// [`battery_run_with`] on a record with or without the cell's OCV curve:
/// with one, the estimators fit the overpotential `U_t − OCV(SOC)` (the
/// fitted `U_oc` is the offset ΔU) and the result is mapped back to
/// terminal voltages (`u_oc` at the end of the record, the model voltage
/// with the OCV along the record).
#[allow(clippy::too_many_arguments)]
pub fn battery_identify(
    path: &Path,
    rec: &io::BatteryRecord,
    cell_ocv: Option<&crate::ocv::CellOcv>,
    method: BatteryMethod,
    memory: Option<usize>,
    iterations: u32,
    print_table: bool,
    refine: Refine,
) -> Result<BatteryResult> {
    let mut r = battery_identify_unassessed(
        path,
        rec,
        cell_ocv,
        method,
        memory,
        iterations,
        print_table,
        refine,
    )?;
    apply_assessment(&mut r, &trust::Screened::accepted(rec));
    Ok(r)
}

/// The model `--model` asks for under `--method`: the paper's regression
/// is linear, so `auto` has nothing to choose there.
pub fn model_for(model: ModelArg, method: BatteryMethod) -> ModelArg {
    match (model, method) {
        (ModelArg::Auto, BatteryMethod::Paper) => ModelArg::Linear,
        (m, _) => m,
    }
}

/// Writes the verdict of [`trust::assess`] into the JSON.
fn apply_assessment(r: &mut BatteryResult, sc: &trust::Screened) {
    let a = trust::assess(
        sc,
        &r.cell,
        r.information.as_ref(),
        r.alpha_bounds,
        &r.model_voltage,
    );
    let j = &mut r.json;
    j.identifiable = a.identifiable;
    j.identifiable_reason = (!a.identifiable).then(|| a.reasons.join("; "));
    j.confidence = a.confidence;
    j.residual_lag1_correlation = a.residual_correlation;
    j.explained_variance = a.explained;
    let counts = sc.counts();
    j.rejected = counts.total();
    j.rejected_rows = counts;
    if counts.total() > 0 {
        // The RMSE over the accepted rows, against the measured voltages.
        let (s, k) = sc
            .measured
            .iter()
            .zip(&r.model_voltage)
            .zip(&sc.rejected)
            .filter(|(_, rej)| rej.is_none())
            .fold((0.0, 0usize), |(s, k), ((v, m), _)| {
                (s + (v - m) * (v - m), k + 1)
            });
        j.rmse_v = (s / k.max(1) as f64).sqrt();
    }
}

/// [`battery_identify`] on a record whose bad rows are rejected first,
/// then refitted without the spikes against the model (docs/trust.md): the
/// rows rejected are substituted and counted (`rejected`, `rejected_rows`),
/// and the verdict is computed over the accepted rows.
///
/// # Errors
/// As [`battery_identify`], and when every row is rejected.
#[allow(clippy::too_many_arguments)]
pub fn battery_identify_screened(
    path: &Path,
    rec: &io::BatteryRecord,
    limits: &trust::Limits,
    ocv: Option<&crate::ocv::OcvSpec>,
    method: BatteryMethod,
    memory: Option<usize>,
    iterations: u32,
    print_table: bool,
    refine: Refine,
) -> Result<(BatteryResult, trust::Screened)> {
    let mut sc = trust::screen(path, rec, limits)?;
    let cell_ocv = ocv.map(|o| o.resolve(path, &sc.record)).transpose()?;
    let fit = |record: &io::BatteryRecord, print_table: bool| {
        battery_identify_unassessed(
            path,
            record,
            cell_ocv.as_ref(),
            method,
            memory,
            iterations,
            print_table,
            refine,
        )
    };
    let mut r = fit(&sc.record, print_table)?;
    // No earlier fit yet: nothing has settled.
    let mut previous = CellParameters {
        alpha: f64::NAN,
        ..r.cell
    };
    for _ in 0..trust::MAX_SPIKE_PASSES {
        let new = sc.find_spikes(&r.model_voltage, limits);
        // A substitute from an earlier fit pulls the refit towards it;
        // refitting with the latest model's substitutes converges fast
        // (each pass by the fraction of rejected rows).
        if new == 0 && (sc.counts().total() == 0 || trust::settled(&r.cell, &previous)) {
            break;
        }
        previous = r.cell;
        sc.substitute_model(&r.model_voltage);
        r = fit(&sc.record, false)?;
    }
    apply_assessment(&mut r, &sc);
    Ok((r, sc))
}

/// [`battery_identify`] without the verdict.
#[allow(clippy::too_many_arguments)]
fn battery_identify_unassessed(
    path: &Path,
    rec: &io::BatteryRecord,
    cell_ocv: Option<&crate::ocv::CellOcv>,
    method: BatteryMethod,
    memory: Option<usize>,
    iterations: u32,
    print_table: bool,
    refine: Refine,
) -> Result<BatteryResult> {
    let Some(c) = cell_ocv else {
        return battery_run_with(path, rec, method, memory, iterations, print_table, refine);
    };
    if refine.ocv_slope {
        bail!("--ocv-slope goes without --ocv (the OCV curve carries the drift)");
    }
    let (y, soc_end) = c.overpotential_record(rec);
    let mut r = battery_run_with(path, &y, method, memory, iterations, print_table, refine)?;
    let offset = r.cell.u_oc;
    for (m, (v, yv)) in r
        .model_voltage
        .iter_mut()
        .zip(rec.voltage.iter().zip(&y.voltage))
    {
        // The overpotential model plus the OCV it was taken from.
        *m += v - yv;
    }
    r.json.u_oc = c.model.table.ocv(soc_end) + offset;
    r.json.ocv_offset_v = Some(offset);
    r.json.soc0 = Some(c.soc0);
    r.json.soc_end = Some(soc_end);
    Ok(r)
}

// Not inlined into `cli::run`: the estimators are built on the stack before
// boxing, and an inlined frame of every command would be probed (page
// faults over megabytes) even for the command that does not run.
#[inline(never)]
pub(crate) fn battery(a: &IdBatteryArgs) -> Result<()> {
    let rec = io::read_battery(&a.input, Some(MAX_ROWS))?;
    note_truncation(&a.input, rec.current.len());
    let _ = a.algorithm; // op and kt coincide for the battery regression
    let refine = Refine {
        memory: a.refine_memory,
        ocv_slope: a.ocv_slope,
        model: model_for(a.model, a.method),
    };
    let defaults = trust::Limits::default();
    let limits = trust::Limits {
        voltage_min: a.voltage_min.unwrap_or(defaults.voltage_min),
        voltage_max: a.voltage_max.unwrap_or(defaults.voltage_max),
        current_limit: a.current_limit.unwrap_or(defaults.current_limit),
        ..defaults
    };
    if !(limits.voltage_min < limits.voltage_max && limits.current_limit > 0.0) {
        bail!(
            "--voltage-min {} --voltage-max {} --current-limit {}: need voltage-min < voltage-max and a positive current limit",
            limits.voltage_min,
            limits.voltage_max,
            limits.current_limit
        );
    }
    let ocv = crate::ocv::OcvSpec::from_args(&a.cell)?;
    let (r, sc) = battery_identify_screened(
        &a.input,
        &rec,
        &limits,
        ocv.as_ref(),
        a.method,
        a.memory,
        a.iterations,
        true,
        refine,
    )?;
    if let Some(w) = sc.warning(&a.input) {
        eprintln!("{w}");
    }
    let j = &r.json;
    println!(
        "{}: R_i = {:.6} Ω, R_ct = {:.6} Ω, Q = {:.3}, alpha = {:.4}, U_oc = {:.5} V, rmse = {:.3e} V ({} iterations, converged: {})",
        j.method, j.r_i, j.r_ct, j.q, j.alpha, j.u_oc, j.rmse_v, j.iterations, j.converged
    );
    match &j.confidence {
        Some(c) => println!(
            "95 % intervals: R_i [{:.6}, {:.6}] Ω, R_ct [{:.6}, {:.6}] Ω, Q [{:.4}, {:.4}], alpha [{:.4}, {:.4}] (residual lag-1 correlation {:.2})",
            c.r_i[0], c.r_i[1], c.r_ct[0], c.r_ct[1], c.q[0], c.q[1], c.alpha[0], c.alpha[1],
            j.residual_lag1_correlation
        ),
        None => println!("95 % intervals: none (the information matrix is singular)"),
    }
    if let Some(why) = &j.identifiable_reason {
        eprintln!(
            "warning: {}: the fit is not identifiable: {why}",
            a.input.display()
        );
    }
    if let (Some(x), Some(i0)) = (j.bv_a_v, j.bv_i0_a) {
        println!("Butler–Volmer: a = {:.3} mV, i0 = {i0:.4} A", x * 1e3);
    }
    if let Some(c) = &j.model_choice {
        println!("model: {} ({})", c.chosen, c.reason);
    }
    if let (Some(d), Some(z0), Some(z1)) = (j.ocv_offset_v, j.soc0, j.soc_end) {
        println!(
            "OCV curve: offset ΔU = {:.2} mV, SOC {z0:.4} → {z1:.4}",
            d * 1e3
        );
    }
    if let Some(p) = &a.fit_out {
        io::write_csv(
            p,
            &["time_s", "voltage_v", "model_v"],
            rec.time
                .iter()
                .zip(&rec.voltage)
                .zip(&r.model_voltage)
                .map(|((t, v), m)| [format!("{t}"), format!("{v:.9}"), format!("{m:.9}")]),
        )?;
        eprintln!("wrote {}", p.display());
    }
    if let Some(p) = &a.json {
        io::write_json(p, j)?;
        eprintln!("wrote {}", p.display());
    }
    if let Some(dir) = &a.plot {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create", dir.display()))?;
        plot::battery_figures(dir, &rec, &r.model_voltage, &r.json.history)?;
        eprintln!("wrote Figures 8–11 to {}", dir.display());
    }
    Ok(())
}
