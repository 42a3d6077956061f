"""identify_battery: the CLI's `identify battery --json` on arrays."""

import json

import numpy as np
import pytest

import fracbms
from conftest import CELL, REPO, cli_json, read_csv


def fit_of(record, **kw):
    c = read_csv(record)
    return fracbms.identify_battery(c["time_s"], c["current_a"], c["voltage_v"], **kw)


def test_equals_the_cli_and_recovers_the_cell(host_sim, cell_record, tmp_path):
    cli = cli_json(host_sim, tmp_path, "identify", "battery", "--input", cell_record)
    py = fit_of(cell_record)
    model_v = py.pop("model_v")
    # Every key of the CLI's JSON, with the same value (bit for bit: the
    # same function on the same numbers).
    assert set(py) == set(cli)
    assert json.dumps(py, sort_keys=True) == json.dumps(cli, sort_keys=True)
    # The record is our own model's: the fit recovers the cell.
    for k in ("r_i", "r_ct", "q", "alpha", "u_oc"):
        assert py[k] == pytest.approx(CELL[k], rel=0.02), k
    assert py["identifiable"] and py["converged"] and py["rejected"] == 0
    # model_v is the CLI's --fit-out model voltage.
    fit_out = tmp_path / "fit.csv"
    host_sim("identify", "battery", "--input", cell_record, "--fit-out", fit_out)
    np.testing.assert_allclose(model_v, read_csv(fit_out)["model_v"], rtol=0, atol=1e-9)


def test_paper_method_and_linear_model_equal_the_cli(host_sim, cell_record, tmp_path):
    cli = cli_json(host_sim, tmp_path, "identify", "battery", "--input", cell_record,
                   "--method", "paper", "--iterations", "30")
    # 30 iterations of the paper's method leave R_ct and α loose: the fit
    # says so, in the JSON and as a warning.
    with pytest.warns(UserWarning, match="record: the fit is not identifiable: 95 % intervals"):
        py = fit_of(cell_record, method="paper", iterations=30)
    py.pop("model_v")
    assert py == cli
    assert py["method"] == "paper" and py["model"] == "linear"
    assert not py["identifiable"] and "R_ct" in py["identifiable_reason"]


def test_with_an_ocv_curve_equals_the_cli(host_sim, tmp_path):
    ocv_file = REPO / "data" / "own-model" / "nmc-ocv.csv"
    rec = tmp_path / "nmc.csv"
    host_sim("simulate", "battery", "--preset", "cell", "--length", "1200", "--ocv", ocv_file,
             "--soc0", "0.8", "--capacity-ah", "2.5", "--mean-current", "-1.5", "--out", rec)
    cli = cli_json(host_sim, tmp_path, "identify", "battery", "--input", rec, "--ocv", ocv_file,
                   "--capacity-ah", "2.5", "--soc0", "0.8")
    o = read_csv(ocv_file)
    py = fit_of(rec, ocv=(o["soc"], o["ocv_v"]), capacity_ah=2.5, soc0=0.8)
    py.pop("model_v")
    assert py == cli
    assert py["soc0"] == 0.8 and py["soc_end"] < 0.8
    assert abs(py["ocv_offset_v"]) < 5e-3


def test_bad_rows_are_rejected_and_counted_as_the_cli_does(host_sim, cell_record, tmp_path):
    c = read_csv(cell_record)
    v = c["voltage_v"].copy()
    v[10] = np.nan
    v[500] += 0.5  # a spike
    bad = tmp_path / "bad.csv"
    with open(bad, "w") as f:
        f.write("time_s,current_a,voltage_v\n")
        for t, i, u in zip(c["time_s"], c["current_a"], v):
            f.write(f"{float(t)!r},{float(i)!r},{float(u)!r}\n")
    cli = cli_json(host_sim, tmp_path, "identify", "battery", "--input", bad)
    with pytest.warns(UserWarning, match=r"record: 2 rows rejected .*rows 12, 502"):
        py = fracbms.identify_battery(c["time_s"], c["current_a"], v)
    py.pop("model_v")
    assert py == cli
    assert py["rejected_rows"] == {"non_finite": 1, "out_of_range": 0, "spikes": 1}


