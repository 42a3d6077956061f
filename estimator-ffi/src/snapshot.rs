//! Snapshots over the C interface, for C teams that own their flash: the
//! size of a cell's or a pack's snapshot, saving it into caller memory and
//! restoring from it (`fracbms_{cell,pack}_snapshot_{size,save,restore}`).
//! The layout, its checks and the restore's judgement are the core's
//! (`estimator_core::battery::snapshot`; the layout table is in
//! docs/persistence.md), as in the firmware and `host-sim online
//! --state-in/--state-out`. This module only converts.

use estimator_core::battery::snapshot::RestorePolicy;

use crate::state::{self, SnapshotOp};
use crate::types::FracbmsCode;
use crate::{code, put, FracbmsCell, FracbmsPack};
use FracbmsCode::*;

/// `UINT32_MAX`: a time the caller does not know.
pub const FRACBMS_TIME_UNKNOWN: u32 = u32::MAX;

/// The caller's bytes as a slice.
///
/// # Safety
/// `buf` is null or valid for `len` bytes.
unsafe fn bytes<'a>(buf: *const u8, len: usize) -> Result<&'a [u8], FracbmsCode> {
    if buf.is_null() {
        return Err(FRACBMS_ERROR_NULL);
    }
    // SAFETY: non-null and valid for `len` bytes by the caller's contract.
    Ok(unsafe { core::slice::from_raw_parts(buf, len) })
}

/// The caller's bytes as a mutable slice.
///
/// # Safety
/// `buf` is null or valid for writes of `len` bytes.
unsafe fn bytes_mut<'a>(buf: *mut u8, len: usize) -> Result<&'a mut [u8], FracbmsCode> {
    if buf.is_null() {
        return Err(FRACBMS_ERROR_NULL);
    }
    // SAFETY: non-null and valid for `len` bytes by the caller's contract.
    Ok(unsafe { core::slice::from_raw_parts_mut(buf, len) })
}

/// The restore policy from the C arguments.
fn policy(now_s: u32, max_age_s: u32) -> RestorePolicy {
    RestorePolicy {
        now_s: (now_s != FRACBMS_TIME_UNKNOWN).then_some(now_s),
        max_age_s: if max_age_s == 0 {
            RestorePolicy::default().max_age_s
        } else {
            max_age_s
        },
        ..RestorePolicy::default()
    }
}

/// Which estimator a call is for.
enum Target {
    Cell(*mut u8),
    Pack(*mut u8),
}

/// Runs `op` on the target.
///
/// # Safety
/// The target's pointer is null or a state made by its `init`, not used
/// elsewhere during the call.
unsafe fn run(target: Target, op: SnapshotOp<'_>) -> Result<usize, FracbmsCode> {
    match target {
        // SAFETY: forwarded from the caller.
        Target::Cell(p) => unsafe { state::cell_snapshot(p, op) },
        // SAFETY: forwarded from the caller.
        Target::Pack(p) => unsafe { state::pack_snapshot(p, op) },
    }
}

/// `size`: the snapshot's size; `save`: into `buf`; `restore`: from it.
///
/// # Safety
/// As the public functions.
unsafe fn size(target: Target, size: *mut usize) -> FracbmsCode {
    // SAFETY: forwarded from the caller.
    match unsafe { run(target, SnapshotOp::Size) } {
        // SAFETY: forwarded from the caller.
        Ok(n) => code(unsafe { put(size, n) }),
        Err(c) => c,
    }
}

/// # Safety
/// As the public functions.
unsafe fn save(
    target: Target,
    saved_at_s: u32,
    buf: *mut u8,
    len: usize,
    written: *mut usize,
) -> FracbmsCode {
    // SAFETY: forwarded from the caller.
    let out = match unsafe { bytes_mut(buf, len) } {
        Ok(b) => b,
        Err(c) => return c,
    };
    let at = (saved_at_s != FRACBMS_TIME_UNKNOWN).then_some(saved_at_s);
    // SAFETY: forwarded from the caller.
    match unsafe { run(target, SnapshotOp::Save(at, out)) } {
        Ok(n) if !written.is_null() => {
            // SAFETY: non-null, valid by the caller's contract.
            code(unsafe { put(written, n) })
        }
        Ok(_) => FRACBMS_OK,
        Err(c) => c,
    }
}

/// # Safety
/// As the public functions.
unsafe fn restore(
    target: Target,
    buf: *const u8,
    len: usize,
    now_s: u32,
    max_age_s: u32,
) -> FracbmsCode {
    // SAFETY: forwarded from the caller.
    let input = match unsafe { bytes(buf, len) } {
        Ok(b) => b,
        Err(c) => return c,
    };
    // SAFETY: forwarded from the caller.
    code(unsafe { run(target, SnapshotOp::Restore(input, policy(now_s, max_age_s))) }.map(|_| ()))
}

