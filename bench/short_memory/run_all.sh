#!/bin/sh
# Remakes every number in REPORT.md (about 20 min on one core). Needs numpy, scipy.
set -e
cd "$(dirname "$0")"
# The project's CLI (built by `cargo build --release -p host-sim`).
[ -x ./host-sim ] || ln -sf ../../target/release/host-sim ./host-sim
./baseline.sh > baseline.txt                         # task 1 (host-sim: records, whole fits, tracks)
for p in pulse hppc drive; do ./host-sim simulate battery --preset cell --profile $p --length 2000 --seed 1 --sigma 0 --out clean_$p.csv >/dev/null; done
python3 check_device.py > check_device.txt           # task 2: python window fit = host-sim estimate
python3 decompose.py clean > decompose_clean.txt     # task 2: causes, noise-free
python3 decompose.py noisy > decompose_noisy.txt     # task 2: causes, seed 1, sigma 1 mV
python3 kernel_error.py > kernel_error.txt           # task 4a: SOE kernel error vs K
python3 coeff_table.py > coeff_table.txt             # c_k(alpha) table, f32 modes
python3 soe_device.py > soe_device.txt               # O(K) loops = matrix form
python3 soe_clean.py > soe_clean.txt                 # task 4b: bias with SOE, noise-free
python3 soe_noisy.py 6 > soe_noisy.txt               # task 4b: bias with SOE, 6 seeds x 3 profiles
python3 spread.py > spread.txt
