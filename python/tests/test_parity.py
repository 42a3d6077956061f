"""Parity across the faces (issue 37): one table of records, run through the
CLI (``host-sim``), the C ABI (``examples/c/parity.c`` linked against
``libfracbms.a``) and Python (``fracbms``); every face must give the same
results and the same rejections.

Which operation runs on which faces, and why:

- ``identify`` (CLI, C, Python): ``identify battery --json``,
  ``fracbms_identify_battery``, ``identify_battery``. Bit for bit: the
  same host function on the same ``f64`` numbers (the C driver prints 17
  digits, JSON and Python keep every bit). A refused record must be refused
  by all three with the CLI's message (its file name read as ``record``).
- ``online`` (CLI, C, Python): the sliding-window estimator sample by
  sample with the firmware's settings (window 256, memory 64, refined, one
  iteration per sample, at rest at power-up, linear model): the C ABI runs
  the core in ``f32`` only, as the firmware does, so the CLI runs
  ``--precision f32 --start at-rest --model linear`` and Python
  ``OnlineCell(precision="f32", start="at-rest", model="linear")``. Every
  row's status, rejection (by reason), published parameters and their
  statuses, the window's fit, ``u_oc``, ``ocv_offset_v`` and the step
  resistance; the sample and rejected counts (by reason: the CLI's summary
  line, Python's ``rejected`` column, the C estimate's ``rejection``).
- ``soc`` (CLI, C, Python; records with an OCV table): the same run's state
  of charge: the count, the observer's SOC, sigma, current bias, capacity
  and its status (C: ``fracbms_cell_set_state_of_charge`` with the start
  SOC the CLI gets from ``--soc0``).
- ``soc_settings`` (CLI, C, Python; records with an OCV table): ``soc``
  with the observer's settings of SOC_SETTINGS (``--soc-rest-s``,
  ``--soc-bias-sigma-a``, ``--soc-voltage-sigma-v``; C:
  ``fracbms_cell_init_with_soc``), which must
  change the run where the record rests.
- ``sop`` (CLI, C, Python): the same run's state of power at 10 and 30 s
  (the CLI's ``sop_*``/``pulse_v_*``/``sop_uncertainty_v_*``/``pulse_ratio_*`` columns and
  ``sop_basis``, Python's, and C's ``fracbms_cell_state_of_power`` after
  each push), for the limits of the record's row in RECORDS.
- ``map`` (CLI, Python) and ``map_c`` (CLI, C, Python; records with an OCV
  table): the online run with a parameter map as the prior (``--prior
  MAP.csv``, ``OnlineCell(map=...)``, ``fracbms_cell_follow_map`` before
  each push); the map has a level that is not identifiable, which every
  face leaves out (counted alike). ``map_c`` holds because a prior set
  before the first sample starts the refinement at its centre on every
  face (the core takes the start at the first sample), and an ``f32``
  estimator follows the map in ``f32`` on every face. ``fracbms_map_cell_at``
  itself is C only: the CLI and Python have no call that returns the map's
  cell at a SOC (they use it only inside ``online`` and ``predict``), so it
  is checked here through the prior it gives.
- ``online_f64`` (CLI, Python): the CLI's default online run (``f64``, from
  the data, model auto). Absent from C: the C ABI has no ``f64`` estimator.
- ``predict`` (CLI, Python): ``predict battery`` and ``predict_battery``
  with the CLI's fit of the same record. Absent from C: the C ABI has no
  prediction of a whole record (a BMS runs the online estimator).

Tolerances: none beyond the faces' printing. Python and C are compared
exactly (both give the ``f32`` estimator's values as exact doubles: C
prints 9 digits, which round-trip an ``f32``). The CLI's track CSV prints
10 significant digits (``{:.9e}``), so a CLI number must equal the other
face's value printed the same way; ``predict``'s ``model_v`` is printed
with 9 decimals (``{:.9}``) and compared likewise. Everything else (the
identify JSON, counts, names) is compared exactly.

Run (after ``cargo build -p host-sim`` and ``cargo build -p estimator-ffi
--release``; ``FRACBMS_C_LIB`` names another ``libfracbms.a``, ``CC``
another compiler)::

    FRACBMS_HOST_SIM=target/debug/host-sim python -m pytest -q python/tests/test_parity.py
"""

import csv
import json
import os
import re
import shlex
import subprocess
import warnings

import numpy as np
import pytest

import fracbms
from conftest import REPO, read_csv

