//! KT-2S-GI: the key-term separation two-stage gradient-based iterative
//! algorithm (§4, eqs. 40–55).
//!
//! With `b_1 = 1` the intermediate variable `x(l−1) = Σ γ_j f_j(u(l−1))` is the
//! key term: the model is linear in `ϑ = [a, c, γ]` for fixed
//! `b' = [b_2 … b_{n_b}]` and linear in `b'` for fixed γ. Stage 1 updates ϑ,
//! stage 2 updates `b'`, each by a gradient step with exact line search on the
//! true cost; stage 3 searches the order α.

use super::line_search::order_search;
use super::regression::{lag, linear_stage, Block, Params, Regression};
use super::{GiSettings, HammersteinEstimate, Iteration, P0};
use crate::error::Error;
use crate::model::{Basis, Orders};
use crate::real::{dist, Real};
use crate::window::SampleWindow;

/// The KT-2S-GI parameters: `a`, `c`, `γ`, `b` with `b_1 = 1`, and α.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KeyTermEstimate<T, const NA: usize, const NB: usize, const NC: usize, const NF: usize> {
    /// Orders of the estimate.
    pub orders: Orders,
    /// `â`.
    pub a: [T; NA],
    /// `ĉ`.
    pub c: [T; NC],
    /// `γ̂`.
    pub gamma: [T; NF],
    /// `b̂` with `b̂_1 = 1` (so `b̂' = b[1..n_b]`).
    pub b: [T; NB],
    /// α̂.
    pub alpha: T,
}

impl<T: Real, const NA: usize, const NB: usize, const NC: usize, const NF: usize>
    KeyTermEstimate<T, NA, NB, NC, NF>
{
    /// The paper's initial values: `ϑ̂₀ = 1/p₀`, `b̂'₀ = 1/p₀`, `b_1 = 1`.
    pub fn initial(orders: Orders, alpha0: T) -> Self {
        let v = T::one() / T::lit(P0);
        let mut me = Self {
            orders,
            a: [T::zero(); NA],
            c: [T::zero(); NC],
            gamma: [T::zero(); NF],
            b: [T::zero(); NB],
            alpha: alpha0,
        };
        me.a.iter_mut().take(orders.na).for_each(|x| *x = v);
        me.c.iter_mut().take(orders.nc).for_each(|x| *x = v);
        me.gamma.iter_mut().take(orders.m).for_each(|x| *x = v);
        me.b.iter_mut().take(orders.nb).for_each(|x| *x = v);
        if NB > 0 {
            me.b[0] = T::one();
        }
        me
    }

    /// The same estimate in the shared products form.
    pub fn to_products<const NP: usize>(&self) -> HammersteinEstimate<T, NA, NB, NC, NF, NP> {
        let o = self.orders;
        let mut p = [T::zero(); NP];
        for i in 0..o.nb {
            for j in 0..o.m {
                if let Some(x) = p.get_mut(i * o.m + j) {
                    *x = self.b[i] * self.gamma[j];
                }
            }
        }
        HammersteinEstimate {
            orders: o,
            a: self.a,
            c: self.c,
            products: p,
            alpha: self.alpha,
        }
    }

    fn all_finite(&self) -> bool {
        self.a
            .iter()
            .chain(&self.c)
            .chain(&self.gamma)
            .chain(&self.b)
            .all(|x| x.is_finite())
            && self.alpha.is_finite()
    }
}

/// The KT-2S-GI estimator state (capacities as in
/// [`OverParamGi`](super::over_param::OverParamGi); `NP ≥ n_b·m` sizes the
/// products used for the noise estimate).
///
/// ```
/// use estimator_core::gi::{key_term::KeyTermGi, GiSettings};
/// use estimator_core::model::{Orders, Polynomial};
/// use estimator_core::window::SampleWindow;
///
/// let settings = GiSettings::<f32>::new(Orders::PAPER, 16);
/// let mut gi = KeyTermGi::<f32, 48, 16, 2, 3, 2, 2, 6>::new(&settings, 0.3).unwrap();
/// let mut window = SampleWindow::<f32, 48>::new();
/// for l in 0..48 {
///     let u = ((l * 31) % 11) as f32 / 5.0 - 1.0;
///     window.push(u, u).unwrap();
/// }
/// let it = gi.iterate(&settings, &Polynomial, &window).unwrap();
/// assert!(it.cost.is_finite());
/// assert_eq!(gi.estimate().b[0], 1.0);
/// ```
#[derive(Clone, Debug)]
pub struct KeyTermGi<
    T,
    const N: usize,
    const MEM: usize,
    const NA: usize,
    const NB: usize,
    const NC: usize,
    const NF: usize,
    const NP: usize,
> {
    est: KeyTermEstimate<T, NA, NB, NC, NF>,
    k: u32,
    reg: Regression<T, N, MEM, NF>,
}

/// KT-2S-GI sized for the paper's Example 1 orders (2/3/2, m = 2).
pub type PaperKeyTermGi<T, const N: usize, const MEM: usize> = KeyTermGi<T, N, MEM, 2, 3, 2, 2, 6>;

