//! The paper regression's tap sums by FFT: the host's [`TapSums`] for the
//! regression over a whole record ([`FftSums`]).
//!
//! A tap sum `Σ_{j<M} w_j·x(l − j)` over rows `l` in `a..b` is the linear
//! convolution of `w` with the stretch `x[a + 1 − M .. b]` (from `x[0]`
//! when `a < M − 1`, the samples before it zero), read from its `M − 1`-th
//! value on. On a real FFT of a size at least the stretch's length plus
//! `M − 1` nothing wraps, so the values are the direct kernels' up to
//! rounding (within 1e−13 of the largest sum; test
//! `fft_sums_are_the_direct_sums`). The regression asks, at each
//! iteration, for the sums of a few weight sets (the order's, a trial
//! order's, their derivatives) against the same two sequences, the current
//! and the centred voltage: their spectra are kept, keyed by their values,
//! so an iteration takes about three transforms per weight set where the
//! direct sums take `rows·M` products. Below [`SUMS_DIRECT_TAPS`] taps, on
//! fewer rows than [`SUMS_DIRECT_ROWS`] or with a value that is not finite
//! (it would spread over every row of a transform), the direct kernels run
//! instead. This module owns the transforms only; the weights, their scale
//! and the regression are `estimator-core`'s.
//!
//! ```
//! use estimator_core::frac::{DirectSums, GlWeights, TapSums};
//! use fracbms_host::branch::FftSums;
//!
//! let w = GlWeights::<f64, 256>::new(0.6, 1.0, 256).unwrap();
//! let x: Vec<f64> = (0..4000).map(|l| if (l / 300) % 2 == 0 { 1.0 } else { -0.5 }).collect();
//! let (mut direct, mut fast) = (vec![0.0; 4000], vec![0.0; 4000]);
//! DirectSums.single(w.weights(), &x, 255..4000, |l, s| direct[l] = s);
//! FftSums::default().single(w.weights(), &x, 255..4000, |l, s| fast[l] = s);
//! let worst = direct.iter().zip(&fast).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
//! assert!(worst < 1e-12);
//! ```

use std::fmt;
use std::ops::Range;

use estimator_core::frac::{DirectSums, TapSums};
use realfft::num_complex::Complex;

use super::transforms::{fast_size, KeptSpectra, Transforms};

/// Below this many taps the direct kernels are used. A pair of sums over
/// 2 048 rows takes them 22 µs with 64 taps and 78 µs with 256, the
/// transforms 21 and 22 µs (`cargo bench -p fracbms-host --bench
/// whole_record -- tap_sums`): the direct kernels cost about 0.17 ns a row
/// and tap, the transforms about 10 ns a row, level near 64 taps.
pub const SUMS_DIRECT_TAPS: usize = 64;

/// On fewer rows than this the direct kernels are used (a sliding
/// window's newest row, a short record): with 64 taps about level.
pub const SUMS_DIRECT_ROWS: usize = 512;

/// How many spectra [`FftSums`] keeps: the two sequences, a weight set and
/// its trial's, their derivatives and a combined sequence, with room.
const KEPT_SPECTRA: usize = 8;

/// The FFT tap sums (see the module docs). It holds transform plans and the
/// spectra of the last sequences and weights; a clone starts with none
/// (they are a cache).
#[derive(Default)]
pub struct FftSums {
    t: Transforms,
    kept: KeptSpectra,
    spec: Vec<Complex<f64>>,
    out: Vec<f64>,
    /// The first sequence's sums of a pair while the second's are taken.
    other: Vec<f64>,
}

impl Clone for FftSums {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl fmt::Debug for FftSums {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("FftSums")
            .field("kept", &self.kept.len())
            .finish_non_exhaustive()
    }
}

/// The stretch of `x` the sums over `rows` (up to `end`) need with `m`
/// taps, and the transform size that holds their convolution unwrapped;
/// `None` where the direct kernels are the better way (see the module
/// docs).
fn plan(w: &[f64], xs: &[&[f64]], rows: &Range<usize>, end: usize) -> Option<(usize, usize)> {
    let m = w.len();
    if m < SUMS_DIRECT_TAPS || end.saturating_sub(rows.start) < SUMS_DIRECT_ROWS {
        return None;
    }
    let from = rows.start.saturating_sub(m - 1);
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    if !finite(w) || !xs.iter().all(|x| finite(&x[from..end])) {
        return None;
    }
    Some((from, fast_size(end - from + m - 1)))
}

impl FftSums {
    /// The sums of the kept weights `kw` against the kept sequence `kx`
    /// (both at `size`) into `out`: the convolution's values from index 0.
    fn convolve_kept(&mut self, kw: usize, kx: usize, size: usize) {
        let (w, x) = (self.kept.hat(kw), self.kept.hat(kx));
        self.spec.clear();
        self.spec.extend(w.iter().zip(x).map(|(a, b)| a * b));
        self.t.backward(&mut self.spec, size, &mut self.out);
    }
}

impl TapSums<f64> for FftSums {
    fn single(&mut self, w: &[f64], x: &[f64], rows: Range<usize>, mut f: impl FnMut(usize, f64)) {
        let end = rows.end.min(x.len());
        let Some((from, size)) = plan(w, &[x], &rows, end) else {
            return DirectSums.single(w, x, rows, f);
        };
        let kw = self.kept.at(&mut self.t, w, size, KEPT_SPECTRA);
        let kx = self.kept.at(&mut self.t, &x[from..end], size, KEPT_SPECTRA);
        self.convolve_kept(kw, kx, size);
        for l in rows.start..end {
            f(l, self.out[l - from]);
        }
    }

    fn pair(
        &mut self,
        w: &[f64],
        x: &[f64],
        y: &[f64],
        rows: Range<usize>,
        mut f: impl FnMut(usize, f64, f64),
    ) {
        let end = rows.end.min(x.len()).min(y.len());
        let Some((from, size)) = plan(w, &[x, y], &rows, end) else {
            return DirectSums.pair(w, x, y, rows, f);
        };
        let kw = self.kept.at(&mut self.t, w, size, KEPT_SPECTRA);
        let kx = self.kept.at(&mut self.t, &x[from..end], size, KEPT_SPECTRA);
        let ky = self.kept.at(&mut self.t, &y[from..end], size, KEPT_SPECTRA);
        self.convolve_kept(kw, kx, size);
        std::mem::swap(&mut self.out, &mut self.other);
        self.convolve_kept(kw, ky, size);
        for l in rows.start..end {
            f(l, self.other[l - from], self.out[l - from]);
        }
    }
}
