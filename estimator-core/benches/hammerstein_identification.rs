//! Host cost of one whole Hammerstein identification on the stable variant
//! of the paper's KT example (`paper-kt-stable`: L = 1000, full memory
//! M = 1000, σ = 0.5), in `f64`:
//!
//! * `paper/op_100`, `paper/kt_100`: 100 iterations of 2S-OP-GI /
//!   KT-2S-GI from the paper's start (the tables' setting);
//! * `refined/from_op`: the prediction-error refinement from the 2S-OP-GI
//!   estimate until it converges (the global search over α included);
//!   add `paper/op_100` for the whole `identify hammerstein --method
//!   refined`;
//! * `refined_iteration/search`, `refined_iteration/descent`: one iteration
//!   of the refinement in each phase.
//!
//! `cargo bench -p estimator-core --bench hammerstein_identification`
//! (about 2 minutes). docs/identification.md has the results.

#[path = "../tests/common/mod.rs"]
mod common;

use criterion::{criterion_group, criterion_main, Criterion};
use estimator_core::gi::key_term::KeyTermGi;
use estimator_core::gi::over_param::OverParamGi;
use estimator_core::gi::prediction_error::{PaperPredictionError, Phase, PredictionErrorSettings};
use estimator_core::gi::{GiSettings, HammersteinEstimate};
use estimator_core::model::{HammersteinSystem, Orders, Polynomial};
use estimator_core::window::SampleWindow;
use std::hint::black_box;
use std::time::Duration;

const L: usize = 1000;
type Estimate = HammersteinEstimate<f64, 2, 3, 2, 2, 6>;

fn record() -> Box<SampleWindow<f64, L>> {
    let sys = HammersteinSystem {
        a: &[-0.021, -0.007],
        b: &[1.0, -0.008, 0.023],
        c: &[-0.35, 0.61],
        gamma: &[-1.7, -0.04],
        alpha: 0.3,
    };
    let d = common::generate::<L>(&sys, L, L, 0.5, 1);
    let mut w = Box::new(SampleWindow::new());
    for (&u, &y) in d.u.iter().zip(&d.y) {
        w.push(u, y).unwrap();
    }
    w
}

fn settings() -> GiSettings<f64> {
    let mut s = GiSettings::new(Orders::PAPER, L);
    s.epsilon = 0.0; // exactly 100 iterations
    s
}

fn paper_op(w: &SampleWindow<f64, L>) -> Estimate {
    let s = settings();
    let mut gi = Box::new(OverParamGi::<f64, L, L, 2, 3, 2, 2, 6>::new(&s, 0.25).unwrap());
    for _ in 0..100 {
        gi.iterate(&s, &Polynomial, w).unwrap();
    }
    *gi.estimate()
}

fn paper_kt(w: &SampleWindow<f64, L>) -> Estimate {
    let s = settings();
    let mut gi = Box::new(KeyTermGi::<f64, L, L, 2, 3, 2, 2, 6>::new(&s, 0.25).unwrap());
    for _ in 0..100 {
        gi.iterate(&s, &Polynomial, w).unwrap();
    }
    gi.products()
}

fn identification(c: &mut Criterion) {
    let w = record();
    c.bench_function("paper/op_100", |b| b.iter(|| black_box(paper_op(&w))));
    c.bench_function("paper/kt_100", |b| b.iter(|| black_box(paper_kt(&w))));
    let start = paper_op(&w);
    let ps = PredictionErrorSettings::new(GiSettings::new(Orders::PAPER, L));
    let mut r = Box::new(PaperPredictionError::<f64, L, L>::new(&ps, &start).unwrap());
    c.bench_function("refined/from_op", |b| {
        b.iter(|| {
            r.restart(&ps, &start).unwrap();
            r.run(&ps, &Polynomial, &w, 400).unwrap();
            black_box(*r.estimate())
        })
    });
    // One iteration in each phase, each from the same state.
    r.restart(&ps, &start).unwrap();
    r.iterate(&ps, &Polynomial, &w).unwrap(); // the differences loaded
    let search = r.clone();
    while r.phase() != Phase::Descent {
        r.iterate(&ps, &Polynomial, &w).unwrap();
    }
    let descent = r.clone();
    for (name, state) in [("search", search), ("descent", descent)] {
        c.bench_function(&format!("refined_iteration/{name}"), |b| {
            b.iter_batched_ref(
                || Box::new(state.clone()),
                |s| black_box(s.iterate(&ps, &Polynomial, &w).unwrap()),
                criterion::BatchSize::LargeInput,
            )
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(5));
    targets = identification
}
criterion_main!(benches);
