//! The estimators in caller-placed memory: the cell (`FracbmsCell`, the
//! core's `CellEstimator`) and the pack (`FracbmsPack`, the core's
//! `PackEstimator`), each with its settings beside it and a header that
//! names its sizes. This module owns the layout of that memory and the
//! sizes built in; the estimation itself is the core's.

use core::mem::{align_of, size_of};

use estimator_core::battery::map::{MapFollower, ParameterMap};
use estimator_core::battery::online::{CellEstimator, CellState, SampleReport};
use estimator_core::battery::pack::{PackEstimator, PackSettings};
use estimator_core::battery::snapshot::{RestorePolicy, SnapshotError};
use estimator_core::battery::Prior;

use crate::power::{FracbmsPower, FracbmsPowerRequest};
use crate::types::{
    FracbmsCode, FracbmsEstimate, FracbmsParameters, FracbmsSoc, Settings, FRACBMS_OCV_POINTS_MAX,
};

/// Written at the start of a cell's memory by `init`.
const CELL_MAGIC: u32 = 0x4652_4331; // "FRC1"
/// Written at the start of a pack's memory by `init`.
const PACK_MAGIC: u32 = 0x4652_5031; // "FRP1"

/// What every state begins with: which `init` made it, and its sizes.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct Header {
    pub magic: u32,
    pub window: u16,
    pub capacity: u16,
}

/// A cell in caller memory.
#[repr(C)]
pub(crate) struct CellSlot<const N: usize, const MEM: usize> {
    header: Header,
    settings: Settings,
    cell: CellEstimator<f32, N, MEM>,
    /// Where a followed map's prior was last taken.
    follower: MapFollower<f32>,
}

/// A pack in caller memory (room for `CELLS` cells).
#[repr(C)]
pub(crate) struct PackSlot<const N: usize, const MEM: usize, const CELLS: usize> {
    header: Header,
    settings: PackSettings<f32, FRACBMS_OCV_POINTS_MAX>,
    pack: PackEstimator<f32, N, MEM, CELLS>,
}

/// Calls `$f::<N, MEM>($args)` for the window `$w` built in (memory
/// capacity `N / 4`); `None` for the others.
macro_rules! by_window {
    ($w:expr, $f:ident ( $($a:expr),* )) => {
        match $w {
            256 => Some($f::<256, 64>($($a),*)),
            #[cfg(feature = "all-windows")]
            64 => Some($f::<64, 16>($($a),*)),
            #[cfg(feature = "all-windows")]
            128 => Some($f::<128, 32>($($a),*)),
            #[cfg(feature = "all-windows")]
            512 => Some($f::<512, 128>($($a),*)),
            #[cfg(feature = "all-windows")]
            1024 => Some($f::<1024, 256>($($a),*)),
            _ => None,
        }
    };
}

/// Calls `$f::<N, MEM, CELLS>($args)` for window `$w` and the room for
/// `$c` cells (4, 8 or 16).
macro_rules! by_pack {
    ($w:expr, $c:expr, $f:ident ( $($a:expr),* )) => {
        match ($w, $c) {
            (256, 4) => Some($f::<256, 64, 4>($($a),*)),
            (256, 8) => Some($f::<256, 64, 8>($($a),*)),
            (256, 16) => Some($f::<256, 64, 16>($($a),*)),
            #[cfg(feature = "all-windows")]
            (64, 4) => Some($f::<64, 16, 4>($($a),*)),
            #[cfg(feature = "all-windows")]
            (64, 8) => Some($f::<64, 16, 8>($($a),*)),
            #[cfg(feature = "all-windows")]
            (64, 16) => Some($f::<64, 16, 16>($($a),*)),
            #[cfg(feature = "all-windows")]
            (128, 4) => Some($f::<128, 32, 4>($($a),*)),
            #[cfg(feature = "all-windows")]
            (128, 8) => Some($f::<128, 32, 8>($($a),*)),
            #[cfg(feature = "all-windows")]
            (128, 16) => Some($f::<128, 32, 16>($($a),*)),
            #[cfg(feature = "all-windows")]
            (512, 4) => Some($f::<512, 128, 4>($($a),*)),
            #[cfg(feature = "all-windows")]
            (512, 8) => Some($f::<512, 128, 8>($($a),*)),
            #[cfg(feature = "all-windows")]
            (512, 16) => Some($f::<512, 128, 16>($($a),*)),
            #[cfg(feature = "all-windows")]
            (1024, 4) => Some($f::<1024, 256, 4>($($a),*)),
            #[cfg(feature = "all-windows")]
            (1024, 8) => Some($f::<1024, 256, 8>($($a),*)),
            #[cfg(feature = "all-windows")]
            (1024, 16) => Some($f::<1024, 256, 16>($($a),*)),
            _ => None,
        }
    };
}

