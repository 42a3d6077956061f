//! Which column of a cycler export is the time, the current, the voltage
//! and the temperature, and in which unit: from the header names
//! (`Test_Time(s)`, `I/mA`, `Voltage [V]`, `Amps`, …) or from a
//! `--columns` map. Owns the names and units the exports use; must not
//! touch the cells below the header.

use crate::bail;
use crate::error::Result;
use serde::Serialize;
use std::fmt;

/// What a column of a battery record holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Role {
    /// Time since the start of the test.
    Time,
    /// Cell current.
    Current,
    /// Terminal voltage.
    Voltage,
    /// Cell (or ambient) temperature; optional.
    Temperature,
}

impl Role {
    /// The roles, in the order of the `--columns` keys.
    pub const ALL: [Role; 4] = [Role::Time, Role::Current, Role::Voltage, Role::Temperature];

    /// `time`, `current`, `voltage`, `temperature`: the `--columns` keys.
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Time => "time",
            Role::Current => "current",
            Role::Voltage => "voltage",
            Role::Temperature => "temperature",
        }
    }

    /// Header names of this role, normalised (lower case, no blanks,
    /// `_`, `-`, `<`, `>`), in tiers: a column of an earlier tier wins over
    /// one of a later tier (Arbin's `Test_Time(s)` over its `Step_Time(s)`
    /// is not a tier question: step time is no time of the test at all).
    fn tiers(self) -> &'static [&'static [&'static str]] {
        match self {
            Role::Time => &[
                &[
                    "testtime",
                    "totaltime",
                    "elapsedtime",
                    "timetotal",
                    "progtime",
                ],
                &["time", "test", "runtime", "t"],
            ],
            Role::Current => &[&[
                "current",
                "i",
                "amps",
                "amp",
                "curr",
                "cellcurrent",
                "batterycurrent",
            ]],
            Role::Voltage => &[&[
                "voltage",
                "ewe",
                "ecell",
                "volts",
                "volt",
                "u",
                "v",
                "cellvoltage",
                "batteryvoltage",
                "terminalvoltage",
            ]],
            Role::Temperature => &[
                &[
                    "temperature",
                    "temp",
                    "celltemperature",
                    "batterytemperature",
                    "batterytemp",
                    "celltemp",
                    "auxtemperature1",
                    "tcell",
                    "t1",
                ],
                &[],
            ],
        }
    }

    /// The unit a header without one is read in: SI, except that the name
    /// may say it (`Amps`, `Volts`).
    fn default_unit(self) -> Unit {
        match self {
            Role::Time => Unit::Second,
            Role::Current => Unit::Ampere,
            Role::Voltage => Unit::Volt,
            Role::Temperature => Unit::Celsius,
        }
    }
}

/// A unit of a column, and how a value in it becomes SI (s, A, V, °C).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Unit {
    /// s.
    #[serde(rename = "s")]
    Second,
    /// ms.
    #[serde(rename = "ms")]
    Millisecond,
    /// min.
    #[serde(rename = "min")]
    Minute,
    /// h.
    #[serde(rename = "h")]
    Hour,
    /// A cell `h:mm:ss[.f]` (or `d-h:mm:ss`), as Neware exports write it.
    #[serde(rename = "h:mm:ss")]
    Clock,
    /// A.
    #[serde(rename = "A")]
    Ampere,
    /// mA.
    #[serde(rename = "mA")]
    Milliampere,
    /// V.
    #[serde(rename = "V")]
    Volt,
    /// mV.
    #[serde(rename = "mV")]
    Millivolt,
    /// °C.
    #[serde(rename = "°C")]
    Celsius,
    /// K.
    #[serde(rename = "K")]
    Kelvin,
}

