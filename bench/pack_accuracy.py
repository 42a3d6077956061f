#!/usr/bin/env python3
"""Per-cell accuracy of a pack estimate against the truth of `host-sim simulate pack`.

    python3 bench/pack_accuracy.py TRUTH.json ESTIMATE.json|TRACK.csv

ESTIMATE is the last line of `cargo xtask qemu --input PACK.csv` (saved as JSON)
or the track of `host-sim online pack` (its last row per cell is used). Prints a
Markdown table: each cell's error (R_i, R_ct, Q relative; alpha absolute), the
flag, and whether it is inside the issue's bands (R_i 5 %, R_ct 10 %, Q 15 %,
alpha 0.05).
"""
import csv
import json
import sys

BANDS = {"r_i": 0.05, "r_ct": 0.10, "q": 0.15, "alpha": 0.05}


def estimates(path):
    if path.endswith(".csv"):
        last = {}
        with open(path) as f:
            for row in csv.DictReader(f):
                last[int(row["cell"])] = row
        out = []
        for k in sorted(last):
            r = last[k]
            num = lambda key: float(r[key]) if r[key] else None
            out.append({"cell": k, **{key: num(key) for key in ["r_i", "r_ct", "q", "alpha"]},
                        "flagged": r.get("flagged") == "1"})
        return out
    with open(path) as f:
        text = f.read().strip().splitlines()[-1]
    return json.loads(text)["cells"]


def main():
    truth = json.load(open(sys.argv[1]))["cells"]
    est = estimates(sys.argv[2])
    print("| cell | aged | R_i | R_ct | Q | alpha | flagged | inside the bands |")
    print("|---|---|---|---|---|---|---|---|")
    inside = 0
    for t, e in zip(truth, est):
        errs = {}
        for key in ["r_i", "r_ct", "q"]:
            errs[key] = None if e[key] is None else e[key] / t[key] - 1.0
        errs["alpha"] = None if e["alpha"] is None else e["alpha"] - t["alpha"]
        ok = all(v is not None and abs(v) <= BANDS[k] for k, v in errs.items())
        inside += ok
        fmt = lambda k: "-" if errs[k] is None else (
            f"{errs[k]:+.4f}" if k == "alpha" else f"{100 * errs[k]:+.1f} %")
        print(f"| {t['cell']} | {'yes' if t['aged'] else ''} | {fmt('r_i')} | {fmt('r_ct')} | "
              f"{fmt('q')} | {fmt('alpha')} | {'yes' if e['flagged'] else ''} | {'yes' if ok else 'no'} |")
    print(f"\n{inside} of {len(truth)} cells inside all bands.")


if __name__ == "__main__":
    main()
