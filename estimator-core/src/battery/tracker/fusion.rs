//! The slow part carried across windows ([`SlowFusion`]): what is
//! published of `R_ct`, `Q` and α as a running mean of the values the
//! windows identified, not the last window's alone.
//!
//! One window of a few minutes pins the branch's slow part loosely: from
//! one window to the next its `Q` scatters by several per cent
//! (docs/pack.md). Each identified value enters a mean weighted by its
//! information (`1/σ²` of `ln R_ct`, `ln Q`, α) that forgets with time and
//! with the state of charge moved (by `exp(−Δt/τ − |ΔSOC|/σ)`, `τ` =
//! [`OnlineSettings::slow_memory_s`](super::OnlineSettings::slow_memory_s),
//! `σ` =
//! [`OnlineSettings::slow_memory_soc`](super::OnlineSettings::slow_memory_soc))
//! and starts again where the state of charge has moved beyond
//! [`OnlineSettings::hold_soc_span`](super::OnlineSettings::hold_soc_span)
//! from the last value it took. Measured in docs/online-publication.md.
//!
//! It owns those sums; it must not judge what is identified
//! ([`super::identified`] does, and asks it for the value to publish) nor
//! touch the estimate the refinement iterates from.

use super::OnlineSettings;
use crate::real::Real;

/// The running means of `ln R_ct`, `ln Q` and α (in that order).
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SlowFusion<T> {
    /// Per parameter, the summed weight (0: nothing fused)…
    weight: [T; 3],
    /// …the weighted sum of the values…
    sum: [T; 3],
    /// …and the state of charge of the last value taken (NaN: none known).
    soc: [T; 3],
    /// The sample count and the state of charge (NaN: not known) the
    /// weights were last aged to.
    at: (u64, T),
}

/// Which of the fused parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Slow {
    /// `R_ct` (fused as its log).
    RCt = 0,
    /// `Q` (fused as its log).
    Q = 1,
    /// α.
    Alpha = 2,
}

impl<T: Real> SlowFusion<T> {
    /// Nothing fused yet.
    pub const EMPTY: Self = Self {
        weight: [T::ZERO; 3],
        sum: [T::ZERO; 3],
        soc: [T::NAN; 3],
        at: (0, T::NAN),
    };

    /// Takes the value `x` of parameter `k` with its spread `sigma` (of its
    /// log for `R_ct` and `Q`, of α itself), identified at sample `n` and
    /// state of charge `soc` (`at = (n, soc)`), into the mean, and returns
    /// the mean. The earlier values' weight falls by `exp(−(n − n₀)·h/τ −
    /// |soc − soc₀|/σ)` (`τ` = [`OnlineSettings::slow_memory_s`], `σ` =
    /// [`OnlineSettings::slow_memory_soc`]; the state of charge's term
    /// where both are known), and to nothing beyond
    /// [`OnlineSettings::hold_soc_span`] of state of charge from the last
    /// value taken. `x` itself is returned, and nothing is kept, when its
    /// spread is not a positive finite number (a fixed order) or `τ` is 0.
    pub(super) fn take<const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        k: Slow,
        x: T,
        sigma: Option<T>,
        at: (u64, Option<T>),
    ) -> T {
        // (Off: nothing computed, as the MCU runs by default.)
        if !s.carries_slow_part() {
            return x;
        }
        let i = k as usize;
        let log = k != Slow::Alpha;
        let y = if log { x.ln() } else { x };
        let Some(sd) = sigma.filter(|e| e.is_finite() && *e > T::zero()) else {
            return x;
        };
        if !y.is_finite() {
            return x;
        }
        // Every weight ages together (one count for the three).
        let (n, soc) = at;
        let now = soc.unwrap_or(T::nan());
        let (n0, soc0) = self.at;
        let moved_soc = (now - soc0).abs();
        let by_soc = if moved_soc.is_nan() {
            T::zero()
        } else {
            moved_soc / s.slow_memory_soc
        };
        if n > n0 || by_soc > T::zero() {
            let dt = T::lit(n.saturating_sub(n0) as f64) * s.battery.h;
            let keep = (-dt / s.slow_memory_s - by_soc).exp();
            for j in 0..3 {
                self.weight[j] = keep * self.weight[j];
                self.sum[j] = keep * self.sum[j];
            }
        }
        self.at = (n0.max(n), if now.is_nan() { soc0 } else { now });
        // (NaN on either side: not known to have moved.)
        let moved = (now - self.soc[i]).abs() > s.hold_soc_span;
        let w = T::one() / (sd * sd);
        if moved || self.weight[i].partial_cmp(&T::zero()) != Some(core::cmp::Ordering::Greater) {
            self.weight[i] = T::zero();
            self.sum[i] = T::zero();
        }
        self.weight[i] = self.weight[i] + w;
        self.sum[i] = self.sum[i] + w * y;
        self.soc[i] = now;
        let mean = self.sum[i] / self.weight[i];
        match (mean.is_finite(), log) {
            (false, _) => {
                // (A weight beyond the float's range: start again here.)
                self.weight[i] = w;
                self.sum[i] = w * y;
                x
            }
            (true, true) => mean.exp(),
            (true, false) => mean,
        }
    }
}

