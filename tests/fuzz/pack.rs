//! The `pack` target: [`PackEstimator`] (window 64, memory 16, up to 4
//! cells, `f32` and `f64`) with the `cell` target's arbitrary settings,
//! an arbitrary schedule and flag ratio, one current and a voltage record
//! per cell (each cell its own parameters and faults: NaN in some cells,
//! steps, spikes), now and then a push with the wrong number of voltages
//! or a state of charge set for one cell.
//!
//! Checked: construction as documented (a zero schedule, a flag ratio that
//! is not positive and finite, 0 or more than 4 cells are errors); at every
//! push every cell's invariants ([`super::cell::check_cell`]); the period's
//! report counts the rejected and updated cells and stays within the
//! schedule; a push with the wrong number of voltages is
//! [`Error::CellCount`] and changes no counter; the health's medians are
//! finite and positive over the cells with an estimate; `refresh_periods`
//! is `⌈cells / updates⌉`; cells past the pack are `None`.

use super::cell::{
    check_cell, check_new, length, parameters, perturb, settings, voltages, Before, Expect,
};
use super::gen::{nasty, nasty_or, pick, rate};
use super::{note, Outcome, Rng};
use estimator_core::battery::pack::{PackEstimator, PackSettings};
use estimator_core::{Error, Real};
use rand::Rng as _;

/// Cell capacity of the packs.
const CELLS: usize = 4;

/// Runs one case.
pub fn case(rng: &mut Rng) -> Outcome {
    if rng.random_bool(0.5) {
        run::<f32, 64, 16>(rng)
    } else {
        run::<f64, 64, 16>(rng)
    }
}

