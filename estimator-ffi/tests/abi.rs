//! The C ABI calls the core: a cell through `fracbms_cell_*` gives the
//! core's `CellEstimator` estimates bit for bit, a pack the core's
//! `PackEstimator`'s; every error is a code; the whole-record fit is the
//! CLI's.

use std::mem::MaybeUninit;

use estimator_core::battery::online::{CellEstimator, OnlineSettings};
use estimator_core::battery::pack::{PackEstimator, PackSettings};
use estimator_core::battery::power::{PowerLimits, PowerReport, PowerSettings};
use estimator_core::battery::{CellParameters, Start};
use fracbms::FracbmsCode::*;
use fracbms::*;

mod common;
use common::{core_settings, defaults, memory, nmc_table, record, same_published};

/// The pulse current the cells correct their pulse voltage at
/// (`FracbmsSettings::pulse_current`): a discharge pulse of the record.
const WATCHED_A: f32 = -3.0;

/// The same power, bit for bit (NaN for NaN): the derived `==` holds no
/// NaN equal, and `pulse_ratio` is NaN until a watched pulse is checked.
fn same_bits(a: &FracbmsPower, b: &FracbmsPower) -> bool {
    format!("{a:?}") == format!("{b:?}")
}

/// How many horizons of `p` carry a corrected pulse voltage.
fn corrected(p: &FracbmsPower) -> usize {
    let n = usize::try_from(p.horizon_count).unwrap();
    p.horizons[..n]
        .iter()
        .filter(|h| h.pulse_ratio.is_finite())
        .count()
}

/// A state-of-power request: limits 3.0–4.2 V, 50 A, horizons 2, 10 and
/// 30 s, a 3 A discharge pulse (the record's own: the cells watch it,
/// [`WATCHED_A`]).
fn power_request() -> FracbmsPowerRequest {
    let mut horizons_s = [0.0; FRACBMS_HORIZONS_MAX];
    horizons_s[..3].copy_from_slice(&[2.0, 10.0, 30.0]);
    FracbmsPowerRequest {
        voltage_min: 3.0,
        voltage_max: 4.2,
        current_limit: 50.0,
        horizons_s,
        horizon_count: 3,
        pulse_current: WATCHED_A,
        carry_s: f32::NAN,
        confidence: f32::NAN,
    }
}

/// The core's answer to [`power_request`], as the ABI writes it.
fn core_power(r: Option<PowerReport<f32>>) -> FracbmsPower {
    let mut out = FracbmsPower::default();
    if let Some(r) = r {
        out.published = true;
        out.horizon_count = r.horizons().len() as u32;
        out.basis = u32::from(r.basis().code());
        for (o, (h, hz)) in out
            .horizons
            .iter_mut()
            .zip(r.horizons().iter().zip([2.0, 10.0, 30.0]))
        {
            *o = FracbmsHorizonPower {
                horizon_s: hz,
                discharge_a: h.sop.discharge_a,
                charge_a: h.sop.charge_a,
                pulse_v: h.pulse_v.unwrap(),
                uncertainty_v: h.uncertainty_v.unwrap(),
                pulse_ratio: h.pulse_ratio.unwrap_or(f32::NAN),
            };
        }
        // The longest horizon asked (30 s, the last).
        out.uncertainty_v = out.horizons[r.horizons().len() - 1].uncertainty_v;
    }
    out
}

/// A cell's state of power through C equals its core reference's, bit for
/// bit; whether it is published.
fn same_power(
    cell: *const FracbmsCell,
    reference: &CellEstimator<f32, 256, 64>,
    cs: &OnlineSettings<f32, FRACBMS_OCV_POINTS_MAX>,
    k: usize,
) -> bool {
    let mut p = FracbmsPower::default();
    assert_eq!(
        unsafe { fracbms_cell_state_of_power(cell, &power_request(), &mut p) },
        FRACBMS_OK
    );
    let want = reference.state_of_power(cs, &core_power_settings());
    assert!(same_bits(&p, &core_power(want)), "sample {k}: {p:?}");
    CORRECTED.with(|c| c.set(c.get() + corrected(&p)));
    p.published
}

