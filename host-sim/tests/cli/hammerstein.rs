//! `simulate hammerstein`, `identify hammerstein`: the JSON contract and
//! round trips.

use super::*;

#[test]
fn hammerstein_identify_writes_the_contract_json() {
    let csv = tmp("ham.csv");
    let json = tmp("ham.json");
    let o = run(&[
        "simulate",
        "hammerstein",
        "--preset",
        "paper-op",
        "--sigma",
        "0.1",
        "--length",
        "300",
        "--seed",
        "1",
        "--out",
        s(&csv),
    ]);
    assert!(o.status.success());
    assert!(std::fs::read_to_string(&csv).unwrap().starts_with("u,y\n"));
    for alg in ["op", "kt"] {
        let o = run(&[
            "identify",
            "hammerstein",
            "--input",
            s(&csv),
            "--algorithm",
            alg,
            "--na",
            "2",
            "--nb",
            "3",
            "--nc",
            "2",
            "--basis",
            "poly:2",
            "--iterations",
            "12",
            "--json",
            s(&json),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(
            out.lines().any(|l| l.trim_start().starts_with("10 ")),
            "{out}"
        );
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        assert_eq!(j["algorithm"], alg);
        // The default method is the refinement: its keys are set.
        assert_eq!(j["method"], "refined");
        assert!(j["refine_iterations"].as_u64().unwrap() > 0);
        assert!(j["refine_cost"].as_f64().unwrap() <= j["paper_cost"].as_f64().unwrap());
        assert!(j["refine_converged"].is_boolean());
        assert!(["paper", "grid"].contains(&j["refine_start"]["kind"].as_str().unwrap()));
        assert!(j["refine_start"]["alpha"].as_f64().unwrap().is_finite());
        assert_eq!(j["a"].as_array().unwrap().len(), 2);
        assert_eq!(j["b"].as_array().unwrap().len(), 3);
        assert_eq!(j["c"].as_array().unwrap().len(), 2);
        assert_eq!(j["gamma"].as_array().unwrap().len(), 2);
        assert_eq!(j["theta_products"].as_array().unwrap().len(), 6);
        assert_eq!(j["history"].as_array().unwrap().len(), 12);
        for k in ["alpha", "cost"] {
            assert!(j[k].as_f64().unwrap().is_finite());
        }
        assert!(j["history"][0]["k"].as_u64() == Some(1));
    }
    // `--method paper`: the paper stage alone, the refinement's keys null.
    let o = run(&[
        "identify",
        "hammerstein",
        "--input",
        s(&csv),
        "--method",
        "paper",
        "--iterations",
        "12",
        "--json",
        s(&json),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(j["method"], "paper");
    assert_eq!(j["cost"], j["paper_cost"]);
    for k in [
        "refine_iterations",
        "refine_cost",
        "refine_converged",
        "refine_start",
    ] {
        assert!(j[k].is_null(), "{k}: {}", j[k]);
    }
}

/// simulate → identify on the `identifiable` preset (docs/identification.md):
/// both algorithms recover the system part. Bounds are explicit. The paper
/// method: a within 0.03, every product b_iγ_j within 0.05, α within 0.05,
/// and the noise model c (estimated from residuals, the hardest part)
/// within 0.15. The refinement (maximum likelihood), from either: a within
/// 0.01, the products within 0.02, c within 0.03, α within 0.01, and a cost
/// no higher than the paper stage's.
#[test]
fn hammerstein_round_trip_recovers_the_system() {
    let csv = tmp("identifiable.csv");
    let o = run(&[
        "simulate",
        "hammerstein",
        "--preset",
        "identifiable",
        "--sigma",
        "0.1",
        "--length",
        "1000",
        "--memory",
        "64",
        "--seed",
        "4",
        "--out",
        s(&csv),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let truth_products: Vec<f64> = [1.0, 0.5, -0.3]
        .iter()
        .flat_map(|b| [1.0, 0.5].map(|g| b * g))
        .collect();
    for (method, algorithm) in [
        ("paper", "op"),
        ("paper", "kt"),
        ("refined", "op"),
        ("refined", "kt"),
    ] {
        let json = tmp(&format!("identifiable-{method}-{algorithm}.json"));
        let o = run(&[
            "identify",
            "hammerstein",
            "--input",
            s(&csv),
            "--method",
            method,
            "--algorithm",
            algorithm,
            "--na",
            "2",
            "--nb",
            "3",
            "--nc",
            "2",
            "--basis",
            "poly:2",
            "--memory",
            "64",
            "--iterations",
            "100",
            "--json",
            s(&json),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let v = |k: &str| -> Vec<f64> {
            j[k].as_array()
                .unwrap_or_else(|| panic!("key {k}"))
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect()
        };
        let near = |got: &[f64], want: &[f64], tol: f64, what: &str| {
            assert_eq!(got.len(), want.len(), "{algorithm} {what}");
            for (g, w) in got.iter().zip(want) {
                assert!(
                    (g - w).abs() <= tol,
                    "{algorithm} {what}: {got:?} vs {want:?}"
                );
            }
        };
        assert_eq!(j["method"], method);
        let (ta, tp, tc, talpha) = if method == "paper" {
            (0.03, 0.05, 0.15, 0.05)
        } else {
            let (cost, paper) = (
                j["cost"].as_f64().unwrap(),
                j["paper_cost"].as_f64().unwrap(),
            );
            assert!(cost <= paper, "{algorithm}: refined cost {cost} > {paper}");
            assert_eq!(j["refine_cost"].as_f64(), Some(cost));
            (0.01, 0.02, 0.03, 0.01)
        };
        near(&v("a"), &[-0.5, 0.2], ta, "a");
        near(&v("theta_products"), &truth_products, tp, "b_i γ_j");
        near(&v("c"), &[0.3, -0.2], tc, "c");
        let alpha = j["alpha"].as_f64().unwrap();
        assert!(
            (alpha - 0.6).abs() <= talpha,
            "{method} {algorithm} α = {alpha}"
        );
    }
}
