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
    /// The program step's index (`Step_Index`, `Step`, `Ns`); optional.
    Step,
    /// Time since the step's start (`Step_Time(s)`, `StepTime`,
    /// `Step (Sec)`); optional.
    StepTime,
    /// The step's kind as letters (Maccor `State` C/D/R, Bitrode `Mode`
    /// CHRG/DCHG/REST, Digatron `Status` C/D/P); optional.
    State,
    /// The export's own charge count (`Capacity(Ah)`, `Amp-hr`, `AhAccu`,
    /// `Ah`, `(Q-Qo)/mA.h`, Arbin's `Charge_Capacity(Ah)` with its
    /// `Discharge_Capacity(Ah)`); optional.
    Charge,
}

impl Role {
    /// The roles, in the order of the `--columns` keys.
    pub const ALL: [Role; 8] = [
        Role::Time,
        Role::Current,
        Role::Voltage,
        Role::Temperature,
        Role::Step,
        Role::StepTime,
        Role::State,
        Role::Charge,
    ];

    /// `time`, `current`, `voltage`, `temperature`: the `--columns` keys.
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Time => "time",
            Role::Current => "current",
            Role::Voltage => "voltage",
            Role::Temperature => "temperature",
            Role::Step => "step",
            Role::StepTime => "step_time",
            Role::State => "state",
            Role::Charge => "charge",
        }
    }

    /// Whether a record can do without the role.
    pub fn optional(self) -> bool {
        !matches!(self, Role::Time | Role::Current | Role::Voltage)
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
                // NASA PCoE: the cell's (beside the load's `Current_load`).
                "currentmeasured",
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
                // NASA PCoE: the cell's (beside the load's `Voltage_load`).
                "voltagemeasured",
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
            Role::Step => &[&["step", "stepindex", "stepid", "stepnumber", "stepno", "ns"]],
            Role::StepTime => &[&["steptime", "steptimes", "timeinstep"]],
            Role::State => &[&["state", "status", "mode", "md"]],
            Role::Charge => &[
                &[
                    "capacity",
                    "amphr",
                    "ahaccu",
                    "ah",
                    "qqo",
                    "(qqo)",
                    "chargecapacity",
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
            Role::StepTime => Unit::Second,
            Role::Charge => Unit::AmpereHour,
            Role::Step | Role::State => Unit::Count,
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
    /// A·h.
    #[serde(rename = "Ah")]
    AmpereHour,
    /// mA·h.
    #[serde(rename = "mAh")]
    MilliampereHour,
    /// No unit: a step index or a state's letters.
    #[serde(rename = "")]
    Count,
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
            Unit::AmpereHour => "Ah",
            Unit::MilliampereHour => "mAh",
            Unit::Count => "",
        }
    }

    /// A value in this unit, in SI (s, A, V) or °C.
    pub fn to_si(self, x: f64) -> f64 {
        match self {
            Unit::Second
            | Unit::Ampere
            | Unit::Volt
            | Unit::Celsius
            | Unit::Clock
            | Unit::AmpereHour
            | Unit::Count => x,
            Unit::Millisecond | Unit::Milliampere | Unit::Millivolt | Unit::MilliampereHour => {
                x / 1000.0
            }
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
        let role = if role == Role::StepTime {
            Role::Time
        } else {
            role
        };
        Some(match (role, s) {
            (Role::Charge, "ah" | "a.h" | "a·h" | "amphr" | "amp-hr") => Unit::AmpereHour,
            (Role::Charge, "mah" | "ma.h" | "ma·h") => Unit::MilliampereHour,
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
    /// The step index, if any.
    pub step: Option<Chosen>,
    /// The time since the step's start, if any.
    pub step_time: Option<Chosen>,
    /// The step's kind as letters, if any.
    pub state: Option<Chosen>,
    /// The export's charge count, if any (Arbin's charge capacity).
    pub charge: Option<Chosen>,
    /// Arbin's discharge capacity, subtracted from [`ColumnChoice::charge`].
    pub discharge_charge: Option<Chosen>,
    /// Headers of columns that measure the load or the charger, not the
    /// cell (NASA PCoE's `Current_load`, `Voltage_load`, `Current_charge`,
    /// `Voltage_charge`): never read, said on the `read` line
    /// ([`other_side`]).
    pub not_the_cell: Vec<String>,
}

/// Whether `header` names a load's or a charger's current or voltage
/// (NASA PCoE's `Current_load`, `Voltage_charge`): the other side of the
/// cycler's wiring, not the cell.
pub fn other_side(header: &str) -> bool {
    matches!(
        normalise(header).as_str(),
        "currentload" | "voltageload" | "currentcharge" | "voltagecharge"
    )
}

/// A `--columns` map: `time=COL,current=COL,voltage=COL[,temperature=COL]`
/// `[,step=COL,step_time=COL,state=COL,charge=COL]`, each COL a header
/// exactly as the file spells it (blanks around it trimmed). Roles left
/// out are recognised from the header; `none` for an optional role
/// (`temperature=none`, `step_time=none`) reads no such column.
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
    /// The step index's header (`none`: not read).
    pub step: Option<String>,
    /// The step time's header (`none`: not read).
    pub step_time: Option<String>,
    /// The state column's header (`none`: not read).
    pub state: Option<String>,
    /// The export's charge column's header (`none`: not read).
    pub charge: Option<String>,
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
                    "--columns: `{item}` is not KEY=COLUMN (keys: {KEYS})"
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
                "step" => &mut m.step,
                "step_time" => &mut m.step_time,
                "state" => &mut m.state,
                "charge" => &mut m.charge,
                _ => bail!(Options, "--columns: unknown key `{key}` (keys: {KEYS})"),
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
            Role::Step => self.step.as_deref(),
            Role::StepTime => self.step_time.as_deref(),
            Role::State => self.state.as_deref(),
            Role::Charge => self.charge.as_deref(),
        }
    }
}

/// The `--columns` keys, as the errors list them.
const KEYS: &str = "time, current, voltage, temperature, step, step_time, state, charge";

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
            if role.optional() && name.eq_ignore_ascii_case("none") {
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
                .filter(|&i| fits(role, tier, &headers[i]))
                .collect();
            match hits.as_slice() {
                [] => continue,
                [i] => return Ok(Some(chosen(role, *i, &headers[*i]))),
                // A step, state or charge column that is not clear is not
                // read (it only refines the record): name it to read it.
                _ if role.optional() && role != Role::Temperature => return Ok(None),
                _ => {
                    return Err(ChoiceError::Ambiguous {
                        role,
                        headers: hits.iter().map(|&i| headers[i].clone()).collect(),
                    })
                }
            }
        }
        if role.optional() {
            Ok(None)
        } else {
            Err(ChoiceError::Missing { role, asked: None })
        }
    };
    let need = |role| pick(role)?.ok_or(ChoiceError::Missing { role, asked: None });
    let charge = pick(Role::Charge)?;
    // Arbin counts charge and discharge in two columns.
    let discharge_charge = charge
        .as_ref()
        .filter(|c| split_unit(Role::Charge, &c.header).0 == "chargecapacity")
        .and_then(|_| {
            let hits: Vec<usize> = (0..headers.len())
                .filter(|&i| split_unit(Role::Charge, &headers[i]).0 == "dischargecapacity")
                .collect();
            match hits.as_slice() {
                [i] => Some(chosen(Role::Charge, *i, &headers[*i])),
                _ => None,
            }
        });
    let charge = charge.filter(|c| {
        split_unit(Role::Charge, &c.header).0 != "chargecapacity" || discharge_charge.is_some()
    });
    Ok(ColumnChoice {
        time: need(Role::Time)?,
        current: need(Role::Current)?,
        voltage: need(Role::Voltage)?,
        temperature: pick(Role::Temperature)?,
        step: pick(Role::Step)?,
        step_time: pick(Role::StepTime)?,
        state: pick(Role::State)?,
        charge,
        discharge_charge,
        not_the_cell: headers
            .iter()
            .filter(|h| other_side(h))
            .map(|h| h.trim().to_string())
            .collect(),
    })
}

/// Whether the header `h` names a column of `role` in `tier`.
fn fits(role: Role, tier: &[&str], h: &str) -> bool {
    let (name, unit) = split_unit(role, h);
    // Maccor's `Step (Sec)` is a step time, not a step index.
    let timed = split_unit(Role::Time, h).1.is_some();
    match role {
        // The temperature's last tier: any name with `temp` in it
        // (`Battery_Temp_degC`, `Aux_Temperature_3`).
        Role::Temperature if tier.is_empty() => name.contains("temp"),
        // The charge's last tier: a name with a charge unit
        // (`Q charge/discharge/mA.h`).
        Role::Charge if tier.is_empty() => unit.is_some() && !name.contains("energy"),
        Role::Step => tier.contains(&name.as_str()) && !timed,
        Role::StepTime => tier.contains(&name.as_str()) || (name == "step" && timed),
        _ => tier.contains(&name.as_str()),
    }
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
#[path = "headers_tests.rs"]
mod tests;