def test_accepts_lists_and_integer_arrays():
    t = list(range(400))
    i = [(-2 if (k // 50) % 2 == 0 else 1) for k in t]
    v = fracbms.simulate_battery(t, i, **CELL)
    assert isinstance(v, np.ndarray) and v.dtype == np.float64 and v.shape == (400,)
    fit = fracbms.identify_battery(np.array(t), np.array(i), list(v))
    assert fit["r_i"] == pytest.approx(CELL["r_i"], rel=1e-3)


def test_uneven_steps_are_put_on_a_period_as_the_cli_does(host_sim, cell_record, tmp_path):
    c = read_csv(cell_record)
    # Drop every fifth row: steps of 1 s and 2 s.
    keep = np.arange(len(c["time_s"])) % 5 != 3
    t, i, v = (c[k][keep] for k in ("time_s", "current_a", "voltage_v"))
    path = tmp_path / "uneven.csv"
    with open(path, "w") as f:
        f.write("time_s,current_a,voltage_v\n")
        for row in zip(t, i, v):
            f.write(",".join(repr(float(x)) for x in row) + "\n")
    cli = cli_json(host_sim, tmp_path, "identify", "battery", "--input", path)
    py = fracbms.identify_battery(t, i, v)
    py.pop("model_v")
    assert json.dumps(py, sort_keys=True) == json.dumps(cli, sort_keys=True)
    r = py["record"]
    assert r["resampled"] and r["period_s"] == 1.0 and r["period_source"] == "chosen"
    assert r["rows_interpolated"] > 0 and r["samples"] > len(t)


def test_unobserved_rows_are_counted_in_no_fit(cell_record):
    """`observed=` marks rows with no measured voltage (a cycler's unlogged
    step start): a block of made-up voltages there leaves the fit where the
    clean record puts it; unmarked, it moves the fit."""
    c = read_csv(cell_record)
    t, i, v = c["time_s"], c["current_a"], c["voltage_v"]
    clean = fracbms.identify_battery(t, i, v)
    k0 = int(np.argmax(np.diff(i) != 0)) + 1
    made_up = v.copy()
    made_up[k0:k0 + 40] += 0.05
    observed = np.ones(len(t))
    observed[k0:k0 + 40] = 0
    masked = fracbms.identify_battery(t, i, made_up, observed=observed)
    unmasked = fracbms.identify_battery(t, i, made_up)
    assert masked["rejected"] == 0
    moved = lambda f: abs(f["r_i"] / clean["r_i"] - 1)
    assert moved(masked) < 0.02
    assert moved(unmasked) > 2 * moved(masked)
    with pytest.raises(ValueError, match="unobserved mask has 3 values"):
        fracbms.identify_battery(t, i, v, observed=[1, 1, 1])


def test_a_regression_that_stops_is_a_warning_and_the_fit_goes_on(host_sim, tmp_path):
    """Pulses in the first 200 s and then a rest: the paper regression's
    rows past its memory carry no excitation and it stops. The fit goes
    on from the data's own starts, as the CLI's does; the reason is a
    UserWarning and the dict's `start_note`, `paper_start` says so."""
    k = np.arange(900)
    i = np.where(k < 200, np.where((k // 40) % 2 == 0, -3.0, 1.0), 0.0)
    t = k.astype(float)
    v = fracbms.simulate_battery(t, i, **CELL)
    path = tmp_path / "rests.csv"
    np.savetxt(path, np.column_stack([t, i, v]), delimiter=",",
               header="time_s,current_a,voltage_v", comments="", fmt="%.17g")
    cli = cli_json(host_sim, tmp_path, "identify", "battery", "--input", path, "--model", "linear")
    with pytest.warns(UserWarning, match=r"record: 2S-OP-GI stopped after 0 iterations "
                                         r"\(window carries no excitation\)"):
        py = fracbms.identify_battery(t, i, v, model="linear")
    py.pop("model_v")
    assert json.dumps(py, sort_keys=True) == json.dumps(cli, sort_keys=True)
    assert py["paper_start"] == "regression_failed"
    assert "carries no excitation" in py["start_note"]
    assert py["r_i"] == pytest.approx(CELL["r_i"], rel=1e-3)
