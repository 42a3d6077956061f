#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Does a window of 256 samples on a 2 s period (twice the span, the same cost) hold the pack's worst cell's Q?
# Answer: no: on the hppc profile the worst cell's Q falls to 61.4-68.7 % (1 s: 88.9-91.0 %) and the drive cycle, sampled at 2 s, is not fitted at all; see "A coarser period for a pack".
"""Puts the pack records of `python3 bench/pack_slow_part.py` (default
`--out`) on a coarser period, every `F`-th row with the current averaged
over the `F` rows it ends (the charge kept) and the voltages of that row,
and runs `online pack` on them as the bench does (`--window 256 --memory
64 --start at-rest --tail`, each `--slow-memory-s`); prints the bench's
shares (rows within ±10 % of the truth from each cell's first identified
window on, pooled and worst cell). `--factor 1` gives the bench's own
rows back.

    python3 bench/pack_slow_part.py --memories 0,200,400,600
    python3 research/pack_coarser_period.py [--factor 2] [--memories 0,200,600]
        [--dir target/pack-slow-part] [--out target/research/pack-coarser-period]
"""

import argparse
import csv
import shutil
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "bench"))
from pack_slow_part import shares  # noqa: E402


def coarser(src, dst, factor):
    rows = list(csv.reader(open(src)))
    head, data = rows[0], rows[1:]
    with open(dst, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(head)
        for k in range(factor - 1, len(data), factor):
            cur = sum(float(data[j][1]) for j in range(k - factor + 1, k + 1)) / factor
            w.writerow([data[k][0], repr(cur)] + data[k][2:])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--host-sim", default="target/release/host-sim")
    ap.add_argument("--dir", default="target/pack-slow-part")
    ap.add_argument("--out", default="target/research/pack-coarser-period")
    ap.add_argument("--factor", type=int, default=2)
    ap.add_argument("--memories", default="0,200,600")
    ap.add_argument("--seeds", default="1,2,3")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    print(f"period ×{a.factor}")
    print("| profile | --slow-memory-s | R_ct rows within ±10 % | worst cell | Q rows within ±10 % | worst cell |")
    print("|---|---|---|---|---|---|")
    for profile in ("hppc", "drive"):
        for mem in a.memories.split(","):
            tot = {"r_ct": [0, 0, []], "q": [0, 0, []]}
            for seed in a.seeds.split(","):
                rec = out / f"{profile}-{seed}-x{a.factor}.csv"
                coarser(f"{a.dir}/{profile}-{seed}.csv", rec, a.factor)
                shutil.copy(f"{a.dir}/{profile}-{seed}.json", rec.with_suffix(".json"))
                track = out / f"{profile}-{seed}-x{a.factor}-slow{mem}-track.csv"
                subprocess.run([a.host_sim, "online", "pack", "--input", str(rec), "--window", "256",
                                "--memory", "64", "--start", "at-rest", "--tail", "--slow-memory-s", mem,
                                "--out", str(track)],
                               check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                for k, cells in shares(rec.with_suffix(".json"), track).items():
                    for within, n, _ in cells.values():
                        tot[k][0] += within
                        tot[k][1] += n
                        tot[k][2].append(within / n)
            cols = []
            for k in ("r_ct", "q"):
                within, n, per_cell = tot[k]
                cols += [f"{100 * within / n:.1f} %", f"{100 * min(per_cell):.1f} %"]
            print(f"| {profile} | {mem} | " + " | ".join(cols) + " |")


if __name__ == "__main__":
    main()
