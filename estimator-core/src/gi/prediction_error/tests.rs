//! Tests of the prediction-error refinement.

use super::*;
use crate::frac::GlWeights;
use crate::gi::Prehistory;
use crate::model::{HammersteinSystem, Orders, Polynomial};

const N: usize = 160;
const MEM: usize = 40;
type Pem = PaperPredictionError<f64, N, MEM>;

/// A record of eq. (4) with a deterministic pseudo-random input and
/// noise.
fn record(memory: usize) -> SampleWindow<f64, N> {
    let sys = HammersteinSystem {
        a: &[-0.3, 0.1],
        b: &[1.0, 0.4, -0.2],
        c: &[0.3, -0.2],
        gamma: &[0.8, 0.3],
        alpha: 0.6,
    };
    let mut seed = 12345u64;
    let mut rnd = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    };
    let u: [f64; N] = core::array::from_fn(|_| rnd());
    let v: [f64; N] = core::array::from_fn(|_| 0.1 * rnd());
    let (mut y, mut e) = ([0.0; N], [0.0; N]);
    let w = GlWeights::<f64, MEM>::new(sys.alpha, 1.0, memory).unwrap();
    sys.simulate(&Polynomial, &w, &u, &v, &mut y, &mut e)
        .unwrap();
    let mut win = SampleWindow::new();
    for (&u, &y) in u.iter().zip(&y) {
        win.push(u, y).unwrap();
    }
    win
}

/// An estimate away from the truth (so no column vanishes).
fn away() -> HammersteinEstimate<f64, 2, 3, 2, 2, 6> {
    HammersteinEstimate {
        orders: Orders::PAPER,
        a: [-0.2, 0.05],
        c: [0.25, -0.1],
        products: [0.7, 0.2, 0.35, 0.15, -0.1, -0.05],
        alpha: 0.55,
    }
}

/// The analytic Jacobian equals central differences of the criterion's
/// residual, with the sequences masked before the first row (unknown
/// prehistory) and without (from rest).
#[test]
fn jacobian_matches_central_differences() {
    for prehistory in [Prehistory::AtRest, Prehistory::Unknown] {
        let mut gi = GiSettings::new(Orders::PAPER, MEM);
        gi.prehistory = prehistory;
        let s = PredictionErrorSettings::new(gi);
        let win = record(MEM);
        let mut pem = Box::new(Pem::new(&s, &away()).unwrap());
        pem.phase = Phase::Descent;
        pem.linearize(&s, &Polynomial, &win, true).unwrap();
        let rows = pem.reg.rows();
        assert_eq!(rows.start == 0, prehistory == Prehistory::AtRest);
        let jac = pem.jac;
        let base = away();
        let residual_at = |pem: &mut Pem, k: usize, h: f64| -> [f64; N] {
            let mut e = base;
            let mut step = [0.0; 11];
            step[k] = h;
            apply_step(&mut e, &step, true);
            pem.reg.trial_cost(e.alpha, &params(&e)).unwrap();
            pem.reg.q
        };
        for (k, column) in jac.iter().enumerate() {
            let h = 1e-6;
            let plus = residual_at(&mut pem, k, h);
            let minus = residual_at(&mut pem, k, -h);
            let mut worst: f64 = 0.0;
            let mut size: f64 = 0.0;
            for l in rows.clone() {
                let fd = (plus[l] - minus[l]) / (2.0 * h);
                worst = worst.max((fd - column[l]).abs());
                size = size.max(fd.abs());
            }
            assert!(size > 1e-3, "column {k} vanishes");
            assert!(
                worst <= 1e-6 * size,
                "{prehistory:?} column {k}: |FD − analytic| {worst:e} of {size:e}"
            );
        }
    }
}

/// Each iteration lowers the criterion or reports no decrease, the
/// search visits the start and every grid order, then the descent
/// converges below the start's cost.
#[test]
fn search_then_descent_lowers_the_cost() {
    let s = PredictionErrorSettings::new(GiSettings::new(Orders::PAPER, MEM));
    let win = record(MEM);
    let mut pem = Box::new(Pem::new(&s, &away()).unwrap());
    let start_cost = pem.cost_at(&s, &Polynomial, &win, &away()).unwrap();
    let mut visited = [false; 27];
    let mut last = None;
    for _ in 0..800 {
        if let Phase::Search { start, linear } = pem.phase() {
            let l = LinearStart::ALL.iter().position(|&x| x == linear).unwrap();
            visited[3 * usize::from(start) + l] = true;
        }
        let before = pem.phase();
        let it = pem.iterate(&s, &Polynomial, &win).unwrap();
        assert_eq!(it.phase, before);
        if before == Phase::Descent {
            if let Some(prev) = last {
                assert!(it.cost <= prev, "{} > {prev}", it.cost);
            }
            last = Some(it.cost);
        }
        if it.converged {
            break;
        }
    }
    assert!(visited.iter().all(|&v| v), "{visited:?}");
    let won = pem.winning_start(&s).unwrap();
    let end = last.unwrap();
    assert!(
        end <= won.cost && end < start_cost,
        "{end} {won:?} {start_cost}"
    );
    assert!(
        (pem.estimate().alpha - 0.6).abs() < 0.1,
        "{}",
        pem.estimate().alpha
    );
}

/// Errors leave the estimate as it was; a wrong start is refused.
#[test]
fn errors_keep_the_estimate() {
    let s = PredictionErrorSettings::new(GiSettings::new(Orders::PAPER, MEM));
    let mut pem = Box::new(Pem::new(&s, &away()).unwrap());
    let mut short = SampleWindow::<f64, N>::new();
    for l in 0..5 {
        short.push(l as f64, 1.0).unwrap();
    }
    assert!(matches!(
        pem.iterate(&s, &Polynomial, &short),
        Err(Error::NotEnoughData { .. })
    ));
    assert_eq!(*pem.estimate(), away());
    let mut bad = away();
    bad.c[0] = f64::NAN;
    assert_eq!(pem.restart(&s, &bad).unwrap_err(), Error::BadSetting);
    assert_eq!(*pem.estimate(), away());
    let mut few = s;
    few.gi.orders.nb = 3;
    assert!(matches!(
        PredictionErrorRefinement::<f64, N, MEM, 2, 3, 2, 2, 6, 10>::new(&few, &away()),
        Err(Error::ParameterCapacity {
            needed: 11,
            capacity: 10
        })
    ));
}
