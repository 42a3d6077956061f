#!/usr/bin/env python3
"""Reference implementation of fracbms' 2S-OP-GI iteration on the battery
regression (paper §6.2; estimator-core/src/battery/regression.rs) in numpy.

It reads the same `time_s,current_a,voltage_v` file as
`host-sim identify battery --method paper`, runs the same iterations
(θ̂₀ = 1/p₀, α̂₀ = 0.5, M = min(256, L/2), stop at change ≤ 1e-7 or after
`--iterations`), and writes the same JSON keys (r_i, r_ct, q, alpha, u_oc,
history of k/alpha/cost). The fractional differences are matrix-vector
products over a sliding-window view, so numpy's BLAS does the O(L·M) work.

    python3 bench/paper_gi_numpy.py --input cell.csv --iterations 100 --json out.json

bench/compare.py runs this and host-sim side by side (results and times).
"""
import argparse
import json
import math
import sys
import time

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

P0 = 1e6
ALPHA0 = 0.5
ALPHA_MIN, ALPHA_MAX = 0.05, 1.0
EPSILON = 1e-7
MAX_HALVINGS = 12
MAX_ORDER_STEP = 0.05
MIN_CURRENT_STD = 1e-3
EPS = np.finfo(np.float64).eps


def weights(alpha, mem):
    """Grünwald–Letnikov weights w_j(α) and dw_j/dα, j < mem."""
    w = np.empty(mem)
    dw = np.empty(mem)
    w[0], dw[0] = 1.0, 0.0
    a1 = alpha + 1.0
    for j in range(1, mem):
        r = 1.0 - a1 / j
        w[j] = w[j - 1] * r
        dw[j] = dw[j - 1] * r - w[j - 1] / j
    return w, dw


class PaperGi:
    def __init__(self, i, v, h, mem):
        self.i, self.v, self.h, self.mem = i, v, h, mem
        self.ln_h = math.log(h)
        self.rows = slice(mem - 1, len(i))
        # Row l of the view holds x[l-M+1..=l]; reversed weights give Σ w_j x[l-j].
        self.iw = sliding_window_view(i, mem)
        self.vw = sliding_window_view(v, mem)
        self.theta = np.full(4, 1.0 / P0)
        self.set_order(ALPHA0)
        self.k = 0

    def set_order(self, alpha):
        self.alpha = alpha
        self.w, self.dw = weights(alpha, self.mem)
        self.g = math.exp(-alpha * self.ln_h)
        wr, dwr = self.w[::-1], self.dw[::-1]
        g, ln_h = self.g, self.ln_h
        vr = self.v[self.rows]
        d = g * (self.iw @ wr)
        self.di = d
        self.ddi = g * (self.iw @ dwr) - ln_h * d
        d = g * (self.vw @ wr)
        self.hv = d - g * vr
        self.dhv = g * (self.vw @ dwr) - ln_h * d + ln_h * g * vr

    def predict(self, th):
        return th[0] * self.i[self.rows] + th[1] * self.di - th[2] * self.hv + th[3]

    def residual(self):
        self.res = self.v[self.rows] - self.predict(self.theta)
        return 0.5 * float(self.res @ self.res)

    def trial_cost(self, alpha):
        w, _ = weights(alpha, self.mem)
        g = math.exp(-alpha * self.ln_h)
        th = self.theta
        z = th[1] * self.i - th[2] * self.v
        dz = g * (sliding_window_view(z, self.mem) @ w[::-1])
        ir, vr = self.i[self.rows], self.v[self.rows]
        r = vr - th[0] * ir - th[2] * g * vr - th[3] - dz
        return 0.5 * float(r @ r)

    def iterate(self):
        ir = self.i[self.rows]
        if np.std(ir) <= MIN_CURRENT_STD:
            raise RuntimeError("not excited")
        theta0 = self.theta.copy()
        alpha0 = self.alpha
        self.residual()
        r = self.res
        grad = np.array([ir @ r, self.di @ r, -(self.hv @ r), r.sum()])
        gg = float(grad @ grad)
        x = self.predict(grad)
        pg = float(x @ x)
        if gg > 0 and pg > 0:
            self.theta = self.theta + (gg / pg) * grad
        cost = self.residual()
        th = self.theta
        d = th[1] * self.ddi - th[2] * self.dhv
        dd = float(d @ d)
        dr = float(d @ self.res)
        rows = len(ir)
        # No trial whose Gauss-Newton predicted decrease dr*δ - dd*δ²/2 is
        # below the cost's rounding (eps*cost*sqrt(rows)).
        noise = EPS * cost * math.sqrt(rows)
        if dd > 0 and math.isfinite(dr) and dr != 0:
            step = max(-MAX_ORDER_STEP, min(MAX_ORDER_STEP, dr / dd))
            t = 1.0
            for _ in range(MAX_HALVINGS + 1):
                trial = max(ALPHA_MIN, min(ALPHA_MAX, alpha0 + t * step))
                if trial == alpha0:
                    break
                delta = trial - alpha0
                if not dr * delta - dd * delta * delta / 2.0 > noise:
                    break
                c = self.trial_cost(trial)
                if math.isfinite(c) and c < cost:
                    self.set_order(trial)
                    cost = c
                    break
                t /= 2.0
        self.k += 1
        change = np.linalg.norm(self.theta - theta0) / max(
            np.linalg.norm(theta0), np.finfo(np.float64).tiny
        ) + abs(self.alpha - alpha0)
        return cost, change <= EPSILON

    def cell(self):
        g, s_m = self.g, float(self.w.sum())
        t1, t2, t3, t4 = self.theta
        d = 1.0 - t3 * g
        if not (t3 > 0 and d > 0):
            return None
        tau = t3 / d
        r_i = t2 / t3
        r_ct = t1 / d - r_i
        p = dict(r_i=r_i, r_ct=r_ct, q=tau / r_ct, alpha=self.alpha,
                 u_oc=t4 * (1 + tau * g) / (1 + tau * g * s_m))
        ok = all(math.isfinite(p[k]) and p[k] > 0 for k in ("r_i", "r_ct", "q"))
        return p if ok and 0 < self.alpha < 2 and math.isfinite(p["u_oc"]) else None


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--input", required=True)
    ap.add_argument("--iterations", type=int, default=50)
    ap.add_argument("--memory", type=int)
    ap.add_argument("--json")
    a = ap.parse_args()
    try:
        data = np.loadtxt(a.input, delimiter=",", skiprows=1, usecols=(0, 1, 2), ndmin=2)
    except (OSError, ValueError) as e:
        sys.exit(f"error: {a.input}: {e}")
    t, i, v = data[:, 0], data[:, 1].copy(), data[:, 2].copy()
    h = float(np.median(np.diff(t)))
    n = len(i)
    mem = a.memory or max(1, min(256, n // 2))
    t0 = time.perf_counter()
    gi = PaperGi(i, v, h, mem)
    history = []
    for _ in range(a.iterations):
        cost, converged = gi.iterate()
        history.append(dict(k=gi.k, alpha=gi.alpha, cost=cost))
        if converged:
            break
    seconds = time.perf_counter() - t0
    cell = gi.cell()
    if cell is None:
        sys.exit(f"error: {a.input}: no physical estimate after {gi.k} iterations")
    out = dict(cell, iterations=gi.k, history=history, seconds_identify=seconds)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f)
    print(json.dumps({k: out[k] for k in ("r_i", "r_ct", "q", "alpha", "u_oc", "iterations")}))


if __name__ == "__main__":
    main()
