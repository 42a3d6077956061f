//! The pack estimator: every series cell of a battery pack on one MCU.
//!
//! The cells of a series string share one current, so the pack keeps the
//! current history once ([`CurrentHistory`]) and each cell only what it must
//! carry between samples ([`CellState`]: its voltages in the same ring, its
//! estimate, state of charge, counters and the iteration state of its
//! estimators; under 2 KiB at `(L, M) = (256, 64)` in `f32`). The
//! window-length arrays an iteration needs (regressors, simulations,
//! sensitivities, trial steps) are in one [`WorkingArea`] shared by all
//! cells: a cell is iterated at a time, and the area is reloaded when it
//! passes to another cell.
//!
//! Every sample period ([`PackEstimator::push`]):
//!
//! 1. **Every cell takes its sample.** Each voltage is validated on its own
//!    (the checks of [`super::online`]); a bad one is rejected, counted for
//!    that cell and substituted, without touching the other cells. Nothing
//!    is lost: every cell's window moves with the pack's current.
//! 2. **Scheduled updates.** [`PackSettings::updates_per_period`] cells are
//!    updated (each runs [`OnlineSettings::iterations_per_sample`]
//!    iterations), round robin from where the last period stopped, so the
//!    work of every period is the same bounded amount and every cell is
//!    updated at least every `⌈cells / updates⌉` periods
//!    ([`PackEstimator::refresh_periods`]).
//! 3. **Polarization.** Every cell's [`PolarizationTail`] follows its
//!    estimate's polarization: taken from a fresh fit's simulation,
//!    carried one sample on otherwise (rests of any length included), so
//!    any cell's state of power can be asked at any time
//!    ([`PackEstimator::state_of_power`]; the string's,
//!    the weakest cell's: [`PackEstimator::pack_state_of_power`]). At
//!    each clean current step whose predicted drop stands above the
//!    cell's voltage noise, the pulse that follows is checked against the
//!    state of power's prediction of it ([`PulseCheck`]); what it missed
//!    by widens the states of power after it.
//! 4. **Health.** [`PackEstimator::health`] sets each cell's `R_i` and
//!    `R_ct` beside the pack's median and flags a cell whose resistance
//!    stands out by more than [`PackSettings::flag_ratio`] (an aged or
//!    failing cell).
//!
//! The module owns the schedule and the health; the per-cell algorithm is
//! [`super::online`]'s (a [`super::online::CellEstimator`] is the one-cell
//! pack).

use super::power::{
    same_pulse, PolarizationTail, PowerReport, PowerSettings, PulseCheck, PulsePredictor,
    MAX_HORIZONS,
};
use super::tracker::{
    check_limits, CellState, CellWindow, CurrentHistory, OnlineSettings, SampleReport, WorkingArea,
};
use super::CellParameters;
use crate::error::Error;
use crate::frac::GlWeights;
use crate::real::Real;

mod checking;

/// Settings of a pack: the cells' online settings (one value for all
/// cells), the schedule and the health threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PackSettings<T, const P: usize = 0> {
    /// The settings every cell runs with.
    pub cell: OnlineSettings<T, P>,
    /// Cell updates per sample period (the per-period budget: each costs
    /// about the same, measured by `cargo xtask bench-target --cells`).
    /// At least 1; more than the cells updates every cell every period.
    pub updates_per_period: u16,
    /// A cell is flagged when its `R_i` or `R_ct` is above the pack's median
    /// by more than this fraction (0.3: 30 % above).
    pub flag_ratio: T,
}

impl<T: Real, const P: usize> PackSettings<T, P> {
    /// Every cell updated every period, cells flagged 30 % above the
    /// median.
    pub fn new(cell: OnlineSettings<T, P>) -> Self {
        Self {
            cell,
            updates_per_period: u16::MAX,
            flag_ratio: T::lit(0.3),
        }
    }
}

