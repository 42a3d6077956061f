#!/usr/bin/env python3
"""The whole `identify battery` command timed with two host-sim binaries,
on one core, alternating, median of RUNS each (docs/performance.md): the
measured Panasonic HPPC overpotential and the 50 000-row made records of
bench/scaling.py, and the Panasonic HPPC export as it comes. The fits'
RMSEs are printed beside, to show both binaries fit alike.

    git worktree add /tmp/old <commit> && (cd /tmp/old && CARGO_TARGET_DIR=/tmp/old-target cargo build --release -p host-sim)
    python3 bench/scaling.py          # target/scaling: the records and the OCV table
    python3 bench/speed_before_after.py /tmp/old-target/release/host-sim target/release/host-sim [--runs 3]
"""

import argparse
import json
import shutil
import statistics
import subprocess
import time

S = "target/scaling"
HPPC = "data/panasonic-18650pf/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat"
CASES = [
    ("Panasonic HPPC overpotential", [f"{S}/panasonic-overpotential.csv", "--model", "linear",
                                      "--voltage-min=-5"]),
    ("Panasonic HPPC export as it comes", [HPPC, "--ocv", f"{S}/panasonic-ocv.csv",
                                           "--capacity-ah", "2.9", "--model", "linear"]),
    ("50 000 rows, linear", [f"{S}/linear-50000.csv", "--model", "linear"]),
    ("50 000 rows, Butler–Volmer", [f"{S}/butler-volmer-50000.csv", "--model", "butler-volmer"]),
]


def run(binary, args):
    cmd = [binary, "identify", "battery", "--input", *args, "--json", "/tmp/speed-before-after.json"]
    if shutil.which("taskset"):
        cmd = ["taskset", "-c", "0"] + cmd
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True)
    dt = time.perf_counter() - t0
    return dt, json.load(open("/tmp/speed-before-after.json"))["rmse_v"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--runs", type=int, default=3)
    a = ap.parse_args()
    print("| record | before (s) | after (s) | RMSE before / after (mV) |")
    print("|---|---|---|---|")
    for name, args in CASES:
        t = {"old": [], "new": []}
        r = {}
        for _ in range(a.runs):
            for which in ("old", "new"):
                dt, r[which] = run(getattr(a, which), args)
                t[which].append(dt)
        print(f"| {name} | {statistics.median(t['old']):.2f} | {statistics.median(t['new']):.2f} "
              f"| {1e3 * r['old']:.6f} / {1e3 * r['new']:.6f} |", flush=True)


if __name__ == "__main__":
    main()
