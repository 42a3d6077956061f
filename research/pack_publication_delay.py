#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Would the pack's worst cell meet ±10 % if the slow part's mean were published only once its windows had slid over new data?
# Answer: on the hppc profile yes (worst cell's Q 100 % with 600 s of memory, published 256 s after its first identified window); on the drive cycle no (88.0-89.3 %): its worst cell's windows stay low for longer than any delay; see "A delay before the mean is published".
"""Emulates, from the tracks of `python3 bench/pack_slow_part.py` (its
`--memories` with 0, 200 and 600, default `--out`), a slow part whose
mean is published only from `D` seconds after each cell's first
identified window (the mean itself unchanged: it still takes every
window from the first). Prints, per memory, profile and delay, the share
of rows within ±10 % of the truth from each cell's first published value
on (a row without a value outside), pooled over the cells and seeds and
for the worst cell (with its seed and cell), for `Q` and `R_ct`, as the
bench counts them; `D` = 0 is the bench's own row.

    python3 bench/pack_slow_part.py --memories 0,200,400,600
    python3 research/pack_publication_delay.py [--dir target/pack-slow-part]
        [--memories 0,200,600] [--delays 0,64,128,192,256,384,512]
"""

import argparse
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "bench"))
from pack_slow_part import shares  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dir", default="target/pack-slow-part")
    ap.add_argument("--memories", default="0,200,600")
    ap.add_argument("--delays", default="0,64,128,192,256,384,512")
    ap.add_argument("--seeds", default="1,2,3")
    a = ap.parse_args()
    delays = [float(x) for x in a.delays.split(",")]
    print("| --slow-memory-s | profile | delay (s) | Q within ±10 % | worst cell (seed, cell) "
          "| R_ct within ±10 % | worst cell (seed, cell) |")
    print("|---|---|---|---|---|---|---|")
    for memory in a.memories.split(","):
        for profile in ("hppc", "drive"):
            for delay in delays:
                per_seed = {seed: shares(f"{a.dir}/{profile}-{seed}.json",
                                         f"{a.dir}/{profile}-{seed}-slow{memory}-track.csv", delay)
                            for seed in a.seeds.split(",")}
                cols = []
                for key in ("q", "r_ct"):
                    pooled = [0, 0]
                    worst = (2.0, None)
                    for seed, out in per_seed.items():
                        for cell, (within, n, _) in sorted(out[key].items()):
                            if n == 0:
                                continue
                            pooled[0] += within
                            pooled[1] += n
                            worst = min(worst, (within / n, (seed, cell)))
                    cols += [f"{100 * pooled[0] / pooled[1]:.1f} %",
                             f"{100 * worst[0]:.1f} % ({worst[1][0]}, {worst[1][1]})"]
                print(f"| {memory} | {profile} | {delay:g} | " + " | ".join(cols) + " |")


if __name__ == "__main__":
    main()
