#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Without a prior, would the second pulse group's first pulses of the Chen2020 DFN HPPC record be predicted within 10 % if the first identified window's own parameters, run back over the first group's pulse of the same current, gave the correction ratio the check could not measure then?
# Answer: yes in this emulation: the 2C pulse at 10 s -23.8 -> +5.2 % of its drop, the 1C pulse +13.5 -> -2.8 % at 10 s and +13.3 -> -4.0 % at 30 s; built for pulses from a relaxed cell (the 2C one; the 1C one follows the charge pulse by 40 s): docs/state-of-power.md, "A record's first pulses, before any fit".
"""A correction ratio from the first fit's own pulses, emulated (issue 72;
docs/state-of-power.md, "A record's first pulses, before any fit").

Without a prior the first pulse group of an HPPC record comes before any
fit, so the check (`PulseCheck`) has no prediction to set it against and
leaves no ratio; the second group's first pulses are then the model's
own. Here, for each pulse current of the Chen2020 DFN HPPC record (1 s),
the parameters `online battery` publishes just before the second group's
pulse of that current (the acceptance's track, no prior) are run over the
record from its rested start with the full-memory Grünwald–Letnikov
recursion (as `estimator_core::battery::simulate`), and the first
group's pulse of the same current is set against the measured one at
each horizon: `r` = measured / modelled drop. The build's own pulse
voltage before the second group's pulse is then scaled by `r`, as the
check's ratio scales it (`u0 − r·(u0 − pulse_v)`), and both misses are
printed as % of the measured drop (+: the drop underpredicted).

    cargo build --release -p host-sim
    python3 bench/sop_pulses.py --acceptance          # target/sop
    python3 research/sop_first_fit_hindcast.py [--out target/sop]
"""

import argparse
import csv

import numpy as np

RECORD = "data/pybamm/chen2020-hppc.csv"
GROUP_GAP_S = 400.0


def branch(current, r_ct, q, alpha, h=1.0):
    """The CPE branch's voltage from rest (full memory)."""
    n = len(current)
    w = np.ones(n)
    for j in range(1, n):
        w[j] = w[j - 1] * (1 - (alpha + 1) / j)
    a = r_ct * q * h ** (-alpha)
    up = np.zeros(n)
    for k in range(n):
        hist = np.dot(w[1:k + 1], up[k - 1::-1]) if k > 0 else 0.0
        up[k] = (r_ct * current[k] - a * hist) / (1 + a)
    return up


def edges(i):
    """Rows where a discharge pulse starts (from no current)."""
    return [k for k in range(1, len(i)) if i[k] < -1.0 and abs(i[k - 1]) < 0.05]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="target/sop")
    a = ap.parse_args()
    rows = list(csv.DictReader(open(RECORD)))
    i = np.array([float(r["current_a"]) for r in rows])
    v = np.array([float(r["voltage_v"]) for r in rows])
    es = edges(i)
    first_group = [e for e in es if e < es[0] + GROUP_GAP_S]
    later = [e for e in es if e >= es[0] + GROUP_GAP_S]
    print("| pulse | horizon | the build's miss | ratio from the first group's pulse | corrected miss |")
    print("|---|---|---|---|---|")
    for e1 in first_group:
        cur = i[e1]
        e2 = next(e for e in later if abs(i[e] - cur) < 0.01)
        track = {int(float(r["time_s"])): r
                 for r in csv.DictReader(open(f"{a.out}/chen2020-hppc/pulse-{-cur:.2f}-none.csv"))}
        x = track[e2 - 1]
        ri, rct, q, alpha = (float(x[k]) for k in ("r_i", "r_ct", "q", "alpha"))
        seg = i[:e1 + 31]
        model = ri * seg + branch(seg, rct, q, alpha)
        for h in (10, 30):
            if not x.get(f"pulse_v_{h}s") or abs(i[e2 + h - 1] - cur) > 0.01:
                continue
            ratio = (v[e1 - 1] - v[e1 - 1 + h]) / (model[e1 - 1] - model[e1 - 1 + h])
            predicted = v[e2 - 1] - float(x[f"pulse_v_{h}s"])
            measured = v[e2 - 1] - v[e2 - 1 + h]
            print(f"| {cur:.2f} A at {e2} s | {h} s | {100 * (measured - predicted) / measured:+.1f} % | "
                  f"{ratio:.3f} | {100 * (measured - ratio * predicted) / measured:+.1f} % |")


if __name__ == "__main__":
    main()