std::thread_local! {
    /// Horizons [`same_power`] found corrected, on this test's thread.
    static CORRECTED: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

fn core_power_settings() -> PowerSettings<f32> {
    let limits = PowerLimits {
        voltage_min: 3.0,
        voltage_max: 4.2,
        current_limit: 50.0,
    };
    PowerSettings::new(limits, &[2, 10, 30], Some(WATCHED_A)).unwrap()
}

#[test]
fn a_cell_through_the_abi_is_the_core_estimator_bit_for_bit() {
    let (i, v) = record();
    let mut s = defaults();
    s.pulse_current = WATCHED_A;
    let (mut size, mut align) = (0, 0);
    assert_eq!(
        unsafe { fracbms_cell_size(256, 64, &mut size, &mut align) },
        FRACBMS_OK
    );
    assert!(align <= 8 && size > 20_000, "{size} B aligned {align}");
    let mut mem = memory(size);
    let mut cell = std::ptr::null_mut();
    assert_eq!(
        unsafe { fracbms_cell_init(mem.as_mut_ptr().cast(), size, &s, &mut cell) },
        FRACBMS_OK
    );
    let mut cs = core_settings();
    cs.pulse_current = Some(WATCHED_A);
    let mut reference = Box::new(CellEstimator::<f32, 256, 64>::new(&cs).unwrap());
    let mut e = MaybeUninit::<FracbmsEstimate>::uninit();
    let mut published_power = 0;
    for (k, (&i, &v)) in i.iter().zip(&v).enumerate() {
        assert_eq!(
            unsafe { fracbms_cell_push(cell, i, v, e.as_mut_ptr()) },
            FRACBMS_OK
        );
        let r = reference.push(&cs, i, v);
        // The state of power reaches C bit for bit.
        if k % 25 == 24 {
            published_power += usize::from(same_power(cell, &reference, &cs, k));
        }
        let e = unsafe { e.assume_init() };
        assert_eq!(e.status, r.status.into());
        assert_eq!(e.iterations, r.iterations);
        same_published(&e.published, &reference.published().into());
        let step = reference.cell_state().step_resistance().map(|s| s.ohm);
        assert_eq!(
            e.step_resistance.to_bits(),
            step.unwrap_or(f32::NAN).to_bits()
        );
    }
    let corrected = CORRECTED.with(std::cell::Cell::get);
    println!(
        "state of power published at {published_power} of 40 checks, {corrected} horizons corrected"
    );
    assert!(published_power >= 20, "{published_power} of 40");
    // The 3 A pulses from a settled cell correct the pulse voltage.
    assert!(corrected > 0);
    // The pulse record identifies R_i (its statuses reach C).
    assert_ne!(
        e_status(&e, |p| p.r_i_status),
        FracbmsIdentification::FRACBMS_IDENTIFICATION_NOT_IDENTIFIED
    );
    let e = unsafe { e.assume_init() };
    let p = reference.estimate().unwrap();
    assert!(e.valid);
    assert_eq!(e.parameters, p.into());
    assert_eq!(e.samples, 1000);
    assert_eq!(e.rejected, 0);
    assert!(e.state_of_charge.is_nan() && e.ocv_offset.is_nan());
    // Reading changes nothing.
    let mut again = MaybeUninit::uninit();
    assert_eq!(
        unsafe { fracbms_cell_estimate(cell, again.as_mut_ptr()) },
        FRACBMS_OK
    );
    assert_eq!(unsafe { again.assume_init() }.parameters, e.parameters);
}

fn e_status(
    e: &MaybeUninit<FracbmsEstimate>,
    f: impl Fn(&FracbmsPublished) -> FracbmsIdentification,
) -> FracbmsIdentification {
    f(&unsafe { e.assume_init() }.published)
}

#[test]
fn identification_names_are_the_tracks() {
    use FracbmsIdentification::*;
    let name = |s: i32| unsafe { std::ffi::CStr::from_ptr(fracbms_identification_name(s)) };
    for (s, want) in [
        (FRACBMS_IDENTIFICATION_NOT_IDENTIFIED, "not_identified"),
        (FRACBMS_IDENTIFICATION_IDENTIFIED, "identified"),
        (FRACBMS_IDENTIFICATION_HELD, "held"),
        (FRACBMS_IDENTIFICATION_STEP, "step"),
        (FRACBMS_IDENTIFICATION_EXPIRED, "expired"),
    ] {
        assert_eq!(name(s as i32).to_str().unwrap(), want);
    }
    assert_eq!(name(99).to_str().unwrap(), "unknown");
}

#[test]
fn every_misuse_is_a_code() {
    let s = defaults();
    let (mut size, mut align) = (0, 0);
    assert_eq!(
        unsafe { fracbms_cell_size(256, 64, std::ptr::null_mut(), &mut align) },
        FRACBMS_ERROR_NULL
    );
    assert_eq!(
        unsafe { fracbms_cell_size(300, 64, &mut size, &mut align) },
        FRACBMS_ERROR_UNSUPPORTED_SIZE
    );
    assert_eq!(
        unsafe { fracbms_cell_size(256, 65, &mut size, &mut align) },
        FRACBMS_ERROR_UNSUPPORTED_SIZE
    );
    assert_eq!(
        unsafe { fracbms_cell_size(256, 0, &mut size, &mut align) },
        FRACBMS_ERROR_UNSUPPORTED_SIZE
    );
    assert_eq!(
        unsafe { fracbms_cell_size(256, 64, &mut size, &mut align) },
        FRACBMS_OK
    );
    let mut mem = memory(size + 8);
    let mut cell = std::ptr::null_mut();
    let base: *mut u8 = mem.as_mut_ptr().cast();
    assert_eq!(
        unsafe { fracbms_cell_init(base.cast(), size - 1, &s, &mut cell) },
        FRACBMS_ERROR_TOO_SMALL
    );
    assert_eq!(
        unsafe { fracbms_cell_init(base.wrapping_add(1).cast(), size, &s, &mut cell) },
        FRACBMS_ERROR_MISALIGNED
    );
    assert_eq!(
        unsafe { fracbms_cell_init(std::ptr::null_mut(), size, &s, &mut cell) },
        FRACBMS_ERROR_NULL
    );
    let mut bad = s;
    bad.h = -1.0;
    assert_eq!(
        unsafe { fracbms_cell_init(base.cast(), size, &bad, &mut cell) },
        FRACBMS_ERROR_SETTINGS
    );
    bad = s;
    bad.method = 7;
    assert_eq!(
        unsafe { fracbms_cell_init(base.cast(), size, &bad, &mut cell) },
        FRACBMS_ERROR_SETTINGS
    );
    for (memory_s, memory_soc) in [
        (-1.0, 0.05),
        (f32::NAN, 0.05),
        (600.0, 0.0),
        (600.0, f32::NAN),
    ] {
        bad = s;
        bad.slow_memory_s = memory_s;
        bad.slow_memory_soc = memory_soc;
        assert_eq!(
            unsafe { fracbms_cell_init(base.cast(), size, &bad, &mut cell) },
            FRACBMS_ERROR_SETTINGS,
            "{memory_s} {memory_soc}"
        );
    }
    bad = s;
    let (soc, ocv) = ([0.0f32, 0.5, 0.4], [3.0f32, 3.5, 4.0]);
    bad.ocv_soc = soc.as_ptr();
    bad.ocv_v = ocv.as_ptr();
    bad.ocv_points = 3;
    bad.capacity_ah = 2.0;
    assert_eq!(
        unsafe { fracbms_cell_init(base.cast(), size, &bad, &mut cell) },
        FRACBMS_ERROR_OCV
    );
    bad.ocv_soc = std::ptr::null();
    assert_eq!(
        unsafe { fracbms_cell_init(base.cast(), size, &bad, &mut cell) },
        FRACBMS_ERROR_NULL
    );
    // Memory that no init wrote.
    let mut e = MaybeUninit::uninit();
    assert_eq!(
        unsafe { fracbms_cell_push(base.cast(), 1.0, 3.7, e.as_mut_ptr()) },
        FRACBMS_ERROR_NOT_INITIALIZED
    );
    assert_eq!(
        unsafe { fracbms_cell_push(std::ptr::null_mut(), 1.0, 3.7, e.as_mut_ptr()) },
        FRACBMS_ERROR_NULL
    );
    // A bad sample is data: rejected, counted, not an error.
    assert_eq!(
        unsafe { fracbms_cell_init(base.cast(), size, &s, &mut cell) },
        FRACBMS_OK
    );
    for v in [f32::NAN, f32::INFINITY, 1e30, -3.7] {
        assert_eq!(
            unsafe { fracbms_cell_push(cell, 1.0, v, e.as_mut_ptr()) },
            FRACBMS_OK
        );
        assert_ne!(
            unsafe { e.assume_init() }.rejection,
            FracbmsRejection::FRACBMS_REJECTION_NONE
        );
    }
    assert_eq!(unsafe { e.assume_init() }.rejected, 4);
    // Names of unknown values.
    let name =
        |p: *const std::ffi::c_char| unsafe { std::ffi::CStr::from_ptr(p) }.to_str().unwrap();
    assert_eq!(name(fracbms_status_name(2)), "tracking");
    assert_eq!(name(fracbms_status_name(99)), "unknown");
    assert_eq!(
        name(fracbms_code_message(-3)),
        "the memory is smaller than reported"
    );
    assert_eq!(name(fracbms_code_message(5)), "unknown code");
}

#[test]
fn a_pack_through_the_abi_is_the_core_pack_bit_for_bit() {
    let (i, v) = record();
    let mut s = defaults();
    s.pulse_current = WATCHED_A;
    let cells = 5u16;
    let (mut size, mut align) = (0, 0);
    assert_eq!(
        unsafe { fracbms_pack_size(256, 64, 17, &mut size, &mut align) },
        FRACBMS_ERROR_CELL_COUNT
    );
    assert_eq!(
        unsafe { fracbms_pack_size(256, 64, cells, &mut size, &mut align) },
        FRACBMS_OK
    );
    let (mut size16, mut size4) = (0, 0);
    unsafe { fracbms_pack_size(256, 64, 16, &mut size16, &mut align) };
    unsafe { fracbms_pack_size(256, 64, 4, &mut size4, &mut align) };
    assert!(size4 < size && size < size16, "room for 4 < 8 < 16 cells");
    let mut mem = memory(size);
    let mut pack = std::ptr::null_mut();
    assert_eq!(
        unsafe { fracbms_pack_init(mem.as_mut_ptr().cast(), size, &s, cells, 2, 0.3, &mut pack) },
        FRACBMS_OK
    );
    assert_eq!(unsafe { fracbms_pack_cells(pack) }, cells);
    let mut ps = PackSettings::new(core_settings());
    ps.cell.pulse_current = Some(WATCHED_A);
    ps.updates_per_period = 2;
    let mut reference = Box::new(PackEstimator::<f32, 256, 64, 8>::new(&ps, 5).unwrap());
    let mut report = FracbmsPackReport::default();
    for (k, (&i, &v)) in i.iter().zip(&v).enumerate() {
        // Cell c reads c mV more; cell 3 a NaN every 100 samples.
        let vs: Vec<f32> = (0..cells)
            .map(|c| {
                if c == 3 && k % 100 == 7 {
                    f32::NAN
                } else {
                    v + f32::from(c) * 1e-3
                }
            })
            .collect();
        assert_eq!(
            unsafe { fracbms_pack_push(pack, i, vs.as_ptr(), cells, &mut report) },
            FRACBMS_OK
        );
        let r = reference.push(&ps, i, &vs).unwrap();
        assert_eq!(
            (report.rejected, report.updated, report.iterations),
            (r.rejected, r.updated, r.iterations)
        );
    }
    for c in 0..cells {
        let mut e = MaybeUninit::uninit();
        assert_eq!(
            unsafe { fracbms_pack_cell(pack, c, e.as_mut_ptr()) },
            FRACBMS_OK
        );
        let e = unsafe { e.assume_init() };
        let want = reference.cell(usize::from(c)).unwrap();
        assert_eq!(e.parameters, want.estimate().unwrap().into());
        same_published(&e.published, &want.published().into());
        assert_eq!(e.rejected, if c == 3 { 10 } else { 0 });
        assert!(!e.flagged, "cells differ by an offset only");
        // Each cell's state of power is the core pack's, bit for bit.
        let mut got = FracbmsPower::default();
        assert_eq!(
            unsafe { fracbms_pack_state_of_power(pack, c, &power_request(), &mut got) },
            FRACBMS_OK
        );
        let want = reference.state_of_power(usize::from(c), &ps.cell, &core_power_settings());
        assert!(
            want.is_some(),
            "cell {c}: a state of power after the record"
        );
        assert!(same_bits(&got, &core_power(want)), "cell {c}: {got:?}");
    }
    // The string's: the weakest cell's.
    let mut got = FracbmsPower::default();
    assert_eq!(
        unsafe {
            fracbms_pack_state_of_power(pack, FRACBMS_PACK_STRING, &power_request(), &mut got)
        },
        FRACBMS_OK
    );
    let want = reference.pack_state_of_power(&ps.cell, &core_power_settings());
    assert!(same_bits(&got, &core_power(want)), "{got:?}");
    assert_eq!(corrected(&got), 0, "a string's sum is not corrected again");
    let weakest = (0..usize::from(cells))
        .map(|c| {
            reference
                .state_of_power(c, &ps.cell, &core_power_settings())
                .unwrap()
                .horizons()[1]
                .sop
                .discharge_a
        })
        .fold(f32::INFINITY, f32::min);
    assert_eq!(got.horizons[1].discharge_a, weakest);
    // A request the core refuses, and a cell out of range, are codes.
    let mut bad = power_request();
    bad.voltage_min = 4.5;
    assert_eq!(
        unsafe { fracbms_pack_state_of_power(pack, 0, &bad, &mut got) },
        FRACBMS_ERROR_SETTINGS
    );
    assert_eq!(
        unsafe { fracbms_pack_state_of_power(pack, cells, &power_request(), &mut got) },
        FRACBMS_ERROR_CELL_COUNT
    );
    assert_eq!(
        unsafe { fracbms_pack_state_of_power(pack, 0, std::ptr::null(), &mut got) },
        FRACBMS_ERROR_NULL
    );
    let mut e = MaybeUninit::uninit();
    assert_eq!(
        unsafe { fracbms_pack_cell(pack, cells, e.as_mut_ptr()) },
        FRACBMS_ERROR_CELL_COUNT
    );
    let short = [3.7f32; 4];
    assert_eq!(
        unsafe { fracbms_pack_push(pack, 0.0, short.as_ptr(), 4, &mut report) },
        FRACBMS_ERROR_CELL_COUNT
    );
}

/// `firmware/data/cell-pulse.csv`: time, current, voltage.
fn cell_pulse() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../firmware/data/cell-pulse.csv"
    ))
    .unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    let col = |k: usize| rows.iter().map(|r| r[k]).collect::<Vec<f64>>();
    (col(0), col(1), col(2))
}

