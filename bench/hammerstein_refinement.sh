#!/usr/bin/env bash
# The prediction-error refinement of `identify hammerstein` against the
# paper algorithms and an independent maximum-likelihood reference
# (bench/hammerstein_ml_reference.py, numpy + scipy), over seeds 1..5 on:
#   paper-kt-stable σ = 0.5 and 1 (L = 1000), σ = 0.5 (L = 4000),
#   paper-op σ = 0.01 and 0.001 (L = 1000);
# full memory (M = L) everywhere, α̂₀ = 0.25 (KT example) / 0.45 (OP).
# Writes target/hammerstein-refinement/*.json and prints the table of
# docs/identification.md (bench/hammerstein_refinement_summary.py).
# About 6 minutes on 2 cores (the reference takes 6–14 s per record).
#
#   bash bench/hammerstein_refinement.sh
set -euo pipefail
cd "$(dirname "$0")/.."
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
cargo build --release -q -p host-sim
B=target/release/host-sim
D=target/hammerstein-refinement
mkdir -p "$D"
now() { date +%s.%N; }
run_case() { # tag preset sigma length alpha0
  local tag=$1 preset=$2 sigma=$3 len=$4 alpha0=$5
  for seed in 1 2 3 4 5; do
    local f="$D/${tag}_${seed}"
    $B simulate hammerstein --preset "$preset" --sigma "$sigma" --length "$len" \
      --seed "$seed" --out "$f.csv" 2>/dev/null
    for method in paper refined; do
      for alg in op kt; do
        local t0; t0=$(now)
        $B identify hammerstein --input "$f.csv" --method $method --algorithm $alg \
          --alpha0 "$alpha0" --json "$f.$method.$alg.json" >/dev/null 2>&1
        awk -v a="$(now)" -v b="$t0" 'BEGIN { print a - b }' > "$f.$method.$alg.seconds"
      done
    done
    python3 bench/hammerstein_ml_reference.py --input "$f.csv" --preset "$preset" \
      --json "$f.reference.json" >/dev/null
    echo "$tag seed $seed done" >&2
  done
}
run_case kt-0.5 paper-kt-stable 0.5 1000 0.25
run_case kt-1 paper-kt-stable 1 1000 0.25
run_case kt-0.5-L4000 paper-kt-stable 0.5 4000 0.25
run_case op-0.01 paper-op 0.01 1000 0.45
run_case op-0.001 paper-op 0.001 1000 0.45
python3 bench/hammerstein_refinement_summary.py "$D"
