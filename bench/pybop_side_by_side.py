#!/usr/bin/env python3
"""PyBOP's Thevenin equivalent-circuit fit beside fracbms on the PyBaMM DFN records.

Optional dependencies, not run in CI. Tested with::

    pybop==26.3  pybamm==26.10.1.1  (pybammsolvers 0.11.1, casadi 3.8.1)
    numpy 2.3.5  scipy 1.17.1  matplotlib 3.11.2  Python 3.11

(``pip install pybop matplotlib`` resolved to these; no pin was needed.)

Setup and run (7.5 minutes on one core, 60 % of it the CMA-ES rows; results in
docs/pybop-side-by-side.md)::

    python3 -m venv .venv-pybop
    .venv-pybop/bin/pip install pybop==26.3 pybamm==26.10.1.1 matplotlib
    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 \\
        .venv-pybop/bin/python bench/pybop_side_by_side.py

Options: ``--records chen2020-drive`` (comma separated; default both drive
records), ``--max-iterations N`` (PyBOP's optimisers), ``--cmaes-records``
(records also fitted with CMA-ES; default chen2020-drive, ``''`` for none),
``--out-dir docs`` (the plot goes to OUT/pybop/side_by_side.png),
``--json FILE`` (the numbers without the time series).

What is compared
----------------
* Data: ``data/pybamm/<record>.csv`` (``time_s,current_a,voltage_v,
  voltage_true_v,soc_true``, 1 s, 3000 rows, starting at rest), the OCV table
  ``<cell>-ocv.csv`` and the capacity and start SOC of ``meta.json``.
* **Current sign.** The records give the current POSITIVE WHEN CHARGING.
  PyBaMM and PyBOP use positive = DISCHARGE, so PyBaMM's
  ``Current function [A]`` is ``-current_a``. fracbms (package and CLI) takes
  the records' convention (charge positive) and gets ``current_a`` unchanged.
* **PyBOP**: ``pybamm.equivalent_circuit.Thevenin`` with 1 and with 2 RC
  pairs (PyBOP 26.x has no ECM class of its own; its examples wrap this PyBaMM
  model in ``pybop.pybamm.Simulator``). Known: the OCV (a linear
  ``pybamm.Interpolant`` of the committed table as a function of SoC, no
  offset), the capacity, the initial SoC 0.9, entropic change 0. Fitted: R0,
  R_k and tau_k = R_k C_k (C_k = tau_k / R_k, PyBOP's ``ecm_tau_redefined``
  example), all in logarithms (``pybop.LogTransformation``), bounds R in
  [1e-4, 0.1] ohm and tau in [1, 1000] s. Cost ``pybop.SumSquaredError`` of
  the free-run voltage against ``voltage_v``.
* **Input as recorded.** Each row holds the current of the second before it
  (zero-order hold; the voltage is at its end). PyBOP's ``Dataset`` protocol
  would interpolate the current linearly between rows (0.7 mV RMS away from
  the exact hold on chen2020-drive with the same parameters); so the current
  is a PyBaMM interpolant evaluated at ``ceil(t)`` and the IDAKLU solver
  stops at every row (``Simulator._t_eval`` set to the row times), which
  reproduces the exact hold to 9 uV. Solver: ``pybamm.IDAKLUSolver`` with
  PyBOP's recommended tolerances (atol = rtol = 1e-6) and ONE thread
  (``RecommendedSolver`` would take every core).
* **Optimisers**: on every record ``pybop.SciPyMinimize`` with
  ``method="L-BFGS-B"``, the gradient from the IDAKLU forward sensitivities,
  from R0 = R_k = 10 mOhm, tau_1 = 10 s (tau_2 = 300 s), maxiter
  ``--max-iterations`` (default 200). On the ``--cmaes-records`` also
  ``pybop.CMAES`` (gradient-free, the optimiser of PyBOP's ECM example) with
  PyBOP's ``PintsOptions`` defaults: at most ``--max-iterations`` (default
  1000) iterations, stop after 15 iterations without a 1 % relative
  improvement; seeded by ``--seed`` (default 1). PyBOP starts population
  optimisers at the mean of the bounds (R 50 mOhm, tau 500 s), not at the
  initial value, with sigma0 the standard deviation of the uniform
  distribution over the bounds (0.58 in the logarithms).
* **Independent check** of each PyBOP fit: the same Thevenin model discretised
  exactly (zero-order hold) in numpy and fitted by
  ``scipy.optimize.least_squares`` from a grid of starts; its RMSE says
  whether PyBOP stopped at the model's best fit. The same check with an OCV
  offset dU fitted too (fracbms fits one) says what that is worth.
* **fracbms**: ``fit_fracbms(record)`` uses the Python package ``fracbms``
  when it imports (``identify_battery`` then ``simulate_battery`` for the
  free run), else the CLI ``target/release/host-sim identify battery --input
  FILE --ocv OCV --capacity-ah C --soc0 0.9 --json --fit-out`` (build it with
  ``cargo build --release -p host-sim``; ``HOST_SIM=PATH`` for another
  binary). ``--model auto`` (the default: the
  linear fractional model or the Butler-Volmer one, whichever the data
  identify) and ``--model linear``. Its time is the wall time of the call
  (for the CLI: of the whole process, reading the CSV included).

RMSEs are over all rows of the free run (the model driven by the current
alone from the known start) against ``voltage_v`` (noisy, sigma = 1 mV) and
against ``voltage_true_v`` (the DFN's noise-free voltage). Times are
``time.perf_counter`` around the fit only (PyBOP: ``optim.run()``; model
building excluded and reported apart).
"""

