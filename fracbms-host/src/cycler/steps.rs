//! A cycler's steps as it ran them: the current signed from a state column
//! (Maccor's `State` C/D/R), each step's start placed where its step time
//! says it began (not at its first logged row), the stretch between that
//! start and the first row marked *unobserved* (its current is known, its
//! voltage is not), and the export's own charge count checked against
//! ours.
//!
//! It owns what the step, step-time, state and charge columns say about
//! the rows; it must not touch the time base (put on a uniform period by
//! [`super::resample`] afterwards) nor the columns' names and units
//! ([`super::headers`]).
//!
//! ```
//! use fracbms_host::cycler::{read_record_from, RecordOptions};
//! use std::path::Path;
//!
//! // A Bitrode-style log: the rest after the pulse is first logged 60 s
//! // after it began (StepTime 60 at its first row).
//! let log = "Time(s),Step,StepTime(s),Current(A),Voltage(V)\n\
//!            0,1,0,0,3.70\n1,2,1,-10,3.50\n2,2,2,-10,3.49\n\
//!            62,3,60,0,3.66\n122,3,120,0,3.67\n";
//! let r = read_record_from(log.as_bytes(), Path::new("log.csv"), &RecordOptions::default())?;
//! // The pulse held 10 A from 0 s (its step began at the row before) to
//! // 2 s (the rest began at its last row): 20 A·s, not 620 A·s.
//! let charge: f64 = r.record.current.iter().map(|i| i * r.record.h).sum();
//! assert!((charge + 20.0).abs() < 1e-9, "{charge}");
//! // Both steps began before their first rows; the rest's first minute
//! // has no voltage (the pulse's 1 s is within a period).
//! assert_eq!(r.report.steps.unlogged.len(), 2);
//! assert_eq!(r.report.unobserved_samples, 60);
//! # Ok::<(), fracbms_host::Error>(())
//! ```

use super::headers::ColumnChoice;
use super::RawRows;
use crate::bail;
use crate::error::Result;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The optional columns of the rows, as read (SI: s, A·h).
#[derive(Clone, Debug, Default)]
pub(super) struct Extra {
    pub step: Option<Vec<f64>>,
    pub step_time: Option<Vec<f64>>,
    pub state: Option<Vec<String>>,
    pub charge: Option<Vec<f64>>,
    pub discharge_charge: Option<Vec<f64>>,
}

impl Extra {
    /// Empty columns for those `c` chose.
    pub fn of(c: &ColumnChoice) -> Self {
        Self {
            step: c.step.as_ref().map(|_| vec![]),
            step_time: c.step_time.as_ref().map(|_| vec![]),
            state: c.state.as_ref().map(|_| vec![]),
            charge: c.charge.as_ref().map(|_| vec![]),
            discharge_charge: c.discharge_charge.as_ref().map(|_| vec![]),
        }
    }

    /// The first row alone.
    pub fn first_row(&self) -> Self {
        fn first<T: Clone>(a: &Option<Vec<T>>) -> Option<Vec<T>> {
            a.as_ref().map(|v| v.iter().take(1).cloned().collect())
        }
        Self {
            step: first(&self.step),
            step_time: first(&self.step_time),
            state: first(&self.state),
            charge: first(&self.charge),
            discharge_charge: first(&self.discharge_charge),
        }
    }

    /// `other`'s rows after these (a column either lacks is dropped).
    pub fn append(&mut self, other: Self) {
        fn join<T>(a: &mut Option<Vec<T>>, b: Option<Vec<T>>) {
            *a = match (a.take(), b) {
                (Some(mut x), Some(mut y)) => {
                    x.append(&mut y);
                    Some(x)
                }
                _ => None,
            };
        }
        join(&mut self.step, other.step);
        join(&mut self.step_time, other.step_time);
        join(&mut self.state, other.state);
        join(&mut self.charge, other.charge);
        join(&mut self.discharge_charge, other.discharge_charge);
    }
}

/// How step starts are read (`--steps`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StepsMode {
    /// From the step-time column where there is one (default).
    #[default]
    Auto,
    /// Each row's current held to the next row, whatever the step time
    /// says.
    Ignore,
    /// As `Auto`, and where there is no step time, every change of the
    /// current the export's charge count dates is placed by it, within
    /// the log's rhythm too (a resampled log; [`StepReport::starts_from`]
    /// `charge`).
    Count,
}

