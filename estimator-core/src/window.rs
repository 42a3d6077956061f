//! The sliding data window: the last `n ≤ N` input/output sample pairs.
//!
//! Pushing is O(1): when the window is full the oldest pair is dropped. A
//! NaN or infinite sample is rejected (and counted) before it can reach the
//! window, so a window only ever holds finite data and no good sample is
//! lost because of a bad one.
//!
//! The estimators read a window through [`Window`], so that a pack of cells
//! can keep the current once for all cells and each cell's voltages apart
//! ([`crate::battery::pack`]); [`SampleWindow`] is the window of one
//! system that owns both.

use heapless::Deque;

use crate::error::Error;
use crate::real::Real;

/// What an estimator reads from a sliding window of `(input, output)`
/// pairs. Implemented by [`SampleWindow`] and by a pack's per-cell view.
pub trait Window<T: Real> {
    /// Number of pairs held.
    fn len(&self) -> usize;
    /// True when no pair is held.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// A number that changes with every change of the contents: one push
    /// adds exactly one (caches keyed on the window rely on it).
    fn version(&self) -> u32;
    /// True once the window has dropped a pair (the samples before the
    /// oldest one held are then unknown, not zero).
    fn has_slid(&self) -> bool;
    /// True when the window began at rest: until it slides, the samples
    /// before its first are rest (a model's state there zero), whatever
    /// the estimator's settings say of a window's start (a window restarted
    /// at a rested cell after a gap in the record).
    fn starts_at_rest(&self) -> bool {
        false
    }
    /// The held pairs, newest first.
    fn recent(&self) -> impl Iterator<Item = (T, T)> + '_;
    /// Copies the held pairs, oldest first, into `u` and `y`; returns how
    /// many were copied (the window length, or less if the slices are
    /// shorter).
    fn copy_into(&self, u: &mut [T], y: &mut [T]) -> usize;
    /// The modes of the samples that left the window
    /// ([`crate::tail::PastModes`]); `None` when they are not kept (the
    /// past is then taken as rest).
    fn past(&self) -> Option<crate::tail::PastModes<T>> {
        None
    }
}

impl<T: Real, const N: usize> Window<T> for SampleWindow<T, N> {
    fn len(&self) -> usize {
        SampleWindow::len(self)
    }
    fn version(&self) -> u32 {
        SampleWindow::version(self)
    }
    fn has_slid(&self) -> bool {
        SampleWindow::has_slid(self)
    }
    fn recent(&self) -> impl Iterator<Item = (T, T)> + '_ {
        SampleWindow::recent(self)
    }
    fn copy_into(&self, u: &mut [T], y: &mut [T]) -> usize {
        SampleWindow::copy_into(self, u, y)
    }
}

/// A ring buffer of `(input, output)` sample pairs with capacity `N`.
///
/// For the Hammerstein model the pair is `(u(l), y(l))`; for the battery model
/// it is `(I(l), U_t(l))`.
#[derive(Clone, Debug)]
pub struct SampleWindow<T, const N: usize> {
    u: Deque<T, N>,
    y: Deque<T, N>,
    pushed: u64,
    rejected: u32,
    version: u32,
}

impl<T: Real, const N: usize> Default for SampleWindow<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real, const N: usize> SampleWindow<T, N> {
    /// An empty window.
    pub const fn new() -> Self {
        Self {
            u: Deque::new(),
            y: Deque::new(),
            pushed: 0,
            rejected: 0,
            version: 0,
        }
    }

    /// Appends one sample pair, dropping the oldest when full.
    ///
    /// # Errors
    /// [`Error::NonFiniteSample`] when `u` or `y` is NaN or infinite; the pair
    /// is not stored and the rejection is counted.
    pub fn push(&mut self, u: T, y: T) -> Result<(), Error> {
        if !(u.is_finite() && y.is_finite()) {
            self.rejected = self.rejected.saturating_add(1);
            return Err(Error::NonFiniteSample);
        }
        if self.u.is_full() {
            let _ = self.u.pop_front();
            let _ = self.y.pop_front();
        }
        // Cannot fail: one slot was freed above when full.
        let _ = self.u.push_back(u);
        let _ = self.y.push_back(y);
        self.pushed += 1;
        self.version = self.version.wrapping_add(1);
        Ok(())
    }

    /// Number of pairs held.
    pub fn len(&self) -> usize {
        self.u.len()
    }
    /// True when no pair is held.
    pub fn is_empty(&self) -> bool {
        self.u.is_empty()
    }
    /// True when `N` pairs are held (the next push drops the oldest).
    pub fn is_full(&self) -> bool {
        self.u.is_full()
    }
    /// The capacity `N`.
    pub const fn capacity(&self) -> usize {
        N
    }
    /// Pairs accepted since creation (or the last [`clear`](Self::clear)).
    pub fn pushed(&self) -> u64 {
        self.pushed
    }
    /// Pairs rejected as non-finite since creation.
    pub fn rejected(&self) -> u32 {
        self.rejected
    }
    /// A number that changes with every change of the contents (a push or
    /// a [`clear`](Self::clear)), for caches keyed on the window: one push
    /// adds exactly one, and a value repeats only after 2³² changes (a cache
    /// that looks at every sample never sees that).
    pub fn version(&self) -> u32 {
        self.version
    }
    /// True once the window has dropped a pair: the samples before the
    /// oldest one held are then unknown (not zero).
    pub fn has_slid(&self) -> bool {
        self.pushed > self.u.len() as u64
    }
    /// Empties the window and resets the counters (not the
    /// [`version`](Self::version), which moves on).
    pub fn clear(&mut self) {
        self.u.clear();
        self.y.clear();
        self.pushed = 0;
        self.rejected = 0;
        self.version = self.version.wrapping_add(1);
    }

    /// The held inputs, oldest first.
    pub fn inputs(&self) -> impl Iterator<Item = T> + '_ {
        self.u.iter().copied()
    }
    /// The held outputs, oldest first.
    pub fn outputs(&self) -> impl Iterator<Item = T> + '_ {
        self.y.iter().copied()
    }

    /// The held pairs, newest first.
    pub fn recent(&self) -> impl Iterator<Item = (T, T)> + '_ {
        self.u
            .iter()
            .rev()
            .copied()
            .zip(self.y.iter().rev().copied())
    }

    /// Copies the held pairs, oldest first, into `u` and `y`; returns how many
    /// were copied (the window length, or less if the slices are shorter).
    pub fn copy_into(&self, u: &mut [T], y: &mut [T]) -> usize {
        let mut n = 0;
        for ((du, dy), (&su, &sy)) in u
            .iter_mut()
            .zip(y.iter_mut())
            .zip(self.u.iter().zip(self.y.iter()))
        {
            *du = su;
            *dy = sy;
            n += 1;
        }
        n
    }
}