import argparse
import csv
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
DEFAULT_RECORDS = "chen2020-drive,prada2013-drive"
R_BOUNDS = (1e-4, 0.1)
TAU_BOUNDS = (1.0, 1000.0)
OPTIMIZER_NAMES = {"lbfgsb": "L-BFGS-B", "cmaes": "CMA-ES"}


# --------------------------------------------------------------------------
# data


def load_record(name, data_dir):
    """The record, its OCV table and its meta.json entry."""
    data_dir = Path(data_dir)
    meta = json.loads((data_dir / "meta.json").read_text())
    info = meta["records"][name]
    cell = name.split("-")[0]
    d = np.genfromtxt(data_dir / f"{name}.csv", delimiter=",", names=True)
    o = np.genfromtxt(data_dir / f"{cell}-ocv.csv", delimiter=",", names=True)
    return {
        "name": name,
        "path": data_dir / f"{name}.csv",
        "ocv_path": data_dir / f"{cell}-ocv.csv",
        "time_s": np.asarray(d["time_s"], float),
        # positive when CHARGING (the records' convention)
        "current_a": np.asarray(d["current_a"], float),
        "voltage_v": np.asarray(d["voltage_v"], float),
        "voltage_true_v": np.asarray(d["voltage_true_v"], float),
        "soc_true": np.asarray(d["soc_true"], float),
        "ocv_soc": np.asarray(o["soc"], float),
        "ocv_v": np.asarray(o["ocv_v"], float),
        "capacity_ah": float(info["capacity_ah"]),
        "soc0": float(info["soc0"]),
    }


def rmse(a, b):
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


# --------------------------------------------------------------------------
# PyBOP


def log_safe_bounds(lo, hi):
    """Bounds whose exp(log(.)) round trip stays inside them.

    PyBOP checks a candidate against the bounds in model space after
    exp(search value); at a bound exp(log(0.1)) = 0.10000000000000002 fails
    the check, the cost becomes inf and L-BFGS-B stops on its fake gradient.
    Moving each bound inward by a few ulps avoids it.
    """
    while np.exp(np.log(lo)) < lo:
        lo = np.nextafter(lo, np.inf)
    while np.exp(np.log(hi)) > hi:
        hi = np.nextafter(hi, -np.inf)
    return [float(lo), float(hi)]


