//! `identify hammerstein`: the paper stage (2S-OP-GI or KT-2S-GI) over a
//! whole `u,y` record, then the prediction-error refinement, and the JSON
//! of the result. The algorithms are `estimator-core`'s (`gi`); this module
//! only drives them and reports.

use super::{
    parse_basis, table_row, Algorithm, HammersteinMethod, HistoryEntry, HAM_MEM, MAX_ROWS,
};
use crate::error::Result;
use crate::{bail, err, io};
use estimator_core::gi::key_term::KeyTermGi;
use estimator_core::gi::over_param::OverParamGi;
use estimator_core::gi::prediction_error::{
    LinearStart, PredictionErrorRefinement, PredictionErrorSettings,
};
use estimator_core::gi::{GiSettings, HammersteinEstimate, Normalization};
use estimator_core::model::{Orders, Polynomial};
use estimator_core::window::SampleWindow;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// How a Hammerstein record is fitted (the flags of `identify hammerstein`
/// but the files; the Python face fills it from its keywords). The default
/// is the CLI's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct HammersteinOptions {
    /// `paper` (the algorithm alone) or `refined` (the prediction-error
    /// refinement started from it: maximum likelihood, the most accurate).
    pub method: HammersteinMethod,
    /// Algorithm of the paper stage.
    pub algorithm: Algorithm,
    /// Order of A(z).
    pub na: usize,
    /// Order of B(z).
    pub nb: usize,
    /// Order of the noise polynomial C(z).
    pub nc: usize,
    /// Basis of the nonlinearity: `poly:m` means f_j(u) = u^j, j = 1..m.
    pub basis: String,
    /// Memory of the fractional differences (default: all rows, at most
    /// [`HAM_MEM`]).
    pub memory: Option<usize>,
    /// Iterations of the paper stage.
    pub iterations: u32,
    /// Most iterations of the refinement (its global search over the order
    /// included).
    pub refine_iterations: u32,
    /// Initial order α̂₀.
    pub alpha0: f64,
}

impl Default for HammersteinOptions {
    fn default() -> Self {
        Self {
            method: HammersteinMethod::Refined,
            algorithm: Algorithm::Op,
            na: 2,
            nb: 3,
            nc: 2,
            basis: "poly:2".into(),
            memory: None,
            iterations: 100,
            refine_iterations: 400,
            alpha0: 0.45,
        }
    }
}

type OpGi = OverParamGi<f64, MAX_ROWS, HAM_MEM, 4, 4, 4, 4, 16>;
type KtGi = KeyTermGi<f64, MAX_ROWS, HAM_MEM, 4, 4, 4, 4, 16>;
type Refinement = PredictionErrorRefinement<f64, MAX_ROWS, HAM_MEM, 4, 4, 4, 4, 16, 25>;
type Estimate = HammersteinEstimate<f64, 4, 4, 4, 4, 16>;

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
            .map_err(|e| err!(Internal, "refinement thread: {e}"))?
            .join()
            .map_err(|_| err!(Internal, "the refinement thread panicked"))?
            .map_err(|e| err!(Estimator, "refinement: {e}"))
    })
}

/// Runs `identify hammerstein` on the `u,y` file `input` (at most
/// [`MAX_ROWS`] rows; a note on stderr says when it was cut) and returns the
/// JSON value, with the table of estimates versus k on the terminal.
pub fn hammerstein_json(input: &Path, a: &HammersteinOptions) -> Result<HammersteinJson> {
    // The flags are checked before the file is read.
    parse_basis(&a.basis)?;
    let cols = io::read_columns(input, &["u", "y"], Some(MAX_ROWS))?;
    if let Some(note) = super::truncation_note(input, cols.data[0].len()) {
        eprintln!("{note}");
    }
    hammerstein_fit(input, &cols, a, true)
}

/// Identifies the Hammerstein system of columns `u,y` (as read by
/// `identify hammerstein`, or [`io::Columns::from_arrays`]) as `a` says;
/// `path` names the data in the errors. With `print`, the table of
/// estimates versus k and a progress bar go to the terminal, as the CLI
/// shows them. At most [`MAX_ROWS`] rows.
pub fn hammerstein_fit(
    path: &Path,
    cols: &io::Columns,
    a: &HammersteinOptions,
    print: bool,
) -> Result<HammersteinJson> {
    let m = parse_basis(&a.basis)?;
    io::same_lengths(path, cols, &["u", "y"])?;
    io::require_finite(path, cols, &["u", "y"], &[0, 1])?;
    let (u, y) = (&cols.data[0], &cols.data[1]);
    if u.len() > MAX_ROWS {
        bail!(
            Data,
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
            .map_err(|e| err!(Estimator, "{}: {e}", path.display()))?;
    }
    let ctx = |e: estimator_core::Error| err!(Estimator, "{}: {e}", path.display());
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
                .map_err(|e| e.prefixed(path.display()))?;
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
        method: a.method.as_str(),
        algorithm: a.algorithm.as_str(),
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
