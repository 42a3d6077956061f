//! The state of power checked against the pulses that follow it
//! ([`PulseCheck`]): at each clean current step whose predicted drop
//! stands above the voltage's noise, the voltage the state of power's
//! model predicts for a pulse of that step's current is taken at a few
//! durations ([`CHECK_STEPS`]), and while the current holds, the
//! measured voltage at each is set against it. What the last pulse missed
//! by, relative to the drop predicted, at each duration
//! ([`ResponseMiss`]) widens the spread of the states of power that follow
//! ([`super::ParameterSpread::response`]): a parameter's interval is what
//! its window knows of it, and the pulse itself says what the model,
//! carried from a window to the next pulse, missed. On the measured
//! Panasonic HPPC tests the pulses the model missed most are those after a
//! level's largest pulse, or near empty (docs/bms-states.md).
//!
//! A pulse from a settled cell ([`settled`]) at the current the state of
//! power is asked for
//! ([`OnlineSettings::pulse_current`](crate::battery::online::OnlineSettings::pulse_current))
//! also leaves its signed ratio, the measured drop over the predicted one
//! at each duration ([`PulseCheck::ratio`]); the pack corrects that
//! current's predicted pulse voltage from a settled cell by it
//! ([`PulseCheck::corrected`]). Each duration is measured from the pulse's
//! edge, wherever it falls within a sample, with each voltage placed where
//! in its period it was taken ([`VoltageTiming`]). On the measured
//! Panasonic HPPC tests and the DFN HPPC records this brings the median
//! miss of the next pulse of that current to 1.1–4.5 % of its drop where
//! it applies (docs/state-of-power.md).
//!
//! A watched pulse from a rested cell that nothing predicts yet (no
//! estimate, no prior: a record's first pulses) keeps its measured drops
//! instead ([`PulseCheck::start_unpredicted`]); the first model the pack
//! has sets them against its own drops for that pulse from rest
//! ([`PulseCheck::resolve`]), and the ratio is kept as if the pulse had
//! been predicted.
//!
//! It owns the check's state; it must not change the estimate or what is
//! published (the pack gives it the predicted voltages and applies the
//! correction, [`crate::battery::pack`]).

use crate::battery::tracker::{clean_edge, precise_change};
use crate::real::Real;

/// The durations a pulse is checked at (samples from its start, the step's
/// own sample the first): at most the state of power's longest horizon
/// that is usually asked (30 s at 1 s), log-spaced.
pub const CHECK_STEPS: [u32; 5] = [1, 2, 5, 10, 30];

const CHECKS: usize = CHECK_STEPS.len();

/// Where in the period whose mean current a sample holds its voltage was
/// taken ([`OnlineSettings::voltage_timing`](crate::battery::online::OnlineSettings::voltage_timing)):
/// where the check of the state of power against the next pulse places
/// each voltage ([`PulseCheck::observe_watching`]).
///
/// ```
/// use estimator_core::battery::power::VoltageTiming;
/// // Periods from a pulse's edge, 0.4 of a period into its first sample,
/// // to its third sample's voltage.
/// assert_eq!(VoltageTiming::End.since_edge(3, 0.6), 2.6);
/// assert_eq!(VoltageTiming::Mean.since_edge(3, 0.6), 2.1);
/// assert_eq!(VoltageTiming::Start.since_edge(3, 0.6), 1.6);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum VoltageTiming {
    /// At the period's end (the default): a gauge that integrates the
    /// current over the period before each reading (the bq769x0), a
    /// simulation.
    #[default]
    End,
    /// The mean over the period: a log put on a coarser period than its
    /// rows where the current moves within each period, as a measured one
    /// does (`fracbms-host`'s resampler).
    Mean,
    /// At the period's start: a log's instants put on a coarser period,
    /// its current held exactly through each.
    Start,
}

impl VoltageTiming {
    /// Periods from a pulse's edge to its `k`-th sample's voltage (the
    /// middle of the period for [`Self::Mean`]), the first sample holding
    /// the share `f` of the pulse's current (the edge `1 − f` into it).
    pub fn since_edge<T: Real>(self, k: u32, f: T) -> T {
        let lead = match self {
            Self::End => 0.0,
            Self::Mean => 0.5,
            Self::Start => 1.0,
        };
        T::lit(f64::from(k)) - T::lit(1.0 + lead) + f
    }

