"""Many files: identify_files against the CLI's --summary-out, and
fracbms.fleet.identify_many on a Dask LocalCluster against the serial run."""

import csv
import os
import shutil

import numpy as np
import pytest

import fracbms
import fracbms.fleet
from conftest import REPO

OCV = REPO / "data" / "pybamm" / "chen2020-ocv.csv"
CAPACITY = 5.153198
NUMBERS = ("r_i", "r_ct", "q", "alpha", "u_oc", "rmse_v", "r_i_lo", "r_i_hi", "alpha_lo",
           "alpha_hi", "soc0", "soc_end", "map_rmse_v")


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """The two Chen2020 DFN records and a file that is not a record."""
    d = tmp_path_factory.mktemp("fleet")
    for f in ("chen2020-hppc.csv", "chen2020-drive.csv"):
        shutil.copy(REPO / "data" / "pybamm" / f, d / f)
    (d / "broken.csv").write_text("a,b\n1,2\n")
    return d


def test_identify_files_gives_the_rows_of_the_cli_summary(host_sim, folder, tmp_path):
    out = tmp_path / "summary.csv"
    r = host_sim("identify", "battery", "--input", folder, "--ocv", OCV, "--capacity-ah",
                 CAPACITY, "--summary-out", out, "--soc-bins", "3", "--map-out",
                 tmp_path / "maps", check=False)
    assert r.returncode == 1, r.stderr  # the broken file
    with open(out, newline="") as f:
        cli = list(csv.DictReader(f))
    assert list(cli[0].keys()) == list(fracbms.SUMMARY_COLUMNS)
    rows = fracbms.identify_files(folder, ocv=OCV, capacity_ah=CAPACITY, map=True, soc_bins=3)
    assert [r["file"] for r in rows] == [c["file"] for c in cli]
    assert [r["status"] for r in rows] == ["error", "ok", "ok"]
    assert rows[0]["error"] == cli[0]["error"] and "no time column" in rows[0]["error"]
    assert rows[0]["r_i"] is None
    for r, c in zip(rows[1:], cli[1:]):
        for k in NUMBERS:
            assert r[k] == float(c[k]), k  # the same f64, to the last bit
        # Three levels, or the single fit's one row where the three fit the
        # record worse (docs/maps.md): as the CLI's summary says.
        assert r["model"] == c["model"] and r["map_levels"] == int(c["map_levels"]) in (1, 3)
        assert str(r["identifiable"]).lower() == c["identifiable"]


def test_bad_options_are_refused_before_any_file():
    with pytest.raises(ValueError, match="needs ocv and capacity_ah"):
        fracbms.identify_files("no-such-dir", map=True)
    with pytest.raises(ValueError, match="jobs= 0"):
        fracbms.identify_files("no-such-dir", jobs=0)
    with pytest.raises(ValueError, match="current_sign='up'"):
        fracbms.identify_files("no-such-dir", current_sign="up")
    with pytest.raises(ValueError, match="no record files there"):
        fracbms.identify_files("no-such-dir/*.csv")


def test_a_local_cluster_gives_the_serial_rows(folder):
    if os.environ.get("FRACBMS_REQUIRE_FLEET"):
        import dask.distributed as distributed  # scripts/check.sh: must run
    else:
        distributed = pytest.importorskip("dask.distributed")
    serial = fracbms.fleet.identify_many(folder, ocv=OCV, capacity_ah=CAPACITY, jobs=1)
    assert list(serial.columns) == list(fracbms.SUMMARY_COLUMNS)
    assert list(serial["status"]) == ["error", "ok", "ok"]
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        on_cluster = fracbms.fleet.identify_many(folder, client, ocv=str(OCV),
                                                 capacity_ah=CAPACITY)
        # Tasks of two files each: the same rows, in the same order.
        batched = fracbms.fleet.identify_many(fracbms.expand_inputs(str(folder)), client,
                                              files_per_task=2, ocv=OCV,
                                              capacity_ah=CAPACITY)
    for df in (on_cluster, batched):
        a, b = serial.drop(columns="fit_s"), df.drop(columns="fit_s")
        assert a.equals(b), (a.compare(b) if a.shape == b.shape else (a, b))
    ok = serial[serial["status"] == "ok"]
    assert np.all(ok["r_i_lo"] <= ok["r_i"]) and np.all(ok["r_i"] <= ok["r_i_hi"])
