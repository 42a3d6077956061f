#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Can any estimator hold the pack's Q within ±10 % of its truth from a cell's first identified window on, on the data of docs/pack.md?
# Answer: not from one window's data (the exact fit of a window's rows: worst cell 57-73 % of the first 600 s; 256 rows: 70-80 %); from all the data so far, 90-100 %; a moving horizon with an arrival cost, 73-90 %; see docs/research.md, "The same data fitted exactly".
"""The best the pack records' data allow for Q, beside what `online pack`
publishes, over the first `--span-s` seconds after each cell's first
identified Q (where the bench's rows outside ±10 % lie).

For every cell of the records of `python3 bench/pack_slow_part.py`
(default `--out`, after it ran with `--memories` including the one
given here), at every `--every-s` seconds from the cell's first identified
Q in its `--slow-memory-s` track: the exact model (the full-memory
Grünwald–Letnikov recursion that simulated the record, noise aside)
fitted by least squares, its `U_oc`, `R_i` and `R_ct` by linear least
squares for each `(τ = R_ct·Q, α)`, and those two multi-started on a
grid and polished (scipy), on

* the last `--window` − 63 samples (`rows`: the rows the estimator's
  window fits once it has slid, its first 63 the history of its memory
  of 64; here that history and the whole past are the exact model's),
* the last `--window` samples (`window`: the whole window, the past
  known exactly: the best a window can do), and
* every sample so far (`growing`: the best any causal estimate can do).

Prints, per profile, the share of those instants whose Q is within
±10 % of the truth, pooled and for the worst cell, for the three fits
and for the track's published Q at the same instants (a line per cell
first).

    python3 bench/pack_slow_part.py --memories 0,200,400,600
    python3 research/pack_q_reference.py [--dir target/pack-slow-part] [--slow-memory-s 600] [--every-s 10] [--span-s 600] [--window 256] [--arrival]

(`--window 512` after `python3 bench/pack_slow_part.py --window 512 --out
DIR` with `--dir DIR`.)

`--arrival` adds a column: a moving-horizon estimate, the exact model
fitted every `--every-s` seconds to the rows a slid window fits (the
past known exactly) with an arrival cost, a quadratic prior at the last
estimate that carries the information (`JᵀJ/σ²` at the estimate) of
every row that has left the window, from the record's start.

`--spot PROFILE,SEED,CELL[,CELL…]` prints instead, for those cells at
272, 300, 350 and 400 s (`--at`), the track's window `Q` (`--slow-memory-s`
0's track) beside the exact fits of the window's 256 and 193 rows and a
fit of its 193 rows whose history is read from the voltages as the
estimator reads it (`U_p = U_t − U_oc − R_i·I` for every sample before
them, the full-memory recursion after): each as its error against the
truth.
"""

import argparse
import csv
import json

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import lfilter

MEMORY = 64


def unit_branch(i, tau, alpha, h):
    """The branch's voltage for R_ct = 1: the recursion of the simulator."""
    n = len(i)
    w = np.cumprod(np.r_[1.0, 1.0 - (alpha + 1.0) / np.arange(1, n)])
    a = tau * h ** (-alpha)
    den = a * w
    den[0] = 1.0 + a
    return lfilter([1.0], den, i)


def fit(i, v, lo, hi, h, warm=None):
    """(Q, x) of the least-squares fit on rows lo..hi (the past from 0
    known), multi-started on a grid of (ln τ, α) and at `warm`."""
    ii, iv = i[:hi], v[lo:hi]

    def linear(x):
        tau, alpha = np.exp(x[0]), x[1]
        g = unit_branch(ii, tau, alpha, h)[lo:hi]
        a = np.column_stack([np.ones(hi - lo), ii[lo:hi], g])
        coef, *_ = np.linalg.lstsq(a, iv, rcond=None)
        return coef, a @ coef - iv

    best = None
    starts = [[lt, al] for al in (0.5, 0.9) for lt in np.log([2.0, 20.0])]
    if warm is not None:
        starts.append(list(warm))
    for x0 in starts:
        r = least_squares(lambda x: linear(x)[1], x0,
                          bounds=([np.log(0.01), 0.05], [np.log(1e4), 1.0]))
        if best is None or r.cost < best.cost:
            best = r
    coef, _ = linear(best.x)
    r_ct = coef[2]
    return (np.exp(best.x[0]) / r_ct if r_ct > 0 else float("nan")), best.x


