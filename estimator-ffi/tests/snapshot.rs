//! Snapshots through the C ABI are the core's: the bytes a cell saves are
//! the core estimator's, a restored cell runs on bit for bit as the core's
//! restored cell, and every bad snapshot is a code that leaves the cell
//! clean.

use std::mem::MaybeUninit;

use estimator_core::battery::online::CellEstimator;
use estimator_core::battery::snapshot::RestorePolicy;
use fracbms::FracbmsCode::*;
use fracbms::*;

mod common;
use common::{core_settings, defaults, memory, record};

/// A cell in fresh memory (the memory must outlive the handle).
fn new_cell(mem: &mut Vec<u64>) -> *mut FracbmsCell {
    let (mut size, mut align) = (0, 0);
    assert_eq!(
        unsafe { fracbms_cell_size(256, 64, &mut size, &mut align) },
        FRACBMS_OK
    );
    *mem = memory(size);
    let mut cell = std::ptr::null_mut();
    let s = defaults();
    assert_eq!(
        unsafe { fracbms_cell_init(mem.as_mut_ptr().cast(), size, &s, &mut cell) },
        FRACBMS_OK
    );
    cell
}

fn push(cell: *mut FracbmsCell, i: f32, v: f32) -> FracbmsEstimate {
    let mut e = MaybeUninit::uninit();
    assert_eq!(
        unsafe { fracbms_cell_push(cell, i, v, e.as_mut_ptr()) },
        FRACBMS_OK
    );
    unsafe { e.assume_init() }
}

#[test]
fn a_snapshot_through_the_abi_is_the_cores_and_resumes_bit_for_bit() {
    let (i, v) = record();
    let cut = 600;
    let mut mem = vec![];
    let cell = new_cell(&mut mem);
    let cs = core_settings();
    let mut reference = Box::new(CellEstimator::<f32, 256, 64>::new(&cs).unwrap());
    for l in 0..cut {
        push(cell, i[l], v[l]);
        reference.push(&cs, i[l], v[l]);
    }
    let mut size = 0;
    assert_eq!(
        unsafe { fracbms_cell_snapshot_size(cell, &mut size) },
        FRACBMS_OK
    );
    assert_eq!(size, 148);
    let mut buf = vec![0u8; size];
    let mut written = 0;
    assert_eq!(
        unsafe { fracbms_cell_snapshot_save(cell, 600, buf.as_mut_ptr(), buf.len(), &mut written) },
        FRACBMS_OK
    );
    assert_eq!(written, 148);
    let mut core_bytes = vec![0u8; 148];
    reference.save(&cs, Some(600), &mut core_bytes).unwrap();
    assert_eq!(buf, core_bytes, "the ABI saves the core's bytes");

    // Restored after a "reset": the C cell and the core's run on alike.
    let mut mem2 = vec![];
    let restored = new_cell(&mut mem2);
    assert_eq!(
        unsafe { fracbms_cell_snapshot_restore(restored, buf.as_ptr(), buf.len(), 660, 0) },
        FRACBMS_OK
    );
    let mut core_restored = Box::new(CellEstimator::<f32, 256, 64>::new(&cs).unwrap());
    let policy = RestorePolicy {
        now_s: Some(660),
        ..RestorePolicy::default()
    };
    core_restored.restore(&cs, &buf, &policy).unwrap();
    let first = push(restored, i[cut], v[cut]);
    core_restored.push(&cs, i[cut], v[cut]);
    assert_eq!(
        first.restoration,
        FracbmsRestoration::FRACBMS_RESTORATION_RESTORED
    );
    assert_eq!(
        first.published.r_i_status,
        FracbmsIdentification::FRACBMS_IDENTIFICATION_RESTORED
    );
    let name = unsafe { std::ffi::CStr::from_ptr(fracbms_identification_name(5)) };
    assert_eq!(name.to_str().unwrap(), "restored");
    for l in cut + 1..i.len() {
        let e = push(restored, i[l], v[l]);
        let r = core_restored.push(&cs, i[l], v[l]);
        assert_eq!(e.status, r.status.into(), "sample {l}");
        let p = core_restored.estimate();
        assert_eq!(e.valid, p.is_some());
        if let Some(p) = p {
            assert_eq!(e.parameters, p.into(), "sample {l}");
        }
    }
}

