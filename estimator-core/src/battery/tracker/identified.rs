//! What the data identify: each published parameter's status
//! ([`Identification`]), the values published per parameter
//! ([`PublishedParameters`]) and the model-free resistance of the last
//! current step ([`StepResistance`]).
//!
//! A window's estimate is the minimum of its cost, whether or not the
//! window's data determine every parameter. A parameter is published only
//! when they do: its 95 % interval from the window's information (the
//! refinement's `JᵀJ` with the prior's, scaled by the residual variance and
//! widened for residuals that follow each other;
//! [`crate::battery::output_error::FitInformation::correlated_standard_errors`])
//! is within a factor
//! [`OnlineSettings::identify_factor`] (α within
//! ±[`OnlineSettings::identify_alpha`]), and, for `R_i`, what the model
//! answers a current step with at once ([`StepResistance::model_ohm`]:
//! `R_i` in the linear model) is within that factor of the resistance the
//! last current step showed. Otherwise the last identified value stays
//! published, marked held, or nothing is published for it yet. What is
//! published of an identified `R_ct`, `Q` or α is the window's value, or
//! with [`OnlineSettings::slow_memory_s`] the mean the windows' values make
//! ([`super::fusion`]).
//!
//! With a prior, identified means by the window's data alone
//! ([`FitInformation::without_prior`]): the prior's weight would otherwise
//! pass every interval. Where only the interval with the prior passes, the
//! window's estimate is published as the prior's
//! ([`Identification::Prior`]).
//!
//! It owns these judgements and the step detection; it must not change the
//! estimate the tracker iterates from (the refinement keeps its own), nor
//! the overall [`Status`].

use super::fusion::Slow;
use super::*;
use crate::battery::output_error::{FitInformation, COLUMNS};
use crate::battery::power::{ParameterSpread, ResponseMiss, SopBasis};
use crate::battery::CellParameters;
use crate::real::Real;

/// Whether a published parameter comes from the data.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Identification {
    /// No window has identified it yet: nothing is published.
    NotIdentified,
    /// The last window identified it: the published value is that
    /// window's.
    Identified,
    /// The last window did not identify it (or was not fitted): the value
    /// of the last window that did is kept.
    Held,
    /// `R_i` only: the last window's data alone do not separate `R_i` from
    /// the branch's fastest part, so it was fitted with the last clean
    /// current step's resistance as evidence
    /// ([`crate::battery::output_error::OutputErrorRefinement::set_r_i_evidence`]),
    /// and the value is within [`OnlineSettings::identify_factor`] of that
    /// step's resistance.
    Step,
    /// The value was identified at a state of charge further than
    /// [`OnlineSettings::hold_soc_span`] from the present one: nothing is
    /// published until a window identifies it again.
    Expired,
    /// A prior is set and the window's data alone do not identify it: the
    /// value is the window's estimate, which the prior holds where the data
    /// say nothing ([`crate::battery::output_error::FitInformation::without_prior`]).
    /// Its interval with the prior is within
    /// [`OnlineSettings::identify_factor`] (α: ±[`OnlineSettings::identify_alpha`]).
    Prior,
    /// The value comes from a snapshot restored at start-up
    /// ([`crate::battery::snapshot`]): what the cell had published before
    /// the reset, kept until a window of new data identifies it again.
    Restored,
}

impl Identification {
    /// A short lower-case name (for the track's `*_status` columns).
    pub fn as_str(&self) -> &'static str {
        match self {
            Identification::NotIdentified => "not_identified",
            Identification::Identified => "identified",
            Identification::Held => "held",
            Identification::Step => "step",
            Identification::Expired => "expired",
            Identification::Restored => "restored",
            Identification::Prior => "prior",
        }
    }

    /// Whether a value is published with this status.
    pub fn is_published(&self) -> bool {
        matches!(
            self,
            Identification::Identified
                | Identification::Held
                | Identification::Step
                | Identification::Restored
                | Identification::Prior
        )
    }
}

/// One published parameter: its value (`None` until identified) and
/// status.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PublishedParameter<T> {
    /// The value of the last window that identified it; for `R_ct`, `Q`
    /// and α with [`OnlineSettings::slow_memory_s`] above 0, the mean of
    /// the values the windows identified.
    pub value: Option<T>,
    /// Whether that window is the last one.
    pub status: Identification,
    /// The state of charge when it was identified (with an OCV curve).
    pub soc: Option<T>,
    /// One standard deviation of the value (of `ln R_i`, `ln R_ct`,
    /// `ln Q`; of α itself) from the information of the window that
    /// identified it (`None`: not known, as for a restored value).
    pub sigma: Option<T>,
}

