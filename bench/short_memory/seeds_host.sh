#!/bin/sh
# The short-memory bias of host-sim's sliding window (L, M) = (256, 64), with
# and without the correction (--tail, also in f32 as the firmware runs it), over 6 seeds x 3 profiles: each track's
# median of the last 500 estimates against the same record's full-memory
# whole-record fit, then the mean over seeds (the bias) and the spread (the
# window's noise). About 2 minutes. Writes seeds_host.txt.
set -e
cd "$(dirname "$0")"
[ -x ./host-sim ] || ln -sf ../../target/release/host-sim ./host-sim
mkdir -p seeds
for p in pulse hppc drive; do
  for s in 1 2 3 4 5 6; do
    r=seeds/${p}_$s
    ./host-sim simulate battery --preset cell --profile $p --length 2000 --seed $s --out $r.csv >/dev/null
    ./host-sim identify battery --input $r.csv --model linear --json $r.whole.json >/dev/null
    ./host-sim online battery --input $r.csv --window 256 --memory 64 --start at-rest --model linear --out $r.truncated.csv >/dev/null
    ./host-sim online battery --input $r.csv --window 256 --memory 64 --start at-rest --model linear --tail --out $r.tail.csv >/dev/null
    ./host-sim online battery --input $r.csv --window 256 --memory 64 --start at-rest --model linear --tail --precision f32 --out $r.tail-f32.csv >/dev/null
  done
done
python3 seeds_host.py > seeds_host.txt
cat seeds_host.txt
