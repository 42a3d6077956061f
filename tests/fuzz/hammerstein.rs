//! The `hammerstein` target: 2S-OP-GI ([`OverParamGi`]), KT-2S-GI
//! ([`KeyTermGi`]) and the prediction-error refinement
//! ([`PredictionErrorRefinement`]) on arbitrary windows and settings, a few
//! iterations each (window 64, memory 16, orders up to 2/3/2 with m = 2,
//! `f32` and `f64`).
//!
//! The window is filled from a random system of eq. (4) simulated with
//! [`HammersteinSystem::simulate`] (stable or not), or from noise,
//! constants, zeros, with NaN/∞/huge/subnormal samples pushed in; the basis
//! is the polynomial one, a bounded one (`tanh`) or one that overflows.
//! The settings ([`GiSettings`], [`PredictionErrorSettings`]) have random
//! orders (some beyond the capacities), memory, period, order bounds, ε,
//! trust radius, grid and damping; now and then an iteration is called with
//! settings other than the constructor's.
//!
//! Checked: construction returns `Ok` exactly when the documented checks
//! pass; a non-finite sample is refused by the window and not stored;
//! every `Ok` iteration counts one more iteration and leaves a finite
//! estimate with a finite cost and α inside the bounds (KT-2S-GI: `b_1 =
//! 1`); every error leaves the estimate and the counter unchanged;
//! `cost_at` does not move the refinement; the simulation's `Ok` output is
//! finite; nothing panics (the products' factorization included).

use super::gen::{log_uniform, nasty, nasty_or, pick, rate};
use super::{note, Outcome, Rng};
use estimator_core::frac::GlWeights;
use estimator_core::gi::key_term::KeyTermGi;
use estimator_core::gi::over_param::OverParamGi;
use estimator_core::gi::prediction_error::{PredictionErrorRefinement, PredictionErrorSettings};
use estimator_core::gi::{GiSettings, HammersteinEstimate, Normalization, Prehistory};
use estimator_core::model::{Basis, HammersteinSystem, Orders, Polynomial};
use estimator_core::window::SampleWindow;
use estimator_core::{Error, Real};
use rand::Rng as _;

const N: usize = 64;
const MEM: usize = 16;
type Op<T> = OverParamGi<T, N, MEM, 2, 3, 2, 2, 6>;
type Kt<T> = KeyTermGi<T, N, MEM, 2, 3, 2, 2, 6>;
type Pem<T> = PredictionErrorRefinement<T, N, MEM, 2, 3, 2, 2, 6, 11>;
type Estimate<T> = HammersteinEstimate<T, 2, 3, 2, 2, 6>;

/// The bases a case may use.
#[derive(Clone, Copy, Debug)]
enum FuzzBasis {
    Polynomial,
    /// `tanh((j+1)·u)`: bounded.
    Tanh,
    /// `u·10³⁰` for `j = 1`: overflows `f32`, and `f64` on large inputs.
    Huge,
    /// NaN for inputs above 1.
    NanAbove1,
}

impl<T: Real> Basis<T> for FuzzBasis {
    fn eval(&self, j: usize, u: T) -> T {
        match self {
            FuzzBasis::Polynomial => Polynomial.eval(j, u),
            FuzzBasis::Tanh => (u * T::lit((j + 1) as f64)).tanh(),
            FuzzBasis::Huge if j == 1 => u * T::lit(1e30),
            FuzzBasis::Huge => u,
            FuzzBasis::NanAbove1 if u > T::one() => T::nan(),
            FuzzBasis::NanAbove1 => Polynomial.eval(j, u),
        }
    }
}

/// Random orders: mostly inside the capacities (2/3/2, m ≤ 2, n_b·m ≤ 6).
fn orders(rng: &mut Rng, pm: f64) -> Orders {
    if rng.random_bool(pm) {
        Orders {
            na: rng.random_range(0..=4),
            nb: rng.random_range(0..=4),
            nc: rng.random_range(0..=4),
            m: rng.random_range(0..=4),
        }
    } else if rng.random_bool(0.3) {
        Orders::PAPER
    } else {
        Orders {
            na: rng.random_range(0..=2),
            nb: rng.random_range(1..=3),
            nc: rng.random_range(0..=2),
            m: rng.random_range(1..=2),
        }
    }
}

