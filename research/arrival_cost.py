#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Does an arrival cost (the previous windows as a decaying prior) bring the online R_ct into the band?
# Answer: not on every record: prada2013-hppc 61 % -> 89 % at lambda 0.8, but chains drift to the order's bound (lambda 0.5); not adopted.
"""The previous window's estimate as a decaying prior: an arrival cost
(issue 35; docs/research.md, issue 35's table of R_ct candidates).

Moving-horizon estimation carries what the samples before a window said
into the window's fit as an *arrival cost*: a quadratic term around the
previous window's estimate, weighted by its information. A 256-sample
window then weighs its own samples and, through the arrival cost, the
ones before it, without storing them: a longer horizon at no cost in
state beyond the estimate and a 4x4 information matrix.

This script emulates it offline on the DFN HPPC records, in the core's
formulation of the window (research/same_window.py's `core_residuals`:
R_i + R_ct || CPE(Q, alpha), short memory M = 64, the first M - 1 rows'
polarization from the data, the OCV table at the track's counted SOC).
Windows of 256 samples end every 256 samples (chains from two offsets,
0 and 128, so each window's arrival cost summarizes exactly the samples
before it). Window j minimizes

    sum r(l)^2 + lambda * (x - x_{j-1})' A_{j-1} (x - x_{j-1})

over x = (ln R_i, ln R_ct, ln Q, alpha) and the OCV offset dU (which
has no arrival cost: it follows the SOC), where A_j is window j's
information over x with dU marginalized (the Schur complement), its
data part J'J widened for correlated residuals as the core widens its
intervals ((1 - rho)/(1 + rho), rho the residuals' lag-1
autocorrelation), plus lambda * A_{j-1}. lambda = 0 is the plain window.

A window identifies R_ct when its 95 % interval (posterior, the residual
variance times the inverse of the total information) is within a factor
2, as the core's test. Each line: per record and lambda, the windows
that identify R_ct and how many of them are within [0.5x, 2x] of the
per-SOC reference (the level's multi-start scipy fit,
bench/prior_free.py's `*-levels/reference-map.csv`). About two minutes.

    python3 bench/prior_free.py                  # tracks and references
    python3 research/arrival_cost.py [--tracks target/prior-free] [--lambdas 0,0.5,0.8,0.9,1]
    python3 research/arrival_cost.py --detail prada2013-hppc --lambdas 0,0.5,0.8   # one chain, window by window
"""

import argparse
import math
import os
import sys

import numpy as np
from scipy.optimize import least_squares

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(1, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "bench"))
import same_window as sw  # noqa: E402

Z95 = 1.959964


def information(jac, res, x_rows):
    """The data's widened J'J over all five coordinates and rho."""
    rho = float(np.dot(res[1:], res[:-1]) / max(np.dot(res, res), 1e-300))
    widen = (1.0 - max(0.0, min(rho, 0.999))) / (1.0 + max(0.0, min(rho, 0.999)))
    return jac[:x_rows].T @ jac[:x_rows] * widen, rho


def marginal(a5):
    """Information over the first four coordinates, dU (the last)
    marginalized."""
    a, b, c = a5[:4, :4], a5[:4, 4:], a5[4:, 4:]
    return a - b @ np.linalg.solve(c, b.T)


