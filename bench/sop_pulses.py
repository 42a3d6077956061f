#!/usr/bin/env python3
"""State of power on a measured cell (issue 36): at every discharge pulse
of the Panasonic 18650PF 25 degC HPPC test, the `pulse_v_{H}s` that
`online battery` published at the last sample before the pulse (no prior,
window 256, its OCV table, `--pulse-current-a` the pulse's own current)
against the measured voltage H seconds into the pulse (the raw 0.1 s
data). Pulses shorter than H are left out.

    cargo build --release -p host-sim
    bash bench/panasonic_chain.sh          # target/real-cells/panasonic/ocv.csv
    python3 bench/sop_pulses.py [--host-sim target/release/host-sim] [--out target/sop]
"""

import argparse
import csv
import os
import subprocess

import numpy as np
import scipy.io as sio

PANASONIC = "data/panasonic-18650pf/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat"
PAN_OCV = "target/real-cells/panasonic/ocv.csv"
HORIZONS = (2, 10)


def pulses():
    """(start time, current, length s) of every discharge pulse from rest."""
    m = sio.loadmat(PANASONIC)["meas"][0, 0]
    t, i, v = (m[k].ravel() for k in ("Time", "Current", "Voltage"))
    edge = (np.diff(i) < -1.0) & (np.abs(i[:-1]) < 0.05) & (np.diff(t) < 0.2)
    out = []
    for j in np.where(edge)[0]:
        e = j + 1
        while e < len(i) and abs(i[e] - i[j + 1]) < 0.2:
            e += 1
        out.append((t[j], i[j + 1], t[e - 1] - t[j]))
    return out, (t, v)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--host-sim", default="target/release/host-sim")
    ap.add_argument("--out", default="target/sop")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    ps, (t, v) = pulses()
    currents = sorted({round(c, 1) for _, c, _ in ps})
    rows = []
    for c in currents:
        track = f"{a.out}/pulse{c}.csv"
        subprocess.run([a.host_sim, "online", "battery", "--input", PANASONIC, "--ocv", PAN_OCV,
                        "--capacity-ah", "2.9", "--window", "256", "--pulse-current-a", str(c),
                        "--horizons", ",".join(map(str, HORIZONS)), "--out", track],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        tr = list(csv.DictReader(open(track)))
        tt = np.array([float(r["time_s"]) for r in tr])
        for start, cur, length in ps:
            if round(cur, 1) != c:
                continue
            k = np.searchsorted(tt, start, side="right") - 1
            if k < 0:
                continue
            before = np.interp(start, t, v)
            for h in HORIZONS:
                if length < h:
                    continue
                p = tr[k][f"pulse_v_{h}s"]
                measured = np.interp(start + h, t, v)
                rows.append((h, c, start, float(p) if p else np.nan, measured, before - measured))
    for h in HORIZONS:
        r = np.array([x[3:] for x in rows if x[0] == h])
        if not len(r):
            continue
        pub = np.isfinite(r[:, 0])
        err = np.abs(r[pub, 0] - r[pub, 1])
        rel = err / np.abs(r[pub, 2])
        print(f"pulse_v_{h}s: {pub.sum()} of {len(r)} pulses with a published prediction; "
              f"error median {1e3 * np.median(err):.1f} mV, max {1e3 * err.max():.1f} mV; "
              f"of the drop: median {100 * np.median(rel):.1f} %, 90th percentile "
              f"{100 * np.percentile(rel, 90):.1f} %, max {100 * rel.max():.1f} %")


if __name__ == "__main__":
    main()
