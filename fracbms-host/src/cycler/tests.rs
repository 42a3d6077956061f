use super::*;

fn read(text: &str, o: &RecordOptions) -> Result<CyclerRecord> {
    read_record_from(text.as_bytes(), Path::new("log.csv"), o)
}

fn message(text: &str, o: &RecordOptions) -> String {
    match read(text, o) {
        Ok(_) => panic!("read: {text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn our_uniform_records_read_exactly_as_before() {
    let text = "time_s,current_a,voltage_v\n0,1.25,3.7\n1,-2.5,3.6\n2,0.1,3.65\n";
    let r = read(text, &RecordOptions::default()).unwrap();
    let old = crate::io::read_battery_from(text.as_bytes(), Path::new("x"), None).unwrap();
    assert_eq!(r.record.time, old.time);
    assert_eq!(r.record.current, old.current);
    assert_eq!(r.record.voltage, old.voltage);
    assert_eq!(r.record.h, old.h);
    assert!(!r.report.resampled && r.report.resampling_line().is_none());
    assert_eq!(r.report.period_source, "uniform");
}

#[test]
fn cells_padded_with_white_space_and_crlf_lines_read_as_plain_ones() {
    let plain = "time_s,current_a,voltage_v\n0,1.25,3.7\n1,-2.5,3.6\n2,0.1,3.65\n";
    let padded =
        "time_s,current_a,voltage_v\r\n 0 ,\t1.25, 3.7\r\n1 , -2.5\t,3.6 \r\n  2,0.1,3.65\t\r\n";
    let a = read(plain, &RecordOptions::default()).unwrap();
    let b = read(padded, &RecordOptions::default()).unwrap();
    assert_eq!(a.record.time, b.record.time);
    assert_eq!(a.record.current, b.record.current);
    assert_eq!(a.record.voltage, b.record.voltage);
    assert_eq!(b.record.current, vec![1.25, -2.5, 0.1]);
    assert_eq!(b.report.rows_read, 3);
    // A cell of white space alone is not a number.
    let blank = "time_s,current_a,voltage_v\n0,1.25,3.7\n1, \t ,3.6\n";
    assert_eq!(
        message(blank, &RecordOptions::default()),
        "log.csv: row 3, column `current_a`: `` is not a number"
    );
}

#[test]
fn units_and_sign_are_converted_and_said() {
    let text = "Time [min],Current [mA],Voltage [mV],Temperature [K]\n\
                0,0,3700,298.15\n0.5,1000,3650,298.65\n1,1000,3640,\n";
    let o = RecordOptions {
        current_sign: CurrentSign::DischargePositive,
        ..RecordOptions::default()
    };
    let r = read(text, &o).unwrap();
    assert_eq!(r.record.time, vec![0.0, 30.0, 60.0]);
    assert_eq!(r.record.current, vec![-0.0, -1.0, -1.0]);
    assert!((r.record.voltage[1] - 3.65).abs() < 1e-12);
    let t = r.temperature.unwrap();
    assert!((t[1] - 25.5).abs() < 1e-9 && t[2].is_nan());
    let line = r.report.summary(Path::new("log.csv"));
    assert_eq!(
        line,
        "read log.csv: 3 rows from row 2: time `Time [min]` (min), current `Current [mA]` (mA) discharge-positive, voltage `Voltage [mV]` (mV), temperature `Temperature [K]` (K); no step-time column: each row's current held to the next"
    );
}

#[test]
fn an_arbin_export_with_extra_and_repeated_columns_reads_as_it_comes() {
    let text = "Data_Point,Loop,Loop,Test_Time(s),Date_Time,Step_Time(s),Step_Index,Current(A),Voltage(V)\r\n\
                1,1,1,0.0,2020-01-01 00:00:00,0.0,1,0,3.70\r\n\
                2,1,1,0.1,2020-01-01 00:00:00,0.1,2,-3,3.60\r\n\
                3,1,1,0.2,2020-01-01 00:00:00,0.2,2,-3,3.59\r\n\
                4,1,1,60.2,2020-01-01 00:01:00,60.0,3,0,3.68\r\n";
    let r = read(text, &RecordOptions::default()).unwrap();
    assert_eq!(r.report.columns.time, "Test_Time(s)");
    assert!(r.report.resampled);
    // The median step (0.1 s), as the record is short.
    assert_eq!(r.record.h, 0.1);
    assert_eq!(r.report.period_source, "chosen");
    let o = RecordOptions {
        period: Some(1.0),
        ..RecordOptions::default()
    };
    let r = read(text, &o).unwrap();
    assert_eq!(r.record.time.len(), 61);
    // [0, 1): the pulse's step began at 0 s (its first row, at 0.1 s, says
    // 0.1 s into it) and the rest's at 0.2 s (its first row, at 60.2 s,
    // says 60 s): −3 A for 0.2 s.
    assert!(
        (r.record.current[0] + 0.6).abs() < 1e-12,
        "{}",
        r.record.current[0]
    );
    assert!(r.report.resampling_line().unwrap().contains("(--period)"));
    assert_eq!(r.report.steps.changes, 2);
    assert_eq!(r.report.steps.unlogged.len(), 2);
    // The rest's first 60 s have no voltage; the pulse's 0.1 s is within
    // a period.
    assert_eq!(r.report.unobserved_samples, 60);
    // Read row by row (--steps ignore), as a reader without step times:
    // 0 A for 0.1 s, −3 A for 0.9 s.
    let o = RecordOptions {
        steps: StepsMode::Ignore,
        ..o
    };
    let r = read(text, &o).unwrap();
    assert!((r.record.current[0] + 2.7).abs() < 1e-12);
    assert_eq!(r.report.unobserved_samples, 0);
}

#[test]
fn hostile_exports_give_one_line_naming_what_was_found() {
    let d = RecordOptions::default();
    let m = message("Time(s),Voltage(V),Step\n0,3.7,1\n1,3.7,1\n", &d);
    assert!(
        m.starts_with("log.csv: row 1: no current column recognised")
            && m.contains("(header: `Time(s)`, `Voltage(V)`, `Step`)"),
        "{m}"
    );
    let m = message("Time(s),Current(A),Voltage(V)\n0,1,3.7\n1,x,3.7\n", &d);
    assert_eq!(
        m,
        "log.csv: row 3, column `Current(A)`: `x` is not a number"
    );
    let m = message("Time(s),Current(A),Voltage(V)\n0,1,3.7\n", &d);
    assert!(m.contains("1 data rows; at least 2"), "{m}");
    let m = message(
        "Time(s),Current(A),Voltage(V)\n5,1,3.7\n4,1,3.7\n3,1,3.7\n",
        &d,
    );
    assert!(
        m.contains("row 3, column `Time(s)`: time goes back at 2 of 3 rows"),
        "{m}"
    );
    let m = message("Time(s),Current(A),Voltage(V)\n0,1,3.7\n0,1,3.7\n", &d);
    assert!(m.contains("one time stamp"), "{m}");
    let m = message("", &d);
    assert!(m.contains("empty"), "{m}");
    let m = message("a,b\n1,2\n", &d);
    assert!(m.contains("row 1:") && m.contains("`a`, `b`"), "{m}");
    let m = message("Time(s),Current(A),Voltage(V)\n0,1,3.7\n1,1\n", &d);
    assert!(
        m.contains("row 3: 2 cells; column `Voltage(V)` is cell 3"),
        "{m}"
    );
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let o = RecordOptions {
            period: Some(bad),
            ..RecordOptions::default()
        };
        let e = read("time_s,current_a,voltage_v\n0,1,3\n1,1,3\n", &o)
            .err()
            .unwrap();
        assert_eq!(e.kind(), crate::ErrorKind::Options);
    }
    for m in [
        message("Time(s),Current(A),Voltage(V)\n0,1,3.7\n1\n", &d),
        message("Time(s),Current(A),Current(A),Voltage(V)\n0,1,1,3.7\n", &d),
    ] {
        assert_eq!(m.lines().count(), 1, "{m}");
    }
}

#[test]
fn a_few_rows_out_of_order_are_counted_and_a_preamble_skipped() {
    let mut text = String::from("Cycler export v2\nCell: A1\n\nTime(s);Current(A);Voltage(V)\n");
    for k in 0..300 {
        text += &format!(
            "{};{};{}\n",
            k,
            if k % 20 < 10 { -1 } else { 1 },
            3.6 + 0.01 * ((k % 20 >= 10) as i32 as f64)
        );
        if k == 100 {
            text += "99.5;0;3.6\n100;0;3.6\n";
        }
    }
    let r = read(&text, &RecordOptions::default()).unwrap();
    assert_eq!(r.report.header_row, 4);
    assert_eq!(
        (
            r.report.resampling.backward_times,
            r.report.resampling.duplicate_times
        ),
        (1, 1)
    );
    assert_eq!(r.record.h, 1.0);
    assert_eq!(r.record.time.len(), 300);
    assert!(r.report.sign_warning.is_none());
    // The same export with the current's sign flipped: said.
    let o = RecordOptions {
        current_sign: CurrentSign::DischargePositive,
        ..RecordOptions::default()
    };
    let w = read(&text, &o).unwrap().report.sign_warning.unwrap();
    assert!(w.contains("--current-sign charge-positive"), "{w}");
}

#[test]
fn clock_times_and_gaps_are_reported() {
    let text = "Record ID,Total Time,Current(mA),Voltage(V)\n\
                1,0:00:00,0,3.7\n2,0:00:01,-500,3.6\n3,0:00:02,-500,3.6\n4,1:00:02,0,3.7\n5,1:00:03,0,3.7\n";
    let r = read(text, &RecordOptions::default()).unwrap();
    assert_eq!(r.report.units.time, Unit::Clock);
    assert_eq!(
        r.report.resampling.gaps,
        vec![Gap {
            start_s: 2.0,
            length_s: 3600.0,
            charge_ah: None,
        }]
    );
    let j = serde_json::to_value(&r.report).unwrap();
    for key in [
        "period_s",
        "rows_merged",
        "rows_interpolated",
        "gaps",
        "duplicate_times",
        "backward_times",
    ] {
        assert!(j.get(key).is_some(), "{key}: {j}");
    }
    assert_eq!(j["units"]["current"], "mA");
}

/// A whole-record fit takes at most `max_samples`: a longer uniform log
/// is put on the period chosen for it; a period that gives more is refused.
#[test]
fn a_uniform_log_beyond_the_limit_is_put_on_a_longer_period() {
    let mut t = String::from("time_s,current_a,voltage_v\n");
    for k in 0..=60_000 {
        t.push_str(&format!("{},-1,3.6\n", k as f64 / 10.0));
    }
    let o = RecordOptions {
        max_samples: Some(MAX_SAMPLES),
        ..RecordOptions::default()
    };
    let r = read(&t, &o).unwrap();
    assert_eq!((r.record.h, r.report.period_source), (0.13, "chosen"));
    assert_eq!(r.record.time.len(), 46_154);
    // Without a limit (online), it is kept as it is.
    let r = read(&t, &RecordOptions::default()).unwrap();
    assert_eq!((r.record.h, r.record.time.len()), (0.1, 60_001));
    let o = RecordOptions {
        period: Some(0.05),
        ..o
    };
    let e = read(&t, &o).unwrap_err().to_string();
    assert!(e.contains("at most 50000"), "{e}");
}

/// A period chosen from the data, raised past the log's own step to keep
/// within the sample budget, is raised again to divide the durations
/// asked (the state of power's horizons), by at most a quarter; a given
/// one, or a log's own step, is kept.
#[test]
fn a_chosen_period_is_raised_to_divide_the_horizons() {
    // 0.1 s rows, one in ten 0.095 s (not uniform), over 174.9 s: within
    // 100 samples, 1.8 s.
    let log = |step: f64, rows: usize| {
        let mut t = String::from("time_s,current_a,voltage_v\n");
        let mut time = 0.0;
        for k in 0..rows {
            t.push_str(&format!("{time:.4},-1,3.6\n"));
            time += if k % 10 == 9 { 0.95 * step } else { step };
        }
        t
    };
    let t = log(0.1, 1750);
    let budget = RecordOptions {
        max_samples: Some(100),
        ..RecordOptions::default()
    };
    let r = read(&t, &budget).unwrap();
    assert_eq!((r.record.h, r.report.period_source), (1.8, "chosen"));
    let o = RecordOptions {
        divide_s: vec![10.0, 30.0],
        ..budget.clone()
    };
    let r = read(&t, &o).unwrap();
    assert_eq!((r.record.h, r.report.period_source), (2.0, "chosen"));
    // 7 s: none of 1.8–2.25 s divides it.
    let o = RecordOptions {
        divide_s: vec![7.0],
        ..budget.clone()
    };
    assert_eq!(read(&t, &o).unwrap().record.h, 1.8);
    let o = RecordOptions {
        period: Some(1.8),
        divide_s: vec![10.0, 30.0],
        ..budget
    };
    let r = read(&t, &o).unwrap();
    assert_eq!((r.record.h, r.report.period_source), (1.8, "given"));
    // A log whose own step is 1.8 s keeps it.
    let o = RecordOptions {
        divide_s: vec![10.0, 30.0],
        ..RecordOptions::default()
    };
    let r = read(&log(1.8, 400), &o).unwrap();
    assert_eq!((r.record.h, r.report.period_source), (1.8, "chosen"));
}

fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data")
        .join(name)
}

