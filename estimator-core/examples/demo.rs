//! A one-minute tour: simulate eq. (4) in an identifiable setting, identify it
//! with 2S-OP-GI and KT-2S-GI, and print δ versus k and the estimates.
//!
//! `cargo run --release -p estimator-core --example demo`

#[path = "../tests/common/mod.rs"]
mod common;

use common::*;
use estimator_core::gi::key_term::KeyTermGi;
use estimator_core::gi::over_param::OverParamGi;
use estimator_core::gi::{GiSettings, Normalization};
use estimator_core::model::{Orders, Polynomial};
use estimator_core::window::SampleWindow;

const N: usize = 1000;
const MEM: usize = 64;

fn main() {
    let sys = system();
    let d = generate::<MEM>(&sys, N, MEM, 0.2, 1);
    let p0 = truth(&sys);
    println!(
        "Simulated eq. (4): L = {N}, M = {MEM}, σ = 0.2, SNR = {:.0}",
        snr::<MEM>(&sys, &d, MEM)
    );
    println!(
        "true a = {:?}, b = {:?}, c = {:?}, γ = {:?}, α = {}",
        sys.a, sys.b, sys.c, sys.gamma, sys.alpha
    );
    let mut s = GiSettings::new(Orders::PAPER, MEM);
    s.epsilon = 1e-9;
    let mut w = Box::new(SampleWindow::<f64, N>::new());
    for (&u, &y) in d.u.iter().zip(&d.y) {
        w.push(u, y).unwrap();
    }
    let mut op = Box::new(OverParamGi::<f64, N, MEM, 2, 3, 2, 2, 6>::new(&s, 0.4).unwrap());
    let mut kt = Box::new(KeyTermGi::<f64, N, MEM, 2, 3, 2, 2, 6>::new(&s, 0.4).unwrap());
    println!("\n|    k | δ 2S-OP-GI | α̂ 2S-OP-GI | δ KT-2S-GI | α̂ KT-2S-GI |");
    let mut p = [0.0; 11];
    let (mut done_op, mut done_kt) = (false, false);
    for k in 1..=5000u32 {
        if !done_op {
            done_op = op.iterate(&s, &Polynomial, &w).unwrap().converged;
        }
        if !done_kt {
            done_kt = kt.iterate(&s, &Polynomial, &w).unwrap().converged;
        }
        if k == 1 || k % 200 == 0 || (done_op && done_kt) {
            op.estimate().parameter_vector(&mut p);
            let d_op = delta(&p, &p0);
            kt.products().parameter_vector(&mut p);
            let d_kt = delta(&p, &p0);
            println!(
                "| {k:4} | {d_op:10.5} | {:11.5} | {d_kt:10.5} | {:11.5} |",
                op.estimate().alpha,
                kt.estimate().alpha
            );
        }
        if done_op && done_kt {
            break;
        }
    }
    let e = op.estimate();
    let (b, g) = e.factor(Normalization::UnitB1).unwrap();
    println!("\n2S-OP-GI ({} iterations): a = {:.4?}, c = {:.4?}, b = {:.4?}, γ = {:.4?} (b₁ = 1), α = {:.4}",
        op.iterations(), e.a, e.c, b, g, e.alpha);
    let k = kt.estimate();
    println!(
        "KT-2S-GI ({} iterations): a = {:.4?}, c = {:.4?}, b = {:.4?}, γ = {:.4?}, α = {:.4}",
        kt.iterations(),
        k.a,
        k.c,
        k.b,
        k.gamma,
        k.alpha
    );
    println!("(true values with b₁ = 1: b = [1, 0.5, −0.3], γ = [1, 0.5])");
}
