//! The C types: codes, statuses, settings and estimates, and their
//! conversion to and from the core's. This module owns the mapping between
//! the two; it must not hold state.

use estimator_core::battery::ocv::{OcvModel, OcvTable};
use estimator_core::battery::online::{
    Identification, Method, OnlineSettings, PublishedParameter, PublishedParameters, Rejection,
    Status,
};
use estimator_core::battery::power::VoltageTiming;
use estimator_core::battery::snapshot::{Restoration, SnapshotError};
use estimator_core::battery::soc::SocEstimate;
use estimator_core::battery::{CellModel, CellParameters, Start};

/// Largest OCV table the C interface takes (points).
pub const FRACBMS_OCV_POINTS_MAX: usize = 128;

/// The core's settings as the C interface stores them.
pub(crate) type Settings = OnlineSettings<f32, FRACBMS_OCV_POINTS_MAX>;

/// What a call did: `FRACBMS_OK`, or why it did nothing.
#[repr(i32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FracbmsCode {
    /// Done.
    FRACBMS_OK = 0,
    /// A pointer argument is null.
    FRACBMS_ERROR_NULL = -1,
    /// The memory is not aligned as the size function reported.
    FRACBMS_ERROR_MISALIGNED = -2,
    /// The memory is smaller than the size function reported.
    FRACBMS_ERROR_TOO_SMALL = -3,
    /// This window and memory (or cell count) are not built into the
    /// library.
    FRACBMS_ERROR_UNSUPPORTED_SIZE = -4,
    /// A setting is out of range (a step `h` not positive, a memory larger
    /// than the window's capacity, limits not finite, ...).
    FRACBMS_ERROR_SETTINGS = -5,
    /// The OCV table is not strictly increasing, or its SOC is outside
    /// `[0, 1]`, or its capacity is not positive.
    FRACBMS_ERROR_OCV = -6,
    /// The state was not made by the matching `init` (or was overwritten).
    FRACBMS_ERROR_NOT_INITIALIZED = -7,
    /// A cell index or count that the pack does not have.
    FRACBMS_ERROR_CELL_COUNT = -8,
    /// Whole-record identification: the record is unusable (too short,
    /// non-uniform time, non-finite values).
    FRACBMS_ERROR_DATA = -9,
    /// Whole-record identification failed.
    FRACBMS_ERROR_FIT = -10,
    /// A parameter map is empty, longer than `FRACBMS_MAP_LEVELS_MAX`, not
    /// sorted by temperature then SOC, or a level is not finite or not a
    /// physical cell.
    FRACBMS_ERROR_MAP = -11,
    /// Restore: the bytes are not a snapshot (bad magic, e.g. erased
    /// flash) or are shorter than the snapshot they start.
    FRACBMS_ERROR_SNAPSHOT_INVALID = -12,
    /// Restore: the snapshot's CRC does not match (corrupt).
    FRACBMS_ERROR_SNAPSHOT_CRC = -13,
    /// Restore: written by another layout version (another firmware).
    FRACBMS_ERROR_SNAPSHOT_VERSION = -14,
    /// Restore: written under other settings (sample period, method,
    /// model, OCV table or capacity).
    FRACBMS_ERROR_SNAPSHOT_SETTINGS = -15,
    /// Restore: older than the given maximum age, or saved after "now".
    FRACBMS_ERROR_SNAPSHOT_STALE = -16,
    /// Restore: the snapshot holds values no estimator publishes.
    FRACBMS_ERROR_SNAPSHOT_IMPLAUSIBLE = -17,
}

/// Health of the estimate after a sample (as `host-sim online battery`'s
/// `status` column).
#[repr(i32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FracbmsStatus {
    /// The window does not yet hold enough samples.
    FRACBMS_STATUS_FILLING = 0,
    /// 2S-OP-GI runs but its estimate is not physical yet.
    FRACBMS_STATUS_STARTING = 1,
    /// The estimate was updated from this window.
    FRACBMS_STATUS_TRACKING = 2,
    /// The window's current carries no excitation, or carries it only in
    /// the warm-up before the rows it fits: estimate held.
    FRACBMS_STATUS_NOT_EXCITED = 3,
    /// The iteration failed (non-finite values): estimate held.
    FRACBMS_STATUS_HELD = 4,
    /// The window's estimate is not physical: the last good one is held.
    FRACBMS_STATUS_UNPHYSICAL = 5,
    /// A parameter of the window's estimate is at its bound: held.
    FRACBMS_STATUS_AT_BOUND = 6,
    /// The window's estimate relaxes slower than the window sees: held.
    FRACBMS_STATUS_SLOW_RELAXATION = 7,
    /// The window's open-circuit voltage is implausible: held.
    FRACBMS_STATUS_OCV_IMPLAUSIBLE = 8,
}

