//! The online estimator's settings: the method, the sample limits, the spike
//! test, the OCV curve, and the plausibility check an estimate must pass
//! before it is published ([`OnlineSettings::implausible`]).

use super::*;
use crate::battery::ocv::OcvModel;
use crate::battery::soc::SocSettings;
use crate::battery::{BatterySettings, CellModel, CellParameters, Start};
use crate::error::Error;
use crate::real::Real;

/// Leading rested samples (current at most `C/100`) whose mean voltage
/// gives the start state of charge when none is set.
pub(super) const REST_SAMPLES: u8 = 10;

/// Which identification method runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Method {
    /// The paper's 2S-OP-GI on the §6.2 regression alone.
    Paper,
    /// Output-error refinement started from 2S-OP-GI (the most accurate).
    Refined,
}

/// Settings of the online estimator (one value for all cells of a pack),
/// with room for an OCV curve of `P` points (`P = 0`: no curve, a constant
/// `U_oc` as in §6.2).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OnlineSettings<T, const P: usize = 0> {
    /// The estimators' settings (use [`Start::FromData`] for a sliding
    /// window).
    pub battery: BatterySettings<T>,
    /// Method.
    pub method: Method,
    /// Iterations run after each sample.
    pub iterations_per_sample: u16,
    /// Iterations of 2S-OP-GI after which the refinement starts even if the
    /// paper method's estimate is not physical yet (it then starts from
    /// `initial`).
    pub paper_budget: u32,
    /// Starting order of 2S-OP-GI.
    pub alpha0: T,
    /// Fallback start of the refinement (e.g. the datasheet values).
    pub initial: CellParameters<T>,
    /// Largest plausible `|I|` (A).
    pub current_limit: T,
    /// Plausible terminal voltage range (V).
    pub voltage_min: T,
    /// Upper end of the plausible voltage range (V).
    pub voltage_max: T,
    /// A voltage further than this many model RMSEs from the prediction is a
    /// spike…
    pub spike_sigmas: T,
    /// …and further than this (V) at least.
    pub spike_floor: T,
    /// After this many consecutive spikes the sample is believed.
    pub max_consecutive_spikes: u8,
    /// The cell's OCV curve and capacity (`None`: constant `U_oc`).
    pub ocv: Option<OcvModel<T, P>>,
    /// With a curve, the largest plausible OCV offset `|ΔU|` (V).
    pub max_ocv_offset: T,
    /// The longest relaxation time `τ^(1/α)` a published estimate may have,
    /// in fitted windows (`(L − M + 1)·h`); with a prior, at least the
    /// prior's own ([`OnlineSettings::prior_relaxation`]).
    pub max_relaxation_windows: T,
    /// `R_i`, `R_ct` and `Q` are published when their 95 % interval from
    /// the window's information is within this factor either way, `R_i`
    /// also when it is within this factor of the last step resistance
    /// ([`super::PublishedParameters`]).
    pub identify_factor: T,
    /// α is published when its 95 % interval is within ± this.
    pub identify_alpha: T,
    /// A published value identified at a state of charge further than
    /// this from the present one expires (with an OCV curve): resistances
    /// and time constants change with the state of charge.
    pub hold_soc_span: T,
    /// The memory (s) of the slow part carried across windows: what is
    /// published of `R_ct`, `Q` and α is the information-weighted mean of
    /// the values the windows identified, an earlier one weighing
    /// `exp(−Δt/slow_memory_s)` less (and nothing beyond
    /// [`hold_soc_span`](Self::hold_soc_span) of state of charge). 0 (the
    /// default): each window's own value.
    pub slow_memory_s: T,
    /// The slow part's memory in state of charge: an earlier value weighs
    /// `exp(−|ΔSOC|/slow_memory_soc)` less besides (with an OCV curve;
    /// default 0.02: resistances and time constants change with the state
    /// of charge).
    pub slow_memory_soc: T,
    /// The current (A, + charging) of the pulse whose voltage the state of
    /// power is asked for ([`PowerSettings::pulse_current`](crate::battery::power::PowerSettings::pulse_current)).
    /// Each cell keeps what its last pulse of this current (within a
    /// tenth) from a settled cell measured against its prediction at each
    /// checked duration ([`PulseCheck`](crate::battery::power::PulseCheck)),
    /// and that pulse voltage, from a settled cell, is corrected by it:
    /// the pulse's own response scaled by the measured over predicted drop
    /// ([`PulseCheck::corrected`](crate::battery::power::PulseCheck::corrected)).
    /// `None` (the default): no correction. Finite and not 0.
    pub pulse_current: Option<T>,
    /// Where in the period whose mean current a sample holds its voltage
    /// was taken: at its end (the default: a gauge, a simulation), the
    /// mean over it (a log put on a coarser period than its rows), or at
    /// its start ([`VoltageTiming`](crate::battery::power::VoltageTiming)).
    /// The check of the state of power against the next pulse places each
    /// voltage so
    /// ([`PulseCheck::observe_watching`](crate::battery::power::PulseCheck::observe_watching)).
    pub voltage_timing: crate::battery::power::VoltageTiming,
    /// The SOC observer beside the count (with a curve;
    /// [`crate::battery::soc`]). [`with_curve`](Self::with_curve) sets its
    /// defaults for the curve's capacity: change them after it.
    pub soc: SocSettings<T>,
}

