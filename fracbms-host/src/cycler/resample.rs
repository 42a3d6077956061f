//! A log with varying steps and gaps, put on a uniform period: the current
//! charge-preserving (the mean over each period), the voltage and the
//! temperature taken at the sample instants, the voltage the period's mean
//! where the current changes inside it (so that the edge keeps its ohmic
//! drop). Owns the time base; must not
//! touch the columns' names, units or signs (read before it runs).

use crate::bail;
use crate::error::{shown, Result};
use estimator_core::battery::power::VoltageTiming;
use serde::Serialize;

/// The most samples a given `--period` may put a log on, whatever the
/// caller takes (ten million: 116 days at 1 s). The resampled record is
/// held whole; `--period 1e-6` on a 5 859 s log asked for 47 GB and
/// aborted the process.
pub const MAX_GIVEN_PERIOD_SAMPLES: usize = 10_000_000;

/// Checks a given period `h` (s) over a log of `span` s: at most `limit`
/// samples (the caller's) and [`MAX_GIVEN_PERIOD_SAMPLES`].
///
/// # Errors
/// [`Options`](crate::error::ErrorKind::Options), naming `--period`.
pub fn check_given_period(h: f64, span: f64, limit: usize) -> Result<()> {
    let samples = (span / h).floor() + 1.0;
    let taken = limit.min(MAX_GIVEN_PERIOD_SAMPLES);
    if samples > taken as f64 {
        bail!(
            Options,
            "--period {}: {} samples over the record's {span} s; at most {taken} are taken (a longer period)",
            shown(h),
            shown(samples)
        );
    }
    Ok(())
}

/// A gap of the log: two rows further apart than the threshold.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Gap {
    /// Time of the row before the gap (s).
    pub start_s: f64,
    /// Length of the gap (s).
    pub length_s: f64,
    /// The charge the gap moved beyond what the current held across it
    /// counts (A·h, + charging), from the export's own charge count
    /// (docs/cycler.md); `None`: unknown.
    pub charge_ah: Option<f64>,
}

/// What cleaning and resampling did to a log.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Resampling {
    /// Rows whose time stamp repeats the previous row's: the later row is
    /// kept (a cycler logs the end of one step and the start of the next
    /// at one instant).
    pub duplicate_times: usize,
    /// Rows whose time is before a row already read: dropped.
    pub backward_times: usize,
    /// Rows averaged into a period that holds another row.
    pub rows_merged: usize,
    /// Samples whose period holds no row: current held, voltage
    /// interpolated between the rows around it.
    pub rows_interpolated: usize,
    /// The steps longer than [`Resampling::gap_threshold_s`].
    pub gaps: Vec<Gap>,
    /// The threshold of a gap (s).
    pub gap_threshold_s: f64,
}

impl Resampling {
    /// Where the record's voltages stand in their samples' periods: a log
    /// put on a coarser period than its rows (rows merged), where the
    /// current moves within a period (as a measured one does through a
    /// pulse), holds the mean voltage over it; a log read at its own rows,
    /// each row's voltage with the current before it. The state of power's
    /// check against the next pulse reads its voltages so.
    pub fn voltage_timing(&self) -> VoltageTiming {
        if self.rows_merged > 0 {
            VoltageTiming::Mean
        } else {
            VoltageTiming::End
        }
    }
}

/// The rows of a log in time order, duplicates and backward rows removed
/// (and counted in `r`): indices into the columns.
pub fn clean(time: &[f64], r: &mut Resampling) -> Vec<usize> {
    let mut keep: Vec<usize> = Vec::with_capacity(time.len());
    for (i, &t) in time.iter().enumerate() {
        match keep.last() {
            Some(&j) if t == time[j] => {
                r.duplicate_times += 1;
                *keep.last_mut().expect("not empty") = i;
            }
            Some(&j) if t < time[j] => r.backward_times += 1,
            _ => keep.push(i),
        }
    }
    keep
}

/// The period a log is resampled at when none is given: the median step,
/// raised so that the record has at most `max_samples` samples, rounded up
/// to two significant digits. `time` increases strictly (after [`clean`]).
pub fn default_period(time: &[f64], max_samples: usize) -> f64 {
    median_step(time).map_or(1.0, |m| within(time, m, max_samples))
}

