//! The joint map fit (`--map-method joint`): every knot's parameters fitted
//! together over the whole record, the map model's voltage against the
//! measured one, with a smoothness penalty across knots.
//!
//! It owns the fit ([`joint_fit`]), the choice of its penalty and of the
//! parameters that vary with SOC by leaving levels out ([`choose`]), and
//! the knots' intervals. It must not split a record (that is
//! [`mod@super::levels`]) nor write files.
//!
//! The model is the map model of [`super::model`]: at each knot `j` a cell
//! `(R_i, R_ct, τ = R_ct·Q, α, ΔU)`, its branch run over the whole record
//! from rest (the exact full-memory branch by FFT), the knots' voltages
//! blended by the hat weights of the counted SOC, plus `OCV(SOC)`. The
//! unknowns are `ln R_i, ln R_ct, ln τ, α, ΔU` per knot for a parameter
//! that varies with SOC, one value for all knots for one that does not;
//! with the Butler–Volmer term (every start cell has one: the levels were
//! fitted with `--model butler-volmer`), `ln a` and `ln i₀` of one term
//! `a·asinh(I/i₀)` shared by the knots, last.
//! The cost is the sum of squared residuals over the measured samples plus
//! `N·λ·Σ (second difference across knots / scale)²` (scales: 1 for the
//! logarithms, 0.1 for α, 10 mV for ΔU), so a knot the data barely see
//! takes its neighbours' values, plus a pull of 1 % of that weight
//! towards the start on every unknown (which only matters where nothing
//! else pins it). Levenberg–Marquardt; the Jacobian of
//! every unknown exact (those of `ln τ` and α from the branch's own
//! transforms, [`FftBranch::unit_branch_with_derivatives`]).
//!
//! Leaving a fold of samples out (a level, or the record's long
//! discharges) is one Newton step from the fit on every sample: the fold's
//! residuals after that step are its prediction error. [`choose`] takes
//! the penalty and the varying set with the least such error.

use crate::branch::FftBranch;
use crate::err;
use crate::error::Result;
use crate::io::BatteryRecord;
use crate::ocv::CellOcv;
use crate::trust::{Confidence, MAX_ALPHA_HALF_WIDTH, MAX_FACTOR, Z95};
use estimator_core::battery::CellParameters;
use nalgebra::{DMatrix, DVector};

pub use crate::map::{JointCandidate as Candidate, JOINT_PARAMETERS as PARAMETERS};

mod inputs;
pub use inputs::JointInputs;

/// The scale of each parameter's second difference in the penalty.
const SCALE: [f64; 5] = [1.0, 1.0, 1.0, 0.1, 0.01];
/// The pull towards the start, relative to the penalty's weight.
const PULL: f64 = 0.01;

/// The bounds of each unknown (`ln R_i`, `ln R_ct`, `ln τ`, α, ΔU).
const BOUNDS: [[f64; 2]; 5] = [
    [-11.5, 2.3],
    [-11.5, 2.3],
    [-9.0, 12.0],
    [0.05, 1.0],
    [-0.5, 0.5],
];

/// The bounds of the shared Butler–Volmer unknowns (`ln a`, `ln i₀`).
const KINETIC_BOUNDS: [[f64; 2]; 2] = [[-11.5, 0.7], [-6.9, 6.9]];

/// How the joint fit runs.
#[derive(Clone, Debug, PartialEq)]
pub struct JointOptions {
    /// The penalty weight λ (V²).
    pub smoothing: f64,
    /// Which of [`PARAMETERS`] vary with SOC (the others are shared).
    pub vary: [bool; 5],
    /// Levenberg–Marquardt iterations at most.
    pub iterations: usize,
}

/// The record as the joint fit sees it.
pub struct JointData<'a> {
    /// The uniform record.
    pub record: &'a BatteryRecord,
    /// The counted SOC after each sample's charge (read again after gaps).
    pub soc: &'a [f64],
    /// The OCV.
    pub ocv: &'a CellOcv,
    /// Which samples the fit counts (measured, finite).
    pub counted: &'a [bool],
    /// The knots' SOCs, ascending.
    pub knots: &'a [f64],
}

