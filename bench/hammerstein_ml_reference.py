#!/usr/bin/env python3
"""Independent maximum-likelihood (prediction-error) reference fit of the
fractional-order Hammerstein model (eq. 4/5 of the paper).

Written from the model formulas only (numpy + scipy, nothing else), as a
yardstick for the Rust estimator.

Model (unit sample period, from rest: samples before t = 0 are zero)
--------------------------------------------------------------------
* Grunwald-Letnikov difference of order alpha with memory M:
  ``D x(t) = sum_{j=0}^{min(t, M-1)} w_j x(t-j)``, ``w_0 = 1``,
  ``w_j = w_{j-1} (1 - (alpha+1)/j)``.  Evaluated as an FFT convolution
  truncated to the record (M = L is the full convolution).
* Basis ``f_j(u) = u^j``, j = 1..m ("poly:m").
* System part ``S(l) = -sum_{i=1}^{na} a_i Dy(l-i)
  + sum_{i=1}^{nb} sum_{j=1}^{m} p_ij Df_j(u)(l-i)`` with ``p_ij = b_i gamma_j``
  (stored i-major, index i*m + j); ``Dx(l-i)`` is zero for ``l-i < 0``.
* Equation error ``e(l) = y(l) - S(l)``; whitened one-step prediction error
  ``eps(l) = e(l) + sum_{k=1}^{nc} c_k De(l-k)``.
* Cost ``V = 1/2 sum_{l=0}^{L-1} eps(l)^2`` over all rows.  If the data were
  generated with ``e(l) = v(l) - sum_k c_k De(l-k)``, v white Gaussian, then
  at the true parameters eps = v and minimizing V is exact Gaussian ML.
* Parameter vector ``p = [a_1..a_na, c_1..c_nc, p_11..p_{nb m}, alpha]``;
  ``delta = |p_hat - p_true| / |p_true|``.

Because D and the delays are linear and commute, with ``Z = [y, Phi]``
(``Phi`` the regressors of a and p, ``theta = (a, p)``):
``eps = H_c (y - Phi theta)``, ``H_c x = x + sum_k c_k S_k D x``
(``S_k`` = delay by k).  So for fixed (alpha, c) eps is linear in theta, for
fixed (alpha, theta) it is linear in c.

Method
------
1. alpha grid over [--alpha-min, --alpha-max] (default 0.02..1.5, step 0.01).
   At each alpha, the profiled cost ``V*(alpha) = min_{a,c,p} V`` is found by
   variable projection over c (theta eliminated by linear least squares):
   a) the projected cost J(c) is evaluated on a dense c grid (default
      [-3, 3]^nc, step 0.05 for nc <= 2; coarser for larger nc) through the
      exact quadratic dependence of the Gram matrix of [H_c y, H_c Phi] on c
      (column-scaled normal equations; the grid is widened automatically
      while the best point lies on its edge);
   b) the best few grid local minima, plus c = 0 (the plain equation-error
      least-squares fit) are polished with scipy.optimize.least_squares on
      the VP residual (QR-based lstsq, no normal equations); the lowest wins.
2. alpha is refined by bounded scalar minimization of V*(alpha) within one
   grid step of the best grid point.
3. A joint scipy.optimize.least_squares over all parameters (a, c, p, alpha)
   finishes from there (analytic Jacobian in a, c, p; central difference in
   alpha).  The result is kept only if it does not raise the cost.

Output (JSON): "p", "alpha", "cost" (V at the estimate), "cost_truth" (V at
the preset's true parameters on the same data; null without --preset),
"delta" (null without --preset), "profile" ([[alpha, V*(alpha)], ...] on
the grid), "profile_local_minima" (grid local minima of the profile,
[[alpha, V*], ...]), "profile_c" ([[alpha, c_1..c_nc], ...], the minimizing
c on the grid; a jump marks a switch between branches of local minima in
c), "seconds", and a few more diagnostic fields.

Note: the profiled cost can have a second branch in which the AR part
(a) and the noise part (c) roughly trade places (exact when the input
term vanishes, since eps = (1 + C D)(1 + A D) y - ...); this is why c is
searched globally on a grid at every alpha rather than continued from
the neighbouring alpha alone.

Run time: about 6-9 s for L = 1000 and 11-14 s for L = 4000 on one core
(set OMP_NUM_THREADS=1 / OPENBLAS_NUM_THREADS=1 to keep BLAS on one core).

Usage
-----
    python3 bench/hammerstein_ml_reference.py --input F.csv \
        --preset paper-kt-stable [--memory M] [--na 2 --nb 3 --nc 2 --m 2] \
        --json out.json

F.csv has the header ``u,y`` (as written by
``host-sim simulate hammerstein ... --out F.csv``).  ``--memory`` defaults to
the number of rows (note: the simulator's own default is min(L, 4096)).
``--from-truth`` additionally runs the joint fit started at the true
parameters and reports its cost ("cost_from_truth") as a check that the
global search did not miss a lower minimum (diagnostic only; never used for
the estimate).
"""

