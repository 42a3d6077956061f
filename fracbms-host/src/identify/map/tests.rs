use super::levels::split;
use super::*;
use crate::identify::battery::model_voltage;
use crate::io::HostOcvTable;
use crate::map::MapMethod;
use crate::ocv::OcvSpec;
use estimator_core::battery::profile::ocv_nmc;
use estimator_core::battery::CellParameters;

const CAP: f64 = 2.5;

fn truth(level: usize) -> CellParameters<f64> {
    // R_i rises as the cell empties; R_ct and α move too.
    let x = level as f64;
    CellParameters {
        r_i: 0.020 + 0.004 * x,
        r_ct: 0.012 + 0.002 * x,
        q: 600.0,
        alpha: 0.70 + 0.02 * x,
        u_oc: 0.0,
        bv_a: 0.0,
        bv_i0: 1.0,
    }
}

fn spec(soc0: Option<f64>) -> OcvSpec {
    let z: Vec<f64> = (0..=50).map(|k| k as f64 / 50.0).collect();
    let v: Vec<f64> = z.iter().map(|&z| ocv_nmc::<f64>(z)).collect();
    OcvSpec::new(HostOcvTable::new(&z, &v).unwrap(), CAP, soc0).unwrap()
}

/// Uniform noise of standard deviation 0.5 mV from `seed` (a 64-bit
/// linear congruential generator).
fn noise_of(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.5e-3 * 12f64.sqrt()
    }
}

/// An HPPC-like record at 1 s: a 640 s rest, then per level 60 s of rest,
/// ±5 A pulses of 10 s, a 0.25 A·h discharge and a 640 s rest, each level
/// simulated from rest with its own cell; noise 0.5 mV.
fn hppc(levels: usize) -> BatteryRecord {
    let mut current = vec![0.0; 640];
    let mut voltage = vec![ocv_nmc::<f64>(0.95); 640];
    let mut z = 0.95;
    let mut noise = noise_of(12345);
    for v in &mut voltage {
        *v += noise();
    }
    for level in 0..levels {
        let mut i = vec![0.0; 60];
        for _ in 0..3 {
            i.extend([-5.0; 10]);
            i.extend([0.0; 40]);
            i.extend([5.0; 10]);
            i.extend([0.0; 40]);
        }
        i.extend([-2.5; 360]);
        i.extend([0.0; 640]);
        let cell = truth(level);
        let up = model_voltage(&cell, 1.0, &i).unwrap();
        for (k, &ik) in i.iter().enumerate() {
            z += ik / 3600.0 / CAP;
            current.push(ik);
            voltage.push(ocv_nmc::<f64>(z) + up[k] + noise());
        }
    }
    let n = current.len();
    BatteryRecord {
        time: (0..n).map(|k| k as f64).collect(),
        current,
        voltage,
        h: 1.0,
    }
}

#[test]
fn the_levels_are_the_parts_between_the_rests() {
    let rec = hppc(3);
    let c = spec(Some(0.95)).resolve(Path::new("r"), &rec).unwrap();
    let soc = counted_soc(&rec, &c, &[]);
    let l = levels(
        &rec,
        &soc,
        &MapOptions::default(),
        &vec![false; rec.time.len()],
    );
    assert_eq!(l.len(), 3, "{l:?}");
    // Level k: from 60 s before its pulses to the end of the rest after.
    let block = 60 + 300 + 360 + 640;
    for (k, p) in l.iter().enumerate() {
        assert_eq!(p.start, 640 + k * block, "{k}");
        assert_eq!(
            p.end,
            (640 + (k + 1) * block + 60).min(rec.time.len()),
            "{k}"
        );
        assert!((p.soc - (0.95 - 0.1 * k as f64)).abs() < 1e-9, "{}", p.soc);
    }
    let bins = levels(
        &rec,
        &soc,
        &MapOptions {
            soc_bins: Some(4),
            ..MapOptions::default()
        },
        &vec![false; rec.time.len()],
    );
    assert_eq!(bins.len(), 4);
    assert_eq!(
        bins.iter().map(|b| b.end - b.start).sum::<usize>(),
        rec.time.len()
    );
}