impl StepsMode {
    /// `auto`, `ignore` or `count`.
    pub fn as_str(self) -> &'static str {
        match self {
            StepsMode::Auto => "auto",
            StepsMode::Ignore => "ignore",
            StepsMode::Count => "count",
        }
    }
}

/// A step's unlogged start: the step began at `start_s`, its first row
/// is at `first_row_s`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Unlogged {
    /// When the step began (s): its first row's time less its step time,
    /// clamped between the row before and that row.
    pub start_s: f64,
    /// Its first logged row (s).
    pub first_row_s: f64,
}

/// What the step columns did (JSON `record.steps`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct StepReport {
    /// `step_time` (starts from the step time), `charge` (no step-time
    /// column, and the export's own signed charge count placed changes of
    /// the current where rows further apart than the log's rhythm make
    /// them; elsewhere each row's current is held to the next), `rows` (no
    /// step-time column, and nothing placed: each row's current is held to
    /// the next row) or `ignored` (`--steps ignore`).
    pub starts_from: &'static str,
    /// The export's charge column when it could place the starts (signed,
    /// never restarting; without a step-time column): it did where
    /// `starts_from` is `charge`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub charge_column: Option<String>,
    /// Whether the count placed the changes within the log's rhythm too
    /// ([`StepsMode::Count`]).
    #[serde(skip)]
    pub count_everywhere: bool,
    /// The step index's header, if read.
    pub step_column: Option<String>,
    /// The step time's header, if read.
    pub step_time_column: Option<String>,
    /// Step changes seen (with `starts_from` `charge`: the changes of the
    /// current between rows further apart than the log's rhythm).
    pub changes: usize,
    /// The steps that began before their first row (their start placed
    /// by the step time, or by the charge count).
    pub unlogged: Vec<Unlogged>,
    /// Rows logged at a step time of 0 after a step change: the switch
    /// itself, not a measurement (Digatron writes 0 A there, and the
    /// loaded voltage where a pulse ends). The step begins at such a
    /// row's time; its first measurement is its first row with a step
    /// time above 0, and the stretch between is [`Unlogged`].
    pub switch_rows: usize,
}

impl StepReport {
    /// What the `read` line says of the steps (`unobserved` samples).
    pub(super) fn read_line(&self, unobserved: usize) -> String {
        let switch = match self.switch_rows {
            0 => String::new(),
            n => format!(", {n} rows at step time 0 taken as the switch, not a measurement"),
        };
        match (self.starts_from, &self.step_time_column, &self.charge_column) {
            ("ignored", _, _) => {
                "; step starts ignored (--steps ignore): each row's current held to the next".into()
            }
            (_, Some(h), _) => format!(
                "; step starts from `{h}`: {} of {} steps began before their first row ({unobserved} unobserved samples){switch}",
                self.unlogged.len(),
                self.changes,
            ),
            ("charge", _, Some(q)) if self.count_everywhere => format!(
                "; no step-time column: each change of the current placed by the export's charge `{q}` (--steps count): {} of {} began before their row ({unobserved} unobserved samples)",
                self.unlogged.len(),
                self.changes,
            ),
            ("charge", _, Some(q)) => format!(
                "; no step-time column: each row's current held to the next, but where rows further apart than the log's rhythm change it, the change placed by the export's charge `{q}`: {} of {} began before the row ({unobserved} unobserved samples)",
                self.unlogged.len(),
                self.changes,
            ),
            _ => "; no step-time column: each row's current held to the next".into(),
        }
    }
}

/// How the state column signed the current (JSON `record.state`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StateReport {
    /// The state column's header.
    pub column: String,
    /// Whether it signed the current (`--current-sign from-state`).
    pub signs_current: bool,
    /// Rows whose current's sign the state contradicts (a charge with
    /// a negative current, or a discharge with a positive one), of those
    /// with a current above 1 % of the largest.
    pub disagreeing_rows: usize,
    /// Rows with a current above 1 % of the largest.
    pub loaded_rows: usize,
}

/// The export's own charge count against ours (JSON
/// `record.charge_check`): charge-positive A·h over the record, the
/// export's count followed across its resets (per step or per cycle) and,
/// for a count of magnitudes (Maccor's `Amp-hr`), signed by the current;
/// the stretches over gaps left out of both.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChargeCheck {
    /// The export's charge column (Arbin: `charge − discharge`).
    pub column: String,
    /// Our count (A·h, + charging).
    pub ours_ah: f64,
    /// The export's (A·h, + charging).
    pub theirs_ah: f64,
    /// The largest difference of the two running counts (A·h).
    pub max_gap_ah: f64,
    /// Where the export's count restarts.
    pub resets: usize,
}

