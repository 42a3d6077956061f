//! The `csv` target: `fracbms_host::io`'s readers ([`read_columns_from`],
//! [`read_battery_from`], [`read_ocv_from`]) on arbitrary bytes.
//!
//! A case builds a CSV document (a header, data rows of numbers written in
//! every way Rust parses them, LF or CRLF, a byte-order mark, blank lines,
//! quoted fields, padding), then perhaps corrupts it: a cell that is not a
//! number or not finite (`NaN`, `inf`, `1e309`), a missing or extra field,
//! a garbage or huge line, invalid UTF-8, NUL bytes, flipped bytes, a cut.
//!
//! Checked:
//! * never a panic;
//! * a document without structural faults reads back exactly (bit for bit,
//!   NaN and ±∞ included, up to `max_rows`), or fails with exactly the
//!   documented one-line error: the first cell that is not a number
//!   (`FILE: row R, column `NAME`: `CELL` is not a number`, control
//!   characters in `CELL` escaped), a non-finite
//!   time (`… is not finite`), too few rows, a non-finite OCV point, too
//!   many points; `R` is the row a spreadsheet shows;
//! * a battery record with a repeated time or an OCV table with a
//!   repeated voltage or an SOC outside `[0, 1]` is refused;
//! * any `Ok` holds equal-length columns (a battery record: a finite time
//!   with a positive uniform step; an OCV table: finite and increasing);
//! * any error is one line that starts with the file's name;
//! * now and then the same bytes through a real file ([`read_columns`]
//!   and friends) give the same result.

use super::gen::{log_uniform, pick, rate};
use super::{note, Outcome, Rng};
use fracbms_host::io::{
    read_battery, read_battery_from, read_columns, read_columns_from, read_ocv, read_ocv_from,
    BatteryRecord, Columns, HostOcvTable, OCV_POINTS,
};
use rand::Rng as _;
use std::path::Path;

/// The name the documents are read under (what errors must start with).
const LABEL: &str = "fuzz.csv";

/// Column names a [`Reader::Columns`] case asks for.
const NAMES: [&str; 8] = ["u", "y", "a", "b c", "time_s", "current_a", "v1", "v2"];

/// Which reader a case runs.
#[derive(Clone, Debug)]
enum Reader {
    Columns {
        names: Vec<&'static str>,
        max_rows: Option<usize>,
    },
    Battery {
        max_rows: Option<usize>,
    },
    Ocv,
}

impl Reader {
    /// The columns the reader asks for.
    fn names(&self) -> Vec<&'static str> {
        match self {
            Reader::Columns { names, .. } => names.clone(),
            Reader::Battery { .. } => vec!["time_s", "current_a", "voltage_v"],
            Reader::Ocv => vec!["soc", "ocv_v"],
        }
    }

    /// The row limit the reader passes to `read_columns`.
    fn max_rows(&self) -> Option<usize> {
        match self {
            Reader::Columns { max_rows, .. } | Reader::Battery { max_rows } => *max_rows,
            Reader::Ocv => Some(OCV_POINTS + 1),
        }
    }
}

/// What a reader returned, reduced to comparable values.
#[derive(Debug, PartialEq)]
enum Read {
    Columns(Vec<Vec<u64>>),
    Battery(Vec<u64>, Vec<u64>, Vec<u64>, u64),
    Ocv(Vec<u64>, Vec<u64>),
    Error(String),
}

fn bits(x: &[f64]) -> Vec<u64> {
    x.iter().map(|v| v.to_bits()).collect()
}

fn from_columns(r: fracbms_host::Result<Columns>) -> Read {
    match r {
        Ok(c) => Read::Columns(c.data.iter().map(|v| bits(v)).collect()),
        Err(e) => Read::Error(format!("{e:#}")),
    }
}

fn from_battery(r: fracbms_host::Result<BatteryRecord>) -> Read {
    match r {
        Ok(b) => Read::Battery(
            bits(&b.time),
            bits(&b.current),
            bits(&b.voltage),
            b.h.to_bits(),
        ),
        Err(e) => Read::Error(format!("{e:#}")),
    }
}

fn from_ocv(r: fracbms_host::Result<HostOcvTable>) -> Read {
    match r {
        Ok(t) => Read::Ocv(bits(t.soc_points()), bits(t.ocv_points())),
        Err(e) => Read::Error(format!("{e:#}")),
    }
}