impl From<Status> for FracbmsStatus {
    fn from(s: Status) -> Self {
        match s {
            Status::Filling => Self::FRACBMS_STATUS_FILLING,
            Status::Starting => Self::FRACBMS_STATUS_STARTING,
            Status::Tracking => Self::FRACBMS_STATUS_TRACKING,
            Status::NotExcited => Self::FRACBMS_STATUS_NOT_EXCITED,
            Status::Held => Self::FRACBMS_STATUS_HELD,
            Status::Unphysical => Self::FRACBMS_STATUS_UNPHYSICAL,
            Status::AtBound => Self::FRACBMS_STATUS_AT_BOUND,
            Status::SlowRelaxation => Self::FRACBMS_STATUS_SLOW_RELAXATION,
            Status::OcvImplausible => Self::FRACBMS_STATUS_OCV_IMPLAUSIBLE,
        }
    }
}

impl FracbmsStatus {
    /// The core's status of a C value, if any.
    pub(crate) fn core(v: i32) -> Option<Status> {
        usize::try_from(v)
            .ok()
            .and_then(|k| Status::ALL.get(k).copied())
    }
}

/// Why this sample was rejected (it was then counted and substituted).
#[repr(i32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FracbmsRejection {
    /// Not rejected.
    FRACBMS_REJECTION_NONE = 0,
    /// NaN or infinite.
    FRACBMS_REJECTION_NON_FINITE = 1,
    /// Outside the plausible current or voltage range.
    FRACBMS_REJECTION_OUT_OF_RANGE = 2,
    /// Too far from the model's one-step prediction.
    FRACBMS_REJECTION_SPIKE = 3,
}

impl From<Option<Rejection>> for FracbmsRejection {
    fn from(r: Option<Rejection>) -> Self {
        match r {
            None => Self::FRACBMS_REJECTION_NONE,
            Some(Rejection::NonFinite) => Self::FRACBMS_REJECTION_NON_FINITE,
            Some(Rejection::OutOfRange) => Self::FRACBMS_REJECTION_OUT_OF_RANGE,
            Some(Rejection::Spike) => Self::FRACBMS_REJECTION_SPIKE,
        }
    }
}

/// Identification method.
#[repr(i32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FracbmsMethod {
    /// The paper's 2S-OP-GI on the §6.2 regression.
    FRACBMS_METHOD_PAPER = 0,
    /// Output-error refinement started from 2S-OP-GI (the most accurate).
    FRACBMS_METHOD_REFINED = 1,
}

impl FracbmsMethod {
    /// The method with this value, if any.
    pub(crate) fn from_i32(v: i32) -> Option<Self> {
        [Self::FRACBMS_METHOD_PAPER, Self::FRACBMS_METHOD_REFINED]
            .into_iter()
            .find(|m| *m as i32 == v)
    }
}

/// Cell model.
#[repr(i32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FracbmsModel {
    /// `U_t = U_oc + R_i·I + U_p` (the paper's).
    FRACBMS_MODEL_LINEAR = 0,
    /// With the Butler–Volmer overpotential `a·asinh(I/i₀)`.
    FRACBMS_MODEL_BUTLER_VOLMER = 1,
    /// Whole-record identification only: the Butler–Volmer model when the
    /// data identify it, else the linear one (as `--model auto`).
    FRACBMS_MODEL_AUTO = 2,
}

/// Where in the period whose mean current a sample holds its voltage was
/// taken (`FracbmsSettings::voltage_timing`; the core's `VoltageTiming`).
#[repr(i32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FracbmsVoltageTiming {
    /// At the period's end: a gauge, a simulation.
    FRACBMS_VOLTAGE_AT_END = 0,
    /// The mean over the period: a log put on a coarser period than its
    /// rows.
    FRACBMS_VOLTAGE_MEAN = 1,
    /// At the period's start.
    FRACBMS_VOLTAGE_AT_START = 2,
}

