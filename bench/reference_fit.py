#!/usr/bin/env python3
"""The best achievable fit of a record: an independent multi-start reference.

What the estimator's whole-record fit (``host-sim identify battery``) is
judged against. Written apart from the Rust code (numpy + scipy), with the
same conventions:

* SOC after row l: ``soc(l) = soc0 + h * sum_{k<=l} I(k) / (3600 C)``, soc0
  from the mean voltage of the first rested rows (|I| <= C/100, at most 10)
  through the inverse of the piecewise-linear OCV table;
* overpotential ``y(l) = V(l) - OCV(soc(l))``;
* the paper's model from rest with FULL Grunwald-Letnikov memory:
  ``y = dU + R_i I + U_p``, ``(1 + a) U_p(l) = R_ct I(l) - a sum_{j=1..l} w_j
  U_p(l-j)``, ``a = R_ct Q h^-alpha``, ``w_0 = 1``,
  ``w_j = w_{j-1} (1 - (alpha + 1)/j)``;
* integer-order Thevenin models with one and two RC pairs (exact
  zero-order-hold discretisation) for comparison.

Each model is fitted by ``scipy.optimize.least_squares`` (resistances and Q
in logarithms) from a grid of starts (for the constant-phase model: alpha in
{0.3, 0.5, 0.7, 0.9, 1.0} x relaxation time tau^(1/alpha) in {3, 30, 300} s
x R_ct/R_i in {0.5, 2}); the best free-run RMSE is the reference.

Usage::

    python3 bench/reference_fit.py data/pybamm/chen2020-drive.csv \
        --ocv data/pybamm/chen2020-ocv.csv --capacity-ah 5.1532 [--json out.json]

Without ``--ocv`` the OCV is a constant (fitted as dU). Needs numpy and scipy.

``python3 bench/reference_fit.py --all data/pybamm`` fits every record of
that folder (``meta.json`` gives the capacities) with its OCV table and
without it, and writes ``reference.json`` there (about 5 minutes).
"""

import argparse
import json
import math
import time

import numpy as np
from scipy.optimize import least_squares


def read_csv(path, names):
    with open(path) as f:
        header = f.readline().strip().split(",")
    idx = [header.index(n) for n in names]
    data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=idx, ndmin=2)
    return [data[:, k] for k in range(len(names))]


def gl_weights(alpha, n):
    w = np.empty(n)
    w[0] = 1.0
    for j in range(1, n):
        w[j] = w[j - 1] * (1.0 - (alpha + 1.0) / j)
    return w


def cpe_polarization(i, h, r_ct, q, alpha):
    """U_p of R_ct || CPE(Q, alpha) from rest, full memory."""
    n = len(i)
    w = gl_weights(alpha, n)
    a = r_ct * q * h ** (-alpha)
    up = np.zeros(n)
    wr = w[1:][::-1]  # wr[-j] = w_j
    for l in range(n):
        hist = np.dot(wr[n - 1 - l:], up[:l]) if l > 0 else 0.0
        up[l] = (r_ct * i[l] - a * hist) / (1.0 + a)
    return up


def rc_polarization(i, h, r, tau):
    """One RC pair, exact for a current held over each sample period."""
    e = math.exp(-h / tau)
    up = np.zeros(len(i))
    x = 0.0
    for l, il in enumerate(i):
        x = e * x + r * (1.0 - e) * il
        up[l] = x
    return up


def fit_cpe(i, y, h):
    def model(p):
        r_i, r_ct, q, alpha, du = math.exp(p[0]), math.exp(p[1]), math.exp(p[2]), p[3], p[4]
        return du + r_i * i + cpe_polarization(i, h, r_ct, q, alpha)

    # A rough total resistance from the data: y ~ dU + R I.
    r_tot = max(abs(np.polyfit(i, y, 1)[0]), 1e-4)
    best = None
    minima = []
    for alpha in [0.3, 0.5, 0.7, 0.9, 1.0]:
        for relax in [3.0, 30.0, 300.0]:
            for ratio in [0.5, 2.0]:
                r_i = r_tot / (1.0 + ratio)
                r_ct = r_tot - r_i
                q = relax**alpha / r_ct
                x0 = [math.log(r_i), math.log(r_ct), math.log(q), min(alpha, 0.999), float(np.mean(y - r_tot * i))]
                try:
                    res = least_squares(
                        lambda p: model(p) - y,
                        x0,
                        bounds=([-20, -20, -20, 0.05, -np.inf], [5, 5, 30, 1.0, np.inf]),
                        x_scale=[1, 1, 1, 0.1, 0.01],
                        max_nfev=200,
                    )
                except (ValueError, FloatingPointError):
                    continue
                rmse = math.sqrt(np.mean(res.fun**2))
                minima.append(rmse)
                if best is None or rmse < best[0]:
                    best = (rmse, res.x, (alpha, relax, ratio))
    rmse, p, start = best
    return {
        "rmse_v": rmse,
        "r_i": math.exp(p[0]),
        "r_ct": math.exp(p[1]),
        "q": math.exp(p[2]),
        "alpha": p[3],
        "ocv_offset_v": p[4],
        "winning_start": {"alpha": start[0], "relaxation_s": start[1], "r_ct_over_r_i": start[2]},
        "local_minima_rmse_v": sorted(set(round(m, 7) for m in minima)),
    }


