#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Would a second, slower (block-averaged) window fitting the branch, with R_i from the fast window, bring R_ct into the band?
# Answer: not on the LFP record: prada2013-hppc 79.9 % at D = 2, worse as D grows (55.9 % at D = 4); not built.
"""Two windows (emulated): R_i from the fast window, the branch from a slow one.

Go / no-go for a second, slower online window (docs/research.md, "Two
windows, emulated"): the fast window at the record's period gives R_i (the
``r_i`` column of ``host-sim online battery``); a slow window of 256
samples of the same data block-averaged by a factor D (period D h, D times
the horizon) fits only the constant-phase branch (ln R_ct, ln Q, alpha, dU)
with R_i FIXED. Emulated in numpy / scipy (not our Rust code), with
bench/reference_fit.py's branch (``cpe_branch``: full Grunwald-Letnikov
memory, current charge-positive, y = V - OCV(SOC)):

* every 16 s of record time, the slow window ending there is fitted by
  ``least_squares`` (alpha in [0.2, 1]; warm start from the previous
  window, three extra starts on the first); the branch runs with full
  memory from the start of the record's gap-free segment (decimated), so the
  window's initial branch state is the model's own: a best case for the
  state, which the firmware's short memory does not have;
* R_ct is identified as our core judges it: s^2 = sum r^2 / (n - p),
  cov = s^2 (J'J)^-1 over (ln R_ct, ln Q, alpha, dU[, ln R_i]), standard
  errors widened by sqrt((1 + rho)/(1 - rho)) (rho the residuals' lag-1
  autocorrelation clipped to [0, 0.99]), 1.96 SE(ln R_ct) <= ln 2; alpha in
  (0, 1], R_ct off its bounds, the relaxation time (R_ct Q)^(1/alpha)
  within the window's span. The published R_ct is the last identified one,
  held;
* variants: A, R_i fixed at the fast track's published R_i (held; windows
  before the first are skipped); B, R_i free; C, R_i fixed at the per-SOC
  reference's (an oracle).

Judged as bench/prior_free.py judges the one-window track: every sample of
the record (DFN HPPC: 1 s; Panasonic: the 0.5 s track) against the per-SOC
reference level nearest the track's SOC (DFN: target/prior-free/<rec>-levels/
reference-map.csv; Panasonic: target/prior-free/panasonic-map.csv, all
levels and its identifiable ones, samples after the first pulse group).
Prints, per record, variant and D: the evaluated windows and the fraction
with R_ct identified, the fraction of samples after the first slow window
with a published R_ct (DFN: also of all samples, as the baseline counts),
and the fraction of published values within [0.5x, 2x] of the reference
(ratios min..median..max). Per-window fits go to <out>/windows-*.csv.

    python3 bench/prior_free.py           # target/prior-free (references)
    python3 research/two_window.py [--host-sim target/release/host-sim] [--out target/two-window]
        [--only chen2020-hppc,prada2013-hppc,panasonic] [--runs A2,A4,A8,B4,C4]

The fast tracks are ``host-sim online battery --window 256`` (Panasonic:
``--period 0.5``), run into --out unless there. One core: the DFN runs
take 6-16 s each; a Panasonic run with ``--every 64`` 70-300 s (about 4x
that at the default 16 s, since its windows run up to 100 evaluations over
up to 3 700 samples of memory). The numbers of the first study:

    python3 research/two_window.py --only chen2020-hppc,prada2013-hppc --runs A2,A4,A8,B4,C4,A4s
    python3 research/two_window.py --only panasonic --runs A4,A8,C4 --every 64
"""

import argparse
import csv
import json
import math
import os
import subprocess
import sys
import time

import numpy as np
from scipy.optimize import least_squares

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(1, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "bench"))
from reference_fit import cpe_branch, read_csv  # noqa: E402

PANASONIC = "data/panasonic-18650pf/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat"
PAN_OCV = "target/real-cells/panasonic/ocv.csv"
PAN_PERIOD = 0.5
WINDOW = 256
EVERY = [16.0]  # s of record between slow windows (--every)
LN2 = math.log(2.0)
# ln R_ct, ln Q, alpha, dU, ln R_i: reference_fit's bounds, alpha >= 0.2.
# (The OCV slope k, V/A h, of the variants with ``s``.)
LO = np.array([-20.0, -20.0, 0.2, -np.inf, -20.0, -np.inf])
HI = np.array([5.0, 30.0, 1.0, np.inf, 5.0, np.inf])
SCALE = np.array([1.0, 1.0, 0.1, 0.01, 1.0, 0.01])