    /// Samples from the pulse's own first whose voltage is not read: 0
    /// where each voltage comes at its period's end, 1 where the first
    /// sample's holds the edge or comes before it.
    fn unread(self) -> u32 {
        u32::from(self != Self::End)
    }

    /// The response's growth at a voltage `since` periods after the edge
    /// (placed by [`Self::since_edge`]), in which the check interpolates:
    /// the square root of the time, a fractional model's response growing
    /// about so; for [`Self::Mean`] its mean over the period.
    fn root<T: Real>(self, since: T) -> T {
        match self {
            Self::Mean => {
                let half = T::lit(0.5);
                let (a, b) = ((since - half).max(T::zero()), since + half);
                T::lit(2.0 / 3.0) * (b * b.sqrt() - a * a.sqrt())
            }
            Self::End | Self::Start => since.sqrt(),
        }
    }
}

/// How far past its last two samples a pulse's voltage is carried on, in
/// periods, to a duration it did not reach: a pulse as long as the
/// duration, its edge within a sample, whose voltages are taken before
/// their periods' ends ([`VoltageTiming::Mean`], [`VoltageTiming::Start`]),
/// ends up to two periods short of it (its last sample's voltage holds the
/// edge back to rest).
pub const CARRY_PERIODS: f64 = 2.0;

/// The relative miss of the last checked pulse at each of [`CHECK_STEPS`]:
/// `|predicted − measured| / |voltage before − predicted|` (NaN: not yet
/// seen at that duration).
///
/// ```
/// use estimator_core::battery::power::ResponseMiss;
/// let m = ResponseMiss::<f64> { miss: [0.01, 0.02, f64::NAN, 0.10, 0.05] };
/// assert_eq!(m.at(2), 0.02);
/// // Between two durations, the larger miss of the two known around it.
/// assert_eq!(m.at(7), 0.10);
/// assert_eq!(m.at(5), 0.10);
/// // Beyond the last, the last.
/// assert_eq!(m.at(60), 0.05);
/// assert_eq!(ResponseMiss::<f64>::NONE.at(10), 0.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ResponseMiss<T> {
    /// Per duration of [`CHECK_STEPS`].
    pub miss: [T; CHECKS],
}

impl<T: Real> ResponseMiss<T> {
    /// Nothing checked yet: no miss known.
    pub const NONE: Self = Self {
        miss: [T::NAN; CHECKS],
    };

    /// The relative miss for a pulse of `steps` samples: the larger of the
    /// nearest known misses at or below it and at or above it (beyond the
    /// last duration, the last known); 0 when none is known.
    pub fn at(&self, steps: u32) -> T {
        let known = |(c, m): (&u32, &T)| (m.is_finite()).then_some((*c, *m));
        let below = CHECK_STEPS
            .iter()
            .zip(&self.miss)
            .rev()
            .filter_map(known)
            .find(|(c, _)| *c <= steps);
        let above = CHECK_STEPS
            .iter()
            .zip(&self.miss)
            .filter_map(known)
            .find(|(c, _)| *c >= steps);
        match (below, above) {
            (Some((_, a)), Some((_, b))) => a.max(b),
            (a, b) => a.or(b).map_or(T::zero(), |(_, m)| m),
        }
    }

    /// Every miss finite and not negative, or not known (NaN).
    pub fn is_valid(&self) -> bool {
        self.miss.iter().all(|m| m.is_nan() || *m >= T::zero())
    }
}

/// A ratio kept in Q12 fixed point (2 B: the cell's state stays within
/// 2 KiB in `f32`); [`UNKNOWN_RATIO`] for none.
const RATIO_ONE: f64 = 4096.0;

/// A ratio not known (not measured, or beyond ±8).
const UNKNOWN_RATIO: i16 = i16::MIN;

/// Two currents are the same pulse's when within a tenth of the larger,
/// of the same sign.
pub(crate) fn same_pulse<T: Real>(a: T, b: T) -> bool {
    a * b > T::zero() && (a - b).abs() <= T::lit(0.1) * a.abs().max(b.abs())
}

