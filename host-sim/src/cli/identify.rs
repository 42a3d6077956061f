//! `identify hammerstein|battery`: the flags, and what each prints.

use super::{AlgorithmArg, BatteryMethodArg, HammersteinMethodArg, ModelArg, RecordArgs};
use anyhow::{Context, Result};
use fracbms_host::identify::hammerstein::{self as hammerstein_fit, HammersteinOptions};
use fracbms_host::identify::many::{self, FileSummary, ManyOptions};
use fracbms_host::identify::record::{self as battery_fit, BatteryFitOptions};
use fracbms_host::map::MapOptions;
use fracbms_host::ocv::OcvOptions;
use fracbms_host::{io, plot};
use std::path::PathBuf;

/// `identify hammerstein`.
#[derive(clap::Args, Debug)]
pub struct IdHammersteinArgs {
    /// Input CSV with columns u,y.
    #[arg(long)]
    pub input: PathBuf,
    #[command(flatten)]
    pub fit: HammersteinFlags,
    /// Write the estimates as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// How `identify hammerstein` fits (every flag but the files):
/// [`HammersteinOptions`].
#[derive(clap::Args, Debug, Clone)]
pub struct HammersteinFlags {
    /// Method: `paper` (the algorithm alone) or `refined` (the
    /// prediction-error refinement started from it: maximum likelihood,
    /// the most accurate; docs/identification.md).
    #[arg(long, value_enum, default_value = "refined")]
    pub method: HammersteinMethodArg,
    /// Algorithm of the paper stage (the whole method with `--method paper`,
    /// the start of the refinement with `refined`).
    #[arg(long, value_enum, default_value = "op")]
    pub algorithm: AlgorithmArg,
    /// Order of A(z).
    #[arg(long, default_value_t = 2)]
    pub na: usize,
    /// Order of B(z).
    #[arg(long, default_value_t = 3)]
    pub nb: usize,
    /// Order of the noise polynomial C(z).
    #[arg(long, default_value_t = 2)]
    pub nc: usize,
    /// Basis of the nonlinearity: poly:m means f_j(u) = u^j, j = 1..m.
    #[arg(long, default_value = "poly:2")]
    pub basis: String,
    /// Memory of the fractional differences (default: all rows, at most 4096).
    #[arg(long)]
    pub memory: Option<usize>,
    /// Iterations of the paper stage.
    #[arg(long, default_value_t = 100)]
    pub iterations: u32,
    /// Most iterations of the refinement (its global search over the order
    /// included).
    #[arg(long, default_value_t = 400)]
    pub refine_iterations: u32,
    /// Initial order α̂₀.
    #[arg(long, default_value_t = 0.45)]
    pub alpha0: f64,
}

/// `identify battery`.
#[derive(clap::Args, Debug)]
pub struct IdBatteryArgs {
    /// Input: a record `time_s,current_a,voltage_v`, or a cycler export
    /// (columns recognised or named with --columns). Or many: a directory
    /// (its .csv, .txt, .tsv and .mat files) or a glob pattern in quotes
    /// (`'logs/*/cell-*.csv'`), fitted on all cores, one line per file;
    /// then --json and --map-out name directories (`NAME.json`,
    /// `NAME-map.csv` per file).
    #[arg(long)]
    pub input: PathBuf,
    #[command(flatten)]
    pub record: RecordArgs,
    /// Write one row per file (`file,status,error_kind,error,samples,
    /// period_s,method,model,r_i,r_ct,q,alpha,u_oc,…,r_i_lo,r_i_hi,…,
    /// identifiable,…,map_levels,…,fit_s`); a file that fails is a row
    /// with `status` `error` and the others go on (exit status 1 if any
    /// failed).
    #[arg(long)]
    pub summary_out: Option<PathBuf>,
    /// Files fitted at once with a directory or pattern (default: every
    /// core).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Method (default: refined, the most accurate).
    #[arg(long, value_enum, default_value = "refined")]
    pub method: BatteryMethodArg,
    /// Algorithm of the paper stage (the battery regression has no b·γ
    /// products to separate, so kt runs the same iteration as op).
    #[arg(long, value_enum, default_value = "op")]
    pub algorithm: AlgorithmArg,
    /// Memory M of the paper regression (default 256); the refinement uses
    /// the whole record (full memory).
    #[arg(long)]
    pub memory: Option<usize>,
    /// Most iterations of the paper regression: 2S-OP-GI's under the
    /// paper method and as the refinement's start on fewer than 4 096
    /// rows; from 4 096 rows the start's solves θ by least squares at each
    /// order (it stops when converged, in about a dozen), on the record's
    /// most excited 8 192 rows when it is longer.
    #[arg(long, default_value_t = 50)]
    pub iterations: u32,
    /// Memory of the refinement (default: the whole record; give the
    /// firmware's memory to compare with it).
    #[arg(long)]
    pub refine_memory: Option<usize>,
    /// Fit an OCV slope dU_oc/dq (the state of charge drifting through the
    /// record; without --ocv).
    #[arg(long)]
    pub ocv_slope: bool,
    /// Cell model: `linear` (R_i + R_ct‖CPE), `butler-volmer` (plus
    /// a·asinh(I/i₀), started from the linear fit) or `auto` (the nonlinear
    /// model only when the data identify it: current beyond i₀, a's 95 %
    /// interval away from 0, those of R_i, R_ct, Q and i₀ within a factor
    /// e, and a lower BIC; the JSON's `model_choice` says why).
    #[arg(long, value_enum, default_value = "auto")]
    pub model: ModelArg,
    #[command(flatten)]
    pub cell: OcvArgs,
    /// Lowest plausible voltage (V; default 1.5, as online): rows below are
    /// rejected, substituted and counted in the JSON's `rejected`, as are
    /// non-finite rows and voltage spikes against the fitted model
    /// (beyond max(8 robust σ, 50 mV); docs/trust.md).
    #[arg(long)]
    pub voltage_min: Option<f64>,
    /// Highest plausible voltage (V; default 5).
    #[arg(long)]
    pub voltage_max: Option<f64>,
    /// Largest plausible |current| (A; default 500).
    #[arg(long)]
    pub current_limit: Option<f64>,
    /// Write the estimates as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write `time_s,voltage_v,model_v,current_a,fitted[,ocv_v]`: the
    /// identified model's free-run simulation from the current alone (OCV,
    /// ΔU and all) beside the data; `fitted` is 1 where the fit counted the
    /// sample's voltage, and with `--ocv` `ocv_v` is the OCV it took away.
    #[arg(long)]
    pub fit_out: Option<PathBuf>,
    /// Write Figures 8–11 for this file (SVG) into this directory.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Also a parameter map: the record split at its SOC levels (the rests
    /// between pulse groups, or --soc-bins), each level fitted with its
    /// intervals and model choice; one row per level:
    /// `temperature_c,soc,r_i,r_ct,q,alpha,bv_a_v,bv_i0_a,ocv_offset_v,rmse_v,identifiable,…`.
    /// Needs --ocv and --capacity-ah. With it, --fit-out is the map
    /// model's free run (parameters by SOC) over the whole record.
    #[arg(long)]
    pub map_out: Option<PathBuf>,
    /// An SVG of the map: R_i, R_ct, Q, α against SOC with 95 % intervals.
    #[arg(long, requires = "map_out")]
    pub map_plot: Option<PathBuf>,
    /// Split the record into this many equal bins of the counted SOC (a
    /// record without rests) instead of at its rests.
    #[arg(long, requires = "map_out")]
    pub soc_bins: Option<usize>,
    /// The shortest rest (s) that separates two SOC levels (parts that
    /// follow one another within 0.03 of SOC stay one level: the pulses of
    /// one HPPC level, docs/maps.md).
    #[arg(long, default_value_t = 600.0)]
    pub min_rest: f64,
    /// Also write each level's record as fitted into this folder
    /// (`level-NN.csv`, `ocv.csv`, `levels.json`), for an independent fit
    /// (`bench/reference_map.py`).
    #[arg(long, requires = "map_out")]
    pub levels_out: Option<PathBuf>,
    /// The record's temperature (°C) for the map's `temperature_c`
    /// (default: the temperature column's mean over the record to 0.1 °C,
    /// or empty).
    #[arg(long)]
    pub temperature_c: Option<f64>,
    /// How the map is fitted: `joint` (every knot together over the whole
    /// record, smooth in SOC; it predicts unseen records better,
    /// docs/maps.md) or `levels` (each level on its own stretch).
    #[arg(long, value_enum, default_value_t = MapMethodArg::Joint, requires = "map_out")]
    pub map_method: MapMethodArg,
    /// The joint map's knots: SOCs, comma-separated (default: the levels'
    /// SOCs, those within 0.03 of one another one knot at their mean).
    #[arg(long, value_delimiter = ',', requires = "map_out")]
    pub soc_knots: Option<Vec<f64>>,
    /// The joint map's smoothing penalty λ (V²) on the second differences
    /// across knots, or `auto`: chosen by leaving levels out (default).
    #[arg(long, default_value = "auto", requires = "map_out")]
    pub map_smoothing: String,
    /// Which parameters vary with SOC in the joint map, comma-separated of
    /// `r_i,r_ct,tau,alpha,du` (the others shared), or `auto`: chosen by
    /// leaving levels out (default).
    #[arg(long, default_value = "auto", requires = "map_out")]
    pub map_vary: String,
}

/// `--map-method`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapMethodArg {
    /// Each level fitted on its own stretch.
    Levels,
    /// Every knot together over the whole record.
    Joint,
}