/// The sign a state's letters give a magnitude current: +1 charge, −1
/// discharge, 0 rest or a control mode without a direction (`CC`, `CV`);
/// None for letters no cycler here writes.
pub fn state_sign(state: &str) -> Option<i8> {
    let s = state.trim().to_ascii_uppercase();
    Some(match s.as_str() {
        "C" | "CH" | "CHA" | "CHG" | "CHRG" | "CHARGE" | "CC_CHG" | "CCCV_CHG" | "CV_CHG" => 1,
        "D" | "DC" | "DCH" | "DIS" | "DCHG" | "DISCHARGE" | "CC_DCHG" | "CV_DCHG" => -1,
        "R" | "P" | "O" | "S" | "E" | "REST" | "PAUSE" | "OCV" | "STOP" | "END" | "" => 0,
        // A control mode, not a direction (Bitrode's `CC`, `CV`): no sign.
        "CC" | "CV" | "CCCV" | "CP" | "CR" | "PULSE" => 0,
        _ => return None,
    })
}

/// Reads the state column of `raw` (None when it holds numbers: BioLogic's
/// `mode` is 1/2/3, not letters) and, when `sign` asks or the current is
/// a magnitude (never negative), signs the current by it.
///
/// # Errors
/// A state with letters [`state_sign`] does not know: one line naming the
/// row and the letters.
pub(super) fn sign_from_state(
    raw: &mut RawRows,
    header: &str,
    from_state: bool,
    path: &Path,
) -> Result<Option<StateReport>> {
    let Some(states) = raw.extra.state.take() else {
        return Ok(None);
    };
    if states
        .iter()
        .all(|s| s.trim().is_empty() || s.trim().parse::<f64>().is_ok())
    {
        return Ok(None);
    }
    let mut signs = Vec::with_capacity(states.len());
    for (k, s) in states.iter().enumerate() {
        let Some(x) = state_sign(s) else {
            bail!(
                Data,
                "{}: row {}, column `{header}`: `{}` is not a state this reader knows (C/D/R, CHRG/DCHG/REST, C/D/P, …); name another with --columns state=COL, or state=none",
                path.display(),
                raw.rows[k],
                crate::io::shown(s.trim())
            );
        };
        signs.push(x);
    }
    let magnitude = raw.current.iter().all(|&i| i >= 0.0 || i.is_nan());
    // Unasked, only a column that says where the current goes signs it.
    let signs_current = from_state || (magnitude && signs.iter().any(|&x| x != 0));
    let big = raw
        .current
        .iter()
        .filter(|x| x.is_finite())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    let (mut loaded, mut against) = (0usize, 0usize);
    for (i, &sg) in raw.current.iter_mut().zip(&signs) {
        if signs_current {
            *i = if sg < 0 { -i.abs() } else { i.abs() };
        } else if i.abs() > 0.01 * big {
            loaded += 1;
            if (sg > 0 && *i < 0.0) || (sg < 0 && *i > 0.0) {
                against += 1;
            }
        }
    }
    Ok(Some(StateReport {
        column: header.to_string(),
        signs_current,
        disagreeing_rows: against,
        loaded_rows: loaded,
    }))
}

