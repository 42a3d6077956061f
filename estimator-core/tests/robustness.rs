//! Bad data, capacities, the sliding window, warm starts, f32, normalization
//! and footprint. Nothing may panic; errors are typed; the last good estimate
//! survives every error.

mod common;

use common::*;
use estimator_core::error::OrderKind;
use estimator_core::gi::key_term::KeyTermGi;
use estimator_core::gi::over_param::{OverParamGi, PaperOverParamGi};
use estimator_core::gi::{GiSettings, HammersteinEstimate, Normalization, Prehistory};
use estimator_core::model::{Orders, Polynomial};
use estimator_core::window::SampleWindow;
use estimator_core::Error;
use proptest::prelude::*;

type Op = OverParamGi<f64, 256, 32, 2, 3, 2, 2, 6>;
type Kt = KeyTermGi<f64, 256, 32, 2, 3, 2, 2, 6>;

fn paper_settings() -> GiSettings<f64> {
    GiSettings::new(Orders::PAPER, 32)
}

fn filled(n: usize, f: impl Fn(usize) -> (f64, f64)) -> SampleWindow<f64, 256> {
    let mut w = SampleWindow::new();
    for l in 0..n {
        let (u, y) = f(l);
        w.push(u, y).unwrap();
    }
    w
}

#[test]
fn non_finite_samples_are_rejected_and_counted() {
    let mut w = SampleWindow::<f32, 8>::new();
    w.push(1.0, 2.0).unwrap();
    assert_eq!(w.push(f32::NAN, 0.0), Err(Error::NonFiniteSample));
    assert_eq!(w.push(0.0, f32::INFINITY), Err(Error::NonFiniteSample));
    assert_eq!(
        w.push(f32::NEG_INFINITY, f32::NAN),
        Err(Error::NonFiniteSample)
    );
    w.push(3.0, 4.0).unwrap();
    assert_eq!(w.len(), 2, "good samples are all kept");
    assert_eq!(w.rejected(), 3);
    assert_eq!(w.inputs().collect::<Vec<_>>(), [1.0, 3.0]);
}

#[test]
fn window_slides_in_order() {
    let mut w = SampleWindow::<f64, 4>::new();
    for i in 0..10 {
        w.push(i as f64, -(i as f64)).unwrap();
        assert!(w.len() <= 4);
    }
    assert!(w.is_full() && w.has_slid());
    assert_eq!(w.inputs().collect::<Vec<_>>(), [6.0, 7.0, 8.0, 9.0]);
    assert_eq!(w.outputs().collect::<Vec<_>>(), [-6.0, -7.0, -8.0, -9.0]);
    assert_eq!(w.pushed(), 10);
    assert_eq!(w.version(), 10);
    // A clear is a change of contents: the version moves on, so a cache
    // keyed on it never takes the next push for "one more sample".
    w.clear();
    assert_eq!((w.len(), w.pushed(), w.version()), (0, 0, 11));
    w.push(1.0, 2.0).unwrap();
    assert_eq!((w.pushed(), w.version()), (1, 12));
}

#[test]
fn window_not_full_enough_is_an_error_and_keeps_the_estimate() {
    let s = paper_settings();
    let mut gi = Op::new(&s, 0.5).unwrap();
    let before = *gi.estimate();
    let w = filled(5, |l| (l as f64, 0.0));
    assert!(matches!(
        gi.iterate(&s, &Polynomial, &w),
        Err(Error::NotEnoughData { have: 5, need: 11 })
    ));
    assert_eq!(*gi.estimate(), before);
    assert_eq!(gi.iterations(), 0);
}

