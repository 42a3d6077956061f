//! Reading and writing the CSV files, with one-line errors that name the
//! file, the row and the column, and writes that never leave a half-written
//! file behind (write to a temporary file, then rename).

use crate::error::{IoContext, Result};
use crate::{bail, err};
use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};

/// Columns read from a CSV file, by name.
pub struct Columns {
    /// One vector per requested column, in the requested order.
    pub data: Vec<Vec<f64>>,
    /// The row of each data row as a spreadsheet shows it (the header is
    /// row 1; blank lines count), for errors found after reading.
    pub rows: Vec<usize>,
}

impl Columns {
    /// The spreadsheet row of data row `k` (0-based).
    pub fn row(&self, k: usize) -> usize {
        self.rows.get(k).copied().unwrap_or(k + 2)
    }

    /// Columns given in memory (a notebook's arrays, a C caller's): data
    /// row `k` is row `k + 2`, as in the CSV file they would be read from.
    pub fn from_arrays(data: Vec<Vec<f64>>) -> Self {
        let n = data.iter().map(Vec::len).max().unwrap_or(0);
        Self {
            data,
            rows: (2..n + 2).collect(),
        }
    }
}

/// A cell as an error message shows it: control characters (a line break
/// inside a quoted cell) escaped, so that the message stays on one line.
pub(crate) fn shown(cell: &str) -> std::borrow::Cow<'_, str> {
    if cell.chars().any(char::is_control) {
        cell.chars()
            .map(|c| {
                if c.is_control() {
                    c.escape_default().to_string()
                } else {
                    c.to_string()
                }
            })
            .collect::<String>()
            .into()
    } else {
        cell.into()
    }
}

/// Reads the named columns (other columns are ignored) of a CSV file with a
/// header. Every cell must be a number (NaN and ±∞ are kept: see
/// [`require_finite`]). Data rows are numbered from 2 (row 1 is the
/// header), as a spreadsheet shows them (blank lines count).
pub fn read_columns(path: &Path, names: &[&str], max_rows: Option<usize>) -> Result<Columns> {
    let file = File::open(path).io_context(|| format!("{}: cannot open", path.display()))?;
    read_columns_from(std::io::BufReader::new(file), path, names, max_rows)
}

/// [`read_columns`] on any reader (an in-memory buffer, a pipe); `path`
/// only names the data in the errors. The fuzz harness (`fracbms-tests`,
/// docs/fuzzing.md) feeds it arbitrary bytes without touching the file
/// system.
pub fn read_columns_from(
    mut reader: impl Read,
    path: &Path,
    names: &[&str],
    max_rows: Option<usize>,
) -> Result<Columns> {
    // Held whole, so that an error can name the line a record is on (the
    // columns read are about as large).
    let mut bytes = Vec::new();
    reader
        .read_to_end(&mut bytes)
        .io_context(|| format!("{}: cannot read", path.display()))?;
    let mut lines = LineCounter::new(&bytes);
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(false)
        .from_reader(bytes.as_slice());
    let headers = rdr
        .headers()
        .map_err(|e| {
            err!(
                Data,
                "{}: row 1: cannot read the header ({e})",
                path.display()
            )
        })?
        .clone();
    let mut idx = Vec::with_capacity(names.len());
    for name in names {
        match headers.iter().position(|h| h == *name) {
            Some(i) => idx.push(i),
            None => bail!(
                Data,
                "{}: row 1: missing column `{name}` (expected header {})",
                path.display(),
                names.join(",")
            ),
        }
    }
    let mut data = vec![Vec::new(); names.len()];
    let mut rows = Vec::new();
    let mut rec = csv::StringRecord::new();
    loop {
        let row = match rdr.read_record(&mut rec) {
            Ok(false) => break,
            Ok(true) => lines.row(rec.position()),
            Err(e) => bail!(
                Data,
                "{}: row {}: malformed CSV ({e})",
                path.display(),
                lines.row(e.position())
            ),
        };
        if max_rows.is_some_and(|m| rows.len() >= m) {
            break;
        }
        for (k, &i) in idx.iter().enumerate() {
            let cell = rec.get(i).unwrap_or("");
            let x: f64 = cell.parse().map_err(|_| {
                err!(
                    Data,
                    "{}: row {row}, column `{}`: `{}` is not a number",
                    path.display(),
                    names[k],
                    shown(cell)
                )
            })?;
            data[k].push(x);
        }
        rows.push(row);
    }
    Ok(Columns { data, rows })
}