/// The documented checks of [`GiSettings::check`] for the capacities used
/// here.
fn gi_valid<T: Real>(s: &GiSettings<T>) -> bool {
    let o = s.orders;
    let f = |x: T| Real::to_f64(x);
    let (lo, hi) = (f(s.alpha_min), f(s.alpha_max));
    o.na <= 2
        && (1..=3).contains(&o.nb)
        && o.nc <= 2
        && (1..=2).contains(&o.m)
        && o.nb * o.m <= 6
        && s.h.is_finite()
        && f(s.h) > 0.0
        && (1..=MEM).contains(&s.memory)
        && lo.is_finite()
        && hi.is_finite()
        && lo > 0.0
        && hi < 2.0
        && lo <= hi
        && s.epsilon.is_finite()
        && f(s.epsilon) >= 0.0
        && s.max_order_step.is_finite()
        && f(s.max_order_step) > 0.0
}

fn in_bounds<T: Real>(s: &GiSettings<T>, a: T) -> bool {
    a.is_finite() && a >= s.alpha_min && a <= s.alpha_max
}

/// Random settings of the paper algorithms.
fn gi_settings<T: Real>(rng: &mut Rng, pm: f64) -> GiSettings<T> {
    let memory = if rng.random_bool(pm) {
        pick(rng, &[0, MEM + 1, usize::MAX])
    } else {
        rng.random_range(1..=MEM)
    };
    let mut s = GiSettings::new(orders(rng, pm), memory);
    let l = |x: f64| T::lit(x);
    s.h = l(nasty_or!(rng, pm, pick(rng, &[1.0, 1.0, 0.1, 10.0])));
    if rng.random_bool(0.3) {
        s.alpha_min = l(rng.random_range(0.01..1.0));
        s.alpha_max = l(rng.random_range(Real::to_f64(s.alpha_min)..1.99));
    }
    s.alpha_min = l(nasty_or!(rng, pm, Real::to_f64(s.alpha_min)));
    s.alpha_max = l(nasty_or!(rng, pm, Real::to_f64(s.alpha_max)));
    s.epsilon = l(nasty_or!(rng, pm, pick(rng, &[1e-6, 0.0, 1e-3, 1e-12])));
    s.max_halvings = pick(rng, &[12, 0, 1, 255]);
    s.max_order_step = l(nasty_or!(rng, pm, pick(rng, &[0.05, 1e-4, 0.5, 2.0])));
    s.estimate_order = !rng.random_bool(0.15);
    s.prehistory = if rng.random_bool(0.5) {
        Prehistory::AtRest
    } else {
        Prehistory::Unknown
    };
    s
}

/// An order inside the settings' bounds (or an arbitrary one at rate
/// `pm`).
fn alpha0<T: Real>(rng: &mut Rng, pm: f64, s: &GiSettings<T>) -> T {
    let (lo, hi) = (Real::to_f64(s.alpha_min), Real::to_f64(s.alpha_max));
    // (`hi − lo` finite: a range of width beyond `f64` cannot be drawn
    // from.)
    let a = if (hi - lo).is_finite() && lo <= hi {
        rng.random_range(lo..=hi)
    } else {
        0.5
    };
    T::lit(nasty_or!(rng, pm, a))
}