#[test]
fn whole_record_identification_is_the_clis() {
    let (t, i, mut v) = cell_pulse();
    let mut fit = MaybeUninit::<FracbmsFit>::uninit();
    let code = unsafe {
        fracbms_identify_battery(
            t.as_ptr(),
            i.as_ptr(),
            v.as_ptr(),
            t.len(),
            std::ptr::null(),
            fit.as_mut_ptr(),
        )
    };
    assert_eq!(code, FRACBMS_OK);
    let fit = unsafe { fit.assume_init() };
    // The CLI's own function on the same file.
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../firmware/data/cell-pulse.csv"
    );
    let cli = |p: &std::path::Path| {
        fracbms_host::identify::record::battery_file(p, &Default::default(), false)
            .unwrap()
            .result
            .json
    };
    let same = |fit: &FracbmsFit, cli: &fracbms_host::identify::BatteryJson| {
        assert_eq!(
            (fit.r_i, fit.r_ct, fit.q, fit.alpha, fit.u_oc, fit.rmse_v),
            (cli.r_i, cli.r_ct, cli.q, cli.alpha, cli.u_oc, cli.rmse_v)
        );
        assert_eq!(
            (fit.converged, fit.rejected, fit.identifiable),
            (cli.converged, cli.rejected, cli.identifiable)
        );
    };
    same(&fit, &cli(std::path::Path::new(path)));
    assert_eq!(fit.rejected, 0);
    // A NaN voltage and a spike are rows rejected, substituted and counted,
    // as the CLI does with the same file: the same fit.
    v[10] = f64::NAN;
    v[200] += 0.4;
    let bad_file = std::env::temp_dir().join(format!("fracbms-abi-bad-{}.csv", std::process::id()));
    let mut csv = String::from("time_s,current_a,voltage_v\n");
    for ((a, b), c) in t.iter().zip(&i).zip(&v) {
        csv.push_str(&format!("{a},{b},{c}\n"));
    }
    std::fs::write(&bad_file, csv).unwrap();
    let mut bad = MaybeUninit::<FracbmsFit>::uninit();
    let code = unsafe {
        fracbms_identify_battery(
            t.as_ptr(),
            i.as_ptr(),
            v.as_ptr(),
            t.len(),
            std::ptr::null(),
            bad.as_mut_ptr(),
        )
    };
    assert_eq!(code, FRACBMS_OK);
    let bad = unsafe { bad.assume_init() };
    let cli_bad = cli(&bad_file);
    std::fs::remove_file(&bad_file).unwrap();
    same(&bad, &cli_bad);
    assert_eq!(bad.rejected, 2);
    assert!(
        (bad.r_i / fit.r_i - 1.0).abs() < 0.01,
        "{} {}",
        bad.r_i,
        fit.r_i
    );
    // A NaN time is one message, not a fit (the CLI's).
    let mut t_bad = t.clone();
    t_bad[10] = f64::NAN;
    let mut none = MaybeUninit::<FracbmsFit>::uninit();
    let code = unsafe {
        fracbms_identify_battery(
            t_bad.as_ptr(),
            i.as_ptr(),
            v.as_ptr(),
            t.len(),
            std::ptr::null(),
            none.as_mut_ptr(),
        )
    };
    assert_eq!(code, FRACBMS_ERROR_DATA);
    let none = unsafe { none.assume_init() };
    let msg = unsafe { std::ffi::CStr::from_ptr(none.message.as_ptr()) }
        .to_str()
        .unwrap();
    assert!(msg.starts_with("record: row 12, column `time_s`"), "{msg}");
}