impl IdBatteryArgs {
    /// The map options of these flags.
    fn map_options(&self) -> Result<MapOptions> {
        let smoothing = match self.map_smoothing.trim() {
            "auto" => None,
            x => Some(
                x.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite() && *v >= 0.0)
                    .ok_or_else(|| {
                        anyhow::anyhow!(
                            "--map-smoothing {x}: give a non-negative number (V²) or auto"
                        )
                    })?,
            ),
        };
        let vary = match self.map_vary.trim() {
            "auto" => None,
            x => {
                let names = fracbms_host::identify::map::joint::PARAMETERS;
                let mut set = [false; 5];
                for part in x.split(',').map(str::trim).filter(|p| !p.is_empty()) {
                    let i = names.iter().position(|n| *n == part).ok_or_else(|| {
                        anyhow::anyhow!(
                            "--map-vary: `{part}` is not one of {} (or auto)",
                            names.join(",")
                        )
                    })?;
                    set[i] = true;
                }
                Some(set)
            }
        };
        if let Some(k) = &self.soc_knots {
            if k.is_empty()
                || k.iter()
                    .any(|z| !(z.is_finite() && (0.0..=1.0).contains(z)))
            {
                anyhow::bail!("--soc-knots: give SOCs in [0, 1], comma-separated");
            }
        }
        Ok(MapOptions {
            min_rest_s: self.min_rest,
            soc_bins: self.soc_bins,
            temperature_c: self.temperature_c,
            method: match self.map_method {
                MapMethodArg::Levels => fracbms_host::map::MapMethod::Levels,
                MapMethodArg::Joint => fracbms_host::map::MapMethod::Joint,
            },
            knots: self.soc_knots.clone(),
            smoothing,
            vary,
            ..MapOptions::default()
        })
    }
}

