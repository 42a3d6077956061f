use super::*;

#[test]
fn a_bad_map_file_is_one_line() {
    let p = std::env::temp_dir().join(format!("fracbms-badmap-{}.csv", std::process::id()));
    std::fs::write(&p, "soc,r_i\n0.5,0.01\n").unwrap();
    let e = ParameterMap::read_csv(&p).unwrap_err().to_string();
    assert!(e.contains("missing column `temperature_c`"), "{e}");
    let mut t = MAP_COLUMNS[..11].join(",");
    t.push_str("\n,0.5,0.02,0.01,abc,0.7,,,0,0.001,true\n");
    std::fs::write(&p, t).unwrap();
    let e = ParameterMap::read_csv(&p).unwrap_err().to_string();
    assert!(e.contains("row 2, column `q`: `abc`"), "{e}");
    let _ = std::fs::remove_file(&p);
}

/// A map written and read back keeps its rows, the reason of a level that
/// is not identifiable included (commas and all), so `online --prior` can
/// say why it leaves the level out; an older map's shorter rows still read.
#[test]
fn a_map_round_trips_with_its_reasons() {
    let p = std::env::temp_dir().join(format!("fracbms-map-rt-{}.csv", std::process::id()));
    let row = |soc: f64, reason: Option<&str>| MapRow {
        temperature_c: Some(25.0),
        soc,
        r_i: 0.02,
        r_ct: 0.015,
        q: 500.0,
        alpha: 0.7,
        bv_a_v: None,
        bv_i0_a: None,
        ocv_offset_v: 0.001,
        rmse_v: 0.002,
        identifiable: reason.is_none(),
        identifiable_reason: reason.map(str::to_owned),
        confidence: None,
        start_s: 0.0,
        end_s: 100.0,
        samples: 101,
    };
    let why = "R_i: its 95 % interval spans more than a factor 2 either way, [0.0003, 0.14] Ω";
    let map = ParameterMap {
        rows: vec![row(0.2, Some(why)), row(0.8, None)],
    };
    map.write_csv(&p).unwrap();
    // A row of a map written before the reason's column, joined by rows
    // (docs/maps.md): one cell shorter.
    let mut text = std::fs::read_to_string(&p).unwrap();
    text.push_str("10,0.5,0.02,0.015,500,0.7,,,0.001,0.002,true,,,,,,,,,0,100,101\n");
    std::fs::write(&p, text).unwrap();
    let back = ParameterMap::read_csv(&p).unwrap();
    let _ = std::fs::remove_file(&p);
    assert_eq!(back.rows.len(), 3);
    let old = back.rows.iter().find(|r| r.temperature_c == Some(10.0));
    assert_eq!(
        old.map(|r| (r.samples, r.identifiable_reason.is_none())),
        Some((101, true))
    );
    let new: Vec<&MapRow> = back
        .rows
        .iter()
        .filter(|r| r.temperature_c == Some(25.0))
        .collect();
    assert_eq!(new[0].identifiable_reason.as_deref(), Some(why));
    assert!(!new[0].identifiable);
    assert_eq!(new[1].identifiable_reason, None);
    assert!(new[1].identifiable);
    assert_eq!(new[1].samples, 101);
}

/// Each column of the map's CSV holds the row's field of its name (the
/// JSON of `identify battery` names them alike), the intervals' bounds
/// included: the one table of columns maps each header to its field.
#[test]
fn each_csv_column_is_its_named_field() {
    let row = MapRow {
        temperature_c: Some(25.0),
        soc: 0.5,
        r_i: 0.021,
        r_ct: 0.016,
        q: 480.0,
        alpha: 0.71,
        bv_a_v: Some(0.012),
        bv_i0_a: Some(1.5),
        ocv_offset_v: -0.001,
        rmse_v: 0.0021,
        identifiable: false,
        identifiable_reason: Some("R_ct, Q too wide".to_owned()),
        confidence: Some(crate::trust::Confidence {
            r_i: [0.020, 0.022],
            r_ct: [0.014, 0.018],
            q: [400.0, 560.0],
            alpha: [0.69, 0.73],
            bv_a: Some([0.010, 0.014]),
            bv_i0: Some([1.2, 1.9]),
        }),
        start_s: 10.0,
        end_s: 900.0,
        samples: 446,
    };
    let json = serde_json::to_value(&row).unwrap();
    assert_eq!(MAP_COLUMNS.len(), MAP_CSV.len());
    for (c, name) in MAP_CSV.iter().zip(MAP_COLUMNS) {
        assert_eq!(c.name, name);
        let cell = (c.cell)(&row);
        let want = match name.rsplit_once('_') {
            Some((p, end @ ("lo" | "hi"))) => {
                json["confidence"][p][usize::from(end == "hi")].clone()
            }
            _ => json[name].clone(),
        };
        let same = match &want {
            serde_json::Value::String(s) => cell == *s,
            serde_json::Value::Bool(b) => cell == b.to_string(),
            serde_json::Value::Number(n) => cell.parse::<f64>().ok() == n.as_f64(),
            _ => false,
        };
        assert!(same, "column `{name}`: `{cell}` against {want}");
    }
}
