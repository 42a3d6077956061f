#!/usr/bin/env bash
# How the measured exports in data/ are read as the cycler ran them
# (docs/measured-cells.md, "Step starts on the measured cells"): per record, the
# `read` line (step starts, unobserved samples), the state column, the
# export's own charge count against ours, and the whole-record fit with the
# step starts (`--steps auto`) beside the row-by-row reading
# (`--steps ignore`). About 20 s on one core.
#
#   bash bench/cycler_steps.sh [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-target/cycler-steps}"
mkdir -p "$out"
cargo build --release -q -p host-sim
hs=$PWD/target/release/host-sim
p=data/panasonic-18650pf
lg=data/lg-m50
run() { # name, file, extra args...
  local name=$1 file=$2; shift 2
  for steps in auto ignore; do
    "$hs" identify battery --input "$file" --model linear --steps $steps "$@" \
      --json "$out/$name-$steps.json" > "$out/$name-$steps.log" 2>&1 || true
  done
  python3 - "$out/$name" "$name" <<'PY'
import json, sys
base, name = sys.argv[1], sys.argv[2]
a, b = (json.load(open(f"{base}-{s}.json")) for s in ("auto", "ignore"))
r = a["record"]
st, cc, s = r["steps"], r["charge_check"], r["state"]
cc_s = (f"`{cc['column']}` ours {cc['ours_ah']:.4f} A·h, theirs {cc['theirs_ah']:.4f} A·h, "
        f"largest gap {1e3 * cc['max_gap_ah']:.1f} mA·h" if cc else "no charge column")
s_s = (f"`{s['column']}`: {s['disagreeing_rows']} of {s['loaded_rows']} loaded rows disagree"
       + (", signs the current" if s["signs_current"] else "") if s else "no state column")
print(f"| {name} | {st['starts_from']} | {len(st['unlogged'])} of {st['changes']} | "
      f"{r['unobserved_samples']} | {s_s} | {cc_s} | "
      f"{1e3 * a['r_i']:.3f} / {1e3 * b['r_i']:.3f} | {1e3 * a['rmse_v']:.3f} / {1e3 * b['rmse_v']:.3f} |")
PY
}
echo "| record | starts from | steps begun before their first row | unobserved samples | state | charge check | R_i mΩ auto / ignore | RMSE mV auto / ignore |"
echo "|---|---|---|---|---|---|---|---|"
for T in 25 10 45; do
  cell=$(case $T in 25) echo Cell1;; 10) echo Cell13;; 45) echo Cell7;; esac)
  run "lgm50-pulse-T$T-SoC5" $lg/LGM50_5Ah_Pulse.mat \
    --table LGM50_5Ah_Pulse.T$T.SoC5.$cell.data --columns temperature=LogTemp001
done
run panasonic-25C-hppc "$p/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat"
run panasonic-10C-hppc "$p/03-27-17_09.06 10degC_5Pulse_HPPC_Pan18650PF.mat"
run panasonic-25C-us06 "$p/03-20-17_01.43 25degC_US06_Pan18650PF.mat"
run panasonic-c20 "$p/05-08-17_13.26 C20 OCV Test_C20_25dC.mat"
run panasonic-dis5-10p "$p/03-11-17_10.10 3390_dis5_10p.mat"