/// Each level's fit recovers its cell; the map model fits the whole record
/// closer than one fit of it; the CSV reads back.
#[test]
fn a_map_recovers_each_level_and_beats_one_fit() {
    // The estimators need the worker's stack.
    crate::worker::on_worker(|| {
        map_recovers_each_level_and_beats_one_fit();
        Ok::<_, crate::Error>(())
    })
    .unwrap();
}

fn map_recovers_each_level_and_beats_one_fit() {
    let rec = hppc(4);
    let limits = Limits::checked(None, None, None).unwrap();
    let refine = Refine {
        model: crate::identify::ModelRequest::Linear,
        ..Refine::default()
    };
    let s = spec(Some(0.95));
    let m = build_map(
        Path::new("r"),
        &rec,
        None,
        &limits,
        &s,
        BatteryMethod::Refined,
        50,
        refine,
        &MapOptions {
            method: MapMethod::Levels,
            ..MapOptions::default()
        },
        &[],
        None,
        &[],
    )
    .unwrap();
    assert!(m.skipped.is_empty(), "{:?}", m.skipped);
    assert_eq!(m.map.rows.len(), 4);
    for (k, r) in m.map.rows.iter().rev().enumerate() {
        let t = truth(k);
        assert!(
            (r.r_i / t.r_i - 1.0).abs() < 0.03,
            "{k}: r_i {} vs {}",
            r.r_i,
            t.r_i
        );
        assert!(
            (r.r_ct / t.r_ct - 1.0).abs() < 0.15,
            "{k}: r_ct {} vs {}",
            r.r_ct,
            t.r_ct
        );
        assert!(
            (r.alpha - t.alpha).abs() < 0.06,
            "{k}: alpha {} vs {}",
            r.alpha,
            t.alpha
        );
        assert!(r.rmse_v < 0.7e-3, "{k}: {}", r.rmse_v);
    }
    let (one, _) = battery_identify_screened(
        Path::new("r"),
        &rec,
        &[],
        &[],
        &limits,
        Some(&s),
        BatteryMethod::Refined,
        None,
        50,
        false,
        refine,
    )
    .unwrap();
    assert!(
        m.rmse_v < 0.8 * one.json.rmse_v,
        "map {} vs one fit {}",
        m.rmse_v,
        one.json.rmse_v
    );

    let p = std::env::temp_dir().join(format!("fracbms-map-{}.csv", std::process::id()));
    m.map.write_csv(&p).unwrap();
    let back = ParameterMap::read_csv(&p).unwrap();
    assert_eq!(back.rows.len(), 4);
    for (a, b) in back.rows.iter().zip(&m.map.rows) {
        assert_eq!(
            (a.soc, a.r_i, a.alpha, a.identifiable),
            (b.soc, b.r_i, b.alpha, b.identifiable)
        );
        assert_eq!(a.confidence, b.confidence);
    }
    // The cell between two levels is between their cells.
    let (lo, hi) = (&m.map.rows[1], &m.map.rows[2]);
    let mid = m.map.cell_at(0.5 * (lo.soc + hi.soc), None).unwrap();
    assert!((mid.r_i - 0.5 * (lo.r_i + hi.r_i)).abs() < 1e-12);
    let _ = std::fs::remove_file(&p);
}

/// A record that ends in a long rest after its last level's rest: the rest
/// alone has no excitation and is not a level (it was fitted to a runaway
/// R_ct before).
#[test]
fn a_rest_alone_is_not_a_level() {
    let mut rec = hppc(2);
    let n0 = rec.time.len();
    let last = *rec.voltage.last().unwrap();
    for k in 0..3000 {
        rec.time.push((n0 + k) as f64);
        rec.current.push(0.0);
        rec.voltage.push(last);
    }
    // A rest of 700 s, a 1-sample blip (above 1 % of the largest current:
    // not rest) and the 2300 s rest: split() makes a part of them, levels()
    // not (one sample under current).
    rec.current[n0 + 700] = 0.2;
    let c = spec(Some(0.95)).resolve(Path::new("r"), &rec).unwrap();
    let soc = counted_soc(&rec, &c, &[]);
    let gap = vec![false; rec.time.len()];
    let o = MapOptions::default();
    let all = split(&rec, &soc, &o, &gap);
    let kept = levels(&rec, &soc, &o, &gap);
    assert_eq!(all.len(), 3, "{all:?}");
    assert_eq!(kept.len(), 2, "{kept:?}");
    // The second level ends where its rest ends (at the blip); the part
    // after it holds the blip and the rest alone.
    assert_eq!(kept[1].end, n0 + 700, "{kept:?}");
    assert!(all[2].start >= n0 + 600, "{all:?}");
}

