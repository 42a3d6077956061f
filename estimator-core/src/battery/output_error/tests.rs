//! Tests of the output-error refinement: the Jacobian against finite
//! differences, restarts, stops at a minimum, the prior, the normal
//! equations' sums; the kinetic voltages in [`kinetic`].

use super::*;
use crate::window::SampleWindow;

mod kinetic;
mod unobserved;

/// The simulated terminal voltage of `p`, β over the loaded window.
fn predicted<const N: usize, const MEM: usize>(
    s: &BatterySettings<f64>,
    oe: &OutputErrorRefinement<f64, N, MEM>,
    p: &CellParameters<f64>,
    beta: f64,
) -> Vec<f64> {
    let n = oe.n;
    let mut w = oe.w.clone();
    w.set_order(p.alpha).unwrap();
    let data = WindowData {
        i: &oe.i[..n],
        v: &oe.v[..n],
        c: &oe.c[..n],
        warm: oe.warm,
        tail: tail_context(s, oe.past.as_ref()),
    };
    let (mut up, mut e, mut eta) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    simulate_window(
        &mut GlRecursion,
        &w,
        &data,
        p,
        beta,
        &mut up,
        &mut e,
        &mut eta,
    );
    (0..n)
        .map(|l| p.u_oc - beta * oe.c[l] + p.static_voltage(oe.i[l]) + up[l])
        .collect()
}

/// A pulse record of the 18650 cell with a little deterministic "noise"
/// (a few tenths of a millivolt) and an OCV drift.
fn noisy_record(len: usize) -> (Vec<f64>, Vec<f64>) {
    let truth = CellParameters::<f64>::cell_18650();
    let current: Vec<f64> = (0..len)
        .map(|l| 3.0 * (0.21 * l as f64).sin() + if (l / 15) % 2 == 0 { 2.0 } else { -2.0 })
        .collect();
    let (mut up, mut v) = (vec![0.0; len], vec![0.0; len]);
    let mut w = GlWeights::<f64, 24>::new(truth.alpha, 1.0, 24).unwrap();
    super::super::simulate::simulate(&truth, &mut w, &current, |_| truth.u_oc, &mut up, &mut v)
        .unwrap();
    for (l, x) in v.iter_mut().enumerate() {
        *x += 3e-4 * (1.7 * l as f64).sin() * (0.37 * l as f64).cos() - 2e-6 * l as f64;
    }
    (current, v)
}

/// After a window restart the refinement computes exactly what a new
/// one does: no sensitivity of an earlier (slid) window survives into a
/// window that starts from rest.
#[test]
fn a_restarted_window_forgets_the_earlier_one() {
    const N: usize = 80;
    let (current, v) = noisy_record(2 * N);
    let mut s = BatterySettings::new(1.0, 24);
    s.ocv_slope = true;
    let mut win = SampleWindow::<f64, N>::new();
    for l in 0..N + 20 {
        win.push(current[l], v[l]).unwrap();
    }
    let start = CellParameters::<f64>::cell_18650();
    let mut used = OutputErrorRefinement::<f64, N, 24>::new(&s, start).unwrap();
    for _ in 0..3 {
        used.iterate(&s, &win).unwrap();
    }
    assert_eq!(used.warm, 23, "the window has slid: history from data");
    win.clear();
    for l in N + 20..2 * N {
        win.push(current[l], v[l]).unwrap();
    }
    used.set_cell(&s, start).unwrap();
    let mut new = OutputErrorRefinement::<f64, N, 24>::new(&s, start).unwrap();
    for _ in 0..3 {
        let a = used.iterate(&s, &win).unwrap();
        let b = new.iterate(&s, &win).unwrap();
        assert_eq!(used.warm, 0);
        assert_eq!(a, b);
        assert_eq!(used.cell(), new.cell());
    }
}