/// What one sample period did to the pack.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PackReport {
    /// Cells whose sample was rejected this period.
    pub rejected: u16,
    /// Cells updated this period.
    pub updated: u16,
    /// Iterations run this period (all cells).
    pub iterations: u32,
}

/// Each cell beside the pack: the pack's median resistances and which
/// cells stand out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PackHealth<T> {
    /// Median `R_i` (Ω) of the cells with an estimate.
    pub median_r_i: T,
    /// Median `R_ct` (Ω) of the cells with an estimate.
    pub median_r_ct: T,
    /// Cells with an estimate.
    pub estimated: u16,
}

/// A pack of up to `CELLS` series cells sharing one current: window
/// capacity `N`, memory capacity `MEM`.
///
/// ```
/// use estimator_core::battery::online::{OnlineSettings, Status};
/// use estimator_core::battery::pack::{PackEstimator, PackSettings};
/// use estimator_core::battery::CellParameters;
///
/// let s = PackSettings::new(OnlineSettings::new(1.0, 16, CellParameters::<f32>::cell_18650()));
/// let mut pack = PackEstimator::<f32, 64, 16, 4>::new(&s, 4).unwrap();
/// let r = pack.push(&s, 1.0, &[3.7, 3.7, f32::NAN, 3.7]).unwrap();
/// assert_eq!(r.rejected, 1);
/// assert_eq!(pack.cell(2).unwrap().counts().non_finite, 1);
/// assert_eq!(pack.cell(0).unwrap().counts().rejected(), 0);
/// assert_eq!(pack.cell(0).unwrap().status(), Status::Filling);
/// ```
#[derive(Clone, Debug)]
pub struct PackEstimator<T, const N: usize, const MEM: usize, const CELLS: usize> {
    pub(super) history: CurrentHistory<T, N>,
    pub(super) cells: [CellState<T, N>; CELLS],
    /// Cells in use (`≤ CELLS`).
    pub(super) active: usize,
    pub(super) work: WorkingArea<T, N, MEM>,
    /// Each cell's polarization under its estimate, now.
    pub(super) tails: [PolarizationTail<T, MEM>; CELLS],
    /// Each cell's state of power checked against its last pulse.
    pub(super) checks: [PulseCheck<T>; CELLS],
    /// The cell the next period's updates start at.
    pub(super) next: usize,
    /// Whether a snapshot keeps each cell's slow part carried across
    /// windows: the settings it was made with had
    /// [`OnlineSettings::slow_memory_s`] above 0
    /// ([`OnlineSettings::carries_slow_part`]).
    pub(super) slow_part: bool,
}

