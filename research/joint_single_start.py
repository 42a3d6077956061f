#!/usr/bin/env python3
# Research script (docs/research.md), not a benchmark.
# Question: Does the LG M50 45 degC joint map lose to the single fit on the rate tests because its search starts from the levels, where the single fit's slower branch (R_ct 52 mOhm, alpha 0.53) would have been kept had it started there?
# Answer: no. Started from the single fit's R_i, R_ct, tau and alpha, scipy's fit of the same joint objective returns to the same minimum (R_ct 13.6 mOhm, alpha 0.633, the same cost to 1e-9): the data pin the shared slow part; nothing to build.
"""The LG M50 45 degC joint map (issue 73; docs/maps.md, "On a second
cell: LG M50") started from the single whole-record fit's slow part.

Makes the 45 degC joint map as bench/lgm50_maps.sh does (the file's own
OCV, the nine one-pulse records joined), with `--levels-out` for the joint
objective (`joint.json`, `joint-record.csv`), then fits that objective
with bench/joint_reference.py's scipy problem from a start where every
knot's R_i and the shared ln R_ct, ln tau and alpha are the single fit's
(the command's JSON), and prints both ends against ours.

    cargo build --release -p host-sim
    python3 research/joint_single_start.py      # about 10 s
"""

import json
import os
import subprocess
import sys

import numpy as np
import scipy.io as sio

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "bench"))
import joint_reference as jr  # noqa: E402

OUT = "target/research/joint-single-start"
D = "data/lg-m50"


def main():
    os.makedirs(OUT, exist_ok=True)
    ocv = os.path.join(OUT, "ocv-file.csv")
    m = sio.loadmat(f"{D}/LGM50_5Ah_OCV.mat", simplify_cells=True)["LGM50_5Ah_OCV"]["T25"]
    with open(ocv, "w") as f:
        f.write("soc,ocv_v\n")
        for s, v in zip(m["refSoC"], m["meanOCV"]):
            f.write(f"{s / 100},{v}\n")
    tables = ",".join(f"LGM50_5Ah_Pulse.T45.SoC{s}.Cell7.data" for s in range(9, 0, -1))
    fit = os.path.join(OUT, "fit-joint-45.json")
    levels = os.path.join(OUT, "levels-joint-45")
    subprocess.run(["target/release/host-sim", "identify", "battery", "--input",
                    f"{D}/LGM50_5Ah_Pulse.mat", "--table", tables, "--columns",
                    "temperature=LogTemp001", "--ocv", ocv, "--capacity-ah", "5", "--soc0", "0.9",
                    "--model", "linear", "--temperature-c", "45", "--map-method", "joint",
                    "--map-out", os.path.join(OUT, "map-joint-45.csv"), "--json", fit,
                    "--levels-out", levels], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    pb = jr.Problem(levels)
    single = json.load(open(fit))
    rmse, cost, _, _ = pb.parts(pb.theta_ours)
    print(f"ours: data RMSE {1e3 * rmse:.4f} mV, cost {cost:.10f}, R_ct "
          f"{1e3 * np.exp(pb.theta_ours[pb.index(1, 0)]):.2f} mOhm, alpha "
          f"{pb.theta_ours[pb.index(3, 0)]:.4f}")
    x0 = pb.theta_ours.copy()
    for j in range(pb.K):
        x0[pb.index(0, j)] = np.log(single["r_i"])
    x0[pb.index(1, 0)] = np.log(single["r_ct"])
    x0[pb.index(2, 0)] = np.log(single["r_ct"] * single["q"])
    x0[pb.index(3, 0)] = single["alpha"]
    print(f"start (the single fit's R_i, R_ct {1e3 * single['r_ct']:.2f} mOhm, tau "
          f"{single['r_ct'] * single['q']:.2f}, alpha {single['alpha']:.4f}): data RMSE "
          f"{1e3 * pb.parts(x0)[0]:.4f} mV")
    res, took, nfev, _ = pb.fit(x0)
    rmse2, cost2, _, _ = pb.parts(res.x)
    print(f"scipy from there: data RMSE {1e3 * rmse2:.4f} mV, cost {cost2:.10f} "
          f"({cost2 / cost:.9f}x ours), R_ct {1e3 * np.exp(res.x[pb.index(1, 0)]):.2f} mOhm, "
          f"tau {np.exp(res.x[pb.index(2, 0)]):.2f}, alpha {res.x[pb.index(3, 0)]:.4f} "
          f"({nfev} evaluations, {took:.1f} s)")


if __name__ == "__main__":
    main()