impl FracbmsVoltageTiming {
    /// The timing with this value, if any.
    pub(crate) fn from_i32(v: i32) -> Option<Self> {
        [
            Self::FRACBMS_VOLTAGE_AT_END,
            Self::FRACBMS_VOLTAGE_MEAN,
            Self::FRACBMS_VOLTAGE_AT_START,
        ]
        .into_iter()
        .find(|m| *m as i32 == v)
    }
}

impl From<VoltageTiming> for FracbmsVoltageTiming {
    fn from(t: VoltageTiming) -> Self {
        match t {
            VoltageTiming::End => Self::FRACBMS_VOLTAGE_AT_END,
            VoltageTiming::Mean => Self::FRACBMS_VOLTAGE_MEAN,
            VoltageTiming::Start => Self::FRACBMS_VOLTAGE_AT_START,
        }
    }
}

/// The cell's parameters (SI units: Ω, F·s^(α−1), V, A).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FracbmsParameters {
    /// Ohmic resistance `R_i` (Ω).
    pub r_i: f32,
    /// Charge-transfer resistance `R_ct` (Ω).
    pub r_ct: f32,
    /// Constant-phase-element coefficient `Q` (F·s^(α−1)).
    pub q: f32,
    /// Fractional order α.
    pub alpha: f32,
    /// Open-circuit voltage (V); with an OCV table `OCV(SOC) + ΔU`.
    pub u_oc: f32,
    /// Butler–Volmer coefficient `a` (V); 0 in the linear model.
    pub bv_a: f32,
    /// Butler–Volmer exchange current `i₀` (A).
    pub bv_i0: f32,
}

impl FracbmsModel {
    /// The model with this value, if any.
    pub(crate) fn from_i32(v: i32) -> Option<Self> {
        [
            Self::FRACBMS_MODEL_LINEAR,
            Self::FRACBMS_MODEL_BUTLER_VOLMER,
            Self::FRACBMS_MODEL_AUTO,
        ]
        .into_iter()
        .find(|m| *m as i32 == v)
    }
}

impl From<CellParameters<f32>> for FracbmsParameters {
    fn from(p: CellParameters<f32>) -> Self {
        Self {
            r_i: p.r_i,
            r_ct: p.r_ct,
            q: p.q,
            alpha: p.alpha,
            u_oc: p.u_oc,
            bv_a: p.bv_a,
            bv_i0: p.bv_i0,
        }
    }
}

impl From<FracbmsParameters> for CellParameters<f32> {
    fn from(p: FracbmsParameters) -> Self {
        Self {
            r_i: p.r_i,
            r_ct: p.r_ct,
            q: p.q,
            alpha: p.alpha,
            u_oc: p.u_oc,
            bv_a: p.bv_a,
            bv_i0: p.bv_i0,
        }
    }
}