def fit_rc(i, y, h, pairs):
    def model(p):
        out = p[0] + math.exp(p[1]) * i
        for k in range(pairs):
            out = out + rc_polarization(i, h, math.exp(p[2 + 2 * k]), math.exp(p[3 + 2 * k]))
        return out

    r_tot = max(abs(np.polyfit(i, y, 1)[0]), 1e-4)
    best = None
    taus = [[3.0], [30.0], [300.0]] if pairs == 1 else [[3.0, 60.0], [10.0, 300.0], [1.0, 30.0]]
    for tau in taus:
        x0 = [float(np.mean(y - r_tot * i)), math.log(r_tot / 2)]
        for t in tau:
            x0 += [math.log(r_tot / (2 * pairs)), math.log(t)]
        res = least_squares(lambda p: model(p) - y, x0, max_nfev=300)
        rmse = math.sqrt(np.mean(res.fun**2))
        if best is None or rmse < best[0]:
            best = (rmse, res.x)
    rmse, p = best
    out = {"rmse_v": rmse, "ocv_offset_v": p[0], "r_i": math.exp(p[1])}
    for k in range(pairs):
        out[f"r_{k + 1}"] = math.exp(p[2 + 2 * k])
        out[f"tau_{k + 1}_s"] = math.exp(p[3 + 2 * k])
    return out


def fit_all(folder):
    """Every record of a folder made by bench/pybamm_data.py, with and
    without its OCV table, into ``reference.json``."""
    from pathlib import Path

    folder = Path(folder)
    meta = json.load(open(folder / "meta.json"))
    out = {}
    for name in sorted(meta["records"]):
        cell = name.split("-")[0]
        cap = meta["ocv"][cell]["capacity_ah"]
        rec = str(folder / f"{name}.csv")
        print(f"== {name} (OCV table, C = {cap:.4f} A h)")
        out[name] = fit_record(rec, str(folder / f"{cell}-ocv.csv"), cap)
        print(f"== {name} (no table)")
        out[f"{name}-no-table"] = fit_record(rec, None, None)
    with open(folder / "reference.json", "w") as f:
        json.dump(out, f, indent=2)
        f.write("\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("record", nargs="?")
    ap.add_argument("--ocv")
    ap.add_argument("--capacity-ah", type=float)
    ap.add_argument("--json")
    ap.add_argument("--all", help="fit every record of this folder into its reference.json")
    a = ap.parse_args()
    if a.all:
        fit_all(a.all)
        return
    if not a.record:
        ap.error("a record, or --all FOLDER")
    out = fit_record(a.record, a.ocv, a.capacity_ah)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=2)
            f.write("\n")


def fit_record(record, ocv_path, capacity_ah):
    t, i, v = read_csv(record, ["time_s", "current_a", "voltage_v"])
    h = float(t[1] - t[0])
    out = {"record": record, "rows": len(t)}
    if ocv_path:
        soc_pts, ocv_pts = read_csv(ocv_path, ["soc", "ocv_v"])
        c = capacity_ah
        rest = np.abs(i[:10]) <= c / 100.0
        n_rest = int(np.argmin(rest)) if not rest.all() else 10
        if n_rest == 0:
            raise SystemExit("the record does not start at rest")
        soc0 = float(np.interp(np.mean(v[:n_rest]), ocv_pts, soc_pts))
        soc = soc0 + h * np.cumsum(i) / (3600.0 * c)
        y = v - np.interp(soc, soc_pts, ocv_pts)
        out.update({"soc0": soc0, "soc_end": float(soc[-1])})
    else:
        y = v.copy()
    t0 = time.time()
    out["cpe"] = fit_cpe(i, y, h)
    out["rc1"] = fit_rc(i, y, h, 1)
    out["rc2"] = fit_rc(i, y, h, 2)
    out["seconds"] = round(time.time() - t0, 1)
    for k in ["cpe", "rc1", "rc2"]:
        m = out[k]
        extra = ", ".join(f"{n} {x:.6g}" for n, x in m.items() if n not in ("rmse_v", "local_minima_rmse_v", "winning_start"))
        print(f"{k:4s} RMSE {1e3 * m['rmse_v']:.3f} mV  {extra}")
    print(f"CPE starts: best from {out['cpe']['winning_start']}; local minima (mV): "
          f"{[round(1e3 * x, 3) for x in out['cpe']['local_minima_rmse_v']][:8]}")
    return out


if __name__ == "__main__":
    main()
