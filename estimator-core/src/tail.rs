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
//! Kernel error (L1 over lags 64…20 000 relative to `Σ|w_j|`, test
//! `kernel_error_is_that_of_the_fitted_sum`): at most 5.5·10⁻³ for α in
//! `[0.3, 1)`. It must not touch the truncated taps themselves
//! ([`crate::frac`]) nor any estimator's state.

use crate::error::Error;
use crate::real::Real;
use num_traits::Float;

/// Modes of the representation.
pub const MODES: usize = 8;
/// Orders in the coefficient table (α = 0.05, 0.10, …, 0.95).
const ORDERS: usize = 19;
/// Smallest memory the table was fitted for: it represents the taps at
/// lags ≥ 64 (and so any larger memory).
pub const MIN_MEMORY: usize = 64;

/// Decay times `T_k` of the modes (samples), geometric over 16…40 000.
pub const DECAY_SAMPLES: [f64; MODES] = [
    16.0,
    48.92603074570228,
    149.60978028308767,
    457.4882943742571,
    1398.9428972721114,
    4277.795200213569,
    13080.971218091676,
    40000.0,
];
/// `g_k(α)` at α = 0.05, 0.10, …, 0.95 (rows), `c_k = −(sin πα/π)·s_k^(1+α)·g_k`.
const G_TABLE: [[f64; MODES]; ORDERS] = [
    [
        1.1851603560196575,
        1.1109950868110614,
        1.11870138799992,
        1.1205951884116934,
        1.108022040619059,
        1.1578613328170555,
        0.886332837356698,
        2.1119886001848704,
    ],
    [
        1.187649860695916,
        1.1113351958803177,
        1.1190864904057245,
        1.1203501336715862,
        1.108822806155443,
        1.154274211469085,
        0.9077452652102761,
        2.045308333355963,
    ],
    [
        1.1898035887328866,
        1.1117446097967196,
        1.119412184197851,
        1.1201994969700735,
        1.1093946734904596,
        1.1515756946533777,
        0.9250824303186402,
        1.987482863232781,
    ],
    [
        1.1916781415945952,
        1.1122107402133776,
        1.1196904640267176,
        1.1201237297186954,
        1.1097830044164985,
        1.1496096001667286,
        0.9389008105454288,
        1.937709399043173,
    ],
    [
        1.1933161347214352,
        1.112724156740558,
        1.1199304842317743,
        1.1201076975652566,
        1.1100232667422543,
        1.1482516983260118,
        0.9496486496821003,
        1.8953695860469575,
    ],
    [
        1.1947501015136939,
        1.1132777537331586,
        1.12013927406385,
        1.1201396034394155,
        1.1101433651823922,
        1.1474025842279179,
        0.9576879031195319,
        1.860000720097575,
    ],
    [
        1.1960052726374422,
        1.1138661437014428,
        1.1203222643636863,
        1.1202101884551965,
        1.1101653855699742,
        1.1469822698240428,
        0.9633111426951687,
        1.8312741921869153,
    ],
    [
        1.1971015669604916,
        1.114485212342664,
        1.120483678392448,
        1.1203121343478641,
        1.1101069106510582,
        1.1469260443237392,
        0.9667547118577652,
        1.8089794104442207,
    ],
    [
        1.1980550255486377,
        1.1151317898334614,
        1.12062682387546,
        1.1204396134675567,
        1.1099820199893917,
        1.1471812795851168,
        0.9682090628562768,
        1.7930119304595964,
    ],
    [
        1.198878849197215,
        1.1158034064634992,
        1.1207543125889292,
        1.120587947762544,
        1.1098020548598735,
        1.1477049462593905,
        0.9678269568267407,
        1.7833648612340933,
    ],
    [
        1.1995841521643715,
        1.1164981098589228,
        1.1208682263938765,
        1.1207533488876231,
        1.1095762069029669,
        1.1484616691016145,
        0.9657300303726217,
        1.7801228502390276,
    ],
    [
        1.2001805112994937,
        1.1172143275558268,
        1.1209702433705586,
        1.120932719181139,
        1.1093119735668986,
        1.1494221946211338,
        0.9620141053701529,
        1.7834581176754696,
    ],
    [
        1.2006763670902936,
        1.1179507631307852,
        1.1210617340600142,
        1.1211234985576215,
        1.1090155122680851,
        1.1505621762563372,
        0.9567535269871313,
        1.793628127479447,
    ],
    [
        1.2010793168575624,
        1.118706317375275,
        1.1211438351159215,
        1.121323546330091,
        1.1086919169509557,
        1.1518612058312068,
        0.9500047479212407,
        1.8109745643007313,
    ],
    [
        1.2013963291857206,
        1.1194800282403738,
        1.1212175058167795,
        1.1215310496874316,
        1.1083454349321455,
        1.153302037163462,
        0.9418093272495782,
        1.8359233407971094,
    ],
    [
        1.2016339006696275,
        1.1202710249320156,
        1.121283571467479,
        1.1217444526820277,
        1.1079796374869906,
        1.1548699604547676,
        0.9321964759717327,
        1.8689853935787382,
    ],
    [
        1.2017981700150273,
        1.1210784928049076,
        1.1213427567435248,
        1.121962401004893,
        1.1075975545209562,
        1.1565522955622691,
        0.9211852536317545,
        1.910758044406395,
    ],
    [
        1.2018950007645617,
        1.1219016465193188,
        1.1213957112134483,
        1.1221836990868017,
        1.1072017810341737,
        1.1583379796583366,
        0.9087864998305089,
        1.9619267065803405,
    ],
    [
        1.2019300411641067,
        1.122739709445275,
        1.1214430288622883,
        1.1224072766636195,
        1.1067945616917145,
        1.160217229753024,
        0.8950045693288374,
        2.023266705770465,
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
        let a = alpha.to_f64();
        // The segment of the table: linear inside, extrapolated beyond the
        // first and last nodes.
        let step = 0.05;
        // The same libm routines on the host and the target (`num-traits`).
        let seg = (Float::floor(a / step) as usize).clamp(1, ORDERS - 1);
        let (lo, hi) = (G_TABLE[seg - 1], G_TABLE[seg]);
        let t = (a - step * seg as f64) / step;
        let (sin, cos) = (
            (core::f64::consts::PI * a).sin(),
            (core::f64::consts::PI * a).cos(),
        );
        let mut k = Self {
            alpha,
            rates: [T::zero(); MODES],
            coefficients: [T::zero(); MODES],
            derivatives: [T::zero(); MODES],
        };
        for m in 0..MODES {
            let s = 1.0 / DECAY_SAMPLES[m];
            let pow = Float::powf(s, 1.0 + a);
            let scale = -(sin / core::f64::consts::PI) * pow;
            let d_scale = -pow * (cos + (sin / core::f64::consts::PI) * Float::ln(s));
            let g = lo[m] + t * (hi[m] - lo[m]);
            let d_g = (hi[m] - lo[m]) / step;
            k.rates[m] = T::lit(Float::exp(-s));
            k.coefficients[m] = T::lit(scale * g);
            k.derivatives[m] = T::lit(d_scale * g + scale * d_g);
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
        // The reference study: 5.5e-3 at worst over α in [0.3, 0.999].
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
        assert!(worst < 6e-3, "{worst}");
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
    fn order_one_has_no_tail_and_bad_orders_are_refused() {
        let k = TailKernel::<f32>::new(1.0).unwrap();
        assert!(k.coefficients.iter().all(|c| c.abs() < 1e-12), "{k:?}");
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
