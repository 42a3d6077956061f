#!/usr/bin/env python3
"""Summary of bench/butler_volmer.sh: the tables of docs/butler-volmer.md."""

import collections
import csv
import json
import math
import sys
from pathlib import Path

out = Path(sys.argv[1] if len(sys.argv) > 1 else "target/butler-volmer")
ref = json.load(open("data/pybamm/reference.json"))
records = ["chen2020-drive", "chen2020-hppc", "prada2013-drive", "prada2013-hppc"]


def load(name):
    return json.load(open(out / f"{name}.json"))


print("## Our own nonlinear model (a = 25 mV, i0 = 1.5 A, R_i = 20 mOhm, R_ct = 15 mOhm, alpha = 0.75)\n")
print("| record | --model | chosen | R_i err | a err | i0 err | R_ct err | alpha err | RMSE (mV) | reason |")
print("|---|---|---|---|---|---|---|---|---|---|")
truth = dict(r_i=0.020, r_ct=0.015, alpha=0.75, bv_a_v=0.025, bv_i0_a=1.5)
for r in ["own-bv", "own-linear"]:
    for m in ["auto", "linear", "butler-volmer"]:
        j = load(f"{r}-{m}")
        rel = lambda k: f"{100 * (j[k] / truth[k] - 1):+.1f} %" if j.get(k) is not None else "-"
        reason = (j.get("model_choice") or {}).get("reason", "")
        print(
            f"| {r} | {m} | {j['model']} | {rel('r_i')} | {rel('bv_a_v')} | {rel('bv_i0_a')} | "
            f"{rel('r_ct')} | {j['alpha'] - 0.75:+.4f} | {1e3 * j['rmse_v']:.3f} | {reason} |"
        )

print("\n## DFN records, whole record with the OCV table: free-run RMSE (mV)\n")
print(
    "| record | ours linear | ours BV | ratio | auto | reference CPE | reference CPE+BV | ours BV / ref | "
    "ref BV in branch | ref 1 RC (Thevenin) | ref 1 RC + BV | ref 2 RC | a (mV) | i0 (A) | R_i (mOhm) | R_ct (mOhm) | alpha |"
)
print("|" + "---|" * 17)
g = lambda d, k: f"{1e3 * d[k]['rmse_v']:.2f}" if k in d else "n/a"
for r in records:
    lin, bv, auto = load(f"{r}-linear"), load(f"{r}-butler-volmer"), load(f"{r}-auto")
    rr = ref[r]
    ratio_ref = f"{bv['rmse_v'] / rr['cpe_bv']['rmse_v']:.3f}" if "cpe_bv" in rr else "n/a"
    print(
        f"| {r} | {1e3 * lin['rmse_v']:.2f} | {1e3 * bv['rmse_v']:.2f} | {lin['rmse_v'] / bv['rmse_v']:.2f}x | "
        f"{auto['model']} | {g(rr, 'cpe')} | {g(rr, 'cpe_bv')} | {ratio_ref} | {g(rr, 'cpe_bv_branch')} | "
        f"{g(rr, 'rc1')} | {g(rr, 'rc1_bv')} | {g(rr, 'rc2')} | {1e3 * bv['bv_a_v']:.1f} | {bv['bv_i0_a']:.2f} | "
        f"{1e3 * bv['r_i']:.2g} | {1e3 * bv['r_ct']:.1f} | {bv['alpha']:.3f} |"
    )
print("\nauto's reasons:\n")
for r in records:
    print(f"* {r}: {load(f'{r}-auto')['model_choice']['reason']}")

print("\n## Sliding window 256 / memory 64 on the DFN records (rows after sample 512)\n")
print(
    "| record | model | prior | one-step prediction RMS (mV) | R_ct / whole-record (same model) | "
    "small-signal R_i + a/i0 / linear whole-record R_i | a (mV) | statuses after the first window |"
)
print("|---|---|---|---|---|---|---|---|")
for r in records:
    data = {row["time_s"]: float(row["voltage_v"]) for row in csv.DictReader(open(f"data/pybamm/{r}.csv"))}
    lin_ri = load(f"{r}-linear")["r_i"]
    for m in ["linear", "butler-volmer"]:
        whole = load(f"{r}-{m}")
        for v in ["none", "prior"]:
            rows = list(csv.DictReader(open(out / f"{r}-{m}-{v}.csv")))
            after = rows[512:]
            err = [float(x["predicted_v"]) - data[x["time_s"]] for x in after if x["predicted_v"]]
            pe = 1e3 * math.sqrt(sum(e * e for e in err) / len(err))
            pub = [x for x in after if x["r_ct"]]
            rct = [float(x["r_ct"]) / whole["r_ct"] for x in pub]
            ss = [
                (float(x["r_i"]) + (float(x["bv_a_v"]) / float(x["bv_i0_a"]) if x["bv_a_v"] else 0.0)) / lin_ri
                for x in pub
                if x["r_i"]
            ]
            a = [1e3 * float(x["bv_a_v"]) for x in pub if x["bv_a_v"]]
            st = collections.Counter(x["status"] for x in rows[256:])
            sts = ", ".join(f"{k} {n}" for k, n in st.most_common())
            arange = f"{min(a):.0f}..{max(a):.0f}" if a else "-"
            # Online publishes R_ct only where the data identify it: a run
            # may publish none.
            span = (lambda x: f"{min(x):.2f}..{max(x):.2f}" if x else "none published")
            print(
                f"| {r} | {m} | {'other record' if v == 'prior' else 'none'} | {pe:.2f} | "
                f"{span(rct)} | {span(ss)} | {arange} | {sts} |"
            )
