//! A snapshot of what the cells have learned, to survive a reset.
//!
//! A BMS microcontroller resets (brown-outs, watchdogs, firmware updates, a
//! vehicle parked for a month). Without a snapshot every reset starts the
//! estimator from nothing: the window refills and nothing is published
//! until it is excited again. [`PackEstimator::save`] writes, per cell, what
//! the cell has learned; [`PackEstimator::restore`] takes it back at boot,
//! with judgement:
//!
//! * the snapshot's magic, layout version ([`OLDEST_READ_VERSION`] to
//!   [`SNAPSHOT_VERSION`]) and CRC are right, its cell count is the pack's, and it was written under the
//!   same settings (a fingerprint of the sample period, the method, the
//!   model and the OCV table with the capacity: what the stored numbers
//!   mean);
//! * it is not stale ([`RestorePolicy::max_age_s`], when the caller has a
//!   clock);
//! * its values are plausible (finite, physical parameters, finite
//!   states of charge);
//! * at the first good sample, a rested voltage (current at most `C/100`)
//!   that contradicts the stored SOC by more than the estimator allows an
//!   OCV offset ([`OnlineSettings::max_ocv_offset`]) means the SOC is read
//!   again through the OCV table: [`Restoration::SocReread`].
//!
//! A snapshot that fails a check is rejected with a [`SnapshotError`] and
//! nothing of it is taken. The restored parameters are published with
//! [`Identification::Restored`](crate::battery::online::Identification::Restored)
//! until a window of new data identifies them again; the refinement starts
//! from the restored estimate.
//!
//! # What is kept, per cell
//! The last good estimate (window coordinates: its `u_oc` is the OCV
//! offset `ΔU` with a table), the published `R_i`, `R_ct`, `Q`, α with
//! the state of charge each was identified at, the counted state of
//! charge, and the SOC observer's state (SOC, current bias, capacity, their
//! covariance, the last identified capacity). For the pack: which cell the
//! next period's updates start at. The window, the counters, the state
//! of power's polarization and its check against the last pulse
//! ([`PulseCheck`](super::power::PulseCheck)) are not kept: they refill
//! from new samples. With [`OnlineSettings::slow_memory_s`] above 0 (the
//! settings the pack was made with), the mean of the slow part carried
//! across windows is kept too, aged to the save; restored, it ages by the
//! time the estimator was off where the clocks know it, and takes the
//! next windows' values as the uninterrupted mean does.
//!
//! # Layout (a fixed layout, little-endian)
//! A fixed layout rather than a serde format: the bytes are the same from
//! the f32 firmware and the f64 host, a C team that owns its flash can
//! read them from this table, and no derive or format crate is linked into
//! the firmware. Every real number is an IEEE-754 `f32`; NaN means "none";
//! an f64 value beyond `f32`'s finite range is saturated to it.
//!
//! | offset | bytes | field |
//! |---|---|---|
//! | 0 | 4 | magic `FBMS` |
//! | 4 | 2 | layout version ([`SNAPSHOT_VERSION`]) |
//! | 6 | 2 | cells `n` |
//! | 8 | 4 | settings fingerprint (CRC-32 of the settings' bytes) |
//! | 12 | 2 | the cell the next period's updates start at |
//! | 14 | 2 | flags: bit 0, each cell's slow part follows it (version 3; 0 before) |
//! | 16 | 4 | saved at (s, the caller's clock; `u32::MAX`: unknown) |
//! | 20 | `c·n` | the cells, cell 1 first (`c` = [`CELL_BYTES`], 124, or with the slow part 124 + [`SLOW_PART_BYTES`] = 164) |
//! | 20 + c·n | 4 | CRC-32 (ISO-HDLC) of every byte before |
//!
//! One cell ([`CELL_BYTES`] = 124), layout versions 2 and 3:
//!
//! | offset | bytes | field |
//! |---|---|---|
//! | 0 | 28 | the estimate `R_i, R_ct, Q, α, u_oc, a, i₀` (NaN when there is none: bit 12 below says whether there is) |
//! | 28 | 32 | the published `R_i, R_ct, Q, α`, each with the SOC it was identified at |
//! | 60 | 2 | a word: bits 0–11 their statuses, 3 bits each; bit 12 an estimate; bits 13, 14 and 15 the rest's early observation, observation and bias reading given |
//! | 62 | 4 | the counted SOC |
//! | 66 | 12 | the observer's `SOC, b, g` |
//! | 78 | 24 | its covariance's upper triangle |
//! | 102 | 2 | its observations (`u16`, saturated at 65 535) |
//! | 104 | 4 | the last identified capacity |
//! | 108 | 4 | the last observation's weight |
//! | 112 | 12 | a rest in progress: its length (s; NaN: no rest, and then bits 13–15 are 0), voltage mean and current mean (NaN: no sample of the rest read a current; ±∞ is implausible) |
//! | 124 | 40 | with flag bit 0 only, the slow part: for `R_ct`, `Q` and α (of the logs of `R_ct` and `Q`) its summed weight, weighted sum and the SOC of its last value (NaN: none), then the SOC the weights were aged to; weights and sums aged to the save |
//!
//! Version 3 added the flag and the slow part; a version-3 snapshot
//! without it is byte for byte a version-2 one but for the version.
//! Layout version 1 (read, no longer written) had the statuses 4 bits
//! each, the observations as a `u32`, no rest current, and a flags word
//! at the end (bit 0 an estimate, bit 1 a rest, bits 2 and 3 its early
//! observation and observation given): the same size. A rest restored
//! from it gives no reading of the current sensor's bias.
//!
//! Sizes: [`snapshot_bytes`]`(1)` = 148 B, `snapshot_bytes(16)` = 2008 B;
//! with the slow part ([`snapshot_bytes_with`]) 188 B and 2648 B (at most
//! 12 cells, 1992 B, fit one 2 KiB flash page with the firmware store's
//! header).
//!
//! This module owns the layout, its checks and the fingerprint; it must
//! not decide what the tracker does with a restored cell (that is
//! [`CellState`](super::online::CellState)'s restore) nor where the bytes
//! are stored (the firmware's storage, the C caller's flash, host-sim's
//! file).

