#!/usr/bin/env python3
"""An independent reference fit of each SOC level of a parameter map.

``host-sim identify battery REC --ocv OCV --capacity-ah C --map-out map.csv
--levels-out DIR`` splits a measured HPPC record into SOC levels, fits each,
and writes into DIR the exact uniform record each level's fit used:

* ``level-NN.csv`` (``time_s,current_a,voltage_v``, NN = 01, 02, ... in
  time order, uniform period);
* ``ocv.csv`` (``soc,ocv_v``, the OCV table used);
* ``levels.json``: ``capacity_ah``, ``model`` (our ``--model``) and per
  level ``file``, ``soc`` (the map row's SOC), ``soc0`` (the SOC before the
  record's first row's charge), ``temperature_c`` (or null), ``start_s``,
  ``end_s``, ``samples`` (and, when given, ``h``, the period, and
  ``fitted``, whether our map has the level's row: checked against the
  match below).

This script fits every level with ``bench/reference_fit.py``'s multi-start
reference, with that file's conventions: ``soc(l) = soc0 + h sum_{k<=l}
I(k) / (3600 C)``, overpotential ``y = V - OCV(soc)`` (the table linear,
flat beyond its ends), the model run from rest with full Grunwald-Letnikov
memory:

* ``--models cpe`` (default): the constant-phase model ``fit_cpe``,
  ``y = dU + R_i I + U_p`` (30 starts);
* ``--models auto``: also ``fit_cpe_bv`` (``+ a asinh(I/i0)``, our
  ``butler-volmer`` model), from the cpe fit; the level keeps the one with
  the lower RMSE (the BV model nests the linear one as i0 grows, so it
  wins unless its fit fails to improve, even on a linear cell, where part
  of R_i may then move into a tiny BV term; ``reference.json`` also gives
  both fits and ``model_by_bic``, the choice by BIC).

It writes ``DIR/reference.json`` (per level: file, soc, soc0, start_s,
end_s, samples, the chosen model and all its fitted parameters, rmse_v,
seconds; with ``auto`` both fits) and ``DIR/reference-map.csv`` in our map
CSV format (``temperature_c,soc,r_i,r_ct,q,alpha,bv_a_v,bv_i0_a,
ocv_offset_v,rmse_v,identifiable``, the interval columns, ``start_s,end_s,
samples``; the intervals left empty, ``identifiable`` ``true`` (the
reference has no verdict; ``host-sim predict battery --model`` reads the
map), the BV columns empty for a cpe level; rows sorted by temperature,
unknown first, then SOC).

With ``--ours map.csv`` (our ``--map-out``) it prints a markdown table,
level by level: SOC, samples, our and the reference's RMSE (mV) and their
ratio, our R_i and alpha against the reference's, and our row's
``identifiable``. A level is matched to a map row by ``start_s`` (within
1e-6 relative; and by temperature when both are known); a level without a
row was skipped by our fit.

Usage::

    python3 bench/reference_map.py DIR [--ours map.csv] [--models cpe|auto]
    python3 bench/reference_map.py --demo DIR   # a synthetic DIR, then its fit

``--demo DIR`` writes a small synthetic DIR (three levels simulated with
``cpe_polarization`` from rest, 1 mV noise, a linear OCV; its true map as
``DIR/truth-map.csv``, the middle level left out as if skipped), fits it
and compares with the truth: a self-test of this script (about 5 s). It
refuses a DIR whose levels.json it did not write.

Needs numpy and scipy. A level of 8192 samples takes about 3 s with cpe;
``auto``'s cpe_bv fit takes up to about a minute or more there.
"""

import argparse
import csv
import json
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import reference_fit as rf  # noqa: E402

MAP_COLUMNS = [
    "temperature_c", "soc", "r_i", "r_ct", "q", "alpha", "bv_a_v", "bv_i0_a", "ocv_offset_v", "rmse_v",
    "identifiable", "r_i_lo", "r_i_hi", "r_ct_lo", "r_ct_hi", "q_lo", "q_hi", "alpha_lo", "alpha_hi",
    "start_s", "end_s", "samples",
]
PARAMS = ["r_i", "r_ct", "q", "alpha", "ocv_offset_v", "bv_a_v", "bv_i0_a"]


