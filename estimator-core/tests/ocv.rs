//! Real cells: the OCV curve and coulomb-counted state of charge in the
//! sliding-window estimator, and the plausibility guard.

mod common;
use common::{nmc_table, pulse_record};

use estimator_core::battery::ocv::OcvModel;
use estimator_core::battery::online::{CellEstimator, OnlineSettings, Status};
use estimator_core::battery::CellParameters;

use common::CAPACITY_AH;

fn percentile(mut x: Vec<f64>, q: f64) -> f64 {
    x.sort_by(|a, b| a.partial_cmp(b).unwrap());
    x[((x.len() - 1) as f64 * q).round() as usize]
}

struct Errors {
    r_i: Vec<f64>,
    r_ct: Vec<f64>,
    alpha: Vec<f64>,
    soc: Vec<f64>,
    /// The same of what is published (issue 35), and the samples that
    /// carry a published R_i and R_ct.
    published: [Vec<f64>; 3],
    samples: usize,
}

impl Errors {
    /// 95th percentiles of the R_i, R_ct and α errors, and the largest
    /// R_ct error.
    fn summary(&self) -> [f64; 4] {
        [
            percentile(self.r_i.clone(), 0.95),
            percentile(self.r_ct.clone(), 0.95),
            percentile(self.alpha.clone(), 0.95),
            percentile(self.r_ct.clone(), 1.0),
        ]
    }
}

/// Runs the estimator (window 256, memory 64) over the record and collects
/// the errors of every published estimate after `warm` samples.
fn track<const P: usize>(
    s: &OnlineSettings<f64, P>,
    i: &[f64],
    v: &[f64],
    soc: &[f64],
    warm: usize,
) -> (Errors, Vec<Status>) {
    let truth = CellParameters::<f64>::cell_18650();
    let mut est = Box::new(CellEstimator::<f64, 256, 64>::new(s).unwrap());
    let mut e = Errors {
        r_i: vec![],
        r_ct: vec![],
        alpha: vec![],
        soc: vec![],
        published: [vec![], vec![], vec![]],
        samples: 0,
    };
    let mut statuses = vec![];
    for l in 0..i.len() {
        let r = est.push(s, i[l], v[l]);
        statuses.push(r.status);
        if l >= warm {
            let p = est.estimate().unwrap();
            e.r_i.push((p.r_i / truth.r_i - 1.0).abs());
            e.r_ct.push((p.r_ct / truth.r_ct - 1.0).abs());
            e.alpha.push((p.alpha - truth.alpha).abs());
            if let Some(z) = est.state_of_charge() {
                e.soc.push((z - soc[l]).abs());
            }
            let pb = est.published();
            e.samples += 1;
            if let Some(x) = pb.r_i.value {
                e.published[0].push((x / truth.r_i - 1.0).abs());
            }
            if let Some(x) = pb.r_ct.value {
                e.published[1].push((x / truth.r_ct - 1.0).abs());
            }
            if let Some(x) = pb.alpha.value {
                e.published[2].push((x - truth.alpha).abs());
            }
        }
    }
    (e, statuses)
}

/// The acceptance test: SOC 0.9 → 0.4 through the NMC curve, pulse
/// profile, window 256, memory 64: 95th-percentile errors R_i ≤ 3 %,
/// R_ct ≤ 10 %, α ≤ 0.05 and no R_ct error above 30 % after the first
/// window.
#[test]
fn sliding_window_with_the_ocv_table_tracks_a_discharging_cell() {
    let (i, v, soc) = pulse_record(1);
    let truth = CellParameters::<f64>::cell_18650();
    let s = OnlineSettings::new(1.0, 64, truth)
        .with_ocv(OcvModel::new(nmc_table(), CAPACITY_AH).unwrap());
    let (e, st) = track(&s, &i, &v, &soc, 512);
    let [ri, rct, a, rct_max] = e.summary();
    let soc_max = percentile(e.soc.clone(), 1.0);
    let held = st[512..].iter().filter(|s| **s != Status::Tracking).count();
    println!(
        "with table: p95 R_i {ri:.4} R_ct {rct:.4} alpha {a:.4}; max R_ct {rct_max:.4}; \
         SOC error at most {soc_max:.2e}; {held} samples not tracking"
    );
    assert!(ri <= 0.03 && rct <= 0.10 && a <= 0.05, "{ri} {rct} {a}");
    // What is published without a prior (issue 35): as good, on nearly
    // every sample.
    let [pri, prct, pa] = e.published.clone().map(|x| percentile(x, 0.95));
    let share = e
        .published
        .clone()
        .map(|x| x.len() as f64 / e.samples as f64);
    println!(
        "published: p95 R_i {pri:.4} R_ct {prct:.4} alpha {pa:.4}; on {:.1} %, {:.1} %, {:.1} % of the samples",
        100.0 * share[0],
        100.0 * share[1],
        100.0 * share[2]
    );
    // Measured: the same p95 as the window's (0.70 %, 4.38 %, 0.022), on
    // every sample after the first window.
    assert!(
        pri <= 0.03 && prct <= 0.10 && pa <= 0.05,
        "{pri} {prct} {pa}"
    );
    assert!(share.iter().all(|&x| x >= 0.99), "{share:?}");
    assert!(rct_max <= 0.30, "{rct_max}");
    // The SOC read from the rested start and counted: exact to the
    // inverse table's error.
    assert!(soc_max < 2e-3, "{soc_max}");
}

/// Without a table (the OCV slope fitted inside the window, as before) the
/// same record is harder; the plausibility guard must keep every published
/// R_ct within 3× of the truth (no runaway).
#[test]
fn without_a_table_no_runaway_is_published() {
    let (i, v, soc) = pulse_record(1);
    let truth = CellParameters::<f64>::cell_18650();
    let s = OnlineSettings::new(1.0, 64, truth);
    let (e, st) = track(&s, &i, &v, &soc, 512);
    let [ri, rct, a, rct_max] = e.summary();
    let held = st[512..].iter().filter(|s| s.is_implausible()).count();
    println!(
        "without table: p95 R_i {ri:.4} R_ct {rct:.4} alpha {a:.4}; max R_ct {rct_max:.4}; \
         {held} samples held as implausible"
    );
    assert!(rct_max < 2.0, "{rct_max}");
}

/// A lookup from any segment hint gives the binary search's value to the
/// bit, and the segment that holds the SOC (inside the table), along a
/// walk of SOCs that crosses segments both ways, the ends, outside and NaN.
#[test]
fn a_lookup_from_a_hint_is_the_lookup() {
    let t = nmc_table();
    let xs = t.soc_points();
    let mut socs: Vec<f64> = (0..=2000)
        .map(|k| -0.05 + 1.1 * k as f64 / 2000.0)
        .collect();
    socs.extend((0..=2000).rev().map(|k| 0.003 + 0.99 * k as f64 / 2000.0));
    socs.extend([0.0, 1.0, f64::NAN, 0.5]);
    let mut hint = 0;
    for &z in &socs {
        for h in [0, 7, 50, 99, 100, 1000, hint] {
            let (v, k) = t.ocv_from(z, h);
            assert_eq!(v.to_bits(), t.ocv(z).to_bits(), "soc {z}, hint {h}");
            if z > 0.0 && z < 1.0 {
                assert!(xs[k] <= z && z < xs[k + 1], "soc {z}: segment {k}");
            }
        }
        hint = t.ocv_from(z, hint).1;
    }
}
