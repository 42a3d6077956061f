//! The starts of `identify battery`'s whole-record refinement that come
//! from the data alone: the stretch the paper's regression runs on
//! ([`most_excited`], [`START_REGRESSION_ROWS`]) and the rough starts
//! ([`rough_starts`]). It must not run a fit (that is [`super::battery`]'s
//! and [`super::refine`]'s).

use estimator_core::battery::CellParameters;

/// The most rows the paper's regression is run on when it starts the
/// output-error refinement: a longer record's regression runs on its most
/// excited stretch of this length ([`most_excited`]). The regression costs
/// the rows times its memory in each of its iterations: on a 50 000-row
/// record `identify battery` took 0.73 s with it on every row and 0.43 s
/// with it on this many (docs/performance.md).
pub const START_REGRESSION_ROWS: usize = 8192;

/// From this many rows the regression that starts the refinement solves
/// θ by least squares at each order (`iterate_projected`, to its minimum in
/// about a dozen iterations); on fewer it runs 2S-OP-GI's `--iterations`.
/// Its 50 iterations were half of the command on an 8 000-row record, and
/// cost little on the short records of a map's levels. There the paper's
/// estimate stays the start: the projected one, though a better fit on
/// three LG M50 pulses, moved the LG M50 10 °C joint map's prediction of
/// its 2C discharge from 60.8 to 64.4 mV (and the map over (SOC, T) from
/// 0.970× to 1.010× the single fit's; docs/research.md).
pub const PROJECTED_START_ROWS: usize = 4096;

/// The projected regression that starts the refinement stops when an
/// iteration moves θ (relative) plus α by less than this, where the
/// paper's method goes on to 10⁻⁷: the refinement takes the start from
/// there. On the made 8 000-row record it stops after 7 iterations
/// instead of 12, the fit the same to every digit the JSON prints.
pub const PROJECTED_START_TOLERANCE: f64 = 1e-4;

/// The stretch of `len` consecutive samples (the whole record when it is
/// shorter) whose current varies the most (its sum of squared deviations
/// from the stretch's mean), among those with at most a tenth of their
/// voltages unobserved (NaN) when there are any such; the first of equals.
pub fn most_excited(current: &[f64], voltage: &[f64], len: usize) -> core::ops::Range<usize> {
    let n = current.len().min(voltage.len());
    if len == 0 || n <= len {
        return 0..n;
    }
    let finite = |x: f64| if x.is_finite() { x } else { 0.0 };
    // Running sums over the stretch [a, a + len).
    let (mut s1, mut s2, mut gaps) = (0.0, 0.0, 0usize);
    for k in 0..len {
        let i = finite(current[k]);
        s1 += i;
        s2 += i * i;
        gaps += usize::from(voltage[k].is_nan());
    }
    let spread = |s1: f64, s2: f64| s2 - s1 * s1 / len as f64;
    let observed = |gaps: usize| gaps * 10 <= len;
    let mut best = (observed(gaps), spread(s1, s2), 0);
    for a in 1..=n - len {
        let (out, inn) = (finite(current[a - 1]), finite(current[a + len - 1]));
        s1 += inn - out;
        s2 += inn * inn - out * out;
        gaps = gaps + usize::from(voltage[a + len - 1].is_nan())
            - usize::from(voltage[a - 1].is_nan());
        let here = (observed(gaps), spread(s1, s2));
        if (here.0, here.1) > (best.0, best.1) {
            best = (here.0, here.1, a);
        }
    }
    best.2..best.2 + len
}

/// Rough physical starts from the data alone: least squares of U on
/// [1, I] gives U_oc and R = R_i + R_ct, split evenly with α = 0.7 and
/// τ^α = 5 s^α, and mostly into R_ct (90 %) with α = 0.9 and
/// τ^α = 30 s^α. (A third start near a pure constant-phase element,
/// R_ct = 1000 R, was tried: the refinement does not move from it, the
/// gradient in ln R_ct vanishing there.)
pub fn rough_starts(current: &[f64], voltage: &[f64]) -> [CellParameters<f64>; 2] {
    let n = current.len() as f64;
    let mi = current.iter().sum::<f64>() / n;
    let mv = voltage.iter().sum::<f64>() / n;
    let sii: f64 = current.iter().map(|i| (i - mi) * (i - mi)).sum();
    let siv: f64 = current
        .iter()
        .zip(voltage)
        .map(|(i, v)| (i - mi) * (v - mv))
        .sum();
    let r = if sii > 0.0 {
        (siv / sii).abs().max(1e-5)
    } else {
        0.01
    };
    let cell = |r_i: f64, r_ct: f64, alpha: f64, q: f64| CellParameters {
        r_i,
        r_ct,
        q,
        alpha,
        u_oc: mv - r * mi,
        bv_a: 0.0,
        bv_i0: 1.0,
    };
    [
        cell(0.5 * r, 0.5 * r, 0.7, 5.0 / (0.5 * r)),
        cell(0.1 * r, 0.9 * r, 0.9, 30.0 / (0.9 * r)),
    ]
}
