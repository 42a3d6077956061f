//! The battery model of §6.2: regression algebra, simulator, the paper's
//! method, the output-error refinement and the online cell estimator.

use estimator_core::battery::online::{CellEstimator, Method, OnlineSettings, Status};
use estimator_core::battery::output_error::OutputErrorRefinement;
use estimator_core::battery::profile::{ocv_nmc, Profile};
use estimator_core::battery::regression::{cell_from_theta, theta_from_cell, PaperRegressionGi};
use estimator_core::battery::simulate::simulate;
use estimator_core::battery::{BatterySettings, CellParameters};
use estimator_core::frac::GlWeights;
use estimator_core::gi::OrderStep;
use estimator_core::window::SampleWindow;
use estimator_core::Error;
use proptest::prelude::*;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

/// Terminal voltage of `p` for `current` from rest, simulated with memory
/// `mem` (`L` = the whole record), plus white noise σ.
fn record(
    p: &CellParameters<f64>,
    current: &[f64],
    ocv: impl Fn(usize) -> f64,
    mem: usize,
    sigma: f64,
    seed: u64,
) -> Vec<f64> {
    let mut w = Box::new(GlWeights::<f64, 4096>::new(p.alpha, 1.0, mem).unwrap());
    let (mut up, mut v) = (vec![0.0; current.len()], vec![0.0; current.len()]);
    simulate(p, &mut w, current, ocv, &mut up, &mut v).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let nd = Normal::new(0.0, sigma.max(1e-300)).unwrap();
    v.iter()
        .map(|x| {
            x + if sigma > 0.0 {
                nd.sample(&mut rng)
            } else {
                0.0
            }
        })
        .collect()
}

fn profile(p: Profile, amp: f64, len: usize) -> Vec<f64> {
    (0..len).map(|l| p.current(l as f64, amp)).collect()
}

fn window<const N: usize>(i: &[f64], v: &[f64]) -> Box<SampleWindow<f64, N>> {
    let mut w = Box::new(SampleWindow::new());
    for (&a, &b) in i.iter().zip(v) {
        w.push(a, b).unwrap();
    }
    w
}

fn rel(a: f64, b: f64) -> f64 {
    (a / b - 1.0).abs()
}

proptest! {
    /// θ → cell parameters inverts cell parameters → θ, for any physical
    /// cell, sample period and memory.
    #[test]
    fn theta_algebra_round_trips(
        r_i in 1e-4f64..0.1, r_ct in 1e-4f64..0.1, q in 10.0f64..5000.0,
        alpha in 0.1f64..1.0, u_oc in 2.5f64..4.5, h in 0.05f64..2.0, mem in 2usize..512,
    ) {
        let p = CellParameters { r_i, r_ct, q, alpha, u_oc, bv_a: 0.0, bv_i0: 1.0 };
        let th = theta_from_cell::<f64, 512>(&p, h, mem).unwrap();
        let back = cell_from_theta::<f64, 512>(&th, alpha, h, mem).unwrap();
        prop_assert!(rel(back.r_i, r_i) < 1e-9);
        prop_assert!(rel(back.r_ct, r_ct) < 1e-9);
        prop_assert!(rel(back.q, q) < 1e-9);
        prop_assert!(rel(back.u_oc, u_oc) < 1e-9);
    }
}

#[test]
fn non_physical_theta_gives_none() {
    // θ₃·g ≥ 1 would need a negative τ.
    assert!(cell_from_theta::<f64, 8>(&[0.01, 0.001, 1.5, 1.0], 0.7, 1.0, 8).is_none());
    // θ from the paper's initialisation 1/p₀: R_ct = θ₁(1+τg) − θ₂/θ₃ < 0.
    assert!(cell_from_theta::<f64, 8>(&[1e-6, 1e-6, 1e-6, 1e-6], 0.7, 1.0, 8).is_none());
}

