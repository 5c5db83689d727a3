"""reflect.analyze and reflect.invert: report objects whose to_dict() is the CLI's --json document
(exactly) on files, renders and arrays; shapes and dtypes of their attributes; errors naming this
API's keywords."""

import json

import numpy as np
import pytest

import reflect
from conftest import ROOT, TINY, plain

# The tiny Lambertian sphere of conftest, seen by a normal probe (B(n) on a lat-long grid).
PROBE = TINY.replace(
    '[camera]\ntype = "orthographic"\nfrom = [3.0, 0.0, 1.0]\nto = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nextent = 1.05',
    '[camera]\ntype = "normal-probe"',
)
# A Phong sphere under a directional source (every order lit), seen by a normal probe.
PHONG = PROBE.replace(
    'type = "sh"\ncoefficients = [[1.0, 0.9, 0.8], [0.1, 0.0, -0.1], [0.3, 0.2, 0.1], [0.0, 0.05, 0.0]]',
    'type = "directional"\ndirection = [0.3, 0.2, 1.0]\nirradiance = 3.0',
).replace('brdf = { type = "lambert", albedo = [0.8, 0.7, 0.6] }', 'brdf = { type = "phong", s = 8.0, ks = 0.9 }').replace(
    'type = "normal-probe"', 'type = "normal-probe"\njitter = true')  # (pixel centres under one source: no noise)
assert PROBE != TINY and PHONG != PROBE and "phong" in PHONG


def render_file(cli, tmp_path, text, name, *flags):
    scene = tmp_path / f"{name}.toml"
    scene.write_text(text)
    out = tmp_path / f"{name}.exr"
    cli("render", scene, "--out", out, "--quiet", *flags)
    return scene, out


def cli_json(cli, *args):
    return json.loads(cli(*args, "--json").stdout)


@pytest.fixture
def ortho(cli, tmp_path):
    return render_file(cli, tmp_path, TINY, "ortho", "--size", "24x24", "--spp", 8)


@pytest.fixture
def probe(cli, tmp_path):
    return render_file(cli, tmp_path, PROBE, "probe", "--size", "32x16", "--spp", 8)


def test_analyze_file_render_and_array_give_the_cli_numbers(cli, ortho, tmp_path):
    scene, exr = ortho
    want = cli_json(cli, "analyze", exr, "--lmax", 2)
    got = reflect.analyze(exr, lmax=2)
    assert isinstance(got, reflect.AnalyzeReport)
    assert got.to_dict() == want and json.loads(got.to_json()) == want
    assert plain(got.to_dict()) == plain({k: got[k] for k in got.keys()})
    # The same render made in Python (same scene and seed: same bits) is analysed as its saved file.
    r = reflect.render(scene, size=(24, 24), spp=8)
    from_render = reflect.analyze(r, lmax=2).to_dict()
    assert from_render.pop("images") == ["<RenderResult 0>"]
    want.pop("images")
    assert from_render == want
    # Its arrays with the scene: the CLI on a file with only those layers (no mask, normal or flag
    # layers, so the sphere's geometry decides the pixels) and the header the render wrote.
    img = reflect.read_image(exr)
    layers = tmp_path / "layers.exr"
    reflect.write_image(
        layers,
        {k: v for k, v in img.channels.items() if k in ("R", "G", "B", "stderr.R", "stderr.G", "stderr.B")},
        {k: v for k, v in img.attributes.items() if k in ("reflect:camera", "reflect:lighting", "reflect:objects")},
    )
    want = cli_json(cli, "analyze", layers, "--lmax", 2)
    from_array = reflect.analyze(r.rgb, lmax=2, scene=scene, stderr=r.stderr).to_dict()
    assert from_array.pop("images") == ["<array 0>"]
    want.pop("images")
    assert from_array == want
    # (Without the mask layer the pixels at the limb count, so the numbers differ from the render's.)
    assert from_array["pixels_used"] != from_render["pixels_used"] or from_array["coefficients"] != from_render[
        "coefficients"]