def pybop_problem(rec, n_rc):
    """pybop.Problem of the Thevenin model with n_rc RC pairs on the record."""
    import pybamm
    import pybop

    t = rec["time_s"]
    # PyBaMM: positive current = DISCHARGE; the records: positive = charge.
    i_discharge = -rec["current_a"]
    soc_tab, ocv_tab = rec["ocv_soc"], rec["ocv_v"]

    def ocv(soc):
        return pybamm.Interpolant(soc_tab, ocv_tab, soc, name="ocv_table", interpolator="linear")

    values = {
        "chemistry": "ecm",
        "Initial SoC": rec["soc0"],
        "Initial temperature [K]": 298.15,
        "Ambient temperature [K]": 298.15,
        "Cell capacity [A.h]": rec["capacity_ah"],
        "Nominal cell capacity [A.h]": rec["capacity_ah"],
        # zero-order hold: the current of row l holds over (t_{l-1}, t_l]
        "Current function [A]": pybamm.Interpolant(
            t, i_discharge, pybamm.Ceiling(pybamm.t), name="current_zoh", interpolator="linear"
        ),
        "Upper voltage cut-off [V]": 5.0,
        "Lower voltage cut-off [V]": 1.5,
        "Cell thermal mass [J/K]": 1000.0,
        "Cell-jig heat transfer coefficient [W/K]": 10.0,
        "Jig thermal mass [J/K]": 500.0,
        "Jig-air heat transfer coefficient [W/K]": 10.0,
        "Open-circuit voltage [V]": ocv,
        "Entropic change [V/K]": 0.0,
        "RCR lookup limit [A]": 1000.0,
        "R0 [Ohm]": pybop.Parameter(
            bounds=log_safe_bounds(*R_BOUNDS), initial_value=0.01, transformation=pybop.LogTransformation()
        ),
    }
    tau_start = [10.0, 300.0, 100.0]
    for k in range(1, n_rc + 1):
        values[f"Element-{k} initial overpotential [V]"] = 0.0
        values[f"R{k} [Ohm]"] = pybop.Parameter(
            bounds=log_safe_bounds(*R_BOUNDS), initial_value=0.01, transformation=pybop.LogTransformation()
        )
        values[f"tau{k} [s]"] = pybop.Parameter(
            bounds=log_safe_bounds(*TAU_BOUNDS),
            initial_value=tau_start[k - 1],
            transformation=pybop.LogTransformation(),
        )
        values[f"C{k} [F]"] = pybamm.Parameter(f"tau{k} [s]") / pybamm.Parameter(f"R{k} [Ohm]")
    parameter_values = pybamm.ParameterValues(values)

    model = pybamm.equivalent_circuit.Thevenin(options={"number of rc elements": n_rc})
    solver = pybamm.IDAKLUSolver(
        atol=1e-6, rtol=1e-6, on_failure="ignore", options={"num_threads": 1}
    )
    simulator = pybop.pybamm.Simulator(
        model, parameter_values=parameter_values, protocol=t, solver=solver
    )
    # Stop the solver at every row: the held current jumps there.
    simulator._t_eval = t  # noqa: SLF001 (no public option in PyBOP 26.3)
    dataset = pybop.Dataset({"Time [s]": t, "Voltage [V]": rec["voltage_v"]})
    cost = pybop.SumSquaredError(dataset)
    return pybop.Problem(simulator, cost)


def fit_pybop(rec, n_rc, optimizer="lbfgsb", max_iterations=None, seed=1):
    """Fit the Thevenin model with n_rc RC pairs by PyBOP; the row of the table."""
    import pybop

    t0 = time.perf_counter()
    problem = pybop_problem(rec, n_rc)
    build_s = time.perf_counter() - t0
    names = list(problem.parameters.names)

    if optimizer == "lbfgsb":
        options = pybop.SciPyMinimizeOptions(
            method="L-BFGS-B", jac=True, maxiter=max_iterations or 200
        )
        optim = pybop.SciPyMinimize(problem, options=options)
    elif optimizer == "cmaes":
        np.random.seed(seed)  # PINTS seeds its CMA-ES from numpy's global generator
        options = pybop.PintsOptions(max_iterations=max_iterations or 1000)
        optim = pybop.CMAES(problem, options=options)
    else:
        raise ValueError(optimizer)

    t0 = time.perf_counter()
    error = None
    try:
        result = optim.run()
    except Exception as e:  # report, do not hide
        result, error = None, f"{type(e).__name__}: {e}"
    fit_s = time.perf_counter() - t0

    out = {
        "tool": "PyBOP",
        "model": f"Thevenin {n_rc} RC, {OPTIMIZER_NAMES[optimizer]}",
        "n_rc": n_rc,
        "free_parameters": 1 + 2 * n_rc,
        "optimizer": optimizer,
        "build_s": build_s,
        "fit_s": fit_s,
        "error": error,
    }
    if result is None:
        return out
    x = dict(zip(names, np.asarray(result.x, float)))
    sol = problem.simulate(x)
    model_v = np.asarray(sol["Voltage [V]"].data, float)
    if model_v.shape != rec["time_s"].shape or not np.all(np.isfinite(model_v)):
        out["error"] = f"the fitted model does not simulate ({result.message})"
        return out
    params = {"R0_ohm": x["R0 [Ohm]"]}
    for k in range(1, n_rc + 1):
        r, tau = x[f"R{k} [Ohm]"], x[f"tau{k} [s]"]
        params.update({f"R{k}_ohm": r, f"tau{k}_s": tau, f"C{k}_F": tau / r})
    at_bound = [
        n
        for n, v in x.items()
        if any(np.isclose(v, b, rtol=1e-3) for b in (R_BOUNDS if "Ohm" in n else TAU_BOUNDS))
    ]
    out.update(
        {
            "params": params,
            "model_v": model_v,
            "rmse_noisy_v": rmse(model_v, rec["voltage_v"]),
            "rmse_true_v": rmse(model_v, rec["voltage_true_v"]),
            "iterations": int(result.n_iterations),
            "evaluations": int(result.n_evaluations),
            "message": str(result.message),
            "at_bound": at_bound,
        }
    )
    return out


