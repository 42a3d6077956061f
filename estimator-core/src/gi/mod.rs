//! The paper's two gradient-based iterative identification algorithms for
//! the fractional-order Hammerstein model of [`crate::model`]:
//!
//! * [`over_param::OverParamGi`] — 2S-OP-GI (§3, eqs. 15–33): the products
//!   `b_i γ_j` are identified as one over-parameterized vector θ, then split.
//! * [`key_term::KeyTermGi`] — KT-2S-GI (§4, eqs. 40–55): `b_1 = 1` and the
//!   key term separates γ from `b' = [b_2 … b_{n_b}]`.
//!
//! Both run one iteration per call over whatever a
//! [`SampleWindow`](crate::window::SampleWindow) holds, in three stages:
//! two linear stages, each a gradient step with an exact (closed-form) line
//! search, and a safeguarded one-dimensional search for the order α
//! ([`line_search`]). The noise estimate `ê(l)` is the residual of the system
//! part (see `docs/paper-errata.md` for this and every other deviation from
//! the printed equations).

pub mod key_term;
pub mod line_search;
pub mod over_param;
pub mod prediction_error;
mod regression;

pub use line_search::OrderStep;

use crate::error::Error;
use crate::model::Orders;
use crate::real::Real;

/// `p₀` of the paper's initialisation `θ̂₀ = 1/p₀`, `ϑ̂₀ = 1/p₀`.
pub const P0: f64 = 1e6;

/// What the samples before the first one held by the window are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Prehistory {
    /// The recording started from rest: everything before the first pushed
    /// sample is zero, so every row of the window can be used (as in the
    /// paper). Once the window slides this falls back to `Unknown`.
    AtRest,
    /// Unknown: only rows whose whole memory lies inside the window are used
    /// (the first `max_lag + M − 1` rows are skipped).
    Unknown,
}

/// Settings shared by both algorithms (kept apart from their state, so one
/// settings value can drive many estimators, e.g. one per cell).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GiSettings<T> {
    /// Structural orders.
    pub orders: Orders,
    /// Memory length M of the fractional differences (`1 ≤ M ≤ MEM`).
    pub memory: usize,
    /// Sample period h (1 for the dimensionless examples).
    pub h: T,
    /// The order search keeps α inside `[alpha_min, alpha_max] ⊂ (0, 2)`.
    pub alpha_min: T,
    /// Upper bound of α (see `alpha_min`).
    pub alpha_max: T,
    /// Stopping tolerance ε of step 6: converged when
    /// `‖Δϑ‖ + ‖Δθ‖ + |Δα| ≤ ε`.
    pub epsilon: T,
    /// Largest number of halvings of the order step before it is rejected.
    pub max_halvings: u8,
    /// Trust radius of the order search: `|α̂_k − α̂_{k−1}| ≤ max_order_step`.
    /// While the linear parameters are still far from their optimum a free
    /// Gauss–Newton step in α chases them into a wrong local minimum; a
    /// bounded step lets both parts converge together.
    pub max_order_step: T,
    /// Estimate α (true) or keep it fixed at its current value (false).
    pub estimate_order: bool,
    /// What precedes the window.
    pub prehistory: Prehistory,
}

impl<T: Real> GiSettings<T> {
    /// Defaults: `h = 1`, α in `[0.01, 1.99]`, `ε = 1e−6`, 12 halvings, order steps of at most 0.05, order
    /// estimated, data from rest.
    pub fn new(orders: Orders, memory: usize) -> Self {
        Self {
            orders,
            memory,
            h: T::one(),
            alpha_min: T::lit(0.01),
            alpha_max: T::lit(1.99),
            epsilon: T::lit(1e-6),
            max_halvings: 12,
            max_order_step: T::lit(0.05),
            estimate_order: true,
            prehistory: Prehistory::AtRest,
        }
    }

    /// Validates the settings against the capacities of an estimator.
    ///
    /// # Errors
    /// [`Error::OrderOutOfRange`], [`Error::ParameterCapacity`],
    /// [`Error::Frac`] for a bad memory or period, [`Error::BadSetting`] for
    /// order bounds outside `(0, 2)` or a negative/non-finite ε.
    pub fn check<
        const MEM: usize,
        const NA: usize,
        const NB: usize,
        const NC: usize,
        const NF: usize,
        const NP: usize,
    >(
        &self,
    ) -> Result<(), Error> {
        self.orders.check::<NA, NB, NC, NF, NP>()?;
        check_search::<T, MEM>(
            self.h,
            self.memory,
            [self.alpha_min, self.alpha_max],
            self.epsilon,
            self.max_order_step,
        )
    }

