"""reflect.render: same bits as the CLI, array shapes and dtypes, scene sources, errors, GIL, Ctrl-C."""

import os
import signal
import threading

import numpy as np
import pytest

import reflect
from conftest import TINY, TINY_DICT


def test_same_bits_as_the_cli(cli, tiny_scene, tmp_path):
    out_cli = tmp_path / "cli.exr"
    cli("render", tiny_scene, "--out", out_cli, "--spp", 3, "--seed", 11, "--size", "9x7", "--quiet")
    r = reflect.render(tiny_scene, spp=3, seed=11, size=(9, 7))
    img = reflect.read_image(out_cli)
    assert np.array_equal(r.rgb, img.layer(""))
    assert np.array_equal(r.stderr, img.layer("stderr."))
    assert np.array_equal(r.normal, img.layer("normal."))
    assert np.array_equal(r.mask, img.channels["mask.Y"])
    # save() writes the same file: every channel and every header attribute. (Not byte for byte:
    # the exr crate keeps attributes in a HashMap, so their order differs from process to process.)
    out_py = tmp_path / "py.exr"
    r.save(out_py)
    saved = reflect.read_image(out_py)
    assert saved.attributes == img.attributes and "reflect:scene" in saved.attributes
    assert saved.channels.keys() == img.channels.keys()
    for name, a in img.channels.items():
        assert np.array_equal(saved.channels[name], a), name


def test_stderr_flag_is_the_cli_layer(cli, tiny_scene, tmp_path):
    # 16 samples (the fewest the flag is judged from) on the tiny sphere: with this seed 11 of the 120 pixels
    # are flagged, in no symmetric pattern, so an all-False or flipped layer fails.
    out_cli = tmp_path / "cli.exr"
    cli("render", tiny_scene, "--out", out_cli, "--spp", 16, "--seed", 5, "--quiet")
    r = reflect.render(tiny_scene, spp=16, seed=5)
    img_flag = reflect.read_image(out_cli).channels["stderr_flag.Y"]
    assert r.stderr_flag.dtype == np.bool_ and r.stderr_flag.shape == img_flag.shape
    assert 0 < r.stderr_flag.sum() < r.stderr_flag.size
    assert np.array_equal(r.stderr_flag, img_flag == 1.0)


def test_arrays_and_stats(tiny_scene):
    r = reflect.render(tiny_scene)
    for a in (r.rgb, r.stderr, r.normal):
        assert a.dtype == np.float32 and a.shape == (10, 12, 3)
    assert r.mask.dtype == np.float32 and r.mask.shape == (10, 12)
    assert r.stderr_flag.dtype == np.bool_ and r.stderr_flag.shape == (10, 12)
    # The sphere covers the centre and misses the corners.
    assert r.mask[5, 6] == 1.0 and r.mask[0, 0] == 0.0
    assert np.all(r.rgb[5, 6] > 0) and np.all(np.isfinite(r.rgb))  # (a miss shows the lighting)
    assert abs(np.linalg.norm(r.normal[5, 6]) - 1) < 1e-5
    s = r.stats
    assert (s["width"], s["height"], s["spp"], s["seed"]) == (12, 10, 4, 7)
    assert s["samples"] == 12 * 10 * 4 and s["rays"] > 0 and s["threads"] >= 1


def test_sources_agree(tiny_scene):
    """Path, TOML text, dict and a loaded Scene are one scene: the same bits."""
    ref = reflect.render(tiny_scene).rgb
    assert np.array_equal(reflect.render(str(tiny_scene)).rgb, ref)
    assert np.array_equal(reflect.render(TINY).rgb, ref)
    assert np.array_equal(reflect.render(TINY_DICT).rgb, ref)
    assert np.array_equal(reflect.render(reflect.load_scene(tiny_scene)).rgb, ref)


def test_threads_do_not_change_the_image(tiny_scene):
    assert np.array_equal(reflect.render(tiny_scene, threads=1).rgb, reflect.render(tiny_scene, threads=2).rgb)


