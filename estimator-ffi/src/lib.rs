//! # fracbms C ABI
//!
//! The fracbms estimator for C firmware and C host programs: the
//! single-cell online estimator, the pack estimator (every series cell of
//! a pack sharing one current), the OCV table, and on the host the
//! whole-record identification of `host-sim identify battery`. Every call
//! goes to the same functions of `estimator-core` (and `fracbms-host`) as the
//! Rust faces.
//!
//! It is a thin adapter and must not hold numerics of its own: a new
//! capability lands in `estimator-core` (or, for whole records, in
//! `fracbms-host`) first, and is only converted here.
//!
//! The header `include/fracbms.h` is generated from this crate by
//! `cargo xtask header` (cbindgen); `docs/c-abi.md` is the guide.
//!
//! ## Where the state lives
//!
//! The caller owns the memory. Ask its size and alignment
//! (`fracbms_cell_size`, `fracbms_pack_size`), give a static buffer to
//! `init`, and pass the returned handle to every later call. No heap, no
//! global state, no locks: one state is used by one context at a time.
//!
//! ## Errors and statuses
//!
//! Every function returns a [`FracbmsCode`]; nothing panics across the
//! boundary (the bare-metal library's panic handler halts, and no valid
//! call is known to reach it, though the remaining index checks are not
//! yet proven unreachable: docs/c-abi.md; on the host an unwinding panic aborts at the
//! `extern "C"` boundary, and the whole-record fit catches its own). A
//! pushed sample always returns `FRACBMS_OK` with a [`FracbmsStatus`] and a
//! [`FracbmsRejection`] in the estimate: a bad sample is data, not an
//! error.
//!
//! ```
//! use fracbms::*;
//! let mut s = core::mem::MaybeUninit::<FracbmsSettings>::uninit();
//! assert_eq!(unsafe { fracbms_settings_default(1.0, s.as_mut_ptr()) }, FracbmsCode::FRACBMS_OK);
//! let s = unsafe { s.assume_init() };
//! let (mut size, mut align) = (0usize, 0usize);
//! assert_eq!(unsafe { fracbms_cell_size(256, 64, &mut size, &mut align) }, FracbmsCode::FRACBMS_OK);
//! let mut memory = vec![0u64; size.div_ceil(8)]; // 8-byte aligned
//! assert!(align <= 8);
//! let mut cell = core::ptr::null_mut();
//! let code = unsafe { fracbms_cell_init(memory.as_mut_ptr().cast(), size, &s, &mut cell) };
//! assert_eq!(code, FracbmsCode::FRACBMS_OK);
//! let mut e = core::mem::MaybeUninit::<FracbmsEstimate>::uninit();
//! assert_eq!(unsafe { fracbms_cell_push(cell, f32::NAN, 3.7, e.as_mut_ptr()) }, FracbmsCode::FRACBMS_OK);
//! let e = unsafe { e.assume_init() };
//! assert_eq!(e.rejection, FracbmsRejection::FRACBMS_REJECTION_NON_FINITE);
//! assert_eq!(e.rejected, 1);
//! ```
#![cfg_attr(target_os = "none", no_std)]
#![deny(unsafe_op_in_unsafe_fn)]
#![deny(missing_docs)]
#![allow(non_camel_case_types)]

use core::ffi::c_char;

#[cfg(not(target_os = "none"))]
mod identify;
mod map;
mod power;
mod snapshot;
mod soc;
mod state;
mod types;

#[cfg(not(target_os = "none"))]
pub use identify::{FracbmsFit, FracbmsIdentifyOptions};
pub use map::{fracbms_cell_follow_map, fracbms_cell_set_prior, fracbms_map_cell_at};
pub use map::{FracbmsMapLevel, FRACBMS_MAP_LEVELS_MAX};
pub use power::{FracbmsHorizonPower, FracbmsPower, FracbmsPowerRequest, FRACBMS_HORIZONS_MAX};
pub use snapshot::{
    fracbms_cell_snapshot_restore, fracbms_cell_snapshot_save, fracbms_cell_snapshot_size,
    fracbms_pack_snapshot_restore, fracbms_pack_snapshot_save, fracbms_pack_snapshot_size,
    FRACBMS_TIME_UNKNOWN,
};
pub use soc::{
    fracbms_cell_init_with_soc, fracbms_pack_init_with_soc, fracbms_soc_settings_default,
    FracbmsSocSettings,
};
pub use types::{
    FracbmsCode, FracbmsEstimate, FracbmsIdentification, FracbmsMethod, FracbmsModel,
    FracbmsParameters, FracbmsPublished, FracbmsRejection, FracbmsRestoration, FracbmsSettings,
    FracbmsSoc, FracbmsStatus, FracbmsVoltageTiming, FRACBMS_OCV_POINTS_MAX,
};