impl<T: Copy> PublishedParameter<T> {
    const NONE: Self = Self {
        value: None,
        status: Identification::NotIdentified,
        soc: None,
        sigma: None,
    };

    /// The same with the value and state of charge mapped by `f` (for
    /// example to another float type).
    pub fn map<U>(self, f: impl Fn(T) -> U) -> PublishedParameter<U> {
        PublishedParameter {
            value: self.value.map(&f),
            status: self.status,
            soc: self.soc.map(&f),
            sigma: self.sigma.map(&f),
        }
    }

    /// The last window identified it (`Some((x, σ))`, with `status`) or
    /// not (`None`) at state of charge `soc`.
    fn update(
        &mut self,
        identified: Option<(T, Option<T>)>,
        status: Identification,
        soc: Option<T>,
    ) {
        match identified {
            Some((x, sigma)) => {
                self.value = Some(x);
                self.status = status;
                self.soc = soc;
                self.sigma = sigma;
            }
            None => self.hold(),
        }
    }

    /// No new evidence: an identified value becomes held (a restored one
    /// stays restored, a prior's stays the prior's).
    fn hold(&mut self) {
        if self.value.is_some()
            && !matches!(
                self.status,
                Identification::Restored | Identification::Prior
            )
        {
            self.status = Identification::Held;
        }
    }
}

impl<T: Real> PublishedParameter<T> {
    /// A value identified further than `span` from the state of charge
    /// `soc` expires.
    fn expire(&mut self, soc: Option<T>, span: T) {
        if let (Some(now), Some(then), Some(_)) = (soc, self.soc, self.value) {
            if (now - then).abs() > span {
                self.value = None;
                self.status = Identification::Expired;
            }
        }
    }
}

/// The parameters a cell publishes, each with its own status.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PublishedParameters<T> {
    /// `R_i` (Ω).
    pub r_i: PublishedParameter<T>,
    /// `R_ct` (Ω).
    pub r_ct: PublishedParameter<T>,
    /// `Q` (`τ = R_ct·Q`).
    pub q: PublishedParameter<T>,
    /// The order α.
    pub alpha: PublishedParameter<T>,
}

impl<T: Copy> PublishedParameters<T> {
    /// Nothing published yet.
    pub const NONE: Self = Self {
        r_i: PublishedParameter::NONE,
        r_ct: PublishedParameter::NONE,
        q: PublishedParameter::NONE,
        alpha: PublishedParameter::NONE,
    };

    /// The four in the order `[R_i, R_ct, Q, α]` with their names.
    pub fn named(&self) -> [(&'static str, PublishedParameter<T>); 4] {
        [
            ("r_i", self.r_i),
            ("r_ct", self.r_ct),
            ("q", self.q),
            ("alpha", self.alpha),
        ]
    }

    /// The same as restored from a snapshot: every published value marked
    /// [`Identification::Restored`].
    pub(crate) fn restored(mut self) -> Self {
        for p in [&mut self.r_i, &mut self.r_ct, &mut self.q, &mut self.alpha] {
            if p.value.is_some() {
                p.status = Identification::Restored;
            }
        }
        self
    }

    /// Every parameter held (no new evidence from this update).
    pub(super) fn hold(&mut self) {
        self.r_i.hold();
        self.r_ct.hold();
        self.q.hold();
        self.alpha.hold();
    }

    /// The same with every value mapped by `f`.
    pub fn map<U>(self, f: impl Fn(T) -> U) -> PublishedParameters<U> {
        PublishedParameters {
            r_i: self.r_i.map(&f),
            r_ct: self.r_ct.map(&f),
            q: self.q.map(&f),
            alpha: self.alpha.map(&f),
        }
    }
}

impl<T: Real> PublishedParameters<T> {
    /// Every value identified further than `span` from the state of
    /// charge `soc` expires.
    pub(super) fn expire(&mut self, soc: Option<T>, span: T) {
        self.r_i.expire(soc, span);
        self.r_ct.expire(soc, span);
        self.q.expire(soc, span);
        self.alpha.expire(soc, span);
    }
}

/// The resistance a current step showed: `ΔU/ΔI` between two consecutive
/// samples, a model-free measure of the resistance within one sample
/// period (`R_i` and the part of the branch that answers within it).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepResistance<T> {
    /// `ΔU/ΔI` (Ω).
    pub ohm: T,
    /// The step `ΔI` (A).
    pub step_a: T,
    /// The current before the step (A): with the Butler–Volmer term the
    /// model's answer to the step depends on where it starts
    /// ([`Self::model_ohm`]).
    pub from_a: T,
    /// [`CellState`]'s sample count when it was seen.
    pub at_sample: u64,
}

