#!/usr/bin/env python3
"""Bias and window-to-window spread of a pack track against its truth.

    python3 bench/pack_track_spread.py TRUTH.json TRACK.csv [TRUTH.json TRACK.csv ...] [--after 600]

TRUTH is the ``FILE.json`` of ``host-sim simulate pack``, TRACK the
``--out`` of ``host-sim online pack``. Over every row whose status is
``tracking`` after ``--after`` seconds, of every cell of every pair, prints
per parameter the mean error (the bias: R_ct and Q relative, alpha
absolute), its standard deviation (the spread from one window to the next)
and the share of rows outside the pack bands (R_ct 10 %, Q 15 %, alpha
0.05). A last estimate outside the bands with a small bias is the spread,
not the model (docs/pack.md).
"""
import csv
import json
import statistics
import sys

BANDS = {"r_ct": 0.10, "q": 0.15, "alpha": 0.05}


def main():
    args = sys.argv[1:]
    after = 600.0
    if "--after" in args:
        k = args.index("--after")
        after = float(args[k + 1])
        del args[k:k + 2]
    if not args or len(args) % 2:
        sys.exit("usage: pack_track_spread.py TRUTH.json TRACK.csv [...] [--after S]")
    err = {k: [] for k in BANDS}
    for truth_path, track_path in zip(args[::2], args[1::2]):
        truth = {c["cell"]: c for c in json.load(open(truth_path))["cells"]}
        for r in csv.DictReader(open(track_path)):
            if r["status"] != "tracking" or float(r["time_s"]) < after or not r["q"]:
                continue
            t = truth[int(r["cell"])]
            err["r_ct"].append(float(r["r_ct"]) / t["r_ct"] - 1)
            err["q"].append(float(r["q"]) / t["q"] - 1)
            err["alpha"].append(float(r["alpha"]) - t["alpha"])
    print(f"{len(err['q'])} tracked rows")
    print("| parameter | mean error | sd | rows outside the band |")
    print("|---|---|---|---|")
    for k, band in BANDS.items():
        x = err[k]
        out = sum(abs(v) > band for v in x) / len(x)
        print(f"| {k} | {statistics.mean(x):+.4f} | {statistics.pstdev(x):.4f} | {100 * out:.1f} % |")


if __name__ == "__main__":
    main()
