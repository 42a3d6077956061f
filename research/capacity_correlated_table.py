#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Is the capacity started right moving 4 % on the Panasonic HPPC test because the filter counts the table's error at each rest as independent, when the rests of one level read the same stretch of the table?
# Answer: partly: a table error correlated over 0.1 of SOC (a state of the filter) cuts the move from 7.3 % to 3.4 % in this emulation, still 3.4x the 1 % goal, and a table spread of 0.02 then never identifies the capacity; not built.
"""The SOC observer's capacity with the OCV table's error as a state
correlated over SOC (issue 72, "started right, it never moves more than
1 %"; docs/research.md, "The SOC observer at rest").

An emulation of the observer on the Panasonic 18650PF 25 degC HPPC
export's rests (those of research/capacity_rest_pairs.py: each rest of at
least 600 s, its last 16 voltages through the C/20 table, the export's own
`Ah` count at its end): a Kalman filter on (SOC, g = C_nominal / C, d),
d the table's error in SOC, a Gauss-Markov process over the SOC moved
(correlation length ell; ell = 0 is an independent error at each rest, as
the observer has it), observed as z = SOC + d with the rested voltage's
5 mV over the table's slope. The capacity is published once its standard
deviation is within 2 % of it (as the observer), from a nominal 10 %
high, right and 10 % low. No bias state (the observer's reads the bias at
each rest).

    bash bench/panasonic_chain.sh          # target/real-cells/panasonic/ocv.csv
    python3 research/capacity_correlated_table.py
"""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from capacity_rest_pairs import MEASURED_AH, rests  # noqa: E402


def run(rest, cnom, sig_t, ell, sig_v=0.005, cap_sig=0.15, soc0_sig=0.1, ident=0.02):
    """The emulated filter from a nominal `cnom`; `sig_t` the table's
    spread in SOC, or a function of the SOC a rest reads giving it there.
    Returns when the capacity is first published, the lowest and highest
    published value and the last (each against the C/20 test's)."""
    t, z, q, slope = rest
    spread = sig_t if callable(sig_t) else (lambda _: sig_t)
    x = np.array([z[0], 1.0, 0.0])
    P = np.diag([soc0_sig**2, cap_sig**2, spread(z[0]) ** 2])
    held, first, out = None, None, []
    for k in range(len(z)):
        if k > 0:
            dq = (q[k] - q[k - 1]) / cnom
            rho = np.exp(-abs(x[1] * dq) / ell) if ell > 0 else 0.0
            F = np.array([[1.0, dq, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, rho]])
            x = F @ x
            P = F @ P @ F.T + np.diag([0.0, 0.0, (1 - rho**2) * spread(z[k]) ** 2])
        H = np.array([1.0, 0.0, 1.0])
        S = H @ P @ H + (sig_v / max(slope[k], 1e-3)) ** 2
        K = P @ H / S
        x = x + K * (z[k] - H @ x)
        P = P - np.outer(K, H @ P)
        c = cnom / x[1]
        if c / x[1] * np.sqrt(P[1, 1]) <= ident * c:
            held = c
            first = first if first is not None else t[k]
        out.append(held if held is not None else cnom)
    out = np.array(out) / MEASURED_AH - 1
    return first, out.min(), out.max(), out[-1]


def main():
    rest = rests()
    print("| table spread (SOC) | correlated over | nominal | first identified | published over the test | at the end |")
    print("|---|---|---|---|---|---|")
    for sig_t in (0.01, 0.02):
        for ell in (0.0, 0.05, 0.1, 0.2):
            for cnom in (MEASURED_AH * 1.1, MEASURED_AH, MEASURED_AH * 0.9):
                f, lo, hi, end = run(rest, cnom, sig_t, ell)
                print(f"| {sig_t} | {ell if ell else 'independent'} | {cnom:.3f} | "
                      f"{'never' if f is None else f'{f:.0f} s'} | {lo:+.1%} to {hi:+.1%} | {end:+.1%} |")


if __name__ == "__main__":
    main()