mod cell;

use super::pack::PackEstimator;
use super::tracker::check_limits;
pub use super::tracker::Restoration;
use super::tracker::{CellSnapshot, OnlineSettings, SLOW_PARTS};
use super::CellModel;
use crate::real::Real;
use cell::{Layout, Reader, Writer};

/// The layout version a snapshot is written with. Versions from
/// [`OLDEST_READ_VERSION`] to it are read; another is rejected
/// ([`SnapshotError::Version`]).
pub const SNAPSHOT_VERSION: u16 = 3;

/// The oldest layout version read: 1, which did not keep a rest's current
/// (a firmware update keeps what the cells learned).
pub const OLDEST_READ_VERSION: u16 = 1;

/// The first four bytes of a snapshot.
pub const SNAPSHOT_MAGIC: [u8; 4] = *b"FBMS";

/// Bytes before the cells.
pub const HEADER_BYTES: usize = 20;

/// Bytes per cell.
pub const CELL_BYTES: usize = 124;

/// Bytes a cell's slow part carried across windows adds to it, when the
/// snapshot keeps it (header flag bit 0): per `R_ct`, `Q`, α its weight,
/// weighted sum and last state of charge, then the state of charge the
/// weights were aged to.
pub const SLOW_PART_BYTES: usize = 40;

/// Bytes of the closing CRC.
pub const CRC_BYTES: usize = 4;

/// The size of a snapshot of `cells` cells (B).
///
/// ```
/// use estimator_core::battery::snapshot::snapshot_bytes;
/// assert_eq!(snapshot_bytes(1), 148);
/// assert_eq!(snapshot_bytes(16), 2008);
/// ```
pub const fn snapshot_bytes(cells: usize) -> usize {
    snapshot_bytes_with(cells, false)
}

