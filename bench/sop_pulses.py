#!/usr/bin/env python3
"""State of power on a measured cell (issue 36): at every discharge pulse
of the Panasonic 18650PF 25 degC HPPC test, the `pulse_v_{H}s` that
`online battery` published at the last sample before the pulse (no prior,
window 256, its OCV table, `--pulse-current-a` the pulse's own current)
against the measured voltage H seconds into the pulse (the raw 0.1 s
data). Pulses shorter than H are left out.

Beside it, an integer-order 1 RC model (R0, R1, tau, the OCV offset and
the branch's start value) identified by least squares on the 1800 s of
data before each pulse (the previous pulse and its relaxation: the test
rests 20 min between pulses, longer than our window of 256 samples at 2 s
reaches; the raw ~1 s log, so it sees more samples than ours), through the
same OCV table and the same counted SOC (the track's `soc_coulomb`), then
run forward with the pulse's current: exact for a 1 RC branch (zero-order
hold). tau is searched on a log grid from 1 to 2000 s (the linear
parameters solved at each) and refined by a bounded scalar search. A span
whose current barely moves (std below 10 mA) identifies nothing: no
prediction, as ours publishes none.

With ``--prior MAP`` (the map of bench/panasonic_chain.sh, made from this
same HPPC test: a best case for a characterized cell), ours also runs with
that map as the prior. Each line adds the pulses whose published SOC is at
least 0.2 (below it the cell's resistance climbs within a level).

    cargo build --release -p host-sim
    bash bench/panasonic_chain.sh          # target/real-cells/panasonic/ocv.csv, map.csv
    python3 bench/sop_pulses.py [--host-sim target/release/host-sim] [--out target/sop] \
        [--prior target/real-cells/panasonic/map.csv] [--butler-volmer]
    python3 bench/sop_pulses.py --resistances    # each pulse's measured resistance only, and
                                                 # how it moves with the current, per level
    python3 bench/sop_pulses.py --acceptance     # every HPPC record, second pulse group on,
                                                 # beside the last pulse's drop and a 1 RC fit:
                                                 # the Panasonic tests at 25 and 10 degC (2 s,
                                                 # 10 s) and the DFN HPPC records of
                                                 # data/pybamm (10 s, 30 s)
    python3 bench/sop_pulses.py --acceptance --worst 8   # and each row's 8 largest misses
"""

import argparse
import csv
import json
import os
import subprocess

import numpy as np
import scipy.io as sio
from scipy.optimize import minimize_scalar

PANASONIC = "data/panasonic-18650pf/03-11-17_08.47 25degC_5Pulse_HPPC_Pan18650PF.mat"
PAN_OCV = "target/real-cells/panasonic/ocv.csv"
HORIZONS = (2, 10)
SPAN_S = 1800.0
CAPACITY_AH = 2.9


def ocv_table(path=PAN_OCV):
    z, u = np.loadtxt(path, delimiter=",", skiprows=1, unpack=True)
    return lambda soc: np.interp(soc, z, u)


def branch(i, dt, tau, u0):
    """The 1 RC branch's unit-resistance response: x[n] with x[0] = u0 and
    x[n+1] = a x[n] + (1 - a) i[n], a = exp(-dt[n]/tau); and the response
    of a start value of 1 alone."""
    a = np.exp(-dt / tau)
    x = np.empty(len(i))
    s = np.empty(len(i))
    x[0], s[0] = u0, 1.0
    for n in range(len(i) - 1):
        x[n + 1] = a[n] * x[n] + (1 - a[n]) * i[n]
        s[n + 1] = a[n] * s[n]
    return x, s


def fit_1rc(t, i, v, ocv_now):
    """Least squares of v - OCV = dU + R0 i + R1 x(tau) + c s(tau) over the
    span; returns (R0, R1, tau, dU, the branch now in volts) or None."""
    if np.std(i) < 0.01:
        return None
    y = v - ocv_now
    dt = np.diff(t, append=t[-1])

    def solve(tau):
        x, s = branch(i, dt, tau, 0.0)
        a = np.column_stack([np.ones_like(i), i, x, s])
        coef, *_ = np.linalg.lstsq(a, y, rcond=None)
        r = y - a @ coef
        return float(r @ r), coef, x, s

    grid = np.geomspace(1.0, 2000.0, 40)
    costs = [solve(tau)[0] for tau in grid]
    k = int(np.argmin(costs))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    tau = minimize_scalar(lambda lt: solve(np.exp(lt))[0], bounds=(np.log(lo), np.log(hi)),
                          method="bounded").x
    tau = float(np.exp(tau))
    _, (du, r0, r1, c), x, s = solve(tau)
    if not (r0 > 0 and r1 > 0):
        return None
    # The branch's voltage after the last sample (its current held for it).
    a = np.exp(-dt[-2] / tau) if len(dt) > 1 else 1.0
    now = r1 * x[-1] + c * s[-1]
    return r0, r1, tau, du, now


