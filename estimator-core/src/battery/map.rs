//! Parameter maps: the cell's parameters per SOC level and temperature,
//! the lookup table a BMS runs on, and the cell at a state between levels.
//!
//! It owns the map's levels ([`MapLevel`]), their checks ([`MapError`])
//! and the interpolation ([`ParameterMap::cell_at`]): at the temperature
//! nearest the one asked, each parameter linear in SOC between the two
//! levels around it, held beyond the first and the last. It must not fit
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

    /// The cell at SOC `soc` and the temperature nearest `temperature_c`:
    /// each parameter linear in SOC between the two levels around `soc`,
    /// held beyond the first and the last (a non-finite `soc` gives the
    /// middle level's cell).
    pub fn cell_at(&self, soc: T, temperature_c: Option<T>) -> CellParameters<T> {
        let rows = self.slice(temperature_c);
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
    pub fn new() -> Self {
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
        assert!((m.cell_at(0.3, Some(14.0)).r_i - 0.05).abs() < 1e-15);
        assert!((m.cell_at(0.3, Some(30.0)).r_i - 0.025).abs() < 1e-15);
        assert!((m.cell_at(0.6, Some(30.0)).r_i - 0.02).abs() < 1e-15);
        // Exactly at a level; held beyond the ends; NaN SOC: the middle.
        assert_eq!(m.cell_at(0.4, Some(25.0)).r_i, 0.03);
        assert_eq!(m.cell_at(0.0, Some(25.0)).r_i, 0.02);
        assert_eq!(m.cell_at(1.0, Some(25.0)).r_i, 0.01);
        assert_eq!(m.cell_at(f64::NAN, Some(25.0)).r_i, 0.03);
        // A NaN temperature is unknown.
        assert_eq!(m.cell_at(0.3, Some(f64::NAN)).r_i, 0.5);
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
        // The temperature step: 25 → 12 °C picks the 10 °C levels.
        let c = r(f.follow(&m, 0.401, 12.0)).unwrap();
        assert!((c - 0.0601).abs() < 1e-12, "{c}");
        // The SOC becoming unknown (or known) is a step.
        assert!(f.follow(&m, f64::NAN, 12.0).is_some());
        assert!(f.follow(&m, f64::NAN, 12.0).is_none());
        assert!(f.follow(&m, 0.3, 12.0).is_some());
    }
}