/// The size of a snapshot of `cells` cells (B) that keeps, with
/// `slow_part`, each cell's slow part carried across windows (the pack's
/// settings have [`OnlineSettings::slow_memory_s`] above 0).
///
/// ```
/// use estimator_core::battery::snapshot::snapshot_bytes_with;
/// assert_eq!(snapshot_bytes_with(1, false), 148);
/// assert_eq!(snapshot_bytes_with(1, true), 188);
/// assert_eq!(snapshot_bytes_with(12, true), 1992);
/// ```
pub const fn snapshot_bytes_with(cells: usize, slow_part: bool) -> usize {
    let cell = if slow_part {
        CELL_BYTES + SLOW_PART_BYTES
    } else {
        CELL_BYTES
    };
    HEADER_BYTES + cell * cells + CRC_BYTES
}

/// Header flag: each cell's slow part follows its [`CELL_BYTES`].
const FLAG_SLOW_PART: u16 = 1;
const _: () = assert!(SLOW_PART_BYTES == 4 * SLOW_PARTS);

const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// Why a snapshot was not written or not taken. Small and `Copy`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SnapshotError {
    /// The buffer is shorter than the snapshot (`needed` bytes).
    TooShort {
        /// Bytes needed.
        needed: usize,
    },
    /// The bytes do not start with [`SNAPSHOT_MAGIC`] (erased flash,
    /// another record).
    NotASnapshot,
    /// Written by another layout version (another firmware), or with
    /// header flags this build does not know.
    Version {
        /// The snapshot's version.
        found: u16,
    },
    /// The CRC does not match: the bytes are corrupt.
    Crc,
    /// Written for another number of cells.
    CellCount {
        /// The snapshot's cells.
        found: usize,
        /// The pack's cells.
        expected: usize,
    },
    /// Written under other settings (sample period, method, model, OCV
    /// table or capacity).
    Settings,
    /// Older than [`RestorePolicy::max_age_s`], or saved after "now"
    /// (a clock that went back).
    Stale {
        /// Seconds from the save to now (negative: saved in the future).
        age_s: i64,
    },
    /// A value no estimator publishes (non-finite or unphysical
    /// parameters, a non-finite SOC, an unknown status).
    Implausible {
        /// The cell (0-based).
        cell: usize,
    },
}

impl SnapshotError {
    /// A short lower-case name (the firmware's `RESTORE … reason=` word).
    pub fn as_str(&self) -> &'static str {
        match self {
            SnapshotError::TooShort { .. } | SnapshotError::NotASnapshot => "invalid",
            SnapshotError::Version { .. } => "version",
            SnapshotError::Crc => "crc",
            SnapshotError::CellCount { .. } => "cell_count",
            SnapshotError::Settings => "settings",
            SnapshotError::Stale { .. } => "stale",
            SnapshotError::Implausible { .. } => "implausible",
        }
    }
}

impl core::fmt::Display for SnapshotError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SnapshotError::TooShort { needed } => {
                write!(f, "snapshot buffer too short ({needed} bytes needed)")
            }
            SnapshotError::NotASnapshot => write!(f, "not a fracbms snapshot (bad magic)"),
            SnapshotError::Version { found } => write!(
                f,
                "snapshot layout version {found}, this build reads \
                 {OLDEST_READ_VERSION} to {SNAPSHOT_VERSION}"
            ),
            SnapshotError::Crc => write!(f, "snapshot CRC mismatch (corrupt)"),
            SnapshotError::CellCount { found, expected } => {
                write!(f, "snapshot of {found} cells, the pack has {expected}")
            }
            SnapshotError::Settings => write!(
                f,
                "snapshot written under other settings (period, method, model or OCV table)"
            ),
            SnapshotError::Stale { age_s } => write!(f, "snapshot is stale (age {age_s} s)"),
            SnapshotError::Implausible { cell } => {
                write!(f, "snapshot holds implausible values for cell {}", cell + 1)
            }
        }
    }
}

