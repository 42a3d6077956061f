//! The pack's current history (one ring for all cells) and a cell's view of
//! it with its own voltages ([`CellWindow`], the window the estimators fit).

use super::*;
use crate::real::Real;
use crate::tail::PastModes;
use crate::window::Window;

/// The current history a pack keeps once for all its cells: the last `N`
/// currents (A), in a ring aligned with every cell's voltages.
#[derive(Clone, Debug)]
pub struct CurrentHistory<T, const N: usize> {
    pub(super) i: [T; N],
    /// Where the next current goes.
    pub(super) head: usize,
    /// Currents held (at most `N`).
    pub(super) count: usize,
}

impl<T: Real, const N: usize> CurrentHistory<T, N> {
    /// An empty history.
    pub const fn new() -> Self {
        Self {
            i: [T::ZERO; N],
            head: 0,
            count: 0,
        }
    }

    /// Empties the history in place (as [`new`](Self::new) makes it).
    pub(crate) fn clear(&mut self) {
        self.i.fill(T::ZERO);
        self.head = 0;
        self.count = 0;
    }

    /// The newest current, if any.
    pub fn newest(&self) -> Option<T> {
        (self.count > 0).then(|| self.i[(self.head + N - 1) % N])
    }

    /// Currents held.
    pub fn len(&self) -> usize {
        self.count
    }

    /// True when no current is held.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The ring slot the next current (and every cell's next voltage) goes
    /// to.
    pub(super) fn slot(&self) -> usize {
        // `head` is always reduced mod N; reducing again lets the optimizer
        // see the slot in the ring (a mask for the power-of-two windows).
        self.head % N
    }

    /// The newest `n` currents (at most those held) as the ring's two runs:
    /// the newest first reads the first run backwards, then the second
    /// backwards (two plain slice loops where a chained iterator branches
    /// at every element).
    pub(super) fn newest_runs(&self, n: usize) -> (&[T], &[T]) {
        let n = n.min(self.count);
        let (near, far) = self.i.split_at(self.slot());
        let a = near.len().min(n);
        let b = far.len().min(n - a);
        // (a ≤ near.len() and b ≤ far.len(): the slices always exist.)
        (
            near.get(near.len() - a..).unwrap_or_default(),
            far.get(far.len() - b..).unwrap_or_default(),
        )
    }

    pub(crate) fn push(&mut self, current: T) {
        let slot = self.slot();
        self.i[slot] = current;
        self.head = (slot + 1) % N;
        self.count = (self.count + 1).min(N);
    }
}

impl<T: Real, const N: usize> Default for CurrentHistory<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

/// One cell's window: the pack's current history with the cell's own
/// voltages (the last [`len`](Window::len) samples of the ring, which may be
/// fewer than the pack's after the cell's window restarted).
#[derive(Clone, Copy, Debug)]
pub struct CellWindow<'a, T, const N: usize> {
    pub(super) history: &'a CurrentHistory<T, N>,
    pub(super) cell: &'a CellState<T, N>,
}

impl<'a, T: Real, const N: usize> CellWindow<'a, T, N> {
    pub(crate) fn new(history: &'a CurrentHistory<T, N>, cell: &'a CellState<T, N>) -> Self {
        Self { history, cell }
    }

    /// Samples held.
    pub fn len(&self) -> usize {
        usize::from(self.cell.len)
    }

    /// True when no sample is held.
    pub fn is_empty(&self) -> bool {
        self.cell.len == 0
    }

    /// The held pairs `(I, U)`, newest first ([`Window::recent`] for the
    /// view's whole lifetime).
    pub fn newest_first(self) -> impl Iterator<Item = (T, T)> + 'a {
        let head = self.history.slot();
        let (i, u) = (&self.history.i, &self.cell.u);
        let currents = i[..head].iter().rev().chain(i[head..].iter().rev());
        let voltages = u[..head].iter().rev().chain(u[head..].iter().rev());
        currents
            .zip(voltages)
            .take(usize::from(self.cell.len))
            .map(|(&i, &u)| (i, u))
    }

    /// The largest current magnitude the window holds (A; 0 when empty, a
    /// NaN never taken): the ring's runs read directly.
    pub fn largest_current(&self) -> T {
        let (near, far) = self.history.newest_runs(self.len());
        let larger = |m: T, &i: &T| if i.abs() > m { i.abs() } else { m };
        let m = near.iter().fold(T::zero(), larger);
        far.iter().fold(m, larger)
    }

    /// Samples accepted into this window since its last restart (substitutes
    /// of rejected samples included).
    pub fn pushed(&self) -> u64 {
        self.cell.pushed
    }
}

impl<T: Real, const N: usize> Window<T> for CellWindow<'_, T, N> {
    fn len(&self) -> usize {
        usize::from(self.cell.len)
    }
    fn version(&self) -> u32 {
        self.cell.version
    }
    fn has_slid(&self) -> bool {
        self.cell.pushed > u64::from(self.cell.len)
    }
    fn starts_at_rest(&self) -> bool {
        self.cell.at_rest
    }
    fn recent(&self) -> impl Iterator<Item = (T, T)> + '_ {
        self.newest_first()
    }
    fn past(&self) -> Option<PastModes<T>> {
        (self.cell.past.count > 0).then_some(self.cell.past)
    }
    fn copy_into(&self, u: &mut [T], y: &mut [T]) -> usize {
        let len = usize::from(self.cell.len).min(u.len()).min(y.len());
        let head = self.history.slot();
        let (si, sv) = (&self.history.i, &self.cell.u);
        // The oldest `len` of the held samples are the ones copied when
        // the slices are short (as `SampleWindow::copy_into`).
        let held = usize::from(self.cell.len);
        let start = (head + N - held) % N;
        for k in 0..len {
            let j = (start + k) % N;
            u[k] = si[j];
            y[k] = sv[j];
        }
        len
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The two runs read backwards are the newest currents, newest first,
    /// before and after the ring wraps, for every count asked.
    #[test]
    fn the_newest_runs_are_the_newest_currents() {
        let mut h = CurrentHistory::<f64, 8>::new();
        for pushed in 1..=20u32 {
            h.push(f64::from(pushed));
            for n in 0..=10 {
                let (near, far) = h.newest_runs(n);
                let got: heapless::Vec<f64, 8> =
                    near.iter().rev().chain(far.iter().rev()).copied().collect();
                let held = h.len().min(n);
                assert_eq!(got.len(), held, "pushed {pushed}, n {n}");
                for (k, &x) in got.iter().enumerate() {
                    assert_eq!(x, f64::from(pushed) - k as f64, "pushed {pushed}, n {n}");
                }
            }
        }
    }
}
