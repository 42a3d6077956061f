#!/usr/bin/env python3
"""An independent scipy reference of the joint map fit: does ours reach the
optimum of its own objective?

``host-sim identify battery ... --map-method joint`` fits every knot's
parameters together over the whole record (``fracbms-host/src/identify/map/
joint.rs``, ``joint_fit``), Levenberg-Marquardt with exact derivatives and
at most 25 iterations per candidate. This script minimises the SAME
objective with ``scipy.optimize.least_squares`` (trust-region reflective,
bounds, tight tolerances, its own finite-difference derivatives of the
branch), written apart from the Rust code, from the same start and from our
fitted point, and compares. Acceptance: our data RMSE <= 1.05 x the
reference's (and, started at ours, the reference should lower the total
cost by no more than ~0.1 %).

The objective (unknowns theta: per parameter ``ln R_i, ln R_ct, ln tau, alpha,
dU`` in that order, K values, one per knot, when it varies with SOC, else one
shared value; ``tau = R_ct Q``)::

    v_hat(k) = OCV(soc(k)) + sum_j w_j(soc(k)) (dU_j + R_i,j I(k) + R_ct,j y_j(k))
    cost = sum_{k counted} (v_hat(k) - v(k))^2
         + L sum_{varying p, j = 1..K-2} ((th_p,j-1 - 2 th_p,j + th_p,j+1) / s_p)^2
         + pull L sum_i ((th_i - th0_i) / s_p(i))^2,      L = lambda * N_counted

(with ``--model butler-volmer``, plus ``a asinh(I(k) / i0)`` in ``v_hat``, its
``ln a`` and ``ln i0`` two more unknowns shared by the knots, scale 1 in the
pull, from ``joint.json``'s ``butler_volmer_start`` within
``butler_volmer_bounds``), with ``w_j`` the hat weights of the knots (held beyond the end knots), I the
current (NaN -> 0), ``y_j`` the unit branch (R_ct = 1) of knot j over the
whole record from rest with full Grunwald-Letnikov memory, ``a = tau_j
h^-alpha_j`` (``bench/reference_fit.py``'s ``cpe_branch`` with r_ct = 1,
q = tau_j), ``s`` = ``scale`` (1, 1, 1, 0.1, 0.01), th0 = ``start``; each
unknown within ``bounds``. The cost printed is this sum (not scipy's half).

Inputs: ``--levels-out DIR`` of a joint map fit writes, besides the levels,
``DIR/joint-record.csv`` (``time_s,current_a,voltage_v,counted,soc,ocv_v``:
the uniform record, which samples the fit counts, the counted SOC after
each sample and the OCV there) and ``DIR/joint.json`` (``h``, ``knots``,
``parameters``, ``start`` and ``fitted`` as K lists ``[ln R_i, ln R_ct,
ln tau, alpha, dU]``, ``smoothing`` lambda, ``vary``, ``scale``, ``bounds``,
``pull``, ``rmse_v``), e.g. (Panasonic 18650PF HPPC at 25 degC)::

    target/release/host-sim identify battery \\
        --input "data/panasonic-18650pf/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat" \\
        --ocv OCV.csv --capacity-ah 2.9 --min-rest 3000 --model linear \\
        --temperature-c 25 --map-method joint --map-out map.csv \\
        --levels-out target/map-validation/levels-joint-25 --json fit.json

Usage::

    python3 bench/joint_reference.py [DIR] [--chain 1e-4]
    # DIR default target/map-validation/levels-joint-25

It first checks that its model at theta = ``fitted`` reproduces our
``rmse_v`` (to 1e-6 V; it stops otherwise), then fits from ``start`` and
from ``fitted`` and prints a Markdown table: data RMSE over the counted
samples (mV), total cost, its penalty part (smoothness + pull), residual
and Jacobian evaluations, wall time; and the ratios ours / reference; then
each knot's parameters, ours against the reference's from ``start``. About
half a minute on one core (K = 14 knots, 48 800 samples, 70 unknowns).

``joint.json``'s ``start`` is the pull's centre of the chosen candidate:
the cells it started from (``joint::choose`` fits a varying set's
penalties largest first, each from the one before). ``--chain 1e-4``
(penalties to fit first, in order) instead fits those from ``start`` and
the chosen penalty from the last of them, pulled towards it: the check
of an export from before ``start`` was the chosen candidate's own.
"""

