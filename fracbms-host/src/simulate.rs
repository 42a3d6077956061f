//! `simulate hammerstein` and `simulate battery`.

use crate::error::Result;
use crate::{bail, err};
use crate::{io, presets};
use estimator_core::battery::profile::ocv_nmc;
use estimator_core::battery::simulate::simulate;
use estimator_core::battery::CellParameters;
use estimator_core::frac::GlWeights;
use estimator_core::model::Polynomial;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Longest memory of the simulators (samples).
pub const SIM_MEMORY: usize = 4096;

/// The most samples a simulation writes (`--length`): ten million, a
/// record of 116 days at 1 s. A simulated record is held whole before it
/// is written; `--length 4294967295` asked for more memory than a host
/// has and aborted the process.
pub const MAX_SIMULATED_SAMPLES: usize = 10_000_000;

/// Checks a simulation's `--length`: from `least` to
/// [`MAX_SIMULATED_SAMPLES`] samples.
///
/// # Errors
/// [`Options`](crate::error::ErrorKind::Options), naming the flag.
pub(crate) fn check_length(length: usize, least: usize) -> Result<()> {
    if !(least..=MAX_SIMULATED_SAMPLES).contains(&length) {
        bail!(
            Options,
            "--length {length}: must be in {least}..={MAX_SIMULATED_SAMPLES}"
        );
    }
    Ok(())
}

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
        bail!(Options, "--sigma {sigma}: must be finite and ≥ 0");
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n01 = Normal::new(0.0, 1.0).map_err(|e| err!(Internal, "normal distribution: {e}"))?;
    let u: Vec<f64> = (0..len).map(|_| n01.sample(&mut rng)).collect();
    let v: Vec<f64> = (0..len).map(|_| sigma * n01.sample(&mut rng)).collect();
    let (mut y, mut e) = (vec![0.0; len], vec![0.0; len]);
    let w = Box::new(GlWeights::<f64, SIM_MEMORY>::new(sys.alpha, 1.0, memory)?);
    sys.system()
        .simulate(&Polynomial, &w, &u, &v, &mut y, &mut e)?;
    if y.iter().any(|x| !x.is_finite()) {
        bail!(
            Data,
            "the simulated output diverged (the preset is unstable at this length)"
        );
    }
    Ok(HammersteinData { u, y })
}

/// How `simulate hammerstein` makes a record: every flag of the command.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimulateHammerstein {
    /// `paper-op`, `paper-kt`, `paper-kt-stable` or `identifiable`
    /// ([`presets::hammerstein`]).
    pub preset: String,
    /// Standard deviation of the white noise v(l).
    pub sigma: f64,
    /// Number of samples.
    pub length: usize,
    /// Random seed (input and noise).
    pub seed: u64,
    /// Memory of the fractional differences (default: the whole record, at
    /// most [`SIM_MEMORY`]).
    pub memory: Option<usize>,
    /// Output CSV (`u,y`).
    pub out: PathBuf,
}

/// `simulate hammerstein`: eq. (4) for a preset, written to `a.out`.
pub fn hammerstein_file(a: &SimulateHammerstein) -> Result<()> {
    let sys = presets::hammerstein(&a.preset).ok_or_else(|| err!(Options, "unknown preset"))?;
    check_length(a.length, 1)?;
    let memory = a.memory.unwrap_or(a.length.min(SIM_MEMORY));
    if memory == 0 || memory > SIM_MEMORY {
        bail!(Options, "--memory {memory}: must be in 1..={SIM_MEMORY}");
    }
    let d = hammerstein_data(&sys, a.sigma, a.length, a.seed, memory)?;
    io::write_csv(
        &a.out,
        &["u", "y"],
        d.u.iter()
            .zip(&d.y)
            .map(|(u, y)| [format!("{u:.12e}"), format!("{y:.12e}")]),
    )
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
    /// State of charge after each sample (constant without a curve).
    pub soc: Vec<f64>,
}

/// The open-circuit voltage a simulated cell follows.
#[derive(Clone, Copy, Debug)]
pub enum OcvCurve<'a> {
    /// The preset's constant `U_oc`.
    Constant,
    /// The NMC-like curve [`ocv_nmc`] from `soc0` for a cell of `capacity_ah`.
    Nmc {
        /// SOC before the first sample.
        soc0: f64,
        /// Capacity (A·h).
        capacity_ah: f64,
    },
    /// A table (`--ocv FILE.csv`).
    Table {
        /// The curve.
        table: &'a io::HostOcvTable,
        /// SOC before the first sample.
        soc0: f64,
        /// Capacity (A·h).
        capacity_ah: f64,
    },
}