/// A row that is not identifiable is not used by the map model: with a
/// runaway row between two good ones the voltage is that of the two good
/// ones alone, and [`map_use`] counts it.
#[test]
fn the_map_model_leaves_out_rows_that_are_not_identifiable() {
    let rec = hppc(2);
    let c = spec(Some(0.95)).resolve(Path::new("r"), &rec).unwrap();
    let row = |soc: f64, cell: CellParameters<f64>, ok: bool| MapRow {
        temperature_c: None,
        soc,
        r_i: cell.r_i,
        r_ct: cell.r_ct,
        q: cell.q,
        alpha: cell.alpha,
        bv_a_v: None,
        bv_i0_a: None,
        ocv_offset_v: 0.0,
        rmse_v: 1e-3,
        identifiable: ok,
        identifiable_reason: (!ok).then(|| "R_ct at its bound".to_owned()),
        confidence: None,
        start_s: 0.0,
        end_s: 1.0,
        samples: 2,
    };
    let runaway = CellParameters {
        r_ct: 0.978,
        ..truth(0)
    };
    let good = ParameterMap {
        rows: vec![row(0.7, truth(1), true), row(0.95, truth(0), true)],
    };
    let mut with = good.clone();
    with.rows.insert(1, row(0.85, runaway, false));
    let a = map_voltage(&good, &rec, &c, None, &[]).unwrap();
    let b = map_voltage(&with, &rec, &c, None, &[]).unwrap();
    assert_eq!(a, b);
    let u = map_use(&with, None);
    assert_eq!((u.levels_used, u.left_out.len()), (2, 1));
    assert!(u.warnings()[0].contains("SOC 0.850"), "{:?}", u.warnings());
    // A map with no usable row is refused in one line.
    let none = ParameterMap {
        rows: vec![row(0.85, runaway, false)],
    };
    let e = map_voltage(&none, &rec, &c, None, &[]).unwrap_err();
    assert!(
        e.to_string()
            .contains("no level of the map is identifiable"),
        "{e}"
    );
}

/// Between two temperatures the map model's rows are the core's Arrhenius
/// cells; the activation energies of a map made with one energy per
/// parameter are that energy; beyond the temperatures the nearest is held.
#[test]
fn a_map_over_temperature_is_arrhenius() {
    use crate::map::GAS_CONSTANT;
    let (e_ri, e_rct, e_tau) = (22e3, 48e3, 31e3);
    let row = |t: f64, soc: f64| {
        let x = 1.0 / (t + 273.15) - 1.0 / 298.15;
        // R_ct and τ the same at every SOC, R_i linear in SOC: the map's
        // own interpolation in SOC is then exact.
        let r_ct = 0.015 * (e_rct / GAS_CONSTANT * x).exp();
        let tau = 40.0 * (e_tau / GAS_CONSTANT * x).exp();
        MapRow {
            temperature_c: Some(t),
            soc,
            r_i: 0.02 * (2.0 - soc) * (e_ri / GAS_CONSTANT * x).exp(),
            r_ct,
            q: tau / r_ct,
            alpha: 0.7,
            bv_a_v: None,
            bv_i0_a: None,
            ocv_offset_v: 0.001,
            rmse_v: 1e-3,
            identifiable: true,
            identifiable_reason: None,
            confidence: None,
            start_s: 0.0,
            end_s: 1.0,
            samples: 2,
        }
    };
    let mut map = ParameterMap {
        rows: vec![
            row(10.0, 0.2),
            row(10.0, 0.8),
            row(40.0, 0.2),
            row(40.0, 0.5),
            row(40.0, 0.8),
        ],
    };
    map.sort();
    let a = map.activation_energies().unwrap();
    for (got, want) in [
        (a.r_i_j_mol, e_ri),
        (a.r_ct_j_mol, e_rct),
        (a.tau_j_mol, e_tau),
    ] {
        assert!((got / want - 1.0).abs() < 1e-9, "{got} vs {want}");
    }
    assert_eq!(a.socs, 13);
    assert_eq!(a.temperatures_c, [10.0, 40.0]);
    let at25 = map.rows_at(Some(25.0));
    assert_eq!(
        at25.iter().map(|r| r.soc).collect::<Vec<_>>(),
        vec![0.2, 0.5, 0.8]
    );
    for r in &at25 {
        let want = map.cell_at(r.soc, Some(25.0)).unwrap();
        assert_eq!(r.cell(), want);
        let truth = row(25.0, r.soc);
        assert!((r.r_ct / truth.r_ct - 1.0).abs() < 1e-9, "{}", r.soc);
    }
    assert_eq!(map_use(&map, Some(25.0)).temperature_rule, "arrhenius");
    // Beyond: held, and said.
    assert_eq!(map.rows_at(Some(45.0)), map.rows_at(Some(40.0)));
    let u = map_use(&map, Some(45.0));
    assert_eq!(u.temperature_rule, "held");
    assert!(u
        .warnings()
        .iter()
        .any(|w| w.contains("outside the map's 10–40 °C")));
}