/// Whether `parts` are a mean's ([`SlowFusion::parts`]): every weight
/// finite and not negative, every sum finite and 0 without a weight, every
/// state of charge finite or NaN (none known).
pub(crate) fn plausible_parts<T: Real>(parts: &[T; SLOW_PARTS]) -> bool {
    let soc_ok = |z: T| z.is_nan() || z.is_finite();
    (0..3).all(|k| {
        let (w, sum, soc) = (parts[3 * k], parts[3 * k + 1], parts[3 * k + 2]);
        w.is_finite()
            && w >= T::zero()
            && sum.is_finite()
            && (w > T::zero() || sum == T::zero())
            && soc_ok(soc)
    }) && soc_ok(parts[SLOW_PARTS - 1])
}

/// What of the mean's weight is left after `dt` seconds (`exp(−dt/τ)`);
/// nothing with the slow part not carried, or `dt` negative or NaN.
fn kept_over<T: Real, const P: usize>(s: &OnlineSettings<T, P>, dt: T) -> T {
    if s.carries_slow_part() && dt >= T::zero() {
        (-dt / s.slow_memory_s).exp()
    } else {
        T::zero()
    }
}

/// The numbers a snapshot keeps of a [`SlowFusion`]
/// ([`crate::battery::snapshot`]): per parameter (`R_ct`, `Q`, α) its
/// summed weight, its weighted sum and the state of charge of the last
/// value it took (NaN: none known), then the state of charge the weights
/// were last aged to.
pub(crate) const SLOW_PARTS: usize = 10;

