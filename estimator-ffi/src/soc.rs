//! The SOC observer's settings through the C ABI: `FracbmsSocSettings`
//! (the core's `SocSettings` less the period and the nominal capacity, which
//! `FracbmsSettings` already carries), their defaults, and the `init`
//! variants that take them. Only conversion here: the observer and its
//! checks are `estimator_core::battery::soc`'s.

use estimator_core::battery::pack::PackSettings;
use estimator_core::battery::soc::SocSettings;

use crate::types::{self, FracbmsCode, FracbmsSettings, Settings};
use crate::{put, state, FracbmsCell, FracbmsPack};

/// The SOC observer's settings (`estimator_core::battery::soc::SocSettings`;
/// `host-sim online battery`'s `--soc-rest-s`, `--soc-bias-sigma-a`,
/// `--soc-rest-load-sigma-a`, `--soc-voltage-sigma-v` set four of them). The period and the nominal
/// capacity are `FracbmsSettings`' `h` and `capacity_ah`, with its OCV
/// table (the observer runs only with one). Start from
/// `fracbms_soc_settings_default` and change what differs: every value must
/// be finite and not negative, `min_slope` positive
/// (`FRACBMS_ERROR_SETTINGS` otherwise, from `init`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FracbmsSocSettings {
    /// A sample is rested when its current, less the estimated bias, is at
    /// most this (A). Default C/50.
    pub rest_current_a: f32,
    /// The shortest rest that gives an observation (s). Default 600.
    pub rest_s: f32,
    /// A rest this long gives its observation without waiting for its end
    /// (s). Default 3600. Below `rest_s` it reads rests at `rest_max_s`:
    /// keep it at least `rest_s` (the CLI's `--soc-rest-s` raises it).
    pub rest_max_s: f32,
    /// The spread of a rested voltage as the OCV (V). Default 0.005.
    pub voltage_sigma_v: f32,
    /// The spread of a voltage read at once, not yet relaxed (V). Default
    /// 0.03.
    pub unrelaxed_sigma_v: f32,
    /// The spread of the OCV curve itself in SOC, added to every
    /// observation's. Default 0.01.
    pub table_sigma_soc: f32,
    /// The spread of a start SOC (given, or read from the first voltage).
    /// Default 0.1.
    pub soc0_sigma: f32,
    /// The prior spread of the current sensor's bias (A). Default C/50; 0
    /// for a calibrated sensor (then set `bias_walk_a` to 0 too, as the
    /// CLI's `--soc-bias-sigma-a 0` does).
    pub bias_sigma_a: f32,
    /// How far the bias may wander in an hour (A). Default C/1000.
    pub bias_walk_a: f32,
    /// The spread of the true current in a rest (A): each rest's mean
    /// current reads the bias with this spread. Default C/1000.
    pub rest_load_sigma_a: f32,
    /// The prior spread of the capacity, relative. Default 0.15.
    pub capacity_sigma: f32,
    /// The capacity is identified when its standard deviation is at most
    /// this fraction of it. Default 0.02.
    pub capacity_identify: f32,
    /// The spread added to the SOC by a gap of unknown charge. Default 0.5.
    pub gap_soc_sigma: f32,
    /// The smallest OCV slope an observation is weighed with (V per unit
    /// SOC). Default 0.001.
    pub min_slope: f32,
    /// The capacity is identified only once relaxed rests linked by the
    /// count have also read SOCs at least this far apart through the OCV
    /// table (0 to 1; 0: no span asked). Default 0.3; `host-sim online
    /// battery --capacity-min-span`. (The last field: added after the
    /// others.)
    pub capacity_min_span: f32,
}

