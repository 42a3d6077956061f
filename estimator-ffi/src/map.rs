//! Parameter maps over the C interface: the cell at a SOC and temperature
//! (`fracbms_map_cell_at`), a cell's prior set by the caller
//! (`fracbms_cell_set_prior`) or following a map as the cell's published SOC
//! and temperature move (`fracbms_cell_follow_map`). The levels are the
//! caller's array (`FracbmsMapLevel`, the identifiable rows of `host-sim
//! identify battery --map-out`); the interpolation and the follow rule are
//! the core's (`estimator_core::battery::map`), as in the firmware and
//! `host-sim online battery --prior MAP.csv`. This module owns the C level
//! (`FracbmsMapLevel`, `FRACBMS_MAP_LEVELS_MAX`) and only converts.

use estimator_core::battery::map::{MapLevel, ParameterMap};
use estimator_core::battery::{CellParameters, Prior};

use crate::state::{self, CellOp};
use crate::types::{FracbmsCode, FracbmsParameters};
use crate::{code, put, FracbmsCell};
use FracbmsCode::*;

/// Largest parameter map the C interface takes (levels).
pub const FRACBMS_MAP_LEVELS_MAX: usize = 64;

/// One level of a parameter map (a row of `host-sim identify battery
/// --map-out` whose `identifiable` is true): the cell fitted at a SOC and a
/// temperature.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FracbmsMapLevel {
    /// Temperature (°C); NaN when unknown.
    pub temperature_c: f32,
    /// State of charge in `[0, 1]`.
    pub soc: f32,
    /// The cell there (`u_oc`: the map's `ocv_offset_v`; a linear level has
    /// `bv_a = 0`, `bv_i0 = 1`).
    pub parameters: FracbmsParameters,
}

impl From<FracbmsMapLevel> for MapLevel<f32> {
    fn from(l: FracbmsMapLevel) -> Self {
        Self {
            temperature_c: (!l.temperature_c.is_nan()).then_some(l.temperature_c),
            soc: l.soc,
            cell: l.parameters.into(),
        }
    }
}

/// The C levels `levels` (`n` of them) converted into `buf` and checked as
/// the core's map.
///
/// # Safety
/// `levels` is null or points to `n` readable levels.
pub(crate) unsafe fn parameter_map(
    levels: *const FracbmsMapLevel,
    n: u16,
    buf: &mut [MapLevel<f32>; FRACBMS_MAP_LEVELS_MAX],
) -> Result<ParameterMap<'_, f32>, FracbmsCode> {
    if levels.is_null() {
        return Err(FracbmsCode::FRACBMS_ERROR_NULL);
    }
    let n = usize::from(n);
    if n > FRACBMS_MAP_LEVELS_MAX {
        return Err(FracbmsCode::FRACBMS_ERROR_MAP);
    }
    // SAFETY: non-null; the caller guarantees `n` readable levels.
    let src = unsafe { core::slice::from_raw_parts(levels, n) };
    for (b, l) in buf.iter_mut().zip(src) {
        *b = (*l).into();
    }
    ParameterMap::new(&buf[..n]).map_err(|_| FracbmsCode::FRACBMS_ERROR_MAP)
}

/// An empty level for the conversion buffer.
const EMPTY: MapLevel<f32> = MapLevel {
    temperature_c: None,
    soc: 0.0,
    cell: CellParameters {
        r_i: 0.0,
        r_ct: 0.0,
        q: 0.0,
        alpha: 0.0,
        u_oc: 0.0,
        bv_a: 0.0,
        bv_i0: 1.0,
    },
};

