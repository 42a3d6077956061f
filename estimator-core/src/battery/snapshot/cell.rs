//! One cell's bytes in a snapshot (the tables of [`super`]): the
//! little-endian writer and reader over the caller's buffer, and
//! [`CellSnapshot`]'s layout in versions 1 to 3, read back with the
//! plausibility checks a restore needs.
//!
//! It owns the cell's layout; it must not judge the header, the CRC or
//! the settings ([`super`] does) nor what a cell does with what it reads
//! ([`CellState`](crate::battery::online::CellState)'s restore).

use crate::battery::soc::{ObserverParts, RestParts};
use crate::battery::tracker::{
    plausible_parts, CellSnapshot, Identification, PublishedParameter, PublishedParameters,
    SLOW_PARTS,
};
use crate::battery::CellParameters;
use crate::real::Real;

/// A little-endian writer over a fixed buffer (the caller checked its
/// length).
pub(super) struct Writer<'a> {
    pub(super) buf: &'a mut [u8],
    pub(super) at: usize,
}

impl Writer<'_> {
    pub(super) fn bytes(&mut self, b: &[u8]) {
        if let Some(dst) = self.buf.get_mut(self.at..self.at + b.len()) {
            dst.copy_from_slice(b);
        }
        self.at += b.len();
    }
    pub(super) fn u16(&mut self, x: u16) {
        self.bytes(&x.to_le_bytes());
    }
    pub(super) fn u32(&mut self, x: u32) {
        self.bytes(&x.to_le_bytes());
    }
    /// `x` as an `f32`, saturated to its finite range: an f64 host's
    /// value beyond it (a resistance of 1e-50 Ω, a covariance of 1e300)
    /// becomes the nearest `f32` of its sign, not 0 or ∞ (found by the fuzz
    /// target `snapshot`). NaN and ±∞ stay.
    pub(super) fn real<T: Real>(&mut self, x: T) {
        let x = x.to_f64();
        let tiny = f64::from(f32::MIN_POSITIVE);
        let y = if !x.is_finite() || x == 0.0 {
            x as f32
        } else if x.abs() < tiny {
            (tiny.copysign(x)) as f32
        } else {
            x.clamp(-f64::from(f32::MAX), f64::from(f32::MAX)) as f32
        };
        self.bytes(&y.to_le_bytes());
    }
    pub(super) fn opt<T: Real>(&mut self, x: Option<T>) {
        self.real(x.unwrap_or(T::nan()));
    }
}

/// A little-endian reader; reading past the end gives zeros (the caller
/// checked the length first).
pub(super) struct Reader<'a> {
    pub(super) buf: &'a [u8],
    pub(super) at: usize,
}

impl Reader<'_> {
    pub(super) fn take<const K: usize>(&mut self) -> [u8; K] {
        let mut out = [0; K];
        if let Some(src) = self.buf.get(self.at..self.at + K) {
            out.copy_from_slice(src);
        }
        self.at += K;
        out
    }
    pub(super) fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }
    pub(super) fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    pub(super) fn real<T: Real>(&mut self) -> T {
        T::lit(f64::from(f32::from_le_bytes(self.take())))
    }
    pub(super) fn opt<T: Real>(&mut self) -> Option<T> {
        let x = self.real::<T>();
        x.is_finite().then_some(x)
    }
}

fn status_code(s: Identification) -> u16 {
    match s {
        Identification::NotIdentified => 0,
        Identification::Identified => 1,
        Identification::Held => 2,
        Identification::Step => 3,
        Identification::Expired => 4,
        Identification::Restored => 5,
        Identification::Prior => 6,
    }
}

fn status_of(code: u16) -> Option<Identification> {
    Some(match code {
        0 => Identification::NotIdentified,
        1 => Identification::Identified,
        2 => Identification::Held,
        3 => Identification::Step,
        4 => Identification::Expired,
        5 => Identification::Restored,
        6 => Identification::Prior,
        _ => return None,
    })
}

impl<T: Real> CellSnapshot<T> {
    pub(super) fn write(&self, w: &mut Writer<'_>) {
        let e = self.estimate;
        let p = e.unwrap_or(CellParameters {
            r_i: T::nan(),
            r_ct: T::nan(),
            q: T::nan(),
            alpha: T::nan(),
            u_oc: T::nan(),
            bv_a: T::nan(),
            bv_i0: T::nan(),
        });
        for x in [p.r_i, p.r_ct, p.q, p.alpha, p.u_oc, p.bv_a, p.bv_i0] {
            w.real(x);
        }
        let named = self.published.named();
        let o = &self.observer;
        let flag = |b: bool, bit: u16| u16::from(b) << bit;
        let mut word = flag(e.is_some(), 12);
        if let Some(rest) = o.rest {
            word |= flag(rest.early, 13) | flag(rest.done, 14) | flag(rest.bias_read, 15);
        }
        for (k, (_, x)) in named.iter().enumerate() {
            w.opt(x.value);
            w.opt(x.soc);
            word |= status_code(x.status) << (3 * k);
        }
        w.u16(word);
        w.opt(self.soc);
        for x in o.x.unwrap_or([T::nan(); 3]) {
            w.real(x);
        }
        for x in o.p {
            w.real(x);
        }
        w.u16(u16::try_from(o.observations).unwrap_or(u16::MAX));
        w.opt(o.capacity_held);
        w.real(o.ocv_weight);
        let rest = o.rest.map_or([T::nan(); 3], |r| [r.len, r.mean, r.current]);
        for x in rest {
            w.real(x);
        }
        for x in self.slow.iter().flatten() {
            w.real(*x);
        }
    }

