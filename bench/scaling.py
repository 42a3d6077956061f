#!/usr/bin/env python3
"""Whole-record fit time against record length: ours against a scipy FFT
reference, same model, same rows, same RMSE (docs/performance.md, issue 34).

Records of 1k, 8k, 50k and 200k rows at 1 s are made here from a
continuous-time-like pulse profile (random pulse levels and lengths,
rests between them) through the constant-phase model with FULL memory
(``reference_fit.cpe_branch``) plus, for the Butler-Volmer rows, the static
term ``a asinh(I/i0)``, and 1 mV of Gaussian noise. Each record is fitted

* by ours, one start: ``fracbms-host``'s example ``refine_once`` (one
  refinement from the start below to convergence, the same
  ``refine_from_start`` every start of ``identify battery`` runs), timed
  inside the process (not the CSV reading);
* by ours, the whole command: ``host-sim identify battery --model
  linear|butler-volmer`` (reading, the paper's regression for a start,
  every refinement start, the Butler-Volmer starts and the choice, the
  intervals, the JSON), timed as a process;
* by ours, the whole fit in this process: the Python package's
  ``fracbms.identify_battery(time_s, current_a, voltage_v, model=...)``, the
  same fit as the command on the same arrays the reference takes (the
  record put on its period, every start, the choice, the intervals, the
  dict), timed as the reference is, in this process; left out (``—``) when
  ``fracbms`` is not installed (``pip install ./python``);
* by the reference: one ``scipy.optimize.least_squares`` fit of the same
  model (the branch by FFT, ``reference_fit.cpe_branch``, O(n log n)) from
  one start, the rough even split ours also tries (alpha 0.7, tau^alpha =
  5 s^alpha, R_i = R_ct = R/2 with R the slope of V on I, U_oc the line's
  intercept: ``rough_starts``), parameters in logarithms as ours.

Then ours, one start, the whole command and the reference on a measured
record (``measured``: the Panasonic HPPC export's overpotential, as
``identify battery --ocv`` fitted it), with the whole command on the
export itself beside them (the Python face has no ``--voltage-min``, and
the overpotential lies below its plausible-voltage floor).

Each prints the free-run RMSE; the ratio of times is theirs over ours in
the same run: one start against one start, and the whole command and the
whole fit in this process against the one start of the reference. The
command also starts a process and reads the CSV, and its memory is new to
it on every run, where the reference's and the in-process fit's are the
warm process's. One core for all: ours under ``taskset -c 0`` (when
present), the reference and the Python face in this process, pinned to the same
core and with OpenBLAS on one thread (set before numpy loads;
``--reference-unpinned`` leaves OpenBLAS's threads to the machine, to
see what that does to the reference). Run it alone. On every record
each fit runs ``--repeat`` times (default 5), in turn, and the medians
are quoted (about 4 minutes).

    cargo build --release -p host-sim
    cargo build --release -p fracbms-host --example refine_once
    pip install ./python      # for the fit in this process (optional)
    python3 bench/scaling.py [--rows 1000,8000,50000,200000] [--out target/scaling]
        [--host-sim target/release/host-sim] [--models linear,butler-volmer] [--repeat 5]
        [--reference-unpinned]
"""

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import time

# The reference on one core, as ours: OpenBLAS's threads are fixed when
# numpy loads, so this comes first (before the arguments are parsed).
if "--reference-unpinned" not in sys.argv:
    for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_var, "1")
    if hasattr(os, "sched_setaffinity") and shutil.which("taskset"):
        os.sched_setaffinity(0, {0})

import numpy as np  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from reference_fit import bv, cpe_branch  # noqa: E402

H = 1.0
TRUTH = dict(r_i=0.020, r_ct=0.015, q=8.0 / 0.015, alpha=0.75, u_oc=3.7)
BV = dict(a=0.01, i0=1.0)


