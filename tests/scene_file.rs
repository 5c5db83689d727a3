//! Scene files (docs/src/conventions.md §6): parsing (defaults, unknown keys), validation at build time (every
//! refusal names the field), and the perspective camera's geometry.

mod common;
use common::*;
use renderer::camera::Camera;
use renderer::math::{Vec2, Vec3};
use renderer::scene::{Scene, SceneFile};

const BASE: &str = r#"
[render]
width = 8
height = 6
spp = 2

[camera]
type = "orthographic"
from = [3.0, 0.0, 1.0]
to = [0.0, 0.0, 0.0]
up = [0.0, 0.0, 1.0]
extent = 1.05

[lighting]
type = "uniform"
radiance = 1.0

[[objects]]
shape = "sphere"
brdf = { type = "lambert", albedo = 0.5 }
"#;

fn build(toml: &str) -> Result<Scene, String> {
    let file = SceneFile::parse(toml)?;
    Scene::build(file, &root()).map_err(|e| e.to_string())
}

fn build_err(toml: &str) -> String {
    match build(toml) {
        Ok(_) => panic!("accepted:\n{toml}"),
        Err(e) => e,
    }
}

#[test]
fn defaults_and_parse_errors() {
    let f = SceneFile::parse(BASE).unwrap();
    // docs/src/conventions.md §6 defaults: seed 0, max_depth 8, the Sobol sampler; sphere at the origin, radius 1.
    assert_eq!((f.render.width, f.render.height, f.render.spp, f.render.seed, f.render.max_depth), (8, 6, 2, 0, 8));
    assert_eq!(f.render.sampler, vocab::Sampler::Sobol);
    let s = build(BASE).unwrap();
    assert_eq!((s.settings.width, s.settings.height), (8, 6));
    // Unknown keys anywhere are errors, named.
    for (from, to, key) in [
        ("spp = 2", "spp = 2\nspeed = 1", "speed"),
        ("extent = 1.05", "extent = 1.05\nzoom = 2", "zoom"),
        ("radiance = 1.0", "radiance = 1.0\ncolour = 1", "colour"),
        ("shape = \"sphere\"", "shape = \"sphere\"\nradius2 = 1", "radius2"),
        ("albedo = 0.5", "albedo = 0.5, gloss = 1", "gloss"),
    ] {
        let e = SceneFile::parse(&BASE.replace(from, to)).unwrap_err();
        assert!(e.contains(key), "{key}: {e}");
    }
    // Unknown variants and wrong types.
    for (from, to, word) in [
        ("type = \"orthographic\"", "type = \"fisheye\"", "fisheye"),
        ("type = \"uniform\"", "type = \"area\"", "area"),
        ("shape = \"sphere\"", "shape = \"cube\"", "cube"),
        ("type = \"lambert\"", "type = \"velvet\"", "velvet"),
        // A wrong type is located by its line (line 5 of BASE is `spp`).
        ("spp = 2", "spp = \"two\"", "line 5"),
        ("[render", "[render\n", "line"),
    ] {
        let e = SceneFile::parse(&BASE.replace(from, to)).unwrap_err();
        assert!(e.contains(word) || e.to_lowercase().contains(word), "{word}: {e}");
    }
    // A missing required key (the camera's `from`) is named.
    let e = SceneFile::parse(&BASE.replace("from = [3.0, 0.0, 1.0]\n", "")).unwrap_err();
    assert!(e.contains("from"), "{e}");
    // A fault in the second [[objects]] entry names that entry and the line of its table (22 of
    // the file), not the first entry's line or the line before a table (found wrong: "line 17").
    let two =
        format!("{BASE}\n[[objects]]\nshape = \"sphere\"\ngloss = 1\nbrdf = {{ type = \"lambert\", albedo = 0.5 }}\n");
    let e = SceneFile::parse(&two).unwrap_err();
    assert!(e.starts_with("line 22: objects[1]: ") && e.contains("gloss"), "{e}");
    // A key-start span at the beginning of a line is on that line (a duplicate key on line 20).
    let dup = BASE.replace("shape = \"sphere\"\n", "shape = \"sphere\"\nshape = \"sphere\"\n");
    let e = SceneFile::parse(&dup).unwrap_err();
    assert!(e.starts_with("line 20: ") && e.contains("duplicate"), "{e}");
}

