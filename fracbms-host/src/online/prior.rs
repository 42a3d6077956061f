//! The online estimator's prior (`online battery --prior`): one
//! characterization fit (the JSON of `identify battery`), or a parameter
//! map whose cell at the counted SOC and the temperature is the prior's
//! centre as the cell moves.
//!
//! It owns reading either file and the map's prior at a state. It must not
//! run the estimator (that is [`super::Tracker`], which takes the prior
//! again as the SOC moves) nor build maps ([`crate::identify::map`]).

use crate::error::Result;
use crate::map::ParameterMap;
use crate::{bail, err};
use estimator_core::battery::map::{MapFollower, MapLevel, ParameterMap as CoreMap};
use estimator_core::battery::{CellParameters, Prior};
use std::path::Path;

/// Where the prior comes from.
#[derive(Clone, Debug)]
pub enum PriorSource {
    /// One fit: the same prior at every state.
    Fit(Prior<f64>),
    /// A parameter map: the prior follows the SOC and temperature.
    Map(PriorMap),
}

/// A parameter map as a prior: its identifiable, physical levels, and the
/// `--prior-*` spreads around the cell interpolated between them.
#[derive(Clone, Debug)]
pub struct PriorMap {
    /// The levels kept (identifiable and physical).
    pub map: ParameterMap,
    /// Levels left out, each with why.
    pub left_out: Vec<String>,
    /// Standard deviation of `ln R_i`, `ln R_ct`, `ln Q`.
    pub log_sigma: f64,
    /// Standard deviation of α.
    pub alpha_sigma: f64,
    /// The residual level σ_v (V) the window's data are weighed at.
    pub noise_v: f64,
    /// The kept levels as the core's (checked: never empty, physical).
    levels: Vec<MapLevel<f64>>,
    /// The same levels rounded to `f32`, which an `f32` estimator follows
    /// (as the C ABI and the firmware do: the same prior bit for bit).
    levels_f32: Vec<MapLevel<f32>>,
}

impl PriorMap {
    /// The map `map` as a prior with these spreads: levels that are not
    /// identifiable, or not a physical cell, are left out (their
    /// parameters are not what the data say), and named in `left_out`.
    ///
    /// # Errors
    /// [`crate::ErrorKind::Data`] when no level is left, or the spreads
    /// are not positive.
    pub fn new(map: &ParameterMap, log_sigma: f64, alpha_sigma: f64, noise_v: f64) -> Result<Self> {
        let (kept, left_out) = map.usable();
        if kept.rows.is_empty() {
            bail!(
                Data,
                "no level of the map can be a prior ({})",
                left_out.join("; ")
            );
        }
        let levels = kept.levels();
        let levels_f32 = levels
            .iter()
            .map(|l| MapLevel {
                temperature_c: l.temperature_c.map(|t| t as f32),
                soc: l.soc as f32,
                cell: l.cell.cast(),
            })
            .collect();
        let p = PriorMap {
            levels,
            levels_f32,
            map: kept,
            left_out,
            log_sigma,
            alpha_sigma,
            noise_v,
        };
        if !p.prior_at(None, None).is_valid() {
            bail!(Data, "a --prior-* spread is not positive");
        }
        Ok(p)
    }

    /// The core's map over the kept levels (`None` only if a field was
    /// changed after [`PriorMap::new`] to a level the core refuses).
    fn core(&self) -> Option<CoreMap<'_, f64>> {
        CoreMap::new(&self.levels).ok()
    }

    /// The prior around `center` with the map's spreads.
    fn around(&self, center: CellParameters<f64>) -> Prior<f64> {
        Prior {
            center,
            log_sigma: self.log_sigma,
            alpha_sigma: self.alpha_sigma,
            noise_v: self.noise_v,
        }
    }

    /// The prior at SOC `z` and temperature `t` (°C): the map's cell there
    /// (each parameter linear in SOC between the levels around `z`;
    /// Arrhenius between the map's temperatures, the nearest held beyond
    /// them: the core's [`CoreMap::cell_at`]). Without a SOC, the middle
    /// level's.
    pub fn prior_at(&self, z: Option<f64>, t: Option<f64>) -> Prior<f64> {
        let z = z.unwrap_or(f64::NAN);
        let center = self
            .core()
            .map_or_else(|| self.map.rows[0].cell(), |m| m.cell_at(z, t));
        self.around(center)
    }

    /// The prior at SOC `z` and temperature `t` (°C, NaN: unknown) when
    /// `follower` says the state has moved enough since it was last taken.
    pub fn follow(&self, follower: &mut MapFollower<f64>, z: f64, t: f64) -> Option<Prior<f64>> {
        let m = self.core()?;
        follower.follow(&m, z, t).map(|c| self.around(c))
    }

    /// [`PriorMap::follow`] in `f32`, as an `f32` estimator (the C ABI's,
    /// the firmware's) follows the map: the levels, the SOC and the
    /// temperature rounded to `f32`, the cell between the levels computed
    /// in `f32` (then exactly as `f64`).
    pub fn follow_f32(
        &self,
        follower: &mut MapFollower<f32>,
        z: f32,
        t: f32,
    ) -> Option<Prior<f64>> {
        let m = CoreMap::new(&self.levels_f32).ok()?;
        follower.follow(&m, z, t).map(|c| self.around(c.cast()))
    }

    /// One line: the levels the prior follows.
    pub fn describe(&self) -> String {
        let r = &self.map.rows;
        let temps: Vec<String> = {
            let mut t: Vec<Option<f64>> = r.iter().map(|x| x.temperature_c).collect();
            t.dedup();
            t.iter()
                .map(|t| t.map_or_else(|| "unknown".to_string(), |t| format!("{t} °C")))
                .collect()
        };
        format!(
            "prior from the map: {} levels, SOC {:.3}–{:.3}, temperature {} ({} left out)",
            r.len(),
            r.iter().map(|x| x.soc).fold(f64::INFINITY, f64::min),
            r.iter().map(|x| x.soc).fold(f64::NEG_INFINITY, f64::max),
            temps.join(", "),
            self.left_out.len()
        )
    }

    /// Whether every kept level has the Butler–Volmer term (then `auto`
    /// fits it online).
    pub fn is_butler_volmer(&self) -> bool {
        self.map.rows.iter().all(|r| r.cell().is_butler_volmer())
    }
}