/// A joint fit: each knot's cell, the fit's RMSE over its counted samples,
/// and the knots' 95 % intervals.
#[derive(Clone, Debug)]
pub struct JointFit {
    /// Each knot's cell (`u_oc` the knot's ΔU).
    pub cells: Vec<CellParameters<f64>>,
    /// The unknowns at the optimum.
    pub theta: Vec<f64>,
    /// RMSE over the counted samples (V).
    pub rmse_v: f64,
    /// The map model's voltage at each sample (V).
    pub model_v: Vec<f64>,
    /// Per knot, the 95 % intervals (`None` when singular).
    pub confidence: Vec<Option<Confidence>>,
    /// Per knot, why not identifiable (empty: identifiable).
    pub reasons: Vec<Vec<String>>,
    /// Iterations run.
    pub iterations: usize,
    /// The cells it started from, the pull's centre ([`choose`] starts a
    /// candidate from the last of its varying set).
    pub start: Vec<CellParameters<f64>>,
    /// Its penalty λ (V²) and varying set.
    pub smoothing: f64,
    /// …
    pub vary: [bool; 5],
    /// The Gauss–Newton matrix with the penalty (for leaving folds out).
    hessian: DMatrix<f64>,
    /// Per counted sample, its residual and its Jacobian's non-zero
    /// entries.
    rows: Vec<Residual>,
}

/// A counted sample's index, residual (model − measured, V) and its
/// Jacobian row's non-zero entries (unknown, value).
type Residual = (usize, f64, Vec<(usize, f64)>);

/// The hat weights of the knots at SOC `z`: the knot at or below and its
/// weight, the knot above and its weight (held beyond the ends).
fn weights(knots: &[f64], z: f64) -> [(usize, f64); 2] {
    let n = knots.len();
    if n == 1 || z <= knots[0] {
        return [(0, 1.0), (0, 0.0)];
    }
    if z >= knots[n - 1] {
        return [(n - 1, 1.0), (n - 1, 0.0)];
    }
    let j = knots.iter().rposition(|k| *k <= z).unwrap_or(0).min(n - 2);
    let w = (z - knots[j]) / (knots[j + 1] - knots[j]);
    [(j, 1.0 - w), (j + 1, w)]
}

/// The layout of the unknowns: per parameter its first index and whether
/// it varies (K values) or is shared (one); with the Butler–Volmer term,
/// its `ln a` and `ln i₀` last, shared by every knot.
struct Layout {
    first: [usize; 5],
    vary: [bool; 5],
    /// The index of `ln a` (`ln i₀` the next), with the term.
    kinetic: Option<usize>,
    len: usize,
}

impl Layout {
    fn new(vary: [bool; 5], knots: usize, kinetic: bool) -> Self {
        let mut first = [0; 5];
        let mut at = 0;
        for p in 0..5 {
            first[p] = at;
            at += if vary[p] { knots } else { 1 };
        }
        Layout {
            first,
            vary,
            kinetic: kinetic.then_some(at),
            len: at + if kinetic { 2 } else { 0 },
        }
    }
    fn index(&self, p: usize, knot: usize) -> usize {
        self.first[p] + if self.vary[p] { knot } else { 0 }
    }
    /// The penalty's scale and the search's bounds of unknown `i`.
    fn scale_and_bounds(&self, i: usize) -> (f64, [f64; 2]) {
        match self.kinetic {
            Some(at) if i >= at => (1.0, KINETIC_BOUNDS[i - at]),
            _ => {
                let p = (0..5).rev().find(|&p| self.first[p] <= i).unwrap_or(0);
                (SCALE[p], BOUNDS[p])
            }
        }
    }
    /// The Butler–Volmer term `(a, i₀)` of `theta`, with the term.
    fn kinetic_of(&self, theta: &[f64]) -> Option<(f64, f64)> {
        self.kinetic
            .map(|at| (theta[at].exp(), theta[at + 1].exp()))
    }
}