/// The cell's open-circuit voltage curve and state of charge.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct OcvArgs {
    /// OCV table CSV with header `soc,ocv_v` (soc in [0, 1], both columns
    /// increasing): the model fits U_t − OCV(SOC) with the SOC counted from
    /// the current, and its U_oc becomes a small offset ΔU.
    #[arg(long)]
    pub ocv: Option<PathBuf>,
    /// Capacity (A·h) for coulomb counting (needed with --ocv).
    #[arg(long)]
    pub capacity_ah: Option<f64>,
    /// State of charge at the start of the record, before the first row's
    /// charge (default: read from the first rows' voltage through the
    /// inverse OCV; the record must then start at rest).
    #[arg(long)]
    pub soc0: Option<f64>,
}

impl From<&HammersteinFlags> for HammersteinOptions {
    fn from(a: &HammersteinFlags) -> Self {
        Self {
            method: a.method.into(),
            algorithm: a.algorithm.into(),
            na: a.na,
            nb: a.nb,
            nc: a.nc,
            basis: a.basis.clone(),
            memory: a.memory,
            iterations: a.iterations,
            refine_iterations: a.refine_iterations,
            alpha0: a.alpha0,
        }
    }
}

impl From<&OcvArgs> for OcvOptions {
    fn from(a: &OcvArgs) -> Self {
        Self {
            ocv: a.ocv.clone(),
            capacity_ah: a.capacity_ah,
            soc0: a.soc0,
        }
    }
}