OCV_CHEN = REPO / "data" / "pybamm" / "chen2020-ocv.csv"
CAPACITY_CHEN = 5.153198325955154  # data/pybamm/meta.json

# The records: a name, how to make the file, its cell (OCV table, capacity,
# start SOC) and the state-of-power request (V_min, V_max, I_limit, I_pulse).
RECORDS = {
    # Our own model, the firmware's record (1000 rows, 1 s, σ = 1 mV).
    "cell-pulse": dict(source="firmware/data/cell-pulse.csv", sop=(3.0, 4.2, 20.0, -2.0)),
    # The DFN drive cycle (PyBaMM Chen2020), its first 1200 rows, with the
    # OCV table (two spikes rejected online). No state of power: R_ct is
    # never identified on this excerpt, so none is published.
    "dfn-drive": dict(source="data/pybamm/chen2020-drive.csv", rows=1200, ocv=OCV_CHEN,
                      capacity_ah=CAPACITY_CHEN, soc0=0.9),
    # The DFN HPPC record, its first 1500 rows (three pulse levels, rests):
    # every status, and a state of power on 828 rows.
    "dfn-hppc": dict(source="data/pybamm/chen2020-hppc.csv", rows=1500, ocv=OCV_CHEN,
                     capacity_ah=CAPACITY_CHEN, soc0=0.9, sop=(2.5, 4.2, 50.0, -CAPACITY_CHEN),
                     rests=True),
    # cell-pulse with hostile rows (as bench/bad_rows.py makes them, at
    # fixed rows): NaN voltages, a NaN current, voltage spikes, a voltage
    # and a current out of the plausible range.
    "hostile": dict(source="firmware/data/cell-pulse.csv", sop=(3.0, 4.2, 20.0, -2.0), bad={
        120: ("voltage_v", "nan"), 421: ("voltage_v", "nan"), 610: ("current_a", "nan"),
        300: ("voltage_v", +0.4), 505: ("voltage_v", -0.3), 777: ("voltage_v", +0.25),
        650: ("voltage_v", "7.5"), 702: ("current_a", "9000")}),
    # A dead voltage sensor: every voltage NaN. Identify refuses it; online
    # rejects every sample.
    "dead-sensor": dict(source="firmware/data/cell-pulse.csv",
                        bad={k: ("voltage_v", "nan") for k in range(1000)}),
    # A NaN time: identify refuses it (online does not read the time).
    "nan-time": dict(source="firmware/data/cell-pulse.csv", bad={5: ("time_s", "nan")}),
}

# A map for the DFN cell (the CSV of `identify battery --map-out`): three
# identifiable levels and one that is not (left out by every face).
MAP_CSV = """temperature_c,soc,r_i,r_ct,q,alpha,bv_a_v,bv_i0_a,ocv_offset_v,rmse_v,identifiable
,0.80,0.0078,0.0250,1400.0,0.78,,,0.0040,0.002,true
,0.85,0.0070,0.0230,1500.0,0.80,,,0.0035,0.002,true
,0.87,0.0500,0.5000,90.0,0.30,,,0.0100,0.050,false
,0.92,0.0062,0.0200,1700.0,0.82,,,0.0030,0.002,true
"""

# Which faces run which operation, and on which records.
FACES = {
    "identify": ("cli", "c", "python"),
    "online": ("cli", "c", "python"),
    "soc": ("cli", "c", "python"),
    "soc_settings": ("cli", "c", "python"),
    "sop": ("cli", "c", "python"),
    "map": ("cli", "python"),
    "map_c": ("cli", "c", "python"),
    "online_f64": ("cli", "python"),
    "predict": ("cli", "python"),
}
REFUSED_BY_IDENTIFY = {"dead-sensor", "nan-time"}


def applies(op, name):
    r = RECORDS[name]
    if name == "nan-time":
        return op == "identify"
    if op in ("soc", "soc_settings", "map", "map_c"):
        return "ocv" in r
    if op == "sop":
        return "sop" in r
    if name in REFUSED_BY_IDENTIFY and op == "predict":
        return False
    return True


CASES = [pytest.param(name, op, id=f"{name}-{op}")
         for name in RECORDS for op in FACES if applies(op, name)]

# The track's columns each face gives, by operation (numbers; names apart).
ONLINE_NUMBERS = ["r_i", "r_ct", "q", "alpha", "window_r_i", "window_r_ct", "window_q",
                  "window_alpha", "u_oc", "ocv_offset_v", "step_resistance_ohm"]