/// Runs `reader` on `bytes` (in memory).
fn read(reader: &Reader, bytes: &[u8]) -> Read {
    let path = Path::new(LABEL);
    match reader {
        Reader::Columns { names, max_rows } => {
            from_columns(read_columns_from(bytes, path, names, *max_rows))
        }
        Reader::Battery { max_rows } => from_battery(read_battery_from(bytes, path, *max_rows)),
        Reader::Ocv => from_ocv(read_ocv_from(bytes, path)),
    }
}

/// Runs `reader`'s file version on `bytes` written to a temporary file
/// (errors name that file: it is replaced by [`LABEL`] to compare).
fn read_file(reader: &Reader, bytes: &[u8]) -> Read {
    let path = std::env::temp_dir().join(format!(
        "fracbms-fuzz-{}-{:?}.csv",
        std::process::id(),
        std::thread::current().id()
    ));
    std::fs::write(&path, bytes).expect("cannot write the temporary file");
    let r = match reader {
        Reader::Columns { names, max_rows } => from_columns(read_columns(&path, names, *max_rows)),
        Reader::Battery { max_rows } => from_battery(read_battery(&path, *max_rows)),
        Reader::Ocv => from_ocv(read_ocv(&path)),
    };
    let _ = std::fs::remove_file(&path);
    match r {
        Read::Error(m) => Read::Error(m.replacen(&path.display().to_string(), LABEL, 1)),
        other => other,
    }
}

/// A number and a way of writing it that parses back to it exactly.
fn number(rng: &mut Rng, x: f64) -> String {
    let s = match rng.random_range(0..8) {
        0..=2 => format!("{x}"),
        3 => format!("{x:e}"),
        4 => format!("{x:E}"),
        5 => format!("{x:.17e}"),
        6 if x.is_sign_positive() => format!("+{x}"),
        _ => format!("{x:?}"),
    };
    match rng.random_range(0..12) {
        0 => format!("  {s}"),
        1 => format!("{s} \t"),
        2 => format!("\"{s}\""),
        _ => s,
    }
}

/// An arbitrary finite value (with a few edge cases: ±0, subnormals,
/// `1e308`).
fn value(rng: &mut Rng) -> f64 {
    let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    match rng.random_range(0..10) {
        0 => 0.0,
        1 => -0.0,
        2 => sign * 5e-324,
        3 => sign * 1e308,
        4 => sign * log_uniform(rng, 1e-300, 1e300),
        5 => f64::from(rng.random_range(-1000i32..1000)),
        _ => rng.random_range(-10.0..10.0),
    }
}

/// Cells that are not numbers to `str::parse::<f64>` (and hold no comma,
/// quote or line break).
const NOT_NUMBERS: [&str; 14] = [
    "abc", "1.2.3", "--1", "0x10", "1e", "e5", "+-1", "1_000", "true", "", "١", "1 2", "∞",
    "nul\0l",
];
/// Cells that parse to a non-finite number.
const NOT_FINITE: [&str; 9] = [
    "inf",
    "-inf",
    "NaN",
    "nan",
    "infinity",
    "-Infinity",
    "1e309",
    "-1e400",
    "+inf",
];

/// A data cell: its text, and the value it must read as when it is a
/// clean number.
#[derive(Clone, Debug)]
struct CellText {
    text: String,
    value: f64,
    kind: Kind,
}

/// What a cell's text is to the reader.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// A number (finite, or NaN/±∞ read as such).
    Number,
    /// Not a number to `str::parse::<f64>`.
    NotNumber,
}

/// A CSV document before it is written out.
#[derive(Clone, Debug)]
struct Doc {
    header: Vec<String>,
    rows: Vec<Vec<CellText>>,
    /// Blank lines after data row `k` (same length as `rows`), and before
    /// the first data row.
    blank_after: Vec<usize>,
    blank_before: usize,
    bom: bool,
    crlf: bool,
    final_newline: bool,
}