impl<T: Real> StepResistance<T> {
    /// What the model `p` answers this step with at once, its chord
    /// resistance over the step: `(R_i·I + a·asinh(I/i₀))` from
    /// [`Self::from_a`] to `from_a + step_a`, over `step_a`. `R_i` itself
    /// in the linear model: there the step measures `R_i`; with the
    /// Butler–Volmer term it measures `R_i` and the term's chord together,
    /// and `R_i` alone may be far below it.
    pub fn model_ohm(&self, p: &CellParameters<T>) -> T {
        if p.is_butler_volmer() {
            (p.static_voltage(self.from_a + self.step_a) - p.static_voltage(self.from_a))
                / self.step_a
        } else {
            p.r_i
        }
    }
}

/// A step counts when its resistance is known to this fraction (its 95 %
/// half-width from the fit's RMSE in both samples, `2·√2·RMSE/|ΔI|`,
/// against the resistance itself).
pub const STEP_PRECISION: f64 = 0.25;

/// The voltage noise a step is judged against before a fit (V): a
/// cycler's or a cell monitor's resolution, about 0.1 mV.
pub const STEP_NOISE_FLOOR_V: f64 = 1e-4;

/// 95 % two-sided normal quantile.
const Z95: f64 = 1.96;

/// Whether the current `i` after `prev` is a clean edge, as a step
/// resistance is taken and a state of power is checked
/// ([`crate::battery::power::PulseCheck`]): the current before it steady
/// (`before`, the current of the sample before `prev`, within a tenth of
/// the step), the step at least half of the larger of the two currents
/// and a hundred times `min_current_std`.
pub(crate) fn clean_edge<T: Real>(min_current_std: T, before: T, prev: T, i: T) -> bool {
    let di = i - prev;
    let edge = T::lit(0.5) * i.abs().max(prev.abs());
    di.is_finite()
        && di.abs() >= T::lit(100.0) * min_current_std
        && di.abs() >= edge
        && (prev - before).abs() <= T::lit(0.1) * di.abs()
}

/// Whether a voltage change `du` (V) is known to [`STEP_PRECISION`]
/// against `noise_v`, the voltage's scatter in each of its two samples
/// (its 95 % half-width `2·√2·noise_v`).
pub(crate) fn precise_change<T: Real>(noise_v: T, du: T) -> bool {
    T::lit(2.0 * core::f64::consts::SQRT_2) * noise_v <= T::lit(STEP_PRECISION) * du.abs()
}

impl<T: Real, const N: usize> CellState<T, N> {
    /// The voltage's scatter in one sample (V): the window's RMSE, or
    /// before a fit (or after the window restarted)
    /// [`STEP_NOISE_FLOOR_V`], a logger's resolution.
    pub(crate) fn voltage_noise(&self) -> T {
        if self.rmse.is_finite() {
            self.rmse
        } else {
            T::lit(STEP_NOISE_FLOOR_V)
        }
    }

    /// The step resistance of the sample `(i, u)` (window coordinates)
    /// after the previous one `prev`, when the step is a clean edge: the
    /// current before it steady (`before`, the current of the sample
    /// before `prev`, within a tenth of the step), the step at least half
    /// of either current and a hundred times `min_current_std`, and its
    /// resistance known to [`STEP_PRECISION`] against the fit's RMSE
    /// ([`STEP_NOISE_FLOOR_V`] before a fit). A sample that straddles the edge (a bin
    /// average, an interpolation across a gap) is the step's first sample
    /// or is passed over: the next one's current before it is not steady.
    pub(super) fn observe_step(&mut self, min_current_std: T, before: T, prev: (T, T), i: T, u: T) {
        let (di, du) = (i - prev.0, u - prev.1);
        if !du.is_finite() || !clean_edge(min_current_std, before, prev.0, i) {
            return;
        }
        let ohm = du / di;
        // Before a fit (or after the window restarted), a logger's
        // resolution stands for the fit's RMSE: a step whose voltage hardly
        // moves (a resampled row that kept the voltage from before the
        // edge) says nothing of the resistance.
        let precise = precise_change(self.voltage_noise(), du);
        if precise && ohm > T::zero() {
            self.step = Some(StepResistance {
                ohm,
                step_a: di,
                from_a: prev.0,
                at_sample: self.counts.samples,
            });
        }
    }