/// The unknowns of `cells` (a shared parameter: the mean over knots).
fn unknowns(cells: &[CellParameters<f64>], l: &Layout) -> Vec<f64> {
    let mut theta = vec![0.0; l.len];
    let mut count = vec![0.0f64; l.len];
    for (j, c) in cells.iter().enumerate() {
        let v = [
            c.r_i.max(1e-5).ln(),
            c.r_ct.max(1e-5).ln(),
            c.tau().max(1e-4).ln(),
            c.alpha,
            c.u_oc,
        ];
        for p in 0..5 {
            let i = l.index(p, j);
            theta[i] += v[p].clamp(BOUNDS[p][0], BOUNDS[p][1]);
            count[i] += 1.0;
        }
    }
    for (t, c) in theta.iter_mut().zip(&count) {
        *t /= (*c).max(1.0);
    }
    if let Some(at) = l.kinetic {
        // The term's start: the knots' median small-current resistance
        // a/i₀ and median i₀.
        let mut a_over_i0: Vec<f64> = cells.iter().map(|c| c.bv_a / c.bv_i0).collect();
        let mut i0: Vec<f64> = cells.iter().map(|c| c.bv_i0).collect();
        let i0 = median(&mut i0);
        theta[at] = (median(&mut a_over_i0) * i0)
            .max(1e-5)
            .ln()
            .clamp(KINETIC_BOUNDS[0][0], KINETIC_BOUNDS[0][1]);
        theta[at + 1] = i0
            .max(1e-3)
            .ln()
            .clamp(KINETIC_BOUNDS[1][0], KINETIC_BOUNDS[1][1]);
    }
    theta
}

fn median(x: &mut [f64]) -> f64 {
    x.sort_by(f64::total_cmp);
    x[x.len() / 2]
}

/// Knot `j`'s parameters `[ln R_i, ln R_ct, ln τ, α, ΔU]` from `theta`.
fn knot(theta: &[f64], l: &Layout, j: usize) -> [f64; 5] {
    core::array::from_fn(|p| theta[l.index(p, j)])
}

/// The cell of knot parameters `k` and the Butler–Volmer term `(a, i₀)`
/// (none: the linear model).
fn cell_of(k: [f64; 5], kinetic: Option<(f64, f64)>) -> CellParameters<f64> {
    let r_ct = k[1].exp();
    let (bv_a, bv_i0) = kinetic.unwrap_or((0.0, 1.0));
    CellParameters {
        r_i: k[0].exp(),
        r_ct,
        q: k[2].exp() / r_ct,
        alpha: k[3],
        u_oc: k[4],
        bv_a,
        bv_i0,
    }
}

/// The penalty's rows: per varying parameter, per interior knot, the
/// second difference scaled (`(unknown, coefficient)` each). (The weak
/// pull towards the start, 1 % of the weight, is [`joint_fit`]'s.)
fn penalty(l: &Layout, knots: usize) -> Vec<Vec<(usize, f64)>> {
    let mut rows = vec![];
    for (p, scale) in SCALE.iter().enumerate() {
        if !l.vary[p] || knots < 3 {
            continue;
        }
        for j in 1..knots - 1 {
            let s = 1.0 / scale;
            rows.push(vec![
                (l.index(p, j - 1), s),
                (l.index(p, j), -2.0 * s),
                (l.index(p, j + 1), s),
            ]);
        }
    }
    rows
}

