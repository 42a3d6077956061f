//! The `cell` target: [`CellEstimator`] (window 64, memory 16 in `f32` and
//! `f64`; window 128, memory 64 in `f64`, where the refinement's tail can
//! run) with arbitrary [`OnlineSettings`] and sample streams.
//!
//! The settings start from the defaults with each field replaced, at a
//! per-case rate, by an arbitrary value (NaN, ±∞, 0, negative, huge,
//! subnormal) or a plausible random one; an OCV curve, a prior and the
//! Butler–Volmer model come and go. Construction must return `Ok` exactly
//! when the documented checks pass ([`expect_new`]) and never panic. The
//! stream is a simulated cell (pulses, rests, sines, noise, a slow OCV
//! drift) with steps, spikes, constant stretches, NaN, ±∞, `1e30`,
//! subnormals and out-of-range values injected; now and then the settings
//! passed to `push` change under the estimator.
//!
//! Checked at every push ([`check_cell`], shared with the `pack` target):
//! the sample counter advances by one, exactly one rejection counter moves
//! when (and only when) the sample is rejected, NaN/∞ and out-of-range
//! samples are rejected as such, the window holds only finite samples, a
//! published estimate is finite and physical (and, under the settings it
//! was published with, plausible), a changed estimate comes with
//! [`Status::Tracking`] (at one iteration per sample), the report agrees
//! with the state; and a clone fed the same sample behaves identically.

use super::gen::{log_uniform, nasty, nasty_or, pick, rate};
pub use super::settings::{check_new, expect_new, parameters, settings, Expect, Settings, P};
use super::settings::{lit, soc_documented};
use super::{note, Outcome, Rng};
use estimator_core::battery::online::{
    CellEstimator, CellState, CellWindow, Rejection, SampleCounts, SampleReport, Status,
};
use estimator_core::battery::CellParameters;
use estimator_core::Real;
use rand::Rng as _;

/// A current record of `len` samples: pulses, rests, sines, noise around
/// an amplitude (usually amperes; unless `clean`, now and then `1e-30` or
/// `1e30`).
pub fn currents(rng: &mut Rng, len: usize, clean: bool) -> Vec<f64> {
    let amp = match rng.random_range(0..20) {
        _ if clean => log_uniform(rng, 0.5, 20.0),
        0 => 1e-30,
        1 => 1e30,
        2 => 0.0,
        _ => log_uniform(rng, 0.01, 100.0),
    };
    let mut out = Vec::with_capacity(len);
    while out.len() < len {
        let d = rng.random_range(1..40).min(len - out.len());
        match rng.random_range(0..6) {
            0 => out.extend(std::iter::repeat_n(0.0, d)),
            1 | 2 => {
                let level = amp * pick(rng, &[-1.0, -0.5, 0.5, 1.0, 0.25]);
                out.extend(std::iter::repeat_n(level, d));
            }
            3 => {
                let period = rng.random_range(2.0..60.0);
                let k0 = out.len();
                out.extend(
                    (0..d).map(|k| amp * ((k0 + k) as f64 * std::f64::consts::TAU / period).sin()),
                );
            }
            4 => out.extend((0..d).map(|_| rng.random_range(-amp..=amp))),
            _ => {
                let x = rng.random_range(-amp..=amp);
                out.extend(std::iter::repeat_n(x, d));
            }
        }
    }
    out
}

