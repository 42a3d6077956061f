//! Host cost of one iteration of each algorithm, and of one sliding-window
//! update, in `f64` and `f32`.
//!
//! * `op_gi` / `kt_gi`: one 2S-OP-GI / KT-2S-GI iteration on eq. (4) with
//!   the paper's orders (2/3/2, m = 2), window L, memory M.
//! * `battery_paper` / `battery_refined`: one 2S-OP-GI iteration on the
//!   battery regression (§6.2) / one output-error LM iteration (from the
//!   same start each time: the simulation of the start, its sensitivities
//!   and the trial steps).
//! * `update`: one `CellEstimator::push` (validation, window, K = 5
//!   iterations of the paper method or of the refinement) at (256, 64).
//!
//! Sizes: L ∈ {256, 1000, 4000}, M ∈ {32, 64, 256, L}. An iteration is
//! timed on a state that has already iterated (the window's differences
//! loaded), so the numbers are the steady per-iteration cost.
//!
//! `cargo bench -p estimator-core --bench iteration` (about 15 minutes);
//! `-- 'op_gi/f64'` for a subset. `docs/performance.md` has the results.

#[path = "../tests/common/mod.rs"]
mod common;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use estimator_core::battery::online::{CellEstimator, Method, OnlineSettings};
use estimator_core::battery::output_error::OutputErrorRefinement;
use estimator_core::battery::profile::Profile;
use estimator_core::battery::regression::PaperRegressionGi;
use estimator_core::battery::simulate::simulate;
use estimator_core::battery::{BatterySettings, CellParameters, Start};
use estimator_core::frac::GlWeights;
use estimator_core::gi::key_term::KeyTermGi;
use estimator_core::gi::over_param::OverParamGi;
use estimator_core::gi::GiSettings;
use estimator_core::model::{Orders, Polynomial};
use estimator_core::real::Real;
use estimator_core::window::SampleWindow;
use std::hint::black_box;
use std::time::Duration;

/// Memories benchmarked for a window of `l` samples.
fn memories(l: usize) -> Vec<usize> {
    let mut m: Vec<usize> = [32, 64, 256].into_iter().filter(|&m| m < l).collect();
    m.push(l);
    m
}

/// Eq. (4) with the paper's system, σ = 0.2.
fn hammerstein(len: usize) -> (Vec<f64>, Vec<f64>) {
    let d = common::generate::<64>(&common::system(), len, 64, 0.2, 1);
    (d.u, d.y)
}

/// The 18650-like cell under the pulse profile, σ = 1 mV.
fn battery(len: usize) -> (Vec<f64>, Vec<f64>) {
    let p = CellParameters::<f64>::cell_18650();
    let i: Vec<f64> = (0..len)
        .map(|l| Profile::Pulse.current(l as f64, 6.0))
        .collect();
    let mut w = Box::new(GlWeights::<f64, 256>::new(p.alpha, 1.0, 256).unwrap());
    let (mut up, mut v) = (vec![0.0; len], vec![0.0; len]);
    simulate(&p, &mut w, &i, |_| p.u_oc, &mut up, &mut v).unwrap();
    let v = v
        .iter()
        .enumerate()
        .map(|(l, x)| x + 1e-3 * ((l as f64 * 12.9898).sin() * 43758.5453).fract())
        .collect();
    (i, v)
}

fn window<T: Real, const N: usize>(u: &[f64], y: &[f64]) -> Box<SampleWindow<T, N>> {
    let mut w = Box::new(SampleWindow::new());
    for (&a, &b) in u.iter().zip(y) {
        w.push(T::lit(a), T::lit(b)).unwrap();
    }
    w
}

