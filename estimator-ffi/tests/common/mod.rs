//! Helpers of the ABI tests: the pulse record, the default settings, and
//! the core's settings they stand for.
#![allow(dead_code)]

use std::mem::MaybeUninit;

use estimator_core::battery::online::OnlineSettings;
use estimator_core::battery::{CellParameters, Start};
use fracbms::FracbmsCode::*;
use fracbms::*;

pub fn record() -> (Vec<f32>, Vec<f32>) {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../firmware/data/cell-pulse.csv"
    ))
    .unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<f32> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (f[1], f[2])
        })
        .unzip()
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

pub fn core_settings() -> OnlineSettings<f32, FRACBMS_OCV_POINTS_MAX> {
    let mut s = OnlineSettings::new(1.0, 64, CellParameters::<f32>::cell_18650());
    s.battery.start = Start::AtRest;
    s.with_curve(None)
}
