#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Would publishing each pack window's R_ct and Q at another order (the pack's, the cell's own) keep every cell within ±10 %?
# Answer: the pack's order does, where the cells share it; a cell's own order does not (its windows' errors run together); see "One order for a pack's cells".
"""Emulates, from the tracks of `python3 bench/pack_slow_part.py --memories 0
--out DIR` (each window's own values, `window_*`), the slow part published
at another order, and prints how the windows' `ln Q` and `ln R_ct` move with
their order.

    python3 research/pack_order_emulation.py DIR [--memory-s 600]

Slopes: each window's error in `ln Q` (`ln R_ct`) against its order's error,
a least-squares line over all windows of the three seeds (against the
truth), and within each cell (each cell's windows about their own means: no
truth needed). Emulation: each identified window's `ln R_ct` and `ln Q`
moved by the truth-based slope times (order − window's order), then fused
as `--slow-memory-s` does with equal weights (a mean forgetting by
`exp(−Δt/S)`), for the order taken as: `none` (the window's own, today's
rule), `pack` (the running mean of every cell's window orders, forgetting
the same way), `cell` (the cell's own running mean) and `cell-whole` (the
cell's mean of all its windows so far). Prints, per profile and rule, the
rows within ±10 % of the truth pooled and for the worst cell.
"""
import argparse
import csv
import json
import math

import numpy as np

CELLS = range(1, 9)
SEEDS = (1, 2, 3)


def windows(d, prof, seed):
    truth = {c["cell"]: c for c in json.load(open(f"{d}/{prof}-{seed}.json"))["cells"]}
    rows = list(csv.DictReader(open(f"{d}/{prof}-{seed}-slow0-track.csv")))
    return truth, rows


def identified(r):
    return r["window_q"] and r["window_alpha"] and r["window_r_ct"] and r["q_status"] == "identified"


def slopes(d, prof):
    x, q, rc = [], [], []
    wx, wq, wr = [], [], []
    for seed in SEEDS:
        truth, rows = windows(d, prof, seed)
        for c in CELLS:
            rs = [r for r in rows if int(r["cell"]) == c and identified(r)]
            a = np.array([float(r["window_alpha"]) for r in rs])
            lq = np.log([float(r["window_q"]) for r in rs])
            lr = np.log([float(r["window_r_ct"]) for r in rs])
            x += list(a - truth[c]["alpha"])
            q += list(lq - math.log(truth[c]["q"]))
            rc += list(lr - math.log(truth[c]["r_ct"]))
            wx += list(a - a.mean())
            wq += list(lq - lq.mean())
            wr += list(lr - lr.mean())
    x, wx = np.array(x), np.array(wx)
    return (np.dot(x, q) / np.dot(x, x), np.dot(x, rc) / np.dot(x, x),
            np.dot(wx, wq) / np.dot(wx, wx), np.dot(wx, wr) / np.dot(wx, wx))


def emulate(d, prof, rule, s_q, s_r, memory):
    pooled = {"q": [0, 0], "r_ct": [0, 0]}
    worst = {"q": 1.0, "r_ct": 1.0}
    for seed in SEEDS:
        truth, rows = windows(d, prof, seed)
        pack = [0.0, 0.0, None]
        own = {c: [0.0, 0.0, None] for c in CELLS}
        whole = {c: [0.0, 0] for c in CELLS}
        fused = {c: {"q": [0.0, 0.0], "r_ct": [0.0, 0.0], "t": None} for c in CELLS}
        count = {c: {"q": [0, 0], "r_ct": [0, 0]} for c in CELLS}

        def age(m, t):
            if m[2] is not None:
                k = math.exp(-(t - m[2]) / memory)
                m[0] *= k
                m[1] *= k
            m[2] = t

        for r in rows:
            c, t = int(r["cell"]), float(r["time_s"])
            f = fused[c]
            if identified(r):
                a = float(r["window_alpha"])
                for m in (pack, own[c]):
                    age(m, t)
                    m[0] += a
                    m[1] += 1
                whole[c][0] += a
                whole[c][1] += 1
                order = {"none": a, "pack": pack[0] / pack[1], "cell": own[c][0] / own[c][1],
                         "cell-whole": whole[c][0] / whole[c][1]}[rule]
                if f["t"] is not None:
                    k = math.exp(-(t - f["t"]) / memory)
                    for p in ("q", "r_ct"):
                        f[p][0] *= k
                        f[p][1] *= k
                f["t"] = t
                f["q"][0] += math.log(float(r["window_q"])) + s_q * (order - a)
                f["r_ct"][0] += math.log(float(r["window_r_ct"])) + s_r * (order - a)
                f["q"][1] += 1
                f["r_ct"][1] += 1
            if f["t"] is None:
                continue
            for p in ("q", "r_ct"):
                v = math.exp(f[p][0] / f[p][1])
                count[c][p][1] += 1
                count[c][p][0] += abs(v / truth[c][p] - 1) <= 0.10
        for c in CELLS:
            for p in ("q", "r_ct"):
                w, n = count[c][p]
                pooled[p][0] += w
                pooled[p][1] += n
                worst[p] = min(worst[p], w / max(n, 1))
    return pooled, worst


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--memory-s", type=float, default=600.0)
    a = ap.parse_args()
    print("| profile | order | Q pooled | Q worst cell | R_ct pooled | R_ct worst cell |")
    print("|---|---|---|---|---|---|")
    for prof in ("hppc", "drive"):
        s_q, s_r, w_q, w_r = slopes(a.dir, prof)
        print(f"<!-- {prof}: d ln Q / d alpha {s_q:.2f} (within cells {w_q:.2f}), "
              f"d ln R_ct / d alpha {s_r:.2f} (within cells {w_r:.2f}) -->")
        for rule in ("none", "pack", "cell", "cell-whole"):
            pooled, worst = emulate(a.dir, prof, rule, s_q, s_r, a.memory_s)
            cell = lambda p: f"{100 * pooled[p][0] / pooled[p][1]:.1f} % | {100 * worst[p]:.1f} %"
            print(f"| {prof} | {rule} | {cell('q')} | {cell('r_ct')} |")


if __name__ == "__main__":
    main()
