//! A value kept in a `static`, built at compile time and handed out once
//! as `&'static mut` (what `static_cell`'s `ConstStaticCell` does): how the
//! board gets its estimator task, built in place in its static
//! ([`crate::task::EstimatorTask::EMPTY`], then `init`), never on the stack.
//!
//! It owns the one-time hand-out and nothing else; what the value is and
//! how it is initialised is its owner's.

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicBool, Ordering};

/// A `static`'s value, taken once.
///
/// ```
/// use firmware::static_cell::TakeOnce;
///
/// static COUNTS: TakeOnce<[u32; 4]> = TakeOnce::new([0; 4]);
/// let c: &'static mut [u32; 4] = COUNTS.take().unwrap();
/// c[0] += 1;
/// assert!(COUNTS.take().is_none());
/// ```
pub struct TakeOnce<T> {
    taken: AtomicBool,
    value: UnsafeCell<T>,
}

// SAFETY: the value is reached only through `take`, which hands out one
// reference, once (the flag); `T: Send` because that `&mut` may be used on
// another thread or in another context than the one that made the static.
unsafe impl<T: Send> Sync for TakeOnce<T> {}

impl<T> TakeOnce<T> {
    /// Holds `value`: a `static`'s initialiser, evaluated at compile time.
    pub const fn new(value: T) -> Self {
        Self {
            taken: AtomicBool::new(false),
            value: UnsafeCell::new(value),
        }
    }

    /// The value, the first time it is asked for; `None` after.
    // A `&mut` from a shared reference is this type's purpose; the flag
    // makes it the only one.
    #[allow(clippy::mut_from_ref)]
    pub fn take(&'static self) -> Option<&'static mut T> {
        if self.taken.swap(true, Ordering::AcqRel) {
            return None;
        }
        // SAFETY: the flag was false and is now true, so this is the one
        // call that gets here: the `&mut` it returns is the only reference
        // to the value ever made, and it lives as long as the static.
        Some(unsafe { &mut *self.value.get() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_value_is_handed_out_once_and_kept() {
        static CELL: TakeOnce<[u32; 3]> = TakeOnce::new([1, 2, 3]);
        let a = CELL.take().expect("the first take");
        a[0] = 9;
        assert!(CELL.take().is_none());
        assert_eq!(*a, [9, 2, 3]);
    }
}