use state::{CellOp, PackOp, PackOut};
use types::FracbmsCode::*;

/// A cell's online estimator, in memory the caller placed
/// (`fracbms_cell_init`). Opaque.
pub struct FracbmsCell {
    _private: [u8; 0],
}

/// A pack's estimator, in memory the caller placed (`fracbms_pack_init`).
/// Opaque.
pub struct FracbmsPack {
    _private: [u8; 0],
}

/// What one sample period did to a pack.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FracbmsPackReport {
    /// Cells whose sample was rejected this period.
    pub rejected: u16,
    /// Cells updated this period.
    pub updated: u16,
    /// Iterations run this period (all cells).
    pub iterations: u32,
}

fn code(r: Result<(), FracbmsCode>) -> FracbmsCode {
    r.err().unwrap_or(FRACBMS_OK)
}

/// Writes `value` through `out` when it is not null.
///
/// # Safety
/// `out` is null or valid for a write of `T`.
unsafe fn put<T>(out: *mut T, value: T) -> Result<(), FracbmsCode> {
    if out.is_null() {
        return Err(FRACBMS_ERROR_NULL);
    }
    // SAFETY: non-null and valid for writes by the caller's contract.
    unsafe { out.write(value) };
    Ok(())
}

/// Fills `out` with the Rust firmware's defaults for sample period `h`
/// (s): window 256, memory 64, the refined method with one iteration per
/// sample, the cell at rest at power-up, the linear model without the
/// short-memory correction, an 18650-class initial estimate, `|I| ≤ 500 A`,
/// `U_t` within `[1.5, 5] V`, no OCV table.
///
/// # Safety
/// `out` is null or valid for a write of a `FracbmsSettings`.
#[no_mangle]
pub unsafe extern "C" fn fracbms_settings_default(
    h: f32,
    out: *mut FracbmsSettings,
) -> FracbmsCode {
    // SAFETY: forwarded from the caller.
    code(unsafe { put(out, types::default_settings(h)) })
}

/// The size and alignment (bytes) of a cell's state for window `window`
/// and memory `memory`.
///
/// # Safety
/// `size` and `align` are null or valid for a write of a `size_t`.
#[no_mangle]
pub unsafe extern "C" fn fracbms_cell_size(
    window: u16,
    memory: u16,
    size: *mut usize,
    align: *mut usize,
) -> FracbmsCode {
    if size.is_null() || align.is_null() {
        return FRACBMS_ERROR_NULL;
    }
    let Some((s, a)) = state::cell_layout(window, memory) else {
        return FRACBMS_ERROR_UNSUPPORTED_SIZE;
    };
    // SAFETY: both checked non-null; valid by the caller's contract.
    code(unsafe { put(size, s).and_then(|()| put(align, a)) })
}

/// Builds a cell's estimator in `memory` (`size` bytes, aligned as
/// `fracbms_cell_size` reported) with `settings`, and returns its handle
/// in `cell`. The OCV table is copied: its arrays may go after the call.
/// The estimator is built on the stack and moved into `memory`: the call
/// needs a deep stack once (72 KB measured at window 256, docs/c-abi.md).
///
/// # Safety
/// `memory` is null or valid for writes of `size` bytes, and not used for
/// anything else while the cell lives; `settings` and `cell` are null or
/// valid; the OCV arrays hold `ocv_points` values.
#[no_mangle]
pub unsafe extern "C" fn fracbms_cell_init(
    memory: *mut core::ffi::c_void,
    size: usize,
    settings: *const FracbmsSettings,
    cell: *mut *mut FracbmsCell,
) -> FracbmsCode {
    // SAFETY: forwarded from the caller; no SOC settings (the defaults).
    unsafe { fracbms_cell_init_with_soc(memory, size, settings, core::ptr::null(), cell) }
}