/// The joint fit from the knots' `start` cells.
///
/// # Errors
/// [`crate::ErrorKind::Data`] when no sample is counted, the knots are
/// not ascending, or the normal equations cannot be solved at the start.
pub fn joint_fit(
    d: &JointData<'_>,
    start: &[CellParameters<f64>],
    o: &JointOptions,
) -> Result<JointFit> {
    let kn = d.knots.len();
    if kn == 0 || start.len() != kn || d.knots.windows(2).any(|w| w[1] <= w[0]) {
        return Err(err!(
            Data,
            "the joint map fit needs ascending knots, one start cell each"
        ));
    }
    let rec = d.record;
    let n = rec.time.len();
    let current: Vec<f64> = rec
        .current
        .iter()
        .map(|i| if i.is_finite() { *i } else { 0.0 })
        .collect();
    let counted: Vec<usize> = (0..n)
        .filter(|&k| d.counted.get(k).copied().unwrap_or(false) && rec.voltage[k].is_finite())
        .collect();
    if counted.is_empty() {
        return Err(err!(Data, "the joint map fit has no measured sample"));
    }
    // The Butler–Volmer term, shared by the knots, when the start has it.
    let l = Layout::new(o.vary, kn, start.iter().all(|c| c.is_butler_volmer()));
    let ocv: Vec<f64> = d.soc.iter().map(|&z| d.ocv.model.table.ocv(z)).collect();
    let w: Vec<[(usize, f64); 2]> = d.soc.iter().map(|&z| weights(d.knots, z)).collect();
    let pen = penalty(&l, kn);
    let start_theta = unknowns(start, &l);
    let nf = counted.len() as f64;
    let lam = o.smoothing.max(0.0) * nf;
    let ridge = PULL * lam;
    let mut b = FftBranch::default();
    // A knot's branch is needed up to the last sample it weighs (its value
    // there depends on the current before it only): shorter transforms.
    // Knots that share τ and α share one branch, up to the furthest end.
    let ends: Vec<usize> = (0..kn)
        .map(|j| {
            (0..n)
                .rev()
                .find(|&k| w[k].iter().any(|&(i, x)| i == j && x > 0.0))
                .map_or(0, |k| k + 1)
        })
        .collect();
    let shared_end = ends.iter().copied().max().unwrap_or(0);
    // Each knot's samples and its weight at each (the ones it weighs).
    let weighed: Vec<Vec<(usize, f64)>> = (0..kn)
        .map(|j| {
            (0..n)
                .filter_map(|k| {
                    let wk: f64 = w[k]
                        .iter()
                        .filter(|(i, x)| *i == j && *x > 0.0)
                        .map(|(_, x)| x)
                        .sum();
                    (wk != 0.0).then_some((k, wk))
                })
                .collect()
        })
        .collect();
    let tau_alpha_vary = o.vary[2] || o.vary[3];
    // The model at theta: the voltage and its Jacobian rows.
    let mut evaluate = |theta: &[f64]| -> (Vec<f64>, Vec<Vec<(usize, f64)>>) {
        let mut v = ocv.clone();
        // A sample is weighed by two knots at most: ten entries a row,
        // and the Butler–Volmer term's two.
        let mut rows: Vec<Vec<(usize, f64)>> = (0..n).map(|_| Vec::with_capacity(12)).collect();
        if let (Some(at), Some((a, i0))) = (l.kinetic, l.kinetic_of(theta)) {
            for (k, &i) in current.iter().enumerate() {
                let x = i / i0;
                let s = x.asinh();
                v[k] += a * s;
                rows[k].push((at, a * s));
                rows[k].push((at + 1, -a * x / (1.0 + x * x).sqrt()));
            }
        }
        type Branches = (Vec<f64>, Vec<f64>, Vec<f64>);
        let mut memo: Vec<((u64, u64, usize), std::rc::Rc<Branches>)> = vec![];
        for (j, &own_end) in ends.iter().enumerate() {
            let p = knot(theta, &l, j);
            let (r_i, r_ct) = (p[0].exp(), p[1].exp());
            let end = if tau_alpha_vary { own_end } else { shared_end };
            if end == 0 {
                continue;
            }
            let current = &current[..end];
            let key = (p[2].to_bits(), p[3].to_bits(), end);
            let found = memo.iter().find(|(k, _)| *k == key).map(|(_, x)| x.clone());
            let ys = match found {
                Some(x) => x,
                None => {
                    // The branch, with its exact derivatives for the
                    // Jacobian.
                    let [y, dt, da] = b.unit_branch_with_derivatives(p[2], p[3], rec.h, current);
                    let x = std::rc::Rc::new((y, dt, da));
                    memo.push((key, x.clone()));
                    x
                }
            };
            let (y, dy_tau, dy_alpha) = (&ys.0, &ys.1, &ys.2);
            for &(k, wk) in &weighed[j] {
                let i = current[k];
                v[k] += wk * (p[4] + r_i * i + r_ct * y[k]);
                let g = [
                    wk * r_i * i,
                    wk * r_ct * y[k],
                    wk * r_ct * dy_tau[k],
                    wk * r_ct * dy_alpha[k],
                    wk,
                ];
                for (q, gq) in g.into_iter().enumerate() {
                    rows[k].push((l.index(q, j), gq));
                }
            }
        }
        (v, rows)
    };
    let cost_of = |v: &[f64], theta: &[f64]| -> f64 {
        let data: f64 = counted
            .iter()
            .map(|&k| (v[k] - rec.voltage[k]).powi(2))
            .sum();
        let smooth: f64 = pen
            .iter()
            .map(|r| r.iter().map(|(i, c)| c * theta[*i]).sum::<f64>().powi(2))
            .sum();
        let pull: f64 = (0..l.len)
            .map(|i| ((theta[i] - start_theta[i]) / l.scale_and_bounds(i).0).powi(2))
            .sum();
        data + lam * smooth + ridge * pull
    };
    let scale_of = |i: usize| l.scale_and_bounds(i).0;
    let mut theta = start_theta.clone();
    let (mut v, mut jrows) = evaluate(&theta);
    let mut cost = cost_of(&v, &theta);
    let mut mu = 1e-3;
    let mut it = 0;
    let normal = |theta: &[f64], v: &[f64], jrows: &[Vec<(usize, f64)>]| {
        let mut a = DMatrix::<f64>::zeros(l.len, l.len);
        let mut g = DVector::<f64>::zeros(l.len);
        for &k in &counted {
            let r = v[k] - rec.voltage[k];
            let row = &jrows[k];
            for &(i, x) in row {
                g[i] += x * r;
                for &(m, y) in row {
                    a[(i, m)] += x * y;
                }
            }
        }
        for prow in &pen {
            let val: f64 = prow.iter().map(|(i, c)| c * theta[*i]).sum();
            for &(i, c) in prow {
                g[i] += lam * c * val;
                for &(m, e) in prow {
                    a[(i, m)] += lam * c * e;
                }
            }
        }
        for i in 0..l.len {
            let s = scale_of(i);
            g[i] += ridge * (theta[i] - start_theta[i]) / (s * s);
            a[(i, i)] += ridge / (s * s);
        }
        (a, g)
    };
    let (mut a, mut g) = normal(&theta, &v, &jrows);
    while it < o.iterations {
        it += 1;
        let mut damped = a.clone();
        for i in 0..l.len {
            damped[(i, i)] += mu * a[(i, i)].max(1e-12);
        }
        let Some(step) = damped.cholesky().map(|c| c.solve(&(-&g))) else {
            mu *= 10.0;
            continue;
        };
        let trial: Vec<f64> = (0..l.len)
            .map(|i| {
                let [lo, hi] = l.scale_and_bounds(i).1;
                (theta[i] + step[i]).clamp(lo, hi)
            })
            .collect();
        // The trial is taken with its Jacobian: most are accepted, and
        // the derivatives cost less than the branch run again.
        let (tv, trows) = evaluate(&trial);
        let tc = cost_of(&tv, &trial);
        if tc.is_finite() && tc < cost {
            let gain = (cost - tc) / cost.max(1e-300);
            (theta, v, jrows, cost) = (trial, tv, trows, tc);
            (a, g) = normal(&theta, &v, &jrows);
            mu = (mu / 3.0).max(1e-9);
            if gain < 1e-5 {
                break;
            }
        } else {
            mu *= 10.0;
            if mu > 1e8 {
                break;
            }
        }
    }
    let rss: f64 = counted
        .iter()
        .map(|&k| (v[k] - rec.voltage[k]).powi(2))
        .sum();
    let rmse_v = (rss / nf).sqrt();
    // Intervals: the penalised information's inverse, scaled by the
    // residual variance.
    let sigma2 = rss / (nf - l.len as f64).max(1.0);
    let cov = a.clone().try_inverse();
    let kinetic = l.kinetic_of(&theta);
    let cells: Vec<CellParameters<f64>> = (0..kn)
        .map(|j| cell_of(knot(&theta, &l, j), kinetic))
        .collect();
    // The shared Butler–Volmer term's half-widths (`ln a`, `ln i₀`): every
    // knot's, as the term is; given, not judged.
    let term: Option<[Option<f64>; 2]> = l.kinetic.map(|at| {
        let half = |i: usize| {
            cov.as_ref()
                .map(|m| sigma2 * m[(at + i, at + i)])
                .filter(|x| x.is_finite() && *x >= 0.0)
                .map(|x| Z95 * x.sqrt())
        };
        [half(0), half(1)]
    });
    let mut confidence = vec![];
    let mut reasons = vec![];
    for (j, c) in cells.iter().enumerate() {
        let var = |p: usize, q: usize| {
            cov.as_ref()
                .map(|m| sigma2 * m[(l.index(p, j), l.index(q, j))])
                .filter(|x| x.is_finite())
        };
        let half = |x: Option<f64>| x.filter(|x| *x >= 0.0).map(|x| Z95 * x.sqrt());
        // ln Q = ln τ − ln R_ct.
        let var_q = match (var(2, 2), var(1, 1), var(1, 2)) {
            (Some(a), Some(b), Some(ab)) => Some(a + b - 2.0 * ab),
            _ => None,
        };
        let log_interval = |x: f64, h: f64| [x * (-h).exp(), x * h.exp()];
        let conf = (|| {
            let (hi, hc, hq, ha) = (
                half(var(0, 0))?,
                half(var(1, 1))?,
                half(var_q)?,
                half(var(3, 3))?,
            );
            // The term's, where the map has one.
            let (bv_a, bv_i0) = match &term {
                Some([h_a, h_i0]) => (
                    h_a.map(|h| log_interval(c.bv_a, h))
                        .filter(|x| x.iter().all(|e| e.is_finite())),
                    h_i0.map(|h| log_interval(c.bv_i0, h))
                        .filter(|x| x.iter().all(|e| e.is_finite())),
                ),
                None => (None, None),
            };
            Some(Confidence {
                r_i: log_interval(c.r_i, hi),
                r_ct: log_interval(c.r_ct, hc),
                q: log_interval(c.q, hq),
                alpha: [c.alpha - ha, c.alpha + ha],
                bv_a,
                bv_i0,
            })
        })();
        let mut why = vec![];
        match &conf {
            None => why.push("the joint information matrix is singular".to_owned()),
            Some(cf) => {
                let wide = cf.too_wide();
                if !wide.is_empty() {
                    why.push(format!(
                        "95 % intervals too wide: {} beyond a factor {MAX_FACTOR} either way",
                        wide.join(", ")
                    ));
                }
                if cf.alpha[1] - cf.alpha[0] > 2.0 * MAX_ALPHA_HALF_WIDTH {
                    why.push(format!(
                        "95 % interval of α too wide (±{:.3})",
                        (cf.alpha[1] - cf.alpha[0]) / 2.0
                    ));
                }
            }
        }
        // At a bound: on it, or nearer to it than the 95 % interval
        // reaches (a value the data cannot tell from the bound, such as an
        // `R_i` of 10 µΩ beside a Butler–Volmer term that takes the whole
        // instantaneous drop).
        let k = knot(&theta, &l, j);
        for (p, name) in [(0, "R_i"), (1, "R_ct"), (2, "τ"), (3, "α")] {
            let reach = half(var(p, p)).unwrap_or(0.0).max(1e-6);
            if k[p] <= BOUNDS[p][0] + reach || k[p] >= BOUNDS[p][1] - reach {
                why.push(format!("{name} at a bound of the joint search"));
            }
        }
        confidence.push(conf);
        reasons.push(why);
    }
    let rows = counted
        .iter()
        .map(|&k| (k, v[k] - rec.voltage[k], jrows[k].clone()))
        .collect();
    Ok(JointFit {
        cells,
        theta,
        rmse_v,
        model_v: v,
        confidence,
        reasons,
        iterations: it,
        start: start.to_vec(),
        smoothing: o.smoothing,
        vary: o.vary,
        hessian: a,
        rows,
    })
}

