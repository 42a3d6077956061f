#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Is the online window's low R_ct caused by its 64-sample short memory?
# Answer: no: the per-SOC levels fitted with the short memory give an R_ct 0.96-1.45x the full-memory one, higher, where the wrong windows are lower.
"""Is the window's low R_ct its short memory? (issue 35; docs/research.md,
"The window's short memory".)

Each SOC level of the DFN HPPC records' per-SOC reference (the levels
`bench/prior_free.py` cuts, fitted by `bench/reference_map.py` with the
full Grunwald-Letnikov memory) fitted again, same rows and the same
multi-start grid, with the online window's memory of 64 samples
(`reference_fit.short_memory_filter`, from rest). One line per level:
both fits' R_ct, R_i, alpha and RMSE, and the ratio of the R_cts. About
two minutes.

    python3 bench/prior_free.py --out target/prior-free
    python3 research/short_memory_reference.py
"""
import json
import math
import os
import sys

import numpy as np
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "bench"))  # noqa: E402
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # noqa: E402
import reference_fit as rf


def main():
    for rec in ("prada2013-hppc", "chen2020-hppc"):
        d = f"target/prior-free/{rec}-levels"
        meta = json.load(open(f"{d}/levels.json"))
        ref = json.load(open(f"{d}/reference.json"))
        soc_pts, ocv_pts = np.loadtxt(f"{d}/ocv.csv", delimiter=",", skiprows=1, unpack=True)
        reflv = {x["file"]: x for x in ref["levels"]}
        for lv in meta["levels"]:
            _, i, v = np.loadtxt(f"{d}/{lv['file']}", delimiter=",", skiprows=1, unpack=True)
            h = lv.get("h", 1.0)
            _, y = rf.overpotential(i, v, h, soc_pts, ocv_pts, meta["capacity_ah"], lv["soc0"])
            fit = rf.fit_cpe(i, y, h, memory=64)
            r = reflv[lv["file"]]
            rr = r.get("cpe", r)
            print(f"{rec} soc {lv['soc']:.2f}: short-memory R_ct {fit['r_ct']:.4f} R_i {fit['r_i']:.4f} "
                  f"a {fit['alpha']:.2f} rmse {fit['rmse_v'] * 1e3:.2f} mV | full-memory R_ct {rr['r_ct']:.4f} "
                  f"R_i {rr['r_i']:.4f} a {rr['alpha']:.2f} rmse {rr['rmse_v'] * 1e3:.2f} mV | "
                  f"ratio {fit['r_ct'] / rr['r_ct']:.2f}", flush=True)


if __name__ == "__main__":
    main()
