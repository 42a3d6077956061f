//! The paper method's blank value, built at compile time, and its
//! initialisation in place: a `static` estimator (the firmware's task) is
//! the blank value, then [`PaperRegressionGi::init`] makes it what
//! [`PaperRegressionGi::new`] returns without a copy of its arrays on the
//! stack.

use super::{PaperRegressionGi, PaperRegressionState, P0};
use crate::battery::BatterySettings;
use crate::error::Error;
use crate::frac::{DirectSums, GlWeights};
use crate::real::Real;

impl<T: Real, const N: usize, const MEM: usize> PaperRegressionGi<T, N, MEM, DirectSums> {
    /// Every array 0, the weights [`GlWeights::BLANK`]: not an estimator
    /// until [`init`](Self::init).
    pub(crate) const BLANK: Self = Self {
        theta: [T::ZERO; 4],
        k: 0,
        w: GlWeights::BLANK,
        i: [T::ZERO; N],
        v: [T::ZERO; N],
        vref: None,
        di: [T::ZERO; N],
        hv: [T::ZERO; N],
        ddi: [T::ZERO; N],
        dhv: [T::ZERO; N],
        derivatives: false,
        order_moves: 0,
        trial_di: [T::ZERO; N],
        trial_hv: [T::ZERO; N],
        res: [T::ZERO; N],
        n: 0,
        stamp: None,
        sums: DirectSums,
    };

    /// Makes this estimator, whatever it held, the one
    /// [`new`](Self::new)`(s, alpha0)` returns, in place.
    ///
    /// # Errors
    /// As [`new`](Self::new); on error nothing changes.
    pub(crate) fn init(&mut self, s: &BatterySettings<T>, alpha0: T) -> Result<(), Error> {
        s.check::<MEM>()?;
        if !(alpha0.is_finite() && alpha0 >= s.alpha_min && alpha0 <= s.alpha_max) {
            return Err(Error::BadSetting);
        }
        self.w.reset(alpha0, s.h, s.memory)?;
        self.theta = [T::lit(1.0 / P0); 4];
        self.k = 0;
        for a in [
            &mut self.i,
            &mut self.v,
            &mut self.di,
            &mut self.hv,
            &mut self.ddi,
            &mut self.dhv,
            &mut self.trial_di,
            &mut self.trial_hv,
            &mut self.res,
        ] {
            a.fill(T::ZERO);
        }
        self.vref = None;
        self.derivatives = false;
        self.order_moves = 0;
        self.n = 0;
        self.stamp = None;
        Ok(())
    }
}

impl<T: Real> PaperRegressionState<T> {
    /// Zeros: a blank cell's, until the cell is initialised.
    pub(crate) const BLANK: Self = Self {
        theta: [T::ZERO; 4],
        alpha: T::ZERO,
        k: 0,
        order_moves: 0,
        vref: None,
    };
}
