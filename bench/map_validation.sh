#!/usr/bin/env bash
# Parameter maps validated on records they were not fitted on
# (docs/maps.md, "How accurate is a map"): the Panasonic NCR18650PF HPPC
# tests at 25 and 10 °C (data/panasonic-18650pf, the exports as they come)
# each give a map of its levels fitted one by one (`--map-method levels`),
# a joint map (`--map-method joint`) and a single whole-record fit; all
# run on the US06 drive cycles at 25 and 10 °C, and the maps of both
# temperatures joined run at each record's own temperature (its
# temperature column's mean: Arrhenius between 10 and 25 °C) and at the
# nearest map temperature. Prints two Markdown tables; `--report` pages go
# into OUT/report-*. The joint map of the 25 °C test is then fitted again
# by bench/joint_reference.py (scipy, the same objective; the levels' and
# the joint fit's inputs go into OUT/levels-*). About 70 s on one core.
#
#   bash bench/map_validation.sh [OUT]
#   HOST_SIM=path/to/host-sim bash bench/map_validation.sh [OUT]   # no build
#   CAPACITY_AH=2.9974 bash bench/map_validation.sh [OUT]   # count with the C/20 test's capacity
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-target/map-validation}"
mkdir -p "$out"
[ -n "${HOST_SIM:-}" ] || cargo build --release -q -p host-sim
hs=${HOST_SIM:-target/release/host-sim}
d=data/panasonic-18650pf
cap=${CAPACITY_AH:-2.9}
$hs ocv --input "$d/05-08-17_13.26 C20 OCV Test_C20_25dC.mat" --from low-rate --out "$out/ocv.csv" > /dev/null 2>&1
ocv=(--ocv "$out/ocv.csv" --capacity-ah $cap)
declare -A hppc=([25]="$d/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat"
                 [10]="$d/03-27-17_09.06 10degC_5Pulse_HPPC_Pan18650PF.mat")
declare -A us06=([25]="$d/03-20-17_01.43 25degC_US06_Pan18650PF.mat"
                 [10]="$d/03-27-17_09.06 10degC_US06_Pan18650PF.mat")
echo "| map of | rows (identifiable) | in-sample RMSE: map / single fit (mV) | time (s) |"
echo "|---|---|---|---|"
for method in levels joint; do
  for T in 25 10; do
    tag=$T; [ $method = joint ] && tag=joint-$T
    start=$(date +%s.%N)
    $hs identify battery --input "${hppc[$T]}" "${ocv[@]}" --min-rest 3000 --model linear \
      --temperature-c $T --map-method $method --map-out "$out/map-$tag.csv" --json "$out/fit-$tag.json" \
      --levels-out "$out/levels-$tag" > "$out/map-$tag.log" 2>&1
    took=$(python3 -c "import sys;print(f'{float(sys.argv[2]) - float(sys.argv[1]):.1f}')" "$start" "$(date +%s.%N)")
    python3 - "$out/fit-$tag.json" "$T °C HPPC, $method" "$took" <<'PY'
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
(cat "$out/map-10.csv"; tail -n +2 "$out/map-25.csv") > "$out/map-10-25.csv"
(cat "$out/map-joint-10.csv"; tail -n +2 "$out/map-joint-25.csv") > "$out/map-joint-10-25.csv"
echo
echo "| record | model | RMSE (mV) | RMSE inside the OCV table (mV) | max error (mV) | temperature rule |"
echo "|---|---|---|---|---|---|"
for T in 25 10; do
  for m in "map-$T.csv" "map-joint-$T.csv" "fit-$T.json" "map-10-25.csv" "map-10-25.csv@$T" \
           "map-joint-10-25.csv" "map-joint-10-25.csv@$T"; do
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
echo
echo "The joint map of the 25 °C test against an independent scipy fit of the same objective:"
python3 bench/joint_reference.py "$out/levels-joint-25" | tail -n +1 | grep -E "^\||^acceptance"
