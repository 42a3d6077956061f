//! `ocv`: the flags of the OCV table read from a test, and the lines it
//! prints.

use super::RecordArgs;
use anyhow::Result;
use fracbms_host::cycler;
use fracbms_host::ocv_extraction::{self, OcvExtractionOptions, OcvSource};
use std::path::PathBuf;

value_enum! {
    /// Where the OCV is read from (`--from`).
    OcvSourceArg => OcvSource {
        /// The relaxed voltage at the end of each rest (at least --min-rest
        /// long) against the counted SOC.
        Rests,
        /// The mean of a ≤ C/10 charge and discharge, or one branch with
        /// its IR drop removed.
        LowRate,
    }
}

/// `ocv`.
#[derive(clap::Args, Debug)]
pub struct OcvArgs {
    /// The test: a record or a cycler export (docs/cycler.md).
    #[arg(long)]
    pub input: PathBuf,
    #[command(flatten)]
    pub record: RecordArgs,
    /// Capacity (A·h); default: the charge between the test's highest and
    /// lowest counted charge (printed).
    #[arg(long)]
    pub capacity_ah: Option<f64>,
    /// SOC at the start of the test; default: SOC 1 at its highest counted
    /// charge.
    #[arg(long)]
    pub soc0: Option<f64>,
    /// Rests or a low-rate charge/discharge.
    #[arg(long, value_enum, default_value = "rests")]
    pub from: OcvSourceArg,
    /// The shortest rest that gives an OCV point (s).
    #[arg(long, default_value_t = 600.0)]
    pub min_rest: f64,
    /// |I| at or below this is rest (A); default 1 % of the largest |I|.
    #[arg(long)]
    pub rest_current: Option<f64>,
    /// The table: `soc,ocv_v`, increasing in both.
    #[arg(long)]
    pub out: PathBuf,
    /// The extraction as JSON: table, capacity, rests or branches.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// An SVG plot of the table over the points it was read from.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

pub(super) fn run(a: OcvArgs) -> Result<()> {
    let record = cycler::RecordOptions {
        capacity_ah: a.capacity_ah,
        ..(&a.record).into()
    };
    let rec = cycler::read_record(&a.input, &record)?;
    super::print_record(&a.input, &rec.report);
    let o = OcvExtractionOptions {
        from: a.from.into(),
        capacity_ah: a.capacity_ah,
        soc0: a.soc0,
        min_rest_s: a.min_rest,
        rest_current_a: a.rest_current,
    };
    let x = ocv_extraction::extract_ocv(&a.input, &rec.record, &o)?;
    ocv_extraction::write_table(&a.out, &x)?;
    if let Some(p) = &a.json {
        // The extraction, and how the record was read (`record`, as in
        // the JSON of `identify battery`).
        let x = ocv_extraction::OcvExtraction {
            record: Some(rec.report.clone()),
            ..x.clone()
        };
        fracbms_host::io::write_json(p, &x)?;
    }
    if let Some(p) = &a.plot {
        ocv_extraction::plot(p, &x)?;
    }
    eprintln!("{}", x.summary(&a.out));
    Ok(())
}
