#!/usr/bin/env python3
"""Lays out another NASA PCoE cell (B0006, B0007, B0018, …) as
`data/nasa-pcoe-b0005` is laid out, from a local clone of the source of
that folder, for `bench/life_nasa.py --data` (docs/life.md). Only the
cell's discharge CSVs and its rows of `metadata.csv` are read from the
clone, at the commit `data/nasa-pcoe-b0005/README.md` names; nothing is
written into the repository.

    git clone https://github.com/SYED-31/NASA_DATA_ANALYSIS_DEPLOY SRC
    python3 bench/nasa_cell.py SRC B0007 target/nasa/B0007
    python3 bench/life_nasa.py --data target/nasa/B0007 --voltage-min 2.2
"""

import csv
import io
import os
import subprocess
import sys

COMMIT = "bae88e9324e2078f286a311c3c6689bdbc8f4225"


def show(src, path):
    return subprocess.run(["git", "-C", src, "show", f"{COMMIT}:{path}"], check=True,
                          capture_output=True).stdout


def main():
    if len(sys.argv) != 4:
        sys.exit("usage: nasa_cell.py SRC_CLONE CELL OUT_DIR")
    src, cell, out = sys.argv[1:]
    text = show(src, "metadata.csv").decode()
    rows = list(csv.reader(io.StringIO(text)))
    header = rows[0]
    mine = [r for r in rows[1:] if r[header.index("battery_id")] == cell]
    if not mine:
        sys.exit(f"{cell}: no rows in metadata.csv")
    os.makedirs(f"{out}/discharge", exist_ok=True)
    with open(f"{out}/metadata.csv", "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        w.writerows(mine)
    n = 0
    for r in mine:
        if r[header.index("type")] == "discharge":
            name = r[header.index("filename")]
            with open(f"{out}/discharge/{name}", "wb") as f:
                f.write(show(src, f"data/{name}"))
            n += 1
    print(f"{cell}: {len(mine)} tests, {n} discharges in {out}")


if __name__ == "__main__":
    main()
