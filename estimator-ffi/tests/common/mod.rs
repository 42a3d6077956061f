//! Helpers of the ABI tests: the pulse record, the default settings, and
//! the core's settings they stand for.
#![allow(dead_code)]

use std::mem::MaybeUninit;

use estimator_core::battery::online::OnlineSettings;
use estimator_core::battery::{CellParameters, Start};
use fracbms::FracbmsCode::*;
use fracbms::*;

/// Columns `a` and `b` of a CSV file of the repository (header skipped).
fn two_columns(path: &str, a: usize, b: usize) -> (Vec<f32>, Vec<f32>) {
    let path = format!("{}/../{path}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<f32> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (f[a], f[b])
        })
        .unzip()
}

/// The firmware's pulse record: `(current_a, voltage_v)`.
pub fn record() -> (Vec<f32>, Vec<f32>) {
    two_columns("firmware/data/cell-pulse.csv", 1, 2)
}

/// The NMC OCV table of the own-model records: `(soc, ocv_v)`.
pub fn nmc_table() -> (Vec<f32>, Vec<f32>) {
    two_columns("data/own-model/nmc-ocv.csv", 0, 1)
}

pub fn defaults() -> FracbmsSettings {
    let mut s = MaybeUninit::uninit();
    assert_eq!(
        unsafe { fracbms_settings_default(1.0, s.as_mut_ptr()) },
        FRACBMS_OK
    );
    unsafe { s.assume_init() }
}

/// 8-byte aligned memory of at least `size` bytes.
pub fn memory(size: usize) -> Vec<u64> {
    vec![0; size.div_ceil(8)]
}

/// Memory for one cell of window 256, memory 64, and its size.
pub fn cell_memory() -> (Vec<u64>, usize) {
    let (mut size, mut align) = (0, 0);
    assert_eq!(
        unsafe { fracbms_cell_size(256, 64, &mut size, &mut align) },
        FRACBMS_OK
    );
    (memory(size), size)
}

pub fn core_settings() -> OnlineSettings<f32, FRACBMS_OCV_POINTS_MAX> {
    let mut s = OnlineSettings::new(1.0, 64, CellParameters::<f32>::cell_18650());
    s.battery.start = Start::AtRest;
    s.with_curve(None)
}

/// The same published values (bit for bit, NaN for none) and statuses.
pub fn same_published(a: &FracbmsPublished, b: &FracbmsPublished) {
    let bits = |p: &FracbmsPublished| [p.r_i, p.r_ct, p.q, p.alpha].map(f32::to_bits);
    let statuses = |p: &FracbmsPublished| [p.r_i_status, p.r_ct_status, p.q_status, p.alpha_status];
    assert_eq!(bits(a), bits(b));
    assert_eq!(statuses(a), statuses(b));
    for (v, s) in [(a.r_i, a.r_i_status), (a.r_ct, a.r_ct_status)] {
        let none = matches!(
            s,
            FracbmsIdentification::FRACBMS_IDENTIFICATION_NOT_IDENTIFIED
                | FracbmsIdentification::FRACBMS_IDENTIFICATION_EXPIRED
        );
        assert_eq!(v.is_nan(), none, "{v} {s:?}");
    }
}
