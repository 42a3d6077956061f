//! The map model: a map's voltage over a record, and what of the map it
//! uses.
//!
//! It owns [`map_voltage`] (the usable rows at a temperature, each row's
//! model run over the whole record, blended in the counted SOC),
//! [`map_use`] (the rows left out, the temperature rule, the activation
//! energies) and the RMSE over measured samples. It must not fit (that is
//! [`super::build_map`]) nor read files.

use super::super::battery::model_voltage;
use crate::cycler::resample::Gap;
use crate::error::Result;
use crate::io::BatteryRecord;
use crate::map::{bracket as map_bracket, counted_soc, MapRow, ParameterMap};
use crate::ocv::CellOcv;
use crate::{bail, err};

/// RMSE over the samples with a finite voltage that are the log's (not
/// made up inside a gap: `gap[k]`).
pub fn rmse(model: &[f64], measured: &[f64], gap: &[bool]) -> f64 {
    let (s, n) = model
        .iter()
        .zip(measured)
        .zip(gap)
        .filter(|((_, v), g)| v.is_finite() && !**g)
        .fold((0.0, 0usize), |(s, n), ((m, v), _)| {
            (s + (m - v) * (m - v), n + 1)
        });
    (s / n.max(1) as f64).sqrt()
}

/// The map model's voltage over `rec` with the OCV `c` at the
/// temperature `t`: the map's usable rows ([`ParameterMap::usable`]: not
/// those that are not identifiable) at `t` ([`ParameterMap::rows_at`]:
/// Arrhenius between temperatures, the nearest held beyond them), each
/// row's model run over the whole record, blended linearly in the counted
/// SOC between the two rows around it (module docs). [`map_use`] says
/// what was left out.
///
/// # Errors
/// [`crate::ErrorKind::Data`] for an empty map or a level whose cell is
/// not physical.
pub fn map_voltage(
    map: &ParameterMap,
    rec: &BatteryRecord,
    c: &CellOcv,
    t: Option<f64>,
    gaps: &[Gap],
) -> Result<Vec<f64>> {
    let (usable, left_out) = map.usable();
    if map.rows.is_empty() {
        bail!(Data, "the parameter map has no levels");
    }
    if usable.rows.is_empty() {
        bail!(
            Data,
            "no level of the map is identifiable, so none is used ({})",
            left_out.join("; ")
        );
    }
    let owned = usable.rows_at(t);
    let rows: Vec<&MapRow> = owned.iter().collect();
    if rows.is_empty() {
        bail!(
            Data,
            "the parameter map's levels are not a map (unsorted or not physical)"
        );
    }
    let soc = counted_soc(rec, c, gaps);
    let current: Vec<f64> = rec
        .current
        .iter()
        .map(|i| if i.is_finite() { *i } else { 0.0 })
        .collect();
    let runs = rows
        .iter()
        .map(|r| {
            let cell = r.cell();
            if !cell.is_physical() {
                return Err(err!(
                    Data,
                    "the map's level at SOC {} is not a physical cell",
                    r.soc
                ));
            }
            model_voltage(&cell, rec.h, &current)
        })
        .collect::<Result<Vec<Vec<f64>>>>()?;
    Ok((0..current.len())
        .map(|k| {
            // The SOC after sample k's charge, as the OCV is taken.
            let z = soc[k] + current[k] * rec.h / (3600.0 * c.model.capacity_ah);
            let (j, w) = map_bracket(&rows, z).unwrap_or((0, 0.0));
            let j1 = (j + 1).min(rows.len() - 1);
            // The OCV at the same SOC, read again after each gap (as the
            // levels are placed), not counted through it.
            runs[j][k] + w * (runs[j1][k] - runs[j][k]) + c.model.table.ocv(z)
        })
        .collect())
}

/// What a map model at a temperature uses: the rows left out (not
/// identifiable or not physical, each with why), where the temperature is
/// against the map's, and the map's activation energies.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct MapUse {
    /// Rows the model runs on (at the temperature: one per SOC).
    pub levels_used: usize,
    /// Rows left out, each with why.
    pub left_out: Vec<String>,
    /// The temperature the map was taken at (°C), if known.
    pub temperature_c: Option<f64>,
    /// How it was taken: `single` (the map has one temperature or none
    /// known), `at` (one of the map's), `arrhenius` (between two),
    /// `held` (beyond the map's: the nearest held), `unknown` (the
    /// record's temperature unknown: the map's first).
    pub temperature_rule: &'static str,
    /// The map's activation energies (several temperatures).
    pub activation: Option<crate::map::ActivationEnergies>,
}

impl MapUse {
    /// One warning per thing a user should know: the rows left out
    /// (counted, with why) and a temperature beyond the map's.
    pub fn warnings(&self) -> Vec<String> {
        let mut w = vec![];
        if !self.left_out.is_empty() {
            let at: Vec<&str> = self
                .left_out
                .iter()
                .map(|x| {
                    x.split(':')
                        .next()
                        .unwrap_or(x)
                        .trim_start_matches("level at ")
                })
                .collect();
            w.push(format!(
                "{} map level(s) not used (not identifiable or not physical: the map's identifiable_reason says why), their neighbours carry the map across: {}",
                self.left_out.len(),
                at.join("; ")
            ));
        }
        if self.temperature_rule == "held" {
            if let (Some(t), Some(a)) = (self.temperature_c, self.activation.as_ref()) {
                w.push(format!(
                    "the record's {t:.1} °C is outside the map's {}–{} °C: the nearest temperature held",
                    a.temperatures_c[0], a.temperatures_c[1]
                ));
            }
        }
        w
    }
}

/// What [`map_voltage`] uses of `map` at the temperature `t`.
pub fn map_use(map: &ParameterMap, t: Option<f64>) -> MapUse {
    let (usable, left_out) = map.usable();
    let temps = usable.temperatures();
    let t = t.filter(|t| t.is_finite());
    let rule = match (t, temps.len()) {
        (_, 0 | 1) => "single",
        (None, _) => "unknown",
        (Some(t), _) if temps.contains(&t) => "at",
        (Some(t), _) if t < temps[0] || t > temps[temps.len() - 1] => "held",
        _ => "arrhenius",
    };
    MapUse {
        levels_used: usable.rows_at(t).len(),
        left_out,
        temperature_c: t,
        temperature_rule: rule,
        activation: usable.activation_energies(),
    }
}
