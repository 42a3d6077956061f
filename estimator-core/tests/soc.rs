//! The SOC observer on the own model (issue 36): records with a known true
//! SOC, a current-sensor bias of +1 % of 1C, a start SOC 10 % off, or
//! both. After the first rest longer than ten minutes the published SOC
//! stays within 2 % of the truth; plain counting's error beside it.

mod common;
use common::{nmc_table, true_soc};

use estimator_core::battery::ocv::OcvTable;
use estimator_core::battery::profile::{ocv_nmc, Profile};
use estimator_core::battery::simulate::simulate;
use estimator_core::battery::soc::{SocObserver, SocSettings};
use estimator_core::battery::CellParameters;
use estimator_core::frac::GlWeights;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

const CAPACITY_AH: f64 = 2.5;
/// The first rest: 20 minutes.
const FIRST_REST: usize = 1200;

/// From SOC 0.9 at rest: 20 min of rest, then five rounds of 20 min of the
/// pulse profile on a 1 A mean discharge and 15 min of rest (SOC 0.9 →
/// 0.23 in 3.25 h), through the NMC curve; memory 4096 s, σ = 1 mV.
/// Returns current, voltage and the true SOC after each sample.
fn record(cell: &CellParameters<f64>) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut i = vec![0.0; FIRST_REST];
    for _ in 0..5 {
        i.extend((0..1200).map(|l| Profile::Pulse.current(l as f64, 5.0) - 1.0));
        i.extend([0.0; 900]);
    }
    let len = i.len();
    let soc = true_soc(&i);
    let mut w = Box::new(GlWeights::<f64, 4096>::new(cell.alpha, 1.0, 4096).unwrap());
    let (mut up, mut v) = (vec![0.0; len], vec![0.0; len]);
    simulate(cell, &mut w, &i, |l| ocv_nmc(soc[l]), &mut up, &mut v).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(36);
    let nd = Normal::new(0.0, 0.001).unwrap();
    for x in &mut v {
        *x += nd.sample(&mut rng);
    }
    (i, v, soc)
}

/// The worst SOC error after the first rest of the observer and of plain
/// counting, with the sensor reading `bias` (A) high and the start given
/// `offset` off.
fn worst(cell: &CellParameters<f64>, bias: f64, offset: f64) -> (f64, f64) {
    let (i, v, soc) = record(cell);
    let table = nmc_table();
    let s = SocSettings::new(CAPACITY_AH, 1.0);
    let mut o = SocObserver::new(&s, Some(0.9 + offset));
    let mut counted = 0.9 + offset;
    let (mut observer, mut coulomb) = (0.0_f64, 0.0_f64);
    for l in 0..i.len() {
        let e = o.push(&s, &table, i[l] + bias, v[l]).unwrap();
        counted += (i[l] + bias) / (CAPACITY_AH * 3600.0);
        // The first rest ends with sample FIRST_REST (its observation).
        if l >= FIRST_REST {
            observer = observer.max((e.soc - soc[l]).abs());
            coulomb = coulomb.max((counted - soc[l]).abs());
        }
    }
    (observer, coulomb)
}

