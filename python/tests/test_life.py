"""A cell's life: fracbms.life against the CLI's --life-out on the same
NASA PCoE logs."""

import csv
import shutil

import pytest

import fracbms
from conftest import REPO

NASA = REPO / "data" / "nasa-pcoe-b0005" / "discharge"
TIMES = [("05122.csv", "2008-04-02T15:25:41.593"), ("05124.csv", "2008-04-02T19:43:48.406"),
         ("05126.csv", "2008-04-03T00:01:06.687")]


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """Three of B0005's discharges, a file that is not a log, and their
    start times listed out of order."""
    d = tmp_path_factory.mktemp("life")
    for f, _ in TIMES:
        shutil.copy(NASA / f, d / f)
    (d / "05123.csv").write_text("a,b\n1,2\n")
    table = tmp_path_factory.mktemp("life-times") / "start_times.csv"
    rows = TIMES[::-1] + [("05123.csv", "2008-04-02T17:00:00")]
    table.write_text("file,start_time\n" + "".join(f"{f},{t}\n" for f, t in rows))
    return d, table


def test_life_gives_the_rows_of_the_cli_life_out(host_sim, logs, tmp_path):
    d, table = logs
    out = tmp_path / "life.csv"
    r = host_sim("online", "battery", "--input", d, "--start-times", table, "--window", "64",
                 "--out", tmp_path / "tracks", "--life-out", out)
    assert r.returncode == 0, r.stderr
    with open(out, newline="") as f:
        cli = list(csv.DictReader(f))
    assert list(cli[0].keys()) == list(fracbms.LIFE_COLUMNS)
    with pytest.warns(UserWarning, match="05123.csv"):
        df = fracbms.life(d, start_times=table, window=64)
    assert list(df.columns) == list(fracbms.LIFE_COLUMNS)
    assert [p.rsplit("/", 1)[-1] for p in df["file"]] == [
        "05122.csv", "05123.csv", "05124.csv", "05126.csv"]
    assert df["r_i_status"][1] == "error" and "no time column" in df["error"][1]
    for k, row in enumerate(cli):
        for key in ("discharged_ah", "charged_ah", "r_i", "r_ct", "alpha"):
            ours = df[key][k]
            if row[key] == "":
                assert ours is None or ours != ours, (k, key)
            else:
                assert abs(float(row[key]) - ours) <= 1e-8 * abs(ours), (k, key)
        assert row["r_i_status"] == df["r_i_status"][k]


def test_without_start_times_the_logs_own_time_stamps_give_the_order(tmp_path):
    """The Panasonic MAT-files' `TimeStamp`: the later log listed first runs
    second, each row with its first row's date and time."""
    pan = REPO / "data" / "panasonic-18650pf"
    later, earlier = pan / "03-27-17_10.29 3423_dis5_10p.mat", pan / "03-11-17_10.10 3390_dis5_10p.mat"
    df = fracbms.life([later, earlier], window=64)
    assert [p.rsplit("/", 1)[-1] for p in df["file"]] == [earlier.name, later.name]
    assert df["start_time"][1] == "2017-03-27T10:29:11"
    assert df["start_time"][0].startswith("2017-03-11T")


@pytest.mark.parametrize("steps", ["auto", "ignore"])
def test_steps_reads_the_logs_as_the_cli_does(host_sim, tmp_path, steps):
    """The Panasonic 10 % discharge steps: each rest first logged 300 s
    after its discharge stopped, no step column. By default the export's
    `Ah` places each rest's start (5.44 A h discharged, the export's own
    count 5.45); `steps="ignore"` holds each row's current to the next
    (7.33 A h), as `--steps ignore` does."""
    d = tmp_path / "logs"
    d.mkdir()
    shutil.copy(REPO / "data" / "panasonic-18650pf" / "03-11-17_10.10 3390_dis5_10p.mat", d)
    out = tmp_path / "life.csv"
    r = host_sim("online", "battery", "--input", d, "--steps", steps, "--window", "64",
                 "--out", tmp_path / "tracks", "--life-out", out)
    assert r.returncode == 0, r.stderr
    with open(out, newline="") as f:
        cli = list(csv.DictReader(f))
    df = fracbms.life(d, steps=steps, window=64)
    for key in ("discharged_ah", "charged_ah"):
        assert abs(float(cli[0][key]) - df[key][0]) <= 1e-9 * df[key][0], key
    want = 5.449 if steps == "auto" else 7.327
    assert abs(df["discharged_ah"][0] - want) < 0.01, df["discharged_ah"][0]
