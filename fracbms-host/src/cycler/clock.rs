//! A log's absolute clock: the date and time of its first row, from a
//! column that holds them (Arbin's `Date_Time`, the Panasonic MAT-files'
//! `TimeStamp`, Maccor's `DPt Time`, Neware's `Realtime` or `Absolute
//! Time`, or a `DateTime`/`Timestamp`/`Date` column), so that a life's
//! logs are put in time order without a table of start times.
//!
//! It owns finding that column and its first dated row in a file; the
//! names and the date forms read are [`super::date_time`]'s (ISO 8601 and
//! the US `M/D/YYYY h:mm:ss AM`; a time without a zone is taken as UTC:
//! the order of one lab's logs does not depend on it). It must not touch
//! the rows a record is read from ([`super::read_record`]).

use super::date_time::parse_date_time;
use super::mat;
use super::text;
use super::RecordOptions;
use crate::error::{IoContext, Result};
use std::path::Path;

/// A log's absolute start: its first row's date and time.
#[derive(Clone, Debug, PartialEq)]
pub struct LogStart {
    /// As ISO 8601, `YYYY-MM-DDTHH:MM:SS` (the zone as the log gave it,
    /// none for UTC or unknown).
    pub iso: String,
    /// Seconds since 1970-01-01 00:00 UTC.
    pub utc_s: f64,
    /// The column it was read from, as the log names it.
    pub column: String,
}

/// The date and time of a log's first row, from its absolute time column
/// (see the module's list); `None` when it has none, or its first row's
/// cell is not a date and time. `o` chooses the header as
/// [`super::read_record`] would.
///
/// # Errors
/// The file cannot be read; its header is not found (as
/// [`super::read_record`] says).
///
/// ```
/// use fracbms_host::cycler::{clock::log_start, RecordOptions};
/// use std::path::Path;
///
/// let p = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../data/panasonic-18650pf/03-27-17_10.29 3423_dis5_10p.mat"));
/// let s = log_start(p, &RecordOptions::default())?.expect("a TimeStamp column");
/// assert_eq!((s.iso.as_str(), s.column.as_str()), ("2017-03-27T10:29:11", "meas.TimeStamp"));
/// # Ok::<(), fracbms_host::Error>(())
/// ```
pub fn log_start(path: &Path, o: &RecordOptions) -> Result<Option<LogStart>> {
    let bytes = std::fs::read(path).io_context(|| format!("{}: cannot read", path.display()))?;
    let found = if bytes.starts_with(mat::MAGIC) {
        mat::first_absolute_time(&bytes, path)?
    } else {
        text::first_absolute_time(&bytes, path, &o.columns)?
    };
    Ok(found.and_then(|(column, cell)| {
        parse_date_time(&cell).map(|(iso, utc_s)| LogStart { iso, utc_s, column })
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_text_log_gives_its_first_dated_row_from_the_preferred_column() {
        let o = RecordOptions::default();
        let first = |text: &str| {
            text::first_absolute_time(text.as_bytes(), Path::new("log.csv"), &o.columns).unwrap()
        };
        // A units row under the header is passed over; `Date_Time` before `Date`.
        let log = "Date,Test_Time(s),Current(A),Voltage(V),Date_Time\n\
                   ,s,A,V,\n\
                   3/1/2020,0,0,4.1,03/01/2020 08:00:05\n\
                   3/1/2020,1,1,4.0,03/01/2020 08:00:06\n";
        assert_eq!(
            first(log),
            Some(("Date_Time".to_string(), "03/01/2020 08:00:05".to_string()))
        );
        assert_eq!(first("time_s,current_a,voltage_v\n0,0,4.1\n"), None);
    }
}
