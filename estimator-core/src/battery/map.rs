//! Parameter maps: the cell's parameters per SOC level and temperature,
//! the lookup table a BMS runs on, and the cell at a state between levels.
//!
//! It owns the map's levels ([`MapLevel`]), their checks ([`MapError`])
//! and the interpolation ([`ParameterMap::cell_at`]): within a temperature,
//! each parameter linear in SOC between the two levels around it, held
//! beyond the first and the last; between two temperatures, Arrhenius
//! ([`arrhenius_mix`]: `ln R_i`, `ln R_ct`, `ln τ` and `ln i₀` linear in
//! `1/T`, the rest linear in `1/T` too); beyond the map's temperatures,
//! the nearest one held. It must not fit
//! (maps are built on the host, `host-sim identify battery --map-out`) nor
//! read files; the map borrows its levels, so a firmware's map is a
//! `static` table in flash and a C caller's an array it owns.
//!
//! The host's map (`fracbms_host::map::ParameterMap`), the firmware's
//! build-time table (`cargo xtask qemu --map FILE`) and the C ABI
//! (`fracbms_map_cell_at`) all interpolate here.
//!
//! ```
//! use estimator_core::battery::map::{MapLevel, ParameterMap};
//! use estimator_core::battery::CellParameters;
//!
//! let at = |soc: f32, r_i: f32| MapLevel {
//!     temperature_c: Some(25.0),
//!     soc,
//!     cell: CellParameters { r_i, ..CellParameters::cell_18650() },
//! };
//! let levels = [at(0.2, 0.030), at(0.8, 0.020)];
//! let map = ParameterMap::new(&levels).unwrap();
//! let cell = map.cell_at(0.5, Some(20.0));
//! assert!((cell.r_i - 0.025).abs() < 1e-6);
//! // Held beyond the ends.
//! assert_eq!(map.cell_at(0.95, None).r_i, 0.020);
//!
//! // Two temperatures: R_i Arrhenius between them (ln R_i linear in 1/T).
//! let cold = MapLevel { temperature_c: Some(10.0), ..at(0.5, 0.040) };
//! let warm = MapLevel { temperature_c: Some(40.0), ..at(0.5, 0.020) };
//! let levels = [cold, warm];
//! let map = ParameterMap::new(&levels).unwrap();
//! let k = |t: f32| 1.0 / (t + 273.15);
//! let w = (k(25.0) - k(10.0)) / (k(40.0) - k(10.0));
//! let expected = 0.040 * (0.5f32).powf(w);
//! assert!((map.cell_at(0.5, Some(25.0)).r_i - expected).abs() < 1e-6);
//! // Held beyond the map's temperatures.
//! assert_eq!(map.cell_at(0.5, Some(50.0)).r_i, 0.020);
//! ```

use super::CellParameters;
use crate::real::Real;

/// One level of a map: the cell fitted at a SOC and a temperature.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MapLevel<T> {
    /// Temperature (°C), `None` when unknown.
    pub temperature_c: Option<T>,
    /// State of charge in `[0, 1]` where the level was fitted.
    pub soc: T,
    /// The cell fitted there (`u_oc` is the level's OCV offset when the
    /// fit knew the OCV curve).
    pub cell: CellParameters<T>,
}

/// What is wrong with a map's levels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MapError {
    /// No level.
    Empty,
    /// A level's SOC or temperature is not finite, or its SOC is outside
    /// `[0, 1]` (level index from 0).
    NonFinite {
        /// Index of the level.
        index: usize,
    },
    /// A level's cell is not physical ([`CellParameters::is_physical`]).
    NotPhysical {
        /// Index of the level.
        index: usize,
    },
    /// The levels are not sorted by temperature (unknown first), then SOC
    /// (the level that breaks the order).
    NotSorted {
        /// Index of the level.
        index: usize,
    },
}

impl core::fmt::Display for MapError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            MapError::Empty => write!(f, "the map has no level"),
            MapError::NonFinite { index } => write!(
                f,
                "map level {index}: SOC or temperature not finite, or SOC outside [0, 1]"
            ),
            MapError::NotPhysical { index } => {
                write!(f, "map level {index}: the cell is not physical")
            }
            MapError::NotSorted { index } => write!(
                f,
                "map level {index}: levels must be sorted by temperature, then SOC"
            ),
        }
    }
}

