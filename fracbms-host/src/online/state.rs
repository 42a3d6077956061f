//! What survives a reset, on the host: `online battery|pack --state-in FILE
//! --state-out FILE`, so that a record can be replayed in two halves as a
//! BMS that reset between them would run it.
//!
//! The snapshot is the core's ([`estimator_core::battery::snapshot`]: the
//! same bytes as the firmware's flash and the C ABI's
//! `fracbms_*_snapshot_save`); this module only reads and writes its file
//! and turns the record's time into the snapshot's clock. It must not
//! judge a snapshot: the core does.

use std::path::Path;

use estimator_core::battery::snapshot::SnapshotError;

use crate::error::{IoContext, Result};
use crate::io;

/// The record's time `t` (s) as the snapshot's clock: whole seconds, or
/// unknown (`None`) for a time that is not finite or outside `u32`'s
/// range (a record that starts at a negative time).
pub fn record_clock(t: f64) -> Option<u32> {
    (t.is_finite() && t >= 0.0 && t < f64::from(u32::MAX)).then(|| t.floor() as u32)
}

/// A snapshot saved into a buffer of its own `size` by `save` (a
/// [`estimator_core::battery::pack::PackEstimator::save`] or a cell's):
/// the buffer is the snapshot's size, so saving cannot fail (an empty
/// vector if it did).
pub(crate) fn saved<E>(
    size: usize,
    save: impl FnOnce(&mut [u8]) -> std::result::Result<usize, E>,
) -> Vec<u8> {
    let mut buf = vec![0; size];
    let n = save(&mut buf).unwrap_or(0);
    buf.truncate(n);
    buf
}

/// How a `--state-in` snapshot was taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StateIn {
    /// No `--state-in`.
    NotGiven,
    /// Restored: the estimator starts from it.
    Restored,
    /// Rejected by the core's checks: the estimator starts clean.
    Rejected(SnapshotError),
}

impl StateIn {
    /// The outcome of a restore.
    pub fn of(r: std::result::Result<(), SnapshotError>) -> Self {
        match r {
            Ok(()) => StateIn::Restored,
            Err(e) => StateIn::Rejected(e),
        }
    }

    /// One line for the CLI's log (none without `--state-in`).
    pub fn describe(&self, path: &Path) -> Option<String> {
        match self {
            StateIn::NotGiven => None,
            StateIn::Restored => Some(format!("{}: snapshot restored", path.display())),
            StateIn::Rejected(e) => Some(format!(
                "warning: {}: snapshot rejected ({e}); starting clean",
                path.display()
            )),
        }
    }
}

/// Reads a snapshot file (`--state-in`).
///
/// # Errors
/// A file that cannot be read.
pub fn read_state(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).io_context(|| format!("--state-in {}: cannot read", path.display()))
}

/// Writes a snapshot file (`--state-out`), atomically.
///
/// # Errors
/// A file that cannot be written.
pub fn write_state(path: &Path, bytes: &[u8]) -> Result<()> {
    io::write_atomic(path, |w| {
        w.write_all(bytes)
            .io_context(|| format!("--state-out {}: cannot write", path.display()))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_record_clock_is_whole_seconds_or_unknown() {
        assert_eq!(record_clock(12.9), Some(12));
        assert_eq!(record_clock(0.0), Some(0));
        assert_eq!(record_clock(-1.0), None);
        assert_eq!(record_clock(f64::NAN), None);
        assert_eq!(record_clock(5e9), None);
    }
}
