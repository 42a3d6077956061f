#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Is a wrong online R_ct the window's own optimum, or a fault of the online search?
# Answer: the window's own optimum: refitted offline by multi-start, 0 of 12 wrong windows move into [0.5x, 2x] on either DFN HPPC record.
"""Is a wrong online R_ct the window's own optimum? (issue 35;
docs/research.md, "The same window, fitted offline").

On the DFN HPPC records, `online battery` (window 256, memory 64, no
prior) publishes an R_ct outside [0.5x, 2x] of the per-SOC reference in
10 % (Chen2020) and about half (Prada2013) of the samples that carry one. This
script takes windows that the core marked `identified` for R_ct, some
outside the band ("wrong"), some inside ("right"), picked at random with a
fixed seed, and fits the same rows offline by multi-start least squares
(scipy; 24 starts on a grid like bench/reference_fit.py's fit_cpe, and
the online estimate), in two formulations of the same model
(R_i + R_ct || CPE(Q, alpha), the OCV table at the track's counted SOC,
short memory M = 64):

* **the core's**: the first M - 1 rows of the window give the
  polarization's history from the data (U_p = y - dU - R_i I), the model
  runs freely from there and rows M - 1 .. L - 1 are fitted
  (`Start::FromData`);
* **self-consistent**: the model runs from rest PRE samples before the
  window on the record's own current, with the same parameters, and every
  row of the window is fitted (the window's data, its history made by the
  model instead of read from the data).

Each line: the online window's R_ct, the two offline optima, the per-SOC
reference; then per record and group, how many offline optima are within
[0.5x, 2x] of the reference and how many ran to the bound of R_ct (the
window does not determine it). About a minute.

    python3 bench/prior_free.py --out target/prior-free   # the tracks and references
    python3 research/same_window.py [--tracks target/prior-free] [--per-group 12] [--pre 600] [--profile]

``--profile`` (about two minutes): instead, the same windows' profile
likelihood in the core's formulation. R_ct is fixed at 0.5x and 2x of the
window's optimum, and at the reference, and the other parameters are
refitted (13 starts). Each fit's cost is taken as a likelihood ratio
against the optimum, ``n ln(cost/cost*) (1 - rho)/(1 + rho)``, where rho is
the optimum's residuals' lag-1 autocorrelation (the core's widening). A
window "identifies" R_ct by the profile when both factors give more than
3.84 (chi-square, 1 degree, 95 %). This is the interval without the
linearization of the information matrix that the core's test uses.
"""

import argparse
import csv
import math
import os
import sys

import numpy as np
from scipy.signal import lfilter, lfiltic

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(1, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "bench"))
import reference_fit as rf  # noqa: E402

MEMORY, WINDOW = 64, 256
RECORDS = (("chen2020-hppc", "data/pybamm/chen2020-ocv.csv"),
           ("prada2013-hppc", "data/pybamm/prada2013-ocv.csv"))
LO = [-20, -20, -20, 0.05, -np.inf]  # ln R_i, ln R_ct, ln Q, alpha, dU
HI = [5, 5, 30, 1.0, np.inf]
AT_BOUND = 4.9  # ln R_ct at its upper bound 5: R_ct not determined


def num(x):
    return float(x) if x not in ("", None) else math.nan


def load_record(rec, ocv_path, tracks):
    """A DFN HPPC record with the online track of `bench/prior_free.py`:
    its current, its overpotential through the OCV table at the track's
    counted SOC, the track's rows, that SOC, and the per-SOC reference's
    R_ct at each row (the level nearest in SOC)."""
    d = np.genfromtxt(f"data/pybamm/{rec}.csv", delimiter=",", names=True)
    cur, volt = d["current_a"], d["voltage_v"]
    z, u = np.loadtxt(ocv_path, delimiter=",", skiprows=1, unpack=True)
    track = list(csv.DictReader(open(f"{tracks}/{rec}.csv")))
    soc = np.array([num(r["soc_coulomb"]) for r in track])
    y_all = volt - np.interp(soc, z, u)
    levels = list(csv.DictReader(open(f"{tracks}/{rec}-levels/reference-map.csv")))
    lsoc = np.array([float(x["soc"]) for x in levels])
    lrct = np.array([float(x["r_ct"]) for x in levels])
    ref = [lrct[np.argmin(np.abs(lsoc - soc[k]))] for k in range(len(track))]
    return cur, y_all, track, soc, ref


def short_branch(i, h, r_ct, q, alpha):
    """U_p from rest with the short memory."""
    return lfilter(*rf.short_memory_filter(h, r_ct, q, alpha, MEMORY), i)


def core_residuals(p, i, y):
    """The core's window: history from the data in the first M - 1 rows."""
    r_i, r_ct, q, alpha, du = math.exp(p[0]), math.exp(p[1]), math.exp(p[2]), p[3], p[4]
    warm = MEMORY - 1
    b, a = rf.short_memory_filter(1.0, r_ct, q, alpha, MEMORY)
    past = (y[:warm] - du - r_i * i[:warm])[::-1]
    up, _ = lfilter(b, a, i[warm:], zi=lfiltic(b, a, past))
    return du + r_i * i[warm:] + up - y[warm:]


