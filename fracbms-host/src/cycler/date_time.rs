//! Date and time cells as cycler logs write them: ISO 8601
//! ([`parse_start_time`]) and the US form (`M/D/YYYY h:mm:ss AM`,
//! [`parse_us_date_time`]), and the names of the columns that hold them
//! (Arbin's `Date_Time`, the Panasonic MAT-files' `TimeStamp`, Maccor's
//! `DPt Time`, Neware's `Realtime` or `Absolute Time`, a `DateTime`,
//! `Timestamp` or `Date` column). A time without a zone is taken as UTC.
//! It owns the parsing only; which file and row are read is
//! [`super::clock`]'s.

/// Column names (lower case, letters and digits only) that hold a row's
/// absolute date and time, in the order they are preferred.
const ABSOLUTE_TIME_COLUMNS: [&str; 7] = [
    "datetime",
    "timestamp",
    "dpttime",
    "absolutetime",
    "realtime",
    "systemtime",
    "date",
];

/// Whether a column's name is one of [`ABSOLUTE_TIME_COLUMNS`]: its rank.
pub(super) fn absolute_time_rank(name: &str) -> Option<usize> {
    let key: String = name
        .chars()
        .filter(char::is_ascii_alphanumeric)
        .map(|c| c.to_ascii_lowercase())
        .collect();
    ABSOLUTE_TIME_COLUMNS.iter().position(|&c| c == key)
}

/// A cell's date and time: ISO 8601, else the US form
/// ([`parse_us_date_time`]); with its ISO spelling.
pub fn parse_date_time(s: &str) -> Option<(String, f64)> {
    let s = s.trim();
    if let Some(t) = parse_start_time(s) {
        return Some((s.replacen(' ', "T", 1), t));
    }
    let iso = parse_us_date_time(s)?;
    parse_start_time(&iso).map(|t| (iso, t))
}

/// `M/D/YYYY[ h:mm[:ss[.f]][ AM|PM]]` (the US form Arbin, Maccor and the
/// Panasonic logs write; a first field over 12 is read as the day,
/// `D/M/YYYY`) as ISO 8601 `YYYY-MM-DDTHH:MM:SS`. `None` for anything
/// else.
///
/// ```
/// use fracbms_host::cycler::date_time::parse_us_date_time;
/// assert_eq!(parse_us_date_time("3/27/2017 10:29:11 AM").as_deref(), Some("2017-03-27T10:29:11"));
/// assert_eq!(parse_us_date_time("3/27/2017 12:05:00 AM").as_deref(), Some("2017-03-27T00:05:00"));
/// assert_eq!(parse_us_date_time("27/03/2017 13:05").as_deref(), Some("2017-03-27T13:05:00"));
/// assert_eq!(parse_us_date_time("2017-03-27"), None);
/// ```
pub fn parse_us_date_time(s: &str) -> Option<String> {
    let mut parts = s.split_whitespace();
    let date: Vec<&str> = parts.next()?.split('/').collect();
    let [a, b, y] = date.as_slice() else {
        return None;
    };
    let (a, b): (u32, u32) = (a.parse().ok()?, b.parse().ok()?);
    if y.len() != 4 {
        return None;
    }
    let y: u32 = y.parse().ok()?;
    let (m, d) = if a > 12 { (b, a) } else { (a, b) };
    if !(1..=12).contains(&m) || !(1..=31).contains(&d) {
        return None;
    }
    let Some(clock) = parts.next() else {
        return Some(format!("{y:04}-{m:02}-{d:02}"));
    };
    let c: Vec<&str> = clock.split(':').collect();
    let (h, mi, sec) = match c.as_slice() {
        [h, mi] => (h.parse::<u32>().ok()?, mi.parse::<u32>().ok()?, "00"),
        [h, mi, sec] => (h.parse::<u32>().ok()?, mi.parse::<u32>().ok()?, *sec),
        _ => return None,
    };
    sec.parse::<f64>()
        .ok()
        .filter(|s| (0.0..61.0).contains(s))?;
    let h = match parts.next().map(str::to_ascii_uppercase).as_deref() {
        None => h,
        Some("AM") if (1..=12).contains(&h) => h % 12,
        Some("PM") if (1..=12).contains(&h) => h % 12 + 12,
        Some(_) => return None,
    };
    if parts.next().is_some() || h > 23 || mi > 59 {
        return None;
    }
    let sec = if sec.find('.') == Some(1) {
        format!("0{sec}")
    } else {
        sec.to_string()
    };
    Some(format!("{y:04}-{m:02}-{d:02}T{h:02}:{mi:02}:{sec}"))
}

