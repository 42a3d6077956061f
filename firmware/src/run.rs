//! The application: one sample per timer tick into the estimator task,
//! logs at the configured rate, a final report and a self-check.

use crate::board::{self, BoardApi};
use estimator_core::battery::online::{CellState, CurrentHistory, WorkingArea};
use estimator_core::battery::power::{PolarizationTail, PulseCheck};
use firmware::config;
use firmware::sampler::PackSampler;
use firmware::static_cell::TakeOnce;
use firmware::ConfiguredTask;

/// Cost of the sample updates (timer clocks), for the performance docs.
#[derive(Default)]
struct Cost {
    /// Updates that ran at least one iteration.
    updates: u32,
    /// Iterations in those updates.
    iterations: u32,
    /// Clocks spent in those updates.
    clocks: u64,
    /// The longest update.
    max: u64,
    /// Of the updates, those that ran the output-error refinement (cell 1).
    refined: u32,
    /// Cell updates (a pack period updates several cells).
    cell_updates: u32,
}

/// The task, built at compile time ([`ConfiguredTask::EMPTY`]: no cells)
/// in its static; `make_task` initialises it there.
static TASK: TakeOnce<ConfiguredTask> = TakeOnce::new(ConfiguredTask::EMPTY);

/// Takes the task from its static and initialises it in place (no copy of
/// it on the stack, whatever the cells). Not inlined, so that the
/// initialisation's frames are popped before the sample loop.
#[inline(never)]
fn make_task(s: &firmware::task::TaskSettings) -> Option<&'static mut ConfiguredTask> {
    let Some(task) = TASK.take() else {
        defmt::error!("the task was taken twice");
        return None;
    };
    match task.init(s) {
        Ok(()) => Some(task),
        Err(e) => {
            defmt::error!("settings rejected: {}", e);
            None
        }
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut b = board::init();
    match config::INJECT {
        "panic" => panic!("injected panic (FRACBMS_INJECT)"),
        // A read from an address outside every memory region: a bus fault
        // escalated to HardFault.
        "hardfault" => {
            let bad = 0xF000_0000 as *const u32;
            // SAFETY: none; the read is meant to fault (FRACBMS_INJECT).
            let _ = unsafe { core::ptr::read_volatile(bad) };
        }
        _ => {}
    }
    let s = firmware::configured_settings();
    let Some(task) = make_task(&s) else {
        b.finish(false)
    };
    // The start-up depth: the board's start and the task's initialisation
    // in its static. Paint again for the depth of the sample loop.
    let init_stack = b.stack_high_water();
    crate::board::stack::paint();
    defmt::info!(
        "fracbms: {=usize} cell(s), window {=usize}, memory {=usize}, method {}, algorithm {=str}, {=u16} iteration(s)/sample, h = {=f32} s",
        config::CELLS,
        config::WINDOW,
        config::MEMORY,
        config::METHOD,
        config::ALGORITHM,
        config::ITERATIONS_PER_SAMPLE,
        config::SAMPLE_PERIOD_S
    );
    if !config::OCV_SOC.is_empty() {
        defmt::println!(
            "OCV table points={=usize} flash_bytes={=usize} capacity_ah={=f32}",
            config::OCV_POINTS,
            core::mem::size_of_val(&config::OCV_SOC) + core::mem::size_of_val(&config::OCV_V),
            config::CAPACITY_AH
        );
    }
    // The snapshot: restored at boot, saved by the write policy.
    let mut persist = crate::persist::Persistence::boot(&mut b, &s, task);
    let resumed = b.resumed_at();
    let (mut period, mut overruns) = (resumed, 0u32);
    let mut cost = Cost::default();
    let mut volts = [f32::NAN; config::CELLS];
    loop {
        if resumed == 0 && config::RESET_AT == Some(period as usize) {
            // A reset under test (FRACBMS_RESET_AT): saved first, as before
            // a known shutdown; the replay resumes at this period.
            persist.save(&b, &s, task);
            defmt::println!("RESET period={=u32}", period);
            b.reset(period);
        }
        overruns += u32::from(b.wait_for_tick() > 0);
        let x = b.sampler().sample_pack(&mut volts);
        let current = x.as_ref().map_or(f32::NAN, |r| r.current_a);
        let t0 = b.clocks();
        let Some(r) = task.on_sample(&s, x, &volts) else {
            break;
        };
        let dt = b.clocks() - t0;
        if r.core.iterations > 0 {
            cost.updates += 1;
            cost.iterations += r.core.iterations;
            cost.cell_updates += u32::from(r.core.updated);
            cost.clocks += dt;
            cost.max = cost.max.max(dt);
            if config::BENCH {
                // Each update's cost, for the median (`cargo xtask
                // bench-target` gathers these lines).
                defmt::println!("UPDATE clocks={=u64}", dt);
            }
            cost.refined += u32::from(task.cell(0).is_some_and(|c| c.is_refining()));
        }
        if let Some(f) = r.fault {
            defmt::warn!("period {=u32}: {}", period, f);
        }
        if r.core.rejected > 0 {
            for k in 0..config::CELLS {
                if let Some(why) = task.cell(k).and_then(|c| c.last_rejection()) {
                    defmt::warn!(
                        "period {=u32}: cell {=usize} rejected ({})",
                        period,
                        k + 1,
                        why
                    );
                }
            }
        }
        if period % config::LOG_EVERY == 0 {
            let c = task.cell(0);
            let status = c.map(|c| c.status());
            match task.estimate() {
                Some(e) => defmt::info!(
                    "period {=u32} {}: R_i {=f32} R_ct {=f32} Q {=f32} alpha {=f32} U_oc {=f32} rmse {=f32}",
                    period, status, e.r_i, e.r_ct, e.q, e.alpha, e.u_oc,
                    c.map_or(f32::INFINITY, |c| c.rmse())
                ),
                None => defmt::info!("period {=u32} {}", period, status),
            }
        }
        persist.after_period(&b, &s, task, current);
        period += 1;
    }
    persist.report();
    let counts = task.counts();
    let f = task.faults();
    let (mut non_finite, mut out_of_range, mut spikes) = (0, 0, 0);
    for c in (0..config::CELLS).filter_map(|k| task.cell(k)) {
        non_finite += c.counts().non_finite;
        out_of_range += c.counts().out_of_range;
        spikes += c.counts().spikes;
    }
    defmt::println!(
        "FAULTS adc={=u32} saturated={=u32} dropped={=u32} stuck={=u32} temperature={=u32} non_finite={=u32} out_of_range={=u32} spikes={=u32} overruns={=u32}",
        f.adc, f.saturated, f.dropped, f.stuck, f.temperature,
        non_finite, out_of_range, spikes, overruns
    );
    defmt::println!(
        "COST updates={=u32} iterations={=u32} cell_updates={=u32} cells={=usize} clocks={=u64} max_clocks={=u64} clock_hz={=u32} window={=usize} memory={=usize}",
        cost.updates,
        cost.iterations,
        cost.cell_updates,
        config::CELLS,
        cost.clocks,
        cost.max,
        <board::Board as BoardApi>::CLOCK_HZ,
        config::WINDOW,
        config::MEMORY
    );
    let work = task
        .cell(0)
        .map(|c| c.refinement_work())
        .unwrap_or_default();
    defmt::println!(
        "WORK updates={=u32} iterations={=u32} simulations={=u32} trials={=u32} linearizations={=u32}",
        cost.refined,
        work.iterations,
        work.simulations,
        work.trials,
        work.linearizations
    );
    defmt::println!(
        "STACK high_water_bytes={=u32} init_bytes={=u32} task_bytes={=usize}",
        b.stack_high_water(),
        init_stack,
        core::mem::size_of::<ConfiguredTask>()
    );
    defmt::println!(
        "MEM bytes_per_cell={=usize} shared_bytes={=usize}",
        // A cell's state, and the polarization tail and the check against
        // the next pulse that the pack carries for it.
        core::mem::size_of::<CellState<f32, { config::WINDOW }>>()
            + core::mem::size_of::<PolarizationTail<f32, { config::MEMORY }>>()
            + core::mem::size_of::<PulseCheck<f32>>(),
        core::mem::size_of::<WorkingArea<f32, { config::WINDOW }, { config::MEMORY }>>()
            + core::mem::size_of::<CurrentHistory<f32, { config::WINDOW }>>()
    );
    // After a reset the counters start again at the period resumed.
    let expected = config::REPLAY_LEN.saturating_sub(resumed as usize);
    let all = counts.samples == expected as u64;
    if !all {
        defmt::error!(
            "check failed: {=u64} of {=usize} sample periods pushed",
            counts.samples,
            expected
        );
    }
    let ok = if config::CELLS == 1 {
        one_cell_result(&s, task, counts.samples, all)
    } else {
        pack_result(&s, task, counts.samples, all)
    };
    b.finish(ok)
}