impl FracbmsSocSettings {
    /// The C view of the core's settings.
    fn from_core(s: &SocSettings<f32>) -> Self {
        Self {
            rest_current_a: s.rest_current_a,
            rest_s: s.rest_s,
            rest_max_s: s.rest_max_s,
            voltage_sigma_v: s.voltage_sigma_v,
            unrelaxed_sigma_v: s.unrelaxed_sigma_v,
            table_sigma_soc: s.table_sigma_soc,
            soc0_sigma: s.soc0_sigma,
            bias_sigma_a: s.bias_sigma_a,
            bias_walk_a: s.bias_walk_a,
            rest_load_sigma_a: s.rest_load_sigma_a,
            capacity_sigma: s.capacity_sigma,
            capacity_identify: s.capacity_identify,
            gap_soc_sigma: s.gap_soc_sigma,
            min_slope: s.min_slope,
            capacity_min_span: s.capacity_min_span,
        }
    }

    /// The core's settings with these values (`s`' period and capacity
    /// kept).
    pub(crate) fn apply(&self, s: &mut SocSettings<f32>) {
        *s = SocSettings {
            capacity_ah: s.capacity_ah,
            h: s.h,
            rest_current_a: self.rest_current_a,
            rest_s: self.rest_s,
            rest_max_s: self.rest_max_s,
            voltage_sigma_v: self.voltage_sigma_v,
            unrelaxed_sigma_v: self.unrelaxed_sigma_v,
            table_sigma_soc: self.table_sigma_soc,
            soc0_sigma: self.soc0_sigma,
            bias_sigma_a: self.bias_sigma_a,
            bias_walk_a: self.bias_walk_a,
            rest_load_sigma_a: self.rest_load_sigma_a,
            capacity_sigma: self.capacity_sigma,
            capacity_identify: self.capacity_identify,
            gap_soc_sigma: self.gap_soc_sigma,
            min_slope: self.min_slope,
            capacity_min_span: self.capacity_min_span,
        };
    }
}

/// The core's settings of `c` with the SOC settings `soc` (null: the
/// defaults for `c`'s capacity). Settings without an OCV table are
/// `FRACBMS_ERROR_SETTINGS`: the observer runs only with one.
///
/// # Safety
/// As `types::settings`; `soc` is null or valid for a read.
unsafe fn settings_with(
    c: &FracbmsSettings,
    soc: *const FracbmsSocSettings,
) -> Result<Settings, FracbmsCode> {
    // SAFETY: forwarded from the caller.
    let mut s = unsafe { types::settings(c) }?;
    if !soc.is_null() {
        if s.ocv.is_none() {
            return Err(FracbmsCode::FRACBMS_ERROR_SETTINGS);
        }
        // SAFETY: non-null, valid for a read by the caller's contract.
        unsafe { soc.read() }.apply(&mut s.soc);
    }
    Ok(s)
}

/// Fills `out` with the SOC observer's defaults for `settings`, which must
/// carry the OCV table and the capacity (`FRACBMS_ERROR_SETTINGS`
/// without a table: the observer runs only with one, and its defaults
/// scale with the capacity): what `fracbms_cell_init` and
/// `fracbms_pack_init` use.
///
/// # Safety
/// `settings` is null or valid for a read, with its OCV arrays as for
/// `fracbms_cell_init`; `out` is null or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fracbms_soc_settings_default(
    settings: *const FracbmsSettings,
    out: *mut FracbmsSocSettings,
) -> FracbmsCode {
    if settings.is_null() || out.is_null() {
        return FracbmsCode::FRACBMS_ERROR_NULL;
    }
    // SAFETY: non-null, valid by the caller's contract.
    let c = unsafe { &*settings };
    let run = || {
        // SAFETY: the caller's OCV arrays hold `ocv_points` values.
        let s = unsafe { types::settings(c) }?;
        if s.ocv.is_none() {
            return Err(FracbmsCode::FRACBMS_ERROR_SETTINGS);
        }
        // SAFETY: `out` non-null, valid for a write by the caller's contract.
        unsafe { put(out, FracbmsSocSettings::from_core(&s.soc)) }
    };
    crate::code(run())
}