/// How [`PackEstimator::restore`] judges a snapshot's age.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RestorePolicy {
    /// Now (s, the clock [`PackEstimator::save`] was given; `None`: no
    /// clock, the age is not judged).
    pub now_s: Option<u32>,
    /// The oldest snapshot taken (s). Default 90 days: parameters age
    /// slowly, and the SOC is checked against the first rested voltage.
    pub max_age_s: u32,
    /// A snapshot at most this old (s, by the clocks) resumes the count
    /// as if no charge had passed (a watchdog reset, a record replayed in
    /// halves); an older one widens the SOC's spread as after a gap
    /// ([`SocSettings::gap_soc_sigma`](super::soc::SocSettings::gap_soc_sigma)),
    /// so that the next rest corrects it. Default 60 s.
    pub resume_s: u32,
    /// Whether a snapshot of unknown age (no clock) widens the SOC's
    /// spread as an old one does. Default `false`: a reset without a
    /// clock is taken to be short, and a rested first voltage that
    /// contradicts the stored SOC still has it read again. Measured on the
    /// DFN HPPC record under QEMU (docs/persistence.md): widening there
    /// let a short rest pull the SOC 1.7 % below the truth, the count
    /// being within 0.2 %.
    pub widen_unknown_age: bool,
}

impl Default for RestorePolicy {
    fn default() -> Self {
        Self {
            now_s: None,
            max_age_s: 90 * 24 * 3600,
            resume_s: 60,
            widen_unknown_age: false,
        }
    }
}

/// A fingerprint of the settings a snapshot's numbers depend on: the
/// sample period, the method, the cell model and, with a curve, the OCV
/// table and the capacity (as `f32`, so that the f32 firmware and the f64
/// host agree).
pub fn settings_fingerprint<T: Real, const P: usize>(s: &OnlineSettings<T, P>) -> u32 {
    let mut d = CRC.digest();
    let f = |x: T| x.to_f64() as f32;
    d.update(&f(s.battery.h).to_le_bytes());
    d.update(&[
        s.method as u8,
        match s.battery.model {
            CellModel::Linear => 0,
            CellModel::ButlerVolmer => 1,
        },
    ]);
    if let Some(m) = &s.ocv {
        d.update(&f(m.capacity_ah).to_le_bytes());
        for (z, v) in m.table.soc_points().iter().zip(m.table.ocv_points()) {
            d.update(&f(*z).to_le_bytes());
            d.update(&f(*v).to_le_bytes());
        }
    }
    d.finalize()
}

impl<T: Real, const N: usize, const MEM: usize, const CELLS: usize>
    PackEstimator<T, N, MEM, CELLS>
{
    /// The size of this pack's snapshot (B): [`snapshot_bytes_with`] of its
    /// cells, with their slow part when the settings the pack was made
    /// with carry one across windows.
    pub fn snapshot_size(&self) -> usize {
        snapshot_bytes_with(self.active, self.slow_part)
    }

    /// Writes what the cells have learned into `buf` (module docs) and
    /// returns the bytes written. `saved_at_s` is the caller's clock
    /// (seconds; `None`: unknown), judged by [`RestorePolicy`] at restore.
    /// No allocation.
    ///
    /// # Errors
    /// [`SnapshotError::TooShort`] when `buf` is shorter than
    /// [`snapshot_size`](Self::snapshot_size) (nothing is written).
    pub fn save<const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
        saved_at_s: Option<u32>,
        buf: &mut [u8],
    ) -> Result<usize, SnapshotError> {
        let n = self.snapshot_size();
        let Some(out) = buf.get_mut(..n) else {
            return Err(SnapshotError::TooShort { needed: n });
        };
        let mut w = Writer { buf: out, at: 0 };
        w.bytes(&SNAPSHOT_MAGIC);
        w.u16(SNAPSHOT_VERSION);
        w.u16(self.active as u16);
        w.u32(settings_fingerprint(s));
        w.u16(self.next as u16);
        w.u16(if self.slow_part { FLAG_SLOW_PART } else { 0 });
        w.u32(saved_at_s.unwrap_or(u32::MAX));
        for cell in self.cells.iter().take(self.active) {
            cell.snapshot(s, self.slow_part).write(&mut w);
        }
        let body = n - CRC_BYTES;
        let crc = CRC.checksum(w.buf.get(..body).unwrap_or(&[]));
        w.u32(crc);
        Ok(n)
    }

    /// Restores the cells from a snapshot `buf` written by
    /// [`save`](Self::save) (module docs): every check first, then the
    /// pack starts again with each cell's learned state (a new window, new
    /// counters). On an error nothing is changed.
    ///
    /// # Errors
    /// The first check that fails ([`SnapshotError`]).
    pub fn restore<const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        buf: &[u8],
        policy: &RestorePolicy,
    ) -> Result<(), SnapshotError> {
        // Settings that build no estimator: the one in use stays.
        check_limits(s).map_err(|_| SnapshotError::Settings)?;
        let (layout, next, age_s) = check(s, buf, policy, self.active)?;
        let gap = match age_s {
            Some(a) => a > i64::from(policy.resume_s),
            None => policy.widen_unknown_age,
        };
        // The slow part ages over the time off, where the clocks know it.
        let offline_s = T::lit(age_s.unwrap_or(0).max(0) as f64);
        // Every cell was read once to check it; read again to take it (no
        // array of snapshots on the stack).
        let mut r = Reader {
            buf,
            at: HEADER_BYTES,
        };
        self.history.clear();
        for cell in self.cells.iter_mut().take(self.active) {
            cell.reset::<MEM, P>(s);
            if let Some(snap) = CellSnapshot::read(&mut r, layout) {
                cell.restore::<MEM, P>(s, &snap, gap, offline_s);
            }
        }
        for tail in &mut self.tails {
            tail.clear();
        }
        self.checks.fill(super::power::PulseCheck::BLANK);
        self.work.release();
        self.next = next;
        Ok(())
    }
}