/// Rows in time order with the step starts put in: where a step began
/// before its first row, a row is put in at that instant with the new
/// step's current (and its first row's voltage, which is not a
/// measurement: the stretch is [`Unlogged`]). `raw`'s rows `keep` (in
/// time order) become the rows returned.
///
/// # Errors
/// A step time that goes backwards within one step.
pub(super) fn place_starts(
    raw: RawRows,
    keep: &[usize],
    mode: StepsMode,
    c: &ColumnChoice,
    path: &Path,
) -> Result<(RawRows, StepReport)> {
    if raw.extra.step.is_none() && raw.extra.step_time.is_none() && keep.len() == raw.time.len() {
        // Every row kept (`keep` increases) and no step known: no start is
        // put in, and the rows are returned as they are.
        let report = StepReport {
            starts_from: if mode == StepsMode::Ignore {
                "ignored"
            } else {
                "rows"
            },
            step_column: c.step.as_ref().map(|c| c.header.clone()),
            step_time_column: c.step_time.as_ref().map(|c| c.header.clone()),
            ..StepReport::default()
        };
        let extra = Extra {
            charge: raw.extra.charge,
            discharge_charge: raw.extra.discharge_charge,
            ..Extra::default()
        };
        return Ok((RawRows { extra, ..raw }, report));
    }
    let switch = match mode {
        StepsMode::Auto | StepsMode::Count => switch_rows(&raw, keep),
        StepsMode::Ignore => vec![false; keep.len()],
    };
    let keep: Vec<usize> = keep
        .iter()
        .zip(&switch)
        .filter_map(|(&i, &s)| (!s).then_some(i))
        .collect();
    let keep = &keep[..];
    let pick = |col: &[f64]| keep.iter().map(|&i| col[i]).collect::<Vec<f64>>();
    let step = raw.extra.step.as_deref().map(pick);
    let step_time = raw.extra.step_time.as_deref().map(pick);
    let mut report = StepReport {
        starts_from: match (mode, &step_time) {
            (StepsMode::Ignore, _) => "ignored",
            (_, Some(_)) => "step_time",
            (_, None) => "rows",
        },
        step_column: c.step.as_ref().map(|c| c.header.clone()),
        step_time_column: c.step_time.as_ref().map(|c| c.header.clone()),
        switch_rows: switch.iter().filter(|&&s| s).count(),
        ..StepReport::default()
    };
    // A row for each kept row (a step start put in grows them by one).
    let column = || Vec::with_capacity(keep.len());
    let mut out = RawRows {
        time: column(),
        current: column(),
        voltage: column(),
        temperature: raw.temperature.as_ref().map(|_| column()),
        rows: Vec::with_capacity(keep.len()),
        clock_time: raw.clock_time,
        extra: Extra {
            charge: raw.extra.charge.as_ref().map(|_| column()),
            discharge_charge: raw.extra.discharge_charge.as_ref().map(|_| column()),
            ..Extra::default()
        },
    };
    let mut put_in = Vec::with_capacity(keep.len());
    let push = |out: &mut RawRows, i: usize| {
        out.time.push(raw.time[i]);
        out.current.push(raw.current[i]);
        out.voltage.push(raw.voltage[i]);
        if let (Some(v), Some(t)) = (out.temperature.as_mut(), raw.temperature.as_deref()) {
            v.push(t[i]);
        }
        out.rows.push(raw.rows[i]);
        for (o, r) in [
            (&mut out.extra.charge, &raw.extra.charge),
            (&mut out.extra.discharge_charge, &raw.extra.discharge_charge),
        ] {
            if let (Some(v), Some(x)) = (o.as_mut(), r.as_deref()) {
                v.push(x[i]);
            }
        }
    };
    for (p, &i) in keep.iter().enumerate() {
        if p > 0 {
            let (t0, t1) = (raw.time[keep[p - 1]], raw.time[i]);
            let same_step = step.as_ref().map(|s| s[p] == s[p - 1]);
            let st = step_time.as_ref().map(|s| (s[p - 1], s[p]));
            let tol = 1e-9 * t1.abs().max(1.0);
            if let (Some(true), Some((a, b))) = (same_step, st) {
                if b < a - tol {
                    bail!(
                        Data,
                        "{}: row {}, column `{}`: the step time goes back within step {} ({b} s after {a} s); name the test's columns with --columns step=COL,step_time=COL, or --steps ignore",
                        path.display(),
                        raw.rows[i],
                        report.step_time_column.as_deref().unwrap_or(""),
                        step.as_ref().map_or(0.0, |s| s[p])
                    );
                }
            }
            // A new step: the index changes, or the step time restarts or
            // says the step began after the row before.
            let new_step = match (same_step, st) {
                (Some(same), _) => !same,
                (None, Some((a, b))) => b < a - tol || t1 - b > t0 + tol,
                (None, None) => false,
            };
            if new_step {
                report.changes += 1;
                if let (StepsMode::Auto | StepsMode::Count, Some((_, b))) = (mode, st) {
                    if b.is_finite() {
                        let start = (t1 - b).clamp(t0, t1);
                        if t1 - start > tol {
                            report.unlogged.push(Unlogged {
                                start_s: start,
                                first_row_s: t1,
                            });
                            push(&mut out, i);
                            let k = out.time.len() - 1;
                            out.time[k] = start;
                            put_in.push(k);
                        }
                    }
                }
            }
        }
        push(&mut out, i);
    }
    // A row put in carries no count of the export's own.
    for k in put_in {
        for v in [&mut out.extra.charge, &mut out.extra.discharge_charge]
            .into_iter()
            .flatten()
        {
            v[k] = f64::NAN;
        }
    }
    Ok((out, report))
}

