"""c_k(alpha) tabulated on an alpha grid (flash constants) and interpolated: kernel error of the interpolated
coefficients vs the exactly fitted ones (L1 over lags 64..20000, relative to sum |w_j|), K = 8, T_k in [16, 40000].
Also: size of the coefficients (cancellation) and the f32 accuracy of the per-sample mode recursions."""
import numpy as np
from scipy.interpolate import CubicSpline
from core import SOE, gl_weights, load
M = 64
soe = SOE(M, 8)
j = np.arange(M, 20000)
E = soe.r[None, :] ** j[:, None]
def l1(c, a):
    w = gl_weights(a, 20000)[M:]
    return np.abs(E @ c - w).sum() / np.abs(w).sum()
print("T_k =", np.round(soe.T, 1).tolist())
print("c_k(0.75) =", np.array2string(soe.coeffs(0.75), precision=3), " sum|c_k r_k^M| / |w_M| =",
      f"{np.abs(soe.coeffs(0.75) * soe.r**M).sum() / abs(gl_weights(0.75, M+1)[M]):.2f}")
test = np.linspace(0.305, 0.995, 70)
for step in [0.05, 0.02, 0.01]:
    grid = np.round(np.arange(0.05, 1.0 + 1e-9, step), 6)
    C = np.array([soe.coeffs(a) for a in grid])
    lin = max(l1(np.array([np.interp(a, grid, C[:, k]) for k in range(8)]), a) for a in test)
    cs = CubicSpline(grid, C, axis=0)
    cub = max(l1(cs(a), a) for a in test)
    print(f"grid step {step}: {len(grid)}x8 table; worst L1 kernel error, linear interp {lin:.1e}, cubic {cub:.1e} "
          f"(exact fit: {max(l1(soe.coeffs(a), a) for a in test):.1e})")
# f32 mode recursions over 100 000 samples (drive record repeated 50x)
i, v = load('rec_drive.csv')
I = np.tile(i, 50); V = np.tile(v, 50)
for label, vr in [('raw v', 0.0), ('v - 3.7 V (reference)', 3.7)]:
    err = []
    for k in [0, 4, 7]:
        r64 = soe.r[k]; r32 = np.float32(r64)
        s1 = si = sv = 0.0; f1 = fi = fv = np.float32(0)
        for n in range(len(I)):
            s1 = r64 * s1 + 1; si = r64 * si + I[n]; sv = r64 * sv + (V[n] - vr)
            f1 = r32 * f1 + np.float32(1); fi = r32 * fi + np.float32(I[n]); fv = r32 * fv + np.float32(V[n] - vr)
        S64 = sv - (3.7 - vr) * s1 - 0.02 * si
        S32 = float(fv) - (3.7 - vr) * float(f1) - 0.02 * float(fi)
        err.append(f"T={soe.T[k]:.0f}: S={S64:.4g}, f32 rel err {abs(S32 - S64) / abs(S64):.1e}")
    print(f"f32 modes, {label}: " + '; '.join(err))
# scaled table: c_k(alpha) = -(sin(pi alpha)/pi) s_k^(1+alpha) g_k(alpha), s_k = 1/T_k (the diffusive-representation
# form j^(-1-alpha) = (1/Gamma(1+alpha)) int s^alpha e^(-js) ds); g_k smooth, linear interpolation of g_k.
s_k = 1.0 / soe.T
def scale(a):
    return -(np.sin(np.pi * a) / np.pi) * s_k ** (1 + a)
for step in [0.05, 0.02]:
    grid = np.round(np.arange(0.05, 0.99 + 1e-9, step), 6)
    G = np.array([soe.coeffs(a) / scale(a) for a in grid])
    lin = max(l1(scale(a) * np.array([np.interp(a, grid, G[:, k]) for k in range(8)]), a) for a in test if a <= grid[-1])
    print(f"scaled table g_k, step {step}: {len(grid)}x8, linear interp worst L1 {lin:.1e}")
grid = np.round(np.arange(0.05, 0.95 + 1e-9, 0.05), 6)
G = np.array([soe.coeffs(a) / scale(a) for a in grid])
def c_table(a):
    # linear interpolation of g_k, linear extrapolation beyond the last node (alpha in (0.95, 1))
    k = min(np.searchsorted(grid, a) , len(grid) - 1); k = max(k, 1)
    t = (a - grid[k - 1]) / (grid[k] - grid[k - 1])
    return scale(a) * (G[k - 1] + t * (G[k] - G[k - 1]))
hi = np.linspace(0.3, 0.999, 141)
print(f"19x8 scaled table alpha 0.05..0.95 (extrapolated to 0.999): worst L1 over alpha in [0.3, 0.999] = "
      f"{max(l1(c_table(a), a) for a in hi):.1e} (exact LS: {max(l1(soe.coeffs(a), a) for a in hi):.1e})")