import argparse
import json
import sys
import time

import numpy as np
from scipy import fft as sfft
from scipy.optimize import least_squares, minimize_scalar

PRESETS = {
    "paper-op": dict(a=[-0.038, -0.014], b=[0.18, -0.175, -0.39],
                     c=[-0.008, 0.02], gamma=[0.0165, 0.024], alpha=0.5),
    "paper-kt-stable": dict(a=[-0.021, -0.007], b=[1.0, -0.008, 0.023],
                            c=[-0.35, 0.61], gamma=[-1.7, -0.04], alpha=0.3),
}


# ---------------------------------------------------------------- basics
def gl_weights(alpha, n):
    """w_0..w_{n-1} of the Grunwald-Letnikov difference of order alpha."""
    j = np.arange(1, n, dtype=float)
    return np.concatenate(([1.0], np.cumprod(1.0 - (alpha + 1.0) / j)))


class Differ:
    """D x for the columns of x (length L along axis 0), memory M."""

    def __init__(self, L, M):
        self.L, self.M = L, min(M, L)
        self.n = sfft.next_fast_len(L + self.M - 1, real=True)
        self._alpha, self._W = None, None

    def __call__(self, x, alpha):
        if alpha != self._alpha:
            self._W = sfft.rfft(gl_weights(alpha, self.M), self.n)
            self._alpha = alpha
        X = sfft.rfft(x, self.n, axis=0)
        W = self._W if x.ndim == 1 else self._W[:, None]
        return sfft.irfft(X * W, self.n, axis=0)[: self.L]


def delay(x, k):
    """S_k x: x(t-k), zero for t < k (axis 0)."""
    if k == 0:
        return x.copy()
    out = np.zeros_like(x)
    out[k:] = x[:-k]
    return out


class Model:
    def __init__(self, u, y, na, nb, nc, m, M):
        self.u, self.y = u, y
        self.L = len(y)
        self.na, self.nb, self.nc, self.m = na, nb, nc, m
        self.D = Differ(self.L, M)
        self.F = np.stack([u ** (j + 1) for j in range(m)], axis=1)  # L x m
        self.ntheta = na + nb * m
        self.npar = na + nc + nb * m + 1

    # split / join  p = [a, c, pij, alpha];  theta = [a, pij]
    def split(self, p):
        na, nc = self.na, self.nc
        a = p[:na]
        c = p[na:na + nc]
        pij = p[na + nc:na + nc + self.nb * self.m]
        return a, c, pij, p[-1]

    def join(self, theta, c, alpha):
        return np.concatenate((theta[:self.na], c, theta[self.na:], [alpha]))

    def Z(self, alpha):
        """Z = [y, +Dy(l-i) (i=1..na), -Df_j(u)(l-i) (i=1..nb, j=1..m)], so
        that e = y - S = Z @ [1, a, pij] (S has -a_i Dy and +p_ij Df_j)."""
        Dy = self.D(self.y, alpha)
        DF = self.D(self.F, alpha)
        cols = [self.y]
        for i in range(1, self.na + 1):
            cols.append(delay(Dy, i))
        for i in range(1, self.nb + 1):
            Di = delay(DF, i)
            for j in range(self.m):
                cols.append(-Di[:, j])
        return np.stack(cols, axis=1)

    def stacks(self, alpha):
        """Z and the delayed differences S_k D Z, k = 1..nc."""
        Zm = self.Z(alpha)
        DZ = self.D(Zm, alpha)
        return Zm, [delay(DZ, k) for k in range(1, self.nc + 1)]

    def residual(self, p):
        a, c, pij, alpha = self.split(p)
        Zm = self.Z(alpha)
        e = Zm @ np.concatenate(([1.0], a, pij))
        De = self.D(e, alpha)
        eps = e.copy()
        for k in range(1, self.nc + 1):
            eps += c[k - 1] * delay(De, k)
        return eps

    def cost(self, p):
        r = self.residual(p)
        return 0.5 * float(r @ r)


