//! `online battery|pack`: the flags, and the lines each prints.

use super::identify::OcvArgs;
use super::{BatteryMethodArg, ModelArg, PrecisionArg, RecordArgs, SocArg, StartArg};
use anyhow::Result;
use fracbms_host::online::{self as online_track, life, OnlineBatteryOptions};
use fracbms_host::pack::{self, OnlinePack};
use std::path::PathBuf;

/// `online battery`.
#[derive(clap::Args, Debug)]
pub struct OnlineBatteryArgs {
    /// Input: a record `time_s,current_a,voltage_v`, or a cycler export
    /// (columns recognised or named with --columns). Or a cell's life: a
    /// directory (its .csv/.txt/.tsv/.mat files) or a quoted pattern
    /// (`'logs/*.csv'`): every log run through one estimator in the order
    /// they were taken (--start-times, else the date and time of each
    /// log's first row where every log has a column of them, else by
    /// name), its state carried
    /// from each to the next as --state-out/--state-in would carry it;
    /// --out is then a directory of tracks (`NAME-track.csv`), and
    /// --life-out writes one row per log (docs/life.md).
    #[arg(long)]
    pub input: PathBuf,
    #[command(flatten)]
    pub record: RecordArgs,
    /// Window length L (one of 64, 128, 256, 512, 1024).
    #[arg(long, default_value_t = 256)]
    pub window: usize,
    /// Memory M (default L/4).
    #[arg(long)]
    pub memory: Option<usize>,
    /// Iterations per sample.
    #[arg(long, default_value_t = 1)]
    pub iterations_per_sample: u16,
    /// Method.
    #[arg(long, value_enum, default_value = "refined")]
    pub method: BatteryMethodArg,
    /// Arithmetic of the estimator: `f64`, or `f32` as the firmware runs it.
    #[arg(long, value_enum, default_value = "f64")]
    pub precision: PrecisionArg,
    /// Where the model starts in the window: `from-data` (the polarization
    /// of the first M − 1 samples from the data: a cell that is never at
    /// rest) or `at-rest` (from rest until the window first slides, as the
    /// firmware starts after power-up).
    #[arg(long, value_enum, default_value = "from-data")]
    pub start: StartArg,
    /// A prior on R_i, R_ct, Q and α: the JSON of `identify battery` (e.g.
    /// of a characterization record of the same cell), or a parameter map
    /// (`MAP.csv`, the `--map-out` of `identify battery`; needs --ocv and
    /// --capacity-ah): the prior is then the map's cell at the counted SOC
    /// and at the temperature column's value, if any (levels that are not
    /// identifiable are left out, with a warning). The window's fit
    /// is then maximum a posteriori: the data where they are informative,
    /// the prior where a window is too short to tell (the refinement starts
    /// at the prior, without the paper method's start-up).
    #[arg(long)]
    pub prior: Option<PathBuf>,
    /// The prior's spread on R_i, R_ct and Q: a factor at one sigma.
    #[arg(long, default_value_t = 2.0)]
    pub prior_factor: f64,
    /// The prior's spread on α at one sigma.
    #[arg(long, default_value_t = 0.1)]
    pub prior_alpha_sigma: f64,
    /// The residual level (mV) at which the window's data are weighed
    /// against the prior (not the noise: model error correlated over the
    /// window makes it worth fewer independent samples; see
    /// docs/real-cells.md).
    #[arg(long, default_value_t = 100.0)]
    pub prior_noise_mv: f64,
    /// Cell model: `linear`, `butler-volmer` (plus a·asinh(I/i₀); a linear
    /// start is given the term with i₀ at the window's RMS current) or
    /// `auto` (the model of the `--prior` fit; linear without a prior).
    #[arg(long, value_enum, default_value = "auto")]
    pub model: ModelArg,
    /// Add the Grünwald–Letnikov taps beyond the memory: those at lags ≥ M
    /// inside the window and the past before it, carried by 8 exponential
    /// modes per cell (the short-memory correction, docs/pack.md; linear
    /// model, memory ≥ 64).
    #[arg(long)]
    pub tail: bool,
    #[command(flatten)]
    pub cell: OcvArgs,
    #[command(flatten)]
    pub states: StateArgs,
    #[command(flatten)]
    pub snapshot: SnapshotArgs,
    /// The record's time 0 (ISO 8601, `2008-04-02T15:25:41`, UTC unless a
    /// zone is given): the snapshot's clock is this plus the record's time,
    /// so a snapshot carried from one log to the next (--state-out,
    /// --state-in) is aged by the time between them. With a life
    /// (--input DIR): each log's comes from --start-times or its own
    /// date and time column.
    #[arg(long, value_name = "ISO8601")]
    pub start_time: Option<String>,
    /// A life's start times: a CSV with columns `file,start_time` (the
    /// log's name or its path as listed; ISO 8601). The logs run in this
    /// order, each aged from the one before by the time between them.
    /// Without it: the date and time of each log's first row (Arbin's
    /// `Date_Time`, a MAT-file's `TimeStamp`, Maccor's `DPt Time`, …)
    /// where every log has one, else file name order.
    #[arg(long, value_name = "FILE.csv")]
    pub start_times: Option<PathBuf>,
    /// A life's rows (--input DIR|PATTERN): `file,start_time,samples,
    /// discharged_ah,charged_ah,r_i,r_i_status,r_ct,alpha,capacity_ah,
    /// capacity_status,soh_c,soh_r,error,capacity_source`, one per log:
    /// its counted charges; the median R_i, R_ct and α its windows
    /// identified (empty where none was, the status then its last); the
    /// capacity: the counted discharge of a capacity check
    /// (capacity_source `full_discharge`: from rest within 0.05 V of
    /// --voltage-max, or the table's highest, to within 0.05 V of
    /// --voltage-min, or its lowest), else the SOC observer's at the log's
    /// end (`observer`, with --ocv); soh_c and soh_r over the first log's;
    /// error: why a log could not be run (the life goes on across it).
    #[arg(long, value_name = "FILE.csv")]
    pub life_out: Option<PathBuf>,
    /// A life's figure (SVG): the counted discharge and the capacity, and
    /// R_i and R_ct, against the log's place in the life.
    #[arg(long, value_name = "FILE.svg")]
    pub life_plot: Option<PathBuf>,
    /// Output CSV `time_s,r_i,r_ct,q,alpha,u_oc,status,soc,ocv_offset_v,
    /// bv_a_v,bv_i0_a,predicted_v,r_i_status,r_ct_status,q_status,
    /// alpha_status,step_resistance_ohm,window_r_i,window_r_ct,window_q,
    /// window_alpha,soc_coulomb,current_bias_a,capacity_ah,
    /// capacity_sigma_ah,soc_sigma,soc_ocv_weight,soh_r,capacity_status`, then the state-of-power columns (r_i…alpha:
    /// the published values, docs/online-publication.md; soc: see --soc; soh_r: the
    /// published R_i over the prior's or map's; u_oc: the open-circuit voltage now,
    /// OCV(SOC) + ΔU with --ocv; soc and ocv_offset_v empty without --ocv;
    /// bv_a_v and bv_i0_a empty for the linear model; predicted_v: the
    /// one-step prediction of this row's voltage from the estimate before
    /// it, empty before the first estimate). The status after each sample:
    /// filling (the window is not full enough yet), starting (2S-OP-GI runs,
    /// no physical estimate yet), tracking (updated from this window),
    /// not_excited (the current barely varies: held), held (an iteration
    /// failed: held), unphysical (the window's estimate has a non-positive
    /// resistance or Q, or α outside (0, 1]: held), at_bound (α at the
    /// search's bound, or R_ct so small that its branch swing R_ct·σ_I is
    /// below the fit's RMSE: held), slow_relaxation (the branch relaxes slower
    /// than the window can see, τ^(1/α) beyond the fitted window: held),
    /// ocv_implausible (U_oc outside the plausible voltage range, or |ΔU|
    /// above 0.15 V with --ocv: held). "Held" keeps the last good estimate.
    #[arg(long, verbatim_doc_comment)]
    pub out: PathBuf,
}