#[test]
fn step_response_has_ohmic_jump_and_polarization_to_r_ct() {
    let p = CellParameters::<f64>::cell_18650();
    let i = vec![-4.0; 3000];
    let v = record(&p, &i, |_| p.u_oc, 3000, 0.0, 0);
    let a = p.tau(); // h = 1
                     // First sample: R_i·I plus U_p(0) = R_ct·I/(1 + a).
    let expect0 = p.u_oc + p.r_i * -4.0 + p.r_ct * -4.0 / (1.0 + a);
    assert!((v[0] - expect0).abs() < 1e-12);
    // Long after: U_oc + (R_i + R_ct)·I, approached from above (a power-law
    // tail, so within 1 % of R_ct·I after 3000 samples, not exactly).
    let end = p.u_oc + (p.r_i + p.r_ct) * -4.0;
    assert!(v[2999] > end && v[2999] - end < 0.01 * p.r_ct * 4.0);
    assert!(v.windows(2).all(|w| w[1] <= w[0] + 1e-15));
}

#[test]
fn regression_is_exact_on_noise_free_truncated_memory_data() {
    // Data simulated with the same memory M the regression uses: the true θ
    // has zero residual on every row l ≥ M − 1 (including the constant term
    // with s_M ≠ 0).
    for (p, h) in [
        (CellParameters::<f64>::paper(), 1.0),
        (CellParameters::cell_18650(), 0.5),
    ] {
        let mem = 64;
        let i = profile(Profile::Drive, 6.0, 400);
        let mut w = Box::new(GlWeights::<f64, 64>::new(p.alpha, h, mem).unwrap());
        let (mut up, mut v) = (vec![0.0; 400], vec![0.0; 400]);
        simulate(&p, &mut w, &i, |_| p.u_oc, &mut up, &mut v).unwrap();
        let win = window::<400>(&i, &v);
        let mut s = BatterySettings::new(h, mem);
        s.estimate_order = false;
        let mut gi = PaperRegressionGi::<f64, 400, 64>::new(&s, 0.5).unwrap();
        gi.set_cell(&s, &p).unwrap();
        let it = gi.iterate(&s, &*win).unwrap();
        assert_eq!(it.rows, 400 - 63);
        assert!(it.cost < 1e-20, "cost {}", it.cost);
        let back = gi.cell().unwrap();
        assert!(back.delta(&p) < 1e-9);
    }
}

#[test]
fn paper_method_never_increases_the_cost() {
    let p = CellParameters::<f64>::cell_18650();
    let i = profile(Profile::Pulse, 6.0, 600);
    let v = record(&p, &i, |_| p.u_oc, 600, 0.001, 3);
    let win = window::<600>(&i, &v);
    let s = BatterySettings::new(1.0, 128);
    let mut gi = PaperRegressionGi::<f64, 600, 128>::new(&s, 0.5).unwrap();
    let mut last = f64::INFINITY;
    let mut accepted = 0;
    for _ in 0..200 {
        let it = gi.iterate(&s, &*win).unwrap();
        assert!(it.cost <= last * (1.0 + 1e-12), "{} > {}", it.cost, last);
        last = it.cost;
        accepted += matches!(it.order_step, OrderStep::Accepted { .. }) as u32;
    }
    assert!(accepted > 0);
    assert!(gi.cell().is_some());
}

/// Runs the refined method offline (2S-OP-GI start, then LM) on a record.
fn refine<const N: usize>(i: &[f64], v: &[f64], gi_iters: u32) -> (CellParameters<f64>, f64) {
    let win = window::<N>(i, v);
    let sg = BatterySettings::new(1.0, 128);
    let mut gi = Box::new(PaperRegressionGi::<f64, N, N>::new(&sg, 0.5).unwrap());
    for _ in 0..gi_iters {
        gi.iterate(&sg, &*win).unwrap();
    }
    let start = gi.cell().expect("2S-OP-GI gives a physical start");
    let so = BatterySettings::new(1.0, N);
    let mut oe = Box::new(OutputErrorRefinement::<f64, N, N>::new(&so, start).unwrap());
    let mut rmse = f64::NAN;
    for _ in 0..100 {
        let st = oe.iterate(&so, &*win).unwrap();
        rmse = st.rmse;
        if st.converged {
            break;
        }
    }
    (oe.cell(), rmse)
}

