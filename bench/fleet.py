"""Files per second when many cells' logs are fitted at once.

The measured Panasonic NCR18650PF records of data/ (the HPPC and US06 tests at
25 and 10 °C, MAT-files as published), each copied `--copies` times under
another name: 4 × copies files, fitted with the 25 °C OCV table from
`bash bench/panasonic_chain.sh` and 2.9 A·h. Wall times (time.perf_counter)
of one run each, in this order:
  - `host-sim identify battery --input DIR --summary-out` with --jobs 1, 2;
  - fracbms.identify_files(DIR, jobs=1|2) (the same pool from Python, the GIL
    released);
  - two Python threads each calling identify_files on half the files with
    jobs=1, against one thread on all (the GIL released: the threads run
    at once);
  - fracbms.fleet.identify_many on a Dask LocalCluster of 1 and 2 worker
    processes (1 thread each), the cluster's start not counted;
and whether every run gave the same rows (fit_s aside).

    bash bench/panasonic_chain.sh            # target/real-cells/panasonic/ocv.csv
    cargo build --release -p host-sim
    python3 -m venv .venv && .venv/bin/pip install './python[fleet]'
    .venv/bin/python bench/fleet.py [--copies 2] [--model linear]
"""

import argparse
import concurrent.futures
import csv
import pathlib
import shutil
import subprocess
import tempfile
import time

import fracbms
import fracbms.fleet

REPO = pathlib.Path(__file__).resolve().parents[1]
DATA = REPO / "data" / "panasonic-18650pf"
RECORDS = [
    "03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat",
    "03-20-17_01.43 25degC_US06_Pan18650PF.mat",
    "03-27-17_09.06 10degC_5Pulse_HPPC_Pan18650PF.mat",
    "03-27-17_09.06 10degC_US06_Pan18650PF.mat",
]


def timed(f):
    t0 = time.perf_counter()
    r = f()
    return time.perf_counter() - t0, r


def strip(rows):
    """The rows as a DataFrame without the wall time."""
    import pandas as pd

    return pd.DataFrame(list(rows), columns=list(fracbms.SUMMARY_COLUMNS)).drop(columns="fit_s")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--copies", type=int, default=2)
    ap.add_argument("--model", default="linear")
    ap.add_argument("--ocv", default=str(REPO / "target/real-cells/panasonic/ocv.csv"))
    a = ap.parse_args()
    options = dict(ocv=a.ocv, capacity_ah=2.9, model=a.model)
    hs = REPO / "target" / "release" / "host-sim"
    with tempfile.TemporaryDirectory() as tmp:
        d = pathlib.Path(tmp) / "logs"
        d.mkdir()
        for c in range(a.copies):
            for r in RECORDS:
                shutil.copy(DATA / r, d / f"copy{c}-{r}")
        files = fracbms.expand_inputs(str(d))
        n = len(files)
        print(f"{n} files ({a.copies} copies of {len(RECORDS)} Panasonic records), model {a.model}")
        results = {}

        def line(name, seconds, rows):
            results[name] = strip(rows)
            ok = sum(r["status"] == "ok" for r in rows)
            print(f"| {name} | {seconds:.1f} | {n / seconds:.3f} | {ok}/{n} |")

        print("| run | wall s | files/s | fitted |\n|---|---:|---:|---:|")
        for jobs in (1, 2):
            out = pathlib.Path(tmp) / f"cli-{jobs}.csv"
            cmd = [str(hs), "identify", "battery", "--input", str(d), "--ocv", a.ocv,
                   "--capacity-ah", "2.9", "--model", a.model, "--jobs", str(jobs),
                   "--summary-out", str(out)]
            s, _ = timed(lambda: subprocess.run(cmd, capture_output=True, check=False))
            with open(out, newline="") as f:
                rows = list(csv.DictReader(f))
            ok = sum(r["status"] == "ok" for r in rows)
            print(f"| `host-sim … --jobs {jobs}` | {s:.1f} | {n / s:.3f} | {ok}/{n} |")
        for jobs in (1, 2):
            s, rows = timed(lambda: fracbms.identify_files(str(d), jobs=jobs, **options))
            line(f"`identify_files(jobs={jobs})`", s, rows)
        half = [files[: n // 2], files[n // 2 :]]
        with concurrent.futures.ThreadPoolExecutor(2) as ex:
            s, parts = timed(
                lambda: list(ex.map(lambda p: fracbms.identify_files(p, jobs=1, **options), half))
            )
        line("2 Python threads, `jobs=1` each", s, parts[0] + parts[1])
        from dask.distributed import Client, LocalCluster

        for workers in (1, 2):
            with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                              dashboard_address=None) as cluster, Client(cluster) as client:
                client.wait_for_workers(workers)
                s, df = timed(lambda: fracbms.fleet.identify_many(files, client, **options))
            line(f"Dask LocalCluster, {workers} worker(s)", s, df.to_dict("records"))
        ref = results["`identify_files(jobs=1)`"]
        same = all(v.equals(ref) for v in results.values())
        print(f"same rows in every Python run: {same}")


if __name__ == "__main__":
    main()
