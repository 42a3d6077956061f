#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Does the correction by the last pulse of the same current predict better when it adds that pulse's miss in volts to the model's drop, instead of scaling the drop by its measured over predicted ratio?
# Answer: no. It moves the medians both ways by at most 0.6 of a point and the worst both ways (Panasonic 10 degC with the map at 2 s 28.4 -> 21.7 %, without a prior 58.9 -> 49.4 %; 25 degC without a prior at 2 s 40.5 -> 42.5 %, at 10 s 68.1 -> 69.9 %; Chen2020 with the map at 10 s 2.7 -> 3.9 %); no row reaches its goal that it missed; not built.
"""The state of power's correction by the last pulse of its current,
made additive, emulated on the tracks that `python3 bench/sop_pulses.py
--acceptance` leaves (issue 72; docs/research.md, "The miss added in
volts").

Per judged pulse and horizon H, from the row before it: the model's own
`pulse_v_{H}s` (the run with `--no-pulse-correction`, under NC) and the
corrected one with its `pulse_ratio_{H}s` r (under TRACKS). The model's
voltage at the pulse's start u0 follows from the two (corrected = u0 −
r·(u0 − own)). The pulse that gave r is the last earlier pulse of the
same current after whose end the track holds r; its own predicted drop
d' is read from the NC track at its start (from the measured voltage
there). The emulated voltage is u0 − (u0 − own) − (r − 1)·d'. "scaled"
is the build's own correction emulated (a check: it equals the
acceptance's table), "added" the additive one, "own" the model's.

    cargo build --release -p host-sim && bash bench/panasonic_chain.sh
    python3 bench/sop_pulses.py --acceptance
    python3 bench/sop_pulses.py --acceptance --online-args="--no-pulse-correction" --out target/sop-nc
    python3 research/sop_additive_correction.py [--tracks target/sop] [--nc target/sop-nc]
"""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "bench"))
import sop_pulses as S  # noqa: E402


def number(x):
    return float(x) if x else None


def row(tracks, nc, name, variant, h):
    """Per judged pulse at horizon h: the relative misses, scaled (the
    build's), added and the model's own."""
    path, _, _, gap_s, _, _ = S.RECORD_SPECS[name]
    ps, (t, v) = S.pulses(path)
    g = S.groups(ps, gap_s)
    out = {"scaled": [], "added": [], "own": []}
    for j, (start, cur, length) in enumerate(ps):
        if g[j] == 0 or length < h:
            continue
        trc, trn = S.pulse_track(tracks, path, cur, variant), S.pulse_track(nc, path, cur, variant)
        rc, rn = trc[S.row_before(trc, start)], trn[S.row_before(trn, start)]
        pc, pn = number(rc[f"pulse_v_{h}s"]), number(rn[f"pulse_v_{h}s"])
        r = number(rc[f"pulse_ratio_{h}s"])
        before, measured = np.interp(start, t, v), np.interp(start + h, t, v)
        drop = abs(before - measured)
        if pc is None or pn is None:
            continue
        out["own"].append(abs(pn - measured) / drop)
        scaled = added = pc
        if r is not None and abs(1 - r) > 1e-6:
            u0 = (pc - r * pn) / (1 - r)
            scaled = u0 - r * (u0 - pn)
            tt = np.array([float(x["time_s"]) for x in trc])
            for k in range(j - 1, -1, -1):
                s2, c2, l2 = ps[k]
                if S.current_key(c2) != S.current_key(cur) or l2 < h:
                    continue
                after = np.searchsorted(tt, s2 + l2 + 20)
                if after < len(trc) and number(trc[after][f"pulse_ratio_{h}s"]) == r:
                    own2 = number(trn[S.row_before(trn, s2)][f"pulse_v_{h}s"])
                    if own2 is not None:
                        d2 = np.interp(s2, t, v) - own2
                        added = u0 - (u0 - pn) - (r - 1) * d2 * cur / c2
                    break
        out["scaled"].append(abs(scaled - measured) / drop)
        out["added"].append(abs(added - measured) / drop)
    return out


def main():
    a = S.tracks_arguments(__doc__.splitlines()[0])
    print("| record | horizon | prior | scaled (the build's) | added | own |")
    print("|---|---|---|---|---|---|")
    for name, spec in S.RECORD_SPECS.items():
        for variant in ("none", "map"):
            for h in spec[4]:
                out = row(a.tracks, a.nc, name, variant, h)
                if not out["own"]:
                    continue
                cells = " | ".join(f"{S.pct(np.median(x))} / {S.pct(max(x))}" for x in out.values())
                print(f"| {name} | {h} s | {variant} | {cells} |")


if __name__ == "__main__":
    main()
