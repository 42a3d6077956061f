#!/usr/bin/env bash
# The measurements of docs/butler-volmer.md: the Butler–Volmer model on a
# record of our own nonlinear model and on the PyBaMM DFN records
# (data/pybamm), against the linear model, the independent reference fits
# (data/pybamm/reference.json) and over the sliding window (256, memory 64)
# with and without a prior from the other record of the same cell.
# Writes everything into OUT (default target/butler-volmer) and prints the
# tables of the doc.
#
#   bash bench/butler_volmer.sh [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-target/butler-volmer}"
mkdir -p "$out"
cargo build --release -q -p host-sim
hs=target/release/host-sim
python3 bench/nmc_ocv.py "$out/nmc-ocv.csv"

# Our own nonlinear model: a = 25 mV, i0 = 1.5 A, pulses -6..+4 A, SOC 0.9 -> 0.56.
own=(--preset cell --profile pulse --amplitude 5 --mean-current -1 --ocv "$out/nmc-ocv.csv" --soc0 0.9 --length 3000)
$hs simulate battery "${own[@]}" --bv-a 0.025 --bv-i0 1.5 --seed 11 --out "$out/own-bv.csv" 2>/dev/null
$hs simulate battery "${own[@]}" --seed 11 --out "$out/own-linear.csv" 2>/dev/null
for r in own-bv own-linear; do
  for m in auto linear butler-volmer; do
    $hs identify battery --input "$out/$r.csv" --ocv "$out/nmc-ocv.csv" --capacity-ah 2.5 --soc0 0.9 \
      --model $m --json "$out/$r-$m.json" >/dev/null 2>&1
  done
done

cap() { python3 -c "import json;print(json.load(open('data/pybamm/meta.json'))['ocv']['$1']['capacity_ah'])"; }
for cell in chen2020 prada2013; do
  table=(--ocv "data/pybamm/$cell-ocv.csv" --capacity-ah "$(cap $cell)")
  for profile in drive hppc; do
    r="$cell-$profile"
    for m in auto linear butler-volmer; do
      $hs identify battery --input "data/pybamm/$r.csv" "${table[@]}" --model $m \
        --json "$out/$r-$m.json" --fit-out "$out/$r-$m-fit.csv" >/dev/null 2>&1
    done
  done
  for profile in drive hppc; do
    r="$cell-$profile"
    other=$([ "$profile" = drive ] && echo hppc || echo drive)
    for m in linear butler-volmer; do
      $hs online battery --input "data/pybamm/$r.csv" --window 256 "${table[@]}" --model $m \
        --out "$out/$r-$m-none.csv" 2>/dev/null
      $hs online battery --input "data/pybamm/$r.csv" --window 256 "${table[@]}" --model $m \
        --prior "$out/$cell-$other-$m.json" --out "$out/$r-$m-prior.csv" 2>/dev/null
    done
  done
done
"${PYTHON:-python3}" bench/butler_volmer_summary.py "$out"