def test_scene_fields_can_be_changed(tiny_scene):
    s = reflect.load_scene(tiny_scene)
    assert s.render["spp"] == 4 and s.objects[0]["brdf"]["type"] == "lambert"
    s.render["spp"] = 2
    s.objects[0]["brdf"] = {"type": "lambert", "albedo": 0.5}
    r = reflect.render(s)
    assert r.stats["spp"] == 2
    # Overrides win over the scene's table, as on the command line.
    assert reflect.render(s, spp=5).stats["spp"] == 5
    # The loaded scene is a copy: the dict it came from is untouched, and copy() is independent.
    t = reflect.load_scene(TINY_DICT)
    t.render["spp"] = 1
    assert TINY_DICT["render"]["spp"] == 4
    u = t.copy()
    u.render["spp"] = 3
    assert t.render["spp"] == 1


def test_relative_data_paths_follow_the_scene_file(data_dir, tmp_path):
    """lighting.file is relative to the scene file, for a path and for a Scene loaded from it."""
    scene = tmp_path / "sub" / "grace.toml"
    scene.parent.mkdir()
    rel = os.path.relpath(data_dir / "grace_probe.hdr", scene.parent)
    text = TINY.replace('type = "sh"\ncoefficients = [[1.0, 0.9, 0.8], [0.1, 0.0, -0.1], [0.3, 0.2, 0.1], [0.0, 0.05, 0.0]]',
                        f'type = "envmap"\nfile = "{rel}"\nmapping = "angular"')
    scene.write_text(text)
    a = reflect.render(scene, size=(6, 5), spp=2)
    b = reflect.render(reflect.load_scene(scene), size=(6, 5), spp=2)
    assert np.array_equal(a.rgb, b.rgb) and a.rgb.max() > 0


def test_missing_file_is_file_not_found(tmp_path):
    p = tmp_path / "nope.toml"
    with pytest.raises(FileNotFoundError, match="nope.toml: cannot read scene file"):
        reflect.render(p)
    with pytest.raises(FileNotFoundError):
        reflect.load_scene(str(p))


def test_bad_scenes_are_value_errors_with_the_cli_message(cli, tiny_scene, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(TINY.replace("extent = 1.05", "extent = 1.05\nzoom = 2"))
    with pytest.raises(ValueError) as e:
        reflect.render(bad)
    # The CLI's one line, without its "error: " prefix.
    line = cli("render", bad, "--out", tmp_path / "x.exr", check=False).stderr.strip()
    assert line == "error: " + str(e.value) and "zoom" in line and "line " in line

    with pytest.raises(ValueError, match="spp = 0 is out of range"):
        reflect.render(tiny_scene, spp=0)
    with pytest.raises(ValueError, match="render.sampler"):
        reflect.render(tiny_scene, sampler="halton")
    with pytest.raises(ValueError, match="unknown field `zoom`"):
        reflect.render({**TINY_DICT, "camera": {**TINY_DICT["camera"], "zoom": 2}})
    with pytest.raises(ValueError, match="missing field `camera`"):
        reflect.render({"lighting": TINY_DICT["lighting"]})
    with pytest.raises(ValueError):
        reflect.render(TINY.replace("[camera]", "[camera"))
    with pytest.raises(ValueError, match="threads"):
        reflect.render(tiny_scene, threads=0)
    with pytest.raises(TypeError):
        reflect.render(42)
    with pytest.raises(ValueError, match="must end in .exr"):
        reflect.render(tiny_scene).save(tmp_path / "out.png")


def test_gil_is_released_while_rendering(tiny_scene):
    """The main thread keeps running Python while another thread renders."""
    result = {}

    def work():
        result["r"] = reflect.render(tiny_scene, size=(96, 96), spp=64)

    t = threading.Thread(target=work)
    t.start()
    ticks = 0
    while t.is_alive():
        ticks += 1
    t.join()
    assert result["r"].rgb.shape == (96, 96, 3)
    # With the GIL held for the whole render this loop could not run while the thread was alive.
    assert ticks > 1000, ticks


def test_ctrl_c_stops_a_render(tiny_scene):
    """SIGINT during a render raises KeyboardInterrupt as soon as the tiles in flight finish.

    The render (2048² pixels × 16384 spp ≈ 7·10¹⁰ samples) would run for hours if the cancel flag
    were ignored, so a broken Ctrl-C shows up as a CI run that never ends, not as a timed assertion.
    """
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            reflect.render(tiny_scene, size=(2048, 2048), spp=16384)
    finally:
        timer.cancel()
