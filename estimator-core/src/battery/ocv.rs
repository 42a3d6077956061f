//! The open-circuit voltage curve `OCV(SOC)` and the coulomb-counted state
//! of charge.
//!
//! A BMS knows its cell's OCV curve (a datasheet, or a slow-rate or
//! rested-pulse test) and counts the charge that flows. This module owns
//! both, and the change of coordinates the estimators work in:
//!
//! ```text
//! SOC(l) = SOC₀ + h·Σ_{k≤l} I(k) / (3600·C)        (C in A·h, I positive when charging)
//! y(l)   = U_t(l) − OCV(SOC(l))                   (the overpotential)
//! y(l)   = ΔU + R_i·I(l) + U_p(l)                 (the §6.2 model, U_oc → ΔU)
//! ```
//!
//! `SOC(l)` is the state of charge *after* sample `l`'s charge (the voltage
//! of sample `l` is read at the end of its interval). With the known part
//! `OCV(SOC)` removed from the voltage, the §6.2 model is unchanged: its
//! constant `U_oc` becomes a small **OCV offset** `ΔU` that absorbs the
//! table's error and the state-of-charge error. Every estimator of
//! [`super`] (the paper regression, the output-error refinement, the
//! sliding-window [`super::online::CellEstimator`]) runs on `y` as it ran
//! on `U_t`.
//!
//! **Why an offset rather than an estimated start SOC.** An SOC error `δ`
//! moves the OCV by `OCV'(SOC)·δ`. Where the curve is steep that is large,
//! but there the start SOC read from a rested voltage through the inverse
//! table is accurate (`δ ≈ σ_V / OCV'`); where the curve is flat (an LFP
//! plateau) the inverse is poor, but the OCV error it causes is small.
//! Over a sliding window of minutes, and over a whole record whose SOC
//! moves through a nearly straight part of the curve, the product is a
//! near-constant voltage: one offset, which enters the model linearly (the
//! paper's regression keeps its form, the Levenberg–Marquardt problem
//! stays as well conditioned as before). An estimated SOC₀ would enter
//! through the table's slope, vanish on a plateau and make the problem
//! nonlinear for no gain on these time scales.
//!
//! What this module must not touch: the estimators' state; it only maps
//! samples.
//!
//! ```
//! use estimator_core::battery::ocv::{OcvModel, OcvTable};
//!
//! let soc = [0.0, 0.5, 1.0];
//! let ocv = [3.0, 3.7, 4.2];
//! let table = OcvTable::<f64, 8>::new(&soc, &ocv).unwrap();
//! assert!((table.ocv(0.25) - 3.35).abs() < 1e-12);
//! assert!((table.slope(0.75) - 1.0).abs() < 1e-12);
//! assert!((table.soc_from_ocv(3.95) - 0.75).abs() < 1e-12);
//!
//! // A 2.5 A·h cell discharged at 2.5 A for 36 s loses 1 % of its charge.
//! let cell = OcvModel::new(table, 2.5).unwrap();
//! let mut z = 0.8;
//! for _ in 0..36 {
//!     z = cell.soc_after(z, -2.5, 1.0);
//! }
//! assert!((z - 0.79).abs() < 1e-12);
//! // Not strictly increasing: a typed error naming the point.
//! assert!(OcvTable::<f64, 8>::new(&[0.0, 0.5, 0.5], &[3.0, 3.5, 3.6]).is_err());
//! ```

use crate::error::Error;
pub use crate::error::OcvError;
use crate::real::Real;

/// The coulomb count is kept inside `±SOC_BOUND_F64` (finite; see
/// [`OcvModel::soc_after`]).
const SOC_BOUND_F64: f64 = 1e6;

/// A piecewise-linear open-circuit voltage curve with room for `P` points:
/// `SOC` strictly increasing in `[0, 1]`, `OCV` (V) strictly increasing.
/// Outside the table's SOC range the end values hold (clamped).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OcvTable<T, const P: usize> {
    soc: [T; P],
    ocv: [T; P],
    len: usize,
}

