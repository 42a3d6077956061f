#!/usr/bin/env python3
"""A cell's life (issue 70, docs/life.md): NASA PCoE cell B0005's 168
discharges through one `online battery` estimator, in the order of their
start times, the state carried from each to the next; against NASA's own
measurements of the same aging.

* `discharged_ah` of each log against NASA's measured capacity of that
  discharge (metadata.csv `Capacity`): the share within 2 %.
* `r_i` (the median R_i each log's windows identified): the share of logs
  with one; its Spearman rank correlation over life with the EIS `Re` and
  `Re + Rct` (metadata.csv, the impedance tests, linear in time at each
  log's start); beside a crude baseline measured here on the same logs,
  the voltage step over the current step at each discharge's first loaded
  row.
* growth over life (the mean of the last ten logs over the first ten's)
  of each.
* the whole life's wall time, one command, pinned to one core
  (`taskset -c 0` where there is one), median of three.

    cargo build --release -p host-sim
    python3 bench/life_nasa.py [--host-sim target/release/host-sim] [--window 256] [--memory M] [--out target/life]
        [--online-args "..."]
        [--data data/nasa-pcoe-b0005] [--voltage-min 2.7]

`--data` is a folder laid out as `data/nasa-pcoe-b0005` (`metadata.csv`
and `discharge/`); another cell of the same test is run with its own
cut-off (`--voltage-min`: B0006 and B0018 2.5 V, B0007 2.2 V, from the
dataset's description).
"""

import argparse
import csv
import os
import shlex
import shutil
import statistics
import subprocess
import time

import numpy as np
from scipy.stats import spearmanr



def matlab_seconds(vector):
    import datetime as dt

    y, m, d, h, mi, s = (float(x) for x in vector.strip("[]").split())
    t = dt.datetime(int(y), int(m), int(d), int(h), int(mi)) + dt.timedelta(seconds=s)
    return t.replace(tzinfo=dt.timezone.utc).timestamp()


def metadata(data):
    rows = list(csv.DictReader(open(f"{data}/metadata.csv")))
    for r in rows:
        r["t"] = matlab_seconds(r["start_time"])
    return rows


def impedance(meta):
    """The EIS tests with an `Re`, in time order: their start times (s),
    `Re` and `Rct` (ohm)."""
    imp = sorted((r for r in meta if r["type"] == "impedance" and r["Re"]), key=lambda r: r["t"])
    return (np.array([r["t"] for r in imp]), np.array([float(r["Re"]) for r in imp]),
            np.array([float(r["Rct"]) for r in imp]))


def first_step(path):
    """The voltage step over the current step at the first loaded row
    (|I| > 1 A) against the row before it (Ω)."""
    d = np.genfromtxt(path, delimiter=",", names=True)
    i, v = d["Current_measured"], d["Voltage_measured"]
    k = int(np.argmax(np.abs(i) > 1.0))
    return (v[k] - v[k - 1]) / (i[k] - i[k - 1])


def after_load(path):
    """The charge counted after the last loaded row (|I| > 1 A), the load
    switching off (A h), each row's current held to the next."""
    d = np.genfromtxt(path, delimiter=",", names=True)
    t, i = d["Time"], d["Current_measured"]
    last = np.nonzero(np.abs(i) > 1.0)[0][-1]
    return -np.sum(i[last:-1] * np.diff(t)[last:]) / 3600


def count_to(path, volts):
    """The charge counted up to the first loaded row (|I| > 1 A) below
    `volts` (A h), each row's current held to the next: a capacity to that
    cut-off."""
    d = np.genfromtxt(path, delimiter=",", names=True)
    t, i, v = d["Time"], d["Current_measured"], d["Voltage_measured"]
    k = np.nonzero((np.abs(i) > 1.0) & (v < volts))[0]
    if len(k) == 0:
        return np.nan
    return -np.sum(i[:k[0]] * np.diff(t)[:k[0]]) / 3600


def rest_after_load(path):
    """The time logged after the last loaded row (|I| > 1 A): the rest at
    the log's end (s)."""
    d = np.genfromtxt(path, delimiter=",", names=True)
    t, i = d["Time"], d["Current_measured"]
    last = np.nonzero(np.abs(i) > 1.0)[0][-1]
    return t[-1] - t[last]


