"""Per-record spread (sd over seeds) and how many of the 6 records are inside the bands (2 % R_i, R_ct; 5 % Q; 0.01 alpha)
for each statistic (last window, median of 15 windows), from soe_noisy.json."""
import json
import numpy as np
d = json.load(open('soe_noisy.json'))
B = dict(r_i=0.02, r_ct=0.02, q=0.05, alpha=0.01)
for key, lst in d.items():
    for which, idx in [('last', 0), ('med', 1)]:
        sd = {k: np.std([x[idx][k] for x in lst], ddof=1) for k in B}
        inside = sum(all(abs(x[idx][k]) <= B[k] for k in B) for x in lst)
        print(f"{key:26s} {which:4s} sd: R_i {100*sd['r_i']:.2f}% R_ct {100*sd['r_ct']:.2f}% Q {100*sd['q']:.2f}% alpha {sd['alpha']:.4f}; inside bands {inside}/{len(lst)}")