#[test]
fn build_refuses_invalid_values_naming_them() {
    let cases: &[(&str, &str, &str)] = &[
        ("width = 8", "width = 0", "resolution"),
        ("height = 6", "height = 100000", "resolution"),
        ("spp = 2", "spp = 0", "spp"),
        ("spp = 2", "spp = 2\nmax_depth = 0", "max_depth"),
        ("spp = 2", "spp = 2\nsampler = \"halton\"", "sampler"),
        ("shape = \"sphere\"", "shape = \"sphere\"\nradius = -1.0", "radius"),
        ("shape = \"sphere\"", "shape = \"sphere\"\ncenter = [0.0, nan, 0.0]", "center"),
        ("albedo = 0.5", "albedo = -0.5", "albedo"),
        ("{ type = \"lambert\", albedo = 0.5 }", "{ type = \"phong\", s = 0.0 }", "s"),
        ("{ type = \"lambert\", albedo = 0.5 }", "{ type = \"phong\", s = 8.0, horizon = \"maybe\" }", "horizon"),
        ("{ type = \"lambert\", albedo = 0.5 }", "{ type = \"torrance-sparrow\", sigma = -0.1 }", "sigma"),
        (
            "{ type = \"lambert\", albedo = 0.5 }",
            "{ type = \"microfacet\", distribution = \"phong\", alpha = 0.2 }",
            "distribution",
        ),
        ("{ type = \"lambert\", albedo = 0.5 }", "{ type = \"mix\", layers = [] }", "layer"),
        ("up = [0.0, 0.0, 1.0]", "up = [-3.0, 0.0, -1.0]", "parallel"),
        ("to = [0.0, 0.0, 0.0]", "to = [3.0, 0.0, 1.0]", "coincide"),
        ("radiance = 1.0", "radiance = -1.0", "radiance"),
        (
            "type = \"uniform\"\nradiance = 1.0",
            "type = \"directional\"\ndirection = [0.0, 0.0, 0.0]\nirradiance = 1.0",
            "direction",
        ),
        (
            "type = \"uniform\"\nradiance = 1.0",
            "type = \"envmap\"\nfile = \"nowhere.hdr\"\nmapping = \"latlong\"",
            "nowhere.hdr",
        ),
        (
            "type = \"uniform\"\nradiance = 1.0",
            "type = \"envmap\"\nfile = \"../shared/data/grace_probe.hdr\"\nmapping = \"cube\"",
            "mapping",
        ),
        (
            "type = \"uniform\"\nradiance = 1.0",
            "type = \"sh\"\ncoefficients = [[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]]",
            "2 coefficients",
        ),
        ("shape = \"sphere\"", "shape = \"mesh\"\nfile = \"x.stl\"", "x.stl"),
    ];
    for (from, to, word) in cases {
        let toml = BASE.replace(from, to);
        assert_ne!(toml, BASE, "replacement {from:?} did not apply");
        match build(&toml) {
            Ok(_) => panic!("{to:?} was accepted"),
            Err(e) => assert!(e.contains(word), "{to:?}: error should name {word:?}: {e}"),
        }
    }
    // The normal-probe camera needs a sphere first.
    let probe = BASE
        .replace("type = \"orthographic\"", "type = \"normal-probe\"")
        .replace("from = [3.0, 0.0, 1.0]\nto = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nextent = 1.05\n", "");
    assert!(build(&probe).is_ok());
    let e = build_err(&probe.replace("shape = \"sphere\"", "shape = \"mesh\"\nfile = \"scenes/meshes/icosphere.obj\""));
    assert!(e.contains("sphere"), "{e}");
}

