#!/usr/bin/env python3
"""Physics-grade test records: PyBaMM's Doyle-Fuller-Newman (DFN) model.

The estimator is judged on data its own model did not make. This script
simulates DFN cells with PyBaMM and writes small CSV files that the tests,
the docs and CI use without PyBaMM:

* two chemistries: ``Chen2020`` (LG M50, NMC811/graphite, a steep OCV) and
  ``Prada2013`` (A123-like LFP/graphite, a flat OCV plateau: the hard case);
* two profiles each, sampled every second: ``drive`` (3000 s, a synthetic
  drive cycle with city, highway and regenerative braking, SOC 0.90 -> about
  0.70) and ``hppc`` (hybrid pulse power characterization blocks of 10 s 2C
  discharge and 10 s 1.5C charge pulses with rests, walking the SOC from
  0.90 down by 5 % per block to about 0.40);
* a third profile, ``soc`` (issue 36, the SOC observer): 15 min at rest,
  then four rounds of 25 min of the drive cycle (a mean of 0.3C) and
  15 min at rest, SOC 0.90 -> about 0.40 in 10 560 s; rests longer than
  ten minutes, as a parked car's;
* each record starts with 60 s at rest from equilibrium, so its first
  voltages are the OCV (the start SOC can be read from the OCV table);
* exact zero-order hold: the current is a PyBaMM input parameter and the
  model is advanced by one ``Simulation.step`` of one sample period per
  sample; row ``l`` holds the current applied over ``(t_l - h, t_l]`` and the
  terminal voltage at ``t_l`` (the end of that interval);
* sign convention of the CSV files: current **positive when charging**
  (PyBaMM's "Current function [A]" is positive on discharge: flipped);
* Gaussian voltage noise sigma = 1 mV (fixed seed) in ``voltage_v``; the
  noise-free voltage in ``voltage_true_v``; ``soc_true`` is the SOC after the
  row, counted with the cell's capacity ``C`` below;
* the OCV tables ``<cell>-ocv.csv`` (``soc,ocv_v``, 101 points): PyBaMM's
  own equilibrium voltage, ``U_p(y(z)) - U_n(x(z))`` at the stoichiometries
  that PyBaMM's ``initial_soc`` maps SOC ``z`` to (linear between the
  0 % and 100 % stoichiometries of its electrode-SOH solver);
* ``C`` is the capacity that this SOC axis implies, ``Q_n * (x_100 - x_0)``
  (5.153 A h for Chen2020 against a nominal 5.0, 2.303 A h for Prada2013):
  with it, coulomb counting and PyBaMM's SOC agree.

Usage (PyBaMM pinned; about 6 minutes on one core)::

    python3 -m venv .venv-pybamm
    .venv-pybamm/bin/pip install pybamm==26.10.1.1
    .venv-pybamm/bin/python bench/pybamm_data.py --out data/pybamm
"""

import argparse
import inspect
import json
import math
import time
from pathlib import Path

import numpy as np
import pybamm

PYBAMM_VERSION = "26.10.1.1"
SIGMA_V = 0.001
SOC0 = 0.9
REST_S = 60
CELLS = {"chen2020": "Chen2020", "prada2013": "Prada2013"}


def capacity_ah(pv):
    """Capacity between PyBaMM's 0 % and 100 % SOC (A h), and the
    stoichiometry map z -> (x, y)."""
    x0, y0 = pybamm.lithium_ion.get_initial_stoichiometries(0.0, pv)
    x1, y1 = pybamm.lithium_ion.get_initial_stoichiometries(1.0, pv)
    area = pv["Electrode height [m]"] * pv["Electrode width [m]"]
    q_n = (
        96485.33212
        * pv["Negative electrode active material volume fraction"]
        * pv["Maximum concentration in negative electrode [mol.m-3]"]
        * pv["Negative electrode thickness [m]"]
        * area
        / 3600.0
    )
    return q_n * (x1 - x0), (x0, x1, y0, y1)


def _ocp(f, sto, t_ref):
    """An open-circuit potential function of the parameter set, called with
    the stoichiometry (and the temperature where it takes one)."""
    if len(inspect.signature(f).parameters) == 1:
        return f(pybamm.Scalar(sto))
    return f(pybamm.Scalar(sto), pybamm.Scalar(t_ref))