/// A refinement done with and started again in place
/// ([`OutputErrorRefinement::init`], with other settings and another
/// start) computes exactly what a new one does, iteration by iteration,
/// on the window it last ran on and on another.
#[test]
fn an_initialised_refinement_repeats_a_new_one() {
    const N: usize = 80;
    let (current, v) = noisy_record(2 * N);
    let s = BatterySettings {
        model: CellModel::ButlerVolmer,
        ocv_slope: true,
        ..BatterySettings::new(1.0, 24)
    };
    let mut win = SampleWindow::<f64, N>::new();
    for l in 0..N + 20 {
        win.push(current[l], v[l]).unwrap();
    }
    let cell = CellParameters::<f64>::cell_18650();
    let mut used =
        OutputErrorRefinement::<f64, N, 24>::new(&s, cell.with_butler_volmer(1.0)).unwrap();
    for _ in 0..4 {
        used.iterate(&s, &win).unwrap();
    }
    assert!(used.warm > 0 && used.k > 0, "a refinement that has run");
    assert!(used.kinetic_kept > 0, "with its kinetic voltages kept");
    let sb = BatterySettings {
        ocv_slope: false,
        ..s
    };
    let start = CellParameters {
        alpha: 0.6,
        r_ct: 1.5 * cell.r_ct,
        ..cell.with_butler_volmer(2.0)
    };
    let bad = CellParameters { r_i: -1.0, ..start };
    let before = used.state();
    assert_eq!(used.init(&sb, bad), Err(Error::BadSetting));
    assert_eq!(used.state(), before, "a refused start changes nothing");
    for other_window in [false, true] {
        if other_window {
            win.clear();
            for l in N + 20..2 * N {
                win.push(current[l], v[l]).unwrap();
            }
        }
        used.init(&sb, start).unwrap();
        let mut new = OutputErrorRefinement::<f64, N, 24>::new(&sb, start).unwrap();
        assert_eq!(used.state(), new.state());
        for _ in 0..4 {
            assert_eq!(used.iterate(&sb, &win), new.iterate(&sb, &win));
            assert_eq!(used.state(), new.state());
        }
        let (a, b) = (used.information(&sb, &win), new.information(&sb, &win));
        assert_eq!(a.map(|i| i.bic()), b.map(|i| i.bic()));
    }
}

/// An iteration that stops on the last iteration's Jacobian (no new
/// sensitivities) stops at a minimum: the exact Levenberg–Marquardt step
/// from there leaves a Bates–Watts relative offset
/// `√((ΔC/6)/(C/(n−6)))` below their recommended 0.001 (the decrease
/// it finds is statistically invisible). From a distant start the test
/// must also say "go on" (and new sensitivities are taken).
#[test]
fn a_stop_on_the_last_jacobian_is_a_minimum() {
    const N: usize = 100;
    let (current, v) = noisy_record(N + 40);
    let mut s = BatterySettings::new(1.0, 24);
    s.ocv_slope = true;
    s.start = Start::FromData;
    let mut win = SampleWindow::<f64, N>::new();
    for l in 0..N {
        win.push(current[l], v[l]).unwrap();
    }
    let truth = CellParameters::<f64>::cell_18650();
    let start = CellParameters {
        r_ct: 2.0 * truth.r_ct,
        q: 0.5 * truth.q,
        alpha: truth.alpha - 0.1,
        ..truth
    };
    let mut oe = OutputErrorRefinement::<f64, N, 24>::new(&s, start).unwrap();
    let (mut stops, mut go_ons) = (0, 0);
    let (mut worst_offset, mut worst_change) = (0.0f64, 0.0f64);
    for l in N..N + 40 {
        win.push(current[l], v[l]).unwrap();
        let mut accepted_before = false;
        for _ in 0..5 {
            let lin = oe.work().linearizations;
            let step = oe.iterate(&s, &win).unwrap();
            let linearized = oe.work().linearizations > lin;
            if accepted_before && linearized {
                go_ons += 1;
            }
            if accepted_before && !linearized {
                stops += 1;
                assert!(step.converged && !step.accepted);
                let mut exact = OutputErrorRefinement::<f64, N, 24>::new(&s, oe.cell()).unwrap();
                exact.beta = oe.beta;
                let e = exact.iterate(&s, &win).unwrap();
                let rows = step.rows as f64;
                let decrease = (step.cost - e.cost).max(0.0);
                let offset = (decrease * (rows - 6.0) / (6.0 * step.cost)).sqrt();
                assert!(
                    offset < 1e-3,
                    "sample {l}: relative offset {offset:e} ({e:?})"
                );
                worst_offset = worst_offset.max(offset);
                if e.accepted {
                    worst_change = worst_change.max(e.change);
                }
            }
            accepted_before = step.accepted;
            if step.converged {
                break;
            }
        }
    }
    // Quoted in docs/performance.md (run with --nocapture).
    std::println!(
        "{stops} chord stops, {go_ons} go-ons; exact step from a stop at most \
             {worst_change:.2e} (epsilon {:e}), relative offset at most {worst_offset:.2e}",
        s.epsilon
    );
    assert!(stops >= 10, "only {stops} stops without sensitivities");
    assert!(go_ons >= 1, "the last Jacobian never said go on");
}