fn perspective(fov: f32, w: u32, h: u32) -> renderer::camera::perspective::Perspective {
    let toml = BASE
        .replace("width = 8", &format!("width = {w}"))
        .replace("height = 6", &format!("height = {h}"))
        .replace("type = \"orthographic\"", "type = \"perspective\"")
        .replace("extent = 1.05", &format!("fov_deg = {fov:?}"));
    match build(&toml).unwrap().camera {
        Camera::Perspective(p) => p,
        _ => unreachable!(),
    }
}

/// The pinhole camera: rays start at `from`; the image centre looks at `to`; the vertical field of
/// view is `fov_deg` (the top and bottom edge centres are fov/2 from the axis); the horizontal one
/// follows the aspect ratio; image right is forward × up and row 0 is the top (docs/src/conventions.md §5); and
/// a world point projects to the pixel whose ray passes through it.
#[test]
fn perspective_camera_geometry() {
    let (w, h) = (40, 30);
    let cam = perspective(50.0, w, h);
    let from = Vec3::new(3.0, 0.0, 1.0);
    let axis = (Vec3::ZERO - from).normalize();
    let angle = |d: Vec3| d.dot(axis).clamp(-1.0, 1.0).acos().to_degrees();
    let centre = cam.generate(h / 2, w / 2, Vec2::ZERO);
    assert!((centre.origin - from).length() < 1e-6);
    assert!(angle(centre.dir) < 1e-3, "centre ray {:?}", centre.dir);
    // Top edge centre (row 0, v = 0) and bottom edge (row h−1, v = 1): 25° off axis, above and below.
    let top = cam.generate(0, w / 2, Vec2::new(0.0, 0.0)).dir;
    let bottom = cam.generate(h - 1, w / 2, Vec2::new(0.0, 1.0)).dir;
    assert!(
        (angle(top) - 25.0).abs() < 1e-3 && (angle(bottom) - 25.0).abs() < 1e-3,
        "{} {}",
        angle(top),
        angle(bottom)
    );
    let up = axis.cross(Vec3::Z).normalize().cross(axis);
    assert!(top.dot(up) > 0.0 && bottom.dot(up) < 0.0, "row 0 is the top");
    // Left/right edges: atan(tan 25° · 4/3) off axis; column w is on the side of forward × up.
    let right_dir = axis.cross(Vec3::Z).normalize();
    let r = cam.generate(h / 2, w - 1, Vec2::new(1.0, 0.0)).dir;
    let expect = (25f32.to_radians().tan() * w as f32 / h as f32).atan().to_degrees();
    assert!((angle(r) - expect).abs() < 1e-3 && r.dot(right_dir) > 0.0, "{} vs {expect}", angle(r));
    // Projection round trip: a world point in view lands on the ray through its pixel.
    for p in [Vec3::new(0.0, 0.3, 0.2), Vec3::new(0.5, -0.4, -0.3), Vec3::new(-1.0, 0.8, 0.5)] {
        let v = p - from;
        let (z, x, y) = (v.dot(axis), v.dot(right_dir), v.dot(up));
        let t = 25f32.to_radians().tan();
        let (px, py) = (x / z / (t * w as f32 / h as f32), y / z / t); // in [−1, 1]
        let (cf, rf) = ((px + 1.0) * 0.5 * w as f32, (1.0 - py) * 0.5 * h as f32);
        let ray = cam.generate(rf as u32, cf as u32, Vec2::new(cf.fract(), rf.fract()));
        let miss = (v - ray.dir * v.dot(ray.dir)).length();
        assert!(miss < 1e-4 * v.length(), "{p}: the ray through its pixel misses it by {miss}");
    }
    // Invalid fields of view are refused.
    for fov in ["0.0", "180.0", "-10.0", "nan"] {
        let toml = BASE
            .replace("type = \"orthographic\"", "type = \"perspective\"")
            .replace("extent = 1.05", &format!("fov_deg = {fov}"));
        assert!(build_err(&toml).contains("fov"), "fov {fov}");
    }
}

