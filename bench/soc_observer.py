#!/usr/bin/env python3
"""The SOC observer on PyBaMM DFN records (issue 36): `online battery
--soc observer` against the records' true SOC, beside plain counting.

Each record (data/pybamm, 1 s: the `soc` records with rests of 15 min,
the HPPC records with rests of 5 min and `--soc-rest-s 300`) is fed four
ways: as it is; with a current-sensor bias of +1 % of 1C; with a start
SOC 10 % off (`--soc0`); and both. The worst |SOC - truth| after the
first rest that corrects the SOC, for the published `soc` and for
`soc_coulomb`. Then the capacity: the same record with `--capacity-ah`
10 % high.

    cargo build --release -p host-sim
    python3 bench/soc_observer.py [--host-sim target/release/host-sim] [--out target/soc-observer]
"""

import argparse
import csv
import json
import os
import subprocess

import numpy as np

# The record and the shortest rest that corrects the SOC (s): the `soc`
# records' rests are 15 min (the default 600 s applies); the HPPC
# records' only 5 min.
RECORDS = (("chen2020-soc", 600), ("prada2013-soc", 600), ("chen2020-hppc", 300), ("prada2013-hppc", 300))


def read(path):
    rows = list(csv.DictReader(open(path)))
    f = lambda x: float(x) if x else np.nan  # noqa: E731
    return {k: np.array([f(r[k]) for r in rows]) for k in rows[0] if k not in ("status",) and not k.endswith("_status") and k != "rejected"}


def first_rest_end(current, rest_s, capacity):
    """The index after the first rest of at least rest_s samples (1 s)."""
    n = 0
    for k, i in enumerate(current):
        if abs(i) <= capacity / 50:
            n += 1
        else:
            if n >= rest_s:
                return k
            n = 0
    return len(current)


def rests(current, rest_s, capacity):
    """(start, end) of every rest of at least rest_s samples (1 s)."""
    out, n = [], 0
    for k, i in enumerate(list(current) + [np.inf]):
        if abs(i) <= capacity / 50:
            n += 1
        else:
            if n >= rest_s:
                out.append((k - n, k))
            n = 0
    return out


def rest_readings(rec, d, rest_s, cap):
    """What a rest reads: the OCV table's inverse of each rest's last
    voltage against the true SOC there; the same of the voltage the
    observer reads (the rest's mean over about its last half minute, the
    core's `Rest::push`: an exponential mean with weight h/30 per sample);
    and the table's slope (V per unit SOC)."""
    o = read(f"data/pybamm/{rec.split('-')[0]}-ocv.csv")
    slope = np.gradient(o["ocv_v"], o["soc"])
    rows = []
    for a, b in rests(d["current_a"], rest_s, cap):
        z = d["soc_true"][b - 1]
        read_z = np.interp(d["voltage_v"][b - 1], o["ocv_v"], o["soc"])
        mean = d["voltage_v"][a]
        for v in d["voltage_v"][a + 1:b]:
            mean += (v - mean) / 30.0
        read_mean = np.interp(mean, o["ocv_v"], o["soc"])
        rows.append((a, b, z, read_z - z, np.interp(z, o["soc"], slope), read_mean - z))
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--host-sim", default="target/release/host-sim")
    ap.add_argument("--out", default="target/soc-observer")
    ap.add_argument("--soc-voltage-sigma-v", type=float,
                    help="passed to online battery: the spread of a rested voltage as the OCV (default 0.005)")
    a = ap.parse_args()
    extra = [] if a.soc_voltage_sigma_v is None else ["--soc-voltage-sigma-v", str(a.soc_voltage_sigma_v)]
    os.makedirs(a.out, exist_ok=True)
    meta = json.load(open("data/pybamm/meta.json"))["records"]
    print(f"| record | case | observer worst | coulomb worst | observer at end | coulomb at end | bias (A) | capacity (A·h) |")
    print("|---|---|---|---|---|---|---|---|")
    for rec, rest_s in RECORDS:
        m = meta[rec]
        cap = m["capacity_ah"]
        d = read(f"data/pybamm/{rec}.csv")
        truth = d["soc_true"]
        start = first_rest_end(d["current_a"], rest_s, cap)
        cases = [("none", 0.0, 0.0, 1.0), ("bias +1% 1C", cap / 100, 0.0, 1.0),
                 ("start -10%", 0.0, -0.1, 1.0), ("both", cap / 100, +0.1 if m["soc0"] < 0.85 else -0.1, 1.0),
                 ("capacity +10%", 0.0, 0.0, 1.1)]
        for case, bias, off, cscale in cases:
            path = os.path.join(a.out, f"{rec}-in.csv")
            with open(path, "w") as f:
                f.write("time_s,current_a,voltage_v\n")
                for t, i, v in zip(d["time_s"], d["current_a"], d["voltage_v"]):
                    f.write(f"{t:g},{i + bias:.9g},{v:.9g}\n")
            out = os.path.join(a.out, f"{rec}-{case.split()[0]}.csv")
            subprocess.run([a.host_sim, "online", "battery", "--input", path, "--window", "256",
                            "--ocv", f"data/pybamm/{rec.split('-')[0]}-ocv.csv",
                            "--capacity-ah", str(cap * cscale), "--soc0", str(m["soc0"] + off),
                            "--soc-rest-s", str(rest_s), "--out", out, *extra],
                           check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            t = read(out)
            status = list(csv.DictReader(open(out)))[-1]["capacity_status"]
            obs, cc = np.abs(t["soc"] - truth), np.abs(t["soc_coulomb"] - truth)
            after = slice(start, None)
            w = lambda x: f"{np.nanmax(x[after]):.4f}" if start < len(x) else "no rest"  # noqa: E731
            print(f"| {rec} | {case} | {w(obs)} | {w(cc)} | {obs[-1]:.4f} | {cc[-1]:.4f} | "
                  f"{t['current_bias_a'][-1]:+.4f} | {t['capacity_ah'][-1]:.3f} (true {cap:.3f}, {status}) |")
            if case.startswith("start"):
                readings = rest_readings(rec, d, rest_s, cap)
                good = [b for _, b, _, err, _, _ in readings if abs(err) <= 0.02]
                after_good = f"{np.nanmax(obs[good[0]:]):.4f}" if good else "no such rest"
                print(f"|   | rests: the table's reading of the rest's last voltage − truth "
                      f"(slope V/unit) | {'; '.join(f'{z:.3f}: {err:+.4f} ({sl:.3f})' for _, _, z, err, sl, _ in readings)} "
                      f"| observer worst after the first rest read within 0.02 | {after_good} |  |  |  |")
                print(f"|   | rests: the table's reading of the observer's rested voltage (the last half "
                      f"minute's mean) − truth | {'; '.join(f'{z:.3f}: {m:+.4f}' for _, _, z, _, _, m in readings)} "
                      f"|  |  |  |  |  |")


if __name__ == "__main__":
    main()
