"""Window fit of the fractional cell model, reproducing estimator-core's output-error fit,
with the variants used to split the bias and the sum-of-exponentials (SOE) tail correction.

Model (h = 1 s):  (1 + a) U_p(l) = R_ct I(l) - a * sum_{j>=1} wt_j U_p(l-j),  a = R_ct Q,
  U_t(l) = U_oc - beta c(l) + R_i I(l) + U_p(l)     (beta: the device's OCV slope, optional)
wt_j = w_j (GL) for j < M; for j >= M: 0 (device), w_j (full memory), or the SOE sum_k c_k r_k^j.
"""
import numpy as np
from scipy.linalg import solve_triangular
from scipy.optimize import least_squares
from scipy.special import gammaln

TRUTH = dict(r_i=0.020, r_ct=0.015, q=8 / 0.015, alpha=0.75, u_oc=3.7)


def gl_weights(alpha, n):
    j = np.arange(1, n)
    w = np.empty(n)
    w[0] = 1.0
    w[1:] = np.cumprod(1.0 - (alpha + 1.0) / j)
    return w


def load(path):
    d = np.loadtxt(path, delimiter=',', skiprows=1)
    return d[:, 1].copy(), d[:, 2].copy()


# ---------------------------------------------------------------- SOE kernel
class SOE:
    """w_j ~ sum_k c_k(alpha) r_k^j for j >= M, with fixed rates r_k = exp(-1/T_k), T_k geometric in
    [t_min, t_max] (independent of alpha, so the mode sums kept as state do not depend on alpha);
    c_k(alpha) by relative least squares on npts log-spaced lags in [M, J)."""

    def __init__(self, M, K, t_min=16.0, t_max=40000.0, J=20000, npts=600):
        self.M, self.K = M, K
        self.T = np.geomspace(t_min, t_max, K) if K > 1 else np.array([t_max])
        self.r = np.exp(-1.0 / self.T)
        self.jfit = np.unique(np.geomspace(M, J - 1, npts).round().astype(int))
        self.B = self.r[None, :] ** self.jfit[:, None]
        self.J = J
        self._cache = {}

    def coeffs(self, alpha):
        key = float(alpha)
        if key in self._cache:
            return self._cache[key]
        if alpha >= 1.0:                       # w_j = 0 for j >= 3
            c = np.zeros(self.K)
        else:
            w = gl_weights(alpha, self.J)[self.jfit]
            s = 1.0 / np.abs(w)
            c, *_ = np.linalg.lstsq(self.B * s[:, None], w * s, rcond=None)
        if len(self._cache) > 20000:
            self._cache.clear()
        self._cache[key] = c
        return c

    def weights(self, alpha, n):
        """weights array of length n: 0 below lag M, the SOE at lags M..n-1."""
        c = self.coeffs(alpha)
        out = np.zeros(n)
        j = np.arange(self.M, n)
        out[self.M:] = (self.r[None, :] ** j[:, None]) @ c
        return out


# -------------------------------------------------------------- simulation
def simulate_window(p, i, v, warm, M, tail=None, pre=None, cw=None, beta=0.0, full_w=False):
    """U_p over a window of length L (local indices 0..L-1).
    p: dict r_i, r_ct, q, alpha, u_oc.  warm: rows 0..warm-1 from data.
    M: memory (taps j < M).  tail: None | 'full' (exact w_j for j >= M inside the window) |
    SOE object (SOE weights for j >= M).  pre: callable(p, beta) -> array (L,) of the
    pre-window tail sum_{j >= lam+1} wt_j U_p(l-j) for each row lam (or None).
    cw: charge still to flow c(l) in the window (for beta)."""
    L = len(i)
    alpha = p['alpha']
    a = p['r_ct'] * p['q']
    w = gl_weights(alpha, L)
    wt = w.copy()
    if tail is None:
        wt[M:] = 0.0
    elif isinstance(tail, SOE):
        wt[M:] = tail.weights(alpha, L)[M:]
    # else 'full': keep w_j
    col = a * wt
    col[0] = 1.0 + a
    # Toeplitz lower-triangular T[l, m] = col[l-m]
    idx = np.arange(L)
    D = idx[:, None] - idx[None, :]
    T = np.where(D >= 0, col[np.clip(D, 0, None)], 0.0)
    ocv = p['u_oc'] - (beta * cw if cw is not None else 0.0)
    d = v - ocv - p['r_i'] * i                     # data-derived U_p
    u = np.empty(L)
    u[:warm] = d[:warm]
    rhs = p['r_ct'] * i[warm:] - T[warm:, :warm] @ u[:warm]
    if pre is not None:
        rhs = rhs - a * pre(p, beta)[warm:]
    u[warm:] = solve_triangular(T[warm:, warm:], rhs, lower=True)
    return u, d


def residuals(p, i, v, warm, M, **kw):
    u, d = simulate_window(p, i, v, warm, M, **kw)
    return (d - u)[warm:]


def charge_to_flow(i):
    c = np.zeros(len(i))
    c[:-1] = np.cumsum(i[::-1])[::-1][1:]
    return c


NAMES = ['r_i', 'r_ct', 'q', 'alpha', 'u_oc', 'beta']


def unpack(x):
    return dict(r_i=np.exp(x[0]), r_ct=np.exp(x[1]), q=np.exp(x[2]), alpha=x[3], u_oc=x[4]), (x[5] if len(x) > 5 else 0.0)


def fit(i, v, warm, M, start=None, slope=True, tail=None, pre=None, xtol=1e-12):
    """Output-error fit of the window (or whole record). Returns (params dict, beta, rmse)."""
    s = start or TRUTH
    x0 = [np.log(s['r_i']), np.log(s['r_ct']), np.log(s['q']), s['alpha'], s['u_oc']]
    lo = [-np.inf, -np.inf, -np.inf, 0.05, -np.inf]
    hi = [np.inf, np.inf, np.inf, 1.0, np.inf]
    cw = charge_to_flow(i) if slope else None
    if slope:
        x0.append(0.0); lo.append(-np.inf); hi.append(np.inf)

    def f(x):
        p, beta = unpack(x)
        return residuals(p, i, v, warm, M, tail=tail, pre=pre, cw=cw, beta=beta)

    r = least_squares(f, x0, bounds=(lo, hi), method='trf', x_scale='jac', xtol=xtol, ftol=1e-14, gtol=1e-14,
                      diff_step=1e-7)
    p, beta = unpack(r.x)
    return p, beta, np.sqrt(np.mean(r.fun ** 2))


def rel(p, ref):
    return dict(r_i=p['r_i'] / ref['r_i'] - 1, r_ct=p['r_ct'] / ref['r_ct'] - 1, q=p['q'] / ref['q'] - 1,
                alpha=p['alpha'] - ref['alpha'])


def fmt(dv):
    return f"R_i {100*dv['r_i']:+6.2f}%  R_ct {100*dv['r_ct']:+6.2f}%  Q {100*dv['q']:+6.2f}%  alpha {dv['alpha']:+.4f}"
