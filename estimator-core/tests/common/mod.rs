//! Test helpers: data from eq. (4), the least-squares reference, δ; the
//! NMC curve of the battery tests.
#![allow(dead_code)]

use estimator_core::battery::ocv::{OcvModel, OcvTable};
use estimator_core::battery::profile::{ocv_nmc, Profile};
use estimator_core::battery::simulate::simulate;
use estimator_core::battery::CellParameters;
use estimator_core::frac::GlWeights;
use estimator_core::model::{Basis, HammersteinSystem, Polynomial};
use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// An identifiable setting (orders 2/3/2, m = 2): every polynomial stable
/// (see `host-sim`'s stability check), the noise-free output dominates σ.
pub const A: [f64; 2] = [-0.5, 0.2];
pub const B: [f64; 3] = [1.0, 0.5, -0.3];
pub const C: [f64; 2] = [0.3, -0.2];
pub const GAMMA: [f64; 2] = [1.0, 0.5];
pub const ALPHA: f64 = 0.6;

pub fn system() -> HammersteinSystem<'static, f64> {
    HammersteinSystem {
        a: &A,
        b: &B,
        c: &C,
        gamma: &GAMMA,
        alpha: ALPHA,
    }
}

pub struct Data {
    pub u: Vec<f64>,
    pub v: Vec<f64>,
    pub y: Vec<f64>,
    pub e: Vec<f64>,
}

/// Unit-variance Gaussian input, white noise of standard deviation `sigma`.
pub fn generate<const MEM: usize>(
    sys: &HammersteinSystem<'_, f64>,
    len: usize,
    memory: usize,
    sigma: f64,
    seed: u64,
) -> Data {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n01 = Normal::new(0.0, 1.0).unwrap();
    let u: Vec<f64> = (0..len).map(|_| n01.sample(&mut rng)).collect();
    let v: Vec<f64> = (0..len).map(|_| sigma * n01.sample(&mut rng)).collect();
    let (mut y, mut e) = (vec![0.0; len], vec![0.0; len]);
    let w = GlWeights::<f64, MEM>::new(sys.alpha, 1.0, memory).unwrap();
    sys.simulate(&Polynomial, &w, &u, &v, &mut y, &mut e)
        .unwrap();
    Data { u, v, y, e }
}

/// True parameter vector p = [a, c, b_i γ_j (i-major), α].
pub fn truth(sys: &HammersteinSystem<'_, f64>) -> Vec<f64> {
    let mut p: Vec<f64> = sys.a.iter().chain(sys.c).copied().collect();
    for &b in sys.b {
        for &g in sys.gamma {
            p.push(b * g);
        }
    }
    p.push(sys.alpha);
    p
}

pub fn delta(p: &[f64], truth: &[f64]) -> f64 {
    let num: f64 = p.iter().zip(truth).map(|(a, b)| (a - b).powi(2)).sum();
    let den: f64 = truth.iter().map(|b| b * b).sum();
    (num / den).sqrt()
}

/// The best achievable reference: least squares on eq. (4) with the true α
/// and the true noise sequence e (α entry exact).
pub fn ls_reference<const MEM: usize>(
    sys: &HammersteinSystem<'_, f64>,
    d: &Data,
    memory: usize,
) -> Vec<f64> {
    ls_at::<MEM>(sys, d, memory, sys.alpha).0
}

/// The reference that must also find α: least squares with the true noise
/// sequence e at each α, α minimizing the residual (golden-section search on
/// [0.05, 1.5]).
pub fn ls_reference_unknown_order<const MEM: usize>(
    sys: &HammersteinSystem<'_, f64>,
    d: &Data,
    memory: usize,
) -> Vec<f64> {
    let f = |a: f64| ls_at::<MEM>(sys, d, memory, a).1;
    let (mut lo, mut hi) = (0.05f64, 1.5f64);
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..60 {
        if f1 < f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - g * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + g * (hi - lo);
            f2 = f(x2);
        }
    }
    ls_at::<MEM>(sys, d, memory, 0.5 * (lo + hi)).0
}

