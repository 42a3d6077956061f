#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Does the correction by the last pulse of the same current predict better when its ratio is shrunk towards 1 as the SOC moves from where it was measured (ratio^(1 - dSOC/span))?
# Answer: no. At spans of 0.5, 0.3, 0.2 and 0.15 of SOC the medians rise on nearly every row (Panasonic 25 degC with the map at 2 s 1.2 -> 1.9-2.6 %, Chen2020 without a prior at 10 s 1.3 -> 1.9-5.1 %), and the worst falls only a little where it falls (Panasonic 10 degC with the map at 2 s 28.4 -> 21.7-25.5 %, 25 degC at 2 s 8.6 -> 6.9-7.8 %); not built.
"""The state of power's correction by the last pulse of its current,
its ratio shrunk by the SOC moved since, emulated on the tracks that
`python3 bench/sop_pulses.py --acceptance` leaves (issue 72;
docs/research.md, "The ratio shrunk as the SOC moves").

Per judged pulse and horizon H, from the row before it: the model's own
`pulse_v_{H}s` (the run with `--no-pulse-correction`, under NC) and the
corrected one with its `pulse_ratio_{H}s` r (under TRACKS). The model's
voltage at the pulse's start u0 follows from the two (corrected = u0 −
r·(u0 − own)); the emulated voltage is u0 − r^w·(u0 − own), w = max(0,
1 − ΔSOC/span), ΔSOC the counted SOC between this pulse and the last
pulse of the same current before it. Span none is the build's own
correction (the acceptance's table, as a check of the emulation).

    cargo build --release -p host-sim && bash bench/panasonic_chain.sh
    python3 bench/sop_pulses.py --acceptance
    python3 bench/sop_pulses.py --acceptance --online-args="--no-pulse-correction" --out target/sop-nc
    python3 research/sop_ratio_soc_shrink.py [--tracks target/sop] [--nc target/sop-nc]
"""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "bench"))
import sop_pulses as S  # noqa: E402


def rows(tracks, nc, name, variant):
    """Per judged pulse: (h, own, corrected, ratio or None, measured,
    drop, ΔSOC or None)."""
    path = S.RECORD_SPECS[name][0]
    ps, (t, v) = S.pulses(path)
    soc = {}
    for start, cur, _ in ps:
        tr = S.pulse_track(tracks, path, cur, variant)
        z = tr[S.row_before(tr, start)]["soc_coulomb"]
        soc[start] = (S.current_key(cur), float(z) if z else np.nan)
    out = []
    for (h, start, cur, own), (_, _, _, cor) in zip(S.rows_before_pulses(nc, name, variant),
                                                     S.rows_before_pulses(tracks, name, variant)):
        p0, pc = own.get(f"pulse_v_{h}s"), cor.get(f"pulse_v_{h}s")
        if not (p0 and pc):
            continue
        r = cor.get(f"pulse_ratio_{h}s")
        before, measured = np.interp(start, t, v), np.interp(start + h, t, v)
        earlier = [s for s, (c, _) in soc.items() if s < start and c == S.current_key(cur)]
        dz = abs(soc[earlier[-1]][1] - soc[start][1]) if earlier else None
        out.append((h, float(p0), float(pc), float(r) if r else None, measured,
                    abs(before - measured), dz))
    return out


def main():
    a = S.tracks_arguments(__doc__.splitlines()[0])
    data = {(n, var): rows(a.tracks, a.nc, n, var) for n in S.RECORD_SPECS for var in ("map", "none")}
    for span in (None, 0.5, 0.3, 0.2, 0.15):
        cells = []
        for (name, variant), rs in data.items():
            for h in sorted({r[0] for r in rs}):
                errs = []
                for hh, p0, pc, r, measured, drop, dz in rs:
                    if hh != h:
                        continue
                    p = pc
                    if span and r is not None and abs(r - 1) > 1e-6 and dz is not None:
                        u0 = (pc - r * p0) / (1 - r)
                        p = u0 - r ** max(0.0, 1 - dz / span) * (u0 - p0)
                    errs.append(abs(p - measured) / drop)
                if errs:
                    cells.append(f"{name}, {h} s, {variant}: {S.pct(np.median(errs))} / {S.pct(max(errs))}")
        print(f"span {span}: " + "; ".join(cells))


if __name__ == "__main__":
    main()