    /// Checks an initial or imposed order against the bounds.
    pub(crate) fn check_alpha(&self, alpha: T) -> Result<(), Error> {
        if alpha.is_finite() && alpha >= self.alpha_min && alpha <= self.alpha_max {
            Ok(())
        } else {
            Err(Error::BadSetting)
        }
    }
}

/// The checks every iterative estimator's settings share: a valid sample
/// period, `1 ≤ memory ≤ MEM`, order bounds inside `(0, 2)`, a finite
/// `ε ≥ 0` and a finite positive trust radius.
pub(crate) fn check_search<T: Real, const MEM: usize>(
    h: T,
    memory: usize,
    [alpha_min, alpha_max]: [T; 2],
    epsilon: T,
    max_order_step: T,
) -> Result<(), Error> {
    crate::frac::GlWeights::<T, 1>::new(T::lit(0.5), h, 1)?;
    if memory == 0 || memory > MEM {
        return Err(crate::error::FracError::BadMemory {
            requested: memory,
            capacity: MEM,
        }
        .into());
    }
    let ok = alpha_min.is_finite()
        && alpha_max.is_finite()
        && alpha_min > T::zero()
        && alpha_max < T::lit(2.0)
        && alpha_min <= alpha_max
        && epsilon.is_finite()
        && epsilon >= T::zero()
        && max_order_step > T::zero()
        && max_order_step.is_finite();
    if ok {
        Ok(())
    } else {
        Err(Error::BadSetting)
    }
}

/// What one iteration did.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Iteration<T> {
    /// Iteration counter k (1 for the first call after a reset).
    pub k: u32,
    /// α̂_k.
    pub alpha: T,
    /// Cost `½ Σ (y(l) − ŷ(l))²` over the rows used, after the iteration.
    pub cost: T,
    /// `‖ϑ̂_k − ϑ̂_{k−1}‖ + ‖θ̂_k − θ̂_{k−1}‖ + |α̂_k − α̂_{k−1}|`.
    pub change: T,
    /// `change ≤ ε` (step 6 of the paper).
    pub converged: bool,
    /// Outcome of the order search.
    pub order_step: OrderStep,
    /// Number of rows of the regression (samples used).
    pub rows: usize,
}

/// The identified Hammerstein parameters in the form both algorithms share:
/// `a`, `c`, the products `b_i γ_j` (what the data identify) and α.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HammersteinEstimate<
    T,
    const NA: usize,
    const NB: usize,
    const NC: usize,
    const NF: usize,
    const NP: usize,
> {
    /// Orders of the estimate.
    pub orders: Orders,
    /// `â_1 … â_{n_a}` (entries past `n_a` are zero).
    pub a: [T; NA],
    /// `ĉ_1 … ĉ_{n_c}`.
    pub c: [T; NC],
    /// `b_i γ_j` at index `i·m + j` (i-major, 0-based).
    pub products: [T; NP],
    /// α̂.
    pub alpha: T,
}

/// How to split the products `b_i γ_j` into `b` and `γ` (they are only
/// identified up to a common scale).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Normalization {
    /// `‖γ‖ = 1` and the first non-negligible `γ_j` positive.
    UnitGamma,
    /// `b_1 = 1` (the key-term normalization).
    UnitB1,
}

