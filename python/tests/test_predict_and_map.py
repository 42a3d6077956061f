"""predict_battery and identify_battery(map=True): the CLI's `predict
battery` and `identify battery --map-out` on arrays."""

import json

import numpy as np
import pytest

import fracbms
from conftest import CELL, REPO, cli_json, read_csv

OCV = REPO / "data" / "own-model" / "nmc-ocv.csv"


def ocv_table():
    c = read_csv(OCV)
    return c["soc"], c["ocv_v"]


def hppc(path):
    """Four levels of ±4 A pulses and a 0.2 A·h discharge, 700 s rests, on
    the NMC curve (2.5 A·h from SOC 0.9)."""
    i = [0.0] * 700
    for _ in range(4):
        for _ in range(2):
            i += [-4.0] * 10 + [0.0] * 40 + [4.0] * 10 + [0.0] * 40
        i += [-2.0] * 360 + [0.0] * 700
    i = np.array(i)
    t = np.arange(float(len(i)))
    soc, ocv = ocv_table()
    z = 0.9 + np.concatenate(([0.0], np.cumsum(i)[:-1])) / 3600.0 / 2.5
    z_after = z + i / 3600.0 / 2.5
    v = fracbms.simulate_battery(t, i, **{k: CELL[k] for k in ("r_i", "r_ct", "q", "alpha")},
                                 u_oc=0.0) + np.interp(z_after, soc, ocv)
    v = v + 0.5e-3 * np.sin(0.7 * t)
    with open(path, "w") as f:
        f.write("time_s,current_a,voltage_v\n")
        for row in zip(t, i, v):
            f.write(",".join(repr(float(x)) for x in row) + "\n")
    return t, i, v


def test_the_map_equals_the_cli(host_sim, tmp_path):
    """The per-level map (map_method="levels", --map-method levels)."""
    path = tmp_path / "hppc.csv"
    t, i, v = hppc(path)
    cli = cli_json(host_sim, tmp_path, "identify", "battery", "--input", path, "--ocv", OCV,
                   "--capacity-ah", "2.5", "--soc0", "0.9", "--model", "linear",
                   "--map-method", "levels", "--map-out", tmp_path / "map.csv")
    py = fracbms.identify_battery(t, i, v, ocv=ocv_table(), capacity_ah=2.5, soc0=0.9,
                                  model="linear", map=True, map_method="levels")
    py.pop("model_v")
    assert json.dumps(py["map"], sort_keys=True) == json.dumps(cli["map"], sort_keys=True)
    levels = py["map"]["levels"]
    # One cell at every level: the four levels' map model is no better than
    # the one fit (0.36 against 0.35 mV, both at the noise), so the map is
    # the single fit's one row, and never worse than it (docs/maps.md).
    assert len(levels) == 1
    for level in levels:
        assert level["r_i"] == pytest.approx(CELL["r_i"], rel=0.05)
    assert py["map"]["map_rmse_v"] == py["map"]["single_rmse_v"]
    with pytest.raises(ValueError, match="map=True needs ocv"):
        fracbms.identify_battery(t, i, v, map=True)


def test_the_joint_map_equals_the_cli(host_sim, tmp_path):
    """The joint map is the default on both faces (and map_method="joint"
    is --map-method joint): the same map, its candidates scored by leaving
    levels out; a bad name is refused."""
    path = tmp_path / "hppc.csv"
    t, i, v = hppc(path)
    cli = cli_json(host_sim, tmp_path, "identify", "battery", "--input", path, "--ocv", OCV,
                   "--capacity-ah", "2.5", "--soc0", "0.9", "--model", "linear",
                   "--map-out", tmp_path / "map.csv")
    py = fracbms.identify_battery(t, i, v, ocv=ocv_table(), capacity_ah=2.5, soc0=0.9,
                                  model="linear", map=True)
    explicit = fracbms.identify_battery(t, i, v, ocv=ocv_table(), capacity_ah=2.5, soc0=0.9,
                                        model="linear", map=True, map_method="joint")
    assert json.dumps(py["map"], sort_keys=True) == json.dumps(cli["map"], sort_keys=True)
    assert json.dumps(explicit["map"], sort_keys=True) == json.dumps(py["map"], sort_keys=True)
    assert py["map"]["joint"], "a joint map lists its scored candidates"
    assert py["map"]["map_rmse_v"] <= py["map"]["single_rmse_v"]
    with pytest.raises(ValueError, match="map_method='tabled': must be one of 'joint', 'levels'"):
        fracbms.identify_battery(t, i, v, ocv=ocv_table(), capacity_ah=2.5, soc0=0.9,
                                 map=True, map_method="tabled")