// Not inlined into `cli::run`: the estimators are built on the stack before
// boxing, and an inlined frame of every command would be probed (page
// faults over megabytes) even for the command that does not run.
#[inline(never)]
pub(super) fn hammerstein(a: IdHammersteinArgs) -> Result<()> {
    let j = hammerstein_fit::hammerstein_json(&a.input, &(&a.fit).into())?;
    println!(
        "alpha = {:.5}, iterations = {}, converged = {}, cost = {:.6e}",
        j.alpha, j.iterations, j.converged, j.cost
    );
    if let Some(p) = &a.json {
        io::write_json(p, &j)?;
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}

#[inline(never)]
pub(super) fn battery(a: IdBatteryArgs) -> Result<()> {
    let _ = a.algorithm; // op and kt coincide for the battery regression
    let o = BatteryFitOptions {
        method: a.method.into(),
        memory: a.memory,
        iterations: Some(a.iterations),
        refine_memory: a.refine_memory,
        ocv_slope: a.ocv_slope,
        model: a.model.into(),
        ocv: (&a.cell).into(),
        voltage_min: a.voltage_min,
        voltage_max: a.voltage_max,
        current_limit: a.current_limit,
        record: (&a.record).into(),
    };
    if a.summary_out.is_some() || many::names_many(&a.input) {
        return battery_many(&a, &o);
    }
    let (f, map) = match &a.map_out {
        Some(_) => {
            let m = a.map_options()?;
            let (f, map) = fracbms_host::identify::map::battery_file(&a.input, &o, &m, true)?;
            (f, Some(map))
        }
        None => (battery_fit::battery_file(&a.input, &o, true)?, None),
    };
    super::print_record(&a.input, &f.report);
    let (rec, r, sc) = (&f.record, &f.result, &f.screened);
    if let Some(w) = sc.warning(&a.input) {
        eprintln!("{w}");
    }
    let j = &r.json;
    if let Some(note) = &j.start_note {
        eprintln!("note: {}: {note}", a.input.display());
    }
    println!(
        "{}: R_i = {:.6} Ω, R_ct = {:.6} Ω, Q = {:.3}, alpha = {:.4}, U_oc = {:.5} V, rmse = {:.3e} V ({} iterations, converged: {}{})",
        j.method,
        j.r_i,
        j.r_ct,
        j.q,
        j.alpha,
        j.u_oc,
        j.rmse_v,
        j.iterations,
        j.converged,
        match (j.stop, j.held_at_bounds.as_deref()) {
            (Some("iteration_limit"), _) => "; stopped at the iteration limit".to_owned(),
            (_, Some(b)) if !b.is_empty() => format!(
                "; {}; a boundary optimum in {}",
                j.stop_reason.unwrap_or("converged").replace('_', " "),
                b.join(", ")
            ),
            _ => String::new(),
        }
    );
    match &j.confidence {
        Some(c) => println!(
            "95 % intervals: R_i {} Ω, R_ct {} Ω, Q {}, alpha {} (residual lag-1 correlation {:.2})",
            interval(c.r_i, 1.0, 6),
            interval(c.r_ct, 1.0, 6),
            interval(c.q, 1.0, 4),
            interval(c.alpha, 1.0, 4),
            j.residual_lag1_correlation
        ),
        None => println!("95 % intervals: none (the information matrix is singular)"),
    }
    if let Some(why) = &j.identifiable_reason {
        eprintln!(
            "warning: {}: the fit is not identifiable: {why}",
            a.input.display()
        );
    }
    if let (Some(x), Some(i0)) = (j.bv_a_v, j.bv_i0_a) {
        // With its 95 % intervals where the fit has them.
        let term = j
            .confidence
            .as_ref()
            .and_then(|c| c.bv_a.zip(c.bv_i0))
            .map(|(ca, ci)| {
                format!(
                    " (95 % intervals: a {} mV, i0 {} A)",
                    interval(ca, 1e3, 3),
                    interval(ci, 1.0, 4)
                )
            })
            .unwrap_or_default();
        println!("Butler–Volmer: a = {:.3} mV, i0 = {i0:.4} A{term}", x * 1e3);
        if j.confidence.as_ref().and_then(|c| c.term_separated()) == Some(false) {
            eprintln!(
                "note: {}: the Butler–Volmer term's a and i0 are not each known within a factor 2 (they trade along a/i0, its slope at rest, {:.3} mΩ): the model holds within the record's currents, not beyond them",
                a.input.display(),
                x / i0 * 1e3
            );
        }
    }
    if let Some(c) = &j.model_choice {
        println!("model: {} ({})", c.chosen, c.reason);
    }
    if let (Some(d), Some(z0), Some(z1)) = (j.ocv_offset_v, j.soc0, j.soc_end) {
        println!(
            "OCV curve: offset ΔU = {:.2} mV, SOC {z0:.4} → {z1:.4}",
            d * 1e3
        );
    }
    if let (Some(m), Some(p)) = (&map, &a.map_out) {
        let rows = &m.map.rows;
        // Both over the same samples: the log's measured ones.
        let single = m.json(rec, &r.model_voltage).single_rmse_v;
        // Without an identifiable row the map has no model to run.
        let map_rmse = if m.rmse_v.is_finite() {
            format!("map {:.2} mV", m.rmse_v * 1e3)
        } else {
            "map none (no identifiable level)".to_owned()
        };
        println!(
            "map: {} levels, SOC {:.3}–{:.3} ({} not identifiable); whole-record RMSE over the measured samples: {map_rmse}, single fit {:.2} mV",
            rows.len(),
            rows[0].soc,
            rows[rows.len() - 1].soc,
            rows.iter().filter(|r| !r.identifiable).count(),
            single * 1e3
        );
        for why in &m.skipped {
            eprintln!("warning: {}: {why}", a.input.display());
        }
        for w in &m.warnings {
            eprintln!("warning: {}: {w}", a.input.display());
        }
        if let Some(best) = m
            .joint
            .iter()
            .filter(|c| c.left_out_rmse_v.is_finite())
            .min_by(|x, y| x.left_out_rmse_v.total_cmp(&y.left_out_rmse_v))
        {
            let names = fracbms_host::identify::map::joint::PARAMETERS;
            let vary: Vec<&str> = (0..5).filter(|&i| best.vary[i]).map(|i| names[i]).collect();
            println!(
                "joint map: smoothing {:e} V², varying {} (of {} candidates, by leaving levels out: {:.2} mV predicted, {:.2} mV fitted)",
                best.smoothing,
                vary.join(","),
                m.joint.len(),
                best.left_out_rmse_v * 1e3,
                best.rmse_v * 1e3
            );
        }
        m.map.write_csv(p)?;
        eprintln!("wrote {}", p.display());
        if let Some(dir) = &a.levels_out {
            let spec = fracbms_host::ocv::OcvSpec::from_options(&o.ocv)?
                .ok_or_else(|| fracbms_host::err!(Options, "--levels-out needs --ocv"))?;
            fracbms_host::identify::map::write_levels(
                dir,
                m,
                &spec,
                &clap::ValueEnum::to_possible_value(&a.model)
                    .map_or_else(String::new, |v| v.get_name().to_string()),
            )?;
            eprintln!("wrote {} levels into {}", m.parts.len(), dir.display());
        }
        if let Some(svg) = &a.map_plot {
            fracbms_host::map::plot(svg, &m.map)?;
            eprintln!("wrote {}", svg.display());
        }
    }
    if let Some(p) = &a.fit_out {
        // With a map, the map model's free run.
        let model_v = map.as_ref().map_or(&r.model_voltage, |m| &m.model_v);
        battery_fit::write_fit_csv(p, rec, model_v, |k| sc.counted(k), r.ocv_v.as_deref())?;
        eprintln!("wrote {}", p.display());
    }
    if let Some(p) = &a.json {
        io::write_json(p, j)?;
        eprintln!("wrote {}", p.display());
    }
    if let Some(dir) = &a.plot {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create", dir.display()))?;
        plot::battery_figures(dir, rec, &r.model_voltage, &r.json.history)?;
        eprintln!("wrote Figures 8–11 to {}", dir.display());
    }
    Ok(())
}

/// `identify battery` on many files (a directory, a pattern, or any input
/// with --summary-out): every file on the pool, a line per file as it
/// ends, the summary CSV, per-file JSON and maps into directories.
fn battery_many(a: &IdBatteryArgs, o: &BatteryFitOptions) -> Result<()> {
    for (flag, given) in [
        ("--fit-out", a.fit_out.is_some()),
        ("--plot", a.plot.is_some()),
        ("--map-plot", a.map_plot.is_some()),
        ("--levels-out", a.levels_out.is_some()),
    ] {
        if given && many::names_many(&a.input) {
            anyhow::bail!("{flag} is for one record; with a directory or pattern give --summary-out, --json DIR or --map-out DIR");
        }
    }
    let m = ManyOptions {
        map: match &a.map_out {
            Some(_) => Some(a.map_options()?),
            None => None,
        },
        jobs: a.jobs,
    };
    many::check_options(o, &m)?;
    let files = many::expand_inputs(&a.input)?;
    let one = files.len() == 1 && !many::names_many(&a.input);
    // One record keeps --json and --map-out as files; many write into
    // directories.
    let json_out = match (&a.json, one) {
        (Some(p), true) => Some(vec![p.clone()]),
        (Some(d), false) => Some(out_dir(d, &files, ".json")?),
        (None, _) => None,
    };
    let map_out = match (&a.map_out, one) {
        (Some(p), true) => Some(vec![p.clone()]),
        (Some(d), false) => Some(out_dir(d, &files, "-map.csv")?),
        (None, _) => None,
    };
    let total = files.len();
    let ended = std::sync::atomic::AtomicUsize::new(0);
    let rows = many::identify_many_with(
        &files,
        o,
        &m,
        |k, path, fit, map| {
            if let Some(note) = &fit.result.json.start_note {
                eprintln!("note: {}: {note}", path.display());
            }
            if let Some(p) = json_out.as_ref().map(|v| &v[k]) {
                io::write_json(p, &fit.result.json)?;
            }
            if let (Some(p), Some(map)) = (map_out.as_ref().map(|v| &v[k]), map) {
                map.map.write_csv(p)?;
            }
            Ok(())
        },
        |row| {
            let n = ended.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            println!("[{n}/{total}] {}", summary_line(row));
        },
    );
    let failed = rows.iter().filter(|r| r.status != "ok").count();
    if let Some(p) = &a.summary_out {
        many::write_summary_csv(p, &rows)?;
        eprintln!("wrote {}", p.display());
    }
    println!(
        "{} files: {} fitted, {failed} failed",
        rows.len(),
        rows.len() - failed
    );
    if failed > 0 {
        anyhow::bail!(
            "{failed} of {} files failed (their rows say why)",
            rows.len()
        );
    }
    Ok(())
}

fn out_dir(dir: &std::path::Path, files: &[PathBuf], suffix: &str) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    Ok(many::outputs_in(dir, files, suffix)?)
}