impl Doc {
    /// The bytes of the document, and the line (1-based, as a spreadsheet
    /// shows it) of each data row.
    fn render(&self) -> (Vec<u8>, Vec<usize>) {
        let nl: &[u8] = if self.crlf { b"\r\n" } else { b"\n" };
        let mut out = Vec::new();
        if self.bom {
            out.extend_from_slice("\u{feff}".as_bytes());
        }
        out.extend_from_slice(self.header.join(",").as_bytes());
        let mut line = 1;
        let mut lines = Vec::with_capacity(self.rows.len());
        for _ in 0..self.blank_before {
            out.extend_from_slice(nl);
            line += 1;
        }
        for (k, row) in self.rows.iter().enumerate() {
            out.extend_from_slice(nl);
            line += 1;
            lines.push(line);
            let texts: Vec<&str> = row.iter().map(|c| c.text.as_str()).collect();
            out.extend_from_slice(texts.join(",").as_bytes());
            for _ in 0..self.blank_after[k] {
                out.extend_from_slice(nl);
                line += 1;
            }
        }
        if self.final_newline {
            out.extend_from_slice(nl);
        }
        (out, lines)
    }
}

/// The expected result of a clean read of columns `cols` (file column
/// indices, one per requested name): their values up to `max_rows`.
fn clean_values(doc: &Doc, cols: &[usize], max_rows: Option<usize>) -> Vec<Vec<f64>> {
    let n = max_rows.map_or(doc.rows.len(), |m| m.min(doc.rows.len()));
    cols.iter()
        .map(|&c| doc.rows[..n].iter().map(|r| r[c].value).collect())
        .collect()
}