    /// The step resistance to fit `R_i` with as evidence in the next
    /// update (none with a prior, or when the last window alone
    /// identified `R_i`): while `R_i` is published from the step
    /// ([`Identification::Step`]), and when the last estimate's `R_i`
    /// contradicts the step (outside [`OnlineSettings::identify_factor`]
    /// of it: the window gave the instantaneous answer to the branch). An
    /// `R_i` consistent with the step but not identified is left to the
    /// data: the step also holds the branch's first sample, and pulling
    /// `R_i` towards it would bias the branch.
    pub(super) fn r_i_evidence<const P: usize>(&self, s: &OnlineSettings<T, P>) -> Option<T> {
        let st = self.step?;
        if s.battery.prior.is_some() {
            return None;
        }
        // The `R_i` the step asks for: the step less the Butler–Volmer
        // term's chord over it (the last estimate's); the step itself in
        // the linear model.
        let kinetic = self
            .estimate
            .as_ref()
            .map_or(T::zero(), |p| st.model_ohm(p) - p.r_i);
        let step = st.ohm - kinetic;
        if step.partial_cmp(&T::zero()) != Some(core::cmp::Ordering::Greater) {
            return None;
        }
        let f = s.identify_factor;
        match self.published.r_i.status {
            Identification::Identified => None,
            Identification::Step => Some(step),
            _ => self
                .estimate
                .as_ref()
                .filter(|p| {
                    let m = st.model_ohm(p);
                    !(m >= st.ohm / f && m <= st.ohm * f)
                })
                .map(|_| step),
        }
    }

    /// Judges each parameter of the window's estimate `p` by the window's
    /// information `info` (none: nothing identified) and `R_i` also by the
    /// last step resistance (`evidence`: `R_i` was fitted with it,
    /// [`Self::r_i_evidence`]); updates what is published.
    pub(super) fn judge<const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        p: &CellParameters<T>,
        info: Option<&FitInformation<T>>,
        evidence: bool,
    ) {
        let Some(info) = info else {
            self.published.hold();
            return;
        };
        // Identified: by the window's data alone. With a prior whose
        // interval passes but the data's alone does not: the prior's.
        let with_prior = info.correlated_standard_errors();
        let has_prior = s.battery.prior.is_some();
        let data = if has_prior {
            info.without_prior(&s.battery).correlated_standard_errors()
        } else {
            with_prior
        };
        let z = T::lit(Z95);
        let log_within = |se: &[Option<T>; COLUMNS], k: usize| {
            se[k].is_some_and(|e| z * e <= s.identify_factor.ln())
        };
        let step_ok = self.step.is_none_or(|st| {
            let m = st.model_ohm(p);
            m >= st.ohm / s.identify_factor && m <= st.ohm * s.identify_factor
        });
        let soc = self.soc;
        let (id, prior) = (Identification::Identified, Identification::Prior);
        let judged = |data_ok: bool, prior_ok: bool| {
            if data_ok {
                Some(id)
            } else if prior_ok && has_prior {
                Some(prior)
            } else {
                None
            }
        };
        let r_i = if log_within(&data, 0) && step_ok {
            Some(id)
        } else if evidence && self.step.is_some() && step_ok {
            Some(Identification::Step)
        } else {
            judged(false, log_within(&with_prior, 0) && step_ok)
        };
        let r_ct = judged(log_within(&data, 1), log_within(&with_prior, 1));
        let q = judged(log_within(&data, 2), log_within(&with_prior, 2));
        // A fixed order is given, not estimated: published as it is.
        let alpha_within =
            |se: &[Option<T>; COLUMNS]| se[3].is_some_and(|e| z * e <= s.identify_alpha);
        let alpha = if info.fitted[3] {
            judged(alpha_within(&data), alpha_within(&with_prior))
        } else {
            Some(id)
        };
        // Each value's spread: the data's where they identify it, with the
        // prior's where only that passes, and a step's precision for
        // `R_i` from a step.
        let spread = |k: usize, st: Identification| match st {
            Identification::Prior => with_prior[k],
            Identification::Step => Some(T::lit(STEP_PRECISION / Z95)),
            _ => data[k],
        };
        let value = |x: T, k: usize, st: Option<Identification>| st.map(|st| (x, spread(k, st)));
        let alpha_v = if info.fitted[3] {
            value(p.alpha, 3, alpha)
        } else {
            // A fixed order is known exactly.
            alpha.map(|_| (p.alpha, Some(T::zero())))
        };
        // The slow part: what the windows identified, carried across them
        // ([`super::fusion`]; each window's own with `slow_memory_s` 0).
        let at = (self.counts.samples, soc);
        let slow = &mut self.slow;
        let mut fused = |k: Slow, v: Option<(T, Option<T>)>, st: Option<Identification>| {
            v.map(|(x, e)| match st {
                Some(Identification::Identified) => (slow.take(s, k, x, e, at), e),
                _ => (x, e),
            })
        };
        let r_ct_v = fused(Slow::RCt, value(p.r_ct, 1, r_ct), r_ct);
        let q_v = fused(Slow::Q, value(p.q, 2, q), q);
        let alpha_v = fused(Slow::Alpha, alpha_v, alpha);
        let pb = &mut self.published;
        pb.r_i.update(value(p.r_i, 0, r_i), r_i.unwrap_or(id), soc);
        pb.r_ct.update(r_ct_v, r_ct.unwrap_or(id), soc);
        pb.q.update(q_v, q.unwrap_or(id), soc);
        pb.alpha.update(alpha_v, alpha.unwrap_or(id), soc);
    }
}