/// How the cell stood before the pulse being checked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum StartedFrom {
    /// Drifting (or not known settled): the pulse's misses are kept, not
    /// its ratios.
    Drifting,
    /// Settled: a watched pulse's ratios are kept too.
    Settled,
    /// Rested, with nothing to predict it from: a watched pulse's measured
    /// drops are kept in `predicted` until a model comes
    /// ([`PulseCheck::resolve`]).
    Unpredicted,
}

/// One cell's check of its state of power against the pulses that follow
/// (module docs): the pulse being checked, the last pulse's misses and the
/// last watched pulse's ratios. 84 B in `f32`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PulseCheck<T> {
    /// The pulse being checked: its current as predicted (A; NaN: none),
    /// the current it holds, the voltage before it (V), its samples so
    /// far, the predicted voltages and its first sample's miss (counted
    /// from the second sample on).
    current: T,
    held: T,
    before: T,
    elapsed: u32,
    predicted: [T; CHECKS],
    first: T,
    /// The last pulse's misses.
    missed: ResponseMiss<T>,
    /// The last pulse at the watched current's measured over predicted
    /// drop at each duration (Q12).
    ratio: [i16; CHECKS],
    /// Whether the pulse's first sample held another current than the
    /// rest (a resampled edge, a current settling), and how the cell
    /// stood before it (whether its ratios may be kept, or its drops wait
    /// for a model).
    stepped: bool,
    from: StartedFrom,
    /// The last sample's current and voltage, and the current before it.
    last: (T, T),
    earlier: T,
}

impl<T: Real> Default for PulseCheck<T> {
    fn default() -> Self {
        Self::BLANK
    }
}

impl<T: Real> PulseCheck<T> {
    /// No sample seen, no pulse checked.
    pub const BLANK: Self = Self {
        current: T::NAN,
        held: T::NAN,
        before: T::NAN,
        elapsed: 0,
        predicted: [T::NAN; CHECKS],
        first: T::NAN,
        missed: ResponseMiss::NONE,
        ratio: [UNKNOWN_RATIO; CHECKS],
        stepped: false,
        from: StartedFrom::Drifting,
        last: (T::NAN, T::NAN),
        earlier: T::NAN,
    };

    /// Whether `current` (A), the next sample's, starts a pulse to check:
    /// a clean edge, as a step resistance is taken
    /// ([`crate::battery::online::StepResistance`]: the current before it
    /// steady, the two samples before within a tenth of the step; the step
    /// at least half of the larger current and a hundred times
    /// `min_current_std`), into a larger current (a pulse, not its end),
    /// with a voltage before it.
    pub fn starts_pulse(&self, min_current_std: T, current: T) -> bool {
        let (prev, v) = self.last;
        v.is_finite()
            && current.abs() > prev.abs()
            && clean_edge(min_current_std, self.earlier, prev, current)
    }

    /// Starts checking a pulse of `current` (A) with the voltages the
    /// state of power predicts for it at each of [`CHECK_STEPS`] (from
    /// the cell as it was before the pulse's first sample), when every
    /// predicted drop from the voltage before it is known to the step
    /// resistance's precision against `noise_v`, the voltage's scatter in
    /// one sample (the window's RMSE): `2·√2·noise_v ≤ 0.25·|drop|`
    /// ([`crate::battery::online::STEP_PRECISION`]). A smaller step's
    /// miss would be the voltage's noise over a drop of a few millivolts,
    /// not the model's. `settled`: the cell's own drift over the pulse
    /// (predicted at no current) is small beside its drop
    /// ([`settled`]), so that a watched pulse's ratio is the model's miss
    /// of the pulse, not of the drift ([`Self::observe_watching`]).
    /// Returns whether the pulse is checked.
    pub fn start(&mut self, current: T, predicted: [T; CHECKS], noise_v: T, settled: bool) -> bool {
        let before = self.last.1;
        let precise = predicted
            .iter()
            .all(|&p| (before - p).is_finite() && precise_change(noise_v, before - p));
        let from = if settled {
            StartedFrom::Settled
        } else {
            StartedFrom::Drifting
        };
        self.begin(precise, current, predicted, from)
    }