/// A perspective render of a Lambertian sphere under uniform light: the covered pixels are exactly
/// those inside the sphere's silhouette (mask 1 inside, 0 outside, partial coverage only on the
/// silhouette), and every fully covered pixel is the albedo. The reference is the closed-form
/// pinhole projection, not the camera's ray generation: seen from distance d, a sphere of radius r
/// centred on the optical axis fills the cone of half-angle α = asin(r/d), whose image on the plane
/// at unit distance is the disc of radius tan α about the image centre; the image plane spans
/// ±tan(fov/2) vertically and ±tan(fov/2)·W/H horizontally, row 0 at the top (docs/src/conventions.md §5).
#[test]
fn perspective_render_sees_the_sphere_where_geometry_says() {
    let (w, h) = (40, 30);
    let toml = BASE
        .replace("width = 8", &format!("width = {w}"))
        .replace("height = 6", &format!("height = {h}"))
        .replace("spp = 2", "spp = 16")
        .replace("type = \"orthographic\"", "type = \"perspective\"")
        .replace("extent = 1.05", "fov_deg = 50.0");
    let film = render_scene(&scene(&toml));
    // Camera at (3, 0, 1) looking at the unit sphere's centre, the origin.
    let silhouette = (1.0 / 10f64.sqrt()).asin().tan();
    let t = 25f64.to_radians().tan();
    // Image-plane point of the pixel corner at (row, col) (fractional: corners are integers).
    let plane = |r: u32, c: u32| {
        (t * (w as f64 / h as f64) * (2.0 * c as f64 / w as f64 - 1.0), t * (1.0 - 2.0 * r as f64 / h as f64))
    };
    let (mut inside, mut outside) = (0, 0);
    // Lambert under uniform light: B = albedo = 0.5; the estimator (MIS of light and BRDF samples)
    // has variance, so within Šidák–Student k of each pixel's σ (16 samples) + f32 rounding.
    let k = analysis::special::pixel_family_k((w * h) as usize, 16, 1e-3) as f32;
    for r in 0..h {
        for c in 0..w {
            let p = film.get(r, c);
            // The pixel is a square on the image plane and the silhouette a disc: all four corners
            // inside → covered. All outside by more than the sagitta of a pixel edge under the
            // disc's arc (0.031²/(8 · 0.333) ≈ 4·10⁻⁴) → no sliver of the disc enters the pixel.
            let corners = [(0, 0), (1, 0), (0, 1), (1, 1)].map(|(dr, dc)| {
                let (x, y) = plane(r + dr, c + dc);
                x.hypot(y)
            });
            if corners.iter().all(|&q| q < silhouette - 1e-4) {
                inside += 1;
                assert_eq!(p.mask, 1.0, "({r},{c})");
                assert!((p.rgb[0] - 0.5).abs() <= k * p.stderr[0] + 1e-5, "({r},{c}): {} ± {}", p.rgb[0], p.stderr[0]);
            } else if corners.iter().all(|&q| q > silhouette + 2e-3) {
                outside += 1;
                assert_eq!(p.mask, 0.0, "({r},{c})");
            }
        }
    }
    assert!(inside > 100 && outside > 100, "{inside} {outside}");
}

