"""reflect.sh: projection, evaluation, transfer, rotation; shapes, dtypes, the CLI's numbers, errors."""

import json

import numpy as np
import pytest

import reflect
from reflect import sh

Y00 = 0.5 / np.sqrt(np.pi)  # 0.282095
Y1 = np.sqrt(3 / (4 * np.pi))  # 0.488603


def test_constant_map_projects_to_l0_only():
    for shape, mapping in (((8, 16, 3), "latlong"), ((9, 9, 3), "angular")):
        c = sh.project(np.full(shape, 2.0), lmax=3)
        assert c.dtype == np.float64 and c.shape == (16, 3)
        if mapping == "latlong":
            # Exact pixel integration: L_00 = ∫ 2 Y_00 dω = 2 · 4π Y_00.
            assert np.allclose(c[0], 2 * 4 * np.pi * Y00, rtol=1e-12)
            assert np.allclose(c[1:], 0, atol=1e-12)


def test_file_and_array_and_cli_agree(cli, data_dir):
    probe = data_dir / "grace_probe.hdr"
    c = sh.project(probe, lmax=4)
    assert c.shape == (25, 3) and c.dtype == np.float64
    doc = json.loads(cli("sh", "project", probe, "--lmax", 4, "--json").stdout)
    assert np.array_equal(c, np.array(doc["coefficients"]))
    img = reflect.read_image(probe)
    assert np.array_equal(sh.project(img.layer(), "angular", lmax=4), c)


def test_evaluate_matches_the_check_values():
    c = np.zeros((4, 3))
    c[sh.index(1, 0)] = [1.0, 2.0, 3.0]  # Y_10 = 0.488603 z
    d = np.array([[0, 0, 1], [0, 0, -2.0], [1, 0, 0]])
    v = sh.evaluate(c, d)
    assert v.shape == (3, 3) and v.dtype == np.float64
    assert np.allclose(v[0], Y1 * np.array([1, 2, 3])) and np.allclose(v[1], -v[0]) and np.allclose(v[2], 0)
    # Scalar coefficients and any leading shape of directions.
    s = sh.evaluate(np.eye(4)[0], np.ones((2, 5, 3)))
    assert s.shape == (2, 5) and np.allclose(s, Y00)


def test_project_then_evaluate_reconstructs_a_band_limited_map():
    h = 64
    theta = np.pi * (np.arange(h) + 0.5) / h
    z = np.cos(theta)[:, None, None] * np.ones((h, 2 * h, 3))
    c = sh.project(1.0 + z, "latlong", lmax=2)
    # ∫ z Y_10 dω = Y1 · 4π/3 (up to the map's piecewise-constant rows), and back: 1 + z at the pole.
    assert np.allclose(c[sh.index(1, 0)], Y1 * 4 * np.pi / 3, rtol=2e-3)
    assert np.allclose(sh.evaluate(c, [[0, 0, 1]]), 2, rtol=2e-3)


def test_transfer():
    f = sh.transfer("lambert", 8)
    assert f.shape == (9,) and f.dtype == np.float64
    assert np.allclose(f, [1, 2 / 3, 1 / 4, 0, -1 / 24, 0, 1 / 64, 0, -1 / 128], atol=1e-12)
    assert np.allclose(sh.transfer("mirror", 3), 1)
    # Integer Phong exponent: zero when l ≥ s + 2 and l ≡ s (mod 2).
    p = sh.transfer("phong", 10, s=4)
    assert p[0] == pytest.approx(1) and abs(p[6]) < 1e-12 and abs(p[8]) < 1e-12
    ts = sh.transfer("torrance-sparrow", 6, sigma=0.1)
    assert np.all(np.diff(ts) < 0)


def test_rotate():
    c = np.zeros((9, 3))
    c[sh.index(1, 0)] = 1.0  # f = z
    # R: +90° about y carries z to x, so f_R(ω) = f(Rᵀω) = x: all weight on Y_11.
    r = sh.rotate(c, [0, 90, 0])
    assert r.shape == (9, 3) and np.allclose(r[sh.index(1, 1)], 1) and np.allclose(np.delete(r, 3, 0), 0, atol=1e-12)
    m = sh.rotation_xyz_deg([0, 90, 0])
    assert np.allclose(m @ [0, 0, 1], [1, 0, 0])
    assert np.allclose(sh.rotate(c[:, 0], m), r[:, 0])


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: sh.project(np.ones((4, 8, 3)), lmax=500), r"lmax= must be an integer in 0\.\.=200, got 500"),
        (lambda: sh.project(np.ones((4, 8, 3)), "cubemap", lmax=2), 'unknown mapping "cubemap"'),
        (lambda: sh.project(np.ones((4, 7, 3)), lmax=2), "cannot infer the mapping"),
        (lambda: sh.project(np.ones((4, 8)), lmax=2), r"shape \(H, W, 3\)"),
        (lambda: sh.project(np.full((4, 8, 3), np.nan), lmax=2), "non-finite"),
        (lambda: sh.evaluate(np.ones((5, 3)), [[0, 0, 1]]), "not \\(lmax\\+1\\)²"),
        (lambda: sh.evaluate(np.ones((4, 3)), [[0, 0, 0]]), "not a finite non-zero vector"),
        (lambda: sh.rotate(np.ones((4, 3)), np.diag([1.0, 1.0, -1.0])), "not a rotation"),
        (lambda: sh.transfer("phong", 4), "needs"),
        (lambda: sh.transfer("phong", 4, s=-1), "s"),
        (lambda: sh.transfer("velvet", 4), "unknown"),
        (lambda: sh.transfer("lambert", 4, s=3), "does not apply"),
    ],
)
def test_bad_input_is_value_error(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_missing_map_is_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.hdr"):
        sh.project(tmp_path / "nope.hdr", lmax=2)
    with pytest.raises(FileNotFoundError):
        reflect.read_image(tmp_path / "nope.exr")