    /// A pulse of `current` begins (where `ok`; else none is checked),
    /// from the last sample's voltage, with `predicted` (a prediction, or
    /// the place its measured drops will be kept) and how the cell stood.
    fn begin(&mut self, ok: bool, current: T, predicted: [T; CHECKS], from: StartedFrom) -> bool {
        if !ok {
            self.current = T::nan();
            return false;
        }
        self.current = current;
        self.before = self.last.1;
        self.held = current;
        self.elapsed = 0;
        self.predicted = predicted;
        self.first = T::nan();
        self.stepped = false;
        self.from = from;
        true
    }

    /// Starts measuring a pulse of `current` (A) that nothing predicts yet,
    /// from a rested cell (no estimate and no prior: a record's first
    /// pulses): at each duration of [`CHECK_STEPS`] a pulse at the watched
    /// current ([`Self::observe_watching`]) reaches, its measured drop is
    /// kept, in place of a prediction, until a model predicts the same
    /// pulse from rest ([`Self::resolve`]). A later such pulse takes its
    /// place. Returns whether it started (a voltage before it).
    ///
    /// ```
    /// use estimator_core::battery::power::{PulseCheck, VoltageTiming};
    /// let mut c = PulseCheck::<f64>::BLANK;
    /// c.observe(0.0, 3.7, false);
    /// assert!(c.start_unpredicted(-2.0));
    /// for n in 1..=31 {
    ///     c.observe_watching(-2.0, 3.6 - 0.001 * n as f64, false, Some(-2.0), VoltageTiming::End);
    /// }
    /// c.observe(0.0, 3.69, false);
    /// assert_eq!(c.unpredicted(), Some(-2.0));
    /// assert_eq!(c.ratio(10), None);
    /// // The first model's drops from rest, 0.8 of the measured ones.
    /// c.resolve([0.101, 0.102, 0.105, 0.11, 0.13].map(|d| 0.8 * d), 1e-3);
    /// assert!((c.ratio(10).unwrap() - 1.25).abs() < 1e-3);
    /// assert_eq!(c.unpredicted(), None);
    /// ```
    pub fn start_unpredicted(&mut self, current: T) -> bool {
        let ok = self.last.1.is_finite();
        self.begin(ok, current, [T::nan(); CHECKS], StartedFrom::Unpredicted)
    }

    /// The current (A) of a watched pulse whose measured drops wait for a
    /// model ([`Self::start_unpredicted`]), once it has ended; `None`
    /// otherwise.
    pub fn unpredicted(&self) -> Option<T> {
        (self.from == StartedFrom::Unpredicted
            && self.current.is_nan()
            && self.predicted.iter().any(|d| d.is_finite()))
        .then_some(self.held)
    }

    /// Sets the waiting pulse's measured drops ([`Self::unpredicted`])
    /// against `drops`, a model's for the same pulse from rest at each of
    /// [`CHECK_STEPS`] (V, from its voltage at no current), each known to
    /// the precision [`Self::start`] asks against `noise_v`: each
    /// duration's ratio and miss are kept as a predicted watched pulse's
    /// from a settled cell would be. The drops wait no longer either way.
    pub fn resolve(&mut self, drops: [T; CHECKS], noise_v: T) {
        if self.unpredicted().is_none() {
            return;
        }
        let measured = self.predicted;
        self.predicted = [T::nan(); CHECKS];
        self.from = StartedFrom::Drifting;
        if !drops
            .iter()
            .all(|&d| d.is_finite() && precise_change(noise_v, d))
        {
            return;
        }
        for (j, (&m, &d)) in measured.iter().zip(&drops).enumerate() {
            let ratio = m / d;
            if ratio.is_finite() {
                self.missed.miss[j] = (ratio - T::one()).abs();
                self.ratio[j] = to_q12(ratio);
            }
        }
    }

