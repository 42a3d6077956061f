#!/usr/bin/env python3
"""The best achievable fit of a record: an independent multi-start reference.

What the estimator's whole-record fit (``host-sim identify battery``) is
judged against. Written apart from the Rust code (numpy + scipy), with the
same conventions:

* SOC after row l: ``soc(l) = soc0 + h * sum_{k<=l} I(k) / (3600 C)``, soc0
  from the mean voltage of the first rested rows (|I| <= C/100, at most 10)
  through the inverse of the piecewise-linear OCV table;
* overpotential ``y(l) = V(l) - OCV(soc(l))``;
* the paper's model from rest with FULL Grunwald-Letnikov memory:
  ``y = dU + R_i I + U_p``, ``(1 + a) U_p(l) = R_ct I(l) - a sum_{j=1..l} w_j
  U_p(l-j)``, ``a = R_ct Q h^-alpha``, ``w_0 = 1``,
  ``w_j = w_{j-1} (1 - (alpha + 1)/j)``;
* integer-order Thevenin models with one and two RC pairs (exact
  zero-order-hold discretisation) for comparison;
* Butler-Volmer variants, nonlinear in the current (``asinh`` is
  ``np.arcsinh``):

  - ``cpe_bv``: ``y = dU + R_i I + a asinh(I/i0) + U_p`` with the CPE branch
    above (a static charge-transfer overpotential on the output);
  - ``cpe_bv_branch``: ``y = dU + R_i I + U_p`` with the branch driven by
    ``R_ct i0 asinh(I(l)/i0)`` in place of ``R_ct I(l)`` (a Hammerstein
    form; the linear branch when ``|I| << i0``);
  - ``cpe_bv_both``: both, ``y = dU + R_i I + a asinh(I/i0) + U_p`` with the
    branch driven by ``R_ct i0b asinh(I/i0b)``;
  - ``rc1_bv``: the one-RC Thevenin model plus ``a asinh(I/i0)``.

The CPE branch of every model (``cpe_branch``) is that recursion
evaluated as the convolution of the drive with the branch's impulse
response, the power series of ``1/(1 + a (1 - z)^alpha)`` (Newton
iteration with FFT products, O(n log n); equal to the recursion,
``cpe_polarization``, to about 1e-13 relative: ``--self-check``). A
constant-phase fit of 8192 samples from its 30 starts takes a few seconds.

Each model is fitted by ``scipy.optimize.least_squares`` (resistances and Q
in logarithms) from a grid of starts (for the constant-phase model: alpha in
{0.3, 0.5, 0.7, 0.9, 1.0} x relaxation time tau^(1/alpha) in {3, 30, 300} s
x R_ct/R_i in {0.5, 2}); the best free-run RMSE is the reference. The
Butler-Volmer variants fit a and i0 in logarithms too (i0 within
[1e-4, 1e4] A; i0 at the top means the term is linear), from their linear
model's best fit (cpe_bv, rc1_bv: i0 in {0.1, 0.3, 1, 3} x the RMS current,
the static term taking half of R_i, a = i0 R_i / 2; cpe_bv_branch: i0 in
{0.3, 1, 3, 10} x the RMS current) and from three starts of the linear
model's grid with i0 the RMS current; cpe_bv_both from the cpe_bv and
cpe_bv_branch fits.

Usage::

    python3 bench/reference_fit.py data/pybamm/chen2020-drive.csv \
        --ocv data/pybamm/chen2020-ocv.csv --capacity-ah 5.1532 [--json out.json]

Without ``--ocv`` the OCV is a constant (fitted as dU). ``--soc0 S`` gives
the SOC before the first row's charge instead of reading it from the
leading rest. ``--models cpe`` fits only the constant-phase model,
``--models linear`` also rc1 and rc2, ``--models all`` (the default) also
the Butler-Volmer variants. ``--self-check`` compares cpe_branch with
cpe_polarization on a random current (largest difference over the largest
|U_p| below 1e-9) and exits. Needs numpy and scipy.

``bench/reference_map.py`` fits the SOC levels of a map with this file's
fits.

``python3 bench/reference_fit.py --all data/pybamm`` fits every record of
that folder (``meta.json`` gives the capacities) with its OCV table and
without it, and writes ``reference.json`` there (minutes: one record with
its table, chen2020-hppc, takes about 55 s, 181 s before fit_cpe used
cpe_branch).
"""

