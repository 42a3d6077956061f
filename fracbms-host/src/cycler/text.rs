//! Text exports (CSV, or tab- or semicolon-separated): the header found
//! among the first lines, and the chosen columns' cells parsed. It owns
//! nothing of what is done with the rows ([`super::finish`]).

use super::headers::{self, ChoiceError, Chosen, ColumnChoice, ColumnMap, Role};
use super::{CurrentSign, RawRows, HEADER_SEARCH_LINES};
use crate::error::Result;
use crate::io::{shown, LineCounter};
use crate::{bail, err};
use std::path::Path;

/// Refuses binary data: a text table holds no NUL byte (UTF-8, or a
/// Windows code page), and binary data read as one would name a header of
/// garbage.
///
/// # Errors
/// [`crate::ErrorKind::Data`] for a NUL byte in the first 64 KiB.
pub(super) fn refuse_binary(bytes: &[u8], path: &Path) -> Result<()> {
    if bytes.iter().take(1 << 16).any(|&b| b == 0) {
        bail!(
            Data,
            "{}: binary data, neither a text table nor a level-5 MAT-file (a UTF-16 text export is not read: save it as UTF-8)",
            path.display()
        );
    }
    Ok(())
}

pub(super) type HeaderFound = (usize, usize, u8, ColumnChoice);

/// The header line: the first of the first lines whose cells (split at
/// `,`, tab or `;`) name the columns. Returns its row, the byte after it,
/// the delimiter and the choice.
pub(super) fn find_header(bytes: &[u8], path: &Path, map: &ColumnMap) -> Result<HeaderFound> {
    let mut first: Option<(usize, Vec<String>, ChoiceError)> = None;
    let mut at = 0usize;
    let mut row = 0usize;
    while at < bytes.len() && row < HEADER_SEARCH_LINES {
        row += 1;
        let end = bytes[at..]
            .iter()
            .position(|&c| c == b'\n' || c == b'\r')
            .map_or(bytes.len(), |p| at + p);
        let line = &bytes[at..end];
        // The next line starts after "\n", "\r\n" or a lone "\r".
        let mut next = end;
        if next < bytes.len() && bytes[next] == b'\r' {
            next += 1;
        }
        if next < bytes.len() && bytes[next] == b'\n' {
            next += 1;
        }
        let line = line.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(line);
        if !line.iter().all(u8::is_ascii_whitespace) {
            let mut best: Option<(Vec<String>, ChoiceError)> = None;
            for delimiter in [b',', b'\t', b';'] {
                let cells = split_line(line, delimiter);
                match headers::choose(&cells, map) {
                    Ok(choice) => return Ok((row, next, delimiter, choice)),
                    Err(e @ ChoiceError::Ambiguous { .. }) => {
                        bail!(
                            Data,
                            "{}: row {row}: {e} (header: {})",
                            path.display(),
                            listed(&cells)
                        )
                    }
                    Err(e) => {
                        if best.as_ref().is_none_or(|(c, _)| cells.len() > c.len()) {
                            best = Some((cells, e));
                        }
                    }
                }
            }
            if first
                .as_ref()
                .is_none_or(|(_, c, _)| best.as_ref().is_some_and(|(b, _)| b.len() > c.len()))
            {
                first = Some(match best {
                    Some((c, e)) => (row, c, e),
                    None => (
                        row,
                        split_line(line, b','),
                        ChoiceError::Missing {
                            role: Role::Time,
                            asked: None,
                        },
                    ),
                });
            }
        }
        at = next;
    }
    match first {
        Some((row, cells, e)) => bail!(
            Data,
            "{}: row {row}: {e} (header: {})",
            path.display(),
            listed(&cells)
        ),
        None => bail!(Data, "{}: the file is empty", path.display()),
    }
}

/// The cells of one line, unquoted and trimmed.
fn split_line(line: &[u8], delimiter: u8) -> Vec<String> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .delimiter(delimiter)
        .flexible(true)
        .from_reader(line);
    let mut rec = csv::ByteRecord::new();
    match rdr.read_byte_record(&mut rec) {
        Ok(true) => rec
            .iter()
            .map(|c| String::from_utf8_lossy(c).trim().to_string())
            .collect(),
        _ => Vec::new(),
    }
}

/// A header as an error lists it: at most 24 cells, each quoted.
pub(super) fn listed(cells: &[String]) -> String {
    let mut s: Vec<String> = cells
        .iter()
        .take(24)
        .map(|c| format!("`{}`", shown(c)))
        .collect();
    if cells.len() > 24 {
        s.push(format!("… ({} columns)", cells.len()));
    }
    s.join(", ")
}

