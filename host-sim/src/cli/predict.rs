//! `predict battery`: the flags of validation on another record, and the
//! line it prints.

use super::identify::OcvArgs;
use super::RecordArgs;
use anyhow::Result;
use fracbms_host::predict::{self, PredictOptions};
use std::path::PathBuf;

/// `predict battery`.
#[derive(clap::Args, Debug)]
pub struct PredictBatteryArgs {
    /// The identified model: the JSON of `identify battery`, or the map CSV
    /// of `identify battery --map-out` (parameters by the counted SOC; needs
    /// --ocv).
    #[arg(long)]
    pub model: PathBuf,
    /// The record's temperature (°C) for a map over temperature (default:
    /// the temperature column's mean, else the map's first temperature).
    #[arg(long)]
    pub temperature_c: Option<f64>,
    /// The record to validate on: a record or a cycler export
    /// (docs/cycler.md).
    #[arg(long)]
    pub input: PathBuf,
    #[command(flatten)]
    pub record: RecordArgs,
    #[command(flatten)]
    pub ocv: OcvArgs,
    /// Output: `time_s,current_a,voltage_v,model_v`.
    #[arg(long)]
    pub out: PathBuf,
    /// The errors as JSON: `rmse_v`, `max_error_v`, `max_error_time_s`,
    /// `samples`, the SOC range and how the record was read.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

pub(super) fn battery(a: PredictBatteryArgs) -> Result<()> {
    let o = PredictOptions {
        model: a.model.clone(),
        temperature_c: a.temperature_c,
        ocv: (&a.ocv).into(),
        record: (&a.record).into(),
    };
    let p = predict::battery_file(&a.input, &a.out, &o)?;
    if let Some(r) = &p.record {
        super::print_record(&a.input, r);
    }
    if let Some(j) = &a.json {
        fracbms_host::io::write_json(j, &p)?;
    }
    println!(
        "{} on {}: RMSE {:.2} mV, max error {:.2} mV at {} s, over {} samples",
        a.model.display(),
        a.input.display(),
        p.rmse_v * 1e3,
        p.max_error_v * 1e3,
        p.max_error_time_s,
        p.samples
    );
    Ok(())
}
