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
    /// (docs/cycler.md). Repeat it (or give several after it) to validate
    /// on several records, with --report.
    #[arg(long, required = true, num_args = 1..)]
    pub input: Vec<PathBuf>,
    #[command(flatten)]
    pub record: RecordArgs,
    #[command(flatten)]
    pub ocv: OcvArgs,
    /// Output: `time_s,current_a,voltage_v,model_v,observed` (one
    /// --input). One of --out, --report and --json is needed.
    #[arg(long, required_unless_present_any = ["report", "json"])]
    pub out: Option<PathBuf>,
    /// The validation page: into this folder, `report.md` (per record the
    /// RMSE and largest error over the measured samples inside the OCV
    /// table, and over every measured sample), `report.json`, and per
    /// record `NN-NAME.svg` (voltage and error against time) and
    /// `NN-NAME.csv` (the --out columns).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// The errors as JSON: `rmse_v`, `max_error_v`, `max_error_time_s`,
    /// `samples`, `in_table`, the SOC range, `map` and how the record was
    /// read (an array of them with several --input, each with its `input`).
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
    let ps = predict::battery_files(&a.input, a.out.as_deref(), a.report.as_deref(), &o)?;
    for (input, p) in a.input.iter().zip(&ps) {
        if let Some(r) = &p.record {
            super::print_record(input, r);
        }
    }
    if let Some(u) = ps.iter().find_map(|p| p.map.as_ref()) {
        for w in u.warnings() {
            eprintln!("warning: {w}");
        }
        if let Some(e) = &u.activation {
            println!("{e}");
        }
    }
    if let Some(j) = &a.json {
        match ps.as_slice() {
            [p] => fracbms_host::io::write_json(j, p)?,
            // Several: each named by its --input.
            _ => fracbms_host::io::write_json(j, &predict::named(&a.input, &ps))?,
        }
    }
    for (input, p) in a.input.iter().zip(&ps) {
        let table = p.in_table.map_or(String::new(), |t| {
            format!(
                "; inside the OCV table (SOC {:.2}–{:.2}): RMSE {:.2} mV, max error {:.2} mV over {} samples",
                t.soc_range[0],
                t.soc_range[1],
                t.rmse_v * 1e3,
                t.max_error_v * 1e3,
                t.samples
            )
        });
        println!(
            "{} on {}: RMSE {:.2} mV, max error {:.2} mV at {} s, over {} samples{table}",
            a.model.display(),
            input.display(),
            p.rmse_v * 1e3,
            p.max_error_v * 1e3,
            p.max_error_time_s,
            p.samples
        );
    }
    if let Some(d) = &a.report {
        println!("wrote {}", d.join("report.md").display());
    }
    Ok(())
}
