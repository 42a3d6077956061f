//! One whole-record refinement from the rough even-split start, timed:
//! the "ours, one start" column of `bench/scaling.py` (docs/performance.md).
//!
//!     cargo run --release -p fracbms-host --example refine_once -- RECORD.csv linear|butler-volmer
//!
//! The record is `time_s,current_a,voltage_v` on a uniform period (a `nan`
//! voltage: a sample not observed, left out of the fit). The
//! start is the first of `identify battery`'s rough starts
//! ([`rough_starts`]), the one `bench/scaling.py` gives its scipy
//! reference: R from the slope of V on I split evenly, α 0.7, τ^α = 5 s^α,
//! U_oc the line's intercept; with the Butler–Volmer term, i₀ = 0.3·max|I|
//! and a = i₀·R_i/2 (R_i halved). Prints one JSON line: seconds, RMSE,
//! iterations, α.

use fracbms_host::identify::battery::{filled, rough_starts};
use fracbms_host::identify::refine::refine_from_start;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let (path, model) = match args.as_slice() {
        [_, p, m] => (p.clone(), m.clone()),
        _ => return Err("usage: refine_once RECORD.csv linear|butler-volmer".into()),
    };
    let rec = fracbms_host::io::read_battery(std::path::Path::new(&path), None)?;
    let (h, i, v) = (rec.h, rec.current, rec.voltage);
    // Unobserved samples (NaN voltage) are filled for the start only, as
    // `identify battery` fills them; the refinement leaves them out.
    let mut start = rough_starts(&i, &filled(&v))[0];
    if model == "butler-volmer" {
        start = start.with_butler_volmer(0.3 * i.iter().fold(0.0f64, |m, x| m.max(x.abs())));
    }
    let t0 = Instant::now();
    let fit = fracbms_host::worker::on_worker(|| refine_from_start(h, &i, &v, start))?;
    let s = t0.elapsed().as_secs_f64();
    println!(
        "{{\"seconds\": {s}, \"rmse_v\": {}, \"iterations\": {}, \"alpha\": {}, \"stop\": \"{}\"}}",
        fit.rmse_v,
        fit.iterations,
        fit.cell.alpha,
        fit.stop.as_str()
    );
    Ok(())
}