/// Checks a snapshot for a pack of `cells` cells, every cell's values
/// included; returns its layout version, the schedule position and the
/// snapshot's age (s, when both clocks are known).
fn check<T: Real, const P: usize>(
    s: &OnlineSettings<T, P>,
    buf: &[u8],
    policy: &RestorePolicy,
    cells: usize,
) -> Result<(Layout, usize, Option<i64>), SnapshotError> {
    let mut r = Reader { buf, at: 0 };
    if buf.len() < HEADER_BYTES + CRC_BYTES {
        return Err(SnapshotError::TooShort {
            needed: snapshot_bytes(cells),
        });
    }
    if r.take::<4>() != SNAPSHOT_MAGIC {
        return Err(SnapshotError::NotASnapshot);
    }
    let version = r.u16();
    if !(OLDEST_READ_VERSION..=SNAPSHOT_VERSION).contains(&version) {
        return Err(SnapshotError::Version { found: version });
    }
    let found = usize::from(r.u16());
    // The flags (reserved, 0, before version 3) say the cells' size.
    let flags = buf
        .get(14..16)
        .map_or(0, |b| u16::from_le_bytes([b[0], b[1]]));
    let known = if version >= 3 { FLAG_SLOW_PART } else { 0 };
    if flags & !known != 0 {
        return Err(SnapshotError::Version { found: version });
    }
    let layout = Layout {
        version,
        slow_part: flags & FLAG_SLOW_PART != 0,
    };
    let n = snapshot_bytes_with(found, layout.slow_part);
    let (Some(body), true) = (buf.get(..n - CRC_BYTES), buf.len() >= n) else {
        return Err(SnapshotError::TooShort { needed: n });
    };
    let stored = buf
        .get(n - CRC_BYTES..n)
        .and_then(|b| b.try_into().ok())
        .map(u32::from_le_bytes);
    if stored != Some(CRC.checksum(body)) {
        return Err(SnapshotError::Crc);
    }
    if found != cells {
        return Err(SnapshotError::CellCount {
            found,
            expected: cells,
        });
    }
    if r.u32() != settings_fingerprint(s) {
        return Err(SnapshotError::Settings);
    }
    let next = usize::from(r.u16());
    let _flags = r.u16();
    let saved = r.u32();
    let age_s = policy
        .now_s
        .filter(|_| saved != u32::MAX)
        .map(|now| i64::from(now) - i64::from(saved));
    if let Some(age_s) = age_s.filter(|a| *a < 0 || *a > i64::from(policy.max_age_s)) {
        return Err(SnapshotError::Stale { age_s });
    }
    for cell in 0..cells {
        CellSnapshot::<T>::read(&mut r, layout)
            .filter(|c| c.observer_publishes(s))
            .ok_or(SnapshotError::Implausible { cell })?;
    }
    if next >= cells {
        return Err(SnapshotError::Implausible { cell: next });
    }
    Ok((layout, next, age_s))
}
