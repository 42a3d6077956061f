//! Unobserved samples (NaN voltages): their currents drive the model, but
//! they are left out of the cost, the Jacobian and the rows.

use super::*;

/// A logged record as a window: NaN voltages pass (a `SampleWindow`
/// refuses them).
struct Logged {
    i: Vec<f64>,
    v: Vec<f64>,
}

impl Window<f64> for Logged {
    fn len(&self) -> usize {
        self.i.len()
    }
    fn version(&self) -> u32 {
        0
    }
    fn has_slid(&self) -> bool {
        false
    }
    fn recent(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.i.iter().copied().zip(self.v.iter().copied()).rev()
    }
    fn copy_into(&self, u: &mut [f64], y: &mut [f64]) -> usize {
        let n = self.i.len().min(u.len()).min(y.len());
        u[..n].copy_from_slice(&self.i[..n]);
        y[..n].copy_from_slice(&self.v[..n]);
        n
    }
}

/// Fits `win` from a start away from the 18650 cell until converged.
fn fit(
    win: &Logged,
) -> (
    CellParameters<f64>,
    RefinementStep<f64>,
    FitInformation<f64>,
) {
    const N: usize = 200;
    let s = BatterySettings::new(1.0, 24);
    let truth = CellParameters::<f64>::cell_18650();
    let start = CellParameters {
        r_ct: 1.5 * truth.r_ct,
        q: 0.7 * truth.q,
        alpha: truth.alpha - 0.05,
        ..truth
    };
    let mut oe = OutputErrorRefinement::<f64, N, 24>::new(&s, start).unwrap();
    let mut step = oe.iterate(&s, win).unwrap();
    for _ in 0..200 {
        if step.converged {
            break;
        }
        step = oe.iterate(&s, win).unwrap();
    }
    assert!(step.converged);
    let info = oe.information(&s, win).unwrap();
    (oe.cell(), step, info)
}

/// Noise-free voltages with a stretch of garbage (+0.5 V over 60 of 200
/// samples): marked unobserved, the fit recovers the cell and counts 140
/// rows; the same garbage left in as measured moves it far.
#[test]
fn unobserved_samples_are_left_out_of_the_fit() {
    let truth = CellParameters::<f64>::cell_18650();
    let (current, noisy) = noisy_record(200);
    // The same record without its noise (the noise is deterministic).
    let v: Vec<f64> = noisy
        .iter()
        .enumerate()
        .map(|(l, x)| {
            x - (3e-4 * (1.7 * l as f64).sin() * (0.37 * l as f64).cos() - 2e-6 * l as f64)
        })
        .collect();
    let gap = 60..120;
    let masked = Logged {
        i: current.clone(),
        v: v.iter()
            .enumerate()
            .map(|(l, &x)| if gap.contains(&l) { f64::NAN } else { x })
            .collect(),
    };
    let (p, step, info) = fit(&masked);
    for (got, want) in [(p.r_i, truth.r_i), (p.r_ct, truth.r_ct), (p.q, truth.q)] {
        assert!((got / want - 1.0).abs() < 1e-6, "{got} against {want}");
    }
    assert!((p.alpha - truth.alpha).abs() < 1e-6);
    assert_eq!(step.rows, 140);
    assert_eq!(info.rows, 140);
    assert!(step.rmse < 1e-6 && info.cost.is_finite());
    let garbage = Logged {
        i: current,
        v: v.iter()
            .enumerate()
            .map(|(l, &x)| if gap.contains(&l) { x + 0.5 } else { x })
            .collect(),
    };
    let (q, step, _) = fit(&garbage);
    assert_eq!(step.rows, 200);
    assert!((q.r_ct / truth.r_ct - 1.0).abs() > 1e-2, "{q:?}");
}