def predict_1rc(model, soc_now, ocv, current, h, capacity_ah=CAPACITY_AH):
    r0, r1, tau, du, up = model
    a = np.exp(-h / tau)
    up_h = up * a + r1 * current * (1 - a)
    return ocv(soc_now + current * h / (3600 * capacity_ah)) + du + r0 * current + up_h


def read(path):
    """(time, current, voltage) of a Panasonic MAT export or of a PyBaMM
    record's CSV (`time_s,current_a,voltage_v,…`)."""
    if path.endswith(".csv"):
        d = np.genfromtxt(path, delimiter=",", names=True)
        return d["time_s"], d["current_a"], d["voltage_v"]
    m = sio.loadmat(path)["meas"][0, 0]
    return tuple(m[k].ravel() for k in ("Time", "Current", "Voltage"))


def pulses(path=PANASONIC):
    """(start time, current, length s) of every discharge pulse from rest.
    The current is the median over the pulse's samples after its edge: the
    Panasonic logs' first sample holds part of the edge (−1.39 A where the
    small pulses hold −1.45 A)."""
    t, i, v = read(path)
    # An edge within one sample: the Panasonic logs' 0.1 s, the DFN's 1 s.
    edge = (np.diff(i) < -1.0) & (np.abs(i[:-1]) < 0.05) & (np.diff(t) < (1.01 if path.endswith(".csv") else 0.2))
    out = []
    for j in np.where(edge)[0]:
        e = j + 1
        while e < len(i) and abs(i[e] - i[j + 1]) < 0.2:
            e += 1
        plateau = i[j + 2:e] if e > j + 2 else i[j + 1:e]
        out.append((t[j], float(np.median(plateau)), t[e - 1] - t[j]))
    return out, (t, v)


def current_key(current):
    """The current (A) a pulse's track is asked for and named by: to 10 mA,
    one track per pulse current of these records."""
    return round(current, 2)


def stats(pred, meas, drop):
    if not len(pred):
        return "none"
    err = np.abs(pred - meas)
    rel = err / np.abs(drop)
    return (f"error median {1e3 * np.median(err):.1f} mV, max {1e3 * err.max():.1f} mV; "
            f"of the drop: median {100 * np.median(rel):.1f} %, 90th percentile "
            f"{100 * np.percentile(rel, 90):.1f} %, max {100 * rel.max():.1f} %")


PAN10 = "data/panasonic-18650pf/03-27-17_09.06 10degC_5Pulse_HPPC_Pan18650PF.mat"
# The HPPC records of data/ (Panasonic 18650PF at 25 and 10 degC), each
# with the C/20 OCV table (25 degC: the only one the data set has).
# The HPPC records of the acceptance: the measured ones above, and the
# PyBaMM DFN HPPC records of data/pybamm (each group a 2C 10 s and a 1C
# 180 s discharge, 580 s apart; against the DFN's own pulse): path, OCV
# table, capacity (A h), the gap between pulse starts that opens a new
# group (s), the horizons (s), and `identify battery`'s `--min-rest` for
# the record's own map.
PYBAMM_CAP = {k: v["capacity_ah"] for k, v in json.load(open("data/pybamm/meta.json"))["records"].items()}
RECORD_SPECS = {
    "Panasonic 25 degC HPPC": (PANASONIC, PAN_OCV, CAPACITY_AH, 1500.0, (2, 10), 3000),
    "Panasonic 10 degC HPPC": (PAN10, PAN_OCV, CAPACITY_AH, 1500.0, (2, 10), 3000),
    "DFN Chen2020 HPPC": ("data/pybamm/chen2020-hppc.csv", "data/pybamm/chen2020-ocv.csv",
                          PYBAMM_CAP["chen2020-hppc"], 300.0, (10, 30), 250),
    "DFN Prada2013 HPPC": ("data/pybamm/prada2013-hppc.csv", "data/pybamm/prada2013-ocv.csv",
                           PYBAMM_CAP["prada2013-hppc"], 300.0, (10, 30), 250),
}
RECORDS = {k: v[0] for k, v in RECORD_SPECS.items() if k.startswith("Panasonic")}
GROUP_GAP_S = 1500.0
# The state of power's default derating (`--sop-confidence`).
CONFIDENCE = 2.0