/// Pushes one sample (current in A, positive when charging; terminal
/// voltage in V) into a cell and runs its iterations; writes the status
/// and the estimate after it to `estimate` (may be null). A bad sample is
/// rejected, counted and substituted: the call still returns `FRACBMS_OK`,
/// with the rejection in `estimate`.
///
/// # Safety
/// `cell` is null or a handle from `fracbms_cell_init` whose memory is
/// still the cell's, not used by another context during the call;
/// `estimate` is null or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fracbms_cell_push(
    cell: *mut FracbmsCell,
    current_a: f32,
    voltage_v: f32,
    estimate: *mut FracbmsEstimate,
) -> FracbmsCode {
    // SAFETY: forwarded from the caller.
    match unsafe { state::cell_op(cell.cast(), CellOp::Push(current_a, voltage_v)) } {
        Ok(e) if !estimate.is_null() => {
            // SAFETY: non-null, valid by the caller's contract.
            code(unsafe { put(estimate, e) })
        }
        Ok(_) => FRACBMS_OK,
        Err(c) => c,
    }
}

/// Writes a cell's current estimate (after its last sample) to `estimate`.
///
/// # Safety
/// As `fracbms_cell_push`.
#[no_mangle]
pub unsafe extern "C" fn fracbms_cell_estimate(
    cell: *const FracbmsCell,
    estimate: *mut FracbmsEstimate,
) -> FracbmsCode {
    // SAFETY: forwarded from the caller; `Read` does not write the cell.
    match unsafe { state::cell_op(cell.cast_mut().cast(), CellOp::Read) } {
        // SAFETY: forwarded from the caller.
        Ok(e) => code(unsafe { put(estimate, e) }),
        Err(c) => c,
    }
}

/// Sets a cell's state of charge now (with an OCV table; e.g. from the
/// BMS's own estimate), before its next sample. Without a call, the first
/// samples' rested voltage gives it through the inverse OCV curve.
///
/// # Safety
/// As `fracbms_cell_push`.
#[no_mangle]
pub unsafe extern "C" fn fracbms_cell_set_state_of_charge(
    cell: *mut FracbmsCell,
    soc: f32,
) -> FracbmsCode {
    // SAFETY: forwarded from the caller.
    code(unsafe { state::cell_op(cell.cast(), CellOp::SetSoc(soc)) }.map(|_| ()))
}

/// Writes a cell's state of power now (after its last sample) for
/// `request` to `power`: at each horizon the largest constant discharge
/// and charge currents that keep the predicted voltage within the limits,
/// and the request's pulse voltage at its end (the core's
/// `CellEstimator::state_of_power`, as `host-sim online battery`'s
/// `sop_*`/`pulse_v_*` columns). `power->published` is false where the
/// model is not published (a parameter not identified) or its present
/// polarization is not known yet.
///
/// # Safety
/// As `fracbms_cell_push`; `request` is null or valid for a read, `power`
/// null or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fracbms_cell_state_of_power(
    cell: *const FracbmsCell,
    request: *const FracbmsPowerRequest,
    power: *mut FracbmsPower,
) -> FracbmsCode {
    if request.is_null() {
        return FRACBMS_ERROR_NULL;
    }
    // SAFETY: non-null and valid for a read by the caller's contract.
    let req = unsafe { request.read() };
    // SAFETY: forwarded from the caller; read only.
    match unsafe { state::cell_power(cell.cast(), &req) } {
        // SAFETY: forwarded from the caller.
        Ok(p) => code(unsafe { put(power, p) }),
        Err(c) => c,
    }
}

/// The size and alignment (bytes) of a pack's state for window `window`,
/// memory `memory` and `cells` cells (1 to 16; the state has room for 4, 8
/// or 16 cells, the next at or above `cells`).
///
/// # Safety
/// `size` and `align` are null or valid for a write of a `size_t`.
#[no_mangle]
pub unsafe extern "C" fn fracbms_pack_size(
    window: u16,
    memory: u16,
    cells: u16,
    size: *mut usize,
    align: *mut usize,
) -> FracbmsCode {
    if size.is_null() || align.is_null() {
        return FRACBMS_ERROR_NULL;
    }
    if state::pack_room(cells) == 0 {
        return FRACBMS_ERROR_CELL_COUNT;
    }
    let Some((s, a)) = state::pack_layout(window, memory, cells) else {
        return FRACBMS_ERROR_UNSUPPORTED_SIZE;
    };
    // SAFETY: both checked non-null; valid by the caller's contract.
    code(unsafe { put(size, s).and_then(|()| put(align, a)) })
}