def record(n, seed, kinetic):
    """Current and voltage of n rows: pulses of -5..5 A lasting 5-200 s,
    each followed by a rest of 10-600 s half of the time."""
    rng = np.random.default_rng(seed)
    i = np.zeros(n)
    k = 0
    while k < n:
        length = int(rng.integers(5, 200))
        i[k:k + length] = rng.uniform(-5.0, 5.0)
        k += length
        if rng.random() < 0.5:
            k += int(rng.integers(10, 600))
    t = TRUTH
    v = t["u_oc"] + t["r_i"] * i + cpe_branch(i, H, t["r_ct"], t["q"], t["alpha"])
    if kinetic:
        v = v + bv(i, BV["a"], BV["i0"])
    return i, v + rng.normal(0.0, 1e-3, n)


def filled(v):
    """v with its NaN (unobserved samples) filled by the straight line
    between measured neighbours, as ours fills them for its starts."""
    ok = np.isfinite(v)
    return np.interp(np.arange(len(v)), np.flatnonzero(ok), v[ok])


def start(i, v):
    """The rough even-split start (fracbms-host's rough_starts, first)."""
    v = filled(v)
    r = max(abs(np.polyfit(i, v, 1)[0]), 1e-5)
    q = 5.0 / (r / 2.0)
    u_oc = float(np.mean(v) - r * np.mean(i))
    return [math.log(r / 2.0), math.log(r / 2.0), math.log(q), 0.7, u_oc]


def reference(i, v, kinetic, h=H):
    """One least-squares fit from the rough start over the samples with a
    voltage (a NaN is one not observed, as ours leaves it out); (seconds,
    rmse, result)."""
    t0 = time.perf_counter()
    seen = np.isfinite(v)
    x0 = start(i, v)
    if kinetic:
        r_i = math.exp(x0[0])
        i_max = float(np.max(np.abs(i)))
        # ln R_i, ln R_ct, ln Q, alpha, U_oc, ln a, ln i0; i0 = 0.3 I_max
        # (ours tries 0.1, 0.3 and 1).
        i0 = 0.3 * i_max
        x0 = x0 + [math.log(i0 * r_i / 2.0), math.log(i0)]

    def model(p):
        r_i, r_ct, q = math.exp(p[0]), math.exp(p[1]), math.exp(p[2])
        y = p[4] + r_i * i + cpe_branch(i, h, r_ct, q, p[3])
        if kinetic:
            y = y + bv(i, math.exp(p[5]), math.exp(p[6]))
        return (y - v)[seen]

    lo = [-20, -20, -20, 0.05, -np.inf] + ([-20, -10] if kinetic else [])
    hi = [5, 5, 30, 1.0, np.inf] + ([5, 10] if kinetic else [])
    x0[3] = min(x0[3], 0.999)
    res = least_squares(model, x0, bounds=(lo, hi), max_nfev=200)
    return time.perf_counter() - t0, math.sqrt(np.mean(res.fun**2)), res


def ours(host_sim, path, model, out_json, extra=()):
    cmd = [host_sim, "identify", "battery", "--input", path, "--model", model,
           "--json", out_json, *extra]
    if shutil.which("taskset"):
        cmd = ["taskset", "-c", "0"] + cmd
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)}: {p.stderr.strip()}")
    j = json.load(open(out_json))
    return dt, j["rmse_v"], j


def one_start(example, path, model):
    cmd = [example, path, model]
    if shutil.which("taskset"):
        cmd = ["taskset", "-c", "0"] + cmd
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)}: {p.stderr.strip()}")
    return json.loads(p.stdout)


PANASONIC = "data/panasonic-18650pf"
PANASONIC_C20 = f"{PANASONIC}/05-08-17_13.26 C20 OCV Test_C20_25dC.mat"
PANASONIC_HPPC = f"{PANASONIC}/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat"