import argparse
import json
import math
import time

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import fftconvolve, lfilter


def read_csv(path, names):
    with open(path) as f:
        header = f.readline().strip().split(",")
    idx = [header.index(n) for n in names]
    data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=idx, ndmin=2)
    return [data[:, k] for k in range(len(names))]


def gl_weights(alpha, n):
    """w_0 = 1, w_j = w_{j-1} (1 - (alpha + 1)/j): np.cumprod multiplies in
    sequence, so these are bit for bit the values of the plain loop."""
    f = np.empty(n)
    f[:1] = 1.0
    f[1:] = 1.0 - (alpha + 1.0) / np.arange(1, n)
    return np.cumprod(f)


def cpe_polarization(i, h, r_ct, q, alpha):
    """U_p of R_ct || CPE(Q, alpha) from rest, full memory."""
    n = len(i)
    w = gl_weights(alpha, n)
    a = r_ct * q * h ** (-alpha)
    up = np.zeros(n)
    wr = w[1:][::-1]  # wr[-j] = w_j
    for l in range(n):
        hist = np.dot(wr[n - 1 - l:], up[:l]) if l > 0 else 0.0
        up[l] = (r_ct * i[l] - a * hist) / (1.0 + a)
    return up


def short_memory_filter(h, r_ct, q, alpha, memory):
    """The core's short-memory recursion as a filter (b, a) for
    scipy.signal.lfilter: (1 + c) U_p(l) + c sum_{j=1}^{memory-1} w_j
    U_p(l - j) = R_ct I(l), c = R_ct Q h^-alpha (the online window's
    model; cpe_polarization is the full memory)."""
    c = r_ct * q * h ** (-alpha)
    return np.array([r_ct]), np.concatenate([[1.0 + c], c * gl_weights(alpha, memory)[1:]])


def rc_polarization(i, h, r, tau):
    """One RC pair, exact for a current held over each sample period."""
    e = math.exp(-h / tau)
    up = np.zeros(len(i))
    x = 0.0
    for l, il in enumerate(i):
        x = e * x + r * (1.0 - e) * il
        up[l] = x
    return up


