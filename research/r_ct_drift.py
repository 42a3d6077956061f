#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Does a wrong window R_ct move when the window's model gets a slow drift term (beta times the charge still to flow)?
# Answer: no: 4 of 16 wrong windows move into the band on chen2020-hppc, 2 of 16 on prada2013-hppc; not adopted.
"""Does a wrong online R_ct move when the window's model gets a slow
drift term? (issue 35; docs/research.md, the table of candidates.)

Windows drawn as research/same_window.py draws them (R_ct `identified`,
outside or inside [0.5x, 2x] of the per-SOC reference; 16 of each, seed 3), fitted again in the core's formulation (history from the data in
the first M - 1 rows), once as the core's model and once with a term
linear in the charge still to flow in the window, `beta c(l)` (the OCV
slope the core fits without a table; here beside the table), both by
scipy multi-start. A model error that a slow process makes would move
R_ct when the drift takes that process; one line per window with the
base and extended R_ct against the reference. About four minutes.

    python3 bench/prior_free.py --out target/prior-free   # the tracks and references
    python3 research/r_ct_drift.py
"""
import math
import os
import sys

import numpy as np
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "bench"))  # noqa: E402
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # noqa: E402
import same_window as sw
import reference_fit as rf
from scipy.signal import lfilter, lfiltic
WINDOW, MEMORY = 256, 64
LO = sw.LO + [-np.inf]; HI = sw.HI + [np.inf]
def core_ext(p, i, y, c):
    r_i, r_ct, q, alpha, du, beta = math.exp(p[0]), math.exp(p[1]), math.exp(p[2]), p[3], p[4], p[5]
    warm = MEMORY - 1
    b, a = rf.short_memory_filter(1.0, r_ct, q, alpha, MEMORY)
    past = (y[:warm] - du - beta * c[:warm] - r_i * i[:warm])[::-1]
    up, _ = lfilter(b, a, i[warm:], zi=lfiltic(b, a, past))
    return du + beta * c[warm:] + r_i * i[warm:] + up - y[warm:]


def main(per=16):
    rng = np.random.default_rng(3)
    for rec, ocv_path in sw.RECORDS:
        cur, y_all, track, soc, ref = sw.load_record(rec, ocv_path, "target/prior-free")
        ident = [k for k, r in enumerate(track) if r["r_ct_status"] == "identified" and k >= WINDOW]
        inside = lambda k, v: 0.5 <= v / ref[k] <= 2.0
        groups = {"wrong": [k for k in ident if not inside(k, sw.num(track[k]["window_r_ct"]))],
                  "right": [k for k in ident if inside(k, sw.num(track[k]["window_r_ct"]))]}
        for tag, ks in groups.items():
            picked = sorted(rng.choice(ks, min(per, len(ks)), replace=False)) if ks else []
            for k in picked:
                r = track[k]
                online = [math.log(sw.num(r["window_r_i"])), math.log(sw.num(r["window_r_ct"])),
                          math.log(sw.num(r["window_q"])), min(sw.num(r["window_alpha"]), 0.999), sw.num(r["ocv_offset_v"])]
                i, y = cur[k - WINDOW + 1:k + 1], y_all[k - WINDOW + 1:k + 1]
                c = np.cumsum(i[::-1])[::-1] / 3600.0  # A h still to flow, ~ the core's c
                base = sw.best(lambda p: sw.core_residuals(p, i, y), sw.starts(i, y, online))
                starts = [list(s) + [0.0] for s in sw.starts(i, y, online)] + [list(base) + [0.0]]
                (_, p, _), _ = rf.multistart(lambda p: core_ext(p, i, y, c), [(None, x0) for x0 in starts], LO, HI, [1, 1, 1, 0.1, 0.01, 0.01])
                rb, re = math.exp(base[1]), math.exp(p[1])
                print(f"{rec} {tag} k={k} soc={soc[k]:.2f} base={rb/ref[k]:.2f}x ext={re/ref[k]:.2f}x ext/base={re/rb:.2f} beta={p[5]:.3f}", flush=True)

if __name__ == "__main__":
    main()