/// The joint fit over the whole record recovers each level's R_i at its
/// knot and fits to the noise; a knot beyond the data takes its
/// neighbours' values (never R_i = 0 nor a runaway); leaving a level out
/// predicts it; the choice by leaving levels out returns a scored
/// candidate.
#[test]
fn the_joint_fit_recovers_the_levels_and_holds_an_unseen_knot() {
    crate::worker::on_worker(|| {
        joint_fit_recovers_the_levels();
        Ok::<_, crate::Error>(())
    })
    .unwrap();
}

/// The joint fit's view of a made record: its OCV (start SOC 0.95), the
/// counted SOC before and after each sample's charge, every sample counted.
fn joint_view(rec: &BatteryRecord) -> (crate::ocv::CellOcv, Vec<f64>, Vec<f64>, Vec<bool>) {
    let c = spec(Some(0.95)).resolve(Path::new("r"), rec).unwrap();
    let before = counted_soc(rec, &c, &[]);
    let soc: Vec<f64> = before
        .iter()
        .zip(&rec.current)
        .map(|(z, i)| z + i / (3600.0 * CAP))
        .collect();
    let counted = vec![true; rec.time.len()];
    (c, before, soc, counted)
}

/// `k` start cells 30 % off the first level's cell everywhere.
fn off_start(k: usize) -> Vec<CellParameters<f64>> {
    (0..k)
        .map(|_| CellParameters {
            r_i: 0.03,
            r_ct: 0.02,
            q: 400.0,
            alpha: 0.8,
            ..truth(0)
        })
        .collect()
}