/// Builds a pack of `cells` series cells in `memory` (`size` bytes,
/// aligned as `fracbms_pack_size` reported): every cell runs `settings`;
/// `updates_per_period` cells are updated per period, round robin (at
/// least 1; `cells` or more updates every cell every period); a cell is
/// flagged when its `R_i` or `R_ct` is above the pack's median by more than
/// `flag_ratio` (0.3: 30 %).
///
/// # Safety
/// As `fracbms_cell_init`, with `pack` for the handle.
#[no_mangle]
pub unsafe extern "C" fn fracbms_pack_init(
    memory: *mut core::ffi::c_void,
    size: usize,
    settings: *const FracbmsSettings,
    cells: u16,
    updates_per_period: u16,
    flag_ratio: f32,
    pack: *mut *mut FracbmsPack,
) -> FracbmsCode {
    // SAFETY: forwarded from the caller; no SOC settings (the defaults).
    unsafe {
        fracbms_pack_init_with_soc(
            memory,
            size,
            settings,
            core::ptr::null(),
            cells,
            updates_per_period,
            flag_ratio,
            pack,
        )
    }
}

/// Pushes one sample period into a pack: the pack's current (A, positive
/// when charging) and `cells` voltages (V, cell 1 first), then runs the
/// period's scheduled cell updates; writes what it did to `report` (may be
/// null). Per-cell outcomes: `fracbms_pack_cell`.
///
/// # Safety
/// `pack` is null or a handle from `fracbms_pack_init` (as for a cell);
/// `voltages` is null or holds `cells` values; `report` is null or valid.
#[no_mangle]
pub unsafe extern "C" fn fracbms_pack_push(
    pack: *mut FracbmsPack,
    current_a: f32,
    voltages: *const f32,
    cells: u16,
    report: *mut FracbmsPackReport,
) -> FracbmsCode {
    if voltages.is_null() {
        return FRACBMS_ERROR_NULL;
    }
    // SAFETY: non-null; holds `cells` values by the caller's contract.
    let v = unsafe { core::slice::from_raw_parts(voltages, usize::from(cells)) };
    // SAFETY: forwarded from the caller.
    match unsafe { state::pack_op(pack.cast(), PackOp::Push(current_a, v)) } {
        Ok(PackOut::Pushed(rejected, updated, iterations)) if !report.is_null() => {
            let r = FracbmsPackReport {
                rejected,
                updated,
                iterations,
            };
            // SAFETY: non-null, valid by the caller's contract.
            code(unsafe { put(report, r) })
        }
        Ok(_) => FRACBMS_OK,
        Err(c) => c,
    }
}

/// Writes cell `k`'s (0-based) estimate after the last period to
/// `estimate`, with `flagged` set when it stands out of the pack.
///
/// # Safety
/// As `fracbms_pack_push`; `estimate` is null or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fracbms_pack_cell(
    pack: *const FracbmsPack,
    k: u16,
    estimate: *mut FracbmsEstimate,
) -> FracbmsCode {
    // SAFETY: forwarded from the caller; `Read` does not write the pack.
    match unsafe { state::pack_op(pack.cast_mut().cast(), PackOp::Read(usize::from(k))) } {
        // SAFETY: forwarded from the caller.
        Ok(PackOut::Cell(e)) => code(unsafe { put(estimate, e) }),
        Ok(PackOut::Pushed(..)) => FRACBMS_ERROR_NOT_INITIALIZED,
        Err(c) => c,
    }
}

/// Writes a pack's state of power now for `request` to `power`: cell
/// `k`'s (0-based), or for `k` = `FRACBMS_PACK_STRING` the string's: at
/// each horizon the weakest cell's currents (one current flows through a
/// series string) and the sum of the cells' pulse voltages; not published
/// while any cell's is not.
///
/// # Safety
/// As `fracbms_pack_push`; `request` is null or valid for a read, `power`
/// null or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fracbms_pack_state_of_power(
    pack: *const FracbmsPack,
    k: u16,
    request: *const FracbmsPowerRequest,
    power: *mut FracbmsPower,
) -> FracbmsCode {
    if request.is_null() {
        return FRACBMS_ERROR_NULL;
    }
    // SAFETY: non-null and valid for a read by the caller's contract.
    let req = unsafe { request.read() };
    let cell = (k != FRACBMS_PACK_STRING).then_some(usize::from(k));
    // SAFETY: forwarded from the caller; read only.
    match unsafe { state::pack_power(pack.cast(), cell, &req) } {
        // SAFETY: forwarded from the caller.
        Ok(p) => code(unsafe { put(power, p) }),
        Err(c) => c,
    }
}