/// The median step of `time`; `None` with fewer than two rows.
fn median_step(time: &[f64]) -> Option<f64> {
    let mut steps: Vec<f64> = time.windows(2).map(|w| w[1] - w[0]).collect();
    if steps.is_empty() {
        return None;
    }
    steps.sort_by(f64::total_cmp);
    Some(steps[steps.len() / 2])
}

/// The step `median` raised so that `time` spans at most `max_samples`
/// samples, rounded up to two significant digits.
fn within(time: &[f64], median: f64, max_samples: usize) -> f64 {
    let span = time[time.len() - 1] - time[0];
    // span / (max − 1): the samples from the first instant to the last.
    nice_up(median.max(span / max_samples.saturating_sub(1).max(1) as f64))
}

/// The period a log is put on when none is given: [`default_period`]
/// within `max_samples`, raised to divide `durations` ([`dividing_period`])
/// only where the budget raised it past the log's own step. A log's own
/// step is how it was measured (a NASA discharge's 9.4 s); a 0.1 s log put
/// on 1.8 s to keep within the budget is put on 2 s for horizons of 10
/// and 30 s.
///
/// ```
/// use fracbms_host::cycler::resample::chosen_period;
/// let fine: Vec<f64> = (0..1000).map(|k| k as f64 * 0.1).collect();
/// assert_eq!(chosen_period(&fine, 56, &[10.0, 30.0]), 2.0);
/// assert_eq!(chosen_period(&fine, 56, &[]), 1.9);
/// let own: Vec<f64> = (0..100).map(|k| k as f64 * 1.8).collect();
/// assert_eq!(chosen_period(&own, 50_000, &[10.0, 30.0]), 1.8);
/// ```
pub fn chosen_period(time: &[f64], max_samples: usize, durations: &[f64]) -> f64 {
    let Some(m) = median_step(time) else {
        return 1.0;
    };
    let h = within(time, m, max_samples);
    if h > within(time, m, usize::MAX) {
        dividing_period(h, durations)
    } else {
        h
    }
}

/// A chosen period `h` raised, where it can be by at most a quarter, to the
/// smallest number of two significant digits that divides every one of
/// `durations` (s, to 1 ppm): a track whose state of power is asked at 10
/// and 30 s, on a log the sample budget puts on 1.8 s, is put on 2 s, so
/// that each horizon is whole samples (at 1.8 s, 10 s would be 6 samples,
/// 10.8 s). `h` as it is where none within a quarter divides them all, or
/// where no duration is given.
///
/// ```
/// use fracbms_host::cycler::resample::dividing_period;
/// assert_eq!(dividing_period(1.8, &[10.0, 30.0]), 2.0);
/// assert_eq!(dividing_period(0.94, &[2.0, 10.0]), 1.0);
/// assert_eq!(dividing_period(2.0, &[10.0, 30.0]), 2.0);
/// // 3.3 s to 4.1 s: none divides 10 s.
/// assert_eq!(dividing_period(3.3, &[10.0, 30.0]), 3.3);
/// assert_eq!(dividing_period(1.8, &[]), 1.8);
/// ```
pub fn dividing_period(h: f64, durations: &[f64]) -> f64 {
    if durations.is_empty() || !(h.is_finite() && h > 0.0) {
        return h;
    }
    let divides = |p: f64| {
        durations.iter().all(|&d| {
            let n = (d / p).round();
            n >= 1.0 && (d / p - n).abs() <= 1e-6 * (d / p)
        })
    };
    let unit = 10f64.powf(h.log10().floor() - 1.0);
    let first = (h / unit * (1.0 - 1e-6)).ceil();
    (0..)
        .map(|k| nice_up((first + f64::from(k)) * unit))
        .take_while(|&p| p <= 1.25 * h * (1.0 + 1e-9))
        .find(|&p| divides(p))
        .unwrap_or(h)
}

/// The smallest number of two significant digits that is ≥ `x` (to
/// 1 ppm): a log's own step stays as it is (0.1 s, 60 s), a raised one
/// is rounded up (0.936 s → 0.94 s).
fn nice_up(x: f64) -> f64 {
    let unit = 10f64.powf(x.log10().floor() - 1.0);
    let v = (x / unit * (1.0 - 1e-6)).ceil() * unit;
    // Decimal steps print as they read (0.1, not 0.100…02).
    format!("{v:.12e}").parse().unwrap_or(v)
}

