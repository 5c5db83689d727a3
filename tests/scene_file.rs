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