def chain(cur, y_all, ends, lam, online_start):
    """The windows ending at `ends`, each with the previous one's arrival
    cost; per window (end, x, identified)."""
    prev = None  # (x over 4 coordinates, information A over them)
    out = []
    for k in ends:
        i, y = cur[k - sw.WINDOW + 1:k + 1], y_all[k - sw.WINDOW + 1:k + 1]
        n = sw.WINDOW - (sw.MEMORY - 1)
        if not (np.all(np.isfinite(y)) and np.std(i[sw.MEMORY - 1:]) > 1e-3):
            continue  # not excited (the core's `not_excited`): the arrival cost waits

        if prev is not None and lam > 0:
            xp, ap = prev
            w, v = np.linalg.eigh(lam * ap)
            root = (v * np.sqrt(np.clip(w, 0.0, None))).T  # root' root = lam * ap

            def resid(p, root=root, xp=xp, i=i, y=y):
                return np.concatenate([sw.core_residuals(p, i, y), root @ (np.asarray(p[:4]) - xp)])
        else:
            root = None

            def resid(p, i=i, y=y):
                return sw.core_residuals(p, i, y)

        x0s = sw.starts(i, y, online_start(k))
        if prev is not None:
            x0s = [list(prev[0]) + [float(np.mean(y - math.exp(prev[0][0]) * i))]] + x0s[:1] + x0s[1::6]
        best = None
        for x0 in x0s:
            x0 = np.clip(np.array(x0, float), np.array(sw.LO) + 1e-3, np.array(sw.HI) - 1e-3)
            try:
                r = least_squares(resid, x0, bounds=(sw.LO, sw.HI), x_scale=[1, 1, 1, 0.1, 0.01], max_nfev=200)
            except (ValueError, FloatingPointError):
                continue
            if best is None or r.cost < best.cost:
                best = r
        x = best.x
        res = best.fun[:n]
        a5, _ = information(best.jac, res, n)
        a4 = marginal(a5)
        total = a4 + (lam * prev[1] if (prev is not None and lam > 0) else 0.0)
        s2 = float(np.dot(res, res)) / max(n - 5, 1)
        # The posterior over all five, for the interval of ln R_ct.
        full = a5.copy()
        if prev is not None and lam > 0:
            full[:4, :4] += lam * prev[1]
        try:
            cov = np.linalg.inv(full) * s2
            se = math.sqrt(max(cov[1, 1], 0.0))
        except np.linalg.LinAlgError:
            se = math.inf
        ident = x[1] < sw.AT_BOUND and Z95 * se <= math.log(2.0)
        out.append((k, x, ident))
        prev = (x[:4].copy(), total)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tracks", default="target/prior-free")
    ap.add_argument("--lambdas", default="0,0.5,0.8,0.9,1")
    ap.add_argument("--detail", metavar="RECORD",
                    help="instead, every window of the chain from offset 0 of RECORD (e.g. prada2013-hppc), per lambda")
    a = ap.parse_args()
    lambdas = [float(x) for x in a.lambdas.split(",")]
    for rec, ocv_path in sw.RECORDS:
        if a.detail and rec != a.detail:
            continue
        cur, y_all, track, soc, refs = sw.load_record(rec, ocv_path, a.tracks)
        ref = refs.__getitem__

        def online_start(k):
            r = track[k]
            try:
                return [math.log(sw.num(r["window_r_i"])), math.log(sw.num(r["window_r_ct"])),
                        math.log(sw.num(r["window_q"])), min(sw.num(r["window_alpha"]), 0.999),
                        sw.num(r["ocv_offset_v"])]
            except ValueError:
                return [math.nan] * 5

        if a.detail:
            ends = list(range(sw.WINDOW - 1 + 256, len(cur), sw.WINDOW))
            for lam in lambdas:
                for k, x, idf in chain(cur, y_all, ends, lam, online_start):
                    relax = (math.exp(x[1]) * math.exp(x[2])) ** (1.0 / x[3])
                    print(f"{rec} | lambda {lam:g} window ending {k} SOC {soc[k]:.3f}: R_i {math.exp(x[0]):.4f} "
                          f"R_ct {math.exp(x[1]):.4f} (reference {ref(k):.4f}) alpha {x[3]:.2f} "
                          f"relaxation {relax:.3g} s, {'identified' if idf else 'not identified'}", flush=True)
            continue
        for lam in lambdas:
            ident = inside = 0
            ratios = []
            for offset in (0, 64, 128, 192):
                ends = list(range(sw.WINDOW - 1 + offset + 256, len(cur), sw.WINDOW))
                for k, x, idf in chain(cur, y_all, ends, lam, online_start):
                    if not idf:
                        continue
                    ratio = math.exp(x[1]) / ref(k)
                    ident += 1
                    inside += 0.5 <= ratio <= 2.0
                    ratios.append(ratio)
            span = f" (ratios {min(ratios):.2f}..{max(ratios):.2f})" if ratios else ""
            print(f"{rec} | lambda {lam:g}: {ident} windows identify R_ct, {inside} within [0.5x, 2x] of the "
                  f"per-SOC reference{span}", flush=True)


if __name__ == "__main__":
    main()
