//! `reproduce`: the flags.

use super::ReproducePartArg;
use anyhow::Result;
use fracbms_host::reproduce::{self as reproduction, Reproduce};
use std::path::PathBuf;

/// `reproduce`.
#[derive(clap::Args, Debug)]
pub struct ReproduceArgs {
    /// Output directory (report.md and SVG figures).
    #[arg(long)]
    pub out: PathBuf,
    /// Seeds per table (the paper's tables: 10).
    #[arg(long, default_value_t = 10)]
    pub seeds: u64,
    /// Which part: `all`, `example1` (Tables 3–6, Figures 2–5, about 5 min
    /// on 2 cores) or `battery` (Figure 6, Table 7, Figures 7–11, seconds).
    #[arg(long, value_enum, default_value = "all")]
    pub part: ReproducePartArg,
}

/// `reproduce`: writes the report and prints where.
#[inline(never)]
pub(super) fn run(a: ReproduceArgs) -> Result<()> {
    let report = reproduction::run(&Reproduce {
        out: a.out,
        seeds: a.seeds,
        part: a.part.into(),
    })?;
    eprintln!("wrote {}", report.display());
    Ok(())
}
