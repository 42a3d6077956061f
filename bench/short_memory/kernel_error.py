"""Task 4a: error of the sum-of-exponentials (SOE) approximation of the GL weights w_j(alpha), j >= M = 64.
Rates fixed (geometric time constants T_k in [t_min, t_max]); c_k(alpha) by relative least squares on j in [M, J).
Metrics over j in [M, 4096] (longer than the fits here) and over [M, 20000):
  rel_max = max_j |w^_j - w_j| / |w_j|,  l1 = sum_j |w^_j - w_j| / sum_{j>=M} |w_j|  (worst-case error of the tail sum
  for a bounded U_p, relative to the tail's size)."""
import numpy as np
from core import SOE, gl_weights
M = 64
ALPHAS = [0.3, 0.4, 0.5, 0.6, 0.7, 0.75, 0.8, 0.9, 0.95, 0.99]
def errs(soe, alpha, Jeval):
    w = gl_weights(alpha, Jeval)[M:]
    c = soe.coeffs(alpha)
    j = np.arange(M, Jeval)
    wh = (soe.r[None, :] ** j[:, None]) @ c
    return np.max(np.abs(wh - w) / np.abs(w)), np.sum(np.abs(wh - w)) / np.sum(np.abs(w))
print("beyond-J tail mass (fraction of sum_{j>=M}|w_j| at lags >= J), by alpha:")
wbig = {a: gl_weights(a, 400000)[M:] for a in ALPHAS}
for J in [2000, 4096, 20000]:
    print(f"  J={J:6d}: " + ' '.join(f"{a}:{np.abs(wbig[a][J-M:]).sum()/np.abs(wbig[a]).sum():.3f}" for a in ALPHAS))
for t_min, t_max, J in [(32.0, 4000.0, 20000), (16.0, 40000.0, 20000), (8.0, 100000.0, 20000)]:
    print(f"\nrates T_k geometric in [{t_min:g}, {t_max:g}], fit on j in [M, {J}):  rel_max / l1 over j<4096  (l1 over j<20000)")
    for K in [2, 3, 4, 5, 6, 8, 10, 12]:
        soe = SOE(M, K, t_min=t_min, t_max=t_max, J=J)
        row = []
        for a in ALPHAS:
            rm, l1 = errs(soe, a, 4096)
            _, l1b = errs(soe, a, 20000)
            row.append(f"{rm:.0e}/{l1:.0e}({l1b:.0e})")
        print(f"  K={K}: " + ' '.join(f"{a}:{x}" for a, x in zip(ALPHAS, row)))
