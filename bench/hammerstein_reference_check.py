#!/usr/bin/env python3
"""CI check: `host-sim identify hammerstein --method refined` reaches the
independent maximum-likelihood reference (bench/hammerstein_ml_reference.py,
numpy + scipy) on records where the paper algorithms stop at a biased fixed
point: `paper-kt-stable`, L = 1000, full memory, σ = 1 seed 100 (where the
paper stage ends with the colour of the noise in A) and σ = 0.5 seed 4.

Asserts, for both starting algorithms: the refinement's cost is at most the
reference's (relative 1e-9: both evaluate the same criterion), at most the
cost at the true parameters, and its estimate is within 1e-3 (relative, on
p = [a, c, b_iγ_j, α]) of the reference's. Exit status 1 on failure.

    python3 bench/hammerstein_reference_check.py    # builds host-sim (release), or --host-sim PATH
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--host-sim", help="this host-sim binary (not built; scripts/check.sh takes cargo test's)")
    hs = ap.parse_args().host_sim
    if hs is None:
        subprocess.run(["cargo", "build", "--quiet", "--release", "-p", "host-sim"], cwd=ROOT, check=True)
        hs = os.path.join(os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target")), "release", "host-sim")
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    failures = 0
    with tempfile.TemporaryDirectory() as d:
        for sigma, seed in [(1.0, 100), (0.5, 4)]:
            csv = os.path.join(d, f"r{seed}.csv")
            subprocess.run([hs, "simulate", "hammerstein", "--preset", "paper-kt-stable", "--sigma", str(sigma),
                            "--length", "1000", "--seed", str(seed), "--out", csv],
                           check=True, capture_output=True)
            ref_json = os.path.join(d, f"r{seed}.reference.json")
            subprocess.run([sys.executable, os.path.join(ROOT, "bench", "hammerstein_ml_reference.py"), "--input", csv,
                            "--preset", "paper-kt-stable", "--json", ref_json],
                           check=True, capture_output=True, env=env)
            ref = json.load(open(ref_json))
            for alg in ["op", "kt"]:
                out = os.path.join(d, f"r{seed}.{alg}.json")
                subprocess.run([hs, "identify", "hammerstein", "--input", csv, "--algorithm", alg, "--alpha0", "0.25",
                                "--json", out], check=True, capture_output=True)
                j = json.load(open(out))
                p = j["a"] + j["c"] + j["theta_products"] + [j["alpha"]]
                q = ref["p"]
                dist = math.sqrt(sum((x - y) ** 2 for x, y in zip(p, q)) / sum(y * y for y in q))
                ok = (j["cost"] <= ref["cost"] * (1 + 1e-9) and j["cost"] <= ref["cost_truth"] and dist <= 1e-3)
                failures += not ok
                print(f"σ = {sigma} seed {seed} from {alg}: cost {j['cost']:.6f} (reference {ref['cost']:.6f}, "
                      f"truth {ref['cost_truth']:.6f}), ‖p − p_ref‖/‖p_ref‖ = {dist:.2e} {'ok' if ok else 'FAILED'}")
    if failures:
        sys.exit(f"{failures} refinement(s) missed the maximum-likelihood reference")


if __name__ == "__main__":
    main()
