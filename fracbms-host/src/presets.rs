//! The systems and cells host-sim simulates.

use estimator_core::battery::profile::Profile;
use estimator_core::battery::CellParameters;
use estimator_core::model::HammersteinSystem;

/// Coefficients of a Hammerstein system (owned).
#[derive(Clone, Debug)]
pub struct Hammerstein {
    /// A(z) without the leading 1.
    pub a: Vec<f64>,
    /// B(z).
    pub b: Vec<f64>,
    /// C(z) without the leading 1 (the noise model).
    pub c: Vec<f64>,
    /// γ of the static nonlinearity `Σ γ_j u^j`.
    pub gamma: Vec<f64>,
    /// Fractional order α.
    pub alpha: f64,
}

impl Hammerstein {
    /// The borrowed form the core's simulator takes.
    pub fn system(&self) -> HammersteinSystem<'_, f64> {
        HammersteinSystem {
            a: &self.a,
            b: &self.b,
            c: &self.c,
            gamma: &self.gamma,
            alpha: self.alpha,
        }
    }
}

/// Hammerstein presets: `paper-op` (Example 1, Tables 3–4), `paper-kt`
/// (Tables 5–6 as printed, whose noise polynomial C is unstable under
/// eq. (4)), `paper-kt-stable` (C with both signs flipped, the variant our
/// reproduction uses), `identifiable` (a well-excited system of the same
/// orders, docs/identification.md: the setting round trips are checked on).
pub fn hammerstein(name: &str) -> Option<Hammerstein> {
    Some(match name {
        "paper-op" => Hammerstein {
            a: vec![-0.038, -0.014],
            b: vec![0.18, -0.175, -0.39],
            c: vec![-0.008, 0.02],
            gamma: vec![0.0165, 0.024],
            alpha: 0.5,
        },
        "paper-kt" => Hammerstein {
            a: vec![-0.021, -0.007],
            b: vec![1.0, -0.008, 0.023],
            c: vec![0.35, -0.61],
            gamma: vec![-1.7, -0.04],
            alpha: 0.3,
        },
        "paper-kt-stable" => Hammerstein {
            c: vec![-0.35, 0.61],
            ..hammerstein("paper-kt")?
        },
        "identifiable" => Hammerstein {
            a: vec![-0.5, 0.2],
            b: vec![1.0, 0.5, -0.3],
            c: vec![0.3, -0.2],
            gamma: vec![1.0, 0.5],
            alpha: 0.6,
        },
        _ => return None,
    })
}

/// A battery preset: the cell, the current amplitude (A), the default
/// noise σ (V).
#[derive(Clone, Copy, Debug)]
pub struct BatteryPreset {
    /// The cell.
    pub cell: CellParameters<f64>,
    /// Largest |I| of the profiles (A).
    pub amplitude: f64,
    /// Default measurement noise σ (V).
    pub sigma: f64,
    /// Capacity (A·h), for the state of charge.
    pub capacity_ah: f64,
}

/// `paper` (§6.2: 1 mΩ, 2 mΩ, Q 320, α 0.7, 4 V, ±150 A, σ 0.1 V) or
/// `cell` (18650-like: 20 mΩ, 15 mΩ, τ 8 s^α, α 0.75, 3.7 V, ±6 A, σ 1 mV).
pub fn battery(name: &str) -> Option<BatteryPreset> {
    Some(match name {
        "paper" => BatteryPreset {
            cell: CellParameters::paper(),
            amplitude: 150.0,
            sigma: 0.1,
            capacity_ah: 100.0,
        },
        "cell" => BatteryPreset {
            cell: CellParameters::cell_18650(),
            amplitude: 6.0,
            sigma: 0.001,
            capacity_ah: 2.5,
        },
        _ => return None,
    })
}

/// `pulse`, `hppc` or `drive`.
pub fn profile(name: &str) -> Option<Profile> {
    Some(match name {
        "pulse" => Profile::Pulse,
        "hppc" => Profile::Hppc,
        "drive" => Profile::Drive,
        _ => return None,
    })
}