/// What is published, the state of charge and the state of power: the
/// flags `online battery` and `online pack` share.
#[derive(clap::Args, Debug)]
pub struct StateArgs {
    /// State of power: the horizons (s) of the columns
    /// `sop_discharge_a_{H}s`, `sop_charge_a_{H}s` (the largest constant
    /// current magnitudes whose predicted voltage stays within the limits
    /// for H seconds) and `pulse_v_{H}s` (the voltage at the end of a pulse
    /// of --pulse-current-a for H seconds), from the model after each
    /// sample, with the parameters `sop_basis` names (the window's, the
    /// map prior's, held ones, or the last identified, widened); empty
    /// until the cell has each parameter from one of these
    /// (docs/state-of-power.md).
    #[arg(long, value_delimiter = ',', default_value = "10,30")]
    pub horizons: Vec<f64>,
    /// The memory (s) of the slow part carried across windows: the
    /// published R_ct, Q and α are the mean of the values the windows
    /// identified, each weighed by its information (1/σ² of its log, of α)
    /// and by exp(−age/S), started again where the SOC has moved more than
    /// 0.15 from the last (docs/online-publication.md). Default 0: each
    /// window's own values. The window_* columns and the state of power
    /// are the window's fit either way.
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    pub slow_memory_s: Option<f64>,
    /// The slow part's memory in state of charge (with --ocv): an earlier
    /// value weighs exp(−|ΔSOC|/F) less besides (default 0.02).
    #[arg(long, value_name = "F", allow_hyphen_values = true)]
    pub slow_memory_soc: Option<f64>,
    /// The lowest voltage a state-of-power pulse may reach (V; default:
    /// the OCV table's lowest; without a table and this, no state of power).
    #[arg(long)]
    pub voltage_min: Option<f64>,
    /// The highest (V; default: the OCV table's highest).
    #[arg(long)]
    pub voltage_max: Option<f64>,
    /// The largest state-of-power current magnitude (A; default 500 A, the
    /// estimator's plausible current).
    #[arg(long)]
    pub current_limit: Option<f64>,
    /// The current of the `pulse_v_{H}s` columns (A, + charging; default: a
    /// 1C discharge, −capacity).
    #[arg(long, allow_hyphen_values = true)]
    pub pulse_current_a: Option<f64>,
    /// How long (s) the state of power may be predicted from the last fit
    /// without a new one, the polarization carried through a rest by the
    /// model (default: as far back as the window reaches; beyond it the
    /// model's relaxation was not fitted, docs/state-of-power.md). A rest of
    /// --soc-rest-s (with --ocv) is predicted from rest whatever this says:
    /// the cell relaxed, at the rested voltage.
    #[arg(long)]
    pub sop_carry_s: Option<f64>,
    /// How many standard deviations of the predicted pulse voltage the
    /// state-of-power currents keep inside --voltage-min and --voltage-max
    /// at each horizon's end (default 2: the limit at 97.7 % one-sided; 0
    /// derates nothing). The standard deviation, from the spread of the
    /// parameters predicted with and the fit's RMSE, is the column
    /// `sop_uncertainty_v` (the longest horizon's) and
    /// `sop_uncertainty_v_{H}s` (docs/state-of-power.md).
    #[arg(long)]
    pub sop_confidence: Option<f64>,
    /// Publish the model's own pulse voltage: without this, `pulse_v_{H}s`
    /// is corrected by the last pulse of the same current (within a
    /// tenth): the predicted drop scaled by that pulse's measured over
    /// predicted drop, the column `pulse_ratio_{H}s`
    /// (docs/state-of-power.md).
    #[arg(long)]
    pub no_pulse_correction: bool,
    /// The `soc` column (with --ocv): `observer` (the default; coulomb
    /// counting corrected at each rest of --soc-rest-s by the OCV table,
    /// with the current sensor's bias and the capacity estimated, columns
    /// current_bias_a, capacity_ah, capacity_sigma_ah, soc_sigma,
    /// soc_ocv_weight) or
    /// `coulomb` (counting from the start SOC, as soc_coulomb).
    #[arg(long, value_enum, default_value = "observer")]
    pub soc: SocArg,
    /// The shortest rest (s) whose voltage corrects the SOC (default 600).
    #[arg(long)]
    pub soc_rest_s: Option<f64>,
    /// The prior spread (A) of the current sensor's bias the observer
    /// estimates (default C/50; 0: a calibrated sensor, no bias state).
    #[arg(long)]
    pub soc_bias_sigma_a: Option<f64>,
    /// The spread (A) of the load a rest carries: how closely a rest's
    /// mean measured current reads the sensor's bias (default C/1000;
    /// larger for a pack with a quiescent draw it does not know).
    #[arg(long)]
    pub soc_rest_load_sigma_a: Option<f64>,
    /// The spread (V) of a rested voltage as the OCV: the table's own
    /// error in volts (its test, hysteresis) and the polarization a rest
    /// still holds (default 0.005). On a flat curve it sets how little a
    /// rest weighs; smaller only for a table known that well.
    #[arg(long)]
    pub soc_voltage_sigma_v: Option<f64>,
    /// The capacity (column capacity_ah) is published as identified only
    /// once two relaxed rests linked by the count (no gap of unknown
    /// charge or SOC set between them) have read SOCs at least this far
    /// apart through the OCV table, and its spread is within 2 % (default 0.3; 0: no span
    /// asked). The capacity is the charge counted between the rests over
    /// the SOC they differ by, weighed with every rest by the SOC
    /// observer (docs/soc-observer.md).
    #[arg(long)]
    pub capacity_min_span: Option<f64>,
}

