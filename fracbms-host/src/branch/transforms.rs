//! The real transforms every solver of the branch runs on
//! ([`super::FftBranch`], [`super::FftSums`]): the planner of a thread, the
//! working buffers a solver keeps between calls, the sizes, and spectra
//! kept by the values they are of (one sequence, or the least recently
//! used of several), with the test that lets a multiple of a kept drive
//! take its spectrum scaled. It owns no series and no model.

use std::cell::RefCell;

use realfft::num_complex::Complex;
use realfft::RealFftPlanner;

thread_local! {
    /// The transform planner of this thread, shared by every
    /// [`Transforms`]: it keeps the plans of the sizes used, so the starts
    /// of a fit and its sums plan each size once (a plan of 2¹⁹ points
    /// computes and stores its twiddles: megabytes of fresh pages).
    static PLANNER: RefCell<RealFftPlanner<f64>> = RefCell::new(RealFftPlanner::new());
}

/// Spectra of one sequence at one transform size, and the sequence they
/// are of (the key: a spectrum is reused only for the same values).
#[derive(Default)]
pub(super) struct Spectrum {
    pub(super) of: Vec<f64>,
    pub(super) size: usize,
    pub(super) hat: Vec<Complex<f64>>,
    /// `hat` is not yet `of`'s (it is taken when first needed).
    pub(super) stale: bool,
}

/// The smallest transform that holds the linear convolution of two
/// sequences of `n` values: [`fast_size`] of `2n`.
pub(super) fn transform_size(n: usize) -> usize {
    fast_size(2 * n)
}

/// The least even size at or above `want` with no prime factor above 5 (a
/// mixed-radix transform of such a size costs about what the power of two
/// does per point, and it is up to a third shorter).
pub(super) fn fast_size(want: usize) -> usize {
    let want = want.max(2);
    let mut best = want.next_power_of_two();
    let mut p3 = 1;
    while p3 < best {
        let mut p35 = p3;
        while p35 < best {
            // The least 2^k·p35 at or above `want` (k ≥ 1).
            let mut m = 2 * p35;
            while m < want {
                m *= 2;
            }
            best = best.min(m);
            p35 *= 5;
        }
        p3 *= 3;
    }
    best
}

/// The transforms and their working buffers, kept between calls (a large
/// buffer allocated anew is a fresh mapping whose pages the kernel clears:
/// a third of a fit's time before they were kept); an `FftBranch`'s are
/// its thread's (`super::working`).
#[derive(Default)]
pub(super) struct Transforms {
    /// The real input of a forward transform (clobbered by it).
    real: Vec<f64>,
    /// The transforms' own scratch.
    scratch: Vec<Complex<f64>>,
}

impl Transforms {
    /// The spectrum of `x` zero-padded to `size` (a size of [`transform_size`]), into
    /// `out`.
    pub(super) fn forward(&mut self, x: &[f64], size: usize, out: &mut Vec<Complex<f64>>) {
        self.real.clear();
        self.real.extend_from_slice(&x[..x.len().min(size)]);
        self.transform_real(size, out);
    }

    /// The spectrum of `x_k·r^k` (`ln r` given) zero-padded to `size`, into
    /// `out`: `x`'s power series at the points of the circle of that size
    /// and radius.
    pub(super) fn forward_scaled(
        &mut self,
        x: &[f64],
        ln_r: f64,
        size: usize,
        out: &mut Vec<Complex<f64>>,
    ) {
        let r = ln_r.exp();
        let mut scale = 1.0;
        self.real.clear();
        self.real.extend(x[..x.len().min(size)].iter().map(|&v| {
            let s = v * scale;
            scale *= r;
            s
        }));
        self.transform_real(size, out);
    }

    /// The spectrum of `real` (clobbered) zero-padded to `size`, into `out`.
    fn transform_real(&mut self, size: usize, out: &mut Vec<Complex<f64>>) {
        let fft = PLANNER.with(|p| p.borrow_mut().plan_fft_forward(size));
        self.real.resize(size, 0.0);
        out.resize(size / 2 + 1, Complex::default());
        self.scratch
            .resize(fft.get_scratch_len(), Complex::default());
        // The lengths are the plan's own: no error is possible.
        let _ = fft.process_with_scratch(&mut self.real, out, &mut self.scratch);
    }

    /// The sequence of spectrum `spec` (of size `size`, clobbered),
    /// normalized, into `out`.
    pub(super) fn backward(&mut self, spec: &mut [Complex<f64>], size: usize, out: &mut Vec<f64>) {
        let fft = PLANNER.with(|p| p.borrow_mut().plan_fft_inverse(size));
        out.resize(size, 0.0);
        // The products of real sequences' spectra are real at 0 and at the
        // Nyquist bin up to rounding; the transform takes them real.
        if let Some(c) = spec.first_mut() {
            c.im = 0.0;
        }
        if let Some(c) = spec.last_mut() {
            c.im = 0.0;
        }
        self.scratch
            .resize(fft.get_scratch_len(), Complex::default());
        let _ = fft.process_with_scratch(spec, out, &mut self.scratch);
        let s = 1.0 / size as f64;
        out.iter_mut().for_each(|v| *v *= s);
    }

