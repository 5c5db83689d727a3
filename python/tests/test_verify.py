"""reflect.verify: the structure of `verify --json`, the CLI's numbers, errors."""

import json

import pytest

import reflect


def test_list_checks_is_the_cli_list(cli):
    names = [line.split()[0] for line in cli("verify", "--list").stdout.splitlines() if line.strip()]
    assert [n for n, _ in reflect.list_checks()] == names


def test_verify_structure_and_same_numbers_as_the_cli(cli, data_dir, tmp_path):
    doc = reflect.verify(quick=True, checks="lambert", seed=3, data=data_dir, out=tmp_path / "report")
    assert set(doc) >= {"checks", "passed", "quick", "k_sigma", "seconds"}
    assert doc["quick"] is True and isinstance(doc["passed"], bool)
    (c,) = doc["checks"]
    assert set(c) >= {"name", "equation", "passed", "measured", "expected", "tolerance"}
    assert c["name"] == "lambert" and c["passed"] is True
    assert (tmp_path / "report" / "report.json").is_file()
    # The same renders and numbers as the command line (timings aside).
    cli_doc = json.loads(
        cli("verify", "--quick", "--check", "lambert", "--seed", 3, "--data", data_dir, "--json",
            "--out", tmp_path / "cli").stdout
    )
    for k in ("measured", "expected", "tolerance", "passed"):
        assert c[k] == cli_doc["checks"][0][k], k


def test_bad_input(tmp_path):
    with pytest.raises(ValueError, match="unknown check 'lambret'; known: lambert"):
        reflect.verify(checks=["lambret"])
    with pytest.raises(ValueError, match="data folder not found"):
        reflect.verify(checks="lambert", data=tmp_path)