def measured(a):
    """The measured row: the Panasonic 25 °C HPPC export in data/ (27 h,
    resampled at 2 s: 48 800 samples, 13 gaps). ``identify battery --ocv``
    on the export as it comes (timed as a process: the MAT file's reading,
    the resampling and the OCV included) writes with ``--fit-out`` the OCV
    it took away and which samples it fitted; the overpotential
    ``voltage_v - ocv_v`` of those samples (NaN elsewhere) is then the record
    all three fit: ours one start, ours the whole command, the scipy
    reference one start, the same linear model with its offset."""
    hs = a.host_sim
    taskset = ["taskset", "-c", "0"] if shutil.which("taskset") else []
    ocv = os.path.join(a.out, "panasonic-ocv.csv")
    subprocess.run([hs, "ocv", "--input", PANASONIC_C20, "--from", "low-rate", "--out", ocv],
                   check=True, capture_output=True)
    fit_csv = os.path.join(a.out, "panasonic-fit.csv")
    cmd = taskset + [hs, "identify", "battery", "--input", PANASONIC_HPPC, "--ocv", ocv,
                     "--capacity-ah", "2.9", "--model", "linear", "--fit-out", fit_csv,
                     "--json", fit_csv + ".json"]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True)
    t_export = time.perf_counter() - t0
    r = np.genfromtxt(fit_csv, delimiter=",", names=True)
    i = r["current_a"]
    y = np.where(r["fitted"] > 0.5, r["voltage_v"] - r["ocv_v"], np.nan)
    path = os.path.join(a.out, "panasonic-overpotential.csv")
    with open(path, "w") as f:
        f.write("time_s,current_a,voltage_v\n")
        for t, c, v in zip(r["time_s"], i, y):
            f.write(f"{t:.9g},{c:.9g},{'nan' if np.isnan(v) else format(v, '.9g')}\n")
    # Each of the three timed --repeat times, in turn, and the median of
    # each taken: a single run of a quarter-second process varies by up to
    # half from one run to the next on a shared machine.
    repeat = max(1, a.repeat)
    ones, commands, refs = [], [], []
    for _ in range(repeat):
        ones.append(one_start(a.refine_once, path, "linear"))
        # The overpotential is near 0 V: the plausible-voltage floor off.
        commands.append(ours(hs, path, "linear", path + ".json", extra=["--voltage-min=-5"]))
        refs.append(reference(i, y, False, h=float(r["time_s"][1] - r["time_s"][0])))
    one = dict(ones[0], seconds=float(np.median([o["seconds"] for o in ones])))
    # The fits are deterministic: the first run's RMSE and parameters
    # stand for all.
    _, rmse_ours, j = commands[0]
    t_ours = float(np.median([c[0] for c in commands]))
    _, rmse_ref, res = refs[0]
    t_ref = float(np.median([f[0] for f in refs]))
    print()
    print("| record | samples fitted | ours, one start (s) | scipy, one start (s) | ours faster | "
          "ours, whole command (s) | ours faster | ours, whole command on the export (s) | "
          "RMSE ours, one start / whole / ref. (mV) | α ours / ref. |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    print(f"| Panasonic 25 °C HPPC | {int(np.isfinite(y).sum())} | {one['seconds']:.3f} | {t_ref:.3f} | "
          f"{t_ref / one['seconds']:.1f}× | {t_ours:.2f} | {t_ref / t_ours:.1f}× | {t_export:.2f} | "
          f"{1e3 * one['rmse_v']:.6f} / {1e3 * rmse_ours:.6f} / {1e3 * rmse_ref:.6f} | "
          f"{j['alpha']:.4f} / {res.x[3]:.4f} |", flush=True)
    return dict(record="panasonic-25degC-hppc", repeat=repeat,
                ours_one_start_s=one["seconds"],
                ours_one_start_iterations=one["iterations"], ours_command_s=t_ours,
                ours_export_command_s=t_export, reference_s=t_ref,
                reference_nfev=int(res.nfev), rmse_one_start_v=one["rmse_v"],
                rmse_ours_v=rmse_ours, rmse_reference_v=rmse_ref)