# --------------------------------------------------------------------------
# independent numpy reference of the same Thevenin model


def thevenin_numpy(rec, r0, rs, taus, offset=0.0):
    """Exact zero-order-hold Thevenin free run (charge-positive current)."""
    from scipy.signal import lfilter

    t = rec["time_s"]
    i = rec["current_a"]
    dt = np.diff(t, prepend=t[0])
    soc = rec["soc0"] + np.cumsum(i * dt) / (3600.0 * rec["capacity_ah"])
    v = np.interp(soc, rec["ocv_soc"], rec["ocv_v"]) + offset + r0 * i
    h = float(np.median(np.diff(t)))
    for r, tau in zip(rs, taus):
        a = np.exp(-h / tau)
        v = v + lfilter([(1.0 - a) * r], [1.0, -a], i)
    return v


def fit_numpy(rec, n_rc, with_offset=False):
    """Best fit of the numpy Thevenin model (least_squares from a grid of starts)."""
    from itertools import product

    from scipy.optimize import least_squares

    lo = [np.log(R_BOUNDS[0])] + [np.log(R_BOUNDS[0]), np.log(TAU_BOUNDS[0])] * n_rc
    hi = [np.log(R_BOUNDS[1])] + [np.log(R_BOUNDS[1]), np.log(TAU_BOUNDS[1])] * n_rc
    if with_offset:
        lo.append(-0.05)
        hi.append(0.05)

    def unpack(p):
        r0 = np.exp(p[0])
        rs = np.exp(p[1 : 1 + 2 * n_rc : 2])
        taus = np.exp(p[2 : 2 + 2 * n_rc : 2])
        off = p[-1] if with_offset else 0.0
        return r0, rs, taus, off

    def resid(p):
        return thevenin_numpy(rec, *unpack(p)) - rec["voltage_v"]

    tau_grids = {1: [(3.0,), (30.0,), (300.0,)], 2: [(3.0, 100.0), (10.0, 300.0), (30.0, 1000.0)]}
    best = None
    for taus, r in product(tau_grids[n_rc], [0.003, 0.01, 0.03]):
        p0 = [np.log(0.01)]
        for tau in taus:
            p0 += [np.log(r), np.log(tau)]
        if with_offset:
            p0.append(0.0)
        p0 = np.clip(p0, np.array(lo) + 1e-9, np.array(hi) - 1e-9)
        s = least_squares(resid, p0, bounds=(lo, hi), x_scale=1.0)
        if best is None or s.cost < best.cost:
            best = s
    r0, rs, taus, off = unpack(best.x)
    v = thevenin_numpy(rec, r0, rs, taus, off)
    return {
        "rmse_noisy_v": rmse(v, rec["voltage_v"]),
        "rmse_true_v": rmse(v, rec["voltage_true_v"]),
        "r0": r0,
        "r": rs.tolist(),
        "tau": taus.tolist(),
        "offset_v": off,
    }


# --------------------------------------------------------------------------
# fracbms