/// The cell index `fracbms_pack_state_of_power` takes for the whole
/// string.
pub const FRACBMS_PACK_STRING: u16 = u16::MAX;

/// The number of cells of a pack (0 for a null or uninitialized handle).
///
/// # Safety
/// As `fracbms_pack_push`.
#[no_mangle]
pub unsafe extern "C" fn fracbms_pack_cells(pack: *const FracbmsPack) -> u16 {
    // SAFETY: forwarded from the caller.
    unsafe { state::pack_cells(pack.cast()) }.map_or(0, |n| n as u16)
}

/// A `FracbmsStatus`'s name as `host-sim online battery` writes it
/// (`"tracking"`, ...; `"unknown"` for another value), NUL-terminated and
/// static.
#[no_mangle]
pub extern "C" fn fracbms_status_name(status: i32) -> *const c_char {
    use estimator_core::battery::online::Status;
    let Some(status) = FracbmsStatus::core(status) else {
        return c"unknown".as_ptr();
    };
    let name: &'static core::ffi::CStr = match status {
        Status::Filling => c"filling",
        Status::Starting => c"starting",
        Status::Tracking => c"tracking",
        Status::NotExcited => c"not_excited",
        Status::Held => c"held",
        Status::Unphysical => c"unphysical",
        Status::AtBound => c"at_bound",
        Status::SlowRelaxation => c"slow_relaxation",
        Status::OcvImplausible => c"ocv_implausible",
    };
    name.as_ptr()
}

/// A `FracbmsIdentification`'s name as `host-sim online battery` writes it
/// in its `*_status` columns (`"unknown"` for another value),
/// NUL-terminated and static.
#[no_mangle]
pub extern "C" fn fracbms_identification_name(status: i32) -> *const c_char {
    use estimator_core::battery::online::Identification;
    let name: &'static core::ffi::CStr = match FracbmsIdentification::core(status) {
        None => c"unknown",
        Some(Identification::NotIdentified) => c"not_identified",
        Some(Identification::Identified) => c"identified",
        Some(Identification::Held) => c"held",
        Some(Identification::Step) => c"step",
        Some(Identification::Expired) => c"expired",
        Some(Identification::Restored) => c"restored",
        Some(Identification::Prior) => c"prior",
    };
    name.as_ptr()
}

/// A `FracbmsCode`'s meaning in a few words (`"unknown code"` for another
/// value), NUL-terminated and static.
#[no_mangle]
pub extern "C" fn fracbms_code_message(code: i32) -> *const c_char {
    let all = [
        FRACBMS_OK,
        FRACBMS_ERROR_NULL,
        FRACBMS_ERROR_MISALIGNED,
        FRACBMS_ERROR_TOO_SMALL,
        FRACBMS_ERROR_UNSUPPORTED_SIZE,
        FRACBMS_ERROR_SETTINGS,
        FRACBMS_ERROR_OCV,
        FRACBMS_ERROR_NOT_INITIALIZED,
        FRACBMS_ERROR_CELL_COUNT,
        FRACBMS_ERROR_DATA,
        FRACBMS_ERROR_FIT,
        FRACBMS_ERROR_MAP,
        FRACBMS_ERROR_SNAPSHOT_INVALID,
        FRACBMS_ERROR_SNAPSHOT_CRC,
        FRACBMS_ERROR_SNAPSHOT_VERSION,
        FRACBMS_ERROR_SNAPSHOT_SETTINGS,
        FRACBMS_ERROR_SNAPSHOT_STALE,
        FRACBMS_ERROR_SNAPSHOT_IMPLAUSIBLE,
    ];
    let Some(code) = all.into_iter().find(|c| *c as i32 == code) else {
        return c"unknown code".as_ptr();
    };
    let m: &'static core::ffi::CStr = match code {
        FRACBMS_OK => c"ok",
        FRACBMS_ERROR_NULL => c"a pointer argument is null",
        FRACBMS_ERROR_MISALIGNED => c"the memory is not aligned as reported",
        FRACBMS_ERROR_TOO_SMALL => c"the memory is smaller than reported",
        FRACBMS_ERROR_UNSUPPORTED_SIZE => c"window or memory not built into the library",
        FRACBMS_ERROR_SETTINGS => c"a setting is out of range",
        FRACBMS_ERROR_OCV => c"the OCV table or capacity is invalid",
        FRACBMS_ERROR_NOT_INITIALIZED => c"the state was not made by init",
        FRACBMS_ERROR_CELL_COUNT => c"cell count or index out of range",
        FRACBMS_ERROR_DATA => c"the record is unusable",
        FRACBMS_ERROR_FIT => c"the fit failed",
        FRACBMS_ERROR_MAP => c"the parameter map is invalid",
        FRACBMS_ERROR_SNAPSHOT_INVALID => c"not a snapshot, or truncated",
        FRACBMS_ERROR_SNAPSHOT_CRC => c"the snapshot is corrupt (CRC)",
        FRACBMS_ERROR_SNAPSHOT_VERSION => c"the snapshot is from another layout version",
        FRACBMS_ERROR_SNAPSHOT_SETTINGS => c"the snapshot was written under other settings",
        FRACBMS_ERROR_SNAPSHOT_STALE => c"the snapshot is stale",
        FRACBMS_ERROR_SNAPSHOT_IMPLAUSIBLE => c"the snapshot holds implausible values",
    };
    m.as_ptr()
}