/// The room a pack of `cells` cells is given: 4, 8 or 16 (0 beyond).
pub(crate) fn pack_room(cells: u16) -> u16 {
    match cells {
        1..=4 => 4,
        5..=8 => 8,
        9..=16 => 16,
        _ => 0,
    }
}

/// Size and alignment of a cell's state.
pub(crate) fn cell_layout(window: u16, memory: u16) -> Option<(usize, usize)> {
    fn layout<const N: usize, const MEM: usize>() -> (usize, usize) {
        (
            size_of::<CellSlot<N, MEM>>(),
            align_of::<CellSlot<N, MEM>>(),
        )
    }
    if memory == 0 || usize::from(memory) > usize::from(window) / 4 {
        return None;
    }
    by_window!(window, layout())
}

/// Size and alignment of a pack's state.
pub(crate) fn pack_layout(window: u16, memory: u16, cells: u16) -> Option<(usize, usize)> {
    fn layout<const N: usize, const MEM: usize, const CELLS: usize>() -> (usize, usize) {
        (
            size_of::<PackSlot<N, MEM, CELLS>>(),
            align_of::<PackSlot<N, MEM, CELLS>>(),
        )
    }
    if memory == 0 || usize::from(memory) > usize::from(window) / 4 {
        return None;
    }
    by_pack!(window, pack_room(cells), layout())
}

/// Checks a caller's memory against a layout.
pub(crate) fn check_memory(
    memory: *mut u8,
    size: usize,
    layout: (usize, usize),
) -> Result<(), FracbmsCode> {
    if memory.is_null() {
        return Err(FracbmsCode::FRACBMS_ERROR_NULL);
    }
    if !(memory as usize).is_multiple_of(layout.1) {
        return Err(FracbmsCode::FRACBMS_ERROR_MISALIGNED);
    }
    if size < layout.0 {
        return Err(FracbmsCode::FRACBMS_ERROR_TOO_SMALL);
    }
    Ok(())
}

/// The estimate of one cell's state.
fn estimate_of<const N: usize>(
    s: &Settings,
    c: &CellState<f32, N>,
    report: Option<SampleReport<f32>>,
) -> FracbmsEstimate {
    let e = c.estimate();
    let counts = c.counts();
    let status = report.map_or(c.status(), |r| r.status);
    FracbmsEstimate {
        status: status.into(),
        rejection: report.map_or(c.last_rejection(), |r| r.rejected).into(),
        iterations: report.map_or(0, |r| r.iterations),
        valid: e.is_some(),
        parameters: e.map(FracbmsParameters::from).unwrap_or_default(),
        state_of_charge: c.state_of_charge().unwrap_or(f32::NAN),
        ocv_offset: c.ocv_offset().unwrap_or(f32::NAN),
        rmse: c.rmse(),
        samples: u32::try_from(counts.samples).unwrap_or(u32::MAX),
        rejected: counts.rejected(),
        flagged: false,
        published: c.published().into(),
        step_resistance: c.step_resistance().map_or(f32::NAN, |st| st.ohm),
        soc: c.soc_estimate(s).map_or(FracbmsSoc::NONE, FracbmsSoc::from),
        restoration: c.restoration().into(),
    }
}

