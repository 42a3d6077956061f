//! The far past of a Grünwald–Letnikov sum: the weights beyond the memory
//! as a sum of exponentials with fixed rates.
//!
//! With memory `M` the estimators keep the taps `j < M` of
//! `Δ^α x(l) = h^(−α)·Σ_j w_j(α)·x(l − j)` and drop the rest, which biases
//! a fit on data with a longer memory (docs/pack.md, item 4). This module
//! owns the representation of the dropped taps,
//!
//! ```text
//! w_j(α) ≈ Σ_k c_k(α)·r_k^j   for j ≥ M,   r_k = e^(−1/T_k),
//! ```
//!
//! with [`MODES`] fixed decay times `T_k` (geometric over 16…40 000
//! samples) and coefficients `c_k(α)` from a table in flash: the
//! diffusive-representation form `c_k = −(sin πα/π)·s_k^(1+α)·g_k(α)`,
//! `s_k = 1/T_k`, with `g_k` fitted by relative least squares on
//! log-spaced lags in `[64, 20 000)` and interpolated linearly in α
//! (`bench/short_memory/rust_table.py`, study in
//! `bench/short_memory/README.md`). Since the rates do not depend on α, the
//! tail of any signal is carried by `MODES` recursions
//! `Z_k ← r_k·Z_k + x`, the same for every order; only the coefficients
//! change with α.
//!
//! Six modes: kernel error (L1 over lags 64…20 000 relative to `Σ|w_j|`,
//! test `kernel_error_is_that_of_the_fitted_sum`) at most 4·10⁻² for α in
//! `[0.3, 1)`, which leaves a bias of 0.3 % on R_ct on a noise-free
//! full-memory record (test `the_tail_removes_the_short_memory_bias`,
//! against 7.7 % truncated). Eight modes would give 5.5·10⁻³ and 0.02 %
//! for 6 % more instructions per update, which the pack's budget (350 000
//! per cell update) does not have (docs/pack.md). It must not touch the truncated taps themselves
//! ([`crate::frac`]) nor any estimator's state.

use crate::error::Error;
use crate::real::Real;

/// Modes of the representation.
pub const MODES: usize = 6;
/// Orders in the coefficient table (α = 0.05, 0.10, …, 0.95).
const ORDERS: usize = 19;
/// Smallest memory the table was fitted for: it represents the taps at
/// lags ≥ 64 (and so any larger memory).
pub const MIN_MEMORY: usize = 64;

