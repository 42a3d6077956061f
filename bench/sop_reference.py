#!/usr/bin/env python3
"""What the best fitted model can do on the DFN state-of-power truth
(issue 36): a reference for the `pulse_v_{10,30}s` goal (error <= 10 % of
the pulse's drop), made without our estimator.

For every 1C row of the committed truth (data/pybamm/sop-truth.csv, made by
bench/sop_dfn.py with PyBaMM: the DFN continued from row t0 of a record with
a constant 1C discharge), each whole-record fit of the same record in
data/pybamm/reference.json (the independent scipy multi-start fits of
bench/reference_fit.py: the constant-phase model ``cpe`` as ours, with the
Butler-Volmer term ``cpe_bv``, and the integer-order ``rc1``, ``rc2``,
``rc1_bv``) is run with full memory over the record's own current up to
t0 and then the pulse, through the same OCV table and counted SOC
(bench/reference_fit.py's conventions). Printed per row and model, as a
fraction of the DFN's drop (its true voltage at t0 minus the pulse's last):

* ``free``: the model's voltage at the pulse's end against the DFN's;
* ``anchored``: the model's change over the pulse added to the voltage
  measured at t0 (the record's noisy ``voltage_v``, as a BMS reads it);
* the DFN's true voltage at t0 less the ``cpe`` fit's, and each record's
  whole-record RMSE per model.

These fits have seen the whole record (the pulse's own SOC range
included), so they are an optimistic bound on what a model of that
structure predicts from the same history, not a product.

    python3 bench/sop_reference.py      # needs numpy and scipy
"""

import csv
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from reference_fit import bv, cpe_branch, read_csv, rc_polarization  # noqa: E402

MODELS = ("cpe", "cpe_bv", "rc1", "rc2", "rc1_bv")


def model_y(name, p, i, h):
    """The overpotential y = V - OCV(SOC) of fit `p` (reference_fit.py's
    models) on the current i, from rest."""
    y = p["ocv_offset_v"] + p["r_i"] * i
    if name.startswith("cpe"):
        y = y + cpe_branch(i, h, p["r_ct"], p["q"], p["alpha"])
    else:
        y = y + rc_polarization(i, h, p["r_1"], p["tau_1_s"])
        if "r_2" in p:
            y = y + rc_polarization(i, h, p["r_2"], p["tau_2_s"])
    if name.endswith("_bv"):
        y = y + bv(i, p["bv_a_v"], p["bv_i0_a"])
    return y


def main():
    ref = json.load(open("data/pybamm/reference.json"))
    meta = json.load(open("data/pybamm/meta.json"))["records"]
    truth = list(csv.DictReader(open("data/pybamm/sop-truth.csv")))
    worst = {m: {"free": [], "anchored": []} for m in MODELS}
    print("record | t0 | s | drop mV | " + " | ".join(f"{m} free, anchored" for m in MODELS))
    for rec in ("chen2020-hppc", "chen2020-drive", "prada2013-hppc", "prada2013-drive"):
        cap = meta[rec]["capacity_ah"]
        cell = rec.split("-")[0]
        t, i, v, vt = read_csv(f"data/pybamm/{rec}.csv", ["time_s", "current_a", "voltage_v", "voltage_true_v"])
        h = float(t[1] - t[0])
        soc_pts, ocv_pts = read_csv(f"data/pybamm/{cell}-ocv.csv", ["soc", "ocv_v"])
        r = ref[rec]
        print(f"{rec}: whole-record RMSE " + ", ".join(f"{m} {1e3 * r[m]['rmse_v']:.1f} mV" for m in MODELS))
        for row in truth:
            if row["record"] != rec or abs(float(row["current_a"]) + cap) > 1e-6 * cap:
                continue
            t0, n = int(row["t0_s"]), int(row["steps"])
            pulse = float(row["current_a"])
            cur = np.concatenate([i[: t0 + 1], np.full(n, pulse)])
            soc = r["soc0"] + h * np.cumsum(cur) / (3600.0 * cap)
            ocv = np.interp(soc, soc_pts, ocv_pts)
            drop = vt[t0] - float(row["v_end"])
            cells = []
            for m in MODELS:
                vm = ocv + model_y(m, r[m], cur, h)
                if m == "cpe":
                    at_t0 = vt[t0] - vm[t0]
                free = abs(vm[-1] - float(row["v_end"])) / drop
                anchored = abs(v[t0] + vm[-1] - vm[t0] - float(row["v_end"])) / drop
                worst[m]["free"].append(free)
                worst[m]["anchored"].append(anchored)
                cells.append(f"{free:.1%}, {anchored:.1%}")
            print(f"{rec} | {t0} | {n} | {1e3 * drop:.0f} | " + " | ".join(cells)
                  + f" | DFN - cpe at t0 {1e3 * at_t0:+.1f} mV")
    for m in MODELS:
        f, a = np.array(worst[m]["free"]), np.array(worst[m]["anchored"])
        print(f"{m}: within 10 % of the drop: free {np.sum(f <= 0.1)} of {f.size} (median {np.median(f):.1%},"
              f" worst {f.max():.1%}); anchored {np.sum(a <= 0.1)} of {a.size} (median {np.median(a):.1%},"
              f" worst {a.max():.1%})")


if __name__ == "__main__":
    main()