def ocv_table(pv, sto):
    """OCV (V) at SOC 0, 0.01, ..., 1 from the electrodes' open-circuit
    potentials at the reference temperature."""
    x0, x1, y0, y1 = sto
    t_ref = pv["Reference temperature [K]"]
    soc = np.linspace(0.0, 1.0, 101)
    ocv = []
    for z in soc:
        x = x0 + z * (x1 - x0)
        y = y0 + z * (y1 - y0)
        up = pv.evaluate(_ocp(pv["Positive electrode OCP [V]"], y, t_ref))
        un = pv.evaluate(_ocp(pv["Negative electrode OCP [V]"], x, t_ref))
        ocv.append(float(up) - float(un))
    return soc, np.array(ocv)


def drive_current(length, c_ah, rng):
    """A synthetic drive cycle (A, positive charging): a speed trace of city
    stops and starts, a highway section and braking; the current follows
    the road power (rolling, aerodynamic, acceleration), regeneration
    clipped at 1C, then scaled so that the mean discharge takes the SOC
    from 0.90 to 0.70 over the record."""
    v = np.zeros(length)
    t = 0
    speed = 0.0
    phase = 0
    while t < length:
        # City (stop-and-go), highway, city again.
        highway = length // 3 <= t < 2 * length // 3
        target = rng.uniform(22.0, 33.0) if highway else rng.uniform(6.0, 16.0)
        accel = rng.uniform(0.8, 2.5)
        while speed < target and t < length:
            speed = min(target, speed + accel)
            v[t] = speed
            t += 1
        cruise = int(rng.uniform(60, 180) if highway else rng.uniform(8, 40))
        for _ in range(cruise):
            if t >= length:
                break
            speed = max(0.0, speed + rng.normal(0.0, 0.4))
            v[t] = speed
            t += 1
        if not highway or phase % 3 == 2:
            brake = rng.uniform(1.0, 3.0)
            while speed > 0 and t < length:
                speed = max(0.0, speed - brake)
                v[t] = speed
                t += 1
            for _ in range(int(rng.uniform(3, 15))):
                if t >= length:
                    break
                v[t] = 0.0
                t += 1
        phase += 1
    dv = np.diff(v, prepend=0.0)
    power = 1.2 * dv * v + 0.012 * v + 0.0004 * v**3  # arbitrary units
    current = -power
    current = np.minimum(current, 0.35 * np.max(-current))  # regeneration limit
    # Scale: mean discharge for 0.2 of the capacity over the record; then
    # clip the regeneration at 1C and the discharge at 3C.
    target_mean = -0.2 * c_ah * 3600.0 / length
    current *= target_mean / current.mean()
    current = np.clip(current, -3.0 * c_ah, 1.0 * c_ah)
    current *= target_mean / current.mean()
    return current


def hppc_current(c_ah, blocks=10):
    """HPPC blocks: 10 s at 2C discharge, 40 s rest, 10 s at 1.5C charge,
    40 s rest, 180 s at 1C discharge (5 % SOC), 300 s rest."""
    block = (
        [-2.0 * c_ah] * 10
        + [0.0] * 40
        + [1.5 * c_ah] * 10
        + [0.0] * 40
        + [-1.0 * c_ah] * 180
        + [0.0] * 300
    )
    return np.array(block * blocks)


def soc_current(c_ah, rng):
    """The ``soc`` profile after the leading rest: 900 s at rest, then four
    rounds of 1500 s of drive cycle (mean 0.3C discharge) and 900 s at rest."""
    parts = [np.zeros(900 - REST_S)]
    for _ in range(4):
        d = drive_current(1500, c_ah, rng)
        d *= (-0.3 * c_ah) / d.mean()
        parts += [np.clip(d, -3.0 * c_ah, 1.0 * c_ah), np.zeros(900)]
    return np.concatenate(parts)


def dfn_simulation(param_set, initial_soc):
    """A built DFN simulation whose current is an input, for stepping
    (``step``)."""
    pv = pybamm.ParameterValues(param_set)
    pv["Current function [A]"] = "[input]"
    # The cut-off voltages are events that stop the solver: 1C regeneration
    # at 90 % SOC briefly exceeds Chen2020's 4.2 V, which a real pack's
    # charger limit would allow for a second. Widened so that no step stops.
    pv["Upper voltage cut-off [V]"] = 4.5
    pv["Lower voltage cut-off [V]"] = 2.0
    model = pybamm.lithium_ion.DFN()
    sim = pybamm.Simulation(model, parameter_values=pv, solver=pybamm.IDAKLUSolver())
    sim.build(initial_soc=initial_soc)
    return sim


