//! The SOC observer's settings reach the core through the C ABI:
//! `fracbms_soc_settings_default` gives the core's defaults, and a cell or a
//! pack built with other settings (`fracbms_*_init_with_soc`) is the core's
//! estimator with those settings, bit for bit, and not the defaults' one.

use std::mem::MaybeUninit;

use estimator_core::battery::ocv::{OcvModel, OcvTable};
use estimator_core::battery::online::{CellEstimator, OnlineSettings};
use estimator_core::battery::pack::{PackEstimator, PackSettings};
use estimator_core::battery::soc::SocSettings;
use estimator_core::battery::{CellParameters, Start};
use fracbms::FracbmsCode::*;
use fracbms::*;

mod common;
use common::{cell_memory, defaults, memory, nmc_table, record};

const CAPACITY_AH: f32 = 0.5;

/// The C settings with the table (whose arrays must outlive them).
fn with_table(zs: &[f32], vs: &[f32]) -> FracbmsSettings {
    let mut s = defaults();
    s.ocv_soc = zs.as_ptr();
    s.ocv_v = vs.as_ptr();
    s.ocv_points = zs.len() as u16;
    s.capacity_ah = CAPACITY_AH;
    s
}

/// The core's settings the C ones stand for, with SOC settings `soc`.
fn core_settings(
    zs: &[f32],
    vs: &[f32],
    soc: Option<&SocSettings<f32>>,
) -> OnlineSettings<f32, FRACBMS_OCV_POINTS_MAX> {
    let curve = OcvModel::new(OcvTable::new(zs, vs).unwrap(), CAPACITY_AH).unwrap();
    let mut s = OnlineSettings::new(1.0, 64, CellParameters::<f32>::cell_18650());
    s.battery.start = Start::AtRest;
    let mut s = s.with_curve(Some(curve));
    if let Some(soc) = soc {
        s.soc = *soc;
    }
    s
}

/// Settings unlike the defaults on this record, each changing what the
/// one before did: rests of 60 s are read (its longest is 84 s), a loose
/// rest load, a calibrated sensor.
fn changed(d: FracbmsSocSettings) -> [FracbmsSocSettings; 3] {
    let short = FracbmsSocSettings { rest_s: 60.0, ..d };
    [
        short,
        FracbmsSocSettings {
            rest_load_sigma_a: 0.05,
            ..short
        },
        FracbmsSocSettings {
            bias_sigma_a: 0.0,
            bias_walk_a: 0.0,
            capacity_min_span: 0.0,
            ..short
        },
    ]
}

fn soc_defaults(s: &FracbmsSettings) -> FracbmsSocSettings {
    let mut out = MaybeUninit::uninit();
    assert_eq!(
        unsafe { fracbms_soc_settings_default(s, out.as_mut_ptr()) },
        FRACBMS_OK
    );
    unsafe { out.assume_init() }
}

/// A cell through the ABI with `soc` (null: the defaults); its SOC
/// estimate after every sample.
fn run_cell(s: &FracbmsSettings, soc: *const FracbmsSocSettings) -> Vec<FracbmsSoc> {
    let (i, v) = record();
    let (mut mem, size) = cell_memory();
    let mut cell = std::ptr::null_mut();
    assert_eq!(
        unsafe { fracbms_cell_init_with_soc(mem.as_mut_ptr().cast(), size, s, soc, &mut cell) },
        FRACBMS_OK
    );
    i.iter()
        .zip(&v)
        .map(|(&i, &v)| {
            let mut e = MaybeUninit::uninit();
            assert_eq!(
                unsafe { fracbms_cell_push(cell, i, v, e.as_mut_ptr()) },
                FRACBMS_OK
            );
            unsafe { e.assume_init() }.soc
        })
        .collect()
}

#[test]
fn the_soc_defaults_are_the_cores() {
    let (zs, vs) = nmc_table();
    let s = with_table(&zs, &vs);
    let d = soc_defaults(&s);
    let core = SocSettings::<f32>::new(CAPACITY_AH, 1.0);
    let mut back = SocSettings::<f32>::new(1.0, 1.0);
    back.capacity_ah = CAPACITY_AH;
    apply_to_check(&d, &mut back);
    assert_eq!(back, core);
    assert_eq!(d.rest_s, 600.0);
    assert_eq!(d.bias_sigma_a, CAPACITY_AH / 50.0);
    assert_eq!(
        unsafe { fracbms_soc_settings_default(std::ptr::null(), &mut changed(d)[0]) },
        FRACBMS_ERROR_NULL
    );
    assert_eq!(
        unsafe { fracbms_soc_settings_default(&s, std::ptr::null_mut()) },
        FRACBMS_ERROR_NULL
    );
}

