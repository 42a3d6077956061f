#!/usr/bin/env python3
"""Writes `excerpt-10degC-near-empty.csv`: the rows of the 10 degC HPPC
export (`03-27-17_09.06 10degC_5Pulse_HPPC_Pan18650PF.mat`) from 60 s
before its 2.9 A pulse at 83 921.6 s to the edge of the next 2.9 A
pulse, at 88 722.7 s: pulses of 2.9, 5.8 and 1.45 A, and the log's gap
over the discharge to the last level (SOC about 0.096 to 0.058), time
from the excerpt's start, as `time_s`
(s), `current_a` (A, discharge negative), `voltage_v` (V) and `ah` (the
export's own `Ah` count). A regression fixture of `host-sim identify
battery` (host-sim/tests/cli/real.rs).

    python3 data/panasonic-18650pf/make_excerpt.py
"""

import os

import scipy.io as sio

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = "03-27-17_09.06 10degC_5Pulse_HPPC_Pan18650PF.mat"
T0, T1 = 83861.63999676704, 88722.7259952575


def main():
    m = sio.loadmat(os.path.join(HERE, SOURCE))["meas"][0, 0]
    t, i, v, ah = (m[k].ravel() for k in ("Time", "Current", "Voltage", "Ah"))
    with open(os.path.join(HERE, "excerpt-10degC-near-empty.csv"), "w") as f:
        f.write("time_s,current_a,voltage_v,ah\n")
        for a, b, c, d in zip(t, i, v, ah):
            if T0 <= a <= T1:
                f.write(f"{a - T0:.3f},{b:.5g},{c:.6g},{d:.7g}\n")


if __name__ == "__main__":
    main()