def fit_cpe(i, y, h, keep=None, memory=None):
    """The constant-phase model y = dU + R_i I + U_p; p = ln R_i, ln R_ct,
    ln Q, alpha, dU. U_p is cpe_branch (cpe_polarization as a convolution,
    O(n log n)); the finite-difference Jacobian moves one coordinate at a
    time, so the branches of the last few (R_ct, Q, alpha) are kept: moving
    R_i or dU costs no branch. ``keep`` (a boolean mask, default every row):
    the rows the residuals are taken over; the model runs on every row's
    current. ``memory``: the branch with that short memory from rest
    (``short_memory_filter``, the online window's model) instead of the
    full memory."""
    keep = np.ones(len(y), bool) if keep is None else np.asarray(keep, bool)
    branches = {}

    def model(p):
        r_i, r_ct, q, alpha, du = math.exp(p[0]), math.exp(p[1]), math.exp(p[2]), p[3], p[4]
        key = (r_ct, q, alpha)
        up = branches.get(key)
        if up is None:
            if len(branches) >= 8:
                branches.clear()
            up = branches[key] = (
                cpe_branch(i, h, r_ct, q, alpha) if memory is None
                else lfilter(*short_memory_filter(h, r_ct, q, alpha, memory), i))
        return du + r_i * i + up

    # A rough total resistance from the data: y ~ dU + R I.
    r_tot = max(abs(np.polyfit(i[keep], y[keep], 1)[0]), 1e-4)
    best = None
    minima = []
    for alpha in [0.3, 0.5, 0.7, 0.9, 1.0]:
        for relax in [3.0, 30.0, 300.0]:
            for ratio in [0.5, 2.0]:
                r_i = r_tot / (1.0 + ratio)
                r_ct = r_tot - r_i
                q = relax**alpha / r_ct
                x0 = [math.log(r_i), math.log(r_ct), math.log(q), min(alpha, 0.999),
                      float(np.mean((y - r_tot * i)[keep]))]
                try:
                    res = least_squares(
                        lambda p: (model(p) - y)[keep],
                        x0,
                        bounds=([-20, -20, -20, 0.05, -np.inf], [5, 5, 30, 1.0, np.inf]),
                        x_scale=[1, 1, 1, 0.1, 0.01],
                        max_nfev=200,
                    )
                except (ValueError, FloatingPointError):
                    continue
                rmse = math.sqrt(np.mean(res.fun**2))
                minima.append(rmse)
                if best is None or rmse < best[0]:
                    best = (rmse, res.x, (alpha, relax, ratio))
    rmse, p, start = best
    return {
        "rmse_v": rmse,
        "r_i": math.exp(p[0]),
        "r_ct": math.exp(p[1]),
        "q": math.exp(p[2]),
        "alpha": p[3],
        "ocv_offset_v": p[4],
        "winning_start": {"alpha": start[0], "relaxation_s": start[1], "r_ct_over_r_i": start[2]},
        "local_minima_rmse_v": sorted(set(round(m, 7) for m in minima)),
    }


def fit_rc(i, y, h, pairs):
    def model(p):
        out = p[0] + math.exp(p[1]) * i
        for k in range(pairs):
            out = out + rc_polarization(i, h, math.exp(p[2 + 2 * k]), math.exp(p[3 + 2 * k]))
        return out

    r_tot = max(abs(np.polyfit(i, y, 1)[0]), 1e-4)
    best = None
    taus = [[3.0], [30.0], [300.0]] if pairs == 1 else [[3.0, 60.0], [10.0, 300.0], [1.0, 30.0]]
    for tau in taus:
        x0 = [float(np.mean(y - r_tot * i)), math.log(r_tot / 2)]
        for t in tau:
            x0 += [math.log(r_tot / (2 * pairs)), math.log(t)]
        res = least_squares(lambda p: model(p) - y, x0, max_nfev=300)
        rmse = math.sqrt(np.mean(res.fun**2))
        if best is None or rmse < best[0]:
            best = (rmse, res.x)
    rmse, p = best
    out = {"rmse_v": rmse, "ocv_offset_v": p[0], "r_i": math.exp(p[1])}
    for k in range(pairs):
        out[f"r_{k + 1}"] = math.exp(p[2 + 2 * k])
        out[f"tau_{k + 1}_s"] = math.exp(p[3 + 2 * k])
    return out


def cpe_impulse(h, r_ct, q, alpha, n):
    """The first n samples of U_p for a unit drive at l = 0 (R_ct I(0) = 1):
    the power series of 1/(1 + a (1 - z)^alpha), a = R_ct Q h^-alpha, by
    Newton's iteration g <- g (2 - d g) with FFT products."""
    d = r_ct * q * h ** (-alpha) * gl_weights(alpha, n)
    d[0] += 1.0
    g = np.array([1.0 / d[0]])
    m = 1
    while m < n:
        m = min(2 * m, n)
        e = -fftconvolve(d[:m], g)[:m]
        e[0] += 2.0
        g = fftconvolve(g, e)[:m]
    return g


def cpe_branch(drive, h, r_ct, q, alpha):
    """U_p of R_ct || CPE(Q, alpha) from rest, full memory, driven by
    R_ct * drive(l) (drive = I: cpe_polarization, as a convolution)."""
    n = len(drive)
    return r_ct * fftconvolve(cpe_impulse(h, r_ct, q, alpha, n), drive)[:n]


