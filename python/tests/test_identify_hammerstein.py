"""identify_hammerstein: `identify hammerstein --json` on arrays."""

import pytest

import fracbms
from conftest import cli_json, read_csv


@pytest.fixture(scope="module")
def paper_record(host_sim, tmp_path_factory):
    path = tmp_path_factory.mktemp("ham") / "ham.csv"
    host_sim("simulate", "hammerstein", "--preset", "paper-kt-stable", "--sigma", "0.5",
             "--length", "600", "--seed", "3", "--out", path)
    return path


@pytest.mark.parametrize("algorithm,method", [("op", "refined"), ("kt", "paper")])
def test_equals_the_cli(host_sim, paper_record, tmp_path, algorithm, method):
    cli = cli_json(host_sim, tmp_path, "identify", "hammerstein", "--input", paper_record,
                   "--na", "2", "--nb", "3", "--nc", "2", "--algorithm", algorithm,
                   "--method", method)
    c = read_csv(paper_record)
    py = fracbms.identify_hammerstein(c["u"], c["y"], na=2, nb=3, nc=2, algorithm=algorithm,
                                      method=method)
    assert py == cli
    assert py["method"] == method and py["algorithm"] == algorithm
    assert len(py["a"]) == 2 and len(py["b"]) == 3 and len(py["c"]) == 2
    if method == "refined":
        assert py["cost"] <= py["paper_cost"]
