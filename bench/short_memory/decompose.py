"""Task 2: split the window fit's bias into its causes (noise-free records: the bias vs the truth;
noisy records: median over windows ending in the last 500 samples vs the whole-record fit)."""
import json, sys
import numpy as np
from core import *
from variants import *

KINDS = ['device', 'm64+pre', 'memL', 'rest', 'memL+pre', 'memL+oracle']
TIMES = list(range(1509, 2000, 35))   # 15 windows ending in the last 500 samples (+ t = 1999 below)

def run(rec, ref, kinds, slope, times):
    i, v = load(rec)
    for kind in kinds:
        res = [window_fit(kind, i, v, t, slope=slope)[0] for t in times]
        last = rel(window_fit(kind, i, v, 1999, slope=slope)[0], ref)
        med = {k: float(np.median([rel(p, ref)[k] for p in res])) for k in ['r_i', 'r_ct', 'q', 'alpha']}
        print(f"  {kind:12s} last: {fmt(last)} | median: {fmt(med)}", flush=True)

if __name__ == '__main__':
    which = sys.argv[1] if len(sys.argv) > 1 else 'clean'
    for prof in ['pulse', 'hppc', 'drive']:
        for slope in [True, False]:
            if which == 'clean':
                print(f"== {prof} noise-free, OCV slope {'fitted' if slope else 'off'}: vs truth")
                run(f'clean_{prof}.csv', TRUTH, KINDS, slope, TIMES)
            else:
                ref = json.load(open(f'whole_{prof}.json'))
                print(f"== {prof} sigma=1 mV, OCV slope {'fitted' if slope else 'off'}: vs whole-record fit (host-sim identify)")
                run(f'rec_{prof}.csv', ref, KINDS, slope, TIMES)