    /// Takes one sample (current in A, voltage in V; `rejected`: the
    /// voltage was not accepted), each voltage taken at the end of the
    /// period whose current the sample holds (`observe_watching` for
    /// other records). At each duration of [`CHECK_STEPS`] the pulse
    /// reaches, its miss replaces the last pulse's there: the drop
    /// measured that long after the pulse's edge, from the voltage before
    /// the pulse, against the drop the state of power predicted for a
    /// pulse of that many samples at the current held (a model's response
    /// is linear in the current). The pulse ends when the voltage is not
    /// usable or the current leaves a tenth of what it holds; one that
    /// ends before a duration leaves the last pulse's miss there.
    ///
    /// A first sample that averaged the current over the edge (a
    /// resampled log: part of the current after it, of the same sign)
    /// holds the share `f` of the current held after it: the edge came
    /// `1 − f` of a period into it. Each duration's voltage is then
    /// interpolated between the two samples around it in the square root
    /// of the time since the edge, or carried on from the two before by
    /// less than [`CARRY_PERIODS`] for a pulse that ends short of it. So
    /// the ratio is the voltage a pulse gives that long after its edge
    /// over what the model publishes for a pulse of that many samples: on
    /// a record put on 2 s whose pulses start anywhere within a period,
    /// the published pulse voltage, corrected by it ([`Self::corrected`]),
    /// is the cell's that long after the edge. A current still settling
    /// after the first sample (within a tenth, smaller) is checked at the
    /// current it settles to, its first sample's miss at its own. A first
    /// sample's miss counts once the second sample holds the same current
    /// (within 2 %).
    pub fn observe(&mut self, current: T, voltage: T, rejected: bool) {
        self.observe_watching(current, voltage, rejected, None, VoltageTiming::End);
    }

    /// [`observe`](Self::observe), a pulse of `watch` (A, within a tenth,
    /// [`OnlineSettings::pulse_current`](crate::battery::online::OnlineSettings::pulse_current))
    /// also leaving its measured over predicted drop at each duration it
    /// reaches ([`Self::ratio`]). The current is the one the pulse holds
    /// from its second sample on: a resampled log's first sample may hold
    /// part of it. `timing`: where in its sample's period each voltage was
    /// taken ([`VoltageTiming`]); but at the period's end, the pulse's own
    /// first sample's voltage is not read (it holds the edge, or comes
    /// before it).
    pub fn observe_watching(
        &mut self,
        current: T,
        voltage: T,
        rejected: bool,
        watch: Option<T>,
        timing: VoltageTiming,
    ) {
        let usable = voltage.is_finite() && !rejected;
        if self.current.is_finite() {
            self.elapsed = self.elapsed.saturating_add(1);
            let held = self.held;
            let goes_on = usable
                && match self.elapsed {
                    1 => {
                        self.held = current;
                        true
                    }
                    2 if (current - held).abs() <= T::lit(0.02) * held.abs() => {
                        if timing == VoltageTiming::End {
                            self.keep(0, self.first, watch);
                        }
                        true
                    }
                    2 => {
                        // A first sample not at the pulse's current: one
                        // that straddled the edge (its edge within the
                        // first sample), or a current still settling
                        // (within a tenth; its first sample's miss at its
                        // own current). The pulse is checked at the
                        // current it now holds.
                        let settling = (current - held).abs() <= T::lit(0.1) * held.abs();
                        let straddled = current * held > T::zero() && current.abs() >= held.abs();
                        self.held = current;
                        self.stepped = straddled;
                        if settling && !straddled && timing == VoltageTiming::End {
                            self.keep(0, self.first, watch);
                        }
                        settling || straddled
                    }
                    _ => (current - held).abs() <= T::lit(0.1) * held.abs(),
                };
            if goes_on {
                self.measure(voltage, timing, watch);
            }
            let last = CHECK_STEPS[CHECKS - 1] + 1 + timing.unread();
            if !goes_on || self.elapsed >= last {
                self.current = T::nan();
            }
        }
        self.earlier = self.last.0;
        self.last = (current, if usable { voltage } else { T::nan() });
    }

