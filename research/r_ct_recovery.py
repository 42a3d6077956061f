#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Can the last rest's recovered voltage tell a window's wrong R_ct from a right one?
# Answer: only on chen2020-hppc (100 % in band, 0 of 145 wrong windows pass); on the other records wrong windows pass as often as right ones; not adopted.
"""The last rest as a test of a window's R_ct (issue 35), emulated on the
tracks of bench/prior_free.py; and how well the per-SOC reference itself
determines R_ct (``--profile``).

Every test of one window's fit tried so far (its interval, its order at a
bound, its residuals, several windows' agreement) fails to find the wrong
R_ct: the wrong value is the window's own optimum (research/same_window.py).
This one looks outside the window. A rest after a load is a model-free
record of how the cell relaxes: the load's current (held for at least
``--min-load`` samples), the rest's length d (at least ``--min-rest``
samples, at most the window's 256) and the voltage it recovered,
``dU = U(end of load + d) - U(end of load)``. A window whose R_ct the core
marked ``identified`` passes when its own model (R_i, R_ct, Q, alpha, the
core's short memory of 64 samples, run from rest over the record's current
from the load's start to the rest's sample d) recovers the same voltage
within ``--tol`` (a factor ``1 + tol``), for the last such rest before the
window and within the SOC span a held value lives (0.15). The published
R_ct is then, as research/r_ct_gate.py emulates the core, the last passing
window's value held until the SOC moves by more than 0.15. Judged against
the same references as bench/prior_free.py: the per-SOC reference on the
DFN HPPC records, the whole-record fit on the drive cycles and the held-out
records, the per-SOC map on the Panasonic test (over all its samples, its
2 s periods rebuilt from the raw log as each period's mean current and
voltage, near what the resampler gives; no event across one of its gaps).
Each line also counts the identifying windows by verdict and by whether
their R_ct is inside the band ("right") or not ("wrong"), and by whether
the window holds such a rest itself (its first ``--min-rest`` samples).

    python3 bench/prior_free.py --out target/prior-free
    python3 research/r_ct_recovery.py [target/prior-free] [--tol 0.1] [--min-load 3] [--min-rest 60]
        [--branch --reach 0] [--settled C]
    python3 research/r_ct_recovery.py --profile target/prior-free/prada2013-hppc-levels   # about a minute

``--branch``: the test on the branch alone: the measured
recovery less the window's own ``R_i`` jump, ``dU + R_i I``, against its
model's branch over the same rest, within a factor ``1 + tol``; a
tolerance on the sum, which ``R_i`` dominates, is loose on ``R_ct``.
``--reach 0``: each rest used to its end, not cut at the window's 256
samples (the DFN HPPC records' rests after a discharge are 300 s).

``--settled C``: instead of the rest, a window identifies
``R_ct`` only when its fitted rows (after the history's first 63) hold a
current edge (a change of more than 5 % of the record's largest current)
followed by at least ``C`` times the window's own relaxation time
``(R_ct Q)^(1/alpha)`` of steady current: the branch's asymptote seen
settle, not extrapolated from the start of its answer.

``--profile``: each level of an HPPC record's per-SOC reference
(bench/reference_map.py's levels) fitted again with R_ct fixed at 0.5x and
2x of its best value, the other parameters free (13 starts each); the RMSE
against the best fit's, and the likelihood ratio the core's intervals
would take it by: ``n ln(RSS_f / RSS) (1 - rho) / (1 + rho)``, rho the best
fit's residuals' lag-1 autocorrelation (the widening of
``FitInformation::correlated_standard_errors``): under 3.84 (chi-square, 1
degree, 95 %), the level's own data do not exclude that R_ct either.
"""

import argparse
import csv
import json
import math
import os
import sys

import numpy as np
from scipy.signal import lfilter

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(1, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "bench"))
import reference_fit as rf  # noqa: E402
import reference_map as rm  # noqa: E402
from r_ct_gate import hold, judge, levels, num  # noqa: E402

MEMORY = 64
HOLD_SOC_SPAN = 0.15
PANASONIC = "data/panasonic-18650pf/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat"