macro_rules! sizes {
    ($name:ident, $t:ty, $tn:literal, $l:literal) => {
        fn $name(c: &mut Criterion) {
            const L: usize = $l;
            let (u, y) = hammerstein(L);
            let hw = window::<$t, L>(&u, &y);
            let (i, v) = battery(L);
            let bw = window::<$t, L>(&i, &v);
            for m in memories(L) {
                let s = GiSettings::<$t>::new(Orders::PAPER, m);
                let mut g = c.benchmark_group(format!("op_gi/{}", $tn));
                let mut op =
                    Box::new(OverParamGi::<$t, L, L, 2, 3, 2, 2, 6>::new(&s, 0.5).unwrap());
                let _ = op.iterate(&s, &Polynomial, &hw);
                g.bench_with_input(BenchmarkId::new(format!("L{L}"), m), &m, |b, _| {
                    b.iter(|| black_box(op.iterate(&s, &Polynomial, &hw)))
                });
                g.finish();
                let mut g = c.benchmark_group(format!("kt_gi/{}", $tn));
                let mut kt = Box::new(KeyTermGi::<$t, L, L, 2, 3, 2, 2, 6>::new(&s, 0.5).unwrap());
                let _ = kt.iterate(&s, &Polynomial, &hw);
                g.bench_with_input(BenchmarkId::new(format!("L{L}"), m), &m, |b, _| {
                    b.iter(|| black_box(kt.iterate(&s, &Polynomial, &hw)))
                });
                g.finish();
                let bs = BatterySettings::<$t>::new(1.0, m);
                let mut g = c.benchmark_group(format!("battery_paper/{}", $tn));
                let mut gi = Box::new(PaperRegressionGi::<$t, L, L>::new(&bs, 0.5).unwrap());
                let _ = gi.iterate(&bs, &*bw);
                g.bench_with_input(BenchmarkId::new(format!("L{L}"), m), &m, |b, _| {
                    b.iter(|| black_box(gi.iterate(&bs, &*bw)))
                });
                g.finish();
                let mut bs = bs;
                bs.start = Start::FromData;
                let start = CellParameters::<$t>::cell_18650();
                let mut g = c.benchmark_group(format!("battery_refined/{}", $tn));
                let mut oe = Box::new(OutputErrorRefinement::<$t, L, L>::new(&bs, start).unwrap());
                let _ = oe.iterate(&bs, &*bw);
                // From the same start each time: repeated iterations on one
                // window would reach its minimum and then stop at once.
                g.bench_with_input(BenchmarkId::new(format!("L{L}"), m), &m, |b, _| {
                    b.iter(|| {
                        let _ = oe.set_cell(&bs, start);
                        black_box(oe.iterate(&bs, &*bw))
                    })
                });
                g.finish();
            }
        }
    };
}

sizes!(f64_256, f64, "f64", 256);
sizes!(f64_1000, f64, "f64", 1000);
sizes!(f64_4000, f64, "f64", 4000);
sizes!(f32_256, f32, "f32", 256);
sizes!(f32_1000, f32, "f32", 1000);
sizes!(f32_4000, f32, "f32", 4000);

/// One sliding-window update at (256, 64): push + 5 iterations.
fn update<T: Real>(c: &mut Criterion, tn: &str) {
    const L: usize = 256;
    let (i, v) = battery(4000);
    for method in [Method::Paper, Method::Refined] {
        let mut s = OnlineSettings::<T>::new(T::one(), 64, CellParameters::cell_18650());
        s.battery.start = Start::AtRest;
        s.method = method;
        s.iterations_per_sample = 5;
        let mut cell = Box::new(CellEstimator::<T, L, 64>::new(&s).unwrap());
        // Past the start-up: the window has slid and the method runs.
        for k in 0..2 * L {
            cell.push(&s, T::lit(i[k]), T::lit(v[k]));
        }
        let mut k = 2 * L;
        let name = match method {
            Method::Paper => "paper",
            Method::Refined => "refined",
        };
        c.bench_function(&format!("update/{tn}/{name}/L256_M64_K5"), |b| {
            b.iter(|| {
                k = if k + 1 < i.len() { k + 1 } else { 2 * L };
                black_box(cell.push(&s, T::lit(i[k]), T::lit(v[k])))
            })
        });
    }
}

fn updates(c: &mut Criterion) {
    update::<f64>(c, "f64");
    update::<f32>(c, "f32");
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    targets = updates, f64_256, f64_1000, f64_4000, f32_256, f32_1000, f32_4000
}
criterion_main!(benches);
