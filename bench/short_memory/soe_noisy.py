"""Task 4b (sigma = 1 mV records, seeds 1..S): window-fit bias vs each record's whole-record full-memory fit
(host-sim identify), for the device (memory 64), the SOE correction (K = 8) and exact full memory
(GL weights over the window and the data before it), with and without the OCV slope.
Per record: 'last' = window ending at t = 1999, 'med' = median over 15 windows ending in t = 1509..1999 (step 35).
Printed: mean over seeds (and the standard error of that mean)."""
import json, subprocess, sys, os
import numpy as np
from core import *
from variants import *
S = int(sys.argv[1]) if len(sys.argv) > 1 else 6
TIMES = list(range(1509, 2000, 35))
KEYS = ['r_i', 'r_ct', 'q', 'alpha']
soe = SOE(M, 8)
out = {}
for prof in ['pulse', 'hppc', 'drive']:
    for seed in range(1, S + 1):
        rec, js = f'rec_{prof}_s{seed}.csv', f'whole_{prof}_s{seed}.json'
        if not os.path.exists(js):
            subprocess.run(['./host-sim', 'simulate', 'battery', '--preset', 'cell', '--profile', prof, '--length', '2000',
                            '--seed', str(seed), '--out', rec], check=True, capture_output=True)
            subprocess.run(['./host-sim', 'identify', 'battery', '--input', rec, '--json', js], check=True, capture_output=True)
        ref = json.load(open(js))
        i, v = load(rec)
        for slope in [True, False]:
            for kind in ['device', 'soe', 'memL+pre']:
                ds = [rel(window_fit(kind, i, v, t, slope=slope, soe=soe)[0], ref) for t in TIMES + [1999]]
                last = ds[-1]
                med = {k: float(np.median([d[k] for d in ds[:-1]])) for k in KEYS}
                out.setdefault(f'{prof}|{slope}|{kind}', []).append((last, med))
        print(f"done {prof} seed {seed}", file=sys.stderr, flush=True)
json.dump({k: v for k, v in out.items()}, open('soe_noisy.json', 'w'))
for key, lst in out.items():
    prof, slope, kind = key.split('|')
    for which, idx in [('last', 0), ('med ', 1)]:
        arr = {k: np.array([x[idx][k] for x in lst]) for k in KEYS}
        m = {k: arr[k].mean() for k in KEYS}
        se = {k: arr[k].std(ddof=1) / np.sqrt(len(lst)) for k in KEYS}
        print(f"{prof:5s} slope={'on ' if slope == 'True' else 'off'} {kind:9s} {which}: {fmt(m)}   (s.e. R_ct {100*se['r_ct']:.2f}% Q {100*se['q']:.2f}% alpha {se['alpha']:.4f})")