/// `fracbms_cell_init` with the SOC observer's settings `soc` (null: the
/// defaults, as `fracbms_cell_init`; not null without an OCV table:
/// `FRACBMS_ERROR_SETTINGS`). They hold for the cell's life, and a
/// snapshot restored into the cell does not carry any: the restored
/// observer's state (SOC, bias, capacity and their spreads) goes on under
/// these settings, and the spreads of a start (`soc0_sigma`,
/// `bias_sigma_a`, `capacity_sigma`) no longer act on it.
///
/// # Safety
/// As `fracbms_cell_init`; `soc` is null or valid for a read.
#[no_mangle]
pub unsafe extern "C" fn fracbms_cell_init_with_soc(
    memory: *mut core::ffi::c_void,
    size: usize,
    settings: *const FracbmsSettings,
    soc: *const FracbmsSocSettings,
    cell: *mut *mut FracbmsCell,
) -> FracbmsCode {
    if settings.is_null() || cell.is_null() {
        return FracbmsCode::FRACBMS_ERROR_NULL;
    }
    // SAFETY: non-null, valid by the caller's contract.
    let c = unsafe { &*settings };
    let Some(layout) = state::cell_layout(c.window, c.memory) else {
        return FracbmsCode::FRACBMS_ERROR_UNSUPPORTED_SIZE;
    };
    let memory = memory.cast::<u8>();
    let run = || {
        state::check_memory(memory, size, layout)?;
        // SAFETY: the caller's OCV arrays hold `ocv_points` values; `soc`
        // null or valid.
        let s = unsafe { settings_with(c, soc) }?;
        // SAFETY: memory checked against the layout of this window.
        unsafe { state::cell_init_sized(memory, s, c.window) }?;
        // SAFETY: `cell` non-null, valid by the caller's contract.
        unsafe { put(cell, memory.cast::<FracbmsCell>()) }
    };
    crate::code(run())
}

/// `fracbms_pack_init` with the SOC observer's settings `soc` for every
/// cell (null: the defaults, as `fracbms_pack_init`), for the pack's life,
/// as `fracbms_cell_init_with_soc`.
///
/// # Safety
/// As `fracbms_pack_init`; `soc` is null or valid for a read.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn fracbms_pack_init_with_soc(
    memory: *mut core::ffi::c_void,
    size: usize,
    settings: *const FracbmsSettings,
    soc: *const FracbmsSocSettings,
    cells: u16,
    updates_per_period: u16,
    flag_ratio: f32,
    pack: *mut *mut FracbmsPack,
) -> FracbmsCode {
    if settings.is_null() || pack.is_null() {
        return FracbmsCode::FRACBMS_ERROR_NULL;
    }
    if state::pack_room(cells) == 0 {
        return FracbmsCode::FRACBMS_ERROR_CELL_COUNT;
    }
    // SAFETY: non-null, valid by the caller's contract.
    let c = unsafe { &*settings };
    let Some(layout) = state::pack_layout(c.window, c.memory, cells) else {
        return FracbmsCode::FRACBMS_ERROR_UNSUPPORTED_SIZE;
    };
    let memory = memory.cast::<u8>();
    let run = || {
        state::check_memory(memory, size, layout)?;
        // SAFETY: the caller's OCV arrays hold `ocv_points` values; `soc`
        // null or valid.
        let cell = unsafe { settings_with(c, soc) }?;
        let mut s = PackSettings::new(cell);
        s.updates_per_period = updates_per_period;
        s.flag_ratio = flag_ratio;
        // SAFETY: memory checked against the layout of these sizes.
        unsafe { state::pack_init_sized(memory, s, c.window, cells) }?;
        // SAFETY: `pack` non-null, valid by the caller's contract.
        unsafe { put(pack, memory.cast::<FracbmsPack>()) }
    };
    crate::code(run())
}
