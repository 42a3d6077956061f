#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Does a resistance read from each NASA B0005 discharge's load step (the step extrapolated back through the fractional branch's early power law) rank with EIS Re at the 0.8?
# Answer: no reading is both at 0.8 and robust: on B0005 a sqrt(t) line over the first 3 loaded rows reaches 0.80 and falls to 0.68 over 10, the fractional power law (alpha free) 0.75-0.79 over 6-15 rows; on B0018 (run with its folder, bench/nasa_cell.py) the same readings rank at -0.81 and -0.84 to 0.22 where the crude baseline gives 0.79; not built.
"""Resistance over life from the load step alone (issue 70, "r_i ... its
Spearman rank correlation with EIS Re ... >= 0.8"; docs/research.md,
"A cell's resistance from its load steps").

Each of B0005's 168 discharge logs starts with two rested rows, then 2 A.
Its rows are 9.4-19 s apart, so the first loaded row holds R_i's step and
10-19 s of the polarization's rise. Three readings of the step, each
against EIS Re (and Re + Rct) linear in time at the log's start
(metadata.csv):

* the crude baseline: the voltage step over the current step at the first
  loaded row (bench/life_nasa.py's);
* the loaded voltage over the first m loaded rows, a line in sqrt(t - t0),
  extrapolated to t0 (the step taken at the last rested row, or halfway to
  the first loaded one);
* the fractional branch's early response, a + b (t - t0)^alpha with alpha
  free (t0 halfway), with and without a linear drift (the OCV falling),
  over m rows.

    python3 research/life_step_resistance.py [DATA]   (default data/nasa-pcoe-b0005;
        another cell laid out by bench/nasa_cell.py)
"""

import os
import sys

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import spearmanr

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "bench"))
from life_nasa import impedance, metadata  # noqa: E402

DATA = sys.argv[1] if len(sys.argv) > 1 else "data/nasa-pcoe-b0005"


def logs():
    meta = metadata(DATA)
    by = {r["filename"]: r for r in meta if r["type"] == "discharge"}
    ti, re, rct = impedance(meta)
    names = sorted(by, key=lambda n: by[n]["t"])
    t = np.array([by[n]["t"] for n in names])
    out = []
    for n in names:
        d = np.genfromtxt(f"{DATA}/discharge/{n}", delimiter=",", names=True)
        out.append((d["Time"], d["Current_measured"], d["Voltage_measured"]))
    return out, np.interp(t, ti, re), np.interp(t, ti, re + rct)


def step(tt, i, v):
    k = int(np.argmax(np.abs(i) > 1.0))
    return k, tt[k - 1], tt[k]


def baseline(tt, i, v):
    k, _, _ = step(tt, i, v)
    return (v[k] - v[k - 1]) / (i[k] - i[k - 1])


def sqrt_line(m, frac):
    def f(tt, i, v):
        k, t0, t1 = step(tt, i, v)
        ts = t0 + frac * (t1 - t0)
        p = np.polyfit(np.sqrt(tt[k:k + m] - ts), v[k:k + m], 1)
        return (p[1] - v[k - 1]) / (i[k:k + m].mean() - i[k - 1])
    return f


def power_law(m, drift):
    def f(tt, i, v):
        k, t0, t1 = step(tt, i, v)
        x = tt[k:k + m] - (t0 + 0.5 * (t1 - t0))
        y = v[k:k + m]

        def res(p):
            return p[0] + p[1] * x ** p[2] + (p[3] * x if drift else 0.0) - y
        lo, hi, p0 = [0, -1, 0.05], [5, 0, 1.0], [y[0], -0.01, 0.5]
        if drift:
            lo, hi, p0 = lo + [-1e-3], hi + [0], p0 + [-1e-5]
        r = least_squares(res, p0, bounds=(lo, hi))
        return (r.x[0] - v[k - 1]) / (i[k:k + m].mean() - i[k - 1])
    return f


def main():
    data, re_t, rr_t = logs()
    print(f"{os.path.basename(os.path.normpath(DATA))}: {len(data)} discharges; EIS Re {re_t.min():.4f}-{re_t.max():.4f} ohm over them")
    print()
    print("| reading of the load step | Spearman with Re | with Re + Rct | growth (last 10 / first 10) |")
    print("|---|---|---|---|")
    rows = [("crude baseline: ΔV/ΔI at the first loaded row", baseline)]
    rows += [(f"sqrt(t) line over {m} loaded rows, step at the last rested row", sqrt_line(m, 0.0))
             for m in (3, 5, 10)]
    rows += [(f"sqrt(t) line over {m} loaded rows, step halfway", sqrt_line(m, 0.5)) for m in (3, 10)]
    rows += [(f"power law, alpha free, over {m} rows", power_law(m, False)) for m in (6, 10, 15)]
    rows += [(f"power law and a drift, over {m} rows", power_law(m, True)) for m in (8, 10, 15, 20)]
    for name, f in rows:
        x = np.array([f(*d) for d in data])
        print(f"| {name} | {spearmanr(x, re_t)[0]:.3f} | {spearmanr(x, rr_t)[0]:.3f} | "
              f"{x[-10:].mean() / x[:10].mean():.3f} |")
    # The logging interval at the step: the test changed it part way.
    dt = np.array([(lambda k: tt[k] - tt[k - 1])(step(tt, i, v)[0]) for tt, i, v in data])
    short = dt < 12.0
    base = np.array([baseline(*d) for d in data])
    print()
    print(f"interval at the step: {dt[~short].min():.1f}-{dt[~short].max():.1f} s in {(~short).sum()} logs "
          f"(the first {np.argmax(short)} among them), {dt[short].min():.1f}-{dt[short].max():.1f} s "
          f"in {short.sum()}; the baseline within the short-interval logs: "
          f"Spearman {spearmanr(base[short], re_t[short])[0]:.3f} with Re, "
          f"{spearmanr(base[short], rr_t[short])[0]:.3f} with Re + Rct; "
          f"mean {base[~short].mean():.4f} ohm in the long-interval logs, {base[short][:10].mean():.4f} "
          f"in the first ten short ones")


if __name__ == "__main__":
    main()
