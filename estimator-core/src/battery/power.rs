//! State of power: from a cell's model and the polarization it carries
//! now, the terminal voltage of a constant-current pulse of a given length
//! ([`PulsePredictor::pulse_voltage`]), and the largest constant currents
//! that keep it within the voltage limits for that long
//! ([`PulsePredictor::state_of_power`], [`StateOfPower`]).
//!
//! The prediction runs the model's own constant-phase recursion forward
//! from the present: the polarization's free response (its history, with
//! the short memory the estimator fits with) plus the response to the
//! pulse's current, the static drop `R_i·I` (and the Butler–Volmer term),
//! and, with an OCV curve, the open-circuit voltage at the charge the
//! pulse moves. Sign convention: current positive when charging; a
//! discharge current limit is returned as a positive magnitude.
//!
//! [`PowerSettings`] asks for several horizons at once (and a pulse's
//! voltage at each); [`PulsePredictor::power`] answers them in one pass of
//! the recursion ([`PowerReport`]). [`PolarizationTail`] is what a cell
//! carries between samples to predict from at any time: its model and its
//! last `M` polarization values, followed sample by sample;
//! [`PulseCheck`] what the last pulse showed of the prediction's miss.
//!
//! This module owns that prediction; it must not touch the estimators'
//! state (the caller gives the model, the history and the weights at the
//! model's order).

use core::cell::Cell;

use super::ocv::OcvModel;
use super::simulate::cpe_filter;
use super::CellParameters;
use crate::frac::{GlWeights, ROW_BLOCK};
use crate::real::Real;

mod check;
mod report;
mod spread;
pub(crate) use check::same_pulse;
pub use check::{
    settled, PulseCheck, ResponseMiss, VoltageTiming, CARRY_PERIODS, CHECK_STEPS, SETTLED_DRIFT,
};
pub use report::{
    samples, HorizonPower, PowerLimits, PowerReport, PowerSettings, SopBasis, StateOfPower,
    DEFAULT_CONFIDENCE, MAX_HORIZONS, MAX_HORIZON_STEPS,
};
pub use spread::ParameterSpread;

/// What a cell carries between samples to predict pulses from at any
/// time: the model it follows (window coordinates, as the estimator's
/// estimate) and that model's polarization now and in the `M − 1` samples
/// before (`past[0]` now). Set from a fit's simulation, then carried
/// forward one sample at a time with the currents that flowed
/// ([`advance`](Self::advance)), so it stays the model's present state
/// through rests of any length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PolarizationTail<T, const MEM: usize> {
    p: Option<CellParameters<T>>,
    past: [T; MEM],
    /// Samples carried since it was last set from a fit.
    since: u32,
    /// The largest current magnitude (A) of the cell's window when the
    /// tail was first carried into a rest under an estimate with the
    /// Butler–Volmer term (0: not noted since the tail was last set).
    largest: T,
}

impl<T: Real, const MEM: usize> Default for PolarizationTail<T, MEM> {
    fn default() -> Self {
        Self::BLANK
    }
}

impl<T: Real, const MEM: usize> PolarizationTail<T, MEM> {
    /// A tail that follows no model ([`Default`]), as a constant.
    pub(crate) const BLANK: Self = Self {
        p: None,
        past: [T::ZERO; MEM],
        since: 0,
        largest: T::ZERO,
    };

    /// The model the tail follows (`None`: it follows none).
    pub fn model(&self) -> Option<&CellParameters<T>> {
        self.p.as_ref()
    }

    /// Follows nothing (an estimate the tail cannot follow).
    pub fn clear(&mut self) {
        self.p = None;
        self.largest = T::zero();
    }

    /// The largest current magnitude (A) of the cell's window as
    /// [`note_largest_current`](Self::note_largest_current) noted it since
    /// the tail was last [`set`](Self::set) (0: not noted).
    pub fn largest_current(&self) -> T {
        self.largest
    }

    /// Notes the largest current magnitude (A) of the cell's window as the
    /// tail is carried into a rest: a Butler–Volmer term's state of power
    /// is capped at the currents its fit saw, also once a long rest has
    /// emptied the window.
    pub fn note_largest_current(&mut self, largest: T) {
        self.largest = largest;
    }

    /// Takes a predictor's model and present polarization (from a fit's
    /// simulation).
    pub fn set<const P: usize>(&mut self, pred: &PulsePredictor<'_, T, MEM, P>) {
        self.p = Some(pred.p);
        self.past = pred.past;
        self.since = 0;
        self.largest = T::zero();
    }

