//! One HPPC-like test of a 30.5 A·h cell exported as Bitrode, Arbin and
//! Maccor write it: pulses at 0.5 s rows, discharges at 1 s rows, rests at
//! 60 s rows whose first row comes 60 s after the rest began (the step
//! time says so). The cell is a known equivalent circuit evaluated exactly
//! at the rows, so the charge and the SOC at every rest's end are known by
//! hand, step by step.

use fracbms_host::cycler::{read_record_from, CurrentSign, RecordOptions, StepsMode};
use fracbms_host::ocv_extraction::{extract_ocv, OcvExtraction, OcvExtractionOptions};
use std::path::Path;

const CAPACITY_AH: f64 = 30.5;
const R0: f64 = 1.5e-3;
const R1: f64 = 1.0e-3;
const TAU: f64 = 100.0;

fn ocv(z: f64) -> f64 {
    3.3 + 0.8 * z + 0.1 * (3.0 * z).sin()
}

/// A step of the schedule: its current (A, + charging), length (s), row
/// period (s) and the offset of its first row after its start (s).
struct Step {
    current: f64,
    length: f64,
    every: f64,
    first: f64,
}

/// One logged row: time, step index, step time, current, voltage, and the
/// true SOC and counted charge (A·h) at the row.
#[derive(Clone, Copy)]
struct Row {
    t: f64,
    step: usize,
    step_t: f64,
    i: f64,
    v: f64,
    /// The charge counted since the step's start (A·h, signed).
    step_q: f64,
    /// The charge counted since the test's start (A·h, signed).
    q: f64,
}

/// The schedule, the rows and, per rest, (its end time, SOC, voltage).
fn test() -> (Vec<Row>, Vec<(f64, f64, f64)>) {
    logged(true)
}

/// [`test`], each load's first row a period after its start
/// (`late_loads`) or 10 ms after it (as the Panasonic MAT-files log a
/// load: at once, the rest after it first logged a minute later).
fn logged(late_loads: bool) -> (Vec<Row>, Vec<(f64, f64, f64)>) {
    let first = |every: f64| if late_loads { every } else { 0.01 };
    let rest = |length: f64| Step {
        current: 0.0,
        length,
        every: 60.0,
        first: 60.0,
    };
    let mut steps = vec![rest(600.0)];
    for _ in 0..9 {
        steps.push(Step {
            current: -30.0,
            length: 30.0,
            every: 0.5,
            first: first(0.5),
        });
        steps.push(rest(600.0));
        steps.push(Step {
            current: -10.0,
            length: 1000.0,
            every: 1.0,
            first: first(1.0),
        });
        steps.push(rest(3600.0));
    }
    let mut rows = vec![];
    let mut rest_ends = vec![];
    let (mut t0, mut z, mut u1, mut q) = (0.0, 1.0, 0.0, 0.0);
    for (k, s) in steps.iter().enumerate() {
        let at = |dt: f64| {
            let e = (-dt / TAU).exp();
            let u = u1 * e + R1 * s.current * (1.0 - e);
            let zz = z + s.current * dt / 3600.0 / CAPACITY_AH;
            (zz, ocv(zz) + R0 * s.current + u, u)
        };
        // The test's first row is at its start; every other step's first
        // row comes `first` after it.
        let mut dt = if k == 0 { 0.0 } else { s.first };
        while dt <= s.length + 1e-9 {
            let (_, v, _) = at(dt);
            let sq = s.current * dt / 3600.0;
            rows.push(Row {
                t: t0 + dt,
                step: k + 1,
                step_t: dt,
                i: s.current,
                v,
                step_q: sq,
                q: q + sq,
            });
            dt += s.every;
        }
        let (zz, v, u) = at(s.length);
        if s.current == 0.0 {
            rest_ends.push((t0 + s.length, zz, v));
        }
        z = zz;
        u1 = u;
        q += s.current * s.length / 3600.0;
        t0 += s.length;
    }
    (rows, rest_ends)
}

fn bitrode(rows: &[Row]) -> String {
    let mut s =
        String::from("Test Time(s),Step,StepTime(s),Mode,Current(A),Voltage(V),Capacity(Ah)\n");
    for r in rows {
        let mode = if r.i < 0.0 { "DCHG" } else { "REST" };
        s += &format!(
            "{},{},{},{mode},{},{:.6},{:.6}\n",
            r.t, r.step, r.step_t, r.i, r.v, r.q
        );
    }
    s
}

