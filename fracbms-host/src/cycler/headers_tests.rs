//! The header recognition on the exports of each vendor.

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

/// NASA PCoE's logs name the cell's columns `_measured` beside the load's
/// (discharge) or the charger's (charge) own, which are never the cell's.
#[test]
fn nasa_pcoe_logs_give_the_cells_columns_and_name_the_others() {
    let c = pick(&[
        "Voltage_measured",
        "Current_measured",
        "Temperature_measured",
        "Current_charge",
        "Voltage_charge",
        "Time",
    ]);
    assert_eq!((c.voltage.index, c.current.index, c.time.index), (0, 1, 5));
    assert_eq!(c.temperature.unwrap().index, 2);
    assert_eq!(c.not_the_cell, ["Current_charge", "Voltage_charge"]);
    // A record without them names none.
    assert!(pick(&["Time [s]", "Current [A]", "Voltage [V]"])
        .not_the_cell
        .is_empty());
}