def bv(i, a, i0):
    """The Butler-Volmer overpotential a asinh(I / i0) (symmetric, alpha_a =
    alpha_c = 1/2); a I / i0 when |I| << i0."""
    return a * np.arcsinh(i / i0)


# Bounds of ln i0 (A): i0 in [1e-4, 1e4].
LN_I0 = (math.log(1e-4), math.log(1e4))


def multistart(resid, starts, lo, hi, x_scale, max_nfev=200):
    """least_squares from each (label, x0) of starts, x0 moved 1e-3 inside
    finite bounds; the best (rmse, p, label) and all the minima's RMSEs."""
    lo, hi = np.array(lo, float), np.array(hi, float)
    best = None
    minima = []
    for label, x0 in starts:
        x0 = np.clip(np.array(x0, float), lo + 1e-3, hi - 1e-3)
        try:
            res = least_squares(resid, x0, bounds=(lo, hi), x_scale=x_scale, max_nfev=max_nfev)
        except (ValueError, FloatingPointError):
            continue
        rmse = math.sqrt(np.mean(res.fun**2))
        minima.append(rmse)
        if best is None or rmse < best[0]:
            best = (rmse, res.x, label)
    return best, sorted(set(round(m, 7) for m in minima))


def grid_starts(i, y, picks):
    """A few (alpha, relaxation s, R_ct/R_i) starts of fit_cpe's grid as
    (label, R_i, R_ct, Q, alpha, dU)."""
    r_tot = max(abs(np.polyfit(i, y, 1)[0]), 1e-4)
    out = []
    for alpha, relax, ratio in picks:
        r_i = r_tot / (1.0 + ratio)
        r_ct = r_tot - r_i
        label = {"alpha": alpha, "relaxation_s": relax, "r_ct_over_r_i": ratio}
        out.append((label, r_i, r_ct, relax**alpha / r_ct, alpha, float(np.mean(y - r_tot * i))))
    return out


CPE_PICKS = [(1.0, 300.0, 0.5), (0.7, 3.0, 0.5), (0.5, 30.0, 2.0)]
CPE_LO = [-20, -20, -20, 0.05, -np.inf]  # ln R_i, ln R_ct, ln Q, alpha, dU
CPE_HI = [5, 5, 30, 1.0, np.inf]


def fit_with_r_ct_fixed(resid, r_ct, ln_r_i, ln_q, alpha, du):
    """A profile point: ``resid(q)`` with q = ln R_i, ln Q, alpha, dU (R_ct
    held at ``r_ct`` by the caller's residuals), from (ln_r_i, ln_q, alpha,
    dU) and 12 grid starts of alpha and relaxation time; the best (rmse, q)."""
    starts = [("given", [ln_r_i, ln_q, min(alpha, 0.999), du])]
    starts += [((al, relax), [ln_r_i, math.log(relax**al / r_ct), min(al, 0.999), du])
               for al in (0.5, 0.7, 0.9, 1.0) for relax in (3.0, 30.0, 300.0)]
    (rmse, q, _), _ = multistart(resid, starts, [CPE_LO[0], *CPE_LO[2:]], [CPE_HI[0], *CPE_HI[2:]],
                                 [1, 1, 0.1, 0.01])
    return rmse, q


def widened_ratio(res, rmse):
    """The likelihood ratio of a fit of RMSE ``rmse`` against the optimum
    whose residuals are ``res``, with the core's widening for correlated
    residuals (``FitInformation::correlated_standard_errors``):
    ``n ln(rmse^2 / rmse0^2) (1 - rho) / (1 + rho)``, rho the lag-1
    autocorrelation of ``res``; and rho. Over 3.84, excluded at 95 %."""
    res = np.asarray(res)
    rho = float(np.dot(res[1:], res[:-1]) / np.dot(res, res))
    rmse0 = math.sqrt(float(np.mean(res**2)))
    return len(res) * 2.0 * math.log(rmse / rmse0) * (1.0 - rho) / (1.0 + rho), rho