impl<T: Real, const P: usize> OcvTable<T, P> {
    /// A table from its two columns.
    ///
    /// # Errors
    /// [`OcvError`] for fewer than 2 or more than `P` points, columns of
    /// different lengths, a non-finite value, an SOC outside `[0, 1]`, or a
    /// column that does not increase strictly.
    pub fn new(soc: &[T], ocv: &[T]) -> Result<Self, OcvError> {
        if soc.len() != ocv.len() {
            return Err(OcvError::LengthMismatch);
        }
        let have = soc.len();
        if have < 2 {
            return Err(OcvError::TooFewPoints { have });
        }
        if have > P {
            return Err(OcvError::TooManyPoints { have, capacity: P });
        }
        let mut t = Self {
            soc: [T::ZERO; P],
            ocv: [T::ZERO; P],
            len: have,
        };
        for (index, (&z, &v)) in soc.iter().zip(ocv).enumerate() {
            if !(z.is_finite() && v.is_finite()) {
                return Err(OcvError::NonFinite { index });
            }
            if !(z >= T::zero() && z <= T::one()) {
                return Err(OcvError::SocOutOfRange { index });
            }
            if index > 0 && !(z > soc[index - 1] && v > ocv[index - 1]) {
                return Err(OcvError::NotIncreasing { index });
            }
            t.soc[index] = z;
            t.ocv[index] = v;
        }
        Ok(t)
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Always false: a table holds at least two points.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The SOC column.
    pub fn soc_points(&self) -> &[T] {
        // `new` refuses more than P points; the clamp lets the optimizer see it.
        &self.soc[..self.len.min(P)]
    }

    /// The OCV column (V).
    pub fn ocv_points(&self) -> &[T] {
        &self.ocv[..self.len.min(P)]
    }

    /// Converts to another scalar type (a host table into the firmware's
    /// `f32`). Rounding can merge two points of a very dense table.
    ///
    /// # Errors
    /// As [`OcvTable::new`] for the rounded values.
    pub fn cast<U: Real>(&self) -> Result<OcvTable<U, P>, OcvError> {
        let mut soc = [U::ZERO; P];
        let mut ocv = [U::ZERO; P];
        for k in 0..self.len {
            soc[k] = U::lit(self.soc[k].to_f64());
            ocv[k] = U::lit(self.ocv[k].to_f64());
        }
        OcvTable::new(&soc[..self.len], &ocv[..self.len])
    }

    /// Index `k` of the segment `[x_k, x_{k+1}]` of `xs` that holds `x`
    /// (the first or last segment outside the range). O(log P).
    fn segment(xs: &[T], x: T) -> usize {
        let (mut lo, mut hi) = (0usize, xs.len().saturating_sub(1));
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if xs.get(mid).is_some_and(|&m| x < m) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        lo
    }

    /// `ys` at `x`, linear on segment `k` of `xs` (`segment` gives
    /// `k + 1 < len`; NaN if it did not).
    fn along(xs: &[T], ys: &[T], k: usize, x: T) -> T {
        match (xs.get(k..=k + 1), ys.get(k..=k + 1)) {
            (Some(&[x0, x1]), Some(&[y0, y1])) => y0 + (y1 - y0) * (x - x0) / (x1 - x0),
            _ => T::nan(),
        }
    }

    /// `ys` at `x`: linear between points, the end values outside (NaN for
    /// a NaN `x`, or an empty table, which `new` refuses).
    fn interpolate(xs: &[T], ys: &[T], x: T) -> T {
        let (Some((&x0, &y0)), Some((&xl, &yl))) =
            (xs.first().zip(ys.first()), xs.last().zip(ys.last()))
        else {
            return T::nan();
        };
        if x <= x0 {
            return y0;
        }
        if x >= xl {
            return yl;
        }
        Self::along(xs, ys, Self::segment(xs, x), x)
    }

    /// `OCV(soc)` (V), linear between points, the end values outside.
    /// A NaN SOC gives NaN.
    pub fn ocv(&self, soc: T) -> T {
        Self::interpolate(self.soc_points(), self.ocv_points(), soc)
    }

    /// [`ocv`](Self::ocv) with the search started at segment `hint` (the
    /// segment of a nearby SOC, such as the last lookup's): the same
    /// value, and the segment that holds `soc` for the next lookup (`hint`
    /// itself outside the table's range). A walk of a pulse's charge
    /// mostly stays in one segment, where the binary search takes seven
    /// steps on a 101-point table.
    ///
    /// ```
    /// use estimator_core::battery::ocv::OcvTable;
    ///
    /// let t = OcvTable::<f64, 3>::new(&[0.0, 0.5, 1.0], &[3.0, 3.6, 4.2]).unwrap();
    /// let (v, k) = t.ocv_from(0.75, 0);
    /// assert_eq!((v, k), (t.ocv(0.75), 1));
    /// assert_eq!(t.ocv_from(0.8, k), (t.ocv(0.8), 1));
    /// ```
    pub fn ocv_from(&self, soc: T, hint: usize) -> (T, usize) {
        let (xs, ys) = (self.soc_points(), self.ocv_points());
        let inside = match (xs.first(), xs.last()) {
            (Some(&x0), Some(&xl)) => soc > x0 && soc < xl,
            _ => false,
        };
        if !inside {
            return (Self::interpolate(xs, ys, soc), hint);
        }
        // The segment `k` with xs[k] ≤ soc < xs[k + 1] is unique (the
        // points increase strictly): the binary search finds the same.
        let k = match xs.get(hint..).and_then(|t| t.get(..2)) {
            Some(&[x0, x1]) if x0 <= soc && soc < x1 => hint,
            _ => Self::segment(xs, soc),
        };
        (Self::along(xs, ys, k, soc), k)
    }

    /// The slope `dOCV/dSOC` (V per unit SOC) of the segment that holds
    /// `soc` (the end segments outside the range).
    pub fn slope(&self, soc: T) -> T {
        let (z, v) = (self.soc_points(), self.ocv_points());
        let k = Self::segment(z, soc);
        match (z.get(k..=k + 1), v.get(k..=k + 1)) {
            (Some(&[z0, z1]), Some(&[v0, v1])) => (v1 - v0) / (z1 - z0),
            _ => T::nan(),
        }
    }

    /// The inverse: the SOC whose OCV is `ocv` (a rested cell's voltage),
    /// clamped to the table's SOC range.
    pub fn soc_from_ocv(&self, ocv: T) -> T {
        Self::interpolate(self.ocv_points(), self.soc_points(), ocv)
    }
}

/// A cell's OCV curve and capacity: what coulomb counting and the change
/// to overpotential coordinates need (one value for all cells of a pack of
/// one chemistry).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OcvModel<T, const P: usize> {
    /// The OCV curve.
    pub table: OcvTable<T, P>,
    /// Capacity C (A·h).
    pub capacity_ah: T,
}