def rests(i, v, logged, min_load, min_rest, reach=256):
    """Every rest after a load: dicts of a (the load's first sample), k (the
    rest's first), d (samples of rest used), dU, and at (the sample the
    test can first be made: k - 1 + d). No event spans a period without a
    logged sample (``logged`` False: a gap of the record)."""
    idle = np.abs(i) < 1e-6
    out, n, k = [], len(i), 1
    while k < n:
        if not (idle[k] and not idle[k - 1]):
            k += 1
            continue
        a = k - 1
        while a > 0 and not idle[a - 1]:
            a -= 1
        b = k
        while b < n and idle[b]:
            b += 1
        d = min(b - k, reach)
        if k - a >= min_load and b - k >= min_rest and np.all(logged[a:k + d]):
            out.append({"a": a, "k": k, "d": d, "at": k - 1 + d, "dU": v[k - 1 + d] - v[k - 1]})
        k = b
    return out


def recovered(e, i, h, r_i, r_ct, q, alpha):
    """The voltage the model y = R_i I + U_p (short memory) recovers over the
    rest of event e, run from rest at the load's start."""
    seg = i[e["a"]:e["at"] + 1]
    return r_i * (seg[-1] - seg[e["k"] - 1 - e["a"]]) + branch_recovered(e, i, h, r_ct, q, alpha)


def branch_recovered(e, i, h, r_ct, q, alpha):
    """The voltage the model's branch U_p alone (short memory) recovers
    over the rest of event e, run from rest at the load's start."""
    seg = i[e["a"]:e["at"] + 1]
    b, a = rf.short_memory_filter(h, r_ct, q, alpha, MEMORY)
    up = lfilter(b, a, seg)
    return up[-1] - up[e["k"] - 1 - e["a"]]


def settled_steps(i):
    """For every sample, the samples since the last current edge (a change
    of more than 5 % of the record's largest current; 0 at the edge)."""
    edge = 0.05 * np.max(np.abs(i))
    s = np.zeros(len(i), dtype=int)
    for k in range(1, len(i)):
        s[k] = 0 if abs(i[k] - i[k - 1]) > edge else s[k - 1] + 1
    return s


def settled_gate(rows, i, h, ref, c, window=256, memory=MEMORY):
    """The emulated published R_ct with the settling rule (``--settled``),
    and the identifying windows counted by verdict as ``gated`` does."""
    s = settled_steps(i)
    tested = {"right, pass": 0, "right, fail": 0, "wrong, pass": 0, "wrong, fail": 0}

    def take(k, r):
        if r["r_ct_status"] != "identified":
            return None
        p = [num(r[c_]) for c_ in ("window_r_i", "window_r_ct", "window_q", "window_alpha")]
        relax = (p[1] * p[2]) ** (1.0 / p[3]) * h
        lo = max(k - window + memory, 0)
        seen = max((s[j] for j in range(lo, k + 1) if s[j] <= j - lo), default=0)
        ok = seen * h >= c * relax
        right = 0.5 <= p[1] / ref[k] <= 2.0
        tested[("right" if right else "wrong") + (", pass" if ok else ", fail")] += 1
        return p[1] if ok else None

    return hold(rows, take), tested


def gated(rows, i, h, ev, tol, ref, branch=False):
    """The emulated published R_ct with the test, and the count of the
    identifying windows by verdict and by whether their R_ct is inside
    [0.5x, 2x] of the reference ("right") or not ("wrong")."""
    soc = np.array([num(r["soc"]) for r in rows])
    at = np.array([e["at"] for e in ev], dtype=int)
    tested = {"no rest": 0, "right, pass": 0, "right, fail": 0, "wrong, pass": 0, "wrong, fail": 0}

    def take(k, r):
        if r["r_ct_status"] != "identified":
            return None
        j = np.searchsorted(at, k, side="right") - 1
        if j < 0 or abs(soc[at[j]] - soc[k]) > HOLD_SOC_SPAN:
            tested["no rest"] += 1
            return None
        p = [num(r[c]) for c in ("window_r_i", "window_r_ct", "window_q", "window_alpha")]
        if branch:
            m = branch_recovered(ev[j], i, h, *p[1:])
            seen = ev[j]["dU"] + p[0] * i[ev[j]["k"] - 1]
        else:
            m, seen = recovered(ev[j], i, h, *p), ev[j]["dU"]
        ok = m * seen > 0 and abs(math.log(m / seen)) <= math.log(1.0 + tol)
        right = 0.5 <= p[1] / ref[k] <= 2.0
        tested[("right" if right else "wrong") + (", pass" if ok else ", fail")] += 1
        return p[1] if ok else None

    return hold(rows, take), tested


