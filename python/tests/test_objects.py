"""The object API: BRDF and light objects over NumPy batches, renders to a target error, errors of our
own, no temporary files, Ctrl-C.

Monte Carlo checks use fixed seeds and tolerances of k = 5 standard errors of the estimate (σ from the
samples' own spread): with the 9 such comparisons in this file (Bonferroni), a correct implementation
fails with probability < 9 · 6e-7 ≈ 5e-6, while the planted errors named in each test move the mean by
far more than 5σ.
"""

import math
import os
import signal
import tempfile
import threading

import numpy as np
import pytest

import reflect
from reflect.brdf import Lambert, Microfacet, Mirror, Phong, TorranceSparrow

K = 5.0


def hemisphere(n, seed):
    """n uniform directions on the upper hemisphere (density 1/2π) and their density."""
    rng = np.random.default_rng(seed)
    u = rng.random((n, 2))
    z = u[:, 0]
    r = np.sqrt(np.maximum(0.0, 1 - z * z))
    phi = 2 * np.pi * u[:, 1]
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1), 1 / (2 * np.pi)


def direction(theta_deg, phi_deg=30.0):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def test_lambert_eval_is_albedo_cos_over_pi_and_zero_below_the_horizon():
    albedo = np.array([0.8, 0.5, 0.2])
    b = Lambert(albedo)
    wi, _ = hemisphere(1000, 1)
    wo = direction(40)
    f = b.eval(wi, wo)
    assert f.shape == (1000, 3) and f.dtype == np.float32
    np.testing.assert_allclose(f, albedo[None, :] * wi[:, 2:3] / np.pi, rtol=1e-5, atol=1e-7)
    below = wi * np.array([1, 1, -1])
    assert np.all(b.eval(below, wo) == 0)
    # The BRDF value itself is eval / cos θ_i (docs: eval includes the cosine).
    np.testing.assert_allclose(f / wi[:, 2:3], np.broadcast_to(albedo / np.pi, f.shape), rtol=1e-4)
    # pdf: cosine-weighted.
    np.testing.assert_allclose(b.pdf(wi, wo), wi[:, 2] / np.pi, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize(
    "brdf",
    [
        Lambert([0.9, 0.6, 0.3]),
        Phong(s=20.0, ks=0.7),
        TorranceSparrow(sigma=0.3, ks=0.8),
        Microfacet(alpha=0.3),
        Microfacet(alpha=0.5, distribution="ggx", fresnel="schlick", f0=[0.9, 0.6, 0.3]),
    ],
    ids=["lambert", "phong", "torrance-sparrow", "beckmann", "ggx-schlick"],
)
def test_sample_weight_pdf_and_eval_agree(brdf):
    """weight = eval/pdf and pdf = pdf(wi) at every drawn direction, and the mean weight (the directional
    albedo by importance sampling) equals the albedo by uniform hemisphere sampling of eval, within
    K σ of the two estimates combined."""
    wo = direction(35)
    n = 200_000
    rng = np.random.default_rng(7)
    s = brdf.sample(wo, rng.random((n, 2)))
    ok = s.pdf > 0
    assert ok.mean() > 0.5
    np.testing.assert_allclose(brdf.pdf(s.wi[ok], wo), s.pdf[ok], rtol=2e-4)
    np.testing.assert_allclose(brdf.eval(s.wi[ok], wo), s.weight[ok] * s.pdf[ok, None], rtol=2e-4, atol=1e-6)
    est = s.weight.astype(np.float64)  # failed samples weigh 0
    wi, p = hemisphere(n, 8)
    quad = brdf.eval(wi, wo).astype(np.float64) / p
    m1, m2 = est.mean(0), quad.mean(0)
    sigma = np.sqrt(est.var(0) / n + quad.var(0) / n)
    assert np.all(np.abs(m1 - m2) <= K * sigma + 1e-9), (m1, m2, sigma)
    assert np.all(m1 > 0) and np.all(m1 < 1.0 + K * sigma)


def test_white_furnace_of_lambert_weights():
    """Cosine sampling of a Lambertian BRDF: every weight is the albedo, so the mean is the albedo."""
    b = Lambert(0.75)
    s = b.sample([0, 0, 1], np.random.default_rng(3).random((10_000, 2)))
    n = len(s.weight)
    m, sigma = s.weight.mean(0), s.weight.std(0) / math.sqrt(n)
    assert np.all(np.abs(m - 0.75) <= K * sigma + 1e-6), (m, sigma)
    assert not s.delta.any() and np.all(s.wi[:, 2] > 0)


def test_mirror_samples_the_reflection_as_a_dirac_lobe():
    wo = direction(30)
    s = Mirror(0.9).sample(wo, np.random.default_rng(0).random((5, 2)))
    assert s.delta.all()
    np.testing.assert_allclose(s.wi, np.tile(wo * np.array([-1, -1, 1]), (5, 1)), atol=1e-6)
    np.testing.assert_allclose(s.weight, 0.9, rtol=1e-6)
    assert np.all(Mirror(0.9).eval(s.wi, wo) == 0)


def test_uniform_light_furnace_and_envmap_consistency(data_dir):
    u = reflect.light.Uniform([1.0, 2.0, 3.0])
    s = u.sample(np.random.default_rng(1).random((1000, 2)))
    # Uniform sphere sampling: weight = L · 4π exactly.
    np.testing.assert_allclose(s.weight, np.tile([4 * np.pi, 8 * np.pi, 12 * np.pi], (1000, 1)), rtol=1e-5)
    np.testing.assert_allclose(u.pdf(s.wi), 1 / (4 * np.pi), rtol=1e-5)
    env = reflect.light.Envmap(data_dir / "grace_probe.hdr", mapping="angular")
    s = env.sample(np.random.default_rng(2).random((20_000, 2)))
    ok = s.pdf > 0
    np.testing.assert_allclose(env.pdf(s.wi[ok]), s.pdf[ok], rtol=1e-4)
    np.testing.assert_allclose(env.eval(s.wi[ok]), s.weight[ok] * s.pdf[ok, None], rtol=1e-4, atol=1e-6)
    # ∫L dω by importance sampling and by uniform sphere sampling agree within K σ.
    n = 400_000
    rng = np.random.default_rng(5)
    z = 2 * rng.random(n) - 1
    phi = 2 * np.pi * rng.random(n)
    r = np.sqrt(1 - z * z)
    d = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    uni = env.eval(d).astype(np.float64) * 4 * np.pi
    imp = s.weight.astype(np.float64)
    sigma = np.sqrt(uni.var(0) / n + imp.var(0) / len(imp))
    assert np.all(np.abs(uni.mean(0) - imp.mean(0)) <= K * sigma), (uni.mean(0), imp.mean(0), sigma)
    # The renderer's compensated table samples only the texels brighter than the mean: alone, its
    # samples miss the rest of ∫L dω (by far more than K σ), and their density is 0 on the darker
    # texels, which the default table samples.
    comp = reflect.light.Envmap(data_dir / "grace_probe.hdr", mapping="angular", compensated=True)
    sc = comp.sample(np.random.default_rng(2).random((20_000, 2)))
    missed = uni.mean(0) - sc.weight.astype(np.float64).mean(0)
    assert np.all(missed > K * np.sqrt(uni.var(0) / n + sc.weight.var(0) / len(sc.weight))), missed
    dark = (comp.pdf(d[:2000]) == 0) & (env.pdf(d[:2000]) > 0)
    assert dark.sum() > 100, dark.sum()


def test_batches_broadcast_and_bad_arrays_name_the_keyword():
    b = Microfacet(alpha=0.2)
    wi, _ = hemisphere(4, 0)
    assert b.eval(wi, [0, 0, 1]).shape == (4, 3) and b.pdf(wi, [0, 0, 1]).shape == (4,)
    np.testing.assert_array_equal(b.eval(wi, [0, 0, 1]), b.eval(wi, np.tile([0, 0, 1.0], (4, 1))))
    with pytest.raises(reflect.InputError, match="wi= must hold unit vectors"):
        b.eval([[0, 0, 2.0]], [0, 0, 1])
    with pytest.raises(reflect.InputError, match=r"wo= must have shape \(N, 3\)"):
        b.pdf(wi, [0, 1])
    with pytest.raises(reflect.InputError, match="u= must hold numbers in"):
        b.sample([0, 0, 1], [[0.5, 1.5]])
    with pytest.raises(reflect.InputError, match="rows"):
        b.eval(wi, wi[:2])
    with pytest.raises(reflect.InputError, match="alpha= must be positive"):
        Microfacet(alpha=-1)
    with pytest.raises(ValueError, match="distribution"):
        Microfacet(alpha=0.1, distribution="phong")
    # Our classes, under the built-in ones a caller already catches.
    assert issubclass(reflect.InputError, reflect.Error) and issubclass(reflect.InputError, ValueError)
    assert issubclass(reflect.MissingFileError, FileNotFoundError) and issubclass(reflect.FileError, OSError)
    with pytest.raises(reflect.MissingFileError):
        reflect.light.Envmap("no/such/map.hdr")


def test_render_to_a_target_error(tiny_scene):
    target = 0.1
    r = reflect.render(tiny_scene, spp=4096, seed=3, target_rel_error=target)
    assert r.stats["stopped_by"] == "target" and r.stats["rel_error_p95"] <= target
    assert 16 <= r.spp < 4096 and r.stats["spp"] == r.spp and r.seed == 3 and r.sampler == "sobol"
    assert r.stats["passes"] >= 2 and r.seconds >= 0
    # It stopped at the first pass that reached the target: half the samples did not (their error is above
    # it, or has no estimate: over 5 % of the pixels flagged, which never reaches a target).
    half = reflect.render(tiny_scene, spp=r.spp // 2, seed=3).stats
    assert half["rel_error_p95"] is None and half["rel_error_unknown"] or half["rel_error_p95"] > target
    # The image is the plain render of the samples reached, bit for bit.
    plain = reflect.render(tiny_scene, spp=r.spp, seed=3)
    assert np.array_equal(plain.rgb, r.rgb) and np.array_equal(plain.stderr, r.stderr)
    assert plain.stats["stopped_by"] == "spp-cap" and plain.stats["rel_error_p95"] is not None
    with pytest.raises(reflect.InputError, match="target_rel_error= must be a positive number"):
        reflect.render(tiny_scene, target_rel_error=0)
    with pytest.raises(reflect.InputError, match="time_limit="):
        reflect.render(tiny_scene, time_limit=float("nan"))
    with pytest.raises(reflect.InputError, match="checkpoint_every= needs checkpoint="):
        reflect.render(tiny_scene, checkpoint_every=5)


def test_render_and_objects_write_no_temporary_file(tiny_scene, tmp_path, monkeypatch):
    """No temporary file anywhere: TMPDIR (read by Rust's temp_dir and Python's tempfile) and the working
    directory are empty folders that must stay empty, and Python's tempfile refuses to be used."""
    tmp, cwd = tmp_path / "tmp", tmp_path / "cwd"
    tmp.mkdir()
    cwd.mkdir()
    monkeypatch.setenv("TMPDIR", str(tmp))
    monkeypatch.chdir(cwd)
    monkeypatch.setattr(tempfile, "tempdir", None)

    def refuse(*a, **k):
        raise AssertionError("a temporary file was asked for")

    for name in ("mkstemp", "mkdtemp", "NamedTemporaryFile", "TemporaryFile", "TemporaryDirectory", "gettempdir"):
        monkeypatch.setattr(tempfile, name, refuse)
    r = reflect.render(tiny_scene, spp=64, target_rel_error=0.2)
    assert r.rgb.shape == (10, 12, 3)
    Microfacet(alpha=0.3).sample([0, 0, 1], np.full((10, 2), 0.5))
    assert list(tmp.iterdir()) == [] and list(cwd.iterdir()) == []


def test_ctrl_c_stops_a_progressive_render_and_keeps_its_checkpoint(tiny_scene, tmp_path):
    """SIGINT (from a timer thread) during a long render to an unreachable target raises KeyboardInterrupt;
    the checkpoint then holds the last finished pass, and the same call resumes from it to the plain
    render's bits."""
    ck = tmp_path / "ck.exr"
    big = dict(size=(64, 64), spp=1 << 20, seed=2, target_rel_error=1e-9, checkpoint=ck, checkpoint_every=3600)
    timer = threading.Timer(1.0, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            reflect.render(tiny_scene, **big)
    finally:
        timer.cancel()
    assert ck.is_file()
    # Resumed (same scene, seed and spp cap), now with a time limit so that it ends.
    done = reflect.render(tiny_scene, **big, time_limit=0.5)
    assert done.stats["stopped_by"] == "time-limit" and not ck.exists()
    plain = reflect.render(tiny_scene, size=(64, 64), spp=done.spp, seed=2)
    assert np.array_equal(done.rgb, plain.rgb) and np.array_equal(done.stderr, plain.stderr)