import argparse
import json
import os
import sys
import time

import numpy as np
from scipy.optimize import least_squares

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from reference_fit import cpe_branch, read_csv  # noqa: E402

DEFAULT_DIR = "target/map-validation/levels-joint-25"
# Central-difference steps of the branch in ln tau and alpha.
STEP_LN_TAU = 1e-5
STEP_ALPHA = 1e-6


class Problem:
    """The joint objective of one ``joint.json`` + ``joint-record.csv``."""

    def __init__(self, folder):
        with open(os.path.join(folder, "joint.json")) as f:
            d = json.load(f)
        self.doc = d
        _, i, v, counted, soc, ocv = read_csv(
            os.path.join(folder, "joint-record.csv"),
            ["time_s", "current_a", "voltage_v", "counted", "soc", "ocv_v"],
        )
        self.h = float(d["h"])
        self.i = np.where(np.isfinite(i), i, 0.0)
        self.v = v
        self.ocv = ocv
        self.counted = (counted > 0) & np.isfinite(v)
        self.nc = int(self.counted.sum())
        if self.nc == 0:
            sys.exit("no counted sample")
        knots = np.asarray(d["knots"], float)
        self.K = k = len(knots)
        # Hat weights: sample n weighs knot lo[n] by 1 - w[n], knot lo[n]+1 by
        # w[n] (all on knot 0 below the first knot, on K-1 above the last).
        if k == 1:
            lo, w = np.zeros(len(soc), int), np.zeros(len(soc))
        else:
            lo = np.clip(np.searchsorted(knots, soc, side="right") - 1, 0, k - 2)
            w = np.clip((soc - knots[lo]) / (knots[lo + 1] - knots[lo]), 0.0, 1.0)
        wk = np.zeros((k, len(soc)))
        for j in range(k):
            wk[j] = np.where(lo == j, 1.0 - w, 0.0) + np.where(lo + 1 == j, w, 0.0)
        self.wk = wk
        # A knot's branch is causal: needed up to the last sample it weighs.
        self.end = [int(np.nonzero(wk[j] > 0)[0][-1]) + 1 if np.any(wk[j] > 0) else 0
                    for j in range(k)]
        self.vary = [bool(x) for x in d["vary"]]
        self.scale = np.asarray(d["scale"], float)
        self.bounds = np.asarray(d["bounds"], float)
        self.lam = float(d["smoothing"]) * self.nc
        self.pull = float(d["pull"])
        # Layout of theta.
        self.first, at = [], 0
        for p in range(5):
            self.first.append(at)
            at += k if self.vary[p] else 1
        # With the Butler-Volmer term: ln a and ln i0 last, shared by the
        # knots (scale 1 in the pull).
        self.kin = at if d.get("butler_volmer") else None
        self.m = at + (2 if self.kin is not None else 0)
        self.param = np.array([p for p in range(5) for _ in range(k if self.vary[p] else 1)])
        self.s = self.scale[self.param]
        self.lo = self.bounds[self.param, 0]
        self.hi = self.bounds[self.param, 1]
        self.theta0 = self.theta_of(np.asarray(d["start"], float))
        self.theta_ours = self.theta_of(np.asarray(d["fitted"], float))
        if self.kin is not None:
            kb = np.asarray(d["butler_volmer_bounds"], float)
            self.s = np.concatenate([self.s, [1.0, 1.0]])
            self.lo = np.concatenate([self.lo, kb[:, 0]])
            self.hi = np.concatenate([self.hi, kb[:, 1]])
            self.theta0 = np.concatenate([self.theta0, np.log(d["butler_volmer_start"])])
            self.theta_ours = np.concatenate([self.theta_ours, np.log(d["butler_volmer"])])
        # Penalty rows (second differences / scale), as a dense matrix.
        rows = []
        for p in range(5):
            if not self.vary[p] or k < 3:
                continue
            for j in range(1, k - 1):
                r = np.zeros(self.m)
                for jj, c in ((j - 1, 1.0), (j, -2.0), (j + 1, 1.0)):
                    r[self.index(p, jj)] += c / self.scale[p]
                rows.append(r)
        self.P = np.array(rows).reshape(len(rows), self.m)
        self.nfev = 0
        self.njev = 0
        self._cache = (None, None)

    def index(self, p, j):
        return self.first[p] + (j if self.vary[p] else 0)

    def theta_of(self, knots_params):
        """theta's knot part from K lists (a shared parameter: the knots'
        mean, as ours)."""
        m = self.kin if self.kin is not None else self.m
        th = np.zeros(m)
        n = np.zeros(m)
        for j in range(self.K):
            for p in range(5):
                th[self.index(p, j)] += knots_params[j, p]
                n[self.index(p, j)] += 1
        return th / np.maximum(n, 1)

    def knot(self, theta, j):
        return [theta[self.index(p, j)] for p in range(5)]

    def branch(self, ln_tau, alpha, end):
        return cpe_branch(self.i[:end], self.h, 1.0, np.exp(ln_tau), alpha)

    def branches(self, theta):
        """Each knot's unit branch (knots sharing tau, alpha and end share one)."""
        key = theta.tobytes()
        if self._cache[0] == key:
            return self._cache[1]
        memo, out = {}, []
        for j in range(self.K):
            _, _, lt, al, _ = self.knot(theta, j)
            kk = (lt, al, self.end[j])
            if kk not in memo:
                memo[kk] = self.branch(lt, al, self.end[j]) if self.end[j] else np.zeros(0)
            out.append(memo[kk])
        self._cache = (key, out)
        return out

    def model(self, theta):
        vh = self.ocv.copy()
        if self.kin is not None:
            a, i0 = np.exp(theta[self.kin]), np.exp(theta[self.kin + 1])
            vh += a * np.arcsinh(self.i / i0)
        for j, y in enumerate(self.branches(theta)):
            e = self.end[j]
            if e == 0:
                continue
            ri, rct, _, _, du = self.knot(theta, j)
            vh[:e] += self.wk[j, :e] * (du + np.exp(ri) * self.i[:e] + np.exp(rct) * y)
        return vh

    def residuals(self, theta):
        self.nfev += 1
        r = (self.model(theta) - self.v)[self.counted]
        return np.concatenate([
            r,
            np.sqrt(self.lam) * (self.P @ theta),
            np.sqrt(self.pull * self.lam) * (theta - self.theta0) / self.s,
        ])

    def jacobian(self, theta):
        self.njev += 1
        n = len(self.v)
        jd = np.zeros((n, self.m))
        ys = self.branches(theta)
        if self.kin is not None:
            a, i0 = np.exp(theta[self.kin]), np.exp(theta[self.kin + 1])
            x = self.i / i0
            jd[:, self.kin] = a * np.arcsinh(x)
            jd[:, self.kin + 1] = -a * x / np.sqrt(1.0 + x * x)
        for j in range(self.K):
            e = self.end[j]
            if e == 0:
                continue
            ri, rct, lt, al, _ = self.knot(theta, j)
            wj = self.wk[j, :e]
            y = ys[j]
            dt = (self.branch(lt + STEP_LN_TAU, al, e)
                  - self.branch(lt - STEP_LN_TAU, al, e)) / (2 * STEP_LN_TAU)
            # Keep alpha +- step inside (0, 1] for the GL weights (bounds
            # are 0.05..1: one-sided at the top).
            a_hi = min(al + STEP_ALPHA, 1.0)
            a_lo = a_hi - 2 * STEP_ALPHA
            da = (self.branch(lt, a_hi, e) - self.branch(lt, a_lo, e)) / (a_hi - a_lo)
            cols = [
                wj * np.exp(ri) * self.i[:e],
                wj * np.exp(rct) * y,
                wj * np.exp(rct) * dt,
                wj * np.exp(rct) * da,
                wj,
            ]
            for p, c in enumerate(cols):
                jd[:e, self.index(p, j)] += c
        return np.vstack([
            jd[self.counted],
            np.sqrt(self.lam) * self.P,
            np.sqrt(self.pull * self.lam) * np.diag(1.0 / self.s),
        ])

    def parts(self, theta):
        """(data RMSE V, total cost V^2, smoothness part V^2, pull part V^2)."""
        r = (self.model(theta) - self.v)[self.counted]
        data = float(r @ r)
        smooth = self.lam * float(np.sum((self.P @ theta) ** 2))
        pull = self.pull * self.lam * float(np.sum(((theta - self.theta0) / self.s) ** 2))
        return np.sqrt(data / self.nc), data + smooth + pull, smooth, pull

    def fit(self, x0):
        self.nfev = self.njev = 0
        x0 = np.clip(x0, self.lo, self.hi)
        t0 = time.time()
        res = least_squares(
            self.residuals, x0, jac=self.jacobian, bounds=(self.lo, self.hi),
            method="trf", x_scale=self.s, ftol=1e-10, xtol=1e-10, gtol=1e-10,
            max_nfev=200,
        )
        return res, time.time() - t0, self.nfev, self.njev