/// Once an iteration finds no lower cost on a window, further iterations
/// on it change nothing and say converged; a new sample starts the
/// search again.
#[test]
fn a_converged_window_is_not_searched_again() {
    const N: usize = 120;
    let truth = CellParameters::<f64>::cell_18650();
    let s = BatterySettings::new(1.0, 24);
    let current: Vec<f64> = (0..N + 1)
        .map(|l| 3.0 * (0.21 * l as f64).sin() + if (l / 15) % 2 == 0 { 2.0 } else { -2.0 })
        .collect();
    let (mut up, mut v) = (vec![0.0; N + 1], vec![0.0; N + 1]);
    let mut w = GlWeights::<f64, 24>::new(truth.alpha, 1.0, 24).unwrap();
    super::super::simulate::simulate(&truth, &mut w, &current, |_| truth.u_oc, &mut up, &mut v)
        .unwrap();
    let mut win = SampleWindow::<f64, N>::new();
    for l in 0..N {
        win.push(current[l], v[l]).unwrap();
    }
    let start = CellParameters {
        r_ct: 0.02,
        q: 400.0,
        ..truth
    };
    let mut oe = OutputErrorRefinement::<f64, N, 24>::new(&s, start).unwrap();
    let mut k = 0;
    let why = loop {
        let step = oe.iterate(&s, &win).unwrap();
        // A reason exactly when it reports a minimum.
        assert_eq!(step.stop.is_some(), step.converged, "{step:?}");
        if !step.accepted {
            break step.stop;
        }
        k += 1;
        assert!(k < 100, "no minimum after 100 iterations");
    };
    let at_min = oe.cell();
    assert!((at_min.r_ct / truth.r_ct - 1.0).abs() < 1e-6, "{at_min:?}");
    for _ in 0..3 {
        let step = oe.iterate(&s, &win).unwrap();
        assert!(step.converged && !step.accepted && step.change == 0.0);
        // The repeat gives the reason of the stop it repeats.
        assert_eq!(step.stop, why);
        assert!(why.is_some());
        assert_eq!(oe.cell(), at_min);
    }
    // One more (noisy) sample: the window changed, the search runs.
    win.push(current[N], v[N] + 0.01).unwrap();
    let step = oe.iterate(&s, &win).unwrap();
    assert!(step.accepted, "{step:?}");
    assert_ne!(oe.cell(), at_min);
}