/// Whether the rows `keep` of `time` are already uniform at their first
/// step (to 1 ppm), and that step.
pub fn uniform(time: &[f64], keep: &[usize]) -> Option<f64> {
    if keep.len() < 2 {
        return None;
    }
    let h = time[keep[1]] - time[keep[0]];
    let ok = keep
        .windows(2)
        .all(|w| ((time[w[1]] - time[w[0]]) - h).abs() <= 1e-6 * h.max(1e-3) + 1e-9);
    ok.then_some(h)
}

/// The log's columns on the uniform grid `t₀ + k·h`, k = 0 … K−1, with
/// `K = ⌊(t_end − t₀)/h⌋` (every period inside the log).
pub struct Uniform {
    /// Sample times (s).
    pub time: Vec<f64>,
    /// Mean current over `[t_k, t_k + h)`, the log's current held from
    /// each row to the next.
    pub current: Vec<f64>,
    /// Voltage at `t_k`, linear between the rows around it, held from the
    /// row before where the current changes at the next row; where the
    /// current changes inside `[t_k, t_k + h)`, the voltage's mean over it
    /// (the same held and linear pieces).
    pub voltage: Vec<f64>,
    /// Temperature at `t_k`, as the voltage.
    pub temperature: Option<Vec<f64>>,
}

/// Resamples the rows `keep` (increasing times) at period `h`; counts the
/// merged and interpolated rows and the gaps in `r`.
///
/// The charge `h·Σ I_k` equals the log's `Σ I_i·(t_{i+1} − t_i)` over the
/// periods it covers (all of it when the span is a multiple of `h`): a
/// NaN current spoils only the periods it is held over. The samples run
/// from the first row's time to the last's, both included when the span
/// is a multiple of `h`: the last sample's current is the last row's,
/// held (as a uniform log's own last row is).
pub fn to_uniform(
    time: &[f64],
    current: &[f64],
    voltage: &[f64],
    temperature: Option<&[f64]>,
    keep: &[usize],
    h: f64,
    r: &mut Resampling,
) -> Uniform {
    let t = |j: usize| time[keep[j]];
    let n = keep.len();
    let t0 = t(0);
    let span = t(n - 1) - t0;
    let k_max = ((span / h) * (1.0 + 1e-12) + 1e-9).floor().max(0.0) as usize;
    for j in 1..n {
        let d = t(j) - t(j - 1);
        if d > r.gap_threshold_s {
            r.gaps.push(Gap {
                start_s: t(j - 1),
                length_s: d,
                charge_ah: None,
            });
        }
    }
    let mut out = Uniform {
        time: Vec::with_capacity(k_max + 1),
        current: Vec::with_capacity(k_max + 1),
        voltage: Vec::with_capacity(k_max + 1),
        temperature: temperature.map(|_| Vec::with_capacity(k_max + 1)),
    };
    // `j`: the last row at or before the period's start.
    let mut j = 0usize;
    for k in 0..=k_max {
        let a = t0 + k as f64 * h;
        let b = t0 + (k + 1) as f64 * h;
        while j + 1 < n && t(j + 1) <= a {
            j += 1;
        }
        // The instant's values, linear between rows j and j + 1.
        let at = |col: &[f64]| {
            if j + 1 >= n || t(j) == a {
                col[keep[j]]
            } else {
                let w = (a - t(j)) / (t(j + 1) - t(j));
                col[keep[j]] + w * (col[keep[j + 1]] - col[keep[j]])
            }
        };
        out.time.push(a);
        if let (Some(col), Some(v)) = (temperature, out.temperature.as_mut()) {
            v.push(at(col));
        }
        // The mean of the held current over [a, b), and the voltage at the
        // instant; where the current changes inside the period, the
        // voltage's mean over it, so that the ohmic drop `R_i·I` of the
        // edge is kept in the same proportion as the current (a voltage
        // taken before the edge with a current that holds part of it is a
        // step without a drop, and a fit then takes the drop for the
        // branch: R_i → 0 on the Panasonic HPPC test at 2 s).
        let mut q = 0.0;
        let mut u = 0.0;
        let mut changes = false;
        let mut i = j;
        let mut rows_in = 0usize;
        loop {
            let lo = t(i).max(a);
            let hi = if i + 1 < n { t(i + 1).min(b) } else { b };
            if hi > lo {
                q += current[keep[i]] * (hi - lo);
                u += voltage_mean(time, current, voltage, keep, i, lo, hi) * (hi - lo);
                changes |= current[keep[i]] != current[keep[j]];
            }
            if t(i) >= a && t(i) < b {
                rows_in += 1;
            }
            if i + 1 >= n || t(i + 1) >= b {
                break;
            }
            i += 1;
        }
        out.current.push(q / h);
        // Where the current steps at the next row, the voltage's jump
        // belongs to the new current: held, not drawn across the step (a
        // rest's end stays relaxed).
        let steps = j + 1 < n && current[keep[j + 1]] != current[keep[j]];
        out.voltage.push(match (changes, steps) {
            (true, _) => u / h,
            (false, true) => voltage[keep[j]],
            (false, false) => at(voltage),
        });
        match rows_in {
            0 => r.rows_interpolated += 1,
            m => r.rows_merged += m - 1,
        }
    }
    out
}

