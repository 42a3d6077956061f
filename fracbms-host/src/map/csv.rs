//! The map's CSV: one table of its columns ([`MAP_CSV`]: each column's
//! name and its cell of a row), written, and read back with the contract's
//! eleven columns required and the rest read when present. A column is
//! added here once: the header ([`MAP_COLUMNS`]) and the writer follow.

use super::{MapRow, ParameterMap};
use crate::error::Result;
use crate::io;
use crate::trust::Confidence;
use crate::{bail, err};
use std::path::Path;

/// One column of the map's CSV: its header and its cell of a row.
#[derive(Clone, Copy, Debug)]
pub struct MapColumn {
    /// The header.
    pub name: &'static str,
    /// The row's cell (empty for unknown: a temperature, a linear level's
    /// Butler–Volmer columns, missing intervals).
    pub cell: fn(&MapRow) -> String,
}

/// An optional value's cell: empty for `None`.
fn opt(x: Option<f64>) -> String {
    x.map_or(String::new(), |x| x.to_string())
}

/// Bound `i` (0: low, 1: high) of the interval `f` picks, or empty.
fn bound(r: &MapRow, f: fn(&Confidence) -> [f64; 2], i: usize) -> String {
    opt(r.confidence.as_ref().map(|c| f(c)[i]))
}

/// An end of a Butler–Volmer interval (empty without the term).
fn term_bound(r: &MapRow, f: fn(&Confidence) -> Option<[f64; 2]>, i: usize) -> String {
    opt(r.confidence.as_ref().and_then(f).map(|x| x[i]))
}

/// The map's CSV, column by column, in order (the contract's eleven
/// first).
pub const MAP_CSV: [MapColumn; 27] = [
    MapColumn {
        name: "temperature_c",
        cell: |r| opt(r.temperature_c),
    },
    MapColumn {
        name: "soc",
        cell: |r| r.soc.to_string(),
    },
    MapColumn {
        name: "r_i",
        cell: |r| r.r_i.to_string(),
    },
    MapColumn {
        name: "r_ct",
        cell: |r| r.r_ct.to_string(),
    },
    MapColumn {
        name: "q",
        cell: |r| r.q.to_string(),
    },
    MapColumn {
        name: "alpha",
        cell: |r| r.alpha.to_string(),
    },
    MapColumn {
        name: "bv_a_v",
        cell: |r| opt(r.bv_a_v),
    },
    MapColumn {
        name: "bv_i0_a",
        cell: |r| opt(r.bv_i0_a),
    },
    MapColumn {
        name: "ocv_offset_v",
        cell: |r| r.ocv_offset_v.to_string(),
    },
    MapColumn {
        name: "rmse_v",
        cell: |r| r.rmse_v.to_string(),
    },
    MapColumn {
        name: "identifiable",
        cell: |r| r.identifiable.to_string(),
    },
    MapColumn {
        name: "r_i_lo",
        cell: |r| bound(r, |c| c.r_i, 0),
    },
    MapColumn {
        name: "r_i_hi",
        cell: |r| bound(r, |c| c.r_i, 1),
    },
    MapColumn {
        name: "r_ct_lo",
        cell: |r| bound(r, |c| c.r_ct, 0),
    },
    MapColumn {
        name: "r_ct_hi",
        cell: |r| bound(r, |c| c.r_ct, 1),
    },
    MapColumn {
        name: "q_lo",
        cell: |r| bound(r, |c| c.q, 0),
    },
    MapColumn {
        name: "q_hi",
        cell: |r| bound(r, |c| c.q, 1),
    },
    MapColumn {
        name: "alpha_lo",
        cell: |r| bound(r, |c| c.alpha, 0),
    },
    MapColumn {
        name: "alpha_hi",
        cell: |r| bound(r, |c| c.alpha, 1),
    },
    MapColumn {
        name: "start_s",
        cell: |r| r.start_s.to_string(),
    },
    MapColumn {
        name: "end_s",
        cell: |r| r.end_s.to_string(),
    },
    MapColumn {
        name: "samples",
        cell: |r| r.samples.to_string(),
    },
    MapColumn {
        name: "identifiable_reason",
        cell: |r| r.identifiable_reason.clone().unwrap_or_default(),
    },
    MapColumn {
        name: "bv_a_lo",
        cell: |r| term_bound(r, |c| c.bv_a, 0),
    },
    MapColumn {
        name: "bv_a_hi",
        cell: |r| term_bound(r, |c| c.bv_a, 1),
    },
    MapColumn {
        name: "bv_i0_lo",
        cell: |r| term_bound(r, |c| c.bv_i0, 0),
    },
    MapColumn {
        name: "bv_i0_hi",
        cell: |r| term_bound(r, |c| c.bv_i0, 1),
    },
];

/// The map's CSV headers, in order: [`MAP_CSV`]'s names.
pub const MAP_COLUMNS: [&str; 27] = {
    let mut out = [""; 27];
    let mut i = 0;
    while i < out.len() {
        out[i] = MAP_CSV[i].name;
        i += 1;
    }
    out
};