def in_process(rows, model):
    """The whole fit in this process through the Python package, on the
    columns of the command's CSV (``rows``: time, current, voltage, as
    written); (seconds, rmse) or None without ``fracbms``."""
    try:
        import fracbms
    except ImportError:
        return None
    t0 = time.perf_counter()
    r = fracbms.identify_battery(rows[:, 0], rows[:, 1], rows[:, 2], model=model)
    return time.perf_counter() - t0, r["rmse_v"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rows", default="1000,8000,50000,200000")
    ap.add_argument("--models", default="linear,butler-volmer")
    ap.add_argument("--out", default="target/scaling")
    ap.add_argument("--host-sim", default="target/release/host-sim")
    ap.add_argument("--refine-once", default="target/release/examples/refine_once")
    ap.add_argument("--skip-reference-above", type=int, default=10**9,
                    help="rows above which the scipy reference is not run")
    ap.add_argument("--repeat", type=int, default=5,
                    help="runs of each fit on each record, in turn; the median time is quoted")
    ap.add_argument("--no-measured", action="store_true",
                    help="leave out the measured record (the Panasonic HPPC test)")
    ap.add_argument("--reference-unpinned", action="store_true",
                    help="OpenBLAS's threads left to the machine (read before numpy "
                    "loads; the script's own thread still on core 0)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    if shutil.which("taskset"):
        os.sched_setaffinity(0, {0})
    print("| rows | model | ours, one start (s) | scipy, one start (s) | ours faster | ours, whole command (s) | ours faster | ours, whole fit in this process (s) | ours faster | RMSE ours, one start / whole / ref. (mV) | α ours / ref. |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    rows = []
    for n in (int(x) for x in a.rows.split(",")):
        for model in a.models.split(","):
            kinetic = model == "butler-volmer"
            i, v = record(n, seed=n, kinetic=kinetic)
            path = os.path.join(a.out, f"{model}-{n}.csv")
            t = np.arange(n) * H
            np.savetxt(path, np.column_stack([t, i, v]), delimiter=",",
                       header="time_s,current_a,voltage_v", comments="", fmt="%.9g")
            written = np.loadtxt(path, delimiter=",", skiprows=1)
            # Each of the four fits `--repeat` times, in turn; medians.
            ones, commands, refs, inside = [], [], [], []
            for _ in range(max(1, a.repeat)):
                ones.append(one_start(a.refine_once, path, model))
                commands.append(ours(a.host_sim, path, model, path + ".json"))
                inside.append(in_process(written, model))
                if n <= a.skip_reference_above:
                    refs.append(reference(i, v, kinetic))
            t_in = None if inside[0] is None else float(np.median([f[0] for f in inside]))
            if t_in is not None and abs(inside[0][1] / commands[0][1] - 1.0) > 1e-9:
                raise SystemExit(f"{path}: the fit in this process ends at RMSE {inside[0][1]} V, "
                                 f"the command at {commands[0][1]} V")
            one = dict(ones[0], seconds=float(np.median([o["seconds"] for o in ones])))
            _, rmse_ours, j = commands[0]
            t_ours = float(np.median([c[0] for c in commands]))
            if refs:
                _, rmse_ref, res = refs[0]
                t_ref = float(np.median([f[0] for f in refs]))
                alpha_ref = res.x[3]
                r1 = f"{t_ref / one['seconds']:.1f}×"
                r2 = f"{t_ref / t_ours:.1f}×"
                r3 = "—" if t_in is None else f"{t_ref / t_in:.1f}×"
                ref_s, ref_r = f"{t_ref:.3f}", f"{1e3 * rmse_ref:.4f}"
                al = f"{j['alpha']:.4f} / {alpha_ref:.4f}"
            else:
                t_ref = rmse_ref = None
                r1 = r2 = r3 = ref_s = ref_r = "—"
                al = f"{j['alpha']:.4f} / —"
            s_in = "—" if t_in is None else f"{t_in:.2f}"
            print(f"| {n} | {model} | {one['seconds']:.3f} | {ref_s} | {r1} | {t_ours:.2f} | {r2} | "
                  f"{s_in} | {r3} | "
                  f"{1e3 * one['rmse_v']:.4f} / {1e3 * rmse_ours:.4f} / {ref_r} | {al} |", flush=True)
            rows.append(dict(rows=n, model=model, ours_one_start_s=one["seconds"],
                             ours_one_start_iterations=one["iterations"], ours_command_s=t_ours,
                             ours_in_process_s=t_in,
                             reference_s=t_ref, reference_nfev=None if t_ref is None else int(res.nfev),
                             rmse_one_start_v=one["rmse_v"], rmse_ours_v=rmse_ours,
                             rmse_reference_v=rmse_ref))
    if not a.no_measured:
        rows.append(measured(a))
    json.dump(rows, open(os.path.join(a.out, "scaling.json"), "w"), indent=1)


if __name__ == "__main__":
    main()