def run(cmd):
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def track(path):
    import pandas as pd

    d = pd.read_csv(path, usecols=["time_s", "r_i", "r_ct", "soc"])
    return {k: d[k].to_numpy(float) for k in d.columns}


def ffill(x):
    idx = np.where(np.isfinite(x), np.arange(len(x)), -1)
    idx = np.maximum.accumulate(idx)
    out = np.where(idx >= 0, x[np.maximum(idx, 0)], np.nan)
    return out


def levels(path):
    """A per-SOC map's soc, r_i, r_ct and identifiable columns."""
    rows = list(csv.DictReader(open(path)))
    out = {k: np.array([float(r[k]) for r in rows]) for k in ("soc", "r_i", "r_ct")}
    out["identifiable"] = np.array([r["identifiable"] == "true" for r in rows])
    return out


def nearest(lsoc, soc):
    return np.array([np.argmin(np.abs(lsoc - z)) if np.isfinite(z) else 0 for z in soc])


# --------------------------------------------------------------- records


def dfn_record(rec, hs, out):
    """A DFN HPPC record at its 1 s period: current, y = V - OCV(counted
    SOC from meta.json's soc0), the fast track, the per-SOC reference."""
    meta = json.load(open("data/pybamm/meta.json"))["records"][rec]
    cell = rec.split("-")[0]
    ocv = f"data/pybamm/{cell}-ocv.csv"
    tpath = f"{out}/{rec}-track.csv"
    if not os.path.exists(tpath):
        run([hs, "online", "battery", "--input", f"data/pybamm/{rec}.csv", "--window", str(WINDOW),
             "--ocv", ocv, "--capacity-ah", str(meta["capacity_ah"]), "--out", tpath])
    t, i, v = read_csv(f"data/pybamm/{rec}.csv", ["time_s", "current_a", "voltage_v"])
    h = float(t[1] - t[0])
    soc_pts, ocv_pts = read_csv(ocv, ["soc", "ocv_v"])
    soc = meta["soc0"] + h * np.cumsum(i) / (3600.0 * meta["capacity_ah"])
    y = v - np.interp(soc, soc_pts, ocv_pts)
    tr = track(tpath)
    assert len(tr["time_s"]) == len(t)
    ref = levels(f"target/prior-free/{rec}-levels/reference-map.csv")
    near = nearest(ref["soc"], tr["soc"])
    return {
        "name": rec, "h": h, "t": t, "i": i, "y": y, "valid": np.ones(len(t), bool),
        "fast_r_i": ffill(tr["r_i"]), "track_r_ct": tr["r_ct"],
        "ref_r_ct": ref["r_ct"][near], "ref_r_i": ref["r_i"][near],
        "judged": np.ones(len(t), bool), "sure": None,
    }


def binned_means(t_raw, x_raw, edges, max_step):
    """Mean over each [edges[k], edges[k+1]) of x held from each row to the
    next (zero-order hold, as the cycler's current); a row's hold ends at a
    step longer than max_step (a gap)."""
    dt = np.diff(t_raw)
    hold = np.where(dt > max_step, 0.0, dt)
    # The integral at the rows: linear between them, flat across a gap.
    cum = np.concatenate([[0.0], np.cumsum(x_raw[:-1] * hold)])
    c = np.interp(edges, t_raw, cum)
    return np.diff(c) / np.diff(edges)