/// With a prior the refinement converges to the minimum of the data's
/// cost plus the prior's: there the gradient of that sum (central
/// differences of the simulation, not the code's normal equations) is
/// below 1e-4 of its value at the start, and no coordinate move lowers
/// the sum. A heavy prior holds the
/// estimate near its centre, a light one lets the data move it.
#[test]
fn a_prior_moves_the_minimum_to_the_posterior() {
    const N: usize = 120;
    let (current, v) = noisy_record(N);
    let mut win = SampleWindow::<f64, N>::new();
    for l in 0..N {
        win.push(current[l], v[l]).unwrap();
    }
    let truth = CellParameters::<f64>::cell_18650();
    let center = CellParameters {
        r_ct: 2.0 * truth.r_ct,
        q: 0.5 * truth.q,
        alpha: 0.6,
        ..truth
    };
    let mut rct = vec![];
    for noise_v in [1e-4, 0.03, 10.0] {
        let mut s = BatterySettings::new(1.0, 24);
        s.prior = Some(super::super::Prior {
            noise_v,
            ..super::super::Prior::new(center)
        });
        let mut oe = OutputErrorRefinement::<f64, N, 24>::new(&s, truth).unwrap();
        let total = |oe: &OutputErrorRefinement<f64, N, 24>, p: &CellParameters<f64>| {
            let pred = predicted(&s, oe, p, 0.0);
            let data: f64 = (oe.warm..oe.n)
                .map(|l| (v[l] - pred[l]).powi(2))
                .sum::<f64>()
                / 2.0;
            data + s.prior.unwrap().cost(p, &s)
        };
        let grad = |oe: &OutputErrorRefinement<f64, N, 24>, p: CellParameters<f64>| {
            let d = 1e-6;
            let mut g = 0.0f64;
            for k in 0..5 {
                let moved = |sign: f64| {
                    let mut q = p;
                    match k {
                        0 => q.r_i *= (sign * d).exp(),
                        1 => q.r_ct *= (sign * d).exp(),
                        2 => q.q *= (sign * d).exp(),
                        3 => q.alpha += sign * d,
                        _ => q.u_oc += sign * d,
                    }
                    total(oe, &q)
                };
                g = g.max(((moved(1.0) - moved(-1.0)) / (2.0 * d)).abs());
            }
            g
        };
        oe.iterate(&s, &win).unwrap();
        let g0 = grad(&oe, truth);
        for _ in 0..200 {
            if oe.iterate(&s, &win).unwrap().converged {
                break;
            }
        }
        let g1 = grad(&oe, oe.cell());
        // Stopped at ε = 1e-7 in the parameters: the gradient left is
        // of the order of the curvature times ε.
        assert!(g1 < 1e-4 * g0, "{noise_v}: {g1:e} vs {g0:e}");
        // …and no move of 1e-3 along any coordinate lowers the sum.
        let at = oe.cell();
        let c0 = total(&oe, &at);
        for k in 0..5 {
            for sign in [-1.0, 1.0] {
                let mut q = at;
                let d: f64 = sign * 1e-3;
                match k {
                    0 => q.r_i *= d.exp(),
                    1 => q.r_ct *= d.exp(),
                    2 => q.q *= d.exp(),
                    3 => q.alpha += d,
                    _ => q.u_oc += 1e-3 * d,
                }
                assert!(
                    total(&oe, &q) >= c0 * (1.0 - 1e-9),
                    "{noise_v}: coordinate {k}"
                );
            }
        }
        rct.push(oe.cell().r_ct);
    }
    // Light prior: the data's R_ct; heavy prior: the centre's.
    assert!((rct[0] / truth.r_ct - 1.0).abs() < 0.05, "{rct:?}");
    assert!((rct[2] / center.r_ct - 1.0).abs() < 0.05, "{rct:?}");
    assert!(rct[1] > rct[0] && rct[1] < rct[2], "{rct:?}");
}

