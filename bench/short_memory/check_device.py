"""Task 2 check: the Python window fit (warm 63, memory 64, OCV slope) against host-sim's published estimate."""
import csv, sys
import numpy as np
from core import *
L, M = 256, 64
for prof in ['pulse', 'hppc', 'drive']:
    i, v = load(f'rec_{prof}.csv')
    rows = list(csv.DictReader(open(f'track_{prof}.csv')))
    for t in [999, 1500, 1999]:
        s = t - L + 1
        hs = {k: float(rows[t][k]) for k in ['r_i', 'r_ct', 'q', 'alpha', 'u_oc']}
        p, beta, rm = fit(i[s:t+1], v[s:t+1], M - 1, M, start=hs)
        p2, beta2, rm2 = fit(i[s:t+1], v[s:t+1], M - 1, M, start=TRUTH)
        print(f"{prof} t={t}: python-vs-hostsim {fmt(rel(p, hs))}  (from truth: {fmt(rel(p2, hs))}) beta={beta:.3g} rmse={rm*1e3:.3f} mV")