impl<T: Real> SlowFusion<T> {
    /// What a snapshot keeps ([`SLOW_PARTS`]), the weights and sums aged
    /// by the time from the last value taken to sample `now` (the cell's
    /// count at the save): restored at a count of 0
    /// ([`Self::from_parts`]), the mean then ages on as the uninterrupted
    /// one does. Nothing kept (every weight 0) with `τ` 0, nor of a
    /// parameter whose weight or sum has left the float's range.
    pub(crate) fn parts<const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
        now: u64,
    ) -> [T; SLOW_PARTS] {
        let mut out = [T::zero(); SLOW_PARTS];
        let dt = T::lit(now.saturating_sub(self.at.0) as f64) * s.battery.h;
        let keep = kept_over(s, dt);
        // (A weight or sum beyond the float's range, or none left: nothing
        // kept of that parameter; a state of charge not finite: none known.)
        let known = |z: T| if z.is_finite() { z } else { T::nan() };
        for k in 0..3 {
            let (w, sum) = (keep * self.weight[k], keep * self.sum[k]);
            if w.is_finite() && sum.is_finite() && w > T::zero() {
                out[3 * k] = w;
                out[3 * k + 1] = sum;
            }
            out[3 * k + 2] = known(self.soc[k]);
        }
        out[SLOW_PARTS - 1] = known(self.at.1);
        out
    }

    /// The mean a snapshot kept ([`Self::parts`]), its count at 0, aged by
    /// `offline_s` (the time the estimator was off, when the clocks know
    /// it; 0 else) with memory `τ`; `None` when the numbers are no mean's
    /// (a weight negative or not finite, a sum not finite, a sum without a
    /// weight, a state of charge infinite).
    pub(crate) fn from_parts<const P: usize>(
        parts: &[T; SLOW_PARTS],
        s: &OnlineSettings<T, P>,
        offline_s: T,
    ) -> Option<Self> {
        if !plausible_parts(parts) {
            return None;
        }
        let keep = kept_over(s, offline_s);
        let mut f = Self::EMPTY;
        for k in 0..3 {
            f.weight[k] = keep * parts[3 * k];
            f.sum[k] = keep * parts[3 * k + 1];
            f.soc[k] = parts[3 * k + 2];
        }
        let at = parts[SLOW_PARTS - 1];
        f.at = (0, at);
        Some(f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::battery::CellParameters;

    /// Two equal-weight values at once give their mean (geometric for the
    /// logs); a value a memory later weighs `e` times the earlier one; the
    /// state of charge moved beyond the span starts the mean again.
    #[test]
    fn the_mean_weighs_by_information_and_forgets_by_time_and_soc() {
        let mut st = OnlineSettings::new(1.0, 64, CellParameters::cell_18650());
        st.slow_memory_s = 100.0;
        st.slow_memory_soc = f64::INFINITY;
        assert_eq!(st.hold_soc_span, 0.15);
        let s = &st;
        let sd = Some(0.1);
        let mut f = SlowFusion::<f64>::EMPTY;
        let first = f.take(s, Slow::Q, 100.0, sd, (0, Some(0.5)));
        assert!((first - 100.0).abs() < 1e-12, "{first}");
        let m = f.take(s, Slow::Q, 400.0, sd, (0, Some(0.5)));
        assert!((m - 200.0).abs() < 1e-9, "{m}");
        // α, a memory later: weights 1/e and 1.
        f.take(s, Slow::Alpha, 0.5, sd, (0, Some(0.5)));
        let a = f.take(s, Slow::Alpha, 0.7, sd, (100, Some(0.5)));
        let e = core::f64::consts::E;
        let want = (0.5 / e + 0.7) / (1.0 / e + 1.0);
        assert!((a - want).abs() < 1e-12, "{a} {want}");
        // Twice the spread: a quarter of the weight.
        let mut g = SlowFusion::<f64>::EMPTY;
        g.take(s, Slow::Alpha, 0.5, Some(0.1), (0, None));
        let b = g.take(s, Slow::Alpha, 1.0, Some(0.2), (0, None));
        assert!((b - (0.5 + 0.25) / 1.25).abs() < 1e-12, "{b}");
        // The state of charge moved by more than the span: only the new one.
        let c = f.take(s, Slow::Q, 50.0, sd, (1, Some(0.3)));
        assert!((c - 50.0).abs() < 1e-12, "{c}");
        // A fixed order, or memory 0: the value itself, nothing kept.
        let mut z = SlowFusion::<f64>::EMPTY;
        assert_eq!(z.take(s, Slow::Alpha, 0.6, Some(0.0), (0, None)), 0.6);
        let off = OnlineSettings::new(1.0, 64, CellParameters::cell_18650());
        assert_eq!(off.slow_memory_s, 0.0);
        assert_eq!(z.take(&off, Slow::RCt, 0.02, sd, (0, None)), 0.02);
        assert_eq!((z.weight, z.sum, z.at.0), ([0.0; 3], [0.0; 3], 0));
        // The state of charge moved by σ at once: weights 1/e and 1.
        let mut by_soc = *s;
        by_soc.slow_memory_soc = 0.05;
        let mut w = SlowFusion::<f64>::EMPTY;
        w.take(&by_soc, Slow::Alpha, 0.5, sd, (0, Some(0.5)));
        let d = w.take(&by_soc, Slow::Alpha, 0.7, sd, (0, Some(0.55)));
        assert!((d - want).abs() < 1e-12, "{d} {want}");
    }

    /// A mean saved at a later sample and restored at a count of 0 takes
    /// the next value as the uninterrupted one does; the time offline ages
    /// it by `exp(−Δt/τ)`; numbers no mean has are refused.
    #[test]
    fn a_mean_kept_by_a_snapshot_ages_on_as_the_uninterrupted_one() {
        let mut st = OnlineSettings::new(1.0, 64, CellParameters::cell_18650());
        st.slow_memory_s = 100.0;
        let s = &st;
        let sd = Some(0.1);
        let mut whole = SlowFusion::<f64>::EMPTY;
        whole.take(s, Slow::RCt, 0.02, sd, (10, Some(0.5)));
        whole.take(s, Slow::Q, 400.0, sd, (10, Some(0.5)));
        // Saved at sample 60, restored, the next value 40 samples on.
        let parts = whole.parts(s, 60);
        let mut resumed = SlowFusion::from_parts(&parts, s, 0.0).unwrap();
        let a = whole.take(s, Slow::RCt, 0.03, sd, (100, Some(0.5)));
        let b = resumed.take(s, Slow::RCt, 0.03, sd, (40, Some(0.5)));
        assert!((a / b - 1.0).abs() < 1e-12, "{a} {b}");
        // Off for a memory: the earlier value weighs 1/e less again.
        let mut late = SlowFusion::from_parts(&parts, s, 100.0).unwrap();
        let c = late.take(s, Slow::RCt, 0.03, sd, (40, Some(0.5)));
        let e = core::f64::consts::E;
        let w0 = (-0.9f64).exp() / e;
        let want = ((w0 * 0.02f64.ln() + 0.03f64.ln()) / (w0 + 1.0)).exp();
        assert!((c / want - 1.0).abs() < 1e-12, "{c} {want}");
        // Numbers no mean has.
        for (k, x) in [
            (0, -1.0),
            (0, f64::INFINITY),
            (1, f64::NAN),
            (2, f64::INFINITY),
        ] {
            let mut bad = parts;
            bad[k] = x;
            assert!(SlowFusion::from_parts(&bad, s, 0.0).is_none(), "{k} {x}");
        }
        let mut orphan = SlowFusion::<f64>::EMPTY.parts(s, 0);
        orphan[4] = 1.0;
        assert!(SlowFusion::from_parts(&orphan, s, 0.0).is_none());
        // Memory 0: nothing kept.
        let off = OnlineSettings::new(1.0, 64, CellParameters::cell_18650());
        assert_eq!(whole.parts(&off, 60)[0], 0.0);
        // A weight beyond the float's range (a spread of 1e-200): nothing
        // kept of that parameter, and the parts are a mean's.
        let mut huge = SlowFusion::<f64>::EMPTY;
        huge.take(s, Slow::Q, 400.0, Some(1e-200), (0, Some(f64::INFINITY)));
        let p = huge.parts(s, 0);
        assert_eq!((p[3], p[4]), (0.0, 0.0));
        assert!(p[5].is_nan() && p[9].is_nan(), "{p:?}");
        assert!(SlowFusion::from_parts(&p, s, 0.0).is_some());
    }
}