/// Runs one case.
pub fn case(rng: &mut Rng) -> Outcome {
    let reader = match rng.random_range(0..3) {
        0 => {
            let k = rng.random_range(0..=3);
            let names = (0..k).map(|_| pick(rng, &NAMES)).collect();
            let max_rows = max_rows(rng);
            Reader::Columns { names, max_rows }
        }
        1 => Reader::Battery {
            max_rows: max_rows(rng),
        },
        _ => Reader::Ocv,
    };
    let names = reader.names();

    // The file's columns: every requested name once (shuffled among extra
    // columns, some of which repeat a requested name after it), or with
    // one missing.
    let mut header: Vec<String> = Vec::new();
    let mut distinct: Vec<&str> = Vec::new();
    for n in &names {
        if !distinct.contains(n) {
            distinct.push(n);
        }
    }
    let missing = (!distinct.is_empty() && rng.random_bool(0.03))
        .then(|| distinct.remove(rng.random_range(0..distinct.len())));
    for n in &distinct {
        header.push(n.to_string());
    }
    for _ in 0..rng.random_range(0..=2) {
        header.push(pick(rng, &["x", "note", "extra", "y2"]).to_string());
    }
    // Shuffle, then a repeated name may follow its first occurrence.
    for i in (1..header.len()).rev() {
        let j = rng.random_range(0..=i);
        header.swap(i, j);
    }
    if !distinct.is_empty() && rng.random_bool(0.05) {
        header.push(pick(rng, &distinct).to_string());
    }
    if header.is_empty() {
        header.push("x".to_string());
    }
    let cols: Vec<usize> = names
        .iter()
        .map(|n| header.iter().position(|h| h == n).unwrap_or(usize::MAX))
        .collect();
    let header_texts: Vec<String> = header
        .iter()
        .map(|h| match rng.random_range(0..10) {
            0 => format!(" {h} "),
            1 => format!("\"{h}\""),
            _ => h.clone(),
        })
        .collect();

    // The rows.
    let n_rows = match rng.random_range(0..40) {
        0..=3 => rng.random_range(0..3),
        4 if matches!(reader, Reader::Ocv) => rng.random_range(500..530),
        5..=7 => rng.random_range(0..200),
        _ => rng.random_range(0..20),
    };
    let step = pick(rng, &[1.0, 0.5, 0.1, 2.0, 0.01, 0.25]);
    let t0 = pick(rng, &[0.0, 0.0, 1.0, 100.0, -5.0]);
    let mut rows = Vec::with_capacity(n_rows);
    let mut last_ocv = rng.random_range(2.5..3.5);
    for k in 0..n_rows {
        let mut row = Vec::with_capacity(header.len());
        for h in &header {
            let x = match (h.as_str(), &reader) {
                ("time_s", Reader::Battery { .. }) => t0 + k as f64 * step,
                ("current_a", Reader::Battery { .. }) => rng.random_range(-50.0..50.0),
                ("voltage_v", _) => rng.random_range(2.5..4.2),
                ("soc", _) => {
                    if n_rows > 1 {
                        k as f64 / (n_rows - 1) as f64
                    } else {
                        0.0
                    }
                }
                ("ocv_v", _) => {
                    last_ocv += rng.random_range(1e-4..0.01);
                    last_ocv
                }
                _ => value(rng),
            };
            row.push(CellText {
                text: number(rng, x),
                value: x,
                kind: Kind::Number,
            });
        }
        rows.push(row);
    }
    let blank = rng.random_bool(0.1);
    let mut doc = Doc {
        header: header_texts,
        blank_after: (0..n_rows)
            .map(|_| usize::from(blank && rng.random_bool(0.1)))
            .collect(),
        blank_before: usize::from(blank && rng.random_bool(0.3)),
        rows,
        bom: rng.random_bool(0.05),
        crlf: rng.random_bool(0.3),
        final_newline: rng.random_bool(0.8),
    };

    // Semantic faults of a battery record or an OCV table (not CSV
    // errors): a non-uniform or non-increasing time, a non-increasing OCV,
    // an SOC outside [0, 1].
    let mut semantic = false;
    let read_rows = n_rows.min(reader.max_rows().unwrap_or(usize::MAX));
    if n_rows > 1 && read_rows > 0 && rng.random_bool(0.05) {
        // A row the reader reads, given the value of a neighbour (a
        // repeated time or OCV) or an SOC outside [0, 1].
        let k = rng.random_range(0..read_rows);
        let other = if k == 0 { 1 } else { k - 1 };
        for (c, name) in header.iter().enumerate() {
            let bad = match name.as_str() {
                "time_s" | "ocv_v" if !matches!(reader, Reader::Columns { .. }) => {
                    Some(doc.rows[other][c].value)
                }
                "soc" => Some(pick(rng, &[-0.1, 1.5])),
                _ => None,
            };
            if let Some(x) = bad {
                doc.rows[k][c] = CellText {
                    text: format!("{x}"),
                    value: x,
                    kind: Kind::Number,
                };
                semantic = true;
            }
        }
    }

    // Bad cells: not numbers, or numbers that are not finite.
    let cell_rate = rate(rng);
    if n_rows > 0 && cell_rate > 0.0 {
        let count = if rng.random_bool(0.5) {
            1
        } else {
            1 + (cell_rate * (n_rows * header.len()) as f64) as usize
        };
        for _ in 0..count {
            let row = rng.random_range(0..n_rows);
            let col = rng.random_range(0..header.len());
            doc.rows[row][col] = if rng.random_bool(0.4) {
                let text = pick(rng, &NOT_FINITE);
                CellText {
                    text: text.to_string(),
                    value: text.parse().expect("a non-finite number"),
                    kind: Kind::Number,
                }
            } else {
                // An empty cell alone on its line is a blank line, which
                // the reader skips.
                let t = pick(rng, &NOT_NUMBERS);
                let t = if t.is_empty() && header.len() == 1 {
                    "abc"
                } else {
                    t
                };
                CellText {
                    text: t.to_string(),
                    value: f64::NAN,
                    kind: Kind::NotNumber,
                }
            };
        }
    }

    // Structural faults: a field missing or added, a multi-line quoted
    // cell.
    let mut structural = 0;
    let struct_rate = rate(rng);
    for r in 0..n_rows {
        if rng.random_bool(struct_rate) {
            structural += 1;
            match rng.random_range(0..3) {
                0 => {
                    let c = rng.random_range(0..doc.rows[r].len());
                    doc.rows[r].remove(c);
                }
                1 => doc.rows[r].push(CellText {
                    text: "1".into(),
                    value: 1.0,
                    kind: Kind::Number,
                }),
                _ => {
                    let c = rng.random_range(0..doc.rows[r].len());
                    doc.rows[r][c].text = "\"1\n2\"".into();
                }
            }
        }
    }
    let (mut bytes, lines) = doc.render();

    // Byte faults.
    let byte_rate = rate(rng);
    let mut byte_faults = 0;
    if rng.random_bool(byte_rate) {
        byte_faults += 1;
        bytes = match rng.random_range(0..8) {
            0 => Vec::new(),
            1 => (0..rng.random_range(0..300))
                .map(|_| rng.random())
                .collect(),
            2 => {
                let cut = rng.random_range(0..=bytes.len());
                bytes[..cut].to_vec()
            }
            3 if rng.random_bool(0.2) => {
                // A huge line: digits (a number beyond f64, or a very long
                // fraction) or garbage.
                let n = rng.random_range(1_000..200_000);
                let fill = pick(rng, b"10x,\"");
                let mut b = bytes;
                b.extend_from_slice(if rng.random_bool(0.5) { b"\n" } else { b"\n0." });
                b.extend(std::iter::repeat_n(fill, n));
                b.extend_from_slice(b"\n");
                b
            }
            _ => {
                let mut b = bytes;
                for _ in 0..rng.random_range(1..8) {
                    if b.is_empty() {
                        break;
                    }
                    let i = rng.random_range(0..b.len());
                    b[i] = pick(
                        rng,
                        &[0u8, 0xff, 0xc3, b'"', b'\r', b'\n', b',', b' ', 0x80],
                    );
                }
                b
            }
        };
    }

    let got = read(&reader, &bytes);
    note(match got {
        Read::Error(_) => "csv: error returned",
        _ => "csv: Ok",
    });

    // The file version agrees now and then.
    if rng.random_bool(0.001) {
        let from_file = read_file(&reader, &bytes);
        if from_file != got {
            return Err(format!(
                "the file reader differs: {from_file:?} against {got:?}"
            ));
        }
    }

    check_any(&reader, &got).map_err(|e| {
        let shown = String::from_utf8_lossy(&bytes[..bytes.len().min(600)]);
        format!("{e}\n  document ({} bytes): {shown:?}", bytes.len())
    })?;

    // The oracles for documents whose outcome is known.
    let clean_structure = missing.is_none() && structural == 0 && byte_faults == 0;
    if !clean_structure {
        note("csv: structural/byte faults (invariants only)");
        return Ok(());
    }
    if names.is_empty() {
        // Nothing to read: an empty set of columns.
        return expect(&got, &Read::Columns(Vec::new()), &bytes);
    }
    // The first cell the reader cannot parse (row by row, then in the
    // order of the names): its error.
    let read_rows = n_rows.min(reader.max_rows().unwrap_or(usize::MAX));
    let unparsed = (0..read_rows).find_map(|r| {
        (0..names.len()).find_map(|k| {
            let cell = &doc.rows[r][cols[k]];
            (cell.kind == Kind::NotNumber).then_some((r, k, cell))
        })
    });
    if let Some((r, k, cell)) = unparsed {
        note("csv: oracle: the exact `not a number` error");
        let want = format!(
            "{LABEL}: row {}, column `{}`: `{}` is not a number",
            lines[r],
            names[k],
            cell.text
                .trim()
                .chars()
                .map(|c| if c.is_control() {
                    c.escape_default().to_string()
                } else {
                    c.to_string()
                })
                .collect::<String>()
        );
        return expect(&got, &Read::Error(want), &bytes);
    }
    let values = clean_values(&doc, &cols, reader.max_rows());
    let n = values[0].len();
    if semantic {
        note("csv: oracle: a bad time/OCV column refused");
        return match got {
            Read::Error(_) => Ok(()),
            _ if matches!(reader, Reader::Columns { .. }) => Ok(()),
            other => Err(format!(
                "a record with a bad time or OCV column was accepted: {other:?}"
            )),
        };
    }
    let first_non_finite = |c: &[f64]| c.iter().position(|x| !x.is_finite());
    let want = match &reader {
        Reader::Columns { .. } => Read::Columns(values.iter().map(|v| bits(v)).collect()),
        Reader::Battery { .. } if first_non_finite(&values[0]).is_some() => {
            let r = first_non_finite(&values[0]).unwrap_or(0);
            Read::Error(format!(
                "{LABEL}: row {}, column `time_s`: `{}` is not finite",
                lines[r], values[0][r]
            ))
        }
        Reader::Battery { .. } if n < 2 => {
            Read::Error(format!("{LABEL}: {n} data rows; at least 2 are needed"))
        }
        Reader::Battery { .. } => {
            // The step is read from the first two rows.
            let h = values[0][1] - values[0][0];
            Read::Battery(
                bits(&values[0]),
                bits(&values[1]),
                bits(&values[2]),
                h.to_bits(),
            )
        }
        Reader::Ocv if n < 2 => Read::Error(format!(
            "{LABEL}: OCV table has {n} points; at least 2 are needed"
        )),
        Reader::Ocv if n > OCV_POINTS => Read::Error(format!(
            "{LABEL}: OCV table has {n} points; the capacity is {OCV_POINTS}"
        )),
        Reader::Ocv => {
            match (0..n).find(|&i| !(values[0][i].is_finite() && values[1][i].is_finite())) {
                Some(i) => Read::Error(format!(
                    "{LABEL}: row {}: OCV table point {i} is not finite",
                    lines[i]
                )),
                None => Read::Ocv(bits(&values[0]), bits(&values[1])),
            }
        }
    };
    note(match want {
        Read::Error(_) => "csv: oracle: the exact record/table error",
        _ => "csv: oracle: the exact values",
    });
    expect(&got, &want, &bytes)
}

