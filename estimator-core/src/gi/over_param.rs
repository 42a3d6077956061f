//! 2S-OP-GI: the two-stage over-parameterization gradient-based iterative
//! algorithm (§3, eqs. 15–33).
//!
//! Stage 1 updates `ϑ = [a, c]`, stage 2 the over-parameterized
//! `θ = [b_i γ_j]`, each by a gradient step with exact line search; stage 3
//! searches the order α. `b` and `γ` are recovered from θ on demand
//! ([`HammersteinEstimate::factor`]).

use super::line_search::order_search;
use super::regression::{lag, linear_stage, Block, Params, Regression};
use super::{GiSettings, HammersteinEstimate, Iteration};
use crate::error::Error;
use crate::model::Basis;
use crate::real::{dist, Real};
use crate::window::SampleWindow;

/// The 2S-OP-GI estimator state for a window of capacity `N`, memory
/// capacity `MEM`, order capacities `NA, NB, NC`, basis capacity `NF` and
/// product capacity `NP ≥ n_b·m`.
///
/// ```
/// use estimator_core::gi::{over_param::OverParamGi, GiSettings};
/// use estimator_core::model::{Orders, Polynomial};
/// use estimator_core::window::SampleWindow;
///
/// let settings = GiSettings::<f64>::new(Orders::PAPER, 32);
/// let mut gi = OverParamGi::<f64, 64, 32, 2, 3, 2, 2, 6>::new(&settings, 0.5).unwrap();
/// let mut window = SampleWindow::<f64, 64>::new();
/// // Not enough data yet: a typed error, no panic, estimate unchanged.
/// assert!(gi.iterate(&settings, &Polynomial, &window).is_err());
/// for l in 0..64 {
///     let u = ((l * 7919) % 13) as f64 / 6.0 - 1.0;
///     window.push(u, 0.3 * u).unwrap();
/// }
/// let it = gi.iterate(&settings, &Polynomial, &window).unwrap();
/// assert_eq!(it.k, 1);
/// ```
#[derive(Clone, Debug)]
pub struct OverParamGi<
    T,
    const N: usize,
    const MEM: usize,
    const NA: usize,
    const NB: usize,
    const NC: usize,
    const NF: usize,
    const NP: usize,
> {
    est: HammersteinEstimate<T, NA, NB, NC, NF, NP>,
    k: u32,
    reg: Regression<T, N, MEM, NF>,
}

/// 2S-OP-GI sized for the paper's Example 1 orders (2/3/2, m = 2).
pub type PaperOverParamGi<T, const N: usize, const MEM: usize> =
    OverParamGi<T, N, MEM, 2, 3, 2, 2, 6>;

impl<
        T: Real,
        const N: usize,
        const MEM: usize,
        const NA: usize,
        const NB: usize,
        const NC: usize,
        const NF: usize,
        const NP: usize,
    > OverParamGi<T, N, MEM, NA, NB, NC, NF, NP>
{
    /// A new estimator with the paper's initial values (`1/p₀`) and the
    /// caller's initial order `alpha0`.
    ///
    /// # Errors
    /// Any settings error of [`GiSettings::check`], or
    /// [`Error::BadSetting`] for an `alpha0` outside the order bounds.
    pub fn new(s: &GiSettings<T>, alpha0: T) -> Result<Self, Error> {
        s.check::<MEM, NA, NB, NC, NF, NP>()?;
        s.check_alpha(alpha0)?;
        Ok(Self {
            est: HammersteinEstimate::initial(s.orders, alpha0),
            k: 0,
            reg: Regression::new(s, alpha0)?,
        })
    }

    /// Restarts from the paper's initial values with order `alpha0`.
    ///
    /// # Errors
    /// As [`OverParamGi::new`]; on error the state is unchanged.
    pub fn reset(&mut self, s: &GiSettings<T>, alpha0: T) -> Result<(), Error> {
        s.check::<MEM, NA, NB, NC, NF, NP>()?;
        s.check_alpha(alpha0)?;
        self.est = HammersteinEstimate::initial(s.orders, alpha0);
        self.k = 0;
        self.reg.invalidate();
        Ok(())
    }

    /// Starts from a given estimate (a warm start), keeping the counter.
    ///
    /// # Errors
    /// [`Error::BadSetting`] if the estimate has non-finite entries or an
    /// order outside `(0, 2)`.
    pub fn set_estimate(
        &mut self,
        est: HammersteinEstimate<T, NA, NB, NC, NF, NP>,
    ) -> Result<(), Error> {
        let finite = est
            .a
            .iter()
            .chain(&est.c)
            .chain(&est.products)
            .all(|x| x.is_finite());
        if !(finite && est.alpha > T::zero() && est.alpha < T::lit(2.0)) {
            return Err(Error::BadSetting);
        }
        self.est = est;
        self.reg.invalidate();
        Ok(())
    }

    /// The current (last good) estimate.
    pub fn estimate(&self) -> &HammersteinEstimate<T, NA, NB, NC, NF, NP> {
        &self.est
    }

    /// Iterations completed since the last reset.
    pub fn iterations(&self) -> u32 {
        self.k
    }

    /// Runs one 2S-OP-GI iteration on the window.
    ///
    /// # Errors
    /// Settings errors, [`Error::NotEnoughData`], [`Error::NotExcited`],
    /// [`Error::NonFiniteSample`] (a basis output overflowed) or
    /// [`Error::Diverged`]. On any error the estimate is unchanged.
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
        let min_rows = o.na + o.nc + o.products() + 1;
        self.reg.load(s, basis, window, alpha_prev, min_rows)?;

        let prev = self.est;
        let mut new = self.est;
        // ê_{k−1} from the previous estimate, then the residual.
        let pp = Params {
            o,
            a: &prev.a,
            c: &prev.c,
            p: &prev.products,
        };
        self.reg.noise_estimate(&pp);
        self.reg.residual(&pp);

        // Stage 1: ϑ = [a, c].
        {
            let (ch, res, q, rows) = self.reg.split();
            let mut ga = [T::zero(); NA];
            let mut gc = [T::zero(); NC];
            let col_a = |i: usize, l: usize| -lag(&ch.y, l, i + 1);
            let col_c = |i: usize, l: usize| -lag(&ch.e, l, i + 1);
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
            ];
            linear_stage(&mut blocks, rows, res, q);
        }
        // Stage 2: θ = [b_i γ_j], with the fresh ϑ.
        {
            let (ch, res, q, rows) = self.reg.split();
            let mut gp = [T::zero(); NP];
            let m = o.m;
            let col_p = |k: usize, l: usize| lag(&ch.f[k % m], l, k / m + 1);
            let mut blocks = [Block {
                params: &mut new.products[..o.products()],
                grad: &mut gp[..o.products()],
                col: &col_p,
            }];
            linear_stage(&mut blocks, rows, res, q);
        }
        // Stage 3: the order.
        let order_step = order_search(
            &mut self.reg,
            s,
            &Params {
                o,
                a: &new.a,
                c: &new.c,
                p: &new.products,
            },
        )?;
        new.alpha = self.reg.w.alpha();
        let cost = self.reg.cost();

        let change = dist(&new.a[..o.na], &prev.a[..o.na])
            + dist(&new.c[..o.nc], &prev.c[..o.nc])
            + dist(
                &new.products[..o.products()],
                &prev.products[..o.products()],
            )
            + (new.alpha - prev.alpha).abs();
        let finite = new
            .a
            .iter()
            .chain(&new.c)
            .chain(&new.products)
            .all(|x| x.is_finite())
            && cost.is_finite()
            && change.is_finite();
        if !finite {
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
