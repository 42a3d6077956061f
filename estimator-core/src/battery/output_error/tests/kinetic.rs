//! Tests of the kinetic voltages `η(I)` of the Butler–Volmer term: the
//! window's are the cell's, bit for bit, and a slid window keeps the ones
//! both windows hold ([`kept_after_slide`]).

use super::*;

#[test]
fn the_kinetic_voltages_of_a_window_are_the_cells() {
    // `fill_kinetic` writes the term out in its loop and skips the `asinh`
    // of a rested sample: every value must be `kinetic_voltage`'s, bit for
    // bit, zeros of either sign included.
    fn check<T: Real>() {
        let p = CellParameters::<T>::cell_18650().with_butler_volmer(T::lit(2.5));
        assert!(p.is_butler_volmer());
        let currents = [0.0, -0.0, 1e-9, -3e-4, 0.01, 2.5, -2.5, 7.0, -40.0, 5e3];
        let i: Vec<T> = currents.iter().map(|&x| T::lit(x)).collect();
        let mut eta = vec![T::nan(); i.len()];
        simulation::fill_kinetic(&p, &i, &mut eta, 0);
        for (&il, &e) in i.iter().zip(&eta) {
            let want = p.kinetic_voltage(il);
            assert_eq!(
                e.to_f64().to_bits(),
                want.to_f64().to_bits(),
                "I = {}",
                il.to_f64()
            );
        }
        // And the linear cell's zeros.
        let lin = CellParameters::<T>::cell_18650();
        simulation::fill_kinetic(&lin, &i, &mut eta, 0);
        assert!(eta.iter().all(|&e| e == T::zero()));
    }
    check::<f32>();
    check::<f64>();
}

/// The kinetic voltages a slid window keeps are the ones it would compute:
/// after every iteration `eta` is `η(I)` of the estimate at every loaded
/// sample, bit for bit, whether the window slid by one sample or several,
/// was restarted, or the estimate was set anew (another term, the window
/// slid by one); and a window slid by one
/// keeps all but its newest sample's (computes one `asinh`). The record
/// is the start's own simulation, so that most trials are rejected and
/// `eta` is then the estimate's simulation's, made with the kept values.
#[test]
fn the_kept_kinetic_voltages_are_the_windows() {
    const N: usize = 80;
    let truth = CellParameters::<f64>::cell_18650().with_butler_volmer(2.5);
    let len = 3 * N;
    let mut current: Vec<f64> = (0..len)
        .map(|l| 3.0 * (0.21 * l as f64).sin() + if (l / 15) % 2 == 0 { 2.0 } else { -2.0 })
        .collect();
    // Rested samples of either sign among them (their `η` is `a·I/i₀`).
    for l in (7..len).step_by(11) {
        current[l] = if l % 2 == 0 { 0.0 } else { -0.0 };
    }
    let (mut up, mut v) = (vec![0.0; len], vec![0.0; len]);
    let mut w = GlWeights::<f64, 24>::new(truth.alpha, 1.0, 24).unwrap();
    crate::battery::simulate::simulate(&truth, &mut w, &current, |_| truth.u_oc, &mut up, &mut v)
        .unwrap();
    let mut s = BatterySettings::new(1.0, 24);
    s.model = CellModel::ButlerVolmer;
    let mut oe = OutputErrorRefinement::<f64, N, 24>::new(&s, truth).unwrap();
    let mut win = SampleWindow::<f64, N>::new();
    let check = |oe: &OutputErrorRefinement<f64, N, 24>, at: usize| {
        let n = oe.n;
        let mut want = vec![f64::NAN; n];
        simulation::fill_kinetic(&oe.p, &oe.i[..n], &mut want, 0);
        for (l, (&e, &w)) in oe.sims[oe.est()].eta[..n].iter().zip(&want).enumerate() {
            assert_eq!(e.to_bits(), w.to_bits(), "sample {l} of the window at {at}");
        }
    };
    let (mut l, mut kept, mut rejected) = (0, 0, 0);
    while l < len {
        // One sample at a time, then three, then a restart.
        let step = if l < 2 * N { 1 } else { 3 };
        if l == 2 * N + 30 {
            win.clear();
            oe.set_cell(&s, truth).unwrap();
        }
        if l == 2 * N - 20 {
            // Another term on the same window slid by one: nothing kept.
            let other = CellParameters {
                bv_i0: 1.5,
                ..truth
            };
            oe.set_cell(&s, other).unwrap();
        }
        for k in l..(l + step).min(len) {
            win.push(current[k], v[k]).unwrap();
        }
        l += step;
        let before = oe.kinetic_kept;
        if let Ok(r) = oe.iterate(&s, &win) {
            check(&oe, l);
            if !r.accepted && step == 1 && win.has_slid() && before as usize == N {
                // Loaded again, all but the newest sample's kept, and the
                // estimate's simulation (not a trial's) left in `eta`.
                kept += 1;
            }
            rejected += usize::from(!r.accepted);
        }
    }
    assert!(
        kept > N / 4,
        "slid by one and kept: {kept} ({rejected} rejected)"
    );
}

/// [`kept_after_slide`]: the samples dropped, the ones kept, checked bit
/// for bit (a changed sample or an unknown count keeps none).
#[test]
fn a_slide_keeps_what_both_windows_hold() {
    let old = [1.0, 2.0, 3.0, 4.0, 5.0];
    assert_eq!(
        kept_after_slide(&old, &[2.0, 3.0, 4.0, 5.0, 6.0], Some(1), 5),
        (1, 4)
    );
    assert_eq!(
        kept_after_slide(&old, &[4.0, 5.0, 7.0, 8.0, 9.0], Some(3), 5),
        (3, 2)
    );
    // Only the first `valid` of the old window are known.
    assert_eq!(
        kept_after_slide(&old, &[2.0, 3.0, 4.0, 5.0, 6.0], Some(1), 3),
        (1, 2)
    );
    // A growing window drops nothing.
    assert_eq!(
        kept_after_slide(&old, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], Some(1), 5),
        (0, 5)
    );
    // Anything else: nothing kept.
    assert_eq!(
        kept_after_slide(&old, &[2.0, 3.0, 4.5, 5.0, 6.0], Some(1), 5),
        (0, 0)
    );
    assert_eq!(
        kept_after_slide(&old, &[2.0, -0.0, 4.0, 5.0, 6.0], Some(1), 5),
        (0, 0)
    );
    assert_eq!(
        kept_after_slide(&old, &[2.0, 3.0, 4.0, 5.0, 6.0], None, 5),
        (0, 0)
    );
    assert_eq!(kept_after_slide(&old, &[9.0; 5], Some(9), 5), (0, 0));
    assert_eq!(
        kept_after_slide(&old, &[2.0, 3.0, 4.0, 5.0, 6.0], Some(2), 5),
        (0, 0)
    );
    let zeros = [0.0, 0.0];
    assert_eq!(kept_after_slide(&zeros, &[0.0, 1.0], Some(1), 2), (1, 1));
    assert_eq!(kept_after_slide(&zeros, &[-0.0, 1.0], Some(1), 2), (0, 0));
}