def arrival_track(i, v, rows_fitted, every, h, stop, sigma=0.001):
    """Sample index -> Q of the moving-horizon estimate with an arrival cost,
    up to the sample index `stop`."""
    step = max(1, int(round(every / h)))
    x = np.array([float(np.median(v)), 0.01, np.log(0.01), np.log(5.0), 0.6])
    info, center = np.zeros((5, 5)), x.copy()
    out = {}
    for hi in range(rows_fitted, min(stop + step, len(i) + 1), step):
        lo = hi - rows_fitted
        chol = np.linalg.cholesky(info + 1e-12 * np.eye(5)).T if info.any() else None

        def res(y):
            r_ct, tau, alpha = np.exp(y[2]), np.exp(y[3]), y[4]
            r = (y[0] + y[1] * i[lo:hi] + r_ct * unit_branch(i[:hi], tau, alpha, h)[lo:hi] - v[lo:hi]) / sigma
            return r if chol is None else np.r_[r, chol @ (y - center)]

        best = None
        for y0 in (x, center):
            r = least_squares(res, y0, bounds=([-np.inf, 0, -20, -10, 0.05], [np.inf, 1, 5, 12, 1.0]))
            if best is None or r.cost < best.cost:
                best = r
        x = best.x
        out[hi] = np.exp(x[3] - x[2])
        leaving = best.jac[:step]
        info, center = info + leaving.T @ leaving, x.copy()
    return out


def fit_history_from_data(i, v, lo, hi, c):
    """Q of the fit of rows lo..hi whose polarization before lo is read from
    the voltages, started at the truth and two other points."""

    def model(x):
        u_oc, r_i, r_ct, tau, alpha = x[0], x[1], np.exp(x[2]), np.exp(x[3]), x[4]
        w = np.cumprod(np.r_[1.0, 1.0 - (alpha + 1.0) / np.arange(1, hi)])
        up = np.empty(hi)
        up[:lo] = v[:lo] - u_oc - r_i * i[:lo]
        for k in range(lo, hi):
            up[k] = (r_ct * i[k] - tau * np.dot(w[1:k + 1], up[k - 1::-1])) / (1 + tau)
        return (u_oc + r_i * i[:hi] + up - v[:hi])[lo:]

    x0 = [c["u_oc"], c["r_i"], np.log(c["r_ct"]), np.log(c["r_ct"] * c["q"]), c["alpha"]]
    best = None
    for dx in (0.0, 0.3, -0.3):
        start = [x0[0], x0[1], x0[2] + dx, x0[3] - dx, c["alpha"] - dx / 2]
        r = least_squares(model, start, bounds=([-np.inf, 0, -20, -10, 0.05], [np.inf, 1, 5, 12, 1.0]))
        if best is None or r.cost < best.cost:
            best = r
    return np.exp(best.x[3] - best.x[2])