/// Builds a cell into `memory` (checked by the caller).
///
/// # Safety
/// `memory` is valid for writes of `size_of::<CellSlot<N, MEM>>()` bytes and
/// aligned for it.
unsafe fn cell_init<const N: usize, const MEM: usize>(
    memory: *mut u8,
    settings: Settings,
    window: u16,
) -> Result<(), FracbmsCode> {
    let cell = CellEstimator::<f32, N, MEM>::new(&settings)
        .map_err(|_| FracbmsCode::FRACBMS_ERROR_SETTINGS)?;
    let slot = CellSlot {
        header: Header {
            magic: CELL_MAGIC,
            window,
            capacity: 1,
        },
        settings,
        cell,
        follower: MapFollower::new(),
    };
    // SAFETY: the caller checked size and alignment; `write` does not read
    // or drop what was there.
    unsafe { memory.cast::<CellSlot<N, MEM>>().write(slot) };
    Ok(())
}

/// Builds a cell into checked memory.
///
/// # Safety
/// As [`cell_init`]: `memory` checked against `cell_layout(window, ..)`.
pub(crate) unsafe fn cell_init_sized(
    memory: *mut u8,
    settings: Settings,
    window: u16,
) -> Result<(), FracbmsCode> {
    // SAFETY: forwarded from the caller.
    unsafe { by_window!(window, cell_init(memory, settings, window)) }
        .unwrap_or(Err(FracbmsCode::FRACBMS_ERROR_UNSUPPORTED_SIZE))
}

/// Reads the header of a state made by `init` of kind `magic`.
///
/// # Safety
/// `state` is null or points to at least a `Header`'s readable bytes.
unsafe fn header(state: *const u8, magic: u32) -> Result<Header, FracbmsCode> {
    if state.is_null() {
        return Err(FracbmsCode::FRACBMS_ERROR_NULL);
    }
    if !(state as usize).is_multiple_of(align_of::<Header>()) {
        return Err(FracbmsCode::FRACBMS_ERROR_MISALIGNED);
    }
    // SAFETY: non-null, aligned, and the caller's memory holds at least the
    // header (every state does).
    let h = unsafe { state.cast::<Header>().read() };
    if h.magic != magic {
        return Err(FracbmsCode::FRACBMS_ERROR_NOT_INITIALIZED);
    }
    Ok(h)
}

/// What can be done to a cell.
pub(crate) enum CellOp<'a> {
    /// Push a sample.
    Push(f32, f32),
    /// Read the estimate.
    Read,
    /// Set the state of charge.
    SetSoc(f32),
    /// Set (or clear) the prior.
    SetPrior(Option<Prior<f32>>),
    /// Follow a map at this temperature; whether the prior was taken again.
    FollowMap(ParameterMap<'a, f32>, f32, &'a mut bool),
}

/// Runs `op` on a cell made by `init`.
///
/// # Safety
/// `state` is null or a state made by `fracbms_cell_init`, not used
/// elsewhere during the call.
pub(crate) unsafe fn cell_op(
    state: *mut u8,
    op: CellOp<'_>,
) -> Result<FracbmsEstimate, FracbmsCode> {
    unsafe fn run<const N: usize, const MEM: usize>(
        state: *mut u8,
        op: CellOp<'_>,
    ) -> FracbmsEstimate {
        // SAFETY: the header named this layout; the caller guarantees
        // exclusive access.
        let slot = unsafe { &mut *state.cast::<CellSlot<N, MEM>>() };
        let report = match op {
            CellOp::Push(i, v) => Some(slot.cell.push(&slot.settings, i, v)),
            CellOp::Read => None,
            CellOp::SetSoc(z) => {
                slot.cell.set_state_of_charge(z);
                None
            }
            CellOp::SetPrior(p) => {
                slot.settings.battery.prior = p;
                None
            }
            CellOp::FollowMap(map, t, taken) => {
                // The published SOC: the observer's, else the count (as
                // `host-sim online battery`'s map prior follows it).
                let z = slot
                    .cell
                    .published_state_of_charge(&slot.settings)
                    .unwrap_or(f32::NAN);
                *taken = false;
                if let Some(mut c) = slot.follower.follow(&map, z, t) {
                    if slot.settings.ocv.is_none() {
                        // The map's u_oc is an offset from the OCV curve;
                        // without a curve the start's own U_oc stands.
                        c.u_oc = slot.settings.initial.u_oc;
                    }
                    slot.settings.battery.prior = Some(Prior::new(c));
                    *taken = true;
                }
                None
            }
        };
        estimate_of(&slot.settings, slot.cell.cell_state(), report)
    }
    // SAFETY: forwarded from the caller.
    let h = unsafe { header(state, CELL_MAGIC) }?;
    // SAFETY: the magic says `init` wrote a `CellSlot` of this window.
    unsafe { by_window!(h.window, run(state, op)) }
        .ok_or(FracbmsCode::FRACBMS_ERROR_NOT_INITIALIZED)
}