/// The final report of a one-cell image (the flat JSON of `cargo xtask
/// qemu`); true when the run passed its self-check.
fn one_cell_result(
    s: &firmware::task::TaskSettings,
    task: &ConfiguredTask,
    samples: u64,
    all: bool,
) -> bool {
    match task.estimate() {
        Some(e) => {
            defmt::println!(
                "RESULT r_i={=f32} r_ct={=f32} q={=f32} alpha={=f32} u_oc={=f32} samples={=u64} rejected={=u32}",
                e.r_i, e.r_ct, e.q, e.alpha, e.u_oc, samples, task.rejected()
            );
            if let Some(c) = task.cell(0) {
                published_line(1, c);
                soc_line(s, 1, c);
            }
            power_line(s, task, Some(0));
            if e.is_butler_volmer() {
                defmt::println!("BV bv_a_v={=f32} bv_i0_a={=f32}", e.bv_a, e.bv_i0);
            }
            if let Some(p) = task.map_prior() {
                defmt::println!(
                    "MAP levels={=usize} prior_r_i={=f32} prior_r_ct={=f32}",
                    config::MAP.len(),
                    p.center.r_i,
                    p.center.r_ct
                );
            }
            if !e.is_physical() {
                defmt::error!("check failed: the final estimate is not physical");
            }
            all && (e.is_physical() || config::BENCH)
        }
        None if config::BENCH => {
            defmt::warn!("no estimate (a cost measurement: not a failure)");
            all
        }
        None => {
            defmt::error!("check failed: no estimate after {=u64} samples", samples);
            false
        }
    }
}

