"""Task 1: bias of the published sliding-window estimate vs the whole-record fit and the truth."""
import csv, json
import numpy as np
TRUTH = dict(r_i=0.020, r_ct=0.015, q=8/0.015, alpha=0.75, u_oc=3.7)
KEYS = ['r_i', 'r_ct', 'q', 'alpha']
def dev(est, ref):
    return ' '.join(f"{k}:{(est[k]-ref[k]):+.4f}" if k == 'alpha' else f"{k}:{100*(est[k]/ref[k]-1):+.2f}%" for k in KEYS)
for p in ['pulse', 'hppc', 'drive']:
    whole = json.load(open(f'whole_{p}.json'))
    rows = list(csv.DictReader(open(f'track_{p}.csv')))
    last = {k: float(rows[-1][k]) for k in KEYS}
    tail = [r for r in rows[-500:] if r['status'] == 'tracking']
    med = {k: float(np.median([float(r[k]) for r in tail])) for k in KEYS}
    print(f"== {p}: whole-record fit " + ' '.join(f"{k}={whole[k]:.6g}" for k in KEYS) + f"; last status {rows[-1]['status']}, tracking rows in last 500: {len(tail)}")
    print(f"  whole vs truth      {dev(whole, TRUTH)}")
    print(f"  last   vs whole     {dev(last, whole)}    vs truth {dev(last, TRUTH)}")
    print(f"  median vs whole     {dev(med, whole)}    vs truth {dev(med, TRUTH)}")