#[test]
fn refinement_meets_the_cell_preset_bounds_on_ten_seeds() {
    // The bound: every parameter within 2 %, α within 0.02, voltage
    // RMSE ≤ 1.1·σ, for the cell preset at σ = 1 mV.
    let truth = CellParameters::<f64>::cell_18650();
    let sigma = 0.001;
    // A 2000 s pulse record: at 1000 s one seed in ten (seed 2) lands at
    // 2.3 % on Q, the statistical spread of the ML estimate at that length.
    const LEN: usize = 2000;
    let i = profile(Profile::Pulse, 6.0, LEN);
    let mut worst: f64 = 0.0;
    for seed in 1..=10 {
        let v = record(&truth, &i, |_| truth.u_oc, LEN, sigma, seed);
        let (p, rmse) = refine::<LEN>(&i, &v, 50);
        let errs = [
            rel(p.r_i, truth.r_i),
            rel(p.r_ct, truth.r_ct),
            rel(p.q, truth.q),
            rel(p.u_oc, truth.u_oc),
        ];
        worst = errs.iter().fold(worst, |m, &e| m.max(e));
        assert!(errs.iter().all(|&e| e < 0.02), "seed {seed}: {p:?}");
        assert!((p.alpha - truth.alpha).abs() < 0.02, "seed {seed}: {p:?}");
        assert!(
            rmse <= 1.1 * sigma && rmse > 0.8 * sigma,
            "seed {seed}: rmse {rmse}"
        );
    }
    eprintln!("worst relative error over 10 seeds: {worst:.4}");
}

#[test]
fn f32_refinement_agrees_with_f64() {
    let truth = CellParameters::<f64>::cell_18650();
    let i = profile(Profile::Pulse, 6.0, 256);
    let v = record(&truth, &i, |_| truth.u_oc, 256, 0.001, 7);
    let mut s64 = BatterySettings::<f64>::new(1.0, 64);
    s64.start = estimator_core::battery::Start::FromData;
    let s32 = BatterySettings::<f32> {
        h: 1.0,
        memory: 64,
        alpha_min: 0.05,
        alpha_max: 1.0,
        epsilon: 1e-7,
        cost_tolerance: 0.0,
        line_search: false,
        max_halvings: 12,
        max_order_step: 0.05,
        estimate_order: true,
        start: s64.start,
        ocv_slope: false,
        min_current_std: 1e-3,
        prior: None,
        model: estimator_core::battery::CellModel::Linear,
        tail: s64.tail,
    };
    let mut w64 = SampleWindow::<f64, 256>::new();
    let mut w32 = SampleWindow::<f32, 256>::new();
    for (&a, &b) in i.iter().zip(&v) {
        w64.push(a, b).unwrap();
        w32.push(a as f32, b as f32).unwrap();
    }
    let mut o64 = OutputErrorRefinement::<f64, 256, 64>::new(&s64, truth).unwrap();
    let mut o32 = OutputErrorRefinement::<f32, 256, 64>::new(&s32, truth.cast()).unwrap();
    for _ in 0..30 {
        o64.iterate(&s64, &w64).unwrap();
        o32.iterate(&s32, &w32).unwrap();
    }
    let (a, b) = (o64.cell(), o32.cell().cast::<f64>());
    assert!(rel(b.r_i, a.r_i) < 1e-3, "{a:?} {b:?}");
    assert!(rel(b.r_ct, a.r_ct) < 1e-2, "{a:?} {b:?}");
    assert!(rel(b.q, a.q) < 1e-2, "{a:?} {b:?}");
    assert!((b.alpha - a.alpha).abs() < 5e-3, "{a:?} {b:?}");
    assert!((b.u_oc - a.u_oc).abs() < 1e-3, "{a:?} {b:?}");
}