def fit_cpe_bv(i, y, h, cpe):
    """cpe_bv: y = dU + R_i I + a asinh(I/i0) + U_p; p = ln R_i, ln a, ln i0,
    ln R_ct, ln Q, alpha, dU; starts from the linear fit cpe."""
    def model(p):
        r_i, a, i0, r_ct, q = (math.exp(x) for x in p[:5])
        return p[6] + r_i * i + bv(i, a, i0) + cpe_branch(i, h, r_ct, q, p[5])

    i_rms = float(np.sqrt(np.mean(i**2)))
    ln = math.log
    starts = []
    for k in [0.1, 0.3, 1.0, 3.0]:
        i0 = k * i_rms
        r_i = cpe["r_i"] / 2.0
        starts.append(({"from": "cpe", "i0_over_i_rms": k},
                       [ln(r_i), ln(i0 * r_i), ln(i0), ln(cpe["r_ct"]), ln(cpe["q"]), cpe["alpha"], cpe["ocv_offset_v"]]))
    for label, r_i, r_ct, q, alpha, du in grid_starts(i, y, CPE_PICKS):
        starts.append((dict(label, i0_over_i_rms=1.0),
                       [ln(r_i / 2.0), ln(i_rms * r_i / 2.0), ln(i_rms), ln(r_ct), ln(q), alpha, du]))
    lo = CPE_LO[:1] + [-20, LN_I0[0]] + CPE_LO[1:]
    hi = CPE_HI[:1] + [5, LN_I0[1]] + CPE_HI[1:]
    best, minima = multistart(lambda p: model(p) - y, starts, lo, hi, [1, 1, 1, 1, 1, 0.1, 0.01])
    rmse, p, start = best
    return {
        "rmse_v": rmse,
        "r_i": math.exp(p[0]),
        "r_ct": math.exp(p[3]),
        "q": math.exp(p[4]),
        "alpha": p[5],
        "ocv_offset_v": p[6],
        "bv_a_v": math.exp(p[1]),
        "bv_i0_a": math.exp(p[2]),
        "winning_start": start,
        "local_minima_rmse_v": minima,
    }


def fit_cpe_bv_branch(i, y, h, cpe):
    """cpe_bv_branch: y = dU + R_i I + U_p, the branch driven by
    R_ct i0 asinh(I/i0); p = ln R_i, ln i0, ln R_ct, ln Q, alpha, dU; starts
    from the linear fit cpe."""
    def model(p):
        r_i, i0, r_ct, q = (math.exp(x) for x in p[:4])
        return p[5] + r_i * i + cpe_branch(bv(i, i0, i0), h, r_ct, q, p[4])

    i_rms = float(np.sqrt(np.mean(i**2)))
    ln = math.log
    starts = []
    for k in [0.3, 1.0, 3.0, 10.0]:
        starts.append(({"from": "cpe", "i0_over_i_rms": k},
                       [ln(cpe["r_i"]), ln(k * i_rms), ln(cpe["r_ct"]), ln(cpe["q"]), cpe["alpha"], cpe["ocv_offset_v"]]))
    for label, r_i, r_ct, q, alpha, du in grid_starts(i, y, CPE_PICKS):
        starts.append((dict(label, i0_over_i_rms=1.0), [ln(r_i), ln(i_rms), ln(r_ct), ln(q), alpha, du]))
    lo = CPE_LO[:1] + [LN_I0[0]] + CPE_LO[1:]
    hi = CPE_HI[:1] + [LN_I0[1]] + CPE_HI[1:]
    best, minima = multistart(lambda p: model(p) - y, starts, lo, hi, [1, 1, 1, 1, 0.1, 0.01])
    rmse, p, start = best
    return {
        "rmse_v": rmse,
        "r_i": math.exp(p[0]),
        "r_ct": math.exp(p[2]),
        "q": math.exp(p[3]),
        "alpha": p[4],
        "ocv_offset_v": p[5],
        "bv_i0_a": math.exp(p[1]),
        "winning_start": start,
        "local_minima_rmse_v": minima,
    }