def spot(a):
    profile, seed, *cells = a.spot.split(",")
    rows = list(csv.DictReader(open(f"{a.dir}/{profile}-{seed}.csv")))
    t = np.array([float(r["time_s"]) for r in rows])
    i = np.array([float(r["current_a"]) for r in rows])
    truth = {c["cell"]: c for c in json.load(open(f"{a.dir}/{profile}-{seed}.json"))["cells"]}
    track = {(int(r["cell"]), float(r["time_s"])): r["window_q"]
             for r in csv.DictReader(open(f"{a.dir}/{profile}-{seed}-slow0-track.csv"))}
    rows_fitted = a.window - (MEMORY - 1)
    print("| cell | t (s) | window's Q | exact fit, 256 rows | exact, 193 rows | 193 rows, history from the voltages |")
    print("|---|---|---|---|---|---|")
    for cell in map(int, cells):
        c = truth[cell]
        v = np.array([float(r[f"cell_{cell}_v"]) for r in rows])
        for at in map(float, a.at.split(",")):
            hi = int(np.searchsorted(t, at, side="right"))
            w = track.get((cell, float(t[hi - 1])), "")
            errs = [float(w) / c["q"] - 1 if w else float("nan")]
            errs.append(fit(i, v, hi - a.window, hi, t[1] - t[0])[0] / c["q"] - 1)
            errs.append(fit(i, v, hi - rows_fitted, hi, t[1] - t[0])[0] / c["q"] - 1)
            errs.append(fit_history_from_data(i, v, hi - rows_fitted, hi, c) / c["q"] - 1)
            print(f"| {cell} | {at:.0f} | " + " | ".join(f"{100 * e:+.1f} %" for e in errs) + " |",
                  flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dir", default="target/pack-slow-part")
    ap.add_argument("--profiles", default="hppc,drive")
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--slow-memory-s", default="600")
    ap.add_argument("--every-s", type=float, default=10.0)
    ap.add_argument("--span-s", type=float, default=600.0)
    ap.add_argument("--window", type=int, default=256)
    ap.add_argument("--spot", default=None)
    ap.add_argument("--arrival", action="store_true")
    ap.add_argument("--at", default="272,300,350,400")
    a = ap.parse_args()
    if a.spot:
        return spot(a)
    rows_fitted = a.window - (MEMORY - 1)
    print(f"| profile | published (`--window {a.window} --slow-memory-s {a.slow_memory_s}`) | exact fit, "
          f"last {rows_fitted} samples | last {a.window} | every sample so far |"
          + (" moving horizon, arrival cost |" if a.arrival else ""))
    print("|---|---|---|---|---|" + ("---|" if a.arrival else ""))
    for profile in a.profiles.split(","):
        kinds = ("ours", "rows", "window", "growing") + (("arrival",) if a.arrival else ())
        tot = {k: [0, 0, []] for k in kinds}
        for seed in a.seeds.split(","):
            rows = list(csv.DictReader(open(f"{a.dir}/{profile}-{seed}.csv")))
            t = np.array([float(r["time_s"]) for r in rows])
            i = np.array([float(r["current_a"]) for r in rows])
            h = t[1] - t[0]
            truth = {c["cell"]: c for c in json.load(open(f"{a.dir}/{profile}-{seed}.json"))["cells"]}
            track = {}
            for r in csv.DictReader(open(f"{a.dir}/{profile}-{seed}-slow{a.slow_memory_s}-track.csv")):
                track.setdefault(int(r["cell"]), []).append(r)
            for cell, c in truth.items():
                v = np.array([float(r[f"cell_{cell}_v"]) for r in rows])
                first = next((float(r["time_s"]) for r in track[cell] if r["q_status"] == "identified"), None)
                if first is None:
                    continue
                published = {float(r["time_s"]): r["q"] for r in track[cell]}
                counts = {k: [0, 0] for k in tot}
                warm = {}
                stop = int(np.searchsorted(t, first + a.span_s, side="right"))
                moving = arrival_track(i, v, rows_fitted, a.every_s, h, stop) if a.arrival else {}
                for at in np.arange(first, min(first + a.span_s, t[-1]), a.every_s):
                    hi = int(np.searchsorted(t, at, side="right"))
                    q_ours = published.get(float(t[hi - 1]), "")
                    ok = {"ours": bool(q_ours) and abs(float(q_ours) / c["q"] - 1) <= 0.10}
                    for k, lo in (("rows", max(0, hi - rows_fitted)), ("window", max(0, hi - a.window)),
                                  ("growing", 0)):
                        q, warm[k] = fit(i, v, lo, hi, h, warm.get(k))
                        ok[k] = abs(q / c["q"] - 1) <= 0.10
                    if a.arrival:
                        q = moving[max((n for n in moving if n <= hi), default=min(moving))]
                        ok["arrival"] = abs(q / c["q"] - 1) <= 0.10
                    for k in tot:
                        counts[k][0] += ok[k]
                        counts[k][1] += 1
                for k in tot:
                    tot[k][0] += counts[k][0]
                    tot[k][1] += counts[k][1]
                    tot[k][2].append(counts[k][0] / counts[k][1])
                print(f"  ({profile} {seed} cell {cell}: " + ", ".join(
                    f"{k} {100 * counts[k][0] / counts[k][1]:.0f} %" for k in tot) + ")", flush=True)
        cols = [f"{100 * w / n:.1f} % (worst cell {100 * min(p):.1f} %)" for w, n, p in tot.values()]
        print(f"| {profile} | " + " | ".join(cols) + " |", flush=True)


if __name__ == "__main__":
    main()