impl<T: Real> OnlineSettings<T> {
    /// Defaults for a Li-ion cell sampled every `h` seconds with memory
    /// `memory`: refined method, one iteration per sample, start from data,
    /// no OCV curve (OCV slope fitted),
    /// `|I| ≤ 500 A`, `U_t ∈ [1.5, 5] V`, spikes beyond `max(8·RMSE, 50 mV)`,
    /// 3 consecutive spikes believed; published relaxation times up to one
    /// fitted window, OCV offsets up to 0.15 V; parameters published when
    /// identified to a factor 2 (α to ±0.1), held within 0.15 of the state
    /// of charge they were identified at; each window's own values published
    /// (no slow part carried across windows).
    pub fn new(h: T, memory: usize, initial: CellParameters<T>) -> Self {
        let mut battery = BatterySettings::new(h, memory);
        battery.start = Start::FromData;
        battery.ocv_slope = true;
        Self {
            battery,
            method: Method::Refined,
            iterations_per_sample: 1,
            paper_budget: 200,
            alpha0: T::lit(0.5),
            initial,
            current_limit: T::lit(500.0),
            voltage_min: T::lit(1.5),
            voltage_max: T::lit(5.0),
            spike_sigmas: T::lit(8.0),
            spike_floor: T::lit(0.05),
            max_consecutive_spikes: 3,
            ocv: None,
            max_ocv_offset: T::lit(0.15),
            max_relaxation_windows: T::one(),
            identify_factor: T::lit(2.0),
            identify_alpha: T::lit(0.1),
            hold_soc_span: T::lit(0.15),
            slow_memory_s: T::zero(),
            slow_memory_soc: T::lit(0.02),
            pulse_current: None,
            voltage_timing: crate::battery::power::VoltageTiming::End,
            soc: SocSettings::new(T::one(), h),
        }
    }
}

impl<T: Real, const P: usize> OnlineSettings<T, P> {
    /// The same settings with the cell's OCV curve and capacity: the
    /// estimator counts the state of charge and fits the overpotential
    /// `U_t − OCV(SOC)`, so the OCV slope is no longer fitted.
    pub fn with_ocv<const Q: usize>(self, ocv: OcvModel<T, Q>) -> OnlineSettings<T, Q> {
        self.with_curve(Some(ocv))
    }

    /// [`with_ocv`](Self::with_ocv) for a curve that may be absent: `None`
    /// gives the same settings without a curve, in the type that has room
    /// for `Q` points (one settings type whether or not a file names a
    /// curve).
    pub fn with_curve<const Q: usize>(self, ocv: Option<OcvModel<T, Q>>) -> OnlineSettings<T, Q> {
        let mut battery = self.battery;
        let mut soc = self.soc;
        if let Some(m) = &ocv {
            battery.ocv_slope = false;
            soc = SocSettings::new(m.capacity_ah, battery.h);
        }
        OnlineSettings {
            battery,
            method: self.method,
            iterations_per_sample: self.iterations_per_sample,
            paper_budget: self.paper_budget,
            alpha0: self.alpha0,
            initial: self.initial,
            current_limit: self.current_limit,
            voltage_min: self.voltage_min,
            voltage_max: self.voltage_max,
            spike_sigmas: self.spike_sigmas,
            spike_floor: self.spike_floor,
            max_consecutive_spikes: self.max_consecutive_spikes,
            ocv,
            max_ocv_offset: self.max_ocv_offset,
            identify_factor: self.identify_factor,
            identify_alpha: self.identify_alpha,
            hold_soc_span: self.hold_soc_span,
            slow_memory_s: self.slow_memory_s,
            slow_memory_soc: self.slow_memory_soc,
            max_relaxation_windows: self.max_relaxation_windows,
            pulse_current: self.pulse_current,
            voltage_timing: self.voltage_timing,
            soc,
        }
    }

    /// The refinement's fallback start in the window's coordinates: with a
    /// curve, [`initial`](Self::initial) with `U_oc` replaced by `ΔU = 0`.
    pub fn initial_in_window(&self) -> CellParameters<T> {
        // With a prior, its centre is the better start.
        let start = match &self.battery.prior {
            Some(pr) => CellParameters {
                u_oc: self.initial.u_oc,
                ..pr.center
            },
            None => self.initial,
        };
        match self.ocv {
            Some(_) => CellParameters {
                u_oc: T::zero(),
                ..start
            },
            None => start,
        }
    }