/// The C struct's values into the core's settings, field by field (as
/// the adapter's own conversion, written out again so that a field it
/// forgets fails here).
fn apply_to_check(c: &FracbmsSocSettings, s: &mut SocSettings<f32>) {
    s.rest_current_a = c.rest_current_a;
    s.rest_s = c.rest_s;
    s.rest_max_s = c.rest_max_s;
    s.voltage_sigma_v = c.voltage_sigma_v;
    s.unrelaxed_sigma_v = c.unrelaxed_sigma_v;
    s.table_sigma_soc = c.table_sigma_soc;
    s.soc0_sigma = c.soc0_sigma;
    s.bias_sigma_a = c.bias_sigma_a;
    s.bias_walk_a = c.bias_walk_a;
    s.rest_load_sigma_a = c.rest_load_sigma_a;
    s.capacity_sigma = c.capacity_sigma;
    s.capacity_identify = c.capacity_identify;
    s.capacity_min_span = c.capacity_min_span;
    s.gap_soc_sigma = c.gap_soc_sigma;
    s.min_slope = c.min_slope;
}

#[test]
fn a_cell_with_soc_settings_is_the_core_cell_with_them() {
    let (zs, vs) = nmc_table();
    let s = with_table(&zs, &vs);
    let (i, v) = record();
    let mut finals = Vec::new();
    for c in changed(soc_defaults(&s)) {
        let mut core_soc = SocSettings::<f32>::new(CAPACITY_AH, 1.0);
        apply_to_check(&c, &mut core_soc);
        let cs = core_settings(&zs, &vs, Some(&core_soc));
        let mut reference = Box::new(CellEstimator::<f32, 256, 64>::new(&cs).unwrap());
        let got = run_cell(&s, &c);
        for (k, ((&i, &v), got)) in i.iter().zip(&v).zip(&got).enumerate() {
            reference.push(&cs, i, v);
            let want: FracbmsSoc = reference.soc_estimate(&cs).unwrap().into();
            assert_eq!(*got, want, "{c:?}: sample {k}");
        }
        finals.push(*got.last().unwrap());
    }
    // Each setting matters on this record: 60-s rests are read where 600-s
    // ones never come, then a rest load reads the bias otherwise, and a
    // calibrated sensor has none.
    let with_defaults = *run_cell(&s, std::ptr::null()).last().unwrap();
    assert!(
        finals[0].observations > with_defaults.observations,
        "{finals:?} against {with_defaults:?}"
    );
    assert_ne!(finals[1].current_bias, finals[0].current_bias);
    assert_eq!(finals[2].current_bias, 0.0, "{finals:?}");
    assert_ne!(finals[0].current_bias, 0.0, "{finals:?}");
    // The defaults' run is `fracbms_cell_init`'s.
    let (mut mem, size) = cell_memory();
    let mut cell = std::ptr::null_mut();
    unsafe { fracbms_cell_init(mem.as_mut_ptr().cast(), size, &s, &mut cell) };
    let mut e = MaybeUninit::uninit();
    for (&i, &v) in i.iter().zip(&v) {
        unsafe { fracbms_cell_push(cell, i, v, e.as_mut_ptr()) };
    }
    assert_eq!(unsafe { e.assume_init() }.soc, with_defaults);
}

