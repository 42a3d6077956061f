"""Task 4b (noise-free records): bias of the window fit with the SOE tail correction vs the truth,
for K modes (T_k geometric in [16, 40000] s), with and without the OCV slope beta."""
import numpy as np
from core import *
from variants import *
TIMES = list(range(1509, 2000, 35)) + [1999]
for prof in ['pulse', 'hppc', 'drive']:
    i, v = load(f'clean_{prof}.csv')
    for slope in [True, False]:
        print(f"== {prof} noise-free, OCV slope {'fitted' if slope else 'off'}: worst |bias| over {len(TIMES)} windows vs truth")
        for K in [4, 6, 8, 10]:
            soe = SOE(M, K)
            for kind in ['soe', 'soe-in']:
                ds = [rel(window_fit(kind, i, v, t, slope=slope, soe=soe)[0], TRUTH) for t in TIMES]
                worst = {k: max((d[k] for d in ds), key=abs) for k in ['r_i', 'r_ct', 'q', 'alpha']}
                print(f"  K={K:2d} {kind:7s} {fmt(worst)}", flush=True)