/// A checked map over borrowed levels (sorted by temperature, unknown
/// first, then by SOC).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParameterMap<'a, T> {
    levels: &'a [MapLevel<T>],
}

/// Temperature order: unknown first.
fn temp_key<T: Real>(t: Option<T>) -> T {
    t.unwrap_or(T::lit(f64::NEG_INFINITY))
}

impl<'a, T: Real> ParameterMap<'a, T> {
    /// A map over `levels`.
    ///
    /// # Errors
    /// [`MapError`] when there is no level, a value is not finite or not
    /// physical, or the levels are not sorted.
    pub fn new(levels: &'a [MapLevel<T>]) -> Result<Self, MapError> {
        if levels.is_empty() {
            return Err(MapError::Empty);
        }
        for (index, l) in levels.iter().enumerate() {
            let t_ok = l.temperature_c.is_none_or(|t| t.is_finite());
            if !(t_ok && l.soc.is_finite() && l.soc >= T::zero() && l.soc <= T::one()) {
                return Err(MapError::NonFinite { index });
            }
            if !l.cell.is_physical() {
                return Err(MapError::NotPhysical { index });
            }
            if index > 0 {
                let p = &levels[index - 1];
                let (tp, tl) = (temp_key(p.temperature_c), temp_key(l.temperature_c));
                if tl < tp || (tl == tp && l.soc < p.soc) {
                    return Err(MapError::NotSorted { index });
                }
            }
        }
        Ok(Self { levels })
    }

    /// The levels.
    pub fn levels(&self) -> &'a [MapLevel<T>] {
        self.levels
    }

    /// The levels at the temperature nearest `temperature_c` (those of the
    /// first temperature when it is `None` or not finite; a known
    /// temperature is nearer than an unknown one).
    pub fn slice(&self, temperature_c: Option<T>) -> &'a [MapLevel<T>] {
        let l = self.levels;
        // The run of levels at one temperature that starts at `start`.
        let run_at = |start: usize| -> &'a [MapLevel<T>] {
            let rest = l.get(start..).unwrap_or_default();
            let t0 = rest.first().map(|x| x.temperature_c);
            let len = rest
                .iter()
                .take_while(|x| Some(x.temperature_c) == t0)
                .count();
            rest.get(..len).unwrap_or_default()
        };
        let mut best = run_at(0);
        if let Some(t) = temperature_c.filter(|t| t.is_finite()) {
            let dist = |run: &[MapLevel<T>]| {
                run.first()
                    .and_then(|x| x.temperature_c)
                    .map(|x| (x - t).abs())
            };
            let mut k = 0;
            while k < l.len() {
                let run = run_at(k);
                if run.is_empty() {
                    break;
                }
                let better = match (dist(run), dist(best)) {
                    (Some(d), Some(b)) => d < b,
                    (Some(_), None) => true,
                    _ => false,
                };
                if better {
                    best = run;
                }
                k += run.len();
            }
        }
        best
    }

    /// The lowest and highest known temperatures of the map (°C), `None`
    /// when no level has one. Beyond them [`cell_at`](Self::cell_at)
    /// holds the nearest.
    pub fn temperature_range(&self) -> Option<(T, T)> {
        let mut known = self.levels.iter().filter_map(|l| l.temperature_c);
        let first = known.next()?;
        let last = known.last().unwrap_or(first);
        Some((first, last))
    }

    /// The runs of levels at the two known temperatures just below and
    /// just above `t`, when `t` lies strictly between two of the map's
    /// temperatures.
    fn temperatures_around(&self, t: T) -> Option<[&'a [MapLevel<T>]; 2]> {
        let l = self.levels;
        let mut below: Option<&'a [MapLevel<T>]> = None;
        let mut k = 0;
        while k < l.len() {
            let t0 = l.get(k)?.temperature_c;
            let len = l
                .get(k..)?
                .iter()
                .take_while(|x| x.temperature_c == t0)
                .count();
            let run = l.get(k..k + len)?;
            k += len.max(1);
            let Some(tr) = t0 else { continue };
            if tr < t {
                below = Some(run);
            } else if tr > t {
                return below.map(|b| [b, run]);
            } else {
                return None;
            }
        }
        None
    }

    /// The cell at SOC `soc` and temperature `temperature_c`: within a
    /// temperature, each parameter linear in SOC between the two levels
    /// around `soc`, held beyond the first and the last (a non-finite
    /// `soc` gives the middle level's cell); strictly between two of the
    /// map's temperatures, the two temperatures' cells at `soc` mixed by
    /// [`arrhenius_mix`]; otherwise the temperature nearest (the first
    /// when `temperature_c` is unknown; a known temperature is nearer than
    /// an unknown one).
    pub fn cell_at(&self, soc: T, temperature_c: Option<T>) -> CellParameters<T> {
        if let Some(t) = temperature_c.filter(|t| t.is_finite()) {
            if let Some([lo, hi]) = self.temperatures_around(t) {
                let (a, b) = (slice_cell(lo, soc), slice_cell(hi, soc));
                let tk = |c: Option<T>| T::one() / (c.unwrap_or(t) + T::lit(KELVIN));
                let (t_lo, t_hi) = (
                    lo.first().map(|x| x.temperature_c),
                    hi.first().map(|x| x.temperature_c),
                );
                let span = tk(t_hi.flatten()) - tk(t_lo.flatten());
                let w = if span != T::zero() {
                    (tk(Some(t)) - tk(t_lo.flatten())) / span
                } else {
                    T::zero()
                };
                return arrhenius_mix(&a, &b, w);
            }
        }
        slice_cell(self.slice(temperature_c), soc)
    }
}

