//! Parameter maps: R_i, R_ct, Q, α (and the Butler–Volmer term) per SOC
//! level and temperature, the lookup tables a BMS runs on.
//!
//! It owns the map's rows, its CSV ([`MAP_COLUMNS`]), the cell at a SOC
//! and temperature (parameters linear in SOC between levels), the counted
//! SOC the levels are placed by, and the map's plot. It must not fit
//! (building a map is [`crate::identify::map`]) nor read records.
//!
//! Conventions: SOC in [0, 1] counted from the current (positive
//! charging), temperature in °C; a level's SOC is the counted SOC where its
//! pulses start (the end of the rest before them).

use crate::cycler::resample::Gap;
use crate::error::Result;
use crate::io::BatteryRecord;
use crate::ocv::CellOcv;
use crate::trust::Confidence;
use estimator_core::battery::map::{MapLevel, ParameterMap as CoreMap, KELVIN};
use estimator_core::battery::CellParameters;
use serde::{Deserialize, Serialize};
use std::path::Path;

pub use self::csv::{MapColumn, MAP_COLUMNS, MAP_CSV};
pub use row::{JointCandidate, MapJson, MapMethod, MapOptions, MapRow, JOINT_PARAMETERS};

mod csv;
mod row;

/// A parameter map: its levels, sorted by temperature then SOC.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ParameterMap {
    /// The levels.
    pub rows: Vec<MapRow>,
}

/// SOC before each sample's charge: counted from `c.soc0`, and after
/// each of the record's `gaps` read again from the rested voltage through
/// the inverse OCV ([`CellOcv::counted_soc`]).
pub fn counted_soc(rec: &BatteryRecord, c: &CellOcv, gaps: &[Gap]) -> Vec<f64> {
    c.counted_soc(rec, gaps)
}

/// Checks a `--temperature-c` given: finite and above absolute zero
/// (the Arrhenius rule divides by the temperature in kelvin).
///
/// # Errors
/// [`Options`](crate::error::ErrorKind::Options), naming the flag.
pub fn check_temperature(t: Option<f64>) -> Result<()> {
    if let Some(t) = t.filter(|t| !(t.is_finite() && *t > -KELVIN)) {
        crate::bail!(
            Options,
            "--temperature-c {}: must be a temperature above absolute zero (°C)",
            crate::error::shown(t)
        );
    }
    Ok(())
}

/// Which samples lie inside one of `gaps` (made up by the resampling: no
/// row of the log is there).
pub fn in_gaps(rec: &BatteryRecord, gaps: &[Gap]) -> Vec<bool> {
    rec.time
        .iter()
        .map(|&t| {
            gaps.iter()
                .any(|g| t > g.start_s && t < g.start_s + g.length_s)
        })
        .collect()
}

impl ParameterMap {
    /// The map of a JSON array of levels, each with the map CSV's columns
    /// (the `levels` of `identify battery --json --map-out`'s `map`, or of
    /// the Python face's `identify_battery(..., map=True)`), sorted; `name`
    /// names it in errors.
    ///
    /// # Errors
    /// [`crate::ErrorKind::Data`] when the rows are not a map's.
    pub fn from_json_levels(levels: &serde_json::Value, name: &Path) -> Result<Self> {
        let rows: Vec<MapRow> = serde_json::from_value(levels.clone())
            .map_err(|e| crate::err!(Data, "{}: not a parameter map ({e})", name.display()))?;
        let mut map = ParameterMap { rows };
        map.sort();
        Ok(map)
    }

    /// Sorts the levels by temperature (unknown first), then SOC.
    pub fn sort(&mut self) {
        self.rows.sort_by(|a, b| {
            let t = |r: &MapRow| r.temperature_c.unwrap_or(f64::NEG_INFINITY);
            t(a).total_cmp(&t(b)).then(a.soc.total_cmp(&b.soc))
        });
    }

