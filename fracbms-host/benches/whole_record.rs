//! Host cost of whole-record fits with the full memory (issue 34,
//! docs/performance.md): one refinement from one start to convergence, on
//! records of 1 000, 8 000 and 50 000 rows at 1 s, the constant-phase branch
//! solved by FFT ([`fracbms_host::branch`]); one branch solve (a
//! simulation) by FFT against the direct recursion; and the paper
//! regression's tap sums of one weight set against two sequences (its
//! regressors at one order) by FFT against the direct kernels, where
//! `SUMS_DIRECT_TAPS` and `SUMS_DIRECT_ROWS` put the crossover.
//!
//! The records: pulses of −5..5 A lasting 5–200 s, rests between half of
//! them, through the 18650 cell of `CellParameters::cell_18650` with the
//! full memory (plus, for the Butler–Volmer rows, `0.01·asinh(I/1 A)`),
//! and a seeded 1 mV noise. The start is `bench/scaling.py`'s: the first
//! of `identify battery`'s rough starts (`rough_starts`).
//!
//! `cargo bench -p fracbms-host --bench whole_record` (about 3 minutes).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use estimator_core::battery::branch::{BranchSolver, GlRecursion};
use estimator_core::battery::CellParameters;
use estimator_core::frac::{DirectSums, GlWeights, TapSums};
use fracbms_host::branch::{FftBranch, FftSums};
use fracbms_host::identify::battery::rough_starts;
use fracbms_host::identify::refine::refine_from_start;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

fn record(n: usize, kinetic: bool) -> (Vec<f64>, Vec<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(n as u64);
    let mut i = vec![0.0; n];
    let mut k = 0;
    while k < n {
        let len = rng.random_range(5..200);
        let level = rng.random_range(-5.0..5.0);
        for x in i.iter_mut().skip(k).take(len) {
            *x = level;
        }
        k += len;
        if rng.random::<f64>() < 0.5 {
            k += rng.random_range(10..600);
        }
    }
    let mut cell = CellParameters::cell_18650();
    if kinetic {
        cell.bv_a = 0.01;
        cell.bv_i0 = 1.0;
    }
    let mut v = FftBranch::default().simulate(&cell, 1.0, &i);
    for x in &mut v {
        *x += 1e-3 * (rng.random::<f64>() * 2.0 - 1.0) * 3f64.sqrt();
    }
    (i, v)
}

fn start(i: &[f64], v: &[f64], kinetic: bool) -> CellParameters<f64> {
    let p = rough_starts(i, v)[0];
    if kinetic {
        p.with_butler_volmer(0.3 * i.iter().fold(0.0f64, |m, x| m.max(x.abs())))
    } else {
        p
    }
}

fn fits(c: &mut Criterion) {
    let mut g = c.benchmark_group("whole_record_fit");
    g.sample_size(10);
    for n in [1000, 8000, 50_000] {
        for (name, kinetic) in [("linear", false), ("butler_volmer", true)] {
            let (i, v) = record(n, kinetic);
            let p = start(&i, &v, kinetic);
            g.bench_with_input(BenchmarkId::new(name, n), &n, |b, _| {
                b.iter(|| {
                    fracbms_host::worker::on_worker(|| refine_from_start(1.0, &i, &v, p))
                        .map(|f| black_box(f.rmse_v))
                        .unwrap()
                })
            });
        }
    }
    g.finish();
}

fn branch(c: &mut Criterion) {
    let mut g = c.benchmark_group("branch_solve");
    g.sample_size(10);
    const MEM: usize = 8192;
    for n in [1000, 8000] {
        let (i, _) = record(n, false);
        let w = Box::new(GlWeights::<f64, MEM>::new(0.75, 1.0, n).unwrap());
        let mut x = vec![0.0; n];
        g.bench_with_input(BenchmarkId::new("direct", n), &n, |b, _| {
            b.iter(|| GlRecursion.filter(w.weights(), 8.0, 0, &mut x, |l| i[l], |_, _, _| {}))
        });
        let mut fft = FftBranch::default();
        g.bench_with_input(BenchmarkId::new("fft", n), &n, |b, _| {
            b.iter(|| fft.filter(w.weights(), 8.0, 0, &mut x, |l| i[l], |_, _, _| {}))
        });
    }
    g.finish();
}

fn tap_sums(c: &mut Criterion) {
    let mut g = c.benchmark_group("tap_sums_pair");
    g.sample_size(20);
    for (n, m) in [
        (1024, 256),
        (2048, 32),
        (2048, 64),
        (2048, 256),
        (8000, 256),
    ] {
        let (i, v) = record(n, false);
        // A new order at every call (its weights computed on both sides):
        // the weights' spectrum is taken each time, as at each of the
        // regression's order steps; the sequences' are kept.
        let mut w = GlWeights::<f64, 256>::new(0.6, 1.0, m).unwrap();
        let mut out = vec![0.0; n];
        let id = format!("{n}_rows_{m}_taps");
        let mut k = 0u32;
        let mut step = move |w: &mut GlWeights<f64, 256>| {
            k = (k + 1) % 1000;
            w.set_order(0.6 + 1e-6 * f64::from(k)).unwrap();
        };
        g.bench_with_input(BenchmarkId::new("direct", &id), &n, |b, _| {
            b.iter(|| {
                step(&mut w);
                DirectSums.pair(w.weights(), &i, &v, m - 1..n, |l, a, c| out[l] = a + c)
            })
        });
        let mut fft = FftSums::default();
        g.bench_with_input(BenchmarkId::new("fft", &id), &n, |b, _| {
            b.iter(|| {
                step(&mut w);
                fft.pair(w.weights(), &i, &v, m - 1..n, |l, a, c| out[l] = a + c)
            })
        });
    }
    g.finish();
}

criterion_group!(benches, fits, branch, tap_sums);
criterion_main!(benches);
