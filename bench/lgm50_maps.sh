#!/usr/bin/env bash
# The maps of the LG M50 21700 (data/lg-m50, the MAT exports as they come)
# and how they predict the rate tests none of them saw (docs/maps.md, "On a
# second cell: LG M50"):
#
#   the nine one-pulse records of each temperature (10, 25, 45 °C; SOC 0.9
#   … 0.1, each after a 600 s rest) joined into one record (--table A,B,…)
#   -> per-level map, joint map, single whole-record fit -> the rate tests
#   (0.5C, 1C, 2C; 1.5C at 45 °C: a CC discharge, rest, C/3 CC-CV charge,
#   rest) predicted by each, the maps joined over (SOC, T), the middle
#   temperature from the outer two -> the scipy reference of each joint
#   map's objective (bench/joint_reference.py).
#
# With the file's own processed OCV (LGM50_5Ah_OCV.mat, meanOCV: written as
# a `soc,ocv_v` table) and, as a check, the table `host-sim ocv` takes from
# the C/10 discharge (no IR drop seen: docs/measured-cells.md).
# About 3 minutes on one core, most of it scipy.
#
#   bash bench/lgm50_maps.sh [OUT]
#   HOST_SIM=path/to/host-sim bash bench/lgm50_maps.sh [OUT]   # no build
#   CAPACITY_AH=5 bash bench/lgm50_maps.sh [OUT]               # the nominal capacity
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-target/real-cells/lgm50-maps}"
mkdir -p "$out"
[ -n "${HOST_SIM:-}" ] || cargo build --release -q -p host-sim
hs=${HOST_SIM:-target/release/host-sim}
d=data/lg-m50
pulse=$d/LGM50_5Ah_Pulse.mat
rate=$d/LGM50_5Ah_RateTest.mat
rcols=time=timeVec,current=currVec,voltage=volVec,temperature=cellTemp_mid
declare -A cells=([25]=Cell1 [10]=Cell13 [45]=Cell7)

python3 - "$d/LGM50_5Ah_OCV.mat" "$out/ocv-file.csv" <<'PY'
import sys
import scipy.io as sio
m = sio.loadmat(sys.argv[1], simplify_cells=True)["LGM50_5Ah_OCV"]["T25"]
with open(sys.argv[2], "w") as f:
    f.write("soc,ocv_v\n")
    for s, v in zip(m["refSoC"], m["meanOCV"]):
        f.write(f"{s / 100},{v}\n")
PY
# The cell's capacity is the one its C/10 discharge at 25 °C measures
# (`host-sim ocv` prints it: 4.9446 A·h), the charge scale of both tables;
# CAPACITY_AH=5 runs everything at the nominal 5 A·h instead.
$hs ocv --input $rate --table LGM50_5Ah_RateTest.T25.cRate_0p1C --columns $rcols --from low-rate \
  ${CAPACITY_AH:+--capacity-ah $CAPACITY_AH} --out "$out/ocv-c10.csv" --json "$out/ocv-c10.json" > /dev/null 2>&1
cap=$(python3 -c "import json,sys;print(json.load(open(sys.argv[1]))['capacity_ah'])" "$out/ocv-c10.json")
echo "capacity: $cap A·h"

for ocv in file c10; do
  o="$out/$ocv"
  mkdir -p "$o"
  echo "== OCV: $ocv"
  echo "| map of | rows (identifiable) | in-sample RMSE: map / single fit (mV) | time (s) |"
  echo "|---|---|---|---|"
  for T in 25 10 45; do
    tables=$(for s in 9 8 7 6 5 4 3 2 1; do printf "LGM50_5Ah_Pulse.T$T.SoC$s.${cells[$T]}.data,"; done)
    for method in levels joint; do
      tag=$method-$T
      start=$(date +%s.%N)
      $hs identify battery --input $pulse --table "${tables%,}" --columns temperature=LogTemp001 \
        --ocv "$out/ocv-$ocv.csv" --capacity-ah $cap --soc0 0.9 --model linear --temperature-c $T \
        --map-method $method --map-out "$o/map-$tag.csv" --json "$o/fit-$tag.json" \
        --levels-out "$o/levels-$tag" > "$o/map-$tag.log" 2>&1
      took=$(python3 -c "import sys;print(f'{float(sys.argv[2]) - float(sys.argv[1]):.1f}')" "$start" "$(date +%s.%N)")
      python3 - "$o/fit-$tag.json" "$T °C pulses, $method" "$took" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
m = j["map"]
n = len(m["levels"])
ok = sum(1 for r in m["levels"] if r["identifiable"])
how = ""
if m.get("joint"):
    b = min(m["joint"], key=lambda c: c["left_out_rmse_v"])
    how = f" (λ {b['smoothing']:g} V², varying {','.join(b['vary'])})"