impl<T: Real, const N: usize, const MEM: usize, const CELLS: usize>
    PackEstimator<T, N, MEM, CELLS>
{
    /// A pack of `cells` cells (at most `CELLS`).
    ///
    /// # Errors
    /// [`Error::CellCount`] for 0 or more than `CELLS` cells; settings
    /// errors (as [`super::online::CellEstimator::new`]; a zero
    /// `updates_per_period` or a flag ratio that is not positive is
    /// [`Error::BadSetting`]).
    pub fn new<const P: usize>(s: &PackSettings<T, P>, cells: usize) -> Result<Self, Error> {
        check_schedule(s)?;
        Self::with_cells(&s.cell, cells)
    }

    /// A pack of no cells, built at compile time: the value of a `static`
    /// that [`init`](Self::init) then makes a pack of its cells in place,
    /// so that the estimator (tens of KiB) is never built on the stack and
    /// moved (the firmware's task). Until then it takes no sample
    /// ([`push`](Self::push) fails with [`Error::CellCount`]) and has no
    /// cell to report on.
    ///
    /// ```
    /// use estimator_core::battery::online::OnlineSettings;
    /// use estimator_core::battery::pack::{PackEstimator, PackSettings};
    /// use estimator_core::battery::CellParameters;
    ///
    /// let s = PackSettings::new(OnlineSettings::new(1.0, 16, CellParameters::<f32>::cell_18650()));
    /// let mut pack = PackEstimator::<f32, 64, 16, 4>::EMPTY;
    /// assert_eq!(pack.cells(), 0);
    /// assert!(pack.push(&s, 1.0, &[]).is_err());
    /// pack.init(&s, 4).unwrap();
    /// assert_eq!(pack.push(&s, 1.0, &[3.7; 4]).unwrap().rejected, 0);
    /// ```
    pub const EMPTY: Self = {
        assert!(CELLS > 0, "a pack holds at least one cell");
        Self {
            history: CurrentHistory::new(),
            cells: [CellState::BLANK; CELLS],
            active: 0,
            work: WorkingArea::BLANK,
            tails: [PolarizationTail::BLANK; CELLS],
            checks: [PulseCheck::BLANK; CELLS],
            next: 0,
            slow_part: false,
        }
    };

    /// Makes this pack, whatever it held, a pack of `cells` cells with
    /// empty windows, in place: the pack [`new`](Self::new)`(s, cells)`
    /// returns, without a copy of it on the stack.
    ///
    /// # Errors
    /// As [`new`](Self::new). On an error the pack is left with no cells
    /// (as [`EMPTY`](Self::EMPTY)).
    pub fn init<const P: usize>(
        &mut self,
        s: &PackSettings<T, P>,
        cells: usize,
    ) -> Result<(), Error> {
        self.active = 0;
        check_schedule(s)?;
        check_cells::<T, N, CELLS, P>(&s.cell, cells)?;
        self.work.init(&s.cell)?;
        self.history.clear();
        for cell in &mut self.cells {
            cell.reset::<MEM, P>(&s.cell);
        }
        self.tails.fill(PolarizationTail::BLANK);
        self.checks.fill(PulseCheck::BLANK);
        self.next = 0;
        self.slow_part = s.cell.carries_slow_part();
        self.active = cells;
        Ok(())
    }

    /// Pushes one sample period: the pack's current (A, positive when
    /// charging) and every cell's terminal voltage (V, cell 1 first), then
    /// runs the period's scheduled cell updates. Never panics; never loses
    /// a sample (a rejected voltage is counted for its cell and
    /// substituted).
    ///
    /// # Errors
    /// [`Error::CellCount`] when `voltages` does not have one voltage per
    /// cell, or the pack has no cells ([`EMPTY`](Self::EMPTY) before
    /// [`init`](Self::init)); nothing is pushed.
    pub fn push<const P: usize>(
        &mut self,
        s: &PackSettings<T, P>,
        current: T,
        voltages: &[T],
    ) -> Result<PackReport, Error> {
        let mut r = PackReport::default();
        self.push_with(
            &s.cell,
            usize::from(s.updates_per_period.max(1)),
            current,
            voltages,
            |_, c: SampleReport<T>| {
                r.rejected += u16::from(c.rejected.is_some());
                r.updated += u16::from(c.iterations > 0);
                r.iterations += u32::from(c.iterations);
            },
        )?;
        Ok(r)
    }

    /// Cells in use.
    pub fn cells(&self) -> usize {
        self.active
    }

    /// Cell `k`'s state (0-based; `None` beyond the cells in use).
    pub fn cell(&self, k: usize) -> Option<&CellState<T, N>> {
        self.cells.get(k).filter(|_| k < self.active)
    }

    /// Cell `k`'s state, to set its state of charge (0-based).
    pub fn cell_mut(&mut self, k: usize) -> Option<&mut CellState<T, N>> {
        self.cells.get_mut(k).filter(|_| k < self.active)
    }

    /// Cell `k`'s check of its state of power against the pulses that
    /// follow ([`PulseCheck`]: what its last checked pulse missed the
    /// prediction by, [`PulseCheck::missed`]), 0-based; `None` beyond the
    /// cells in use. A step is checked against the cell's own voltage
    /// noise (its window's RMSE).
    pub fn pulse_check(&self, k: usize) -> Option<&PulseCheck<T>> {
        self.checks.get(k).filter(|_| k < self.active)
    }

    /// Cell `k`'s window (the pack's currents with its voltages). Cell
    /// indices beyond the cells in use give the last cell's (a pack of no
    /// cells, the first slot's).
    pub fn window(&self, k: usize) -> CellWindow<'_, T, N> {
        let k = k.min(self.active.saturating_sub(1));
        CellWindow::new(&self.history, &self.cells[k])
    }

    /// The longest run of periods between two updates of a cell:
    /// `⌈cells / updates_per_period⌉`.
    pub fn refresh_periods<const P: usize>(&self, s: &PackSettings<T, P>) -> usize {
        let u = usize::from(s.updates_per_period.max(1)).min(self.active);
        self.active.div_ceil(u.max(1))
    }

    /// The pack's median `R_i` and `R_ct` over the cells with an estimate
    /// (`None` before any has one).
    pub fn health(&self) -> Option<PackHealth<T>> {
        let mut r_i = [T::zero(); CELLS];
        let mut r_ct = [T::zero(); CELLS];
        let mut n = 0;
        for p in self.cells[..self.active]
            .iter()
            .filter_map(|c| c.estimate())
        {
            r_i[n] = p.r_i;
            r_ct[n] = p.r_ct;
            n += 1;
        }
        if n == 0 {
            return None;
        }
        Some(PackHealth {
            median_r_i: median(&mut r_i[..n]),
            median_r_ct: median(&mut r_ct[..n]),
            estimated: n as u16,
        })
    }

    /// True when cell `k` has an estimate whose `R_i` or `R_ct` is above
    /// the pack's median by more than [`PackSettings::flag_ratio`].
    pub fn is_flagged<const P: usize>(
        &self,
        s: &PackSettings<T, P>,
        health: &PackHealth<T>,
        k: usize,
    ) -> bool {
        let limit = T::one() + s.flag_ratio;
        self.cell(k)
            .and_then(|c| c.estimate())
            .is_some_and(|p: CellParameters<T>| {
                p.r_i > limit * health.median_r_i || p.r_ct > limit * health.median_r_ct
            })
    }
}

