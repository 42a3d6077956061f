#!/usr/bin/env python3
"""The start times of a NASA PCoE cell's discharge logs, as `online battery
--start-times` takes them (`file,start_time`, ISO 8601), from the test's
own log (`metadata.csv`: each test's start as a MATLAB date vector
`[Y M D h m s]`, the rig's local time, written here without a zone).

    python3 bench/nasa_start_times.py [data/nasa-pcoe-b0005] > start_times.csv
"""

import csv
import sys


def iso(vector):
    y, m, d, h, mi, s = (float(x) for x in vector.strip("[]").split())
    whole = int(s)
    frac = f"{s - whole:.3f}"[1:]
    return f"{int(y):04d}-{int(m):02d}-{int(d):02d}T{int(h):02d}:{int(mi):02d}:{whole:02d}{frac}"


def main():
    folder = sys.argv[1] if len(sys.argv) > 1 else "data/nasa-pcoe-b0005"
    print("file,start_time,test_id")
    with open(f"{folder}/metadata.csv") as f:
        for r in csv.DictReader(f):
            if r["type"] == "discharge":
                print(f"{r['filename']},{iso(r['start_time'])},{r['test_id']}")


if __name__ == "__main__":
    main()
