#!/usr/bin/env python3
"""A record replayed in two halves through `host-sim online battery
--state-out/--state-in`, against the uninterrupted run (docs/persistence.md).

Prints, for the first sample of the second half and at a few samples after
it, the largest relative deviation of the published R_i, R_ct, Q, alpha and
SOC (and of the window's fit) between the resumed and the whole run.

    python3 bench/resume_halves.py --host-sim target/debug/host-sim \
        --input data/pybamm/chen2020-hppc.csv --cut 2900 [--drop-slow-part] \
        -- --ocv data/pybamm/chen2020-ocv.csv --capacity-ah 5.153198 [--slow-memory-s 600]

With `--drop-slow-part` the snapshot between the halves loses the slow
part carried across windows (header flag cleared, each cell's 40 B cut,
the CRC made again): the second half restores as from a snapshot that
never kept it, its mean started again at its first identified window.
"""
import argparse
import csv
import math
import os
import subprocess
import sys
import tempfile
import zlib

PUBLISHED = ["r_i", "r_ct", "q", "alpha", "soc"]
WINDOW = ["window_r_i", "window_r_ct", "window_q", "window_alpha"]


def run(host_sim, args):
    r = subprocess.run([host_sim] + args, capture_output=True, text=True)
    if r.returncode:
        sys.exit(r.stderr)
    return r.stderr


def rel(a, b):
    """Relative deviation; NaN where only one of the two is published."""
    if a == "" and b == "":
        return 0.0
    if a == "" or b == "":
        return math.nan
    a, b = float(a), float(b)
    return 0.0 if a == b else abs(a / b - 1.0)


def drop_slow_part(path):
    """Rewrites the snapshot at `path` without the slow part
    (docs/persistence.md's layout: a 20 B header whose flags at offset 14
    say it is kept, then 124 + 40 B a cell, then the CRC-32)."""
    b = open(path, "rb").read()
    flags = int.from_bytes(b[14:16], "little")
    if not flags & 1:
        sys.exit(f"{path}: the snapshot keeps no slow part (flags {flags})")
    cells = (len(b) - 24) // 164
    out = bytearray(b[:20])
    out[14:16] = (flags & ~1).to_bytes(2, "little")
    for c in range(cells):
        out += b[20 + 164 * c:20 + 164 * c + 124]
    out += zlib.crc32(bytes(out)).to_bytes(4, "little")
    open(path, "wb").write(bytes(out))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--host-sim", default="target/debug/host-sim")
    p.add_argument("--input", required=True)
    p.add_argument("--cut", type=int, required=True, help="data rows in the first half")
    p.add_argument("--drop-slow-part", action="store_true",
                   help="restore the second half without the slow part the snapshot kept")
    p.add_argument("extra", nargs="*", help="flags for online battery (after --)")
    a = p.parse_args()
    d = tempfile.mkdtemp(prefix="resume-halves-")
    lines = open(a.input).read().splitlines()
    first, second = os.path.join(d, "first.csv"), os.path.join(d, "second.csv")
    open(first, "w").write("\n".join([lines[0]] + lines[1 : a.cut + 1]) + "\n")
    open(second, "w").write("\n".join([lines[0]] + lines[a.cut + 1 :]) + "\n")
    whole_t, t1, t2 = (os.path.join(d, f) for f in ("whole-t.csv", "t1.csv", "t2.csv"))
    state = os.path.join(d, "state.bin")
    run(a.host_sim, ["online", "battery", "--input", a.input, "--out", whole_t] + a.extra)
    run(a.host_sim, ["online", "battery", "--input", first, "--out", t1, "--state-out", state] + a.extra)
    if a.drop_slow_part:
        drop_slow_part(state)
    log = run(a.host_sim, ["online", "battery", "--input", second, "--out", t2, "--state-in", state] + a.extra)
    print(log.strip().splitlines()[-1] if log.strip() else "")
    print(f"snapshot: {os.path.getsize(state)} B")
    w = list(csv.DictReader(open(whole_t)))
    h = list(csv.DictReader(open(t2)))
    print("samples after the cut | max rel. published (R_i, R_ct, Q, alpha, SOC) | max rel. window fit | status resumed / whole")
    for k in [0, 1, 64, 128, 256, 300, 400, 600, 1000, len(h) - 1]:
        if k >= len(h):
            continue
        x, y = h[k], w[a.cut + k]
        pub = max((rel(x[n], y[n]) for n in PUBLISHED), key=lambda v: -1 if math.isnan(v) else v)
        win = max((rel(x[n], y[n]) for n in WINDOW), key=lambda v: -1 if math.isnan(v) else v)
        print(f"{k:>5} | {pub:.3g} | {win:.3g} | {x['status']} / {y['status']}")


if __name__ == "__main__":
    main()