def dfn(out, rec, args):
    data = list(csv.DictReader(open(f"data/pybamm/{rec}.csv")))
    t, i, v = (np.array([float(r[c]) for r in data]) for c in ("time_s", "current_a", "voltage_v"))
    rows = list(csv.DictReader(open(f"{out}/{rec}.csv")))
    soc = np.array([num(r["soc"]) for r in rows])
    if rec.endswith("-hppc"):
        against, (ls, lr) = "the per-SOC reference", levels(f"{out}/{rec}-levels/reference-map.csv")
        ref = np.array([lr[np.argmin(np.abs(ls - z))] if np.isfinite(z) else np.nan for z in soc])
    else:
        doc = f"{out}/{rec}-reference.json" if rec.endswith("-soc") else "data/pybamm/reference.json"
        fit = json.load(open(doc))
        against, ref = "the whole-record fit", np.full(len(rows), (fit["cpe"] if rec.endswith("-soc") else fit[rec]["cpe"])["r_ct"])
    logged = np.ones(len(t), bool)
    report(rec, rows, i, 1.0, (rests(i, v, logged, args.min_load, args.min_rest, reach=reach(args)),
                               rests(i, v, logged, args.min_load, args.min_rest, reach=args.min_rest)),
           ref, against, args)


def panasonic(out, args):
    import scipy.io as sio

    meas = sio.loadmat(PANASONIC)["meas"][0, 0]
    t_raw, i_raw, v_raw = (meas[k].ravel() for k in ("Time", "Current", "Voltage"))
    rows = list(csv.DictReader(open(f"{out}/panasonic-track.csv")))
    t = np.array([num(r["time_s"]) for r in rows])
    h = float(np.median(np.diff(t)))
    lo, hi = np.searchsorted(t_raw, t), np.searchsorted(t_raw, t + h)
    n = np.maximum(hi - lo, 1)
    ci, cv = np.cumsum(np.r_[0.0, i_raw]), np.cumsum(np.r_[0.0, v_raw])
    i, v = (ci[hi] - ci[lo]) / n, (cv[hi] - cv[lo]) / n
    i[np.abs(i) < 0.02] = 0.0  # the logger's zero at rest
    soc = np.array([num(r["soc"]) for r in rows])
    ls, lr = levels(f"{out}/panasonic-map.csv")
    ref = np.array([lr[np.argmin(np.abs(ls - z))] if np.isfinite(z) else np.nan for z in soc])
    logged = hi > lo
    report("panasonic", rows, i, h, (rests(i, v, logged, args.min_load, args.min_rest, reach=reach(args)),
                                     rests(i, v, logged, args.min_load, args.min_rest, reach=args.min_rest)),
           ref, "the per-SOC map", args)


def inside(rows, ev, ref, window=256, memory=MEMORY):
    """The identifying windows that hold a rest of ``ev`` themselves (its
    load's end past the history's first ``memory`` rows, its first d
    samples, here ``--min-rest``, in the window), and those that do not:
    right and wrong in each."""
    ks, ends = np.array([e["k"] for e in ev], dtype=int), np.array([e["at"] for e in ev], dtype=int)
    out = {"a rest inside": [0, 0], "none inside": [0, 0]}
    for k, r in enumerate(rows):
        if r["r_ct_status"] != "identified":
            continue
        held = bool(np.any((ks >= k - window + memory) & (ends <= k)))
        right = 0.5 <= num(r["window_r_ct"]) / ref[k] <= 2.0
        out["a rest inside" if held else "none inside"][0 if right else 1] += 1
    return "; ".join(f"{key}: right {v[0]}, wrong {v[1]}" for key, v in out.items())


