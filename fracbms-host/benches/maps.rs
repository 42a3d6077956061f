//! Host cost of a parameter map (issue 73, docs/maps.md): `build_map` on
//! an HPPC-like record of 45 480 samples at 1 s with 10 levels, by the
//! levels fitted one by one (`--map-method levels`) and by the joint fit
//! of every knot over the whole record (`--map-method joint`, the penalty
//! and the varying set chosen by leaving levels out, as the CLI's
//! default), both with the single whole-record fit left out.
//!
//! The record: a 640 s rest, then per level 60 s of rest, three ±5 A pairs
//! of 10 s pulses, a 0.09 A·h discharge at 2.5 A and a 3 994 s rest, each
//! level's cell (R_i 20–56 mΩ, R_ct 12–30 mΩ, α 0.70–0.88) simulated from
//! rest through the NMC OCV curve of a 2.5 A·h cell, and 0.5 mV of noise.
//!
//! `cargo bench -p fracbms-host --bench maps` (about 3 minutes).

use criterion::{criterion_group, criterion_main, Criterion};
use estimator_core::battery::profile::ocv_nmc;
use estimator_core::battery::CellParameters;
use fracbms_host::identify::battery::{model_voltage, Refine};
use fracbms_host::identify::map::build_map;
use fracbms_host::identify::{BatteryMethod, ModelRequest};
use fracbms_host::io::{BatteryRecord, HostOcvTable};
use fracbms_host::map::{MapMethod, MapOptions};
use fracbms_host::ocv::OcvSpec;
use fracbms_host::trust::Limits;
use std::hint::black_box;
use std::path::Path;

const CAP: f64 = 2.5;
const LEVELS: usize = 10;

fn record() -> BatteryRecord {
    let mut current = vec![0.0; 640];
    let mut voltage = vec![ocv_nmc::<f64>(0.95); 640];
    let mut z = 0.95;
    let mut seed = 12345u64;
    let mut noise = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.5e-3 * 12f64.sqrt()
    };
    for v in &mut voltage {
        *v += noise();
    }
    for level in 0..LEVELS {
        let x = level as f64;
        let cell = CellParameters {
            r_i: 0.020 + 0.004 * x,
            r_ct: 0.012 + 0.002 * x,
            q: 600.0,
            alpha: 0.70 + 0.02 * x,
            u_oc: 0.0,
            bv_a: 0.0,
            bv_i0: 1.0,
        };
        let mut i = vec![0.0; 60];
        for _ in 0..3 {
            i.extend([-5.0; 10]);
            i.extend([0.0; 40]);
            i.extend([5.0; 10]);
            i.extend([0.0; 40]);
        }
        i.extend([-2.5; 130]);
        i.extend([0.0; 3994]);
        let up = model_voltage(&cell, 1.0, &i).unwrap();
        for (k, &ik) in i.iter().enumerate() {
            z += ik / 3600.0 / CAP;
            current.push(ik);
            voltage.push(ocv_nmc::<f64>(z) + up[k] + noise());
        }
    }
    let n = current.len();
    BatteryRecord {
        time: (0..n).map(|k| k as f64).collect(),
        current,
        voltage,
        h: 1.0,
    }
}

fn maps(c: &mut Criterion) {
    let rec = record();
    let z: Vec<f64> = (0..=50).map(|k| k as f64 / 50.0).collect();
    let v: Vec<f64> = z.iter().map(|&z| ocv_nmc::<f64>(z)).collect();
    let ocv = OcvSpec::new(HostOcvTable::new(&z, &v).unwrap(), CAP, Some(0.95)).unwrap();
    let limits = Limits::checked(None, None, None).unwrap();
    let refine = Refine {
        model: ModelRequest::Linear,
        ..Refine::default()
    };
    let mut g = c.benchmark_group("map_45480_samples_10_levels");
    g.sample_size(10);
    for (name, method) in [("levels", MapMethod::Levels), ("joint", MapMethod::Joint)] {
        let o = MapOptions {
            min_rest_s: 600.0,
            method,
            ..MapOptions::default()
        };
        g.bench_function(name, |b| {
            b.iter(|| {
                fracbms_host::worker::on_worker(|| {
                    build_map(
                        Path::new("bench"),
                        &rec,
                        None,
                        &limits,
                        &ocv,
                        BatteryMethod::Refined,
                        50,
                        refine,
                        &o,
                        &[],
                        None,
                        &[],
                    )
                })
                .map(|m| black_box(m.rmse_v))
                .unwrap()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, maps);
criterion_main!(benches);
