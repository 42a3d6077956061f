#!/usr/bin/env bash
# Parameter maps validated on records they were not fitted on
# (docs/maps.md, "How accurate is a map"): the Panasonic NCR18650PF HPPC
# tests at 25 and 10 °C (data/panasonic-18650pf, the exports as they come)
# each give a map and a single whole-record fit; both run on the US06 drive
# cycles at 25 and 10 °C, and the map of both temperatures joined runs at
# each record's own temperature (its temperature column's mean: Arrhenius
# between 10 and 25 °C) and at the nearest map temperature. Prints one
# Markdown table; `--report` pages go into OUT/report-*.
#
#   bash bench/map_validation.sh [OUT]
#   HOST_SIM=path/to/host-sim bash bench/map_validation.sh [OUT]   # no build
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-target/map-validation}"
mkdir -p "$out"
[ -n "${HOST_SIM:-}" ] || cargo build --release -q -p host-sim
hs=${HOST_SIM:-target/release/host-sim}
d=data/panasonic-18650pf
cap=2.9
$hs ocv --input "$d/05-08-17_13.26 C20 OCV Test_C20_25dC.mat" --from low-rate --out "$out/ocv.csv" > /dev/null 2>&1
ocv=(--ocv "$out/ocv.csv" --capacity-ah $cap)
declare -A hppc=([25]="$d/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat"
                 [10]="$d/03-27-17_09.06 10degC_5Pulse_HPPC_Pan18650PF.mat")
declare -A us06=([25]="$d/03-20-17_01.43 25degC_US06_Pan18650PF.mat"
                 [10]="$d/03-27-17_09.06 10degC_US06_Pan18650PF.mat")
echo "| map of | levels (identifiable) | in-sample RMSE: map / single fit (mV) | time (s) |"
echo "|---|---|---|---|"
for T in 25 10; do
  start=$(date +%s.%N)
  $hs identify battery --input "${hppc[$T]}" "${ocv[@]}" --min-rest 3000 --model linear \
    --temperature-c $T --map-out "$out/map-$T.csv" --json "$out/fit-$T.json" > "$out/map-$T.log" 2>&1
  took=$(python3 -c "import sys;print(f'{float(sys.argv[2]) - float(sys.argv[1]):.1f}')" "$start" "$(date +%s.%N)")
  python3 - "$out/fit-$T.json" "$T" "$took" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
m = j["map"]
n = len(m["levels"])
ok = sum(1 for r in m["levels"] if r["identifiable"])
print(f"| {sys.argv[2]} °C HPPC | {n} ({ok}) | {1e3 * m['map_rmse_v']:.2f} / {1e3 * m['single_rmse_v']:.2f} | {sys.argv[3]} |")
PY
done
(cat "$out/map-10.csv"; tail -n +2 "$out/map-25.csv") > "$out/map-10-25.csv"
echo
echo "| record | model | RMSE (mV) | RMSE inside the OCV table (mV) | max error (mV) | temperature rule |"
echo "|---|---|---|---|---|---|"
for T in 25 10; do
  for m in "map-$T.csv" "fit-$T.json" "map-10-25.csv" "map-10-25.csv@$T"; do
    model="$out/${m%@*}"
    t=(); [ "$m" != "${m%@*}" ] && t=(--temperature-c "${m#*@}")
    name=$(echo "$m" | tr '@' '-')
    j="$out/us06-$T-$name.json"
    $hs predict battery --model "$model" --input "${us06[$T]}" "${ocv[@]}" ${t[@]+"${t[@]}"} \
      --report "$out/report-us06-$T-$name" --json "$j" > "$out/us06-$T-$name.log" 2>&1
    python3 - "$j" "US06 $T °C" "$m" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
t = j["in_table"]
m = j.get("map") or {}
rule = m.get("temperature_rule", "—")
if m.get("temperature_c") is not None:
    rule += f" ({m['temperature_c']:.1f} °C)"
print(f"| {sys.argv[2]} | `{sys.argv[3]}` | {1e3 * j['rmse_v']:.2f} | {1e3 * t['rmse_v']:.2f} | "
      f"{1e3 * j['max_error_v']:.0f} | {rule} |")
PY
  done
done
grep -h "activation energy" "$out"/us06-*-map-10-25.csv.log | head -1
