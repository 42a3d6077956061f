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