def growth(x):
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return x[-10:].mean() / x[:10].mean()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--host-sim", default="target/release/host-sim")
    ap.add_argument("--out", default="target/life")
    ap.add_argument("--window", default="256")
    ap.add_argument("--memory", default=None, help="the estimator's memory (default: the window's quarter)")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--data", default="data/nasa-pcoe-b0005")
    ap.add_argument("--voltage-min", default="2.7")
    ap.add_argument("--online-args", default="",
                    help="more arguments for `online battery`, as one string (e.g. \"--start at-rest\")")
    a = ap.parse_args()
    data = a.data
    os.makedirs(a.out, exist_ok=True)
    times = os.path.join(a.out, "start_times.csv")
    with open(times, "w") as f:
        subprocess.run(["python3", "bench/nasa_start_times.py", data], stdout=f, check=True)
    life = os.path.join(a.out, "life.csv")
    cmd = [a.host_sim, "online", "battery", "--input", f"{data}/discharge",
           "--start-times", times, "--window", a.window,
           "--voltage-min", a.voltage_min, "--voltage-max", "4.2",
           "--out", os.path.join(a.out, "tracks"), "--life-out", life]
    if a.memory:
        cmd += ["--memory", a.memory]
    cmd += shlex.split(a.online_args)
    pin = ["taskset", "-c", "0"] if shutil.which("taskset") else []
    secs = []
    for _ in range(a.runs):
        t0 = time.perf_counter()
        subprocess.run(pin + cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        secs.append(time.perf_counter() - t0)
    rows = list(csv.DictReader(open(life)))
    meta = metadata(data)
    by_file = {r["filename"]: r for r in meta if r["type"] == "discharge"}
    ti, re, rct = impedance(meta)

    names = [os.path.basename(r["file"]) for r in rows]
    t = np.array([by_file[n]["t"] for n in names])
    nasa = np.array([float(by_file[n]["Capacity"]) for n in names])
    dis = np.array([float(r["discharged_ah"]) if r["discharged_ah"] else np.nan for r in rows])
    r_i = np.array([float(r["r_i"]) if r["r_i"] else np.nan for r in rows])
    re_t = np.interp(t, ti, re)
    rerct_t = np.interp(t, ti, re + rct)
    base = np.array([first_step(f"{data}/discharge/{n}") for n in names])
    ok = np.isfinite(r_i)

    within = np.abs(dis / nasa - 1) <= 0.02
    cell = os.path.basename(os.path.normpath(data))
    print(f"{cell}: {len(rows)} discharges, {len(ti)} impedance tests; life in one command "
          f"(window {a.window}): {statistics.median(secs):.2f} s median of {a.runs} on one core")
    print(f"discharged_ah within 2 % of NASA's capacity: {within.sum()} of {len(rows)} "
          f"({within.mean():.1%}); ratio median {np.median(dis / nasa):.4f}, "
          f"range {np.min(dis / nasa):.4f}-{np.max(dis / nasa):.4f}")
    cap = np.array([float(r["capacity_ah"]) if r["capacity_ah"] else np.nan for r in rows])
    checks = np.array([r["capacity_source"] == "full_discharge" for r in rows])
    soh_c = np.array([float(r["soh_c"]) if r["soh_c"] else np.nan for r in rows])
    nasa_soh = nasa / nasa[0]
    print(f"capacity checks recognised (rest at 4.2 V to {a.voltage_min} V, capacity_source=full_discharge): "
          f"{checks.sum()} of {len(rows)}; soh_c against NASA's capacity over its first: "
          f"largest difference {np.nanmax(np.abs(soh_c - nasa_soh)):.4f}, "
          f"at the end {soh_c[-1]:.4f} vs {nasa_soh[-1]:.4f}")
    tail = np.array([after_load(f"{data}/discharge/{n}") for n in names])
    print(f"counted after the last loaded row (the load switching off): median {np.median(tail):.4f} A h, "
          f"at most {tail.max():.4f} A h; the baseline at the first log {base[0]:.4f} ohm, "
          f"EIS Re then {re_t[0]:.4f} ohm")
    to27 = np.array([count_to(f"{data}/discharge/{n}", 2.7) for n in names]) / nasa
    print(f"counted to the first loaded row below 2.7 V, over NASA's capacity: median "
          f"{np.nanmedian(to27):.4f}, range {np.nanmin(to27):.4f}-{np.nanmax(to27):.4f} "
          f"({np.isfinite(to27).sum()} logs reach 2.7 V)")
    rest = np.array([rest_after_load(f"{data}/discharge/{n}") for n in names])
    print(f"rest logged after the last loaded row: {rest.min():.0f}-{rest.max():.0f} s, "
          f"median {np.median(rest):.0f} s")
    print()
    print("| resistance | logs with a value | Spearman with Re | with Re + Rct | growth over life (last 10 / first 10) |")
    print("|---|---|---|---|---|")
    print(f"| EIS Re (interpolated at each log's start) | {len(rows)} | 1 | "
          f"{spearmanr(re_t, rerct_t)[0]:.3f} | {growth(re_t):.3f} |")
    print(f"| EIS Re + Rct | {len(rows)} | {spearmanr(rerct_t, re_t)[0]:.3f} | 1 | {growth(rerct_t):.3f} |")
    if ok.sum() >= 3:
        print(f"| `r_i` (online, median per log) | {ok.sum()} ({ok.mean():.1%}) | "
              f"{spearmanr(r_i[ok], re_t[ok])[0]:.3f} | {spearmanr(r_i[ok], rerct_t[ok])[0]:.3f} | "
              f"{growth(r_i):.3f} |")
    else:
        print(f"| `r_i` (online, median per log) | {ok.sum()} ({ok.mean():.1%}) | — | — | — |")
    print(f"| crude baseline: ΔV/ΔI at the first loaded row | {len(rows)} | "
          f"{spearmanr(base, re_t)[0]:.3f} | {spearmanr(base, rerct_t)[0]:.3f} | {growth(base):.3f} |")


if __name__ == "__main__":
    main()
