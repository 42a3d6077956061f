#!/usr/bin/env python3
"""A record replayed in two halves through `host-sim online battery
--state-out/--state-in`, against the uninterrupted run (docs/persistence.md).

Prints, for the first sample of the second half and at a few samples after
it, the largest relative deviation of the published R_i, R_ct, Q, alpha and
SOC (and of the window's fit) between the resumed and the whole run.

    python3 bench/resume_halves.py --host-sim target/debug/host-sim \
        --input data/pybamm/chen2020-hppc.csv --cut 2900 \
        -- --ocv data/pybamm/chen2020-ocv.csv --capacity-ah 5.153198
"""
import argparse
import csv
import math
import os
import subprocess
import sys
import tempfile

PUBLISHED = ["r_i", "r_ct", "q", "alpha", "soc"]
WINDOW = ["window_r_i", "window_r_ct", "window_q", "window_alpha"]


def run(host_sim, args):
    r = subprocess.run([host_sim] + args, capture_output=True, text=True)
    if r.returncode:
        sys.exit(r.stderr)
    return r.stderr


def rel(a, b):
    """Relative deviation; NaN where only one of the two is published."""
    if a == "" and b == "":
        return 0.0
    if a == "" or b == "":
        return math.nan
    a, b = float(a), float(b)
    return 0.0 if a == b else abs(a / b - 1.0)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--host-sim", default="target/debug/host-sim")
    p.add_argument("--input", required=True)
    p.add_argument("--cut", type=int, required=True, help="data rows in the first half")
    p.add_argument("extra", nargs="*", help="flags for online battery (after --)")
    a = p.parse_args()
    d = tempfile.mkdtemp(prefix="resume-halves-")
    lines = open(a.input).read().splitlines()
    first, second = os.path.join(d, "first.csv"), os.path.join(d, "second.csv")
    open(first, "w").write("\n".join([lines[0]] + lines[1 : a.cut + 1]) + "\n")
    open(second, "w").write("\n".join([lines[0]] + lines[a.cut + 1 :]) + "\n")
    whole_t, t1, t2 = (os.path.join(d, f) for f in ("whole-t.csv", "t1.csv", "t2.csv"))
    state = os.path.join(d, "state.bin")
    run(a.host_sim, ["online", "battery", "--input", a.input, "--out", whole_t] + a.extra)
    run(a.host_sim, ["online", "battery", "--input", first, "--out", t1, "--state-out", state] + a.extra)
    log = run(a.host_sim, ["online", "battery", "--input", second, "--out", t2, "--state-in", state] + a.extra)
    print(log.strip().splitlines()[-1] if log.strip() else "")
    print(f"snapshot: {os.path.getsize(state)} B")
    w = list(csv.DictReader(open(whole_t)))
    h = list(csv.DictReader(open(t2)))
    print("samples after the cut | max rel. published (R_i, R_ct, Q, alpha, SOC) | max rel. window fit | status resumed / whole")
    for k in [0, 1, 64, 128, 256, 300, 400, 600, 1000, len(h) - 1]:
        if k >= len(h):
            continue
        x, y = h[k], w[a.cut + k]
        pub = max((rel(x[n], y[n]) for n in PUBLISHED), key=lambda v: -1 if math.isnan(v) else v)
        win = max((rel(x[n], y[n]) for n in WINDOW), key=lambda v: -1 if math.isnan(v) else v)
        print(f"{k:>5} | {pub:.3g} | {win:.3g} | {x['status']} / {y['status']}")


if __name__ == "__main__":
    main()