def read_level(path, given_h=None):
    """A level record: t, I, V and its period h (levels.json's ``h`` when
    given, else t[1] - t[0]); warns when the spacing is not uniform."""
    t, i, v = rf.read_csv(path, ["time_s", "current_a", "voltage_v"])
    if len(t) < 3:
        raise ValueError(f"{path}: {len(t)} rows")
    if not (np.all(np.isfinite(i)) and np.all(np.isfinite(v)) and np.all(np.isfinite(t))):
        raise ValueError(f"{path}: values that are not finite")
    h = float(given_h) if given_h is not None else float(t[1] - t[0])
    dt = np.diff(t)
    if h <= 0 or np.max(np.abs(dt - h)) > 1e-6 * h:
        print(f"warning: {path}: the period is not uniform (h {h:g} s, steps {dt.min():g} to {dt.max():g} s)",
              file=sys.stderr)
    return t, i, v, h


def fit_level(i, y, h, models):
    """The reference fit of one level: fit_cpe, and with models == "auto"
    also fit_cpe_bv; the chosen model's name, its fit, and all fits."""
    fits = {"cpe": rf.fit_cpe(i, y, h)}
    if models == "auto":
        fits["cpe_bv"] = rf.fit_cpe_bv(i, y, h, fits["cpe"])
    name = min(fits, key=lambda k: fits[k]["rmse_v"])
    return name, fits[name], fits


def bic(fit, n):
    """n ln(mean squared residual) + k ln n, k the fitted coordinates (cpe 5,
    cpe_bv 7): lower is better; what the lower RMSE alone does not weigh."""
    k = 7 if "bv_a_v" in fit else 5
    return n * math.log(fit["rmse_v"] ** 2) + k * math.log(n)


def fit_dir(folder, models="cpe"):
    """Fits every level of ``folder/levels.json``; writes reference.json
    and reference-map.csv there and returns the reference.json document."""
    meta = json.load(open(os.path.join(folder, "levels.json")))
    cap = float(meta["capacity_ah"])
    soc_pts, ocv_pts = rf.read_csv(os.path.join(folder, "ocv.csv"), ["soc", "ocv_v"])
    if np.any(np.diff(soc_pts) <= 0) or np.any(np.diff(ocv_pts) <= 0):
        print("warning: ocv.csv is not increasing in soc and ocv_v (np.interp needs both)", file=sys.stderr)
    print(f"{folder}: {len(meta['levels'])} levels, C = {cap:g} A h, our model {meta.get('model')}, "
          f"reference models {models}")
    t_all = time.time()
    out = []
    for lv in meta["levels"]:
        rec = {k: lv.get(k) for k in ["file", "soc", "soc0", "temperature_c", "start_s", "end_s", "samples"]}
        if "fitted" in lv:
            rec["fitted"] = lv["fitted"]  # whether our map has its row, when levels.json says
        t0 = time.time()
        try:
            t, i, v, h = read_level(os.path.join(folder, lv["file"]), lv.get("h"))
            if len(t) != lv["samples"]:
                print(f"warning: {lv['file']}: {len(t)} rows, levels.json says {lv['samples']}", file=sys.stderr)
            if not np.any(i != 0.0):
                raise ValueError("no current")
            soc, y = rf.overpotential(i, v, h, soc_pts, ocv_pts, cap, float(lv["soc0"]))
            name, best, fits = fit_level(i, y, h, models)
        except (ValueError, TypeError, np.linalg.LinAlgError) as e:
            rec.update({"error": str(e), "seconds": round(time.time() - t0, 2)})
            print(f"{lv['file']}: not fitted ({e})")
            out.append(rec)
            continue
        rec.update({"h": h, "soc_end": float(soc[-1]), "model": name})
        rec.update({k: best.get(k) for k in PARAMS})
        rec["rmse_v"] = best["rmse_v"]
        # The same reference over the rows our fit kept (levels.json's
        # `rejected` and `unobserved`, the rows its rmse_v leaves out: no
        # measured voltage, or a spike): the comparison on the same data.
        left = set(lv.get("rejected") or []) | set(lv.get("unobserved") or [])
        rej = sorted(k for k in left if 0 <= k < len(t))
        rec["rejected"] = rej
        if rej:
            keep = np.ones(len(t), bool)
            keep[rej] = False
            try:
                if keep.sum() < 6:
                    raise ValueError(f"{keep.sum()} rows kept")
                same = rf.fit_cpe(i, y, h, keep)
                rec["same_rows"] = {k: same[k] for k in ("rmse_v", "r_i", "r_ct", "q", "alpha", "ocv_offset_v")}
            except (ValueError, TypeError, np.linalg.LinAlgError) as e:
                rec["same_rows_error"] = str(e)
                print(f"{lv['file']}: no fit on the rows ours kept ({e})")
        rec["winning_start"] = best["winning_start"]
        rec["local_minima_rmse_v"] = best["local_minima_rmse_v"]
        if models == "auto":
            rec["model_by_bic"] = min(fits, key=lambda k: bic(fits[k], len(t)))
            rec["fits"] = fits
        rec["seconds"] = round(time.time() - t0, 2)
        print(f"{lv['file']}: SOC {lv['soc']:.3f}, {len(t)} samples, {name} RMSE {1e3 * best['rmse_v']:.3f} mV, "
              f"R_i {1e3 * best['r_i']:.3f} mOhm, R_ct {1e3 * best['r_ct']:.3f} mOhm, Q {best['q']:.4g}, "
              f"alpha {best['alpha']:.3f}" + (f", by BIC {rec['model_by_bic']}" if models == "auto" else "")
              + f" ({rec['seconds']:.1f} s)")
        out.append(rec)
    seconds = round(time.time() - t_all, 1)
    doc = {"levels_json": os.path.join(folder, "levels.json"), "capacity_ah": cap, "our_model": meta.get("model"),
           "models": models, "levels": out, "seconds": seconds}
    with open(os.path.join(folder, "reference.json"), "w") as f:
        json.dump(doc, f, indent=2)
        f.write("\n")
    write_map_csv(os.path.join(folder, "reference-map.csv"), [r for r in out if "error" not in r])
    print(f"wrote {os.path.join(folder, 'reference.json')} and {os.path.join(folder, 'reference-map.csv')}")
    return doc