def panasonic_record(hs, out):
    """The Panasonic 25 degC HPPC test on the 0.5 s track's grid: mean
    current and voltage over each period [t_k, t_k + h) (zero-order hold of
    the 0.1 s rows), y = V - OCV(the track's SOC); periods that touch a
    step longer than 10 periods (the 13 logged-out discharges) are gaps."""
    import scipy.io as sio

    tpath = f"{out}/pan-{PAN_PERIOD:g}.csv"
    if not os.path.exists(tpath):
        run([hs, "online", "battery", "--input", PANASONIC, "--ocv", PAN_OCV, "--capacity-ah", "2.9",
             "--window", str(WINDOW), "--period", str(PAN_PERIOD), "--out", tpath])
    tr = track(tpath)
    meas = sio.loadmat(PANASONIC)["meas"][0, 0]
    t_raw, i_raw, v_raw = (meas[k].ravel().astype(float) for k in ("Time", "Current", "Voltage"))
    keep = np.concatenate([[True], np.diff(t_raw) > 0])  # duplicates / backward rows
    t_raw, i_raw, v_raw = t_raw[keep], i_raw[keep], v_raw[keep]
    h = PAN_PERIOD
    max_step = 10 * h
    t = tr["time_s"]
    edges = np.concatenate([t, [t[-1] + h]]) + t_raw[0]
    i = binned_means(t_raw, i_raw, edges, max_step)
    v = binned_means(t_raw, v_raw, edges, max_step)
    # Gaps: periods overlapping a long step, and periods beyond the last row.
    valid = edges[1:] <= t_raw[-1]
    for k in np.where(np.diff(t_raw) > max_step)[0]:
        valid &= ~((edges[1:] > t_raw[k]) & (edges[:-1] < t_raw[k + 1]))
    soc_pts, ocv_pts = read_csv(PAN_OCV, ["soc", "ocv_v"])
    y = v - np.interp(tr["soc"], soc_pts, ocv_pts)
    mp = levels("target/prior-free/panasonic-map.csv")
    near = nearest(mp["soc"], tr["soc"])
    ok = mp["identifiable"]
    # prior_free.py's "after the first pulse group": the tenth pulse edge.
    di = np.diff(i_raw)
    edge = (np.abs(di) > 1.0) & (np.abs(i_raw[:-1]) < 0.05) & (np.diff(t_raw) < 0.2)
    ts = t_raw[np.where(edge)[0] + 1]
    after = t > ts[min(9, len(ts) - 1)]
    return {
        "name": "panasonic", "h": h, "t": t, "i": i, "y": y, "valid": valid,
        "fast_r_i": ffill(tr["r_i"]), "track_r_ct": tr["r_ct"],
        "ref_r_ct": mp["r_ct"][near], "ref_r_i": mp["r_i"][near],
        "judged": after, "sure": after & ok[near],
    }


# ----------------------------------------------------------- slow window


def decimate(rec, d):
    """Block means over D consecutive samples (blocks from the record's
    first sample); a block is valid when all its samples are. Returns the
    block current, y, validity and each block's last sample index."""
    n = len(rec["t"]) // d * d
    ib = rec["i"][:n].reshape(-1, d).mean(1)
    yb = rec["y"][:n].reshape(-1, d).mean(1)
    vb = rec["valid"][:n].reshape(-1, d).all(1)
    last = np.arange(d - 1, n, d)
    return ib, yb, vb, last


def identify(res, p, span):
    """Our core's verdict on a window's R_ct (see the module docstring);
    returns (identified, 1.96 SE(ln R_ct), relaxation time s, rho)."""
    r = res.fun
    n = len(r)
    s2 = float(r @ r) / max(n - p, 1)
    den = float(r @ r)
    rho = float(r[1:] @ r[:-1]) / den if den > 0 else 0.0
    rho = min(max(rho, 0.0), 0.99)
    jtj = res.jac.T @ res.jac
    try:
        cov = s2 * np.linalg.inv(jtj)
        var = cov[0, 0]
    except np.linalg.LinAlgError:
        var = np.nan
    ci = 1.96 * math.sqrt(var) * math.sqrt((1 + rho) / (1 - rho)) if var > 0 else np.inf
    ln_rct, ln_q, alpha = res.x[0], res.x[1], res.x[2]
    relax = math.exp((ln_rct + ln_q) / alpha)
    on_bound = (ln_rct - LO[0] < 1e-3) or (HI[0] - ln_rct < 1e-3)
    ok = ci <= LN2 and 0 < alpha <= 1 and not on_bound and relax <= span
    return ok, ci, relax, rho


