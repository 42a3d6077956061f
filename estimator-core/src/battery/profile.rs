//! Current profiles and an open-circuit-voltage curve for simulated test
//! data (host-sim's `simulate battery`, the tests, the QEMU replay).
//!
//! All profiles are deterministic functions of time; the current is
//! positive when charging and scaled by an amplitude `A` (the largest
//! `|I|`).

use crate::real::Real;

/// End times (s) of the segments of the pulse block.
const PULSE_ENDS: [f64; 30] = [
    2., 3., 6., 7., 12., 14., 22., 25., 26., 39., 41., 46., 47., 68., 71., 72., 80., 82., 112.,
    117., 121., 124., 126., 139., 140., 145., 153., 155., 156., 240.,
];
/// Levels (fractions of the amplitude) of the pulse block's segments.
const PULSE_LEVELS: [f64; 30] = [
    1., 0., -1., 0.5, -1., 1., 0., -0.5, 1., -1., 0., 1., -1., -0.5, 0., -1., 1., -0.5, 0., 1.,
    -1., 0.5, -1., 1., 0., -0.5, 1., -1., 0.5, 0.,
];

/// A test current profile.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Profile {
    /// A 240 s block of 30 pulses of both signs and levels `±A`, `±A/2`
    /// and rests, with widths from 1 s to 30 s (a multi-sine-like spread of
    /// time scales: the short ones separate `R_i` from `R_ct`, the long ones
    /// show the fractional tail) ending in an 84 s rest; no net charge.
    Pulse,
    /// The hybrid pulse power characterization block (after the USABC/DOE
    /// HPPC test), 120 s: discharge `−A` 10 s, rest 40 s, charge `+0.75·A`
    /// 10 s, rest 40 s, then a `−A/4` discharge of 20 s that moves the state
    /// of charge to the next step.
    Hppc,
    /// A drive-cycle-like current: a sum of incommensurate sinusoids
    /// (accelerations, cruising, regenerative braking up to `+0.6·A`) around
    /// a mean discharge of `−A/4`, clipped to `[−A, 0.6·A]`.
    Drive,
}

impl Profile {
    /// The current (A) at time `t` (s) for amplitude `amplitude` (A).
    pub fn current<T: Real>(&self, t: T, amplitude: T) -> T {
        let a = amplitude;
        match self {
            Profile::Pulse => {
                let s = modulo(t.to_f64(), 240.0);
                let k = PULSE_ENDS.iter().position(|&e| s < e).unwrap_or(0);
                a * T::lit(PULSE_LEVELS[k])
            }
            Profile::Hppc => {
                let s = modulo(t.to_f64(), 120.0);
                let f = match s {
                    s if s < 10.0 => -1.0,
                    s if s < 50.0 => 0.0,
                    s if s < 60.0 => 0.75,
                    s if s < 100.0 => 0.0,
                    _ => -0.25,
                };
                a * T::lit(f)
            }
            Profile::Drive => {
                let t = t.to_f64();
                let two_pi = core::f64::consts::TAU;
                let x = -0.25
                    + 0.45 * libm::sin(two_pi * t / 97.0)
                    + 0.30 * libm::sin(two_pi * t / 31.0 + 1.0)
                    + 0.20 * libm::sin(two_pi * t / 13.0 + 2.0)
                    + 0.10 * libm::sin(two_pi * t / 5.3 + 0.5);
                a * T::lit(x.clamp(-1.0, 0.6))
            }
        }
    }
}

/// `x mod p` in `[0, p)` without std.
fn modulo(x: f64, p: f64) -> f64 {
    let r = libm::fmod(x, p);
    if r < 0.0 {
        r + p
    } else {
        r
    }
}

/// Open-circuit voltage (V) of an NMC-like Li-ion cell at state of charge
/// `soc ∈ [0, 1]` (clamped): a smooth, monotone, realistically nonlinear
/// curve, 3.31 V at 0 % (with a steep knee below 10 %), 3.66 V at 40 %,
/// 4.04 V at 90 %, 4.16 V at 100 %.
pub fn ocv_nmc<T: Real>(soc: T) -> T {
    let z = soc.to_f64().clamp(0.0, 1.0);
    let v = 3.43 + 0.68 * z - 0.5 * z * z + 0.55 * z * z * z - 0.12 * libm::exp(-30.0 * z);
    T::lit(v)
}