impl StateArgs {
    /// The state-of-power options.
    fn power(&self) -> Result<online_track::power::PowerOptions> {
        let mut p = online_track::power::PowerOptions::default().with_horizons(&self.horizons)?;
        p.voltage_min = self.voltage_min;
        p.voltage_max = self.voltage_max;
        p.current_limit = self.current_limit;
        p.pulse_current_a = self.pulse_current_a;
        p.carry_s = self.sop_carry_s;
        p.confidence = self.sop_confidence;
        p.pulse_correction = !self.no_pulse_correction;
        Ok(p)
    }

    /// The state-of-charge options.
    fn soc(&self) -> online_track::soc::SocOptions {
        online_track::soc::SocOptions {
            mode: self.soc.into(),
            rest_s: self.soc_rest_s,
            bias_sigma_a: self.soc_bias_sigma_a,
            rest_load_sigma_a: self.soc_rest_load_sigma_a,
            voltage_sigma_v: self.soc_voltage_sigma_v,
            capacity_min_span: self.capacity_min_span,
        }
    }
}

/// What survives a reset: the flags `online battery` and `online pack`
/// share (docs/persistence.md).
#[derive(clap::Args, Debug)]
pub struct SnapshotArgs {
    /// Start from this snapshot (a `--state-out` file, the firmware's and
    /// the C ABI's bytes): each cell's parameters, SOC, current bias and
    /// capacity as they were (published with status `restored` until a
    /// window identifies them), the SOC read again from the OCV table when
    /// the first rested voltage contradicts it. A snapshot that is corrupt,
    /// stale, from another layout version, cell count or settings is
    /// rejected with a warning and the estimator starts clean. Adds the
    /// column `restoration` (`restored`, `soc_reread`, `clean`).
    #[arg(long, value_name = "FILE")]
    pub state_in: Option<PathBuf>,
    /// Save the snapshot after the last sample to this file (binary,
    /// docs/persistence.md's layout).
    #[arg(long, value_name = "FILE")]
    pub state_out: Option<PathBuf>,
}

