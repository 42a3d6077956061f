#!/usr/bin/env python3
"""Writes the NMC-like OCV curve of `estimator_core::battery::profile::ocv_nmc`
(the one `host-sim simulate battery --ocv nmc` uses) as a 101-point table
`soc,ocv_v`, for the commands that take an OCV table file.

    python3 bench/nmc_ocv.py data/own-model/nmc-ocv.csv
"""
import math
import sys

out = sys.argv[1] if len(sys.argv) > 1 else "data/own-model/nmc-ocv.csv"
with open(out, "w") as f:
    f.write("soc,ocv_v\n")
    for k in range(101):
        z = k / 100
        v = 3.43 + 0.68 * z - 0.5 * z * z + 0.55 * z**3 - 0.12 * math.exp(-30.0 * z)
        f.write(f"{z:.2f},{v:.9f}\n")