def fit_cpe_bv_both(i, y, h, cpe_bv, branch):
    """cpe_bv_both: y = dU + R_i I + a asinh(I/i0) + U_p, the branch driven by
    R_ct i0b asinh(I/i0b); p = ln R_i, ln a, ln i0, ln R_ct, ln Q, alpha, dU,
    ln i0b; starts from the fits cpe_bv and cpe_bv_branch."""
    def model(p):
        r_i, a, i0, r_ct, q = (math.exp(x) for x in p[:5])
        i0b = math.exp(p[7])
        return p[6] + r_i * i + bv(i, a, i0) + cpe_branch(bv(i, i0b, i0b), h, r_ct, q, p[5])

    i_rms = float(np.sqrt(np.mean(i**2)))
    ln = math.log
    starts = []
    m = cpe_bv
    for k in [1.0, 10.0]:
        starts.append(({"from": "cpe_bv", "i0b_over_i_rms": k},
                       [ln(m["r_i"]), ln(m["bv_a_v"]), ln(m["bv_i0_a"]), ln(m["r_ct"]), ln(m["q"]), m["alpha"],
                        m["ocv_offset_v"], ln(k * i_rms)]))
    m = branch
    for k in [0.3, 1.0]:
        i0, r_i = k * i_rms, m["r_i"] / 2.0
        starts.append(({"from": "cpe_bv_branch", "i0_over_i_rms": k},
                       [ln(r_i), ln(i0 * r_i), ln(i0), ln(m["r_ct"]), ln(m["q"]), m["alpha"], m["ocv_offset_v"],
                        ln(m["bv_i0_a"])]))
    lo = CPE_LO[:1] + [-20, LN_I0[0]] + CPE_LO[1:] + [LN_I0[0]]
    hi = CPE_HI[:1] + [5, LN_I0[1]] + CPE_HI[1:] + [LN_I0[1]]
    best, minima = multistart(lambda p: model(p) - y, starts, lo, hi, [1, 1, 1, 1, 1, 0.1, 0.01, 1])
    rmse, p, start = best
    return {
        "rmse_v": rmse,
        "r_i": math.exp(p[0]),
        "r_ct": math.exp(p[3]),
        "q": math.exp(p[4]),
        "alpha": p[5],
        "ocv_offset_v": p[6],
        "bv_a_v": math.exp(p[1]),
        "bv_i0_a": math.exp(p[2]),
        "bv_branch_i0_a": math.exp(p[7]),
        "winning_start": start,
        "local_minima_rmse_v": minima,
    }


def fit_rc1_bv(i, y, h, rc1):
    """rc1_bv: the one-RC model plus a asinh(I/i0); p = dU, ln R_i, ln R_1,
    ln tau_1, ln a, ln i0; starts from the linear fit rc1 and fit_rc's taus."""
    def model(p):
        r_i, r_1, tau, a, i0 = (math.exp(x) for x in p[1:])
        return p[0] + r_i * i + rc_polarization(i, h, r_1, tau) + bv(i, a, i0)

    i_rms = float(np.sqrt(np.mean(i**2)))
    ln = math.log
    starts = []
    for k in [0.1, 0.3, 1.0, 3.0]:
        i0, r_i = k * i_rms, rc1["r_i"] / 2.0
        starts.append(({"from": "rc1", "i0_over_i_rms": k},
                       [rc1["ocv_offset_v"], ln(r_i), ln(rc1["r_1"]), ln(rc1["tau_1_s"]), ln(i0 * r_i), ln(i0)]))
    r_tot = max(abs(np.polyfit(i, y, 1)[0]), 1e-4)
    for tau in [3.0, 30.0, 300.0]:
        starts.append(({"tau_1_s": tau, "i0_over_i_rms": 1.0},
                       [float(np.mean(y - r_tot * i)), ln(r_tot / 4), ln(r_tot / 2), ln(tau), ln(i_rms * r_tot / 4),
                        ln(i_rms)]))
    lo = [-np.inf] * 4 + [-20, LN_I0[0]]
    hi = [np.inf] * 4 + [5, LN_I0[1]]
    best, minima = multistart(lambda p: model(p) - y, starts, lo, hi, 1.0, max_nfev=300)
    rmse, p, start = best
    return {
        "rmse_v": rmse,
        "ocv_offset_v": p[0],
        "r_i": math.exp(p[1]),
        "r_1": math.exp(p[2]),
        "tau_1_s": math.exp(p[3]),
        "bv_a_v": math.exp(p[4]),
        "bv_i0_a": math.exp(p[5]),
        "winning_start": start,
        "local_minima_rmse_v": minima,
    }