/// The spreadsheet row (1-based line) of the records of a CSV text, read
/// in order: a record's position is where the reader stood before it (on
/// the previous record's line ending, before any blank lines it skipped),
/// so its row is that of the first byte after the line endings there.
pub(crate) struct LineCounter<'a> {
    bytes: &'a [u8],
    /// Bytes counted so far, and the line breaks among them.
    at: usize,
    breaks: usize,
}

impl<'a> LineCounter<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Self {
        Self {
            bytes,
            at: 0,
            breaks: 0,
        }
    }

    /// The row of the record that starts at (or after the line endings
    /// following) `pos`; the row after the last one counted without a
    /// position.
    pub(crate) fn row(&mut self, pos: Option<&csv::Position>) -> usize {
        let b = self.bytes;
        let mut start = pos.map_or(self.at, |p| p.byte() as usize).min(b.len());
        while start < b.len() && (b[start] == b'\n' || b[start] == b'\r') {
            start += 1;
        }
        // A record never starts before the last one counted.
        while self.at < start {
            let c = b[self.at];
            // A line ends at "\n", "\r\n" or a lone "\r".
            if c == b'\n' || (c == b'\r' && b.get(self.at + 1) != Some(&b'\n')) {
                self.breaks += 1;
            }
            self.at += 1;
        }
        self.breaks + 1
    }
}

/// Fails on the first NaN or infinite value of the columns `which` (indices
/// into `names`, as read by [`read_columns`]), with the row (the header is
/// row 1) and the column. [`read_columns`] keeps such values, since a
/// sample stream's bad rows are the estimators' to reject (docs/trust.md);
/// a time base, an OCV table or a Hammerstein record must be finite.
pub fn require_finite(path: &Path, c: &Columns, names: &[&str], which: &[usize]) -> Result<()> {
    for &k in which {
        if let Some(l) = c.data[k].iter().position(|x| !x.is_finite()) {
            bail!(
                Data,
                "{}: row {}, column `{}`: `{}` is not finite",
                path.display(),
                c.row(l),
                names[k],
                c.data[k][l]
            );
        }
    }
    Ok(())
}

/// A battery record: uniform sample period, current (A, + charging),
/// terminal voltage (V).
#[derive(Clone, Debug)]
pub struct BatteryRecord {
    /// Time of each sample (s).
    pub time: Vec<f64>,
    /// Current (A).
    pub current: Vec<f64>,
    /// Terminal voltage (V).
    pub voltage: Vec<f64>,
    /// Sample period h (s), from the time column.
    pub h: f64,
}

/// Reads `time_s,current_a,voltage_v` and checks the time step is uniform.
pub fn read_battery(path: &Path, max_rows: Option<usize>) -> Result<BatteryRecord> {
    let c = read_columns(path, &["time_s", "current_a", "voltage_v"], max_rows)?;
    battery_record(path, c)
}

/// [`read_battery`] on any reader; `path` only names the data in the
/// errors.
pub fn read_battery_from(
    reader: impl Read,
    path: &Path,
    max_rows: Option<usize>,
) -> Result<BatteryRecord> {
    let c = read_columns_from(
        reader,
        path,
        &["time_s", "current_a", "voltage_v"],
        max_rows,
    )?;
    battery_record(path, c)
}

/// The record of the three columns `time_s,current_a,voltage_v` (as read
/// by [`read_battery`], or [`Columns::from_arrays`]): the time must be
/// finite and uniform; a non-finite current or voltage is kept for the
/// estimators to reject. `path` names the data in the errors.
pub fn battery_record(path: &Path, mut c: Columns) -> Result<BatteryRecord> {
    same_lengths(path, &c, &["time_s", "current_a", "voltage_v"])?;
    require_finite(path, &c, &["time_s", "current_a", "voltage_v"], &[0])?;
    let voltage = c.data.pop().unwrap_or_default();
    let current = c.data.pop().unwrap_or_default();
    let time = c.data.pop().unwrap_or_default();
    if time.len() < 2 {
        bail!(
            Data,
            "{}: {} data rows; at least 2 are needed",
            path.display(),
            time.len()
        );
    }
    let h = uniform_step(path, &time)?;
    Ok(BatteryRecord {
        time,
        current,
        voltage,
        h,
    })
}

