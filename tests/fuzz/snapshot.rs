//! The `snapshot` target: the restore path
//! ([`estimator_core::battery::snapshot`]) on what a pack of 1 to 4 cells
//! saved after an arbitrary stream under arbitrary valid settings, with
//! the bytes then mutated or not (bits flipped, bytes set, truncated,
//! extended, replaced by random bytes; the CRC resealed half of the time)
//! and restored into a new pack of the same or another cell count.
//!
//! Checked: nothing panics; an unmutated snapshot restores into the same
//! cell count under the same settings; a refused restore changes nothing
//! (every cell clean, no estimate); after a restore every cell is
//! `Restored` and each push of a second stream keeps the `cell` target's
//! invariants ([`check_cell`]: no sample lost, published estimates finite
//! and physical, …).

use super::cell::{check_cell, length, settings, stream, Before, Expect};
use super::{note, Outcome, Rng};
use estimator_core::battery::pack::{PackEstimator, PackSettings};
use estimator_core::battery::snapshot::{
    snapshot_bytes, Restoration, RestorePolicy, CELL_BYTES, CRC_BYTES, HEADER_BYTES,
    SLOW_PART_BYTES,
};
use estimator_core::Real;
use rand::Rng as _;

/// Cell capacity of the packs.
const CELLS: usize = 4;

/// Runs one case.
pub fn case(rng: &mut Rng) -> Outcome {
    if rng.random_bool(0.5) {
        run::<f32, 64, 16>(rng)
    } else {
        run::<f64, 64, 16>(rng)
    }
}

/// The snapshot's CRC again after an edit (so that the checks behind it
/// are reached).
fn reseal(bytes: &mut [u8]) {
    if let Some(n) = bytes.len().checked_sub(CRC_BYTES) {
        let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&bytes[..n]);
        bytes[n..].copy_from_slice(&crc.to_le_bytes());
    }
}

/// Edits `bytes` one of several ways; returns whether they changed.
fn mutate(rng: &mut Rng, bytes: &mut Vec<u8>) -> bool {
    let before = bytes.clone();
    match rng.random_range(0..6) {
        0 => {
            for _ in 0..rng.random_range(1..4) {
                let k = rng.random_range(0..bytes.len());
                bytes[k] ^= 1 << rng.random_range(0..8);
            }
        }
        1 => {
            let k = rng.random_range(0..bytes.len());
            bytes[k] = rng.random();
        }
        2 => bytes.truncate(rng.random_range(0..bytes.len())),
        3 => bytes.extend((0..rng.random_range(1..64)).map(|_| rng.random::<u8>())),
        4 => {
            let n = rng.random_range(0..2 * bytes.len());
            *bytes = (0..n).map(|_| rng.random()).collect();
        }
        _ => {
            // A value field: an f32 of a cell set to something nasty.
            let at = 20 + 4 * rng.random_range(0..(bytes.len().saturating_sub(24)) / 4);
            let x: f32 = *[f32::NAN, f32::INFINITY, -1.0, 0.0, 1e30, 3.0]
                .get(rng.random_range(0..6))
                .unwrap_or(&0.0);
            if let Some(b) = bytes.get_mut(at..at + 4) {
                b.copy_from_slice(&x.to_le_bytes());
            }
        }
    }
    if rng.random_bool(0.5) {
        reseal(bytes);
    }
    *bytes != before
}

