//! Two single-seed checks quoted in the docs.
//!
//! `cargo run --release -p estimator-core --example single_seed_checks`
//!
//! 1. `docs/identification.md`: on seed 12 (L = 2000, σ = 0.1) the cost is
//!    lower at the estimated α than at the true α with the best linear
//!    parameters, and a run started from the latter returns to α̂.
//! 2. `docs/reproduction/README.md`: on the sign-flipped KT example (seed 100,
//!    σ = 0.5, M = L = 1000) KT-2S-GI meets the stopping rule at the same α̂
//!    from α̂₀ = 0.25 and from the true 0.3.

#[path = "../tests/common/mod.rs"]
mod common;

use common::*;
use estimator_core::gi::key_term::KeyTermGi;
use estimator_core::gi::over_param::OverParamGi;
use estimator_core::gi::GiSettings;
use estimator_core::model::{HammersteinSystem, Orders, Polynomial};
use estimator_core::window::SampleWindow;

fn main() {
    {
        const N: usize = 2048;
        const MEM: usize = 64;
        let d = generate::<MEM>(&system(), 2000, MEM, 0.1, 12);
        let mut s = GiSettings::new(Orders::PAPER, MEM);
        s.epsilon = 1e-11;
        let mut w = Box::new(SampleWindow::<f64, N>::new());
        for (&u, &y) in d.u.iter().zip(&d.y) {
            w.push(u, y).unwrap();
        }
        let mut free = Box::new(OverParamGi::<f64, N, MEM, 2, 3, 2, 2, 6>::new(&s, 0.4).unwrap());
        for _ in 0..20_000 {
            let it = free.iterate(&s, &Polynomial, &w).unwrap();
            if it.converged {
                println!(
                    "α estimated: k = {}, cost = {:.4}, α̂ = {:.4}",
                    it.k, it.cost, it.alpha
                );
                break;
            }
        }
        let mut fixed_s = s;
        fixed_s.estimate_order = false;
        let mut fixed =
            Box::new(OverParamGi::<f64, N, MEM, 2, 3, 2, 2, 6>::new(&fixed_s, 0.6).unwrap());
        for _ in 0..20_000 {
            let it = fixed.iterate(&fixed_s, &Polynomial, &w).unwrap();
            if it.converged {
                println!("α fixed at 0.6: k = {}, cost = {:.4}", it.k, it.cost);
                break;
            }
        }
        for _ in 0..20_000 {
            let it = fixed.iterate(&s, &Polynomial, &w).unwrap();
            if it.converged {
                println!(
                    "released from there: cost = {:.4}, α̂ = {:.4}",
                    it.cost, it.alpha
                );
                break;
            }
        }
    }
    {
        const L: usize = 1000;
        const MEM: usize = 1000;
        let kt = HammersteinSystem {
            a: &[-0.021, -0.007],
            b: &[1.0, -0.008, 0.023],
            c: &[-0.35, 0.61],
            gamma: &[-1.7, -0.04],
            alpha: 0.3,
        };
        let p0 = truth(&kt);
        let d = generate::<MEM>(&kt, L, MEM, 0.5, 100);
        println!(
            "KT example seed 100: δ_LS(true α) = {:.4}, δ_LS(α searched) = {:.4}",
            delta(&ls_reference::<MEM>(&kt, &d, MEM), &p0),
            delta(&ls_reference_unknown_order::<MEM>(&kt, &d, MEM), &p0)
        );
        let mut s = GiSettings::new(Orders::PAPER, MEM);
        s.epsilon = 1e-9;
        let mut w = Box::new(SampleWindow::<f64, L>::new());
        for (&u, &y) in d.u.iter().zip(&d.y) {
            w.push(u, y).unwrap();
        }
        for a0 in [0.25, 0.3] {
            let mut g = Box::new(KeyTermGi::<f64, L, MEM, 2, 3, 2, 2, 6>::new(&s, a0).unwrap());
            let mut p = [0.0; 11];
            for _ in 0..3000 {
                let it = g.iterate(&s, &Polynomial, &w).unwrap();
                if it.converged {
                    g.products().parameter_vector(&mut p);
                    println!(
                        "KT-2S-GI from α̂₀ = {a0}: converged at k = {}, α̂ = {:.4}, δ = {:.4}",
                        it.k,
                        it.alpha,
                        delta(&p, &p0)
                    );
                    break;
                }
            }
        }
    }
}