def host_sim_path():
    p = os.environ.get("HOST_SIM") or str(REPO / "target" / "release" / "host-sim")
    if not Path(p).exists():
        raise FileNotFoundError(
            f"{p} missing: cargo build --release -p host-sim (or set HOST_SIM)"
        )
    return p


def _fracbms_row(rec, js, model_v, path, model_flag, wall_s):
    nonlinear = js.get("model") == "butler-volmer"
    params = {
        "r_i_ohm": js["r_i"],
        "r_ct_ohm": js["r_ct"],
        "q": js["q"],
        "alpha": js["alpha"],
        "ocv_offset_v": js.get("ocv_offset_v", 0.0),
    }
    if nonlinear:
        params.update({"bv_a_v": js["bv_a_v"], "bv_i0_a": js["bv_i0_a"]})
    return {
        "tool": "fracbms",
        "model": f"fractional, {js.get('model')} (--model {model_flag})",
        "chosen": js.get("model"),
        "free_parameters": 7 if nonlinear else 5,
        "path": path,
        "fit_s": wall_s,
        "params": params,
        "model_v": model_v,
        "rmse_noisy_v": rmse(model_v, rec["voltage_v"]),
        "rmse_true_v": rmse(model_v, rec["voltage_true_v"]),
        "rmse_reported_v": js.get("rmse_v"),
        "iterations": js.get("iterations"),
        "converged": js.get("converged"),
        "error": None,
    }


def fit_fracbms_cli(rec, model="auto"):
    exe = host_sim_path()
    with tempfile.TemporaryDirectory() as tmp:
        js_path, fit_path = Path(tmp) / "fit.json", Path(tmp) / "fit.csv"
        cmd = [
            exe, "identify", "battery",
            "--input", str(rec["path"]),
            "--ocv", str(rec["ocv_path"]),
            "--capacity-ah", repr(rec["capacity_ah"]),
            "--soc0", repr(rec["soc0"]),
            "--model", model,
            "--json", str(js_path),
            "--fit-out", str(fit_path),
        ]
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True)
        wall_s = time.perf_counter() - t0
        if proc.returncode != 0:
            return {
                "tool": "fracbms",
                "model": f"fractional (--model {model})",
                "path": "CLI",
                "fit_s": wall_s,
                "error": proc.stderr.strip()[-500:],
            }
        js = json.loads(js_path.read_text())
        with open(fit_path) as f:
            rows = list(csv.DictReader(f))
        model_v = np.array([float(r["model_v"]) for r in rows])
    return _fracbms_row(rec, js, model_v, "CLI", model, wall_s)


def fit_fracbms(rec, model="auto"):
    """fracbms's fit of the record: the Python package if it imports, else the CLI."""
    try:
        import fracbms
    except ImportError:
        fracbms = None
    if fracbms is None:
        return fit_fracbms_cli(rec, model)

    kwargs = dict(
        ocv=(rec["ocv_soc"], rec["ocv_v"]),
        capacity_ah=rec["capacity_ah"],
        soc0=rec["soc0"],
        method="refined",
        model=model,
    )
    t0 = time.perf_counter()
    # the records' convention: current positive when charging
    js = fracbms.identify_battery(rec["time_s"], rec["current_a"], rec["voltage_v"], **kwargs)
    wall_s = time.perf_counter() - t0
    # the fitted model's free-run voltage (the CLI's --fit-out model_v)
    model_v = np.asarray(js.pop("model_v"), float)
    return _fracbms_row(rec, js, model_v, "package", model, wall_s)


# --------------------------------------------------------------------------
# report


def fmt_params(row):
    p = row.get("params") or {}
    if row["tool"] == "PyBOP":
        parts = [f"R0 {1e3 * p['R0_ohm']:.2f} mΩ"]
        k = 1
        while f"R{k}_ohm" in p:
            parts.append(
                f"R{k} {1e3 * p[f'R{k}_ohm']:.2f} mΩ, τ{k} {p[f'tau{k}_s']:.1f} s "
                f"(C{k} {p[f'C{k}_F']:.0f} F)"
            )
            k += 1
        return "; ".join(parts)
    s = (
        f"R_i {1e3 * p['r_i_ohm']:.2f} mΩ, R_ct {1e3 * p['r_ct_ohm']:.2f} mΩ, "
        f"Q {p['q']:.0f}, α {p['alpha']:.3f}, ΔU {1e3 * p['ocv_offset_v']:.2f} mV"
    )
    if "bv_a_v" in p:
        s += f", a {1e3 * p['bv_a_v']:.1f} mV, i₀ {p['bv_i0_a']:.2f} A"
    return s