def first_starts(i, y, h, r_i, span):
    """Three starts: R_ct = total resistance of y ~ dU + R I less R_i,
    (alpha, relaxation time) in (0.9, span/10), (0.6, span/40), (0.8, span/3)."""
    if np.ptp(i) > 0:
        r_tot = abs(np.polyfit(i, y, 1)[0])
    else:
        r_tot = 2 * r_i
    r_ct = max(r_tot - r_i, 0.5 * r_i, 1e-4)
    du = float(np.mean(y - (r_i + r_ct) * i))
    out = []
    for alpha, relax in ((0.9, span / 10), (0.6, span / 40), (0.8, span / 3)):
        out.append(np.array([math.log(r_ct), math.log(relax ** alpha / r_ct), alpha, du, math.log(r_i), 0.0]))
    return out


def fit_window(i_hist, y_win, hd, x0s, free):
    """least_squares of the coordinates ``free`` of x = (ln R_ct, ln Q,
    alpha, dU, ln R_i, k) over the last WINDOW samples, the rest held at
    x0s[0]'s; the branch runs over all of i_hist (full memory); k (V/A h)
    is the OCV slope over the window's charge (variants with ``s``)."""
    n = len(i_hist)
    i_win = i_hist[n - WINDOW:]
    q_win = np.cumsum(i_win) * hd / 3600.0
    q_win -= q_win.mean()
    cache = {}
    full = np.array(x0s[0], float)

    def resid(p):
        x = full.copy()
        x[free] = p
        key = (x[0], x[1], x[2])
        up = cache.get(key)
        if up is None:
            if len(cache) > 8:
                cache.clear()
            up = cache[key] = cpe_branch(i_hist, hd, math.exp(x[0]), math.exp(x[1]), x[2])[n - WINDOW:]
        return x[3] + math.exp(x[4]) * i_win + x[5] * q_win + up - y_win

    lo, hi = LO[free], HI[free]
    best = None
    for x0 in x0s:
        p0 = np.clip(np.array(x0, float)[free], lo + 1e-3, hi - 1e-3)
        try:
            res = least_squares(resid, p0, bounds=(lo, hi), x_scale=SCALE[free], max_nfev=100)
        except (ValueError, FloatingPointError):
            continue
        if best is None or res.cost < best.cost:
            best = res
    if best is None:
        return None, None
    x = full.copy()
    x[free] = best.x
    return best, x


def slow_track(rec, d, variant, slope=False, log=None):
    """The slow window every EVERY_S s; returns the per-window rows and the
    published R_ct held over the record's samples."""
    h = rec["h"]
    hd = d * h
    span = WINDOW * hd
    every = int(round(EVERY[0] / hd))
    t0 = time.time()
    free = [0, 1, 2, 3] + ([4] if variant == "B" else []) + ([5] if slope else [])
    ib, yb, vb, last = decimate(rec, d)
    # Start of each block's gap-free run (the branch's memory starts there).
    seg_start = np.zeros(len(vb), int)
    s = 0
    for b in range(len(vb)):
        if not vb[b]:
            s = b + 1
        seg_start[b] = s
    rows = []
    pub = np.full(len(rec["t"]), np.nan)
    prev = None
    for b in range(WINDOW - 1, len(vb)):
        if (b + 1) % every or not vb[b] or seg_start[b] > b - WINDOW + 1:
            continue
        e = last[b]
        if variant == "A":
            r_i = rec["fast_r_i"][e]
        elif variant == "C":
            r_i = rec["ref_r_i"][e]
        else:
            r_i = math.exp(prev[4]) if prev is not None else np.nan
        if variant != "B" and not (np.isfinite(r_i) and r_i > 0):
            continue
        i_hist = ib[seg_start[b]:b + 1]
        y_win = yb[b - WINDOW + 1:b + 1]
        if prev is None:
            if variant == "B":
                i_w = i_hist[-WINDOW:]
                r_i = max(abs(np.polyfit(i_w, y_win, 1)[0]) / 2, 1e-4) if np.ptp(i_w) > 0 else 0.01
            starts = first_starts(i_hist[-WINDOW:], y_win, hd, r_i, span)
        else:
            x = prev.copy()
            x[4] = math.log(r_i)
            starts = [x]
        res, x = fit_window(i_hist, y_win, hd, starts, free)
        if res is None:
            continue
        prev = x
        if len(rows) % 500 == 0:
            print(f"  {rec['name']} {variant} D={d}: window {len(rows)} at t = {rec['t'][e]:.0f} s,"
                  f" {time.time() - t0:.0f} s", file=sys.stderr, flush=True)
        ok, ci, relax, rho = identify(res, len(res.x), span)
        r_ct = math.exp(x[0])
        if ok:
            pub[e:] = r_ct
        rows.append((rec["t"][e], math.exp(x[4]), r_ct, math.exp(x[1]), x[2], x[3], ci, relax, rho,
                     math.sqrt(np.mean(res.fun ** 2)), int(ok), rec["ref_r_ct"][e], e, x[5]))
    if log:
        with open(log, "w") as f:
            f.write("time_s,r_i,r_ct,q,alpha,du,ci_ln_r_ct,relaxation_s,rho,rmse_v,identified,ref_r_ct,sample,ocv_slope_v_per_ah\n")
            for r in rows:
                f.write(",".join(f"{x:.6g}" for x in r) + "\n")
    return rows, pub


