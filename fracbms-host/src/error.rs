//! The library's typed error: what went wrong ([`ErrorKind`]) and one line
//! that says it, naming the file, the row and the column, or the option.
//!
//! Every face shows the message as it is: the CLI prints it after
//! `error: `, Python raises it as `ValueError` (`OSError` for
//! [`ErrorKind::Io`]), the C ABI returns a status by its kind. This module
//! owns the error type and its conversions; it must not format messages for
//! a particular face.

use std::fmt;

/// What kind of failure an [`Error`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ErrorKind {
    /// A file could not be opened, read, created or written.
    Io,
    /// The data (a record, an OCV table, a prior) are not what the function
    /// needs: not a number, a missing column, too few rows, a time step
    /// that is not uniform, a record that does not start at rest.
    Data,
    /// An option's value is out of range, or options contradict each other.
    Options,
    /// An estimator of `estimator-core` stopped on these data (no
    /// excitation, divergence, no physical estimate).
    Estimator,
    /// A fault of ours (please report it).
    Internal,
}

impl ErrorKind {
    /// The kind's name: `io`, `data`, `options`, `estimator`, `internal`.
    pub fn as_str(self) -> &'static str {
        match self {
            ErrorKind::Io => "io",
            ErrorKind::Data => "data",
            ErrorKind::Options => "options",
            ErrorKind::Estimator => "estimator",
            ErrorKind::Internal => "internal",
        }
    }
}

/// An error of the host library: its kind and a one-line message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error {
    kind: ErrorKind,
    message: String,
}

/// `Result` with the library's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// An error of `kind` saying `message`.
    pub fn new(kind: ErrorKind, message: impl Into<String>) -> Self {
        Self {
            kind,
            message: message.into(),
        }
    }

    /// What kind of failure it is.
    pub fn kind(&self) -> ErrorKind {
        self.kind
    }

    /// The one-line message.
    pub fn message(&self) -> &str {
        &self.message
    }

    /// The same error with `prefix: ` before its message (e.g. the file).
    pub fn prefixed(self, prefix: impl fmt::Display) -> Self {
        Self {
            kind: self.kind,
            message: format!("{prefix}: {}", self.message),
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Error {}

impl From<estimator_core::Error> for Error {
    fn from(e: estimator_core::Error) -> Self {
        Self::new(ErrorKind::Estimator, e.to_string())
    }
}

impl From<estimator_core::FracError> for Error {
    fn from(e: estimator_core::FracError) -> Self {
        Self::new(ErrorKind::Estimator, e.to_string())
    }
}

impl From<std::io::Error> for Error {
    fn from(e: std::io::Error) -> Self {
        Self::new(ErrorKind::Io, e.to_string())
    }
}

impl From<csv::Error> for Error {
    fn from(e: csv::Error) -> Self {
        Self::new(ErrorKind::Io, e.to_string())
    }
}

impl From<serde_json::Error> for Error {
    fn from(e: serde_json::Error) -> Self {
        Self::new(ErrorKind::Io, e.to_string())
    }
}

impl From<fmt::Error> for Error {
    fn from(e: fmt::Error) -> Self {
        Self::new(ErrorKind::Internal, e.to_string())
    }
}

/// Says what was being done when an I/O call failed: `context: cause`.
pub trait IoContext<T> {
    /// The error as [`ErrorKind::Io`] with `what()` before its cause.
    fn io_context<S: fmt::Display>(self, what: impl FnOnce() -> S) -> Result<T>;
}

impl<T, E: fmt::Display> IoContext<T> for std::result::Result<T, E> {
    fn io_context<S: fmt::Display>(self, what: impl FnOnce() -> S) -> Result<T> {
        self.map_err(|e| Error::new(ErrorKind::Io, format!("{}: {e}", what())))
    }
}

/// A number as an error message shows it: as Rust prints it between
/// 10⁻⁴ and 10⁹ (`0.0005`, `11718001`), in exponent form beyond
/// (`1e-300`, `1e308`), where the plain form runs to hundreds of digits.
///
/// ```
/// use fracbms_host::error::shown;
/// assert_eq!(shown(0.0005), "0.0005");
/// assert_eq!(shown(1e-300), "1e-300");
/// assert_eq!(shown(5.859e9), "5.859e9");
/// ```
pub fn shown(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-4..1e9).contains(&x.abs()) {
        x.to_string()
    } else {
        format!("{x:e}")
    }
}

/// An [`Error`] of a kind (`Data`, `Options`, …) with a formatted message.
#[macro_export]
#[doc(hidden)]
macro_rules! err {
    ($kind:ident, $($fmt:tt)+) => {
        $crate::error::Error::new($crate::error::ErrorKind::$kind, format!($($fmt)+))
    };
}

/// Returns an [`Error`] of a kind with a formatted message.
#[macro_export]
#[doc(hidden)]
macro_rules! bail {
    ($kind:ident, $($fmt:tt)+) => {
        return Err($crate::err!($kind, $($fmt)+))
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn io_context_puts_the_cause_after_the_context() {
        let r: std::result::Result<(), std::io::Error> =
            Err(std::io::Error::new(std::io::ErrorKind::NotFound, "gone"));
        let e = r.io_context(|| "x.csv: cannot open").unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Io);
        assert_eq!(e.to_string(), "x.csv: cannot open: gone");
    }

    #[test]
    fn prefixed_keeps_the_kind() {
        let e = err!(Data, "row {}: bad", 3).prefixed("f.csv");
        assert_eq!(e.kind(), ErrorKind::Data);
        assert_eq!(e.message(), "f.csv: row 3: bad");
    }
}