#[test]
fn orders_above_capacity_are_rejected() {
    let mut s = paper_settings();
    s.orders.na = 3;
    assert_eq!(
        Op::new(&s, 0.5).unwrap_err(),
        Error::OrderOutOfRange {
            which: OrderKind::Na,
            value: 3,
            capacity: 2
        }
    );
    s.orders = Orders {
        na: 1,
        nb: 3,
        nc: 1,
        m: 2,
    };
    // NP = 4 < n_b·m = 6.
    assert_eq!(
        OverParamGi::<f64, 64, 8, 2, 3, 2, 2, 4>::new(&s, 0.5).unwrap_err(),
        Error::ParameterCapacity {
            needed: 6,
            capacity: 4
        }
    );
    s.orders = Orders {
        na: 1,
        nb: 0,
        nc: 1,
        m: 2,
    };
    assert!(matches!(
        Op::new(&s, 0.5),
        Err(Error::OrderOutOfRange {
            which: OrderKind::Nb,
            ..
        })
    ));
    s.orders = Orders {
        na: 1,
        nb: 1,
        nc: 1,
        m: 0,
    };
    assert!(matches!(
        Kt::new(&s, 0.5),
        Err(Error::OrderOutOfRange {
            which: OrderKind::Basis,
            ..
        })
    ));
    let mut s = paper_settings();
    s.memory = 33;
    assert!(matches!(Op::new(&s, 0.5), Err(Error::Frac(_))));
    let s = paper_settings();
    for alpha0 in [0.0, 2.0, -1.0, f64::NAN] {
        assert_eq!(Op::new(&s, alpha0).unwrap_err(), Error::BadSetting);
    }
    let mut bad = paper_settings();
    bad.alpha_max = 2.5;
    assert_eq!(Kt::new(&bad, 0.5).unwrap_err(), Error::BadSetting);
}

#[test]
fn zero_and_constant_inputs_are_not_excited() {
    let s = paper_settings();
    let mut op = Op::new(&s, 0.5).unwrap();
    let mut kt = Kt::new(&s, 0.5).unwrap();
    for w in [filled(200, |_| (0.0, 0.1)), filled(200, |_| (3.3, 1.0))] {
        assert_eq!(op.iterate(&s, &Polynomial, &w), Err(Error::NotExcited));
        assert_eq!(kt.iterate(&s, &Polynomial, &w), Err(Error::NotExcited));
    }
    assert_eq!(op.iterations(), 0);
}

#[test]
fn saturated_and_huge_inputs_never_panic() {
    let s = paper_settings();
    let mut op = Op::new(&s, 0.5).unwrap();
    // A saturated (clipped) input still excites: iterations run and stay finite.
    let w = filled(200, |l| {
        (if (l / 7) % 2 == 0 { 1.0 } else { -1.0 }, (l % 5) as f64)
    });
    for _ in 0..20 {
        let it = op.iterate(&s, &Polynomial, &w).unwrap();
        assert!(it.cost.is_finite());
    }
    // u² overflows: typed error, estimate kept.
    let good = *op.estimate();
    let w = filled(200, |l| (if l % 2 == 0 { 1e200 } else { -1e200 }, 1.0));
    assert_eq!(op.iterate(&s, &Polynomial, &w), Err(Error::NonFiniteSample));
    assert_eq!(*op.estimate(), good);
}

#[test]
fn slid_window_uses_only_rows_with_full_memory() {
    let mut s = paper_settings();
    let mut op = Op::new(&s, 0.5).unwrap();
    let mut w = SampleWindow::<f64, 256>::new();
    for l in 0..300 {
        w.push(((l * 37 % 19) as f64 - 9.0) / 5.0, (l % 3) as f64)
            .unwrap();
    }
    let it = op.iterate(&s, &Polynomial, &w).unwrap();
    // max lag 3 + memory 32 − 1 rows are skipped once the window has slid.
    assert_eq!(it.rows, 256 - (3 + 32 - 1));
    s.prehistory = Prehistory::Unknown;
    let w2 = filled(100, |l| (((l * 37 % 19) as f64 - 9.0) / 5.0, 0.0));
    let it = op.iterate(&s, &Polynomial, &w2).unwrap();
    assert_eq!(it.rows, 100 - 34);
}