/// The Jacobian from the sensitivity recursions equals central finite
/// differences of the simulation, column by column, on a slid window
/// (history from data, OCV slope fitted), on one whose history rows are
/// at rest (every current 0: the free responses to the current are not
/// run), and with a start from rest; for the linear model and with the
/// Butler–Volmer term (whose columns are zero in the linear model).
#[test]
fn jacobian_equals_finite_differences() {
    const N: usize = 160;
    const MEM: usize = 32;
    let models = [CellModel::Linear, CellModel::ButlerVolmer];
    // (start, samples at rest before the current starts): the slid
    // window's history rows are samples 37..68, all at rest for 77.
    let cases = [
        (Start::FromData, 0),
        (Start::FromData, 77),
        (Start::AtRest, 0),
    ];
    for ((start, rest), model) in cases.into_iter().flat_map(|c| models.map(|m| (c, m))) {
        let mut s = BatterySettings::new(0.5, MEM);
        s.start = start;
        s.ocv_slope = true;
        s.model = model;
        let mut win = SampleWindow::<f64, N>::new();
        // A window that has slid (FromData) or not (AtRest).
        let len = if start == Start::FromData {
            N + 37
        } else {
            N - 20
        };
        for l in 0..len {
            let x = l as f64;
            let i = if l < rest {
                0.0
            } else {
                3.0 * (0.11 * x).sin() + 2.0 * (0.037 * x).cos() - 0.5
            };
            let v = 3.7 + 0.02 * i + 0.004 * (0.05 * x).sin() - 1e-5 * x;
            win.push(i, v).unwrap();
        }
        let p = CellParameters {
            r_i: 0.018,
            r_ct: 0.013,
            q: 430.0,
            alpha: 0.71,
            u_oc: 3.69,
            bv_a: if model == CellModel::ButlerVolmer {
                0.021
            } else {
                0.0
            },
            bv_i0: 1.3,
        };
        let mut oe = OutputErrorRefinement::<f64, N, MEM>::new(&s, p).unwrap();
        oe.beta = 2e-6;
        oe.load(&s, &win).unwrap();
        oe.w.set_order(p.alpha).unwrap();
        let n = oe.n;
        let data = WindowData {
            i: &oe.i[..n],
            v: &oe.v[..n],
            c: &oe.c[..n],
            warm: oe.warm,
            tail: tail_context(&s, oe.past.as_ref()),
        };
        let es = oe.est();
        let sim = &mut oe.sims[es];
        simulate_window(
            &mut GlRecursion,
            &oe.w,
            &data,
            &p,
            oe.beta,
            &mut sim.up[..n],
            &mut sim.e[..n],
            &mut sim.eta[..n],
        );
        oe.sensitivities(
            true,
            s.model == CellModel::ButlerVolmer,
            s.uses_tail(),
            false,
        );
        oe.jacobian_columns(&s);
        // Central differences in x = [ln R_i, ln R_ct, ln Q, α, U_oc, β,
        // ln a, ln i₀].
        let step = [1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-9, 1e-5, 1e-5];
        for (k, &d) in step.iter().enumerate() {
            if k >= 6 && model == CellModel::Linear {
                for l in oe.warm..n {
                    assert_eq!(oe.jacobian_row(&s, l)[k], 0.0);
                }
                continue;
            }
            let moved = |sign: f64| {
                let mut q = p;
                let mut beta = oe.beta;
                match k {
                    0 => q.r_i *= (sign * d).exp(),
                    1 => q.r_ct *= (sign * d).exp(),
                    2 => q.q *= (sign * d).exp(),
                    3 => q.alpha += sign * d,
                    4 => q.u_oc += sign * d,
                    5 => beta += sign * d,
                    6 => q.bv_a *= (sign * d).exp(),
                    _ => q.bv_i0 *= (sign * d).exp(),
                }
                predicted(&s, &oe, &q, beta)
            };
            let (hi, lo) = (moved(1.0), moved(-1.0));
            let fd: Vec<f64> = (0..n).map(|l| (hi[l] - lo[l]) / (2.0 * d)).collect();
            let scale = fd[oe.warm..].iter().fold(0.0f64, |m, x| m.max(x.abs()));
            assert!(scale > 0.0, "column {k} is zero");
            for (l, &f) in fd.iter().enumerate().skip(oe.warm) {
                let j = oe.jacobian_row(&s, l)[k];
                assert!(
                    (j - f).abs() <= 1e-6 * scale,
                    "{start:?} {model:?} rest {rest}: column {k}, row {l}: {j} vs {f}"
                );
            }
            if k == 4 && start == Start::FromData {
                // Without the OCV slope, `iterate` runs ∂U_p/∂U_oc with the
                // simulation (the pair kernel) and the sensitivities skip
                // it: the column is the same finite difference.
                let mut flat = s;
                flat.ocv_slope = false;
                let mut other = OutputErrorRefinement::<f64, N, MEM>::new(&flat, p).unwrap();
                other.beta = 0.0;
                other.load(&flat, &win).unwrap();
                other.w.set_order(p.alpha).unwrap();
                let (n, warm) = (other.n, other.warm);
                let data = WindowData {
                    i: &other.i[..n],
                    v: &other.v[..n],
                    c: &other.c[..n],
                    warm,
                    tail: tail_context(&flat, other.past.as_ref()),
                };
                other.s_uoc[..warm].fill(-1.0);
                other.s_uoc[warm..n].fill(f64::NAN);
                let es = other.est();
                let sim = &mut other.sims[es];
                let (_, filled) = simulate_window_with_free(
                    &mut GlRecursion,
                    &other.w,
                    &data,
                    &p,
                    0.0,
                    &mut sim.up[..n],
                    &mut sim.e[..n],
                    &mut sim.eta[..n],
                    0,
                    Some(&mut other.s_uoc[..n]),
                );
                assert!(filled && warm > 0);
                other.sensitivities(false, model == CellModel::ButlerVolmer, false, true);
                other.jacobian_columns(&flat);
                // (β moves nothing at U_oc: the same finite difference.)
                for (l, &f) in fd.iter().enumerate().skip(warm) {
                    let j = other.jacobian_row(&flat, l)[k];
                    assert!(
                        (j - f).abs() <= 1e-6 * scale,
                        "{model:?}: U_oc column run with the simulation, row {l}: {j} vs {f}"
                    );
                }
            }
        }
    }
}