print(f"| {sys.argv[2]}{how} | {n} ({ok}) | {1e3 * m['map_rmse_v']:.2f} / {1e3 * m['single_rmse_v']:.2f} | {sys.argv[3]} |")
PY
    done
  done
  for method in levels joint; do
    (cat "$o/map-$method-10.csv"; tail -n +2 "$o/map-$method-25.csv"; tail -n +2 "$o/map-$method-45.csv") > "$o/map-$method-all.csv"
    (cat "$o/map-$method-10.csv"; tail -n +2 "$o/map-$method-45.csv") > "$o/map-$method-10-45.csv"
  done
  echo
  echo "| record | levels map | joint map | single fit | joint map / single fit | joint, 10+25+45 °C | its / single fit | joint, 10+45 °C | the discharge alone: joint / single |"
  echo "|---|---|---|---|---|---|---|---|---|"
  for T in 25 10 45; do
    rates="0p5C 1C 2C"; [ $T = 45 ] && rates="0p5C 1C 1p5C"
    for r in $rates; do
      row=(); raw=()
      for m in map-levels-$T.csv map-joint-$T.csv fit-joint-$T.json map-joint-all.csv map-joint-10-45.csv; do
        j="$o/rate-$T-$r-$m.json"
        $hs predict battery --model "$o/$m" --input $rate --table LGM50_5Ah_RateTest.T$T.cRate_$r \
          --columns $rcols --ocv "$out/ocv-$ocv.csv" --capacity-ah $cap --soc0 1 --json "$j" \
          --out "${j%.json}.csv" > "$o/rate-$T-$r-$m.log" 2>&1 || { row+=("refused"); raw+=(nan); continue; }
        read -r x shown < <(python3 -c "import json,sys;x=json.load(open(sys.argv[1]))['in_table']['rmse_v'];print(x, f'{1e3*x:.1f}')" "$j")
        raw+=("$x"); row+=("$shown")
      done
      # The ratios from the RMSEs as the JSON has them, not as printed.
      ratio=$(python3 -c "import sys;print(f'{float(sys.argv[1]) / float(sys.argv[2]):.3f}')" "${raw[1]}" "${raw[2]}")
      ratio_all=$(python3 -c "import sys;print(f'{float(sys.argv[1]) / float(sys.argv[2]):.3f}')" "${raw[3]}" "${raw[2]}")
      # The constant-current discharge alone (the measured samples under a
      # discharge current), as a BMS most needs it predicted.
      dis=$(python3 - "$o/rate-$T-$r-map-joint-$T.csv.csv" "$o/rate-$T-$r-fit-joint-$T.json.csv" <<'PY'
import csv, sys
import numpy as np
out = []
for f in sys.argv[1:]:
    r = list(csv.DictReader(open(f)))
    i = np.array([float(x["current_a"]) for x in r])
    e = np.array([float(x["model_v"]) - float(x["voltage_v"]) for x in r])
    keep = (i < -0.05) & np.array([x["observed"] == "1" for x in r])
    out.append(1e3 * np.sqrt(np.mean(e[keep] ** 2)))
print(f"{out[0]:.1f} / {out[1]:.1f}")
PY
)
      echo "| $T °C ${r/p/.} | ${row[0]} | ${row[1]} | ${row[2]} | $ratio | ${row[3]} | $ratio_all | ${row[4]} | $dis |"
    done
  done
  # The middle temperature's pulse record from the outer two's joint map.
  tables=$(for s in 9 8 7 6 5 4 3 2 1; do printf "LGM50_5Ah_Pulse.T25.SoC$s.Cell1.data,"; done)
  $hs predict battery --model "$o/map-joint-10-45.csv" --input $pulse --table "${tables%,}" \
    --columns temperature=LogTemp001 --ocv "$out/ocv-$ocv.csv" --capacity-ah $cap --soc0 0.9 \
    --json "$o/pulse-25-from-10-45.json" > "$o/pulse-25-from-10-45.log" 2>&1
  python3 - "$o/pulse-25-from-10-45.json" "$o/fit-joint-25.json" <<'PY'
import json, sys
p = json.load(open(sys.argv[1]))["rmse_v"]
own = json.load(open(sys.argv[2]))["map"]["map_rmse_v"]
print(f"\nthe 25 °C pulse records from the 10 and 45 °C joint maps (Arrhenius): {1e3 * p:.2f} mV; "
      f"the 25 °C joint map's own: {1e3 * own:.2f} mV ({p / own:.2f}x)")
PY
  grep -h "activation energ" "$o"/rate-25-1C-map-joint-10-45.csv.log | head -1 || true
  echo
  echo "The joint maps against an independent scipy fit of the same objective:"
  for T in 25 10 45; do
    python3 bench/joint_reference.py "$o/levels-joint-$T" | grep -E "^acceptance" | sed "s/^/$T °C: /"
  done
  echo
done