/// Fills a window: a simulated system, noise, constants or zeros, with
/// arbitrary values pushed in (a non-finite one must be refused).
fn window<T: Real>(rng: &mut Rng, o: Orders) -> Result<SampleWindow<T, N>, String> {
    let len = match rng.random_range(0..6) {
        0 => rng.random_range(0..20),
        1 => rng.random_range(20..N),
        _ => rng.random_range(N..2 * N),
    };
    let amp = log_uniform(rng, 1e-3, 1e3);
    let u: Vec<f64> = match rng.random_range(0..8) {
        0 => vec![0.0; len],
        1 => vec![amp; len],
        _ => (0..len).map(|_| rng.random_range(-amp..=amp)).collect(),
    };
    let mut y = vec![0.0; len];
    match rng.random_range(0..4) {
        0 | 1 if o.nb > 0 && o.m > 0 => {
            let draw = |rng: &mut Rng, n: usize, s: f64| -> Vec<f64> {
                (0..n).map(|_| rng.random_range(-s..=s)).collect()
            };
            let scale = pick(rng, &[0.3, 0.3, 1.0, 3.0]);
            let (a, b, c, g) = (
                draw(rng, o.na, scale),
                draw(rng, o.nb, 1.5),
                draw(rng, o.nc, scale),
                draw(rng, o.m, 1.5),
            );
            let alpha = rng.random_range(0.05..1.95);
            let sys = HammersteinSystem {
                a: &a,
                b: &b,
                c: &c,
                gamma: &g,
                alpha,
            };
            let sigma = pick(rng, &[0.0, 0.01, 0.5]);
            let v: Vec<f64> = (0..len).map(|_| rng.random_range(-sigma..=sigma)).collect();
            let mut e = vec![0.0; len];
            let w = GlWeights::<f64, MEM>::new(alpha, 1.0, MEM).map_err(|e| format!("{e:?}"))?;
            if sys
                .simulate(&Polynomial, &w, &u, &v, &mut y, &mut e)
                .is_ok()
                && !y.iter().chain(&e).all(|x| x.is_finite())
            {
                return Err("simulate returned Ok with a non-finite output".into());
            }
        }
        2 => y.iter_mut().for_each(|x| *x = rng.random_range(-amp..=amp)),
        _ => {}
    }
    let r = rate(rng);
    let mut w = SampleWindow::<T, N>::new();
    for (&uk, &yk) in u.iter().zip(&y) {
        let (uk, yk) = (T::lit(nasty_or!(rng, r, uk)), T::lit(nasty_or!(rng, r, yk)));
        let len = w.len();
        let pushed = w.push(uk, yk);
        let finite = uk.is_finite() && yk.is_finite();
        match (pushed, finite) {
            (Ok(()), true) if w.len() == (len + 1).min(N) => {}
            (Err(Error::NonFiniteSample), false) if w.len() == len => {}
            (p, _) => {
                return Err(format!(
                    "window push ({uk:?}, {yk:?}): {p:?}, len {len} -> {}",
                    w.len()
                ))
            }
        }
    }
    Ok(w)
}

fn finite<T: Real>(e: &Estimate<T>) -> bool {
    e.a.iter()
        .chain(&e.c)
        .chain(&e.products)
        .all(|x| x.is_finite())
        && e.alpha.is_finite()
}

fn bits<T: Real>(e: &Estimate<T>) -> Vec<u64> {
    e.a.iter()
        .chain(&e.c)
        .chain(&e.products)
        .chain(core::iter::once(&e.alpha))
        .map(|&x| Real::to_f64(x).to_bits())
        .collect()
}

/// The invariants of one iteration of a paper algorithm.
#[allow(clippy::too_many_arguments)]
fn check_iteration<T: Real>(
    what: &str,
    s: &GiSettings<T>,
    r: &Result<estimator_core::gi::Iteration<T>, Error>,
    before: &Estimate<T>,
    after: &Estimate<T>,
    k_before: u32,
    k_after: u32,
) -> Outcome {
    match r {
        Ok(it) => {
            if it.k != k_before + 1 || k_after != it.k {
                return Err(format!(
                    "{what}: iteration {} after {k_before} (counter {k_after})",
                    it.k
                ));
            }
            if !(it.cost.is_finite() && it.change.is_finite() && finite(after)) {
                return Err(format!(
                    "{what}: Ok with a non-finite result: {it:?} {after:?}"
                ));
            }
            if !in_bounds(s, it.alpha) || it.alpha != after.alpha {
                return Err(format!(
                    "{what}: α {:?} outside [{:?}, {:?}] or not the estimate's {:?}",
                    it.alpha, s.alpha_min, s.alpha_max, after.alpha
                ));
            }
            if it.converged != (it.change <= s.epsilon) || it.rows > N {
                return Err(format!("{what}: {it:?}"));
            }
        }
        Err(_) => {
            if bits(before) != bits(after) || k_before != k_after {
                return Err(format!("{what}: {r:?} changed the estimate or the counter"));
            }
        }
    }
    Ok(())
}