/// A window with the modes of a past (what a pack's cell window gives).
struct WithPast<'a, const N: usize> {
    win: &'a SampleWindow<f64, N>,
    past: PastModes<f64>,
}

impl<const N: usize> Window<f64> for WithPast<'_, N> {
    fn len(&self) -> usize {
        self.win.len()
    }
    fn version(&self) -> u32 {
        self.win.version()
    }
    fn has_slid(&self) -> bool {
        true
    }
    fn recent(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.win.recent()
    }
    fn copy_into(&self, u: &mut [f64], y: &mut [f64]) -> usize {
        self.win.copy_into(u, y)
    }
    fn past(&self) -> Option<PastModes<f64>> {
        Some(self.past)
    }
}

/// With the tail beyond the memory (taps at lags ≥ M inside the window
/// and a past before it), the Jacobian from the sensitivity recursions
/// still equals central finite differences of the simulation, column by
/// column (h = 0.5, α = 0.71 inside a segment of the coefficient table,
/// OCV slope fitted).
#[test]
fn jacobian_with_the_tail_equals_finite_differences() {
    const N: usize = 200;
    const MEM: usize = 64;
    let mut s = BatterySettings::new(0.5, MEM);
    s.start = Start::FromData;
    s.ocv_slope = true;
    s.tail = true;
    assert!(s.uses_tail());
    let sample = |l: usize| {
        let x = l as f64;
        let i = 3.0 * (0.11 * x).sin() + 2.0 * (0.037 * x).cos() - 0.5;
        (i, 3.7 + 0.02 * i + 0.004 * (0.05 * x).sin() - 1e-5 * x)
    };
    // 300 samples left before the window's 200.
    let mut past = PastModes::new();
    for l in 0..300 {
        let (i, v) = sample(l);
        past.leave(i, v, sample(l + 1).0);
    }
    let mut win = SampleWindow::<f64, N>::new();
    for l in 300..500 {
        let (i, v) = sample(l);
        win.push(i, v).unwrap();
    }
    let view = WithPast { win: &win, past };
    let p = CellParameters {
        r_i: 0.018,
        r_ct: 0.013,
        q: 430.0,
        alpha: 0.71,
        u_oc: 3.69,
        bv_a: 0.0,
        bv_i0: 1.3,
    };
    let mut oe = OutputErrorRefinement::<f64, N, MEM>::new(&s, p).unwrap();
    oe.beta = 2e-6;
    oe.load(&s, &view).unwrap();
    assert!(oe.past.is_some() && oe.warm == MEM - 1);
    oe.w.set_order(p.alpha).unwrap();
    let n = oe.n;
    let data = WindowData {
        i: &oe.i[..n],
        v: &oe.v[..n],
        c: &oe.c[..n],
        warm: oe.warm,
        tail: tail_context(&s, oe.past.as_ref()),
    };
    let es = oe.est();
    let sim = &mut oe.sims[es];
    simulate_window(
        &mut GlRecursion,
        &oe.w,
        &data,
        &p,
        oe.beta,
        &mut sim.up[..n],
        &mut sim.e[..n],
        &mut sim.eta[..n],
    );
    oe.sensitivities(true, false, true, false);
    oe.jacobian_columns(&s);
    // The tail changes the simulation: the test sees it.
    let mut plain = s;
    plain.tail = false;
    let without = predicted(&plain, &oe, &p, oe.beta);
    let with = predicted(&s, &oe, &p, oe.beta);
    let moved = (0..n).fold(0.0f64, |m, l| m.max((with[l] - without[l]).abs()));
    assert!(moved > 1e-4, "the tail moves the simulation by {moved} V");
    let step = [1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-9];
    for (k, &d) in step.iter().enumerate() {
        let moved = |sign: f64| {
            let mut q = p;
            let mut beta = oe.beta;
            match k {
                0 => q.r_i *= (sign * d).exp(),
                1 => q.r_ct *= (sign * d).exp(),
                2 => q.q *= (sign * d).exp(),
                3 => q.alpha += sign * d,
                4 => q.u_oc += sign * d,
                _ => beta += sign * d,
            }
            predicted(&s, &oe, &q, beta)
        };
        let (hi, lo) = (moved(1.0), moved(-1.0));
        let fd: Vec<f64> = (0..n).map(|l| (hi[l] - lo[l]) / (2.0 * d)).collect();
        let scale = fd[oe.warm..].iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(scale > 0.0, "column {k} is zero");
        for (l, &f) in fd.iter().enumerate().skip(oe.warm) {
            let j = oe.jacobian_row(&s, l)[k];
            assert!(
                (j - f).abs() <= 1e-6 * scale,
                "column {k}, row {l}: {j} vs {f}"
            );
        }
    }
}