impl Unit {
    /// The unit's symbol, as the JSON and the summary line spell it.
    pub fn as_str(self) -> &'static str {
        match self {
            Unit::Second => "s",
            Unit::Millisecond => "ms",
            Unit::Minute => "min",
            Unit::Hour => "h",
            Unit::Clock => "h:mm:ss",
            Unit::Ampere => "A",
            Unit::Milliampere => "mA",
            Unit::Volt => "V",
            Unit::Millivolt => "mV",
            Unit::Celsius => "°C",
            Unit::Kelvin => "K",
        }
    }

    /// A value in this unit, in SI (s, A, V) or °C.
    pub fn to_si(self, x: f64) -> f64 {
        match self {
            Unit::Second | Unit::Ampere | Unit::Volt | Unit::Celsius | Unit::Clock => x,
            Unit::Millisecond | Unit::Milliampere | Unit::Millivolt => x / 1000.0,
            Unit::Minute => x * 60.0,
            Unit::Hour => x * 3600.0,
            Unit::Kelvin => x - 273.15,
        }
    }

    /// The unit a symbol (as found in a header, any case) names for
    /// `role`, if any.
    fn parse(role: Role, symbol: &str) -> Option<Unit> {
        let s = symbol.trim().to_ascii_lowercase();
        let s = s.trim_start_matches('°');
        Some(match (role, s) {
            (Role::Time, "s" | "sec" | "secs" | "second" | "seconds") => Unit::Second,
            (Role::Time, "ms" | "msec") => Unit::Millisecond,
            (Role::Time, "min" | "mins" | "minute" | "minutes") => Unit::Minute,
            (Role::Time, "h" | "hr" | "hrs" | "hour" | "hours") => Unit::Hour,
            (Role::Time, "h:mm:ss" | "hh:mm:ss" | "hh:mm:ss.sss") => Unit::Clock,
            (Role::Current, "a" | "amp" | "amps") => Unit::Ampere,
            (Role::Current, "ma") => Unit::Milliampere,
            (Role::Voltage, "v" | "volt" | "volts") => Unit::Volt,
            (Role::Voltage, "mv") => Unit::Millivolt,
            (Role::Temperature, "c" | "degc" | "deg c" | "celsius" | "℃") => Unit::Celsius,
            (Role::Temperature, "k" | "kelvin") => Unit::Kelvin,
            _ => return None,
        })
    }
}

impl fmt::Display for Unit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A header cell split into its name and the unit it states, if any:
/// `Test_Time(s)`, `Time (s)`, `Time [s]`, `time/s`, `time_s`.
fn split_unit(role: Role, header: &str) -> (String, Option<Unit>) {
    let h = header.trim();
    for (open, close) in [('(', ')'), ('[', ']')] {
        if let Some(body) = h.strip_suffix(close) {
            if let Some(i) = body.rfind(open) {
                if let Some(u) = Unit::parse(role, &body[i + 1..]) {
                    return (normalise(&body[..i]), Some(u));
                }
                return (normalise(&body[..i]), None);
            }
        }
    }
    for sep in ['/', '_', ' '] {
        if let Some(i) = h.rfind(sep) {
            if let Some(u) = Unit::parse(role, &h[i + sep.len_utf8()..]) {
                return (normalise(&h[..i]), Some(u));
            }
        }
    }
    (normalise(h), None)
}

/// A name as the tiers spell it: lower case, without blanks, `_`, `-`,
/// `<`, `>` and `.`.
fn normalise(name: &str) -> String {
    name.chars()
        .filter(|c| !matches!(c, ' ' | '_' | '-' | '<' | '>' | '.' | '\t'))
        .flat_map(char::to_lowercase)
        .collect()
}

/// The unit a column of `role` is read in: the header's, else the name's
/// (`Amps`, `Volts`) or SI.
fn unit_of(role: Role, header: &str) -> Unit {
    split_unit(role, header)
        .1
        .unwrap_or_else(|| role.default_unit())
}

/// One column chosen for a role: its index, header and unit, and whether
/// the header stated the unit.
#[derive(Clone, Debug, PartialEq)]
pub struct Chosen {
    /// Index of the column (0-based).
    pub index: usize,
    /// The header cell, as found.
    pub header: String,
    /// The unit its values are read in.
    pub unit: Unit,
    /// Whether the header (or its name, `Amps`) said the unit, rather than
    /// the SI default being taken.
    pub unit_stated: bool,
}

/// The columns of a record: time, current and voltage, and the temperature
/// if there is one.
#[derive(Clone, Debug, PartialEq)]
pub struct ColumnChoice {
    /// Time since the start of the test.
    pub time: Chosen,
    /// Current.
    pub current: Chosen,
    /// Terminal voltage.
    pub voltage: Chosen,
    /// Temperature, if the record has a column for it.
    pub temperature: Option<Chosen>,
}

/// A `--columns` map: `time=COL,current=COL,voltage=COL[,temperature=COL]`,
/// each COL a header exactly as the file spells it (blanks around it
/// trimmed). Roles left out are recognised from the header;
/// `temperature=none` reads no temperature.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Deserialize, Serialize)]
pub struct ColumnMap {
    /// The time column's header.
    pub time: Option<String>,
    /// The current column's header.
    pub current: Option<String>,
    /// The voltage column's header.
    pub voltage: Option<String>,
    /// The temperature column's header (`none`: no temperature).
    pub temperature: Option<String>,
}