    /// The drop measured at the pulse's `elapsed`-th sample (its voltage
    /// `voltage`, the one before in `self.last`) set against the
    /// prediction at each duration it tells ([`Self::observe`]).
    fn measure(&mut self, voltage: T, timing: VoltageTiming, watch: Option<T>) {
        let e = self.elapsed;
        // The share of the held current in the first sample.
        let f = if self.stepped {
            (self.current / self.held).min(T::one())
        } else {
            T::one()
        };
        let since = |k: u32| timing.since_edge(k, f);
        let now = self.before - voltage;
        // The sample before, where its voltage came after the edge.
        let lead = timing.unread();
        let prev = (e > 1 + lead).then(|| self.before - self.last.1);
        let scale = self.held / self.current;
        let predicted = self.predicted;
        // This sample's voltage and the one before, placed from the edge,
        // and where the response's growth stands at each.
        let (d, d0) = (since(e), since(e.saturating_sub(1)));
        let (r1, r0) = (timing.root(d), timing.root(d0));
        // The first two samples after the edge also reach back to a
        // duration before them (a mean over a period that started after it).
        let first_pair = e == 2 + lead;
        for (j, (&c, &p)) in CHECK_STEPS.iter().zip(&predicted).enumerate() {
            let at = T::lit(f64::from(c));
            let measured = if d == at {
                Some(now)
            } else {
                // Between the sample before and this one, or carried on
                // from them by less than `CARRY_PERIODS` (a pulse that ends
                // before the next sample leaves this), in the response's
                // growth (`VoltageTiming::root`).
                prev.filter(|_| (d0 < at || first_pair) && at - d < T::lit(CARRY_PERIODS))
                    .map(|prev| now + (at.sqrt() - r1) / (r1 - r0) * (now - prev))
            };
            let predicted = (self.before - p) * scale;
            let Some(measured) = measured else {
                continue;
            };
            // (Unpredicted: the drop itself, kept until a model predicts it.)
            let unpredicted = self.from == StartedFrom::Unpredicted;
            if !(measured.is_finite()
                && (unpredicted || (predicted.is_finite() && predicted.abs() > T::zero())))
            {
                continue;
            }
            let ratio = if unpredicted {
                measured
            } else {
                measured / predicted
            };
            if e == 1 {
                // The first sample's waits for the second.
                self.first = ratio;
            } else {
                self.keep(j, ratio, watch);
            }
        }
    }

    /// Keeps the `j`-th duration's measured over predicted drop: its miss,
    /// and its ratio for a watched pulse from a settled cell; for an
    /// unpredicted watched pulse, the measured drop itself (until
    /// [`Self::resolve`]).
    fn keep(&mut self, j: usize, ratio: T, watch: Option<T>) {
        if !ratio.is_finite() {
            return;
        }
        let watched = watch.is_some_and(|w| same_pulse(w, self.held));
        match self.from {
            StartedFrom::Unpredicted => {
                if watched {
                    self.predicted[j] = ratio;
                }
            }
            from => {
                self.missed.miss[j] = (ratio - T::one()).abs();
                if from == StartedFrom::Settled && watched {
                    self.ratio[j] = to_q12(ratio);
                }
            }
        }
    }

    /// The record starts again (a gap, a restarted window): the samples
    /// before it say nothing of a step after it, and a pulse being checked
    /// ends. The misses are kept (they are the model's).
    pub fn restart(&mut self) {
        self.current = T::nan();
        self.last = (T::nan(), T::nan());
        self.earlier = T::nan();
    }

    /// What the last pulses missed by at each duration.
    pub fn missed(&self) -> ResponseMiss<T> {
        self.missed
    }

    /// The last watched pulse's measured drop over its predicted one for
    /// a pulse of `steps` samples ([`Self::observe_watching`]; to
    /// 2.4·10⁻⁴): at a duration of [`CHECK_STEPS`] its own, between two
    /// known ones interpolated in the samples, below the first known that
    /// one, beyond the longest duration checked that one's; `None` while
    /// none is known at or beyond `steps` (a shorter pulse does not stand
    /// for a longer one).
    pub fn ratio(&self, steps: u32) -> Option<T> {
        let known = || {
            CHECK_STEPS
                .iter()
                .zip(&self.ratio)
                .filter(|(_, &r)| r != UNKNOWN_RATIO)
                .map(|(&c, &r)| (T::lit(f64::from(c)), T::lit(f64::from(r) / RATIO_ONE)))
        };
        let at = T::lit(f64::from(steps));
        let below = known().filter(|(c, _)| *c <= at).last();
        let above = known().find(|(c, _)| *c >= at);
        let longest = T::lit(f64::from(CHECK_STEPS[CHECKS - 1]));
        match (below, above) {
            (Some((c0, r0)), Some((c1, r1))) if c1 > c0 => {
                Some(r0 + (r1 - r0) * (at - c0) / (c1 - c0))
            }
            (_, Some((_, r))) => Some(r),
            // Beyond the longest duration checked, its ratio; not a
            // shorter pulse's for a longer one.
            (Some((c, r)), None) if c >= longest => Some(r),
            _ => None,
        }
    }