def step(sim, current_charge_positive, start=None):
    """One 1 s zero-order-hold step of `sim` at a current (A, charge
    positive), from `start` (a solution; None: where the simulation is)."""
    return sim.step(dt=1.0, npts=2, inputs={"Current function [A]": -float(current_charge_positive)},
                    save=False, starting_solution=start)


def simulate(param_set, current_charge_positive, initial_soc):
    """Terminal voltage after each 1 s zero-order-hold step."""
    sim = dfn_simulation(param_set, initial_soc)
    out = np.empty(len(current_charge_positive))
    for k, i in enumerate(current_charge_positive):
        out[k] = step(sim, i)["Voltage [V]"].entries[-1]
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("data/pybamm"))
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--profiles", default="drive,hppc,soc",
                    help="the profiles to make (the others' files and meta entries are kept)")
    a = ap.parse_args()
    profiles = a.profiles.split(",")
    if pybamm.__version__ != PYBAMM_VERSION:
        print(f"note: pybamm {pybamm.__version__}, the files were made with {PYBAMM_VERSION}")
    a.out.mkdir(parents=True, exist_ok=True)
    meta = {"pybamm": pybamm.__version__, "sigma_v": SIGMA_V, "records": {}, "ocv": {}}
    if (a.out / "meta.json").exists():
        meta = json.load(open(a.out / "meta.json"))
    for short, name in CELLS.items():
        pv = pybamm.ParameterValues(name)
        c_ah, sto = capacity_ah(pv)
        soc, ocv = ocv_table(pv, sto)
        bad = np.nonzero(np.diff(ocv) <= 0)[0]
        if len(bad):
            raise SystemExit(f"{name}: the OCV does not increase after SOC {soc[bad]}")
        with open(a.out / f"{short}-ocv.csv", "w") as f:
            f.write("soc,ocv_v\n")
            for z, v in zip(soc, ocv):
                f.write(f"{z:.2f},{v:.6f}\n")
        meta["ocv"][short] = {
            "parameter_set": name,
            "capacity_ah": c_ah,
            "nominal_capacity_ah": pv["Nominal cell capacity [A.h]"],
            "points": len(soc),
            "plateau_slope_v_per_soc_min": float(np.min(np.diff(ocv) / np.diff(soc))),
        }
        for profile in profiles:
            rng = np.random.default_rng(a.seed)
            body = {
                "drive": lambda: drive_current(3000 - REST_S, c_ah, rng),
                "hppc": lambda: hppc_current(c_ah),
                "soc": lambda: soc_current(c_ah, rng),
            }[profile]()
            current = np.concatenate([np.zeros(REST_S), body])
            t0 = time.time()
            v_true = simulate(name, current, SOC0)
            secs = time.time() - t0
            noise = np.random.default_rng(a.seed + 1).normal(0.0, SIGMA_V, len(current))
            v = v_true + noise
            soc_true = SOC0 + np.cumsum(current) / (3600.0 * c_ah)
            path = a.out / f"{short}-{profile}.csv"
            with open(path, "w") as f:
                f.write("time_s,current_a,voltage_v,voltage_true_v,soc_true\n")
                for k in range(len(current)):
                    f.write(
                        f"{k},{current[k]:.6f},{v[k]:.6f},{v_true[k]:.6f},{soc_true[k]:.6f}\n"
                    )
            rest_err = float(v_true[REST_S - 1] - np.interp(SOC0, soc, ocv))
            meta["records"][f"{short}-{profile}"] = {
                "parameter_set": name,
                "capacity_ah": c_ah,
                "soc0": SOC0,
                "soc_end": float(soc_true[-1]),
                "rows": len(current),
                "sigma_v": SIGMA_V,
                "seed": a.seed,
                "current_min_a": float(current.min()),
                "current_max_a": float(current.max()),
                "rest_voltage_minus_table_v": rest_err,
                "simulation_s": round(secs, 1),
            }
            print(
                f"{path}: {len(current)} rows, I {current.min():.2f}..{current.max():.2f} A, "
                f"V {v_true.min():.3f}..{v_true.max():.3f} V, SOC {SOC0} -> {soc_true[-1]:.3f}, "
                f"rest V - table {1e3 * rest_err:.3f} mV, noise rms "
                f"{1e3 * math.sqrt(np.mean((v - v_true) ** 2)):.3f} mV, {secs:.0f} s"
            )
    with open(a.out / "meta.json", "w") as f:
        json.dump(meta, f, indent=2)
        f.write("\n")


if __name__ == "__main__":
    main()