#[test]
fn sliding_window_warm_start_tracks() {
    // Feed a long record through a 256-sample window, running 5 warm-started
    // iterations every 8 samples. On the final window the tracked estimate
    // must be as good as a cold start run to convergence on that window.
    const MEM: usize = 32;
    let sys = system();
    let d = generate::<MEM>(&sys, 1200, MEM, 0.05, 5);
    let p0 = truth(&sys);
    let mut s = GiSettings::new(Orders::PAPER, MEM);
    s.epsilon = 1e-9;
    let new = || Box::new(OverParamGi::<f64, 256, MEM, 2, 3, 2, 2, 6>::new(&s, 0.4).unwrap());
    let mut op = new();
    let mut w = Box::new(SampleWindow::<f64, 256>::new());
    for l in 0..1200 {
        w.push(d.u[l], d.y[l]).unwrap();
        if l >= 255 && l % 8 == 0 {
            for _ in 0..5 {
                op.iterate(&s, &Polynomial, &w).unwrap();
            }
        }
    }
    let k_tracked = op.iterations();
    let mut cold = new();
    for _ in 0..10_000 {
        if cold.iterate(&s, &Polynomial, &w).unwrap().converged {
            break;
        }
    }
    let (mut p, mut q) = ([0.0; 11], [0.0; 11]);
    op.estimate().parameter_vector(&mut p);
    cold.estimate().parameter_vector(&mut q);
    let (tracked, converged) = (delta(&p, &p0), delta(&q, &p0));
    println!(
        "final window: δ tracked = {tracked:.4} ({k_tracked} iterations over the record), \
         δ cold start = {converged:.4} ({} iterations)",
        cold.iterations()
    );
    assert!(
        tracked <= 1.1 * converged + 0.005,
        "{tracked} vs {converged}"
    );
}

#[test]
fn f32_converges_like_f64() {
    const MEM: usize = 32;
    let sys = system();
    let d = generate::<MEM>(&sys, 1000, MEM, 0.1, 21);
    let p0 = truth(&sys);
    let s64 = GiSettings::<f64>::new(Orders::PAPER, MEM);
    let mut s32 = GiSettings::<f32>::new(Orders::PAPER, MEM);
    s32.epsilon = 1e-5;
    let mut g64 = Box::new(OverParamGi::<f64, 1024, MEM, 2, 3, 2, 2, 6>::new(&s64, 0.4).unwrap());
    let mut g32 = Box::new(OverParamGi::<f32, 1024, MEM, 2, 3, 2, 2, 6>::new(&s32, 0.4).unwrap());
    let (mut w64, mut w32) = (Box::new(SampleWindow::new()), Box::new(SampleWindow::new()));
    for (&u, &y) in d.u.iter().zip(&d.y) {
        w64.push(u, y).unwrap();
        w32.push(u as f32, y as f32).unwrap();
    }
    for _ in 0..1500 {
        g64.iterate(&s64, &Polynomial, &w64).unwrap();
        g32.iterate(&s32, &Polynomial, &w32).unwrap();
    }
    let (mut p64, mut p32) = ([0.0f64; 11], [0.0f32; 11]);
    g64.estimate().parameter_vector(&mut p64);
    g32.estimate().parameter_vector(&mut p32);
    let p32: Vec<f64> = p32.iter().map(|&x| x as f64).collect();
    let (d64, d32) = (delta(&p64, &p0), delta(&p32, &p0));
    println!(
        "δ f64 = {d64:.5}, δ f32 = {d32:.5}, |p32 − p64|/|p| = {:.2e}",
        delta(&p32, &p64)
    );
    assert!(d64 < 0.05 && d32 < 0.05);
    assert!(delta(&p32, &p64) < 0.01);
}

