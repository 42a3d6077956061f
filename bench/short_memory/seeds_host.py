#!/usr/bin/env python3
"""Summary of seeds_host.sh: per profile and sum, the mean over seeds of the
median (last 500 estimates) deviation from the whole-record fit, and the
largest single-seed deviation."""
import csv
import json
import statistics

KEYS = ["r_i", "r_ct", "q", "alpha"]


def median_dev(track, whole):
    rows = list(csv.DictReader(open(track)))[-500:]
    out = {}
    for k in KEYS:
        vals = [float(r[k]) for r in rows if r[k] not in ("", "nan")]
        m = statistics.median(vals)
        out[k] = m - whole[k] if k == "alpha" else (m / whole[k] - 1) * 100
    return out


def fmt(k, v):
    return f"{v:+.3f}" if k == "alpha" else f"{v:+.1f} %"


print("| profile | sum | mean R_i | mean R_ct | mean Q | mean α | worst seed R_ct | worst seed Q | worst seed α |")
print("|---|---|---|---|---|---|---|---|---|")
for p in ["pulse", "hppc", "drive"]:
    for tail in ["truncated", "tail", "tail-f32"]:
        devs = []
        for s in range(1, 7):
            whole = json.load(open(f"seeds/{p}_{s}.whole.json"))
            devs.append(median_dev(f"seeds/{p}_{s}.{tail}.csv", whole))
        mean = {k: statistics.mean(d[k] for d in devs) for k in KEYS}
        worst = {k: max((d[k] for d in devs), key=abs) for k in KEYS}
        print(f"| {p} | {tail} | " + " | ".join(fmt(k, mean[k]) for k in KEYS) + " | "
              + " | ".join(fmt(k, worst[k]) for k in ["r_ct", "q", "alpha"]) + " |")