/// Builds a pack into `memory` (checked by the caller).
///
/// # Safety
/// `memory` is valid for writes of `size_of::<PackSlot<N, MEM, CELLS>>()`
/// bytes and aligned for it.
unsafe fn pack_init<const N: usize, const MEM: usize, const CELLS: usize>(
    memory: *mut u8,
    settings: PackSettings<f32, FRACBMS_OCV_POINTS_MAX>,
    window: u16,
    cells: u16,
) -> Result<(), FracbmsCode> {
    let pack = PackEstimator::<f32, N, MEM, CELLS>::new(&settings, usize::from(cells))
        .map_err(|_| FracbmsCode::FRACBMS_ERROR_SETTINGS)?;
    let slot = PackSlot {
        header: Header {
            magic: PACK_MAGIC,
            window,
            capacity: CELLS as u16,
        },
        settings,
        pack,
    };
    // SAFETY: the caller checked size and alignment.
    unsafe { memory.cast::<PackSlot<N, MEM, CELLS>>().write(slot) };
    Ok(())
}

/// Builds a pack into checked memory.
///
/// # Safety
/// As [`pack_init`]: `memory` checked against `pack_layout(window, .., cells)`.
pub(crate) unsafe fn pack_init_sized(
    memory: *mut u8,
    settings: PackSettings<f32, FRACBMS_OCV_POINTS_MAX>,
    window: u16,
    cells: u16,
) -> Result<(), FracbmsCode> {
    // SAFETY: forwarded from the caller.
    unsafe {
        by_pack!(
            window,
            pack_room(cells),
            pack_init(memory, settings, window, cells)
        )
    }
    .unwrap_or(Err(FracbmsCode::FRACBMS_ERROR_UNSUPPORTED_SIZE))
}

/// What can be done to a pack.
pub(crate) enum PackOp<'a> {
    /// Push one period: the current and every cell's voltage.
    Push(f32, &'a [f32]),
    /// Read cell `k`'s estimate (0-based).
    Read(usize),
}

/// What a pack operation gives back.
pub(crate) enum PackOut {
    /// Rejected cells, updated cells and iterations of the period.
    Pushed(u16, u16, u32),
    /// A cell's estimate.
    Cell(FracbmsEstimate),
}

/// Runs `op` on a pack made by `init`.
///
/// # Safety
/// `state` is null or a state made by `fracbms_pack_init`, not used
/// elsewhere during the call.
pub(crate) unsafe fn pack_op(state: *mut u8, op: PackOp<'_>) -> Result<PackOut, FracbmsCode> {
    unsafe fn run<const N: usize, const MEM: usize, const CELLS: usize>(
        state: *mut u8,
        op: PackOp<'_>,
    ) -> Result<PackOut, FracbmsCode> {
        // SAFETY: the header named this layout; the caller guarantees
        // exclusive access.
        let slot = unsafe { &mut *state.cast::<PackSlot<N, MEM, CELLS>>() };
        match op {
            PackOp::Push(i, v) => {
                let r = slot
                    .pack
                    .push(&slot.settings, i, v)
                    .map_err(|_| FracbmsCode::FRACBMS_ERROR_CELL_COUNT)?;
                Ok(PackOut::Pushed(r.rejected, r.updated, r.iterations))
            }
            PackOp::Read(k) => {
                let c = slot
                    .pack
                    .cell(k)
                    .ok_or(FracbmsCode::FRACBMS_ERROR_CELL_COUNT)?;
                let mut e = estimate_of(&slot.settings.cell, c, None);
                e.flagged = slot
                    .pack
                    .health()
                    .is_some_and(|h| slot.pack.is_flagged(&slot.settings, &h, k));
                Ok(PackOut::Cell(e))
            }
        }
    }
    // SAFETY: forwarded from the caller.
    let h = unsafe { header(state, PACK_MAGIC) }?;
    // SAFETY: the magic says `init` wrote a `PackSlot` of these sizes.
    unsafe { by_pack!(h.window, h.capacity, run(state, op)) }
        .ok_or(FracbmsCode::FRACBMS_ERROR_NOT_INITIALIZED)?
}