/// 0 °C in kelvin.
pub const KELVIN: f64 = 273.15;

/// The cell a fraction `w` of the way from `a` to `b` in `1/T` (`w = 0`:
/// `a`; `w = 1`: `b`): `R_i`, `R_ct`, the time constant `τ = R_ct·Q` and
/// the exchange current `i₀` geometric (Arrhenius: `ln x` linear in `1/T`,
/// so each with the activation energy its two temperatures give), α, the
/// OCV offset and the Butler–Volmer `a` linear. A value that is not
/// positive on either side is mixed linearly.
pub fn arrhenius_mix<T: Real>(
    a: &CellParameters<T>,
    b: &CellParameters<T>,
    w: T,
) -> CellParameters<T> {
    let lin = |x: T, y: T| x + w * (y - x);
    let geo = |x: T, y: T| {
        if x > T::zero() && y > T::zero() {
            (x.ln() + w * (y.ln() - x.ln())).exp()
        } else {
            lin(x, y)
        }
    };
    let r_ct = geo(a.r_ct, b.r_ct);
    let tau = geo(a.tau(), b.tau());
    CellParameters {
        r_i: geo(a.r_i, b.r_i),
        r_ct,
        q: if r_ct > T::zero() {
            tau / r_ct
        } else {
            lin(a.q, b.q)
        },
        alpha: lin(a.alpha, b.alpha),
        u_oc: lin(a.u_oc, b.u_oc),
        bv_a: lin(a.bv_a, b.bv_a),
        bv_i0: geo(a.bv_i0, b.bv_i0),
    }
}

/// The cell at `soc` within one temperature's run of levels (see
/// [`ParameterMap::cell_at`]).
fn slice_cell<T: Real>(rows: &[MapLevel<T>], soc: T) -> CellParameters<T> {
    // A map has a level (`new`), so a run has one; NaN if it had none.
    let (Some(first), Some(last), Some(middle)) =
        (rows.first(), rows.last(), rows.get(rows.len() / 2))
    else {
        let nan = T::nan();
        return CellParameters {
            r_i: nan,
            r_ct: nan,
            q: nan,
            alpha: nan,
            u_oc: nan,
            bv_a: nan,
            bv_i0: nan,
        };
    };
    if !soc.is_finite() {
        return middle.cell;
    }
    if soc <= first.soc {
        return first.cell;
    }
    if soc >= last.soc {
        return last.cell;
    }
    // first.soc < soc < last.soc: the first pair of neighbours whose
    // upper level is above soc (the last pair if none is).
    let above = |p: &&[MapLevel<T>]| matches!(p, [_, b] if b.soc > soc);
    let Some([a, b]) = rows
        .windows(2)
        .find(above)
        .or_else(|| rows.windows(2).last())
        .and_then(|p| <&[MapLevel<T>; 2]>::try_from(p).ok())
    else {
        return last.cell;
    };
    let w = if b.soc > a.soc {
        (soc - a.soc) / (b.soc - a.soc)
    } else {
        T::zero()
    };
    let mix = |x: T, y: T| x + w * (y - x);
    let (a, b) = (a.cell, b.cell);
    CellParameters {
        r_i: mix(a.r_i, b.r_i),
        r_ct: mix(a.r_ct, b.r_ct),
        q: mix(a.q, b.q),
        alpha: mix(a.alpha, b.alpha),
        u_oc: mix(a.u_oc, b.u_oc),
        bv_a: mix(a.bv_a, b.bv_a),
        bv_i0: mix(a.bv_i0, b.bv_i0),
    }
}

