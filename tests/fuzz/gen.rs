//! Generators of arbitrary values shared by the targets.

use super::Rng;
use rand::Rng as _;

/// A value from the edges of `f64`: NaN, ±∞, ±0, the largest and smallest
/// normal numbers, subnormals (of `f64` and of `f32`), `1e30`, `1e308`,
/// `ε`, a log-uniform magnitude over the whole range, or an ordinary
/// number.
pub fn nasty(rng: &mut Rng) -> f64 {
    let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    match rng.random_range(0..18) {
        0 => f64::NAN,
        1 => f64::INFINITY,
        2 => f64::NEG_INFINITY,
        3 => 0.0,
        4 => -0.0,
        5 => sign * 1e30,
        6 => sign * f64::MAX,
        7 => sign * f64::MIN_POSITIVE,
        8 => sign * 5e-324,
        9 => sign * 1e-310 * rng.random::<f64>(),
        10 => sign * 1e-40,
        11 => sign * f64::EPSILON,
        12 => sign * 1e308,
        13 => sign * f64::from(f32::MAX) * (1.0 + rng.random::<f64>()),
        14 => sign * 10f64.powf(rng.random_range(-320.0..308.0)),
        15 => sign * f64::from(f32::MIN_POSITIVE) * rng.random::<f64>(),
        _ => rng.random_range(-1e3..1e3),
    }
}

/// `x`, or with probability `p` a [`nasty`] value.
pub fn or_nasty(rng: &mut Rng, p: f64, x: f64) -> f64 {
    if rng.random_bool(p) {
        nasty(rng)
    } else {
        x
    }
}

/// Log-uniform in `[lo, hi]` (both positive).
pub fn log_uniform(rng: &mut Rng, lo: f64, hi: f64) -> f64 {
    (rng.random_range(lo.ln()..=hi.ln())).exp()
}

/// A probability for a case: 0 most often, else small or large (so that
/// some cases are clean, some lightly and some heavily perturbed).
pub fn rate(rng: &mut Rng) -> f64 {
    match rng.random_range(0..6) {
        0 | 1 => 0.0,
        2 => 0.002,
        3 => 0.02,
        4 => 0.1,
        _ => 0.5,
    }
}

/// Pick one of `xs`.
pub fn pick<T: Copy>(rng: &mut Rng, xs: &[T]) -> T {
    xs[rng.random_range(0..xs.len())]
}

/// `nasty_or!(rng, p, x)`: [`or_nasty`] with `x` evaluated first (so that
/// `x` may draw from `rng` too).
macro_rules! nasty_or {
    ($rng:expr, $p:expr, $x:expr) => {{
        let x: f64 = $x;
        let p: f64 = $p;
        $crate::fuzz::gen::or_nasty($rng, p, x)
    }};
}
pub(crate) use nasty_or;