/// Writes to `out` the map's cell at `soc` and `temperature_c` (NaN:
/// unknown): each parameter linear in SOC between the two levels around
/// `soc`, held beyond the first and the last (a NaN `soc`: the middle
/// level's); strictly between two of the map's temperatures, Arrhenius
/// between their cells (`ln R_i`, `ln R_ct`, `ln τ` linear in `1/T`);
/// beyond them, the nearest temperature held. `levels` holds `n_levels` levels (at most
/// `FRACBMS_MAP_LEVELS_MAX`) sorted by temperature (unknown first), then
/// SOC; `FRACBMS_ERROR_MAP` otherwise.
///
/// # Safety
/// `levels` is null or points to `n_levels` readable levels; `out` is null
/// or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fracbms_map_cell_at(
    levels: *const FracbmsMapLevel,
    n_levels: u16,
    soc: f32,
    temperature_c: f32,
    out: *mut FracbmsParameters,
) -> FracbmsCode {
    if out.is_null() {
        return FRACBMS_ERROR_NULL;
    }
    let mut buf = [EMPTY; FRACBMS_MAP_LEVELS_MAX];
    // SAFETY: forwarded from the caller.
    let map = match unsafe { parameter_map(levels, n_levels, &mut buf) } {
        Ok(m) => m,
        Err(c) => return c,
    };
    let t = (!temperature_c.is_nan()).then_some(temperature_c);
    // SAFETY: non-null, valid by the caller's contract.
    code(unsafe { put(out, map.cell_at(soc, t).into()) })
}

/// Sets a cell's prior: the window fit is then maximum a posteriori around
/// `center` (the core's default spreads: a factor 2 on R_i, R_ct and Q at
/// one sigma, 0.1 on α, the data weighed at 0.1 V). A null `center` clears
/// the prior. `FRACBMS_ERROR_SETTINGS` for a centre that is not a physical
/// cell. It holds until changed (by this call or `fracbms_cell_follow_map`).
/// Set before the first `fracbms_cell_push`, it is the start too: the
/// refinement starts at `center`, without the 2S-OP-GI start-up, as a cell
/// built with a prior (`host-sim online battery --prior FIT.json`).
///
/// # Safety
/// `cell` as in `fracbms_cell_push`; `center` is null or valid for a read.
#[no_mangle]
pub unsafe extern "C" fn fracbms_cell_set_prior(
    cell: *mut FracbmsCell,
    center: *const FracbmsParameters,
) -> FracbmsCode {
    let prior = if center.is_null() {
        None
    } else {
        // SAFETY: non-null, valid by the caller's contract.
        let c: CellParameters<f32> = unsafe { *center }.into();
        if !c.is_physical() {
            return FRACBMS_ERROR_SETTINGS;
        }
        Some(Prior::new(c))
    };
    // SAFETY: forwarded from the caller.
    code(unsafe { state::cell_op(cell.cast(), CellOp::SetPrior(prior)) }.map(|_| ()))
}

/// Lets a cell's prior follow a parameter map: call it before each
/// `fracbms_cell_push` with the cell's temperature (°C; NaN: the last one
/// given). The prior's centre is the map's cell at the cell's published SOC
/// (the observer's, else the count; with an OCV table; the middle level's
/// without a SOC) and that
/// temperature, taken again when the SOC has moved by 0.001 or the
/// temperature by 0.5 °C since it was last taken (then `*taken` is true),
/// with the spreads of `fracbms_cell_set_prior`. The map is read during
/// the call only. Without an OCV table a level's `u_oc` is not used.
/// Called before the first push, the map's cell is the start too, as with
/// `fracbms_cell_set_prior`.
///
/// # Safety
/// `cell` as in `fracbms_cell_push`; `levels` as in `fracbms_map_cell_at`;
/// `taken` is null or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fracbms_cell_follow_map(
    cell: *mut FracbmsCell,
    levels: *const FracbmsMapLevel,
    n_levels: u16,
    temperature_c: f32,
    taken: *mut bool,
) -> FracbmsCode {
    let mut buf = [EMPTY; FRACBMS_MAP_LEVELS_MAX];
    // SAFETY: forwarded from the caller.
    let map = match unsafe { parameter_map(levels, n_levels, &mut buf) } {
        Ok(m) => m,
        Err(c) => return c,
    };
    let mut was_taken = false;
    // SAFETY: forwarded from the caller.
    let r = unsafe {
        state::cell_op(
            cell.cast(),
            CellOp::FollowMap(map, temperature_c, &mut was_taken),
        )
    };
    match r {
        Ok(_) if taken.is_null() => FRACBMS_OK,
        // SAFETY: non-null, valid by the caller's contract.
        Ok(_) => code(unsafe { put(taken, was_taken) }),
        Err(c) => c,
    }
}