    /// The levels at the temperature nearest `t` (all of one unknown
    /// temperature when `t` or the map's temperatures are unknown), sorted
    /// by SOC.
    pub fn slice(&self, t: Option<f64>) -> Vec<&MapRow> {
        let temps: Vec<Option<f64>> = {
            let mut v: Vec<Option<f64>> = self.rows.iter().map(|r| r.temperature_c).collect();
            v.dedup();
            v
        };
        let pick = match t {
            Some(t) => temps
                .iter()
                .copied()
                .min_by(|a, b| {
                    let d = |x: &Option<f64>| x.map_or(f64::INFINITY, |x| (x - t).abs());
                    d(a).total_cmp(&d(b))
                })
                .flatten(),
            None => temps.first().copied().flatten(),
        };
        self.rows
            .iter()
            .filter(|r| r.temperature_c == pick)
            .collect()
    }

    /// The levels as the core's [`MapLevel`]s, sorted as the core's map
    /// wants them (temperature, unknown first, then SOC).
    pub fn levels(&self) -> Vec<MapLevel<f64>> {
        let mut m = self.clone();
        m.sort();
        m.rows
            .iter()
            .map(|r| MapLevel {
                temperature_c: r.temperature_c,
                soc: r.soc,
                cell: r.cell(),
            })
            .collect()
    }

    /// The cell at SOC `z` and temperature `t`: each parameter linear in
    /// SOC between the two levels around `z`, held beyond the first and the
    /// last; the middle level's for a non-finite `z`; Arrhenius between two
    /// temperatures, the nearest held beyond the map's. The
    /// core's [`CoreMap::cell_at`], the firmware's and the C ABI's.
    /// `None` for an empty map or one with a level that is not physical.
    pub fn cell_at(&self, z: f64, t: Option<f64>) -> Option<CellParameters<f64>> {
        let levels = self.levels();
        let m = CoreMap::new(&levels).ok()?;
        Some(m.cell_at(z, t))
    }
}

/// The gas constant (J/(mol·K)), for activation energies.
pub const GAS_CONSTANT: f64 = 8.314_462_618;

/// The activation energies of a map over several temperatures (J/mol):
/// per parameter, the slope of `ln x` against `1/T` fitted over every
/// SOC the temperatures share (one intercept per SOC), times the gas
/// constant. Between two temperatures the map is Arrhenius with the
/// energy those two give ([`estimator_core::battery::map::arrhenius_mix`]);
/// these fitted energies say how far one energy describes the whole map.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ActivationEnergies {
    /// Of R_i.
    pub r_i_j_mol: f64,
    /// Of R_ct.
    pub r_ct_j_mol: f64,
    /// Of the time constant τ = R_ct·Q.
    pub tau_j_mol: f64,
    /// The temperatures (°C) they were fitted over.
    pub temperatures_c: [f64; 2],
    /// The SOCs (shared by every temperature) they were fitted at.
    pub socs: usize,
}

impl std::fmt::Display for ActivationEnergies {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "activation energy (Arrhenius, {}–{} °C, {} SOCs): R_i {:.1} kJ/mol, R_ct {:.1} kJ/mol, τ {:.1} kJ/mol",
            self.temperatures_c[0],
            self.temperatures_c[1],
            self.socs,
            self.r_i_j_mol / 1e3,
            self.r_ct_j_mol / 1e3,
            self.tau_j_mol / 1e3
        )
    }
}

impl ParameterMap {
    /// The rows a map model may use, and each row left out with why:
    /// a row that is not identifiable (its parameters are not what the
    /// data say; `identifiable_reason` quoted) or not a physical cell.
    /// Its neighbours carry the map across it.
    pub fn usable(&self) -> (ParameterMap, Vec<String>) {
        let mut kept = ParameterMap::default();
        let mut left_out = vec![];
        for r in &self.rows {
            let at = match r.temperature_c {
                Some(t) => format!("level at SOC {:.3}, {t} °C", r.soc),
                None => format!("level at SOC {:.3}", r.soc),
            };
            if !r.cell().is_physical() {
                left_out.push(format!("{at}: not a physical cell"));
            } else if !r.identifiable {
                left_out.push(format!(
                    "{at}: not identifiable ({})",
                    r.identifiable_reason
                        .as_deref()
                        .unwrap_or("no reason given")
                ));
            } else {
                kept.rows.push(r.clone());
            }
        }
        kept.sort();
        (kept, left_out)
    }

