#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: How does the measured cell's pulse resistance move with the current, level by level, and does the OCV read at a surface state of charge shifted by the current explain it where a Butler-Volmer term cannot?
# Answer: it falls with the current above SOC 0.5 (10 s, 17.4 A over 1.45 A: 0.82-0.90 at 25 degC, 0.56-0.89 at 10 degC), is flat at 0.35-0.47, and rises below 0.27 at 25 degC (up to 1.28); a drop R*I + OCV(z) - OCV(z - k*I) follows the rising levels (rms 23.4-27.1 mV linear, 4.8-7.6 mV with it; k*17.4 A 0.09-0.23 of SOC, where the count moves 0.017), but fits the falling ones only with k jumping 0.002-0.56 from level to level; not built (docs/research.md, "The resistance's current dependence, level by level").
"""Each level of the Panasonic 18650PF HPPC tests (25 and 10 degC): the
10 s drop of its full-length discharge pulses (the raw 0.1 s log, from
the voltage at the edge) against the current, fitted two ways by least
squares over the level's pulses:

* linear: `R*I`, one resistance for every current;
* through the OCV at a surface state of charge: `R*I + OCV(z) - OCV(z -
  k*I)`, the C/20 OCV table of bench/panasonic_chain.sh read at the
  level's state of charge `z` moved by `k` per ampere (a diffusion that
  leaves the particles' surface emptier than their bulk at the pulse's
  end; the bulk moves 10 s x 17.4 A / 2.9 A h = 0.017 of SOC). Where the
  table is curved the drop is then not proportional to the current.

`z` is the state of charge `python3 bench/sop_pulses.py --acceptance`
counted at the level's first pulse (read from its `--worst` listing, so
run it first with `--worst 100 > target/sop-acceptance.txt`). Printed per
level: the 10 s resistance at the smallest and largest current, both
fits' rms over the level's pulses, and `k x 17.4 A`.

    cargo build --release -p host-sim && bash bench/panasonic_chain.sh
    python3 bench/sop_pulses.py --acceptance --worst 100 > target/sop-acceptance.txt
    python3 research/pulse_resistance_by_current.py [--acceptance target/sop-acceptance.txt]
"""

import argparse
import os
import re
import sys

import numpy as np
from scipy.optimize import least_squares

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "bench"))
import sop_pulses as S  # noqa: E402

HORIZON_S = 10.0
LARGEST_A = 17.4


def socs(listing):
    """Each pulse's counted SOC by its start (s), from the acceptance's
    `--worst` listing."""
    out = {}
    for line in open(listing):
        for m in re.finditer(r"at (\d+) s, (-[\d.]+) A, SOC ([\d.]+)", line):
            out[int(m.group(1))] = float(m.group(3))
    return out


def levels(ps):
    """The pulses split into levels: a new level at each smallest pulse."""
    out = [[]]
    for p in ps:
        if out[-1] and p[1] > -2.0:
            out.append([])
        out[-1].append(p)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--acceptance", default="target/sop-acceptance.txt")
    a = ap.parse_args()
    soc = socs(a.acceptance)
    z_t, u_t = np.loadtxt(S.PAN_OCV, delimiter=",", skiprows=1, unpack=True)

    def ocv(z):
        return np.interp(z, z_t, u_t)

    print("| record | SOC | R at 10 s, smallest / largest current (mOhm) | rms linear (mV) "
          "| rms through OCV(z - k I) (mV) | k x 17.4 A (SOC) |")
    print("|---|---|---|---|---|---|")
    for name, path in S.RECORDS.items():
        ps, (t, v) = S.pulses(path)
        for level in levels(ps):
            pts = [(st, -cur, np.interp(st, t, v) - np.interp(st + HORIZON_S, t, v))
                   for st, cur, length in level if length >= HORIZON_S]
            z = soc.get(int(round(pts[0][0]))) if pts else None
            if len(pts) < 3 or z is None:
                continue
            i = np.array([p[1] for p in pts])
            d = np.array([p[2] for p in pts])
            r_lin = float(d @ i / (i @ i))
            rms_lin = np.sqrt(np.mean((d - r_lin * i) ** 2))

            def res(x):
                return x[0] * i + ocv(z) - ocv(z - x[1] * i) - d

            fits = [least_squares(res, [r_lin, k0], bounds=([0.0, 0.0], [1.0, 1.0]))
                    for k0 in (1e-4, 1e-3, 1e-2)]
            best = min(fits, key=lambda f: f.cost)
            rms = np.sqrt(np.mean(best.fun ** 2))
            print(f"| {name} | {z:.3f} | {1e3 * d[0] / i[0]:.1f} / {1e3 * d[-1] / i[-1]:.1f} "
                  f"| {1e3 * rms_lin:.1f} | {1e3 * rms:.1f} | {best.x[1] * LARGEST_A:.3f} |")


if __name__ == "__main__":
    main()
