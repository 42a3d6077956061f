#!/usr/bin/env bash
# The measurements of docs/real-cells.md on the PyBaMM DFN records
# (data/pybamm): whole-record fits with and without the OCV table, and the
# sliding-window tracks (window 256, memory 64) without a prior and with a
# prior from the other record of the same cell, with and without the table.
# Writes everything into OUT (default target/real-cells), prints a summary
# table, and plots docs/real-cells/tracks.svg when matplotlib is importable.
#
#   bash bench/real_cells.sh [OUT]
#
# ONLINE_ARGS adds flags to every `online battery` line, e.g.
# ONLINE_ARGS=--tail bash bench/real_cells.sh target/real-cells-tail
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-target/real-cells}"
mkdir -p "$out"
cargo build --release -q -p host-sim
hs=target/release/host-sim
# shellcheck disable=SC2206
extra=(${ONLINE_ARGS:-})
cap() { python3 -c "import json;print(json.load(open('data/pybamm/meta.json'))['ocv']['$1']['capacity_ah'])"; }
for cell in chen2020 prada2013; do
  c=$(cap "$cell")
  for profile in drive hppc; do
    r="$cell-$profile"
    table=(--ocv "data/pybamm/$cell-ocv.csv" --capacity-ah "$c")
    $hs identify battery --input "data/pybamm/$r.csv" "${table[@]}" --json "$out/$r-fit.json" \
      --fit-out "$out/$r-fit.csv" >/dev/null
    $hs identify battery --input "data/pybamm/$r.csv" --json "$out/$r-fit-no-table.json" >/dev/null
  done
  for profile in drive hppc; do
    r="$cell-$profile"
    other=$([ "$profile" = drive ] && echo hppc || echo drive)
    table=(--ocv "data/pybamm/$cell-ocv.csv" --capacity-ah "$c")
    prior=(--prior "$out/$cell-$other-fit.json")
    $hs online battery --input "data/pybamm/$r.csv" --window 256 ${extra[@]+"${extra[@]}"} "${table[@]}" --out "$out/$r-table.csv" 2>/dev/null
    $hs online battery --input "data/pybamm/$r.csv" --window 256 ${extra[@]+"${extra[@]}"} --out "$out/$r-none.csv" 2>/dev/null
    $hs online battery --input "data/pybamm/$r.csv" --window 256 ${extra[@]+"${extra[@]}"} "${table[@]}" "${prior[@]}" \
      --out "$out/$r-table-prior.csv" 2>/dev/null
    $hs online battery --input "data/pybamm/$r.csv" --window 256 ${extra[@]+"${extra[@]}"} "${prior[@]}" \
      --out "$out/$r-none-prior.csv" 2>/dev/null
  done
done
"${PYTHON:-python3}" bench/real_cells_summary.py "$out"