/// The `sphere-ground-shadow` scene (a unit sphere resting on a ground sphere whose top is z = −1,
/// directional light of irradiance 3 from +z, ground albedo 0.5) with the ground's radius `r`.
fn ground_scene(r: f64, max_depth: u32, spp: u32) -> String {
    format!(
        "[render]\nwidth = 32\nheight = 32\nspp = {spp}\nseed = 0\nmax_depth = {max_depth}\n\
         [camera]\ntype = \"orthographic\"\nfrom = [5.0, 0.0, 1.0]\nto = [0.0, 0.0, 0.0]\nextent = 2.0\n\
         [lighting]\ntype = \"directional\"\ndirection = [0.0, 0.0, 1.0]\nirradiance = 3.0\n\
         [[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, {:e}]\nradius = {r:e}\n\
         brdf = {{ type = \"lambert\", albedo = 0.5 }}\n\
         [[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n\
         brdf = {{ type = \"lambert\", albedo = 0.8 }}\n",
        -r - 1.0
    )
}

/// Far ground of these scenes: the pixels of the 32² view (extent 2, from (5, 0, 1)) whose
/// footprint (centre and four corners, float64 ray cast against the plane z = −1 and the unit
/// sphere) misses the sphere by 0.1 and reaches the ground more than `d` from the axis: outside
/// the sphere's shadow (radius 1) and lit by the light alone up to the sphere's bounce light.
/// Returns (mean, its standard error from the `stderr` layer, pixels).
/// `top` is the ground's height as the scene holds it (centre and radius are f32: at R = 1e9 the
/// centre −(R + 1) rounds to −R, and the ground's top is z = 0).
fn far_ground(f: &renderer::film::Film, d: f64, top: f64) -> (f64, f64, usize) {
    let fwd = glam::DVec3::new(-5.0, 0.0, -1.0).normalize();
    let right = fwd.cross(glam::DVec3::Z).normalize();
    let up = right.cross(fwd);
    let (mut sum, mut var, mut n) = (0.0, 0.0, 0);
    for (i, p) in f.pixels.iter().enumerate() {
        let (r, c) = ((i / 32) as f64, (i % 32) as f64);
        let far = [(0.5, 0.5), (0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1.0)].iter().all(|&(dr, dc)| {
            let (x, y) = (2.0 * (2.0 * (c + dc) / 32.0 - 1.0), 2.0 * (1.0 - 2.0 * (r + dr) / 32.0));
            let o = glam::DVec3::new(5.0, 0.0, 1.0) + x * right + y * up;
            let closest = o - o.dot(fwd) * fwd;
            let t = (o.z - top) / -fwd.z;
            let g = o + t * fwd;
            closest.length() > 1.1 && t > 0.0 && g.truncate().length() > d
        });
        if far {
            let v = p.rgb.iter().map(|&x| x as f64).sum::<f64>() / 3.0;
            let s = p.stderr.iter().map(|&x| x as f64).fold(0.0, f64::max);
            sum += v;
            var += s * s;
            n += 1;
        }
    }
    (sum / n as f64, var.sqrt() / n as f64, n)
}

/// Issue 33, kind 6 (`sphere-ground-shadow`): the far ground is lit, E·ρ/π = 3 · 0.5/π = 0.47746,
/// at every radius of the ground sphere. At max_depth 1 the estimator of an unshadowed far-ground
/// pixel has no variance (the delta light's next-event estimate, Lambert, no other light), so the
/// tolerance is k = 4 standard errors of the mean (from the `stderr` layer, zero here) plus the
/// ground's tilt (1 − cos θ ≤ (30/R)²/2 < 5e-6) and f32 rounding, 1e-5 in all. Before the fix the
/// sphere test rejected roots under 1e-4·R: 0.023 at R = 2e5, 0 from 1e6.
#[test]
fn far_ground_is_lit_at_every_radius() {
    let expected = 1.5 / std::f64::consts::PI;
    for r in [1e4, 2e5, 1e6, 1e9] {
        let s = scene(&ground_scene(r, 1, 4));
        let top = (-r - 1.0) as f32 as f64 + r as f32 as f64;
        let (mean, se, n) = far_ground(&render_scene(&s), 3.0, top);
        assert!(n >= 100, "R = {r:e}: {n} far-ground pixels");
        assert!((mean - expected).abs() <= 4.0 * se + 1e-5, "R = {r:e}: far ground {mean} ± {se}, not {expected}");
    }
}