/// A test current: a profile at an amplitude, plus a constant.
#[derive(Clone, Copy, Debug)]
pub struct Current {
    /// The profile.
    pub profile: estimator_core::battery::profile::Profile,
    /// Its amplitude (A).
    pub amplitude: f64,
    /// A constant added to it (A; negative: a mean discharge).
    pub mean: f64,
}

impl Current {
    /// The profile at `amplitude`, nothing added.
    pub fn new(profile: estimator_core::battery::profile::Profile, amplitude: f64) -> Self {
        Self {
            profile,
            amplitude,
            mean: 0.0,
        }
    }
}

/// Simulates a cell from rest with memory `min(len, SIM_MEMORY)`.
pub fn battery_data(
    cell: &CellParameters<f64>,
    drive: Current,
    sigma: f64,
    len: usize,
    seed: u64,
    h: f64,
    ocv_curve: OcvCurve<'_>,
) -> Result<BatteryData> {
    if !(sigma.is_finite() && sigma >= 0.0) {
        bail!(Options, "--sigma {sigma}: must be finite and ≥ 0");
    }
    let current: Vec<f64> = (0..len)
        .map(|l| drive.profile.current(l as f64 * h, drive.amplitude) + drive.mean)
        .collect();
    let CellVoltage { clean, ocv, soc } = battery_voltage(cell, &current, h, ocv_curve)?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let nd = Normal::new(0.0, 1.0).map_err(|e| err!(Internal, "normal distribution: {e}"))?;
    let voltage = clean
        .iter()
        .map(|v| v + sigma * nd.sample(&mut rng))
        .collect();
    Ok(BatteryData {
        current,
        clean,
        voltage,
        ocv,
        soc,
    })
}

/// The noise-free voltages of a cell over a current record.
pub struct CellVoltage {
    /// Terminal voltage (V).
    pub clean: Vec<f64>,
    /// Open-circuit voltage (V).
    pub ocv: Vec<f64>,
    /// State of charge after each sample (NaN without a curve).
    pub soc: Vec<f64>,
}

/// Simulates `cell` from rest over `current` (A, positive when charging;
/// sample period `h`) with memory `min(len, SIM_MEMORY)`: the terminal
/// voltage `simulate battery` writes before its noise is added.
pub fn battery_voltage(
    cell: &CellParameters<f64>,
    current: &[f64],
    h: f64,
    ocv_curve: OcvCurve<'_>,
) -> Result<CellVoltage> {
    if !(h.is_finite() && h > 0.0) {
        bail!(Options, "--h {h}: must be finite and positive");
    }
    if !cell.is_physical() {
        bail!(
            Data,
            "the cell is not physical (a resistance, Q, i₀ not positive, or a < 0)"
        );
    }
    let len = current.len();
    // SOC after each sample's charge (the voltage is read at the end of
    // the sample's interval): SOC(l) = soc0 + h·Σ_{k≤l} I(k)/(3600·C).
    let counted = |soc0: f64, cap_ah: f64| -> Vec<f64> {
        let mut soc = soc0;
        current
            .iter()
            .map(|&i| {
                soc += i * h / (cap_ah * 3600.0);
                soc
            })
            .collect()
    };
    let (soc, ocv): (Vec<f64>, Vec<f64>) = match ocv_curve {
        OcvCurve::Constant => (vec![f64::NAN; len], vec![cell.u_oc; len]),
        OcvCurve::Nmc { soc0, capacity_ah } => {
            let soc = counted(soc0, capacity_ah);
            let ocv = soc.iter().map(|&z| ocv_nmc(z)).collect();
            (soc, ocv)
        }
        OcvCurve::Table {
            table,
            soc0,
            capacity_ah,
        } => {
            let soc = counted(soc0, capacity_ah);
            let ocv = soc.iter().map(|&z| table.ocv(z)).collect();
            (soc, ocv)
        }
    };
    let memory = len.clamp(1, SIM_MEMORY);
    let mut w = Box::new(GlWeights::<f64, SIM_MEMORY>::new(cell.alpha, h, memory)?);
    let (mut up, mut clean) = (vec![0.0; len], vec![0.0; len]);
    simulate(cell, &mut w, current, |l| ocv[l], &mut up, &mut clean)?;
    Ok(CellVoltage { clean, ocv, soc })
}

