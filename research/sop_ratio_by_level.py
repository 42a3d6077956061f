#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Does the correction by the last pulse of the same current do better at the worst pulses when it is combined with the ratio the level's last pulse (any current) left: their product over the same-current level's ratio at that pulse's current, or the geometric mean of the two?
# Answer: no. With the record's own map the product lowers the medians (Panasonic 0.8-1.7 %, DFN 1.0-2.8 %) and the LFP DFN record's worst at 10 s (7.3 -> 5.3 %), but raises the 10 degC test's worst at 10 s (20.1 -> 27.2 %); the geometric mean lowers the 25 degC worst at 10 s (17.9 -> 10.8 %) but raises the DFN records' 10 s medians (Chen2020 1.3 -> 10.7 %). Not built.
"""The pulse correction of the state of power (docs/state-of-power.md,
"Corrected by the last pulse of its current") emulated four ways on the
tracks of `python3 bench/sop_pulses.py --acceptance
--online-args="--no-pulse-correction" --out target/sop-nc`, with the
record's own map as the prior (whose predictions do not depend on the
correction): per pulse of each HPPC record, from the first group on, the
model's predicted drop at each horizon (`pulse_v_{H}s` at the last sample
before the pulse, from the measured voltage there) and the measured drop
give a ratio `r` (measured over predicted). The next pulse's predicted
drop is scaled by

* `same`: the ratio of the last pulse of its current (what is built);
* `any`: the ratio of the last pulse, whatever its current;
* `product`: the last pulse's ratio times the same current's ratio over
  the ratio the last pulse's current left in that same-current pulse's
  group (a level's ratio times a current's, as if they multiplied);
* `geometric`: the geometric mean of `same` and `any`.

Prints the median and worst error, % of the measured drop, over the
pulses the acceptance judges (from the second group on); then each
current's ratio, level by level.

    cargo build --release -p host-sim && bash bench/panasonic_chain.sh
    python3 bench/sop_pulses.py --acceptance --online-args="--no-pulse-correction" --out target/sop-nc
    python3 research/sop_ratio_by_level.py [--nc target/sop-nc]
"""

import csv
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "bench"))
import sop_pulses as S  # noqa: E402


def predicted(nc):
    """Per (record, horizon): the pulses in time order, each a dict of its
    group, current, measured and predicted drop (the map's tracks)."""
    out = {}
    for name, (path, _, _, gap_s, horizons, _) in S.RECORD_SPECS.items():
        ps, (t, v) = S.pulses(path)
        g = S.groups(ps, gap_s)
        rec = S.record_dir(nc, path)
        tracks = {}
        for h in horizons:
            rows = []
            for j, (start, cur, length) in enumerate(ps):
                if length < h:
                    continue
                c = S.current_key(cur)
                if c not in tracks:
                    tracks[c] = list(csv.DictReader(open(f"{rec}/pulse{c}-map.csv")))
                row = tracks[c][S.row_before(tracks[c], start)]
                if not row[f"pulse_v_{h}s"]:
                    continue
                before = np.interp(start, t, v)
                rows.append({"g": g[j], "cur": S.current_key(cur),
                             "meas": before - np.interp(start + h, t, v),
                             "pred": before - float(row[f"pulse_v_{h}s"])})
            out[(name, h)] = rows
    return out


def ratio(q):
    return q["meas"] / q["pred"]


def same(r, prev):
    s = [q for q in prev if q["cur"] == r["cur"]]
    return ratio(s[-1]) if s else 1.0


def any_current(r, prev):
    return ratio(prev[-1]) if prev else 1.0


def product(r, prev):
    if not prev:
        return 1.0
    last = prev[-1]
    s = [q for q in prev if q["cur"] == r["cur"]]
    if not s or s[-1] is last:
        return ratio(last)
    o = [q for q in prev if q["g"] == s[-1]["g"] and q["cur"] == last["cur"]]
    return ratio(last) * ratio(s[-1]) / ratio(o[-1]) if o else ratio(s[-1])


def geometric(r, prev):
    return float(np.sqrt(same(r, prev) * any_current(r, prev)))


SCHEMES = {"same": same, "any": any_current, "product": product, "geometric": geometric}


def main():
    a = S.tracks_arguments(__doc__.splitlines()[0])
    print("| record | horizon | " + " | ".join(SCHEMES) + " |")
    print("|---|---|" + "---|" * len(SCHEMES))
    for (name, h), rows in predicted(a.nc).items():
        cells = []
        for f in SCHEMES.values():
            e = [abs(1 - r["pred"] * f(r, rows[:n]) / r["meas"])
                 for n, r in enumerate(rows) if r["g"] != 0]
            cells.append(f"{100 * np.median(e):.1f} / {100 * np.max(e):.1f}")
        print(f"| {name} | {h} s | " + " | ".join(cells) + " |")
    # Each current's ratio (measured over predicted drop), level by level.
    print()
    for (name, h), rows in predicted(a.nc).items():
        for cur in sorted({r["cur"] for r in rows}):
            rs = " ".join(f"{ratio(r):.3f}" for r in rows if r["cur"] == cur)
            print(f"{name}, {h} s, {cur} A, measured over predicted by level: {rs}")


if __name__ == "__main__":
    main()