# ------------------------------------------------ profile at fixed alpha
class Profile:
    """min over (c, theta) at a fixed alpha by variable projection in c."""

    def __init__(self, model, alpha):
        self.mod, self.alpha = model, alpha
        self.Zm, self.SDZ = model.stacks(alpha)
        blocks = [self.Zm] + self.SDZ              # nc+1 blocks of L x (1+nt)
        big = np.concatenate(blocks, axis=1)
        self.scale = np.sqrt((self.Zm ** 2).sum(0)) + 1e-300
        nb_ = len(blocks)
        q = self.Zm.shape[1]
        bigs = big / np.tile(self.scale, nb_)
        G = bigs.T @ bigs
        self.Gb = G.reshape(nb_, q, nb_, q).transpose(0, 2, 1, 3)  # [k,l,:,:]

    def A_b(self, c):
        """H_c applied to Z: columns [H_c y, -H_c Phi]."""
        H = self.Zm.copy()
        for k, Sk in enumerate(self.SDZ):
            H += c[k] * Sk
        return H

    def theta_eps(self, c):
        H = self.A_b(c)
        b, A = H[:, 0], -H[:, 1:]                 # eps = b - A theta
        theta, *_ = np.linalg.lstsq(A, b, rcond=None)
        return theta, b - A @ theta

    def J_grid(self, C):
        """Projected cost (unscaled, 1/2 sum eps^2) for rows of C (N x nc),
        through the Gram matrix (fast, for the search only)."""
        N = C.shape[0]
        Ct = np.concatenate((np.ones((N, 1)), C), axis=1)     # N x (nc+1)
        G = np.einsum("nk,nl,klij->nij", Ct, Ct, self.Gb, optimize=True)
        g00 = G[:, 0, 0]
        g0 = G[:, 1:, 0]
        Gaa = G[:, 1:, 1:]
        try:
            sol = np.linalg.solve(Gaa, g0[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:
            sol = np.stack([np.linalg.lstsq(Gi, gi, rcond=None)[0]
                            for Gi, gi in zip(Gaa, g0)])
        J = g00 - np.einsum("ni,ni->n", g0, sol)
        return 0.5 * np.maximum(J, 0.0) * self.scale[0] ** 2

    def polish(self, c0):
        nc = self.mod.nc
        if nc == 0:
            theta, eps = self.theta_eps(np.zeros(0))
            return 0.5 * float(eps @ eps), np.zeros(0), theta
        fun = lambda c: self.theta_eps(c)[1]
        r = least_squares(fun, np.asarray(c0, float), method="lm",
                          x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12)
        theta, eps = self.theta_eps(r.x)
        return 0.5 * float(eps @ eps), r.x, theta

    def solve(self, c_half=3.0, n_keep=4, extra_starts=()):
        nc = self.mod.nc
        if nc == 0:
            return self.polish(np.zeros(0))
        if nc <= 2:
            step = 0.05
        elif nc == 3:
            step = 0.2
        else:
            step = 0.5
        for _ in range(6):                         # widen while min on edge
            g1 = np.arange(-c_half, c_half + step / 2, step)
            mesh = np.meshgrid(*([g1] * nc), indexing="ij")
            C = np.stack([m_.ravel() for m_ in mesh], axis=1)
            J = self.J_grid(C)
            Jg = J.reshape([len(g1)] * nc)
            idx = np.unravel_index(np.argmin(Jg), Jg.shape)
            if all(0 < i < len(g1) - 1 for i in idx):
                break
            c_half *= 2.0
        # grid local minima (<= all 3^nc-1 neighbours), best first
        pad = np.pad(Jg, 1, constant_values=np.inf)
        is_min = np.ones_like(Jg, dtype=bool)
        for off in np.ndindex(*([3] * nc)):
            if all(o == 1 for o in off):
                continue
            sl = tuple(slice(o, o + len(g1)) for o in off)
            is_min &= Jg <= pad[sl]
        cand = np.argwhere(is_min)
        order = np.argsort(Jg[is_min])[:n_keep]
        starts = [g1[cand[o]] for o in order]
        starts.append(np.zeros(nc))
        starts.extend(np.asarray(s, float) for s in extra_starts)
        best = None
        for s in starts:
            res = self.polish(s)
            if best is None or res[0] < best[0]:
                best = res
        self.n_grid_minima = int(is_min.sum())
        return best


# ---------------------------------------------------------------- driver
def truth_vector(preset, na, nb, nc, m):
    P = PRESETS[preset]
    a, b, c, g = (np.asarray(P[k], float) for k in ("a", "b", "c", "gamma"))
    if (len(a), len(b), len(c), len(g)) != (na, nb, nc, m):
        raise SystemExit(f"preset {preset} has orders na={len(a)} nb={len(b)}"
                         f" nc={len(c)} m={len(g)}")
    pij = np.outer(b, g).ravel()                   # i-major
    return np.concatenate((a, c, pij, [P["alpha"]]))


def count_local_minima(vals):
    v = np.asarray(vals)
    n = len(v)
    out = []
    for i in range(n):
        left = v[i - 1] if i > 0 else np.inf
        right = v[i + 1] if i < n - 1 else np.inf
        if v[i] < left and v[i] < right:
            out.append(i)
    return out


def joint_fit(model, p0, alpha_bounds):
    na, nc, nt = model.na, model.nc, model.ntheta

    def jac(p):
        a, c, pij, alpha = model.split(p)
        Zm = model.Z(alpha)
        DZ = model.D(Zm, alpha)
        tvec = np.concatenate(([1.0], a, pij))
        e = Zm @ tvec
        De = DZ @ tvec
        Hz = Zm.copy()
        for k in range(1, nc + 1):
            Hz += c[k - 1] * delay(DZ, k)
        J = np.empty((model.L, model.npar))
        # eps = Hz @ [1, theta]: d/dtheta = Hz[:, 1:]
        J[:, :na] = Hz[:, 1:1 + na]
        J[:, na + nc:na + nc + nt - na] = Hz[:, 1 + na:]
        for k in range(1, nc + 1):
            J[:, na + k - 1] = delay(De, k)
        h = 1e-6 * max(1.0, abs(alpha))
        pp, pm = p.copy(), p.copy()
        pp[-1] += h
        pm[-1] -= h
        J[:, -1] = (model.residual(pp) - model.residual(pm)) / (2 * h)
        return J

    lo = np.full(model.npar, -np.inf)
    hi = np.full(model.npar, np.inf)
    lo[-1], hi[-1] = alpha_bounds
    p0 = np.clip(p0, lo + 1e-12, hi - 1e-12)
    r = least_squares(model.residual, p0, jac=jac, bounds=(lo, hi),
                      method="trf", x_scale="jac",
                      xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=500)
    return r.x, 0.5 * float(r.fun @ r.fun)


def fit(model, a_min, a_max, a_step, verbose=False):
    grid = np.round(np.arange(a_min, a_max + a_step / 2, a_step), 10)
    prof, sols = [], []
    prev_c = None
    for al in grid:
        P = Profile(model, al)
        extra = [prev_c] if prev_c is not None else []
        V, c, th = P.solve(extra_starts=extra)
        prof.append(V)
        sols.append((c, th))
        prev_c = c
        if verbose:
            print(f"alpha={al:.3f} V*={V:.6f} c={np.round(c, 4)}",
                  file=sys.stderr)
    prof = np.array(prof)
    ib = int(np.argmin(prof))

    # refine alpha by bounded scalar minimization of the profile
    lo = grid[max(ib - 1, 0)]
    hi = grid[min(ib + 1, len(grid) - 1)]
    cache = {}
    seeds = [sols[ib][0]]

    def prof_at(al):
        P = Profile(model, float(al))
        res = P.solve(extra_starts=seeds)
        cache[float(al)] = res
        return res[0]

    if hi > lo:
        r = minimize_scalar(prof_at, bounds=(lo, hi), method="bounded",
                            options={"xatol": 1e-7})
        al_ref = float(r.x)
        V_ref, c_ref, th_ref = cache.get(al_ref) or Profile(
            model, al_ref).solve(extra_starts=seeds)
    else:
        al_ref = grid[ib]
        V_ref, (c_ref, th_ref) = prof[ib], sols[ib]
    if V_ref > prof[ib]:                            # never worse than grid
        al_ref, V_ref, (c_ref, th_ref) = grid[ib], prof[ib], sols[ib]
    p_ref = model.join(th_ref, c_ref, al_ref)

    # joint polish over all parameters including alpha
    p_j, V_j = joint_fit(model, p_ref, (a_min, a_max))
    if V_j <= V_ref:
        p_hat, V_hat = p_j, V_j
    else:
        p_hat, V_hat = p_ref, V_ref
    return dict(grid=grid, prof=prof, p=p_hat, V=V_hat, V_profile=V_ref,
                alpha_profile=al_ref, prof_c=[s_[0] for s_ in sols])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--input", required=True, help="CSV with header u,y")
    ap.add_argument("--preset", choices=sorted(PRESETS), default=None)
    ap.add_argument("--memory", type=int, default=None,
                    help="GL memory M (default: number of rows)")
    ap.add_argument("--na", type=int, default=2)
    ap.add_argument("--nb", type=int, default=3)
    ap.add_argument("--nc", type=int, default=2)
    ap.add_argument("--m", type=int, default=2)
    ap.add_argument("--alpha-min", type=float, default=0.02)
    ap.add_argument("--alpha-max", type=float, default=1.5)
    ap.add_argument("--alpha-step", type=float, default=0.01)
    ap.add_argument("--from-truth", action="store_true",
                    help="also run the joint fit from the true parameters "
                         "(diagnostic)")
    ap.add_argument("--json", default=None, help="output JSON path")
    ap.add_argument("-v", "--verbose", action="store_true")
    args = ap.parse_args()

    t0 = time.perf_counter()
    with open(args.input) as fh:
        header = [h.strip() for h in fh.readline().split(",")]
    data = np.loadtxt(args.input, delimiter=",", skiprows=1, ndmin=2)
    u = data[:, header.index("u")].astype(float)
    y = data[:, header.index("y")].astype(float)
    L = len(y)
    M = args.memory if args.memory else L
    model = Model(u, y, args.na, args.nb, args.nc, args.m, M)

    res = fit(model, args.alpha_min, args.alpha_max, args.alpha_step,
              args.verbose)
    secs = time.perf_counter() - t0

    out = dict(p=res["p"].tolist(), alpha=float(res["p"][-1]),
               cost=res["V"], cost_profile=res["V_profile"],
               alpha_profile=res["alpha_profile"],
               rows=L, memory=min(M, L),
               orders=dict(na=args.na, nb=args.nb, nc=args.nc, m=args.m))
    mins = count_local_minima(res["prof"])
    out["profile_local_minima"] = [[float(res["grid"][i]),
                                    float(res["prof"][i])] for i in mins]
    out["cost_truth"] = None
    out["delta"] = None
    if args.preset:
        pt = truth_vector(args.preset, args.na, args.nb, args.nc, args.m)
        out["preset"] = args.preset
        out["p_truth"] = pt.tolist()
        out["cost_truth"] = model.cost(pt)
        out["delta"] = float(np.linalg.norm(res["p"] - pt)
                             / np.linalg.norm(pt))
        if args.from_truth:
            p_t, V_t = joint_fit(model, pt, (args.alpha_min, args.alpha_max))
            out["cost_from_truth"] = V_t
            out["alpha_from_truth"] = float(p_t[-1])
    out["profile"] = [[float(a), float(v)]
                      for a, v in zip(res["grid"], res["prof"])]
    out["profile_c"] = [[float(a)] + [float(x) for x in c]
                        for a, c in zip(res["grid"], res["prof_c"])]
    out["seconds"] = secs
    txt = json.dumps(out, indent=1)
    if args.json:
        with open(args.json, "w") as fh:
            fh.write(txt + "\n")
    summary = {k: out[k] for k in ("alpha", "cost", "cost_truth", "delta",
                                   "seconds")}
    summary["profile_local_minima"] = out["profile_local_minima"]
    if "cost_from_truth" in out:
        summary["cost_from_truth"] = out["cost_from_truth"]
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
