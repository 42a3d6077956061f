//! `simulate hammerstein` and `simulate battery`.

use crate::cli::{SimBatteryArgs, SimHammersteinArgs};
use crate::{io, presets, progress};
use anyhow::{bail, Context, Result};
use estimator_core::battery::profile::ocv_nmc;
use estimator_core::battery::simulate::simulate;
use estimator_core::battery::CellParameters;
use estimator_core::frac::GlWeights;
use estimator_core::model::Polynomial;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Longest memory of the simulators (samples).
pub const SIM_MEMORY: usize = 4096;

/// A simulated Hammerstein record.
pub struct HammersteinData {
    /// Input u(l) ~ N(0, 1).
    pub u: Vec<f64>,
    /// Output y(l).
    pub y: Vec<f64>,
}

/// Simulates eq. (4) for a preset: input N(0, 1), white noise N(0, σ²),
/// from rest, memory `memory`.
pub fn hammerstein_data(
    sys: &presets::Hammerstein,
    sigma: f64,
    len: usize,
    seed: u64,
    memory: usize,
) -> Result<HammersteinData> {
    if !(sigma.is_finite() && sigma >= 0.0) {
        bail!("--sigma {sigma}: must be finite and ≥ 0");
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n01 = Normal::new(0.0, 1.0).context("normal distribution")?;
    let u: Vec<f64> = (0..len).map(|_| n01.sample(&mut rng)).collect();
    let v: Vec<f64> = (0..len).map(|_| sigma * n01.sample(&mut rng)).collect();
    let (mut y, mut e) = (vec![0.0; len], vec![0.0; len]);
    let w = Box::new(GlWeights::<f64, SIM_MEMORY>::new(sys.alpha, 1.0, memory)?);
    sys.system()
        .simulate(&Polynomial, &w, &u, &v, &mut y, &mut e)?;
    if y.iter().any(|x| !x.is_finite()) {
        bail!("the simulated output diverged (the preset is unstable at this length)");
    }
    Ok(HammersteinData { u, y })
}

// Not inlined into `cli::run`: the estimators are built on the stack before
// boxing, and an inlined frame of every command would be probed (page
// faults over megabytes) even for the command that does not run.
#[inline(never)]
pub(crate) fn hammerstein(a: &SimHammersteinArgs) -> Result<()> {
    let sys = presets::hammerstein(&a.preset).context("unknown preset")?;
    if a.length == 0 {
        bail!("--length must be at least 1");
    }
    let memory = a.memory.unwrap_or(a.length.min(SIM_MEMORY));
    if memory == 0 || memory > SIM_MEMORY {
        bail!("--memory {memory}: must be in 1..={SIM_MEMORY}");
    }
    let d = hammerstein_data(&sys, a.sigma, a.length, a.seed, memory)?;
    io::write_csv(
        &a.out,
        &["u", "y"],
        d.u.iter()
            .zip(&d.y)
            .map(|(u, y)| [format!("{u:.12e}"), format!("{y:.12e}")]),
    )?;
    eprintln!("wrote {} rows to {}", a.length, a.out.display());
    Ok(())
}

/// A simulated battery record.
pub struct BatteryData {
    /// Current (A).
    pub current: Vec<f64>,
    /// Noise-free terminal voltage (V).
    pub clean: Vec<f64>,
    /// Measured terminal voltage (V).
    pub voltage: Vec<f64>,
    /// Open-circuit voltage (V).
    pub ocv: Vec<f64>,
}

/// Simulates a cell from rest with memory `min(len, SIM_MEMORY)`.
#[allow(clippy::too_many_arguments)]
pub fn battery_data(
    cell: &CellParameters<f64>,
    profile: estimator_core::battery::profile::Profile,
    amplitude: f64,
    sigma: f64,
    len: usize,
    seed: u64,
    h: f64,
    ocv_curve: Option<(f64, f64)>,
) -> Result<BatteryData> {
    if !(sigma.is_finite() && sigma >= 0.0) {
        bail!("--sigma {sigma}: must be finite and ≥ 0");
    }
    if !(h.is_finite() && h > 0.0) {
        bail!("--h {h}: must be finite and positive");
    }
    let current: Vec<f64> = (0..len)
        .map(|l| profile.current(l as f64 * h, amplitude))
        .collect();
    let ocv: Vec<f64> = match ocv_curve {
        None => vec![cell.u_oc; len],
        Some((soc0, cap_ah)) => {
            let mut soc = soc0;
            current
                .iter()
                .map(|&i| {
                    let v = ocv_nmc(soc);
                    soc += i * h / (cap_ah * 3600.0);
                    v
                })
                .collect()
        }
    };
    let memory = len.clamp(1, SIM_MEMORY);
    let mut w = Box::new(GlWeights::<f64, SIM_MEMORY>::new(cell.alpha, h, memory)?);
    let (mut up, mut clean) = (vec![0.0; len], vec![0.0; len]);
    let pb = progress::bar(len as u64, "simulating");
    // Simulate in one pass (the progress bar only marks start and end: the
    // recursion is one call).
    simulate(cell, &mut w, &current, |l| ocv[l], &mut up, &mut clean)?;
    pb.finish_and_clear();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let nd = Normal::new(0.0, 1.0).context("normal distribution")?;
    let voltage = clean
        .iter()
        .map(|v| v + sigma * nd.sample(&mut rng))
        .collect();
    Ok(BatteryData {
        current,
        clean,
        voltage,
        ocv,
    })
}

// Not inlined into `cli::run`: the estimators are built on the stack before
// boxing, and an inlined frame of every command would be probed (page
// faults over megabytes) even for the command that does not run.
#[inline(never)]
pub(crate) fn battery(a: &SimBatteryArgs) -> Result<()> {
    let preset = presets::battery(&a.preset).context("unknown preset")?;
    let profile = presets::profile(&a.profile).context("unknown profile")?;
    if a.length == 0 {
        bail!("--length must be at least 1");
    }
    let sigma = a.sigma.unwrap_or(preset.sigma);
    let curve = (a.ocv == "nmc").then_some((a.soc0, preset.capacity_ah));
    if !(0.0..=1.0).contains(&a.soc0) {
        bail!("--soc0 {}: must be in [0, 1]", a.soc0);
    }
    let t0 = std::time::Instant::now();
    let d = battery_data(
        &preset.cell,
        profile,
        preset.amplitude,
        sigma,
        a.length,
        a.seed,
        a.h,
        curve,
    )?;
    io::write_csv(
        &a.out,
        &["time_s", "current_a", "voltage_v"],
        d.current
            .iter()
            .zip(&d.voltage)
            .enumerate()
            .map(|(l, (i, v))| {
                [
                    format!("{}", l as f64 * a.h),
                    format!("{i}"),
                    format!("{v:.9}"),
                ]
            }),
    )?;
    eprintln!(
        "wrote {} rows to {} ({:.0} rows/s)",
        a.length,
        a.out.display(),
        a.length as f64 / t0.elapsed().as_secs_f64().max(1e-9)
    );
    Ok(())
}