/// The terminal voltage of a cell with parameters `p` (a first-order RC
/// branch standing in for the constant-phase one) driven by `current`:
/// with noise, a slow OCV drift, ADC rounding, and (unless `clean`) now
/// and then a constant stretch, a step, a scaled record.
pub fn voltages(rng: &mut Rng, p: &CellParameters<f64>, current: &[f64], clean: bool) -> Vec<f64> {
    let (tau, sigma, drift) = if clean {
        (
            log_uniform(rng, 2.0, 30.0),
            pick(rng, &[0.0, 1e-4, 1e-3]),
            pick(rng, &[0.0, 1e-5]),
        )
    } else {
        (
            log_uniform(rng, 1.0, 200.0),
            pick(rng, &[0.0, 1e-4, 1e-3, 1e-2, 0.1]),
            pick(rng, &[0.0, 0.0, 1e-5, -1e-4, 1e-3]),
        )
    };
    let a = (-1.0 / tau).exp();
    let adc = pick(rng, &[0.0, 0.0, 1e-3, 1e-2]);
    let mut up = 0.0;
    let mut out: Vec<f64> = current
        .iter()
        .enumerate()
        .map(|(k, &i)| {
            up = a * up + (1.0 - a) * p.r_ct * i;
            let noise = if sigma > 0.0 {
                sigma * (rng.random::<f64>() - 0.5) * 3.46
            } else {
                0.0
            };
            let v = p.u_oc + drift * k as f64 + p.static_voltage(i) + up + noise;
            if adc > 0.0 {
                (v / adc).round() * adc
            } else {
                v
            }
        })
        .collect();
    let n = out.len();
    if clean {
        return out;
    }
    if n > 0 && rng.random_bool(0.1) {
        // A constant stretch.
        let k = rng.random_range(0..n);
        let d = rng.random_range(1..=n - k);
        let c = out[k];
        out[k..k + d].iter_mut().for_each(|v| *v = c);
    }
    if n > 0 && rng.random_bool(0.1) {
        // A step (a recalibrated sensor, a contactor).
        let k = rng.random_range(0..n);
        let dv = pick(rng, &[-1.0, -0.1, -0.01, 0.01, 0.1, 0.5]);
        out[k..].iter_mut().for_each(|v| *v += dv);
    }
    if rng.random_bool(0.02) {
        let f = pick(rng, &[1e-30, 1e30, -1.0, 0.0]);
        out.iter_mut().for_each(|v| *v *= f);
    }
    out
}

/// Injects arbitrary values into a record at rate `r`: spikes, NaN, ±∞,
/// `1e30`, subnormals, out-of-range values.
pub fn perturb(rng: &mut Rng, r: f64, x: &mut [f64], spike: f64) {
    if r == 0.0 {
        return;
    }
    for v in x.iter_mut() {
        if rng.random_bool(r) {
            *v = if rng.random_bool(0.3) {
                *v + spike * pick(rng, &[-1.0, 1.0, 3.0, -10.0])
            } else {
                nasty(rng)
            };
        }
    }
}

/// What a cell was before a push.
#[derive(Clone, Copy, Debug)]
pub struct Before<T> {
    counts: SampleCounts,
    /// The estimate in the window's coordinates (the OCV offset as `u_oc`
    /// with a curve).
    raw: Option<CellParameters<T>>,
}

impl<T: Real> Before<T> {
    /// The state of `st` now.
    pub fn of<const N: usize>(st: &CellState<T, N>) -> Self {
        Self {
            counts: st.counts(),
            raw: raw(st),
        }
    }
}

/// The estimate in the window's coordinates.
fn raw<T: Real, const N: usize>(st: &CellState<T, N>) -> Option<CellParameters<T>> {
    st.estimate().map(|p| match st.ocv_offset() {
        Some(d) => CellParameters { u_oc: d, ..p },
        None => p,
    })
}

fn same<T: Real>(a: &Option<CellParameters<T>>, b: &Option<CellParameters<T>>) -> bool {
    let bits = |p: &CellParameters<T>| {
        [p.r_i, p.r_ct, p.q, p.alpha, p.u_oc, p.bv_a, p.bv_i0].map(|x| Real::to_f64(x).to_bits())
    };
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => bits(a) == bits(b),
        _ => false,
    }
}

