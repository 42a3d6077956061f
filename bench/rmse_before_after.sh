#!/usr/bin/env bash
# The free-run RMSE of every measured-cell fit with two host-sim binaries
# (issue 34: "unchanged, <= 1.001x today's"): the 27 LG M50 pulse levels
# (bench/lgm50_chain.sh's level command) and the 14 Panasonic HPPC levels
# (bench/panasonic_chain.sh's map command), per fit new/old.
#
#   git worktree add /tmp/old <commit> && (cd /tmp/old && CARGO_TARGET_DIR=/tmp/old-target cargo build --release -p host-sim)
#   bash bench/lgm50_chain.sh && bash bench/panasonic_chain.sh     # their OCV tables
#   bash bench/rmse_before_after.sh /tmp/old-target/release/host-sim target/release/host-sim [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
old=$1; new=$2; out="${3:-target/rmse-before-after}"
mkdir -p "$out"
d=data/lg-m50; pulse=$d/LGM50_5Ah_Pulse.mat
lgocv=target/real-cells/lgm50/ocv.csv; panocv=target/real-cells/panasonic/ocv.csv
hppc="data/panasonic-18650pf/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat"
for t in "$lgocv" "$panocv"; do
  if [ ! -f "$t" ]; then
    echo "rmse_before_after.sh: $t is missing: run bash bench/lgm50_chain.sh && bash bench/panasonic_chain.sh first" >&2
    exit 1
  fi
done
declare -A cells=([25]=Cell1 [10]=Cell13 [45]=Cell7)
for which in old new; do
  hs=${!which}
  for T in 25 10 45; do for s in 9 8 7 6 5 4 3 2 1; do
    lv="$out/$which/lg-T$T-SoC$s"; mkdir -p "$lv"
    "$hs" identify battery --input $pulse --table LGM50_5Ah_Pulse.T$T.SoC$s.${cells[$T]}.data \
      --columns temperature=LogTemp001 --ocv $lgocv --capacity-ah 5 --soc0 0.$s \
      --soc-bins 1 --model linear --temperature-c $T --map-out "$lv/map.csv" --json "$lv/fit.json" \
      > "$lv/log.txt" 2>&1 || true
  done; done
  /usr/bin/time -f "$which: Panasonic map %U s of CPU" "$hs" identify battery --input "$hppc" \
    --ocv $panocv --capacity-ah 2.9 --min-rest 3000 --model linear \
    --map-out "$out/$which/panasonic-map.csv" --json "$out/$which/panasonic.json" 2>&1 | grep -E "CPU|^map"
done
python3 - "$out" <<'PY'
import csv, json, os, sys
out = sys.argv[1]
ratios = []
for T in (25, 10, 45):
    for s in range(9, 0, -1):
        f = [f"{out}/{w}/lg-T{T}-SoC{s}/fit.json" for w in ("old", "new")]
        if all(os.path.exists(x) for x in f):
            a, b = (json.load(open(x))["rmse_v"] for x in f)
            ratios.append(b / a)
print(f"LG M50: {len(ratios)} levels, new/old RMSE {min(ratios):.6f} .. {max(ratios):.6f}, "
      f"{sum(r <= 1.001 for r in ratios)} within 1.001x")
o, n = (list(csv.DictReader(open(f"{out}/{w}/panasonic-map.csv"))) for w in ("old", "new"))
r = [float(b["rmse_v"]) / float(a["rmse_v"]) for a, b in zip(o, n)]
print(f"Panasonic: {len(r)} levels, new/old RMSE {min(r):.5f} .. {max(r):.5f}, "
      f"{sum(x <= 1.001 for x in r)} within 1.001x")
PY
