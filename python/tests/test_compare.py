"""reflect.compare: the CLI's --json document on files, renders and arrays; the verdict on a scale
error; errors naming the input."""

import json

import numpy as np
import pytest

import reflect
from conftest import TINY, plain

# The tiny scene of conftest at 32 × 32, 16 spp, independent sampler (calibrated error bars).
SCENE = TINY.replace("width = 12", "width = 32").replace("height = 10", "height = 32").replace(
    "spp = 4", "spp = 16\nsampler = \"independent\"")
assert SCENE != TINY


def render_pair(cli, tmp_path):
    paths = []
    for name, seed in (("a", 1), ("b", 2)):
        scene = tmp_path / f"{name}.toml"
        scene.write_text(SCENE.replace("seed = 7", f"seed = {seed}"))
        out = tmp_path / f"{name}.exr"
        cli("render", scene, "--out", out, "--quiet")
        paths.append(out)
    return paths


def test_compare_equals_the_cli_json(cli, tmp_path):
    a, b = render_pair(cli, tmp_path)
    doc = json.loads(cli("compare", a, b, "--json", "--block", "4").stdout)
    r = reflect.compare(a, b, block=4)
    assert plain(r) == plain(doc)
    assert r["verdict"] == "agree", r["reason"]
    # The same images as arrays (with their error layers and spp): the same document.
    ia, ib = reflect.read_image(a), reflect.read_image(b)

    def as_dict(img):
        return {"rgb": img.layer(""), "stderr": img.layer("stderr."), "stderr_own": img.layer("stderr_own."),
                "stderr_flag": img.channels["stderr_flag.Y"],
                "mask": img.channels["mask.Y"], "spp": 16}

    assert plain(reflect.compare(as_dict(ia), as_dict(ib), block=4)) == plain(doc)
    # A RenderResult of scene a: the file's pixels, so the same document.
    rr = reflect.render(str(tmp_path / "a.toml"))
    assert plain(reflect.compare(rr, b, block=4)) == plain(doc)


def test_compare_fails_a_scale_error_and_names_inputs(cli, tmp_path):
    a, b = render_pair(cli, tmp_path)
    ib = reflect.read_image(b)
    rgb, err = ib.layer(""), ib.layer("stderr.")
    scaled = {"rgb": rgb * 1.2, "stderr": err * 1.2, "spp": 16}
    r = reflect.compare(a, scaled)
    assert r["verdict"] == "disagree" and "scale" in r["reason"], r["reason"]
    with pytest.raises(ValueError, match=r"^b: .*32×31"):
        reflect.compare(a, {"rgb": rgb[:31], "stderr": err[:31]})
    with pytest.raises(ValueError, match="neither image has an error estimate"):
        reflect.compare(rgb, rgb * 1.0)
    with pytest.raises(FileNotFoundError):
        reflect.compare(a, tmp_path / "missing.exr")


def test_a_render_state_reads_as_the_render_of_its_samples(cli, tmp_path):
    """A merge --partial of the first shards (a state of samples [0, n)) reads as the n-spp render:
    the same channels and header from read_image, the same report from compare."""
    scene = tmp_path / "s.toml"
    scene.write_text(TINY)
    parts = [tmp_path / f"p{i}.exr" for i in range(3)]
    for i, p in enumerate(parts):
        cli("render", scene, "--spp", "48", "--shard", f"{i}/3", "--out", p, "-q")
    state = tmp_path / "state.exr"
    cli("merge", parts[0], parts[1], "--partial", "--out", state, "-q")
    done = tmp_path / "done.exr"
    cli("render", scene, "--spp", "32", "--out", done, "-q")
    other = tmp_path / "other.exr"
    cli("render", scene, "--spp", "32", "--seed", "11", "--out", other, "-q")
    a, b = reflect.read_image(state), reflect.read_image(done)
    assert a.attributes == b.attributes
    assert sorted(a.channels) == sorted(b.channels)
    for k in b.channels:
        assert np.array_equal(a.channels[k], b.channels[k]), k
    ra, rb = reflect.compare(state, other), reflect.compare(done, other)
    assert ra["a"] == rb["a"] and ra["tests"] == rb["tests"] and ra["pixels"] == rb["pixels"]
    with pytest.raises(ValueError, match="not a render's first samples"):
        reflect.read_image(parts[1])