def knots_table(pb, th_a, th_b, name_a, name_b):
    names = ["ln R_i", "ln R_ct", "ln tau", "alpha", "dU (mV)"]
    out = ["| knot SOC | " + " | ".join(f"{n} {name_a} / {name_b}" for n in names) + " |",
           "|---|" + "---|" * 5]
    for j, z in enumerate(pb.doc["knots"]):
        a, b = pb.knot(th_a, j), pb.knot(th_b, j)
        cells = []
        for p in range(5):
            f = 1e3 if p == 4 else 1.0
            cells.append(f"{a[p] * f:.3f} / {b[p] * f:.3f}")
        out.append(f"| {z:.3f} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def table(pb, rows, c_ours, rm_ours):
    """Markdown rows: label, theta, nfev, njev, seconds (None: not known)."""
    out = ["| fit | data RMSE (mV) | total cost (V²) | penalty part (V²): smoothness + pull | "
           "evaluations (f / J) | wall time (s) | RMSE ours / this | cost ours / this |",
           "|---|---|---|---|---|---|---|---|"]
    for label, th, nfev, njev, secs in rows:
        rm, c, sm, pl = pb.parts(th)
        ev = "—" if nfev is None else f"{nfev} / {njev}"
        tm = "—" if secs is None else f"{secs:.1f}"
        out.append(f"| {label} | {rm * 1e3:.4f} | {c:.6f} | {sm + pl:.6f}: {sm:.6f} + {pl:.6f} | "
                   f"{ev} | {tm} | {rm_ours / rm:.5f} | {c_ours / c:.6f} |")
    return "\n".join(out)


def fit_rows(pb, starts):
    rows, fits = [], {}
    for label, x0 in starts:
        res, secs, nfev, njev = pb.fit(x0)
        print(f"{label}: {res.message} (status {res.status}), {secs:.1f} s, "
              f"{int(np.sum(res.active_mask != 0))} unknowns at a bound", flush=True)
        rows.append((label, res.x, nfev, njev, secs))
        fits[label] = res.x
    return rows, fits


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dir", nargs="?", default=DEFAULT_DIR,
                    help=f"the --levels-out folder (default {DEFAULT_DIR})")
    ap.add_argument("--chain", default="",
                    help="penalties (V^2, comma-separated, in order) our choice fitted "
                         "before the chosen one in its varying set, e.g. 1e-4: the "
                         "reference fits them from start, each from and pulled towards "
                         "the one before, then repeats the comparison with the pull "
                         "centred on the last (see the caveat above)")
    args = ap.parse_args()
    folder = args.dir
    if not os.path.exists(os.path.join(folder, "joint.json")):
        sys.exit(f"{folder}/joint.json missing: run identify battery "
                 "--map-method joint --levels-out DIR (see the docstring)")
    t_all = time.time()
    pb = Problem(folder)
    print(f"{folder}: {len(pb.v)} samples ({pb.nc} counted), K = {pb.K} knots, "
          f"{pb.m} unknowns, lambda = {pb.doc['smoothing']:g} V^2, vary = {pb.vary}")
    rm_ours = pb.parts(pb.theta_ours)[0]
    print(f"model at fitted: RMSE {rm_ours:.12f} V, ours (joint.json rmse_v) "
          f"{pb.doc['rmse_v']:.12f} V, difference {abs(rm_ours - pb.doc['rmse_v']):.2e} V")
    if not abs(rm_ours - pb.doc["rmse_v"]) <= 1e-6:
        sys.exit("the model does not reproduce our RMSE: the objectives differ")
    rm0, c0, _, _ = pb.parts(pb.theta0)
    print(f"at start: RMSE {rm0 * 1e3:.4f} mV, cost {c0:.6g} V^2")

    c_ours = pb.parts(pb.theta_ours)[1]
    rows, fits = fit_rows(pb, (("reference from start", pb.theta0),
                               ("reference from ours", pb.theta_ours)))
    print()
    print("Pull centred on joint.json's start:")
    print()
    print(table(pb, [("ours (fitted)", pb.theta_ours, None, None, None)] + rows, c_ours, rm_ours))
    print()
    ref = fits["reference from start"]
    ratio = rm_ours / pb.parts(ref)[0]
    print(f"acceptance: RMSE ours / reference from start = {ratio:.4f} "
          f"({'pass' if ratio <= 1.05 else 'FAIL'}, <= 1.05); the reference from ours "
          f"lowers the cost by {100 * (1 - pb.parts(fits['reference from ours'])[1] / c_ours):.4f} %")
    print()
    print(knots_table(pb, pb.theta_ours, ref, "ours", "ref"))
    if pb.kin is not None:
        ao, io = np.exp(pb.theta_ours[pb.kin:pb.kin + 2])
        ar, ir = np.exp(ref[pb.kin:pb.kin + 2])
        print(f"\nButler-Volmer term: a {ao * 1e3:.3f} / {ar * 1e3:.3f} mV, "
              f"i0 {io:.4f} / {ir:.4f} A (ours / ref)")

    chain = [float(x) for x in args.chain.split(",") if x.strip()]
    if chain:
        lam = pb.lam
        x, t0, nfev, njev = pb.theta0, time.time(), 0, 0
        for c in chain:
            pb.lam = c * pb.nc
            res, _, nf, nj = pb.fit(x)
            nfev, njev = nfev + nf, njev + nj
            print(f"chain lambda = {c:g}: {res.message}, RMSE "
                  f"{pb.parts(res.x)[0] * 1e3:.4f} mV", flush=True)
            pb.theta0 = x = res.x
        pb.lam = lam
        res, secs, nf, nj = pb.fit(x)
        label = "reference chained " + " → ".join(f"{c:g}" for c in chain + [pb.doc["smoothing"]])
        rows = [(label, res.x, nfev + nf, njev + nj, time.time() - t0)]
        print(f"{label}: {res.message}", flush=True)
        more, fits = fit_rows(pb, (("reference from ours", pb.theta_ours),))
        c_ours = pb.parts(pb.theta_ours)[1]
        print()
        print("Pull centred on the reference's chained fit at lambda = "
              f"{chain[-1]:g} (as our choice pulled towards its previous candidate):")
        print()
        print(table(pb, [("ours (fitted)", pb.theta_ours, None, None, None)] + rows + more,
                    c_ours, rm_ours))
        print()
        print(f"RMSE ours / reference chained = {rm_ours / pb.parts(res.x)[0]:.5f}; "
              f"max |theta ours - theta chained| = {np.max(np.abs(pb.theta_ours - res.x)):.4f}")
    print(f"\ntotal wall time {time.time() - t_all:.0f} s")


if __name__ == "__main__":
    main()