/// A file's line: its fit in brief, or its error.
fn summary_line(r: &FileSummary) -> String {
    match (&r.error, r.r_i, r.r_ct, r.q, r.alpha, r.rmse_v) {
        // The messages name their file already.
        (Some(e), ..) if e.starts_with(&r.file) => format!("error: {e}"),
        (Some(e), ..) => format!("{}: error: {e}", r.file),
        (None, Some(ri), Some(rct), Some(q), Some(alpha), Some(rmse)) => format!(
            "{}: R_i = {ri:.6} Ω, R_ct = {rct:.6} Ω, Q = {q:.3}, alpha = {alpha:.4}, rmse = {rmse:.3e} V, {}{} ({:.1} s)",
            r.file,
            r.model.unwrap_or("linear"),
            match r.identifiable {
                Some(false) => ", not identifiable",
                _ => "",
            },
            r.fit_s
        ),
        _ => format!("{}: fitted", r.file),
    }
}

/// An interval `[lo, hi]` scaled by `scale`, each end with `decimals`
/// places, or in exponent form from 10⁶ on (an interval of a parameter
/// the data do not pin can reach 10²⁰⁰).
fn interval([lo, hi]: [f64; 2], scale: f64, decimals: usize) -> String {
    let end = |x: f64| {
        let x = x * scale;
        if x.is_finite() && x.abs() >= 1e6 {
            format!("{x:.3e}")
        } else {
            format!("{x:.decimals$}")
        }
    };
    format!("[{}, {}]", end(lo), end(hi))
}
