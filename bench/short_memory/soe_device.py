"""The SOE tail correction written as the device would run it (plain loops, O(K) state), checked against the
matrix form used in the fits (core.simulate_window with tail=SOE and the SOE pre-window tail from data).

Persistent state (updated once per sample, when sample s leaves the window; r_k fixed):
  pack:  S1_k  <- r_k S1_k + 1                 (modes of the constant)
         SI_k  <- r_k SI_k + i(s)              (modes of the current)
         P_k   <- r_k P_k + i(s+1) * S1_k(new) ... see below (modes of the charge, only with the OCV slope beta)
  cell:  SV_k  <- r_k SV_k + v(s)              (modes of the cell's voltage)
In a fit (parameters p, beta), the modes of the data-derived history before the window are
  S_k = SV_k - U_oc S1_k - R_i SI_k + beta (P_k + c_w(0) S1_k)
and the per-row tail over everything older than M taps is  sum_k c_k(alpha) r_k^M Z_k(l-M)  with
  Z_k(-1) = S_k,  Z_k(n) = r_k Z_k(n-1) + U_p(n)   (n = local index in the window, warm or simulated)."""
import numpy as np
from core import *
from variants import L, M, pre_data


def modes_before(i, v, s, r):
    """pack/cell states after samples 0..s-1 have left the window (per-sample recursions)."""
    K = len(r)
    S1 = np.zeros(K); SI = np.zeros(K); SV = np.zeros(K); P = np.zeros(K)
    for n in range(s):                      # sample n leaves; i(n+1) is then the window's oldest
        S1 = r * S1 + 1.0
        SI = r * SI + i[n]
        SV = r * SV + v[n]
        P = r * P + i[n + 1] * S1           # P_k(n) = sum_{m<=n} r^(n-m) sum_{t=m+1}^{n+1} i(t)
    return S1, SI, SV, P


def simulate_device(p, beta, iw, vw, state, soe):
    S1, SI, SV, P = state
    r, c = soe.r, soe.coeffs(p['alpha'])
    cr = c * r ** M                          # c_k r_k^M, once per trial alpha
    a = p['r_ct'] * p['q']
    w = gl_weights(p['alpha'], M)
    cw = charge_to_flow(iw)
    d = vw - (p['u_oc'] - beta * cw) - p['r_i'] * iw
    Z = SV - p['u_oc'] * S1 - p['r_i'] * SI + beta * (P + cw[0] * S1)   # Z_k(-1)
    u = np.zeros(L)
    u[:M - 1] = d[:M - 1]
    for l in range(M - 1, L):
        Z = r * Z + u[l - M]  if l - M >= 0 else Z   # Z_k(l-M)
        h = w[1:] @ u[l - 1::-1][:M - 1] if l >= 1 else 0.0
        tail = cr @ Z
        u[l] = (p['r_ct'] * iw[l] - a * (h + tail)) / (1 + a)
    return u


if __name__ == '__main__':
    i, v = load('rec_drive.csv')
    soe = SOE(M, 8)
    for t in [700, 1999]:
        s = t - L + 1
        p = dict(r_i=0.021, r_ct=0.014, q=500.0, alpha=0.7, u_oc=3.69); beta = 1e-6
        st = modes_before(i, v, s, soe.r)
        u1 = simulate_device(p, beta, i[s:t+1], v[s:t+1], st, soe)
        u2, _ = simulate_window(p, i[s:t+1], v[s:t+1], M - 1, M, tail=soe,
                                pre=pre_data(i, v, s, soe.weights, True), cw=charge_to_flow(i[s:t+1]), beta=beta)
        print(f"t={t}: max |U_p(loops) - U_p(matrix)| = {np.abs(u1 - u2)[M-1:].max():.2e} V (U_p up to {np.abs(u2).max():.3f} V)")