/// Fails unless `c` holds one column per name, all of one length (always
/// so when read from a file; arrays given in memory may differ).
pub fn same_lengths(path: &Path, c: &Columns, names: &[&str]) -> Result<()> {
    let lens: Vec<usize> = c.data.iter().map(Vec::len).collect();
    if lens.len() != names.len() || lens.iter().any(|&n| n != lens[0]) {
        bail!(
            Data,
            "{}: columns {} have {} values: they must be of one length",
            path.display(),
            names.join(", "),
            lens.iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(())
}

/// The sample period of a `time_s` column: its first step, which every
/// step must repeat (to 1 ppm).
pub fn uniform_step(path: &Path, time: &[f64]) -> Result<f64> {
    if time.len() < 2 {
        bail!(
            Data,
            "{}: {} data rows; at least 2 are needed",
            path.display(),
            time.len()
        );
    }
    let h = time[1] - time[0];
    if h.is_nan() || h <= 0.0 {
        bail!(
            Data,
            "{}: row 3, column `time_s`: time does not increase ({} after {})",
            path.display(),
            time[1],
            time[0]
        );
    }
    for (k, w) in time.windows(2).enumerate() {
        let d = w[1] - w[0];
        if (d - h).abs() > 1e-6 * h.max(1e-3) + 1e-9 {
            bail!(
                Data,
                "{}: row {}, column `time_s`: non-uniform time step {d} s (the first step is {h} s)",
                path.display(),
                k + 3
            );
        }
    }
    Ok(h)
}

/// Writes a file atomically: `fill` writes into a temporary file next to
/// `path`, which is renamed over `path` only if `fill` succeeds.
pub fn write_atomic(path: &Path, fill: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    let tmp = temp_path(path);
    let res = (|| {
        let f = File::create(&tmp).io_context(|| format!("{}: cannot create", path.display()))?;
        let mut w = BufWriter::new(f);
        fill(&mut w)?;
        w.flush()
            .io_context(|| format!("{}: cannot write", path.display()))?;
        Ok(())
    })();
    match res {
        Ok(()) => {
            std::fs::rename(&tmp, path).io_context(|| format!("{}: cannot write", path.display()))
        }
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

fn temp_path(path: &Path) -> PathBuf {
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(".partial");
    path.with_file_name(name)
}

/// Writes a CSV file atomically from a header and rows.
pub fn write_csv<I, R>(path: &Path, header: &[&str], rows: I) -> Result<()>
where
    I: IntoIterator<Item = R>,
    R: IntoIterator<Item = String>,
{
    write_atomic(path, |w| {
        let mut wr = csv::Writer::from_writer(w);
        wr.write_record(header)?;
        for r in rows {
            wr.write_record(r)?;
        }
        wr.flush()?;
        Ok(())
    })
}

/// Writes JSON atomically.
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    write_atomic(path, |w| {
        serde_json::to_writer_pretty(&mut *w, value)?;
        writeln!(w)?;
        Ok(())
    })
}

/// Largest number of points of an OCV table file.
pub const OCV_POINTS: usize = 512;

/// The host's OCV table (room for [`OCV_POINTS`] points).
pub type HostOcvTable = estimator_core::battery::ocv::OcvTable<f64, OCV_POINTS>;

/// Reads an OCV table `soc,ocv_v` (soc in [0, 1], both increasing
/// strictly), with one-line errors that name the file and the row.
pub fn read_ocv(path: &Path) -> Result<HostOcvTable> {
    let c = read_columns(path, &["soc", "ocv_v"], Some(OCV_POINTS + 1))?;
    ocv_table(path, c)
}

/// [`read_ocv`] on any reader; `path` only names the data in the errors.
pub fn read_ocv_from(reader: impl Read, path: &Path) -> Result<HostOcvTable> {
    let c = read_columns_from(reader, path, &["soc", "ocv_v"], Some(OCV_POINTS + 1))?;
    ocv_table(path, c)
}

/// The OCV table of the two columns `soc,ocv_v` (as read by [`read_ocv`],
/// or [`Columns::from_arrays`]); `path` names the data in the errors.
pub fn ocv_table(path: &Path, c: Columns) -> Result<HostOcvTable> {
    same_lengths(path, &c, &["soc", "ocv_v"])?;
    let (soc, ocv) = (&c.data[0], &c.data[1]);
    HostOcvTable::new(soc, ocv).map_err(|e| {
        use estimator_core::battery::ocv::OcvError;
        match e {
            OcvError::NonFinite { index }
            | OcvError::SocOutOfRange { index }
            | OcvError::NotIncreasing { index } => {
                err!(Data, "{}: row {}: {e}", path.display(), c.row(index))
            }
            _ => err!(Data, "{}: {e}", path.display()),
        }
    })
}