/// The invariants of one cell after one push of `(current, voltage)` with
/// settings `s` (`published_with_s`: the estimator was built with `s`, so a
/// newly published estimate must be plausible under it).
pub fn check_cell<T: Real, const N: usize>(
    s: &Settings<T>,
    published_with_s: bool,
    before: &Before<T>,
    st: &CellState<T, N>,
    window: CellWindow<'_, T, N>,
    current: T,
    voltage: T,
) -> Outcome {
    let c0 = before.counts;
    let c = st.counts();
    if c.samples != c0.samples + 1 {
        return Err(format!(
            "sample lost: counter {} -> {} after one push",
            c0.samples, c.samples
        ));
    }
    let moved = (
        c.non_finite - c0.non_finite,
        c.out_of_range - c0.out_of_range,
        c.spikes - c0.spikes,
    );
    let want = match st.last_rejection() {
        None => (0, 0, 0),
        Some(Rejection::NonFinite) => (1, 0, 0),
        Some(Rejection::OutOfRange) => (0, 1, 0),
        Some(Rejection::Spike) => (0, 0, 1),
    };
    if moved != want {
        return Err(format!(
            "rejection counters moved by {moved:?} for rejection {:?}",
            st.last_rejection()
        ));
    }
    let non_finite = !(current.is_finite() && voltage.is_finite());
    let out_of_range =
        current.abs() > s.current_limit || voltage < s.voltage_min || voltage > s.voltage_max;
    let why = st.last_rejection();
    if non_finite && why != Some(Rejection::NonFinite) {
        return Err(format!(
            "sample ({current:?}, {voltage:?}) not rejected as non-finite: {why:?}"
        ));
    }
    if !non_finite && out_of_range && why != Some(Rejection::OutOfRange) {
        return Err(format!(
            "sample ({current:?}, {voltage:?}) not rejected as out of range: {why:?}"
        ));
    }
    if !non_finite
        && !out_of_range
        && matches!(why, Some(Rejection::NonFinite | Rejection::OutOfRange))
    {
        return Err(format!(
            "plausible sample ({current:?}, {voltage:?}) rejected as {why:?}"
        ));
    }
    // The window.
    let held: Vec<(T, T)> = window.newest_first().collect();
    if held.len() != window.len() || window.len() > N {
        return Err(format!(
            "window of len {} holds {} samples (capacity {N})",
            window.len(),
            held.len()
        ));
    }
    if (window.len() as u64) > window.pushed() {
        return Err(format!(
            "window holds {} samples but {} were pushed since its restart",
            window.len(),
            window.pushed()
        ));
    }
    if let Some((i, u)) = held.iter().find(|(i, u)| !(i.is_finite() && u.is_finite())) {
        return Err(format!("window holds a non-finite sample ({i:?}, {u:?})"));
    }
    // The estimate.
    let est = st.estimate();
    if st.status() == Status::Tracking && est.is_none() {
        return Err("status Tracking without an estimate".into());
    }
    if let Some(p) = est {
        let pos = |x: T| x.is_finite() && x > T::zero();
        let physical = pos(p.r_i)
            && pos(p.r_ct)
            && pos(p.q)
            && pos(p.alpha)
            && p.alpha <= T::one()
            && p.u_oc.is_finite()
            && p.bv_a.is_finite()
            && p.bv_a >= T::zero()
            && pos(p.bv_i0);
        if !physical {
            return Err(format!("published estimate not finite/physical: {p:?}"));
        }
    }
    let now = raw(st);
    if !same(&now, &before.raw) {
        // With several iterations per sample the status is the last
        // one's: an estimate published by an earlier one may be followed
        // by an implausible one.
        if s.iterations_per_sample <= 1 && st.status() != Status::Tracking {
            return Err(format!(
                "estimate changed with status {:?}: {:?} -> {now:?}",
                st.status(),
                before.raw
            ));
        }
        let p = now.expect("a changed estimate is Some (Tracking)");
        let b = &s.battery;
        let tol = T::lit(1e-3);
        let ocv_ok = match s.ocv {
            Some(_) => p.u_oc.abs() <= s.max_ocv_offset,
            None => p.u_oc >= s.voltage_min && p.u_oc <= s.voltage_max,
        };
        let bound = p.alpha <= b.alpha_min + tol
            || (b.alpha_max < T::one() && p.alpha >= b.alpha_max - tol);
        if published_with_s && (!ocv_ok || bound) {
            return Err(format!(
                "implausible estimate published (ocv ok {ocv_ok}, alpha at bound {bound}): {p:?}"
            ));
        }
    }
    if st.rmse().is_nan() || st.rmse() < T::zero() {
        return Err(format!("rmse {:?}", st.rmse()));
    }
    // The published state of charge: finite, with a spread that is a
    // spread (at most 1: knowing nothing), under settings its check
    // passes (settings changed under the estimator may not).
    if let Some(e) = st.soc_estimate(s).filter(|_| soc_documented(&s.soc)) {
        let spread = |x: T| x.is_finite() && x >= T::zero();
        if !(e.soc.is_finite()
            && spread(e.sigma)
            && e.sigma <= T::one()
            && spread(e.capacity_sigma_ah)
            && e.current_bias_a.is_finite()
            && e.capacity_ah.is_finite())
        {
            return Err(format!(
                "published SOC estimate not finite or its spread not one: {e:?}"
            ));
        }
    }
    Ok(())
}

