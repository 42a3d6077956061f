"""simulate_battery: `simulate battery`'s noise-free voltage."""

import numpy as np
import pytest

import fracbms
from conftest import CELL, REPO, read_csv


def test_equals_the_cli_without_noise(host_sim, tmp_path):
    out = tmp_path / "sim.csv"
    host_sim("simulate", "battery", "--preset", "cell", "--profile", "drive", "--sigma", "0",
             "--length", "800", "--h", "0.5", "--out", out)
    c = read_csv(out)
    v = fracbms.simulate_battery(c["time_s"], c["current_a"], **CELL)
    # The CLI writes 9 decimals.
    np.testing.assert_allclose(v, c["voltage_v"], rtol=0, atol=6e-10)


def test_with_an_ocv_curve_and_butler_volmer_equals_the_cli(host_sim, tmp_path):
    ocv_file = REPO / "data" / "own-model" / "nmc-ocv.csv"
    out = tmp_path / "sim.csv"
    host_sim("simulate", "battery", "--preset", "cell", "--sigma", "0", "--length", "600",
             "--ocv", ocv_file, "--soc0", "0.6", "--capacity-ah", "2.5", "--mean-current", "-1",
             "--bv-a", "0.02", "--bv-i0", "1.5", "--out", out)
    c, o = read_csv(out), read_csv(ocv_file)
    cell = {k: CELL[k] for k in ("r_i", "r_ct", "q", "alpha")}
    v = fracbms.simulate_battery(c["time_s"], c["current_a"], **cell, bv_a_v=0.02, bv_i0_a=1.5,
                                 ocv=(o["soc"], o["ocv_v"]), capacity_ah=2.5, soc0=0.6)
    np.testing.assert_allclose(v, c["voltage_v"], rtol=0, atol=6e-10)
    shifted = fracbms.simulate_battery(c["time_s"], c["current_a"], **cell, bv_a_v=0.02,
                                       bv_i0_a=1.5, ocv=(o["soc"], o["ocv_v"]), capacity_ah=2.5,
                                       soc0=0.6, ocv_offset_v=0.01)
    np.testing.assert_allclose(shifted - v, 0.01, rtol=0, atol=1e-12)


def test_ohmic_step_from_rest():
    t = np.arange(10.0)
    v = fracbms.simulate_battery(t, np.full(10, -1.0), **CELL)
    # At the first sample of a 1 A discharge: U_oc − R_i·1 − the branch's first step.
    assert v[0] < CELL["u_oc"] - CELL["r_i"]
    assert np.all(np.diff(v) < 0)
    with pytest.raises(ValueError, match="u_oc goes without ocv"):
        fracbms.simulate_battery(t, t, **CELL, ocv=([0.0, 1.0], [3.0, 4.0]), capacity_ah=2.0,
                                 soc0=0.5)
