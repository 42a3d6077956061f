//! The settings the `cell`, `pack` and `snapshot` targets draw
//! ([`settings`]: the defaults with fields replaced by arbitrary or
//! plausible values, an OCV curve, a prior, the Butler–Volmer model, the
//! SOC observer's settings) and what the estimators' constructors must do
//! with them, from their documentation ([`expect_new`], [`Expect`]). It
//! owns no estimator and checks no sample: that is [`super::cell`]'s.

use super::gen::{log_uniform, nasty_or, pick};
use super::{Outcome, Rng};
use estimator_core::battery::ocv::{OcvModel, OcvTable};
use estimator_core::battery::online::{Method, OnlineSettings};
use estimator_core::battery::{CellModel, CellParameters, Prior, Start};
use estimator_core::Real;
use rand::Rng as _;
/// Points of the OCV curves the cases use.
pub const P: usize = 8;

/// The online settings the targets use (room for a curve of [`P`] points).
pub type Settings<T> = OnlineSettings<T, P>;

/// What the constructor must do with a settings value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Expect {
    /// Every documented check passes: `Ok`.
    Ok,
    /// A documented check fails: an error.
    Err,
    /// Not said by the documentation (an infinite spike or OCV-offset or
    /// relaxation limit): either.
    Either,
}

pub(super) fn lit<T: Real>(x: f64) -> T {
    T::lit(x)
}

/// Plausible random cell parameters (linear or Butler–Volmer).
pub fn parameters(rng: &mut Rng) -> CellParameters<f64> {
    let bv = rng.random_bool(0.2);
    CellParameters {
        r_i: log_uniform(rng, 1e-4, 0.5),
        r_ct: log_uniform(rng, 1e-4, 0.5),
        q: log_uniform(rng, 1.0, 1e5),
        alpha: rng.random_range(0.1..=1.0),
        u_oc: rng.random_range(2.8..4.2),
        bv_a: if bv { log_uniform(rng, 1e-3, 0.1) } else { 0.0 },
        bv_i0: log_uniform(rng, 0.1, 100.0),
    }
}

fn cast<T: Real>(p: &CellParameters<f64>) -> CellParameters<T> {
    p.cast()
}

/// Parameters with each field replaced by a nasty value at rate `pm`.
fn mutate_parameters(rng: &mut Rng, pm: f64, p: CellParameters<f64>) -> CellParameters<f64> {
    CellParameters {
        r_i: nasty_or!(rng, pm, p.r_i),
        r_ct: nasty_or!(rng, pm, p.r_ct),
        q: nasty_or!(rng, pm, p.q),
        alpha: nasty_or!(rng, pm, p.alpha),
        u_oc: nasty_or!(rng, pm, p.u_oc),
        bv_a: nasty_or!(rng, pm, p.bv_a),
        bv_i0: nasty_or!(rng, pm, p.bv_i0),
    }
}

/// A random OCV curve: `n` points increasing in both columns (sometimes
/// not: the table then refuses it and the case runs without a curve).
fn ocv_table<T: Real>(rng: &mut Rng, pm: f64) -> Option<OcvTable<T, P>> {
    let n = rng.random_range(2..=P);
    let mut soc = Vec::with_capacity(n);
    let mut ocv = Vec::with_capacity(n);
    let (z0, z1) = if rng.random_bool(0.7) {
        (0.0, 1.0)
    } else {
        let a = rng.random_range(0.0..0.5);
        (a, rng.random_range(a + 0.01..=1.0))
    };
    let mut v = rng.random_range(2.5..3.5);
    for k in 0..n {
        soc.push(nasty_or!(
            rng,
            pm / 4.0,
            z0 + (z1 - z0) * k as f64 / (n - 1) as f64
        ));
        v += log_uniform(rng, 1e-4, 0.5);
        ocv.push(nasty_or!(rng, pm / 4.0, v));
    }
    let soc: Vec<T> = soc.into_iter().map(lit).collect();
    let ocv: Vec<T> = ocv.into_iter().map(lit).collect();
    OcvTable::new(&soc, &ocv).ok()
}

