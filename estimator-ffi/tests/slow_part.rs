//! The slow part carried across windows through the C ABI
//! (`FracbmsSettings::slow_memory_s`, `slow_memory_soc`).

use std::mem::MaybeUninit;

use estimator_core::battery::online::CellEstimator;
use fracbms::FracbmsCode::*;
use fracbms::*;

mod common;
use common::{cell_memory, core_settings, defaults, record, same_published};

/// The slow part carried across windows (`slow_memory_s`) reaches C: what
/// the cell publishes is the core's, bit for bit, and on the pulse record
/// it is not each window's own; its snapshot is the core's, slow part
/// included.
#[test]
fn the_slow_part_through_the_abi_is_the_cores_bit_for_bit() {
    let (i, v) = record();
    let mut s = defaults();
    assert_eq!((s.slow_memory_s, s.slow_memory_soc), (0.0, 0.02));
    s.slow_memory_s = 600.0;
    let (mut mem, size) = cell_memory();
    let mut cell = std::ptr::null_mut();
    assert_eq!(
        unsafe { fracbms_cell_init(mem.as_mut_ptr().cast(), size, &s, &mut cell) },
        FRACBMS_OK
    );
    let mut cs = core_settings();
    cs.slow_memory_s = 600.0;
    let mut reference = Box::new(CellEstimator::<f32, 256, 64>::new(&cs).unwrap());
    let mut own = Box::new(CellEstimator::<f32, 256, 64>::new(&core_settings()).unwrap());
    let mut e = MaybeUninit::<FracbmsEstimate>::uninit();
    let mut moved = 0;
    for (&i, &v) in i.iter().zip(&v) {
        assert_eq!(
            unsafe { fracbms_cell_push(cell, i, v, e.as_mut_ptr()) },
            FRACBMS_OK
        );
        reference.push(&cs, i, v);
        own.push(&core_settings(), i, v);
        let e = unsafe { e.assume_init() };
        same_published(&e.published, &reference.published().into());
        let (a, b) = (reference.published().q.value, own.published().q.value);
        moved += usize::from(a.is_some() && a != b);
    }
    println!("published Q other than the window's own at {moved} of 1000 samples");
    assert!(moved > 100, "{moved}");
    // Its snapshot keeps the slow part (188 B): the core's bytes.
    let mut size = 0usize;
    assert_eq!(
        unsafe { fracbms_cell_snapshot_size(cell, &mut size) },
        FRACBMS_OK
    );
    assert_eq!(size, 188);
    let (mut buf, mut written) = (vec![0u8; size], 0usize);
    let saved = unsafe {
        fracbms_cell_snapshot_save(
            cell,
            FRACBMS_TIME_UNKNOWN,
            buf.as_mut_ptr(),
            size,
            &mut written,
        )
    };
    assert_eq!((saved, written), (FRACBMS_OK, size));
    let mut core = vec![0u8; reference.snapshot_size()];
    assert_eq!(reference.save(&cs, None, &mut core), Ok(size));
    assert_eq!(buf, core);
}