impl<T: Real, const P: usize> OcvModel<T, P> {
    /// A curve with the cell's capacity (A·h).
    ///
    /// # Errors
    /// [`Error::BadSetting`] for a capacity that is not finite and positive.
    pub fn new(table: OcvTable<T, P>, capacity_ah: T) -> Result<Self, Error> {
        let m = Self { table, capacity_ah };
        m.check()?;
        Ok(m)
    }

    /// Checks the capacity (the table checked itself when it was made).
    ///
    /// # Errors
    /// [`Error::BadSetting`] for a capacity that is not finite and positive.
    pub fn check(&self) -> Result<(), Error> {
        if self.capacity_ah.is_finite() && self.capacity_ah > T::zero() {
            Ok(())
        } else {
            Err(Error::BadSetting)
        }
    }

    /// The state of charge after a sample of current `current` (A, positive
    /// when charging) held for `h` seconds, from `soc` before it. Not
    /// clamped to `[0, 1]`: a count that leaves it says the capacity or the
    /// start is wrong, and the table holds its end values there. Only kept
    /// finite, inside `±10⁶` (a capacity of 10⁻³⁰⁰ A·h or a period of
    /// 10³⁰⁰ s would otherwise overflow the count to ±∞ and then NaN).
    pub fn soc_after(&self, soc: T, current: T, h: T) -> T {
        let z = soc + h * current / (T::lit(3600.0) * self.capacity_ah);
        let bound = T::lit(SOC_BOUND_F64);
        z.max(-bound).min(bound)
    }

