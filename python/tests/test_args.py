"""Every bad keyword argument of the package is a ValueError naming the keyword: negative or too
large integers, floats where an integer is needed (3.0 included: no silent truncation), bools where
a number is needed, NaN, ±inf and wrong types; never an OverflowError or TypeError naming nothing."""

import math

import numpy as np
import pytest

import reflect
from reflect import invert, sh

from conftest import TINY

BAD_INTS = [-1, 2**64, 2.5, 3.0, True, math.nan, "3", None.__class__]


@pytest.mark.parametrize("kw", ["spp", "seed", "threads"])
@pytest.mark.parametrize("bad", BAD_INTS)
def test_render_integers(kw, bad):
    with pytest.raises(ValueError, match=rf"\b{kw}="):
        reflect.render(TINY, **{kw: bad})


@pytest.mark.parametrize("bad", [(32.5, 8), (32.0, 8), (-1, 8), (8, 2**32), (True, 8), (8,), 8, "8x8", (8, math.nan)])
def test_render_size(bad):
    with pytest.raises(ValueError, match=r"\bsize="):
        reflect.render(TINY, size=bad)


def test_render_other_keywords():
    with pytest.raises(ValueError, match=r"\bsampler="):
        reflect.render(TINY, sampler=3)
    with pytest.raises(ValueError, match=r"\bprogress="):
        reflect.render(TINY, progress=1)


def test_render_accepts_numpy_integers_and_the_result_is_the_int_one():
    a = reflect.render(TINY, spp=np.int64(2), size=(np.int32(6), 5), seed=np.uint64(3))
    b = reflect.render(TINY, spp=2, size=(6, 5), seed=3)
    assert np.array_equal(a.rgb, b.rgb)


@pytest.mark.parametrize(
    "call, kw",
    [
        (lambda: sh.project(np.ones((4, 8, 3)), lmax=-1), "lmax"),
        (lambda: sh.project(np.ones((4, 8, 3)), lmax=2.5), "lmax"),
        (lambda: sh.project(np.ones((4, 8, 3)), lmax=2.0), "lmax"),
        (lambda: sh.project(np.ones((4, 8, 3)), lmax=True), "lmax"),
        (lambda: sh.project(np.ones((4, 8, 3)), lmax=2**64), "lmax"),
        (lambda: sh.project(np.ones((4, 8, 3)), mapping=1, lmax=2), "mapping"),
        (lambda: sh.transfer("lambert", -1), "lmax"),
        (lambda: sh.transfer("lambert", 4.5), "lmax"),
        (lambda: sh.transfer("phong", 4, s=math.nan), "s"),
        (lambda: sh.transfer("phong", 4, s=True), "s"),
        (lambda: sh.transfer("phong", 4, s="8"), "s"),
        (lambda: sh.transfer("torrance-sparrow", 4, sigma=math.inf), "sigma"),
        (lambda: sh.transfer("torrance-sparrow", 4, sigma=0.1, theta_o_deg=math.nan), "theta_o_deg"),
        (lambda: sh.transfer(3, 4), "brdf"),
        (lambda: sh.index(2.0, 1), "l"),
        (lambda: sh.index(2, 0.5), "m"),
        (lambda: sh.lm(-1), "k"),
        (lambda: sh.lm(3.5), "k"),
    ],
)
def test_sh_arguments(call, kw):
    with pytest.raises(ValueError, match=rf"\b{kw}="):
        call()


def test_verify_arguments():
    for kw, bad in [("seed", -1), ("seed", 1.5), ("threads", 0), ("threads", 2.0), ("quick", 1)]:
        with pytest.raises(ValueError, match=rf"\b{kw}="):
            reflect.verify(**{kw: bad})
    with pytest.raises(ValueError, match=r"\bchecks="):
        reflect.verify(checks=[1])


@pytest.fixture
def tiny_exr(tmp_path):
    p = tmp_path / "tiny.exr"
    reflect.render(TINY, size=(16, 16), spp=2).save(str(p))
    return str(p)


@pytest.mark.parametrize(
    "call, kw",
    [
        (lambda f: reflect.analyze(f, lmax=2.5), "lmax"),
        (lambda f: reflect.analyze(f, lmax=-1), "lmax"),
        (lambda f: reflect.analyze(f, lmax=True), "lmax"),
        (lambda f: reflect.analyze(f, lmax=math.nan), "lmax"),
        (lambda f: reflect.analyze(f, lmax=2, albedo=math.nan), "albedo"),
        (lambda f: reflect.analyze(f, lmax=2, param="normals"), "param"),
        (lambda f: reflect.analyze(f, lmax=2, brdf="blinn"), "brdf"),
        (lambda f: invert.lighting(f, lmax=1.5), "lmax"),
        (lambda f: invert.lighting(f, lmax=1, max_amplification=0.5), "max_amplification"),
        (lambda f: invert.brdf(f, model="blinn", lmax=2), "model"),
        (lambda f: invert.brdf(f, model="phong", lmax=2, min=math.inf), "min"),
    ],
)
def test_command_keywords(tiny_exr, call, kw):
    with pytest.raises(ValueError, match=rf"\b{kw}="):
        call(tiny_exr)


def test_json_null_becomes_nan_in_float_arrays():
    """The reports' JSON → NumPy rule (how-to/python.md): a list of numbers with a null is float64 with NaN
    there; integers alone are int64; lists of strings, and ragged lists, are not arrays."""
    from reflect._analysis import _arrays

    out = _arrays(
        {
            "coefficients": [[1.5, None], [None, 2.0]],
            "lm": [0, 1, 2],
            "sigma": [None, None],
            "nested": {"x": [1, None]},
            "names": ["a", None],
            "ragged": [[1.0], [2.0, None]],
        }
    )
    c = out["coefficients"]
    assert c.dtype == np.float64 and c.shape == (2, 2)
    assert np.isnan(c[0, 1]) and np.isnan(c[1, 0]) and c[0, 0] == 1.5 and c[1, 1] == 2.0
    assert out["lm"].dtype == np.int64 and out["lm"].tolist() == [0, 1, 2]
    assert out["sigma"].dtype == np.float64 and np.isnan(out["sigma"]).all()
    x = out["nested"]["x"]
    assert x.dtype == np.float64 and x[0] == 1.0 and np.isnan(x[1])
    assert out["names"] == ["a", None]
    assert isinstance(out["ragged"], list) and np.isnan(out["ragged"][1][1])