fn run<T: Real, const N: usize, const MEM: usize>(rng: &mut Rng) -> Outcome {
    let clean = rng.random_bool(0.35);
    let (cell_s, e) = settings::<T, MEM>(rng, clean);
    let mut s: PackSettings<T, { super::cell::P }> = PackSettings::new(cell_s);
    s.updates_per_period = pick(rng, &[u16::MAX, 1, 2, 3, 4, 0, 5]);
    s.flag_ratio = T::lit(nasty_or!(rng, 0.05, pick(rng, &[0.3, 0.1, 2.0])));
    let cells = pick(rng, &[1, 2, 3, 4, 4, 4, 0, 5]);
    let schedule_ok =
        s.updates_per_period > 0 && s.flag_ratio.is_finite() && s.flag_ratio > T::zero();
    let expect = match e {
        _ if !schedule_ok || cells == 0 || cells > CELLS => Expect::Err,
        e => e,
    };
    let made = PackEstimator::<T, N, MEM, CELLS>::new(&s, cells);
    check_new(
        "PackEstimator::new",
        made.as_ref().map(|_| ()).map_err(|e| *e),
        expect,
    )?;
    if let Err(err) = &made {
        if (cells == 0 || cells > CELLS)
            && schedule_ok
            && *err
                != (Error::CellCount {
                    given: cells,
                    expected: CELLS,
                })
        {
            return Err(format!("{cells} cells: {err:?}"));
        }
    }
    let Ok(mut pack) = made else {
        note("pack: constructor error");
        return Ok(());
    };
    note("pack: constructor Ok");
    if pack.cells() != cells {
        return Err(format!("{} cells for {cells}", pack.cells()));
    }
    let updates = usize::from(s.updates_per_period).min(cells);
    if pack.refresh_periods(&s) != cells.div_ceil(updates) {
        return Err(format!(
            "refresh_periods {} for {cells} cells, {updates} updates",
            pack.refresh_periods(&s)
        ));
    }
    let len = length(rng, N, clean);
    let mut current = super::cell::currents(rng, len, clean);
    if !clean {
        let r = rate(rng);
        perturb(rng, r, &mut current, 100.0);
    }
    let base = parameters(rng);
    let volts: Vec<Vec<f64>> = (0..cells)
        .map(|_| {
            // Cells of one pack: the same chemistry, some spread, some
            // with faults of their own.
            let p = if rng.random_bool(0.7) {
                base
            } else {
                parameters(rng)
            };
            let mut v = voltages(rng, &p, &current, clean);
            let r = if clean || rng.random_bool(0.5) {
                0.0
            } else {
                rate(rng)
            };
            perturb(rng, r, &mut v, 0.5);
            v
        })
        .collect();
    let swap_at = rng
        .random_bool(0.03)
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
                push_s.cell = other;
                swapped = true;
            }
        }
        let tag = |e: String| {
            format!(
                "period {k} of {len} ({}, {cells} cells{}): {e}\n  current {:?}, voltages {:?}\n  settings {:?}",
                std::any::type_name::<T>(),
                if swapped { ", settings changed" } else { "" },
                current[k],
                volts.iter().map(|c| c[k]).collect::<Vec<_>>(),
                push_s
            )
        };
        let i = T::lit(current[k]);
        let v: Vec<T> = volts.iter().map(|c| T::lit(c[k])).collect();
        if rng.random_bool(0.01) {
            // The wrong number of voltages: an error, nothing pushed.
            let n = pick(rng, &[0, cells - 1, cells + 1, 2 * cells + 3]);
            let wrong: Vec<T> = (0..n).map(|_| T::lit(nasty(rng))).collect();
            let before: Vec<_> = (0..cells)
                .map(|c| pack.cell(c).map(|st| st.counts()))
                .collect();
            note("pack: a push with the wrong number of voltages");
            match pack.push(&push_s, i, &wrong) {
                Err(Error::CellCount { given, expected }) if given == n && expected == cells => {}
                other => return Err(tag(format!("{n} voltages for {cells} cells: {other:?}"))),
            }
            let after: Vec<_> = (0..cells)
                .map(|c| pack.cell(c).map(|st| st.counts()))
                .collect();
            if before != after {
                return Err(tag("a refused push changed the counters".into()));
            }
        }
        let before: Vec<Before<T>> = (0..cells)
            .map(|c| Before::of(pack.cell(c).expect("a cell of the pack")))
            .collect();
        let report = pack
            .push(&push_s, i, &v)
            .map_err(|e| tag(format!("push of {cells} voltages: {e:?}")))?;
        let mut rejected = 0;
        for c in 0..cells {
            let st = pack.cell(c).expect("a cell of the pack");
            check_cell(
                &push_s.cell,
                !swapped,
                &before[c],
                st,
                pack.window(c),
                i,
                v[c],
            )
            .map_err(|e| tag(format!("cell {c}: {e}")))?;
            rejected += u16::from(st.last_rejection().is_some());
        }
        let updates = usize::from(push_s.updates_per_period.max(1)).min(cells);
        if report.rejected != rejected
            || usize::from(report.updated) > updates
            || report.iterations
                > u32::from(push_s.cell.iterations_per_sample) * u32::from(report.updated)
        {
            return Err(tag(format!(
                "report {report:?} ({rejected} cells rejected, {updates} updates scheduled)"
            )));
        }
        if rng.random_bool(0.05) {
            check_health(&pack, &push_s).map_err(tag)?;
        }
        if rng.random_bool(0.003) {
            let c = rng.random_range(0..cells);
            let z = T::lit(nasty_or!(rng, 0.3, rng.random_range(0.0..1.0)));
            pack.cell_mut(c).expect("a cell").set_state_of_charge(z);
        }
    }
    for c in 0..cells {
        let st = pack.cell(c).expect("a cell of the pack");
        if st.estimate().is_some() {
            note("pack: a cell with an estimate");
        }
        if st.counts().rejected() > 0 {
            note("pack: a cell with rejected samples");
        }
    }
    if swapped {
        note("pack: settings changed under the estimator");
    }
    check_health(&pack, &push_s)
}

/// The pack's health against its cells' estimates.
fn check_health<T: Real, const N: usize, const MEM: usize>(
    pack: &PackEstimator<T, N, MEM, CELLS>,
    s: &PackSettings<T, { super::cell::P }>,
) -> Outcome {
    let cells = pack.cells();
    let estimated = (0..cells)
        .filter(|&c| pack.cell(c).and_then(|st| st.estimate()).is_some())
        .count();
    match pack.health() {
        None if estimated == 0 => {}
        Some(h) if usize::from(h.estimated) == estimated => {
            let pos = |x: T| x.is_finite() && x > T::zero();
            if !(pos(h.median_r_i) && pos(h.median_r_ct)) {
                return Err(format!("health medians not finite/positive: {h:?}"));
            }
            for c in 0..CELLS + 2 {
                let flagged = pack.is_flagged(s, &h, c);
                if flagged {
                    note("pack: a flagged cell");
                }
                if c >= cells && flagged {
                    return Err(format!("cell {c} past the pack flagged"));
                }
            }
        }
        other => return Err(format!("health {other:?} with {estimated} cells estimated")),
    }
    if pack.cell(cells).is_some() || pack.cell(usize::MAX).is_some() {
        return Err("a cell past the pack".into());
    }
    let _ = pack.window(usize::MAX).len();
    Ok(())
}
