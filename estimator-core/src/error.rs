//! Typed errors. Every fallible function of the crate returns one of these;
//! nothing in the crate panics on bad data.

/// Which structural order a [`Error::OrderOutOfRange`] is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OrderKind {
    /// `n_a`, the order of A(z).
    Na,
    /// `n_b`, the order of B(z).
    Nb,
    /// `n_c`, the order of the noise polynomial C(z).
    Nc,
    /// `m`, the number of basis functions of the static nonlinearity.
    Basis,
}

/// Errors of the fractional-difference operator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FracError {
    /// The order α is NaN or infinite.
    NonFiniteOrder,
    /// The sample period h is not finite and positive.
    BadSamplePeriod,
    /// The memory length is 0 or above the capacity `MEM`.
    BadMemory {
        /// Requested memory length.
        requested: usize,
        /// Compile-time capacity.
        capacity: usize,
    },
}

/// Errors of configuration, of the data window and of an identification
/// iteration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// A fractional-difference setting is invalid.
    Frac(FracError),
    /// A structural order is zero where it may not be, or above capacity.
    OrderOutOfRange {
        /// Which order.
        which: OrderKind,
        /// Requested value.
        value: usize,
        /// Compile-time capacity (or the largest admissible value).
        capacity: usize,
    },
    /// `n_b · m` exceeds the parameter capacity `NP`.
    ParameterCapacity {
        /// `n_b · m`.
        needed: usize,
        /// The const-generic capacity.
        capacity: usize,
    },
    /// An order bound, an initial order, ε or another real setting is not
    /// finite or not inside its admissible range.
    BadSetting,
    /// A sample was NaN or infinite; it was rejected and not stored.
    NonFiniteSample,
    /// The window does not yet hold enough samples for the chosen orders
    /// and memory.
    NotEnoughData {
        /// Samples (rows) available.
        have: usize,
        /// Samples (rows) needed.
        need: usize,
    },
    /// The window carries no excitation (e.g. constant zero input): the
    /// estimate is kept unchanged.
    NotExcited,
    /// The iteration produced a non-finite value; the last good estimate was
    /// restored.
    Diverged,
    /// An OCV table is malformed.
    Ocv(OcvError),
    /// The start state of charge was to be read from a rested voltage, but
    /// the record does not start at rest (the first current exceeds `C/100`).
    NotAtRest,
    /// A pack was given a number of cells (or cell voltages) other than the
    /// one it has (or more than its compile-time capacity).
    CellCount {
        /// Cells (voltages) given.
        given: usize,
        /// Cells the pack has (or can have).
        expected: usize,
    },
}

/// What is wrong with an OCV table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OcvError {
    /// Fewer than two points.
    TooFewPoints {
        /// Points given.
        have: usize,
    },
    /// More points than the table's capacity `P`.
    TooManyPoints {
        /// Points given.
        have: usize,
        /// The const-generic capacity.
        capacity: usize,
    },
    /// The SOC and OCV columns differ in length.
    LengthMismatch,
    /// A value is NaN or infinite (point index from 0).
    NonFinite {
        /// Index of the point.
        index: usize,
    },
    /// A state of charge outside `[0, 1]`.
    SocOutOfRange {
        /// Index of the point.
        index: usize,
    },
    /// The SOC or the OCV does not increase strictly from the point before
    /// (the inverse `SOC(OCV)` would not exist).
    NotIncreasing {
        /// Index of the point.
        index: usize,
    },
}

impl core::fmt::Display for OcvError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            OcvError::TooFewPoints { have } => {
                write!(f, "OCV table has {have} points; at least 2 are needed")
            }
            OcvError::TooManyPoints { have, capacity } => {
                write!(f, "OCV table has {have} points; the capacity is {capacity}")
            }
            OcvError::LengthMismatch => write!(f, "OCV table columns differ in length"),
            OcvError::NonFinite { index } => {
                write!(f, "OCV table point {index} is not finite")
            }
            OcvError::SocOutOfRange { index } => {
                write!(f, "OCV table point {index}: state of charge outside [0, 1]")
            }
            OcvError::NotIncreasing { index } => write!(
                f,
                "OCV table point {index}: soc and ocv must both increase strictly"
            ),
        }
    }
}

impl From<OcvError> for Error {
    fn from(e: OcvError) -> Self {
        Error::Ocv(e)
    }
}

impl From<FracError> for Error {
    fn from(e: FracError) -> Self {
        Error::Frac(e)
    }
}

impl core::fmt::Display for FracError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FracError::NonFiniteOrder => write!(f, "fractional order is not finite"),
            FracError::BadSamplePeriod => write!(f, "sample period must be finite and positive"),
            FracError::BadMemory {
                requested,
                capacity,
            } => write!(
                f,
                "memory length {requested} outside 1..={capacity} (the compile-time capacity)"
            ),
        }
    }
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Error::Frac(e) => e.fmt(f),
            Error::OrderOutOfRange {
                which,
                value,
                capacity,
            } => write!(f, "order {which:?} = {value} outside 1..={capacity}"),
            Error::ParameterCapacity { needed, capacity } => write!(
                f,
                "n_b*m = {needed} exceeds the parameter capacity {capacity}"
            ),
            Error::BadSetting => write!(f, "a real-valued setting is not finite or out of range"),
            Error::NonFiniteSample => write!(f, "sample is NaN or infinite"),
            Error::NotEnoughData { have, need } => {
                write!(f, "window holds {have} usable samples, {need} needed")
            }
            Error::NotExcited => write!(f, "window carries no excitation"),
            Error::Diverged => write!(f, "iteration diverged; last good estimate kept"),
            Error::Ocv(e) => e.fmt(f),
            Error::NotAtRest => write!(
                f,
                "the record does not start at rest (first current above C/100), so its start \
                 state of charge cannot be read from the OCV table; give it"
            ),
            Error::CellCount { given, expected } => {
                write!(f, "{given} cells (voltages) given, the pack has {expected}")
            }
        }
    }
}

impl core::error::Error for FracError {}
impl core::error::Error for Error {}
impl core::error::Error for OcvError {}