    /// The overpotential `y = U_t − OCV(soc)` of a terminal voltage at
    /// state of charge `soc`.
    pub fn overpotential(&self, soc: T, voltage: T) -> T {
        voltage - self.table.ocv(soc)
    }

    /// The state of charge at the start of a record that begins at rest,
    /// before the first row's charge: the inverse OCV of the mean voltage
    /// of the leading rows whose current is at most `C/100` (at most 10 of
    /// them).
    ///
    /// # Errors
    /// [`Error::NotAtRest`] when the first row's current exceeds `C/100`;
    /// [`Error::NotEnoughData`] for an empty record; [`Error::NonFiniteSample`]
    /// for a non-finite value among those rows.
    pub fn soc_at_rest(&self, current: &[T], voltage: &[T]) -> Result<T, Error> {
        let rest = self.capacity_ah / T::lit(100.0);
        let mut sum = T::zero();
        let mut n = 0usize;
        for (&i, &v) in current.iter().zip(voltage).take(10) {
            if !(i.is_finite() && v.is_finite()) {
                return Err(Error::NonFiniteSample);
            }
            if i.abs() > rest {
                break;
            }
            sum = sum + v;
            n += 1;
        }
        if current.is_empty() || voltage.is_empty() {
            return Err(Error::NotEnoughData { have: 0, need: 1 });
        }
        if n == 0 {
            return Err(Error::NotAtRest);
        }
        Ok(self.table.soc_from_ocv(sum / T::lit(n as f64)))
    }

