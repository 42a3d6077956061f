#!/usr/bin/env python3
"""The 1C pulses of the committed DFN truth (data/pybamm/sop-truth.csv,
made by bench/sop_dfn.py with PyBaMM) judged again without PyBaMM: for
another `online battery` window or any change of the estimator, the
`pulse_v_{10,30}s` published at each truth row's instant against the
DFN's continuation of the record with that pulse (which does not depend
on our estimator). The state-of-power rows of the truth are not judged
here: their current was our default run's.

As bench/sop_dfn.py runs it: window 256 by default, OCV table, no prior on
the HPPC records, the HPPC record's whole-record fit (`identify battery
--json`) as prior on the drive cycles, `--voltage-min` 3.3 V (Chen2020) or
2.9 V (Prada2013), `--current-limit` 5C.

    cargo build --release -p host-sim
    python3 bench/sop_truth.py [--window 256] [--model linear|butler-volmer] [--tail]
        [--host-sim target/release/host-sim]

`--model butler-volmer` runs `online battery --model butler-volmer`, and the
drive cycles' prior is the HPPC record's Butler-Volmer fit.
"""

import argparse
import csv
import json
import os
import subprocess

RECORDS = ("chen2020-hppc", "chen2020-drive", "prada2013-hppc", "prada2013-drive")
VOLTAGE_MIN = {"chen2020": 3.3, "prada2013": 2.9}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--host-sim", default="target/release/host-sim")
    ap.add_argument("--window", default="256")
    ap.add_argument("--model", default="linear", choices=("linear", "butler-volmer"))
    ap.add_argument("--out", default="target/sop-truth")
    ap.add_argument("--tail", action="store_true", help="online battery --tail (the linear model)")
    a = ap.parse_args()
    tail = ["--tail"] if a.tail else []
    os.makedirs(a.out, exist_ok=True)
    meta = json.load(open("data/pybamm/meta.json"))["records"]
    truth = list(csv.DictReader(open("data/pybamm/sop-truth.csv")))
    print(f"window {a.window}, model {a.model}{', --tail' if a.tail else ''}: 1C pulse, error / drop")
    for rec in RECORDS:
        cap = meta[rec]["capacity_ah"]
        cell = rec.split("-")[0]
        prior = []
        if rec.endswith("-drive"):
            fit = f"{a.out}/{cell}-hppc-{a.model}-fit.json"
            subprocess.run([a.host_sim, "identify", "battery", "--input", f"data/pybamm/{cell}-hppc.csv",
                            "--ocv", f"data/pybamm/{cell}-ocv.csv", "--capacity-ah", str(cap),
                            "--model", a.model, "--json", fit], check=True, capture_output=True)
            prior = ["--prior", fit]
        path = f"{a.out}/{rec}-{a.window}-{a.model}{'-tail' if a.tail else ''}.csv"
        subprocess.run([a.host_sim, "online", "battery", "--input", f"data/pybamm/{rec}.csv",
                        "--window", a.window, "--ocv", f"data/pybamm/{cell}-ocv.csv",
                        "--capacity-ah", str(cap), "--horizons", "10,30",
                        "--voltage-min", str(VOLTAGE_MIN[cell]), "--current-limit", str(5 * cap),
                        "--model", a.model, *prior, *tail, "--out", path], check=True, capture_output=True)
        track = list(csv.DictReader(open(path)))
        data = list(csv.DictReader(open(f"data/pybamm/{rec}.csv")))
        out = []
        for t in truth:
            if t["record"] != rec or abs(float(t["current_a"]) + cap) > 1e-6 * cap:
                continue
            t0, h = int(t["t0_s"]), int(t["steps"])
            p = track[t0][f"pulse_v_{h}s"]
            v0, v_end = float(data[t0]["voltage_true_v"]), float(t["v_end"])
            err = f"{abs(float(p) - v_end) / (v0 - v_end):.1%}" if p else "none"
            out.append(f"t0 {t0} {h} s {err}")
        print(f"{rec}: " + "; ".join(out) if out else f"{rec}: no 1C rows in the truth")


if __name__ == "__main__":
    main()