def cell(x):
    """A CSV cell: empty for None, else the shortest exact decimal."""
    return "" if x is None else repr(float(x)) if isinstance(x, float) else str(x)


def write_map_csv(path, levels):
    """The fitted levels as our map CSV (rows by temperature, unknown
    first, then SOC)."""
    key = lambda r: (-math.inf if r["temperature_c"] is None else r["temperature_c"], r["soc"])  # noqa: E731
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(MAP_COLUMNS)
        for r in sorted(levels, key=key):
            row = {k: r.get(k) for k in ["temperature_c", "soc", "ocv_offset_v", "rmse_v", "start_s", "end_s",
                                        "samples"] + PARAMS}
            # The reference has no verdict of its own; `true` lets
            # `host-sim predict battery --model` read the map.
            row["identifiable"] = "true"
            w.writerow([cell(row.get(c)) for c in MAP_COLUMNS])


def read_map_csv(path):
    """Our map CSV's rows as dicts of strings."""
    with open(path, newline="") as f:
        return [{k.strip(): (v or "").strip() for k, v in row.items()} for row in csv.DictReader(f)]


def close(a, b, rel=1e-6):
    return abs(a - b) <= rel * max(abs(a), abs(b), 1.0)


def match(level, rows):
    """Our map row of a level: the same start_s (and temperature when both
    are known), or None."""
    for r in rows:
        if not r.get("start_s") or not close(float(r["start_s"]), float(level["start_s"])):
            continue
        t = level.get("temperature_c")
        if t is not None and r.get("temperature_c") and not close(float(r["temperature_c"]), t):
            continue
        return r
    return None


def ours_on_every_row(folder, lv, r, cap):
    """The free-run RMSE of our row's parameters over every row of the level
    (ours screens spikes out of its fit and reports the RMSE over the rows
    it kept; the reference fits every row), computed here with the
    reference's own simulator; None for a Butler-Volmer row."""
    if r.get("bv_a_v"):
        return None
    soc_pts, ocv_pts = rf.read_csv(os.path.join(folder, "ocv.csv"), ["soc", "ocv_v"])
    _, i, v, h = read_level(os.path.join(folder, lv["file"]), lv.get("h"))
    _, y = rf.overpotential(i, v, h, soc_pts, ocv_pts, cap, lv["soc0"])
    f = {k: float(r[k]) for k in ("r_i", "r_ct", "q", "alpha", "ocv_offset_v")}
    model = f["ocv_offset_v"] + f["r_i"] * i + rf.cpe_branch(i, h, f["r_ct"], f["q"], f["alpha"])
    return math.sqrt(np.mean((model - y) ** 2))