#[test]
fn factor_recovers_b_and_gamma() {
    let o = Orders::PAPER;
    let (b, g) = ([0.18, -0.175, -0.39], [0.0165, 0.024]);
    let mut est = HammersteinEstimate::<f64, 2, 3, 2, 2, 6>::initial(o, 0.5);
    for (i, bi) in b.iter().enumerate() {
        for (j, gj) in g.iter().enumerate() {
            est.products[i * 2 + j] = bi * gj;
        }
    }
    let (bu, gu) = est.factor(Normalization::UnitGamma).unwrap();
    let ng = (g[0] * g[0] + g[1] * g[1]).sqrt();
    for j in 0..2 {
        assert!((gu[j] - g[j] / ng).abs() < 1e-12);
    }
    for i in 0..3 {
        assert!((bu[i] - b[i] * ng).abs() < 1e-12);
    }
    let (b1, g1) = est.factor(Normalization::UnitB1).unwrap();
    assert!((b1[0] - 1.0).abs() < 1e-12);
    for i in 0..3 {
        assert!((b1[i] - b[i] / b[0]).abs() < 1e-12);
    }
    for j in 0..2 {
        assert!((g1[j] - g[j] * b[0]).abs() < 1e-12);
    }
    // b_1 = 0: eq. (31) would divide by zero; the rank-one fit does not.
    let mut z = est;
    z.products[0] = 0.0;
    z.products[1] = 0.0;
    assert!(z.factor(Normalization::UnitGamma).is_some());
    assert!(z.factor(Normalization::UnitB1).is_none());
    z.products = [0.0; 6];
    assert!(z.factor(Normalization::UnitGamma).is_none());
}