/// Reads the prior of `--prior PATH`: a `.csv` is a parameter map (the
/// `--map-out` of `identify battery`), anything else the JSON of
/// `identify battery`; the spreads are those of the `--prior-*` flags.
///
/// # Errors
/// A file that cannot be read, a prior that is not physical, a spread that
/// is not positive.
pub fn read_prior_source(
    path: &Path,
    prior_factor: f64,
    prior_alpha_sigma: f64,
    prior_noise_mv: f64,
) -> Result<PriorSource> {
    let is_csv = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
    if !is_csv {
        return read_prior(path, prior_factor, prior_alpha_sigma, prior_noise_mv)
            .map(PriorSource::Fit);
    }
    check_factor(prior_factor)?;
    let map = ParameterMap::read_csv(path)?;
    map_prior(&map, path, prior_factor, prior_alpha_sigma, prior_noise_mv)
}

/// The map `map` (named `name` in errors) as a prior with the `--prior-*`
/// spreads.
fn map_prior(
    map: &ParameterMap,
    name: &Path,
    prior_factor: f64,
    prior_alpha_sigma: f64,
    prior_noise_mv: f64,
) -> Result<PriorSource> {
    check_factor(prior_factor)?;
    PriorMap::new(
        map,
        prior_factor.ln(),
        prior_alpha_sigma,
        prior_noise_mv * 1e-3,
    )
    .map(PriorSource::Map)
    .map_err(|e| err!(Data, "{}: {}", name.display(), e.message()))
}

/// A prior from a JSON value: a fit's ([`prior_from_fit`]), or a parameter
/// map's, `{"levels": [rows with the map CSV's columns]}` (the `map` of
/// `identify battery --json --map-out`, or of the Python face's
/// `identify_battery(..., map=True)`); `name` names it in errors.
///
/// # Errors
/// As [`prior_from_fit`]; for a map, rows that are not the map's, or no
/// level that can be a prior ([`PriorMap::new`]).
pub fn prior_source_from_json(
    j: &serde_json::Value,
    name: &Path,
    prior_factor: f64,
    prior_alpha_sigma: f64,
    prior_noise_mv: f64,
) -> Result<PriorSource> {
    let Some(levels) = j.get("levels") else {
        return prior_from_fit(j, name, prior_factor, prior_alpha_sigma, prior_noise_mv)
            .map(PriorSource::Fit);
    };
    check_factor(prior_factor)?;
    let map = ParameterMap::from_json_levels(levels, name)?;
    map_prior(&map, name, prior_factor, prior_alpha_sigma, prior_noise_mv)
}

fn check_factor(prior_factor: f64) -> Result<()> {
    if !(prior_factor.is_finite() && prior_factor > 1.0) {
        bail!(Options, "--prior-factor {}: must be above 1", prior_factor);
    }
    Ok(())
}

/// Reads a prior: `path` is the JSON of `identify battery` (`--prior
/// FIT.json`), the spreads are those of the `--prior-*` flags.
///
/// # Errors
/// A file that cannot be read, a prior that is not physical, a spread that
/// is not positive.
pub fn read_prior(
    path: &Path,
    prior_factor: f64,
    prior_alpha_sigma: f64,
    prior_noise_mv: f64,
) -> Result<Prior<f64>> {
    let j = crate::identify::battery::read_json_file(path)?;
    prior_from_fit(&j, path, prior_factor, prior_alpha_sigma, prior_noise_mv)
}

/// A prior from the JSON value of a fit (`identify battery --json`, or the
/// Python face's dict of `identify_battery`); `name` names it in errors.
///
/// # Errors
/// A value that is not a fit, a prior that is not physical, a spread that
/// is not positive.
pub fn prior_from_fit(
    j: &serde_json::Value,
    name: &Path,
    prior_factor: f64,
    prior_alpha_sigma: f64,
    prior_noise_mv: f64,
) -> Result<Prior<f64>> {
    let path = name;
    let (center, _) = crate::identify::battery::cell_from_json(j, path)?;
    check_factor(prior_factor)?;
    let p = Prior {
        center,
        log_sigma: prior_factor.ln(),
        alpha_sigma: prior_alpha_sigma,
        noise_v: prior_noise_mv * 1e-3,
    };
    if !p.is_valid() {
        bail!(
            Data,
            "{}: the prior is not physical, or a --prior-* spread is not positive",
            path.display()
        );
    }
    Ok(p)
}