/// Settings of the online estimator (one cell, or every cell of a pack).
/// Fill with `fracbms_settings_default`, then change what differs.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct FracbmsSettings {
    /// Sample period `h` (s).
    pub h: f32,
    /// Sliding-window length `L` (samples): 256 (64, 128, 512, 1024 when
    /// the library is built with the feature `all-windows`).
    pub window: u16,
    /// Grünwald–Letnikov memory `M` (samples), `1 ..= window / 4`.
    pub memory: u16,
    /// Identification method, a `FracbmsMethod` (an integer in the C
    /// structs the caller fills: another value is `FRACBMS_ERROR_SETTINGS`).
    pub method: i32,
    /// Iterations run after each sample (each cell update of a pack).
    pub iterations_per_sample: u16,
    /// The cell is at rest at power-up (the polarization starts from 0
    /// until the window first slides), as a BMS starts. `false`: the
    /// polarization of the window's first samples is taken from the data.
    pub start_at_rest: bool,
    /// Cell model, `FRACBMS_MODEL_LINEAR` or `FRACBMS_MODEL_BUTLER_VOLMER`.
    pub model: i32,
    /// The short-memory correction (the Grünwald–Letnikov taps beyond the
    /// memory as 6 exponential modes; +32 % cost per update).
    pub tail: bool,
    /// Start of the estimate (and fallback while 2S-OP-GI starts).
    pub initial: FracbmsParameters,
    /// Largest plausible `|I|` (A); beyond it a sample is rejected.
    pub current_limit: f32,
    /// Lower end of the plausible terminal voltage (V).
    pub voltage_min: f32,
    /// Upper end of the plausible terminal voltage (V).
    pub voltage_max: f32,
    /// The OCV table's states of charge (`ocv_points` values in `[0, 1]`,
    /// strictly increasing), or null without a table. Read during `init`
    /// only (copied into the state).
    pub ocv_soc: *const f32,
    /// The OCV table's voltages (V), `ocv_points` values.
    pub ocv_v: *const f32,
    /// Points of the OCV table (0: no table, constant `U_oc` and the OCV
    /// slope fitted); at most `FRACBMS_OCV_POINTS_MAX`.
    pub ocv_points: u16,
    /// The cell's capacity (A·h), with a table.
    pub capacity_ah: f32,
    /// The memory (s) of the slow part carried across windows
    /// (`--slow-memory-s`): the published `R_ct`, `Q` and α are the mean of
    /// what the windows identified, an earlier value weighing
    /// `exp(−Δt/slow_memory_s)` less. 0 (the default): each window's own.
    /// Negative or NaN: `FRACBMS_ERROR_SETTINGS`.
    pub slow_memory_s: f32,
    /// The slow part's memory in state of charge (`--slow-memory-soc`,
    /// default 0.02): an earlier value weighs `exp(−|ΔSOC|/slow_memory_soc)`
    /// less besides. Not positive or NaN: `FRACBMS_ERROR_SETTINGS`.
    pub slow_memory_soc: f32,
    /// The current (A, + charging) of the pulse whose voltage the state of
    /// power is asked for (`FracbmsPowerRequest::pulse_current`): a
    /// request at this current (within a tenth) has its pulse voltage
    /// corrected by the last pulse of that current's measured over
    /// predicted drop (`FracbmsHorizonPower::pulse_ratio`), as `host-sim
    /// online battery` does unless `--no-pulse-correction`. NaN (the
    /// default) or 0: no correction. Infinite: `FRACBMS_ERROR_SETTINGS`.
    pub pulse_current: f32,
    /// Where in the period whose mean current a sample holds its voltage
    /// was taken, as the check of the state of power against the next
    /// pulse places it: `FRACBMS_VOLTAGE_AT_END` (the default: a gauge
    /// that integrates the current over the period before each reading, as
    /// the bq769x0 does), `FRACBMS_VOLTAGE_MEAN` (a log put on a coarser
    /// period than its rows, as `host-sim online battery` resamples it) or
    /// `FRACBMS_VOLTAGE_AT_START`. Another value: `FRACBMS_ERROR_SETTINGS`.
    pub voltage_timing: i32,
}

/// One sample's outcome and the estimate after it.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct FracbmsEstimate {
    /// Health of the estimate.
    pub status: FracbmsStatus,
    /// Whether (and why) this sample was rejected.
    pub rejection: FracbmsRejection,
    /// Iterations run for this sample.
    pub iterations: u16,
    /// `parameters` holds an estimate (false until the first one).
    pub valid: bool,
    /// The last good estimate (all 0 while `valid` is false).
    pub parameters: FracbmsParameters,
    /// Coulomb-counted state of charge (with an OCV table; NaN otherwise).
    pub state_of_charge: f32,
    /// OCV offset `ΔU` (V) of the estimate (with a table; NaN otherwise).
    pub ocv_offset: f32,
    /// RMSE (V) of the window's fit after the last iteration.
    pub rmse: f32,
    /// Samples pushed so far.
    pub samples: u32,
    /// Samples rejected so far.
    pub rejected: u32,
    /// Pack only: the cell's `R_i` or `R_ct` stands out of the pack's
    /// median by more than the flag ratio.
    pub flagged: bool,
    /// What is published of each parameter: only what the data identify
    /// (`parameters` is the window's fit, identified or not).
    pub published: FracbmsPublished,
    /// The resistance `ΔU/ΔI` of the last clean current step (Ω; NaN
    /// before one), the model-free check of `R_i`.
    pub step_resistance: f32,
    /// The SOC observer's estimate (with an OCV table; all NaN before the
    /// start SOC is known). `state_of_charge` is the count.
    pub soc: FracbmsSoc,
    /// Whether the cell started from a snapshot, and whether its SOC stood
    /// against the first rested voltage.
    pub restoration: FracbmsRestoration,
}