# ---------------------------------------------------------------- judging


def band(values, ref):
    """Fraction of the finite values within [0.5, 2] x ref; ratios
    min, median, max."""
    pub = np.isfinite(values)
    r = values[pub] / ref[pub]
    if not r.size:
        return "no values"
    inside = ((r >= 0.5) & (r <= 2.0)).mean()
    return f"{inside:.1%} in [0.5x, 2x] (ratios {r.min():.3g}..{np.median(r):.3g}..{r.max():.3g})"


def report(rec, label, rows, pub):
    ident = np.array([r[10] for r in rows])
    first = int(rows[0][12]) if rows else len(pub)
    n = len(pub)
    after = np.arange(n) >= first
    judged = rec["judged"]
    base = after & judged
    line = (f"{rec['name']} {label}: {len(rows)} windows, R_ct identified in {ident.mean() if rows else 0:.1%};"
            f" published on {np.isfinite(pub[base]).mean():.1%} of samples after the first window")
    if rec["name"] != "panasonic":
        line += f" ({np.isfinite(pub).mean():.1%} of all)"
    line += "; " + band(pub[judged], rec["ref_r_ct"][judged])
    if rec["sure"] is not None:
        s = rec["sure"]
        line += f"; identifiable levels only: {band(pub[s], rec['ref_r_ct'][s])}"
    print(line, flush=True)


def baseline(rec):
    """The one-window track's R_ct, judged the same way."""
    pub = rec["track_r_ct"]
    j = rec["judged"]
    line = f"{rec['name']} one 256-sample window (period {rec['h']:g} s): published on {np.isfinite(pub[j]).mean():.1%}; " \
        + band(pub[j], rec["ref_r_ct"][j])
    if rec["sure"] is not None:
        line += f"; identifiable levels only: {band(pub[rec['sure']], rec['ref_r_ct'][rec['sure']])}"
    print(line, flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--host-sim", default="target/release/host-sim")
    ap.add_argument("--out", default="target/two-window")
    ap.add_argument("--every", type=float, default=EVERY[0], help="seconds of record between slow windows (16)")
    ap.add_argument("--only", default="chen2020-hppc,prada2013-hppc,panasonic")
    ap.add_argument("--runs", default="A2,A4,A8,B4,C4",
                    help="variant letter and D, comma-separated; a trailing s also fits an OCV slope over "
                         "the window's charge, as our core's sliding window does (A4s). Panasonic skips "
                         "D < 4: its slow period is D x 0.5 s")
    a = ap.parse_args()
    EVERY[0] = a.every
    os.makedirs(a.out, exist_ok=True)
    runs = [(r[0], int(r[1:].rstrip("s")), r.endswith("s")) for r in a.runs.split(",")]
    for name in a.only.split(","):
        rec = panasonic_record(a.host_sim, a.out) if name == "panasonic" else dfn_record(name, a.host_sim, a.out)
        baseline(rec)
        for variant, d, slope in runs:
            if name == "panasonic" and d < 4:
                continue
            t0 = time.time()
            tag = f"{variant}{d}{'s' if slope else ''}"
            rows, pub = slow_track(rec, d, variant, slope, log=f"{a.out}/windows-{name}-{tag}.csv")
            report(rec, f"{tag}: {variant} D={d}{' with OCV slope' if slope else ''} (period {d * rec['h']:g} s, horizon {WINDOW * d * rec['h']:g} s,"
                        f" {time.time() - t0:.0f} s)", rows, pub)


if __name__ == "__main__":
    main()