/// Runs one case.
pub fn case(rng: &mut Rng) -> Outcome {
    if rng.random_bool(0.4) {
        run::<f32>(rng)
    } else {
        run::<f64>(rng)
    }
}

fn run<T: Real>(rng: &mut Rng) -> Outcome {
    let pm = pick(rng, &[0.0, 0.0, 0.02, 0.1, 0.3]);
    let s = gi_settings::<T>(rng, pm);
    let a0 = alpha0(rng, pm, &s);
    let valid = gi_valid(&s) && in_bounds(&s, a0);
    let basis = pick(
        rng,
        &[
            FuzzBasis::Polynomial,
            FuzzBasis::Polynomial,
            FuzzBasis::Polynomial,
            FuzzBasis::Tanh,
            FuzzBasis::Huge,
            FuzzBasis::NanAbove1,
        ],
    );
    let w = window::<T>(rng, s.orders)?;
    let op = Op::<T>::new(&s, a0);
    let kt = Kt::<T>::new(&s, a0);
    for (what, ok) in [
        ("OverParamGi::new", op.is_ok()),
        ("KeyTermGi::new", kt.is_ok()),
    ] {
        if ok != valid {
            return Err(format!(
                "{what}: ok {ok} for settings that are valid {valid}: {s:?}, α₀ {a0:?}"
            ));
        }
    }
    let (Ok(mut op), Ok(mut kt)) = (op, kt) else {
        note("hammerstein: paper constructors error");
        return Ok(());
    };
    note("hammerstein: paper constructors Ok");
    let iterations = rng.random_range(1..=8);
    let mut it_s = s;
    for k in 0..iterations {
        if rng.random_bool(0.03) {
            it_s = gi_settings::<T>(rng, 0.1);
        }
        let tag = |e: String| format!("iteration {k} ({}): {e}", std::any::type_name::<T>());
        let (before, kb) = (*op.estimate(), op.iterations());
        let r = op.iterate(&it_s, &basis, &w);
        note(if r.is_ok() {
            "hammerstein: 2S-OP-GI iteration Ok"
        } else {
            "hammerstein: 2S-OP-GI iteration error"
        });
        check_iteration(
            "2S-OP-GI",
            &it_s,
            &r,
            &before,
            op.estimate(),
            kb,
            op.iterations(),
        )
        .map_err(tag)?;
        let (before, kb) = (kt.products(), kt.iterations());
        let r = kt.iterate(&it_s, &basis, &w);
        note(if r.is_ok() {
            "hammerstein: KT-2S-GI iteration Ok"
        } else {
            "hammerstein: KT-2S-GI iteration error"
        });
        check_iteration(
            "KT-2S-GI",
            &it_s,
            &r,
            &before,
            &kt.products(),
            kb,
            kt.iterations(),
        )
        .map_err(tag)?;
        if kt.estimate().b[0] != T::one() {
            return Err(tag(format!("KT-2S-GI: b₁ = {:?}", kt.estimate().b[0])));
        }
    }
    for norm in [Normalization::UnitGamma, Normalization::UnitB1] {
        let _ = op.estimate().factor(norm);
        let _ = kt.products().factor(norm);
    }
    if rng.random_bool(0.1) {
        let mut e = *op.estimate();
        e.alpha = T::lit(nasty(rng));
        let ok = op.set_estimate(e).is_ok();
        if ok != (e.alpha > T::zero() && e.alpha < T::lit(2.0) && finite(&e)) {
            return Err(format!("set_estimate: ok {ok} for α {:?}", e.alpha));
        }
    }

    // The refinement from either paper stage or an arbitrary start.
    let mut ps = PredictionErrorSettings::new(if rng.random_bool(0.8) {
        s
    } else {
        gi_settings::<T>(rng, pm)
    });
    ps.grid_points = pick(rng, &[8, 0, 1, 3, 20]);
    if rng.random_bool(0.3) {
        ps.grid_low = T::lit(nasty_or!(rng, pm, rng.random_range(-0.5..1.0)));
        ps.grid_high = T::lit(nasty_or!(rng, pm, rng.random_range(0.0..2.5)));
    }
    ps.grid_iterations = pick(rng, &[12, 0, 1, 3]);
    ps.max_damping_trials = pick(rng, &[12, 1, 3, 0, 40]);
    let start = match rng.random_range(0..4) {
        0 => kt.products(),
        1 => {
            let mut e = Estimate::<T>::initial(ps.gi.orders, alpha0(rng, pm, &ps.gi));
            for x in e.a.iter_mut().chain(&mut e.c).chain(&mut e.products) {
                *x = T::lit(nasty_or!(rng, pm, rng.random_range(-2.0..2.0)));
            }
            e
        }
        _ => *op.estimate(),
    };
    let g = &ps.gi;
    let grid_ok = ps.grid_points == 0
        || (ps.grid_low.is_finite() && ps.grid_high.is_finite() && ps.grid_low < ps.grid_high);
    let valid = gi_valid(g)
        && grid_ok
        && ps.max_damping_trials > 0
        && start.orders == g.orders
        && finite(&start)
        && in_bounds(g, start.alpha);
    let pem = Pem::<T>::new(&ps, &start);
    if pem.is_ok() != valid {
        return Err(format!(
            "PredictionErrorRefinement::new: {:?} for settings valid {valid}: {ps:?}, start {start:?}",
            pem.as_ref().err()
        ));
    }
    let Ok(mut pem) = pem else {
        note("hammerstein: refinement constructor error");
        return Ok(());
    };
    note("hammerstein: refinement constructor Ok");
    let iterations = rng.random_range(1..=12);
    for k in 0..iterations {
        let tag = |e: String| {
            format!(
                "refinement iteration {k} ({}): {e}",
                std::any::type_name::<T>()
            )
        };
        let (before, kb) = (*pem.estimate(), pem.iterations());
        let r = pem.iterate(&ps, &basis, &w);
        note(if r.is_ok() {
            "hammerstein: refinement iteration Ok"
        } else {
            "hammerstein: refinement iteration error"
        });
        let (after, ka) = (pem.estimate(), pem.iterations());
        match &r {
            Ok(it) => {
                if !(it.cost.is_finite() && finite(after)) {
                    return Err(tag(format!(
                        "Ok with a non-finite result: {it:?} {after:?}"
                    )));
                }
                if !in_bounds(&ps.gi, after.alpha) {
                    return Err(tag(format!("α {:?} outside the bounds", after.alpha)));
                }
                if ka != kb + 1 || it.k != ka {
                    return Err(tag(format!("iteration {} after {kb} (counter {ka})", it.k)));
                }
            }
            Err(_) => {
                if bits(&before) != bits(after) {
                    return Err(tag(format!("{r:?} changed the estimate")));
                }
            }
        }
        if pem.winning_start(&ps).is_some() {
            note("hammerstein: refinement search over, descent");
        }
        let _ = pem.phase();
    }
    if rng.random_bool(0.3) {
        let before = bits(pem.estimate());
        let mut e = *op.estimate();
        if rng.random_bool(0.5) {
            e.products[0] = T::lit(nasty(rng));
        }
        let _ = pem.cost_at(&ps, &basis, &w, &e);
        if bits(pem.estimate()) != before {
            return Err("cost_at moved the refinement's estimate".into());
        }
    }
    if rng.random_bool(0.1) {
        let _ = pem.restart(&ps, &kt.products());
        let _ = pem.iterate(&ps, &basis, &w);
    }
    Ok(())
}
