//! `--ocv`, `--capacity-ah`, `--soc0`: the cell's OCV curve and the start
//! state of charge of a record, checked into one value with one-line errors.
//! The coulomb counting and the overpotential are estimator-core's
//! ([`estimator_core::battery::ocv`]); this module only reads and checks.

use crate::error::Result;
use crate::io::{self, BatteryRecord, HostOcvTable, OCV_POINTS};
use crate::{bail, err};
use estimator_core::battery::ocv::OcvModel;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The cell's open-circuit voltage curve and state of charge, as given
/// (`--ocv`, `--capacity-ah`, `--soc0`): checked into an [`OcvSpec`] by
/// [`OcvSpec::from_options`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct OcvOptions {
    /// OCV table CSV with header `soc,ocv_v` (soc in [0, 1], both columns
    /// increasing): the model fits U_t − OCV(SOC) with the SOC counted from
    /// the current, and its U_oc becomes a small offset ΔU.
    pub ocv: Option<PathBuf>,
    /// Capacity (A·h) for coulomb counting (needed with an OCV table).
    pub capacity_ah: Option<f64>,
    /// State of charge at the start of the record, before the first row's
    /// charge (default: read from the first rows' voltage through the
    /// inverse OCV; the record must then start at rest).
    pub soc0: Option<f64>,
}

/// A record's OCV curve, capacity and start SOC.
#[derive(Clone, Copy, Debug)]
pub struct CellOcv {
    /// Curve and capacity.
    pub model: OcvModel<f64, OCV_POINTS>,
    /// SOC before the first row's charge.
    pub soc0: f64,
}

impl CellOcv {
    /// SOC before each sample's charge: counted from `c.soc0`, and after
    /// each of the record's `gaps` read again from the rested voltage through
    /// the inverse OCV where the record resumes at rest (the charge of a gap
    /// is unknown: a pulse test logged without its discharges between levels).
    pub fn counted_soc(
        &self,
        rec: &BatteryRecord,
        gaps: &[crate::cycler::resample::Gap],
    ) -> Vec<f64> {
        let c = self;
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

    /// [`overpotential_record`](Self::overpotential_record) of a record
    /// with `gaps` (a log that leaves out stretches: the Panasonic HPPC
    /// tests' discharges between levels): the SOC is read again at rest
    /// after each gap through the inverse OCV, as the map's
    /// ([`crate::map::counted_soc`]), not counted through it.
    pub fn overpotential_record_across(
        &self,
        rec: &BatteryRecord,
        gaps: &[crate::cycler::resample::Gap],
    ) -> (BatteryRecord, f64) {
        if gaps.is_empty() {
            return self.overpotential_record(rec);
        }
        let soc = self.counted_soc(rec, gaps);
        let mut end = self.soc0;
        let y = (soc.iter().zip(&rec.current).zip(&rec.voltage))
            .map(|((&z, &i), &v)| {
                end = self.model.soc_after(z, i, rec.h);
                self.model.overpotential(end, v)
            })
            .collect();
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

/// A cell's OCV curve and capacity, and the start SOC when it is given:
/// what `--ocv`, `--capacity-ah` and `--soc0` say, checked, before a
/// record is read (the Python face builds it from arrays).
#[derive(Clone, Copy, Debug)]
pub struct OcvSpec {
    /// Curve and capacity.
    pub model: OcvModel<f64, OCV_POINTS>,
    /// SOC before the first row's charge (`None`: read from the record's
    /// rested start).
    pub soc0: Option<f64>,
}

/// Why the capacity or start SOC of an [`OcvSpec`] was refused (each face
/// names its own argument in the message).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OcvSpecError {
    /// The capacity (A·h) is not finite and positive.
    Capacity(f64),
    /// The start SOC is not in `[0, 1]`.
    Soc0(f64),
}

impl OcvSpec {
    /// Checks the capacity and start SOC for `table`.
    pub fn new(
        table: HostOcvTable,
        capacity_ah: f64,
        soc0: Option<f64>,
    ) -> Result<Self, OcvSpecError> {
        Self::check(capacity_ah, soc0)?;
        let model =
            OcvModel::new(table, capacity_ah).map_err(|_| OcvSpecError::Capacity(capacity_ah))?;
        Ok(Self { model, soc0 })
    }

    /// The checks of [`OcvSpec::new`] that need no table.
    pub fn check(capacity_ah: f64, soc0: Option<f64>) -> Result<(), OcvSpecError> {
        if !(capacity_ah.is_finite() && capacity_ah > 0.0) {
            return Err(OcvSpecError::Capacity(capacity_ah));
        }
        match soc0 {
            Some(z) if !(0.0..=1.0).contains(&z) => Err(OcvSpecError::Soc0(z)),
            _ => Ok(()),
        }
    }

    /// Checks `--capacity-ah` and `--soc0` and reads `--ocv`: `None`
    /// without `--ocv`.
    pub fn from_options(a: &OcvOptions) -> Result<Option<Self>> {
        let Some(path) = &a.ocv else {
            if a.capacity_ah.is_some() || a.soc0.is_some() {
                bail!(Options, "--capacity-ah and --soc0 go with --ocv FILE.csv");
            }
            return Ok(None);
        };
        let cap = a.capacity_ah.ok_or_else(|| {
            err!(
                Options,
                "--ocv needs --capacity-ah (the cell's capacity in A·h)"
            )
        })?;
        let said = |e| match e {
            OcvSpecError::Capacity(c) => {
                err!(Options, "--capacity-ah {c}: must be finite and positive")
            }
            OcvSpecError::Soc0(z) => err!(Options, "--soc0 {z}: must be in [0, 1]"),
        };
        // The flags are checked before the file is read.
        Self::check(cap, a.soc0).map_err(said)?;
        Self::new(io::read_ocv(path)?, cap, a.soc0)
            .map_err(said)
            .map(Some)
    }

    /// The start SOC for record `rec` (file `path`): `soc0` when given,
    /// else read from the first rows' voltage through the inverse OCV,
    /// which needs a record that starts at rest.
    pub fn resolve(&self, path: &Path, rec: &BatteryRecord) -> Result<CellOcv> {
        let model = self.model;
        let soc0 = match self.soc0 {
            Some(z) => z,
            None => model.soc_at_rest(&rec.current, &rec.voltage).map_err(|_| {
                err!(
                    Data,
                    "{}: row 2: the record does not start at rest (|I| = {} A above C/100 = {} A), \
                     so its start SOC cannot be read from the OCV table; give --soc0",
                    path.display(),
                    rec.current.first().map_or(0.0, |i| i.abs()),
                    model.capacity_ah / 100.0
                )
            })?,
        };
        Ok(CellOcv { model, soc0 })
    }
}

/// Checks `--capacity-ah` and reads `--ocv`, without a record (the start
/// SOC is left to the caller).
pub fn model(a: &OcvOptions) -> Result<Option<OcvModel<f64, OCV_POINTS>>> {
    Ok(OcvSpec::from_options(a)?.map(|s| s.model))
}

/// Reads the options for record `rec` (file `path`): `None` without
/// `--ocv`. Without `--soc0` the start SOC is read from the first rows'
/// voltage through the inverse OCV; the record must then start at rest.
pub fn resolve(a: &OcvOptions, path: &Path, rec: &BatteryRecord) -> Result<Option<CellOcv>> {
    OcvSpec::from_options(a)?
        .map(|s| s.resolve(path, rec))
        .transpose()
}
