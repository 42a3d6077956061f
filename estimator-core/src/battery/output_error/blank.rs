//! The refinement's blank value, built at compile time, and its
//! initialisation in place: a `static` estimator (the firmware's task) is
//! the blank value, then [`OutputErrorRefinement::init`] makes it what
//! [`OutputErrorRefinement::new`] returns without a copy of its arrays on
//! the stack.

use super::{OutputErrorRefinement, RefinementState, RefinementWork, Simulation, LAMBDA0};
use crate::battery::branch::{BranchSolver, GlRecursion};
use crate::battery::{BatterySettings, CellParameters};
use crate::error::Error;
use crate::frac::GlWeights;
use crate::real::Real;

/// No work done.
const NO_WORK: RefinementWork = RefinementWork {
    iterations: 0,
    simulations: 0,
    trials: 0,
    linearizations: 0,
};

impl<T: Real, const N: usize, const MEM: usize> OutputErrorRefinement<T, N, MEM, GlRecursion> {
    /// Every array 0, the parameters [`CellParameters::ZERO`], the weights
    /// [`GlWeights::BLANK`]: not a refinement until [`init`](Self::init).
    pub(crate) const BLANK: Self = Self {
        p: CellParameters::ZERO,
        solver: GlRecursion,
        lambda: T::ZERO,
        k: 0,
        w: GlWeights::BLANK,
        i: [T::ZERO; N],
        v: [T::ZERO; N],
        sims: [Simulation::ZERO, Simulation::ZERO],
        s_rct: [T::ZERO; N],
        s_q: [T::ZERO; N],
        s_a: [T::ZERO; N],
        s_ri: [T::ZERO; N],
        s_uoc: [T::ZERO; N],
        s_beta: [T::ZERO; N],
        s_bva: [T::ZERO; N],
        s_bvi0: [T::ZERO; N],
        c: [T::ZERO; N],
        beta: T::ZERO,
        kinetic_kept: 0,
        unobserved: 0,
        n: 0,
        warm: 0,
        past: None,
        stamp: None,
        held: 0,
        fresh: false,
        stalled: None,
        linear: None,
        information: None,
        evidence: None,
        work: NO_WORK,
    };
}

impl<T: Real, const N: usize, const MEM: usize, K: BranchSolver<T>>
    OutputErrorRefinement<T, N, MEM, K>
{
    /// Makes this refinement, whatever it held, the one
    /// [`new`](Self::new)`(s, start)` returns, in place: a refinement
    /// done with (a start given up, a fit whose estimate is taken) is
    /// started again without building another, so its arrays are written
    /// where they are instead of being built and moved.
    ///
    /// ```
    /// use estimator_core::battery::branch::GlRecursion;
    /// use estimator_core::battery::output_error::OutputErrorRefinement;
    /// use estimator_core::battery::{BatterySettings, CellParameters};
    ///
    /// let s = BatterySettings::new(1.0, 64);
    /// let cell = CellParameters::cell_18650();
    /// let mut oe = OutputErrorRefinement::<f64, 64, 64, GlRecursion>::new(&s, cell)?;
    /// let again = CellParameters { alpha: 0.6, ..cell };
    /// oe.init(&s, again)?;
    /// assert_eq!(oe.cell(), again);
    /// # Ok::<(), estimator_core::Error>(())
    /// ```
    ///
    /// # Errors
    /// As [`new`](Self::new); on error nothing changes.
    pub fn init(&mut self, s: &BatterySettings<T>, start: CellParameters<T>) -> Result<(), Error> {
        s.check::<MEM>()?;
        if !start.is_physical() || start.alpha < s.alpha_min || start.alpha > s.alpha_max {
            return Err(Error::BadSetting);
        }
        self.w.reset(start.alpha, s.h, s.memory)?;
        self.p = start;
        self.solver.reset();
        self.lambda = T::lit(LAMBDA0);
        self.k = 0;
        for sim in &mut self.sims {
            for a in [&mut sim.up, &mut sim.e, &mut sim.eta] {
                a.fill(T::ZERO);
            }
        }
        for a in [
            &mut self.i,
            &mut self.v,
            &mut self.s_rct,
            &mut self.s_q,
            &mut self.s_a,
            &mut self.s_ri,
            &mut self.s_uoc,
            &mut self.s_beta,
            &mut self.s_bva,
            &mut self.s_bvi0,
            &mut self.c,
        ] {
            a.fill(T::ZERO);
        }
        self.beta = T::ZERO;
        self.kinetic_kept = 0;
        self.unobserved = 0;
        self.n = 0;
        self.warm = 0;
        self.past = None;
        self.stamp = None;
        self.held = 0;
        self.fresh = false;
        self.stalled = None;
        self.linear = None;
        self.information = None;
        self.evidence = None;
        self.work = NO_WORK;
        Ok(())
    }
}

impl<T: Real> RefinementState<T> {
    /// Zeros: a blank cell's, until the cell is initialised.
    pub(crate) const BLANK: Self = Self {
        p: CellParameters::ZERO,
        lambda: T::ZERO,
        beta: T::ZERO,
        k: 0,
        work: NO_WORK,
    };
}