fn drifting_record(len: usize, seed: u64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let truth = CellParameters::<f64>::cell_18650();
    let i = profile(Profile::Drive, 6.0, len);
    let cap = 2.5 * 3600.0;
    let mut soc = vec![0.9; len];
    for l in 1..len {
        soc[l] = soc[l - 1] + i[l - 1] / cap;
    }
    let ocv: Vec<f64> = soc.iter().map(|&z| ocv_nmc(z)).collect();
    let v = record(&truth, &i, |l| ocv[l], 4096.min(len), 0.001, seed);
    (i, v, ocv)
}

fn median(mut x: Vec<f64>) -> f64 {
    x.sort_by(|a, b| a.partial_cmp(b).unwrap());
    x[x.len() / 2]
}

#[test]
fn sliding_window_tracks_drifting_ocv() {
    // SOC 90 % → 40 % over 3000 s; window 256, memory 64, one LM
    // iteration per sample. Measured (seed 1): median |error| R_i 0.5 %,
    // R_ct 3.4 %, α 0.020, U_oc 2.1 mV.
    let truth = CellParameters::<f64>::cell_18650();
    let (i, v, ocv) = drifting_record(3000, 1);
    assert!(ocv[0] - ocv[2999] > 0.35);
    let s = OnlineSettings::new(1.0, 64, truth);
    let mut est = Box::new(CellEstimator::<f64, 256, 64>::new(&s).unwrap());
    let (mut e_ri, mut e_rct, mut e_a, mut e_u) = (vec![], vec![], vec![], vec![]);
    for l in 0..3000 {
        let r = est.push(&s, i[l], v[l]);
        assert!(r.rejected.is_none(), "sample {l} rejected");
        if l >= 1000 {
            let p = est.estimate().unwrap();
            e_ri.push(rel(p.r_i, truth.r_i));
            e_rct.push(rel(p.r_ct, truth.r_ct));
            e_a.push((p.alpha - truth.alpha).abs());
            e_u.push((p.u_oc - ocv[l]).abs());
        }
    }
    assert!(est.is_refining());
    let (ri, rct, a, u) = (median(e_ri), median(e_rct), median(e_a), median(e_u));
    assert!(
        ri < 0.02 && rct < 0.10 && a < 0.05 && u < 0.005,
        "{ri} {rct} {a} {u}"
    );
}

#[test]
fn rest_holds_the_estimate_and_reports_not_excited() {
    let truth = CellParameters::<f64>::cell_18650();
    let mut i = profile(Profile::Pulse, 6.0, 600);
    i.extend(std::iter::repeat_n(0.0, 600));
    let v = record(&truth, &i, |_| truth.u_oc, 1200, 0.001, 2);
    let s = OnlineSettings::new(1.0, 32, truth);
    let mut est = Box::new(CellEstimator::<f64, 128, 32>::new(&s).unwrap());
    let mut held = None;
    for l in 0..1200 {
        let r = est.push(&s, i[l], v[l]);
        if l == 599 {
            assert_eq!(r.status, Status::Tracking);
        }
        if r.status == Status::NotExcited && held.is_none() {
            held = est.estimate();
        }
    }
    assert_eq!(est.status(), Status::NotExcited);
    let held = held.expect("the rest was detected");
    assert_eq!(est.estimate(), Some(held));
    assert!(rel(held.r_i, truth.r_i) < 0.05);
}

