#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Is the capacity started right moving on the Panasonic HPPC test because the C/20 table places its charge branch by the test's one count (2.61 A h charged against 3.00 A h discharged)?
# Answer: no: a table from each branch placed by its own count, or the discharge branch moved by the half-gap, ends the capacity 5.0 % and 3.6 % low, where the table as built ends 0.3 % high; not built.
"""The C/20 OCV table made three ways, each read by the Panasonic HPPC
export's rests (issue 72, "started right, it never moves more than
1 %"; docs/research.md, "The SOC observer at rest").

The C/20 test of data/panasonic-18650pf discharges 3.00 A h from full to
2.5 V and then charges 2.61 A h to 4.2 V (no CV phase). `host-sim ocv
--from low-rate` places both branches on the one count of the test, so
its charge branch ends at SOC 0.87 and lies 110-170 mV above the
discharge branch at the same SOC from 0.6 to 0.87; their mean is the
table, the discharge branch moved by the median half-gap above 0.87. Here, beside it:

* each branch placed by its own count (the discharge from 1 to 0, the
  charge from 0 to 1), their mean (a half-gap of 19 mV);
* the discharge branch moved up by that half-gap.

Each table reads the SOC of every rest of the HPPC export (those of
research/capacity_rest_pairs.py); printed: the rests' SOC less the one
counted from the first rest at the C/20 capacity, the least-squares
capacity over every rest, and the filter of research/
capacity_correlated_table.py (independent table errors of 0.01 SOC,
as the observer has them) from a nominal capacity 10 % high, right and
10 % low.

    bash bench/panasonic_chain.sh          # target/real-cells/panasonic/ocv.csv
    python3 research/capacity_branch_table.py
"""

import os
import sys

import numpy as np
import scipy.io as sio

sys.path.insert(0, os.path.dirname(__file__))
from capacity_correlated_table import run  # noqa: E402
from capacity_rest_pairs import MEASURED_AH, OCV, rest_rows  # noqa: E402

C20 = "data/panasonic-18650pf/05-08-17_13.26 C20 OCV Test_C20_25dC.mat"


def branch(t, i, v, mask, falling):
    """A branch's SOC by its own count (1 to 0 when `falling`) and voltage."""
    tt, ii, vv = t[mask], i[mask], v[mask]
    q = np.cumsum(np.abs(ii) * np.diff(tt, prepend=tt[0])) / 3600
    s = q / q[-1]
    return (1 - s if falling else s), vv, q[-1]


def main():
    m = sio.loadmat(C20)["meas"][0, 0]
    t, i, v = (m[k].ravel() for k in ("Time", "Current", "Voltage"))
    sd, vd, qd = branch(t, i, v, (t > 240) & (t < 74680), True)
    sc, vc, qc = branch(t, i, v, (t > 78281) & (t < 143255), False)
    grid = np.round(np.arange(0.01, 1.0001, 0.01), 2)
    dis, ch = np.interp(grid, sd[::-1], vd[::-1]), np.interp(grid, sc, vc)
    gap = np.median(ch - dis) / 2
    print(f"C/20 test: discharge {qd:.4f} A h, charge {qc:.4f} A h; "
          f"half-gap by each branch's own count {1e3 * gap:.1f} mV")
    built = np.genfromtxt(OCV, delimiter=",", names=True)
    tables = {
        "the table as built (one count)": (built["soc"], built["ocv_v"]),
        "each branch by its own count, mean": (grid, (dis + ch) / 2),
        "discharge branch + half-gap": (grid, dis + gap),
    }
    tr, vr, q = rest_rows()
    for name, (sg, vg) in tables.items():
        z = np.interp(vr, vg, sg)
        slope = np.abs(np.interp(z, sg, np.gradient(vg, sg)))
        off = z - (z[0] + (q - q[0]) / MEASURED_AH)
        coef = np.polyfit(q, z, 1)
        print(f"== {name}: least-squares capacity {1 / coef[0]:.4f} A h "
              f"({1 / coef[0] / MEASURED_AH - 1:+.1%})")
        print("   rests' SOC less the count (rests 1, 4, 7, 13, 21, 31, 41, 51, 54): "
              + " ".join(f"{x:+.3f}" for x in off[[0, 3, 6, 12, 20, 30, 40, 50, 53]]))
        for cnom in (MEASURED_AH * 1.1, MEASURED_AH, MEASURED_AH * 0.9):
            first, lo, hi, end = run((tr, z, q, slope), cnom, 0.01, 0.0)
            print(f"   nominal {cnom:.3f} A h: first published at {first:.0f} s, "
                  f"{lo:+.1%} to {hi:+.1%}, at the end {end:+.1%}")


if __name__ == "__main__":
    main()