def starts(i, y, online):
    """The online estimate and fit_cpe's grid of starts."""
    out = [online] if all(map(math.isfinite, online)) else []
    r_tot = max(abs(np.polyfit(i, y, 1)[0]), 1e-4)
    for alpha in (0.5, 0.7, 0.9, 1.0):
        for relax in (3.0, 30.0, 300.0):
            for ratio in (0.2, 1.0):
                r_i = r_tot / (1.0 + ratio)
                r_ct = r_tot - r_i
                out.append([math.log(r_i), math.log(r_ct), math.log(relax**alpha / r_ct),
                            min(alpha, 0.999), float(np.mean(y - r_tot * i))])
    return out


def best(resid, x0s):
    """The multi-start optimum's parameters (bench/reference_fit.py's
    multistart)."""
    (_, p, _), _ = rf.multistart(resid, [(None, x0) for x0 in x0s], LO, HI, [1, 1, 1, 0.1, 0.01])
    return p


def profile_line(i, y, p, ref):
    """The widened likelihood ratios at 0.5x, 2x and the reference, and
    whether both factors are excluded."""
    res = core_residuals(p, i, y)
    lr = []
    for f in (0.5, 2.0, ref / math.exp(p[1])):
        ln_r_ct = p[1] + math.log(f)
        rmse, _ = rf.fit_with_r_ct_fixed(lambda q: core_residuals([q[0], ln_r_ct, q[1], q[2], q[3]], i, y),
                                         math.exp(ln_r_ct), p[0], p[2] + p[1] - ln_r_ct, p[3], p[4])
        ratio, rho = rf.widened_ratio(res, rmse)
        lr.append(ratio)
    return lr[0] > 3.84 and lr[1] > 3.84, (f"optimum R_ct {math.exp(p[1]):.4f}, rho {rho:.3f}, ratio at 0.5x "
                                           f"{lr[0]:.1f}, at 2x {lr[1]:.1f}, at the reference {lr[2]:.1f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tracks", default="target/prior-free")
    ap.add_argument("--per-group", type=int, default=12)
    ap.add_argument("--pre", type=int, default=600, help="samples the self-consistent model runs before the window")
    ap.add_argument("--profile", action="store_true", help="the windows' profile likelihood instead")
    a = ap.parse_args()
    rng = np.random.default_rng(1)
    for rec, ocv_path in RECORDS:
        cur, y_all, track, soc, ref = load_record(rec, ocv_path, a.tracks)
        ident = [k for k, r in enumerate(track)
                 if r["r_ct_status"] == "identified" and k >= WINDOW + a.pre]
        inside = lambda k, v: 0.5 <= v / ref[k] <= 2.0  # noqa: E731
        groups = {
            "wrong": [k for k in ident if not inside(k, num(track[k]["window_r_ct"]))],
            "right": [k for k in ident if inside(k, num(track[k]["window_r_ct"]))],
        }
        for tag, ks in groups.items():
            picked = sorted(rng.choice(ks, min(a.per_group, len(ks)), replace=False)) if ks else []
            tally = {"core": [0, 0], "self-consistent": [0, 0]}
            by_profile = 0
            for k in picked:
                r = track[k]
                online = [math.log(num(r["window_r_i"])), math.log(num(r["window_r_ct"])),
                          math.log(num(r["window_q"])), min(num(r["window_alpha"]), 0.999),
                          num(r["ocv_offset_v"])]
                i, y = cur[k - WINDOW + 1:k + 1], y_all[k - WINDOW + 1:k + 1]
                core = best(lambda p: core_residuals(p, i, y), starts(i, y, online))
                if a.profile:
                    ident_, text = profile_line(i, y, core, ref[k])
                    by_profile += ident_
                    print(f"{rec} {tag} sample {k} SOC {soc[k]:.2f}: reference {ref[k]:.4f}, {text}"
                          f" -> {'identified' if ident_ else 'not identified'}", flush=True)
                    continue
                lo = k - WINDOW + 1 - a.pre
                ip, yp = cur[lo:k + 1], y_all[lo:k + 1]

                def consistent(p):
                    up = short_branch(ip, 1.0, math.exp(p[1]), math.exp(p[2]), p[3])
                    return (p[4] + math.exp(p[0]) * ip + up - yp)[-WINDOW:]

                selfc = best(consistent, starts(i, y, online))
                line = []
                for name, p in (("core", core), ("self-consistent", selfc)):
                    if p[1] >= AT_BOUND:
                        tally[name][1] += 1
                        line.append(f"{name} R_ct at its bound (alpha {p[3]:.2f})")
                    else:
                        tally[name][0] += inside(k, math.exp(p[1]))
                        line.append(f"{name} R_ct {math.exp(p[1]):.4f} alpha {p[3]:.2f} R_i {math.exp(p[0]):.4f}")
                print(f"{rec} {tag} sample {k} SOC {soc[k]:.2f}: online R_ct {num(r['window_r_ct']):.4f} "
                      f"alpha {num(r['window_alpha']):.2f} R_i {num(r['window_r_i']):.4f} | "
                      + " | ".join(line) + f" | reference {ref[k]:.4f}", flush=True)
            if a.profile:
                print(f"{rec} | {len(picked)} {tag} windows: {by_profile} identify R_ct by the profile", flush=True)
                continue
            for name, (good, bound) in tally.items():
                print(f"{rec} | {len(picked)} {tag} windows, {name} optimum: within [0.5x, 2x] of the reference "
                      f"{good} of {len(picked) - bound} (R_ct at its bound in {bound})", flush=True)


if __name__ == "__main__":
    main()
