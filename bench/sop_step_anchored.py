#!/usr/bin/env python3
"""A candidate for the state of power, measured and not adopted
(docs/research.md, "The state of power"): the model's answer over the
first sample replaced by the last clean current step's resistance
(`step_resistance_ohm`, ΔU/ΔI over one sample), so that a pulse's
predicted voltage is `pulse_v + I·(R_model,1 − R_step)` with `R_model,1 =
(pulse_v_2s − v_now)/I` (the Panasonic tracks run at 2 s: the 2 s horizon
is one sample). Read from the tracks `bench/sop_pulses.py --acceptance`
writes (target/sop), on the same pulses (the Panasonic HPPC tests at 25
and 10 degC, second level on), without a prior and with the record's own
map; error as a fraction of the pulse's measured drop, and the share of
pulses that end above the prediction less 2 sigma.

    python3 bench/sop_pulses.py --acceptance --online-args="--no-pulse-correction"   # the model's tracks
    python3 bench/sop_step_anchored.py
"""

import numpy as np

import sop_pulses as S


def main():
    print("| record | prior | horizon | pulses | ours: median / 90th / worst % | above pulse_v − 2σ "
          "| step-anchored: median / 90th / worst % | above pulse_v − 2σ |")
    print("|---|---|---|---|---|---|---|---|")
    for name, (path, _, _, gap_s, horizons, _) in S.RECORD_SPECS.items():
        if not name.startswith("Panasonic"):
            continue
        ps, (t, v) = S.pulses(path)
        g = S.groups(ps, gap_s)
        for variant in ("none", "map"):
            tracks = {}
            for h in horizons:
                ours, anchored, cov0, cov1 = [], [], [], []
                for j, (start, cur, length) in enumerate(ps):
                    if g[j] == 0 or length < h:
                        continue
                    c = S.current_key(cur)
                    if c not in tracks:
                        tracks[c] = S.pulse_track("target/sop", path, cur, variant)
                    tr = tracks[c]
                    k = S.row_before(tr, start)
                    before, measured = np.interp(start, t, v), np.interp(start + h, t, v)
                    drop = abs(before - measured)
                    row = tr[k]
                    if not row[f"pulse_v_{h}s"]:
                        continue
                    p, sd = float(row[f"pulse_v_{h}s"]), float(row[f"sop_uncertainty_v_{h}s"])
                    ours.append(abs(p - measured) / drop)
                    cov0.append(measured >= p - S.CONFIDENCE * sd)
                    q = p
                    if row["step_resistance_ohm"]:
                        now = float(v[np.searchsorted(t, start) - 1])
                        r_model = (float(row["pulse_v_2s"]) - now) / cur
                        q = p + cur * (float(row["step_resistance_ohm"]) - r_model)
                    anchored.append(abs(q - measured) / drop)
                    cov1.append(measured >= q - S.CONFIDENCE * sd)
                f = lambda x: " / ".join(f"{100 * y:.1f}" for y in
                                         (np.median(x), np.percentile(x, 90), np.max(x)))
                print(f"| {name} | {variant} | {h} s | {len(ours)} | {f(ours)} | {100 * np.mean(cov0):.1f} % "
                      f"| {f(anchored)} | {100 * np.mean(cov1):.1f} % |")


if __name__ == "__main__":
    main()