fn joint_fit_recovers_the_levels() {
    let rec = hppc(3);
    let (c, before, soc, counted) = joint_view(&rec);
    // Knots at the levels' SOCs (0.95, 0.85, 0.75) and one at 0.99 that
    // no sample reaches.
    let knots = [0.75, 0.85, 0.95, 0.99];
    let d = joint::JointData {
        record: &rec,
        soc: &soc,
        ocv: &c,
        counted: &counted,
        knots: &knots,
    };
    // A start 30 % off the truth everywhere.
    let start = off_start(4);
    let o = joint::JointOptions {
        smoothing: 1e-7,
        vary: [true; 5],
        iterations: 40,
    };
    let fit = joint::joint_fit(&d, &start, &o).unwrap();
    // The record switches its cell per level, the map model blends in SOC:
    // neither fits to the noise (0.5 mV). The joint fit fits it closer
    // than the map of the levels fitted one by one.
    let limits = Limits::checked(None, None, None).unwrap();
    let refine = Refine {
        model: crate::identify::ModelRequest::Linear,
        ..Refine::default()
    };
    let by_levels = build_map(
        Path::new("r"),
        &rec,
        None,
        &limits,
        &spec(Some(0.95)),
        BatteryMethod::Refined,
        50,
        refine,
        &MapOptions {
            method: MapMethod::Levels,
            ..MapOptions::default()
        },
        &[],
        None,
        &[],
    )
    .unwrap();
    assert!(
        fit.rmse_v < by_levels.rmse_v,
        "{} vs {}",
        fit.rmse_v,
        by_levels.rmse_v
    );
    for (j, level) in [(2usize, 0usize), (1, 1), (0, 2)] {
        let (got, want) = (fit.cells[j].r_i, truth(level).r_i);
        assert!((got / want - 1.0).abs() < 0.05, "knot {j}: {got} vs {want}");
    }
    let (r_lo, r_hi) = (fit.cells[1].r_i, fit.cells[2].r_i);
    let unseen = fit.cells[3].r_i;
    assert!(
        unseen > 0.5 * r_lo.min(r_hi) && unseen < 2.0 * r_lo.max(r_hi),
        "{unseen} against {r_lo}, {r_hi}"
    );
    // Leaving out nothing is no fold.
    assert!(fit.left_out(&vec![false; rec.time.len()]).is_none());
    let l = levels(
        &rec,
        &before,
        &MapOptions::default(),
        &vec![false; rec.time.len()],
    );
    assert_eq!(l.len(), 3);
    let folds: Vec<Vec<bool>> = l
        .iter()
        .map(|p| {
            (0..rec.time.len())
                .map(|k| k >= p.start && k < p.end)
                .collect()
        })
        .collect();
    let (best, tried) = joint::choose(
        &d,
        &start,
        &folds,
        &[1e-7, 1e-4],
        &[[true; 5], joint::VARY_SETS[2]],
        30,
    )
    .unwrap();
    assert_eq!(tried.len(), 4);
    // The chosen candidate is the one that predicts the levels left out
    // best; the weak penalty fits closer and predicts worse.
    assert!(tried.iter().all(|c| c.left_out_rmse_v.is_finite()));
    let chosen = tried
        .iter()
        .min_by(|a, b| a.left_out_rmse_v.total_cmp(&b.left_out_rmse_v))
        .unwrap();
    assert_eq!(best.rmse_v, chosen.rmse_v);
    let weak = &tried[1];
    assert_eq!((weak.smoothing, weak.vary), (1e-7, [true; 5]));
    assert!(weak.rmse_v < chosen.rmse_v && weak.left_out_rmse_v > chosen.left_out_rmse_v);
    // Each level left out is predicted closer than the map of the levels
    // fitted one by one fits it with the level in.
    for (p, f) in l.iter().zip(&folds) {
        let (r, m) = best.left_out(f).unwrap();
        assert!(
            m > 1000 && r < by_levels.rmse_v,
            "level at {}: {r} over {m}",
            p.soc
        );
    }
}

/// The long discharges of a record: stretches of one sign of current of
/// at least the given length.
#[test]
fn long_discharges_are_the_long_stretches_under_one_sign() {
    let rec = hppc(2);
    let long = joint::long_discharges(&rec, 300.0);
    // Each level's 360 s discharge, nothing else.
    assert_eq!(long.iter().filter(|x| **x).count(), 2 * 360);
    assert!(joint::long_discharges(&rec, 400.0).iter().all(|x| !x));
}

