//! Both algorithms against the least-squares reference (true α, true noise e)
//! on data from eq. (4) in an identifiable setting, over 10 seeds.
//!
//! `cargo run --release -p estimator-core --example identifiable`
//! prints the Markdown table quoted in `docs/identification.md` (medians over
//! the seeds; the ratio columns are medians of the per-seed ratios).

#[path = "../tests/common/mod.rs"]
mod common;

use common::*;
use estimator_core::gi::key_term::KeyTermGi;
use estimator_core::gi::over_param::OverParamGi;
use estimator_core::gi::GiSettings;
use estimator_core::model::{HammersteinSystem, Orders, Polynomial};
use estimator_core::window::SampleWindow;

const N: usize = 2048;
const MEM: usize = 64;

fn run(sys: &HammersteinSystem<'_, f64>, d: &Data) -> (Vec<f64>, Vec<f64>, u32, u32) {
    let mut s = GiSettings::new(Orders::PAPER, MEM);
    s.epsilon = 1e-9;
    let mut w = Box::new(SampleWindow::<f64, N>::new());
    for (&u, &y) in d.u.iter().zip(&d.y) {
        w.push(u, y).unwrap();
    }
    let mut op = Box::new(OverParamGi::<f64, N, MEM, 2, 3, 2, 2, 6>::new(&s, 0.4).unwrap());
    let mut kt = Box::new(KeyTermGi::<f64, N, MEM, 2, 3, 2, 2, 6>::new(&s, 0.4).unwrap());
    let (mut k_op, mut k_kt) = (0, 0);
    for _ in 0..5000 {
        let it = op.iterate(&s, &Polynomial, &w).unwrap();
        k_op = it.k;
        if it.converged {
            break;
        }
    }
    for _ in 0..5000 {
        let it = kt.iterate(&s, &Polynomial, &w).unwrap();
        k_kt = it.k;
        if it.converged {
            break;
        }
    }
    let (mut p1, mut p2) = ([0.0; 11], [0.0; 11]);
    op.estimate().parameter_vector(&mut p1);
    kt.products().parameter_vector(&mut p2);
    let _ = sys;
    (p1.to_vec(), p2.to_vec(), k_op, k_kt)
}

/// Per seed: SNR, δ_LS(true α), δ_OP, δ_KT, k_OP, k_KT, δ_LS(α searched).
type Row = (f64, f64, f64, f64, f64, f64, f64);

fn main() {
    let white = system();
    let coloured = HammersteinSystem {
        c: &[-0.8, 0.3],
        ..system()
    };
    println!("| noise | L | σ | SNR | δ_LS true α | δ_LS α searched | δ_OP | δ_KT | δ_OP/δ_LS | δ_KT/δ_LS | max ratio OP / KT | k OP / KT |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let systems = [
        ("c = [0.3, −0.2]", &white),
        ("c = [−0.8, 0.3] (strongly coloured)", &coloured),
    ];
    let only_white = std::env::var_os("ONLY_WHITE").is_some();
    for (name, sys) in systems.into_iter().take(if only_white { 1 } else { 2 }) {
        let p0 = truth(sys);
        for &(len, sigma) in &[(500usize, 0.2), (1000, 0.2), (2000, 0.1), (2000, 0.3)] {
            let mut rows = Vec::new();
            for seed in 0..seeds() {
                let d = generate::<MEM>(sys, len, MEM, sigma, 1000 + seed);
                let snr = snr::<MEM>(sys, &d, MEM);
                let r = delta(&ls_reference::<MEM>(sys, &d, MEM), &p0);
                let r2 = delta(&ls_reference_unknown_order::<MEM>(sys, &d, MEM), &p0);
                let (p1, p2, k1, k2) = run(sys, &d);
                rows.push((
                    snr,
                    r,
                    delta(&p1, &p0),
                    delta(&p2, &p0),
                    k1 as f64,
                    k2 as f64,
                    r2,
                ));
            }
            let col = |f: &dyn Fn(&Row) -> f64| median(rows.iter().map(f).collect());
            let maxr = |f: &dyn Fn(&Row) -> f64| rows.iter().map(f).fold(0.0, f64::max);
            println!(
                "| {name} | {len} | {sigma} | {:.0} | {:.4} | {:.4} | {:.4} | {:.4} | {:.2} | {:.2} | {:.2} / {:.2} | {:.0} / {:.0} |",
                col(&|r| r.0), col(&|r| r.1), col(&|r| r.6), col(&|r| r.2), col(&|r| r.3),
                col(&|r| r.2 / r.1), col(&|r| r.3 / r.1),
                maxr(&|r| r.2 / r.1), maxr(&|r| r.3 / r.1),
                col(&|r| r.4), col(&|r| r.5)
            );
        }
    }
}

/// Number of seeds: the first argument, 10 by default.
fn seeds() -> u64 {
    std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(10)
}
