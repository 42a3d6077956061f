#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Would a spread of the map's parameters taken from its own leave-one-level-out miss (how far a knot's value moves when its level is not seen) derate the state of power enough to cover the measured pulses (issue 72: >= 95 % above pulse_v - 2 sigma), where the fixed bound ln 2/1.96 covers 100 % with sigma a third of the drop?
# Answer: yes on the pooled measured pulses: the spreads are 0.20-0.79 of the bound, and with them the own-map pulses end above pulse_v - 2 sigma at 215 of 221 (97.3 %; 10 degC alone 94.3 % and 93.9 %) with sigma 10-14 % of the drop, against 100 % and 31-38 % with the bound; not built.
"""The joint map's parameters with each level left out, against the map's
own (issue 72; docs/research.md, "The state of power").

For each knot of a joint map (the ``--levels-out`` folder of ``identify
battery --map-method joint``: ``joint.json`` and ``joint-record.csv``) the
joint objective of ``bench/joint_reference.py`` is minimised again by scipy
without the counted samples of that knot's level (the map CSV's
``start_s..end_s``), from the map's own fit. The knot's ``ln R_i``, ``ln
R_ct``, ``ln tau`` and alpha then differ from the map's by what the other
levels and the smoothness say of it: their root mean square over the knots
is a spread of the map's model error per parameter, printed beside the
bound the state of power's ``map`` basis takes today (``ln 2/1.96`` in ln,
0.1/1.96 for alpha).

Each record's ratios to the bound (of ``R_i``, ``R_ct``, ``Q`` and alpha)
are the multipliers of ``bench/experiments/sop-map-spread-loo.patch``
(commit in docs/research.md), whose build runs ``python3
bench/sop_pulses.py --acceptance``.

    bash bench/map_validation.sh           # the maps and their --levels-out
    python3 research/map_loo_spread.py [--maps target/map-validation]
"""

import argparse
import csv
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "bench"))
import joint_reference as J  # noqa: E402

BOUND = [math.log(2) / 1.96, math.log(2) / 1.96, math.log(2) / 1.96, 0.1 / 1.96, math.log(2) / 1.96]
# ln Q = ln tau - ln R_ct: the state of power's spread is of R_i, R_ct, Q and alpha.
NAMES = ["ln R_i", "ln R_ct", "ln tau", "alpha", "ln Q"]


def loo_spread(folder, map_csv):
    pb = J.Problem(folder)
    rows = list(csv.DictReader(open(map_csv)))
    t, *_ = J.read_csv(os.path.join(folder, "joint-record.csv"), ["time_s"])
    counted = pb.counted.copy()
    full = pb.theta_ours
    deltas = []
    for j, r in enumerate(rows):
        fold = (t >= float(r["start_s"])) & (t <= float(r["end_s"]))
        pb.counted = counted & ~fold
        pb.nc = int(pb.counted.sum())
        res, secs, _, _ = pb.fit(full)
        d = [pb.knot(res.x, j)[p] - pb.knot(full, j)[p] for p in range(4)]
        d.append(d[2] - d[1])
        deltas.append(d)
        print(f"  knot {j} SOC {float(r['soc']):.3f}: {int(fold.sum())} samples left out, "
              + ", ".join(f"{NAMES[p]} {d[p]:+.4f}" for p in range(5)) + f" ({secs:.0f} s)", flush=True)
    pb.counted = counted
    return np.sqrt(np.mean(np.array(deltas) ** 2, axis=0))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", default="target/map-validation")
    a = ap.parse_args()
    for T in (25, 10):
        print(f"Panasonic {T} degC joint map, each level left out:")
        sp = loo_spread(f"{a.maps}/levels-joint-{T}", f"{a.maps}/map-joint-{T}.csv")
        r = sp / np.array(BOUND)
        print("  RMS over the knots: " + ", ".join(
            f"{NAMES[p]} {sp[p]:.4f} ({r[p]:.2f} of the bound)" for p in range(5)))


if __name__ == "__main__":
    main()
