//! Truncation error of short-memory Grünwald–Letnikov differences.
//!
//! `cargo run --release -p estimator-core --example truncation`
//!
//! For α ∈ {0.3, 0.5, 0.7, 0.9}, h = 1, and a slowly varying signal
//! x(l) = 1 + sin(0.01 l) over 2000 samples, prints the largest
//! |Δ^α_M x(l) − Δ^α_full x(l)| over the last 1000 samples, relative to the
//! largest |Δ^α_full x|, for memory lengths M = 8 … 1024, and the bound
//! |Σ_{j≥M} w_j| · max|x| on the neglected tail.

use estimator_core::frac::GlWeights;

const N: usize = 2000;

fn main() {
    let x: Vec<f64> = (0..N).map(|l| 1.0 + (0.01 * l as f64).sin()).collect();
    let xmax = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    println!("| α | M | max error / max |Δ^α x| | tail bound |Σ_{{j≥M}} w_j|·max|x| |");
    println!("|---|---|---|---|");
    for &alpha in &[0.3, 0.5, 0.7, 0.9] {
        let full = GlWeights::<f64, N>::new(alpha, 1.0, N).unwrap();
        let scale = (N / 2..N)
            .map(|l| full.difference(&x, l).abs())
            .fold(0.0, f64::max);
        for &m in &[8usize, 16, 32, 64, 128, 256, 512, 1024] {
            let w = GlWeights::<f64, N>::new(alpha, 1.0, m).unwrap();
            let err = (N / 2..N)
                .map(|l| (w.difference(&x, l) - full.difference(&x, l)).abs())
                .fold(0.0, f64::max);
            let tail: f64 = full.weights()[m..].iter().sum::<f64>().abs();
            println!(
                "| {alpha} | {m} | {:.3e} | {:.3e} |",
                err / scale,
                tail * xmax
            );
        }
    }
}
