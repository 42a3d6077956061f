#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: How much does checking the state of power against the last pulse (PulseCheck) widen the pulse voltage's sigma on the measured HPPC pulses?
# Answer: without a prior, median 1.052x, 90th/95th percentile 2.23x/2.59x, more than doubled at 30 of 221 pulses (largest 6.30x); with the map, at most 1.57x (each pulse measured from its edge, docs/state-of-power.md).
"""The pulse voltage's sigma with the check against the last pulse over
the same without it, per measured Panasonic HPPC pulse (issue 72;
docs/state-of-power.md, "How sure, and the derated limits").

Reads two sets of `online battery` tracks that `python3
bench/sop_pulses.py --acceptance` leaves: one from a build without the
check (the commit before it, 5b2df75; on 2 s, the period this build
chooses for both Panasonic tests) in OLD, one from this build in NEW,
and, per pulse from the second group on and per horizon, prints the ratio
of `sop_uncertainty_v_{H}s` at the last sample before the pulse.

    git worktree add /tmp/old 5b2df75
    (cd /tmp/old && CARGO_TARGET_DIR=/tmp/old-target cargo build --release -p host-sim)
    python3 bench/sop_pulses.py --acceptance --host-sim /tmp/old-target/release/host-sim --out target/sop-old --online-args="--period 2"
    cargo build --release -p host-sim
    python3 bench/sop_pulses.py --acceptance
    python3 research/sop_sigma_ratio.py [--old target/sop-old] [--new target/sop]
"""

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "bench"))
import sop_pulses as S  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", default="target/sop-old")
    ap.add_argument("--new", default="target/sop")
    a = ap.parse_args()
    for variant in ("none", "map"):
        ratios = []
        for name in ("Panasonic 25 degC HPPC", "Panasonic 10 degC HPPC"):
            # The same pulses in the same order from both sets of tracks.
            for (h, _, _, old), (_, _, _, new) in zip(S.rows_before_pulses(a.old, name, variant),
                                                      S.rows_before_pulses(a.new, name, variant)):
                so, sn = old[f"sop_uncertainty_v_{h}s"], new[f"sop_uncertainty_v_{h}s"]
                if so and sn:
                    ratios.append(float(sn) / float(so))
        r = np.array(ratios)
        print(f"prior {variant}: {len(r)} pulses; sigma with the check / without: median {np.median(r):.3f}, "
              f"90th percentile {np.percentile(r, 90):.2f}, 95th {np.percentile(r, 95):.2f}, "
              f"largest {r.max():.2f}; more than doubled at {(r > 2).sum()}")


if __name__ == "__main__":
    main()