/// Fills `out` with the defaults of `host-sim identify battery`: refined,
/// `FRACBMS_MODEL_AUTO`, 50 iterations, no OCV table. Host only.
///
/// # Safety
/// `out` is null or valid for a write.
#[cfg(not(target_os = "none"))]
#[no_mangle]
pub unsafe extern "C" fn fracbms_identify_options_default(
    out: *mut FracbmsIdentifyOptions,
) -> FracbmsCode {
    // SAFETY: forwarded from the caller.
    code(unsafe { put(out, identify::default_options()) })
}

/// Identifies a whole record (`rows` samples; current positive when
/// charging) as `host-sim identify battery` does, with the same code: the
/// result has its JSON's keys. Bad rows (a NaN or implausible current or
/// voltage, a voltage spike) are rejected, substituted and counted in
/// `fit->rejected`, as the CLI and Python do; rows marked in
/// `options->unobserved` are counted in no fit. `options` may be null (the
/// defaults). On an error `fit->message` holds the CLI's one-line message.
/// Host only (the fit allocates).
///
/// # Safety
/// The three arrays hold `rows` values; `options` is null or valid, its OCV
/// arrays hold `ocv_points` values and its `unobserved` is null or holds
/// `rows` values; `fit` is valid for a write.
#[cfg(not(target_os = "none"))]
#[no_mangle]
pub unsafe extern "C" fn fracbms_identify_battery(
    time_s: *const f64,
    current_a: *const f64,
    voltage_v: *const f64,
    rows: usize,
    options: *const FracbmsIdentifyOptions,
    fit: *mut FracbmsFit,
) -> FracbmsCode {
    if time_s.is_null() || current_a.is_null() || voltage_v.is_null() || fit.is_null() {
        return FRACBMS_ERROR_NULL;
    }
    let o = if options.is_null() {
        identify::default_options()
    } else {
        // SAFETY: non-null, valid by the caller's contract.
        unsafe { *options }
    };
    let n = o.ocv_points as usize;
    if n > 0 && (o.ocv_soc.is_null() || o.ocv_v.is_null()) {
        return FRACBMS_ERROR_NULL;
    }
    // SAFETY: non-null; the caller guarantees the lengths.
    let (t, i, v, ocv) = unsafe {
        (
            core::slice::from_raw_parts(time_s, rows),
            core::slice::from_raw_parts(current_a, rows),
            core::slice::from_raw_parts(voltage_v, rows),
            (n > 0).then(|| {
                (
                    core::slice::from_raw_parts(o.ocv_soc, n),
                    core::slice::from_raw_parts(o.ocv_v, n),
                )
            }),
        )
    };
    let unobserved: Vec<bool> = if o.unobserved.is_null() {
        vec![]
    } else {
        // SAFETY: non-null; the caller guarantees `rows` values.
        unsafe { core::slice::from_raw_parts(o.unobserved, rows) }
            .iter()
            .map(|&m| m != 0)
            .collect()
    };
    // SAFETY: non-null, valid for a write by the caller's contract.
    let fit = unsafe { &mut *fit };
    identify::identify(t, i, v, &unobserved, ocv, &o, fit)
}

/// The bare-metal library's panic handler: halts. No valid call is known
/// to reach it (every input is checked and every error is a code; the
/// index checks left in the image are not yet proven unreachable); a
/// firmware's watchdog resets the MCU if one ever did.
#[cfg(all(target_os = "none", feature = "panic-handler"))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {
        core::hint::spin_loop();
    }
}