impl JointFit {
    /// The prediction error of each fold (samples `folds[f]`, a mask over
    /// the record) left out: one Newton step from this fit without the
    /// fold's samples, then the RMSE of the fold's residuals after it.
    /// `None` for a fold without counted samples or a singular step.
    pub fn left_out(&self, fold: &[bool]) -> Option<(f64, usize)> {
        let dim = self.hessian.nrows();
        let mut h = self.hessian.clone();
        let mut jr = DVector::<f64>::zeros(dim);
        let mut inside = vec![];
        for (k, r, row) in &self.rows {
            if !fold.get(*k).copied().unwrap_or(false) {
                continue;
            }
            for &(i, x) in row {
                jr[i] += x * r;
                for &(m, y) in row {
                    h[(i, m)] -= x * y;
                }
            }
            inside.push((*r, row));
        }
        if inside.is_empty() {
            return None;
        }
        // The fit without the fold: the gradient there is −J_fᵀ r_f.
        let step = h.cholesky()?.solve(&(-jr));
        let sse: f64 = inside
            .iter()
            .map(|(r, row)| {
                let moved: f64 = row.iter().map(|(i, x)| x * step[*i]).sum();
                (r + moved).powi(2)
            })
            .sum();
        Some(((sse / inside.len() as f64).sqrt(), inside.len()))
    }
}