/// A map of three levels around the 18650 cell (R_i 15, 20, 30 mΩ at SOC
/// 0.2, 0.5, 0.8; unknown temperature).
fn map_levels() -> Vec<FracbmsMapLevel> {
    [(0.2, 0.015), (0.5, 0.020), (0.8, 0.030)]
        .iter()
        .map(|&(soc, r_i)| FracbmsMapLevel {
            temperature_c: f32::NAN,
            soc,
            parameters: CellParameters {
                r_i,
                u_oc: 0.001,
                ..CellParameters::<f32>::cell_18650()
            }
            .into(),
        })
        .collect()
}

#[test]
fn a_map_through_the_abi_is_the_cores() {
    use estimator_core::battery::map::{MapFollower, MapLevel, ParameterMap};
    use estimator_core::battery::ocv::{OcvModel, OcvTable};
    use estimator_core::battery::Prior;
    let levels = map_levels();
    let core_levels: Vec<MapLevel<f32>> = levels.iter().map(|&l| l.into()).collect();
    let map = ParameterMap::new(&core_levels).unwrap();
    let mut out = FracbmsParameters::default();
    for (soc, t) in [(0.35, f32::NAN), (0.9, 25.0), (f32::NAN, f32::NAN)] {
        assert_eq!(
            unsafe { fracbms_map_cell_at(levels.as_ptr(), 3, soc, t, &mut out) },
            FRACBMS_OK
        );
        assert_eq!(
            out,
            map.cell_at(soc, (!t.is_nan()).then_some(t)).into(),
            "{soc}"
        );
    }
    assert!((out.r_i - 0.020).abs() < 1e-9, "NaN SOC: the middle level");
    // Misuse: null, unsorted, too long, empty, not physical.
    let null = std::ptr::null();
    assert_eq!(
        unsafe { fracbms_map_cell_at(null, 3, 0.5, 25.0, &mut out) },
        FRACBMS_ERROR_NULL
    );
    let lv = levels.as_ptr();
    let null_out = std::ptr::null_mut();
    assert_eq!(
        unsafe { fracbms_map_cell_at(lv, 3, 0.5, 25.0, null_out) },
        FRACBMS_ERROR_NULL
    );
    let mut bad = levels.clone();
    bad.swap(0, 2);
    assert_eq!(
        unsafe { fracbms_map_cell_at(bad.as_ptr(), 3, 0.5, 25.0, &mut out) },
        FRACBMS_ERROR_MAP
    );
    let long = vec![levels[0]; FRACBMS_MAP_LEVELS_MAX + 1];
    assert_eq!(
        unsafe { fracbms_map_cell_at(long.as_ptr(), long.len() as u16, 0.5, 25.0, &mut out) },
        FRACBMS_ERROR_MAP
    );
    assert_eq!(
        unsafe { fracbms_map_cell_at(lv, 0, 0.5, 25.0, &mut out) },
        FRACBMS_ERROR_MAP
    );
    let mut bad = levels.clone();
    bad[1].parameters.r_ct = -1.0;
    assert_eq!(
        unsafe { fracbms_map_cell_at(bad.as_ptr(), 3, 0.5, 25.0, &mut out) },
        FRACBMS_ERROR_MAP
    );

    // A cell with an OCV table following the map through the ABI is the
    // core's estimator following it with the core's follower, bit for bit.
    let (zs, vs) = nmc_table();
    let mut s = defaults();
    s.ocv_soc = zs.as_ptr();
    s.ocv_v = vs.as_ptr();
    s.ocv_points = zs.len() as u16;
    s.capacity_ah = 0.5;
    let (mut size, mut align) = (0, 0);
    unsafe { fracbms_cell_size(256, 64, &mut size, &mut align) };
    let mut mem = memory(size);
    let mut cell = std::ptr::null_mut();
    assert_eq!(
        unsafe { fracbms_cell_init(mem.as_mut_ptr().cast(), size, &s, &mut cell) },
        FRACBMS_OK
    );
    assert_eq!(
        unsafe { fracbms_cell_set_state_of_charge(cell, 0.7) },
        FRACBMS_OK
    );
    let curve: OcvModel<f32, FRACBMS_OCV_POINTS_MAX> =
        OcvModel::new(OcvTable::new(&zs, &vs).unwrap(), 0.5).unwrap();
    let mut cs = OnlineSettings::new(1.0, 64, CellParameters::<f32>::cell_18650());
    cs.battery.start = Start::AtRest;
    let mut cs = cs.with_curve(Some(curve));
    let mut reference = Box::new(CellEstimator::<f32, 256, 64>::new(&cs).unwrap());
    reference.set_state_of_charge(0.7);
    let mut follower = MapFollower::new();
    let (i, v) = record();
    let (mut taken_count, mut e) = (0, MaybeUninit::<FracbmsEstimate>::uninit());
    let mut published_power = 0;
    let temperature = |k: usize| if k < 500 { 25.0 } else { f32::NAN };
    for (k, (&i, &v)) in i.iter().zip(&v).enumerate() {
        let mut taken = false;
        assert_eq!(
            unsafe { fracbms_cell_follow_map(cell, lv, 3, temperature(k), &mut taken) },
            FRACBMS_OK
        );
        // The published SOC: the observer's once it has started, the
        // count before (as the CLI's map prior).
        let z = reference
            .soc_estimate(&cs)
            .map(|e| e.soc)
            .or(reference.state_of_charge())
            .unwrap();
        let expect = follower.follow(&map, z, temperature(k));
        assert_eq!(taken, expect.is_some(), "sample {k}");
        if let Some(c) = expect {
            cs.battery.prior = Some(Prior::new(c));
            taken_count += 1;
        }
        unsafe { fracbms_cell_push(cell, i, v, e.as_mut_ptr()) };
        let r = reference.push(&cs, i, v);
        let got = unsafe { e.assume_init() };
        assert_eq!(got.status, r.status.into());
        // The SOC observer reaches C bit for bit.
        let want = reference.soc_estimate(&cs).map(FracbmsSoc::from).unwrap();
        assert_eq!(
            got.soc.state_of_charge.to_bits(),
            want.state_of_charge.to_bits()
        );
        assert_eq!(got.soc, want);
        // So does the state of power, with the OCV curve.
        if k % 50 == 49 {
            published_power += usize::from(same_power(cell, &reference, &cs, k));
        }
    }
    // The cell starts at rest (`Start::AtRest`): its first window, fitted
    // from rest, publishes every parameter, R_ct as the map's prior
    // (`prior`: the data alone do not identify it), so there is a state
    // of power to compare, and C gives the core's at every check
    // (`same_power`).
    assert!(published_power > 0, "{published_power}");
    let e = unsafe { e.assume_init() };
    assert_eq!(e.parameters, reference.estimate().unwrap().into());
    assert_eq!(e.state_of_charge, reference.state_of_charge().unwrap());
    // The SOC moved through the map: the prior was taken again and again.
    let moved = (e.state_of_charge - 0.7).abs();
    assert!(
        taken_count > 10 && moved > 0.05,
        "{taken_count} takes, SOC moved {moved}"
    );
    // A prior set by hand, then cleared.
    let center = FracbmsParameters::from(CellParameters::<f32>::cell_18650());
    assert_eq!(unsafe { fracbms_cell_set_prior(cell, &center) }, FRACBMS_OK);
    let mut bad = center;
    bad.q = f32::NAN;
    assert_eq!(
        unsafe { fracbms_cell_set_prior(cell, &bad) },
        FRACBMS_ERROR_SETTINGS
    );
    assert_eq!(
        unsafe { fracbms_cell_set_prior(cell, std::ptr::null()) },
        FRACBMS_OK
    );
    assert_eq!(
        unsafe { fracbms_cell_set_prior(std::ptr::null_mut(), &center) },
        FRACBMS_ERROR_NULL
    );
}