    /// `pulse_v`, the voltage predicted at the end of a pulse of `steps`
    /// samples at the watched current, corrected by what the last watched
    /// pulse measured against its prediction ([`Self::ratio`]): the
    /// pulse's own response, from `free_v` (the voltage predicted at the
    /// same instant at no current), scaled by that ratio. `None` without a
    /// ratio, or for a voltage that is not finite.
    ///
    /// ```
    /// use estimator_core::battery::power::{PulseCheck, VoltageTiming, CHECK_STEPS};
    /// let mut c = PulseCheck::<f64>::BLANK;
    /// for _ in 0..3 {
    ///     c.observe(0.0, 3.7, false);
    /// }
    /// // A −2 A pulse predicted 0.1 V down, measured 0.12 V down.
    /// assert!(c.start(-2.0, [3.6; 5], 1e-3, true));
    /// for _ in 0..30 {
    ///     c.observe_watching(-2.0, 3.58, false, Some(-2.0), VoltageTiming::End);
    /// }
    /// let r = c.ratio(10).unwrap();
    /// assert!((r - 1.2).abs() < 1e-3);
    /// // The next pulse predicted 0.1 V below a cell that would rest at
    /// // 3.71 V is taken 0.12 V below it.
    /// assert!((c.corrected(10, 3.61, 3.71).unwrap() - 3.59).abs() < 1e-3);
    /// ```
    pub fn corrected(&self, steps: u32, pulse_v: T, free_v: T) -> Option<T> {
        let r = self.ratio(steps)?;
        let v = free_v - r * (free_v - pulse_v);
        v.is_finite().then_some(v)
    }
}

/// How far the cell's own drift over a pulse may go beside the pulse's
/// own response, at every duration of [`CHECK_STEPS`] (or at the horizon
/// asked), for the pulse to count as from a settled cell: a twentieth.
pub const SETTLED_DRIFT: f64 = 0.05;

/// Whether a pulse starts from a settled cell, as the model predicts it:
/// at every duration the drift at no current from the present voltage,
/// `free − now`, within [`SETTLED_DRIFT`] of the pulse's own response
/// `free − predicted` (V).
///
/// ```
/// use estimator_core::battery::power::settled;
/// assert!(settled(3.7, &[3.6; 5], &[3.701; 5]));
/// assert!(!settled(3.7, &[3.6; 5], &[3.71; 5]));
/// ```
pub fn settled<T: Real>(now: T, predicted: &[T; CHECKS], free: &[T; CHECKS]) -> bool {
    predicted
        .iter()
        .zip(free)
        .all(|(&p, &f)| settled_at(now, p, f))
}

/// [`settled`] at one duration: the drift `free − now` within
/// [`SETTLED_DRIFT`] of the pulse's own response `free − pulse_v`.
pub(crate) fn settled_at<T: Real>(now: T, pulse_v: T, free: T) -> bool {
    (free - now).abs() <= T::lit(SETTLED_DRIFT) * (free - pulse_v).abs()
}

/// A ratio in Q12 ([`UNKNOWN_RATIO`] beyond ±8 or not finite).
fn to_q12<T: Real>(r: T) -> i16 {
    let x = r.to_f64() * RATIO_ONE;
    if x.is_finite() && x.abs() < f64::from(i16::MAX) {
        // Rounded to the nearest (`as` truncates toward zero).
        (x + if x < 0.0 { -0.5 } else { 0.5 }) as i16
    } else {
        UNKNOWN_RATIO
    }
}

#[cfg(test)]
#[path = "check_tests.rs"]
mod tests;