def test_analyze_shapes_and_dtypes(ortho):
    d = reflect.analyze(ortho[1], lmax=2)
    assert d.coefficients is d["coefficients"] and d.lmax == 2 and d.images == [str(ortho[1])]
    assert d["coefficients"].shape == (9, 3) and d["coefficients"].dtype == np.float64
    assert d["stderr"].shape == (9, 3) and d["lighting"]["coefficients"].shape == (9, 3)
    assert d["lm"].dtype == np.int64 and d["lm"].tolist()[:4] == [[0, 0], [1, -1], [1, 0], [1, 1]]
    assert d["lambda_rho_analytic"].shape == (3, 3) and d["predicted"].shape == (9, 3)
    assert isinstance(d["filter"], reflect.Table) and d["filter"][0]["estimate"].shape == (3,)
    assert d.filter.estimate.shape == (3, 3) and d.filter.l.dtype == np.int64
    assert isinstance(d["warnings"], list) and all(isinstance(w, str) for w in d["warnings"])
    assert isinstance(d["lmax_carried"], int) and d["sphere"]["center"].shape == (3,)


def test_analyze_headerless_array_with_camera_sphere_and_lighting(cli, ortho, tmp_path):
    """An array with camera, sphere and lighting keywords is the CLI on an RGB-only file with
    --from/--to/--extent and --lighting."""
    scene, exr = ortho
    rgb = reflect.read_image(exr).layer("")
    bare = tmp_path / "bare.exr"
    reflect.write_image(bare, {c: rgb[..., k] for k, c in enumerate("RGB")})
    want = cli_json(cli, "analyze", bare, "--lmax", 2, "--from", "3,0,1", "--to", "0,0,0", "--extent", 1.05,
                    "--lighting", scene)
    cam = {"type": "orthographic", "from": [3.0, 0.0, 1.0], "to": [0.0, 0.0, 0.0], "extent": 1.05}
    lighting = reflect.load_scene(scene).lighting
    for light in (lighting, np.array(lighting["coefficients"]), scene):
        got = reflect.analyze(rgb, lmax=2, camera=cam, sphere={"center": [0, 0, 0], "radius": 1.0},
                              lighting=light).to_dict()
        assert got.pop("images") == ["<array 0>"]
        src = got["lighting"].pop("source")
        assert src.startswith("<lighting") or src == str(scene)
        w = dict(want, lighting=dict(want["lighting"]))
        w.pop("images"), w["lighting"].pop("source")
        # The header sphere has no BRDF: no analytic column, as the file without a header.
        assert got == w
    # A sphere without a BRDF elsewhere: the CLI's --center/--radius.
    want = cli_json(cli, "analyze", bare, "--lmax", 1, "--from", "3,0,1", "--extent", 1.05, "--radius", 0.95,
                    "--center", "0,0,0.01")
    got = reflect.analyze(rgb, lmax=1, camera=cam, sphere={"center": [0, 0, 0.01], "radius": 0.95}).to_dict()
    assert got.pop("images") == ["<array 0>"] and got["sphere"]["radius"] == 0.95
    want.pop("images")
    assert got == want