/// Decay times `T_k` of the modes (samples), geometric over 16…40 000.
pub const DECAY_SAMPLES: [f64; MODES] = [
    16.0,
    76.50819998320293,
    365.84404154186103,
    1749.3793183092448,
    8365.116420730179,
    40000.0,
];
/// `r_k = e^(−1/T_k)`.
pub const RATES: [f64; MODES] = [
    0.9394130628134758,
    0.987014553561725,
    0.9972703271656442,
    0.9994285320351441,
    0.999880463082633,
    0.9999750003124974,
];
/// `ln s_k = −ln T_k`.
const LN_S: [f64; MODES] = [
    -2.772588722239781,
    -4.337397924411039,
    -5.902207126582298,
    -7.467016328753556,
    -9.031825530924815,
    -10.596634733096073,
];
/// `g_k(α)` at α = 0.05, 0.10, …, 0.95 (rows), `c_k = −(sin πα/π)·s_k^(1+α)·g_k`.
const G_TABLE: [[f64; MODES]; ORDERS] = [
    [
        2.1410353341960424,
        1.5188979612887832,
        1.5835751205252242,
        1.5450904638353455,
        1.571435690652881,
        2.027232035017325,
    ],
    [
        2.1448459383314784,
        1.5186756317252714,
        1.584567500285323,
        1.54186231890332,
        1.5880727676552768,
        1.9511652975305942,
    ],
    [
        2.1469502476670694,
        1.5186177716152882,
        1.585389394555864,
        1.538947201469592,
        1.6034674438677363,
        1.8780450621115978,
    ],
    [
        2.1475511596207864,
        1.5187034348414228,
        1.5860660813476157,
        1.5362760920817682,
        1.6179151625342238,
        1.8067708005190246,
    ],
    [
        2.14681260312487,
        1.5189163611841283,
        1.5866168555515139,
        1.5337946225085834,
        1.631657471861254,
        1.7363292177608687,
    ],
    [
        2.1448699823670823,
        1.5192436837837568,
        1.5870565067851683,
        1.5314597211965035,
        1.6448932662296987,
        1.665767183457053,
    ],
    [
        2.141837574669767,
        1.5196749817797701,
        1.5873964189047407,
        1.5292370873591306,
        1.6577874087140252,
        1.5941696623907355,
    ],
    [
        2.137813803171781,
        1.5202015815284131,
        1.5876453937195094,
        1.5270992739822213,
        1.670477405043873,
        1.5206412996648486,
    ],
    [
        2.1328850164098454,
        1.5208160386383798,
        1.5878102716786684,
        1.525024222667048,
        1.6830786117258583,
        1.4442906815662195,
    ],
    [
        2.1271282125083504,
        1.5215117528204798,
        1.5878964017594157,
        1.5229941367138926,
        1.69568833026273,
        1.3642165494573584,
    ],
    [
        2.1206130135276866,
        1.5222826812104644,
        1.5879079984363837,
        1.5209946094152869,
        1.708389046951827,
        1.2794954259548805,
    ],
    [
        2.113403104696872,
        1.52312312538532,
        1.5878484134834396,
        1.519013946275299,
        1.721251011525205,
        1.1891702440672314,
    ],
    [
        2.105557290218753,
        1.5240275740751017,
        1.58772034312095,
        1.5170426355191928,
        1.734334299959471,
        1.0922396662951572,
    ],
    [
        2.0971302736025237,
        1.5249905883372354,
        1.5875259858122799,
        1.5150729326347472,
        1.7476904716860742,
        0.987647852440644,
    ],
    [
        2.0881732395508172,
        1.5260067194118583,
        1.587267162217492,
        1.5130985330334328,
        1.7613639054751398,
        0.8742744895733099,
    ],
    [
        2.078734292458832,
        1.5270704519981806,
        1.5869454060321044,
        1.5111143130945615,
        1.775392878897868,
        0.7509249404756776,
    ],
    [
        2.0688587912457543,
        1.5281761674458678,
        1.5865620323822818,
        1.5091161244826425,
        1.7898104416988934,
        0.6163204015318564,
    ],
    [
        2.058589609173057,
        1.5293181226465502,
        1.5861181889035232,
        1.5071006300980256,
        1.8046451223304438,
        0.4690879903517254,
    ],
    [
        2.0479673390175646,
        1.5304904414731713,
        1.58561489348683,
        1.5050651726282662,
        1.8199214984618508,
        0.30775070909120716,
    ],
];

/// The tail coefficients at one order: `w_j(α) ≈ Σ_k c_k·r_k^j` for
/// `j ≥ MIN_MEMORY`, and `∂c_k/∂α`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TailKernel<T> {
    /// The order.
    pub alpha: T,
    /// `r_k = e^(−1/T_k)`.
    pub rates: [T; MODES],
    /// `c_k(α)`.
    pub coefficients: [T; MODES],
    /// `∂c_k/∂α`.
    pub derivatives: [T; MODES],
}

impl<T: Real> TailKernel<T> {
    /// The kernel at order `alpha` in `(0, 1]` (zero at `α = 1`, whose
    /// weights vanish beyond lag 1).
    ///
    /// # Errors
    /// [`Error::BadSetting`] for an order outside `(0, 1]` or not finite.
    pub fn new(alpha: T) -> Result<Self, Error> {
        if !(alpha > T::zero() && alpha <= T::one()) {
            return Err(Error::BadSetting);
        }
        // The segment of the table: linear inside, extrapolated beyond the
        // first and last nodes. In `T` (the same libm routines on the host
        // and the target, through `num-traits`): about 20 transcendental
        // calls per order.
        let step = T::lit(0.05);
        let seg = ((alpha / step).floor().to_f64() as usize).clamp(1, ORDERS - 1);
        let (lo, hi) = (G_TABLE[seg - 1], G_TABLE[seg]);
        let t = (alpha - step * T::lit(seg as f64)) / step;
        let pi = T::lit(core::f64::consts::PI);
        let (sin, cos) = (pi * alpha).sin_cos();
        let mut k = Self {
            alpha,
            rates: RATES.map(T::lit),
            coefficients: [T::zero(); MODES],
            derivatives: [T::zero(); MODES],
        };
        for m in 0..MODES {
            let ln_s = T::lit(LN_S[m]);
            let pow = ((T::one() + alpha) * ln_s).exp();
            let scale = -(sin / pi) * pow;
            let d_scale = -pow * (cos + (sin / pi) * ln_s);
            let (g0, g1) = (T::lit(lo[m]), T::lit(hi[m]));
            let g = g0 + t * (g1 - g0);
            let d_g = (g1 - g0) / step;
            k.coefficients[m] = scale * g;
            k.derivatives[m] = d_scale * g + scale * d_g;
        }
        Ok(k)
    }