/// The log's voltage averaged over `[lo, hi]` inside the rows `i`, `i + 1`
/// (of `keep`): linear between them, but held at row `i`'s where the
/// current steps at row `i + 1` (the voltage's jump belongs to the new
/// current: a rest's end stays relaxed), and after the last row.
fn voltage_mean(
    time: &[f64],
    current: &[f64],
    voltage: &[f64],
    keep: &[usize],
    i: usize,
    lo: f64,
    hi: f64,
) -> f64 {
    let v0 = voltage[keep[i]];
    let Some(&next) = keep.get(i + 1) else {
        return v0;
    };
    if current[next] != current[keep[i]] {
        return v0;
    }
    let (t0, t1) = (time[keep[i]], time[next]);
    let at = |x: f64| v0 + (x - t0) / (t1 - t0) * (voltage[next] - v0);
    0.5 * (at(lo) + at(hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(time: &[f64], current: &[f64], h: f64) -> (Uniform, Resampling) {
        let mut r = Resampling {
            gap_threshold_s: 100.0,
            ..Resampling::default()
        };
        let keep = clean(time, &mut r);
        let v: Vec<f64> = time.iter().map(|t| 3.0 + t * 1e-3).collect();
        let u = to_uniform(time, current, &v, None, &keep, h, &mut r);
        (u, r)
    }

    #[test]
    fn the_charge_is_kept_and_the_voltage_averaged_over_the_same_period() {
        // 0.1 s rows on a pulse, 60 s rows on a rest, a 250 s gap.
        let mut time = vec![];
        let mut current = vec![];
        for k in 0..100 {
            time.push(k as f64 * 0.1);
            current.push(if k < 50 { -5.0 } else { 2.5 });
        }
        for k in 0..5 {
            time.push(10.0 + 60.0 * k as f64);
            current.push(if k < 3 { 0.1 } else { 0.2 });
        }
        time.push(490.0);
        current.push(0.0);
        let charge: f64 = time
            .windows(2)
            .zip(&current)
            .map(|(w, i)| i * (w[1] - w[0]))
            .sum();
        let (u, r) = run(&time, &current, 1.0);
        assert_eq!(u.time.len(), 491);
        let resampled: f64 = u.current.iter().sum::<f64>() * 1.0;
        assert!(
            (resampled - charge).abs() < 1e-9 * charge.abs(),
            "{resampled} vs {charge}"
        );
        assert_eq!(u.current[4], -5.0);
        assert!((u.current[9] - 2.5).abs() < 1e-12 && u.current[5] == 2.5);
        // Voltage at the instant where the current does not change inside
        // the period: 3 V + t mV…
        assert!((u.voltage[37] - 3.037).abs() < 1e-12);
        assert!((u.voltage[200] - 3.200).abs() < 1e-12);
        // …held where the current steps at the next row (130 s: 0.1 A, then
        // 0.2 A from 190 s; 250 s: 0.2 A, then 0 A from 490 s).
        assert!((u.voltage[150] - 3.130).abs() < 1e-12);
        assert!((u.voltage[300] - 3.250).abs() < 1e-12);
        // An edge inside a period (at 2 s, [4, 6) holds the step at 5 s):
        // the current's mean and the voltage's mean over it, the voltage
        // held over [4.9, 5) where the current steps at the next row.
        let (u2, _) = run(&time, &current, 2.0);
        assert!((u2.current[2] + 1.25).abs() < 1e-12, "{}", u2.current[2]);
        let want = (0.9 * (3.0 + 4.45e-3) + 0.1 * 3.0049 + (3.0 + 5.5e-3)) / 2.0;
        assert!(
            (u2.voltage[2] - want).abs() < 1e-12,
            "{} vs {want}",
            u2.voltage[2]
        );
        // [2, 4): no change inside: the instant's voltage.
        assert!((u2.voltage[1] - 3.002).abs() < 1e-12);
        // 100 rows in 10 periods: 90 merged; 5 rests of 60 s and the gap;
        // the last row is the last sample's.
        assert_eq!(r.rows_merged, 90);
        assert_eq!(r.rows_interpolated, 490 - 10 - 5);
        assert_eq!(
            r.gaps,
            vec![Gap {
                start_s: 250.0,
                length_s: 240.0,
                charge_ah: None,
            }]
        );
    }

    #[test]
    fn duplicate_and_backward_times_are_counted_not_fatal() {
        let time = [0.0, 1.0, 1.0, 2.0, 1.5, 3.0, 3.0, 4.0];
        let current = [1.0, 9.0, 2.0, 2.0, 7.0, 9.0, 3.0, 3.0];
        let (u, r) = run(&time, &current, 1.0);
        assert_eq!((r.duplicate_times, r.backward_times), (2, 1));
        assert_eq!(u.current, vec![1.0, 2.0, 2.0, 3.0, 3.0]);
    }

    #[test]
    fn a_nan_current_spoils_only_its_periods() {
        let time: Vec<f64> = (0..20).map(|k| k as f64 * 0.5).collect();
        let mut current = vec![1.0; 20];
        current[6] = f64::NAN;
        let (u, _) = run(&time, &current, 1.0);
        let bad: Vec<usize> = (0..u.current.len())
            .filter(|&k| u.current[k].is_nan())
            .collect();
        assert_eq!(bad, vec![3]);
    }

    #[test]
    fn the_default_period_is_the_median_step_within_a_sample_budget() {
        let t: Vec<f64> = (0..1000).map(|k| k as f64 * 0.1).collect();
        assert_eq!(default_period(&t, 50_000), 0.1);
        assert_eq!(default_period(&t, 100), 1.1);
        // A 60 s log keeps its 60 s.
        let t: Vec<f64> = (0..100).map(|k| k as f64 * 60.0).collect();
        assert_eq!(default_period(&t, 50_000), 60.0);
        assert_eq!(default_period(&[0.0, 0.3, 0.6], 10), 0.3);
        assert_eq!(nice_up(2.0), 2.0);
        assert_eq!(nice_up(0.0123), 0.013);
        assert_eq!(nice_up(0.1), 0.1);
        assert_eq!(nice_up(0.936), 0.94);
    }

    /// A log of 0.1 s rows put on 2 s holds the mean voltage of each
    /// period its current moves in: its voltages are read as means; a log
    /// on its own rows as at each period's end.
    #[test]
    fn a_log_put_on_a_coarser_period_holds_mean_voltages() {
        let time: Vec<f64> = (0..200).map(|k| 0.1 * f64::from(k)).collect();
        let current: Vec<f64> = (0..200).map(|k| if k < 95 { 0.0 } else { -2.0 }).collect();
        let voltage: Vec<f64> = current.iter().map(|i| 3.7 + 0.05 * i).collect();
        for (h, timing) in [(2.0, VoltageTiming::Mean), (0.1, VoltageTiming::End)] {
            let mut r = Resampling {
                gap_threshold_s: 10.0,
                ..Default::default()
            };
            let keep = clean(&time, &mut r);
            let _ = to_uniform(&time, &current, &voltage, None, &keep, h, &mut r);
            assert_eq!(r.voltage_timing(), timing, "period {h} s");
        }
    }
}
