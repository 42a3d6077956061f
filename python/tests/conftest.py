"""Shared fixtures: the host-sim binary the results are compared with, and
records it writes.

The tests compare the package with the CLI on the same data, so they need
the `host-sim` binary: ``$FRACBMS_HOST_SIM`` when set (scripts/check.sh sets
it; a missing file is then a failure), else ``target/debug/host-sim`` or
``target/release/host-sim`` of this checkout (the tests that need it are
skipped when neither exists).
"""

import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]

# The `cell` preset of `host-sim simulate battery` (CellParameters::cell_18650).
CELL = dict(r_i=0.020, r_ct=0.015, q=8.0 / 0.015, alpha=0.75, u_oc=3.7)


def _host_sim():
    given = os.environ.get("FRACBMS_HOST_SIM")
    if given:
        return pathlib.Path(given)
    for profile in ("debug", "release"):
        p = REPO / "target" / profile / "host-sim"
        if p.exists():
            return p
    return None


@pytest.fixture(scope="session")
def host_sim():
    p = _host_sim()
    if p is None:
        pytest.skip("no host-sim binary: run `cargo build -p host-sim` or set FRACBMS_HOST_SIM")
    assert p.exists(), f"FRACBMS_HOST_SIM={p} does not exist"

    def run(*args, check=True):
        r = subprocess.run([str(p), *map(str, args)], capture_output=True, text=True)
        if check:
            assert r.returncode == 0, r.stderr
        return r

    return run


def read_csv(path):
    """The columns of a CSV file with a header, by name (floats; empty
    cells are NaN, text columns are kept as strings)."""
    with open(path) as f:
        header = f.readline().strip().split(",")
        rows = [line.rstrip("\n").split(",") for line in f if line.strip()]
    cols = {}
    for k, name in enumerate(header):
        cells = [r[k] for r in rows]
        try:
            cols[name] = np.array([float(c) if c else np.nan for c in cells])
        except ValueError:
            cols[name] = np.array(cells)
    return cols


@pytest.fixture(scope="session")
def cell_record(host_sim, tmp_path_factory):
    """A record of our own model: the `cell` preset (18650-like), pulse
    profile, σ = 1 mV, 1500 rows."""
    path = tmp_path_factory.mktemp("records") / "cell.csv"
    host_sim("simulate", "battery", "--preset", "cell", "--length", "1500", "--out", path)
    return path


def cli_json(host_sim, tmp_path, *args):
    out = tmp_path / "out.json"
    host_sim(*args, "--json", out)
    return json.loads(out.read_text())