/// [`OutputErrorRefinement::accumulate`]: every sum of `JᵀJ` and `Jᵀr` is
/// the columns' products added row by row in order, bit for bit, for both
/// models, with the OCV slope's column and (its column zero) without it,
/// where its sums are left at zero.
#[test]
fn the_normal_equations_are_the_columns_sums() {
    fn check<T: Real>() {
        const N: usize = 40;
        let s = BatterySettings::<T>::new(T::one(), 8);
        let mut oe =
            OutputErrorRefinement::<T, N, 8>::new(&s, CellParameters::<T>::cell_18650()).unwrap();
        oe.n = N;
        oe.warm = 7;
        // Arbitrary columns: column k's row l, and the residuals.
        let value = |k: usize, l: usize| T::lit(((k * 37 + l * 11) % 23) as f64 / 7.0 - 1.3);
        for slope in [true, false] {
            for l in 0..N {
                oe.s_ri[l] = value(0, l);
                oe.s_rct[l] = value(1, l);
                oe.s_q[l] = value(2, l);
                oe.s_a[l] = value(3, l);
                oe.s_uoc[l] = value(4, l);
                oe.s_beta[l] = if slope { value(5, l) } else { T::zero() };
                oe.s_bva[l] = value(6, l);
                oe.s_bvi0[l] = value(7, l);
                let spare = oe.spare();
                oe.sims[spare].up[l] = value(8, l);
            }
            let cols: [&[T]; COLUMNS + 1] = [
                &oe.s_ri,
                &oe.s_rct,
                &oe.s_q,
                &oe.s_a,
                &oe.s_uoc,
                &oe.s_beta,
                &oe.s_bva,
                &oe.s_bvi0,
                &oe.sims[oe.spare()].up,
            ];
            let sum = |x: usize, y: usize| {
                (oe.warm..N).fold(T::zero(), |acc, l| acc + cols[x][l] * cols[y][l])
            };
            for kinetic in [true, false] {
                let c = if kinetic { COLUMNS } else { LINEAR_COLUMNS };
                let (a, b) = match (kinetic, slope) {
                    (true, true) => oe.accumulate::<COLUMNS, true>(),
                    (true, false) => oe.accumulate::<COLUMNS, false>(),
                    (false, true) => oe.accumulate::<LINEAR_COLUMNS, true>(),
                    (false, false) => oe.accumulate::<LINEAR_COLUMNS, false>(),
                };
                for (x, (row, &bx)) in a.iter().zip(&b).enumerate() {
                    let want = if x < c { sum(x, COLUMNS) } else { T::zero() };
                    assert_eq!(bx.bits(), want.bits(), "b[{x}], {kinetic} {slope}");
                    for (y, &axy) in row.iter().enumerate() {
                        let want = if x < c && y < c { sum(x, y) } else { T::zero() };
                        assert_eq!(axy.bits(), want.bits(), "a[{x}][{y}], {kinetic} {slope}");
                    }
                }
            }
        }
    }
    check::<f32>();
    check::<f64>();
}
