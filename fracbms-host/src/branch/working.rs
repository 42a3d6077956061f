//! The working buffers of [`FftBranch`]'s calls, one set per thread
//! ([`Working`]): every solver of a thread (a fit's starts, the model
//! voltage after it) runs its calls in its thread's, since they hold
//! nothing between calls. It owns no transform and no spectrum kept by
//! value (that is [`super::transforms`]'s).

use std::cell::RefCell;

use realfft::num_complex::Complex;

use super::transforms::Transforms;
use super::FftBranch;

/// The working buffers of an [`FftBranch`] call: the transforms' input
/// and scratch, a spectrum and three sequences. They hold nothing between
/// calls, so every solver of a thread (a fit's starts, the model voltage
/// after it) takes its thread's, kept here: a 200 000-row record's are
/// 13 MB, touched once instead of once a start.
#[derive(Default)]
pub(super) struct Working {
    pub(super) t: Transforms,
    pub(super) spec: Vec<Complex<f64>>,
    pub(super) fx: Vec<f64>,
    pub(super) fy: Vec<f64>,
    pub(super) y: Vec<f64>,
    pub(super) series_hat: Vec<Complex<f64>>,
}

thread_local! {
    /// This thread's [`Working`] buffers, between calls.
    static WORKING: RefCell<Working> = RefCell::new(Working::default());
}

impl FftBranch {
    /// Runs `f` with the thread's [`Working`] buffers as this solver's (a
    /// call inside another keeps them), and gives them back after.
    pub(super) fn working<R>(&mut self, f: impl FnOnce(&mut Self) -> R) -> R {
        if self.in_call {
            return f(self);
        }
        self.swap_working();
        self.in_call = true;
        let r = f(self);
        self.in_call = false;
        self.swap_working();
        r
    }

    /// Exchanges the solver's working buffers with the thread's.
    fn swap_working(&mut self) {
        WORKING.with(|c| {
            // A thread's buffers are borrowed only here, never across a
            // call: the borrow cannot fail, but if it did the solver
            // would keep its own.
            if let Ok(mut w) = c.try_borrow_mut() {
                std::mem::swap(&mut self.work, &mut *w);
            }
        });
    }
}