    /// The distinct known temperatures (°C), ascending.
    pub fn temperatures(&self) -> Vec<f64> {
        let mut t: Vec<f64> = self.rows.iter().filter_map(|r| r.temperature_c).collect();
        t.sort_by(f64::total_cmp);
        t.dedup();
        t
    }

    /// The map at the temperature `t`, as rows sorted by SOC: strictly
    /// between two of its temperatures, one row at every SOC of either
    /// with the core's cell there ([`CoreMap::cell_at`]: Arrhenius between
    /// the temperatures, linear in SOC within each); otherwise the rows of
    /// the temperature nearest (held beyond the map's). Empty for an empty
    /// map or one the core refuses.
    pub fn rows_at(&self, t: Option<f64>) -> Vec<MapRow> {
        let temps = self.temperatures();
        let inside = t.filter(|t| {
            t.is_finite()
                && temps.first().is_some_and(|lo| lo < t)
                && temps.last().is_some_and(|hi| hi > t)
                && !temps.contains(t)
        });
        let Some(t) = inside else {
            return self.slice(t).into_iter().cloned().collect();
        };
        let levels = self.levels();
        let Ok(core) = CoreMap::new(&levels) else {
            return vec![];
        };
        let lo = temps
            .iter()
            .copied()
            .filter(|x| *x < t)
            .fold(f64::NAN, f64::max);
        let hi = temps
            .iter()
            .copied()
            .filter(|x| *x > t)
            .fold(f64::NAN, f64::min);
        let mut socs: Vec<f64> = self
            .rows
            .iter()
            .filter(|r| r.temperature_c == Some(lo) || r.temperature_c == Some(hi))
            .map(|r| r.soc)
            .collect();
        socs.sort_by(f64::total_cmp);
        socs.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        socs.into_iter()
            .map(|soc| {
                let c = core.cell_at(soc, Some(t));
                let bv = c.bv_a > 0.0;
                MapRow {
                    temperature_c: Some(t),
                    soc,
                    r_i: c.r_i,
                    r_ct: c.r_ct,
                    q: c.q,
                    alpha: c.alpha,
                    bv_a_v: bv.then_some(c.bv_a),
                    bv_i0_a: bv.then_some(c.bv_i0),
                    ocv_offset_v: c.u_oc,
                    rmse_v: f64::NAN,
                    identifiable: true,
                    identifiable_reason: None,
                    confidence: None,
                    start_s: f64::NAN,
                    end_s: f64::NAN,
                    samples: 0,
                }
            })
            .collect()
    }