fn arbin(rows: &[Row]) -> String {
    let mut s = String::from(
        "Data_Point,Test_Time(s),Step_Time(s),Step_Index,Current(A),Voltage(V),Charge_Capacity(Ah),Discharge_Capacity(Ah)\n",
    );
    for (k, r) in rows.iter().enumerate() {
        s += &format!(
            "{},{},{},{},{},{:.6},{:.6},{:.6}\n",
            k + 1,
            r.t,
            r.step_t,
            r.step,
            r.i,
            r.v,
            0.0,
            -r.q
        );
    }
    s
}

/// Maccor: `Amps` a magnitude with the direction in `State`, `Amp-hr`
/// the step's own count of magnitudes.
fn maccor(rows: &[Row]) -> String {
    let mut s = String::from("Rec#,Cyc#,Step,Test Time (sec),Step (Sec),Amp-hr,Amps,Volts,State\n");
    for (k, r) in rows.iter().enumerate() {
        let state = if r.i < 0.0 { "D" } else { "R" };
        s += &format!(
            "{},1,{},{},{},{:.6},{},{:.6},{state}\n",
            k + 1,
            r.step,
            r.t,
            r.step_t,
            r.step_q.abs(),
            r.i.abs(),
            r.v
        );
    }
    s
}

fn table(text: &str, o: &RecordOptions) -> (fracbms_host::cycler::CyclerRecord, OcvExtraction) {
    let r = read_record_from(text.as_bytes(), Path::new("hppc.csv"), o).unwrap();
    let x = extract_ocv(
        Path::new("hppc.csv"),
        &r.record,
        &OcvExtractionOptions {
            capacity_ah: Some(CAPACITY_AH),
            soc0: Some(1.0),
            ..OcvExtractionOptions::default()
        },
    )
    .unwrap();
    (r, x)
}

/// The SOC counted from the record at every rest's end is the
/// step-by-step count's, to 0.002.
fn assert_rest_socs(rec: &fracbms_host::io::BatteryRecord, ends: &[(f64, f64, f64)], name: &str) {
    for &(t_end, z, _) in ends {
        let k = rec.time.iter().position(|&t| t >= t_end - 1e-9).unwrap();
        let counted = 1.0 + rec.current[..k].iter().sum::<f64>() * rec.h / 3600.0 / CAPACITY_AH;
        assert!(
            (counted - z).abs() < 0.002,
            "{name}: SOC {counted} at {t_end} s, by hand {z}"
        );
    }
}

#[test]
fn late_logged_rests_are_counted_step_by_step_in_every_vendors_export() {
    let (rows, ends) = test();
    let o = RecordOptions {
        capacity_ah: Some(CAPACITY_AH),
        ..RecordOptions::default()
    };
    let mut tables = vec![];
    for (name, text) in [
        ("bitrode", bitrode(&rows)),
        ("arbin", arbin(&rows)),
        ("maccor", maccor(&rows)),
    ] {
        let (r, x) = table(&text, &o);
        let rec = &r.record;
        assert_eq!(rec.h, 1.0, "{name}");
        assert_rest_socs(rec, &ends, name);
        // 18 rests begin a minute before their first row: 60 samples each.
        assert_eq!(r.report.steps.unlogged.len(), 18 + 9 + 9, "{name}");
        assert_eq!(r.report.unobserved_samples, 18 * 60, "{name}");
        // Every rest's end is a point of the table, where it truly is.
        assert_eq!(x.rests.len(), ends.len(), "{name}");
        for (p, &(t_end, z, v)) in x.rests.iter().zip(&ends) {
            assert!(
                (p.end_s - t_end).abs() <= 1.0,
                "{name}: {} vs {t_end}",
                p.end_s
            );
            assert!((p.soc - z).abs() < 0.01, "{name}: SOC {} vs {z}", p.soc);
            assert!(
                (p.voltage_v - v).abs() < 3e-3,
                "{name}: {} V vs {v} V",
                p.voltage_v
            );
        }
        assert!(x.soc.iter().all(|z| (0.0..=1.0).contains(z)), "{name}");
        // The export's own count agrees with ours.
        let c = r.report.charge_check.as_ref().unwrap();
        assert!(c.max_gap_ah < 0.02, "{name}: {c:?}");
        assert!(
            (c.theirs_ah - rows.last().unwrap().q).abs() < 0.01,
            "{name}: {c:?}"
        );
        assert!(r.report.charge_warning.is_none(), "{name}");
        tables.push((name, x));
    }
    // Maccor's magnitudes were signed by its state column, unasked.
    let (r, _) = table(&maccor(&rows), &o);
    assert_eq!(r.report.current_sign, CurrentSign::FromState);
    assert!(r.report.state.as_ref().unwrap().signs_current);
    assert!(r
        .report
        .summary(Path::new("m"))
        .contains("from-state `State`"));
    // The three exports give one table.
    let (_, a) = &tables[0];
    for (name, b) in &tables[1..] {
        assert_eq!(a.soc.len(), b.soc.len(), "{name}");
        for k in 0..a.soc.len() {
            assert!((a.soc[k] - b.soc[k]).abs() < 1e-3, "{name}: {k}");
            assert!((a.ocv_v[k] - b.ocv_v[k]).abs() < 1e-3, "{name}: {k}");
        }
    }
}