/// What cell `cell` (1-based) publishes: each parameter's value (NaN when
/// none) and status, and the last step resistance (NaN before one), as
/// `host-sim online battery`'s `r_i…alpha`, `*_status` and
/// `step_resistance_ohm` columns.
fn published_line<const N: usize>(cell: usize, c: &CellState<f32, N>) {
    let p = c.published();
    let v = |x: Option<f32>| x.unwrap_or(f32::NAN);
    defmt::println!(
        "PUBLISHED cell={=usize} r_i={=f32} r_i_status={=str} r_ct={=f32} r_ct_status={=str} q={=f32} q_status={=str} alpha={=f32} alpha_status={=str} step_resistance_ohm={=f32}",
        cell,
        v(p.r_i.value),
        p.r_i.status.as_str(),
        v(p.r_ct.value),
        p.r_ct.status.as_str(),
        v(p.q.value),
        p.q.status.as_str(),
        v(p.alpha.value),
        p.alpha.status.as_str(),
        v(c.step_resistance().map(|st| st.ohm))
    );
}

/// A cell's state of charge (with an OCV table, once known): `soc` the
/// observer's (the published SOC, as `host-sim online battery`'s `soc`),
/// `soc_coulomb` the count, the observer's bias, capacity, spread and last
/// weight, and the OCV offset of the estimate (NaN before one).
fn soc_line<const N: usize>(s: &firmware::task::TaskSettings, cell: usize, c: &CellState<f32, N>) {
    let (Some(z), Some(e)) = (c.state_of_charge(), c.soc_estimate(&s.pack.cell)) else {
        return;
    };
    defmt::println!(
        "SOC cell={=usize} soc={=f32} soc_coulomb={=f32} current_bias_a={=f32} capacity_ah={=f32} capacity_sigma_ah={=f32} capacity_identified={=bool} soc_sigma={=f32} soc_ocv_weight={=f32} ocv_offset_v={=f32}",
        cell,
        e.soc,
        z,
        e.current_bias_a,
        e.capacity_ah,
        e.capacity_sigma_ah,
        e.capacity_identified,
        e.sigma,
        e.ocv_weight,
        c.ocv_offset().unwrap_or(f32::NAN)
    );
}