impl ColumnMap {
    /// Parses `time=COL,current=COL,…`.
    ///
    /// # Errors
    /// [`crate::ErrorKind::Options`]: an item without `=`, an unknown or
    /// repeated key, an empty header name.
    pub fn parse(spec: &str) -> Result<Self> {
        let mut m = ColumnMap::default();
        for item in spec.split(',') {
            let Some((key, col)) = item.split_once('=') else {
                bail!(
                    Options,
                    "--columns: `{item}` is not KEY=COLUMN (keys: time, current, voltage, temperature)"
                );
            };
            let (key, col) = (key.trim(), col.trim());
            if col.is_empty() {
                bail!(Options, "--columns: `{key}=` names no column");
            }
            let slot = match key {
                "time" => &mut m.time,
                "current" => &mut m.current,
                "voltage" => &mut m.voltage,
                "temperature" => &mut m.temperature,
                _ => bail!(
                    Options,
                    "--columns: unknown key `{key}` (keys: time, current, voltage, temperature)"
                ),
            };
            if slot.is_some() {
                bail!(Options, "--columns: `{key}` is given twice");
            }
            *slot = Some(col.to_string());
        }
        Ok(m)
    }

    fn get(&self, role: Role) -> Option<&str> {
        match role {
            Role::Time => self.time.as_deref(),
            Role::Current => self.current.as_deref(),
            Role::Voltage => self.voltage.as_deref(),
            Role::Temperature => self.temperature.as_deref(),
        }
    }
}

/// Why no column could be chosen for a role (the caller words the line,
/// with the file and the header found).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ChoiceError {
    /// No header of the role's names (or the `--columns` name is absent).
    Missing {
        /// The role.
        role: Role,
        /// The header asked for with `--columns`, if one was.
        asked: Option<String>,
    },
    /// Several columns fit the role equally well.
    Ambiguous {
        /// The role.
        role: Role,
        /// The headers that fit.
        headers: Vec<String>,
    },
}

impl fmt::Display for ChoiceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ChoiceError::Missing {
                role,
                asked: Some(name),
            } => write!(f, "no column `{name}` (asked for as the {})", role.as_str()),
            ChoiceError::Missing { role, asked: None } => write!(
                f,
                "no {} column recognised; name it with --columns {}=COL",
                role.as_str(),
                role.as_str()
            ),
            ChoiceError::Ambiguous { role, headers } => write!(
                f,
                "{} columns fit the {}: {}; name one with --columns {}=COL",
                headers.len(),
                role.as_str(),
                headers
                    .iter()
                    .map(|h| format!("`{h}`"))
                    .collect::<Vec<_>>()
                    .join(", "),
                role.as_str()
            ),
        }
    }
}

/// Chooses the columns of `headers` for each role: the `map`'s where it
/// names one, else by the header names (the best tier that has any; two
/// columns in it are ambiguous). The temperature may be missing.
///
/// # Errors
/// The first role that is missing or ambiguous.
pub fn choose(
    headers: &[String],
    map: &ColumnMap,
) -> std::result::Result<ColumnChoice, ChoiceError> {
    let pick = |role: Role| -> std::result::Result<Option<Chosen>, ChoiceError> {
        if let Some(name) = map.get(role) {
            if role == Role::Temperature && name.eq_ignore_ascii_case("none") {
                return Ok(None);
            }
            let hits: Vec<usize> = (0..headers.len())
                .filter(|&i| headers[i].trim() == name)
                .collect();
            return match hits.as_slice() {
                [] => Err(ChoiceError::Missing {
                    role,
                    asked: Some(name.to_string()),
                }),
                [i] => Ok(Some(chosen(role, *i, &headers[*i]))),
                _ => Err(ChoiceError::Ambiguous {
                    role,
                    headers: hits.iter().map(|&i| headers[i].clone()).collect(),
                }),
            };
        }
        // Columns another role was given by name are not candidates.
        let taken = |i: usize| {
            Role::ALL
                .iter()
                .any(|&r| r != role && map.get(r).is_some_and(|n| headers[i].trim() == n))
        };
        for tier in role.tiers() {
            let hits: Vec<usize> = (0..headers.len())
                .filter(|&i| !taken(i))
                .filter(|&i| {
                    let name = split_unit(role, &headers[i]).0;
                    if tier.is_empty() {
                        // The temperature's last tier: any name with `temp`
                        // in it (`Battery_Temp_degC`, `Aux_Temperature_3`).
                        name.contains("temp")
                    } else {
                        tier.contains(&name.as_str())
                    }
                })
                .collect();
            match hits.as_slice() {
                [] => continue,
                [i] => return Ok(Some(chosen(role, *i, &headers[*i]))),
                _ => {
                    return Err(ChoiceError::Ambiguous {
                        role,
                        headers: hits.iter().map(|&i| headers[i].clone()).collect(),
                    })
                }
            }
        }
        if role == Role::Temperature {
            Ok(None)
        } else {
            Err(ChoiceError::Missing { role, asked: None })
        }
    };
    let need = |role| pick(role)?.ok_or(ChoiceError::Missing { role, asked: None });
    Ok(ColumnChoice {
        time: need(Role::Time)?,
        current: need(Role::Current)?,
        voltage: need(Role::Voltage)?,
        temperature: pick(Role::Temperature)?,
    })
}