/// Least squares on eq. (4) at order `alpha` with the true e: (p, residual).
fn ls_at<const MEM: usize>(
    sys: &HammersteinSystem<'_, f64>,
    d: &Data,
    memory: usize,
    alpha: f64,
) -> (Vec<f64>, f64) {
    let o = sys.orders();
    let w = GlWeights::<f64, MEM>::new(alpha, 1.0, memory).unwrap();
    let n = d.y.len();
    let dy: Vec<f64> = (0..n).map(|l| w.difference(&d.y, l)).collect();
    let de: Vec<f64> = (0..n).map(|l| w.difference(&d.e, l)).collect();
    let df: Vec<Vec<f64>> = (0..o.m)
        .map(|j| {
            let f: Vec<f64> = d.u.iter().map(|&u| Polynomial.eval(j, u)).collect();
            (0..n).map(|l| w.difference(&f, l)).collect()
        })
        .collect();
    let lag = |x: &[f64], l: usize, i: usize| if l >= i { x[l - i] } else { 0.0 };
    let cols = o.na + o.nc + o.products();
    let phi = DMatrix::from_fn(n, cols, |l, k| {
        if k < o.na {
            -lag(&dy, l, k + 1)
        } else if k < o.na + o.nc {
            -lag(&de, l, k - o.na + 1)
        } else {
            let q = k - o.na - o.nc;
            lag(&df[q % o.m], l, q / o.m + 1)
        }
    });
    let y = DVector::from_column_slice(&d.y);
    let sol = phi.clone().svd(true, true).solve(&y, 1e-12).unwrap();
    let rss = (&y - &phi * &sol).norm_squared();
    let mut p: Vec<f64> = sol.iter().copied().collect();
    p.push(alpha);
    (p, rss)
}

/// Noise-free output power over noise power (the signal-to-noise ratio).
pub fn snr<const MEM: usize>(sys: &HammersteinSystem<'_, f64>, d: &Data, memory: usize) -> f64 {
    let w = GlWeights::<f64, MEM>::new(sys.alpha, 1.0, memory).unwrap();
    let zero = vec![0.0; d.u.len()];
    let (mut y0, mut e0) = (vec![0.0; d.u.len()], vec![0.0; d.u.len()]);
    sys.simulate(&Polynomial, &w, &d.u, &zero, &mut y0, &mut e0)
        .unwrap();
    let p = |x: &[f64]| x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64;
    let noise: Vec<f64> = d.y.iter().zip(&y0).map(|(a, b)| a - b).collect();
    p(&y0) / p(&noise)
}

/// Median of a non-empty sample.
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The NMC curve sampled every 1 % of SOC, as a BMS would store it.
pub fn nmc_table() -> OcvTable<f64, 101> {
    let soc: Vec<f64> = (0..=100).map(|k| k as f64 / 100.0).collect();
    let ocv: Vec<f64> = soc.iter().map(|&z| ocv_nmc(z)).collect();
    OcvTable::new(&soc, &ocv).unwrap()
}

/// The capacity of [`pulse_record`]'s cell (A·h).
pub const CAPACITY_AH: f64 = 2.5;

/// The `cell` preset's pulse profile (±6 A) on a 1.5 A mean discharge from
/// SOC 0.9 with a 60 s rest first: SOC 0.9 → 0.4 in 3060 s through the
/// nonlinear NMC curve; full-memory simulation, σ = 1 mV. Returns current,
/// voltage and the true SOC after each sample.
pub fn pulse_record(seed: u64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let truth = CellParameters::<f64>::cell_18650();
    let len = 3060;
    let i: Vec<f64> = (0..len)
        .map(|l| {
            if l < 60 {
                0.0
            } else {
                Profile::Pulse.current((l - 60) as f64, 6.0) - 1.5
            }
        })
        .collect();
    let v = noisy_seeded(truth_voltage(&truth, &i), len, seed);
    (i.clone(), v, true_soc(&i))
}

/// The NMC curve as the OCV model of a [`CAPACITY_AH`] cell.
pub fn nmc() -> OcvModel<f64, 101> {
    OcvModel::new(nmc_table(), CAPACITY_AH).unwrap()
}

/// Cell `p`'s terminal voltage under current `i` through the NMC curve
/// from SOC 0.9 (full-memory simulation).
pub fn truth_voltage(p: &CellParameters<f64>, i: &[f64]) -> Vec<f64> {
    let len = i.len();
    let soc = true_soc(i);
    let mut w = Box::new(GlWeights::<f64, 4096>::new(p.alpha, 1.0, len).unwrap());
    let (mut up, mut v) = (vec![0.0; len], vec![0.0; len]);
    simulate(p, &mut w, i, |l| ocv_nmc(soc[l]), &mut up, &mut v).unwrap();
    v
}

/// `v` with σ = 1 mV on its first `seen` samples (the ones the estimator
/// sees).
pub fn noisy(v: Vec<f64>, seen: usize) -> Vec<f64> {
    noisy_seeded(v, seen, 7)
}

/// [`noisy`] with its noise drawn from `seed`.
pub fn noisy_seeded(mut v: Vec<f64>, seen: usize, seed: u64) -> Vec<f64> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let nd = Normal::new(0.0, 0.001).unwrap();
    for x in &mut v[..seen] {
        *x += nd.sample(&mut rng);
    }
    v
}

/// The true SOC after each sample of current `i` (A, + charging) from 0.9,
/// counted at [`CAPACITY_AH`].
pub fn true_soc(i: &[f64]) -> Vec<f64> {
    let mut z = 0.9;
    i.iter()
        .map(|&x| {
            z += x / (CAPACITY_AH * 3600.0);
            z
        })
        .collect()
}
