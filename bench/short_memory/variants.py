"""Window-fit variants: the device and the ones that split its bias (used by decompose.py, soe_eval.py)."""
import numpy as np
from core import *

L, M = 256, 64


def pre_data(i, v, s, wfun, slope=True):
    """pre-window tail from data: pre[lam] = sum_{m<s} wt(s+lam-m) d(m), d = v - U_oc + beta c - R_i i,
    wt = wfun(alpha, n) (weights array, index = lag).  c(m) = charge still to flow to the window's end."""
    if s == 0:
        return None
    iw = i[:s + L]
    cpre = (np.cumsum(iw[::-1])[::-1] - iw)[:s]       # sum_{t>m} i(t), t <= s+L-1
    lag = s + np.arange(L)[:, None] - np.arange(s)[None, :]   # L x s
    ip, vp = i[:s], v[:s]

    def pre(p, beta):
        wt = wfun(p['alpha'], s + L)
        W = wt[lag]
        d = vp - p['u_oc'] + (beta * cpre if slope else 0.0) - p['r_i'] * ip
        return W @ d
    return pre


def pre_oracle(i, s):
    """pre-window tail from the full-memory simulation (from rest at sample 0) with the trial parameters
    (not realisable online: shows what a perfect far past would give)."""
    if s == 0:
        return None
    lag = s + np.arange(L)[:, None] - np.arange(s)[None, :]

    def pre(p, beta):
        u, _ = simulate_window(p, i[:s], np.zeros(s), 0, s, tail='full')
        wt = gl_weights(p['alpha'], s + L)
        return wt[lag] @ u
    return pre


def full_w(alpha, n):
    return gl_weights(alpha, n)


def window_fit(kind, i, v, t, slope=True, soe=None, start=None):
    s = t - L + 1
    iw, vw = i[s:t + 1], v[s:t + 1]
    warm = M - 1
    if kind == 'device':            # memory 64, no tail (host-sim)
        return fit(iw, vw, warm, M, slope=slope, start=start)
    if kind == 'memL':              # memory = whole window (taps into the warm part and earlier rows)
        return fit(iw, vw, warm, M, tail='full', slope=slope, start=start)
    if kind == 'rest':              # memory = whole window, from rest (no warm history, no past)
        return fit(iw, vw, 0, M, tail='full', slope=slope, start=start)
    if kind == 'm64+pre':           # memory 64 inside the window + exact GL tail of the data before it
        return fit(iw, vw, warm, M, slope=slope, pre=pre_data(i, v, s, full_w, slope), start=start)
    if kind == 'memL+pre':          # memory = everything: exact GL weights over the window and the data before it
        return fit(iw, vw, warm, M, tail='full', slope=slope, pre=pre_data(i, v, s, full_w, slope), start=start)
    if kind == 'memL+oracle':       # in-window full memory + far past simulated from rest (oracle)
        return fit(iw, vw, warm, M, tail='full', slope=slope, pre=pre_oracle(i, s), start=start)
    if kind == 'soe':               # SOE tail inside the window + SOE modes of the data before it
        return fit(iw, vw, warm, M, tail=soe, slope=slope, pre=pre_data(i, v, s, soe.weights, slope), start=start)
    if kind == 'soe-in':            # SOE tail inside the window only (no past)
        return fit(iw, vw, warm, M, tail=soe, slope=slope, start=start)
    raise ValueError(kind)
