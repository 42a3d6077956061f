#!/usr/bin/env bash
# The whole chain of docs/measured-cells.md on a measured cell, the Panasonic
# NCR18650PF at 25 °C (data/panasonic-18650pf, the exports as they come):
#
#   raw C/20 export -> OCV table -> HPPC export -> per-level parameter map
#   (`--map-method levels`, + each level's record: what the scipy reference
#   fits again level by level; the joint map is bench/map_validation.sh's) -> scipy reference per level -> validation of both maps
#   on the US06 drive cycle -> online with the map as the prior.
#
# Writes everything into OUT (default target/real-cells/panasonic) and prints
# the numbers the page quotes. About 2 minutes on one core (the map 7 s
# since its fits run with the full memory by FFT, 117 s before), plus
# 1.5 min for the reference (numpy + scipy).
#
#   bash bench/panasonic_chain.sh [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-target/real-cells/panasonic}"
mkdir -p "$out"
cargo build --release -q -p host-sim
hs=$PWD/target/release/host-sim
d=data/panasonic-18650pf
c20="$d/05-08-17_13.26 C20 OCV Test_C20_25dC.mat"
hppc="$d/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat"
us06="$d/03-20-17_01.43 25degC_US06_Pan18650PF.mat"
cap=2.9
echo "== OCV from the C/20 test"
$hs ocv --input "$c20" --from low-rate --out "$out/ocv.csv" --plot "$out/ocv.svg" 2>&1 | tail -1
echo "== map of the HPPC test"
rm -rf "$out/levels"
/usr/bin/time -f "map: %e s wall, %U s user" $hs identify battery --input "$hppc" \
  --ocv "$out/ocv.csv" --capacity-ah $cap --min-rest 3000 --model linear --map-method levels \
  --map-out "$out/map.csv" --map-plot "$out/map.svg" --levels-out "$out/levels" \
  --json "$out/fit.json" --fit-out "$out/fit.csv" 2>&1 | grep -E "^(map|refined|wrote [0-9]+ levels)" || true
echo "== scipy reference per level"
python3 bench/reference_map.py "$out/levels" --ours "$out/map.csv" | grep -E "^\||total time"
echo "== validation on the US06 drive cycle"
for m in "$out/map.csv" "$out/levels/reference-map.csv"; do
  $hs predict battery --model "$m" --input "$us06" --ocv "$out/ocv.csv" --capacity-ah $cap \
    --out "$out/us06-$(basename "$m")" --json "$out/us06-$(basename "$m" .csv).json" 2>&1 | tail -1
done
# The drive cycle does not start at rest on a 1 s period: its start SOC as
# predict read it at the log's own rested first rows.
soc0=$(python3 -c "import json,sys;print(round(json.load(open(sys.argv[1]))['soc0'],4))" "$out/us06-map.json")
echo "== online on the US06 drive cycle with the map as the prior"
for prior in map none; do
  p=(--prior "$out/map.csv"); [ $prior = none ] && p=()
  $hs online battery --input "$us06" --ocv "$out/ocv.csv" --capacity-ah $cap --soc0 "$soc0" --period 1 \
    "${p[@]}" --out "$out/us06-online-$prior.csv" 2>&1 | grep -v "^warning" | grep -E "prior from|^wrote"
  python3 - "$out/us06-online-$prior.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
st = {}
for r in rows:
    st[r["status"]] = st.get(r["status"], 0) + 1
pub = [float(r["r_i"]) for r in rows if r["status"] == "tracking" and r["r_i"]]
pub.sort()
print("statuses:", ", ".join(f"{k} {v}" for k, v in sorted(st.items(), key=lambda x: -x[1])))
if pub:
    print(f"published R_i: median {1e3 * pub[len(pub) // 2]:.2f} mOhm, 5-95 % "
          f"{1e3 * pub[len(pub) // 20]:.2f}-{1e3 * pub[len(pub) * 19 // 20]:.2f} mOhm")
PY
done
