#!/usr/bin/env bash
# Coverage of the 95 % intervals of `identify battery` (docs/trust.md):
# seeds 1..N (default 100) of the `cell` preset (pulse profile, 1000 s,
# σ = 1 mV; truth R_i 20 mΩ, R_ct 15 mΩ, Q 533.33, α 0.75), fitted with the
# linear model (the truth's), and how many intervals hold the truth.
#
#   bash bench/interval_coverage.sh [N] [PROFILE]
set -euo pipefail
cd "$(dirname "$0")/.."
N=${1:-100}
PROFILE=${2:-pulse}
cargo build --release -q -p host-sim
B=target/release/host-sim
D=target/interval-coverage/$PROFILE
mkdir -p "$D"
for seed in $(seq 1 "$N"); do
  $B simulate battery --preset cell --profile "$PROFILE" --length 1000 --seed "$seed" \
    --out "$D/$seed.csv" 2>/dev/null
  $B identify battery --input "$D/$seed.csv" --model linear --json "$D/$seed.json" \
    >/dev/null 2>&1
done
python3 - "$D" "$N" <<'PY'
import json, sys
d, n = sys.argv[1], int(sys.argv[2])
truth = {"r_i": 0.020, "r_ct": 0.015, "q": 8.0 / 0.015, "alpha": 0.75}
hold = {k: 0 for k in truth}
ident = 0
width = {k: [] for k in truth}
for s in range(1, n + 1):
    j = json.load(open(f"{d}/{s}.json"))
    ident += j["identifiable"]
    c = j["confidence"]
    for k, t in truth.items():
        lo, hi = c[k]
        hold[k] += lo <= t <= hi
        width[k].append((hi - lo) / (2 * j[k]) if k != "alpha" else (hi - lo) / 2)
print(f"{n} seeds: identifiable on {ident}")
for k in truth:
    w = sorted(width[k])[len(width[k]) // 2]
    unit = "" if k == "alpha" else " (relative)"
    print(f"{k}: the interval holds the truth on {hold[k]} of {n} ({100 * hold[k] / n:.0f} %); median half-width {w:.4f}{unit}")
PY