/// A pack's schedule and health settings: at least one update a period, a
/// positive, finite flag ratio.
fn check_schedule<T: Real, const P: usize>(s: &PackSettings<T, P>) -> Result<(), Error> {
    if s.updates_per_period == 0 || !(s.flag_ratio > T::zero() && s.flag_ratio.is_finite()) {
        return Err(Error::BadSetting);
    }
    Ok(())
}

/// `cells` cells of a pack of capacity `CELLS` with windows of `N`
/// samples, and the cells' settings.
fn check_cells<T: Real, const N: usize, const CELLS: usize, const P: usize>(
    s: &OnlineSettings<T, P>,
    cells: usize,
) -> Result<(), Error> {
    if cells == 0 || cells > CELLS || cells > usize::from(u16::MAX) {
        return Err(Error::CellCount {
            given: cells,
            expected: CELLS,
        });
    }
    if N > usize::from(u16::MAX) {
        return Err(Error::BadSetting);
    }
    check_limits(s)
}

/// The median of `x` (sorted in place; the mean of the middle two for an
/// even count). Insertion sort: a pack has at most a few hundred cells.
fn median<T: Real>(x: &mut [T]) -> T {
    for k in 1..x.len() {
        let mut j = k;
        while j > 0 && x[j - 1] > x[j] {
            x.swap(j - 1, j);
            j -= 1;
        }
    }
    let n = x.len();
    if n % 2 == 1 {
        x[n / 2]
    } else {
        (x[n / 2 - 1] + x[n / 2]) / T::lit(2.0)
    }
}