/// `online pack`.
#[derive(clap::Args, Debug)]
pub struct OnlinePackArgs {
    /// Input CSV with columns time_s,current_a,cell_1_v,…,cell_N_v.
    #[arg(long)]
    pub input: PathBuf,
    /// Window length L (one of 64, 128, 256, 512, 1024).
    #[arg(long, default_value_t = 256)]
    pub window: usize,
    /// Memory M (default L/4).
    #[arg(long)]
    pub memory: Option<usize>,
    /// Iterations per cell update.
    #[arg(long, default_value_t = 1)]
    pub iterations_per_sample: u16,
    /// Cell updates per sample period, round robin (default: every cell
    /// every period).
    #[arg(long)]
    pub updates_per_period: Option<u16>,
    /// Flag a cell whose R_i or R_ct is above the pack's median by more
    /// than this fraction.
    #[arg(long, default_value_t = 0.3)]
    pub flag_ratio: f64,
    /// Arithmetic of the estimator: `f64`, or `f32` as the firmware runs it.
    #[arg(long, value_enum, default_value = "f64")]
    pub precision: PrecisionArg,
    /// Where the model starts in the window (as `online battery`).
    #[arg(long, value_enum, default_value = "from-data")]
    pub start: StartArg,
    /// Add the Grünwald–Letnikov taps beyond the memory: those at lags ≥ M
    /// inside the window and the past before it, carried by 8 exponential
    /// modes per cell (the short-memory correction, docs/pack.md; linear
    /// model, memory ≥ 64).
    #[arg(long)]
    pub tail: bool,
    /// The cells' OCV table and capacity (one chemistry): each cell's SOC
    /// and state of power. --soc0 sets every cell's start SOC; without it
    /// each cell's is read from its own first rested voltages (as the
    /// firmware does).
    #[command(flatten)]
    pub cell: OcvArgs,
    #[command(flatten)]
    pub states: StateArgs,
    #[command(flatten)]
    pub snapshot: SnapshotArgs,
    /// Output CSV in long format, one row per cell and sample:
    /// `time_s,cell,r_i,r_ct,q,alpha,u_oc,status,rejected,flagged` (cell
    /// 1-based; the estimate empty before the cell's first; status as in
    /// `online battery`; rejected 1 when this sample of the cell was
    /// rejected; flagged 1 when the cell stands out from the median),
    /// `r_i_status…alpha_status`, `window_r_i…window_alpha` (the window's
    /// fit), then as `online battery`'s: `soc`, `soc_coulomb`,
    /// `current_bias_a`, `capacity_ah`, `capacity_sigma_ah`, `soc_sigma`,
    /// `soc_ocv_weight`, `capacity_status` (empty without --ocv), the
    /// cell's `sop_discharge_a_{H}s,sop_charge_a_{H}s,pulse_v_{H}s` and the
    /// string's `pack_sop_discharge_a_{H}s,pack_sop_charge_a_{H}s,
    /// pack_pulse_v_{H}s` (the weakest cell's currents, the sum of the
    /// cells' pulse voltages; the same on every cell's row of a sample).
    #[arg(long)]
    pub out: PathBuf,
}

