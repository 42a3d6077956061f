#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Does a capacity started right hold within 1 % on the Panasonic HPPC test if the rests that read the C/20 table where it has its discharge branch alone (above SOC 0.87) weigh less?
# Answer: no: its dip falls from -7.3 % to -0.2..-0.7 %, but it then ends 2.3-2.5 % high (the table below SOC 0.87 reads the counted charge 2.5 % short); not built.
"""The SOC observer's capacity with the table's spread larger where the
C/20 table has one branch only (issue 72, "started right, it never moves
more than 1 %"; docs/research.md, "The SOC observer at rest").

The C/20 test's charge branch ends at SOC 0.87 (no CV phase;
research/capacity_branch_table.py), so above it the table is the
discharge branch alone. An emulation of the observer on the Panasonic
18650PF 25 degC HPPC export's rests (research/capacity_rest_pairs.py's),
research/capacity_correlated_table.py's filter with the table's error
independent at each rest: each rest observed as its SOC read through
the table with the rested voltage's 5 mV over the table's slope and the
table's own spread in SOC, one value below the cut and another above
it. The capacity is published once
its standard deviation is within 2 % of it (as the observer), from a
nominal 10 % high, right and 10 % low. No bias state.

    bash bench/panasonic_chain.sh          # target/real-cells/panasonic/ocv.csv
    python3 research/capacity_single_branch_spread.py
"""

import os
import sys

sys.path.insert(0, os.path.dirname(__file__))
from capacity_correlated_table import run  # noqa: E402
from capacity_rest_pairs import MEASURED_AH, rests  # noqa: E402

CUT = 0.87


def main():
    rest = rests()
    print(f"| table spread below / above SOC {CUT} | nominal | first identified | published over the test | at the end |")
    print("|---|---|---|---|---|")
    for below, above in ((0.01, 0.01), (0.005, 0.03), (0.005, 0.05), (0.01, 0.05), (0.005, 0.1)):
        for cnom in (MEASURED_AH * 1.1, MEASURED_AH, MEASURED_AH * 0.9):
            f, lo, hi, end = run(rest, cnom, lambda z: above if z > CUT else below, 0.0)
            print(f"| {below} / {above} | {cnom:.3f} | {'never' if f is None else f'{f:.0f} s'} | "
                  f"{lo:+.1%} to {hi:+.1%} | {end:+.1%} |")


if __name__ == "__main__":
    main()