/// Cell `k`'s (0-based) state of power, or the string's (`None`), as
/// `host-sim online battery`'s `sop_discharge_a_{H}s`, `sop_charge_a_{H}s`
/// and `pulse_v_{H}s` at the horizons of
/// [`firmware::task::POWER_HORIZONS_S`] (NaN, `published=false` where the
/// model is not published) and `sop_basis` (where its parameters came
/// from: `window`, `map`, `held`, `stale`; empty without one) and
/// `sop_uncertainty_v` (the 30 s pulse voltage's standard deviation) and
/// `pulse_ratio_{H}s` (what the pulse voltage was corrected by, NaN: not
/// corrected); nothing without an OCV table.
fn power_line(s: &firmware::task::TaskSettings, task: &ConfiguredTask, k: Option<usize>) {
    if s.power.is_none() {
        return;
    }
    let r = match k {
        Some(k) => task.cell_power(s, k),
        None => task.power(),
    };
    let h = |j: usize| {
        r.and_then(|r| r.horizons().get(j).copied())
            .map_or((f32::NAN, f32::NAN, f32::NAN), |h| {
                (
                    h.sop.discharge_a,
                    h.sop.charge_a,
                    h.pulse_v.unwrap_or(f32::NAN),
                )
            })
    };
    let ((d10, c10, v10), (d30, c30, v30)) = (h(0), h(1));
    let basis = r.map_or("", |r| r.basis().as_str());
    let sigma = r
        .and_then(|r| r.horizons().get(1).and_then(|h| h.uncertainty_v))
        .unwrap_or(f32::NAN);
    let ratio = |j: usize| {
        r.and_then(|r| r.horizons().get(j).and_then(|h| h.pulse_ratio))
            .unwrap_or(f32::NAN)
    };
    defmt::println!(
        "SOP cell={=usize} published={=bool} sop_discharge_a_10s={=f32} sop_charge_a_10s={=f32} pulse_v_10s={=f32} sop_discharge_a_30s={=f32} sop_charge_a_30s={=f32} pulse_v_30s={=f32} sop_basis={=str} sop_uncertainty_v={=f32} pulse_ratio_10s={=f32} pulse_ratio_30s={=f32}",
        k.map_or(0, |k| k + 1),
        r.is_some(),
        d10,
        c10,
        v10,
        d30,
        c30,
        v30,
        basis,
        sigma,
        ratio(0),
        ratio(1)
    );
}

/// The final report of a pack image: one `CELL` line per cell (its
/// estimate, rejected samples, flag) and a `PACK` line; true when every
/// cell has a physical estimate (or this is a cost measurement).
fn pack_result(
    s: &firmware::task::TaskSettings,
    task: &ConfiguredTask,
    samples: u64,
    all: bool,
) -> bool {
    let health = task.health();
    let mut ok = all;
    for k in 0..config::CELLS {
        let rejected = task.cell(k).map_or(0, |c| c.counts().rejected());
        let flagged = health.is_some_and(|h| task.is_flagged(s, &h, k));
        if let Some(c) = task.cell(k) {
            published_line(k + 1, c);
            soc_line(s, k + 1, c);
        }
        power_line(s, task, Some(k));
        match task.estimate_of(k) {
            Some(e) => {
                defmt::println!(
                    "CELL cell={=usize} r_i={=f32} r_ct={=f32} q={=f32} alpha={=f32} u_oc={=f32} rejected={=u32} flagged={=bool}",
                    k + 1, e.r_i, e.r_ct, e.q, e.alpha, e.u_oc, rejected, flagged
                );
                if !e.is_physical() {
                    defmt::error!(
                        "check failed: cell {=usize}'s estimate is not physical",
                        k + 1
                    );
                    ok &= config::BENCH;
                }
            }
            None => {
                defmt::println!(
                    "CELL cell={=usize} rejected={=u32} flagged=false",
                    k + 1,
                    rejected
                );
                if !config::BENCH {
                    defmt::error!("check failed: no estimate of cell {=usize}", k + 1);
                    ok = false;
                }
            }
        }
    }
    if let Some(h) = health {
        defmt::println!(
            "PACK cells={=usize} samples={=u64} rejected={=u32} median_r_i={=f32} median_r_ct={=f32}",
            config::CELLS, samples, task.rejected(), h.median_r_i, h.median_r_ct
        );
    } else {
        defmt::println!(
            "PACK cells={=usize} samples={=u64} rejected={=u32}",
            config::CELLS,
            samples,
            task.rejected()
        );
    }
    // The string's: the weakest cell's (cell=0).
    power_line(s, task, None);
    ok
}