/// Rows marked unobserved (`FracbmsIdentifyOptions.unobserved`) are counted
/// in no fit: a block of made-up voltages there leaves the fit where the
/// clean record puts it, and is not counted as rejected; unmarked, the
/// same block moves the fit.
#[test]
fn unobserved_rows_are_counted_in_no_fit() {
    let (t, i, v) = cell_pulse();
    let fit_of = |v: &[f64], mask: Option<&[u8]>| {
        let mut o = MaybeUninit::<FracbmsIdentifyOptions>::uninit();
        assert_eq!(
            unsafe { fracbms_identify_options_default(o.as_mut_ptr()) },
            FRACBMS_OK
        );
        let mut o = unsafe { o.assume_init() };
        o.unobserved = mask.map_or(std::ptr::null(), <[u8]>::as_ptr);
        let mut fit = MaybeUninit::<FracbmsFit>::uninit();
        let code = unsafe {
            fracbms_identify_battery(
                t.as_ptr(),
                i.as_ptr(),
                v.as_ptr(),
                t.len(),
                &o,
                fit.as_mut_ptr(),
            )
        };
        assert_eq!(code, FRACBMS_OK);
        unsafe { fit.assume_init() }
    };
    let clean = fit_of(&v, None);
    // 40 rows from the first current step on: their voltage made up 50 mV
    // high (a cycler's unlogged start, filled with its first row's value).
    let k0 = (1..i.len()).find(|&k| i[k] != i[k - 1]).unwrap();
    let mut made_up = v.clone();
    let mut mask = vec![0u8; v.len()];
    for k in k0..k0 + 40 {
        made_up[k] += 0.05;
        mask[k] = 1;
    }
    let masked = fit_of(&made_up, Some(&mask));
    let unmasked = fit_of(&made_up, None);
    assert_eq!(masked.rejected, 0);
    let moved = |f: &FracbmsFit| (f.r_i / clean.r_i - 1.0).abs();
    assert!(moved(&masked) < 0.02, "{} vs {}", masked.r_i, clean.r_i);
    assert!(
        moved(&unmasked) > 2.0 * moved(&masked),
        "{} {} {}",
        unmasked.r_i,
        masked.r_i,
        clean.r_i
    );
}
