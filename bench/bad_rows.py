#!/usr/bin/env python3
"""Issue 21, bad rows offline (docs/trust.md): a record of the `cell` preset
(pulse, 1000 s, seed 3) with 30 voltage spikes (±0.1…0.5 V, random rows and
signs) and 3 NaN voltages, fitted by `identify battery` beside the clean
record; prints the relative differences, the rejected counts and the
intervals, and what `online battery` rejects on the same bad record (its
track's `rejected` column against the bad rows).

    python3 bench/bad_rows.py        # builds host-sim (release)
"""
import csv
import json
import os
import random
import subprocess
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    subprocess.run(["cargo", "build", "--quiet", "--release", "-p", "host-sim"], cwd=ROOT, check=True)
    hs = os.path.join(os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target")), "release", "host-sim")
    with tempfile.TemporaryDirectory() as d:
        clean, bad = os.path.join(d, "clean.csv"), os.path.join(d, "bad.csv")
        subprocess.run([hs, "simulate", "battery", "--preset", "cell", "--length", "1000", "--seed", "3",
                        "--out", clean], check=True, capture_output=True)
        rows = list(csv.reader(open(clean)))
        header, data = rows[0], rows[1:]
        rng = random.Random(5)
        bad_rows = rng.sample(range(5, len(data)), 33)
        for k, i in enumerate(bad_rows):
            v = float(data[i][2])
            data[i][2] = "NaN" if k < 3 else f"{v + rng.choice([-1, 1]) * rng.uniform(0.1, 0.5):.6f}"
        with open(bad, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(header)
            w.writerows(data)
        fits = {}
        for name, path in [("clean", clean), ("bad", bad)]:
            out = os.path.join(d, f"{name}.json")
            p = subprocess.run([hs, "identify", "battery", "--input", path, "--json", out],
                               check=True, capture_output=True, text=True)
            fits[name] = json.load(open(out))
            if name == "bad":
                print([line for line in p.stderr.splitlines() if "rejected" in line][0])
        # The online estimator on the same bad record, for comparison.
        track = os.path.join(d, "track.csv")
        p = subprocess.run([hs, "online", "battery", "--input", bad, "--out", track],
                           check=True, capture_output=True, text=True)
        print("online battery:", [line for line in p.stderr.splitlines() if "rejected" in line][0])
        # The track's `rejected` column: which rows, for what reason.
        why = {k: r["rejected"] for k, r in enumerate(csv.DictReader(open(track))) if r["rejected"]}
        hit = [k for k in bad_rows if k in why]
        print(f"online: {len(hit)} of the {len(bad_rows)} bad rows rejected "
              f"({sum(why[k] == 'non_finite' for k in hit)} non_finite, {sum(why[k] == 'spike' for k in hit)} spike), "
              f"{len(set(why) - set(bad_rows))} other rows rejected")
        a, b = fits["clean"], fits["bad"]
        print("| | clean | 30 spikes + 3 NaN | difference |")
        print("|---|---|---|---|")
        for k in ["r_i", "r_ct", "q", "alpha", "u_oc"]:
            print(f"| {k} | {a[k]:.6g} | {b[k]:.6g} | {100 * (b[k] / a[k] - 1):+.2f} % |")
        print(f"| rejected | {a['rejected']} | {b['rejected']} {b['rejected_rows']} | |")
        print(f"| identifiable | {a['identifiable']} | {b['identifiable']} | |")
        for k in ["r_i", "r_ct", "q", "alpha"]:
            print(f"{k} 95 % interval: clean {a['confidence'][k]}, bad rows {b['confidence'][k]}")


if __name__ == "__main__":
    main()