#[test]
fn without_step_starts_the_charge_drifts_and_the_exports_count_says_so() {
    let (rows, ends) = test();
    let o = RecordOptions {
        capacity_ah: Some(CAPACITY_AH),
        steps: StepsMode::Ignore,
        ..RecordOptions::default()
    };
    let (r, x) = table(&bitrode(&rows), &o);
    let c = r.report.charge_check.as_ref().unwrap();
    // Each rest holds the load before it for its first minute: 9 × (0.5 +
    // 0.167) A·h too much discharge.
    assert!((c.ours_ah - c.theirs_ah + 6.0).abs() < 0.1, "{c:?}");
    let w = r.report.charge_warning.as_ref().unwrap();
    assert!(w.contains("`Capacity(Ah)`"), "{w}");
    assert!(r.report.summary(Path::new("b")).contains("--steps ignore"));
    let last = x.rests.last().unwrap();
    assert!((last.soc - ends.last().unwrap().1).abs() > 0.1);
}

#[test]
fn an_export_that_contradicts_itself_is_one_line() {
    let (rows, _) = test();
    let o = RecordOptions::default();
    let message = |text: &str| {
        read_record_from(text.as_bytes(), Path::new("x.csv"), &o)
            .unwrap_err()
            .to_string()
    };
    // A step time that goes back within a step.
    let text = bitrode(&rows[..200]).replacen(",2,1.5,DCHG", ",2,0.1,DCHG", 1);
    let m = message(&text);
    assert!(m.contains("the step time goes back within step 2"), "{m}");
    assert_eq!(m.lines().count(), 1);
    // A state no cycler here writes.
    let text = maccor(&rows[..200]).replacen(",D\n", ",Q\n", 1);
    let m = message(&text);
    assert!(m.contains("`Q` is not a state"), "{m}");
    // A magnitude current without a state column, the voltage falling
    // where it rises.
    let mut text = String::from("Test Time(s),Current(A),Voltage(V)\n");
    for r in &rows[..300] {
        text += &format!("{},{},{}\n", r.t, r.i.abs(), r.v);
    }
    let m = message(&text);
    assert!(
        m.contains("never negative") && m.contains("--current-sign"),
        "{m}"
    );
    // The state disagrees with a signed current at most rows: a warning.
    let text = bitrode(&rows).replace("DCHG", "CHRG");
    let r = read_record_from(text.as_bytes(), Path::new("x.csv"), &o).unwrap();
    let w = r.report.state_warning.unwrap();
    assert!(w.contains("disagree"), "{w}");
}

