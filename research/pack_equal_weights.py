#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Is the pack's worst cell outside ±10 % because the slow part's mean weighs each window by its own information?
# Answer: no: weighing every window alike gives the same shares (worst cell's Q 89.2-91.5 % at 600 s, against 88.3-91.0 %); the rows outside are the first windows'; see "One order for a pack's cells".
"""Emulates, from the tracks of `python3 bench/pack_slow_part.py` (its
`--memories` with 0 and 600, default `--out`), the slow part's mean with
every identified window weighed alike, forgetting over `--memory-s` (no
SOC term: the pack records have no OCV curve), published where the
window-by-window track publishes; beside the build's own mean at 600 s
(information-weighted). Prints, per profile and parameter, the share of
rows within ±10 % of the truth from each cell's first identified window
on (a row without a value outside), pooled over the cells and seeds and
for the worst cell, as the bench counts them.

    python3 bench/pack_slow_part.py --memories 0,200,400,600
    python3 research/pack_equal_weights.py [--dir target/pack-slow-part] [--memory-s 200,600,1800]
"""

import argparse
import csv
import json
import math


def truths(d, profile, seed):
    return {c["cell"]: c for c in json.load(open(f"{d}/{profile}-{seed}.json"))["cells"]}


def equal_weights(d, profile, seed, tau, key):
    """Per cell (rows within ±10 %, rows counted) of the equal-weight mean."""
    truth = truths(d, profile, seed)
    state = {}
    for r in csv.DictReader(open(f"{d}/{profile}-{seed}-slow0-track.csv")):
        c, t = int(r["cell"]), float(r["time_s"])
        w, s, last, within, n = state.get(c, (0.0, 0.0, None, 0, 0))
        if r[f"{key}_status"] == "identified" and r[key]:
            if last is not None:
                keep = math.exp(-(t - last) / tau)
                w, s = w * keep, s * keep
            w, s, last = w + 1.0, s + math.log(float(r[key])), t
        if last is not None:
            n += 1
            if r[key]:
                within += abs(math.exp(s / w) / truth[c][key] - 1) <= 0.10
        state[c] = (w, s, last, within, n)
    return {c: (v[3], v[4]) for c, v in state.items()}


def built(d, profile, seed, key, memory="600"):
    """The same count on the build's own track at that slow memory."""
    truth = truths(d, profile, seed)
    out, started = {}, set()
    for r in csv.DictReader(open(f"{d}/{profile}-{seed}-slow{memory}-track.csv")):
        c = int(r["cell"])
        if r[f"{key}_status"] == "identified":
            started.add(c)
        if c not in started:
            continue
        within, n = out.get(c, (0, 0))
        if r[key]:
            within += abs(float(r[key]) / truth[c][key] - 1) <= 0.10
        out[c] = (within, n + 1)
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dir", default="target/pack-slow-part")
    ap.add_argument("--memory-s", default="200,600,1800")
    ap.add_argument("--seeds", default="1,2,3")
    a = ap.parse_args()
    seeds = [int(s) for s in a.seeds.split(",")]
    print("| profile | parameter | mean | pooled | worst cell |")
    print("|---|---|---|---|---|")
    for profile in ("hppc", "drive"):
        for key in ("r_ct", "q"):
            runs = [("information-weighted, 600 s (the build)", lambda s: built(a.dir, profile, s, key))]
            runs += [(f"equal weights, {m} s", lambda s, m=float(m): equal_weights(a.dir, profile, s, m, key))
                     for m in a.memory_s.split(",")]
            for label, f in runs:
                tw = tn = 0
                worst = 1.0
                for s in seeds:
                    for within, n in f(s).values():
                        tw, tn, worst = tw + within, tn + n, min(worst, within / n)
                print(f"| {profile} | {key} | {label} | {100 * tw / tn:.1f} % | {100 * worst:.1f} % |")


if __name__ == "__main__":
    main()
