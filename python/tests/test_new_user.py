"""What a new user, working from the docs alone, stumbled on (issue 35's trial): a render short of its
target said nothing, whole-image means counted the background, a camera dict without ``to`` rendered
nowhere but analysed, documented defaults were missing, one direction came back as a batch, a report's
warnings were only in ``.warnings``, and records were lists of dicts. Each test here fails if one
comes back."""

import _thread
import inspect
import json
import re
import threading
import warnings

import numpy as np
import pytest

import reflect
from conftest import ROOT, TINY
from reflect import brdf as rb
from reflect import light as rl

PAGE = (ROOT / "docs" / "src" / "how-to" / "python.md").read_text()

SMALL = {
    "render": {"width": 16, "height": 16, "seed": 1},
    "camera": {"type": "orthographic", "from": [3, 0, 1], "to": [0, 0, 0], "extent": 1.05},
    "lighting": {"type": "directional", "direction": [0.3, 0.2, 1.0], "irradiance": 3.0},
    "objects": [{"shape": "sphere", "brdf": {"type": "lambert", "albedo": 0.8}}],
}


# --- a render short of its target --------------------------------------------------------------


def test_a_render_stopped_at_its_spp_cap_warns_and_says_so_in_stats(cli, tmp_path):
    with pytest.warns(reflect.TargetNotReachedWarning, match=r"target_rel_error=1e-06 not reached.*spp-cap.*spp="):
        img = reflect.render(SMALL, spp=32, target_rel_error=1e-6)
    st = img.stats
    assert (st["stopped_by"], st["spp_cap"], st["target_reached"], img.spp) == ("spp-cap", 32, False, 32)
    assert issubclass(reflect.TargetNotReachedWarning, reflect.Warning) and issubclass(reflect.Warning, UserWarning)
    # The same names and values as the CLI's --json.
    scene = tmp_path / "s.toml"
    scene.write_text(TINY)
    out = cli("render", scene, "--out", tmp_path / "s.exr", "--spp", 32, "--target-rel-error", 1e-6, "--quiet", "--json")
    doc = json.loads(out.stdout)["progressive"]
    with pytest.warns(reflect.TargetNotReachedWarning):
        st2 = reflect.render(scene, spp=32, target_rel_error=1e-6).stats
    assert {k: st2[k] for k in ("spp_cap", "target_reached", "stopped_by", "passes")} == {
        k: doc[k] for k in ("spp_cap", "target_reached", "stopped_by", "passes")
    }


def test_a_render_that_reaches_its_target_does_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error", reflect.Warning)
        img = reflect.render(SMALL, spp=4096, target_rel_error=0.5)
        plain = reflect.render(SMALL, spp=16)
    assert img.stats["target_reached"] is True and img.stats["spp_cap"] == 4096
    assert plain.stats["target_reached"] is None


# --- means over the object ---------------------------------------------------------------------


def test_background_pixels_have_zero_stderr_and_the_quick_start_masks_them():
    img = reflect.render(SMALL, spp=16)
    background = img.mask == 0
    assert background.any() and (img.stderr[background] == 0).all()
    assert img.stderr[img.mask > 0].mean() > img.stderr.mean()
    readme = (ROOT / "README.md").read_text()
    block = re.search(r"```python\n(import reflect\n.*?)```", readme, flags=re.S).group(1)
    assert "image.stderr[sphere]" in block and "sphere = image.mask > 0" in block, block
    assert "stderr[mask > 0]" in reflect.RenderResult.__doc__ or "mask > 0" in reflect.RenderResult.__doc__


# --- one camera default ------------------------------------------------------------------------