def test_invert_lighting_and_brdf_give_the_cli_numbers(cli, probe, tmp_path):
    scene, exr = probe
    want = cli_json(cli, "invert", "lighting", exr, "--lmax", 2)
    got = reflect.invert.lighting(exr, lmax=2)
    assert isinstance(got, reflect.InvertLightingReport) and got.to_dict() == want
    assert got["coefficients"].shape == (9, 3) and got["lambda_rho"].shape == (3,)
    assert got["regularised"]["coefficients"].shape == (9, 3) and got["albedo"].dtype == np.float64
    # A value that contradicts the header is the CLI's error, the value named by its keyword.
    line = cli("invert", "lighting", exr, "--lmax", 2, "--albedo", "0.5,0.6,0.7", check=False).stderr.strip()
    with pytest.raises(reflect.InputError) as e:
        reflect.invert.lighting(exr, lmax=2, albedo=[0.5, 0.6, 0.7])
    assert line == "error: " + str(e.value).replace("albedo=", "--albedo ") and "contradict" in line
    assert "--albedo" in line and "albedo=0.5,0.6,0.7" in str(e.value) and "--" not in str(e.value)
    # Flags as keywords, and the array of the same render with its scene.
    want = cli_json(cli, "invert", "lighting", exr, "--lmax", 2, "--brdf", "lambert", "--albedo", "0.8,0.7,0.6",
                    "--lambda-rule", "discrepancy")
    img = reflect.read_image(exr)
    got = reflect.invert.lighting(img.layer(""), lmax=2, brdf="lambert", albedo=[0.8, 0.7, 0.6],
                                  lambda_rule="discrepancy", scene=scene, stderr=img.layer("stderr.")).to_dict()
    assert got.pop("images") == ["<array 0>"]
    want.pop("images")
    assert got == want

    pscene, pexr = render_file(cli, tmp_path, PHONG, "phong", "--size", "48x24", "--spp", 8)
    want = cli_json(cli, "invert", "brdf", pexr, "--model", "phong", "--lmax", 4, "--min", 1, "--max", 100)
    got = reflect.invert.brdf(pexr, model="phong", lmax=4, min=1, max=100)
    assert isinstance(got, reflect.InvertBrdfReport) and got.to_dict() == want
    assert got["interval"].shape == (2,) and got["profile"].ndim == 2 and got["profile"].shape[1] == 2
    assert isinstance(got["estimate"], float) and got["parameter"] == "s"


def test_errors_are_the_cli_lines(cli, ortho, tmp_path):
    scene, exr = ortho
    missing = tmp_path / "missing.exr"
    line = cli("analyze", missing, "--lmax", 2, check=False).stderr.strip()
    with pytest.raises(FileNotFoundError) as e:
        reflect.analyze(missing, lmax=2)
    assert line == "error: " + str(e.value) and "missing.exr" in line
    # Bad arguments are refused in Python, naming the keyword (the CLI names its flag).
    line = cli("analyze", exr, "--lmax", 100000, check=False).stderr.strip()
    with pytest.raises(reflect.InputError) as e:
        reflect.analyze(exr, lmax=100000)
    assert "0..=200" in line and str(e.value) == "lmax= must be an integer in 0..=200, got 100000"
    with pytest.raises(reflect.InputError) as e:
        reflect.invert.brdf(exr, model="blinn", lmax=2)
    assert str(e.value) == "model= must be one of 'phong', 'torrance-sparrow', 'microfacet', got 'blinn'"
    with pytest.raises(reflect.InputError, match=r"^brdf=: unknown BRDF type \"blinn\""):
        reflect.analyze(exr, lmax=2, brdf="blinn")
    # A file without a camera: what to pass, in this API's terms.
    bare = tmp_path / "bare.exr"
    reflect.write_image(bare, {c: np.ones((8, 8), np.float32) for c in "RGB"})
    with pytest.raises(reflect.InputError, match=r"bare.exr: no reflect:camera in the header: pass scene="):
        reflect.analyze(bare, lmax=1)
    # A 2-D array is named whole (it used to be split into rows, each "shape (4,)").
    with pytest.raises(ValueError, match=r"\(H, W, 3\).*got \(4, 5\)"):
        reflect.analyze(np.zeros((4, 5)), lmax=1)
    # A non-finite value: the message says which input array holds it.
    with pytest.raises(ValueError, match=r"^image 0 \(array\): channel G: non-finite value NaN at row 1, column 2"):
        bad = np.ones((4, 5, 3))
        bad[1, 2, 1] = np.nan
        reflect.analyze(bad, lmax=1)
    with pytest.raises(ValueError, match="describe images given as arrays"):
        reflect.analyze(exr, lmax=2, camera={"type": "normal-probe"})
    # An array without a camera: the message names the array, never a temporary file.
    with pytest.raises(ValueError) as e:
        reflect.analyze(np.ones((8, 8, 3)), lmax=1)
    assert "<array 0>" in str(e.value) and "reflect-" not in str(e.value)
    with pytest.raises(ValueError, match="unknown field"):
        reflect.analyze(np.ones((8, 8, 3)), lmax=1, camera={"type": "orthographic", "zoom": 2})