ONLINE_NAMES = ["status", "rejected", "r_i_status", "r_ct_status", "q_status", "alpha_status"]
SOC_NUMBERS = ["soc", "soc_coulomb", "soc_sigma", "current_bias_a", "capacity_ah",
               "capacity_sigma_ah", "soc_ocv_weight"]
# The SOC observer's settings of ``soc_settings``: the CLI's flags (``_`` as
# ``-``), the C driver's (``fracbms_cell_init_with_soc``), Python's keywords.
# Rests of two minutes are read, and the sensor is calibrated (no bias
# estimated: the CLI's ``--soc-bias-sigma-a 0`` also zeroes the bias's walk,
# which the C driver must do as well), and a rested voltage is trusted to
# 2 mV.
SOC_SETTINGS = dict(soc_rest_s=120.0, soc_bias_sigma_a=0.0, soc_voltage_sigma_v=0.002)
SOP_NUMBERS = [f"{k}_{h}s" for h in (10, 30)
               for k in ("sop_discharge_a", "sop_charge_a", "pulse_v", "sop_uncertainty_v",
                         "pulse_ratio")]
# The longest horizon's spread: the track's column, C's `FracbmsPower.uncertainty_v`.
SOP_NUMBERS.append("sop_uncertainty_v")
IDENTIFY_NUMBERS = ["r_i", "r_ct", "q", "alpha", "u_oc", "bv_a_v", "bv_i0_a", "ocv_offset_v",
                    "soc0", "soc_end", "rmse_v"]


# --- the records ---------------------------------------------------------

def write_record(name, path):
    """Writes record `name` to `path` (`time_s,current_a,voltage_v`)."""
    r = RECORDS[name]
    with open(REPO / r["source"]) as f:
        rows = list(csv.reader(f))
    header = rows[0]
    keep = [header.index(c) for c in ("time_s", "current_a", "voltage_v")]
    rows = [[row[k] for k in keep] for row in rows[1:1 + r.get("rows", len(rows))]]
    for k, (col, what) in r.get("bad", {}).items():
        j = ("time_s", "current_a", "voltage_v").index(col)
        # A number is added (a spike), a string replaces the cell.
        rows[k][j] = f"{float(rows[k][j]) + what:.6f}" if isinstance(what, float) else what
    with open(path, "w") as f:
        f.write("time_s,current_a,voltage_v\n")
        f.writelines(",".join(row) + "\n" for row in rows)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("parity")
    out = {}
    for name in RECORDS:
        write_record(name, d / f"{name}.csv")
        out[name] = d / f"{name}.csv"
    (d / "map.csv").write_text(MAP_CSV)
    out["map"] = d / "map.csv"
    out["dir"] = d
    return out


def cell_args(name):
    """The CLI's (and the C driver's) flags of the record's cell."""
    r = RECORDS[name]
    if "ocv" not in r:
        return []
    return ["--ocv", r["ocv"], "--capacity-ah", repr(r["capacity_ah"]), "--soc0", repr(r["soc0"])]


def cell_kw(name):
    """Python's keywords of the record's cell."""
    r = RECORDS[name]
    if "ocv" not in r:
        return {}
    o = read_csv(r["ocv"])
    return dict(ocv=(o["soc"], o["ocv_v"]), capacity_ah=r["capacity_ah"], soc0=r["soc0"])


def sop_args(name):
    if "sop" not in RECORDS[name]:
        return []
    vmin, vmax, ilim, ipulse = RECORDS[name]["sop"]
    return ["--voltage-min", repr(vmin), "--voltage-max", repr(vmax),
            "--current-limit", repr(ilim), "--pulse-current-a", repr(ipulse)]


def sop_kw(name):
    if "sop" not in RECORDS[name]:
        return {}
    vmin, vmax, ilim, ipulse = RECORDS[name]["sop"]
    return dict(voltage_min=vmin, voltage_max=vmax, current_limit=ilim, pulse_current_a=ipulse)


# The firmware's settings (fracbms_settings_default) on the CLI and Python.
FIRMWARE_ARGS = ["--precision", "f32", "--start", "at-rest", "--model", "linear"]
FIRMWARE_KW = dict(precision="f32", start="at-rest", model="linear")


# --- the faces -----------------------------------------------------------