/// Arbitrary online settings for an estimator of memory capacity `MEM`,
/// and what its constructor must do with them (`clean`: no field replaced
/// by an arbitrary value).
pub fn settings<T: Real, const MEM: usize>(rng: &mut Rng, clean: bool) -> (Settings<T>, Expect) {
    let pm = if clean {
        0.0
    } else {
        pick(rng, &[0.0, 0.01, 0.05, 0.2])
    };
    let h = nasty_or!(rng, pm, pick(rng, &[1.0, 1.0, 0.1, 0.5, 10.0, 1e-3]));
    let memory = if rng.random_bool(pm) {
        pick(rng, &[0, MEM + 1, usize::MAX, 1 << 20])
    } else if rng.random_bool(0.3) {
        MEM
    } else {
        rng.random_range(1..=MEM)
    };
    let truth = parameters(rng);
    let initial = if rng.random_bool(0.5) {
        CellParameters::cell_18650()
    } else {
        truth
    };
    let initial = mutate_parameters(rng, pm, initial);
    let mut s = OnlineSettings::new(lit::<T>(h), memory, cast(&initial));
    let b = &mut s.battery;
    if rng.random_bool(0.3) {
        b.alpha_min = lit(nasty_or!(rng, pm, rng.random_range(0.01..0.5)));
    }
    if rng.random_bool(0.3) {
        b.alpha_max = lit(nasty_or!(rng, pm, rng.random_range(0.5..1.99)));
    }
    b.alpha_min = lit(nasty_or!(rng, pm, Real::to_f64(b.alpha_min)));
    b.alpha_max = lit(nasty_or!(rng, pm, Real::to_f64(b.alpha_max)));
    if rng.random_bool(0.3) {
        b.epsilon = lit(pick(rng, &[0.0, 1e-12, 1e-4, 0.1]));
    }
    b.epsilon = lit(nasty_or!(rng, pm, Real::to_f64(b.epsilon)));
    b.max_halvings = if rng.random_bool(0.2) {
        rng.random()
    } else {
        b.max_halvings
    };
    b.max_order_step = lit(nasty_or!(
        rng,
        pm,
        if rng.random_bool(0.3) {
            log_uniform(rng, 1e-4, 2.0)
        } else {
            0.05
        }
    ));
    b.estimate_order = !rng.random_bool(0.1);
    b.start = if rng.random_bool(0.2) {
        Start::AtRest
    } else {
        Start::FromData
    };
    b.ocv_slope = rng.random_bool(0.7);
    b.min_current_std = lit(nasty_or!(
        rng,
        pm,
        pick(rng, &[1e-3, 1e-3, 0.0, 1e-6, 0.1, 10.0])
    ));
    if rng.random_bool(0.2) {
        let center = parameters(rng);
        let mut prior = Prior::new(cast::<T>(&mutate_parameters(rng, pm, center)));
        prior.log_sigma = lit(nasty_or!(rng, pm, Real::to_f64(prior.log_sigma)));
        prior.alpha_sigma = lit(nasty_or!(rng, pm, Real::to_f64(prior.alpha_sigma)));
        prior.noise_v = lit(nasty_or!(rng, pm, Real::to_f64(prior.noise_v)));
        b.prior = Some(prior);
    }
    if rng.random_bool(0.2) {
        b.model = CellModel::ButlerVolmer;
    }
    b.tail = rng.random_bool(0.3);
    s.method = if rng.random_bool(0.3) {
        Method::Paper
    } else {
        Method::Refined
    };
    s.iterations_per_sample = pick(rng, &[0, 1, 1, 1, 2, 3]);
    s.paper_budget = pick(rng, &[0, 1, 5, 20, 200, u32::MAX]);
    let (lo, hi) = (
        Real::to_f64(s.battery.alpha_min),
        Real::to_f64(s.battery.alpha_max),
    );
    let alpha0 = if (hi - lo).is_finite() && lo <= hi && rng.random_bool(0.7) {
        rng.random_range(lo..=hi)
    } else {
        0.5
    };
    s.alpha0 = lit(nasty_or!(rng, pm, alpha0));
    s.current_limit = lit(nasty_or!(
        rng,
        pm,
        pick(rng, &[500.0, 500.0, 50.0, 1.0, 1e6])
    ));
    s.voltage_min = lit(nasty_or!(rng, pm, pick(rng, &[1.5, 1.5, 2.5, 0.0, -10.0])));
    s.voltage_max = lit(nasty_or!(rng, pm, pick(rng, &[5.0, 5.0, 4.3, 100.0])));
    s.spike_sigmas = lit(nasty_or!(rng, pm, pick(rng, &[8.0, 8.0, 1.0, 3.0, 1e-3])));
    s.spike_floor = lit(nasty_or!(
        rng,
        pm,
        pick(rng, &[0.05, 0.05, 1e-3, 1e-9, 1.0])
    ));
    s.max_consecutive_spikes = pick(rng, &[3, 3, 0, 1, 10, 255]);
    s.max_ocv_offset = lit(nasty_or!(rng, pm, pick(rng, &[0.15, 0.15, 1e-3, 1.0])));
    s.max_relaxation_windows = lit(nasty_or!(rng, pm, pick(rng, &[1.0, 1.0, 0.1, 10.0])));
    let curve = if rng.random_bool(0.35) {
        ocv_table::<T>(rng, pm).map(|table| OcvModel {
            table,
            capacity_ah: lit(nasty_or!(rng, pm, log_uniform(rng, 0.1, 200.0))),
        })
    } else {
        None
    };
    let mut s = s.with_curve(curve);
    if rng.random_bool(0.3) {
        // The SOC observer's settings (checked by `SocSettings::check`;
        // its spreads may be far beyond any information).
        let o = &mut s.soc;
        let f = |x: T| Real::to_f64(x);
        o.rest_s = lit(nasty_or!(rng, pm, pick(rng, &[600.0, 60.0, 0.0, 1e6])));
        o.voltage_sigma_v = lit(nasty_or!(rng, pm, pick(rng, &[0.005, 0.0, 1.0])));
        o.table_sigma_soc = lit(nasty_or!(rng, pm, pick(rng, &[0.01, 0.0, 10.0])));
        o.soc0_sigma = lit(nasty_or!(rng, pm, pick(rng, &[0.1, 0.0, 1e20])));
        o.bias_sigma_a = lit(nasty_or!(
            rng,
            pm,
            pick(rng, &[f(o.bias_sigma_a), 0.0, 1e20])
        ));
        o.bias_walk_a = lit(nasty_or!(
            rng,
            pm,
            pick(rng, &[f(o.bias_walk_a), 0.0, 1e20])
        ));
        o.rest_load_sigma_a = lit(nasty_or!(
            rng,
            pm,
            pick(rng, &[f(o.rest_load_sigma_a), 0.0, 1e20])
        ));
        o.capacity_sigma = lit(nasty_or!(rng, pm, pick(rng, &[0.15, 0.0, 1e20])));
        o.gap_soc_sigma = lit(nasty_or!(rng, pm, pick(rng, &[0.5, 0.0, 1e30])));
        o.min_slope = lit(nasty_or!(rng, pm, pick(rng, &[1e-3, 1e-9, 1e3])));
        o.capacity_min_span = lit(nasty_or!(rng, pm, pick(rng, &[0.3, 0.0, 1e9])));
    }
    if rng.random_bool(0.3) {
        // The slow part carried across windows (`check_limits`: its memory
        // not negative, its memory in state of charge positive; either may
        // be infinite).
        s.slow_memory_s = lit(nasty_or!(
            rng,
            pm,
            pick(rng, &[600.0, 1.0, 1e6, f64::INFINITY])
        ));
        s.slow_memory_soc = lit(nasty_or!(rng, pm, pick(rng, &[0.02, 1e-6, 10.0])));
    }
    if let Some(m) = &s.ocv {
        // Known issue (tests/tests/fuzz.rs,
        // `an_overflowing_coulomb_count_keeps_the_window_finite`): a
        // coulomb count `h·I/(3600·C)` that can overflow over a record (a
        // tiny capacity, a huge period) makes the SOC ±∞, then NaN, and a
        // NaN enters the window. Such a case runs without the curve.
        let f = |x: T| Real::to_f64(x).abs();
        let step = f(s.battery.h) * f(s.current_limit) / (3600.0 * f(m.capacity_ah));
        let bounded = step * 4096.0 < f(T::max_value()) / 4.0;
        if super::avoid_known_issues() && !bounded {
            s.ocv = None;
        }
    }
    let e = expect_new::<T, MEM>(&s);
    (s, e)
}