    /// `x ∗ k` over its first `size` values (cyclic), with `k`'s spectrum
    /// `k_hat` at that size, into `out` (`spec` is working space).
    pub(super) fn convolve(
        &mut self,
        x: &[f64],
        k_hat: &[Complex<f64>],
        size: usize,
        spec: &mut Vec<Complex<f64>>,
        out: &mut Vec<f64>,
    ) {
        self.forward(x, size, spec);
        spec.iter_mut().zip(k_hat).for_each(|(a, b)| *a *= b);
        self.backward(spec, size, out);
    }
}

impl Spectrum {
    /// Forgets the sequence and its spectrum (as [`Default`] has none),
    /// keeping the buffers' allocations.
    pub(super) fn forget(&mut self) {
        self.of.clear();
        self.size = 0;
        self.hat.clear();
        self.stale = false;
    }

    /// Keeps the spectrum of `x` at `size` (recomputed when `x` or the
    /// size changed); true when it was recomputed.
    pub(super) fn keep(&mut self, t: &mut Transforms, x: &[f64], size: usize) -> bool {
        if self.size == size && self.of == x {
            return false;
        }
        t.forward(x, size, &mut self.hat);
        self.of.clear();
        self.of.extend_from_slice(x);
        self.size = size;
        true
    }

    /// Keeps the spectrum of `x_k·r^k` at `size` (`ln r` given), as the
    /// spectrum of `x` on the circle ([`Transforms::forward_scaled`]).
    pub(super) fn keep_scaled(&mut self, t: &mut Transforms, x: &[f64], ln_r: f64, size: usize) {
        t.forward_scaled(x, ln_r, size, &mut self.hat);
        self.of.clear();
        self.of.extend_from_slice(x);
        self.size = size;
    }
}

/// Spectra kept by the values they are of, the least recently used given
/// up beyond a capacity: the drives of [`FftBranch`], the sequences and
/// weights of [`FftSums`].
#[derive(Default)]
pub(super) struct KeptSpectra {
    /// Each spectrum, and when it was last asked for (a count of calls).
    kept: Vec<(Spectrum, u64)>,
    calls: u64,
}

impl KeptSpectra {
    /// The index of the spectrum of `x` at `size`, taken now unless kept
    /// (in the place of the least recently used when `capacity` are). An
    /// index stays valid until more than `capacity − 1` other sequences
    /// have been asked for since.
    pub(super) fn at(
        &mut self,
        t: &mut Transforms,
        x: &[f64],
        size: usize,
        capacity: usize,
    ) -> usize {
        self.calls += 1;
        let now = self.calls;
        if let Some(k) = self
            .kept
            .iter()
            .position(|(s, _)| s.size == size && !s.stale && s.of == x)
        {
            self.kept[k].1 = now;
            return k;
        }
        let k = if self.kept.len() < capacity.max(1) {
            self.kept.push((Spectrum::default(), now));
            self.kept.len() - 1
        } else {
            (0..self.kept.len())
                .min_by_key(|&k| self.kept[k].1)
                .unwrap_or(0)
        };
        let (s, used) = &mut self.kept[k];
        s.keep(t, x, size);
        s.stale = false;
        *used = now;
        k
    }

    /// How many spectra are kept.
    pub(super) fn len(&self) -> usize {
        self.kept.len()
    }

    /// The spectrum at `k` (an index [`at`](Self::at) gave).
    pub(super) fn hat(&self, k: usize) -> &[Complex<f64>] {
        &self.kept[k].0.hat
    }
}

/// `c` with `x = c·of` to within [`PROPORTION_ROUNDINGS`] of each value,
/// so that `c` times `of`'s spectrum is `x`'s to the transform's own
/// rounding, read at `of[peak]` (its largest value); `None` when `x` is no
/// such multiple (another length, a NaN, a value off the line), or `of` is
/// empty or zero there.
pub(super) fn proportion(of: &[f64], peak: usize, x: &[f64]) -> Option<f64> {
    if of.len() != x.len() {
        return None;
    }
    let c = x.get(peak)? / of.get(peak)?;
    if !c.is_finite() {
        return None;
    }
    let tol = PROPORTION_ROUNDINGS * f64::EPSILON;
    // Every value checked (no early exit: the loop vectorizes).
    of.iter()
        .zip(x)
        .fold(true, |ok, (&o, &v)| {
            ok & ((v - c * o).abs() <= tol * v.abs())
        })
        .then_some(c)
}

/// How many roundings (of `f64::EPSILON`, relative) a value of a drive may
/// lie off the kept drive times its scale and still take the kept
/// spectrum: `R_ct·I` against `R_ct'·I` is off by at most four (each
/// product, the scale's quotient and its product).
pub(super) const PROPORTION_ROUNDINGS: f64 = 8.0;

/// The product of two spectra of one size, into `out`.
pub(super) fn product(a: &[Complex<f64>], b: &[Complex<f64>], out: &mut Vec<Complex<f64>>) {
    out.clear();
    out.extend(a.iter().zip(b).map(|(x, y)| x * y));
}