/// The pulses of one HPPC level parted by shorter rests are one level, and
/// one knot; levels further apart in SOC, or parted by a gap, are not.
#[test]
fn the_pulses_of_one_soc_are_one_level_and_one_knot() {
    let at = |start: usize, end: usize, soc: f64| Level { start, end, soc };
    // Five pulses 10 minutes apart spanning 0.021 of SOC (the Panasonic
    // test's at 0.97 with --min-rest 600), each level overlapping the
    // next by its lead; then the next level 0.08 lower.
    let socs = [0.9746, 0.9732, 0.9704, 0.9648, 0.9537, 0.8952, 0.8938];
    let parts: Vec<Level> = socs
        .iter()
        .enumerate()
        .map(|(k, &z)| at(100 * k, 100 * (k + 1) + 10, z))
        .collect();
    let merged = one_level_per_soc(parts.clone());
    assert_eq!(
        merged,
        vec![at(0, 510, 0.9746), at(500, 710, 0.8952)],
        "{merged:?}"
    );
    assert_eq!(level_runs(&parts), vec![vec![6, 5], vec![4, 3, 2, 1, 0]]);
    let knots = level_knots(&parts);
    assert_eq!(knots.len(), 2, "{knots:?}");
    assert!((knots[0] - 0.8945).abs() < 1e-12, "{knots:?}");
    assert!((knots[1] - socs[..5].iter().sum::<f64>() / 5.0).abs() < 1e-12);
    // A gap between two levels at one SOC keeps them apart (no level spans
    // a gap), though they make one knot.
    let apart = vec![at(0, 100, 0.5), at(150, 250, 0.49)];
    assert_eq!(one_level_per_soc(apart.clone()), apart);
    assert_eq!(level_knots(&apart).len(), 1);
}

/// With the Butler–Volmer term (`--model butler-volmer`) the knots share
/// one term `(a, i₀)`, fitted with them: on a record of three pulse
/// currents (2.5, 5 and 10 A) made with the term, the joint fit recovers
/// it and fits to the noise, where the linear joint fit of the same record
/// cannot; the map built with the levels fitted with the term (`--model
/// butler-volmer`) writes it in every row, within 10 %.
#[test]
fn the_joint_fit_shares_one_butler_volmer_term() {
    crate::worker::on_worker(|| {
        joint_fit_shares_one_butler_volmer_term();
        Ok::<_, crate::Error>(())
    })
    .unwrap();
}