/// A whole-record fit of the Bitrode export with its own OCV table ends at
/// the SOC the step-by-step count ends at.
#[test]
fn a_whole_record_fit_ends_at_the_step_counts_soc() {
    use fracbms_host::identify::record::{battery_file, BatteryFitOptions};
    let (rows, ends) = test();
    let dir = std::env::temp_dir().join(format!("fracbms-steps-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let input = dir.join("bitrode.csv");
    std::fs::write(&input, bitrode(&rows)).unwrap();
    let table = dir.join("ocv.csv");
    let mut t = String::from("soc,ocv_v\n");
    for k in 0..=50 {
        let z = f64::from(k) / 50.0;
        t += &format!("{z},{}\n", ocv(z));
    }
    std::fs::write(&table, t).unwrap();
    let o = BatteryFitOptions {
        model: fracbms_host::identify::ModelRequest::Linear,
        ocv: fracbms_host::ocv::OcvOptions {
            ocv: Some(table),
            capacity_ah: Some(CAPACITY_AH),
            soc0: Some(1.0),
        },
        ..BatteryFitOptions::default()
    };
    // On a worker with the stack the CLI gives the fit.
    let f = fracbms_host::worker::on_worker(|| battery_file(&input, &o, false)).unwrap();
    let soc_end = f.result.json.soc_end.unwrap();
    let by_hand = ends.last().unwrap().1;
    assert!((soc_end - by_hand).abs() < 0.01, "{soc_end} vs {by_hand}");
    assert_eq!(f.report.unobserved_samples, 18 * 60);
    let r = f.result.json.record.as_ref().unwrap();
    assert_eq!(r.unobserved_samples, 18 * 60);
}

/// The same test as an export without step columns but with its own
/// charge count, logged as the Panasonic MAT-files are (a load's first row
/// at its start, a rest's a minute after it, `Ah`): where the rows around
/// a change of the current are further apart than the log's rhythm, the
/// count places the change, so each rest starts where the load stopped,
/// not at its first row a minute later.
#[test]
fn without_a_step_time_the_exports_count_places_the_step_starts() {
    let (rows, ends) = logged(false);
    let export = |count: bool| {
        let mut s = String::from(if count {
            "Time(s),Current(A),Voltage(V),Ah\n"
        } else {
            "Time(s),Current(A),Voltage(V)\n"
        });
        for r in &rows {
            s += &format!("{},{},{:.6}", r.t, r.i, r.v);
            s += &if count {
                format!(",{:.6}\n", r.q)
            } else {
                "\n".into()
            };
        }
        s
    };
    let o = RecordOptions {
        capacity_ah: Some(CAPACITY_AH),
        ..RecordOptions::default()
    };
    let (r, x) = table(&export(true), &o);
    let rec = &r.record;
    assert_eq!(rec.h, 1.0);
    let st = &r.report.steps;
    assert_eq!(st.starts_from, "charge");
    assert_eq!(st.charge_column.as_deref(), Some("Ah"));
    // The 18 rests, each first logged a minute after the load stopped:
    // its first 60 samples unobserved, or 59 where the count's rounding
    // (1 µA·h, about 0.1 ms of the load) puts the start just after a
    // sample.
    assert_eq!((st.changes, st.unlogged.len()), (18, 18));
    for u in &st.unlogged {
        let late = u.first_row_s - u.start_s;
        assert!((late - 60.0).abs() < 1e-3, "{u:?}");
    }
    assert!((18 * 59..=18 * 60).contains(&r.report.unobserved_samples));
    assert!(r
        .report
        .summary(Path::new("p"))
        .contains("the change placed by the export's charge `Ah`: 18 of 18"));
    assert_rest_socs(rec, &ends, "the count's placing");
    for (p, &(_, z, v)) in x.rests.iter().zip(&ends) {
        assert!((p.soc - z).abs() < 0.01, "SOC {} vs {z}", p.soc);
        assert!((p.voltage_v - v).abs() < 3e-3, "{} V vs {v} V", p.voltage_v);
    }
    let c = r.report.charge_check.as_ref().unwrap();
    assert!(c.max_gap_ah < 0.02, "{c:?}");
    assert!(r.report.charge_warning.is_none());
    // Each load's first row a period late (within the log's rhythm): the
    // default places the 18 rests alone, `--steps count` every change the
    // count dates, and the SOC is then the step-by-step count's as the
    // exports with a step time give it.
    let late = |steps| {
        let (rows, _) = test();
        let mut s = String::from("Time(s),Current(A),Voltage(V),Ah\n");
        for r in &rows {
            s += &format!("{},{},{:.6},{:.6}\n", r.t, r.i, r.v, r.q);
        }
        let o = RecordOptions {
            capacity_ah: Some(CAPACITY_AH),
            steps,
            ..RecordOptions::default()
        };
        table(&s, &o)
    };
    let (r, _) = late(StepsMode::Auto);
    assert_eq!(r.report.steps.unlogged.len(), 18);
    let (r, _) = late(StepsMode::Count);
    assert_eq!(r.report.steps.unlogged.len(), 36);
    assert!((18 * 59..=18 * 60).contains(&r.report.unobserved_samples));
    let (_, ends) = test();
    let rec = &r.record;
    assert_rest_socs(rec, &ends, "--steps count");
    // Without the count, each row's current is held to the next: every
    // rest holds the load before it for its first minute (6 A·h of
    // discharge too many), and the last rest lands 0.1 SOC off.
    let (r, x) = table(&export(false), &o);
    assert_eq!(r.report.steps.starts_from, "rows");
    assert!(r.report.steps.unlogged.is_empty());
    let drift = -r.record.current.iter().sum::<f64>() / 3600.0 + rows.last().unwrap().q;
    assert!((drift - 6.0).abs() < 0.1, "{drift}");
    let last = x.rests.last().unwrap();
    assert!((last.soc - ends.last().unwrap().1).abs() > 0.1);
}
