"""Snapshots in Python (docs/persistence.md): ``OnlineCell.save_state`` is
the CLI's ``--state-out`` byte for byte, a record resumed from it in two
halves publishes what the whole run does, and a bad snapshot raises and
leaves the cell clean."""

import numpy as np
import pytest

import fracbms
from conftest import REPO, read_csv

CAP = 5.153198325955154
CUT = 2900


def _data():
    rec = REPO / "data" / "pybamm" / "chen2020-hppc.csv"
    ocv = REPO / "data" / "pybamm" / "chen2020-ocv.csv"
    return rec, ocv, read_csv(rec), read_csv(ocv)


def _cell(o, **kw):
    return fracbms.OnlineCell(ocv=(o["soc"], o["ocv_v"]), capacity_ah=CAP, **kw)


@pytest.mark.parametrize("slow_memory_s, size", [(None, 148), (600.0, 188)])
def test_save_state_is_the_clis_state_out(host_sim, tmp_path, slow_memory_s, size):
    """With the slow part carried across windows the snapshot keeps it
    too (188 B), on both faces alike."""
    rec, ocv, c, o = _data()
    first = tmp_path / "first.csv"
    lines = rec.read_text().splitlines()
    first.write_text("\n".join(lines[: CUT + 1]) + "\n")
    state = tmp_path / "state.bin"
    slow = [] if slow_memory_s is None else ["--slow-memory-s", slow_memory_s]
    host_sim("online", "battery", "--input", first, "--out", tmp_path / "t.csv",
             "--ocv", ocv, "--capacity-ah", CAP, "--state-out", state, *slow)
    cell = _cell(o, slow_memory_s=slow_memory_s)
    cell.run(c["current_a"][:CUT], c["voltage_v"][:CUT])
    # The CLI saves at the record's last time, CUT - 1 s.
    assert cell.save_state(saved_at_s=float(CUT - 1)) == state.read_bytes()
    assert len(state.read_bytes()) == size


def test_a_record_resumed_in_two_halves_publishes_the_whole_runs_values():
    _, _, c, o = _data()
    whole = _cell(o).run(c["current_a"], c["voltage_v"])
    first = _cell(o)
    first.run(c["current_a"][:CUT], c["voltage_v"][:CUT])
    snapshot = first.save_state(saved_at_s=float(CUT - 1))
    second = _cell(o)
    second.restore_state(snapshot, now_s=float(CUT))
    assert second.restoration == "restored"
    half = second.run(c["current_a"][CUT:], c["voltage_v"][CUT:])
    for k in ["r_i", "r_ct", "q", "alpha", "soc"]:
        a, b = half[k], whole[k][CUT:]
        # The first sample: within 1 % (what was published before the cut).
        if np.isfinite(b[0]):
            assert a[0] == pytest.approx(b[0], rel=0.01), k
        # Once the window has refilled and been refitted.
        for j in [300, 1000, len(a) - 1]:
            if np.isfinite(b[j]) or np.isfinite(a[j]):
                assert a[j] == pytest.approx(b[j], rel=1e-6), (k, j)
    assert half["r_i_status"][0] == "restored"


def test_a_bad_snapshot_raises_and_the_cell_stays_clean():
    _, _, c, o = _data()
    first = _cell(o)
    first.run(c["current_a"][:CUT], c["voltage_v"][:CUT])
    good = bytearray(first.save_state())
    bad = bytes(good[:30]) + bytes([good[30] ^ 1]) + bytes(good[31:])
    cell = _cell(o)
    with pytest.raises(ValueError, match="snapshot rejected: snapshot CRC mismatch"):
        cell.restore_state(bad)
    with pytest.raises(ValueError, match="bad magic"):
        cell.restore_state(b"\xff" * 148)
    assert cell.restoration == "clean"
    track = cell.run(c["current_a"][:300], c["voltage_v"][:300])
    assert not np.any(track["r_i_status"] == "restored")