#[inline(never)]
pub(super) fn battery(a: OnlineBatteryArgs) -> Result<()> {
    let o = OnlineBatteryOptions {
        window: a.window,
        memory: a.memory,
        iterations_per_sample: a.iterations_per_sample,
        method: a.method.into(),
        precision: a.precision.into(),
        start: a.start.into(),
        prior: a.prior.clone(),
        prior_factor: a.prior_factor,
        prior_alpha_sigma: a.prior_alpha_sigma,
        prior_noise_mv: a.prior_noise_mv,
        model: a.model.into(),
        tail: a.tail,
        ocv: (&a.cell).into(),
        record: (&a.record).into(),
        power: a.states.power()?,
        soc: a.states.soc(),
        slow_memory_s: a.states.slow_memory_s,
        slow_memory_soc: a.states.slow_memory_soc,
        state_in: a.snapshot.state_in.clone(),
        state_out: a.snapshot.state_out.clone(),
        start_time_s: match &a.start_time {
            Some(t) => Some(life::parse_start_time(t).ok_or_else(|| {
                anyhow::anyhow!("--start-time {t}: not an ISO 8601 time (YYYY-MM-DDTHH:MM:SS)")
            })?),
            None => None,
        },
    };
    if fracbms_host::identify::many::names_many(&a.input) {
        return battery_life(&a, &o);
    }
    if let Err(e) = std::fs::metadata(&a.input) {
        anyhow::bail!("{}: {e}", a.input.display());
    }
    for (flag, given) in [
        ("--life-out", a.life_out.is_some()),
        ("--start-times", a.start_times.is_some()),
        ("--life-plot", a.life_plot.is_some()),
    ] {
        if given {
            anyhow::bail!(
                "{flag}: a life needs --input DIR or a pattern, not one file ({})",
                a.input.display()
            );
        }
    }
    let r = online_track::battery_file(&a.input, &a.out, &o)?;
    super::print_record(&a.input, &r.record);
    if let Some(line) = a
        .snapshot
        .state_in
        .as_ref()
        .and_then(|p| r.state_in.describe(p))
    {
        eprintln!("{line}");
    }
    if let (Some((line, left_out)), Some(p)) = (&r.prior_map, &a.prior) {
        eprintln!("{}: {line}", p.display());
        for why in left_out {
            eprintln!("warning: {}: {why}", p.display());
        }
    }
    let s = r.summary;
    eprintln!(
        "wrote {} ({} samples, {} rejected: {} not finite, {} out of range, {} spikes; {:.0} samples/s, model {})",
        a.out.display(),
        s.samples,
        s.rejected,
        s.non_finite,
        s.out_of_range,
        s.spikes,
        s.samples as f64 / r.seconds.max(1e-9),
        r.model.as_str()
    );
    for line in s.published.lines() {
        eprintln!("{line}");
    }
    let work = s.work;
    if work.iterations > 0 {
        // The refinement's cost drivers: each simulation and each
        // sensitivity pass is O(L·M).
        eprintln!(
            "refinement: {} iterations, {} window simulations ({} trial steps), {} sensitivity passes",
            work.iterations, work.simulations, work.trials, work.linearizations
        );
    }
    Ok(())
}