/// How a cell started (`estimator_core::battery::snapshot::Restoration`;
/// as `host-sim online battery`'s `restoration` column).
#[repr(i32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FracbmsRestoration {
    /// Started clean (no snapshot restored).
    #[default]
    FRACBMS_RESTORATION_CLEAN = 0,
    /// Started from a snapshot; its SOC stands.
    FRACBMS_RESTORATION_RESTORED = 1,
    /// Started from a snapshot whose SOC a rested first voltage
    /// contradicted: read again through the OCV table.
    FRACBMS_RESTORATION_SOC_REREAD = 2,
}

impl From<Restoration> for FracbmsRestoration {
    fn from(r: Restoration) -> Self {
        match r {
            Restoration::Clean => Self::FRACBMS_RESTORATION_CLEAN,
            Restoration::Restored => Self::FRACBMS_RESTORATION_RESTORED,
            Restoration::SocReread => Self::FRACBMS_RESTORATION_SOC_REREAD,
        }
    }
}

impl From<SnapshotError> for FracbmsCode {
    fn from(e: SnapshotError) -> Self {
        match e {
            SnapshotError::TooShort { .. } | SnapshotError::NotASnapshot => {
                Self::FRACBMS_ERROR_SNAPSHOT_INVALID
            }
            SnapshotError::Crc => Self::FRACBMS_ERROR_SNAPSHOT_CRC,
            SnapshotError::Version { .. } => Self::FRACBMS_ERROR_SNAPSHOT_VERSION,
            SnapshotError::CellCount { .. } => Self::FRACBMS_ERROR_CELL_COUNT,
            SnapshotError::Settings => Self::FRACBMS_ERROR_SNAPSHOT_SETTINGS,
            SnapshotError::Stale { .. } => Self::FRACBMS_ERROR_SNAPSHOT_STALE,
            SnapshotError::Implausible { .. } => Self::FRACBMS_ERROR_SNAPSHOT_IMPLAUSIBLE,
        }
    }
}

/// The SOC observer's estimate (`estimator_core::battery::soc`): coulomb
/// counting corrected at rest by the OCV table, with the current sensor's
/// bias and the capacity estimated; as `host-sim online battery`'s `soc`,
/// `current_bias_a`, `capacity_ah`, `soc_sigma`, `soc_ocv_weight`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FracbmsSoc {
    /// The published state of charge (0..1).
    pub state_of_charge: f32,
    /// Its standard deviation.
    pub sigma: f32,
    /// The current sensor's bias (A): measured − true.
    pub current_bias: f32,
    /// The estimated capacity (A·h).
    pub capacity_ah: f32,
    /// Its standard deviation (A·h): large where the data do not tell the
    /// capacity from the bias.
    pub capacity_sigma_ah: f32,
    /// Whether the data identify the capacity now (else `capacity_ah` is
    /// the last identified, or the nominal one).
    pub capacity_identified: bool,
    /// The last rest's weight on the SOC, 0..1 (near 0 on a flat OCV).
    pub ocv_weight: f32,
    /// Rest observations so far.
    pub observations: u32,
}

impl FracbmsSoc {
    /// Nothing known: NaN, 0 observations.
    pub const NONE: Self = Self {
        state_of_charge: f32::NAN,
        sigma: f32::NAN,
        current_bias: f32::NAN,
        capacity_ah: f32::NAN,
        capacity_sigma_ah: f32::NAN,
        capacity_identified: false,
        ocv_weight: f32::NAN,
        observations: 0,
    };
}

impl From<SocEstimate<f32>> for FracbmsSoc {
    fn from(e: SocEstimate<f32>) -> Self {
        Self {
            state_of_charge: e.soc,
            sigma: e.sigma,
            current_bias: e.current_bias_a,
            capacity_ah: e.capacity_ah,
            capacity_sigma_ah: e.capacity_sigma_ah,
            capacity_identified: e.capacity_identified,
            ocv_weight: e.ocv_weight,
            observations: e.observations,
        }
    }
}