    /// One cell of `layout` (version 1 to 3, its slow part or not), or
    /// `None` when a value is implausible.
    pub(super) fn read(r: &mut Reader<'_>, layout: Layout) -> Option<Self> {
        let version = layout.version;
        let mut e = [T::zero(); 7];
        for x in &mut e {
            *x = r.real();
        }
        let mut values = [(None, None); 4];
        for v in &mut values {
            *v = (r.opt::<T>(), r.opt::<T>());
        }
        // Version 1: 4 bits a status; version 2: 3, and the flags above.
        let word = r.u16();
        let width = if version == 1 { 4 } else { 3 };
        let mut statuses = [Identification::NotIdentified; 4];
        for (k, st) in statuses.iter_mut().enumerate() {
            *st = status_of((word >> (width * k)) & ((1 << width) - 1))?;
        }
        let soc = r.opt::<T>();
        let mut x = [T::zero(); 3];
        for v in &mut x {
            *v = r.real();
        }
        let mut p = [T::zero(); 6];
        for v in &mut p {
            *v = r.real();
        }
        let observations = if version == 1 {
            r.u32()
        } else {
            u32::from(r.u16())
        };
        let capacity_held = r.opt::<T>();
        let ocv_weight = r.real::<T>();
        let (rest_len, rest_mean) = (r.real::<T>(), r.real::<T>());
        let (has_estimate, rest) = if version == 1 {
            let flags = r.u16();
            let bit = |k: u16| flags >> k & 1 == 1;
            // Its current was not kept: the rest gives no reading of the
            // bias (a mean restarted a few samples before the rest's end
            // would stand for a whole rest's).
            let rest = bit(1).then_some(RestParts {
                len: rest_len,
                mean: rest_mean,
                current: T::nan(),
                early: bit(2),
                done: bit(3),
                bias_read: true,
            });
            (bit(0), rest)
        } else {
            let current = r.real::<T>();
            let bit = |k: u16| word >> k & 1 == 1;
            // A rest in progress is one with a length; its flags without
            // one are no snapshot the writer makes.
            if rest_len.is_nan() && word >> 13 != 0 {
                return None;
            }
            let rest = (!rest_len.is_nan()).then_some(RestParts {
                len: rest_len,
                mean: rest_mean,
                current,
                early: bit(13),
                done: bit(14),
                bias_read: bit(15),
            });
            (bit(12), rest)
        };
        let slow = if layout.slow_part {
            let mut parts = [T::zero(); SLOW_PARTS];
            for x in &mut parts {
                *x = r.real();
            }
            if !plausible_parts(&parts) {
                return None;
            }
            Some(parts)
        } else {
            None
        };
        let [r_i, r_ct, q, alpha, u_oc, bv_a, bv_i0] = e;
        // `i₀` has no effect without a Butler–Volmer term (`a = 0`); the
        // linear model's may not fit an `f32` (an infinity, or 0: found by
        // the fuzz target `snapshot`): read back as 1.
        let usable = bv_i0.is_finite() && bv_i0 > T::zero();
        let bv_i0 = if bv_a == T::zero() && !usable {
            T::one()
        } else {
            bv_i0
        };
        let estimate = has_estimate.then_some(CellParameters {
            r_i,
            r_ct,
            q,
            alpha,
            u_oc,
            bv_a,
            bv_i0,
        });
        let one = |k: usize| {
            let (value, soc) = values.get(k).copied().unwrap_or((None, None));
            let status = statuses
                .get(k)
                .copied()
                .unwrap_or(Identification::NotIdentified);
            PublishedParameter {
                value,
                status,
                soc,
                sigma: None,
            }
        };
        let snap = Self {
            estimate,
            published: PublishedParameters {
                r_i: one(0),
                r_ct: one(1),
                q: one(2),
                alpha: one(3),
            },
            soc,
            observer: ObserverParts {
                x: x.iter().all(|v| v.is_finite()).then_some(x),
                p,
                observations,
                capacity_held,
                ocv_weight,
                rest,
            },
            slow,
        };
        snap.plausible().then_some(snap)
    }

    /// Values an estimator could have published (module docs).
    fn plausible(&self) -> bool {
        // Any finite SOC: the count itself leaves [0, 1] on a record that
        // charges past full (found by the fuzz target `snapshot`); a rested
        // first voltage that contradicts it has it read again.
        let soc_ok = |z: Option<T>| z.is_none_or(|z| z.is_finite());
        // What the online estimator publishes: physical, α at most 1
        // (the plausibility check of [`OnlineSettings`]).
        let estimate_ok = self
            .estimate
            .is_none_or(|p| p.is_physical() && p.alpha <= T::one());
        let published_ok = self.published.named().iter().all(|(name, x)| {
            let positive = x.value.is_none_or(|v| {
                v.is_finite() && v > T::zero() && (*name != "alpha" || v <= T::one())
            });
            // A published status needs a value, and the other way round.
            positive && soc_ok(x.soc) && x.status.is_published() == x.value.is_some()
        });
        let o = &self.observer;
        let observer_ok = o.p.iter().all(|v| v.is_finite())
            && o.ocv_weight.is_finite()
            && o.capacity_held.is_none_or(|c| c > T::zero())
            && o.rest.is_none_or(|r| {
                r.len >= T::zero() && r.mean.is_finite() && !r.current.is_infinite()
            })
            && o.x.is_none_or(|x| soc_ok(Some(x[0])) && x[2] > T::zero());
        estimate_ok && published_ok && soc_ok(self.soc) && observer_ok
    }
}

/// How a snapshot's cells are laid out: its version, and whether each
/// keeps its slow part (header flag bit 0, from version 3).
#[derive(Clone, Copy, Debug)]
pub(super) struct Layout {
    pub(super) version: u16,
    pub(super) slow_part: bool,
}