impl<
        T: Real,
        const N: usize,
        const MEM: usize,
        const NA: usize,
        const NB: usize,
        const NC: usize,
        const NF: usize,
        const NP: usize,
    > KeyTermGi<T, N, MEM, NA, NB, NC, NF, NP>
{
    /// A new estimator with the paper's initial values and order `alpha0`.
    ///
    /// # Errors
    /// Any settings error of [`GiSettings::check`], or
    /// [`Error::BadSetting`] for an `alpha0` outside the order bounds.
    pub fn new(s: &GiSettings<T>, alpha0: T) -> Result<Self, Error> {
        s.check::<MEM, NA, NB, NC, NF, NP>()?;
        s.check_alpha(alpha0)?;
        Ok(Self {
            est: KeyTermEstimate::initial(s.orders, alpha0),
            k: 0,
            reg: Regression::new(s, alpha0)?,
        })
    }

    /// Restarts from the paper's initial values with order `alpha0`.
    ///
    /// # Errors
    /// As [`KeyTermGi::new`]; on error the state is unchanged.
    pub fn reset(&mut self, s: &GiSettings<T>, alpha0: T) -> Result<(), Error> {
        s.check::<MEM, NA, NB, NC, NF, NP>()?;
        s.check_alpha(alpha0)?;
        self.est = KeyTermEstimate::initial(s.orders, alpha0);
        self.k = 0;
        self.reg.invalidate();
        Ok(())
    }

    /// The current (last good) estimate.
    pub fn estimate(&self) -> &KeyTermEstimate<T, NA, NB, NC, NF> {
        &self.est
    }

    /// The current estimate with the products `b_i γ_j`.
    pub fn products(&self) -> HammersteinEstimate<T, NA, NB, NC, NF, NP> {
        self.est.to_products()
    }

    /// Iterations completed since the last reset.
    pub fn iterations(&self) -> u32 {
        self.k
    }

    /// Runs one KT-2S-GI iteration on the window.
    ///
    /// # Errors
    /// As [`OverParamGi::iterate`](super::over_param::OverParamGi::iterate).
    pub fn iterate<B: Basis<T>>(
        &mut self,
        s: &GiSettings<T>,
        basis: &B,
        window: &SampleWindow<T, N>,
    ) -> Result<Iteration<T>, Error> {
        s.check::<MEM, NA, NB, NC, NF, NP>()?;
        if s.orders != self.est.orders {
            return Err(Error::BadSetting);
        }
        let o = s.orders;
        let alpha_prev = self.est.alpha.max(s.alpha_min).min(s.alpha_max);
        let min_rows = o.na + o.nc + o.m + o.nb;
        self.reg.load(s, basis, window, alpha_prev, min_rows)?;

        let prev = self.est;
        let mut new = self.est;
        let pp: HammersteinEstimate<T, NA, NB, NC, NF, NP> = prev.to_products();
        let params = Params {
            o,
            a: &pp.a,
            c: &pp.c,
            p: &pp.products,
        };
        self.reg.noise_estimate(&params);
        self.reg.residual(&params);

        // Stage 1: ϑ = [a, c, γ] for fixed b (b_1 = 1): the γ column is the
        // B-filtered basis output Σ_i b_i Δ^α f_j(u(l−i)).
        {
            let (ch, res, q, rows) = self.reg.split();
            let mut ga = [T::zero(); NA];
            let mut gc = [T::zero(); NC];
            let mut gg = [T::zero(); NF];
            let b = prev.b;
            let col_a = |i: usize, l: usize| -lag(&ch.y, l, i + 1);
            let col_c = |i: usize, l: usize| -lag(&ch.e, l, i + 1);
            let col_g = |j: usize, l: usize| {
                (0..o.nb).fold(T::zero(), |s, i| s + b[i] * lag(&ch.f[j], l, i + 1))
            };
            let mut blocks = [
                Block {
                    params: &mut new.a[..o.na],
                    grad: &mut ga[..o.na],
                    col: &col_a,
                },
                Block {
                    params: &mut new.c[..o.nc],
                    grad: &mut gc[..o.nc],
                    col: &col_c,
                },
                Block {
                    params: &mut new.gamma[..o.m],
                    grad: &mut gg[..o.m],
                    col: &col_g,
                },
            ];
            linear_stage(&mut blocks, rows, res, q);
        }
        // Stage 2: b' = [b_2 … b_{n_b}] with the fresh γ: column
        // Σ_j γ_j Δ^α f_j(u(l−i)), i = 2 … n_b.
        if o.nb > 1 {
            let (ch, res, q, rows) = self.reg.split();
            let mut gb = [T::zero(); NB];
            let gamma = new.gamma;
            let col_b = |k: usize, l: usize| {
                (0..o.m).fold(T::zero(), |s, j| s + gamma[j] * lag(&ch.f[j], l, k + 2))
            };
            let mut blocks = [Block {
                params: &mut new.b[1..o.nb],
                grad: &mut gb[1..o.nb],
                col: &col_b,
            }];
            linear_stage(&mut blocks, rows, res, q);
        }
        // Stage 3: the order.
        let np: HammersteinEstimate<T, NA, NB, NC, NF, NP> = new.to_products();
        let order_step = order_search(
            &mut self.reg,
            s,
            &Params {
                o,
                a: &np.a,
                c: &np.c,
                p: &np.products,
            },
        )?;
        new.alpha = self.reg.w.alpha();
        let cost = self.reg.cost();

        let change = dist(&new.a[..o.na], &prev.a[..o.na])
            + dist(&new.c[..o.nc], &prev.c[..o.nc])
            + dist(&new.gamma[..o.m], &prev.gamma[..o.m])
            + dist(&new.b[..o.nb], &prev.b[..o.nb])
            + (new.alpha - prev.alpha).abs();
        if !new.all_finite() || !cost.is_finite() || !change.is_finite() {
            self.reg.invalidate();
            return Err(Error::Diverged);
        }
        self.est = new;
        self.k += 1;
        Ok(Iteration {
            k: self.k,
            alpha: new.alpha,
            cost,
            change,
            converged: change <= s.epsilon,
            order_step,
            rows: self.reg.rows().len(),
        })
    }
}