    /// Maps a whole record to overpotentials: `out[l] = U_t(l) −
    /// OCV(SOC(l))` with `SOC(l)` counted from `soc0` (before the first
    /// row) over rows `0..=l`; returns the SOC after the last row. `out`
    /// receives `min` of the three lengths.
    pub fn overpotentials(&self, h: T, soc0: T, current: &[T], voltage: &[T], out: &mut [T]) -> T {
        let mut soc = soc0;
        for ((o, &i), &v) in out.iter_mut().zip(current).zip(voltage) {
            soc = self.soc_after(soc, i, h);
            *o = self.overpotential(soc, v);
        }
        soc
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_checks_its_points() {
        type Tb = OcvTable<f64, 4>;
        assert_eq!(
            Tb::new(&[0.0], &[3.0]),
            Err(OcvError::TooFewPoints { have: 1 })
        );
        assert_eq!(
            Tb::new(&[0.0, 0.2, 0.4, 0.6, 0.8], &[3.0, 3.1, 3.2, 3.3, 3.4]),
            Err(OcvError::TooManyPoints {
                have: 5,
                capacity: 4
            })
        );
        assert_eq!(Tb::new(&[0.0, 1.0], &[3.0]), Err(OcvError::LengthMismatch));
        assert_eq!(
            Tb::new(&[0.0, f64::NAN], &[3.0, 3.1]),
            Err(OcvError::NonFinite { index: 1 })
        );
        assert_eq!(
            Tb::new(&[-0.1, 1.0], &[3.0, 3.1]),
            Err(OcvError::SocOutOfRange { index: 0 })
        );
        assert_eq!(
            Tb::new(&[0.0, 0.5, 1.0], &[3.0, 3.5, 3.5]),
            Err(OcvError::NotIncreasing { index: 2 })
        );
        assert_eq!(
            Tb::new(&[0.0, 0.5, 0.4], &[3.0, 3.5, 3.6]),
            Err(OcvError::NotIncreasing { index: 2 })
        );
    }

    /// Interpolation, slope and inverse agree with a dense curve, the
    /// inverse undoes the forward map, and the ends are clamped.
    #[test]
    fn interpolation_slope_and_inverse() {
        let n = 21;
        let soc: std::vec::Vec<f64> = (0..n).map(|k| k as f64 / (n - 1) as f64).collect();
        let ocv: std::vec::Vec<f64> = soc
            .iter()
            .map(|&z| super::super::profile::ocv_nmc::<f64>(z))
            .collect();
        let t = OcvTable::<f64, 32>::new(&soc, &ocv).unwrap();
        for k in 0..=200 {
            let z = k as f64 / 200.0;
            let v = t.ocv(z);
            // The chord through the two neighbouring points, found by a
            // linear scan (not the table's bisection).
            let k = (0..n - 1).rfind(|&k| soc[k] <= z).unwrap();
            let k = k.min(n - 2);
            let chord = ocv[k] + (ocv[k + 1] - ocv[k]) * (z - soc[k]) / (soc[k + 1] - soc[k]);
            assert!((v - chord).abs() < 1e-12, "{z}: {v} vs {chord}");
            // …which is within 4 mV of the smooth curve above its knee.
            if z >= 0.1 {
                assert!((v - super::super::profile::ocv_nmc::<f64>(z)).abs() < 4e-3);
            }
            assert!((t.soc_from_ocv(v) - z).abs() < 1e-12, "{z}");
            // The slope is the chord's, on both sides of a point.
            let d = 1e-7;
            if z > d && z < 1.0 - d {
                let fd = (t.ocv(z + d) - t.ocv(z - d)) / (2.0 * d);
                let seg = t.slope(z);
                assert!((fd - seg).abs() < 1e-6 || (z * 20.0).fract() < 1e-6, "{z}");
            }
        }
        assert_eq!(t.ocv(-0.5), ocv[0]);
        assert_eq!(t.ocv(1.5), ocv[n - 1]);
        assert_eq!(t.soc_from_ocv(0.0), 0.0);
        assert_eq!(t.soc_from_ocv(9.0), 1.0);
        assert!(t.ocv(f64::NAN).is_nan());
    }

    #[test]
    fn rest_start_and_overpotentials() {
        let t = OcvTable::<f64, 4>::new(&[0.0, 1.0], &[3.0, 4.0]).unwrap();
        let m = OcvModel::new(t, 1.0).unwrap();
        assert_eq!(OcvModel::new(t, 0.0), Err(Error::BadSetting));
        assert_eq!(OcvModel::new(t, f64::NAN), Err(Error::BadSetting));
        // Rest rows at 3.5 V: SOC 0.5; the load row is not averaged in.
        let i = [0.0, 0.001, 0.0, -2.0];
        let v = [3.49, 3.51, 3.5, 3.3];
        assert!((m.soc_at_rest(&i, &v).unwrap() - 0.5).abs() < 1e-12);
        assert_eq!(m.soc_at_rest(&[1.0], &[3.5]), Err(Error::NotAtRest));
        assert_eq!(
            m.soc_at_rest(&[], &[]),
            Err(Error::NotEnoughData { have: 0, need: 1 })
        );
        // 1 A for 360 s: +10 % of 1 A·h.
        let cur = [1.0; 360];
        let volt = [3.6; 360];
        let mut y = [0.0; 360];
        let end = m.overpotentials(1.0, 0.5, &cur, &volt, &mut y);
        assert!((end - 0.6).abs() < 1e-12);
        assert!((y[0] - (3.6 - (3.5 + 1.0 / 3600.0))).abs() < 1e-12);
        assert!(y[359].abs() < 1e-12);
    }
}