/// Writes to `size_out` the bytes of this cell's snapshot (148; 188 when its
/// settings' `slow_memory_s` is above 0, the slow part kept too).
///
/// # Safety
/// `cell` is null or a handle from `fracbms_cell_init`; `size_out` is null or
/// valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fracbms_cell_snapshot_size(
    cell: *const FracbmsCell,
    size_out: *mut usize,
) -> FracbmsCode {
    // SAFETY: forwarded from the caller; `Size` does not write the cell.
    unsafe { size(Target::Cell(cell.cast_mut().cast()), size_out) }
}

/// Writes what the cell has learned into `buf` (`len` bytes, at least
/// `fracbms_cell_snapshot_size`) and the bytes written to `written` (may
/// be null). `saved_at_s` is the caller's clock (s; `FRACBMS_TIME_UNKNOWN`
/// without one), judged at restore. `FRACBMS_ERROR_TOO_SMALL` (nothing
/// written) for a short buffer. No allocation.
///
/// # Safety
/// `cell` as in `fracbms_cell_snapshot_size`; `buf` is null or valid for
/// writes of `len` bytes; `written` is null or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fracbms_cell_snapshot_save(
    cell: *const FracbmsCell,
    saved_at_s: u32,
    buf: *mut u8,
    len: usize,
    written: *mut usize,
) -> FracbmsCode {
    // SAFETY: forwarded from the caller; `Save` does not write the cell.
    unsafe {
        save(
            Target::Cell(cell.cast_mut().cast()),
            saved_at_s,
            buf,
            len,
            written,
        )
    }
}

/// Restores a cell from a snapshot in `buf` (`len` bytes), before its
/// first sample: its magic, version, CRC, cell count and settings are
/// checked, its age against `now_s` (`FRACBMS_TIME_UNKNOWN`: not judged)
/// and `max_age_s` (0: 90 days), and its values. On an error
/// (`FRACBMS_ERROR_SNAPSHOT_*`, `FRACBMS_ERROR_CELL_COUNT`) nothing is
/// changed: the cell starts clean. The restored parameters are published
/// as `FRACBMS_IDENTIFICATION_RESTORED` until a window identifies them;
/// the estimate's `restoration` says whether the stored SOC stood against
/// the first rested voltage.
///
/// # Safety
/// `cell` is null or a handle from `fracbms_cell_init`, not used elsewhere
/// during the call; `buf` is null or valid for reads of `len` bytes.
#[no_mangle]
pub unsafe extern "C" fn fracbms_cell_snapshot_restore(
    cell: *mut FracbmsCell,
    buf: *const u8,
    len: usize,
    now_s: u32,
    max_age_s: u32,
) -> FracbmsCode {
    // SAFETY: forwarded from the caller.
    unsafe { restore(Target::Cell(cell.cast()), buf, len, now_s, max_age_s) }
}

/// Writes to `size_out` the bytes of this pack's snapshot (24 and 124 per
/// cell: 2008 for 16 cells; 164 per cell, 2648 for 16, when its settings'
/// `slow_memory_s` is above 0, the slow part kept too).
///
/// # Safety
/// `pack` is null or a handle from `fracbms_pack_init`; `size_out` is null or
/// valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fracbms_pack_snapshot_size(
    pack: *const FracbmsPack,
    size_out: *mut usize,
) -> FracbmsCode {
    // SAFETY: forwarded from the caller; `Size` does not write the pack.
    unsafe { size(Target::Pack(pack.cast_mut().cast()), size_out) }
}

/// As `fracbms_cell_snapshot_save`, for every cell of a pack and the
/// position of its update schedule.
///
/// # Safety
/// As `fracbms_cell_snapshot_save`, with a handle from `fracbms_pack_init`.
#[no_mangle]
pub unsafe extern "C" fn fracbms_pack_snapshot_save(
    pack: *const FracbmsPack,
    saved_at_s: u32,
    buf: *mut u8,
    len: usize,
    written: *mut usize,
) -> FracbmsCode {
    // SAFETY: forwarded from the caller; `Save` does not write the pack.
    unsafe {
        save(
            Target::Pack(pack.cast_mut().cast()),
            saved_at_s,
            buf,
            len,
            written,
        )
    }
}

/// As `fracbms_cell_snapshot_restore`, for a pack (the snapshot's cell
/// count must be the pack's).
///
/// # Safety
/// As `fracbms_cell_snapshot_restore`, with a handle from
/// `fracbms_pack_init`.
#[no_mangle]
pub unsafe extern "C" fn fracbms_pack_snapshot_restore(
    pack: *mut FracbmsPack,
    buf: *const u8,
    len: usize,
    now_s: u32,
    max_age_s: u32,
) -> FracbmsCode {
    // SAFETY: forwarded from the caller.
    unsafe { restore(Target::Pack(pack.cast()), buf, len, now_s, max_age_s) }
}