/// A MAT-file of the Panasonic 18650PF data (a struct `meas` of column
/// vectors, zlib-compressed) reads as its fields name it.
#[test]
fn a_mat_file_struct_reads_as_a_table() {
    let p = data("panasonic-18650pf/03-27-17_10.29 3423_dis5_10p.mat");
    let r = read_record(&p, &RecordOptions::default()).unwrap();
    let rep = &r.report;
    assert_eq!(rep.table.as_deref(), Some("meas"));
    assert_eq!(
        (rep.columns.time.as_str(), rep.columns.current.as_str()),
        ("Time", "Current")
    );
    assert_eq!(
        rep.columns.temperature.as_deref(),
        Some("Battery_Temp_degC")
    );
    assert_eq!(rep.units.temperature, Some(headers::Unit::Celsius));
    assert_eq!(rep.rows_read, 203);
    assert!(rep.summary(&p).contains("from MAT table `meas`"));
    // Discharge negative, as the data say: no sign warning.
    assert!(rep.sign_warning.is_none());
    // A table that is not there, and a file that only starts like one.
    let o = RecordOptions {
        table: Some("meas.x".into()),
        ..RecordOptions::default()
    };
    let e = read_record(&p, &o).unwrap_err().to_string();
    assert!(
        e.contains("no table `meas.x` (tables of numeric vectors: `meas`)"),
        "{e}"
    );
    let mut junk = mat::MAGIC.to_vec();
    junk.extend([7u8; 300]);
    let e = read_record_from(&junk[..], Path::new("j.mat"), &RecordOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("j.mat: not a readable MAT-file"), "{e}");
    // One line, without the parser's terminal drawing.
    assert!(
        !e.contains('\n') && !e.contains('\u{1b}') && !e.contains('─'),
        "{e}"
    );
    assert!(e.chars().count() < 200, "{e}");
    // Binary data that is not a MAT-file: one line, no header of garbage.
    let noise: Vec<u8> = (0u32..3000)
        .map(|k| (k.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    let e = read_record_from(&noise[..], Path::new("n.mat"), &RecordOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("n.mat: binary data, neither a text table"),
        "{e}"
    );
}

/// The Panasonic 10 % discharge steps, logged every 60 s with each rest's
/// first row 300 s after its discharge stopped and no step column: the
/// export's own `Ah` places each rest's start, and the two counts then
/// agree; held from row to row, each rest would run its discharge on for
/// 300 s (0.07 A·h each, 0.9 A·h over the record).
#[test]
fn the_panasonic_discharge_steps_end_where_the_exports_count_says() {
    let p = data("panasonic-18650pf/03-27-17_10.29 3423_dis5_10p.mat");
    let r = read_record(&p, &RecordOptions::default()).unwrap();
    let st = &r.report.steps;
    assert_eq!(
        (st.starts_from, st.charge_column.as_deref()),
        ("charge", Some("Ah"))
    );
    assert_eq!((st.changes, st.unlogged.len()), (12, 12));
    for u in &st.unlogged {
        assert!((u.first_row_s - u.start_s - 300.0).abs() < 1.0, "{u:?}");
    }
    let c = r.report.charge_check.as_ref().unwrap();
    assert!(c.max_gap_ah < 1e-3, "{c:?}");
    assert!(r.report.charge_warning.is_none());
    let held = read_record(
        &p,
        &RecordOptions {
            steps: StepsMode::Ignore,
            ..RecordOptions::default()
        },
    )
    .unwrap();
    let c = held.report.charge_check.as_ref().unwrap();
    assert!(c.max_gap_ah > 0.5, "{c:?}");
}

/// The Panasonic 25 °C HPPC test: its 6C pulses end at their last loaded
/// row, the next row about 1 s later (within the log's rhythm). Held to
/// it, our count parts from the export's by 48.6 mA·h and the reader
/// warns, naming `--steps count`; with it the two agree to 7 mA·h.
#[test]
fn the_panasonic_hppc_pulses_end_where_the_count_says_with_steps_count() {
    let p = data("panasonic-18650pf/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat");
    let read = |steps| {
        let o = RecordOptions {
            steps,
            capacity_ah: Some(2.9),
            ..RecordOptions::default()
        };
        read_record(&p, &o).unwrap().report
    };
    let auto = read(StepsMode::Auto);
    // Nothing placed: read row by row, as without a count.
    assert_eq!((auto.steps.starts_from, auto.steps.changes), ("rows", 0));
    assert!(auto.steps.unlogged.is_empty());
    let gap = auto.charge_check.as_ref().unwrap().max_gap_ah;
    assert!(gap > 0.04, "{gap}");
    let w = auto.charge_warning.unwrap();
    assert!(w.contains("(--steps count, --current-sign)"), "{w}");
    let count = read(StepsMode::Count);
    assert_eq!(
        (count.steps.unlogged.len(), count.steps.changes),
        (124, 134)
    );
    let gap = count.charge_check.as_ref().unwrap().max_gap_ah;
    assert!(gap < 0.01, "{gap}");
    assert!(count.charge_warning.is_none());
    assert!(count.summary(&p).contains("(--steps count): 124 of 134"));
}

/// A charge count with holes, a restart and rows that disagree with it
/// places nothing it cannot explain, and panics on none of it.
#[test]
fn a_count_that_cannot_date_a_change_places_nothing() {
    let read = |count: [&str; 6]| {
        let mut log = String::from("Time(s),Current(A),Voltage(V),Ah\n");
        let rows = [
            (0.0, 0.0),
            (60.0, -1.0),
            (61.0, -1.0),
            (62.0, -1.0),
            (362.0, 0.0),
            (363.0, 0.0),
        ];
        for ((t, i), q) in rows.iter().zip(count) {
            log += &format!("{t},{i},3.7,{q}\n");
        }
        for steps in [StepsMode::Auto, StepsMode::Count] {
            let o = RecordOptions {
                steps,
                ..RecordOptions::default()
            };
            read_record_from(log.as_bytes(), Path::new("c.csv"), &o).unwrap();
        }
        read_record_from(
            log.as_bytes(),
            Path::new("c.csv"),
            &RecordOptions::default(),
        )
        .unwrap()
        .report
        .steps
    };
    // The discharge's end dated by the count: it stopped at its last row.
    let st = read([
        "0",
        "-0.0",
        "-0.000278",
        "-0.000556",
        "-0.000556",
        "-0.000556",
    ]);
    assert_eq!((st.starts_from, st.unlogged.len()), ("charge", 1));
    assert!((st.unlogged[0].start_s - 62.0).abs() < 0.1, "{st:?}");
    // A hole where the change is: nothing to date it.
    let st = read(["0", "-0.0", "-0.000278", "NaN", "-0.000556", "-0.000556"]);
    assert!(st.unlogged.is_empty(), "{st:?}");
    // A count that moved more than the load could: nothing placed.
    let st = read(["0", "-0.0", "-0.000278", "-0.000556", "-0.5", "-0.5"]);
    assert!(st.unlogged.is_empty(), "{st:?}");
    // A count that restarts: not used at all.
    let st = read(["0", "-0.0", "-0.000278", "-0.000556", "0", "0"]);
    assert_eq!(st.starts_from, "rows");
}

/// A Digatron-style pulse (its LG M50 export): the pulse's first row, at
/// step time 0, reads 0 A under the loaded voltage; the rest's first row,
/// at step time 0, still reads the pulse's loaded voltage.
const DIGATRON_PULSE: &str = "ProgTime,Step,StepTime,Status,Current,Voltage\n\
    0.0,1,600.0,P,0,3.700\n\
    0.02,2,0.0,D,0,3.470\n\
    0.1,2,0.08,D,-7.5,3.468\n\
    0.2,2,0.18,D,-7.5,3.466\n\
    10.02,2,10.0,D,-7.5,3.430\n\
    10.04,3,0.0,P,0,3.430\n\
    11.04,3,1.0,P,0,3.672\n\
    12.04,3,2.0,P,0,3.676\n";

#[test]
fn rows_at_step_time_zero_are_the_switch_not_a_measurement() {
    let o = RecordOptions {
        period: Some(0.02),
        ..RecordOptions::default()
    };
    let r = read(DIGATRON_PULSE, &o).unwrap();
    assert_eq!(r.report.steps.switch_rows, 2);
    // The pulse ran from its switch (0.02 s) to the rest's (10.04 s):
    // 7.5 A for 10.02 s, not from the first row that reads it (0.1 s).
    let charge: f64 = r.record.current.iter().map(|i| i * r.record.h).sum();
    assert!((charge + 7.5 * 10.02).abs() < 1e-6, "{charge}");
    // The rest's first second has no measured voltage (its first row's
    // loaded voltage is not the rest's): 50 samples of 0.02 s, and the
    // pulse's first 0.08 s, 4.
    assert_eq!(r.report.unobserved_samples, 54);
    let mask = r.report.unobserved(r.record.h, &r.record.time);
    for (k, &t) in r.record.time.iter().enumerate() {
        let inside = (0.02..0.1 - 1e-9).contains(&t) || (10.04..11.04 - 1e-9).contains(&t);
        assert_eq!(mask[k], inside, "t = {t}");
    }
    assert!(r
        .report
        .summary(Path::new("log.csv"))
        .contains("2 rows at step time 0 taken as the switch, not a measurement"));
    // Read row by row, the same export holds 0 A under the loaded voltage
    // and the pulse's voltage 1 s into the rest.
    let ignore = RecordOptions {
        steps: steps::StepsMode::Ignore,
        ..o
    };
    let r = read(DIGATRON_PULSE, &ignore).unwrap();
    assert_eq!(r.report.steps.switch_rows, 0);
    let charge: f64 = r.record.current.iter().map(|i| i * r.record.h).sum();
    assert!((charge + 7.5 * 9.94).abs() < 1e-6, "{charge}");
}

#[test]
fn a_first_row_at_step_time_zero_with_nothing_after_it_in_its_step_is_kept() {
    // The record's last step has one row: it is the only reading of it.
    let text = "ProgTime,Step,StepTime,Current,Voltage\n\
                0,1,0,0,3.70\n1,2,0,-1,3.60\n2,2,1,-1,3.59\n3,3,0,0,3.66\n";
    let r = read(text, &RecordOptions::default()).unwrap();
    assert_eq!(r.report.steps.switch_rows, 1);
    assert_eq!(r.record.time.last(), Some(&3.0));
}

#[test]
fn mat_tables_named_together_are_joined_across_a_gap() {
    let p = data("lg-m50/LGM50_5Ah_Pulse.mat");
    let bytes = std::fs::read(&p).unwrap();
    let one = |t: &str| {
        let o = RecordOptions {
            table: Some(t.to_string()),
            columns: ColumnMap::parse("temperature=LogTemp001").unwrap(),
            period: Some(0.1),
            ..RecordOptions::default()
        };
        read_record_from(&bytes[..], &p, &o).unwrap()
    };
    let (a, b) = (
        "LGM50_5Ah_Pulse.T25.SoC9.Cell1.data",
        "LGM50_5Ah_Pulse.T25.SoC8.Cell1.data",
    );
    let (ra, rb) = (one(a), one(b));
    let j = one(&format!("{a}, {b}"));
    // The second starts 600 s after the first ends; its first row's
    // rested voltage is held over the gap's last second.
    let end = ra.record.time.last().unwrap() - ra.record.time[0];
    let span = rb.record.time.last().unwrap() - rb.record.time[0];
    let joined = j.record.time.last().unwrap() - j.record.time[0];
    assert!(
        (joined - (end + mat::JOIN_GAP_S + span)).abs() < 0.1 + 1e-9,
        "{joined}"
    );
    assert_eq!(j.report.resampling.gaps.len(), 1);
    // Each part's charge is its own; the gap carries none.
    let q = |r: &CyclerRecord| r.record.current.iter().sum::<f64>() * r.record.h;
    assert!(
        (q(&j) - q(&ra) - q(&rb)).abs() < 1e-6,
        "{} {} {}",
        q(&j),
        q(&ra),
        q(&rb)
    );
    assert_eq!(
        j.report.steps.switch_rows,
        ra.report.steps.switch_rows + rb.report.steps.switch_rows
    );
    // The export's own count restarts per record: it is not checked.
    assert!(j.report.charge_check.is_none());
    assert!(j
        .report
        .summary(&p)
        .contains("2 MAT tables joined in this order, each after a gap of at least 600 s"));
    let o = RecordOptions {
        table: Some(format!("{a},LGM50_5Ah_Pulse.T25.SoC0.Cell1.data")),
        columns: ColumnMap::parse("temperature=LogTemp001").unwrap(),
        ..RecordOptions::default()
    };
    let e = read_record_from(&bytes[..], &p, &o)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no table `LGM50_5Ah_Pulse.T25.SoC0.Cell1.data`"),
        "{e}"
    );
}

/// A NASA PCoE discharge log reads as it comes: the cell's measured
/// current and voltage, not the load's, said once on the `read` line;
/// its counted charge is NASA's measured capacity of that discharge.
#[test]
fn a_nasa_pcoe_discharge_reads_the_cells_columns_not_the_loads() {
    let p = data("nasa-pcoe-b0005/discharge/05122.csv");
    let r = read_record(&p, &RecordOptions::default()).unwrap();
    let rep = &r.report;
    assert_eq!(
        (
            rep.columns.time.as_str(),
            rep.columns.current.as_str(),
            rep.columns.voltage.as_str()
        ),
        ("Time", "Current_measured", "Voltage_measured")
    );
    assert_eq!(
        rep.columns.temperature.as_deref(),
        Some("Temperature_measured")
    );
    assert_eq!(rep.not_the_cell, ["Current_load", "Voltage_load"]);
    let line = rep.summary(&p);
    assert!(
        line.ends_with("; `Current_load`, `Voltage_load`: the load's, not the cell's (not read)"),
        "{line}"
    );
    assert_eq!(line.matches("Current_load").count(), 1, "{line}");
    // Discharge negative, as the data say: no sign warning.
    assert!(rep.sign_warning.is_none(), "{:?}", rep.sign_warning);
    // The charge counted over the record (each sample's current held for
    // its period) against NASA's `Capacity` of this discharge
    // (metadata.csv): 1.856 A·h.
    let rec = &r.record;
    let ah = -rec.current.iter().sum::<f64>() * rec.h / 3600.0;
    assert!(
        (ah / 1.856_487 - 1.0).abs() < 0.01,
        "counted {ah} A·h, period {} s",
        rec.h
    );
}