    /// Samples carried forward since the tail was last [`set`](Self::set)
    /// from a fit.
    pub fn since_fit(&self) -> u32 {
        self.since
    }

    /// Carries the polarization one sample forward through `current` (A)
    /// with weights `w` at the model's order; does nothing when it follows
    /// no model or `w` is at another order.
    pub fn advance(&mut self, w: &GlWeights<T, MEM>, current: T) {
        if let Some(p) = &self.p {
            if same_order(w, p) {
                advance_past(p, w, &mut self.past, current);
                self.since = self.since.saturating_add(1);
            }
        }
    }
}

/// `w` is at `p`'s order.
fn same_order<T: Real, const MEM: usize>(w: &GlWeights<T, MEM>, p: &CellParameters<T>) -> bool {
    (w.alpha() - p.alpha).abs() <= T::lit(1e-9) * p.alpha.abs().max(T::one())
}

/// One sample of the constant-phase recursion: `past` (`past[0]` now)
/// moves one sample on through `current`.
fn advance_past<T: Real, const MEM: usize>(
    p: &CellParameters<T>,
    w: &GlWeights<T, MEM>,
    past: &mut [T; MEM],
    current: T,
) {
    let wts = w.weights();
    let m = wts.len().min(MEM);
    let a = p.tau() * w.scale();
    let h = wts
        .iter()
        .take(m)
        .skip(1)
        .zip(past.iter())
        .fold(T::zero(), |s, (&w, &x)| s + w * x);
    let x = (p.r_ct * current - a * h) / (T::one() + a);
    for j in (1..MEM).rev() {
        past[j] = past[j - 1];
    }
    if MEM > 0 {
        past[0] = x;
    }
}

/// A cell's model and its present polarization, ready to predict pulses.
///
/// ```
/// use estimator_core::battery::power::{PowerLimits, PulsePredictor};
/// use estimator_core::battery::CellParameters;
/// use estimator_core::frac::GlWeights;
///
/// let p = CellParameters::<f64>::cell_18650();
/// let w = GlWeights::<f64, 64>::new(p.alpha, 1.0, 64).unwrap();
/// // At rest: no polarization.
/// // Without an OCV curve (its table size is then any).
/// let cell = PulsePredictor::<f64, 64, 2>::new(&p, &w, &[0.0; 10], None).unwrap();
/// let limits = PowerLimits { voltage_min: 3.0, voltage_max: 4.2, current_limit: 20.0 };
/// let sop = cell.state_of_power(&limits, 10);
/// // The pulse at the limit current ends on the limit voltage.
/// let v = cell.pulse_voltage(-sop.discharge_a, 10);
/// assert!((v - 3.0).abs() < 1e-6 || sop.discharge_a == 20.0);
/// ```
#[derive(Clone, Debug)]
pub struct PulsePredictor<'a, T, const MEM: usize, const P: usize> {
    p: CellParameters<T>,
    /// The weights at `p`'s order (a copy: a predictor stands alone).
    w: GlWeights<T, MEM>,
    /// The polarization now and before: `past[j]` is `j` samples ago (the
    /// first `M` count).
    past: [T; MEM],
    ocv: Option<(&'a OcvModel<T, P>, T)>,
}