def fit_all(folder):
    """Every record of a folder made by bench/pybamm_data.py, with and
    without its OCV table, into ``reference.json``."""
    from pathlib import Path

    folder = Path(folder)
    meta = json.load(open(folder / "meta.json"))
    out = {}
    for name in sorted(meta["records"]):
        cell = name.split("-")[0]
        cap = meta["ocv"][cell]["capacity_ah"]
        rec = str(folder / f"{name}.csv")
        print(f"== {name} (OCV table, C = {cap:.4f} A h)")
        out[name] = fit_record(rec, str(folder / f"{cell}-ocv.csv"), cap)
        print(f"== {name} (no table)")
        out[f"{name}-no-table"] = fit_record(rec, None, None)
    with open(folder / "reference.json", "w") as f:
        json.dump(out, f, indent=2)
        f.write("\n")


def self_check(seed=1, tol=1e-9):
    """cpe_branch (the fast branch fit_cpe uses) against the plain recursion
    cpe_polarization on a random 500-sample current at a few (R_ct, Q,
    alpha, h): the largest |difference| over the largest |U_p| must stay
    below tol. Returns the differences."""
    rng = np.random.default_rng(seed)
    i = rng.normal(0.0, 3.0, 500)
    i[rng.random(500) < 0.3] = 0.0  # rests, as in a pulse record
    cases = [  # (R_ct ohm, Q F s^(alpha-1), alpha, h s)
        (0.02, 700.0, 0.73, 1.0),
        (0.01, 5.0, 0.3, 0.1),
        (0.05, 2000.0, 1.0, 10.0),
        (0.03, 1e4, 0.5, 0.5),
        (1e-3, 1e6, 0.9, 2.0),
        (0.1, 1e-3, 0.05, 1.0),
    ]
    out = []
    for r_ct, q, alpha, h in cases:
        slow = cpe_polarization(i, h, r_ct, q, alpha)
        fast = cpe_branch(i, h, r_ct, q, alpha)
        rel = float(np.max(np.abs(fast - slow)) / np.max(np.abs(slow)))
        print(f"R_ct {r_ct:g}, Q {q:g}, alpha {alpha:g}, h {h:g}: max |fast - slow| / max |slow| = {rel:.2e}")
        if not rel < tol:
            raise AssertionError(f"cpe_branch differs from cpe_polarization by {rel:.2e} relative")
        out.append(rel)
    print(f"self-check passed: every difference below {tol:g}")
    return out


MODELS = {
    "cpe": ["cpe"],
    "linear": ["cpe", "rc1", "rc2"],
    "all": ["cpe", "rc1", "rc2", "cpe_bv", "cpe_bv_branch", "cpe_bv_both", "rc1_bv"],
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("record", nargs="?")
    ap.add_argument("--ocv")
    ap.add_argument("--capacity-ah", type=float)
    ap.add_argument("--soc0", type=float,
                    help="SOC before the first row's charge (default: read from the leading rest)")
    ap.add_argument("--models", choices=sorted(MODELS), default="all",
                    help="cpe: the constant-phase model only; linear: cpe, rc1, rc2; all (default): "
                         "also the Butler-Volmer variants")
    ap.add_argument("--json")
    ap.add_argument("--all", help="fit every record of this folder into its reference.json")
    ap.add_argument("--self-check", action="store_true",
                    help="check cpe_branch against cpe_polarization and exit")
    a = ap.parse_args()
    if a.self_check:
        self_check()
        return
    if a.all:
        fit_all(a.all)
        return
    if not a.record:
        ap.error("a record, or --all FOLDER")
    if a.ocv and a.capacity_ah is None:
        ap.error("--ocv needs --capacity-ah")
    if a.soc0 is not None and not a.ocv:
        ap.error("--soc0 needs --ocv")
    out = fit_record(a.record, a.ocv, a.capacity_ah, soc0=a.soc0, models=a.models)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=2)
            f.write("\n")