/// The candidates [`choose`] tries: penalties (V²) and varying sets.
pub const SMOOTHING_GRID: [f64; 4] = [1e-7, 1e-6, 1e-5, 1e-4];

/// The varying sets [`choose`] tries: every parameter; R_i, R_ct and ΔU
/// (the slow part's τ and α shared); R_i and ΔU alone.
pub const VARY_SETS: [[bool; 5]; 3] = [
    [true, true, true, true, true],
    [true, true, false, false, true],
    [true, false, false, false, true],
];

/// Fits the candidates of `smoothing` × `vary` (each from the last fit
/// of the same varying set, from the largest penalty down) and takes the
/// one whose folds, each left out, are predicted best. Down one set's
/// penalties, the first score above the one before ends that set: past
/// the least left-out error, less smoothing only fits the data it sees
/// more closely (and the smallest penalties take the most iterations).
///
/// # Errors
/// As [`joint_fit`]; [`crate::ErrorKind::Data`] when no candidate could
/// be scored.
pub fn choose(
    d: &JointData<'_>,
    start: &[CellParameters<f64>],
    folds: &[Vec<bool>],
    smoothing: &[f64],
    vary: &[[bool; 5]],
    iterations: usize,
) -> Result<(JointFit, Vec<Candidate>)> {
    let mut best: Option<(f64, JointFit)> = None;
    let mut tried = vec![];
    for &set in vary {
        let mut before = f64::INFINITY;
        let mut from = start.to_vec();
        let mut lams = smoothing.to_vec();
        lams.sort_by(|a, b| b.total_cmp(a));
        for lam in lams {
            let o = JointOptions {
                smoothing: lam,
                vary: set,
                iterations,
            };
            let fit = joint_fit(d, &from, &o)?;
            let (mut sse, mut count) = (0.0, 0usize);
            for f in folds {
                if let Some((r, m)) = fit.left_out(f) {
                    sse += r * r * m as f64;
                    count += m;
                }
            }
            let score = if count > 0 {
                (sse / count as f64).sqrt()
            } else {
                f64::NAN
            };
            tried.push(Candidate {
                smoothing: lam,
                vary: set,
                rmse_v: fit.rmse_v,
                left_out_rmse_v: score,
                iterations: fit.iterations,
            });
            from.clone_from(&fit.cells);
            if score.is_finite() && best.as_ref().is_none_or(|(s, _)| score < *s) {
                best = Some((score, fit));
            }
            if score > before {
                break;
            }
            before = score;
        }
    }
    best.map(|(_, f)| (f, tried)).ok_or_else(|| {
        err!(
            Data,
            "no joint map candidate could be scored by leaving levels out"
        )
    })
}

