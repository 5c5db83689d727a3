"""reflect.analyze and reflect.invert on arrays and renders write no file: no temporary file through
Python's tempfile or open(…, "w"), and nothing in a fresh TMPDIR or working folder (the native
code's writes would land there)."""

import builtins
import os
import tempfile

import numpy as np
import pytest

import reflect
from conftest import ROOT, TINY

PROBE = TINY.replace(
    '[camera]\ntype = "orthographic"\nfrom = [3.0, 0.0, 1.0]\nto = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nextent = 1.05',
    '[camera]\ntype = "normal-probe"',
)
assert PROBE != TINY


class Written(AssertionError):
    pass


@pytest.fixture
def no_writes(monkeypatch, tmp_path):
    """Every tempfile function and open() for writing raise; TMPDIR and the working folder are fresh
    empty folders, checked empty afterwards."""
    tmp, cwd = tmp_path / "tmp", tmp_path / "cwd"
    tmp.mkdir()
    cwd.mkdir()
    monkeypatch.setenv("TMPDIR", str(tmp))
    monkeypatch.setattr(tempfile, "tempdir", str(tmp))
    monkeypatch.chdir(cwd)

    def refuse(name):
        def f(*args, **kwargs):
            raise Written(f"tempfile.{name} called")

        return f

    for name in ("mkstemp", "mkdtemp", "mktemp", "NamedTemporaryFile", "TemporaryFile", "SpooledTemporaryFile",
                 "TemporaryDirectory"):
        monkeypatch.setattr(tempfile, name, refuse(name))
    real_open = builtins.open

    def guarded_open(file, mode="r", *args, **kwargs):
        if any(c in mode for c in "wax+"):
            raise Written(f"open({file!r}, {mode!r})")
        return real_open(file, mode, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", guarded_open)
    yield
    assert list(tmp.iterdir()) == [] and list(cwd.iterdir()) == [], (list(tmp.iterdir()), list(cwd.iterdir()))


@pytest.fixture
def renders():
    ortho = reflect.render(TINY, size=(24, 24), spp=8)
    probe = reflect.render(PROBE, size=(32, 16), spp=8)
    return ortho, probe


def test_the_guard_catches_writes(no_writes):
    """The instrumentation itself: a temporary folder or a file opened for writing is caught."""
    with pytest.raises(Written):
        tempfile.TemporaryDirectory()
    with pytest.raises(Written):
        open("x.txt", "w")


def test_analyze_and_invert_on_arrays_write_no_file(renders, no_writes):
    ortho, probe = renders
    cam = {"type": "orthographic", "from": [3.0, 0.0, 1.0], "extent": 1.05}
    sphere = {"center": [0, 0, 0], "radius": 1.0, "brdf": {"type": "lambert", "albedo": [0.8, 0.7, 0.6]}}
    lighting = np.array([[1.0, 0.9, 0.8], [0.1, 0.0, -0.1], [0.3, 0.2, 0.1], [0.0, 0.05, 0.0]])
    a = reflect.analyze(ortho.rgb, lmax=2, camera=cam, sphere=sphere, lighting=lighting, stderr=ortho.stderr)
    assert a.coefficients.shape == (9, 3) and a.images == ["<array 0>"] and a.verdict is not None
    assert reflect.analyze(ortho, lmax=2).filter is not None
    inv = reflect.invert.lighting(probe.rgb, lmax=2, camera={"type": "normal-probe"}, sphere=sphere,
                                  stderr=probe.stderr)
    assert inv.coefficients.shape == (9, 3) and np.isfinite(inv.coefficients[:4]).all()
    assert reflect.invert.lighting(probe, lmax=2).lambda_rho.shape == (3,)
    fit = reflect.invert.brdf(probe.rgb, model="phong", lmax=2, camera={"type": "normal-probe"},
                              sphere={"brdf": {"type": "phong", "s": 8.0}},
                              lighting={"type": "directional", "direction": [0.3, 0.2, 1.0], "irradiance": 3.0})
    assert fit.parameter == "s" and fit.profile.ndim == 2


def test_invert_factor_writes_no_file(no_writes):
    """The light field of a scene rendered in memory, and views given as arrays, factor without a file."""
    scene = ROOT / "scenes/factor-microfacet-directional.toml"
    r = reflect.invert.factor(scene=scene, nodes=(2, 4), lmax=2, size=(16, 8))
    assert r.renders["count"] == 9 and r.lighting.shape == (9,)
