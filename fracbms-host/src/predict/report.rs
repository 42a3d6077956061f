//! The validation page of `predict battery --report DIR`: per record, the
//! RMSE and the largest error over the measured samples inside the OCV
//! table, a figure of the voltage and the error against time, and one
//! Markdown table to paste into a report.
//!
//! It owns the page's files. It must not run a model (that is
//! [`super::run_model`]) nor read records.
//!
//! The files: `report.md` (the table), `report.json` (one object per
//! record: `input`, `figure`, `csv`, and the prediction's JSON), and per
//! record `NN-NAME.svg` and `NN-NAME.csv` (the `--out` columns
//! `time_s,current_a,voltage_v,model_v,observed`).

use super::Prediction;
use crate::err;
use crate::error::Result;
use crate::io::BatteryRecord;
use crate::plot::{panels, Panel, Series};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The most points a figure's curve carries (every n-th sample beyond).
const FIGURE_POINTS: usize = 4000;

/// One record of the page: its file, how it was read and what the model
/// predicted there.
pub struct Entry<'a> {
    /// The record's file.
    pub input: &'a Path,
    /// The record as the model ran on it.
    pub record: &'a BatteryRecord,
    /// The prediction.
    pub prediction: &'a Prediction,
}

/// The file-name stem of the `k`-th record (from 1): `NN-` and the input's
/// stem with every character but letters, digits, `-`, `_` and `.` as `_`.
pub fn stem(k: usize, input: &Path) -> String {
    let name = input
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let clean: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    format!("{k:02}-{clean}")
}

/// The samples of a figure: every n-th, so that at most
/// [`FIGURE_POINTS`] remain, and only measured ones.
fn thinned(rec: &BatteryRecord, p: &Prediction, f: impl Fn(usize) -> f64) -> Vec<(f64, f64)> {
    let n = rec.time.len();
    let step = n.div_ceil(FIGURE_POINTS).max(1);
    (0..n)
        .step_by(step)
        .filter(|&k| p.observed.get(k).copied().unwrap_or(true) && rec.voltage[k].is_finite())
        .map(|k| (rec.time[k], f(k)))
        .collect()
}

/// Writes the page for `model` (its file, named in the table) into `dir`
/// (made if missing); the per-record CSVs are written by the caller
/// (`csv` names them). Returns the paths written.
///
/// # Errors
/// [`crate::ErrorKind::Io`] when a file cannot be written,
/// [`crate::ErrorKind::Data`] when a figure cannot be drawn.
pub fn write(dir: &Path, model: &Path, entries: &[Entry<'_>]) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| err!(Io, "cannot make {}: {e}", dir.display()))?;
    let mut written = vec![];
    let mut md = String::new();
    let mut json = vec![];
    let _ = writeln!(md, "# Validation of `{}`\n", model.display());
    let _ = writeln!(
        md,
        "Errors of the model's voltage against the measured one, over the measured samples \
         (not inside a gap of the log nor a step's unlogged start) whose counted SOC lies inside \
         the OCV table; beside them, over every measured sample.\n"
    );
    let _ = writeln!(
        md,
        "| record | samples in table | RMSE in table (mV) | max error in table (mV) | at (s) | RMSE, every measured sample (mV) | SOC | figure |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|");
    for (k, e) in entries.iter().enumerate() {
        let s = stem(k + 1, e.input);
        let (rec, p) = (e.record, e.prediction);
        let svg = dir.join(format!("{s}.svg"));
        let measured = thinned(rec, p, |k| rec.voltage[k]);
        let model_v = thinned(rec, p, |k| p.model_v[k]);
        let error = thinned(rec, p, |k| 1e3 * (p.model_v[k] - rec.voltage[k]));
        let name = e.input.display().to_string();
        panels(
            &svg,
            &[
                Panel {
                    title: &format!("{name}: voltage"),
                    x: "time (s)",
                    y: "voltage (V)",
                    series: vec![
                        Series {
                            label: "measured",
                            points: measured,
                            color: 3,
                        },
                        Series {
                            label: "model",
                            points: model_v,
                            color: 1,
                        },
                    ],
                    log_y: false,
                },
                Panel {
                    title: "error (model − measured)",
                    x: "time (s)",
                    y: "error (mV)",
                    series: vec![Series {
                        label: "error",
                        points: error,
                        color: 0,
                    }],
                    log_y: false,
                },
            ],
        )?;
        written.push(svg);
        let mv = |x: f64| {
            if x.is_finite() {
                format!("{:.2}", 1e3 * x)
            } else {
                "—".to_owned()
            }
        };
        let (n, rmse, worst, at) = p.in_table.map_or((0, f64::NAN, f64::NAN, f64::NAN), |t| {
            (t.samples, t.rmse_v, t.max_error_v, t.max_error_time_s)
        });
        let soc = match (p.soc0, p.soc_end) {
            (Some(a), Some(b)) => format!("{a:.3} → {b:.3}"),
            _ => "—".to_owned(),
        };
        let _ = writeln!(
            md,
            "| `{name}` | {n} | **{}** | {} | {} | {} | {soc} | [{s}.svg]({s}.svg) |",
            mv(rmse),
            mv(worst),
            if at.is_finite() {
                format!("{at:.1}")
            } else {
                "—".to_owned()
            },
            mv(p.rmse_v),
        );
        let mut j = serde_json::to_value(p).map_err(|x| err!(Io, "cannot write JSON: {x}"))?;
        if let Some(o) = j.as_object_mut() {
            o.insert("input".into(), name.clone().into());
            o.insert("figure".into(), format!("{s}.svg").into());
            o.insert("csv".into(), format!("{s}.csv").into());
        }
        json.push(j);
    }
    if let Some(u) = entries.iter().find_map(|e| e.prediction.map.as_ref()) {
        let _ = writeln!(md);
        for w in u.warnings() {
            let _ = writeln!(md, "* {w}");
        }
        if let Some(a) = &u.activation {
            let _ = writeln!(md, "* {a}");
        }
    }
    let page = dir.join("report.md");
    std::fs::write(&page, md).map_err(|e| err!(Io, "cannot write {}: {e}", page.display()))?;
    written.push(page);
    let j = dir.join("report.json");
    crate::io::write_json(&j, &json)?;
    written.push(j);
    Ok(written)
}