fn joint_fit_shares_one_butler_volmer_term() {
    let (a, i0) = (0.02, 3.0);
    // One cell throughout (a cell switched per level is not a map model's
    // blend in SOC: neither model would fit to the noise).
    let cell = |_level: usize| CellParameters {
        bv_a: a,
        bv_i0: i0,
        ..truth(1)
    };
    let mut noise = noise_of(777);
    let (mut current, mut voltage, mut z) = (vec![0.0; 600], vec![], 0.95);
    voltage.extend((0..600).map(|_| ocv_nmc::<f64>(z)));
    for level in 0..3 {
        let mut i = vec![0.0; 60];
        for amp in [-10.0, 5.0, -5.0] {
            i.extend([amp; 10]);
            i.extend([0.0; 50]);
        }
        i.extend([-2.5; 360]);
        i.extend([0.0; 600]);
        let up = model_voltage(&cell(level), 1.0, &i).unwrap();
        for (k, &ik) in i.iter().enumerate() {
            z += ik / 3600.0 / CAP;
            current.push(ik);
            voltage.push(ocv_nmc::<f64>(z) + up[k]);
        }
    }
    for v in &mut voltage {
        *v += noise();
    }
    let n = current.len();
    let rec = BatteryRecord {
        time: (0..n).map(|k| k as f64).collect(),
        current,
        voltage,
        h: 1.0,
    };
    let (c, _, soc, counted) = joint_view(&rec);
    let knots = [0.75, 0.85, 0.95];
    let d = joint::JointData {
        record: &rec,
        soc: &soc,
        ocv: &c,
        counted: &counted,
        knots: &knots,
    };
    // Every knot started linear-like (then half its R_i as the term, i₀
    // 1 A).
    let linear = off_start(3);
    let start: Vec<CellParameters<f64>> =
        linear.iter().map(|c| c.with_butler_volmer(1.0)).collect();
    let o = joint::JointOptions {
        smoothing: 1e-7,
        vary: [true; 5],
        iterations: 60,
    };
    let fit = joint::joint_fit(&d, &start, &o).unwrap();
    let without = joint::joint_fit(&d, &linear, &o).unwrap();
    let c0 = fit.cells[0];
    assert!(fit
        .cells
        .iter()
        .all(|c| (c.bv_a, c.bv_i0) == (c0.bv_a, c0.bv_i0)));
    assert!((c0.bv_a / a - 1.0).abs() < 0.05, "a {}", c0.bv_a);
    assert!((c0.bv_i0 / i0 - 1.0).abs() < 0.05, "i0 {}", c0.bv_i0);
    assert!(fit.rmse_v < 0.55e-3, "{}", fit.rmse_v);
    assert!(
        without.rmse_v > 2.0 * fit.rmse_v,
        "{} vs {}",
        without.rmse_v,
        fit.rmse_v
    );
    assert!(without.cells.iter().all(|c| !c.is_butler_volmer()));
    // The shared term's 95 % intervals, the same at every knot, hold the
    // term the record was made with; the linear fit has none.
    let term = |c: &Option<crate::trust::Confidence>| c.as_ref().map(|c| (c.bv_a, c.bv_i0));
    let (ca, ci) = term(&fit.confidence[0]).unwrap();
    let (ca, ci) = (ca.unwrap(), ci.unwrap());
    assert!(ca[0] < a && a < ca[1], "a {a} in {ca:?}");
    assert!(ci[0] < i0 && i0 < ci[1], "i0 {i0} in {ci:?}");
    assert!(ca[1] / ca[0] < 1.5 && ci[1] / ci[0] < 1.5, "{ca:?} {ci:?}");
    assert!(fit
        .confidence
        .iter()
        .all(|c| term(c) == Some((Some(ca), Some(ci)))));
    assert!(without
        .confidence
        .iter()
        .all(|c| term(c) == Some((None, None))));
    let inputs = joint::JointInputs::of(&d, &fit);
    assert_eq!(inputs.butler_volmer, Some([c0.bv_a, c0.bv_i0]));
    // The map of the record with the levels fitted with the term: every
    // knot's row carries the one shared term; with the linear levels, none.
    for (model, with_term) in [
        (crate::identify::ModelRequest::ButlerVolmer, true),
        (crate::identify::ModelRequest::Linear, false),
    ] {
        let m = build_map(
            Path::new("r"),
            &rec,
            None,
            &Limits::checked(None, None, None).unwrap(),
            &spec(Some(0.95)),
            BatteryMethod::Refined,
            50,
            Refine {
                model,
                ..Refine::default()
            },
            &MapOptions::default(),
            &[],
            None,
            &[],
        )
        .unwrap();
        let rows = &m.map.rows;
        assert!(rows.len() >= 3, "{}", rows.len());
        let term = (rows[0].bv_a_v, rows[0].bv_i0_a);
        assert!(rows.iter().all(|r| (r.bv_a_v, r.bv_i0_a) == term));
        assert_eq!(term.0.is_some(), with_term, "{model:?}");
        if let (Some(a_map), Some(i0_map)) = term {
            assert!((a_map / a - 1.0).abs() < 0.1, "a {a_map}");
            assert!((i0_map / i0 - 1.0).abs() < 0.1, "i0 {i0_map}");
        }
        // Every row's intervals carry the term's exactly when it has one,
        // and the CSV gives them back.
        for r in rows {
            let c = r.confidence.as_ref().unwrap();
            assert_eq!(c.bv_a.is_some(), with_term, "{model:?} {c:?}");
            assert_eq!(c.bv_i0.is_some(), with_term, "{model:?} {c:?}");
        }
        let csv = std::env::temp_dir().join(format!(
            "fracbms-bv-map-{}-{with_term}.csv",
            std::process::id()
        ));
        m.map.write_csv(&csv).unwrap();
        let back = crate::map::ParameterMap::read_csv(&csv).unwrap();
        let _ = std::fs::remove_file(&csv);
        assert_eq!(back.rows.len(), rows.len());
        for (x, y) in back.rows.iter().zip(rows) {
            let (cx, cy) = (
                x.confidence.as_ref().unwrap(),
                y.confidence.as_ref().unwrap(),
            );
            assert_eq!(
                (cx.bv_a.is_some(), cx.bv_i0.is_some()),
                (with_term, with_term)
            );
            for (u, v) in [(cx.bv_a, cy.bv_a), (cx.bv_i0, cy.bv_i0)] {
                if let (Some(u), Some(v)) = (u, v) {
                    assert!((u[0] / v[0] - 1.0).abs() < 1e-12 && (u[1] / v[1] - 1.0).abs() < 1e-12);
                }
            }
        }
    }
}