/// What the estimators' constructors must do with `s` (memory capacity
/// `MEM`), from their documentation: [`BatterySettings::check`], a bad
/// `alpha0` or start, non-finite limits, a bad capacity.
///
/// [`BatterySettings::check`]: estimator_core::battery::BatterySettings::check
pub fn expect_new<T: Real, const MEM: usize>(s: &Settings<T>) -> Expect {
    let f = |x: T| Real::to_f64(x);
    let pos = |x: T| x.is_finite() && x > T::zero();
    let b = &s.battery;
    let (lo, hi) = (f(b.alpha_min), f(b.alpha_max));
    let in_bounds = |a: T| a.is_finite() && f(a) >= lo && f(a) <= hi;
    let start = s.initial_in_window();
    let prior_ok = b.prior.is_none_or(|p| p.is_valid());
    let documented = pos(b.h)
        && b.memory >= 1
        && b.memory <= MEM
        && lo.is_finite()
        && hi.is_finite()
        && lo > 0.0
        && hi < 2.0
        && lo <= hi
        && b.epsilon.is_finite()
        && f(b.epsilon) >= 0.0
        && pos(b.max_order_step)
        && b.min_current_std.is_finite()
        && f(b.min_current_std) >= 0.0
        && prior_ok
        && in_bounds(s.alpha0)
        && start.is_physical()
        && in_bounds(start.alpha)
        && s.initial.alpha.is_finite()
        && pos(s.current_limit)
        && s.voltage_min.is_finite()
        && s.voltage_max.is_finite()
        && s.voltage_min < s.voltage_max
        && s.spike_sigmas > T::zero()
        && pos(s.spike_floor)
        && s.max_ocv_offset > T::zero()
        && s.max_relaxation_windows > T::zero()
        && s.slow_memory_s >= T::zero()
        && s.slow_memory_soc > T::zero()
        && s.ocv.is_none_or(|m| pos(m.capacity_ah))
        && soc_documented(&s.soc);
    if !documented {
        Expect::Err
    } else if pos(s.spike_sigmas) && pos(s.max_ocv_offset) && pos(s.max_relaxation_windows) {
        Expect::Ok
    } else {
        Expect::Either
    }
}