#[test]
fn spikes_and_nans_are_rejected_counted_and_not_learned() {
    let truth = CellParameters::<f64>::cell_18650();
    let i = profile(Profile::Pulse, 6.0, 1500);
    let v = record(&truth, &i, |_| truth.u_oc, 1500, 0.001, 4);
    let mut bad_v = v.clone();
    let mut bad_i = i.clone();
    let spikes = [700usize, 820, 905, 1111, 1300];
    for &l in &spikes {
        bad_v[l] += 0.4; // a 400 mV glitch
    }
    bad_v[1000] = f64::NAN;
    bad_i[1200] = f64::INFINITY;
    bad_v[1400] = 9.0; // out of range
    let s = OnlineSettings::new(1.0, 32, truth);
    let mut clean = Box::new(CellEstimator::<f64, 128, 32>::new(&s).unwrap());
    let mut dirty = Box::new(CellEstimator::<f64, 128, 32>::new(&s).unwrap());
    for l in 0..1500 {
        clean.push(&s, i[l], v[l]);
        dirty.push(&s, bad_i[l], bad_v[l]);
    }
    let c = dirty.counts();
    assert_eq!(c.samples, 1500);
    assert_eq!(
        (c.spikes, c.non_finite, c.out_of_range),
        (spikes.len() as u32, 2, 1)
    );
    assert_eq!(clean.counts().rejected(), 0);
    assert_eq!(dirty.window().pushed(), 1500, "no sample lost");
    let (a, b) = (clean.estimate().unwrap(), dirty.estimate().unwrap());
    assert!(
        rel(b.r_i, a.r_i) < 0.01 && rel(b.r_ct, a.r_ct) < 0.05,
        "{a:?} {b:?}"
    );
    assert!((b.u_oc - a.u_oc).abs() < 0.002);
}

#[test]
fn a_real_step_is_believed_after_a_few_samples() {
    // A sustained 300 mV offset (e.g. a sensor recalibration) is not a
    // spike: after max_consecutive_spikes rejections it is accepted.
    let truth = CellParameters::<f64>::cell_18650();
    let i = profile(Profile::Pulse, 6.0, 800);
    let mut v = record(&truth, &i, |_| truth.u_oc, 800, 0.001, 5);
    for x in &mut v[600..] {
        *x += 0.3;
    }
    let s = OnlineSettings::new(1.0, 32, truth);
    let mut est = Box::new(CellEstimator::<f64, 128, 32>::new(&s).unwrap());
    let mut last = None;
    for l in 0..800 {
        last = Some(est.push(&s, i[l], v[l]));
    }
    assert_eq!(est.counts().spikes, u32::from(s.max_consecutive_spikes));
    // The window restarted at the step (the samples before it cannot be
    // fitted with those after it), so the fit is back at the noise level
    // (σ = 1 mV) instead of chasing the step.
    let rmse = last.unwrap().rmse;
    assert!(rmse < 2e-3, "rmse {rmse}");
    assert!(est.window().len() < 128 || est.window().pushed() < 800);
    let e = est.estimate().unwrap();
    assert!(
        (e.u_oc - (truth.u_oc + 0.3)).abs() < 0.01,
        "{e:?} {:?}",
        est.status()
    );
}

#[test]
fn paper_method_runs_online_and_bad_settings_are_typed_errors() {
    let truth = CellParameters::<f64>::cell_18650();
    let mut s = OnlineSettings::new(1.0, 32, truth);
    s.method = Method::Paper;
    s.iterations_per_sample = 3;
    let i = profile(Profile::Pulse, 6.0, 400);
    let v = record(&truth, &i, |_| truth.u_oc, 400, 0.001, 6);
    let mut est = Box::new(CellEstimator::<f64, 256, 64>::new(&s).unwrap());
    let mut statuses = std::collections::HashSet::new();
    for l in 0..400 {
        statuses.insert(est.push(&s, i[l], v[l]).status);
    }
    assert!(!est.is_refining());
    assert!(statuses.contains(&Status::Filling) && statuses.contains(&Status::Starting));
    assert!(!statuses.contains(&Status::Held));
    eprintln!("paper online: {:?} {statuses:?}", est.estimate());

    let mut bad = s;
    bad.battery.memory = 0;
    assert!(matches!(
        CellEstimator::<f64, 128, 32>::new(&bad),
        Err(Error::Frac(_))
    ));
    let mut bad = s;
    bad.voltage_min = f64::NAN;
    assert_eq!(
        CellEstimator::<f64, 128, 32>::new(&bad).err(),
        Some(Error::BadSetting)
    );
    let mut bad = s;
    bad.battery.alpha_max = 2.5;
    assert!(CellEstimator::<f64, 128, 32>::new(&bad).is_err());
}

