#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Would taking the model's polarization off a rested voltage make the SOC observer's rest reading better?
# Answer: with the full memory on Chen2020 yes (0.92-1.75 % -> 0.12-1.07 %), on the LFP plateau worse at three of ten rests; not built.
"""What the model says is left of the polarization at the end of a rest
(issue 36; docs/research.md, "The SOC observer at rest").

The SOC observer reads a rested voltage as the OCV. The model could say
how much polarization the rest still holds, and the observer could read
`U - U_p` instead. At the end of every rest of at least 240 s of the DFN
HPPC records (window 256, memory 64, no prior), this prints the true
polarization (the measured voltage less the OCV at the record's true
SOC) and two of the model's:

* its one-step prediction at rest (`predicted_v - u_oc` in the track of
  `online battery`): the window's polarization history is read from the
  data, so this is the measured voltage's own distance from the window's
  OCV (with its offset), not a prediction;
* the model's own relaxation: the branch of the window's parameters at
  the rest's start, run over the record's current from 1000 s before the
  rest's end, with the short memory (64 samples: what the state of
  power's carried tail holds) and with full memory;

and the SOC error each reading would make through the table's slope.

    python3 bench/prior_free.py --out target/prior-free
    python3 research/rest_polarization.py [target/prior-free]
"""

import csv
import os
import sys

import numpy as np
from scipy.signal import lfilter

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(1, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "bench"))
import reference_fit as rf  # noqa: E402


def num(x):
    return float(x) if x not in ("", None) else np.nan


def branch(i, r_ct, q, alpha, memory):
    return lfilter(*rf.short_memory_filter(1.0, r_ct, q, alpha, memory), i)


def main():
    tracks = sys.argv[1] if len(sys.argv) > 1 else "target/prior-free"
    for rec, ocv_path in (("chen2020-hppc", "data/pybamm/chen2020-ocv.csv"),
                          ("prada2013-hppc", "data/pybamm/prada2013-ocv.csv")):
        d = np.genfromtxt(f"data/pybamm/{rec}.csv", delimiter=",", names=True)
        z, u = np.loadtxt(ocv_path, delimiter=",", skiprows=1, unpack=True)
        track = list(csv.DictReader(open(f"{tracks}/{rec}.csv")))
        model = np.array([num(r["predicted_v"]) - num(r["u_oc"]) for r in track])
        i, v, soc = d["current_a"], d["voltage_v"], d["soc_true"]
        edges = np.where(np.abs(np.diff(i)) > 0.01)[0] + 1
        for seg in np.split(np.arange(len(i)), edges):
            if len(seg) < 240 or abs(i[seg[0]]) > 1e-9:
                continue
            k = seg[-1]
            slope = np.interp(soc[k], z[1:], np.diff(u) / np.diff(z))
            true = v[k] - np.interp(soc[k], z, u)
            r = track[seg[0] - 1]
            p = [num(r[c]) for c in ("window_r_ct", "window_q", "window_alpha")]
            span = i[max(0, k - 1000):k + 1]
            short, full = (branch(span, *p, m)[-1] for m in (64, len(span)))
            off = lambda x: f"{100 * (true - x) / slope:+.2f} %"  # noqa: E731
            print(f"{rec} rest ending at {k} s ({len(seg)} s), SOC {soc[k]:.3f}: polarization "
                  f"{1e3 * true:+.1f} mV; the one-step prediction's {1e3 * model[k]:+.1f} mV; the model's own "
                  f"relaxation {1e3 * short:+.2f} mV (short memory), {1e3 * full:+.2f} mV (full) | SOC read "
                  f"{100 * true / slope:+.2f} % off; with each taken off {off(model[k])}, {off(short)}, {off(full)}")


if __name__ == "__main__":
    main()
