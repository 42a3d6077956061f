//! What the tracker reports: a cell's health after an update ([`Status`]),
//! why a sample was rejected ([`Rejection`]), one sample's report and the
//! running counters.

/// Health of the estimate after a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Status {
    /// The window does not yet hold enough samples.
    Filling,
    /// 2S-OP-GI is running but its estimate is not physical yet.
    Starting,
    /// The estimate was updated from this window.
    Tracking,
    /// The window's current carries no excitation, or carries it only in
    /// the warm-up before the rows it fits: estimate held.
    NotExcited,
    /// The iteration failed (non-finite values): estimate held.
    Held,
    /// The window's estimate is not physical (a resistance or `Q` not
    /// positive, α outside `(0, 1]`): the last good estimate is held.
    Unphysical,
    /// The window's estimate has a parameter at its bound: α at the
    /// search's bound, or `R_ct` so small (towards 0) that the branch's
    /// swing `R_ct·σ_I` is below the fit's RMSE. Not identified; the last
    /// good estimate is held.
    AtBound,
    /// The window's estimate relaxes slower than the window can see
    /// (`τ^(1/α)` beyond [`OnlineSettings::max_relaxation_windows`](super::OnlineSettings::max_relaxation_windows),
    /// and beyond the prior's own relaxation
    /// ([`OnlineSettings::prior_relaxation`](super::OnlineSettings::prior_relaxation))): the
    /// branch would be imitating a drift; the last good estimate is held.
    SlowRelaxation,
    /// The window's open-circuit voltage is outside the plausible voltage
    /// range (with a curve: `|ΔU|` above [`OnlineSettings::max_ocv_offset`](super::OnlineSettings::max_ocv_offset)):
    /// the last good estimate is held.
    OcvImplausible,
}

impl Status {
    /// A short lower-case name (for logs and CSV files).
    pub fn as_str(&self) -> &'static str {
        match self {
            Status::Filling => "filling",
            Status::Starting => "starting",
            Status::Tracking => "tracking",
            Status::NotExcited => "not_excited",
            Status::Held => "held",
            Status::Unphysical => "unphysical",
            Status::AtBound => "at_bound",
            Status::SlowRelaxation => "slow_relaxation",
            Status::OcvImplausible => "ocv_implausible",
        }
    }

    /// Every status, in the order of the enum (for documentation and
    /// tests).
    pub const ALL: [Status; 9] = [
        Status::Filling,
        Status::Starting,
        Status::Tracking,
        Status::NotExcited,
        Status::Held,
        Status::Unphysical,
        Status::AtBound,
        Status::SlowRelaxation,
        Status::OcvImplausible,
    ];

    /// True when the estimate was held because the window's estimate was
    /// not plausible.
    pub fn is_implausible(&self) -> bool {
        matches!(
            self,
            Status::Unphysical | Status::AtBound | Status::SlowRelaxation | Status::OcvImplausible
        )
    }
}

/// Why a sample was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Rejection {
    /// NaN or infinite.
    NonFinite,
    /// Outside the plausible current or voltage range.
    OutOfRange,
    /// Too far from the model's prediction.
    Spike,
}

/// What one sample did.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SampleReport<T> {
    /// Health of the estimate.
    pub status: Status,
    /// `Some` when the sample was rejected (and substituted).
    pub rejected: Option<Rejection>,
    /// Iterations run for this sample.
    pub iterations: u16,
    /// The fit's RMSE (V) after the last successful iteration.
    pub rmse: T,
}

/// Counters of everything the estimator has seen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SampleCounts {
    /// Samples offered to [`CellEstimator::push`](crate::battery::online::CellEstimator::push).
    pub samples: u64,
    /// Rejected as NaN/∞.
    pub non_finite: u32,
    /// Rejected as out of range.
    pub out_of_range: u32,
    /// Rejected as spikes.
    pub spikes: u32,
}

impl SampleCounts {
    /// All rejected samples.
    pub fn rejected(&self) -> u32 {
        self.non_finite + self.out_of_range + self.spikes
    }
}