    /// The activation energies of a map over at least two temperatures
    /// that share SOCs (each temperature's cell at every SOC inside all
    /// of their SOC ranges, on a 0.05 grid); `None` otherwise.
    pub fn activation_energies(&self) -> Option<ActivationEnergies> {
        let temps = self.temperatures();
        if temps.len() < 2 {
            return None;
        }
        let levels = self.levels();
        let core = CoreMap::new(&levels).ok()?;
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        for &t in &temps {
            let run = self.slice(Some(t));
            lo = lo.max(run.first()?.soc);
            hi = hi.min(run.last()?.soc);
        }
        let socs: Vec<f64> = (0..=20)
            .map(|k| f64::from(k) * 0.05)
            .filter(|z| *z >= lo - 1e-9 && *z <= hi + 1e-9)
            .collect();
        let socs = if socs.is_empty() {
            vec![0.5 * (lo + hi)]
        } else {
            socs
        };
        if lo > hi {
            return None;
        }
        // Slope of ln x on 1/T with one intercept per SOC.
        let slope = |f: &dyn Fn(&CellParameters<f64>) -> f64| -> f64 {
            let (mut sxy, mut sxx) = (0.0, 0.0);
            for &z in &socs {
                let pts: Vec<(f64, f64)> = temps
                    .iter()
                    .map(|&t| {
                        let c = core.cell_at(z, Some(t));
                        (1.0 / (t + KELVIN), f(&c).max(f64::MIN_POSITIVE).ln())
                    })
                    .collect();
                let n = pts.len() as f64;
                let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
                let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
                for (x, y) in &pts {
                    sxy += (x - mx) * (y - my);
                    sxx += (x - mx) * (x - mx);
                }
            }
            sxy / sxx * GAS_CONSTANT
        };
        Some(ActivationEnergies {
            r_i_j_mol: slope(&|c| c.r_i),
            r_ct_j_mol: slope(&|c| c.r_ct),
            tau_j_mol: slope(&|c| c.tau()),
            temperatures_c: [temps[0], temps[temps.len() - 1]],
            socs: socs.len(),
        })
    }
}

/// The level `j` at or below `z` and the weight of level `j + 1` (0 beyond
/// the ends).
pub fn bracket(rows: &[&MapRow], z: f64) -> Option<(usize, f64)> {
    let n = rows.len();
    if n == 0 {
        return None;
    }
    if z <= rows[0].soc {
        return Some((0, 0.0));
    }
    if z >= rows[n - 1].soc {
        return Some((n - 1, 0.0));
    }
    let j = rows.iter().rposition(|r| r.soc <= z).unwrap_or(0);
    let (a, b) = (rows[j].soc, rows[j + 1].soc);
    Some((j, if b > a { (z - a) / (b - a) } else { 0.0 }))
}

/// An SVG of the map: R_i, R_ct, τ = R_ct·Q and α against SOC, each with
/// its 95 % interval.
///
/// # Errors
/// When it cannot be drawn or written.
pub fn plot(path: &Path, map: &ParameterMap) -> Result<()> {
    use crate::plot::{panels, Panel, Series};
    let rows = map.slice(None);
    let series = |f: &dyn Fn(&MapRow) -> f64, iv: &dyn Fn(&Confidence) -> [f64; 2], scale: f64| {
        let mut s = vec![Series {
            label: "fit",
            points: rows.iter().map(|r| (r.soc, scale * f(r))).collect(),
            color: 0,
        }];
        for (i, label) in [(0, "95 % low"), (1, "95 % high")] {
            s.push(Series {
                label,
                points: rows
                    .iter()
                    .filter_map(|r| r.confidence.as_ref().map(|c| (r.soc, scale * iv(c)[i])))
                    .collect(),
                color: 1,
            });
        }
        s
    };
    panels(
        path,
        &[
            Panel {
                title: "Ohmic resistance R_i",
                x: "SOC",
                y: "R_i (mΩ)",
                series: series(&|r| r.r_i, &|c| c.r_i, 1e3),
                log_y: false,
            },
            Panel {
                title: "Charge-transfer resistance R_ct",
                x: "SOC",
                y: "R_ct (mΩ)",
                series: series(&|r| r.r_ct, &|c| c.r_ct, 1e3),
                log_y: false,
            },
            Panel {
                title: "CPE coefficient Q",
                x: "SOC",
                y: "Q (F·s^(α−1))",
                series: series(&|r| r.q, &|c| c.q, 1.0),
                log_y: true,
            },
            Panel {
                title: "Fractional order α",
                x: "SOC",
                y: "α",
                series: series(&|r| r.alpha, &|c| c.alpha, 1.0),
                log_y: false,
            },
        ],
    )
}

#[cfg(test)]
mod tests;