#[test]
fn footprint_of_an_f32_estimator() {
    // Reported in docs/footprint.md and docs/performance.md; the bounds guard
    // against accidental growth.
    let op = core::mem::size_of::<PaperOverParamGi<f32, 256, 64>>();
    let kt = core::mem::size_of::<estimator_core::gi::key_term::PaperKeyTermGi<f32, 256, 64>>();
    let win = core::mem::size_of::<SampleWindow<f32, 256>>();
    println!("size_of: 2S-OP-GI {op} B, KT-2S-GI {kt} B, window {win} B");
    assert!(op < 32 * 1024 && kt < 32 * 1024, "{op} {kt}");
    assert!(win <= 2 * 256 * 4 + 64);
    // The battery cell estimator (docs/performance.md, Memory).
    use estimator_core::battery::online::CellEstimator;
    use estimator_core::battery::output_error::OutputErrorRefinement;
    use estimator_core::battery::regression::PaperRegressionGi;
    let paper = core::mem::size_of::<PaperRegressionGi<f32, 256, 64>>();
    let oe = core::mem::size_of::<OutputErrorRefinement<f32, 256, 64>>();
    let cell = core::mem::size_of::<CellEstimator<f32, 256, 64>>();
    println!("size_of: battery 2S-OP-GI {paper} B, refinement {oe} B, cell estimator {cell} B");
    // 9 window-length arrays and the weights for 2S-OP-GI.
    assert!(paper <= (9 * 256 + 2 * 64) * 4 + 128, "{paper}");
    // 26 616 B for the linear model; the Butler–Volmer term adds two
    // window-length arrays (the free responses of its two columns, 2 048 B)
    // and its two parameters to every copy of the parameters and its
    // columns to the cached normal matrix (88 B): 28 752 B. As the one-cell
    // pack (`battery::pack`) it is a cell's state, the shared working area
    // and the current history, nothing else; the cell's state keeps its own
    // copy of the estimators' iteration state (88 B more: 28 840 B), and the
    // modes of its window's past for the short-memory correction are in the
    // cell's state and, while it iterates, in the working area (2 × 104 B:
    // 29 048 B). The working area keeps the kinetic voltage of the estimate
    // and of the trial at every sample (2 × 1 024 B: 31 072 B), so that an
    // iteration takes one `asinh` per sample and simulation. What the data
    // identify (issue 35) adds the last normal equations' information to
    // the working area (280 B) and the published parameters with their
    // statuses and the last step resistance to the cell's state (72 B):
    // 31 424 B; the state of charge each was identified at (32 B, for
    // their expiry) and the refinement's step evidence (8 B): 31 464 B.
    // The SOC observer (issue 36, `battery::soc`) adds its state to the
    // cell's: 72 B, 31 536 B. The state of power's polarization tail (the
    // estimate and its last M polarization values, `battery::power`) is
    // the pack's, one per cell: 292 B, 31 840 B with the padding after it
    // (31 856 B with the SOC observer's guards). The current before the
    // last step, for the Butler–Volmer model's chord over it (4 B, 8 B
    // with padding): 31 864 B. A rest's mean current, which observes the
    // current sensor's bias (the SOC observer, 4 B, 8 B with padding):
    // 31 872 B. The tail's note of the largest current of the window, for
    // a Butler–Volmer state of power from a long rest (4 B, in padding):
    // 31 872 B; a pack cell 1 848 B. The working area's count of the
    // kinetic voltages a slid window keeps (4 B, in padding): 31 872 B.
    // The refinement's count of a window's unobserved samples (4 B, 8 B
    // with padding): 31 880 B. Each parameter's last value once it has
    // expired, for a `stale` state of power (16 B): 31 896 B. Each
    // published parameter's spread, for the state of power's uncertainty
    // (4 × 8 B): 31 928 B; a pack cell 1 896 B. The slow part carried
    // across windows (`OnlineSettings::slow_memory_s`: three weights, sums
    // and states of charge, and the count and state of charge they were
    // aged to; 56 B): 31 984 B; a pack cell 1 952 B. The SOC observer's
    // span of the rests read (`SocSettings::capacity_min_span`: the lowest
    // and highest SOC, 8 B): 31 992 B; a pack cell 1 960 B. The state of
    // power's check against the next pulse (`PulseCheck`: the pulse's
    // currents, voltage before it, samples, five predicted voltages, the
    // first sample's miss, the last pulse's five misses and the last two
    // samples, 72 B): 32 064 B; a pack cell 2 032 B. The last pulse at
    // the watched current's five ratios, measured over predicted drop
    // (`OnlineSettings::pulse_current`; Q12 fixed point, 2 B each), and
    // whether a pulse's first sample held another current (12 B with
    // padding): 32 080 B; a pack cell 2 044 B.
    use estimator_core::battery::online::{CellState, CurrentHistory, WorkingArea};
    use estimator_core::battery::power::{PolarizationTail, PulseCheck};
    let tail =
        core::mem::size_of::<PolarizationTail<f32, 64>>() + core::mem::size_of::<PulseCheck<f32>>();
    let parts = core::mem::size_of::<CellState<f32, 256>>()
        + tail
        + core::mem::size_of::<WorkingArea<f32, 256, 64>>()
        + core::mem::size_of::<CurrentHistory<f32, 256>>();
    // Beyond the parts: the cells in use and the next cell to update (two
    // `usize`), and padding.
    assert!(cell <= parts + 24, "{cell} {parts}");
    let per_cell = core::mem::size_of::<CellState<f32, 256>>() + tail;
    println!("size_of: a pack cell's state, tail and pulse check {per_cell} B");
    // The MCU budget of a pack's cell (issue 35): 2 KiB.
    assert!(per_cell <= 2048, "{per_cell}");
    assert!(
        cell < 26 * 1024
            + 4 * 256 * 4
            + 128
            + 96
            + 2 * 104
            + 352
            + 72
            + 304
            + 8
            + 16
            + 32
            + 56
            + 8
            + 72
            + 12,
        "{cell}"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn arbitrary_finite_windows_never_panic(
        data in proptest::collection::vec((-1e3f64..1e3, -1e3f64..1e3), 0..120),
        alpha0 in 0.05f64..1.9,
        iters in 1usize..6,
    ) {
        let s = paper_settings();
        let mut op = Op::new(&s, alpha0).unwrap();
        let mut kt = Kt::new(&s, alpha0).unwrap();
        let mut w = SampleWindow::<f64, 256>::new();
        for &(u, y) in &data {
            w.push(u, y).unwrap();
        }
        for _ in 0..iters {
            let before = *op.estimate();
            match op.iterate(&s, &Polynomial, &w) {
                Ok(it) => {
                    prop_assert!(it.cost.is_finite());
                    prop_assert!(it.alpha >= s.alpha_min && it.alpha <= s.alpha_max);
                }
                Err(_) => prop_assert_eq!(*op.estimate(), before),
            }
            let before = *kt.estimate();
            if kt.iterate(&s, &Polynomial, &w).is_err() {
                prop_assert_eq!(*kt.estimate(), before);
            }
        }
    }
}