/// Whether a published parameter comes from the data (as `host-sim online
/// battery`'s `*_status` columns; `fracbms_identification_name`).
#[repr(i32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FracbmsIdentification {
    /// No window has identified it yet: nothing is published (NaN).
    FRACBMS_IDENTIFICATION_NOT_IDENTIFIED = 0,
    /// The last window identified it.
    FRACBMS_IDENTIFICATION_IDENTIFIED = 1,
    /// The last window did not: the value of the last one that did.
    FRACBMS_IDENTIFICATION_HELD = 2,
    /// `R_i` only: fitted with the last current step's resistance as
    /// evidence, the window alone not separating it from the branch.
    FRACBMS_IDENTIFICATION_STEP = 3,
    /// Identified at a state of charge too far from the present one:
    /// nothing is published (NaN).
    FRACBMS_IDENTIFICATION_EXPIRED = 4,
    /// From a snapshot restored at start-up (`fracbms_*_snapshot_restore`):
    /// what was published before the reset, until a window identifies it
    /// again.
    FRACBMS_IDENTIFICATION_RESTORED = 5,
    /// A prior is set and the last window's data alone do not identify
    /// it: the window's estimate, which the prior holds where the data say
    /// nothing.
    FRACBMS_IDENTIFICATION_PRIOR = 6,
}

impl From<Identification> for FracbmsIdentification {
    fn from(s: Identification) -> Self {
        match s {
            Identification::NotIdentified => Self::FRACBMS_IDENTIFICATION_NOT_IDENTIFIED,
            Identification::Identified => Self::FRACBMS_IDENTIFICATION_IDENTIFIED,
            Identification::Held => Self::FRACBMS_IDENTIFICATION_HELD,
            Identification::Step => Self::FRACBMS_IDENTIFICATION_STEP,
            Identification::Expired => Self::FRACBMS_IDENTIFICATION_EXPIRED,
            Identification::Restored => Self::FRACBMS_IDENTIFICATION_RESTORED,
            Identification::Prior => Self::FRACBMS_IDENTIFICATION_PRIOR,
        }
    }
}

impl FracbmsIdentification {
    /// The core's identification of a C value, if any.
    pub(crate) fn core(v: i32) -> Option<Identification> {
        [
            Identification::NotIdentified,
            Identification::Identified,
            Identification::Held,
            Identification::Step,
            Identification::Expired,
            Identification::Restored,
            Identification::Prior,
        ]
        .into_iter()
        .find(|&s| Self::from(s) as i32 == v)
    }
}

/// The parameters a cell publishes: each value (NaN when nothing is
/// published) with its status.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FracbmsPublished {
    /// `R_i` (Ω).
    pub r_i: f32,
    /// `R_ct` (Ω).
    pub r_ct: f32,
    /// `Q`.
    pub q: f32,
    /// The order α.
    pub alpha: f32,
    /// Status of `r_i`.
    pub r_i_status: FracbmsIdentification,
    /// Status of `r_ct`.
    pub r_ct_status: FracbmsIdentification,
    /// Status of `q`.
    pub q_status: FracbmsIdentification,
    /// Status of `alpha`.
    pub alpha_status: FracbmsIdentification,
}

impl From<PublishedParameters<f32>> for FracbmsPublished {
    fn from(p: PublishedParameters<f32>) -> Self {
        let v = |x: PublishedParameter<f32>| x.value.unwrap_or(f32::NAN);
        Self {
            r_i: v(p.r_i),
            r_ct: v(p.r_ct),
            q: v(p.q),
            alpha: v(p.alpha),
            r_i_status: p.r_i.status.into(),
            r_ct_status: p.r_ct.status.into(),
            q_status: p.q.status.into(),
            alpha_status: p.alpha.status.into(),
        }
    }
}

