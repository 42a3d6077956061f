//! `--ocv`, `--capacity-ah`, `--soc0`: the cell's OCV curve and the start
//! state of charge of a record, checked into one value with one-line errors.
//! The coulomb counting and the overpotential are estimator-core's
//! ([`estimator_core::battery::ocv`]); this module only reads and checks.

use crate::cli::OcvArgs;
use crate::io::{self, BatteryRecord, OCV_POINTS};
use anyhow::{anyhow, bail, Result};
use estimator_core::battery::ocv::OcvModel;
use std::path::Path;

/// A record's OCV curve, capacity and start SOC.
#[derive(Clone, Copy, Debug)]
pub struct CellOcv {
    /// Curve and capacity.
    pub model: OcvModel<f64, OCV_POINTS>,
    /// SOC before the first row's charge.
    pub soc0: f64,
}

impl CellOcv {
    /// The record with its voltage replaced by the overpotential
    /// `U_t − OCV(SOC)`, and the SOC after its last row.
    pub fn overpotential_record(&self, rec: &BatteryRecord) -> (BatteryRecord, f64) {
        let mut y = vec![0.0; rec.voltage.len()];
        let end = self
            .model
            .overpotentials(rec.h, self.soc0, &rec.current, &rec.voltage, &mut y);
        (
            BatteryRecord {
                time: rec.time.clone(),
                current: rec.current.clone(),
                voltage: y,
                h: rec.h,
            },
            end,
        )
    }
}

/// Checks `--capacity-ah` and reads `--ocv`, without a record (the start
/// SOC is left to the caller).
pub fn model(a: &OcvArgs) -> Result<Option<OcvModel<f64, OCV_POINTS>>> {
    let Some(path) = &a.ocv else {
        if a.capacity_ah.is_some() || a.soc0.is_some() {
            bail!("--capacity-ah and --soc0 go with --ocv FILE.csv");
        }
        return Ok(None);
    };
    let cap = a
        .capacity_ah
        .ok_or_else(|| anyhow!("--ocv needs --capacity-ah (the cell's capacity in A·h)"))?;
    if !(cap.is_finite() && cap > 0.0) {
        bail!("--capacity-ah {cap}: must be finite and positive");
    }
    if let Some(z) = a.soc0 {
        if !(0.0..=1.0).contains(&z) {
            bail!("--soc0 {z}: must be in [0, 1]");
        }
    }
    let table = io::read_ocv(path)?;
    OcvModel::new(table, cap)
        .map_err(|e| anyhow!("--capacity-ah {cap}: {e}"))
        .map(Some)
}

/// Reads the options for record `rec` (file `path`): `None` without
/// `--ocv`. Without `--soc0` the start SOC is read from the first rows'
/// voltage, which needs a record that starts at rest.
pub fn resolve(a: &OcvArgs, path: &Path, rec: &BatteryRecord) -> Result<Option<CellOcv>> {
    let Some(model) = model(a)? else {
        return Ok(None);
    };
    let soc0 = match a.soc0 {
        Some(z) => z,
        None => model.soc_at_rest(&rec.current, &rec.voltage).map_err(|_| {
            anyhow!(
                "{}: row 2: the record does not start at rest (|I| = {} A above C/100 = {} A), \
                     so its start SOC cannot be read from the OCV table; give --soc0",
                path.display(),
                rec.current.first().map_or(0.0, |i| i.abs()),
                model.capacity_ah / 100.0
            )
        })?,
    };
    Ok(Some(CellOcv { model, soc0 }))
}