def reach(args):
    """The samples of each rest the test uses (``--reach``; 0: all)."""
    return args.reach if args.reach > 0 else 10 ** 12


def report(rec, rows, i, h, events, ref, against, args):
    """``events``: the rests up to the window's reach (the test's), and the
    same rests cut at ``--min-rest`` samples (``inside``'s)."""
    ev, ev_in = events
    today = hold(rows, lambda k, r: num(r["window_r_ct"]) if r["r_ct_status"] == "identified" else None)
    if args.settled is not None:
        g, tested = settled_gate(rows, i, h, ref, args.settled)
        print(f"{rec} | R_ct vs {against}: as the core judges: {judge(today, ref)} | with the settling rule"
              f" (C {args.settled:g}): {judge(g, ref)} | identifying windows: {tested}")
        return
    g, tested = gated(rows, i, h, ev, args.tol, ref, args.branch)
    what = "the branch's" if args.branch else "the sum's"
    print(f"{rec} | {len(ev)} rests after a load | R_ct vs {against}: as the core judges: {judge(today, ref)}"
          f" | with the last rest's test ({what}, tol {args.tol:g}, reach {args.reach or 'all'}): {judge(g, ref)}"
          f" | identifying windows: {tested} | windows by whether they hold such a rest: {inside(rows, ev_in, ref)}")


def profile(folder):
    meta = json.load(open(os.path.join(folder, "levels.json")))
    cap = float(meta["capacity_ah"])
    sp, op = rf.read_csv(os.path.join(folder, "ocv.csv"), ["soc", "ocv_v"])
    for lv in meta["levels"]:
        _, i, v, h = rm.read_level(os.path.join(folder, lv["file"]), lv.get("h"))
        _, y = rf.overpotential(i, v, h, sp, op, cap, float(lv["soc0"]))
        best = rf.fit_cpe(i, y, h)
        res = (best["ocv_offset_v"] + best["r_i"] * i
               + rf.cpe_branch(i, h, best["r_ct"], best["q"], best["alpha"]) - y)
        line = []
        for f in (0.5, 2.0):
            r_ct = best["r_ct"] * f

            def resid(p):
                return p[3] + math.exp(p[0]) * i + rf.cpe_branch(i, h, r_ct, math.exp(p[1]), p[2]) - y

            rmse, x = rf.fit_with_r_ct_fixed(resid, r_ct, math.log(best["r_i"]), math.log(best["q"]),
                                             best["alpha"], best["ocv_offset_v"])
            lr, rho = rf.widened_ratio(res, rmse)
            line.append(f"R_ct x{f:g}: RMSE {rmse * 1e3:.2f} mV ({100 * (rmse / best['rmse_v'] - 1):+.1f} %),"
                        f" R_i {math.exp(x[0]):.4f}, alpha {x[2]:.2f}, widened ratio {lr:.1f}")
        print(f"{folder} | SOC {float(lv['soc']):.3f}: R_i {best['r_i']:.4f}, R_ct {best['r_ct']:.4f}, alpha"
              f" {best['alpha']:.2f}, RMSE {best['rmse_v'] * 1e3:.2f} mV, lag-1 rho {rho:.3f} | " + "; ".join(line),
              flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", nargs="?", default="target/prior-free")
    ap.add_argument("--tol", type=float, default=0.1)
    ap.add_argument("--min-load", type=int, default=3)
    ap.add_argument("--min-rest", type=int, default=60)
    ap.add_argument("--branch", action="store_true", help="test the branch's recovery, not the sum's")
    ap.add_argument("--reach", type=int, default=256, help="samples of each rest used (0: all; default 256)")
    ap.add_argument("--settled", type=float, metavar="C", help="the settling rule instead of the rest's test")
    ap.add_argument("--profile", metavar="LEVELS_DIR")
    args = ap.parse_args()
    if args.profile:
        profile(args.profile)
        return
    for rec in ("chen2020-hppc", "prada2013-hppc", "chen2020-drive", "prada2013-drive", "chen2020-soc",
                "prada2013-soc"):
        dfn(args.out, rec, args)
    if os.path.exists(f"{args.out}/panasonic-track.csv"):
        panasonic(args.out, args)


if __name__ == "__main__":
    main()
