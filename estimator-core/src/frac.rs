//! Grünwald–Letnikov fractional differences with short (truncated) memory.
//!
//! For an order α, a sample period h and a memory length M,
//!
//! ```text
//! Δ^α x(l) = h^(−α) · Σ_{j=0}^{min(l, M−1)} w_j(α) · x(l − j),
//! w_0 = 1,  w_j = w_{j−1} · (1 − (α + 1)/j)
//! ```
//!
//! with `l` counted from 0 at the first sample and every sample before the
//! first taken as zero (the system starts at rest). `M` is the runtime memory
//! length, at most the const-generic capacity `MEM`.
//!
//! The derivative with respect to the order, which the order search needs,
//! follows from the same recursion,
//!
//! ```text
//! ∂w_0/∂α = 0,  ∂w_j/∂α = ∂w_{j−1}/∂α · (1 − (α + 1)/j) − w_{j−1}/j
//! ∂(Δ^α x)/∂α = h^(−α) · Σ_j (∂w_j/∂α) x(l − j) − ln h · Δ^α x(l).
//! ```

use crate::error::FracError;
use crate::real::Real;

/// Grünwald–Letnikov weights `w_j(α)` and `∂w_j/∂α` for `j < len ≤ MEM`,
/// together with the scale `h^(−α)`.
#[derive(Clone, Debug)]
pub struct GlWeights<T, const MEM: usize> {
    alpha: T,
    h: T,
    len: usize,
    scale: T,
    ln_h: T,
    w: [T; MEM],
    dw: [T; MEM],
}

impl<T: Real, const MEM: usize> GlWeights<T, MEM> {
    /// Weights for order `alpha`, sample period `h` (seconds, or 1 for a
    /// dimensionless sampled system) and memory length `len`.
    ///
    /// # Errors
    /// [`FracError::NonFiniteOrder`] for a NaN/∞ order,
    /// [`FracError::BadSamplePeriod`] unless `h` is finite and positive,
    /// [`FracError::BadMemory`] unless `1 ≤ len ≤ MEM`.
    pub fn new(alpha: T, h: T, len: usize) -> Result<Self, FracError> {
        let mut me = Self {
            alpha: T::zero(),
            h: T::one(),
            len: 1,
            scale: T::one(),
            ln_h: T::zero(),
            w: [T::zero(); MEM],
            dw: [T::zero(); MEM],
        };
        me.set(alpha, h, len)?;
        Ok(me)
    }

    /// Recomputes the weights in place for a new order, period and memory.
    /// On error the weights are left unchanged.
    ///
    /// # Errors
    /// As [`GlWeights::new`].
    pub fn set(&mut self, alpha: T, h: T, len: usize) -> Result<(), FracError> {
        if !alpha.is_finite() {
            return Err(FracError::NonFiniteOrder);
        }
        if !(h.is_finite() && h > T::zero()) {
            return Err(FracError::BadSamplePeriod);
        }
        if len == 0 || len > MEM {
            return Err(FracError::BadMemory {
                requested: len,
                capacity: MEM,
            });
        }
        self.alpha = alpha;
        self.h = h;
        self.len = len;
        self.ln_h = h.ln();
        self.scale = (-alpha * self.ln_h).exp();
        self.w[0] = T::one();
        self.dw[0] = T::zero();
        let a1 = alpha + T::one();
        for j in 1..len {
            let jj = T::lit(j as f64);
            let r = T::one() - a1 / jj;
            self.w[j] = self.w[j - 1] * r;
            self.dw[j] = self.dw[j - 1] * r - self.w[j - 1] / jj;
        }
        Ok(())
    }

    /// Re-evaluates the weights for a new order, keeping `h` and the memory.
    ///
    /// # Errors
    /// [`FracError::NonFiniteOrder`] for a NaN/∞ order.
    pub fn set_order(&mut self, alpha: T) -> Result<(), FracError> {
        self.set(alpha, self.h, self.len)
    }

    /// The order α.
    pub fn alpha(&self) -> T {
        self.alpha
    }
    /// The sample period h.
    pub fn h(&self) -> T {
        self.h
    }
    /// The memory length M (number of weights used).
    pub fn len(&self) -> usize {
        self.len
    }
    /// Always false: a memory holds at least the weight `w_0 = 1`.
    pub fn is_empty(&self) -> bool {
        false
    }
    /// `h^(−α)`.
    pub fn scale(&self) -> T {
        self.scale
    }
    /// The weights `w_0 … w_{M−1}`, without the `h^(−α)` scale.
    pub fn weights(&self) -> &[T] {
        &self.w[..self.len]
    }
    /// The order derivatives `∂w_0/∂α … ∂w_{M−1}/∂α`.
    pub fn weight_derivatives(&self) -> &[T] {
        &self.dw[..self.len]
    }

    /// `Δ^α x(l)`: the fractional difference of the sequence `x` at index
    /// `l`, counting samples before `x[0]` as zero. Returns zero for an index
    /// past the end of `x`.
    #[inline]
    pub fn difference(&self, x: &[T], l: usize) -> T {
        if l >= x.len() {
            return T::zero();
        }
        let taps = (l + 1).min(self.len);
        self.scale * dot_rev(&self.w[..taps], &x[l + 1 - taps..=l])
    }

    /// `Δ^α x(l)` for a sequence given by a function of the index
    /// (`x(i)` is called for `i = l, l−1, …, max(0, l−M+1)`).
    #[inline]
    pub fn difference_by(&self, l: usize, x: impl Fn(usize) -> T) -> T {
        let taps = (l + 1).min(self.len);
        let s = self.w[..taps]
            .iter()
            .enumerate()
            .fold(T::zero(), |s, (j, &w)| s + w * x(l - j));
        self.scale * s
    }