    /// The represented weight at lag `j` (meaningful for `j ≥ MIN_MEMORY`).
    pub fn weight(&self, j: usize) -> T {
        self.coefficients
            .iter()
            .zip(&self.rates)
            .fold(T::zero(), |s, (&c, &r)| s + c * r.powi(j as i32))
    }
}

/// The modes of a window's past: what the samples that left the window
/// contribute to the tail of every later row, kept as
/// `Z_k = Σ_{m≥1} r_k^(m−1)·x(−m)` (`x(−1)` the sample that left last) for
/// the voltage (less a reference `v_ref`, for `f32`), the current, the
/// constant 1 and the charge. They do not depend on the order: the past's
/// polarization `U_p = v − U_oc + β·c − R_i·I` is a linear combination
/// of them for any parameters (`β·c`: an OCV slope over the charge still
/// to flow, `c(−m) = c(0) + h·Σ_{k=−m+1}^{0} I(k)`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PastModes<T> {
    /// Modes of `v − v_ref` (V).
    pub voltage: [T; MODES],
    /// Modes of the current (A).
    pub current: [T; MODES],
    /// Modes of 1.
    pub one: [T; MODES],
    /// Modes of `Σ_{k=−m+1}^{0} I(k)` (A), the charge from each past
    /// sample to the window's first, over `h`.
    pub charge: [T; MODES],
    /// The reference voltage (V): the first voltage that left.
    pub v_ref: T,
    /// Samples that left (saturating).
    pub count: u32,
}

impl<T: Real> Default for PastModes<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> PastModes<T> {
    /// No past (a cell at rest before its window).
    pub const fn new() -> Self {
        Self {
            voltage: [T::ZERO; MODES],
            current: [T::ZERO; MODES],
            one: [T::ZERO; MODES],
            charge: [T::ZERO; MODES],
            v_ref: T::ZERO,
            count: 0,
        }
    }

    /// The sample `(current, voltage)` leaves the window; `next_current`
    /// is the current of the window's new first sample.
    pub fn leave(&mut self, current: T, voltage: T, next_current: T) {
        if self.count == 0 {
            self.v_ref = voltage;
        }
        for (k, &rate) in RATES.iter().enumerate() {
            let r = T::lit(rate);
            self.voltage[k] = r * self.voltage[k] + (voltage - self.v_ref);
            self.current[k] = r * self.current[k] + current;
            self.one[k] = r * self.one[k] + T::one();
            self.charge[k] = r * self.charge[k] + next_current * self.one[k];
        }
        self.count = self.count.saturating_add(1);
    }

    /// The modes of the past polarization `U_p = v − U_oc + β·c − R_i·I`
    /// for `U_oc`, `R_i`, the OCV slope `β` and `c0`, the charge still to
    /// flow from the window's first sample (A·s), sample period `h`.
    pub fn polarization(&self, u_oc: T, r_i: T, beta: T, c0: T, h: T) -> [T; MODES] {
        core::array::from_fn(|k| {
            (self.voltage[k] + (self.v_ref - u_oc) * self.one[k]) - r_i * self.current[k]
                + beta * self.charge_modes(k, c0, h)
        })
    }