/// Each field of the C struct, to set one at a time.
fn fields(s: &mut FracbmsSocSettings) -> [(&'static str, &mut f32); 15] {
    [
        ("rest_current_a", &mut s.rest_current_a),
        ("rest_s", &mut s.rest_s),
        ("rest_max_s", &mut s.rest_max_s),
        ("voltage_sigma_v", &mut s.voltage_sigma_v),
        ("unrelaxed_sigma_v", &mut s.unrelaxed_sigma_v),
        ("table_sigma_soc", &mut s.table_sigma_soc),
        ("soc0_sigma", &mut s.soc0_sigma),
        ("bias_sigma_a", &mut s.bias_sigma_a),
        ("bias_walk_a", &mut s.bias_walk_a),
        ("rest_load_sigma_a", &mut s.rest_load_sigma_a),
        ("capacity_sigma", &mut s.capacity_sigma),
        ("capacity_identify", &mut s.capacity_identify),
        ("capacity_min_span", &mut s.capacity_min_span),
        ("gap_soc_sigma", &mut s.gap_soc_sigma),
        ("min_slope", &mut s.min_slope),
    ]
}

#[test]
fn every_soc_setting_reaches_the_core() {
    // A NaN in any one field is refused by the core's check: so the
    // adapter carries every field (one it dropped would keep the default).
    let (zs, vs) = nmc_table();
    let s = with_table(&zs, &vs);
    let d = soc_defaults(&s);
    let (mut mem, size) = cell_memory();
    for k in 0..15 {
        let mut bad = d;
        let (name, x) = fields(&mut bad).into_iter().nth(k).unwrap();
        *x = f32::NAN;
        let mut cell = std::ptr::null_mut();
        assert_eq!(
            unsafe {
                fracbms_cell_init_with_soc(mem.as_mut_ptr().cast(), size, &s, &bad, &mut cell)
            },
            FRACBMS_ERROR_SETTINGS,
            "{name}"
        );
    }
    let mut cell = std::ptr::null_mut();
    assert_eq!(
        unsafe { fracbms_cell_init_with_soc(mem.as_mut_ptr().cast(), size, &s, &d, &mut cell) },
        FRACBMS_OK
    );
}

#[test]
fn soc_settings_need_the_ocv_table() {
    // Without a table the observer does not run, and its defaults would be
    // those of a 1 A·h cell: refused, not silently wrong.
    let (zs, vs) = nmc_table();
    let d = soc_defaults(&with_table(&zs, &vs));
    let s = defaults();
    let mut out = d;
    assert_eq!(
        unsafe { fracbms_soc_settings_default(&s, &mut out) },
        FRACBMS_ERROR_SETTINGS
    );
    let (mut mem, size) = cell_memory();
    let mut cell = std::ptr::null_mut();
    assert_eq!(
        unsafe { fracbms_cell_init_with_soc(mem.as_mut_ptr().cast(), size, &s, &d, &mut cell) },
        FRACBMS_ERROR_SETTINGS
    );
    // Null SOC settings: the defaults, as `fracbms_cell_init`.
    assert_eq!(
        unsafe {
            fracbms_cell_init_with_soc(
                mem.as_mut_ptr().cast(),
                size,
                &s,
                std::ptr::null(),
                &mut cell,
            )
        },
        FRACBMS_OK
    );
}

#[test]
fn soc_settings_the_core_refuses_are_a_code() {
    let (zs, vs) = nmc_table();
    let s = with_table(&zs, &vs);
    let d = soc_defaults(&s);
    let (mut mem, size) = cell_memory();
    for bad in [
        FracbmsSocSettings {
            rest_s: f32::NAN,
            ..d
        },
        FracbmsSocSettings {
            min_slope: 0.0,
            ..d
        },
        FracbmsSocSettings {
            bias_sigma_a: -1.0,
            ..d
        },
    ] {
        let mut cell = std::ptr::null_mut();
        assert_eq!(
            unsafe {
                fracbms_cell_init_with_soc(mem.as_mut_ptr().cast(), size, &s, &bad, &mut cell)
            },
            FRACBMS_ERROR_SETTINGS,
            "{bad:?}"
        );
        let mut pack = std::ptr::null_mut();
        let (mut psize, mut palign) = (0, 0);
        unsafe { fracbms_pack_size(256, 64, 2, &mut psize, &mut palign) };
        let mut pmem = memory(psize);
        assert_eq!(
            unsafe {
                fracbms_pack_init_with_soc(
                    pmem.as_mut_ptr().cast(),
                    psize,
                    &s,
                    &bad,
                    2,
                    2,
                    0.3,
                    &mut pack,
                )
            },
            FRACBMS_ERROR_SETTINGS,
            "{bad:?}"
        );
    }
}

#[test]
fn a_pack_with_soc_settings_is_the_core_pack_with_them() {
    let (zs, vs) = nmc_table();
    let s = with_table(&zs, &vs);
    let c = changed(soc_defaults(&s))[1];
    let mut core_soc = SocSettings::<f32>::new(CAPACITY_AH, 1.0);
    apply_to_check(&c, &mut core_soc);
    let mut ps = PackSettings::new(core_settings(&zs, &vs, Some(&core_soc)));
    ps.updates_per_period = 2;
    let cells = 2u16;
    let mut reference = Box::new(PackEstimator::<f32, 256, 64, 4>::new(&ps, 2).unwrap());
    let (mut size, mut align) = (0, 0);
    unsafe { fracbms_pack_size(256, 64, cells, &mut size, &mut align) };
    let mut mem = memory(size);
    let mut pack = std::ptr::null_mut();
    assert_eq!(
        unsafe {
            fracbms_pack_init_with_soc(
                mem.as_mut_ptr().cast(),
                size,
                &s,
                &c,
                cells,
                2,
                0.3,
                &mut pack,
            )
        },
        FRACBMS_OK
    );
    let (i, v) = record();
    let n = i.len();
    let mut report = FracbmsPackReport::default();
    for (k, (&i, &v)) in i.iter().zip(&v).enumerate() {
        let vs = [v, v + 2e-3];
        assert_eq!(
            unsafe { fracbms_pack_push(pack, i, vs.as_ptr(), cells, &mut report) },
            FRACBMS_OK
        );
        reference.push(&ps, i, &vs).unwrap();
        for cell in 0..cells {
            let mut e = MaybeUninit::uninit();
            assert_eq!(
                unsafe { fracbms_pack_cell(pack, cell, e.as_mut_ptr()) },
                FRACBMS_OK
            );
            let got = unsafe { e.assume_init() }.soc;
            let want: FracbmsSoc = reference
                .cell(usize::from(cell))
                .unwrap()
                .soc_estimate(&ps.cell)
                .unwrap()
                .into();
            assert_eq!(got, want, "sample {k}, cell {cell}");
            if k + 1 == n {
                assert!(got.observations > 1, "cell {cell}: {got:?}");
            }
        }
    }
}