impl ParameterMap {
    /// Writes the map as CSV ([`MAP_CSV`]).
    ///
    /// # Errors
    /// [`crate::ErrorKind::Io`] when the file cannot be written.
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        io::write_csv(
            path,
            &MAP_COLUMNS,
            self.rows
                .iter()
                .map(|r| MAP_CSV.iter().map(|c| (c.cell)(r)).collect::<Vec<_>>()),
        )
    }

    /// Reads a map CSV: the contract's eleven columns are needed, the rest
    /// are read when present.
    ///
    /// # Errors
    /// [`crate::ErrorKind::Io`] or [`crate::ErrorKind::Data`] (a missing
    /// column, a cell that is not a number, no rows), naming the row.
    pub fn read_csv(path: &Path) -> Result<Self> {
        // Flexible: maps written before a column was added, joined by rows
        // with newer ones, have rows one cell shorter.
        let mut rdr = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .flexible(true)
            .from_path(path)
            .map_err(|e| err!(Io, "{}: cannot read ({e})", path.display()))?;
        let headers = rdr
            .headers()
            .map_err(|e| err!(Data, "{}: {e}", path.display()))?
            .clone();
        let col = |name: &str| headers.iter().position(|h| h == name);
        let mut idx = vec![];
        for name in &MAP_COLUMNS[..11] {
            idx.push(col(name).ok_or_else(|| {
                err!(
                    Data,
                    "{}: missing column `{name}` (a map of identify battery --map-out)",
                    path.display()
                )
            })?);
        }
        let extra = |name: &str| col(name);
        let mut rows = vec![];
        for (k, rec) in rdr.records().enumerate() {
            let row = k + 2;
            let rec = rec.map_err(|e| err!(Data, "{}: row {row}: {e}", path.display()))?;
            let cell = |i: usize| rec.get(i).unwrap_or("");
            let num = |i: usize, name: &str| -> Result<f64> {
                cell(i).parse::<f64>().map_err(|_| {
                    err!(
                        Data,
                        "{}: row {row}, column `{name}`: `{}` is not a number",
                        path.display(),
                        cell(i)
                    )
                })
            };
            let opt = |i: usize, name: &str| -> Result<Option<f64>> {
                if cell(i).is_empty() {
                    Ok(None)
                } else {
                    num(i, name).map(Some)
                }
            };
            let opt_named = |name: &str| -> Result<Option<f64>> {
                match extra(name) {
                    Some(i) => opt(i, name),
                    None => Ok(None),
                }
            };
            let pair = |a: &str, b: &str| -> Result<Option<[f64; 2]>> {
                Ok(match (opt_named(a)?, opt_named(b)?) {
                    (Some(x), Some(y)) => Some([x, y]),
                    _ => None,
                })
            };
            let confidence = match (
                pair("r_i_lo", "r_i_hi")?,
                pair("r_ct_lo", "r_ct_hi")?,
                pair("q_lo", "q_hi")?,
                pair("alpha_lo", "alpha_hi")?,
            ) {
                (Some(r_i), Some(r_ct), Some(q), Some(alpha)) => Some(Confidence {
                    r_i,
                    r_ct,
                    q,
                    alpha,
                    bv_a: pair("bv_a_lo", "bv_a_hi")?,
                    bv_i0: pair("bv_i0_lo", "bv_i0_hi")?,
                }),
                _ => None,
            };
            let identifiable = match cell(idx[10]) {
                "true" | "1" => true,
                "false" | "0" => false,
                x => bail!(
                    Data,
                    "{}: row {row}, column `identifiable`: `{x}` is not true or false",
                    path.display()
                ),
            };
            let r = MapRow {
                temperature_c: opt(idx[0], "temperature_c")?,
                soc: num(idx[1], "soc")?,
                r_i: num(idx[2], "r_i")?,
                r_ct: num(idx[3], "r_ct")?,
                q: num(idx[4], "q")?,
                alpha: num(idx[5], "alpha")?,
                bv_a_v: opt(idx[6], "bv_a_v")?,
                bv_i0_a: opt(idx[7], "bv_i0_a")?,
                ocv_offset_v: num(idx[8], "ocv_offset_v")?,
                rmse_v: num(idx[9], "rmse_v")?,
                identifiable,
                identifiable_reason: extra("identifiable_reason")
                    .map(|i| cell(i).to_owned())
                    .filter(|x| !x.is_empty()),
                confidence,
                start_s: opt_named("start_s")?.unwrap_or(f64::NAN),
                end_s: opt_named("end_s")?.unwrap_or(f64::NAN),
                samples: opt_named("samples")?.unwrap_or(0.0) as usize,
            };
            if !r.cell().is_physical() {
                bail!(Data, "{}: row {row}: not a physical cell", path.display());
            }
            rows.push(r);
        }
        if rows.is_empty() {
            bail!(Data, "{}: the map has no rows", path.display());
        }
        let mut m = ParameterMap { rows };
        m.sort();
        Ok(m)
    }
}