/// The report of a push agrees with the state after it.
pub fn check_report<T: Real, const N: usize>(
    s: &Settings<T>,
    r: &SampleReport<T>,
    st: &CellState<T, N>,
) -> Outcome {
    if r.status != st.status()
        || r.rejected != st.last_rejection()
        || Real::to_f64(r.rmse).to_bits() != Real::to_f64(st.rmse()).to_bits()
    {
        return Err(format!(
            "report {r:?} disagrees with the state ({:?}, {:?}, {:?})",
            st.status(),
            st.last_rejection(),
            st.rmse()
        ));
    }
    if r.iterations > s.iterations_per_sample {
        return Err(format!(
            "{} iterations for {} per sample",
            r.iterations, s.iterations_per_sample
        ));
    }
    Ok(())
}

/// Runs one case.
pub fn case(rng: &mut Rng) -> Outcome {
    match rng.random_range(0..8) {
        0..=2 => run::<f32, 64, 16>(rng),
        3..=5 => run::<f64, 64, 16>(rng),
        6 => run::<f32, 128, 64>(rng),
        _ => run::<f64, 128, 64>(rng),
    }
}

/// A sample stream: currents and voltages of a simulated cell, perturbed
/// unless `clean`.
pub fn stream(rng: &mut Rng, len: usize, clean: bool) -> (Vec<f64>, Vec<f64>) {
    let mut i = currents(rng, len, clean);
    let truth = parameters(rng);
    let mut v = voltages(rng, &truth, &i, clean);
    if !clean {
        let r = rate(rng);
        perturb(rng, r, &mut i, 100.0);
        let r = rate(rng);
        perturb(rng, r, &mut v, 0.5);
    }
    (i, v)
}

/// A record length for a window of `n`: mostly long enough for the
/// estimator to track (a `clean` case: 3 to 8 windows).
pub fn length(rng: &mut Rng, n: usize, clean: bool) -> usize {
    match rng.random_range(0..10) {
        _ if clean => rng.random_range(3 * n..8 * n),
        0 => rng.random_range(0..n),
        1..=3 => rng.random_range(n..2 * n),
        _ => rng.random_range(2 * n..6 * n),
    }
}