def static_library():
    """`$FRACBMS_C_LIB`, else the workspace's `target/release/libfracbms.a`
    (built if missing)."""
    given = os.environ.get("FRACBMS_C_LIB")
    if given:
        assert os.path.exists(given), f"FRACBMS_C_LIB={given} does not exist"
        return given
    target = os.environ.get("CARGO_TARGET_DIR", str(REPO / "target"))
    lib = os.path.join(target, "release", "libfracbms.a")
    if not os.path.exists(lib):
        subprocess.run(["cargo", "build", "-q", "-p", "estimator-ffi", "--release"], cwd=REPO,
                       check=True)
    return lib


@pytest.fixture(scope="module")
def c_driver(tmp_path_factory):
    """examples/c/parity.c compiled against the host library; runs it and
    returns its JSON lines."""
    exe = tmp_path_factory.mktemp("c") / "parity"
    cc = shlex.split(os.environ.get("CC", "cc"))
    r = subprocess.run([*cc, "-std=c11", "-O2", "-Wall", "-Wextra", "-Werror",
                        f"-I{REPO / 'include'}", str(REPO / "examples" / "c" / "parity.c"),
                        static_library(), "-lpthread", "-ldl", "-lm", "-o", str(exe)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr

    def run(*args):
        p = subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True)
        assert p.returncode in (0, 1), p.stderr
        return [json.loads(line) for line in p.stdout.splitlines()]

    return run


@pytest.fixture(scope="module")
def cli(host_sim):
    """host-sim, returning the completed process (not checked)."""
    return lambda *args: host_sim(*args, check=False)


SUMMARY = re.compile(r"\((\d+) samples, (\d+) rejected: (\d+) not finite, (\d+) out of range, "
                     r"(\d+) spikes;")
MAP_LINE = re.compile(r"prior from the map: (\d+) levels, .* \((\d+) left out\)")


def cli_track(cli, record, out, *args):
    """`online battery`: the track's columns and the summary line's counts."""
    p = cli("online", "battery", "--input", record, "--out", out, *args)
    assert p.returncode == 0, p.stderr
    m = SUMMARY.search(p.stderr)
    assert m, p.stderr
    counts = dict(zip(("samples", "rejected", "non_finite", "out_of_range", "spikes"),
                      map(int, m.groups())))
    m = MAP_LINE.search(p.stderr)
    if m:
        counts["map_levels"], counts["map_left_out"] = map(int, m.groups())
    track = read_csv(out)
    # A text column empty on every row reads as NaN.
    for k in ONLINE_NAMES + ["capacity_status", "sop_basis"]:
        track[k] = np.array(["" if isinstance(x, float) else x for x in track[k]])
    return track, counts


def c_track(lines):
    """The C driver's online lines as columns, and its summary."""
    *rows, summary = lines
    assert summary.get("summary"), summary
    cols = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    counts = {k: summary[k] for k in ("samples", "rejected", "non_finite", "out_of_range",
                                      "spikes")}
    if summary["map_levels"]:
        counts["map_levels"] = summary["map_levels"]
        counts["map_left_out"] = summary["map_left_out"]
    return cols, counts


def py_track(name, **kw):
    """OnlineCell.run over the record: the columns and the counts."""
    c = read_csv(name)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        cell = fracbms.OnlineCell(h=float(c["time_s"][1] - c["time_s"][0]), **kw)
    track = cell.run(c["current_a"], c["voltage_v"])
    why = list(track["rejected"])
    counts = dict(samples=cell.samples, rejected=cell.rejected,
                  non_finite=why.count("non_finite"), out_of_range=why.count("out_of_range"),
                  spikes=why.count("spike"))
    if "map" in kw:
        # A level left out is a warning: "prior map: level at SOC …: … (left
        # out)". Python does not say how many it kept: the map's count.
        left_out = sum("(left out)" in str(w.message) for w in said)
        kept = MAP_CSV.count(",true\n")
        counts["map_levels"], counts["map_left_out"] = kept, left_out
    return track, counts


class Runs:
    """Each face's run of each record, made once for the module."""

    def __init__(self, files, cli, c_driver):
        self.files, self.cli, self.c = files, cli, c_driver
        self.cache = {}

    def get(self, key, make):
        if key not in self.cache:
            self.cache[key] = make()
        return self.cache[key]

    def identify(self, face, name):
        f = self.files[name]
        if face == "cli":
            def make():
                out = self.files["dir"] / f"{name}-fit.json"
                p = self.cli("identify", "battery", "--input", f, *cell_args(name), "--json", out)
                if p.returncode != 0:
                    return {"error": p.stderr.strip().removeprefix("error: ")}
                return json.loads(out.read_text())
        elif face == "c":
            def make():
                (line,) = self.c("identify", f, *cell_args(name))
                return line if line["code"] == 0 else {"error": line["message"],
                                                       "code": line["code"]}
        else:
            def make():
                c = read_csv(f)
                try:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        fit = fracbms.identify_battery(c["time_s"], c["current_a"],
                                                       c["voltage_v"], **cell_kw(name))
                except ValueError as e:
                    return {"error": str(e)}
                fit.pop("model_v")
                return fit
        return self.get(("identify", face, name), make)

    def online(self, face, name, with_map=False, soc_settings=False):
        """The firmware's settings, with the record's cell and state-of-power
        request (and the map as the prior; or the SOC observer's settings
        of SOC_SETTINGS)."""
        f = self.files[name]
        tag = "map" if with_map else "soc_settings" if soc_settings else "online"
        soc = SOC_SETTINGS if soc_settings else {}
        if face == "cli":
            extra = ["--prior", self.files["map"]] if with_map else []
            extra += [x for k, v in soc.items() for x in (f"--{k.replace('_', '-')}", repr(v))]
            out = self.files["dir"] / f"{name}-{tag}.csv"
            make = lambda: cli_track(self.cli, f, out, *FIRMWARE_ARGS, *cell_args(name),
                                     *sop_args(name), *extra)
        elif face == "c":
            extra = ["--map", self.files["map"]] if with_map else []
            if "sop" in RECORDS[name]:
                extra += ["--sop", ",".join(repr(x) for x in RECORDS[name]["sop"])]
            extra += [x for k, v in soc.items() for x in (f"--{k.replace('_', '-')}", repr(v))]
            make = lambda: c_track(self.c("online", f, *cell_args(name), *extra))
        else:
            extra = dict(map=self.files["map"]) if with_map else {}
            extra.update(soc)
            make = lambda: py_track(f, **FIRMWARE_KW, **cell_kw(name), **sop_kw(name), **extra)
        return self.get((tag, face, name), make)

    def online_f64(self, face, name):
        f = self.files[name]
        if face == "cli":
            out = self.files["dir"] / f"{name}-f64.csv"
            make = lambda: cli_track(self.cli, f, out, *cell_args(name), *sop_args(name))
        else:
            make = lambda: py_track(f, **cell_kw(name), **sop_kw(name))
        return self.get(("online_f64", face, name), make)

    def predict(self, face, name):
        f = self.files[name]
        fit_json = self.files["dir"] / f"{name}-fit.json"
        self.identify("cli", name)  # writes fit_json
        if face == "cli":
            def make():
                out, js = (self.files["dir"] / f"{name}-predict.{x}" for x in ("csv", "json"))
                p = self.cli("predict", "battery", "--model", fit_json, "--input", f,
                             *cell_args(name), "--out", out, "--json", js)
                assert p.returncode == 0, p.stderr
                j = json.loads(js.read_text())
                j["model_v"] = read_csv(out)["model_v"]
                j["observed"] = read_csv(out)["observed"]
                return j
        else:
            def make():
                c = read_csv(f)
                return fracbms.predict_battery(c["time_s"], c["current_a"], c["voltage_v"],
                                               model=json.loads(fit_json.read_text()),
                                               **cell_kw(name))
        return self.get(("predict", face, name), make)


@pytest.fixture(scope="module")
def runs(files, cli, c_driver):
    return Runs(files, cli, c_driver)


# --- what "the same" means -----------------------------------------------

def as_cli_prints(x):
    """`x` as the track CSV prints it: 10 significant digits (`{:.9e}`),
    NaN where the cell is empty."""
    x = np.asarray(x, dtype=float)
    return np.array([float(f"{v:.9e}") if np.isfinite(v) else np.nan for v in x])


def same_numbers(a, b, what):
    """Equal arrays, NaN where the other is NaN (no tolerance)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape, (what, a.shape, b.shape)
    bad = ~((a == b) | (np.isnan(a) & np.isnan(b)))
    assert not bad.any(), (f"{what}: {bad.sum()} rows differ, first at row "
                           f"{np.argmax(bad)}: {a[bad][0]!r} vs {b[bad][0]!r}")


def same_tracks(tracks, numbers, names=()):
    """The faces' tracks: names equal, numbers equal (the CLI's as it
    prints the others')."""
    faces = list(tracks)
    for k in names:
        ref = list(tracks[faces[0]][k])
        for face in faces[1:]:
            got = list(tracks[face][k])
            assert got == ref, (f"{k}: {faces[0]} and {face} differ first at row "
                                f"{next(j for j, (x, y) in enumerate(zip(ref, got)) if x != y)}")
    exact = [f for f in faces if f != "cli"]
    for k in numbers:
        for face in exact[1:]:
            same_numbers(tracks[face][k], tracks[exact[0]][k], f"{k}: {exact[0]} vs {face}")
        if "cli" in tracks:
            same_numbers(tracks["cli"][k], as_cli_prints(tracks[exact[0]][k]),
                         f"{k}: cli vs {exact[0]}")


def c_published_soc(c):
    """The C estimate's SOC as the track publishes `soc`: the observer's,
    else the count."""
    return np.where(np.isnan(c["soc"].astype(float)), c["soc_coulomb"], c["soc"])


# --- the test ------------------------------------------------------------

@pytest.mark.parametrize("name, op", CASES)
def test_the_faces_agree(runs, name, op):
    faces = FACES[op]
    if op == "identify":
        fits = {face: runs.identify(face, name) for face in faces}
        if name in REFUSED_BY_IDENTIFY:
            path = str(runs.files[name])
            msgs = {face: fits[face].get("error", "").replace(path, "record") for face in faces}
            assert all(msgs.values()), fits
            assert len(set(msgs.values())) == 1, msgs
            assert fits["c"]["code"] == -9  # FRACBMS_ERROR_DATA
            return
        cli, c, py = fits["cli"], fits["c"], fits["python"]
        # Python returns the CLI's JSON, every key and bit.
        assert json.dumps(py, sort_keys=True) == json.dumps(cli, sort_keys=True)
        for k in IDENTIFY_NUMBERS:
            same_numbers(c[k], np.nan if cli[k] is None else cli[k], f"{k}: c vs cli")
        for k in ("model", "iterations", "converged", "rejected", "identifiable"):
            assert c[k] == cli[k], k
        assert cli["rejected"] == sum(cli["rejected_rows"].values())
        return
    if op == "predict":
        cli, py = runs.predict("cli", name), runs.predict("python", name)
        same_numbers(cli.pop("model_v"), [float(f"{v:.9f}") for v in py.pop("model_v")],
                     "model_v")
        same_numbers(cli.pop("observed"), py.pop("observed"), "observed")
        assert json.dumps(py, sort_keys=True) == json.dumps(cli, sort_keys=True)
        return
    if op == "online_f64":
        tracks = {face: runs.online_f64(face, name) for face in faces}
    else:
        with_map = op in ("map", "map_c")
        tracks = {face: runs.online(face, name, with_map, op == "soc_settings")
                  for face in faces}
    counts = {face: tracks[face][1] for face in faces}
    tracks = {face: tracks[face][0] for face in faces}
    if "c" in tracks:
        tracks["c"]["soc"] = c_published_soc(tracks["c"])
    # The same samples, rejected alike (by reason).
    assert len({json.dumps(c, sort_keys=True) for c in counts.values()}) == 1, counts
    if op in ("online", "map", "map_c", "online_f64"):
        numbers = ONLINE_NUMBERS + (SOC_NUMBERS + SOP_NUMBERS if op == "online_f64" else [])
        names = ONLINE_NAMES + (["capacity_status"] if op == "online_f64" else [])
        same_tracks(tracks, numbers, names)
    elif op == "soc":
        same_tracks(tracks, SOC_NUMBERS, ["capacity_status"])
    elif op == "soc_settings":
        same_tracks(tracks, SOC_NUMBERS, ["capacity_status"])
        # The settings reach every face: on a record with rests of two
        # minutes the SOC is not the defaults' run; without one (the drive
        # cycle's excerpt) it is.
        default = runs.online("python", name)[0]
        changed = tracks["python"]
        same = all(np.array_equal(changed[k], default[k], equal_nan=True)
                   for k in ("soc", "current_bias_a"))
        assert same != RECORDS[name].get("rests", False), name
    elif op == "sop":
        # Published on some rows (else the comparison is of NaNs only).
        assert np.isfinite(tracks["python"]["sop_discharge_a_10s"]).any()
        same_tracks(tracks, SOP_NUMBERS, ["sop_basis"])