    /// Modes of the past's charge still to flow, `c(−m)` (A·s).
    pub fn charge_modes(&self, k: usize, c0: T, h: T) -> T {
        c0 * self.one[k] + h * self.charge[k]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact GL weights `w_0..n`.
    fn weights(alpha: f64, n: usize) -> Vec<f64> {
        let mut w = vec![1.0; n];
        for j in 1..n {
            w[j] = w[j - 1] * (1.0 - (alpha + 1.0) / j as f64);
        }
        w
    }

    #[test]
    fn kernel_error_is_that_of_the_fitted_sum() {
        // The reference study (bench/short_memory/kernel_error.txt): 2–4e-2
        // at six modes over α in [0.3, 0.999] (5.5e-3 at eight).
        let mut worst: f64 = 0.0;
        for step in 0..=70 {
            let a = 0.3 + 0.699 * f64::from(step) / 70.0;
            let w = weights(a, 20_000);
            let k = TailKernel::<f64>::new(a).unwrap();
            let mut z = k.rates.map(|r| r.powi(MIN_MEMORY as i32));
            let (mut err, mut mass) = (0.0, 0.0);
            for &wj in &w[MIN_MEMORY..] {
                let approx: f64 = k.coefficients.iter().zip(&z).map(|(c, z)| c * z).sum();
                err += (approx - wj).abs();
                mass += wj.abs();
                for (zk, r) in z.iter_mut().zip(&k.rates) {
                    *zk *= r;
                }
            }
            worst = worst.max(err / mass);
        }
        assert!(worst < 4.5e-2, "{worst}");
        // The kernel represents something: the truncated tail is not small.
        let w = weights(0.75, 20_000);
        let tail: f64 = w[MIN_MEMORY..].iter().map(|x| x.abs()).sum();
        assert!(tail > 0.01, "{tail}");
    }

    #[test]
    fn derivative_matches_finite_differences() {
        // Inside segments of the table (at a node the slope changes).
        for a in [0.33, 0.52, 0.72, 0.88, 0.97] {
            let k = TailKernel::<f64>::new(a).unwrap();
            let e = 1e-6;
            let (p, m) = (
                TailKernel::<f64>::new(a + e).unwrap(),
                TailKernel::<f64>::new(a - e).unwrap(),
            );
            for i in 0..MODES {
                let fd = (p.coefficients[i] - m.coefficients[i]) / (2.0 * e);
                let scale = k.derivatives[i].abs().max(1e-30);
                assert!(
                    (fd - k.derivatives[i]).abs() / scale < 1e-5,
                    "α {a} mode {i}: {fd} {}",
                    k.derivatives[i]
                );
            }
        }
    }

    #[test]
    fn past_modes_are_the_discounted_sums() {
        // Five samples leave; the modes equal the sums they stand for.
        let (i, v) = ([1.0, -2.0, 0.5, 3.0, -1.0], [3.7, 3.65, 3.72, 3.8, 3.6]);
        let mut past = PastModes::<f64>::new();
        for m in 0..5 {
            let next = if m + 1 < 5 { i[m + 1] } else { 0.25 };
            past.leave(i[m], v[m], next);
        }
        let (u_oc, r_i, beta, c0, h) = (3.7, 0.02, 1e-4, 7.0, 1.0);
        let up = past.polarization(u_oc, r_i, beta, c0, h);
        for k in 0..MODES {
            let r = RATES[k];
            // x(−m) is sample 5 − m; the window's first current is 0.25.
            let mut want = 0.0;
            for m in 1..=5 {
                let s = 5 - m;
                // c(−m) = c0 + h·(I(0) + I(−1) + … + I(−m+1)).
                let c = c0 + h * (0.25 + i[s + 1..].iter().sum::<f64>());
                let up_m = v[s] - u_oc + beta * c - r_i * i[s];
                want += r.powi(m as i32 - 1) * up_m;
            }
            assert!((up[k] - want).abs() < 1e-12, "mode {k}: {} {want}", up[k]);
        }
    }

    #[test]
    fn order_one_has_no_tail_and_bad_orders_are_refused() {
        // At α = 1 the coefficients vanish (sin π·1 = 0, to f32 rounding).
        let (k, mid) = (
            TailKernel::<f32>::new(1.0).unwrap(),
            TailKernel::<f32>::new(0.75).unwrap(),
        );
        for (c, m) in k.coefficients.iter().zip(&mid.coefficients) {
            assert!(c.abs() < 1e-5 * m.abs(), "{k:?}");
        }
        for bad in [0.0, -0.1, 1.01, f32::NAN] {
            assert_eq!(TailKernel::<f32>::new(bad).err(), Some(Error::BadSetting));
        }
        // f32 follows f64.
        let (a, b) = (
            TailKernel::<f32>::new(0.75).unwrap(),
            TailKernel::<f64>::new(0.75).unwrap(),
        );
        for i in 0..MODES {
            let r = f64::from(a.coefficients[i]) / b.coefficients[i] - 1.0;
            assert!(r.abs() < 1e-5, "{r}");
        }
    }
}
