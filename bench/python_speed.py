"""The Python package's speed beside the CLI's on the same record.

Medians of `--runs` wall times (time.perf_counter) of
  - fracbms.identify_battery and `host-sim identify battery` (the process
    included: start, CSV read, JSON write);
  - fracbms.OnlineCell.run, OnlineCell.push per sample, and
    `host-sim online battery` (writing its CSV);
on the LG M50 drive cycle with its OCV table (data/pybamm).

    python3 -m venv .venv && .venv/bin/pip install ./python
    cargo build --release -p host-sim
    .venv/bin/python bench/python_speed.py [--runs 3]
"""

import argparse
import pathlib
import statistics
import subprocess
import tempfile
import time

import numpy as np

import fracbms

REPO = pathlib.Path(__file__).resolve().parents[1]
DATA = REPO / "data" / "pybamm"
CAPACITY_AH = 5.153198325955154


def median_time(f, runs):
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--host-sim", default=str(REPO / "target" / "release" / "host-sim"))
    a = ap.parse_args()
    d = np.genfromtxt(DATA / "chen2020-drive.csv", delimiter=",", names=True)
    o = np.genfromtxt(DATA / "chen2020-ocv.csv", delimiter=",", names=True)
    ocv = (o["soc"], o["ocv_v"])
    n = len(d)
    cli_ocv = ["--ocv", DATA / "chen2020-ocv.csv", "--capacity-ah", repr(CAPACITY_AH)]
    with tempfile.TemporaryDirectory() as tmp:
        def cli(*args):
            subprocess.run([a.host_sim, *map(str, args)], check=True, capture_output=True)

        py_fit = median_time(lambda: fracbms.identify_battery(
            d["time_s"], d["current_a"], d["voltage_v"], ocv=ocv, capacity_ah=CAPACITY_AH), a.runs)
        cli_fit = median_time(lambda: cli("identify", "battery", "--input",
                                          DATA / "chen2020-drive.csv", *cli_ocv,
                                          "--json", pathlib.Path(tmp) / "fit.json"), a.runs)
        py_run = median_time(lambda: fracbms.OnlineCell(ocv=ocv, capacity_ah=CAPACITY_AH).run(
            d["current_a"], d["voltage_v"]), a.runs)
        current, voltage = d["current_a"].tolist(), d["voltage_v"].tolist()

        def push_all():
            cell = fracbms.OnlineCell(ocv=ocv, capacity_ah=CAPACITY_AH, soc0=0.9)
            for i, v in zip(current, voltage):
                cell.push(i, v)

        py_push = median_time(push_all, a.runs)
        cli_online = median_time(lambda: cli("online", "battery", "--input",
                                             DATA / "chen2020-drive.csv", *cli_ocv,
                                             "--out", pathlib.Path(tmp) / "track.csv"), a.runs)
    print(f"chen2020-drive, {n} rows, OCV table, medians of {a.runs} runs")
    print(f"identify_battery      {py_fit:8.3f} s   host-sim identify battery {cli_fit:8.3f} s"
          f"   ratio {py_fit / cli_fit:.2f}")
    print(f"OnlineCell.run        {py_run:8.3f} s   host-sim online battery   {cli_online:8.3f} s"
          f"   ratio {py_run / cli_online:.2f}   ({n / py_run:.0f} samples/s)")
    print(f"OnlineCell.push       {py_push / n * 1e6:8.1f} µs a sample")


if __name__ == "__main__":
    main()
