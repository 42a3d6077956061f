"""Bad data and bad keywords: ValueError with the CLI's one-line message."""

import re

import numpy as np
import pytest

import fracbms
from conftest import CELL


def cli_error(host_sim, path, *args):
    """The CLI's message for a file, with the file named `record` as the
    package names its arrays."""
    r = host_sim(*args, check=False)
    assert r.returncode == 1
    line = r.stderr.strip().splitlines()[-1]
    assert line.startswith("error: ")
    return line[len("error: "):].replace(str(path), "record")


def write(path, header, columns):
    with open(path, "w") as f:
        f.write(header + "\n")
        for row in zip(*columns):
            f.write(",".join(repr(float(x)) for x in row) + "\n")


def record(n=300):
    t = np.arange(float(n))
    i = np.where((t // 50) % 2 == 0, -2.0, 1.0)
    return t, i, fracbms.simulate_battery(t, i, **CELL)


@pytest.mark.parametrize("where", ["nan", "inf", "back"])
def test_bad_time_gives_the_cli_message(host_sim, tmp_path, where):
    t, i, v = record()
    t = t.copy()
    if where == "back":
        # A time that goes back at more than 1 % of the rows is no test
        # time (a step time, files joined).
        t[6:] -= 5.5
    else:
        t[6] = {"nan": np.nan, "inf": np.inf}[where]
    path = tmp_path / "bad.csv"
    write(path, "time_s,current_a,voltage_v", (t, i, v))
    expected = cli_error(host_sim, path, "identify", "battery", "--input", path)
    with pytest.raises(ValueError) as e:
        fracbms.identify_battery(t, i, v)
    assert str(e.value) == expected
    assert "row 8" in expected  # index 6 is row 8 of the file
    assert "\n" not in str(e.value)


def test_nan_in_a_hammerstein_record_gives_the_cli_message(host_sim, tmp_path):
    u = np.sin(np.arange(200.0))
    y = np.cos(np.arange(200.0))
    y[3] = np.nan
    path = tmp_path / "bad.csv"
    write(path, "u,y", (u, y))
    expected = cli_error(host_sim, path, "identify", "hammerstein", "--input", path,
                         "--na", "1", "--nb", "1", "--nc", "1")
    with pytest.raises(ValueError) as e:
        fracbms.identify_hammerstein(u, y, na=1, nb=1, nc=1)
    assert str(e.value) == expected == "record: row 5, column `y`: `NaN` is not finite"


def test_bad_ocv_table_gives_the_cli_message(host_sim, tmp_path):
    t, i, v = record()
    soc = np.array([0.0, 0.5, 0.4, 1.0])
    ocv = np.array([3.0, 3.5, 3.6, 4.1])
    rec, table = tmp_path / "rec.csv", tmp_path / "ocv.csv"
    write(rec, "time_s,current_a,voltage_v", (t, i, v))
    write(table, "soc,ocv_v", (soc, ocv))
    expected = cli_error(host_sim, table, "identify", "battery", "--input", rec, "--ocv", table,
                         "--capacity-ah", "2", "--soc0", "0.5")
    with pytest.raises(ValueError) as e:
        fracbms.identify_battery(t, i, v, ocv=(soc, ocv), capacity_ah=2.0, soc0=0.5)
    assert str(e.value) == expected.replace("record", "ocv")
    assert str(e.value).startswith("ocv: row 4:")


def test_nan_everywhere_it_cannot_be_a_rejected_row():
    t, i, v = record()
    bad_i = i.copy()
    bad_i[3] = np.nan
    with pytest.raises(ValueError, match=r"^record: row 5, column `current_a`: `NaN` is not finite$"):
        fracbms.simulate_battery(t, bad_i, **CELL)
    with pytest.raises(ValueError, match="not physical"):
        fracbms.simulate_battery(t, i, **{**CELL, "r_ct": np.nan})
    with pytest.raises(ValueError, match=r"capacity_ah=NaN: must be finite and positive"):
        fracbms.identify_battery(t, i, v, ocv=([0.0, 1.0], [3.0, 4.0]), capacity_ah=np.nan)
    with pytest.raises(ValueError, match=r"^ocv: row 3: "):
        fracbms.OnlineCell(ocv=([0.0, np.nan], [3.0, 4.0]), capacity_ah=2.0)
    with pytest.raises(ValueError, match=r"h=NaN: must be finite and positive"):
        fracbms.OnlineCell(h=np.nan)


def test_every_row_rejected_is_an_error():
    t, i, v = record()
    with pytest.raises(ValueError, match="record: "):
        fracbms.identify_battery(t, i, np.full_like(v, np.nan))


def test_bad_keywords():
    t, i, v = record()
    with pytest.raises(ValueError, match=r"^method='fast': must be one of 'paper', 'refined'$"):
        fracbms.identify_battery(t, i, v, method="fast")
    with pytest.raises(ValueError, match="capacity_ah and soc0 go with ocv"):
        fracbms.identify_battery(t, i, v, capacity_ah=2.0)
    with pytest.raises(ValueError, match=r"ocv needs capacity_ah"):
        fracbms.identify_battery(t, i, v, ocv=([0.0, 1.0], [3.0, 4.0]))
    with pytest.raises(ValueError, match=r"soc0=1.5: must be in \[0, 1\]"):
        fracbms.identify_battery(t, i, v, ocv=([0.0, 1.0], [3.0, 4.0]), capacity_ah=2.0, soc0=1.5)
    with pytest.raises(ValueError, match=r"columns time_s, current_a, voltage_v have 300, 299, 300 values"):
        fracbms.identify_battery(t, i[:-1], v)
    with pytest.raises(ValueError, match=r"^window=100: must be one of 64, 128, 256, 512, 1024$"):
        fracbms.OnlineCell(window=100, memory=32)
    with pytest.raises(ValueError, match=r"^memory=64: must be in 1..=56$"):
        fracbms.OnlineCell(window=64)
    # A horizon the state of power would take for ever to run.
    with pytest.raises(ValueError, match=r"^horizons=1e308: at most 3600 samples of the 1 s period"):
        fracbms.OnlineCell(ocv=([0.0, 1.0], [3.0, 4.0]), capacity_ah=2.0, horizons=[1e308])
    with pytest.raises(ValueError, match="u_oc is needed without ocv"):
        fracbms.simulate_battery(t, i, r_i=0.02, r_ct=0.015, q=500.0, alpha=0.7)
    assert fracbms.MAX_BATTERY_ROWS == 262144
    with pytest.raises(ValueError, match=re.escape("at most 262144 are identified")):
        n = fracbms.MAX_BATTERY_ROWS + 1
        fracbms.identify_battery(np.arange(float(n)), np.ones(n), np.full(n, 3.7))
    with pytest.raises(TypeError):
        fracbms.identify_battery(t, i, v, "refined")  # keywords only