/// How `simulate battery` makes a record: every flag of the command.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimulateBattery {
    /// `paper` (§6.2, ±150 A) or `cell` (18650-like, ±6 A).
    pub preset: String,
    /// Current profile: `pulse`, `hppc` or `drive`.
    pub profile: String,
    /// Voltage noise σ (V); default: the preset's.
    pub sigma: Option<f64>,
    /// Number of samples.
    pub length: usize,
    /// Random seed of the noise.
    pub seed: u64,
    /// Sample period (s).
    pub h: f64,
    /// Open-circuit voltage: `constant`, `nmc`, or an OCV table file.
    pub ocv: String,
    /// State of charge before the first sample.
    pub soc0: f64,
    /// Capacity (A·h; default: the preset's).
    pub capacity_ah: Option<f64>,
    /// Current amplitude of the profile (A; default: the preset's).
    pub amplitude: Option<f64>,
    /// A constant current added to the profile (A).
    pub mean_current: f64,
    /// Butler–Volmer coefficient a (V); 0: the linear model.
    pub bv_a: f64,
    /// Butler–Volmer exchange current i₀ (A; needed with `bv_a`).
    pub bv_i0: Option<f64>,
    /// Output CSV (`time_s,current_a,voltage_v,soc`).
    pub out: PathBuf,
}

/// Checks `--soc0` and `--capacity-ah` of a simulation (`simulate
/// battery|pack`); returns the capacity (A·h), the preset's when not given.
pub(crate) fn state_of_charge_options(
    soc0: f64,
    capacity_ah: Option<f64>,
    preset_ah: f64,
) -> Result<f64> {
    if !(0.0..=1.0).contains(&soc0) {
        bail!(Options, "--soc0 {soc0}: must be in [0, 1]");
    }
    let capacity_ah = capacity_ah.unwrap_or(preset_ah);
    if !(capacity_ah.is_finite() && capacity_ah > 0.0) {
        bail!(
            Options,
            "--capacity-ah {capacity_ah}: must be finite and positive"
        );
    }
    Ok(capacity_ah)
}

/// `simulate battery`: a cell of a preset over a profile, with noise,
/// written to `a.out`.
pub fn battery_file(a: &SimulateBattery) -> Result<()> {
    let preset = presets::battery(&a.preset).ok_or_else(|| err!(Options, "unknown preset"))?;
    let profile = presets::profile(&a.profile).ok_or_else(|| err!(Options, "unknown profile"))?;
    check_length(a.length, 1)?;
    let sigma = a.sigma.unwrap_or(preset.sigma);
    let capacity_ah = state_of_charge_options(a.soc0, a.capacity_ah, preset.capacity_ah)?;
    let table;
    let curve = match a.ocv.as_str() {
        "constant" => OcvCurve::Constant,
        "nmc" => OcvCurve::Nmc {
            soc0: a.soc0,
            capacity_ah,
        },
        file => {
            table = io::read_ocv(std::path::Path::new(file))?;
            OcvCurve::Table {
                table: &table,
                soc0: a.soc0,
                capacity_ah,
            }
        }
    };
    let amplitude = a.amplitude.unwrap_or(preset.amplitude);
    if !(amplitude.is_finite() && amplitude >= 0.0) {
        bail!(Options, "--amplitude {amplitude}: must be finite and ≥ 0");
    }
    if !a.mean_current.is_finite() {
        bail!(Options, "--mean-current {}: must be finite", a.mean_current);
    }
    let cell = match (a.bv_a, a.bv_i0) {
        (x, _) if !(x.is_finite() && x >= 0.0) => {
            bail!(Options, "--bv-a {x}: must be finite and ≥ 0 (V)")
        }
        (x, None) if x > 0.0 => bail!(Options, "--bv-a needs --bv-i0 (the exchange current, A)"),
        (_, Some(i0)) if !(i0.is_finite() && i0 > 0.0) => {
            bail!(Options, "--bv-i0 {i0}: must be finite and positive (A)")
        }
        (x, i0) => CellParameters {
            bv_a: x,
            bv_i0: i0.unwrap_or(preset.cell.bv_i0),
            ..preset.cell
        },
    };
    let d = battery_data(
        &cell,
        Current {
            profile,
            amplitude,
            mean: a.mean_current,
        },
        sigma,
        a.length,
        a.seed,
        a.h,
        curve,
    )?;
    // Without a curve the SOC column is still counted, for the record.
    let soc = match curve {
        OcvCurve::Constant => {
            let mut z = a.soc0;
            d.current
                .iter()
                .map(|&i| {
                    z += i * a.h / (capacity_ah * 3600.0);
                    z
                })
                .collect()
        }
        _ => d.soc.clone(),
    };
    io::write_csv(
        &a.out,
        &["time_s", "current_a", "voltage_v", "soc"],
        d.current
            .iter()
            .zip(&d.voltage)
            .zip(&soc)
            .enumerate()
            .map(|(l, ((i, v), z))| {
                [
                    format!("{}", l as f64 * a.h),
                    format!("{i}"),
                    format!("{v:.9}"),
                    format!("{z:.9}"),
                ]
            }),
    )
}
