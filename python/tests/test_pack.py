"""fracbms.online_pack against ``host-sim online pack``: the same track,
column by column, on a simulated 4-cell string with the cells' OCV table
(each cell's SOC and state of power and the string's), and without one."""

import numpy as np
import pytest

import fracbms
from conftest import REPO, read_csv

OCV = REPO / "data" / "pybamm" / "chen2020-ocv.csv"


def cli_text(value):
    """A number as the CLI's track prints it (``{:.9e}``), NaN as empty."""
    if np.isnan(value):
        return ""
    mantissa, exp = f"{value:.9e}".split("e")
    return f"{mantissa}e{int(exp)}"


@pytest.fixture(scope="module")
def string(host_sim, tmp_path_factory):
    path = tmp_path_factory.mktemp("pack") / "pack.csv"
    host_sim("simulate", "pack", "--cells", "4", "--profile", "hppc", "--spread", "0.1",
             "--aged", "3", "--sigma", "0.001", "--length", "1200", "--ocv", OCV,
             "--soc0", "0.7", "--out", path)
    return path


@pytest.mark.parametrize("with_ocv", [True, False])
def test_online_pack_equals_the_cli(host_sim, string, tmp_path, with_ocv):
    rec = read_csv(string)
    cells = np.column_stack([rec[f"cell_{k}_v"] for k in range(1, 5)])
    ocv = read_csv(OCV)
    flags = ["--tail", "--horizons", "2,10"]
    kw = dict(tail=True, horizons=[2.0, 10.0])
    if with_ocv:
        flags += ["--ocv", OCV, "--capacity-ah", "2.5", "--soc0", "0.7",
                  "--soc-voltage-sigma-v", "0.002"]
        kw.update(ocv=(ocv["soc"], ocv["ocv_v"]), capacity_ah=2.5, soc0=0.7,
                  soc_voltage_sigma_v=0.002)
    out = tmp_path / "track.csv"
    host_sim("online", "pack", "--input", string, *flags, "--out", out)
    cli = read_csv(out)
    py = fracbms.online_pack(rec["current_a"], cells, **kw)
    assert list(py) == list(cli)
    assert len(py["cell"]) == 4 * 1200
    assert list(py["cell"][:5]) == [1, 2, 3, 4, 1]
    for name, column in cli.items():
        got = py[name]
        if isinstance(got, list):
            # Text; a column empty on every row reads as NaN from the CSV.
            want = ["" if isinstance(x, float) and np.isnan(x) else x for x in column]
            assert got == want, name
        elif name in ("rejected", "flagged"):
            assert list(np.asarray(got, dtype=float)) == list(column), name
        elif name in ("time_s", "cell"):
            assert np.array_equal(np.asarray(got, dtype=float), column), name
        else:
            # The CLI prints 10 significant digits: the package's value,
            # printed so, is the CLI's text.
            printed = [cli_text(x) for x in got]
            want = [cli_text(x) for x in column]
            assert printed == want, name
    sop = py["pack_sop_discharge_a_10s"]
    if with_ocv:
        assert np.isfinite(sop).sum() > 1000
        last = slice(-4, None)
        # The aged cell (3) limits the string.
        assert sop[-1] == py["sop_discharge_a_10s"][last][2]
        assert np.all(np.isfinite(py["soc"][last]))
    else:
        assert np.all(np.isnan(sop)) and np.all(np.isnan(py["soc"]))


def test_online_pack_refuses_bad_arguments_with_the_keywords():
    i = np.zeros(10)
    with pytest.raises(ValueError, match="cells_v has 9 rows"):
        fracbms.online_pack(i, np.full((9, 2), 3.7))
    with pytest.raises(ValueError, match="soc0=1.5"):
        fracbms.online_pack(i, np.full((10, 2), 3.7), ocv=([0.0, 1.0], [3.0, 4.2]),
                            capacity_ah=2.5, soc0=1.5)
    with pytest.raises(ValueError, match="window="):
        fracbms.online_pack(i, np.full((10, 2), 3.7), window=100)
    with pytest.raises(ValueError, match="soc-voltage-sigma-v"):
        fracbms.online_pack(i, np.full((10, 2), 3.7), ocv=([0.0, 1.0], [3.0, 4.2]),
                            capacity_ah=2.5, soc_voltage_sigma_v=float("inf"))


def test_online_pack_snapshots_are_the_clis(host_sim, string, tmp_path):
    """``return_state`` gives the CLI's ``--state-out`` bytes for the same
    first half; ``state_in`` resumes the second half as the CLI's
    ``--state-in`` does (the same track with its ``restoration`` column);
    a corrupt snapshot raises."""
    rec = read_csv(string)
    cut = 600
    lines = string.read_text().splitlines()
    first, second = tmp_path / "first.csv", tmp_path / "second.csv"
    first.write_text("\n".join(lines[: cut + 1]) + "\n")
    second.write_text("\n".join([lines[0]] + lines[cut + 1:]) + "\n")
    ocv = read_csv(OCV)
    flags = ["--ocv", OCV, "--capacity-ah", "2.5", "--soc0", "0.7", "--tail"]
    kw = dict(ocv=(ocv["soc"], ocv["ocv_v"]), capacity_ah=2.5, soc0=0.7, tail=True)
    state = tmp_path / "state.bin"
    host_sim("online", "pack", "--input", first, *flags, "--out", tmp_path / "a.csv",
             "--state-out", state)
    cells = np.column_stack([rec[f"cell_{k}_v"] for k in range(1, 5)])
    h = float(rec["time_s"][1] - rec["time_s"][0])
    track, snapshot = fracbms.online_pack(rec["current_a"][:cut], cells[:cut], h=h,
                                          t0=float(rec["time_s"][0]), return_state=True, **kw)
    assert snapshot == state.read_bytes()
    assert len(snapshot) == 20 + 4 * 124 + 4
    assert "restoration" not in track

    out = tmp_path / "b.csv"
    host_sim("online", "pack", "--input", second, *flags, "--out", out, "--state-in", state)
    cli = read_csv(out)
    py = fracbms.online_pack(rec["current_a"][cut:], cells[cut:], h=h,
                             t0=float(rec["time_s"][cut]), state_in=snapshot, **kw)
    assert list(py) == list(cli) and list(py)[-1] == "restoration"
    assert set(py["restoration"]) == {"restored"}
    for name in ("r_i", "r_ct", "soc", "sop_discharge_a_10s", "pack_sop_discharge_a_10s"):
        assert [cli_text(x) for x in py[name]] == [cli_text(x) for x in cli[name]], name
    assert py["r_i_status"][0] == "restored"

    bad = snapshot[:30] + bytes([snapshot[30] ^ 1]) + snapshot[31:]
    with pytest.raises(ValueError, match="state_in: snapshot rejected: snapshot CRC mismatch"):
        fracbms.online_pack(rec["current_a"][cut:], cells[cut:], h=h, state_in=bad, **kw)