def test_a_camera_without_to_renders_and_analyses_as_one_looking_at_the_origin():
    without = dict(SMALL, camera={"type": "orthographic", "from": [3, 0, 1], "extent": 1.05})
    a, b = reflect.render(without, spp=8), reflect.render(SMALL, spp=8)
    assert np.array_equal(a.rgb, b.rgb)
    cam = without["camera"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", reflect.Warning)
        ra = reflect.analyze(a.rgb, lmax=2, camera=cam, lighting=SMALL["lighting"]).to_dict()
        rb_ = reflect.analyze(a.rgb, lmax=2, camera=dict(cam, to=[0, 0, 0]), lighting=SMALL["lighting"]).to_dict()
    assert ra == rb_


# --- documented defaults -----------------------------------------------------------------------


@pytest.mark.parametrize(
    "cls", [rb.Lambert, rb.Mirror, rb.Phong, rb.TorranceSparrow, rb.Microfacet, rb.Mix,
            rl.Uniform, rl.Directional, rl.Axial, rl.SH, rl.Envmap],
)
def test_the_python_page_gives_every_constructor_default(cls):
    sig = inspect.signature(cls.__init__)
    params = [p for p in sig.parameters.values() if p.name != "self"]
    shown = ", ".join(p.name if p.default is inspect.Parameter.empty else f"{p.name}={p.default!r}".replace("'", '"')
                      for p in params)
    assert f"{cls.__name__}({shown})" in PAGE, f"python.md does not give {cls.__name__}({shown})"


# --- unbatched in, unbatched out ---------------------------------------------------------------


def test_one_direction_gives_an_unbatched_result():
    m = rb.Microfacet(alpha=0.3)
    wi, wo = np.array([0.0, 0.6, 0.8]), np.array([0.0, -0.6, 0.8])
    assert m.eval(wi, wo).shape == (3,) and np.shape(m.pdf(wi, wo)) == ()
    assert np.allclose(m.eval(wi, wo), m.eval(wi[None], wo[None])[0])
    assert m.pdf(wi, wo) == m.pdf(wi[None], wo[None])[0]
    s = m.sample(wo, [0.3, 0.6])
    assert [np.shape(x) for x in s] == [(3,), (3,), (), ()]
    batch = m.sample(wo[None], [[0.3, 0.6]])
    assert all(np.array_equal(x, y[0]) for x, y in zip(s, batch))
    # A batch in either argument keeps the batch.
    assert m.eval(wi[None], wo).shape == (1, 3) and m.pdf(wi, np.stack([wo, wo])).shape == (2,)
    sky = rl.Uniform(2.0)
    assert sky.eval([0, 0, 1]).shape == (3,) and np.shape(sky.pdf([0, 0, 1])) == ()
    assert [np.shape(x) for x in sky.sample([0.2, 0.7])] == [(3,), (3,), (), ()]


# --- warnings in Python terms, raised ----------------------------------------------------------


def test_report_warnings_are_raised_as_reflect_warnings_and_name_the_order_read():
    img = reflect.render(SMALL, spp=8)
    sh = reflect.sh.project(np.ones((8, 16, 3), np.float32), lmax=2)   # a constant map, cut at l = 2
    with pytest.warns(reflect.Warning) as got:
        r = reflect.analyze(img, lmax=2, lighting=sh)
    raised = [str(w.message) for w in got if issubclass(w.category, reflect.Warning)]
    assert raised == list(r.warnings) and raised
    cut = [w for w in raised if w.startswith("the lighting is SH coefficients to l = 2")]
    assert len(cut) == 1 and "read it to l = 16" in cut[0] and "at least l = 16" in cut[0], cut
    assert not any("--" in w for w in raised), raised
    # The warning points at the caller's line, not inside the package.
    assert all(w.filename == __file__ for w in got if issubclass(w.category, reflect.Warning))
    assert "max(16, lmax + 2)" in PAGE and "lmax + 8" not in PAGE


def test_the_guide_explains_no_diagnosis_and_mapping_inference():
    doc = reflect.analyze.__doc__
    assert "no_diagnosis=True" in doc and "slower" in doc and "no_diagnosis=True" in PAGE and "slower" in PAGE
    assert "W = 2H lat-long" in doc and "W = 2H lat-long" in PAGE


# --- records as columns ------------------------------------------------------------------------


def test_records_are_tables_of_arrays_and_to_dict_keeps_the_document():
    img = reflect.render(SMALL, spp=8)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", reflect.Warning)
        r = reflect.analyze(img, lmax=2)
    f = r.filter
    assert isinstance(f, reflect.Table) and len(f) == 3
    assert f.l.dtype == np.int64 and f.l.tolist() == [0, 1, 2]
    assert f.estimate.shape == (3, 3) and f.estimate.dtype == np.float64 and f.stderr.shape == (3, 3)
    assert f["estimate"] is f.estimate and np.array_equal(f[1]["estimate"], f.estimate[1])
    doc = r.to_dict()["filter"]
    assert isinstance(doc, list) and isinstance(doc[0], dict)
    assert np.allclose(np.array([row["estimate"] for row in doc], dtype=float), f.estimate, equal_nan=True)
    assert [row["l"] for row in f] == [0, 1, 2]


# --- Ctrl-C ------------------------------------------------------------------------------------


def _never_finished(monkeypatch, cls):
    """Records whether the native call got as far as building its report: a KeyboardInterrupt raised
    only after the call returned (signals not checked during it) would still be a KeyboardInterrupt."""
    built = []
    init = cls.__init__

    def record(self, *a, **k):
        built.append(True)
        init(self, *a, **k)

    monkeypatch.setattr(cls, "__init__", record)
    return built


def test_ctrl_c_interrupts_a_long_analysis(monkeypatch):
    """A contradicted 512² view makes the diagnosis search run for minutes; Ctrl-C (here
    interrupt_main from a timer thread, as SIGINT does) ends the call with KeyboardInterrupt, before
    the analysis has built its report."""
    img = reflect.render(dict(SMALL, render={"width": 128, "height": 128, "seed": 1}), spp=4)
    big = np.repeat(np.repeat(img.rgb, 4, axis=0), 4, axis=1)
    wrong = {"type": "directional", "direction": [-0.5, 0.4, 0.3], "irradiance": 3.0}
    built = _never_finished(monkeypatch, reflect.AnalyzeReport)
    timer = threading.Timer(0.5, _thread.interrupt_main)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", reflect.Warning)
                reflect.analyze(big, lmax=6, camera=SMALL["camera"], sphere={"brdf": SMALL["objects"][0]["brdf"]},
                                lighting=wrong)
    finally:
        timer.cancel()
    assert not built


def test_ctrl_c_interrupts_a_rendered_light_field(tmp_path, monkeypatch):
    """invert.factor(scene=…) renders n_μ × n_φ + 1 views; Ctrl-C stops them (the cancel flag the
    renderer polls) and the call ends with KeyboardInterrupt."""
    scene = tmp_path / "lf.toml"
    scene.write_text(TINY.replace("spp = 4", "spp = 256"))
    built = _never_finished(monkeypatch, reflect.InvertFactorReport)
    timer = threading.Timer(0.5, _thread.interrupt_main)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            reflect.invert.factor(scene=scene, lmax=4, nodes=(8, 16), size=(96, 48))
    finally:
        timer.cancel()
    assert not built