    /// `(Δ^α x(l), ∂(Δ^α x(l))/∂α)` at index `l`.
    #[inline]
    pub fn difference_with_derivative(&self, x: &[T], l: usize) -> (T, T) {
        if l >= x.len() {
            return (T::zero(), T::zero());
        }
        let taps = (l + 1).min(self.len);
        let (s, ds) = dot_rev2(&self.w[..taps], &self.dw[..taps], &x[l + 1 - taps..=l]);
        let d = self.scale * s;
        (d, self.scale * ds - self.ln_h * d)
    }

    /// Writes `Δ^α x(l)` for every `l < min(x.len(), out.len())` into `out`.
    pub fn apply(&self, x: &[T], out: &mut [T]) {
        for (l, o) in out.iter_mut().enumerate().take(x.len()) {
            *o = self.difference(x, l);
        }
    }

    /// Writes `Δ^α x(l)` into `out` and `∂(Δ^α x(l))/∂α` into `dout` for
    /// every `l` covered by all three slices.
    pub fn apply_with_derivative(&self, x: &[T], out: &mut [T], dout: &mut [T]) {
        let n = x.len().min(out.len()).min(dout.len());
        for l in 0..n {
            let (d, dd) = self.difference_with_derivative(x, l);
            out[l] = d;
            dout[l] = dd;
        }
    }
}

/// `Σ_k w[k]·x[n−1−k]` over the common length `n` (a convolution tap sum
/// with the newest sample last), in four interleaved partial sums so that
/// the additions do not wait on each other (about 4× faster on a host
/// core; the Cortex-M4F gains from the shorter dependency chain too).
#[inline]
#[cfg(not(target_arch = "arm"))]
pub(crate) fn dot_rev<T: Real>(w: &[T], x: &[T]) -> T {
    let n = w.len().min(x.len());
    let (w, x) = (&w[..n], &x[x.len() - n..]);
    let mut s = [T::zero(); 4];
    let wc = w.chunks_exact(4);
    let xc = x.rchunks_exact(4);
    let (wr, xr) = (wc.remainder(), xc.remainder());
    for (wq, xq) in wc.zip(xc) {
        s[0] = s[0] + wq[0] * xq[3];
        s[1] = s[1] + wq[1] * xq[2];
        s[2] = s[2] + wq[2] * xq[1];
        s[3] = s[3] + wq[3] * xq[0];
    }
    for (&a, &b) in wr.iter().zip(xr.iter().rev()) {
        s[0] = s[0] + a * b;
    }
    (s[0] + s[1]) + (s[2] + s[3])
}

/// [`dot_rev`] on Arm: one running sum, measured cheaper on the
/// Cortex-M4F (`docs/performance.md`).
#[inline]
#[cfg(target_arch = "arm")]
pub(crate) fn dot_rev<T: Real>(w: &[T], x: &[T]) -> T {
    w.iter()
        .zip(x.iter().rev())
        .fold(T::zero(), |s, (&w, &x)| s + w * x)
}

/// [`dot_rev`] of two weight sets against the same samples at once.
#[inline]
#[cfg(target_arch = "arm")]
pub(crate) fn dot_rev2<T: Real>(w: &[T], dw: &[T], x: &[T]) -> (T, T) {
    w.iter()
        .zip(dw)
        .zip(x.iter().rev())
        .fold((T::zero(), T::zero()), |(s, d), ((&w, &dw), &x)| {
            (s + w * x, d + dw * x)
        })
}

/// [`dot_rev`] of two weight sets against the same samples at once.
#[inline]
#[cfg(not(target_arch = "arm"))]
pub(crate) fn dot_rev2<T: Real>(w: &[T], dw: &[T], x: &[T]) -> (T, T) {
    let n = w.len().min(dw.len()).min(x.len());
    let (w, dw, x) = (&w[..n], &dw[..n], &x[x.len() - n..]);
    let (mut s, mut d) = ([T::zero(); 4], [T::zero(); 4]);
    let wc = w.chunks_exact(4);
    let dc = dw.chunks_exact(4);
    let xc = x.rchunks_exact(4);
    let (wr, dr, xr) = (wc.remainder(), dc.remainder(), xc.remainder());
    for ((wq, dq), xq) in wc.zip(dc).zip(xc) {
        for k in 0..4 {
            s[k] = s[k] + wq[k] * xq[3 - k];
            d[k] = d[k] + dq[k] * xq[3 - k];
        }
    }
    for ((&a, &da), &b) in wr.iter().zip(dr).zip(xr.iter().rev()) {
        s[0] = s[0] + a * b;
        d[0] = d[0] + da * b;
    }
    ((s[0] + s[1]) + (s[2] + s[3]), (d[0] + d[1]) + (d[2] + d[3]))
}

#[cfg(test)]
mod dot_tests {
    use super::{dot_rev, dot_rev2};

    #[test]
    fn interleaved_sums_equal_the_plain_tap_sum() {
        for n in 0..14 {
            let w: Vec<f64> = (0..n).map(|k| 1.0 / (k as f64 + 1.5)).collect();
            let dw: Vec<f64> = (0..n).map(|k| (k as f64).sin()).collect();
            // x longer than w: only its last n samples take part.
            let x: Vec<f64> = (0..n + 3).map(|k| (k as f64 * 0.7).cos()).collect();
            let plain = |w: &[f64]| -> f64 { (0..n).map(|k| w[k] * x[n + 2 - k]).sum() };
            assert!((dot_rev(&w, &x) - plain(&w)).abs() < 1e-14, "n = {n}");
            let (a, b) = dot_rev2(&w, &dw, &x);
            assert!(
                (a - plain(&w)).abs() < 1e-14 && (b - plain(&dw)).abs() < 1e-14,
                "n = {n}"
            );
        }
    }
}
