#!/usr/bin/env python3
"""State of power against PyBaMM's DFN truth (issue 36).

From a few instants of the DFN records (data/pybamm), the pulse the
estimator predicts (`online battery`, window 256, OCV table; no prior on
the HPPC records, on the drive cycles the prior of the HPPC record's
whole-record fit, `identify battery --json`, as the product runs) against
PyBaMM's DFN continued from the same history with that pulse:

* a 1C discharge for 10 and 30 s (`pulse_v_{10,30}s`);
* the state-of-power discharge currents for 10 and 30 s
  (`sop_discharge_a_{10,30}s`, with `--voltage-min` below and
  `--current-limit` 5C): the DFN pulse at that current should just reach
  the limit (unless the current is the 5C cap).

Writes the truth to data/pybamm/sop-truth.csv (`record,t0_s,current_a,
steps,v_end,v_min`: the pulse of `current_a` for `steps` samples after row
t0; its last and lowest voltage), which `tests/tests/pybamm.rs` reads to
judge the core's prediction without PyBaMM, and prints the comparison.

    cargo build --release -p host-sim
    python3 -m venv .venv-pybamm && .venv-pybamm/bin/pip install pybamm==26.10.1.1 scipy
    .venv-pybamm/bin/python bench/sop_dfn.py [--host-sim target/release/host-sim]
    .venv-pybamm/bin/python bench/sop_dfn.py --model butler-volmer --truth /tmp/bv-truth.csv
"""

import argparse
import csv
import json
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from pybamm_data import simulate  # noqa: E402

# Record, its voltage limit for the SOP, the instants (rows), and whether
# it runs with the HPPC record's fit as prior.
CASES = [
    ("chen2020-drive", 3.3, (1200, 2000, 2800), True),
    ("prada2013-drive", 2.9, (1200, 2000, 2800), True),
    ("chen2020-hppc", 3.3, (1500, 3000, 4500), False),
    ("prada2013-hppc", 2.9, (1500, 3000, 4500), False),
]
PARAMETER_SETS = {"chen2020": "Chen2020", "prada2013": "Prada2013"}


def read(path):
    rows = list(csv.DictReader(open(path)))
    return rows


def nearest_published(track, t0, key):
    """The row at or before t0 (searching back 200 rows) whose `key` is
    published."""
    for k in range(t0, max(t0 - 200, 0), -1):
        if track[k][key]:
            return k
    return None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--host-sim", default="target/release/host-sim")
    ap.add_argument("--out", default="target/sop-dfn")
    ap.add_argument("--truth", default="data/pybamm/sop-truth.csv")
    ap.add_argument("--records", default=",".join(c[0] for c in CASES))
    ap.add_argument("--model", default="linear", choices=["linear", "butler-volmer", "auto"],
                    help="the cell model of the prior's fit and of the online run")
    a = ap.parse_args()
    if a.model != "linear" and a.truth == ap.get_default("truth"):
        sys.exit("--model other than linear: give --truth elsewhere (the committed truth is "
                 "the linear run's, which tests/tests/pybamm.rs judges)")
    model = ["--model", a.model]
    os.makedirs(a.out, exist_ok=True)
    meta = json.load(open("data/pybamm/meta.json"))["records"]
    truth_rows = []
    print("| record | row | pulse | predicted V | DFN V | error / drop |")
    print("|---|---|---|---|---|---|")
    for rec, vmin, instants, with_prior in [c for c in CASES if c[0] in a.records.split(",")]:
        cap = meta[rec]["capacity_ah"]
        cell = rec.split("-")[0]
        prior = []
        if with_prior:
            fit = os.path.join(a.out, f"{cell}-hppc-fit.json")
            subprocess.run([a.host_sim, "identify", "battery", "--input", f"data/pybamm/{cell}-hppc.csv",
                            "--ocv", f"data/pybamm/{cell}-ocv.csv", "--capacity-ah", str(cap),
                            *model, "--json", fit],
                           check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            prior = ["--prior", fit]
        data = read(f"data/pybamm/{rec}.csv")
        current = np.array([float(r["current_a"]) for r in data])
        track_path = os.path.join(a.out, f"{rec}.csv")
        subprocess.run([a.host_sim, "online", "battery", "--input", f"data/pybamm/{rec}.csv",
                        "--window", "256", "--ocv", f"data/pybamm/{cell}-ocv.csv",
                        "--capacity-ah", str(cap), "--horizons", "10,30",
                        "--voltage-min", str(vmin), "--current-limit", str(5 * cap),
                        *prior, *model, "--out", track_path],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        track = read(track_path)
        for want in instants:
            t0 = nearest_published(track, want, "pulse_v_30s")
            if t0 is None:
                print(f"| {rec} | {want} | nothing published within 200 rows | | | |")
                continue
            r = track[t0]
            v0 = float(data[t0]["voltage_true_v"])
            pulses = [(-cap, 30, {10: float(r["pulse_v_10s"]), 30: float(r["pulse_v_30s"])})]
            for h in (10, 30):
                i = -float(r[f"sop_discharge_a_{h}s"])
                pulses.append((i, h, {h: vmin}))
            for i, steps, predicted in pulses:
                profile = np.concatenate([current[: t0 + 1], np.full(steps, i)])
                v = simulate(PARAMETER_SETS[cell], profile, meta[rec]["soc0"])
                seg = v[t0 + 1:]
                truth_rows.append((rec, t0, i, steps, float(seg[-1]), float(seg.min())))
                for h, p in predicted.items():
                    got = seg[h - 1] if p != vmin else seg[:h].min()
                    drop = v0 - got
                    label = f"{i:.2f} A for {h} s" + (" (SOP)" if p == vmin else "")
                    print(f"| {rec} | {t0} | {label} | {p:.4f} | {got:.4f} | {abs(p - got) / abs(drop):.1%} |")
                    if p == vmin:
                        print(f"| | | the DFN's lowest above the limit | | {1e3 * (got - vmin):+.1f} mV "
                              f"| {(got - vmin) / abs(drop):+.1%} |")
                    if p != vmin and h == 10 and steps == 30:
                        truth_rows.append((rec, t0, i, 10, float(seg[9]), float(seg[:10].min())))
    # Rows of records not run this time are kept.
    kept = []
    if os.path.exists(a.truth):
        done = {r[0] for r in truth_rows}
        kept = [r for r in csv.reader(open(a.truth)) if r[0] != "record" and r[0] not in done]
    with open(a.truth, "w") as f:
        f.write("record,t0_s,current_a,steps,v_end,v_min\n")
        for row in kept:
            f.write(",".join(row) + "\n")
        for row in truth_rows:
            f.write("{},{},{:.9g},{},{:.6f},{:.6f}\n".format(*row))
    print(f"wrote {a.truth}")


if __name__ == "__main__":
    main()
