#!/usr/bin/env python3
"""Runs `host-sim identify battery --method paper` and the numpy reference
(bench/paper_gi_numpy.py) on the same file, checks that their results agree
to 1e-9, and times both (median wall time of whole commands over --runs
runs, each including start-up and reading the file).

    python3 bench/compare.py [--length 1000] [--iterations 100] [--runs 7]

Builds host-sim (release) first, unless --host-sim names a binary. The last line is one JSON object:
{"rows", "iterations", "max_rel_diff", "host_sim_s", "numpy_s", "numpy_identify_s", "speedup"}.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(cmd):
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if p.returncode != 0:
        sys.exit(f"error: {' '.join(cmd)} failed: {p.stderr.strip().splitlines()[-1:]}")
    return dt


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--length", type=int, default=1000)
    ap.add_argument("--iterations", type=int, default=100)
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--host-sim", help="this host-sim binary (not built; the check of "
                    "scripts/check.sh takes cargo test's: the same results, not its speed)")
    a = ap.parse_args()
    hs = a.host_sim
    if hs is None:
        subprocess.run(["cargo", "build", "--quiet", "--release", "-p", "host-sim"], cwd=ROOT, check=True)
        hs = os.path.join(os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target")), "release", "host-sim")
    with tempfile.TemporaryDirectory() as d:
        csv = os.path.join(d, "cell.csv")
        run([hs, "simulate", "battery", "--preset", "cell", "--profile", "pulse", "--sigma", "0.0001",
             "--length", str(a.length), "--seed", str(a.seed), "--out", csv])
        rs, py = os.path.join(d, "rs.json"), os.path.join(d, "py.json")
        rust_cmd = [hs, "identify", "battery", "--input", csv, "--method", "paper",
                    "--iterations", str(a.iterations), "--json", rs]
        numpy_cmd = [sys.executable, os.path.join(ROOT, "bench", "paper_gi_numpy.py"), "--input", csv,
                     "--iterations", str(a.iterations), "--json", py]
        t_rs, t_py, t_py_id = [], [], []
        for _ in range(a.runs):
            t_rs.append(run(rust_cmd))
            t_py.append(run(numpy_cmd))
            with open(py) as f:
                t_py_id.append(json.load(f)["seconds_identify"])
        with open(rs) as f:
            r = json.load(f)
        with open(py) as f:
            p = json.load(f)
    if len(r["history"]) != len(p["history"]):
        sys.exit(f"error: {len(r['history'])} iterations in host-sim, {len(p['history'])} in numpy")
    diffs = [abs(r[k] / p[k] - 1) for k in ("r_i", "r_ct", "q", "alpha", "u_oc")]
    diffs += [abs(x["cost"] / y["cost"] - 1) for x, y in zip(r["history"], p["history"])]
    diffs += [abs(x["alpha"] - y["alpha"]) for x, y in zip(r["history"], p["history"])]
    out = dict(
        rows=a.length,
        iterations=len(r["history"]),
        max_rel_diff=max(diffs),
        host_sim_s=statistics.median(t_rs),
        numpy_s=statistics.median(t_py),
        numpy_identify_s=statistics.median(t_py_id),
    )
    out["speedup"] = out["numpy_s"] / out["host_sim_s"]
    print(f"host-sim {out['host_sim_s']*1e3:.1f} ms, numpy {out['numpy_s']*1e3:.1f} ms "
          f"(of which identification {out['numpy_identify_s']*1e3:.1f} ms): {out['speedup']:.1f}x; "
          f"largest difference {out['max_rel_diff']:.2e}", file=sys.stderr)
    print(json.dumps(out))
    if out["max_rel_diff"] > 1e-9:
        sys.exit(1)


if __name__ == "__main__":
    main()