/// [`SocSettings::check`]'s documentation: every setting finite and not
/// negative, the capacity, the period and the smallest slope positive,
/// the span asked of the rests at most 1, the capacity's square finite.
///
/// [`SocSettings::check`]: estimator_core::battery::soc::SocSettings::check
pub fn soc_documented<T: Real>(o: &estimator_core::battery::soc::SocSettings<T>) -> bool {
    let all = [
        o.capacity_ah,
        o.h,
        o.rest_current_a,
        o.rest_s,
        o.rest_max_s,
        o.voltage_sigma_v,
        o.unrelaxed_sigma_v,
        o.table_sigma_soc,
        o.soc0_sigma,
        o.bias_sigma_a,
        o.bias_walk_a,
        o.rest_load_sigma_a,
        o.capacity_sigma,
        o.capacity_identify,
        o.capacity_min_span,
        o.gap_soc_sigma,
        o.min_slope,
    ];
    all.iter().all(|x| x.is_finite() && *x >= T::zero())
        && [o.capacity_ah, o.h, o.min_slope]
            .iter()
            .all(|x| *x > T::zero())
        && o.capacity_min_span <= T::one()
        && (o.capacity_ah * o.capacity_ah).is_finite()
}

/// Checks a constructor's result against [`Expect`].
pub fn check_new<E: core::fmt::Debug>(what: &str, ok: Result<(), E>, e: Expect) -> Outcome {
    match (ok, e) {
        (Ok(()), Expect::Err) => Err(format!("{what}: Ok for invalid settings")),
        (Err(err), Expect::Ok) => Err(format!("{what}: {err:?} for valid settings")),
        _ => Ok(()),
    }
}
