//! The global search before the descent: the fixed orders and the three
//! starts of the linear parameters ([`LinearStart`]) at each, and which
//! start won.

use super::*;

/// Where the linear parameters `[a, c, b_iγ_j]` of a start of the search
/// come from. At a fixed order the criterion can have a minimum for each way
/// of explaining the colour of the output: by the noise model C (small a) or
/// by the autoregression A (small c); each start below leads into one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LinearStart {
    /// The start estimate's (the paper stage's).
    Given,
    /// `a = 0`: least squares for `b_iγ_j`, then least squares for the
    /// noise model `c` on the equation error it leaves.
    NoiseModel,
    /// `c = 0`: least squares for `a` and `b_iγ_j` together (the
    /// equation-error fit).
    EquationError,
}

impl LinearStart {
    /// The starts in the order the search visits them at each order.
    pub const ALL: [LinearStart; 3] = [
        LinearStart::Given,
        LinearStart::NoiseModel,
        LinearStart::EquationError,
    ];

    pub(super) fn next(self) -> Option<Self> {
        match self {
            LinearStart::Given => Some(LinearStart::NoiseModel),
            LinearStart::NoiseModel => Some(LinearStart::EquationError),
            LinearStart::EquationError => None,
        }
    }
}

/// Where the refinement is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Phase {
    /// The global search: the linear parameters at the fixed order of start
    /// `start` (0: the start's own order, then the grid).
    Search {
        /// Index of the start's order.
        start: u8,
        /// Where its linear parameters start.
        linear: LinearStart,
    },
    /// The descent of every parameter, α included, from the winning start.
    Descent,
}

/// The start of the order search the descent began from.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WinningStart<T> {
    /// 0: the start estimate's own order; `g ≥ 1`: grid order `g`.
    pub index: u8,
    /// Where its linear parameters started.
    pub linear: LinearStart,
    /// The fixed order of that start.
    pub alpha: T,
    /// The criterion after the fit of the linear parameters at that order.
    pub cost: T,
}
impl<
        T: Real,
        const N: usize,
        const MEM: usize,
        const NA: usize,
        const NB: usize,
        const NC: usize,
        const NF: usize,
        const NP: usize,
        const NQ: usize,
    > PredictionErrorRefinement<T, N, MEM, NA, NB, NC, NF, NP, NQ>
{
    /// Builds the linear parameters of a start at the current order from
    /// zero by exact least squares on the parameters the criterion is
    /// linear in (the others held).
    pub(super) fn linear_start<B: Basis<T>>(
        &mut self,
        s: &PredictionErrorSettings<T>,
        basis: &B,
        window: &SampleWindow<T, N>,
        linear: LinearStart,
    ) -> Result<(), Error> {
        let o = s.gi.orders;
        let alpha = self.est.alpha;
        self.est = HammersteinEstimate {
            orders: o,
            a: [T::zero(); NA],
            c: [T::zero(); NC],
            products: [T::zero(); NP],
            alpha,
        };
        let (na, nc) = (o.na, o.nc);
        match linear {
            LinearStart::Given => Ok(()),
            LinearStart::NoiseModel => {
                self.least_squares(s, basis, window, |k| k >= na + nc)?;
                self.least_squares(s, basis, window, |k| k >= na && k < na + nc)
            }
            LinearStart::EquationError => {
                self.least_squares(s, basis, window, |k| k < na || k >= na + nc)
            }
        }
    }

    /// One Gauss–Newton step without damping on the linear parameters with
    /// `keep(k)` (exact least squares when the criterion is linear in them);
    /// the estimate is kept when the system is singular.
    pub(super) fn least_squares<B: Basis<T>>(
        &mut self,
        s: &PredictionErrorSettings<T>,
        basis: &B,
        window: &SampleWindow<T, N>,
        keep: impl Fn(usize) -> bool,
    ) -> Result<(), Error> {
        self.linearize(s, basis, window, false)?;
        let np = parameters(&s.gi);
        let (h, g) = self.normal_equations(np, keep);
        if let Some(step) = T::solve_spd(&h, &g) {
            apply_step(&mut self.est, &step[..np], false);
        }
        Ok(())
    }

    /// Ends the fit at start `start` (cost `cost`) and moves to the next
    /// start, or to the descent from the best.
    pub(super) fn next_start(
        &mut self,
        s: &PredictionErrorSettings<T>,
        at: (u8, LinearStart),
        cost: T,
    ) {
        if cost < self.best_cost {
            self.best_cost = cost;
            self.best = self.est;
            self.best_start = at;
        }
        self.at_start = 0;
        self.damping = T::lit(DAMPING0);
        let next = match at.1.next() {
            Some(linear) => Some((at.0, linear)),
            None if at.0 < s.grid_points => Some((at.0 + 1, LinearStart::Given)),
            None => None,
        };
        if let Some((start, linear)) = next {
            self.phase = Phase::Search { start, linear };
            self.est = self.start;
            self.est.alpha = s.start_order(start, self.start.alpha);
        } else {
            self.phase = Phase::Descent;
            self.est = self.best;
        }
    }
}
