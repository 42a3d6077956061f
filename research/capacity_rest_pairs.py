#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Would a capacity from the rests alone (the charge counted between rests over the SOC their voltages read) keep a capacity started right within 1 %?
# Answer: no: on the Panasonic HPPC test the first estimate whose 95 % interval is within 5 % is 3.4-11.9 % low (the table's shape near full charge), though the line over every rest ends within 0.4 %; not built.
"""Capacity from rests alone (issue 72, item 3; docs/research.md, "The
SOC observer at rest").

On the Panasonic 18650PF 25 degC HPPC export as it comes, each rest of
at least 600 s (or its first 3600 s) gives the SOC its last 16 voltages
read through the C/20 OCV table, and the export's own `Ah` count at that
row. Two estimators of the capacity, each published once its 95 %
interval is within 5 % of it and the rests span at least 0.3 of SOC:

* a weighted line through every rest so far (SOC against counted
  charge), each rest weighed as the SOC observer weighs it (5 mV over the
  table's slope, in quadrature with the table's own 0.01-0.03 in SOC),
  with and without its spread scaled by the residuals;
* the pair of the highest- and the lowest-SOC rest so far.

It prints when each is first published, its value then, and the range
it moves over from there, against the C/20 test's 2.995 A h.

    bash bench/panasonic_chain.sh          # target/real-cells/panasonic/ocv.csv
    python3 research/capacity_rest_pairs.py
"""

import numpy as np
import scipy.io as sio

HPPC = "data/panasonic-18650pf/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat"
OCV = "target/real-cells/panasonic/ocv.csv"
MEASURED_AH = 2.995
MIN_SPAN = 0.3


def rest_rows():
    """Each rest's end time, its last 16 voltages' mean and the export's
    `Ah` count at its end."""
    m = sio.loadmat(HPPC)["meas"][0, 0]
    t, i, v, ah = (m[k].ravel() for k in ("Time", "Current", "Voltage", "Ah"))
    ends, start, last = [], None, None
    for k in range(1, len(t)):
        if abs(i[k]) < 0.06 and t[k] - t[k - 1] < 100:
            start = t[k] if start is None else start
            if t[k] - start >= 3600 and last != start:
                ends.append(k)
                last = start
        else:
            if start is not None and t[k - 1] - start >= 600 and last != start:
                ends.append(k - 1)
                last = start
            start = None
    vr = np.array([v[max(0, k - 15):k + 1].mean() for k in ends])
    return t[ends], vr, ah[ends]


def rests():
    o = np.genfromtxt(OCV, delimiter=",", names=True)
    t, vr, ah = rest_rows()
    z = np.interp(vr, o["ocv_v"], o["soc"])
    slope = np.abs(np.interp(z, o["soc"], np.gradient(o["ocv_v"], o["soc"])))
    return t, z, ah, slope


def report(name, published):
    if not published:
        print(f"{name}: never published")
        return
    (t0, c0), caps = published[0], np.array([c for _, c in published])
    print(f"{name}: first published at {t0:.0f} s at {c0 / MEASURED_AH - 1:+.1%}; "
          f"from there {caps.min() / MEASURED_AH - 1:+.1%} to {caps.max() / MEASURED_AH - 1:+.1%}, "
          f"at the end {caps[-1] / MEASURED_AH - 1:+.1%}")


def main():
    t, z, q, slope = rests()
    print(f"{len(z)} rests, SOC {z.min():.2f}-{z.max():.2f}")
    for table in (0.01, 0.02, 0.03):
        w = 1 / ((0.005 / np.maximum(slope, 1e-3)) ** 2 + table ** 2)
        for scaled in (False, True):
            out = []
            for n in range(3, len(z) + 1):
                W, Q, Z = w[:n], q[:n], z[:n]
                qb, zb = (W * Q).sum() / W.sum(), (W * Z).sum() / W.sum()
                sqq = (W * (Q - qb) ** 2).sum()
                s = (W * (Q - qb) * (Z - zb)).sum() / sqq
                chi = (W * (Z - zb - s * (Q - qb)) ** 2).sum() / (n - 2)
                c = 1 / s
                sd = c * c * np.sqrt((max(1.0, chi) if scaled else 1.0) / sqq)
                if Z.max() - Z.min() >= MIN_SPAN and 1.96 * sd <= 0.05 * c:
                    out.append((t[n - 1], c))
            report(f"line, table {table}{', residual-scaled' if scaled else ''}", out)
        hi = lo = None
        out = []
        var = (0.005 / np.maximum(slope, 1e-3)) ** 2 + table ** 2
        for n in range(len(z)):
            r = (z[n], q[n], var[n])
            hi = r if hi is None or r[0] > hi[0] else hi
            lo = r if lo is None or r[0] < lo[0] else lo
            dz = hi[0] - lo[0]
            if dz >= MIN_SPAN:
                c = (hi[1] - lo[1]) / dz
                if 1.96 * c * np.sqrt(hi[2] + lo[2]) / dz <= 0.05 * c:
                    out.append((t[n], c))
        report(f"extreme pair, table {table}", out)


if __name__ == "__main__":
    main()