/// Converts the C settings into the core's, copying the OCV table.
///
/// # Safety
/// `ocv_soc` and `ocv_v` must each point to `ocv_points` readable `f32`
/// when `ocv_points > 0`.
pub(crate) unsafe fn settings(c: &FracbmsSettings) -> Result<Settings, FracbmsCode> {
    let mut s = OnlineSettings::new(c.h, usize::from(c.memory), c.initial.into());
    s.battery.start = if c.start_at_rest {
        Start::AtRest
    } else {
        Start::FromData
    };
    s.method = match FracbmsMethod::from_i32(c.method) {
        Some(FracbmsMethod::FRACBMS_METHOD_PAPER) => Method::Paper,
        Some(FracbmsMethod::FRACBMS_METHOD_REFINED) => Method::Refined,
        None => return Err(FracbmsCode::FRACBMS_ERROR_SETTINGS),
    };
    s.iterations_per_sample = c.iterations_per_sample;
    s.battery.model = match FracbmsModel::from_i32(c.model) {
        Some(FracbmsModel::FRACBMS_MODEL_LINEAR) => CellModel::Linear,
        Some(FracbmsModel::FRACBMS_MODEL_BUTLER_VOLMER) => CellModel::ButlerVolmer,
        _ => return Err(FracbmsCode::FRACBMS_ERROR_SETTINGS),
    };
    s.battery.tail = c.tail;
    s.slow_memory_s = c.slow_memory_s;
    s.slow_memory_soc = c.slow_memory_soc;
    s.pulse_current = match c.pulse_current {
        i if i.is_nan() || i == 0.0 => None,
        i if i.is_finite() => Some(i),
        _ => return Err(FracbmsCode::FRACBMS_ERROR_SETTINGS),
    };
    s.voltage_timing = match FracbmsVoltageTiming::from_i32(c.voltage_timing) {
        Some(FracbmsVoltageTiming::FRACBMS_VOLTAGE_AT_END) => VoltageTiming::End,
        Some(FracbmsVoltageTiming::FRACBMS_VOLTAGE_MEAN) => VoltageTiming::Mean,
        Some(FracbmsVoltageTiming::FRACBMS_VOLTAGE_AT_START) => VoltageTiming::Start,
        None => return Err(FracbmsCode::FRACBMS_ERROR_SETTINGS),
    };
    s.current_limit = c.current_limit;
    s.voltage_min = c.voltage_min;
    s.voltage_max = c.voltage_max;
    let points = usize::from(c.ocv_points);
    let curve = if points == 0 {
        None
    } else {
        if c.ocv_soc.is_null() || c.ocv_v.is_null() {
            return Err(FracbmsCode::FRACBMS_ERROR_NULL);
        }
        if points > FRACBMS_OCV_POINTS_MAX {
            return Err(FracbmsCode::FRACBMS_ERROR_OCV);
        }
        // SAFETY: the caller guarantees `points` readable values at each
        // non-null pointer (checked above); they are only read here.
        let (soc, v) = unsafe {
            (
                core::slice::from_raw_parts(c.ocv_soc, points),
                core::slice::from_raw_parts(c.ocv_v, points),
            )
        };
        let table = OcvTable::new(soc, v).map_err(|_| FracbmsCode::FRACBMS_ERROR_OCV)?;
        Some(OcvModel::new(table, c.capacity_ah).map_err(|_| FracbmsCode::FRACBMS_ERROR_OCV)?)
    };
    Ok(s.with_curve(curve))
}

/// The defaults of the Rust firmware for sample period `h` at window 256,
/// memory 64.
pub(crate) fn default_settings(h: f32) -> FracbmsSettings {
    let core = OnlineSettings::new(h, 64, CellParameters::<f32>::cell_18650());
    FracbmsSettings {
        h,
        window: 256,
        memory: 64,
        method: FracbmsMethod::FRACBMS_METHOD_REFINED as i32,
        iterations_per_sample: 1,
        start_at_rest: true,
        model: FracbmsModel::FRACBMS_MODEL_LINEAR as i32,
        tail: false,
        initial: core.initial.into(),
        current_limit: core.current_limit,
        voltage_min: core.voltage_min,
        voltage_max: core.voltage_max,
        ocv_soc: core::ptr::null(),
        ocv_v: core::ptr::null(),
        ocv_points: 0,
        capacity_ah: 0.0,
        slow_memory_s: core.slow_memory_s,
        slow_memory_soc: core.slow_memory_soc,
        pulse_current: f32::NAN,
        voltage_timing: FracbmsVoltageTiming::from(core.voltage_timing) as i32,
    }
}
