"""reflect.verify: the structure of `verify --json`, the CLI's numbers, errors."""

import json
import os
import signal
import threading

import pytest

import reflect
from conftest import plain


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
        assert plain(c[k]) == cli_doc["checks"][0][k], k


def test_bad_input(tmp_path):
    with pytest.raises(ValueError, match="unknown check 'lambret'; known: lambert"):
        reflect.verify(checks=["lambret"])
    with pytest.raises(ValueError, match="data folder not found"):
        reflect.verify(checks="lambert", data=tmp_path)


def test_ctrl_c_stops_verify(data_dir):
    """SIGINT during verify raises KeyboardInterrupt once the running check finishes.

    The quick `lambert` check 1000 times over would run for hours if the cancel flag were ignored,
    so a broken Ctrl-C shows up as a CI run that never ends, not as a timed assertion.
    """
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            reflect.verify(quick=True, checks=["lambert"] * 1000, data=data_dir)
    finally:
        timer.cancel()