impl<'a, T: Real, const MEM: usize, const P: usize> PulsePredictor<'a, T, MEM, P> {
    /// The cell `p` (its `u_oc`: the OCV offset `ΔU` with a curve, the
    /// open-circuit voltage without) with weights `w` at `p`'s order and
    /// the model's period, its polarization `history` (oldest first, the
    /// last is now; only the last `M − 1` count) and, with a curve, the
    /// curve and the state of charge now. `None` for a model that is not
    /// physical or weights at another order.
    pub fn new(
        p: &CellParameters<T>,
        w: &GlWeights<T, MEM>,
        history: &[T],
        ocv: Option<(&'a OcvModel<T, P>, T)>,
    ) -> Option<Self> {
        if !(p.is_physical() && same_order(w, p) && history.iter().all(|x| x.is_finite())) {
            return None;
        }
        let mut past = [T::zero(); MEM];
        for (x, &h) in past.iter_mut().zip(history.iter().rev()) {
            *x = h;
        }
        Some(Self {
            p: *p,
            w: w.clone(),
            past,
            ocv,
        })
    }

    /// Carries the polarization one sample forward through a sample of
    /// `current` (A) that happened (the charge it moved is the caller's
    /// state of charge, already counted).
    pub fn advance(&mut self, current: T) {
        advance_past(&self.p, &self.w, &mut self.past, current);
    }

    /// A predictor from a tail that follows a model, with weights `w` at
    /// its order and, with a curve, the curve and the state of charge
    /// now. `None` as [`new`](Self::new), or for a tail that follows none.
    pub fn from_tail(
        tail: &PolarizationTail<T, MEM>,
        w: GlWeights<T, MEM>,
        ocv: Option<(&'a OcvModel<T, P>, T)>,
    ) -> Option<Self> {
        Self::from_tail_with(tail, tail.p?, w, ocv)
    }

    /// [`from_tail`](Self::from_tail) with the model `p` in place of the
    /// tail's own: the polarization the tail carries, continued by `p`
    /// (weights `w` at `p`'s order). `None` as [`new`](Self::new).
    pub fn from_tail_with(
        tail: &PolarizationTail<T, MEM>,
        p: CellParameters<T>,
        w: GlWeights<T, MEM>,
        ocv: Option<(&'a OcvModel<T, P>, T)>,
    ) -> Option<Self> {
        if !(p.is_physical() && same_order(&w, &p) && tail.past.iter().all(|x| x.is_finite())) {
            return None;
        }
        Some(Self {
            p,
            w,
            past: tail.past,
            ocv,
        })
    }

    /// Runs the recursion `steps` samples forward and calls `seen(k, F_k,
    /// G_k)` for `k = 1…steps`: `F_k` the polarization's free response
    /// from the history, `G_k` its response to a unit current from rest,
    /// so that a constant current `I` gives `U_p = F_k + I·G_k`.
    ///
    /// Up to `MEM` steps the responses run through the simulation's own
    /// block recursion ([`cpe_filter`]: the far taps of four rows per pass
    /// of the weights), the free one after its history, the step's from
    /// rest; longer horizons in chunks of `MEM` (the sums in tap order).
    fn responses(&self, steps: usize, mut seen: impl FnMut(usize, T, T)) {
        let wts = self.w.weights();
        let m = wts.len().min(MEM);
        let a = self.p.tau() * self.w.scale();
        if steps <= MEM && m > 0 {
            // x: the free response after the `m − 1` samples of its
            // history (oldest first, the last is now); y: the unit step's
            // from rest (its history is zero: only its own taps count).
            // Both run to whole blocks (as far as their room goes), so
            // that every row is summed alike whatever the length asked: a
            // pulse's prediction does not depend on the other horizons.
            let warm = m - 1;
            let rows = steps.div_ceil(ROW_BLOCK) * ROW_BLOCK;
            let (mut xb, mut yb) = ([[T::zero(); MEM]; 2], [[T::zero(); MEM]; 2]);
            let (xs, ys) = (xb.as_flattened_mut(), yb.as_flattened_mut());
            let (nx, ny) = ((warm + rows).min(xs.len()), rows.min(ys.len()));
            let (Some(x), Some(y)) = (xs.get_mut(..nx), ys.get_mut(..ny)) else {
                return;
            };
            for (xl, &p) in x.iter_mut().take(warm).rev().zip(&self.past) {
                *xl = p;
            }
            let w = wts.get(..m).unwrap_or_default();
            cpe_filter(w, a, warm, x, |_| T::zero(), |_, _, _| {});
            let r_ct = self.p.r_ct;
            cpe_filter(w, a, 0, y, |_| r_ct, |_, _, _| {});
            let rows = x.iter().skip(warm).zip(y.iter()).take(steps);
            for (k, (&f, &g)) in rows.enumerate() {
                seen(k + 1, f, g);
            }
            return;
        }
        let inv = T::one() / (T::one() + a);
        // The values in chunks of `MEM`: `fresh[i]` the chunk's `i`-th,
        // `past[i]` the value `i + 1` samples before the chunk's first (no
        // shifting per sample: the sums read both slices where they are).
        let mut past_f = self.past;
        let mut past_g = [T::zero(); MEM];
        let mut fresh_f = [T::zero(); MEM];
        let mut fresh_g = [T::zero(); MEM];
        // The step response starts from rest: its past is zero until the
        // first chunk is full.
        let mut g_past = false;
        let mut n = 0;
        for k in 1..=steps {
            let nf = n.min(m.saturating_sub(1));
            let (mut hf, mut hg) = (T::zero(), T::zero());
            // Taps 1..=nf on this chunk, newest first: fresh[n − j]
            // (nf ≤ n ≤ MEM and nf < m: the slices always exist).
            let (near, far) = (
                wts.get(1..=nf).unwrap_or_default(),
                wts.get(nf + 1..m).unwrap_or_default(),
            );
            let (ff, fg) = (
                fresh_f.get(..n).unwrap_or_default(),
                fresh_g.get(..n).unwrap_or_default(),
            );
            // (The last nf of each, four taps at a time and then the rest,
            // each sum still in tap order: the loop's own work was most of
            // its cost on the Cortex-M4F.)
            let (ff, fg) = (
                ff.get(n - nf..).unwrap_or_default(),
                fg.get(n - nf..).unwrap_or_default(),
            );
            let (wq, wr) = near.as_chunks::<4>();
            let (fr, fq) = ff.as_rchunks::<4>();
            let (gr, gq) = fg.as_rchunks::<4>();
            for ((w, x), y) in wq.iter().zip(fq.iter().rev()).zip(gq.iter().rev()) {
                for k in 0..4 {
                    hf = hf + w[k] * x[3 - k];
                    hg = hg + w[k] * y[3 - k];
                }
            }
            for (&wj, (&xf, &xg)) in wr.iter().zip(fr.iter().rev().zip(gr.iter().rev())) {
                hf = hf + wj * xf;
                hg = hg + wj * xg;
            }
            // Taps nf + 1..m on the past: past[j − n − 1], from past[0]
            // (the range is empty unless nf = n).
            for (&wj, &x) in far.iter().zip(&past_f) {
                hf = hf + wj * x;
            }
            if g_past {
                for (&wj, &x) in far.iter().zip(&past_g) {
                    hg = hg + wj * x;
                }
            }
            let f = -(a * hf) * inv;
            let g = (self.p.r_ct - a * hg) * inv;
            if n == MEM {
                // The chunk is full: it becomes the past.
                for i in 0..MEM {
                    past_f[i] = fresh_f[MEM - 1 - i];
                    past_g[i] = fresh_g[MEM - 1 - i];
                }
                g_past = true;
                n = 0;
            }
            if n < MEM {
                fresh_f[n] = f;
                fresh_g[n] = g;
                n += 1;
            }
            seen(k, f, g);
        }
    }

    /// The open-circuit voltage after `charge` (A·s, + charging) from now,
    /// its table lookup started at the segment in `segment` (left at the
    /// one it used: [`OcvTable::ocv_from`](super::ocv::OcvTable::ocv_from),
    /// the same value as from any other).
    fn open_circuit(&self, charge: T, segment: &Cell<usize>) -> T {
        match self.ocv {
            Some((m, soc)) => {
                let z = soc + charge / (T::lit(3600.0) * m.capacity_ah);
                let (v, k) = m.table.ocv_from(z, segment.get());
                segment.set(k);
                v + self.p.u_oc
            }
            None => self.p.u_oc,
        }
    }

    /// The terminal voltage after `k` samples of `current` from now, given
    /// the free and step responses there (`segment` as in
    /// [`open_circuit`](Self::open_circuit)).
    fn voltage(&self, current: T, k: usize, f: T, g: T, segment: &Cell<usize>) -> T {
        self.voltage_with(current, self.p.static_voltage(current), k, f, g, segment)
    }

    /// [`voltage`](Self::voltage) given the static voltage of `current`
    /// (`R_i·I` and the kinetic term, the same at every sample of a pulse).
    fn voltage_with(
        &self,
        current: T,
        static_v: T,
        k: usize,
        f: T,
        g: T,
        segment: &Cell<usize>,
    ) -> T {
        let charge = current * T::lit(k as f64) * self.w.h();
        self.open_circuit(charge, segment) + static_v + f + current * g
    }

    /// The predicted terminal voltage at the end of a constant `current`
    /// (A, + charging) held for `steps` samples from now (the present
    /// voltage's model value for `steps = 0`, at no current).
    pub fn pulse_voltage(&self, current: T, steps: usize) -> T {
        let segment = Cell::new(0);
        let mut v = self.voltage(T::zero(), 0, self.past[0], T::zero(), &segment);
        self.responses(steps, |k, f, g| {
            if k == steps {
                v = self.voltage(current, k, f, g, &segment);
            }
        });
        v
    }

    /// [`pulse_voltage`](Self::pulse_voltage) at each of `steps` (samples,
    /// each at least 1; NaN for a 0), in one pass of the recursion to the
    /// longest.
    ///
    /// ```
    /// use estimator_core::battery::power::PulsePredictor;
    /// use estimator_core::battery::CellParameters;
    /// use estimator_core::frac::GlWeights;
    /// let p = CellParameters::<f64>::cell_18650();
    /// let w = GlWeights::<f64, 64>::new(p.alpha, 1.0, 64).unwrap();
    /// let cell = PulsePredictor::<f64, 64, 0>::new(&p, &w, &[0.0; 10], None).unwrap();
    /// let v = cell.pulse_voltages(-5.0, &[1, 10, 30]);
    /// assert_eq!(v[1], cell.pulse_voltage(-5.0, 10));
    /// ```
    pub fn pulse_voltages<const K: usize>(&self, current: T, steps: &[u32; K]) -> [T; K] {
        let segment = Cell::new(0);
        let mut out = [T::nan(); K];
        let longest = steps.iter().copied().max().unwrap_or(0) as usize;
        self.responses(longest, |k, f, g| {
            for (o, &s) in out.iter_mut().zip(steps) {
                if s as usize == k {
                    *o = self.voltage(current, k, f, g, &segment);
                }
            }
        });
        out
    }

    /// The largest constant discharge and charge currents that keep the
    /// predicted voltage within `limits` at every sample of a horizon of
    /// `steps` samples ([`power`](Self::power) for one horizon).
    pub fn state_of_power(&self, limits: &PowerLimits<T>, steps: usize) -> StateOfPower<T> {
        let h = [u32::try_from(steps).unwrap_or(u32::MAX)];
        let r = self.run(limits, &h, None, None);
        r.horizons[0].sop
    }

    /// Every horizon of `s` in one pass of the recursion: at each, the
    /// largest constant discharge and charge currents whose predicted
    /// voltage stays within the limits at every sample up to it (capped by
    /// the current limit; 0 when even a rest would cross), and the
    /// voltage of the settings' pulse at its end.
    ///
    /// Each sample's voltage falls (rises) monotonically with the
    /// discharge (charge) current, so the bound is carried from sample to
    /// sample and lowered only where a sample would cross: its root by
    /// bracketed regula falsi (Illinois), to `10⁻⁹ V` or `2⁻⁴⁰` of the
    /// current limit, whichever comes first, always on the safe side.
    pub fn power(&self, s: &PowerSettings<T>) -> PowerReport<T> {
        self.run(&s.limits, s.horizons(), s.pulse_current, None)
    }

    fn run(
        &self,
        limits: &PowerLimits<T>,
        horizons: &[u32],
        pulse: Option<T>,
        spread: Option<(&ParameterSpread<T>, T)>,
    ) -> PowerReport<T> {
        let cap = limits.current_limit;
        let empty = HorizonPower {
            sop: StateOfPower {
                steps: 0,
                discharge_a: cap,
                charge_a: cap,
            },
            pulse_v: None,
            uncertainty_v: None,
            pulse_ratio: None,
        };
        let mut out = PowerReport {
            horizons: [empty; MAX_HORIZONS],
            count: horizons.len().min(MAX_HORIZONS),
            basis: SopBasis::Window,
        };
        for (o, &k) in out.horizons.iter_mut().zip(horizons) {
            o.sop.steps = k as usize;
        }
        let longest = horizons.iter().copied().max().unwrap_or(0) as usize;
        // Every response kept up to `MEM` samples (the horizons' ends
        // solved from them below).
        let short = longest <= MEM;
        let (mut fs, mut gs) = ([T::zero(); MEM], [T::zero(); MEM]);
        if short {
            // (k runs 1..=longest ≤ MEM.)
            self.responses(longest, |k, f, g| {
                let at = k.wrapping_sub(1);
                if let (Some(x), Some(y)) = (fs.get_mut(at), gs.get_mut(at)) {
                    (*x, *y) = (f, g);
                }
            });
        }
        // Each horizon's voltage spread at a current, and the margin the
        // limit currents keep for it at the horizon's end.
        let shifts = spread.and_then(|(sp, _)| {
            let base = if short {
                let mut b = [T::nan(); MAX_HORIZONS];
                for (x, &h) in b.iter_mut().zip(horizons) {
                    *x = gs
                        .get((h as usize).wrapping_sub(1))
                        .copied()
                        .unwrap_or(T::nan());
                }
                b
            } else {
                self.step_ends(horizons, longest)
            };
            Some((self.shifts(horizons, longest, sp, &base)?, sp))
        });
        let conf = spread.map_or(T::zero(), |(_, c)| c);
        // A held Butler–Volmer term's spread: its shift at each current.
        let kinetic = shifts
            .as_ref()
            .is_some_and(|(_, sp)| spread::moves_kinetic(&self.p, sp));
        let sigma = |j: usize, i: T| {
            let (sh, sp) = shifts.as_ref()?;
            let k = if kinetic {
                spread::kinetic_shift(&self.p, sp, i)
            } else {
                T::zero()
            };
            Some(spread::sigma_at(*sh.get(j)?, sp.noise_v, i, k))
        };
        let margin = |j: usize, i: T| sigma(j, i).map_or(T::zero(), |s| conf * s);
        let sure = T::lit(SURE_V);
        let (mut d, mut c) = (cap, cap);
        // The OCV table's segment of the last lookup: the next starts there.
        let segment = Cell::new(0);
        let voltage = |i: T, k: usize, f: T, g: T| self.voltage(i, k, f, g, &segment);
        let discharge = |x: T, k: usize, f: T, g: T| voltage(-x, k, f, g) - limits.voltage_min;
        let charge = |x: T, k: usize, f: T, g: T| limits.voltage_max - voltage(x, k, f, g);
        if short {
            // Every response kept: each horizon's end solved once, the
            // samples before it only checked (and solved where one
            // fails), in order of the horizons' lengths. The same bounds
            // as sample by sample (below), with fewer roots.
            let mut order = [0usize; MAX_HORIZONS];
            for (j, o) in order.iter_mut().enumerate().take(out.count) {
                *o = j;
            }
            let order = order
                .get_mut(..out.count.min(MAX_HORIZONS))
                .unwrap_or_default();
            sort_by_steps(order, &out.horizons);
            let mut checked = 0;
            for &j in order.iter() {
                let Some(end) = out.horizons.get(j).map(|o| o.sop.steps) else {
                    continue;
                };
                if end == 0 {
                    continue;
                }
                // (k runs 1..=end ≤ longest ≤ MEM.)
                let at = |k: usize| {
                    let at = k.wrapping_sub(1);
                    fs.get(at)
                        .zip(gs.get(at))
                        .map_or((T::nan(), T::nan()), |(&f, &g)| (f, g))
                };
                let (fe, ge) = at(end);
                d = largest(d, limits.voltage_min, |x| {
                    discharge(x, end, fe, ge) - margin(j, -x)
                });
                c = largest(c, limits.voltage_max, |x| {
                    charge(x, end, fe, ge) - margin(j, x)
                });
                // The checks at the bounds found so far: their static
                // voltages once for every sample they pass. A sample passes
                // without its voltage when its polarization at the bound
                // (free and forced) is at least `SURE_V` farther inside the
                // limit than the end's: the end passes, the static voltage
                // is the same at every sample, and the open-circuit voltage
                // there, with less charge moved, is no nearer the limit
                // (the table is monotone).
                let (mut sd, mut sc) = (self.p.static_voltage(-d), self.p.static_voltage(c));
                for k in checked + 1..end {
                    let (f, g) = at(k);
                    let (df, dg) = (f - fe, g - ge);
                    let d_sure = df - d * dg >= sure;
                    let c_sure = df + c * dg <= -sure;
                    if d_sure && c_sure {
                        continue;
                    }
                    if !d_sure
                        && self.voltage_with(-d, sd, k, f, g, &segment) - limits.voltage_min
                            < T::zero()
                    {
                        d = largest(d, limits.voltage_min, |x| discharge(x, k, f, g));
                        sd = self.p.static_voltage(-d);
                    }
                    if !c_sure
                        && limits.voltage_max - self.voltage_with(c, sc, k, f, g, &segment)
                            < T::zero()
                    {
                        c = largest(c, limits.voltage_max, |x| charge(x, k, f, g));
                        sc = self.p.static_voltage(c);
                    }
                }
                checked = checked.max(end);
                if let Some(o) = out.horizons.get_mut(j) {
                    o.sop.discharge_a = d;
                    o.sop.charge_a = c;
                    o.pulse_v = pulse.map(|i| voltage(i, end, fe, ge));
                    o.uncertainty_v = pulse.and_then(|i| sigma(j, i));
                }
            }
            return out;
        }
        self.responses(longest, |k, f, g| {
            d = largest(d, limits.voltage_min, |x| discharge(x, k, f, g));
            c = largest(c, limits.voltage_max, |x| charge(x, k, f, g));
            for (j, o) in out.horizons.iter_mut().enumerate().take(out.count) {
                if o.sop.steps == k {
                    d = largest(d, limits.voltage_min, |x| {
                        discharge(x, k, f, g) - margin(j, -x)
                    });
                    c = largest(c, limits.voltage_max, |x| charge(x, k, f, g) - margin(j, x));
                    o.sop.discharge_a = d;
                    o.sop.charge_a = c;
                    o.pulse_v = pulse.map(|i| voltage(i, k, f, g));
                    o.uncertainty_v = pulse.and_then(|i| sigma(j, i));
                }
            }
        });
        out
    }
}

/// A margin (V) beyond any rounding of a predicted voltage (a few `f32`
/// ulp of a cell's voltage): a sample whose voltage is known from the
/// horizon's end to be at least this far inside the limits passes
/// unchecked.
const SURE_V: f64 = 1e-5;

/// Iterations of a limit current's root at most.
const ROOT_ITERATIONS: usize = 60;

/// The largest `x` in `[0, bound]` with `f(x) ≥ 0`, for `f` decreasing
/// (and continuous; a voltage margin to `limit`): `bound` itself when it
/// passes, 0 when 0 fails (or `f` is NaN there), else the root by
/// bracketed regula falsi with the Illinois rule (superlinear on the
/// piecewise-smooth voltages here), stopped at `f ≤ 10⁻⁹ V` or a bracket
/// of `2⁻⁴⁰·bound`, or where `T` cannot resolve more (16 ulp of the
/// limit, 4 ulp of the bound: 8 µV and 0.5 ppm in `f32`); always a passing
/// point.
fn largest<T: Real>(bound: T, limit: T, f: impl Fn(T) -> T) -> T {
    let fb = f(bound);
    if fb >= T::zero() {
        return bound;
    }
    let f0 = f(T::zero());
    if f0.is_nan() || f0 < T::zero() {
        return T::zero();
    }
    let eps = T::epsilon();
    let tol_x = bound * T::lit(9.094_947_017_729_282e-13).max(T::lit(4.0) * eps);
    let tol_f = T::lit(1e-9).max(T::lit(16.0) * eps * limit.abs());
    // The bracket: lo passes (its true value `at_lo`), hi fails;
    // `flo`/`fhi` are the Illinois-weighted ends.
    let (mut lo, mut at_lo, mut flo, mut hi, mut fhi) = (T::zero(), f0, f0, bound, fb);
    let mut side = 0i8;
    for _ in 0..ROOT_ITERATIONS {
        if hi - lo <= tol_x || at_lo <= tol_f {
            break;
        }
        let mut x = lo + (hi - lo) * (flo / (flo - fhi));
        if !(x > lo && x < hi) {
            x = (lo + hi) / T::lit(2.0);
            if !(x > lo && x < hi) {
                break;
            }
        }
        let fx = f(x);
        if fx >= T::zero() {
            (lo, at_lo, flo) = (x, fx, fx);
            if side == 1 {
                fhi = fhi / T::lit(2.0);
            }
            side = 1;
        } else {
            (hi, fhi) = (x, fx);
            if side == -1 {
                flo = flo / T::lit(2.0);
            }
            side = -1;
        }
    }
    lo
}

#[cfg(test)]
mod tests;

/// Sorts the horizon indices `order` by their lengths, stably (an
/// insertion sort: at most [`MAX_HORIZONS`] of them, and no range checks as
/// in `core`'s sort). An index past `horizons` sorts first.
fn sort_by_steps<T>(order: &mut [usize], horizons: &[HorizonPower<T>]) {
    let steps = |j: usize| horizons.get(j).map_or(0, |o| o.sop.steps);
    for a in 1..order.len() {
        let mut b = a;
        while b > 0 && steps(order[b - 1]) > steps(order[b]) {
            order.swap(b - 1, b);
            b -= 1;
        }
    }
}