    /// Why `p` (in the estimator's coordinates: `u_oc` is `ΔU` with a
    /// curve) may not be published from a window of `rows` fitted samples
    /// whose current has standard deviation `current_std` (A), fitted to
    /// `rmse` (V), or `None` when it may.
    pub fn implausible(
        &self,
        p: &CellParameters<T>,
        rows: usize,
        current_std: T,
        rmse: T,
    ) -> Option<Status> {
        let b = &self.battery;
        let pos = |x: T| x.is_finite() && x > T::zero();
        if !(pos(p.r_i) && pos(p.r_ct) && pos(p.q) && pos(p.alpha) && p.alpha <= T::one()) {
            return Some(Status::Unphysical);
        }
        if !(p.bv_a.is_finite() && p.bv_a >= T::zero() && pos(p.bv_i0)) {
            return Some(Status::Unphysical);
        }
        let ocv_ok = match self.ocv {
            Some(_) => p.u_oc.abs() <= self.max_ocv_offset,
            None => p.u_oc >= self.voltage_min && p.u_oc <= self.voltage_max,
        };
        if !ocv_ok {
            return Some(Status::OcvImplausible);
        }
        let tol = T::lit(1e-3);
        if p.alpha <= b.alpha_min + tol || (b.alpha_max < T::one() && p.alpha >= b.alpha_max - tol)
        {
            return Some(Status::AtBound);
        }
        // R_ct at its lower bound, 0: a branch whose voltage swing is below
        // the fit's residual is not seen by the window (nor are its Q, α).
        let swing = p.r_ct * current_std;
        if swing.is_nan() || rmse.is_nan() || swing < rmse {
            return Some(Status::AtBound);
        }
        let relax = p.tau().powf(T::one() / p.alpha);
        let longest = self.max_relaxation_windows * T::lit(rows as f64) * b.h;
        // (The prior's relaxation, a power, only when the window's is
        // beyond the window.)
        if relax.is_nan() || (relax > longest && relax > self.prior_relaxation()) {
            return Some(Status::SlowRelaxation);
        }
        None
    }

    /// Whether a Butler–Volmer term in the cell's parameters is held, not
    /// fitted: the linear model ([`CellModel::Linear`]) never fits the
    /// term, so one it carries is a prior's (a map fitted with the term
    /// over its test's currents). A held term is not capped at the
    /// window's largest current, needs no window that has seen one, and
    /// its spread is the prior's bound.
    pub fn holds_kinetic_term(&self) -> bool {
        self.battery.model == CellModel::Linear
    }

    /// Whether the slow part is carried across windows
    /// ([`slow_memory_s`](Self::slow_memory_s) above 0; a snapshot then
    /// keeps it, [`crate::battery::snapshot`]).
    pub fn carries_slow_part(&self) -> bool {
        self.slow_memory_s > T::zero()
    }

    /// The longest relaxation a window's estimate may have because the
    /// prior has it (s): the prior's own `τ^(1/α)` with `τ` widened by
    /// [`identify_factor`](Self::identify_factor)² (its `R_ct` and `Q`
    /// each by the factor); 0 without a prior. A window of a drive cycle
    /// does not see a relaxation of many minutes, but when the prior (a
    /// map fitted over the whole test, rests included) carries one, the
    /// window's fit keeps it from the prior: that branch is the prior's,
    /// not a drift the window imitates, and the window's `R_i` is still
    /// judged on its own (docs/maps.md).
    pub fn prior_relaxation(&self) -> T {
        let Some(pr) = &self.battery.prior else {
            return T::zero();
        };
        let c = &pr.center;
        let f = self.identify_factor;
        let relax = (c.tau() * f * f).powf(T::one() / c.alpha);
        if relax.is_finite() && relax > T::zero() {
            relax
        } else {
            T::zero()
        }
    }
}

/// Checks the limits of the online settings (the rest is checked by the
/// estimators).
pub(crate) fn check_limits<T: Real, const P: usize>(s: &OnlineSettings<T, P>) -> Result<(), Error> {
    let limits_ok = s.current_limit > T::zero()
        && s.current_limit.is_finite()
        && s.voltage_min.is_finite()
        && s.voltage_max.is_finite()
        && s.voltage_min < s.voltage_max
        && s.spike_sigmas > T::zero()
        && s.spike_floor > T::zero()
        && s.spike_floor.is_finite()
        && s.max_ocv_offset > T::zero()
        && s.max_relaxation_windows > T::zero()
        && s.slow_memory_s >= T::zero()
        && s.slow_memory_soc > T::zero()
        && s.pulse_current
            .is_none_or(|i| i.is_finite() && i != T::zero());
    if !limits_ok {
        return Err(Error::BadSetting);
    }
    if let Some(m) = &s.ocv {
        m.check()?;
    }
    s.soc.check()
}