def test_predict_equals_the_cli_for_a_fit_and_a_map(host_sim, tmp_path):
    path = tmp_path / "hppc.csv"
    t, i, v = hppc(path)
    fit = fracbms.identify_battery(t, i, v, ocv=ocv_table(), capacity_ah=2.5, soc0=0.9,
                                   model="linear", map=True)
    fit.pop("model_v")
    fit_json = tmp_path / "fit.json"
    fit_json.write_text(json.dumps(fit))
    for model, model_file in ((fit, fit_json), (fit["map"], None)):
        if model_file is None:
            model_file = tmp_path / "map.csv"
            host_sim("identify", "battery", "--input", path, "--ocv", OCV, "--capacity-ah", "2.5",
                     "--soc0", "0.9", "--model", "linear", "--map-out", model_file)
        cli = cli_json(host_sim, tmp_path, "predict", "battery", "--model", model_file,
                       "--input", path, "--ocv", OCV, "--capacity-ah", "2.5", "--soc0", "0.9",
                       "--out", tmp_path / "pred.csv")
        py = fracbms.predict_battery(t, i, v, model=model, ocv=ocv_table(), capacity_ah=2.5,
                                     soc0=0.9)
        model_v = py.pop("model_v")
        # The samples the RMSE is taken over: the CLI's `observed` column.
        np.testing.assert_array_equal(py.pop("observed"),
                                      read_csv(tmp_path / "pred.csv")["observed"])
        for k in ("rmse_v", "max_error_v", "samples", "soc0", "unobserved_samples"):
            assert py[k] == pytest.approx(cli[k], rel=1e-9), k
        np.testing.assert_allclose(model_v, read_csv(tmp_path / "pred.csv")["model_v"],
                                   rtol=0, atol=1e-8)
        assert py["rmse_v"] < 2e-3
    with pytest.raises(ValueError, match="give ocv and capacity_ah"):
        fracbms.predict_battery(t, i, v, model=fit)
    with pytest.raises(ValueError, match=r"^temperature_c=-300: must be a temperature above absolute zero"):
        fracbms.predict_battery(t, i, v, model=fit["map"], ocv=ocv_table(), capacity_ah=2.5,
                                soc0=0.9, temperature_c=-300.0)


def test_online_with_a_map_prior_equals_the_cli(host_sim, tmp_path):
    """OnlineCell(prior=MAP.csv) runs `online battery --prior MAP.csv`: the
    prior follows the map's cell at the counted SOC; a map prior under a
    tight spread holds R_i at the map's value there."""
    from test_online import assert_same_track, cli_track
    path = tmp_path / "hppc.csv"
    t, i, v = hppc(path)
    map_csv = tmp_path / "map.csv"
    host_sim("identify", "battery", "--input", path, "--ocv", OCV, "--capacity-ah", "2.5",
             "--soc0", "0.9", "--model", "linear", "--map-out", map_csv)
    tight = ("--prior-factor", "1.02", "--prior-alpha-sigma", "0.005")
    cli = cli_track(host_sim, path, tmp_path, "--ocv", OCV, "--capacity-ah", "2.5", "--soc0",
                    "0.9", "--prior", map_csv, *tight)
    cell = fracbms.OnlineCell(ocv=ocv_table(), capacity_ah=2.5, soc0=0.9, prior=str(map_csv),
                              prior_factor=1.02, prior_alpha_sigma=0.005)
    py = cell.run(i, v, temperature_c=np.full(len(i), 25.0))
    assert_same_track(py, cli)
    tracking = py["status"] == "tracking"
    assert tracking.sum() > 1000
    # The map's levels all hold the same cell: R_i stays at it.
    np.testing.assert_allclose(py["r_i"][tracking], CELL["r_i"], rtol=0.05)
    with pytest.raises(ValueError, match="no-such-map.csv"):
        fracbms.OnlineCell(prior=str(tmp_path / "no-such-map.csv"))


def test_online_takes_a_fit_or_a_map_as_dicts(host_sim, tmp_path):
    """OnlineCell(prior=dict) is `online battery --prior FIT.json` for the
    dict identify_battery returns; OnlineCell(map=...) takes the map of
    identify_battery(map=True) (or the whole result) as the CSV's map."""
    from test_online import assert_same_track, cli_track
    path = tmp_path / "hppc.csv"
    t, i, v = hppc(path)
    kw = dict(ocv=ocv_table(), capacity_ah=2.5, soc0=0.9)
    fit = fracbms.identify_battery(t, i, v, model="linear", map=True, **kw)
    # The fit as a dict: the CLI's run with the fit's JSON.
    fit_json = tmp_path / "fit.json"
    fit_json.write_text(json.dumps({k: v for k, v in fit.items() if k != "model_v"}))
    cli = cli_track(host_sim, path, tmp_path, "--ocv", OCV, "--capacity-ah", "2.5", "--soc0",
                    "0.9", "--prior", fit_json)
    by_dict = fracbms.OnlineCell(prior=fit, **kw).run(i, v)
    assert_same_track(by_dict, cli)
    # The map as a dict, or inside the result: the same track as its CSV.
    map_csv = tmp_path / "map.csv"
    host_sim("identify", "battery", "--input", path, "--ocv", OCV, "--capacity-ah", "2.5",
             "--soc0", "0.9", "--model", "linear", "--map-out", map_csv)
    temp = np.full(len(i), 25.0)
    by_csv = fracbms.OnlineCell(map=str(map_csv), **kw).run(i, v, temperature_c=temp)
    for m in (fit["map"], fit):
        by_map = fracbms.OnlineCell(map=m, **kw).run(i, v, temperature_c=temp)
        assert list(by_map["status"]) == list(by_csv["status"])
        # The CSV keeps 10 significant digits of the map's numbers.
        np.testing.assert_allclose(by_map["r_i"], by_csv["r_i"], rtol=1e-6, equal_nan=True)
        np.testing.assert_allclose(by_map["r_ct"], by_csv["r_ct"], rtol=1e-6, equal_nan=True)
    tracking = by_csv["status"] == "tracking"
    assert tracking.sum() > 1000
    with pytest.raises(ValueError, match="give one"):
        fracbms.OnlineCell(prior=fit, map=fit["map"], **kw)
    with pytest.raises(ValueError, match="no levels"):
        fracbms.OnlineCell(map={"r_i": 0.02}, **kw)
    with pytest.raises(ValueError, match="map's CSV"):
        fracbms.OnlineCell(map=str(fit_json), **kw)
    with pytest.raises(ValueError, match="prior_factor=0.5"):
        fracbms.OnlineCell(prior=fit, prior_factor=0.5, **kw)