def compare(doc, rows, folder):
    """The markdown table of our map rows against the reference levels."""
    cap = float(doc["capacity_ah"])
    lines = [
        "| level | SOC | samples | ours, fitted rows (mV) | ours, every row (mV) | ref. (mV) | ours / ref., every row "
        "| R_i ours / ref. (mOhm) | alpha ours / ref. | identifiable | rows ours leaves out | ref. on our rows (mV) "
        "| ours / ref., our rows |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    used = set()
    for lv in doc["levels"]:
        r = match(lv, rows)
        if lv.get("fitted") is not None and lv["fitted"] != (r is not None):
            print(f"warning: {lv['file']}: levels.json says fitted {lv['fitted']}, but the map has "
                  f"{'a' if r is not None else 'no'} row at start_s {lv['start_s']}", file=sys.stderr)
        ref = "error" not in lv
        ref_rmse = f"{1e3 * lv['rmse_v']:.3f}" if ref else "not fitted"
        head = f"| {lv['file']} | {lv['soc']:.3f} | {lv['samples']} "
        if r is None:
            lines.append(head + f"| skipped | | {ref_rmse} | | | | |")
            continue
        used.add(id(r))
        fitted = float(r["rmse_v"])
        ours = ours_on_every_row(folder, lv, r, cap)
        every = "" if ours is None else f"{1e3 * ours:.3f}"
        head += f"| {1e3 * fitted:.3f} | {every} "
        if ref and ours is not None:
            # Over the rows our fit kept: our rmse_v against the reference
            # refitted on them (the every-row fit when none was rejected).
            same = lv.get("same_rows") or {"rmse_v": lv["rmse_v"]}
            tail = (f"| {len(lv.get('rejected') or [])} | {1e3 * same['rmse_v']:.3f} "
                    f"| {fitted / same['rmse_v'] if same['rmse_v'] > 0 else math.inf:.3f} |")
            lines.append(head + f"| {ref_rmse} | {ours / lv['rmse_v'] if lv['rmse_v'] > 0 else math.inf:.3f} "
                                f"| {1e3 * float(r['r_i']):.3f} / {1e3 * lv['r_i']:.3f} "
                                f"| {float(r['alpha']):.3f} / {lv['alpha']:.3f} | {r.get('identifiable', '')} "
                         + tail)
        else:
            lines.append(head + f"| {ref_rmse} | | {1e3 * float(r['r_i']):.3f} / "
                                f"| {float(r['alpha']):.3f} / | {r.get('identifiable', '')} |")
    extra = [r for r in rows if id(r) not in used]
    if extra:
        lines.append("")
        lines.append(f"{len(extra)} map rows match no level (start_s "
                     f"{', '.join(r.get('start_s', '?') for r in extra)}).")
    return "\n".join(lines)


def demo(folder, seed=7, noise_v=1e-3):
    """Writes a synthetic levels folder: three levels of a fake HPPC (from
    rest: 60 s rest, 10 s discharge at 1C, 40 s rest, 10 s charge at 0.75C,
    40 s rest, 360 s discharge at 1C (0.1 SOC), 600 s rest), each simulated
    with its own (R_i, R_ct, Q, alpha, dU) by cpe_polarization plus noise
    (noise_v, default 1 mV), a linear OCV; the truth as truth-map.csv (level 2 left out, as if
    our fit had skipped it). Returns the true rows."""
    meta = os.path.join(folder, "levels.json")
    if os.path.exists(meta) and not json.load(open(meta)).get("demo"):
        raise SystemExit(f"{meta} exists and is not a demo's: not overwritten")
    os.makedirs(folder, exist_ok=True)
    rng = np.random.default_rng(seed)
    cap, h = 2.0, 1.0
    soc_pts = np.array([0.0, 1.0])
    ocv_pts = 3.4 + 0.8 * soc_pts
    with open(os.path.join(folder, "ocv.csv"), "w") as f:
        f.write("soc,ocv_v\n" + "".join(f"{cell(z)},{cell(o)}\n" for z, o in zip(soc_pts, ocv_pts)))
    segs = [(60, 0.0), (10, -1.0), (40, 0.0), (10, 0.75), (40, 0.0), (360, -1.0), (600, 0.0)]
    i = np.concatenate([np.full(n, c * cap) for n, c in segs])
    truth = [  # (R_i, R_ct, Q, alpha, dU)
        (0.030, 0.020, 900.0, 0.70, 0.002),
        (0.025, 0.015, 1500.0, 0.80, -0.001),
        (0.022, 0.012, 600.0, 0.60, 0.0),
    ]
    levels, rows = [], []
    soc0, t_start = 0.9, 0.0
    for k, (r_i, r_ct, q, alpha, du) in enumerate(truth):
        t = t_start + h * np.arange(len(i))
        soc = soc0 + h * np.cumsum(i) / (3600.0 * cap)
        v = np.interp(soc, soc_pts, ocv_pts) + du + r_i * i + rf.cpe_polarization(i, h, r_ct, q, alpha)
        v = v + rng.normal(0.0, noise_v, len(v))
        name = f"level-{k + 1:02d}.csv"
        with open(os.path.join(folder, name), "w") as f:
            f.write("time_s,current_a,voltage_v\n")
            f.writelines(f"{cell(a)},{cell(b)},{cell(c)}\n" for a, b, c in zip(t, i, v))
        levels.append({"file": name, "soc": soc0, "soc0": soc0, "temperature_c": 25.0, "start_s": float(t[0]),
                       "end_s": float(t[-1]), "samples": len(t), "h": h, "fitted": k != 1})
        rows.append({"temperature_c": 25.0, "soc": soc0, "r_i": r_i, "r_ct": r_ct, "q": q, "alpha": alpha,
                     "ocv_offset_v": du, "rmse_v": 1e-3, "identifiable": "true", "start_s": float(t[0]),
                     "end_s": float(t[-1]), "samples": len(t)})
        soc0 = float(soc[-1])
        t_start = float(t[-1]) + 1200.0
    with open(os.path.join(folder, "levels.json"), "w") as f:
        json.dump({"capacity_ah": cap, "model": "linear", "demo": True, "levels": levels}, f, indent=2)
        f.write("\n")
    with open(os.path.join(folder, "truth-map.csv"), "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(MAP_COLUMNS)
        for r in sorted([rows[0], rows[2]], key=lambda r: r["soc"]):
            w.writerow([cell(r.get(c)) for c in MAP_COLUMNS])
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", help="the folder of --levels-out (levels.json, ocv.csv, level-NN.csv)")
    ap.add_argument("--ours", help="our map CSV (--map-out) to compare with")
    ap.add_argument("--models", choices=["cpe", "auto"], default="cpe",
                    help="cpe (default): the constant-phase model; auto: also cpe_bv, the better by RMSE")
    ap.add_argument("--demo", action="store_true",
                    help="first write a synthetic DIR (three levels, known parameters) and compare with its truth")
    ap.add_argument("--no-fit", action="store_true",
                    help="compare with the reference.json already in DIR instead of fitting again")
    a = ap.parse_args()
    t0 = time.time()
    if a.demo:
        truth = demo(a.dir)
        a.ours = a.ours or os.path.join(a.dir, "truth-map.csv")
    if a.ours:
        rows = read_map_csv(a.ours)  # read before the long fit: a bad path fails at once
    if a.no_fit:
        with open(os.path.join(a.dir, "reference.json")) as f:
            doc = json.load(f)
    else:
        doc = fit_dir(a.dir, a.models)
    if a.ours:
        print()
        print(compare(doc, rows, a.dir))
    if a.demo:
        print()
        print("| level | parameter | truth | reference | relative error |")
        print("|---|---|---|---|---|")
        worst = 0.0
        for lv, tr in zip(doc["levels"], truth):
            for k in ["r_i", "r_ct", "q", "alpha"]:
                err = lv[k] / tr[k] - 1.0
                worst = max(worst, abs(err))
                print(f"| {lv['file']} | {k} | {tr[k]:.6g} | {lv[k]:.6g} | {err:+.2%} |")
            print(f"| {lv['file']} | ocv_offset_v | {tr['ocv_offset_v']:.6g} | {lv['ocv_offset_v']:.6g} | "
                  f"{lv['ocv_offset_v'] - tr['ocv_offset_v']:+.2e} V |")
        print(f"demo: largest relative error of R_i, R_ct, Q, alpha: {worst:.2%}")
    print(f"total time: {time.time() - t0:.1f} s")


if __name__ == "__main__":
    main()