/// Cells in use of a pack made by `init`.
///
/// # Safety
/// As [`pack_op`].
pub(crate) unsafe fn pack_cells(state: *const u8) -> Result<usize, FracbmsCode> {
    unsafe fn run<const N: usize, const MEM: usize, const CELLS: usize>(state: *const u8) -> usize {
        // SAFETY: the header named this layout.
        unsafe { &*state.cast::<PackSlot<N, MEM, CELLS>>() }
            .pack
            .cells()
    }
    // SAFETY: forwarded from the caller.
    let h = unsafe { header(state, PACK_MAGIC) }?;
    // SAFETY: the magic says `init` wrote a `PackSlot` of these sizes.
    unsafe { by_pack!(h.window, h.capacity, run(state)) }
        .ok_or(FracbmsCode::FRACBMS_ERROR_NOT_INITIALIZED)
}

/// The state of power of a cell made by `init` for `req` (the core's
/// [`CellEstimator::state_of_power`]).
///
/// # Safety
/// As [`cell_op`] (read only).
pub(crate) unsafe fn cell_power(
    state: *const u8,
    req: &FracbmsPowerRequest,
) -> Result<FracbmsPower, FracbmsCode> {
    unsafe fn run<const N: usize, const MEM: usize>(
        state: *const u8,
        req: &FracbmsPowerRequest,
    ) -> Result<FracbmsPower, FracbmsCode> {
        // SAFETY: the header named this layout.
        let slot = unsafe { &*state.cast::<CellSlot<N, MEM>>() };
        let s = &slot.settings;
        let power = req
            .settings(s.battery.h)
            .ok_or(FracbmsCode::FRACBMS_ERROR_SETTINGS)?;
        Ok(req.answer(slot.cell.state_of_power(s, &power)))
    }
    // SAFETY: forwarded from the caller.
    let h = unsafe { header(state, CELL_MAGIC) }?;
    // SAFETY: the magic says `init` wrote a `CellSlot` of this window.
    unsafe { by_window!(h.window, run(state, req)) }
        .ok_or(FracbmsCode::FRACBMS_ERROR_NOT_INITIALIZED)?
}

/// The state of power of a pack made by `init` for `req`: cell `k`'s
/// (0-based), or the string's (the weakest cell's) for `None`.
///
/// # Safety
/// As [`pack_op`] (read only).
pub(crate) unsafe fn pack_power(
    state: *const u8,
    k: Option<usize>,
    req: &FracbmsPowerRequest,
) -> Result<FracbmsPower, FracbmsCode> {
    unsafe fn run<const N: usize, const MEM: usize, const CELLS: usize>(
        state: *const u8,
        k: Option<usize>,
        req: &FracbmsPowerRequest,
    ) -> Result<FracbmsPower, FracbmsCode> {
        // SAFETY: the header named this layout.
        let slot = unsafe { &*state.cast::<PackSlot<N, MEM, CELLS>>() };
        let s = &slot.settings.cell;
        let power = req
            .settings(s.battery.h)
            .ok_or(FracbmsCode::FRACBMS_ERROR_SETTINGS)?;
        let report = match k {
            Some(k) => {
                slot.pack
                    .cell(k)
                    .ok_or(FracbmsCode::FRACBMS_ERROR_CELL_COUNT)?;
                slot.pack.state_of_power(k, s, &power)
            }
            None => slot.pack.pack_state_of_power(s, &power),
        };
        Ok(req.answer(report))
    }
    // SAFETY: forwarded from the caller.
    let h = unsafe { header(state, PACK_MAGIC) }?;
    // SAFETY: the magic says `init` wrote a `PackSlot` of these sizes.
    unsafe { by_pack!(h.window, h.capacity, run(state, k, req)) }
        .ok_or(FracbmsCode::FRACBMS_ERROR_NOT_INITIALIZED)?
}