fn cells() -> [(&'static str, CellParameters<f64>); 2] {
    let fast = CellParameters::<f64>::cell_18650();
    // τ^(1/α) of 300 s: a branch still relaxing after ten minutes.
    let slow = CellParameters {
        r_ct: 0.03,
        q: 300f64.powf(0.75) / 0.03,
        ..fast
    };
    [("18650 preset", fast), ("slow branch", slow)]
}

#[test]
fn after_the_first_long_rest_the_soc_stays_within_two_percent() {
    let bias = CAPACITY_AH / 100.0;
    for (name, cell) in cells() {
        for (case, b, off) in [
            ("bias", bias, 0.0),
            ("start", 0.0, 0.1),
            ("both", bias, -0.1),
        ] {
            let (obs, cc) = worst(&cell, b, off);
            eprintln!("{name:14} {case:6} observer {obs:.4}  coulomb {cc:.4}");
            assert!(obs < 0.02, "{name} {case}: observer off by {obs}");
            assert!(cc > obs, "{name} {case}: counting {cc} vs observer {obs}");
        }
    }
}

#[test]
fn without_bias_the_observer_errs_by_what_the_rested_voltage_holds() {
    // Counting from the true start with an exact sensor is exact here
    // (0). The observer's error is what the rested voltages carry: on the
    // preset, the table's 1 % interpolation and 1 mV noise (measured
    // 0.09 %); on the slow branch, the polarization still left after 15
    // minutes of rest, 3.1 mV after 1200 s at 1 A (measured 0.89 %), which
    // the observations read as a lower SOC and a capacity 1 % low.
    for ((name, cell), bound) in cells().into_iter().zip([0.002, 0.011]) {
        let (obs, cc) = worst(&cell, 0.0, 0.0);
        eprintln!("{name:14} none   observer {obs:.4}  coulomb {cc:.4}");
        assert!(cc < 1e-9, "{name}: counting {cc}");
        assert!(obs < bound, "{name}: observer {obs}");
    }
}

/// A PyBaMM DFN record of data/pybamm: current, voltage, true SOC, and
/// its OCV table and capacity.
fn dfn(record: &str) -> (Vec<f64>, Vec<f64>, Vec<f64>, OcvTable<f64, 101>, f64) {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../data/pybamm/");
    let text = std::fs::read_to_string(format!("{dir}{record}.csv")).unwrap();
    let (mut i, mut v, mut z) = (vec![], vec![], vec![]);
    for line in text.lines().skip(1) {
        let f: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        i.push(f[1]);
        v.push(f[2]);
        z.push(f[4]);
    }
    let cell = record.split('-').next().unwrap();
    let text = std::fs::read_to_string(format!("{dir}{cell}-ocv.csv")).unwrap();
    let (mut soc, mut ocv) = (vec![], vec![]);
    for line in text.lines().skip(1) {
        let f: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        soc.push(f[0]);
        ocv.push(f[1]);
    }
    let meta = std::fs::read_to_string(format!("{dir}meta.json")).unwrap();
    // "capacity_ah": the first after the record's name.
    let at = meta.find(&format!("\"{record}\"")).unwrap();
    let key = "\"capacity_ah\": ";
    let from = at + meta[at..].find(key).unwrap() + key.len();
    let to = from + meta[from..].find(',').unwrap();
    let capacity = meta[from..to].trim().parse().unwrap();
    (i, v, z, OcvTable::new(&soc, &ocv).unwrap(), capacity)
}

/// The observer over a DFN record fed with `bias` (A) and a start `offset`:
/// the worst error after the first 15-minute rest (observer, counting),
/// and the worst error over the published spread there.
fn dfn_worst(record: &str, bias: f64, offset: f64) -> (f64, f64, f64) {
    let (i, v, z, table, capacity) = dfn(record);
    let s = SocSettings::new(capacity, 1.0);
    let mut o = SocObserver::new(&s, Some(0.9 + offset));
    let mut counted = 0.9 + offset;
    let (mut observer, mut coulomb, mut sigmas) = (0.0_f64, 0.0_f64, 0.0_f64);
    for l in 0..i.len() {
        let e = o.push(&s, &table, i[l] + bias, v[l]).unwrap();
        counted += (i[l] + bias) / (capacity * 3600.0);
        if l >= 900 {
            observer = observer.max((e.soc - z[l]).abs());
            coulomb = coulomb.max((counted - z[l]).abs());
            sigmas = sigmas.max((e.soc - z[l]).abs() / e.sigma);
        }
    }
    (observer, coulomb, sigmas)
}

#[test]
fn on_a_dfn_nmc_cell_the_soc_stays_within_two_percent_after_the_first_rest() {
    // data/pybamm/chen2020-soc.csv: 15 min at rest, then four rounds of
    // 25 min of a drive cycle and 15 min of rest (SOC 0.9 → 0.4).
    let (_, _, _, _, capacity) = dfn("chen2020-soc");
    let bias = capacity / 100.0;
    for (case, b, off) in [
        ("none", 0.0, 0.0),
        ("bias", bias, 0.0),
        ("start", 0.0, -0.1),
        ("both", bias, 0.1),
    ] {
        let (obs, cc, k) = dfn_worst("chen2020-soc", b, off);
        eprintln!("chen2020-soc {case:6} observer {obs:.4}  coulomb {cc:.4}  worst/sigma {k:.2}");
        assert!(obs < 0.02, "{case}: observer off by {obs}");
        if case != "none" {
            assert!(cc > 2.0 * obs, "{case}: counting {cc} vs observer {obs}");
        }
    }
}

#[test]
fn on_a_flat_lfp_plateau_the_observer_says_it_cannot_see() {
    // data/pybamm/prada2013-soc.csv: the LFP plateau (about 0.03 V per
    // unit SOC). A start 10 % off is corrected only slowly, but the
    // published spread says so: the error stays within 3 sigma.
    for (case, off) in [("start", -0.1), ("none", 0.0)] {
        let (obs, cc, k) = dfn_worst("prada2013-soc", 0.0, off);
        eprintln!("prada2013-soc {case:6} observer {obs:.4}  coulomb {cc:.4}  worst/sigma {k:.2}");
        assert!(k < 3.0, "{case}: error {obs} is {k} sigma");
    }
}

#[test]
fn the_cell_estimator_carries_the_observer_sample_by_sample() {
    // The online estimator's observer (in its cell state) is the
    // standalone one fed the same samples: the count's current and every
    // accepted voltage; a rejected voltage is not read.
    use estimator_core::battery::ocv::OcvModel;
    use estimator_core::battery::online::{CellEstimator, OnlineSettings};
    let (i, mut v, _, table, capacity) = dfn("chen2020-soc");
    v[1500] = f64::NAN;
    let s = OnlineSettings::new(1.0, 16, CellParameters::cell_18650())
        .with_ocv(OcvModel::new(table, capacity).unwrap());
    let mut est = Box::new(CellEstimator::<f64, 64, 16>::new(&s).unwrap());
    est.set_state_of_charge(0.85);
    let mut alone = SocObserver::new(&s.soc, Some(0.85));
    // Through the first two rests (0–900 s, 2400–3300 s).
    for l in 0..3400 {
        est.push(&s, i[l] + 0.05, v[l]);
        let want = alone.push(&s.soc, &table, i[l] + 0.05, v[l]);
        assert_eq!(est.soc_estimate(&s), want, "sample {l}");
    }
    let e = est.soc_estimate(&s).unwrap();
    assert!(e.observations >= 2, "{e:?}");
}