/// A row limit: none, or small, or about the rows a case has.
fn max_rows(rng: &mut Rng) -> Option<usize> {
    match rng.random_range(0..4) {
        0 => Some(rng.random_range(0..5)),
        1 => Some(rng.random_range(0..300)),
        _ => None,
    }
}

/// `got == want`, or a failure that shows both and the document.
fn expect(got: &Read, want: &Read, bytes: &[u8]) -> Outcome {
    if got == want {
        return Ok(());
    }
    let shown = String::from_utf8_lossy(&bytes[..bytes.len().min(600)]);
    Err(format!(
        "read {got:?}\n  expected {want:?}\n  document ({} bytes): {shown:?}",
        bytes.len()
    ))
}

/// The invariants of any result.
fn check_any(reader: &Reader, got: &Read) -> Outcome {
    let finite = |v: &[u64]| v.iter().all(|&b| f64::from_bits(b).is_finite());
    match got {
        Read::Error(m) => {
            if !m.starts_with(&format!("{LABEL}: ")) {
                return Err(format!("an error that does not name the file: {m:?}"));
            }
            if m.contains('\n') || m.contains('\r') {
                return Err(format!("an error of more than one line: {m:?}"));
            }
        }
        Read::Columns(data) => {
            let names = reader.names();
            if data.len() != names.len() {
                return Err(format!("{} columns for {} names", data.len(), names.len()));
            }
            if let Some(first) = data.first() {
                if data.iter().any(|c| c.len() != first.len()) {
                    return Err("columns of different lengths".into());
                }
                if reader.max_rows().is_some_and(|m| first.len() > m) {
                    return Err(format!("{} rows beyond max_rows", first.len()));
                }
            }
            // NaN and ±∞ are read as such (the estimators reject them).
        }
        Read::Battery(t, i, v, h) => {
            let h = f64::from_bits(*h);
            if t.len() < 2 || t.len() != i.len() || t.len() != v.len() {
                return Err(format!(
                    "a battery record of {}/{}/{} rows",
                    t.len(),
                    i.len(),
                    v.len()
                ));
            }
            // The current and voltage may be NaN or ±∞ (the estimators
            // reject them); the time may not.
            if !(finite(t) && h.is_finite() && h > 0.0) {
                return Err(format!(
                    "a battery record with a non-finite time or step {h}"
                ));
            }
            let t: Vec<f64> = t.iter().map(|&b| f64::from_bits(b)).collect();
            for w in t.windows(2) {
                let d = w[1] - w[0];
                if (d - h).abs() > 1e-6 * h.max(1e-3) + 1e-9 {
                    return Err(format!("a non-uniform step {d} accepted (h = {h})"));
                }
            }
            if reader.max_rows().is_some_and(|m| t.len() > m) {
                return Err(format!("{} rows beyond max_rows", t.len()));
            }
        }
        Read::Ocv(soc, ocv) => {
            let (z, v): (Vec<f64>, Vec<f64>) = (
                soc.iter().map(|&b| f64::from_bits(b)).collect(),
                ocv.iter().map(|&b| f64::from_bits(b)).collect(),
            );
            if z.len() < 2 || z.len() > OCV_POINTS || z.len() != v.len() {
                return Err(format!("an OCV table of {} points", z.len()));
            }
            let ok = z.iter().chain(&v).all(|x| x.is_finite())
                && z.iter().all(|&x| (0.0..=1.0).contains(&x))
                && z.windows(2).all(|w| w[1] > w[0])
                && v.windows(2).all(|w| w[1] > w[0]);
            if !ok {
                return Err(format!("a bad OCV table accepted: {z:?} {v:?}"));
            }
        }
    }
    Ok(())
}
