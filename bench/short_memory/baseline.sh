#!/bin/sh
# Task 1: records, whole-record full-memory fits, sliding-window tracks (L, M) = (256, 64)
set -e
cd "$(dirname "$0")"
# The project's CLI (built by `cargo build --release -p host-sim`).
[ -x ./host-sim ] || ln -sf ../../target/release/host-sim ./host-sim
for p in pulse hppc drive; do
  ./host-sim simulate battery --preset cell --profile $p --length 2000 --seed 1 --out rec_$p.csv >/dev/null
  ./host-sim identify battery --input rec_$p.csv --json whole_$p.json >/dev/null
  ./host-sim online battery --input rec_$p.csv --window 256 --memory 64 --out track_$p.csv >/dev/null
done
python3 baseline.py