/// The case files themselves (max_depth 2: the ground also receives the unit sphere's bounce
/// light): the far ground (6 or more from the axis) is 0.4775 within k = 4 standard errors below,
/// and above by that plus the bounce light's bound ρ/π · L · Ω · cos: the sphere's radiance
/// L ≤ 0.8 · 3/π, its solid angle Ω ≤ π/6², and cos ≤ 2/6 (the sphere's top is 2 above the ground).
#[test]
fn sphere_ground_shadow_cases_light_the_far_ground() {
    use std::f64::consts::PI;
    let expected = 1.5 / PI;
    let bounce = 0.5 / PI * (2.4 / PI) * (PI / 36.0) * (2.0 / 6.0);
    for name in ["ground_R1e+04", "ground_R2e+05"] {
        let path = root().join("../shared/cases/sphere-ground-shadow").join(format!("{name}.toml"));
        let s = Scene::load(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        let (mean, se, n) = far_ground(&render_scene(&s), 6.0, -1.0);
        assert!(n >= 100, "{name}: {n} far-ground pixels");
        assert!(
            mean > expected - 4.0 * se - 1e-5 && mean < expected + 4.0 * se + bounce,
            "{name}: far ground {mean} ± {se}, not {expected}"
        );
    }
}

/// Issue 33, kind 6 (`sphere-huge`): objects that reach beyond the limit (1e10 from the origin) are
/// refused by the scene build, naming the object and the limit, spheres and meshes alike (a mesh
/// through its transform); at the limit a sphere builds.
#[test]
fn objects_beyond_the_reach_limit_are_refused() {
    for (r, ok) in [(1e19, false), (1e30, false), (1e11, false), (4.9e9, true)] {
        let toml = ground_scene(r, 1, 1);
        match build(&toml) {
            Ok(_) => assert!(ok, "R = {r:e} accepted"),
            Err(e) => {
                assert!(!ok, "R = {r:e}: {e}");
                assert!(e.contains("objects[0]") && e.contains("sphere") && e.contains("limit is 1e10"), "{e}");
            }
        }
    }
    let mesh = BASE.replace("shape = \"sphere\"", "shape = \"icosphere\"\nsubdivisions = 1\nradius = 2e10");
    let e = build_err(&mesh);
    assert!(e.contains("objects[0]") && e.contains("mesh") && e.contains("limit is 1e10"), "{e}");
}

/// An environment map's `layer` key must name a layer or part: empty, blank or control characters are
/// refused naming the key, before the file is read; an unknown name is refused with the file's layers.
#[test]
fn envmap_layer_key_must_name_a_layer() {
    let map = root().join("../shared/data/grace_latlong.exr");
    assert!(map.exists(), "missing data: {} (the tests need ../shared beside the checkout)", map.display());
    let scene = |layer: &str| {
        format!(
            "[camera]\ntype = \"orthographic\"\nfrom = [3.0, 0.0, 0.0]\nto = [0.0, 0.0, 0.0]\nextent = 1.1\n\n\
             [lighting]\ntype = \"envmap\"\nfile = {:?}\nlayer = {layer}\n\n[[objects]]\nshape = \"sphere\"\n\
             brdf = {{ type = \"lambert\", albedo = 0.5 }}\n",
            map.to_str().unwrap()
        )
    };
    for bad in ["\"\"", "\"  \"", "\"a\\u0007b\""] {
        let e = build_err(&scene(bad));
        assert!(e.contains("layer") && e.contains("must name a layer or part"), "{bad}: {e}");
    }
    let e = build_err(&scene("\"diffuse\""));
    assert!(e.contains("diffuse"), "{e}");
    assert!(build(&scene("\"rgba\"")).is_ok(), "a beauty name selects the beauty");
}
