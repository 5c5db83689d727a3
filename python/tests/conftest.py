"""Shared fixtures: the checkout, the CLI binary to compare with, tiny scenes."""

import math
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def cli_binary():
    """The `reflect` binary: $REFLECT_BIN (must exist when set, as in CI), else the checkout's release build."""
    env = os.environ.get("REFLECT_BIN")
    if env:
        assert Path(env).is_file(), f"REFLECT_BIN={env} does not exist"
        return Path(env)
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    b = target / "release" / "reflect"
    if not b.is_file():
        # Missing prerequisites fail, never skip: a skipped test would pass CI without checking anything.
        pytest.fail(f"no reflect binary at {b} (build it with cargo build --release, or set REFLECT_BIN)")
    return b


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Under CI=true a skipped test fails: a skip there (missing data, a missing module) would pass CI
    without checking anything. Locally a skip stays a skip, and -rs (pyproject.toml) lists it."""
    outcome = yield
    report = outcome.get_result()
    if os.environ.get("CI") == "true" and report.skipped and not hasattr(report, "wasxfail"):
        reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
        report.outcome = "failed"
        report.longrepr = f"skipped under CI=true, which fails the run (a skip checks nothing): {reason}"


@pytest.fixture
def cli():
    b = cli_binary()

    def run(*args, check=True):
        return subprocess.run([str(b), *map(str, args)], capture_output=True, text=True, check=check, cwd=ROOT)

    return run


@pytest.fixture
def data_dir():
    d = Path(os.environ.get("REFLECT_DATA", ROOT.parent / "shared" / "data"))
    if not (d / "grace_probe.hdr").is_file():
        pytest.fail(f"missing data: no Grace probe in {d} (set REFLECT_DATA)")
    return d


# A unit Lambertian sphere under SH lighting, tiny: enough pixels on and off the sphere.
TINY = """
[render]
width = 12
height = 10
spp = 4
seed = 7
max_depth = 1

[camera]
type = "orthographic"
from = [3.0, 0.0, 1.0]
to = [0.0, 0.0, 0.0]
up = [0.0, 0.0, 1.0]
extent = 1.05

[lighting]
type = "sh"
coefficients = [[1.0, 0.9, 0.8], [0.1, 0.0, -0.1], [0.3, 0.2, 0.1], [0.0, 0.05, 0.0]]

[[objects]]
shape = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
brdf = { type = "lambert", albedo = [0.8, 0.7, 0.6] }
"""

TINY_DICT = {
    "render": {"width": 12, "height": 10, "spp": 4, "seed": 7, "max_depth": 1},
    "camera": {"type": "orthographic", "from": [3.0, 0.0, 1.0], "to": [0.0, 0.0, 0.0], "up": [0.0, 0.0, 1.0],
               "extent": 1.05},
    "lighting": {"type": "sh", "coefficients": [[1.0, 0.9, 0.8], [0.1, 0.0, -0.1], [0.3, 0.2, 0.1], [0.0, 0.05, 0.0]]},
    "objects": [{"shape": "sphere", "center": [0.0, 0.0, 0.0], "radius": 1.0,
                 "brdf": {"type": "lambert", "albedo": [0.8, 0.7, 0.6]}}],
}


@pytest.fixture
def tiny_scene(tmp_path):
    p = tmp_path / "tiny.toml"
    p.write_text(TINY)
    return p


def plain(v):
    """A report back in JSON's terms (arrays → lists, NaN → null), to compare with the CLI's document."""
    import reflect

    if isinstance(v, reflect.Table):  # records as columns: back to the list of objects
        return [plain(row) for row in v]
    if isinstance(v, np.generic):
        return plain(v.item())
    if isinstance(v, dict):
        return {k: plain(x) for k, x in v.items()}
    if isinstance(v, np.ndarray):
        return plain(v.tolist())
    if isinstance(v, list):
        return [plain(x) for x in v]
    if isinstance(v, float) and math.isnan(v):
        return None
    return v