#[test]
fn every_bad_snapshot_is_a_code_and_the_cell_stays_clean() {
    let (i, v) = record();
    let mut mem = vec![];
    let cell = new_cell(&mut mem);
    for l in 0..600 {
        push(cell, i[l], v[l]);
    }
    let mut good = vec![0u8; 148];
    let null = std::ptr::null_mut();
    assert_eq!(
        unsafe { fracbms_cell_snapshot_save(cell, 1000, good.as_mut_ptr(), 148, null) },
        FRACBMS_OK
    );
    let mut short = vec![0u8; 147];
    assert_eq!(
        unsafe { fracbms_cell_snapshot_save(cell, 1000, short.as_mut_ptr(), 147, null) },
        FRACBMS_ERROR_TOO_SMALL
    );
    assert_eq!(
        unsafe { fracbms_cell_snapshot_save(cell, 1000, null.cast(), 148, null) },
        FRACBMS_ERROR_NULL
    );
    let mut corrupt = good.clone();
    corrupt[30] ^= 1;
    let mut version = good.clone();
    version[4] = 9;
    let day = 24 * 3600;
    let cases: [(&str, &[u8], u32, u32, FracbmsCode); 6] = [
        (
            "corrupt",
            &corrupt,
            FRACBMS_TIME_UNKNOWN,
            0,
            FRACBMS_ERROR_SNAPSHOT_CRC,
        ),
        (
            "erased",
            &[0xFF; 148],
            FRACBMS_TIME_UNKNOWN,
            0,
            FRACBMS_ERROR_SNAPSHOT_INVALID,
        ),
        (
            "truncated",
            &good[..100],
            FRACBMS_TIME_UNKNOWN,
            0,
            FRACBMS_ERROR_SNAPSHOT_INVALID,
        ),
        (
            "another version",
            &version,
            FRACBMS_TIME_UNKNOWN,
            0,
            FRACBMS_ERROR_SNAPSHOT_VERSION,
        ),
        (
            "91 days old",
            &good,
            1000 + 91 * day,
            0,
            FRACBMS_ERROR_SNAPSHOT_STALE,
        ),
        (
            "older than asked",
            &good,
            1000 + 2 * day,
            day,
            FRACBMS_ERROR_SNAPSHOT_STALE,
        ),
    ];
    for (what, bytes, now, max_age, expected) in cases {
        let mut m = vec![];
        let c = new_cell(&mut m);
        assert_eq!(
            unsafe { fracbms_cell_snapshot_restore(c, bytes.as_ptr(), bytes.len(), now, max_age) },
            expected,
            "{what}"
        );
        let e = push(c, 0.0, 3.7);
        assert_eq!(
            e.restoration,
            FracbmsRestoration::FRACBMS_RESTORATION_CLEAN,
            "{what}"
        );
        assert!(e.published.r_i.is_nan(), "{what}");
        let msg = unsafe { std::ffi::CStr::from_ptr(fracbms_code_message(expected as i32)) };
        assert_ne!(msg.to_str().unwrap(), "unknown code", "{what}");
    }
    // Another pack size: a 4-cell pack takes no cell's snapshot.
    let s = defaults();
    let (mut size, mut align) = (0, 0);
    assert_eq!(
        unsafe { fracbms_pack_size(256, 64, 4, &mut size, &mut align) },
        FRACBMS_OK
    );
    let mut pm = memory(size);
    let mut pack = std::ptr::null_mut();
    assert_eq!(
        unsafe { fracbms_pack_init(pm.as_mut_ptr().cast(), size, &s, 4, 1, 1.5, &mut pack) },
        FRACBMS_OK
    );
    let mut psize = 0;
    assert_eq!(
        unsafe { fracbms_pack_snapshot_size(pack, &mut psize) },
        FRACBMS_OK
    );
    assert_eq!(psize, 20 + 4 * 124 + 4);
    assert_eq!(
        unsafe {
            fracbms_pack_snapshot_restore(pack, good.as_ptr(), good.len(), FRACBMS_TIME_UNKNOWN, 0)
        },
        FRACBMS_ERROR_CELL_COUNT
    );
    let mut four = vec![0u8; psize];
    assert_eq!(
        unsafe {
            fracbms_pack_snapshot_save(pack, FRACBMS_TIME_UNKNOWN, four.as_mut_ptr(), psize, null)
        },
        FRACBMS_OK
    );
    assert_eq!(
        unsafe {
            fracbms_pack_snapshot_restore(pack, four.as_ptr(), psize, FRACBMS_TIME_UNKNOWN, 0)
        },
        FRACBMS_OK
    );
}