/// The paper method in `f32` follows the `f64` one on the same window: the
/// regression is evaluated on centred voltages (`battery::regression`
/// module docs), so the `f32` residuals keep their digits and the order
/// steps `f64` takes stay verifiable in `f32`.
#[test]
fn f32_paper_method_follows_f64() {
    let truth = CellParameters::<f64>::cell_18650();
    let i = profile(Profile::Pulse, 6.0, 256);
    let v = record(&truth, &i, |_| truth.u_oc, 256, 1e-4, 1);
    let s64 = BatterySettings::<f64>::new(1.0, 64);
    let s32 = BatterySettings::<f32>::new(1.0, 64);
    let mut w64 = SampleWindow::<f64, 256>::new();
    let mut w32 = SampleWindow::<f32, 256>::new();
    for (&a, &b) in i.iter().zip(&v) {
        w64.push(a, b).unwrap();
        w32.push(a as f32, b as f32).unwrap();
    }
    let mut g64 = PaperRegressionGi::<f64, 256, 64>::new(&s64, 0.5).unwrap();
    let mut g32 = PaperRegressionGi::<f32, 256, 64>::new(&s32, 0.5).unwrap();
    for _ in 0..400 {
        g64.iterate(&s64, &w64).unwrap();
        g32.iterate(&s32, &w32).unwrap();
    }
    let d_alpha = (g64.alpha() - g32.alpha() as f64).abs();
    let (a, b) = (g64.cell().unwrap(), g32.cell().unwrap().cast::<f64>());
    eprintln!(
        "after 400 iterations: |Δα| = {d_alpha:.2e}, R_ct {:.3e} relative, α64 = {:.5}",
        rel(b.r_ct, a.r_ct),
        a.alpha
    );
    assert!(d_alpha < 1e-4, "α: f64 {} f32 {}", g64.alpha(), g32.alpha());
    assert!(rel(b.r_i, a.r_i) < 1e-4, "{a:?} {b:?}");
    assert!(rel(b.r_ct, a.r_ct) < 1e-3, "{a:?} {b:?}");
}

/// A prior given before the cell's first sample (as the C ABI's
/// `fracbms_cell_set_prior` after `init`, or a map followed before the first
/// push) is the start, exactly as a prior given when the cell is built: the
/// refinement starts at its centre without the 2S-OP-GI start-up, and the
/// two cells give the same reports bit for bit. Given after the first
/// sample, it is not the start (the start-up runs): the reports part.
#[test]
fn a_prior_set_before_the_first_sample_starts_the_cell_as_one_given_at_construction() {
    use estimator_core::battery::Prior;
    let truth = CellParameters::<f64>::cell_18650();
    let without = OnlineSettings::new(1.0, 16, truth);
    let mut with = without;
    with.battery.prior = Some(Prior::new(CellParameters {
        r_i: truth.r_i * 1.3,
        r_ct: truth.r_ct * 0.8,
        ..truth
    }));
    let mut built = CellEstimator::<f64, 64, 16>::new(&with).unwrap();
    let mut before = CellEstimator::<f64, 64, 16>::new(&without).unwrap();
    let mut after = CellEstimator::<f64, 64, 16>::new(&without).unwrap();
    assert!(built.cell_state().is_refining());
    assert!(!before.cell_state().is_refining());
    // A square wave of ±2 A every 10 s through R_i and a first-order R_ct
    // branch.
    let mut up = 0.0;
    let mut parted = false;
    for k in 0..300 {
        let i = if (k / 10) % 2 == 0 { 2.0 } else { -2.0 };
        up = 0.9 * up + 0.1 * truth.r_ct * i;
        let v = truth.u_oc + truth.r_i * i + up;
        let a = built.push(&with, i, v);
        let b = before.push(&with, i, v);
        let c = after.push(if k == 0 { &without } else { &with }, i, v);
        assert_eq!(format!("{a:?}"), format!("{b:?}"), "sample {k}");
        parted |= format!("{a:?}") != format!("{c:?}");
    }
    assert!(before.cell_state().is_refining());
    assert!(built.estimate().is_some());
    assert!(
        parted,
        "a prior given after the first sample must not be the start"
    );
}