/// The joint fit's Levenberg–Marquardt iterations per candidate at most.
pub const JOINT_ITERATIONS: usize = 25;

/// The knot nearest SOC `z`.
pub fn nearest(knots: &[f64], z: f64) -> usize {
    (0..knots.len())
        .min_by(|&a, &b| (knots[a] - z).abs().total_cmp(&(knots[b] - z).abs()))
        .unwrap_or(0)
}

/// The samples of `rec`'s stretches of one sign of current beyond 1 % of
/// its largest, lasting at least `min_s`: the long discharges (and
/// charges) a BMS most needs predicted.
pub fn long_discharges(rec: &BatteryRecord, min_s: f64) -> Vec<bool> {
    let n = rec.current.len();
    let big = rec
        .current
        .iter()
        .filter(|x| x.is_finite())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    let sign = |i: f64| {
        if i.is_finite() && i.abs() > 0.01 * big {
            i.signum() as i8
        } else {
            0
        }
    };
    let mut out = vec![false; n];
    let mut k = 0;
    while k < n {
        let s = sign(rec.current[k]);
        let a = k;
        while k < n && sign(rec.current[k]) == s {
            k += 1;
        }
        if s != 0 && (k - a) as f64 * rec.h >= min_s {
            out[a..k].fill(true);
        }
        if k == a {
            k += 1;
        }
    }
    out
}