/// Step starts placed from the export's own charge count, for rows
/// without a step time (the Panasonic MAT-files' `Ah`): where two rows
/// further apart than the log's rhythm (more than a period `h` and more
/// than 1.5 times the rows' median spacing: a stretch the cycler did not
/// log as it logs the rest) but not a gap (at most `gap_s`) carry
/// currents `I₀`, `I₁` that differ by more than 1 % of the largest, and the
/// export's signed count moved `ΔQ` between them, the current changed at
/// the instant `τ` that gives that charge, `I₀·(τ − t₀) + I₁·(t₁ − τ) =
/// ΔQ`: a row is put in at `τ` with the new current, and the stretch to
/// the row is [`Unlogged`] (its voltage unobserved). Held from row to row
/// instead, a discharge that ended at its last logged row runs on to the
/// next one (a 60 s log's rest first logged 300 s later: 0.07 A·h a
/// step). Nothing is placed where the count's step lies outside what the
/// two currents can give (by more than 1 % of their difference: a
/// restart, or more than one change), where it says the change came at
/// the row itself, or for an export that counts magnitudes or whose count
/// restarts anywhere. With `everywhere` ([`StepsMode::Count`]) the rows
/// within the log's rhythm are placed too. The report names the count
/// when it could place a start, and says `charge` where it placed any.
pub(super) fn place_starts_from_count(
    raw: &mut RawRows,
    (h, gap_s): (f64, f64),
    everywhere: bool,
    column: &str,
    report: &mut StepReport,
) {
    let Some((theirs, _, magnitude)) = counts(raw) else {
        return;
    };
    // A count of magnitudes, or one that restarts, cannot place a change.
    let restarts = charge_check(raw, column, gap_s).map_or(1, |c| c.resets);
    if magnitude || restarts > 0 {
        return;
    }
    // The count could date a change; the report says `charge` where it
    // did (a log with none placed reads as `rows`, as without a count).
    report.charge_column = Some(column.to_string());
    let big = raw
        .current
        .iter()
        .filter(|x| x.is_finite())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    let mut spacing: Vec<f64> = raw.time.windows(2).map(|w| w[1] - w[0]).collect();
    spacing.sort_by(f64::total_cmp);
    let median = spacing.get(spacing.len() / 2).copied().unwrap_or(0.0);
    let rhythm = if everywhere {
        0.0
    } else {
        (h * (1.0 + 1e-9)).max(1.5 * median)
    };
    let (mut at, mut changes, mut unlogged) = (Vec::new(), 0, Vec::new());
    for p in 1..raw.time.len() {
        let (t0, t1) = (raw.time[p - 1], raw.time[p]);
        let (i0, i1) = (raw.current[p - 1], raw.current[p]);
        let dt = t1 - t0;
        let step = (i1 - i0).abs();
        if dt <= rhythm || dt > gap_s || !step.is_finite() || step <= 0.01 * big {
            continue;
        }
        changes += 1;
        let dq = (theirs[p] - theirs[p - 1]) * 3600.0;
        let (lo, hi) = (i0.min(i1) * dt, i0.max(i1) * dt);
        let tol = 0.01 * (i1 - i0).abs() * dt;
        if !dq.is_finite() || dq < lo - tol || dq > hi + tol {
            continue;
        }
        let tau = t0 + (dq.clamp(lo, hi) - i1 * dt) / (i0 - i1);
        if t1 - tau > 0.01 * dt {
            at.push((p, tau.clamp(t0, t1)));
            unlogged.push(Unlogged {
                start_s: tau.clamp(t0, t1),
                first_row_s: t1,
            });
        }
    }
    if at.is_empty() {
        return;
    }
    report.starts_from = "charge";
    report.count_everywhere = everywhere;
    report.changes = changes;
    report.unlogged = unlogged;
    // The rows put in: each a copy of the new step's first row at its
    // start, with no count of the export's.
    let copy = |v: &[f64]| put_in(v, &at, |p, _| v[p]);
    raw.current = copy(&raw.current);
    raw.voltage = copy(&raw.voltage);
    raw.temperature = raw.temperature.as_deref().map(copy);
    raw.time = put_in(&raw.time, &at, |_, tau| tau);
    raw.rows = put_in(&raw.rows, &at, |p, _| raw.rows[p]);
    for c in [&mut raw.extra.charge, &mut raw.extra.discharge_charge]
        .into_iter()
        .flatten()
    {
        *c = put_in(c, &at, |_, _| f64::NAN);
    }
}

