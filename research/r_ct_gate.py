#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Do two R_ct gates, the order at its bound and the consensus of two windows, remove the wrong online R_ct?
# Answer: only a little (chen2020-hppc 89.9 % -> 91.7 % and 91.2 %, prada2013-hppc 51.5 % -> 56.8 % and 62.3 %); wrong windows agree; not adopted.
"""Two candidate R_ct gates, emulated on the tracks of bench/prior_free.py
(issue 35; docs/research.md, "The order at its bound; consensus").

The windows that identify a wrong R_ct on the DFN HPPC records are mostly
fits whose order sits at its bound (alpha = alpha_max = 1, an integer-order
RC of 20 s): at a bound the information matrix's interval, which the core's
`identified` test uses, is not the parameter's. The gate: such a window does
not identify R_ct. Emulated from the track: the published R_ct is the last
window value that the core marked `identified` (or `prior`) and that passes
the gate, held until the SOC moves by more than 0.15 (the core's
`hold_soc_span`). The second gate, consensus: a window's R_ct is
published only when an earlier window at least 256 samples before it (no
overlap), within the same SOC span, identified one within a factor 1.5.
Every row, without and with a gate, is emulated the same way, so they compare with each other (the DFN rows without the gate
reproduce bench/prior_free.py's per-SOC figures; the Panasonic row here is
over all samples against the map, not only after the first pulse group).

    python3 bench/prior_free.py --out target/prior-free
    python3 research/r_ct_gate.py target/prior-free
"""

import csv
import json
import sys

import numpy as np

ALPHA_AT_BOUND = 0.9999  # alpha_max = 1 in every run here
HOLD_SOC_SPAN = 0.15


def num(x):
    try:
        return float(x)
    except ValueError:
        return np.nan


def hold(rows, take):
    """The published R_ct: the last value `take(k, row)` gives (None: no
    new value), or a `prior` window's, held until the SOC moves by more
    than HOLD_SOC_SPAN from where it was taken."""
    out = np.full(len(rows), np.nan)
    cur = csoc = None
    for k, r in enumerate(rows):
        soc = num(r["soc"])
        v = take(k, r)
        if v is None and r["r_ct_status"] == "prior":
            v = num(r["window_r_ct"])
        if v is not None:
            cur, csoc = v, soc
        if cur is not None and np.isfinite(soc) and np.isfinite(csoc) and abs(soc - csoc) > HOLD_SOC_SPAN:
            cur = None
        out[k] = np.nan if cur is None else cur
    return out


def emulate(rows, gate):
    return hold(rows, lambda k, r: num(r["window_r_ct"]) if r["r_ct_status"] == "identified" and gate(r) else None)


def consensus(rows, sep=256, factor=1.5):
    seen = []  # (sample, value, soc) of every identifying window

    def take(k, r):
        if r["r_ct_status"] != "identified":
            return None
        v, soc = num(r["window_r_ct"]), num(r["soc"])
        agreed = any(k - kk >= sep and abs(np.log(v / vv)) <= np.log(factor) and abs(soc - ss) <= HOLD_SOC_SPAN
                     for kk, vv, ss in seen)
        seen.append((k, v, soc))
        return v if agreed else None

    return hold(rows, take)


def judge(values, ref):
    pub = np.isfinite(values)
    r = values[pub] / ref[pub]
    inside = (r >= 0.5) & (r <= 2.0)
    if not r.size:
        return f"published {pub.mean():.1%}"
    return f"published {pub.mean():.1%}, within [0.5x, 2x] {inside.mean():.1%} (ratios {r.min():.2f}..{r.max():.2f})"


def levels(path):
    m = list(csv.DictReader(open(path)))
    return np.array([num(x["soc"]) for x in m]), np.array([num(x["r_ct"]) for x in m])


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "target/prior-free"
    ref = json.load(open("data/pybamm/reference.json"))
    gates = {
        "as the core judges": lambda r: True,
        "and alpha not at its bound": lambda r: num(r["window_alpha"]) < ALPHA_AT_BOUND,
    }
    for rec in ("chen2020-hppc", "prada2013-hppc", "chen2020-drive", "prada2013-drive", "panasonic-track"):
        rows = list(csv.DictReader(open(f"{out}/{rec}.csv")))
        soc = np.array([num(r["soc"]) for r in rows])
        if rec == "panasonic-track":
            against, (ls, lr) = "the per-SOC map", levels(f"{out}/panasonic-map.csv")
        elif rec.endswith("-hppc"):
            against, (ls, lr) = "the per-SOC reference", levels(f"{out}/{rec}-levels/reference-map.csv")
        else:
            against, ls = "the whole-record fit", None
        if ls is None:
            refv = np.full(len(rows), ref[rec]["cpe"]["r_ct"])
        else:
            refv = np.array([lr[np.argmin(np.abs(ls - z))] if np.isfinite(z) else np.nan for z in soc])
        ident = np.array([r["r_ct_status"] == "identified" for r in rows])
        at = ident & np.array([num(r["window_alpha"]) >= ALPHA_AT_BOUND for r in rows])
        print(f"{rec} | windows identifying R_ct: {ident.sum()}, alpha at its bound in {at.sum()}")
        for name, gate in gates.items():
            print(f"{rec} | R_ct vs {against}, {name}: {judge(emulate(rows, gate), refv)}")
        print(f"{rec} | R_ct vs {against}, by consensus of two windows: {judge(consensus(rows), refv)}")


if __name__ == "__main__":
    main()