def groups(ps, gap_s=GROUP_GAP_S):
    """Each pulse's group number: a new group after a gap between pulse
    starts longer than gap_s (the test's discharge to the next level)."""
    g, out = 0, []
    for k, (start, _, _) in enumerate(ps):
        if k and start - ps[k - 1][0] > gap_s:
            g += 1
        out.append(g)
    return out


def record_map(host_sim, path, out, method, ocv=PAN_OCV, capacity_ah=CAPACITY_AH, min_rest=3000,
               model="linear"):
    """The record's own parameter map (bench/panasonic_chain.sh's settings,
    `--map-method method`; joint by default: its state of power is the
    closer of the two methods here, docs/bms-states.md)."""
    m = f"{out}/map.csv"
    subprocess.run([host_sim, "identify", "battery", "--input", path, "--ocv", ocv,
                    "--capacity-ah", str(capacity_ah), "--min-rest", str(min_rest), "--model", model,
                    "--map-method", method, "--map-out", m], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return m


def pct(x):
    return f"{100 * x:.1f}"


def record_dir(out, path):
    """Where `--acceptance` writes a record's map and tracks, under `out`."""
    return f"{out}/{os.path.splitext(os.path.basename(path))[0][:14].replace(' ', '_')}"


def pulse_track(out, path, current, variant):
    """The rows of the `--acceptance` run of the record at `path` asked for
    pulses of `current` (A), without a prior (`variant` "none") or with the
    record's own map ("map")."""
    return list(csv.DictReader(open(f"{record_dir(out, path)}/pulse{current_key(current)}-{variant}.csv")))


def row_before(track, start):
    """The index of the track's last row before a pulse that starts at
    `start` (s): the row the state of power for that pulse is read from."""
    tt = np.array([float(r["time_s"]) for r in track])
    return np.searchsorted(tt, start - (tt[1] - tt[0]), side="right") - 1


def pulses_judged(name):
    """Per horizon, the pulses of the record `name` (a key of
    `RECORD_SPECS`) the acceptance judges: from its second group on and at
    least a horizon long, as `(h, start, current)`."""
    path, _, _, gap_s, horizons, _ = RECORD_SPECS[name]
    ps, _ = pulses(path)
    g = groups(ps, gap_s)
    for h in horizons:
        for j, (start, cur, length) in enumerate(ps):
            if g[j] != 0 and length >= h:
                yield h, start, cur


def rows_before_pulses(out, name, variant):
    """Per pulse of `pulses_judged(name)`: `(h, start, current, row)`, the
    row of the record's `--acceptance` track under `out` (without a prior,
    `variant` "none", or with its own map, "map") that the pulse's state of
    power is read from. Each track is read once."""
    path = RECORD_SPECS[name][0]
    tracks = {}
    for h, start, cur in pulses_judged(name):
        c = current_key(cur)
        if c not in tracks:
            tracks[c] = pulse_track(out, path, cur, variant)
        yield h, start, cur, tracks[c][row_before(tracks[c], start)]


def tracks_arguments(description):
    """The flags of a research script that reads the tracks of
    `--acceptance` (under `--tracks`) and of `--acceptance
    --online-args="--no-pulse-correction" --out target/sop-nc` (under
    `--nc`), parsed."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--tracks", default="target/sop")
    ap.add_argument("--nc", default="target/sop-nc")
    return ap.parse_args()


def acceptance(host_sim, out, map_method, online_args=(), map_model="linear", worst=0):
    """Every pulse from each record's second pulse group on, with and
    without the record's own map as the prior, beside two baselines
    measured on the same pulses: the last pulse's drop at that duration
    again (scaled by the currents' ratio, the Panasonic test changes the
    current from pulse to pulse) and a 1 RC model fitted to the 1800 s
    before the pulse (the last pulse and its rest). With `worst`, each
    row's that many largest misses follow the table, signed: positive
    where the prediction lies above the measured voltage (the drop
    underpredicted)."""
    print("| record | horizon | prior | pulses | with a value | basis (window/map/held/stale) "
          "| ours: median / worst % of the drop | measured above pulse_v - 2 sigma "
          "| median sigma, % of the drop | last drop again | 1 RC on the last pulse |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    # The derating's check pooled over the measured records, per prior.
    pooled = {}
    # Per row of the table, its pulses' misses for `worst`.
    misses = []
    for name, (path, ocv_path, cap, gap_s, horizons, min_rest) in RECORD_SPECS.items():
        ocv = ocv_table(ocv_path)
        ps, (t, v) = pulses(path)
        i_raw = read(path)[1]
        g = groups(ps, gap_s)
        rec_out = record_dir(out, path)
        os.makedirs(rec_out, exist_ok=True)
        mp = record_map(host_sim, path, rec_out, map_method, ocv_path, cap, min_rest, map_model)
        currents = sorted({current_key(c) for _, c, _ in ps})
        # Baselines: per pulse and horizon, keyed by the pulse's index.
        naive, rc = {}, {}
        prev = {}
        for j, (start, cur, length) in enumerate(ps):
            before = np.interp(start, t, v)
            drops = {h: before - np.interp(start + h, t, v) for h in horizons if length >= h}
            # The last pulse that lasted h (on the Panasonic tests every
            # pulse lasts 10 s: the pulse before; on the DFN's, at 30 s
            # the last 1C discharge).
            for h in drops:
                if h in prev:
                    pd, pc = prev[h]
                    naive[(j, h)] = before - pd * cur / pc
                prev[h] = (drops[h], cur)
        # The window of 256 samples unless `online_args` gives one.
        window = [] if "--window" in online_args else ["--window", "256"]
        for variant, extra in (("none", []), ("own map", ["--prior", mp])):
            tracks, refused = {}, None
            for c in currents:
                track = f"{rec_out}/pulse{c}-{'map' if extra else 'none'}.csv"
                p = subprocess.run([host_sim, "online", "battery", "--input", path, "--ocv", ocv_path,
                                    "--capacity-ah", str(cap), "--pulse-current-a", str(c),
                                    "--horizons", ",".join(map(str, horizons)), "--out", track]
                                   + window + extra + list(online_args),
                                   stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
                if p.returncode != 0 and extra and "no level of the map can be a prior" in p.stderr:
                    # A map none of whose rows can be a prior: its row says so.
                    refused = p.stderr.strip().splitlines()[-1][:120]
                    break
                p.check_returncode()
                tracks[c] = list(csv.DictReader(open(track)))
            if refused:
                for h in horizons:
                    print(f"| {name} | {h} s | {variant} | — | — | — | refused: {refused} | — | — | — | — |")
                continue
            for h in horizons:
                ours, base, one_rc, basis, n = [], [], [], {}, 0
                signed = []
                covered, sigmas = [], []
                for j, (start, cur, length) in enumerate(ps):
                    if g[j] == 0 or length < h:
                        continue
                    n += 1
                    tr = tracks[current_key(cur)]
                    tt = np.array([float(r["time_s"]) for r in tr])
                    k = row_before(tr, start)
                    before = np.interp(start, t, v)
                    measured = np.interp(start + h, t, v)
                    drop = abs(before - measured)
                    p = tr[k][f"pulse_v_{h}s"]
                    b = tr[k].get("sop_basis", "")
                    if p:
                        miss = (float(p) - measured) / drop
                        ours.append(abs(miss))
                        signed.append((miss, start, cur, tr[k].get("soc_coulomb", "")))
                        basis[b] = basis.get(b, 0) + 1
                        # The derated limit's check: a discharge pulse
                        # ends no lower than its prediction less 2 sigma.
                        sd = tr[k].get(f"sop_uncertainty_v_{h}s", "")
                        if sd:
                            covered.append(measured >= float(p) - CONFIDENCE * float(sd))
                            sigmas.append(float(sd) / drop)
                    if (j, h) in naive:
                        base.append(abs(naive[(j, h)] - measured) / drop)
                    if (j, h) not in rc:
                        span = (t > start - SPAN_S) & (t <= start)
                        soc = np.interp(t[span], tt, [float(r["soc_coulomb"]) for r in tr])
                        model = fit_1rc(t[span], i_raw[span], v[span], ocv(soc))
                        rc[(j, h)] = predict_1rc(model, soc[-1], ocv, cur, h, cap) if model else np.nan
                    if np.isfinite(rc[(j, h)]):
                        one_rc.append(abs(rc[(j, h)] - measured) / drop)
                mw = lambda x: f"{pct(np.median(x))} / {pct(np.max(x))}" if x else "none"
                bs = "/".join(str(basis.get(x, 0)) for x in ("window", "map", "held", "stale"))
                cov = f"{sum(covered)} of {len(covered)} ({pct(np.mean(covered))} %)" if covered else "none"
                if name.startswith("Panasonic"):
                    pooled.setdefault(variant, []).extend(covered)
                sg = pct(np.median(sigmas)) if sigmas else "none"
                print(f"| {name} | {h} s | {variant} | {n} | {len(ours)} | {bs} | {mw(ours)} "
                      f"| {cov} | {sg} | {mw(base)} | {mw(one_rc)} |")
                misses.append((f"{name}, {h} s, {variant}", signed))
    print()
    for variant, c in pooled.items():
        print(f"measured records, prior {variant}: {sum(c)} of {len(c)} pulses end above "
              f"pulse_v - {CONFIDENCE:g} sigma ({pct(np.mean(c))} %)")
    if worst > 0:
        print(f"\nThe {worst} largest misses of each row, % of the drop (+: the drop underpredicted):")
        soc = lambda x: f"SOC {float(x):.3f}" if x else "SOC -"
        for row, m in misses:
            top = sorted(m, key=lambda x: -abs(x[0]))[:worst]
            print(f"{row}: " + "; ".join(f"{100 * e:+.1f} at {start:.0f} s, {cur:.2f} A, {soc(sc)}"
                                        for e, start, cur, sc in top))


def resistances():
    """Each measured HPPC test's pulses, a level on a line (the charge the
    export counts out of the cell before it): each pulse's
    2 s and 10 s resistance (the raw log's drop over the current), then the
    10 s resistance of the level's largest current over its smallest's
    (below 1: the resistance falls as the current rises; above 1: it
    rises). A pulse cut short by the voltage limit before 10 s is left
    out of the ratio."""
    for name, path in RECORDS.items():
        print(f"# {name}")
        ps, (t, v) = pulses(path)
        m = sio.loadmat(path)["meas"][0, 0]
        t_ah, ah = m["Time"].ravel(), m["Ah"].ravel()
        levels = [[]]
        for start, cur, length in ps:
            if levels[-1] and cur > -2.0:
                levels.append([])
            levels[-1].append((start, cur, length))
        for level in levels:
            line, r10 = [], []
            for start, cur, length in level:
                r = [1e3 * (np.interp(start, t, v) - np.interp(start + h, t, v)) / -cur
                     for h in HORIZONS]
                line.append(f"{start:.0f} s {cur:.2f} A: " + ", ".join(
                    f"{h} s {x:.1f} mOhm" for h, x in zip(HORIZONS, r)))
                if length >= max(HORIZONS):
                    r10.append(r[-1])
            ratio = f"; 10 s, largest current over smallest: {r10[-1] / r10[0]:.2f}" if len(r10) > 1 else ""
            out = max(0.0, -np.interp(level[0][0], t_ah, ah))
            print(f"{out:.2f} A h out: " + "; ".join(line) + ratio)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--host-sim", default="target/release/host-sim")
    ap.add_argument("--out", default="target/sop")
    ap.add_argument("--prior", metavar="MAP", help="also run with this parameter map as the prior "
                    "(e.g. target/real-cells/panasonic/map.csv, the map of bench/panasonic_chain.sh)")
    ap.add_argument("--butler-volmer", action="store_true",
                    help="also run with the Butler-Volmer term (no prior)")
    ap.add_argument("--resistances", action="store_true",
                    help="only print each pulse's measured 2 s and 10 s resistance "
                    "(the drop over the current), a level's pulses on one line")
    ap.add_argument("--acceptance", action="store_true",
                    help="only the table of every HPPC record of data/ (measured and DFN) from the second pulse "
                    "group on, with and without the record's own map as the prior, beside the "
                    "two baselines (issue 72)")
    ap.add_argument("--map-method", default="joint", choices=("joint", "levels"),
                    help="with --acceptance: how the record's own map is made (default joint)")
    ap.add_argument("--map-model", default="linear", choices=("linear", "butler-volmer"),
                    help="with --acceptance: the model the record's own map is fitted with (default linear)")
    ap.add_argument("--worst", type=int, default=0, metavar="N",
                    help="with --acceptance: also list each row's N largest misses, signed")
    ap.add_argument("--online-args", default="",
                    help="with --acceptance: more flags for every `online battery` run, "
                    "e.g. '--slow-memory-s 600'")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    if a.acceptance:
        acceptance(a.host_sim, a.out, a.map_method, a.online_args.split(), a.map_model, a.worst)
        return
    if a.resistances:
        resistances()
        return
    ps, (t, v) = pulses()
    i_raw = sio.loadmat(PANASONIC)["meas"][0, 0]["Current"].ravel()
    ocv = ocv_table()
    currents = sorted({current_key(c) for _, c, _ in ps})
    # Ours as published (carried from the fit no farther than the window
    # reaches), and carried through the test's 20-min rests.
    variants = {
        "window 256 (512 s)": ["--window", "256"],
        "window 256, --sop-carry-s 3600": ["--window", "256", "--sop-carry-s", "3600"],
        "window 1024 (2048 s: the previous pulse in it)": ["--window", "1024"],
    }
    if a.butler_volmer:
        variants["window 256, --model butler-volmer"] = ["--window", "256", "--model", "butler-volmer"]
    if a.prior:
        variants[f"window 256, the map {a.prior} as the prior"] = ["--window", "256", "--prior", a.prior]
        variants[f"window 256, the map as the prior, --sop-carry-s 3600"] = [
            "--window", "256", "--prior", a.prior, "--sop-carry-s", "3600"]
    rows = {name: [] for name in variants}
    r_ct = {name: [] for name in variants}
    for name, extra in variants.items():
        for c in currents:
            tag = "-".join(x.replace("/", "_") for x in extra)
            track = f"{a.out}/pulse{c}-{tag}.csv"
            subprocess.run([a.host_sim, "online", "battery", "--input", PANASONIC, "--ocv", PAN_OCV,
                            "--capacity-ah", str(CAPACITY_AH), "--pulse-current-a", str(c),
                            "--horizons", ",".join(map(str, HORIZONS)), "--out", track] + extra,
                           check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            tr = list(csv.DictReader(open(track)))
            tt = np.array([float(r["time_s"]) for r in tr])
            for start, cur, length in ps:
                if current_key(cur) != c:
                    continue
                # The last sample whose period [t_k, t_k + h) ends before
                # the pulse (the resampled current is each period's mean:
                # the sample at the edge already holds part of the pulse).
                k = np.searchsorted(tt, start - (tt[1] - tt[0]), side="right") - 1
                if k < 0:
                    continue
                before = np.interp(start, t, v)
                # The 1 RC model on the span before the pulse, with the
                # track's counted SOC at each raw instant.
                span = (t > start - SPAN_S) & (t <= start)
                soc = np.interp(t[span], tt, [float(r["soc_coulomb"]) for r in tr])
                model = fit_1rc(t[span], i_raw[span], v[span], ocv(soc))
                for h in HORIZONS:
                    if length < h:
                        continue
                    p = tr[k][f"pulse_v_{h}s"]
                    measured = np.interp(start + h, t, v)
                    rc = predict_1rc(model, soc[-1], ocv, cur, h) if model else np.nan
                    rows[name].append((h, c, start, float(p) if p else np.nan, measured,
                                       before - measured, rc, float(tr[k]["soc"] or "nan")))
                if tr[k]["r_ct"]:
                    r_ct[name].append(float(tr[k]["r_ct"]))
    for name in variants:
        print(f"== ours: {name}")
        if r_ct[name]:
            print(f"R_ct published at the samples before the pulses: "
                  f"{1e3 * min(r_ct[name]):.1f} to {1e3 * max(r_ct[name]):.1f} mOhm")
        for h in HORIZONS:
            r = np.array([x[3:] for x in rows[name] if x[0] == h])
            if not len(r):
                continue
            pub = np.isfinite(r[:, 0])
            rc = np.isfinite(r[:, 3])
            both = pub & rc
            print(f"pulse_v_{h}s: {pub.sum()} of {len(r)} pulses with a published prediction: "
                  + stats(r[pub, 0], r[pub, 1], r[pub, 2]))
            print(f"  the {both.sum()} of them the 1 RC model also predicts: ours "
                  + stats(r[both, 0], r[both, 1], r[both, 2]))
            print("    1 RC: " + stats(r[both, 3], r[both, 1], r[both, 2]))
            print(f"  1 RC on all {rc.sum()} pulses it identifies: "
                  + stats(r[rc, 3], r[rc, 1], r[rc, 2]))
            # Below SOC 0.2 the cell's resistance climbs within a level,
            # past what a value held from the level above says.
            high = pub & (r[:, 4] >= 0.2)
            print(f"  ours at the {high.sum()} published pulses at SOC >= 0.2: "
                  + stats(r[high, 0], r[high, 1], r[high, 2]))


if __name__ == "__main__":
    main()
