//! Measured cycler data as they come (data/panasonic-18650pf, MAT-files):
//! the OCV from the test.

use super::*;

fn table(path: &Path) -> Vec<(f64, f64)> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let (a, b) = l.split_once(',').unwrap();
            (a.parse().unwrap(), b.parse().unwrap())
        })
        .collect()
}

fn at(t: &[(f64, f64)], z: f64) -> f64 {
    let j = t
        .iter()
        .rposition(|p| p.0 <= z)
        .unwrap_or(0)
        .min(t.len() - 2);
    let (a, b) = (t[j], t[j + 1]);
    a.1 + (z - a.0) / (b.0 - a.0) * (b.1 - a.1)
}

/// The C/20 test: the mean of the charge and discharge branches; the
/// capacity measured as the dataset states it (2.995 A·h out).
#[test]
fn panasonic_c20_gives_the_ocv_and_the_capacity() {
    let (out, json) = (tmp("pan-c20.csv"), tmp("pan-c20.json"));
    let o = run(&[
        "ocv",
        "--input",
        s(&data(
            "panasonic-18650pf/05-08-17_13.26 C20 OCV Test_C20_25dC.mat",
        )),
        "--from",
        "low-rate",
        "--out",
        s(&out),
        "--json",
        s(&json),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j = read_json(&json);
    let c = j["capacity_ah"].as_f64().unwrap();
    assert!((c - 2.995).abs() < 0.01, "{c}");
    assert_eq!(j["branches"].as_array().unwrap().len(), 2);
    let t = table(&out);
    assert!(t.len() > 80 && t.windows(2).all(|w| w[1].0 > w[0].0 && w[1].1 > w[0].1));
    // The range the two branches share (the charge has no CV phase: it
    // stops short of full).
    assert!(
        t[0].0 < 0.02 && t[t.len() - 1].0 > 0.85,
        "{:?}",
        (t[0], t[t.len() - 1])
    );
}

/// The 25 °C HPPC test's rests: the table passes within 2 mV of the rest
/// voltages at the rest points, but where points were pooled to keep it
/// increasing.
#[test]
fn panasonic_hppc_rests_give_the_ocv_within_2_mv() {
    let (out, json) = (tmp("pan-hppc.csv"), tmp("pan-hppc.json"));
    let o = run(&[
        "ocv",
        "--input",
        s(&data(
            "panasonic-18650pf/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat",
        )),
        "--min-rest",
        "1000",
        "--out",
        s(&out),
        "--json",
        s(&json),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j = read_json(&json);
    let t = table(&out);
    let rests = j["rests"].as_array().unwrap();
    let pooled = j["points_pooled"].as_u64().unwrap() as usize;
    let far = rests
        .iter()
        .filter(|r| {
            let (z, v) = (r["soc"].as_f64().unwrap(), r["voltage_v"].as_f64().unwrap());
            (at(&t, z) - v).abs() > 2e-3
        })
        .count();
    assert!(rests.len() > 50, "{}", rests.len());
    assert!(
        far <= pooled,
        "{far} rest points off by more than 2 mV, {pooled} pooled"
    );
}

/// The LG M50's OCV table from its 25 °C C/10 discharge (`ocv --from
/// low-rate`), written to `name` in the test folder.
fn lg_m50_ocv(name: &str) -> PathBuf {
    let ocv = tmp(name);
    succeeds(&[
        "ocv",
        "--input",
        s(&data("lg-m50/LGM50_5Ah_RateTest.mat")),
        "--table",
        "LGM50_5Ah_RateTest.T25.cRate_0p1C",
        "--columns",
        "time=timeVec,current=currVec,voltage=volVec",
        "--from",
        "low-rate",
        "--capacity-ah",
        "5",
        "--out",
        s(&ocv),
    ]);
    ocv
}

/// The LG M50 at 10 °C, SOC 0.2 (data/lg-m50, one 7.5 A pulse as the
/// Digatron logged it): the refinement, with its second rough start (most
/// of R into R_ct, α 0.9), fits it within 5 mV (1.4 mV today), and no row
/// is a spike now that the rows at step time 0 are read as the switch
/// (before, the row after each edge, 0 A under the loaded voltage, was).
#[test]
fn lg_m50_cold_pulse_needs_the_second_start() {
    let ocv = lg_m50_ocv("lg-ocv.csv");
    let json = tmp("lg-t10-soc2.json");
    let o = run(&[
        "identify",
        "battery",
        "--input",
        s(&data("lg-m50/LGM50_5Ah_Pulse.mat")),
        "--table",
        "LGM50_5Ah_Pulse.T10.SoC2.Cell13.data",
        "--columns",
        "temperature=LogTemp001",
        "--ocv",
        s(&ocv),
        "--capacity-ah",
        "5",
        "--soc0",
        "0.2",
        "--model",
        "linear",
        "--json",
        s(&json),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j = read_json(&json);
    let rmse = j["rmse_v"].as_f64().unwrap();
    assert!(rmse < 5e-3, "{j}");
    let rejected = j["rejected"].as_u64().unwrap();
    assert_eq!(rejected, 0, "{j}");
}

/// Runs host-sim with `args`; fails the test with its error unless it
/// succeeds.
fn succeeds(args: &[&str]) {
    let o = run(args);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// The state of power after the long rests of a measured cell (issue 36):
/// the Panasonic 25 °C HPPC test on its 2 s period, its OCV from the C/20
/// test, `pulse_v_10s` for a 5.8 A discharge, at every 5.8 A discharge
/// pulse after at least 600 s of rest (the SOC observer's `rest_s`), from
/// the last track row before the pulse, against the raw log 10 s into it,
/// at the pulses above SOC 0.2 (below, the map's levels are not
/// identifiable and the cell's resistance climbs within a level).
/// * With its own joint map as the prior (`identify battery --map-method
///   joint --map-out`: the best case of a characterized cell), every such
///   pulse is predicted from rest with the map's parameters (`sop_basis`
///   `map`), 90 % of them within 10 % of the pulse's drop, the issue's
///   bound (measured: all 9, 1.8–7.5 %). With the per-level map, one of
///   the 9 is 15.4 % off and this fails. Before the pulse from rest
///   nothing was published there: the last fit is further back than the
///   window reaches.
/// * Without a prior, every one predicted is within 10 % (1.2–5.5 %
///   today; 0.4–3.9 % before the restarted windows at rest). Before a window whose excitation had left its fitted rows was
///   no longer fitted, 7 of the 9 were off by 10.1–63.8 %: that last fit
///   of each pulse, of the relaxation alone, was held through the rest.
#[test]
fn panasonic_pulses_after_long_rests_are_predicted_from_rest() {
    let (hppc, ocv) = panasonic_hppc_and_ocv("pan-sop-ocv.csv");
    let map = tmp("pan-sop-map.csv");
    let cell = ["--ocv", s(&ocv), "--capacity-ah", "2.9"];
    let mut args = vec!["identify", "battery", "--input", s(&hppc)];
    args.extend_from_slice(&cell);
    args.extend_from_slice(&[
        "--min-rest",
        "3000",
        "--model",
        "linear",
        "--map-method",
        "joint",
        "--map-out",
        s(&map),
    ]);
    succeeds(&args);
    for prior in [Some(&map), None] {
        let (errors, unpublished) = pulses_from_rest(&hppc, &cell, prior, 5.8);
        // With the map every one is published; without a prior the test's
        // first 5.8 A pulse comes before the model is.
        if prior.is_some() {
            assert_eq!(unpublished, 0);
        }
        let checked = errors.len();
        let within = errors.iter().filter(|&&e| e <= 0.10).count();
        let worst = errors.iter().fold(0.0f64, |m, &e| m.max(e));
        eprintln!(
            "prior {}: {within} of {checked} within 10 %, worst {:.1} %, {unpublished} unpublished",
            prior.is_some(),
            100.0 * worst
        );
        assert!(checked >= 8, "{checked}");
        if prior.is_some() {
            assert!(
                10 * within >= 9 * checked,
                "{within} of {checked}, worst {worst}"
            );
        } else {
            assert!(unpublished <= 1, "{unpublished}");
            assert_eq!(within, checked, "worst {worst}");
        }
    }
}

/// Each level of the Panasonic HPPC test starts seconds after one of the
/// log's gaps (a 10 % discharge the export does not hold) with a 1.4 A
/// pulse, then rests 20 minutes before its 2.9 A pulse. The window
/// restarted at the gap begins at a rested cell and is fitted from rest
/// (`CellEstimator::resume_after_gap`), so the 1.4 A pulse is fitted and
/// the 2.9 A pulse is predicted from it: without a prior, of the 9 after
/// 600 s of rest above SOC 0.2, all but one within 10 % of the drop at
/// 10 s (measured 0.5–2.7 %; the last, at SOC 0.21, 19.8 %: there the
/// cell's resistance starts to climb within a level, from 35 mΩ at SOC
/// 0.21 to 52 mΩ at 0.11, docs/state-of-power-accuracy.md). Before, the 1.4 A pulse sat
/// in the restarted window's first 63 samples, never fitted, and the
/// 2.9 A pulse was predicted from the previous level's fit of its 17.4 A
/// pulse (the cell's resistance falls with the current): 7 of the 9 off
/// by 10.1–23.9 %, and this test fails.
#[test]
fn panasonic_pulses_after_a_gap_are_fitted_from_rest() {
    let (hppc, ocv) = panasonic_hppc_and_ocv("pan-gap-ocv.csv");
    let cell = ["--ocv", s(&ocv), "--capacity-ah", "2.9"];
    let (errors, unpublished) = pulses_from_rest(&hppc, &cell, None, 2.9);
    let worst = errors.iter().fold(0.0f64, |m, &e| m.max(e));
    eprintln!(
        "2.9 A: {} checked, worst {:.1} %, {unpublished} unpublished",
        errors.len(),
        100.0 * worst
    );
    let within = errors.iter().filter(|&&e| e <= 0.10).count();
    assert!(errors.len() >= 8, "{}", errors.len());
    assert!(within + 1 >= errors.len(), "{within} of {}", errors.len());
}

/// The Panasonic HPPC export leaves out the discharge to every level (13
/// gaps of 1 950–3 750 s), but its own charge count `Ah` runs on across
/// them. The reader gives each gap that charge (`Gap::charge_ah`) and the
/// estimator counts it through the gap (`CellEstimator::bridge_gap`), so
/// the rests on either side tell the capacity: started 10 % high (3.295
/// A·h against the 2.995 A·h the C/20 test measured) it ends within 3 %
/// (measured +2.0 %), identified. Before, the SOC was read again after
/// every gap and the capacity stayed at 3.295 A·h, not identified.
#[test]
fn panasonic_capacity_is_learned_across_the_gaps_from_the_exports_charge() {
    let (hppc, ocv) = panasonic_hppc_and_ocv("pan-cap-ocv.csv");
    let track = tmp("pan-cap-track.csv");
    succeeds(&[
        "online",
        "battery",
        "--input",
        s(&hppc),
        "--ocv",
        s(&ocv),
        "--capacity-ah",
        "3.295",
        "--out",
        s(&track),
    ]);
    let text = std::fs::read_to_string(&track).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let last: Vec<&str> = lines.last().unwrap().split(',').collect();
    let col = |name: &str| last[header.iter().position(|h| *h == name).unwrap()];
    let capacity: f64 = col("capacity_ah").parse().unwrap();
    let err = capacity / 2.995 - 1.0;
    eprintln!(
        "capacity at the end {capacity:.4} A·h: {:+.2} %",
        100.0 * err
    );
    assert!(err.abs() <= 0.03, "{err}");
    assert_eq!(col("capacity_status"), "identified");
}

/// The Panasonic 25 °C HPPC test and its OCV table from the C/20 test
/// (`host-sim ocv --from low-rate`, written to the test file `name`).
fn panasonic_hppc_and_ocv(name: &str) -> (PathBuf, PathBuf) {
    let d = data("panasonic-18650pf");
    let ocv = tmp(name);
    let c20 = d.join("05-08-17_13.26 C20 OCV Test_C20_25dC.mat");
    succeeds(&[
        "ocv",
        "--input",
        s(&c20),
        "--from",
        "low-rate",
        "--out",
        s(&ocv),
    ]);
    (
        d.join("03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat"),
        ocv,
    )
}

/// The errors of `pulse_v_10s` (a fraction of the measured drop) at every
/// discharge pulse of `current` A (magnitude) after at least 600 s of rest
/// in the log of the Panasonic HPPC test `hppc`, from the last track row of
/// `online battery` (2 s period, the `cell` arguments, `prior`) whose
/// period ends before the pulse, against the raw log 10 s into it, at the
/// pulses whose published SOC is at least 0.2 (below, the map's levels are
/// not identifiable and the cell's resistance climbs within a level); and
/// how many such pulses had nothing published before them.
fn pulses_from_rest(
    hppc: &Path,
    cell: &[&str],
    prior: Option<&PathBuf>,
    current: f64,
) -> (Vec<f64>, usize) {
    // The raw log: the pulses and the truth 10 s into each.
    let raw = fracbms_host::cycler::read_record(hppc, &Default::default())
        .unwrap()
        .rows;
    let (t, i, v) = (&raw.time, &raw.current, &raw.voltage);
    let at = |x: f64| {
        let k = t.partition_point(|&s| s <= x).clamp(1, t.len() - 1);
        let w = (x - t[k - 1]) / (t[k] - t[k - 1]);
        v[k - 1] + w * (v[k] - v[k - 1])
    };
    let track = tmp(&format!(
        "pan-sop-track-{current}-{}.csv",
        if prior.is_some() { "prior" } else { "no-prior" }
    ));
    let pulse = format!("{}", -current);
    let mut args = vec!["online", "battery", "--input", s(hppc), "--period", "2"];
    args.extend_from_slice(cell);
    if let Some(m) = prior {
        args.extend_from_slice(&["--prior", s(m)]);
    }
    args.extend_from_slice(&[
        "--horizons",
        "10",
        "--pulse-current-a",
        &pulse,
        "--out",
        s(&track),
    ]);
    succeeds(&args);
    let text = std::fs::read_to_string(&track).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (ct, cv, cs) = (col("time_s"), col("pulse_v_10s"), col("soc"));
    let rows: Vec<(f64, Option<f64>, f64)> = lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (
                f[ct].parse().unwrap(),
                f[cv].parse().ok(),
                f[cs].parse().unwrap_or(f64::NAN),
            )
        })
        .collect();
    let (mut errors, mut unpublished) = (Vec::new(), 0);
    for k in 1..t.len() {
        // A discharge edge from rest, the log continuous across it.
        if !(i[k - 1].abs() < 0.05 && (i[k] + current).abs() < 0.2 && t[k] - t[k - 1] < 0.2) {
            continue;
        }
        let start = t[k - 1];
        // At least 600 s of rest before it, without a gap in the log.
        let rest_from = start - 600.0;
        let j0 = t.partition_point(|&s| s < rest_from);
        let rested = j0 > 0
            && i[j0..k].iter().all(|x| x.abs() < 0.05)
            && t[j0..k].windows(2).all(|w| w[1] - w[0] < 5.0);
        if !rested {
            continue;
        }
        // The last track row whose 2 s period ends before the pulse.
        let r = rows.partition_point(|row| row.0 + 2.0 <= start) - 1;
        let (_, pulse_v, soc) = rows[r];
        let Some(pulse_v) = pulse_v else {
            unpublished += 1;
            continue;
        };
        if soc < 0.2 {
            continue;
        }
        let drop = at(start) - at(start + 10.0);
        let err = (pulse_v - at(start + 10.0)).abs() / drop;
        eprintln!(
            "{current} A, prior {}: pulse at {start:.0} s, SOC {soc:.3}: {:.1} % of {drop:.3} V",
            prior.is_some(),
            100.0 * err
        );
        errors.push(err);
    }
    (errors, unpublished)
}

/// The LG M50's nine one-pulse records at 25 °C (data/lg-m50, SOC 0.9 …
/// 0.1, each after a 600 s rest; the discharges between them were not
/// exported), joined into one record with `--table A,B,…`: the joint map
/// fits every knot together across the gaps (the SOC read again from the
/// rested voltage after each) with every knot identifiable, where each
/// pulse alone does not pin R_ct and Q; it fits the test in well under
/// half the single fit's RMSE and predicts the 1C rate test, a
/// constant-current cycle none of them saw, closer than the single fit
/// (docs/maps.md: 88.5 against 97.5 mV, the OCV table from the C/10
/// discharge).
#[test]
fn lg_m50_pulse_records_joined_give_a_map_that_predicts_the_rate_test() {
    let ocv = lg_m50_ocv("lg-joint-ocv.csv");
    let pulse = data("lg-m50/LGM50_5Ah_Pulse.mat");
    let rate = data("lg-m50/LGM50_5Ah_RateTest.mat");
    let tables: Vec<String> = (1..=9)
        .rev()
        .map(|k| format!("LGM50_5Ah_Pulse.T25.SoC{k}.Cell1.data"))
        .collect();
    let (map, fit) = (tmp("lg-joint-map.csv"), tmp("lg-joint-fit.json"));
    let o = run(&[
        "identify",
        "battery",
        "--input",
        s(&pulse),
        "--table",
        &tables.join(","),
        "--columns",
        "temperature=LogTemp001",
        "--ocv",
        s(&ocv),
        "--capacity-ah",
        "5",
        "--soc0",
        "0.9",
        "--model",
        "linear",
        "--temperature-c",
        "25",
        "--map-method",
        "joint",
        "--map-out",
        s(&map),
        "--json",
        s(&fit),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("9 MAT tables joined"), "{err}");
    assert!(
        err.contains("18 rows at step time 0 taken as the switch"),
        "{err}"
    );
    let j = read_json(&fit);
    let m = &j["map"];
    let levels = m["levels"].as_array().unwrap();
    assert_eq!(levels.len(), 9, "{m}");
    assert!(levels.iter().all(|r| r["identifiable"] == true), "{m}");
    // The knots span the SOC read again after each gap, 0.9 down past 0.2.
    let socs: Vec<f64> = levels.iter().map(|r| r["soc"].as_f64().unwrap()).collect();
    assert!(socs[0] < 0.2 && (socs[8] - 0.9).abs() < 1e-9, "{socs:?}");
    let (map_rmse, single) = (
        m["map_rmse_v"].as_f64().unwrap(),
        m["single_rmse_v"].as_f64().unwrap(),
    );
    assert!(map_rmse < 0.5 * single, "{map_rmse} {single}");
    let predicted = |model: &Path| {
        let out = tmp(&format!(
            "lg-joint-1c-{}.json",
            model.file_name().unwrap().to_string_lossy()
        ));
        succeeds(&[
            "predict",
            "battery",
            "--model",
            s(model),
            "--input",
            s(&rate),
            "--table",
            "LGM50_5Ah_RateTest.T25.cRate_1C",
            "--columns",
            "time=timeVec,current=currVec,voltage=volVec,temperature=cellTemp_mid",
            "--ocv",
            s(&ocv),
            "--capacity-ah",
            "5",
            "--soc0",
            "1",
            "--json",
            s(&out),
        ]);
        read_json(&out)["rmse_v"].as_f64().unwrap()
    };
    let (by_map, by_single) = (predicted(&map), predicted(&fit));
    assert!(by_map < by_single, "map {by_map} single fit {by_single}");
}

/// The whole-record refinement's line search (`BatterySettings::
/// line_search`) on the Panasonic HPPC test's overpotential, as
/// `identify battery --ocv` fitted it (`--fit-out`: the OCV taken away,
/// the samples fitted): the model cannot fit a measured cell exactly, and
/// near the minimum the damped Gauss–Newton step overshoots across the
/// valley, so the search zig-zags. With the line search the same start
/// ends at the same minimum (the cost to its tolerance, the parameters to
/// 0.1 %) in fewer iterations.
#[test]
fn panasonic_overpotential_is_fitted_in_fewer_iterations_with_the_line_search() {
    use estimator_core::battery::output_error::OutputErrorRefinement;
    use estimator_core::battery::BatterySettings;
    use fracbms_host::branch::FftBranch;
    use fracbms_host::identify::battery::{filled, rough_starts};
    use fracbms_host::identify::refine::{LoggedWindow, WHOLE_RECORD_COST_TOLERANCE};

    let (hppc, ocv) = panasonic_hppc_and_ocv("line-search-ocv.csv");
    let fit_out = tmp("line-search-fit.csv");
    succeeds(&[
        "identify",
        "battery",
        "--input",
        s(&hppc),
        "--ocv",
        s(&ocv),
        "--capacity-ah",
        "2.9",
        "--model",
        "linear",
        "--fit-out",
        s(&fit_out),
    ]);
    let mut rows = csv::Reader::from_path(&fit_out).unwrap();
    let head = rows.headers().unwrap().clone();
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    let (t, i, v, o, f) = (
        col("time_s"),
        col("current_a"),
        col("voltage_v"),
        col("ocv_v"),
        col("fitted"),
    );
    let (mut time, mut current, mut over) = (Vec::new(), Vec::new(), Vec::new());
    for r in rows.records() {
        let r = r.unwrap();
        let x = |k: usize| r[k].parse::<f64>().unwrap();
        time.push(x(t));
        current.push(x(i));
        over.push(if x(f) > 0.5 { x(v) - x(o) } else { f64::NAN });
    }
    let h = time[1] - time[0];
    const N: usize = 65_536;
    assert!(current.len() <= N);
    let start = rough_starts(&current, &filled(&over))[0];
    let win = LoggedWindow {
        current: &current,
        voltage: &over,
    };
    let fit = |line_search: bool| {
        let s = BatterySettings {
            cost_tolerance: WHOLE_RECORD_COST_TOLERANCE,
            line_search,
            ..BatterySettings::new(h, current.len())
        };
        let mut oe =
            Box::new(OutputErrorRefinement::<f64, N, N, FftBranch>::new(&s, start).unwrap());
        for k in 1..=100 {
            let st = oe.iterate(&s, &win).unwrap();
            if st.converged {
                return (k, st.rmse, oe.cell());
            }
        }
        panic!("line search {line_search}: not converged in 100 iterations");
    };
    // (The refinement of 65 536 rows is built on the worker's stack.)
    let run = |ls: bool| fracbms_host::worker::on_worker(|| Ok::<_, fracbms_host::Error>(fit(ls)));
    let (k_off, rmse_off, p_off) = run(false).unwrap();
    let (k_on, rmse_on, p_on) = run(true).unwrap();
    assert!(
        (rmse_on / rmse_off - 1.0).abs() < 1e-8,
        "RMSE {rmse_on:e} with it, {rmse_off:e} without"
    );
    for (a, b) in [
        (p_on.r_i, p_off.r_i),
        (p_on.r_ct, p_off.r_ct),
        (p_on.q, p_off.q),
        (p_on.alpha, p_off.alpha),
    ] {
        assert!((a / b - 1.0).abs() < 1e-3, "{a} with it, {b} without");
    }
    assert!(
        k_on < k_off,
        "{k_on} iterations with the line search, {k_off} without"
    );
}

/// A refit without the spikes a fit found never ends worse than that fit:
/// three pulses of the Panasonic 10 °C HPPC test near empty
/// (`data/panasonic-18650pf/excerpt-10degC-near-empty.csv`), fitted with
/// the Butler–Volmer term. Its first fit runs i₀ towards 0 (10.6 mV
/// RMSE), the spike test then takes the pulses' rows, and the refit from
/// that fit's linear model, `R_i + a/i₀` (about 3e24 Ω), ended at
/// R_i = 1.5e24 Ω and an RMSE of 7e22 V. Such a refit is not taken: the
/// first fit stands, with its rows.
#[test]
fn a_spike_refit_never_ends_worse_than_the_fit_it_corrects() {
    let (_, ocv) = panasonic_hppc_and_ocv("pan-excerpt-ocv.csv");
    let excerpt = data("panasonic-18650pf/excerpt-10degC-near-empty.csv");
    let json = tmp("pan-excerpt-bv.json");
    succeeds(&[
        "identify",
        "battery",
        "--input",
        s(&excerpt),
        "--columns",
        "time=time_s,current=current_a,voltage=voltage_v,charge=ah,temperature=none",
        "--period",
        "1",
        "--ocv",
        s(&ocv),
        "--capacity-ah",
        "2.9",
        "--soc0",
        "0.0958",
        "--model",
        "butler-volmer",
        "--json",
        s(&json),
    ]);
    let j = read_json(&json);
    let rmse = j["rmse_v"].as_f64().unwrap();
    let r_i = j["r_i"].as_f64().unwrap();
    eprintln!(
        "RMSE {:.2} mV, R_i {r_i:e} Ohm, {} rows rejected",
        1e3 * rmse,
        j["rejected"]
    );
    assert!(rmse < 0.02, "{j}");
    assert!(r_i < 1.0, "{j}");
}