def overpotential(i, v, h, soc_pts, ocv_pts, capacity_ah, soc0):
    """SOC after each row, soc0 + h cumsum(I) / (3600 C), and the
    overpotential y = V - OCV(SOC) (the table interpolated linearly, held
    flat beyond its ends)."""
    soc = soc0 + h * np.cumsum(i) / (3600.0 * capacity_ah)
    return soc, v - np.interp(soc, soc_pts, ocv_pts)


def fit_record(record, ocv_path, capacity_ah, soc0=None, models="all"):
    """Fits one record (MODELS[models]); soc0 (with an OCV table) is the SOC
    before the first row's charge, else read from the leading rest."""
    t, i, v = read_csv(record, ["time_s", "current_a", "voltage_v"])
    h = float(t[1] - t[0])
    out = {"record": record, "rows": len(t)}
    if ocv_path:
        soc_pts, ocv_pts = read_csv(ocv_path, ["soc", "ocv_v"])
        c = capacity_ah
        if soc0 is None:
            rest = np.abs(i[:10]) <= c / 100.0
            n_rest = int(np.argmin(rest)) if not rest.all() else 10
            if n_rest == 0:
                raise SystemExit("the record does not start at rest")
            soc0 = float(np.interp(np.mean(v[:n_rest]), ocv_pts, soc_pts))
        soc, y = overpotential(i, v, h, soc_pts, ocv_pts, c, soc0)
        out.update({"soc0": soc0, "soc_end": float(soc[-1])})
    else:
        y = v.copy()
    names = MODELS[models]
    t0 = time.time()
    out["cpe"] = fit_cpe(i, y, h)
    if "rc1" in names:
        out["rc1"] = fit_rc(i, y, h, 1)
        out["rc2"] = fit_rc(i, y, h, 2)
    took = {"linear": time.time() - t0}
    t1 = time.time()
    if "cpe_bv" in names:
        out["cpe_bv"] = fit_cpe_bv(i, y, h, out["cpe"])
        out["cpe_bv_branch"] = fit_cpe_bv_branch(i, y, h, out["cpe"])
        out["cpe_bv_both"] = fit_cpe_bv_both(i, y, h, out["cpe_bv"], out["cpe_bv_branch"])
        out["rc1_bv"] = fit_rc1_bv(i, y, h, out["rc1"])
    took["bv"] = time.time() - t1
    out["seconds"] = round(time.time() - t0, 1)
    for k in names:
        m = out[k]
        extra = ", ".join(f"{n} {x:.6g}" for n, x in m.items() if n not in ("rmse_v", "local_minima_rmse_v", "winning_start"))
        print(f"{k:13s} RMSE {1e3 * m['rmse_v']:.3f} mV  {extra}")
    for k in [k for k in names if "winning_start" in out[k]]:
        minima = out[k].get("local_minima_rmse_v", [])
        print(f"{k} starts: best from {out[k]['winning_start']}; local minima (mV): "
              f"{[round(1e3 * x, 3) for x in minima][:8]}")
    if "cpe_bv" in names:
        print(f"seconds: linear models {took['linear']:.1f}, Butler-Volmer variants {took['bv']:.1f}")
    else:
        print(f"seconds: {took['linear']:.1f}")
    return out


if __name__ == "__main__":
    main()