/// `v` with `x(p, τ)` put in before its row `p`, for each `(p, τ)` of `at`
/// (`p` ascending).
fn put_in<T: Copy>(v: &[T], at: &[(usize, f64)], x: impl Fn(usize, f64) -> T) -> Vec<T> {
    let mut out = Vec::with_capacity(v.len() + at.len());
    let mut next = at.iter().peekable();
    for (k, &y) in v.iter().enumerate() {
        while let Some(&&(p, tau)) = next.peek().filter(|(p, _)| *p == k) {
            out.push(x(p, tau));
            next.next();
        }
        out.push(y);
    }
    out
}

/// Which of the rows `keep` (in time order) are a step's switch: after a
/// step change (the index changes, or without one the step time
/// restarts), at a step time of 0 (to 1 ms), in a step that has a later
/// row with a step time above 0. A cycler cannot have measured the new
/// step's current and voltage at the instant it switched: Digatron's LG
/// M50 export writes 0 A at the first row of every pulse and the pulse's
/// loaded voltage at the first row of the rest after it.
fn switch_rows(raw: &RawRows, keep: &[usize]) -> Vec<bool> {
    let mut out = vec![false; keep.len()];
    let Some(st) = raw.extra.step_time.as_deref() else {
        return out;
    };
    let step = raw.extra.step.as_deref();
    let same = |a: usize, b: usize| match step {
        Some(s) => s[a] == s[b],
        None => st[b] >= st[a],
    };
    let zero = |i: usize| st[i].abs() <= 1e-3;
    let mut p = 1;
    while p < keep.len() {
        let (a, b) = (keep[p - 1], keep[p]);
        if !same(a, b) && zero(b) {
            // The step's rows at step time 0, and whether a measured row
            // follows in the same step.
            let mut q = p;
            while q + 1 < keep.len() && same(keep[q], keep[q + 1]) && zero(keep[q + 1]) {
                q += 1;
            }
            let measured = q + 1 < keep.len() && same(keep[q], keep[q + 1]);
            if measured {
                out[p..=q].iter_mut().for_each(|x| *x = true);
            }
            p = q + 1;
        } else {
            p += 1;
        }
    }
    out
}

/// Which of the samples at `time` fall in an unlogged step start longer
/// than the period `h`: they have no measured voltage.
pub fn unobserved(unlogged: &[Unlogged], h: f64, time: &[f64]) -> Vec<bool> {
    let spans: Vec<&Unlogged> = unlogged
        .iter()
        .filter(|u| u.first_row_s - u.start_s > h * (1.0 + 1e-9))
        .collect();
    let mut out = vec![false; time.len()];
    if spans.is_empty() {
        return out;
    }
    let mut j = 0;
    for (o, &t) in out.iter_mut().zip(time) {
        while j < spans.len() && spans[j].first_row_s <= t {
            j += 1;
        }
        if let Some(u) = spans.get(j) {
            *o = t >= u.start_s - 1e-9 * t.abs().max(1.0) && t < u.first_row_s;
        }
    }
    out
}

/// The export's charge count at each row of `r` (A·h; NaN where it has
/// none), our count (each row's current held to the next) and whether the
/// export counts magnitudes (it rises, between resets, where we
/// discharge); `None` without a charge column or with fewer than two
/// rows that have a count.
fn counts(r: &RawRows) -> Option<(Vec<f64>, Vec<f64>, bool)> {
    let c = r.extra.charge.as_deref()?;
    let theirs: Vec<f64> = match r.extra.discharge_charge.as_deref() {
        Some(d) => c.iter().zip(d).map(|(a, b)| a - b).collect(),
        None => c.to_vec(),
    };
    let n = r.time.len();
    let mut q = vec![0.0; n];
    for k in 1..n {
        let i = r.current[k - 1];
        q[k] =
            q[k - 1] + if i.is_finite() { i } else { 0.0 } * (r.time[k] - r.time[k - 1]) / 3600.0;
    }
    let real: Vec<usize> = (0..n).filter(|&k| theirs[k].is_finite()).collect();
    if real.len() < 2 {
        return None;
    }
    let (mut up, mut down) = (0usize, 0usize);
    for w in real.windows(2) {
        let (a, b) = (w[0], w[1]);
        let d_ours = q[b] - q[a];
        let d = theirs[b] - theirs[a];
        if d_ours < -1e-9 && d.abs() < 2.0 * d_ours.abs() {
            if d > 0.0 {
                up += 1;
            } else {
                down += 1;
            }
        }
    }
    Some((theirs, q, up > 0 && up > 9 * down))
}