def print_row(r):
    who = f"{r['record']} {r['tool']} {r['model']}"
    if r["tool"] == "fracbms":
        who += f" ({r['path']})"
    if r.get("error"):
        print(f"{who} FAILED after {r['fit_s']:.1f} s: {r['error']}", flush=True)
        return
    extra = ""
    if r["tool"] == "PyBOP":
        extra = (
            f" (build {r['build_s']:.1f} s), {r['iterations']} it, {r['evaluations']} ev, "
            f"{r['message']!r}, at bound {r['at_bound']}"
        )
    else:
        extra = f", reported rmse {1e3 * r['rmse_reported_v']:.3f} mV, converged {r['converged']}"
    print(
        f"{who}: rmse {1e3 * r['rmse_noisy_v']:.3f} / {1e3 * r['rmse_true_v']:.3f} mV, "
        f"{r['fit_s']:.2f} s{extra}, {fmt_params(r)}",
        flush=True,
    )


def table(rows):
    lines = [
        "| record | tool | model | free par. | RMSE vs noisy (mV) | RMSE vs true (mV) | fitted parameters | fit time (s) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if r.get("error"):
            lines.append(
                f"| {r['record']} | {r['tool']} | {r['model']} | {r.get('free_parameters', '')} "
                f"| failed | failed | {r['error'][:120]} | {r['fit_s']:.2f} |"
            )
            continue
        lines.append(
            f"| {r['record']} | {r['tool']} | {r['model']} | {r['free_parameters']} "
            f"| {1e3 * r['rmse_noisy_v']:.2f} | {1e3 * r['rmse_true_v']:.2f} "
            f"| {fmt_params(r)} | {r['fit_s']:.2f} |"
        )
    return "\n".join(lines)


def plot(rows, records, out_png):
    """Free-run error against the DFN voltage: one panel per model and record."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kinds = []
    for r in rows:
        if r.get("plot_key") and r["plot_key"] not in kinds:
            kinds.append(r["plot_key"])
    colors = {"1 RC": "tab:orange", "2 RC": "tab:red", "linear": "tab:blue",
              "butler-volmer": "tab:green"}
    n, m = len(kinds), len(records)
    fig, axes = plt.subplots(n + 1, m, figsize=(6.5 * m, 1.6 + 1.9 * n), sharex=True,
                             squeeze=False,
                             gridspec_kw={"height_ratios": [0.8] + [1.0] * n})
    for j, rec in enumerate(records):
        ax = axes[0, j]
        ax.plot(rec["time_s"], rec["current_a"], color="0.3", lw=0.5)
        ax.set_title(f"{rec['name']}: current (+ = charge)", fontsize=9)
        if j == 0:
            ax.set_ylabel("A")
        for i, k in enumerate(kinds, start=1):
            ax = axes[i, j]
            ax.axhspan(-1, 1, color="0.8", zorder=0)
            ax.axhline(0, color="k", lw=0.4)
            if j == 0:
                ax.set_ylabel("model − DFN (mV)")
            found = [r for r in rows if r["record"] == rec["name"] and r.get("plot_key") == k]
            if not found or found[0].get("error"):
                ax.set_title(f"{k}: not run or failed", fontsize=9)
                continue
            r = found[0]
            label = k + (f" (chose {r['chosen']})" if r["tool"] == "fracbms" else "")
            shape = r.get("chosen") or r["model"]
            color = next((c for name, c in colors.items() if name in shape), "k")
            ax.plot(rec["time_s"], 1e3 * (r["model_v"] - rec["voltage_true_v"]), color=color, lw=0.5)
            ax.set_title(
                f"{label}: RMSE {1e3 * r['rmse_true_v']:.2f} mV vs DFN, "
                f"{1e3 * r['rmse_noisy_v']:.2f} mV vs noisy",
                fontsize=9,
            )
    # the same voltage scale on every error panel
    errors = [1e3 * (r["model_v"] - rec["voltage_true_v"]) for rec in records for r in rows
              if r["record"] == rec["name"] and r.get("plot_key") and not r.get("error")]
    if errors:
        lo = min(e.min() for e in errors)
        hi = max(e.max() for e in errors)
        pad = 0.05 * (hi - lo)
        for ax in axes[1:].ravel():
            ax.set_ylim(lo - pad, hi + pad)
    lo_i = min(rec["current_a"].min() for rec in records)
    hi_i = max(rec["current_a"].max() for rec in records)
    for ax in axes[0]:
        ax.set_ylim(lo_i - 1, hi_i + 1)
    for j in range(m):
        axes[-1, j].set_xlabel("time (s); grey band: ±1 mV, the noise σ")
    fig.tight_layout()
    out_png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_png, dpi=90)
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--records", default=DEFAULT_RECORDS)
    ap.add_argument("--data-dir", default=str(REPO / "data" / "pybamm"))
    ap.add_argument("--out-dir", default=str(REPO / "docs"))
    ap.add_argument("--max-iterations", type=int, default=None,
                    help="PyBOP optimiser iterations (default: 200 for L-BFGS-B, 1000 for CMA-ES)")
    ap.add_argument("--cmaes-records", default="chen2020-drive",
                    help="records also fitted by CMA-ES (comma separated, 'all', '' for none)")
    ap.add_argument("--seed", type=int, default=1, help="seed of CMA-ES")
    ap.add_argument("--rc", default="1,2", help="RC pairs of the Thevenin fits")
    ap.add_argument("--no-check", action="store_true", help="skip the numpy reference fits")
    ap.add_argument("--json", help="also write the results (without time series) here")
    args = ap.parse_args()

    import pybamm
    import pybop

    t_start = time.perf_counter()
    versions = {
        "python": platform.python_version(),
        "pybop": pybop.__version__,
        "pybamm": pybamm.__version__,
        "numpy": np.__version__,
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, "
        f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}",
    }
    print(json.dumps(versions))
    try:
        import fracbms  # noqa: F401

        print("fracbms: the Python package", getattr(fracbms, "__version__", ""))
    except ImportError:
        print(f"fracbms: package not importable, using the CLI {host_sim_path()}")

    records = [load_record(n.strip(), args.data_dir) for n in args.records.split(",") if n.strip()]
    rows, checks = [], {}
    for rec in records:
        optimizers = ["lbfgsb"]
        if args.cmaes_records == "all" or rec["name"] in args.cmaes_records.split(","):
            optimizers.append("cmaes")
        for n_rc in [int(k) for k in args.rc.split(",")]:
            for optimizer in optimizers:
                r = fit_pybop(rec, n_rc, optimizer, args.max_iterations, args.seed)
                r["record"] = rec["name"]
                if optimizer == "lbfgsb":
                    r["plot_key"] = f"PyBOP Thevenin {n_rc} RC (L-BFGS-B)"
                rows.append(r)
                print_row(r)
            if not args.no_check:
                c = {
                    "without_offset": fit_numpy(rec, n_rc),
                    "with_offset": fit_numpy(rec, n_rc, with_offset=True),
                }
                checks[f"{rec['name']} {n_rc} RC"] = c
                print(
                    f"   numpy check, {n_rc} RC: best {1e3 * c['without_offset']['rmse_noisy_v']:.3f} mV "
                    f"(with ΔU {1e3 * c['with_offset']['rmse_noisy_v']:.3f} mV, "
                    f"ΔU {1e3 * c['with_offset']['offset_v']:.2f} mV)",
                    flush=True,
                )
        for model in ["auto", "linear"]:
            r = fit_fracbms(rec, model)
            r["record"] = rec["name"]
            r["plot_key"] = f"fracbms --model {model}"
            rows.append(r)
            print_row(r)

    print()
    print(table(rows))
    out_png = Path(args.out_dir) / "pybop" / "side_by_side.png"
    plot(rows, records, out_png)
    print(f"\nwrote {out_png}")
    total = time.perf_counter() - t_start
    print(f"total {total:.0f} s")
    if args.json:
        clean = [{k: v for k, v in r.items() if k not in ("model_v", "plot_key")} for r in rows]
        Path(args.json).write_text(
            json.dumps({"versions": versions, "rows": clean, "checks": checks, "total_s": total},
                       indent=2, default=float)
        )


if __name__ == "__main__":
    sys.exit(main())
