//! The map's CSV: [`MAP_COLUMNS`] written, and read back with the
//! contract's eleven columns required and the rest read when present.

use super::{MapRow, ParameterMap, MAP_COLUMNS};
use crate::error::Result;
use crate::io;
use crate::trust::Confidence;
use crate::{bail, err};
use std::path::Path;

impl ParameterMap {
    /// Writes the map as CSV ([`MAP_COLUMNS`]; empty cells for unknown
    /// temperature, a linear level's BV columns and missing intervals).
    ///
    /// # Errors
    /// [`crate::ErrorKind::Io`] when the file cannot be written.
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        let opt = |x: Option<f64>| x.map_or(String::new(), |x| x.to_string());
        io::write_csv(
            path,
            &MAP_COLUMNS,
            self.rows.iter().map(|r| {
                let c = r.confidence.as_ref();
                let iv = |f: fn(&Confidence) -> [f64; 2], i: usize| opt(c.map(|c| f(c)[i]));
                vec![
                    opt(r.temperature_c),
                    r.soc.to_string(),
                    r.r_i.to_string(),
                    r.r_ct.to_string(),
                    r.q.to_string(),
                    r.alpha.to_string(),
                    opt(r.bv_a_v),
                    opt(r.bv_i0_a),
                    r.ocv_offset_v.to_string(),
                    r.rmse_v.to_string(),
                    r.identifiable.to_string(),
                    iv(|c| c.r_i, 0),
                    iv(|c| c.r_i, 1),
                    iv(|c| c.r_ct, 0),
                    iv(|c| c.r_ct, 1),
                    iv(|c| c.q, 0),
                    iv(|c| c.q, 1),
                    iv(|c| c.alpha, 0),
                    iv(|c| c.alpha, 1),
                    r.start_s.to_string(),
                    r.end_s.to_string(),
                    r.samples.to_string(),
                    r.identifiable_reason.clone().unwrap_or_default(),
                ]
            }),
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