fn run<T: Real, const N: usize, const MEM: usize>(rng: &mut Rng) -> Outcome {
    // A third of the cases are clean: valid settings and a plausible
    // stream, so that the estimator tracks and publishes.
    let clean = rng.random_bool(0.35);
    let (s, expect) = settings::<T, MEM>(rng, clean);
    let made = CellEstimator::<T, N, MEM>::new(&s);
    check_new(
        "CellEstimator::new",
        made.as_ref().map(|_| ()).map_err(|e| *e),
        expect,
    )?;
    let Ok(mut cell) = made else {
        note("cell: constructor error");
        return Ok(());
    };
    note("cell: constructor Ok");
    if N == 128 {
        note("cell: window 128, memory 64 (tail possible)");
    }
    let len = length(rng, N, clean);
    let (i, v) = stream(rng, len, clean);
    let soc_rate = pick(rng, &[0.0, 0.0, 0.01]);
    if rng.random_bool(0.1) {
        cell.set_state_of_charge(lit(nasty_or!(rng, 0.3, rng.random_range(0.0..1.0))));
    }
    // Now and then the settings change under the estimator (to settings
    // the constructor accepts, or to arbitrary ones).
    let swap_at = rng
        .random_bool(0.05)
        .then(|| rng.random_range(0..len.max(1)));
    let clone_at = rng
        .random_bool(0.05)
        .then(|| rng.random_range(0..len.max(1)));
    let mut push_s = s;
    let mut swapped = false;
    for k in 0..len {
        if swap_at == Some(k) {
            let (other, e) = settings::<T, MEM>(rng, false);
            // Known issue (tests/tests/fuzz.rs,
            // `push_with_settings_of_another_memory_does_not_panic`): a
            // memory of 0 or `usize::MAX` passed to `push` overflows.
            let known = super::avoid_known_issues() && !(1..=MEM).contains(&other.battery.memory);
            if !known && (e == Expect::Ok || rng.random_bool(0.2)) {
                push_s = other;
                swapped = true;
            }
        }
        let (ik, vk) = (lit::<T>(i[k]), lit::<T>(v[k]));
        let twin = (clone_at == Some(k)).then(|| cell.clone());
        let before = Before::of(cell.cell_state());
        let r = cell.push(&push_s, ik, vk);
        let tag = |e: String| {
            format!(
                "push {k} of {len} ({}{}): {e}\n  sample ({:?}, {:?})\n  settings {:?}",
                std::any::type_name::<T>(),
                if swapped { ", settings changed" } else { "" },
                i[k],
                v[k],
                push_s
            )
        };
        check_report(&push_s, &r, cell.cell_state()).map_err(tag)?;
        check_cell(
            &push_s,
            !swapped,
            &before,
            cell.cell_state(),
            cell.window(),
            ik,
            vk,
        )
        .map_err(tag)?;
        if let Some(mut twin) = twin {
            let r2 = twin.push(&push_s, ik, vk);
            let same_report = format!("{r:?}") == format!("{r2:?}");
            if !same_report || !same(&raw(twin.cell_state()), &raw(cell.cell_state())) {
                return Err(tag(format!("a clone differs: {r:?} vs {r2:?}")));
            }
        }
        if rng.random_bool(0.02) {
            let _ = cell.predict(&push_s, lit(nasty_or!(rng, 0.3, i[k])));
        }
        if rng.random_bool(soc_rate) {
            cell.set_state_of_charge(lit(nasty_or!(rng, 0.3, rng.random_range(0.0..1.0))));
        }
    }
    let _ = cell.refinement_work();
    let _ = cell.state_of_charge();
    let c = cell.counts();
    for (yes, what) in [
        (cell.estimate().is_some(), "cell: an estimate published"),
        (cell.is_refining(), "cell: output-error refinement reached"),
        (c.non_finite > 0, "cell: non-finite samples rejected"),
        (c.out_of_range > 0, "cell: out-of-range samples rejected"),
        (c.spikes > 0, "cell: spikes rejected"),
        (swapped, "cell: settings changed under the estimator"),
        (s.ocv.is_some(), "cell: with an OCV curve"),
        (s.battery.prior.is_some(), "cell: with a prior"),
    ] {
        if yes {
            note(what);
        }
    }
    Ok(())
}