/// `YYYY-MM-DD[THH:MM[:SS[.f]]][Z|±HH:MM]` (a blank for the `T` too) as
/// seconds since 1970-01-01 00:00 UTC; a time without a zone is taken as
/// UTC. `None` for anything else.
///
/// ```
/// use fracbms_host::cycler::date_time::parse_start_time;
/// assert_eq!(parse_start_time("1970-01-02"), Some(86_400.0));
/// assert_eq!(parse_start_time("2008-04-02T15:25:41Z"), Some(1_207_149_941.0));
/// assert_eq!(parse_start_time("2008-04-02 17:25:41+02:00"), Some(1_207_149_941.0));
/// assert_eq!(parse_start_time("02/04/2008"), None);
/// ```
pub fn parse_start_time(s: &str) -> Option<f64> {
    let s = s.trim();
    let (date, rest) = match s.find(['T', ' ']) {
        Some(i) => (&s[..i], Some(&s[i + 1..])),
        None => (s, None),
    };
    let d: Vec<&str> = date.split('-').collect();
    let [y, m, day] = d.as_slice() else {
        return None;
    };
    if y.len() != 4 || m.len() != 2 || day.len() != 2 {
        return None;
    }
    let (y, m, day): (i64, u32, u32) = (y.parse().ok()?, m.parse().ok()?, day.parse().ok()?);
    if !(1..=12).contains(&m) || !(1..=31).contains(&day) {
        return None;
    }
    let mut secs = days_from_civil(y, m, day) as f64 * 86_400.0;
    if let Some(rest) = rest {
        // The zone: `Z`, or `±HH:MM` after the clock.
        let (clock, offset) = if let Some(c) = rest.strip_suffix(['Z', 'z']) {
            (c, 0.0)
        } else if let Some(i) = rest.rfind(['+', '-']) {
            let z: Vec<&str> = rest[i + 1..].split(':').collect();
            let [zh, zm] = z.as_slice() else {
                return None;
            };
            let sign = if rest[i..].starts_with('-') {
                -1.0
            } else {
                1.0
            };
            let (zh, zm): (f64, f64) = (zh.parse().ok()?, zm.parse().ok()?);
            (&rest[..i], sign * (zh * 3600.0 + zm * 60.0))
        } else {
            (rest, 0.0)
        };
        let c: Vec<&str> = clock.split(':').collect();
        let (h, mi, sec) = match c.as_slice() {
            [h, mi] => (h.parse::<f64>().ok()?, mi.parse::<f64>().ok()?, 0.0),
            [h, mi, sec] => (
                h.parse::<f64>().ok()?,
                mi.parse::<f64>().ok()?,
                sec.parse::<f64>().ok()?,
            ),
            _ => return None,
        };
        if !(0.0..24.0).contains(&h) || !(0.0..60.0).contains(&mi) || !(0.0..61.0).contains(&sec) {
            return None;
        }
        secs += h * 3600.0 + mi * 60.0 + sec - offset;
    }
    secs.is_finite().then_some(secs)
}

/// Days from 1970-01-01 to the proleptic Gregorian date (H. Hinnant's
/// `days_from_civil`).
fn days_from_civil(y: i64, m: u32, d: u32) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = i64::from((m + 9) % 12);
    let doy = (153 * mp + 2) / 5 + i64::from(d) - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn start_times_parse_as_utc_seconds_or_not_at_all() {
        assert_eq!(parse_start_time("1970-01-01T00:00:00Z"), Some(0.0));
        assert_eq!(parse_start_time("2000-03-01"), Some(951_868_800.0));
        assert_eq!(parse_start_time("2024-02-29T12:00"), Some(1_709_208_000.0));
        assert_eq!(parse_start_time("1969-12-31T23:59:59"), Some(-1.0));
        assert_eq!(parse_start_time("2008-13-01"), None);
        assert_eq!(parse_start_time("2008-04-02T25:00:00"), None);
        assert_eq!(parse_start_time("2008-4-2"), None);
        assert_eq!(parse_start_time(""), None);
    }

    #[test]
    fn cells_read_as_iso_or_the_us_form() {
        let t = |s: &str| parse_date_time(s).map(|(iso, t)| (iso, t as i64));
        assert_eq!(
            t("2008-04-02 15:25:41"),
            Some(("2008-04-02T15:25:41".into(), 1_207_149_941))
        );
        assert_eq!(
            t("4/2/2008 3:25:41 PM"),
            Some(("2008-04-02T15:25:41".into(), 1_207_149_941))
        );
        assert_eq!(
            t("04/02/2008 15:25:41.5").map(|x| x.0),
            Some("2008-04-02T15:25:41.5".into())
        );
        assert_eq!(
            t("4/2/2008 12:00:00 PM").map(|x| x.0),
            Some("2008-04-02T12:00:00".into())
        );
        assert_eq!(t("4/2/2008 13:00:00 PM"), None);
        assert_eq!(t("13/13/2008"), None);
        assert_eq!(t("4/2/08 10:00"), None);
        assert_eq!(t("3.6"), None);
        assert_eq!(t("later 1"), None);
    }
}