/// The SOC step after which [`MapFollower`] takes the map's cell again.
pub const MAP_SOC_STEP: f64 = 0.001;
/// The temperature step (°C) after which [`MapFollower`] takes the map's
/// cell again.
pub const MAP_TEMPERATURE_STEP: f64 = 0.5;

/// Follows a map as the cell moves: the state (SOC, temperature) the map's
/// cell was last taken at, so that an online estimator's prior is taken
/// again only when the SOC has moved by [`MAP_SOC_STEP`] or the
/// temperature by [`MAP_TEMPERATURE_STEP`] (the host's `online battery
/// --prior MAP.csv` and the firmware's `FRACBMS_MAP` both follow a map so).
///
/// ```
/// use estimator_core::battery::map::{MapFollower, MapLevel, ParameterMap};
/// use estimator_core::battery::CellParameters;
///
/// let at = |soc: f64, r_i: f64| MapLevel {
///     temperature_c: None,
///     soc,
///     cell: CellParameters { r_i, ..CellParameters::cell_18650() },
/// };
/// let levels = [at(0.2, 0.030), at(0.8, 0.020)];
/// let map = ParameterMap::new(&levels).unwrap();
/// let mut f = MapFollower::new();
/// // The first call takes the cell (before any SOC: the middle level's).
/// assert_eq!(f.follow(&map, f64::NAN, f64::NAN).unwrap().r_i, 0.020);
/// assert!(f.follow(&map, 0.5, f64::NAN).is_some());
/// assert!(f.follow(&map, 0.5005, f64::NAN).is_none());
/// assert!(f.follow(&map, 0.502, f64::NAN).is_some());
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MapFollower<T> {
    taken_at: Option<(T, T)>,
}

impl<T: Real> MapFollower<T> {
    /// A follower that has taken nothing yet.
    pub const fn new() -> Self {
        Self { taken_at: None }
    }

    /// The SOC and temperature (°C) the cell was last taken at (NaN where
    /// unknown).
    pub fn taken_at(&self) -> Option<(T, T)> {
        self.taken_at
    }