/// The pack estimator's per-sample flow for cells `0..cells`, shared with
/// [`CellEstimator`](crate::battery::online::CellEstimator) (the one-cell pack). See [`PackEstimator::push`].
impl<T: Real, const N: usize, const MEM: usize, const CELLS: usize>
    PackEstimator<T, N, MEM, CELLS>
{
    /// A pack of `cells` cells (at most `CELLS`), every one with an empty
    /// window.
    ///
    /// # Errors
    /// [`Error::CellCount`] for 0 or more than `CELLS` cells; the settings
    /// errors of [`CellEstimator::new`](crate::battery::online::CellEstimator::new).
    pub fn with_cells<const P: usize>(
        s: &OnlineSettings<T, P>,
        cells: usize,
    ) -> Result<Self, Error> {
        check_cells::<T, N, CELLS, P>(s, cells)?;
        let cell = CellState::new::<MEM, P>(s);
        // The working area is built in the return value: a local moved in
        // would be one more copy of its arrays on the (start-up) stack.
        Ok(Self {
            history: CurrentHistory::new(),
            cells: core::array::from_fn(|_| cell.clone()),
            active: cells,
            work: WorkingArea::new(s)?,
            tails: [PolarizationTail::default(); CELLS],
            checks: [PulseCheck::BLANK; CELLS],
            next: 0,
            slow_part: s.carries_slow_part(),
        })
    }

    /// Pushes one sample period (the pack's current and one voltage per
    /// cell), then runs `updates` cell updates, round robin from where the
    /// last period stopped; `report(k, r)` hears every cell's report.
    pub(crate) fn push_with<const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        updates: usize,
        current: T,
        voltages: &[T],
        mut report: impl FnMut(usize, SampleReport<T>),
    ) -> Result<(), Error> {
        let cells = self.active;
        if cells == 0 || voltages.len() != cells {
            return Err(Error::CellCount {
                given: voltages.len(),
                expected: cells,
            });
        }
        // The current the ring stores for this period: the measured one
        // when plausible, else the last one (none before the first).
        let plausible = current.is_finite() && current.abs() <= s.current_limit;
        let stored = if plausible {
            Some(current)
        } else {
            self.history.newest()
        };
        // A clean step starts a check of each cell's state of power: its
        // pulse voltages for the step's current, predicted from the cell as
        // it was before this sample.
        let checked = if plausible { current } else { T::nan() };
        for k in 0..cells {
            // (An empty window: the cell starts, or starts again after a
            // gap.)
            if self.window(k).is_empty() {
                self.checks[k].restart();
            }
            if self.checks[k].starts_pulse(s.battery.min_current_std, checked) {
                if let Some((predicted, settled)) = self.check_predictions(k, s, checked) {
                    let noise = self.cells[k].voltage_noise();
                    self.checks[k].start(checked, predicted, noise, settled);
                } else if self.unpredicted_from_rest(k, s, checked) {
                    self.checks[k].start_unpredicted(checked);
                }
            }
        }
        let Self {
            history,
            cells: states,
            work,
            ..
        } = self;
        for (cell, &v) in states[..cells].iter_mut().zip(voltages) {
            cell.accept(s, history, work, stored, current, v);
        }
        if let Some(i) = stored {
            history.push(i);
        }
        let updates = updates.min(cells);
        let first = self.next;
        for k in 0..cells {
            let scheduled = (k + cells - first) % cells < updates;
            let r = self.cells[k].update(s, &self.history, &mut self.work, k, scheduled);
            let v = voltages.get(k).copied().unwrap_or(T::nan());
            let timing = s.voltage_timing;
            self.checks[k].observe_watching(
                checked,
                v,
                r.rejected.is_some(),
                s.pulse_current,
                timing,
            );
            report(k, r);
            // A watched pulse nothing predicted, set against the first
            // model from rest (once).
            if let Some(held) = self.checks[k].unpredicted() {
                if let Some(drops) = self.drops_from_rest(k, s, held) {
                    let noise = self.cells[k].voltage_noise();
                    self.checks[k].resolve(drops, noise);
                }
            }
            // While the working area is still this cell's.
            self.follow_polarization(s, k, stored);
        }
        self.next = (first + updates) % cells;
        Ok(())
    }

    /// Moves cell `k`'s [`PolarizationTail`] to this sample (right after
    /// its update, while the working area may still be its): from its
    /// fit's simulation when the working area holds one of the estimate
    /// that is new (or of this sample), carried forward through the
    /// samples the simulation has not seen; else one sample on through
    /// `stored` under the same estimate; cleared when neither is possible
    /// (a new estimate whose simulation is gone).
    fn follow_polarization<const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        k: usize,
        stored: Option<T>,
    ) {
        {
            let c = &self.cells[k];
            let tail = &mut self.tails[k];
            let Some(p) = c.window_estimate() else {
                tail.clear();
                return;
            };
            let follows = tail.model() == Some(p);
            let fresh = self
                .work
                .polarization_of(k, p)
                .filter(|(_, stamp, _)| !follows || *stamp == c.window_version());
            if let Some((up, stamp, w)) = fresh {
                let since = c.window_version().wrapping_sub(stamp) as usize;
                let window = CellWindow::new(&self.history, c);
                let pred = (since <= window.len())
                    // Only the last `M` values count (and are checked).
                    .then(|| {
                        let recent = &up[up.len().saturating_sub(MEM)..];
                        PulsePredictor::<T, MEM, 0>::new(p, w, recent, None)
                    })
                    .flatten();
                match pred {
                    Some(mut pred) => {
                        // The currents since, oldest first (since ≤ the
                        // window's length ≤ N).
                        let mut newer = [T::zero(); N];
                        let newer = &mut newer[..since.min(N)];
                        for (slot, (i, _)) in newer.iter_mut().rev().zip(window.newest_first()) {
                            *slot = i;
                        }
                        for &i in newer.iter() {
                            pred.advance(i);
                        }
                        tail.set(&pred);
                    }
                    None => tail.clear(),
                }
            } else if follows {
                if p.is_butler_volmer() && tail.largest_current() == T::zero() && c.resting() {
                    // Carried into a rest: the largest current of the window
                    // the estimate was fitted on, which the state of power
                    // from a long rest caps the term at. Read once per rest
                    // from the window now, which has lost the fit window's
                    // oldest samples since: a cap at most the fit's, on the
                    // safe side.
                    let window = CellWindow::new(&self.history, c);
                    tail.note_largest_current(window.largest_current());
                }
                if let Some(i) = stored {
                    if self.work.weights().alpha() == p.alpha {
                        tail.advance(self.work.weights(), i);
                    } else {
                        match GlWeights::<T, MEM>::new(p.alpha, s.battery.h, s.battery.memory) {
                            Ok(w) => tail.advance(&w, i),
                            Err(_) => tail.clear(),
                        }
                    }
                }
            } else {
                tail.clear();
            }
        }
    }

    /// Cell `k`'s model and the polarization it carries now, to predict a
    /// constant-current pulse and the state of power from
    /// ([`crate::battery::power`]): its last good estimate (window
    /// coordinates) and the polarization that estimate's fit simulated,
    /// carried forward through every sample since. After a rest the SOC
    /// observer reads ([`CellState::rested_voltage`]; with the
    /// Butler–Volmer term, once the tail has noted its window's largest
    /// current), the cell is taken as relaxed instead: no polarization, at
    /// the rested voltage. `None` before an estimate, after a new estimate
    /// until its simulation is taken, when more samples have passed since
    /// the fit than the window holds (a long rest that is not yet that
    /// long, a restart), and with an OCV curve before the state of charge
    /// is known (the open-circuit voltage follows the pulse's charge from
    /// the count).
    pub fn pulse_predictor<'a, const P: usize>(
        &self,
        k: usize,
        s: &'a OnlineSettings<T, P>,
    ) -> Option<PulsePredictor<'a, T, MEM, P>> {
        self.predictor_within(k, s, None, None)
    }

    /// [`pulse_predictor`](Self::pulse_predictor) carried at most `carry`
    /// samples from its fit (`None`: as far as the window reaches), with
    /// `model`'s parameters in place of the estimate's (`None`: the
    /// estimate's): the polarization the estimate's fit left, continued by
    /// `model`.
    fn predictor_within<'a, const P: usize>(
        &self,
        k: usize,
        s: &'a OnlineSettings<T, P>,
        carry: Option<u32>,
        model: Option<&CellParameters<T>>,
    ) -> Option<PulsePredictor<'a, T, MEM, P>> {
        let c = self.cell(k)?;
        let tail = &self.tails[k];
        // Without an estimate (none yet, or none plausible), only a model
        // given (the map's) from a relaxed cell.
        let p = c.window_estimate();
        let q = model.or(p)?;
        let ocv = match (&s.ocv, c.state_of_charge()) {
            (Some(m), Some(z)) => Some((m, z)),
            (Some(_), None) => return None,
            (None, _) => None,
        };
        // A rest long enough to read the OCV from (the SOC observer's
        // `rest_s`) has relaxed the cell: the pulse starts from rest, at
        // the rested voltage, with no polarization. The carried one would
        // be the last fit's split between the OCV offset and the branch,
        // which a window at rest does not identify (on the measured
        // Panasonic cell the split reached ±32 mV and put the 2 s pulse
        // 47 % of its drop off at the 90th percentile; docs/bms-states.md).
        // With a Butler–Volmer term the window fits, only while the tail
        // knows the largest current of the window the estimate was fitted
        // on (the term's state of power is capped there; a long rest has
        // emptied the window itself); a term the linear model holds was
        // not fitted there.
        let known = q.bv_a == T::zero()
            || s.holds_kinetic_term()
            || (p.is_some() && tail.model() == p && tail.largest_current() > T::zero());
        let rested = known.then(|| c.relaxed_voltage(s).zip(ocv)).flatten();
        if let Some((v, (m, z))) = rested {
            let w = self.weights_at(q, s)?;
            let from_rest = CellParameters {
                u_oc: v - m.table.ocv(z),
                ..*q
            };
            return PulsePredictor::new(&from_rest, &w, &[], ocv);
        }
        // Carried no farther from its fit than the window reaches (after a
        // restart: none). Farther, the model's relaxation is not what was
        // fitted: on the measured Panasonic cell, pulses after rests longer
        // than the window were predicted 22–41 % of their drop off
        // (docs/bms-states.md, bench/sop_pulses.py).
        let reach = carry.map_or_else(|| CellWindow::new(&self.history, c).len(), |n| n as usize);
        if p.is_none() || tail.model() != p || tail.since_fit() as usize > reach {
            return None;
        }
        // The working area's weights when they are at this order (the
        // cell it holds), else new ones (written out here, not through
        // `weights_at`: its `Option` cost a copy of the weights on every
        // update on the Cortex-M4F).
        let held = self.work.weights();
        let w =
            if held.alpha() == q.alpha && held.h() == s.battery.h && held.len() == s.battery.memory
            {
                held.clone()
            } else {
                GlWeights::new(q.alpha, s.battery.h, s.battery.memory).ok()?
            };
        PulsePredictor::from_tail_with(tail, *q, w, ocv)
    }

    /// The weights at `p`'s order: the working area's when they are (the
    /// cell it holds), else new ones (for the pulse from rest).
    fn weights_at<const P: usize>(
        &self,
        p: &CellParameters<T>,
        s: &OnlineSettings<T, P>,
    ) -> Option<GlWeights<T, MEM>> {
        let held = self.work.weights();
        if held.alpha() == p.alpha && held.h() == s.battery.h && held.len() == s.battery.memory {
            Some(held.clone())
        } else {
            GlWeights::new(p.alpha, s.battery.h, s.battery.memory).ok()
        }
    }

    /// Cell `k`'s state of power now for `power`'s horizons, predicted
    /// with the best parameter set the cell holds
    /// ([`CellState::sop_parameters`]: the window's, the map prior's, or
    /// the last good estimate, held or stale; the report's
    /// [`PowerReport::basis`] says which) from the polarization its
    /// [`pulse_predictor`](Self::pulse_predictor) carries (at most
    /// [`PowerSettings::carry`] samples from the fit, or from a relaxed
    /// cell). `None` before every parameter has been published once
    /// (with a prior, before a fit only from a relaxed cell: a rest the SOC
    /// observer reads, or one since the record began), or without a
    /// predictor. With a Butler–Volmer term the window fits, the
    /// currents are capped at the largest the cell's window holds: the
    /// term is not extrapolated (a term the linear model holds, a
    /// Butler–Volmer prior's, is not capped). Each pulse voltage carries its standard deviation
    /// from the set's spread ([`CellState::sop_spread`]) and what the
    /// cell's last pulse missed its prediction by ([`PulseCheck`]), and the
    /// currents keep [`PowerSettings::confidence`] of it inside the limits.
    /// A pulse at [`OnlineSettings::pulse_current`] from a settled cell
    /// has its voltage corrected by the last such pulse of that current's
    /// measured over predicted drop ([`PulseCheck::corrected`],
    /// [`HorizonPower::pulse_ratio`](super::power::HorizonPower::pulse_ratio));
    /// the limit currents stay the model's.
    pub fn state_of_power<const P: usize>(
        &self,
        k: usize,
        s: &OnlineSettings<T, P>,
        power: &PowerSettings<T>,
    ) -> Option<PowerReport<T>> {
        let c = self.cell(k)?;
        let (q, basis) = c.sop_parameters(s)?;
        let predictor = self.predictor_within(k, s, power.carry, Some(&q))?;
        // A Butler–Volmer term's curvature is known only over the currents
        // its window saw: beyond the largest of them its overpotential
        // grows as `asinh`, far slower than a cell's at high rate. Its
        // state of power is not extrapolated past them (on the DFN drive
        // cycles, a 5C state of power from the extrapolated term took the
        // cell 165–262 mV below its limit within 30 s; docs/bms-states.md).
        let mut power = *power;
        // A term the linear model holds (a Butler–Volmer prior's) was
        // fitted over the prior's test's currents: not capped by the
        // window's.
        if c.window_estimate().is_some_and(|p| p.is_butler_volmer()) && !s.holds_kinetic_term() {
            // The window's largest current; from a long rest, which has
            // emptied the window, the one noted as the tail was carried
            // into the rest (`follow_polarization`).
            let noted = self.tails[k].largest_current();
            let seen = if noted > T::zero() && c.rested_voltage(s).is_some() {
                noted
            } else {
                self.window(k).largest_current()
            };
            let cap = &mut power.limits.current_limit;
            *cap = cap.min(seen);
        }
        let check = &self.checks[k];
        let spread = c.sop_spread(s, basis, &q, check.missed());
        let report = predictor
            .power_with_spread(&power, &spread)
            .with_basis(basis);
        // The watched pulse's voltage, corrected by what the last pulse of
        // its current measured against its prediction.
        let watched = power
            .pulse_current
            .zip(s.pulse_current)
            .is_some_and(|(i, w)| same_pulse(i, w));
        let known = power.horizons().iter().any(|&k| check.ratio(k).is_some());
        Some(if watched && known {
            // The voltage at no current at every horizon, in one pass.
            let mut steps = [0; MAX_HORIZONS];
            for (slot, &h) in steps.iter_mut().zip(power.horizons()) {
                *slot = h;
            }
            let free = predictor.pulse_voltages(T::zero(), &steps);
            report.with_pulse_corrected(check, predictor.pulse_voltage(T::zero(), 0), &free)
        } else {
            report
        })
    }

    /// The string's state of power: at each horizon the weakest cell's
    /// currents (a series string carries one current) and the sum of the
    /// cells' pulse voltages ([`PowerReport::series`]); `None` while any
    /// cell in use has none (a string is only as known as its least known
    /// cell).
    pub fn pack_state_of_power<const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
        power: &PowerSettings<T>,
    ) -> Option<PowerReport<T>> {
        PowerReport::string((0..self.active).map(|k| self.state_of_power(k, s, power)))
    }
}