impl<T: Real, const N: usize> CellState<T, N> {
    /// The parameters a state of power is predicted with, and where they
    /// come from ([`SopBasis`]), as one set (a constant-phase branch's
    /// `R_ct`, `Q` and α trade along a relaxation: values of different
    /// windows do not make one branch):
    ///
    /// - [`SopBasis::Window`]: the last update's window identified every
    ///   parameter ([`Identification::Identified`] or
    ///   [`Identification::Step`]): its estimate;
    /// - [`SopBasis::Map`]: else, with a prior (the map at the present
    ///   state of charge and temperature), the prior's `R_i`, `R_ct`, `Q`
    ///   and α;
    /// - [`SopBasis::Held`]: else, while every parameter has a published
    ///   value (identified by an earlier window within
    ///   [`OnlineSettings::hold_soc_span`], or restored), the last good
    ///   estimate;
    /// - [`SopBasis::Stale`]: else, once every parameter has been
    ///   published at least once, the last good estimate.
    ///
    /// The rest of the model (`ΔU`, the Butler–Volmer term) is the last
    /// estimate's, in the window's coordinates (with a prior and no
    /// estimate yet, none: a pulse is then predicted only from a relaxed
    /// cell, its `ΔU` read from the rested voltage). `None` without a
    /// prior before the first estimate, or while a parameter has never
    /// been published.
    pub fn sop_parameters<const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
    ) -> Option<(CellParameters<T>, SopBasis)> {
        let prior = s.battery.prior.as_ref().map(|pr| pr.center);
        let Some(p) = self.estimate else {
            let c = prior?;
            // (A Butler–Volmer map's term is not predicted from: its
            // currents are capped at what a fitted window saw.)
            let q = CellParameters {
                u_oc: T::zero(),
                ..c
            };
            return Some((q, SopBasis::Map));
        };
        let named = self.published.named();
        let window = named.iter().all(|(_, x)| {
            x.value.is_some()
                && matches!(x.status, Identification::Identified | Identification::Step)
        });
        if window {
            return Some((p, SopBasis::Window));
        }
        if let Some(c) = prior {
            let q = CellParameters {
                r_i: c.r_i,
                r_ct: c.r_ct,
                q: c.q,
                alpha: c.alpha,
                ..p
            };
            return Some((q, SopBasis::Map));
        }
        if named.iter().all(|(_, x)| x.value.is_some()) {
            return Some((p, SopBasis::Held));
        }
        let ever = named
            .iter()
            .zip(self.stale)
            .all(|((_, x), st)| x.value.is_some() || !st.is_nan());
        ever.then_some((p, SopBasis::Stale))
    }

    /// How far the set [`sop_parameters`](Self::sop_parameters) gives for
    /// `basis` may be from the cell's ([`ParameterSpread`]). The widest
    /// spread a published value can have is its identification's bound,
    /// `ln(`[`OnlineSettings::identify_factor`]`)/1.96`
    /// ([`OnlineSettings::identify_alpha`]`/1.96` for α):
    ///
    /// - [`SopBasis::Window`]: each value's own spread from the window
    ///   that identified it ([`PublishedParameter::sigma`]);
    /// - [`SopBasis::Held`]: the same, widened in quadrature by the bound
    ///   times the state of charge moved since it was identified over
    ///   [`OnlineSettings::hold_soc_span`] (the whole bound at the span's
    ///   edge); the bound where it is not known (a restored value);
    /// - [`SopBasis::Map`]: the bound (a map row is an identified value,
    ///   but of another record of the cell);
    /// - [`SopBasis::Stale`]: twice the bound (a value identified further
    ///   away than the state of charge it is held over).
    ///
    /// A Butler–Volmer term the linear model holds (a Butler–Volmer
    /// prior's, [`OnlineSettings::holds_kinetic_term`]) is a map value
    /// whatever the basis: its `ln a` and `ln i₀` have the bound of `R_i` each
    /// ([`ParameterSpread::bv_a`]; docs/state-of-power.md).
    ///
    /// Whatever the basis, `R_i`'s is widened in quadrature by what the
    /// model misses at a current step, seen without it: `|ln(R_step /
    /// R_model)|` of the last clean step ([`StepResistance::ohm`] against
    /// [`StepResistance::model_ohm`] of `p`, the set predicted with). A
    /// parameter's interval is what its window knows of it; a pulse's
    /// first seconds also carry what the model cannot follow (a
    /// resistance that falls with the current, a relaxation faster than a
    /// sample): with it, the measured Panasonic HPPC pulses end above
    /// `pulse_v − 2σ` at 92.5–95.0 % of the pulses without a prior
    /// (docs/bms-states.md).
    ///
    /// The voltage's scatter is the window's RMSE (before a fit, 0.1 mV:
    /// a cell monitor's resolution), and `response` what the cell's last
    /// checked pulse missed its prediction by
    /// ([`crate::battery::power::PulseCheck::missed`];
    /// [`ResponseMiss::NONE`] when none was checked).
    pub fn sop_spread<const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
        basis: SopBasis,
        p: &CellParameters<T>,
        response: ResponseMiss<T>,
    ) -> ParameterSpread<T> {
        let z = T::lit(Z95);
        let bound = [
            s.identify_factor.ln() / z,
            s.identify_factor.ln() / z,
            s.identify_factor.ln() / z,
            s.identify_alpha / z,
        ];
        let named = self.published.named();
        let mut sd = bound;
        match basis {
            SopBasis::Window => {
                for (x, (_, p)) in sd.iter_mut().zip(named) {
                    if let Some(e) = p.sigma.filter(|e| e.is_finite()) {
                        *x = e;
                    }
                }
            }
            SopBasis::Held => {
                // Widened with the state of charge moved since: to the
                // bound at the hold span's edge.
                let span = s.hold_soc_span;
                for ((x, (_, p)), b) in sd.iter_mut().zip(named).zip(bound) {
                    let moved = match (self.soc, p.soc) {
                        (Some(now), Some(then)) if span > T::zero() => {
                            ((now - then).abs() / span).min(T::one())
                        }
                        _ => T::zero(),
                    };
                    if let Some(e) = p.sigma.filter(|e| e.is_finite()) {
                        let far = moved * b;
                        *x = (e * e + far * far).sqrt();
                    }
                }
            }
            SopBasis::Map => {}
            SopBasis::Stale => {
                for x in sd.iter_mut() {
                    *x = T::lit(2.0) * *x;
                }
            }
        }
        if let Some(st) = self.step {
            let miss = (st.ohm / st.model_ohm(p)).ln().abs();
            if miss.is_finite() {
                sd[0] = (sd[0] * sd[0] + miss * miss).sqrt();
            }
        }
        // A Butler–Volmer term the linear model holds is the prior's (a
        // map's, fitted over another record): the map's bound, whatever
        // the basis. The Butler–Volmer model's own term is the window's,
        // and is not moved.
        let held = s.holds_kinetic_term() && p.is_butler_volmer();
        let term = if held { bound[0] } else { T::zero() };
        ParameterSpread {
            r_i: sd[0],
            r_ct: sd[1],
            q: sd[2],
            alpha: sd[3],
            bv_a: term,
            bv_i0: term,
            noise_v: self.voltage_noise(),
            response,
        }
    }
}