/// The charge each gap of `gaps` moved beyond what the current held across
/// it counts (A·h, + charging), from the export's own charge count: the
/// count's step over the gap less the held current's. `None` for a gap
/// whose count is not known on both sides, and for every gap of an export
/// that counts magnitudes or whose count restarts anywhere (`resets`, as
/// [`charge_check`] found them): across a gap neither can be told from a
/// charge.
pub(super) fn gap_charges(r: &RawRows, gaps: &[super::Gap], resets: usize) -> Vec<Option<f64>> {
    let known = counts(r).filter(|(_, _, magnitude)| !magnitude && resets == 0);
    gaps.iter()
        .map(|g| {
            let (theirs, q, _) = known.as_ref()?;
            let a = r.time.partition_point(|&t| t < g.start_s);
            let b = a + 1;
            let ta = *r.time.get(a)?;
            if (ta - g.start_s).abs() > 1e-9 * ta.abs().max(1.0) {
                return None;
            }
            let d = theirs.get(b)? - theirs.get(a)?;
            let held = q.get(b)? - q.get(a)?;
            (d - held).is_finite().then_some(d - held)
        })
        .collect()
}

/// The export's charge against ours over the rows `r` (after the step
/// starts), leaving out the steps longer than `gap_s`.
pub(super) fn charge_check(r: &RawRows, column: &str, gap_s: f64) -> Option<ChargeCheck> {
    let (theirs, q, magnitude) = counts(r)?;
    let real: Vec<usize> = (0..r.time.len())
        .filter(|&k| theirs[k].is_finite())
        .collect();
    let tol = 1e-6;
    let (mut ours, mut them, mut gap, mut resets) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    for w in real.windows(2) {
        let (a, b) = (w[0], w[1]);
        if r.time[b] - r.time[a] > gap_s {
            continue;
        }
        let d_ours = q[b] - q[a];
        let expect = if magnitude { d_ours.abs() } else { d_ours };
        let (ca, cb) = (theirs[a], theirs[b]);
        // A restart: the count falls towards zero and is then explained
        // by this step alone.
        let reset = cb.abs() < ca.abs() - tol && (cb - expect).abs() < (cb - ca - expect).abs();
        let d = if reset {
            resets += 1;
            cb
        } else {
            cb - ca
        };
        let d = if magnitude {
            d.abs() * if d_ours < 0.0 { -1.0 } else { 1.0 }
        } else {
            d
        };
        ours += d_ours;
        them += d;
        gap = gap.max((ours - them).abs());
    }
    Some(ChargeCheck {
        column: column.to_string(),
        ours_ah: ours,
        theirs_ah: them,
        max_gap_ah: gap,
        resets,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn states_sign_as_each_cycler_writes_them() {
        for (s, want) in [
            ("C", 1),
            ("d", -1),
            ("R", 0),
            ("CHRG", 1),
            ("DCHG", -1),
            ("REST", 0),
            ("P", 0),
        ] {
            assert_eq!(state_sign(s), Some(want), "{s}");
        }
        assert_eq!(state_sign("X"), None);
    }

    #[test]
    fn unobserved_samples_are_those_inside_a_long_unlogged_start() {
        let u = [
            Unlogged {
                start_s: 2.0,
                first_row_s: 5.0,
            },
            // Shorter than a period: observed.
            Unlogged {
                start_s: 7.5,
                first_row_s: 8.0,
            },
        ];
        let t: Vec<f64> = (0..10).map(f64::from).collect();
        let m = unobserved(&u, 1.0, &t);
        let want: Vec<bool> = (0..10).map(|k| (2..5).contains(&k)).collect();
        assert_eq!(m, want);
    }
}