fn chosen(role: Role, index: usize, header: &str) -> Chosen {
    let (name, unit) = split_unit(role, header);
    let named = matches!(
        (role, name.as_str()),
        (Role::Current, "amps" | "amp") | (Role::Voltage, "volts" | "volt")
    );
    Chosen {
        index,
        header: header.trim().to_string(),
        unit: unit.unwrap_or_else(|| unit_of(role, header)),
        unit_stated: unit.is_some() || named,
    }
}

/// A time cell in seconds: a number, or `h:mm:ss[.f]` / `d-h:mm:ss[.f]`
/// (Neware) for [`Unit::Clock`].
pub fn parse_time(cell: &str, unit: Unit) -> Option<f64> {
    if let Ok(x) = cell.parse::<f64>() {
        return Some(unit.to_si(x));
    }
    let (days, clock) = match cell.split_once('-') {
        Some((d, c)) => (d.trim().parse::<f64>().ok()?, c),
        None => (0.0, cell),
    };
    let parts: Vec<&str> = clock.split(':').collect();
    if parts.len() != 3 {
        return None;
    }
    let h: f64 = parts[0].trim().parse().ok()?;
    let m: f64 = parts[1].trim().parse().ok()?;
    let s: f64 = parts[2].trim().parse().ok()?;
    Some(days * 86_400.0 + h * 3600.0 + m * 60.0 + s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn h(names: &[&str]) -> Vec<String> {
        names.iter().map(|s| s.to_string()).collect()
    }

    fn pick(names: &[&str]) -> ColumnChoice {
        choose(&h(names), &ColumnMap::default()).unwrap()
    }

    #[test]
    fn recognises_the_common_exports_with_their_units() {
        // Arbin
        let c = pick(&[
            "Data_Point",
            "Test_Time(s)",
            "Date_Time",
            "Step_Time(s)",
            "Current(A)",
            "Voltage(V)",
            "Aux_Temperature_1(C)",
        ]);
        assert_eq!((c.time.index, c.time.unit), (1, Unit::Second));
        assert_eq!((c.current.index, c.voltage.index), (4, 5));
        assert_eq!(c.temperature.unwrap().unit, Unit::Celsius);
        // BioLogic
        let c = pick(&[
            "mode",
            "time/s",
            "control/V/mA",
            "Ewe/V",
            "I/mA",
            "Q-Qo/mA.h",
        ]);
        assert_eq!((c.time.index, c.voltage.index, c.current.index), (1, 3, 4));
        assert_eq!(c.current.unit, Unit::Milliampere);
        // PyBaMM / PyBOP
        let c = pick(&["Time [s]", "Current [A]", "Voltage [V]"]);
        assert_eq!(c.voltage.unit, Unit::Volt);
        // Maccor: unitless Amps and Volts, time in hours.
        let c = pick(&[
            "Rec#",
            "Cyc#",
            "Step",
            "Test Time (Hr)",
            "Amp-hr",
            "Amps",
            "Volts",
        ]);
        assert_eq!((c.time.index, c.time.unit), (3, Unit::Hour));
        assert_eq!((c.current.index, c.current.unit_stated), (5, true));
        // Neware: a clock time, current in mA.
        let c = pick(&[
            "Record ID",
            "Total Time",
            "Current(mA)",
            "Voltage(V)",
            "Realtime",
        ]);
        assert_eq!((c.time.index, c.current.unit), (1, Unit::Milliampere));
        assert!(!c.time.unit_stated);
        // Ours.
        let c = pick(&["time_s", "current_a", "voltage_v"]);
        assert_eq!(
            (c.time.unit, c.current.unit, c.voltage.unit),
            (Unit::Second, Unit::Ampere, Unit::Volt)
        );
        // Bitrode-style, with step columns and repeated headers around.
        let c = pick(&[
            "Loop",
            "Loop",
            "Step",
            "Mode",
            "Time(s)",
            "Current(A)",
            "Voltage(V)",
            "Temperature(C)",
        ]);
        assert_eq!((c.time.index, c.current.index, c.voltage.index), (4, 5, 6));
        assert_eq!(
            pick(&["Time (min)", "I (A)", "U (mV)"]).time.unit,
            Unit::Minute
        );
        assert_eq!(pick(&["t/ms", "I/A", "U/mV"]).voltage.unit, Unit::Millivolt);
    }

    /// The headers of the table in docs/cycler.md.
    #[test]
    fn the_documented_headers_are_read() {
        let c = pick(&["Test Time (sec)", "Amps", "Volts", "Temp 1"]);
        assert_eq!(
            (c.time.unit, c.temperature.unwrap().index),
            (Unit::Second, 3)
        );
        let c = pick(&["Total Time", "Current(A)", "Voltage(V)", "T1(°C)"]);
        assert_eq!(c.temperature.unwrap().unit, Unit::Celsius);
        let c = pick(&["time/s", "I/mA", "Ecell/V"]);
        assert_eq!(c.voltage.index, 2);
        let c = pick(&[
            "Time [s]",
            "Current [A]",
            "Terminal voltage [V]",
            "Cell temperature [K]",
        ]);
        assert_eq!(c.temperature.unwrap().unit, Unit::Kelvin);
        let c = pick(&[
            "Test_Time(s)",
            "Current(A)",
            "Voltage(V)",
            "Aux_Temperature_1(C)",
        ]);
        assert_eq!(c.temperature.unwrap().index, 3);
        let c = pick(&["time_s", "current_a", "voltage_v", "temperature_c"]);
        assert_eq!(c.temperature.unwrap().unit, Unit::Celsius);
        let e = choose(
            &h(&["time/s", "I/mA", "Ewe/V", "Ecell/V"]),
            &ColumnMap::default(),
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "2 columns fit the voltage: `Ewe/V`, `Ecell/V`; name one with --columns voltage=COL"
        );
    }

    #[test]
    fn a_missing_or_doubled_column_is_named_not_guessed() {
        let e = choose(&h(&["Time(s)", "Voltage(V)"]), &ColumnMap::default()).unwrap_err();
        assert_eq!(
            e,
            ChoiceError::Missing {
                role: Role::Current,
                asked: None
            }
        );
        let e = choose(
            &h(&["Time(s)", "Current(A)", "Voltage(V)", "Voltage(V)"]),
            &ColumnMap::default(),
        )
        .unwrap_err();
        assert!(
            matches!(
                e,
                ChoiceError::Ambiguous {
                    role: Role::Voltage,
                    ..
                }
            ),
            "{e}"
        );
        let hd = h(&[
            "Time(s)",
            "Current(A)",
            "Voltage(V)",
            "Temp_1(C)",
            "Chamber_Temp_degC",
        ]);
        let e = choose(&hd, &ColumnMap::default()).unwrap_err();
        assert!(
            e.to_string().contains("`Temp_1(C)`, `Chamber_Temp_degC`"),
            "{e}"
        );
        // A name of the first tier (the battery's) wins over the chamber's.
        let c = pick(&[
            "Time(s)",
            "Current(A)",
            "Voltage(V)",
            "Battery_Temp_degC",
            "Chamber_Temp_degC",
        ]);
        assert_eq!(c.temperature.unwrap().index, 3);
        // The map settles it, or drops the temperature.
        let mut m = ColumnMap::parse("temperature=Temp_1(C)").unwrap();
        assert_eq!(choose(&hd, &m).unwrap().temperature.unwrap().index, 3);
        m.temperature = Some("none".into());
        assert_eq!(choose(&hd, &m).unwrap().temperature, None);
    }

    #[test]
    fn a_column_map_names_columns_exactly() {
        let m = ColumnMap::parse("time=T, current=Ib,voltage=Vb").unwrap();
        let c = choose(&h(&["Vb", "Ib", "T", "Current(A)"]), &m).unwrap();
        assert_eq!((c.time.index, c.current.index, c.voltage.index), (2, 1, 0));
        let e = choose(&h(&["Vb", "T"]), &m).unwrap_err();
        assert_eq!(e.to_string(), "no column `Ib` (asked for as the current)");
        for bad in ["time", "tiem=T", "time=T,time=U", "time="] {
            assert!(ColumnMap::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn clock_times_read_as_seconds() {
        assert_eq!(parse_time("1:02:03.5", Unit::Clock), Some(3723.5));
        assert_eq!(parse_time("2-00:00:01", Unit::Clock), Some(172_801.0));
        assert_eq!(parse_time("90", Unit::Minute), Some(5400.0));
        assert_eq!(parse_time("1:2", Unit::Clock), None);
        assert_eq!(parse_time("x", Unit::Second), None);
    }
}