fn run<T: Real, const N: usize, const MEM: usize>(rng: &mut Rng) -> Outcome {
    let clean = rng.random_bool(0.5);
    let (cell_s, e) = settings::<T, MEM>(rng, clean);
    if e != Expect::Ok {
        note("snapshot: settings refused");
        return Ok(());
    }
    let s: PackSettings<T, { super::cell::P }> = PackSettings::new(cell_s);
    let cells = rng.random_range(1..=CELLS);
    let Ok(mut pack) = PackEstimator::<T, N, MEM, CELLS>::new(&s, cells) else {
        return Err("valid settings refused by the pack".into());
    };
    let len = length(rng, N, clean);
    let (i, v) = stream(rng, len, clean);
    // Cells a few mV apart.
    let volts = |v: f64| -> Vec<T> { (0..cells).map(|c| T::lit(v + 0.002 * c as f64)).collect() };
    for (&i, &v) in i.iter().zip(&v) {
        pack.push(&s, T::lit(i), &volts(v))
            .map_err(|e| format!("push: {e:?}"))?;
    }
    if pack.snapshot_size() != snapshot_bytes(cells) {
        note("snapshot: with the slow part");
    }
    let mut bytes = vec![0u8; pack.snapshot_size()];
    pack.save(&s.cell, None, &mut bytes)
        .map_err(|e| format!("save into its own size: {e:?}"))?;
    let changed = rng.random_bool(0.7) && mutate(rng, &mut bytes);
    let into = if rng.random_bool(0.2) {
        rng.random_range(1..=CELLS)
    } else {
        cells
    };
    let Ok(mut fresh) = PackEstimator::<T, N, MEM, CELLS>::new(&s, into) else {
        return Err("valid settings refused by the pack".into());
    };
    match fresh.restore(&s.cell, &bytes, &RestorePolicy::default()) {
        Err(e) => {
            note("snapshot: refused");
            if !changed && into == cells {
                // Only a state the estimator should not be in may be
                // refused: a SOC observer whose covariance is not finite
                // (under extreme settings; read from the bytes: each cell's
                // covariance is 6 f32 at offset 78 of its 124, or of its
                // 164 with the slow part, docs/persistence.md).
                let cell_bytes = if pack.snapshot_size() == snapshot_bytes(cells) {
                    CELL_BYTES
                } else {
                    CELL_BYTES + SLOW_PART_BYTES
                };
                let overflowed = (0..cells).any(|c| {
                    let at = HEADER_BYTES + cell_bytes * c + 78;
                    bytes.get(at..at + 24).is_some_and(|p| {
                        p.chunks_exact(4)
                            .any(|w| !f32::from_le_bytes([w[0], w[1], w[2], w[3]]).is_finite())
                    })
                });
                if !overflowed {
                    return Err(format!("an unmutated snapshot refused: {e:?}"));
                }
                note("snapshot: a non-finite observer refused");
            }
            for c in 0..into {
                let st = fresh.cell(c).ok_or("a cell of the pack")?;
                if st.restoration() != Restoration::Clean || st.estimate().is_some() {
                    return Err(format!("a refused restore ({e:?}) changed cell {c}"));
                }
            }
            return Ok(());
        }
        Ok(()) => note(if changed {
            "snapshot: a mutated snapshot taken"
        } else {
            "snapshot: restored"
        }),
    }
    if into != cells {
        return Err(format!("a snapshot of {cells} cells restored into {into}"));
    }
    for c in 0..cells {
        if fresh.cell(c).ok_or("a cell")?.restoration() != Restoration::Restored {
            return Err(format!("cell {c} not marked restored"));
        }
    }
    // The restored pack runs on.
    let len2 = length(rng, N, clean);
    let (i2, v2) = stream(rng, len2, clean);
    for (k, (&i, &v)) in i2.iter().zip(&v2).enumerate() {
        let u = volts(v);
        let before: Vec<Before<T>> = (0..cells)
            .map(|c| fresh.cell(c).map(Before::of).ok_or("a cell"))
            .collect::<Result<_, _>>()?;
        let cur = T::lit(i);
        fresh
            .push(&s, cur, &u)
            .map_err(|e| format!("push after restore: {e:?}"))?;
        for c in 0..cells {
            let st = fresh.cell(c).ok_or("a cell")?;
            check_cell(&s.cell, true, &before[c], st, fresh.window(c), cur, u[c])
                .map_err(|e| format!("after restore, period {k}, cell {c}: {e}"))?;
        }
    }
    Ok(())
}