impl<
        T: Real,
        const NA: usize,
        const NB: usize,
        const NC: usize,
        const NF: usize,
        const NP: usize,
    > HammersteinEstimate<T, NA, NB, NC, NF, NP>
{
    /// The paper's initial values: every parameter `1/p₀`, order `alpha0`.
    pub fn initial(orders: Orders, alpha0: T) -> Self {
        let v = T::one() / T::lit(P0);
        let mut me = Self {
            orders,
            a: [T::zero(); NA],
            c: [T::zero(); NC],
            products: [T::zero(); NP],
            alpha: alpha0,
        };
        me.a.iter_mut().take(orders.na).for_each(|x| *x = v);
        me.c.iter_mut().take(orders.nc).for_each(|x| *x = v);
        me.products
            .iter_mut()
            .take(orders.products())
            .for_each(|x| *x = v);
        me
    }

    /// `b_i γ_j` (0-based `i < n_b`, `j < m`).
    pub fn product(&self, i: usize, j: usize) -> T {
        self.products[i * self.orders.m + j]
    }

    /// Writes `p = [a, c, b_1γ_1 … b_{n_b}γ_m, α]` into `out` and returns its
    /// length `n_a + n_c + n_b·m + 1` (or 0 if `out` is too short). This is
    /// the normalization-free vector the relative error δ is measured on.
    pub fn parameter_vector(&self, out: &mut [T]) -> usize {
        let o = self.orders;
        let len = o.na + o.nc + o.products() + 1;
        if out.len() < len {
            return 0;
        }
        let mut k = 0;
        for &x in self.a[..o.na]
            .iter()
            .chain(&self.c[..o.nc])
            .chain(&self.products[..o.products()])
        {
            out[k] = x;
            k += 1;
        }
        out[k] = self.alpha;
        len
    }

    /// Splits the products into `b` and `γ` by the best rank-one fit of the
    /// `n_b × m` matrix `[b_i γ_j]` (alternating least squares started from
    /// its largest row, the consistent form of eqs. 31–33), then scales by
    /// `norm`. Returns `None` when the products are all zero, or `b_1 ≈ 0`
    /// under [`Normalization::UnitB1`].
    pub fn factor(&self, norm: Normalization) -> Option<([T; NB], [T; NF])> {
        factor_rank_one::<T, NB, NF>(&self.products, self.orders.nb, self.orders.m, norm)
    }
}

/// Best rank-one factorization `P ≈ b γᵀ` of the i-major `nb × m` matrix
/// stored in `p`, normalized as asked.
pub(crate) fn factor_rank_one<T: Real, const NB: usize, const NF: usize>(
    p: &[T],
    nb: usize,
    m: usize,
    norm: Normalization,
) -> Option<([T; NB], [T; NF])> {
    if nb > NB || m > NF || p.len() < nb * m {
        return None;
    }
    let row = |i: usize| &p[i * m..(i + 1) * m];
    // Start from the row of largest norm (eq. 31 uses row 1, which fails when
    // b_1 = 0).
    let mut best = 0;
    let mut best_n = T::zero();
    for i in 0..nb {
        let n = crate::real::norm(row(i));
        if n > best_n {
            best_n = n;
            best = i;
        }
    }
    if best_n.is_zero() || !best_n.is_finite() {
        return None;
    }
    let mut g = [T::zero(); NF];
    g[..m].copy_from_slice(row(best));
    let mut b = [T::zero(); NB];
    for _ in 0..64 {
        let gg = crate::real::dot(&g[..m], &g[..m]);
        if gg.is_zero() {
            return None;
        }
        for (i, bi) in b.iter_mut().enumerate().take(nb) {
            *bi = crate::real::dot(row(i), &g[..m]) / gg;
        }
        let bb = crate::real::dot(&b[..nb], &b[..nb]);
        if bb.is_zero() {
            return None;
        }
        let mut change = T::zero();
        for j in 0..m {
            let mut s = T::zero();
            for (i, &bi) in b.iter().enumerate().take(nb) {
                s = s + p[i * m + j] * bi;
            }
            let new = s / bb;
            change = change + (new - g[j]).abs();
            g[j] = new;
        }
        if change <= T::epsilon() * T::lit(8.0) * crate::real::norm(&g[..m]) {
            break;
        }
    }
    let scale = match norm {
        Normalization::UnitGamma => {
            let n = crate::real::norm(&g[..m]);
            let first = g[..m]
                .iter()
                .copied()
                .find(|x| x.abs() > T::lit(1e-6) * n)?;
            if first < T::zero() {
                -n
            } else {
                n
            }
        }
        Normalization::UnitB1 => {
            if b[0].abs() <= T::epsilon() * crate::real::norm(&b[..nb]) {
                return None;
            }
            T::one() / b[0]
        }
    };
    for x in g[..m].iter_mut() {
        *x = *x / scale;
    }
    for x in b[..nb].iter_mut() {
        *x = *x * scale;
    }
    Some((b, g))
}
