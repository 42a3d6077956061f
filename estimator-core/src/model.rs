//! The identification model of the paper, eq. (4)/(5):
//!
//! ```text
//! y(l) = −Σ_{i=1}^{n_a} a_i Δ^α y(l−i)
//!        + Σ_{i=1}^{n_b} b_i Σ_{j=1}^{m} γ_j Δ^α f_j(u(l−i))
//!        − Σ_{i=1}^{n_c} c_i Δ^α e(l−i) + v(l)
//! e(l) = −Σ_{i=1}^{n_c} c_i Δ^α e(l−i) + v(l)
//! ```
//!
//! where `Δ^α x(l−i)` is the truncated-memory Grünwald–Letnikov difference of
//! [`crate::frac`] evaluated at time `l−i`. The static nonlinearity is
//! `f(u) = Σ γ_j f_j(u)` over a caller-supplied [`Basis`].

use crate::error::{Error, OrderKind};
use crate::frac::GlWeights;
use crate::real::Real;

/// Runtime structural orders, each at most its const-generic capacity.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Orders {
    /// Order of A(z) (number of output lags), may be 0.
    pub na: usize,
    /// Order of B(z) (number of input lags), at least 1.
    pub nb: usize,
    /// Order of the noise polynomial C(z), may be 0 (white equation error).
    pub nc: usize,
    /// Number of basis functions of the nonlinearity, at least 1.
    pub m: usize,
}

impl Orders {
    /// The paper's Example 1: `n_a = 2, n_b = 3, n_c = 2, m = 2`.
    pub const PAPER: Orders = Orders {
        na: 2,
        nb: 3,
        nc: 2,
        m: 2,
    };

    /// Number of over-parameterized system parameters `n_b · m`.
    pub const fn products(&self) -> usize {
        self.nb * self.m
    }

    /// Largest lag of any regressor, `max(n_a, n_b, n_c)`.
    pub const fn max_lag(&self) -> usize {
        let ab = if self.na > self.nb { self.na } else { self.nb };
        if ab > self.nc {
            ab
        } else {
            self.nc
        }
    }

    /// Checks the orders against the capacities `NA, NB, NC, NF` and the
    /// product capacity `NP ≥ n_b · m`.
    ///
    /// # Errors
    /// [`Error::OrderOutOfRange`] or [`Error::ParameterCapacity`].
    pub fn check<
        const NA: usize,
        const NB: usize,
        const NC: usize,
        const NF: usize,
        const NP: usize,
    >(
        &self,
    ) -> Result<(), Error> {
        let out = |which, value, capacity| {
            Err(Error::OrderOutOfRange {
                which,
                value,
                capacity,
            })
        };
        if self.na > NA {
            return out(OrderKind::Na, self.na, NA);
        }
        if self.nb == 0 || self.nb > NB {
            return out(OrderKind::Nb, self.nb, NB);
        }
        if self.nc > NC {
            return out(OrderKind::Nc, self.nc, NC);
        }
        if self.m == 0 || self.m > NF {
            return out(OrderKind::Basis, self.m, NF);
        }
        if self.products() > NP {
            return Err(Error::ParameterCapacity {
                needed: self.products(),
                capacity: NP,
            });
        }
        Ok(())
    }
}

/// The basis functions `f_1 … f_m` of the static nonlinearity.
///
/// `eval(j, u)` returns `f_{j+1}(u)` for `j = 0 … m−1`. Any
/// `Fn(usize, T) -> T` closure is a basis.
pub trait Basis<T> {
    /// `f_{j+1}(u)`.
    fn eval(&self, j: usize, u: T) -> T;
}

impl<T, F: Fn(usize, T) -> T> Basis<T> for F {
    fn eval(&self, j: usize, u: T) -> T {
        self(j, u)
    }
}

/// The polynomial basis `f_j(u) = u^j`, `j = 1 … m` (the paper's Example 1
/// uses `f(u) = γ_1 u + γ_2 u²`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Polynomial;

impl<T: Real> Basis<T> for Polynomial {
    fn eval(&self, j: usize, u: T) -> T {
        let mut p = u;
        for _ in 0..j {
            p = p * u;
        }
        p
    }
}

/// True parameters of eq. (4), borrowed as slices (for simulation and for
/// comparing estimates with the truth).
#[derive(Clone, Copy, Debug)]
pub struct HammersteinSystem<'a, T> {
    /// `a_1 … a_{n_a}`.
    pub a: &'a [T],
    /// `b_1 … b_{n_b}`.
    pub b: &'a [T],
    /// `c_1 … c_{n_c}`.
    pub c: &'a [T],
    /// `γ_1 … γ_m`.
    pub gamma: &'a [T],
    /// The commensurate order α.
    pub alpha: T,
}

impl<T: Real> HammersteinSystem<'_, T> {
    /// The orders of this system.
    pub fn orders(&self) -> Orders {
        Orders {
            na: self.a.len(),
            nb: self.b.len(),
            nc: self.c.len(),
            m: self.gamma.len(),
        }
    }

    /// Simulates eq. (4) from rest: given the input `u` and the white noise
    /// `v`, writes the output into `y` and the coloured noise `e = v / C` into
    /// `e`. All four slices must have the same length. The fractional
    /// differences use `weights` (order, period and memory); `weights.alpha()`
    /// should equal `self.alpha`.
    ///
    /// Cost: O(len · M · (n_a + n_c + n_b·m)).
    ///
    /// # Errors
    /// [`Error::BadSetting`] when the slice lengths differ or the orders
    /// are empty where they may not be; [`Error::Diverged`] when the output
    /// leaves the finite range (an unstable system).
    pub fn simulate<const MEM: usize>(
        &self,
        basis: &impl Basis<T>,
        weights: &GlWeights<T, MEM>,
        u: &[T],
        v: &[T],
        y: &mut [T],
        e: &mut [T],
    ) -> Result<(), Error> {
        let n = u.len();
        if v.len() != n
            || y.len() != n
            || e.len() != n
            || self.b.is_empty()
            || self.gamma.is_empty()
        {
            return Err(Error::BadSetting);
        }
        let f = |l: usize| -> T {
            self.gamma
                .iter()
                .enumerate()
                .fold(T::zero(), |s, (j, &g)| s + g * basis.eval(j, u[l]))
        };
        for l in 0..n {
            let mut en = v[l];
            for (i, &ci) in self.c.iter().enumerate() {
                let lag = i + 1;
                if l >= lag {
                    en = en - ci * weights.difference(&e[..l], l - lag);
                }
            }
            e[l] = en;
            let mut yn = en;
            for (i, &ai) in self.a.iter().enumerate() {
                let lag = i + 1;
                if l >= lag {
                    yn = yn - ai * weights.difference(&y[..l], l - lag);
                }
            }
            for (i, &bi) in self.b.iter().enumerate() {
                let lag = i + 1;
                if l >= lag {
                    yn = yn + bi * weights.difference_by(l - lag, f);
                }
            }
            if !yn.is_finite() {
                return Err(Error::Diverged);
            }
            y[l] = yn;
        }
        Ok(())
    }
}
