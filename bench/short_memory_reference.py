#!/usr/bin/env python3
"""Is the window's low R_ct its short memory? (issue 35; docs/real-cells.md,
"The whole-record fit is no reference".)

Each SOC level of the DFN HPPC records' per-SOC reference (the levels
`bench/prior_free.py` cuts, fitted by `bench/reference_map.py` with the
full Grunwald-Letnikov memory) fitted again, same rows and the same
multi-start grid, with the online window's memory of 64 samples
(`reference_fit.short_memory_filter`, from rest). One line per level:
both fits' R_ct, R_i, alpha and RMSE, and the ratio of the R_cts. About
two minutes.

    python3 bench/prior_free.py --out target/prior-free
    python3 bench/short_memory_reference.py
"""
import json
import math
import sys

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import lfilter
sys.path.insert(0, "bench")  # noqa: E402
import reference_fit as rf
for rec in ("prada2013-hppc", "chen2020-hppc"):
    d = f"target/prior-free/{rec}-levels"
    meta = json.load(open(f"{d}/levels.json")); ref = json.load(open(f"{d}/reference.json"))
    soc_pts, ocv_pts = np.loadtxt(f"{d}/ocv.csv", delimiter=",", skiprows=1, unpack=True)
    reflv = {x["file"]: x for x in ref["levels"]}
    for lv in meta["levels"]:
        t, i, v = np.loadtxt(f"{d}/{lv['file']}", delimiter=",", skiprows=1, unpack=True)
        h = lv.get("h", 1.0)
        _, y = rf.overpotential(i, v, h, soc_pts, ocv_pts, meta["capacity_ah"], lv["soc0"])
        def model(p, M=64):
            r_i, r_ct, q, alpha, du = math.exp(p[0]), math.exp(p[1]), math.exp(p[2]), p[3], p[4]
            return du + r_i * i + lfilter(*rf.short_memory_filter(h, r_ct, q, alpha, M), i)
        r_tot = max(abs(np.polyfit(i, y, 1)[0]), 1e-4)
        best = None
        for alpha in [0.3, 0.5, 0.7, 0.9, 1.0]:
            for relax in [3.0, 30.0, 300.0]:
                for ratio in [0.5, 2.0]:
                    r_i = r_tot / (1 + ratio); r_ct = r_tot - r_i
                    x0 = [math.log(r_i), math.log(r_ct), math.log(relax**alpha / r_ct), min(alpha, .999), float(np.mean(y - r_tot * i))]
                    try:
                        res = least_squares(lambda p: model(p) - y, x0, bounds=([-20,-20,-20,.05,-np.inf],[5,5,30,1,np.inf]), x_scale=[1,1,1,.1,.01], max_nfev=200)
                    except Exception:
                        continue
                    rm = math.sqrt(np.mean(res.fun**2))
                    if best is None or rm < best[0]: best = (rm, res.x)
        rm, p = best
        r = reflv[lv["file"]]
        rr = r.get("cpe", r)
        print(f"{rec} soc {lv['soc']:.2f}: short-memory R_ct {math.exp(p[1]):.4f} R_i {math.exp(p[0]):.4f} a {p[3]:.2f} rmse {rm*1e3:.2f} mV | full-memory R_ct {rr['r_ct']:.4f} R_i {rr['r_i']:.4f} a {rr['alpha']:.2f} rmse {rr['rmse_v']*1e3:.2f} mV | ratio {math.exp(p[1])/rr['r_ct']:.2f}", flush=True)