/// `online battery --input DIR|PATTERN`: a cell's life.
fn battery_life(a: &OnlineBatteryArgs, o: &OnlineBatteryOptions) -> Result<()> {
    if a.start_time.is_some() {
        anyhow::bail!("--start-time: a life takes each log's from --start-times");
    }
    // What is written after the whole life is run: its folders checked
    // before the first log.
    for (flag, path) in [
        ("--life-out", &a.life_out),
        ("--life-plot", &a.life_plot),
        ("--state-out", &a.snapshot.state_out),
    ] {
        let Some(dir) = path
            .as_deref()
            .and_then(std::path::Path::parent)
            .filter(|d| !d.as_os_str().is_empty())
        else {
            continue;
        };
        // (`--out`, the tracks' folder, is made by the run.)
        if !dir.is_dir() && !dir.starts_with(&a.out) {
            anyhow::bail!(
                "{flag} {}: no such directory {}",
                path.as_deref().unwrap_or(dir).display(),
                dir.display()
            );
        }
    }
    let t0 = std::time::Instant::now();
    let snapshot = match &a.snapshot.state_in {
        Some(p) => Some(online_track::state::read_state(p)?),
        None => None,
    };
    let l = life::life(
        &a.input,
        &a.out,
        o,
        a.start_times.as_deref(),
        snapshot,
        |line| eprintln!("{line}"),
    )?;
    if let (Some(p), Some(bytes)) = (&a.snapshot.state_out, &l.snapshot) {
        online_track::state::write_state(p, bytes)?;
    }
    if let Some(p) = &a.life_out {
        life::write_life_csv(p, &l.rows)?;
    }
    if let Some(p) = &a.life_plot {
        life::plot_life(p, &l.rows)?;
    }
    let failed = l.rows.iter().filter(|r| r.error.is_some()).count();
    let with_r_i = l.rows.iter().filter(|r| r.r_i.is_some()).count();
    eprintln!(
        "life: {} logs ({failed} could not be run), tracks in {}{}; R_i identified in {with_r_i} of them; {:.1} s",
        l.rows.len(),
        a.out.display(),
        a.life_out
            .as_ref()
            .map_or(String::new(), |p| format!(", rows in {}", p.display())),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

#[inline(never)]
pub(super) fn pack(a: OnlinePackArgs) -> Result<()> {
    let t0 = std::time::Instant::now();
    let o = OnlinePack {
        window: a.window,
        memory: a.memory,
        iterations_per_sample: a.iterations_per_sample,
        updates_per_period: a.updates_per_period,
        flag_ratio: a.flag_ratio,
        precision: a.precision.into(),
        start: a.start.into(),
        tail: a.tail,
        ocv: (&a.cell).into(),
        power: a.states.power()?,
        soc: a.states.soc(),
        slow_memory_s: a.states.slow_memory_s,
        slow_memory_soc: a.states.slow_memory_soc,
        state_in: a.snapshot.state_in.clone(),
        state_out: a.snapshot.state_out.clone(),
    };
    let (summary, cells) = pack::online_file(&a.input, &a.out, &o)?;
    let secs = t0.elapsed().as_secs_f64();
    if let (Some(p), Some(st)) = (&a.snapshot.state_in, summary.state_in) {
        if let Some(line) = st.describe(p) {
            eprintln!("{line}");
        }
    }
    eprintln!(
        "wrote {} ({} samples of {} cells, {} rejected, {} iterations, {:.0} samples/s)",
        a.out.display(),
        summary.samples,
        cells,
        summary.rejected.iter().map(|&x| u64::from(x)).sum::<u64>(),
        summary.iterations,
        summary.samples as f64 / secs.max(1e-9)
    );
    for line in summary.published.lines() {
        eprintln!("{line}");
    }
    Ok(())
}
