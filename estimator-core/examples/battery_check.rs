//! Scratch check of the battery estimators on the presets (one seed).
use estimator_core::battery::output_error::OutputErrorRefinement;
use estimator_core::battery::profile::Profile;
use estimator_core::battery::regression::PaperRegressionGi;
use estimator_core::battery::simulate::simulate;
use estimator_core::battery::{BatterySettings, CellParameters};
use estimator_core::frac::GlWeights;
use estimator_core::window::SampleWindow;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

const L: usize = 1000;

fn run(name: &str, truth: CellParameters<f64>, amp: f64, sigma: f64, profile: Profile, mem: usize) {
    let mut w = GlWeights::<f64, L>::new(truth.alpha, 1.0, L).unwrap();
    let current: Vec<f64> = (0..L).map(|l| profile.current(l as f64, amp)).collect();
    let (mut up, mut v) = (vec![0.0; L], vec![0.0; L]);
    simulate(&truth, &mut w, &current, |_| truth.u_oc, &mut up, &mut v).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let nd = Normal::new(0.0, sigma).unwrap();
    let mut win = SampleWindow::<f64, L>::new();
    for l in 0..L {
        win.push(current[l], v[l] + nd.sample(&mut rng)).unwrap();
    }
    // Exact θ at the paper memory, for the bias check
    let s = BatterySettings::new(1.0, mem);
    let th =
        estimator_core::battery::regression::theta_from_cell::<f64, L>(&truth, 1.0, mem).unwrap();
    println!("{name}: true theta {th:?}");
    let mut gi = PaperRegressionGi::<f64, L, L>::new(&s, 0.5).unwrap();
    for k in 1..=2000 {
        let it = gi.iterate(&s, &win).unwrap();
        if [1, 10, 50, 200, 1000, 2000].contains(&k) || it.converged {
            let c = gi.cell();
            println!(
                "  GI k={k} alpha={:.4} cost={:.4e} theta={:?} delta={:?}",
                it.alpha,
                it.cost,
                gi.theta(),
                c.map(|c| c.delta(&truth))
            );
            if let Some(c) = c {
                println!("     cell {c:?}");
            }
        }
        if it.converged {
            break;
        }
    }
    for (lbl, st) in [
        ("truth", truth),
        (
            "perturbed",
            CellParameters {
                r_i: truth.r_i * 1.5,
                r_ct: truth.r_ct * 0.7,
                q: truth.q * 1.5,
                alpha: truth.alpha - 0.1,
                u_oc: truth.u_oc + 0.05,
            },
        ),
    ] {
        let so = BatterySettings::new(1.0, L);
        let mut oe = OutputErrorRefinement::<f64, L, L>::new(&so, st).unwrap();
        let mut last = None;
        for k in 1..=200 {
            let r = oe.iterate(&so, &win).unwrap();
            if k == 1 {
                println!("  OE from {lbl}: cost at start {:.6e}", r.cost);
            }
            last = Some((k, r));
            if r.converged {
                break;
            }
        }
        let (k, r) = last.unwrap();
        let c = oe.cell();
        println!(
            "    k={k} cost {:.6e} rel r_i {:.4} r_ct {:.4} q {:.4} dalpha {:.4} du {:.5}",
            r.cost,
            c.r_i / truth.r_i - 1.0,
            c.r_ct / truth.r_ct - 1.0,
            c.q / truth.q - 1.0,
            c.alpha - truth.alpha,
            c.u_oc - truth.u_oc
        );
    }
    let start = gi.cell().unwrap_or(CellParameters {
        r_i: truth.r_i * 2.0,
        r_ct: truth.r_ct * 0.5,
        q: truth.q * 0.5,
        alpha: 0.5,
        u_oc: truth.u_oc + 0.1,
    });
    let so = BatterySettings::new(1.0, L);
    let mut oe = OutputErrorRefinement::<f64, L, L>::new(&so, start).unwrap();
    for k in 1..=100 {
        let st = oe.iterate(&so, &win).unwrap();
        if st.converged || k == 100 {
            let c = oe.cell();
            println!(
                "  OE k={k} rmse={:.5} (sigma {sigma}) lambda={:.1e} {c:?}",
                st.rmse, st.lambda
            );
            println!(
                "     rel err r_i {:.4} r_ct {:.4} q {:.4} alpha {:.4} u_oc {:.5}",
                c.r_i / truth.r_i - 1.0,
                c.r_ct / truth.r_ct - 1.0,
                c.q / truth.q - 1.0,
                c.alpha - truth.alpha,
                c.u_oc - truth.u_oc
            );
            break;
        }
    }
}

fn main() {
    run(
        "paper",
        CellParameters::paper(),
        150.0,
        0.1,
        Profile::Pulse,
        256,
    );
    run(
        "paper s=0.01",
        CellParameters::paper(),
        150.0,
        0.01,
        Profile::Pulse,
        256,
    );
    run(
        "cell",
        CellParameters::cell_18650(),
        6.0,
        0.001,
        Profile::Pulse,
        256,
    );
    run(
        "cell hppc",
        CellParameters::cell_18650(),
        6.0,
        0.001,
        Profile::Hppc,
        256,
    );
    run(
        "cell drive",
        CellParameters::cell_18650(),
        6.0,
        0.001,
        Profile::Drive,
        256,
    );
}
