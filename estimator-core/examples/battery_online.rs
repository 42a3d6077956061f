//! Scratch: online tracking on the drifting-OCV drive profile.
use estimator_core::battery::online::{CellEstimator, Method, OnlineSettings};
use estimator_core::battery::profile::{ocv_nmc, Profile};
use estimator_core::battery::simulate::simulate;
use estimator_core::battery::CellParameters;
use estimator_core::frac::GlWeights;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

const L: usize = 3000;

fn main() {
    let truth = CellParameters::<f64>::cell_18650();
    let cap_as = 2.5 * 3600.0;
    let current: Vec<f64> = (0..L)
        .map(|l| Profile::Drive.current(l as f64, 6.0))
        .collect();
    let mut soc = vec![0.9; L];
    for l in 1..L {
        soc[l] = soc[l - 1] + current[l - 1] / cap_as;
    }
    let ocv: Vec<f64> = soc.iter().map(|&z| ocv_nmc(z)).collect();
    let mut w = Box::new(GlWeights::<f64, L>::new(truth.alpha, 1.0, L).unwrap());
    let (mut up, mut v) = (vec![0.0; L], vec![0.0; L]);
    simulate(&truth, &mut w, &current, |l| ocv[l], &mut up, &mut v).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let nd = Normal::new(0.0, 0.001).unwrap();
    let meas: Vec<f64> = v.iter().map(|x| x + nd.sample(&mut rng)).collect();
    println!(
        "soc end {:.3}, ocv {:.3} -> {:.3}",
        soc[L - 1],
        ocv[0],
        ocv[L - 1]
    );
    for (mem, method, k) in [
        (64usize, Method::Refined, 1u16),
        (128, Method::Refined, 1),
        (128, Method::Refined, 3),
        (64, Method::Paper, 5),
    ] {
        let mut s = OnlineSettings::new(1.0, mem, CellParameters::cell_18650());
        s.method = method;
        s.iterations_per_sample = k;
        let mut est = Box::new(CellEstimator::<f64, 256, 256>::new(&s).unwrap());
        let mut errs = (vec![], vec![], vec![], vec![], vec![]);
        for l in 0..L {
            let r = est.push(&s, current[l], meas[l]);
            if l >= 1000 {
                if let Some(p) = est.estimate() {
                    errs.0.push((p.r_i / truth.r_i - 1.0).abs());
                    errs.1.push((p.r_ct / truth.r_ct - 1.0).abs());
                    errs.2.push((p.alpha - truth.alpha).abs());
                    errs.3.push((p.u_oc - ocv[l]).abs());
                    errs.4.push((p.q / truth.q - 1.0).abs());
                }
            }
            if l % 500 == 499 {
                println!(
                    "  l={l} {:?} {:?} ocv {:.4}",
                    r.status,
                    est.estimate()
                        .map(|p| (p.r_i, p.r_ct, p.q, p.alpha, p.u_oc)),
                    ocv[l]
                );
            }
        }
        let med = |v: &mut Vec<f64>| {
            v.sort_by(|a, b| a.partial_cmp(b).unwrap());
            (v[v.len() / 2], v[v.len() * 95 / 100])
        };
        println!("mem {mem} {method:?} k={k}: median/p95 |err| r_i {:?} r_ct {:?} q {:?} alpha {:?} u_oc {:?} counts {:?}", med(&mut errs.0), med(&mut errs.1), med(&mut errs.4), med(&mut errs.2), med(&mut errs.3), est.counts());
    }
}