    /// The map's cell at `soc` and `temperature_c` (NaN: unknown; an
    /// unknown temperature keeps the one last taken at) when it is the
    /// first call or the state has moved by a step since the cell was last
    /// taken; `None` while it has not.
    pub fn follow(
        &mut self,
        map: &ParameterMap<'_, T>,
        soc: T,
        temperature_c: T,
    ) -> Option<CellParameters<T>> {
        let t = match self.taken_at {
            Some((_, t0)) if !temperature_c.is_finite() => t0,
            _ => temperature_c,
        };
        if let Some((z0, t0)) = self.taken_at {
            let dz = match (soc.is_finite(), z0.is_finite()) {
                (true, true) => (soc - z0).abs() >= T::lit(MAP_SOC_STEP),
                (a, b) => a != b,
            };
            let dt = match (t.is_finite(), t0.is_finite()) {
                (true, true) => (t - t0).abs() >= T::lit(MAP_TEMPERATURE_STEP),
                (a, b) => a != b,
            };
            if !dz && !dt {
                return None;
            }
        }
        self.taken_at = Some((soc, t));
        Some(map.cell_at(soc, t.is_finite().then_some(t)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn level(t: Option<f64>, soc: f64, r_i: f64) -> MapLevel<f64> {
        MapLevel {
            temperature_c: t,
            soc,
            cell: CellParameters {
                r_i,
                ..CellParameters::cell_18650()
            },
        }
    }

    #[test]
    fn checks_levels() {
        assert_eq!(ParameterMap::<f64>::new(&[]), Err(MapError::Empty));
        let l = [level(Some(25.0), 0.5, 0.02), level(Some(25.0), 0.2, 0.02)];
        assert_eq!(ParameterMap::new(&l), Err(MapError::NotSorted { index: 1 }));
        let l = [level(Some(25.0), 0.5, 0.02), level(Some(10.0), 0.6, 0.02)];
        assert_eq!(ParameterMap::new(&l), Err(MapError::NotSorted { index: 1 }));
        let l = [level(None, 0.5, 0.02), level(Some(f64::NAN), 0.6, 0.02)];
        assert_eq!(ParameterMap::new(&l), Err(MapError::NonFinite { index: 1 }));
        let l = [level(None, 1.5, 0.02)];
        assert_eq!(ParameterMap::new(&l), Err(MapError::NonFinite { index: 0 }));
        let l = [level(None, 0.5, -0.02)];
        assert_eq!(
            ParameterMap::new(&l),
            Err(MapError::NotPhysical { index: 0 })
        );
    }

    #[test]
    fn linear_in_soc_at_the_nearest_temperature() {
        let l = [
            level(None, 0.5, 0.5),
            level(Some(10.0), 0.2, 0.04),
            level(Some(10.0), 0.6, 0.08),
            level(Some(25.0), 0.2, 0.02),
            level(Some(25.0), 0.4, 0.03),
            level(Some(25.0), 0.8, 0.01),
        ];
        let m = ParameterMap::new(&l).unwrap();
        // Unknown temperature: the first run (the unknown one).
        assert_eq!(m.slice(None).len(), 1);
        assert_eq!(m.cell_at(0.3, None).r_i, 0.5);
        // 14 °C is nearer 10 than 25; a known temperature beats unknown.
        assert_eq!(m.slice(Some(14.0)).len(), 2);
        // Between 10 and 25 °C: Arrhenius between the two temperatures'
        // cells at the SOC (0.05 at 10 °C, 0.025 at 25 °C).
        let k = |t: f64| 1.0 / (t + KELVIN);
        let w = (k(14.0) - k(10.0)) / (k(25.0) - k(10.0));
        let r = m.cell_at(0.3, Some(14.0)).r_i;
        assert!((r - 0.05 * 0.5f64.powf(w)).abs() < 1e-15, "{r}");
        assert!(r < 0.05 && r > 0.025);
        // Beyond the warmest: held.
        assert!((m.cell_at(0.3, Some(30.0)).r_i - 0.025).abs() < 1e-15);
        assert!((m.cell_at(0.3, Some(5.0)).r_i - 0.05).abs() < 1e-15);
        assert!((m.cell_at(0.6, Some(30.0)).r_i - 0.02).abs() < 1e-15);
        // Exactly at a level; held beyond the ends; NaN SOC: the middle.
        assert_eq!(m.cell_at(0.4, Some(25.0)).r_i, 0.03);
        assert_eq!(m.cell_at(0.0, Some(25.0)).r_i, 0.02);
        assert_eq!(m.cell_at(1.0, Some(25.0)).r_i, 0.01);
        assert_eq!(m.cell_at(f64::NAN, Some(25.0)).r_i, 0.03);
        // A NaN temperature is unknown.
        assert_eq!(m.cell_at(0.3, Some(f64::NAN)).r_i, 0.5);
    }

    /// Cells made by one activation energy per parameter at 10 and 40 °C
    /// give that parameter at 25 °C exactly, τ = R_ct·Q included; α is
    /// linear in 1/T; the ends are held.
    #[test]
    fn arrhenius_between_temperatures() {
        let gas = 8.314_462_618;
        // Activation energies (J/mol) of R_i, R_ct, τ.
        let (e_ri, e_rct, e_tau) = (20e3, 45e3, 30e3);
        let at = |t_c: f64, soc: f64| {
            let x = 1.0 / (t_c + KELVIN) - 1.0 / (25.0 + KELVIN);
            let r_ct = 0.015 * (e_rct / gas * x).exp();
            let tau = 40.0 * (e_tau / gas * x).exp();
            MapLevel {
                temperature_c: Some(t_c),
                soc,
                cell: CellParameters {
                    r_i: 0.02 * (e_ri / gas * x).exp() * (1.0 + soc),
                    r_ct,
                    q: tau / r_ct,
                    alpha: 0.6 + 0.3 * (t_c - 10.0) / 30.0,
                    ..CellParameters::cell_18650()
                },
            }
        };
        let l = [at(10.0, 0.2), at(10.0, 0.8), at(40.0, 0.2), at(40.0, 0.8)];
        let m = ParameterMap::new(&l).unwrap();
        assert_eq!(m.temperature_range(), Some((10.0, 40.0)));
        let c = m.cell_at(0.5, Some(25.0));
        let truth = at(25.0, 0.5).cell;
        let rel = |a: f64, b: f64| (a / b - 1.0).abs();
        assert!(rel(c.r_i, truth.r_i) < 1e-12, "{} {}", c.r_i, truth.r_i);
        assert!(rel(c.r_ct, truth.r_ct) < 1e-12);
        assert!(rel(c.tau(), truth.tau()) < 1e-12);
        // α: linear in 1/T (not in T), between the two.
        let k = |t: f64| 1.0 / (t + KELVIN);
        let w = (k(25.0) - k(10.0)) / (k(40.0) - k(10.0));
        assert!((c.alpha - (0.6 + 0.3 * w)).abs() < 1e-12);
        // At a map temperature: that temperature's cell; beyond: held.
        assert_eq!(m.cell_at(0.5, Some(10.0)), m.cell_at(0.5, Some(0.0)));
        assert_eq!(m.cell_at(0.5, Some(40.0)), m.cell_at(0.5, Some(60.0)));
        assert!(rel(m.cell_at(0.2, Some(40.0)).r_i, at(40.0, 0.2).cell.r_i) < 1e-15);
        // f32 too.
        let l32: Vec<MapLevel<f32>> = l
            .iter()
            .map(|x| MapLevel {
                temperature_c: x.temperature_c.map(|t| t as f32),
                soc: x.soc as f32,
                cell: CellParameters {
                    r_i: x.cell.r_i as f32,
                    r_ct: x.cell.r_ct as f32,
                    q: x.cell.q as f32,
                    alpha: x.cell.alpha as f32,
                    u_oc: x.cell.u_oc as f32,
                    bv_a: x.cell.bv_a as f32,
                    bv_i0: x.cell.bv_i0 as f32,
                },
            })
            .collect();
        let m32 = ParameterMap::new(&l32).unwrap();
        let c32 = m32.cell_at(0.5, Some(25.0));
        assert!(rel(f64::from(c32.r_ct), truth.r_ct) < 1e-5);
    }

    #[test]
    fn the_follower_takes_the_cell_again_only_after_a_step() {
        let l = [
            level(Some(10.0), 0.2, 0.04),
            level(Some(10.0), 0.6, 0.08),
            level(Some(25.0), 0.2, 0.02),
            level(Some(25.0), 0.6, 0.06),
        ];
        let m = ParameterMap::new(&l).unwrap();
        let mut f = MapFollower::new();
        let r = |c: Option<CellParameters<f64>>| c.map(|c| c.r_i);
        assert!((r(f.follow(&m, 0.4, 25.0)).unwrap() - 0.04).abs() < 1e-15);
        assert_eq!(r(f.follow(&m, 0.4009, 25.4)), None);
        // An unknown temperature keeps the last one taken.
        assert_eq!(r(f.follow(&m, 0.4009, f64::NAN)), None);
        let c = r(f.follow(&m, 0.401, f64::NAN)).unwrap();
        assert!((c - 0.0401).abs() < 1e-12, "{c}");
        assert_eq!(f.taken_at(), Some((0.401, 25.0)));
        // The temperature step: 25 → 10 °C takes the 10 °C levels.
        let c = r(f.follow(&m, 0.401, 10.0)).unwrap();
        assert!((c - 0.0601).abs() < 1e-12, "{c}");
        // 10 → 12 °C: between the two temperatures' cells.
        let c = r(f.follow(&m, 0.401, 12.0)).unwrap();
        assert!(c < 0.0601 && c > 0.0401, "{c}");
        // The SOC becoming unknown (or known) is a step.
        assert!(f.follow(&m, f64::NAN, 12.0).is_some());
        assert!(f.follow(&m, f64::NAN, 12.0).is_none());
        assert!(f.follow(&m, 0.3, 12.0).is_some());
    }
}
