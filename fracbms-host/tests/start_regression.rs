//! The paper's regression as the start of a whole-record fit: on a record
//! longer than [`START_REGRESSION_ROWS`] it runs on the most excited
//! stretch only, and the fit still ends at the cell; from
//! [`PROJECTED_START_ROWS`] rows it is the projected regression.

use std::path::Path;

use estimator_core::battery::CellParameters;
use fracbms_host::identify::battery::{
    battery_run, model_voltage, most_excited, PROJECTED_START_ROWS, START_REGRESSION_ROWS,
};
use fracbms_host::identify::BatteryMethod;
use fracbms_host::io::BatteryRecord;
use fracbms_host::worker::on_worker;

/// Rest for `rest` rows, then 10-row pulses of ±`amp` A every 50 rows.
fn pulses(n: usize, rest: usize, amp: f64) -> Vec<f64> {
    (0..n)
        .map(|k| {
            if k < rest || (k - rest) % 50 >= 10 {
                0.0
            } else if ((k - rest) / 50).is_multiple_of(2) {
                -amp
            } else {
                amp
            }
        })
        .collect()
}

/// The made records' cell.
fn made_cell() -> CellParameters<f64> {
    CellParameters {
        r_i: 0.02,
        r_ct: 0.03,
        q: 400.0,
        alpha: 0.7,
        u_oc: 3.7,
        bv_a: 0.0,
        bv_i0: 1.0,
    }
}

/// `cell`'s voltage under `current`, one row a second.
fn made_record(cell: &CellParameters<f64>, current: Vec<f64>) -> BatteryRecord {
    let voltage = model_voltage(cell, 1.0, &current).unwrap();
    BatteryRecord {
        time: (0..current.len()).map(|k| k as f64).collect(),
        current,
        voltage,
        h: 1.0,
    }
}

#[test]
fn the_most_excited_stretch_is_where_the_pulses_are() {
    let i = pulses(20_000, 15_000, 2.0);
    let v = vec![3.6; i.len()];
    let r = most_excited(&i, &v, 4_000);
    assert_eq!(r.len(), 4_000);
    // Within one pulse period of the rest's end, holding as many pulse
    // rows as 4 000 rows can (80 pulses of 10).
    assert!(r.start >= 15_000 - 50, "{r:?}");
    assert_eq!(i[r].iter().filter(|x| **x != 0.0).count(), 800);
    // A record no longer than the stretch is taken whole.
    assert_eq!(most_excited(&i[..3_000], &v[..3_000], 4_000), 0..3_000);
    assert_eq!(most_excited(&i, &v, 0), 0..20_000);
}

#[test]
fn a_stretch_mostly_unobserved_is_passed_over() {
    // Pulses of 2 A throughout, of 3 A in rows 8 000..12 000, whose
    // voltages are all unobserved: the 3 A stretch varies the most but
    // says nothing.
    let mut i = pulses(20_000, 0, 2.0);
    let mut v = vec![3.6; i.len()];
    for k in 8_000..12_000 {
        i[k] *= 1.5;
        v[k] = f64::NAN;
    }
    let r = most_excited(&i, &v, 4_000);
    let unobserved = v[r.clone()].iter().filter(|x| x.is_nan()).count();
    assert!(unobserved * 10 <= r.len(), "{r:?}: {unobserved} unobserved");
    // With every voltage observed, the 3 A stretch is taken.
    let seen = vec![3.6; i.len()];
    let r = most_excited(&i, &seen, 4_000);
    assert!(r.start >= 8_000 - 50 && r.end <= 12_000 + 50, "{r:?}");
}

#[test]
fn a_long_record_is_fitted_to_its_cell_from_a_stretch_started_regression() {
    let cell = made_cell();
    let n = 2 * START_REGRESSION_ROWS + 4_000;
    let rec = made_record(&cell, pulses(n, n - 6_000, 3.0));
    let r = on_worker(|| {
        battery_run(
            Path::new("made"),
            &rec,
            BatteryMethod::Refined,
            None,
            50,
            false,
        )
    })
    .unwrap();
    let j = &r.json;
    for (name, got, want) in [
        ("R_i", j.r_i, cell.r_i),
        ("R_ct", j.r_ct, cell.r_ct),
        ("Q", j.q, cell.q),
        ("alpha", j.alpha, cell.alpha),
    ] {
        assert!(
            (got / want - 1.0).abs() < 1e-3,
            "{name}: {got} against {want}"
        );
    }
    assert!(j.rmse_v < 1e-6, "{}", j.rmse_v);
}

/// From [`PROJECTED_START_ROWS`] rows the refinement's start is the
/// projected regression, converged in a few iterations; below them, and
/// under the paper's method, 2S-OP-GI runs its iterations. Both starts
/// end at the same fit.
#[test]
fn the_start_is_projected_from_its_row_count() {
    let cell = made_cell();
    let run = |n: usize, method: BatteryMethod| {
        let rec = made_record(&cell, pulses(n, 100, 3.0));
        on_worker(|| battery_run(Path::new("made"), &rec, method, None, 50, false))
            .unwrap()
            .json
    };
    let long = run(PROJECTED_START_ROWS, BatteryMethod::Refined);
    let short = run(PROJECTED_START_ROWS - 1, BatteryMethod::Refined);
    let paper = run(PROJECTED_START_ROWS, BatteryMethod::Paper);
    assert!(
        long.history.len() < 20,
        "{} projected iterations",
        long.history.len()
    );
    assert_eq!(short.history.len(), 50);
    assert_eq!(paper.history.len(), 50);
    for j in [&long, &short] {
        assert!((j.r_ct / cell.r_ct - 1.0).abs() < 1e-3, "{}", j.r_ct);
        assert!(j.rmse_v < 1e-6, "{}", j.rmse_v);
    }
    // The projected start is nearer the regression's minimum: its last
    // cost is below 2S-OP-GI's after 50 iterations on the same rows.
    let last = |j: &fracbms_host::identify::battery::BatteryJson| j.history.last().unwrap().cost;
    assert!(
        last(&long) < last(&paper),
        "{} vs {}",
        last(&long),
        last(&paper)
    );
}
