//! Reading and writing the CSV files, with one-line errors that name the
//! file, the row and the column, and writes that never leave a half-written
//! file behind (write to a temporary file, then rename).

use anyhow::{anyhow, bail, Context, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Columns read from a CSV file, by name.
pub struct Columns {
    /// One vector per requested column, in the requested order.
    pub data: Vec<Vec<f64>>,
}

/// Reads the named columns (other columns are ignored) of a CSV file with a
/// header. Every cell must be a finite number. Data rows are numbered from
/// 2 (row 1 is the header), as a spreadsheet shows them.
pub fn read_columns(path: &Path, names: &[&str], max_rows: Option<usize>) -> Result<Columns> {
    let file = File::open(path).with_context(|| format!("{}: cannot open", path.display()))?;
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(false)
        .from_reader(std::io::BufReader::new(file));
    let headers = rdr
        .headers()
        .map_err(|e| anyhow!("{}: row 1: cannot read the header ({e})", path.display()))?
        .clone();
    let mut idx = Vec::with_capacity(names.len());
    for name in names {
        match headers.iter().position(|h| h == *name) {
            Some(i) => idx.push(i),
            None => bail!(
                "{}: row 1: missing column `{name}` (expected header {})",
                path.display(),
                names.join(",")
            ),
        }
    }
    let mut data = vec![Vec::new(); names.len()];
    let mut rec = csv::StringRecord::new();
    let mut row = 1usize;
    loop {
        row += 1;
        match rdr.read_record(&mut rec) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => bail!("{}: row {row}: malformed CSV ({e})", path.display()),
        }
        if max_rows.is_some_and(|m| data[0].len() >= m) {
            break;
        }
        for (k, &i) in idx.iter().enumerate() {
            let cell = rec.get(i).unwrap_or("");
            let x: f64 = cell.parse().map_err(|_| {
                anyhow!(
                    "{}: row {row}, column `{}`: `{cell}` is not a number",
                    path.display(),
                    names[k]
                )
            })?;
            if !x.is_finite() {
                bail!(
                    "{}: row {row}, column `{}`: `{cell}` is not finite",
                    path.display(),
                    names[k]
                );
            }
            data[k].push(x);
        }
    }
    Ok(Columns { data })
}

/// A battery record: uniform sample period, current (A, + charging),
/// terminal voltage (V).
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
    let mut c = read_columns(path, &["time_s", "current_a", "voltage_v"], max_rows)?;
    let voltage = c.data.pop().unwrap_or_default();
    let current = c.data.pop().unwrap_or_default();
    let time = c.data.pop().unwrap_or_default();
    if time.len() < 2 {
        bail!(
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

/// Writes a file atomically: `fill` writes into a temporary file next to
/// `path`, which is renamed over `path` only if `fill` succeeds.
/// The sample period of a `time_s` column: its first step, which every
/// step must repeat (to 1 ppm).
pub fn uniform_step(path: &Path, time: &[f64]) -> Result<f64> {
    if time.len() < 2 {
        bail!(
            "{}: {} data rows; at least 2 are needed",
            path.display(),
            time.len()
        );
    }
    let h = time[1] - time[0];
    if h.is_nan() || h <= 0.0 {
        bail!(
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
                "{}: row {}, column `time_s`: non-uniform time step {d} s (the first step is {h} s)",
                path.display(),
                k + 3
            );
        }
    }
    Ok(h)
}

pub fn write_atomic(path: &Path, fill: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    let tmp = temp_path(path);
    let res = (|| {
        let f = File::create(&tmp).with_context(|| format!("{}: cannot create", path.display()))?;
        let mut w = BufWriter::new(f);
        fill(&mut w)?;
        w.flush()
            .with_context(|| format!("{}: cannot write", path.display()))?;
        Ok(())
    })();
    match res {
        Ok(()) => {
            std::fs::rename(&tmp, path).with_context(|| format!("{}: cannot write", path.display()))
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
    let (soc, ocv) = (&c.data[0], &c.data[1]);
    HostOcvTable::new(soc, ocv).map_err(|e| {
        use estimator_core::battery::ocv::OcvError;
        match e {
            OcvError::NonFinite { index }
            | OcvError::SocOutOfRange { index }
            | OcvError::NotIncreasing { index } => {
                anyhow!("{}: row {}: {e}", path.display(), index + 2)
            }
            _ => anyhow!("{}: {e}", path.display()),
        }
    })
}