/// What a snapshot call does (`fracbms_*_snapshot_*`; the core's
/// `battery::snapshot`).
pub(crate) enum SnapshotOp<'a> {
    /// The snapshot's size.
    Size,
    /// Save at this time (s; `None`: unknown) into the buffer.
    Save(Option<u32>, &'a mut [u8]),
    /// Restore from the buffer with this policy.
    Restore(&'a [u8], RestorePolicy),
}

/// Runs a snapshot `op` through an estimator's `size`, `save` and
/// `restore` (a cell's or a pack's): the bytes (size, written, read) or
/// the error's code.
fn snapshot_run<E>(
    e: &mut E,
    op: SnapshotOp<'_>,
    size: impl FnOnce(&E) -> usize,
    save: impl FnOnce(&E, Option<u32>, &mut [u8]) -> Result<usize, SnapshotError>,
    restore: impl FnOnce(&mut E, &[u8], &RestorePolicy) -> Result<(), SnapshotError>,
) -> Result<usize, FracbmsCode> {
    match op {
        SnapshotOp::Size => Ok(size(e)),
        SnapshotOp::Save(at, buf) => save(e, at, buf).map_err(|e| match e {
            SnapshotError::TooShort { .. } => FracbmsCode::FRACBMS_ERROR_TOO_SMALL,
            e => e.into(),
        }),
        SnapshotOp::Restore(buf, policy) => restore(e, buf, &policy)
            .map(|()| buf.len())
            .map_err(Into::into),
    }
}

/// Runs a snapshot `op` on a cell made by `init`.
///
/// # Safety
/// As [`cell_op`] (`Size` and `Save` do not write the cell).
pub(crate) unsafe fn cell_snapshot(
    state: *mut u8,
    op: SnapshotOp<'_>,
) -> Result<usize, FracbmsCode> {
    unsafe fn run<const N: usize, const MEM: usize>(
        state: *mut u8,
        op: SnapshotOp<'_>,
    ) -> Result<usize, FracbmsCode> {
        // SAFETY: the header named this layout; the caller guarantees
        // exclusive access.
        let slot = unsafe { &mut *state.cast::<CellSlot<N, MEM>>() };
        let s = &slot.settings;
        snapshot_run(
            &mut slot.cell,
            op,
            |c| c.snapshot_size(),
            |c, at, b| c.save(s, at, b),
            |c, b, p| c.restore(s, b, p),
        )
    }
    // SAFETY: forwarded from the caller.
    let h = unsafe { header(state, CELL_MAGIC) }?;
    // SAFETY: the magic says `init` wrote a `CellSlot` of this window.
    unsafe { by_window!(h.window, run(state, op)) }
        .ok_or(FracbmsCode::FRACBMS_ERROR_NOT_INITIALIZED)?
}

/// Runs a snapshot `op` on a pack made by `init`.
///
/// # Safety
/// As [`pack_op`] (`Size` and `Save` do not write the pack).
pub(crate) unsafe fn pack_snapshot(
    state: *mut u8,
    op: SnapshotOp<'_>,
) -> Result<usize, FracbmsCode> {
    unsafe fn run<const N: usize, const MEM: usize, const CELLS: usize>(
        state: *mut u8,
        op: SnapshotOp<'_>,
    ) -> Result<usize, FracbmsCode> {
        // SAFETY: the header named this layout; the caller guarantees
        // exclusive access.
        let slot = unsafe { &mut *state.cast::<PackSlot<N, MEM, CELLS>>() };
        let s = &slot.settings.cell;
        snapshot_run(
            &mut slot.pack,
            op,
            |k| k.snapshot_size(),
            |k, at, b| k.save(s, at, b),
            |k, b, p| k.restore(s, b, p),
        )
    }
    // SAFETY: forwarded from the caller.
    let h = unsafe { header(state, PACK_MAGIC) }?;
    // SAFETY: the magic says `init` wrote a `PackSlot` of these sizes.
    unsafe { by_pack!(h.window, h.capacity, run(state, op)) }
        .ok_or(FracbmsCode::FRACBMS_ERROR_NOT_INITIALIZED)?
}
