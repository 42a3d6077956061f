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
use estimator_core::battery::map::{MapLevel, ParameterMap as CoreMap};
use estimator_core::battery::CellParameters;
use serde::{Deserialize, Serialize};
use std::path::Path;

pub use row::{MapJson, MapOptions, MapRow, MAP_COLUMNS};

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
/// the inverse OCV where the record resumes at rest (the charge of a gap
/// is unknown: a pulse test logged without its discharges between levels).
pub fn counted_soc(rec: &BatteryRecord, c: &CellOcv, gaps: &[Gap]) -> Vec<f64> {
    let n = rec.current.len();
    let mut z = c.soc0;
    let mut out = Vec::with_capacity(n);
    let mut next_gap = 0;
    for k in 0..n {
        // The first sample at or after a gap's end: anchor there.
        while next_gap < gaps.len()
            && rec.time[k] >= gaps[next_gap].start_s + gaps[next_gap].length_s
        {
            if let Ok(at_rest) = c.model.soc_at_rest(&rec.current[k..], &rec.voltage[k..]) {
                z = at_rest;
            }
            next_gap += 1;
        }
        out.push(z);
        let i = rec.current[k];
        if i.is_finite() {
            z += i * rec.h / (3600.0 * c.model.capacity_ah);
        }
    }
    out
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

    /// The cell at SOC `z` (temperature nearest `t`): each parameter
    /// linear in SOC between the two levels around `z`, held beyond the
    /// first and the last; the middle level's for a non-finite `z`. The
    /// core's [`CoreMap::cell_at`], the firmware's and the C ABI's.
    /// `None` for an empty map or one with a level that is not physical.
    pub fn cell_at(&self, z: f64, t: Option<f64>) -> Option<CellParameters<f64>> {
        let levels = self.levels();
        let m = CoreMap::new(&levels).ok()?;
        Some(m.cell_at(z, t))
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