/// The data rows below the header, the chosen columns parsed and
/// converted to SI (°C for the temperature).
pub(super) fn read_rows(
    data: &[u8],
    header_row: usize,
    delimiter: u8,
    c: &ColumnChoice,
    path: &Path,
    sign: CurrentSign,
) -> Result<RawRows> {
    let mut lines = LineCounter::new(data);
    // Each cell read is trimmed of ASCII white space where it is read (the
    // reader's own trimming builds every row anew).
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .delimiter(delimiter)
        .flexible(true)
        .from_reader(data);
    // The columns hold a row per line at most: made that long at once, not
    // grown by copies.
    let lines_in = data.iter().filter(|&&b| b == b'\n').count() + 1;
    let column = || Vec::with_capacity(lines_in);
    let mut out = RawRows {
        time: column(),
        current: column(),
        voltage: column(),
        temperature: c.temperature.as_ref().map(|_| column()),
        rows: Vec::with_capacity(lines_in),
        clock_time: false,
        extra: super::steps::Extra::of(c),
    };
    let s = sign.factor();
    let mut rec = csv::ByteRecord::new();
    loop {
        let row = match rdr.read_byte_record(&mut rec) {
            Ok(false) => break,
            Ok(true) => header_row + lines.row(rec.position()),
            Err(e) => bail!(
                Data,
                "{}: row {}: malformed CSV ({e})",
                path.display(),
                header_row + lines.row(e.position())
            ),
        };
        let cell = |ch: &Chosen| -> Result<&str> {
            let b = rec.get(ch.index).map(<[u8]>::trim_ascii).ok_or_else(|| {
                err!(
                    Data,
                    "{}: row {row}: {} cells; column `{}` is cell {}",
                    path.display(),
                    rec.len(),
                    ch.header,
                    ch.index + 1
                )
            })?;
            std::str::from_utf8(b).map_err(|_| {
                err!(
                    Data,
                    "{}: row {row}, column `{}`: not UTF-8 text",
                    path.display(),
                    ch.header
                )
            })
        };
        let not_a_number = |ch: &Chosen, x: &str| {
            err!(
                Data,
                "{}: row {row}, column `{}`: `{}` is not a number",
                path.display(),
                ch.header,
                shown(x)
            )
        };
        let number = |ch: &Chosen| -> Result<f64> {
            let x = cell(ch)?;
            x.parse::<f64>()
                .map(|v| ch.unit.to_si(v))
                .map_err(|_| not_a_number(ch, x))
        };
        let tx = cell(&c.time)?;
        let t = headers::parse_time(tx, c.time.unit).ok_or_else(|| not_a_number(&c.time, tx))?;
        if !t.is_finite() {
            bail!(
                Data,
                "{}: row {row}, column `{}`: `{t}` is not finite",
                path.display(),
                c.time.header,
            );
        }
        if out.rows.is_empty() && tx.parse::<f64>().is_err() {
            out.clock_time = true;
        }
        out.time.push(t);
        out.current.push(s * number(&c.current)?);
        out.voltage.push(number(&c.voltage)?);
        if let (Some(ch), Some(v)) = (&c.temperature, out.temperature.as_mut()) {
            // An empty temperature cell is a missing reading, not an error.
            let x = cell(ch)?;
            v.push(if x.is_empty() {
                f64::NAN
            } else {
                x.parse::<f64>()
                    .map(|v| ch.unit.to_si(v))
                    .map_err(|_| not_a_number(ch, x))?
            });
        }
        // The step, state and charge columns: an empty cell is a missing
        // reading (NaN, or an empty state).
        let optional = |ch: &Option<Chosen>, col: &mut Option<Vec<f64>>| -> Result<()> {
            if let (Some(ch), Some(v)) = (ch, col.as_mut()) {
                let x = cell(ch)?;
                v.push(if x.is_empty() {
                    f64::NAN
                } else {
                    headers::parse_time(x, ch.unit).ok_or_else(|| not_a_number(ch, x))?
                });
            }
            Ok(())
        };
        let e = &mut out.extra;
        optional(&c.step, &mut e.step)?;
        optional(&c.step_time, &mut e.step_time)?;
        optional(&c.charge, &mut e.charge)?;
        optional(&c.discharge_charge, &mut e.discharge_charge)?;
        if let (Some(ch), Some(v)) = (&c.state, e.state.as_mut()) {
            v.push(cell(ch)?.to_string());
        }
        out.rows.push(row);
    }
    Ok(out)
}

/// The absolute time column of a text export (its name) and the cell of
/// its first data row that reads as a date and time
/// ([`super::date_time::parse_date_time`]; a units row under the header is
/// passed over); `None` without such a column or cell.
pub(super) fn first_absolute_time(
    bytes: &[u8],
    path: &Path,
    map: &ColumnMap,
) -> Result<Option<(String, String)>> {
    let (_, start, delimiter, _) = find_header(bytes, path, map)?;
    let head = bytes[..start].trim_ascii_end();
    let from = head
        .iter()
        .rposition(|&c| c == b'\n' || c == b'\r')
        .map_or(0, |p| p + 1);
    let line = &head[from..];
    let cells = split_line(
        line.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(line),
        delimiter,
    );
    let Some((index, name)) = cells
        .iter()
        .enumerate()
        .filter_map(|(i, c)| super::date_time::absolute_time_rank(c).map(|r| (r, i, c)))
        .min()
        .map(|(_, i, c)| (i, c.clone()))
    else {
        return Ok(None);
    };
    let cell = bytes[start..]
        .split(|&c| c == b'\n' || c == b'\r')
        .filter(|l| !l.iter().all(u8::is_ascii_whitespace))
        .take(3)
        .filter_map(|l| split_line(l, delimiter).get(index).cloned())
        .find(|c| super::date_time::parse_date_time(c).is_some());
    Ok(cell.map(|c| (name, c)))
}
