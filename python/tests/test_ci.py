"""The test run itself: under CI=true a skipped test fails the run; locally skips are listed (-rs)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent


def test_skip_probe():
    """Skips when REFLECT_SKIP_PROBE=1 (run only by the test below), passes otherwise."""
    if os.environ.get("REFLECT_SKIP_PROBE") == "1":
        pytest.skip("probe skip: no data")


def _run_probe(ci):
    env = {k: v for k, v in os.environ.items() if k != "CI"}
    env["REFLECT_SKIP_PROBE"] = "1"
    if ci:
        env["CI"] = "true"
    return subprocess.run(
        [sys.executable, "-m", "pytest", f"{HERE / 'test_ci.py'}::test_skip_probe", "-p", "no:cacheprovider"],
        capture_output=True,
        text=True,
        env=env,
        cwd=HERE.parent,
    )


def test_a_skip_fails_under_ci_and_is_reported_otherwise():
    local = _run_probe(ci=False)
    assert local.returncode == 0, local.stdout + local.stderr
    assert "SKIPPED" in local.stdout and "probe skip: no data" in local.stdout, "-rs lists the skip and its reason"
    ci = _run_probe(ci=True)
    assert ci.returncode == 1, ci.stdout + ci.stderr
    assert "skipped under CI=true" in ci.stdout and "probe skip: no data" in ci.stdout, ci.stdout