def test_invert_separate_and_factor_give_the_cli_numbers(cli, tmp_path):
    views = []
    for v in ("view0", "view50", "view50-180"):
        out = tmp_path / f"sep-{v}.exr"
        cli("render", f"scenes/separation-{v}.toml", "--out", out, "--quiet", "--size", "48x24", "--spp", 4)
        views.append(out)
    want = cli_json(cli, "invert", "separate", *views, "--lmax", 4, "--scan")
    got = reflect.invert.separate(views, lmax=4, scan=True)
    assert isinstance(got, reflect.InvertSeparateReport) and got.to_dict() == want
    # The same renders made in Python (relative data paths follow the scene files, as for the CLI).
    renders = [reflect.render(ROOT / "scenes" / f"separation-{v}.toml", size=(48, 24), spp=4)
               for v in ("view0", "view50", "view50-180")]
    from_renders = reflect.invert.separate(renders, lmax=4, scan=True).to_dict()
    assert from_renders["diffuse_view"]["file"] == "<RenderResult 0>"
    for d in (from_renders, want):
        d.pop("diffuse_view"), d.pop("specular_views")  # (file names)
    assert from_renders == want

    scene = "scenes/factor-microfacet-directional.toml"
    want = cli_json(cli, "invert", "factor", "--scene", scene, "--nodes", "2x4", "--lmax", 2, "--size", "16x8")
    report = reflect.invert.factor(scene=ROOT / scene, nodes=(2, 4), lmax=2, size=(16, 8))
    assert isinstance(report, reflect.InvertFactorReport)
    got = report.to_dict()
    assert got["renders"].pop("wall_seconds") >= 0 and want["renders"].pop("wall_seconds") >= 0
    assert got["input"].pop("scene").endswith(scene) and want["input"].pop("scene") == scene
    assert got == want


def test_invert_factor_of_rendered_views_equals_the_scene_mode(cli):
    """The light field given as renders (one per node, made in Python) factors to exactly what the
    scene mode renders and factors itself: the same pixels (pixel centres, same seed and spp), so the
    same numbers, with no file written."""
    import tomllib

    scene = ROOT / "scenes/factor-microfacet-directional.toml"
    table = tomllib.loads(scene.read_text())
    nodes = cli_json(cli, "invert", "factor", "--print-nodes", "2x4")["outgoing"]

    def view(theta, phi):
        t = dict(table, camera={"type": "normal-probe", "theta_o_deg": theta, "phi_o_deg": phi, "jitter": False})
        return reflect.render(t, size=(16, 8))

    views = [view(n["theta_o_deg"], n["phi_o_deg"]) for n in nodes]
    got = reflect.invert.factor(views, normal=view(0.0, 0.0), lmax=2).to_dict()
    want = reflect.invert.factor(scene=scene, nodes=(2, 4), lmax=2, size=(16, 8)).to_dict()
    assert got["mode"] == "images" and want["mode"] == "scene"
    for k in ("mode", "input", "renders", "warnings"):
        got.pop(k), want.pop(k)
    assert got == want
    # Arrays with their cameras give the same numbers again.
    arrays = reflect.invert.factor(
        [v.rgb for v in views], lmax=2, normal=view(0.0, 0.0).rgb,
        camera=[{"type": "normal-probe", "theta_o_deg": n["theta_o_deg"], "phi_o_deg": n["phi_o_deg"]} for n in nodes],
    ).to_dict()
    for k in ("mode", "input", "renders", "warnings", "max_stderr"):
        arrays.pop(k)
    got.pop("max_stderr")
    assert arrays == got
    with pytest.raises(reflect.InputError, match="nodes="):
        reflect.invert.factor(scene=scene, lmax=2)
    with pytest.raises(reflect.InputError, match="quadrature="):
        reflect.invert.factor(views, lmax=2, quadrature="simpson")
