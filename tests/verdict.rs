//! `analyze`'s verdict (issue 37) and the microfacet transfer model, on images our own renderer
//! writes, some rewritten in other renderers' conventions (headerless, no stderr layer, Mitsuba's
//! default Gaussian film as `examples/foreign_render.rs` writes it).
//!
//! - Microfacet round trip: Beckmann and GGX spheres (α 0.3, F = 1) seen by the `normal-probe`
//!   camera at normal exitance under Grace: every order of the measured filter within 4 printed σ
//!   of the analytic column (Šidák over 2 images × 5 orders × 3 channels = 30 comparisons at
//!   α = 1e-3 gives k = 3.9) and the verdict consistent. (Off normal exitance a probe labelled by
//!   n does not obey the q = 0 relation about R, so the coefficients at θ_o are checked against a
//!   brute-force oracle in `analysis::transfer::microfacet` instead.)
//! - Planted errors flagged: the map rotated by 5° about +z (at 64 spp), a square (angular) map read as
//!   lat-long, a wrong camera extent; with the render's stderr layer, without it, and on a
//!   Gaussian film. (A 2° rotation is not flagged at this size and sample count: the Lambert filter
//!   of l ≤ 2 absorbs it within its error bars.)
//! - Correct images are not flagged at the stated rate: α = 1 % per image; 6 seeds × 2 (with and
//!   without stderr): P(≥ 2 flagged of 12 | α = 0.01) = 6e-3, so at most one may be.
//!
//! Renders: 64² (probes 64 × 32), independent sampler, fixed seeds.

mod common;
use analysis::image::{Image, read_image, write_exr};
use common::*;
use serde_json::Value;
use std::path::{Path, PathBuf};

const N: usize = 64;

fn grace_s() -> String {
    grace().to_str().unwrap().to_string()
}

/// A Lambert 0.8 sphere under Grace (scenes/lambert-grace.toml) at N², the map rotated by
/// `rot_z` degrees about +z, the camera extent `extent`.
fn lambert_scene(rot_z: f64, extent: f64, seed: u64) -> String {
    format!(
        "[render]\nwidth = {N}\nheight = {N}\nspp = 16\nseed = {seed}\nmax_depth = 1\nsampler = \"independent\"\n\
         [camera]\ntype = \"orthographic\"\nfrom = [3.0, 0.0, 1.0]\nto = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\n\
         extent = {extent}\n\
         [lighting]\ntype = \"envmap\"\nfile = {:?}\nmapping = \"angular\"\nscale = 1.0\nrotate_deg = [0.0, 0.0, {rot_z}]\n\
         [[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n\
         brdf = {{ type = \"lambert\", albedo = [0.8, 0.8, 0.8] }}\n",
        grace_s()
    )
}

/// Writes `text` as `dir/name.toml` and renders it to `dir/name.exr`.
fn render_text(dir: &Path, name: &str, text: &str) -> PathBuf {
    let scene = dir.join(format!("{name}.toml"));
    std::fs::write(&scene, text).unwrap();
    let out = dir.join(format!("{name}.exr"));
    let (code, err) = reflect(&["render", scene.to_str().unwrap(), "--out", out.to_str().unwrap(), "-q"]);
    assert_eq!(code, 0, "{err}");
    out
}

fn analyze(args: &[&str]) -> (Value, String) {
    let mut all = vec!["analyze"];
    all.extend_from_slice(args);
    all.push("--json");
    let (code, out, err) = reflect_out(&all);
    assert_eq!(code, 0, "{all:?}: {err}");
    (serde_json::from_str(&out).unwrap_or_else(|e| panic!("bad JSON ({e}): {out}")), err)
}

fn status(doc: &Value) -> &str {
    doc["verdict"]["status"].as_str().unwrap_or_else(|| panic!("no verdict: {doc}"))
}

/// The image without its stderr layer (header kept).
fn without_stderr(path: &Path) -> PathBuf {
    let mut img = read_image(path).unwrap();
    img.channels.retain(|k, _| !k.starts_with("stderr"));
    let out = path.with_extension("nostderr.exr");
    write_exr(&out, &img).unwrap();
    out
}

/// Mitsuba 3's `gaussian` filter at its defaults (stddev 0.5 px, radius 2 px).
fn gaussian(x: f64) -> f64 {
    let g = |t: f64| (-t * t / (2.0 * 0.25)).exp();
    if x.abs() < 2.0 { (g(x) - g(2.0)).max(0.0) } else { 0.0 }
}

/// The scene rendered 4× finer and reconstructed with Mitsuba's Gaussian film at N², R, G, B only
/// (no header, no stderr), as `examples/foreign_render.rs` does, plus a background floor that
/// varies by up to `floor` between pixels (as Mitsuba's film does by ~1e-5), so that no uniform
/// background exists.
fn gaussian_film(dir: &Path, name: &str, text: &str, floor: f32) -> PathBuf {
    let fine = text.replacen(&format!("width = {N}"), &format!("width = {}", 4 * N), 1).replacen(
        &format!("height = {N}"),
        &format!("height = {}", 4 * N),
        1,
    );
    let fine = fine.replacen("spp = 16", "spp = 2", 1);
    let img = read_image(render_text(dir, &format!("{name}-fine"), &fine)).unwrap();
    let fw = 4 * N;
    let mut out = Image { width: N, height: N, ..Default::default() };
    let mut planes = vec![vec![0f32; N * N]; 3];
    for py in 0..N {
        for px in 0..N {
            let (cx, cy) = (px as f64 + 0.5, py as f64 + 0.5);
            let lo = |c: f64| ((c - 2.0) * 4.0).floor().max(0.0) as usize;
            let hi = |c: f64| (((c + 2.0) * 4.0).ceil() as usize).min(fw);
            let (mut acc, mut wsum) = ([0.0f64; 3], 0.0);
            for fy in lo(cy)..hi(cy) {
                let wy = gaussian((fy as f64 + 0.5) / 4.0 - cy);
                for fx in lo(cx)..hi(cx) {
                    let w = wy * gaussian((fx as f64 + 0.5) / 4.0 - cx);
                    for (ch, n) in ["R", "G", "B"].iter().enumerate() {
                        acc[ch] += w * img.channel(n).unwrap()[fy * fw + fx] as f64;
                    }
                    wsum += w;
                }
            }
            for ch in 0..3 {
                planes[ch][py * N + px] =
                    (acc[ch] / wsum) as f32 + floor * ((px * 7 + py * 13 + ch) % 10) as f32 / 10.0;
            }
        }
    }
    for (n, p) in ["R", "G", "B"].iter().zip(planes) {
        out.channels.insert(n.to_string(), p);
    }
    let path = dir.join(format!("{name}-gaussian.exr"));
    write_exr(&path, &out).unwrap();
    path
}

#[test]
fn microfacet_normal_probe_round_trip() {
    let dir = temp_dir("verdict-microfacet");
    let k = 4.0;
    for dist in ["beckmann", "ggx"] {
        for theta_o in [0.0] {
            let text = format!(
                "[render]\nwidth = 64\nheight = 32\nspp = 64\nseed = 3\nmax_depth = 1\nsampler = \"independent\"\n\
                 [camera]\ntype = \"normal-probe\"\ntheta_o_deg = {theta_o}\n\
                 [lighting]\ntype = \"envmap\"\nfile = {:?}\nmapping = \"angular\"\n\
                 [[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n\
                 brdf = {{ type = \"microfacet\", distribution = \"{dist}\", alpha = 0.3, fresnel = \"none\" }}\n",
                grace_s()
            );
            let p = render_text(&dir, &format!("{dist}-{theta_o}"), &text);
            let (doc, _) = analyze(&[p.to_str().unwrap(), "--lmax", "4"]);
            let an = doc["lambda_rho_analytic"].as_array().expect("an analytic column for microfacet");
            for (l, o) in doc["filter"].as_array().unwrap().iter().enumerate() {
                for ch in 0..3 {
                    let (e, s) = (o["estimate"][ch].as_f64().unwrap(), o["stderr"][ch].as_f64().unwrap());
                    let a = an[l][ch].as_f64().unwrap();
                    assert!((e - a).abs() <= k * s, "{dist} θ_o {theta_o} l={l} ch={ch}: {e} ± {s} vs analytic {a}");
                }
            }
            assert_eq!(status(&doc), "consistent", "{dist} θ_o {theta_o}: {}", doc["verdict"]["line"]);
        }
    }
    // The flags give the same column as the header (closed-set values by --brdf-param).
    let (code, out, err) = reflect_out(&[
        "sh",
        "transfer",
        "--brdf",
        "microfacet",
        "--brdf-param",
        "alpha=0.3",
        "--brdf-param",
        "distribution=ggx",
        "--lmax",
        "2",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("microfacet"), "{out}");
}

#[test]
fn analyze_flags_a_rotated_map_a_wrong_mapping_and_a_wrong_extent() {
    let dir = temp_dir("verdict-planted");
    let told = dir.join("told.toml");
    std::fs::write(&told, lambert_scene(0.0, 1.05, 0)).unwrap();
    let told_s = told.to_str().unwrap();
    for rot in [5.0] {
        // 64 spp: at 16 and 32 a 5° rotation sits near the threshold (p 2e-3 to 1e-2, the angle found
        // 3.75–4.5°, for renders of seed 1 whose light samples differ), a coin toss of a test; at 64,
        // p 2e-5 to 5e-5 and 4.25–4.5° for the same renders.
        let rotated = lambert_scene(rot, 1.05, 1).replacen("spp = 16", "spp = 64", 1);
        let p = render_text(&dir, &format!("rot{rot}"), &rotated);
        for (what, img) in [("stderr layer", p.clone()), ("no stderr", without_stderr(&p))] {
            let (doc, _) = analyze(&[img.to_str().unwrap(), "--lighting", told_s, "--lmax", "2"]);
            let v = &doc["verdict"];
            assert_eq!(status(&doc), "contradicts", "{rot}°, {what}: {}", v["line"]);
            assert_eq!(v["suspect"]["assumption"], "rotation", "{rot}°, {what}: {}", v["line"]);
            let deg: f64 = v["suspect"]["detail"].as_str().unwrap().split("by ").nth(1).unwrap()[..5]
                .trim_end_matches('°')
                .parse()
                .unwrap();
            assert!((deg.abs() - rot).abs() <= 1.0, "{rot}°, {what}: {}", v["line"]);
            // --no-diagnosis: the same test, and only the scale is tried.
            let (fast, _) = analyze(&[img.to_str().unwrap(), "--lighting", told_s, "--lmax", "2", "--no-diagnosis"]);
            let f = &fast["verdict"];
            assert_eq!(status(&fast), "contradicts", "{rot}°, {what}, --no-diagnosis: {}", f["line"]);
            assert_eq!(f["chi2"], v["chi2"], "{rot}°, {what}: --no-diagnosis changed the test");
            let tried: Vec<&str> =
                f["alternatives"].as_array().unwrap().iter().map(|a| a["assumption"].as_str().unwrap()).collect();
            assert_eq!(tried, ["scale"], "{rot}°, {what}, --no-diagnosis: {}", f["line"]);
        }
        // Mitsuba's Gaussian film, headerless: the told scene as a sidecar.
        let g = gaussian_film(&dir, &format!("rot{rot}"), &lambert_scene(rot, 1.05, 2), 1e-5);
        let (doc, _) = analyze(&[g.to_str().unwrap(), "--scene", told_s, "--lmax", "2"]);
        assert_eq!(status(&doc), "contradicts", "{rot}°, gaussian film: {}", doc["verdict"]["line"]);
    }
    // A square (angular) map read as lat-long: a warning, and the verdict names the mapping.
    let good = render_text(&dir, "good", &lambert_scene(0.0, 1.05, 3));
    let g = grace_s();
    for img in [good.clone(), without_stderr(&good)] {
        let (doc, err) = analyze(&[img.to_str().unwrap(), "--lighting", &g, "--mapping", "latlong", "--lmax", "2"]);
        assert!(err.contains("angular by its aspect ratio but is read as latlong"), "{err}");
        assert_eq!(status(&doc), "contradicts", "{}", doc["verdict"]["line"]);
        assert_eq!(doc["verdict"]["suspect"]["assumption"], "mapping", "{}", doc["verdict"]["line"]);
    }
    // A wrong extent, on a Gaussian film (no uniform background): the silhouette from the image's
    // own edge refuses it, naming the radii.
    let g = gaussian_film(&dir, "good", &lambert_scene(0.0, 1.05, 4), 1e-5);
    let wrong = dir.join("wrong-extent.toml");
    std::fs::write(&wrong, lambert_scene(0.0, 1.2, 0)).unwrap();
    let (code, _, err) =
        reflect_out(&["analyze", g.to_str().unwrap(), "--scene", wrong.to_str().unwrap(), "--lmax", "2"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("own edge") && err.lines().count() == 1, "{err}");
    // The diagnosis names the extent, with a range that holds the true 1.05.
    assert!(err.contains("likely wrong assumption is the extent"), "{err}");
    let range = err.split("an extent of ").nth(1).unwrap().split(' ').next().unwrap();
    let (lo, hi) = range.split_once('–').unwrap_or((range, range));
    let (lo, hi): (f64, f64) = (lo.parse().unwrap(), hi.parse().unwrap());
    assert!(lo <= 1.05 + 0.02 && hi >= 1.05 - 0.02, "{err}");
    // ... and the right extent passes the check and the verdict.
    let (doc, _) = analyze(&[g.to_str().unwrap(), "--scene", told_s, "--lmax", "2"]);
    assert_eq!(status(&doc), "consistent", "{}", doc["verdict"]["line"]);
}

#[test]
fn correct_images_are_not_flagged_beyond_the_stated_rate() {
    let dir = temp_dir("verdict-null");
    let told = dir.join("told.toml");
    std::fs::write(&told, lambert_scene(0.0, 1.05, 0)).unwrap();
    let mut flagged = Vec::new();
    for seed in 10..16 {
        let p = render_text(&dir, &format!("seed{seed}"), &lambert_scene(0.0, 1.05, seed));
        for img in [p.clone(), without_stderr(&p)] {
            let (doc, _) = analyze(&[img.to_str().unwrap(), "--lmax", "2"]);
            assert_eq!(doc["verdict"]["alpha"], 0.01);
            if status(&doc) != "consistent" {
                flagged.push(doc["verdict"]["line"].to_string());
            }
        }
    }
    assert!(flagged.len() <= 1, "{flagged:#?}");
}

/// A map flipped left to right (a renderer whose azimuth runs the other way: φ → π − φ on the
/// angular probe) is flagged and the diagnosis names the mirrored frame, at the right turn (180°:
/// u → −u is φ → −φ then a half turn), with and without the stderr layer. Planted error: without
/// the `mirrored` alternative the suspect is a rotation or none.
#[test]
fn analyze_names_a_mirrored_map() {
    let dir = temp_dir("verdict-mirror");
    let mut map = read_image(grace()).unwrap();
    let w = map.width;
    for plane in map.channels.values_mut() {
        for row in plane.chunks_mut(w) {
            row.reverse();
        }
    }
    let flipped = dir.join("grace-flipped.exr");
    write_exr(&flipped, &map).unwrap();
    let told = dir.join("told.toml");
    std::fs::write(&told, lambert_scene(0.0, 1.05, 0)).unwrap();
    let text =
        lambert_scene(0.0, 1.05, 5).replace(&format!("{:?}", grace_s()), &format!("{:?}", flipped.to_str().unwrap()));
    let p = render_text(&dir, "mirrored", &text);
    for (what, img) in [("stderr layer", p.clone()), ("no stderr", without_stderr(&p))] {
        let (doc, _) = analyze(&[img.to_str().unwrap(), "--lighting", told.to_str().unwrap(), "--lmax", "2"]);
        let v = &doc["verdict"];
        assert_eq!(status(&doc), "contradicts", "{what}: {}", v["line"]);
        assert_eq!(v["suspect"]["assumption"], "mirrored", "{what}: {}", v["line"]);
        let detail = v["suspect"]["detail"].as_str().unwrap();
        let deg: f64 = detail.rsplit("by ").next().unwrap().split('°').next().unwrap().parse().unwrap();
        assert!((deg.abs() - 180.0).abs() <= 2.0, "{what}: {detail}");
    }
}

/// The text says which χ²/ν is which: the fit at l ≤ l_max (above 1 by the truncated orders, not
/// the verdict's test) and the one with the orders up to the truncation order (the one warned
/// about above 2), and the verdict line says when the pixels scatter beyond their σ. Planted error:
/// the text without the second line (as it was) fails.
#[test]
fn analyze_text_names_both_chi2_and_agrees_with_json() {
    let dir = temp_dir("verdict-text");
    let p = render_text(&dir, "good", &lambert_scene(0.0, 1.05, 20));
    let p = p.to_str().unwrap();
    let (code, out, err) = reflect_out(&["analyze", p, "--lmax", "2"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("filter fit χ²/ν at l <= 2") && out.contains("not the verdict's test"), "{out}");
    let top = out.lines().find(|l| l.starts_with("# with the orders up to l = ")).unwrap_or_else(|| panic!("{out}"));
    assert!(top.contains("truncation_chi2_per_dof"), "{top}");
    let (doc, werr) = analyze(&[p, "--lmax", "2"]);
    let x: Vec<f64> =
        doc["filter_fit"].as_array().unwrap().iter().map(|c| c["truncation_chi2_per_dof"].as_f64().unwrap()).collect();
    for (c, v) in ["R", "G", "B"].iter().zip(&x) {
        assert!(top.contains(&format!("{c} {v:.3}")), "{top} against {x:?}");
    }
    let line = doc["verdict"]["line"].as_str().unwrap();
    assert!(out.contains(line), "{out}");
    // Above 2: a warning and the verdict's note; else neither.
    let above = x.iter().any(|v| *v > 2.0);
    assert_eq!(line.contains("scatter beyond their σ"), above && status(&doc) == "consistent", "{line}: {x:?}");
    assert_eq!(
        werr.contains("more scatter than the per-pixel σ") || werr.contains("signal the model does not carry"),
        above,
        "{werr}: {x:?}"
    );
}

/// `invert brdf`'s verdict: the measured filter against the recovered model (Phong at the fitted
/// s). Correct Phong images (s = 8, `horizon = "ignore"` so that eq. 43 is exact; 64², 16 spp,
/// 4 seeds) pass at α = 1 %: false alarms Binomial(4, 0.01), P(≥ 2) = 5.9e-4, so more than one
/// fails; a Lambert sphere and a Torrance–Sparrow one (σ 0.3) fitted as Phong are flagged, with
/// exit status 0 (a finding, as `analyze`'s) and the text's `# verdict:` line the JSON's. Planted
/// error: a verdict that is always consistent fails on the Lambert sphere.
#[test]
fn invert_brdf_verdict_passes_the_model_and_flags_another_brdf() {
    let dir = temp_dir("verdict-invert");
    let scene = |brdf: &str, seed: u64| {
        lambert_scene(0.0, 1.05, seed).replace("brdf = { type = \"lambert\", albedo = [0.8, 0.8, 0.8] }", brdf)
    };
    let invert = |img: &Path| {
        let (code, out, err) =
            reflect_out(&["invert", "brdf", img.to_str().unwrap(), "--model", "phong", "--lmax", "6", "--json"]);
        assert_eq!(code, 0, "{err}");
        serde_json::from_str::<Value>(&out).unwrap()
    };
    let phong = "brdf = { type = \"phong\", s = 8.0, horizon = \"ignore\" }";
    let mut flagged = Vec::new();
    for seed in 30..34 {
        let p = render_text(&dir, &format!("phong{seed}"), &scene(phong, seed));
        let doc = invert(&p);
        assert_eq!(doc["verdict"]["alpha"], 0.01);
        if status(&doc) != "consistent" {
            flagged.push(doc["verdict"]["line"].to_string());
        }
    }
    assert!(flagged.len() <= 1, "{flagged:#?}");
    for (name, brdf) in [
        ("lambert", "brdf = { type = \"lambert\", albedo = [0.8, 0.8, 0.8] }"),
        ("ts", "brdf = { type = \"torrance-sparrow\", sigma = 0.3, horizon = \"ignore\" }"),
    ] {
        let p = render_text(&dir, name, &scene(brdf, 40));
        let doc = invert(&p);
        assert_eq!(status(&doc), "contradicts", "{name}: {}", doc["verdict"]["line"]);
        let (code, out, err) = reflect_out(&["invert", "brdf", p.to_str().unwrap(), "--model", "phong", "--lmax", "6"]);
        assert_eq!(code, 0, "{err}");
        let line = out.lines().find(|l| l.starts_with("# verdict: ")).unwrap_or_else(|| panic!("{out}"));
        assert_eq!(&line[2..], doc["verdict"]["line"].as_str().unwrap());
    }
}

/// `invert lighting`'s verdict on normal-probe renders (64 × 32): the orders the told BRDF does not
/// pass (a Lambertian sphere's odd l ≥ 3) must hold nothing but noise and what the pixel grid puts
/// there from the passed orders. Lambert probes agree: of 4 seeds at 64 spp at most one may be
/// flagged (α = 0.01 each: P(≥ 2 of 4) = 6e-4), and one at 16384 spp, where the grid's share is
/// ≈ 10σ, must be consistent (its χ² is 15–19 per channel for ν 18 with it subtracted); a Phong sphere (s = 4) told to be
/// Lambertian contradicts it, with exit status 0 and the text's `# verdict:` line the JSON's.
/// Planted errors the test failed on: the grid's share not subtracted (the 16384-spp probe
/// contradicts: χ² 151 for ν 54); a verdict that is always consistent (the Phong
/// sphere passes).
#[test]
fn invert_lighting_verdict_tests_the_orders_the_brdf_blocks() {
    let dir = temp_dir("verdict-invert-lighting");
    let probe = |brdf: &str, seed: u64, spp: u32| {
        lambert_scene(0.0, 1.05, seed)
            .replace(&format!("width = {N}\nheight = {N}"), "width = 64\nheight = 32")
            .replace("spp = 16", &format!("spp = {spp}"))
            .replace(
                "type = \"orthographic\"\nfrom = [3.0, 0.0, 1.0]\nto = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nextent = 1.05",
                "type = \"normal-probe\"",
            )
            .replace("brdf = { type = \"lambert\", albedo = [0.8, 0.8, 0.8] }", brdf)
    };
    let lambert = "brdf = { type = \"lambert\", albedo = [0.8, 0.8, 0.8] }";
    let invert = |img: &Path, extra: &[&str]| {
        let mut args = vec!["invert", "lighting", img.to_str().unwrap(), "--lmax", "6"];
        args.extend_from_slice(extra);
        let (code, out, err) = reflect_out(&[args.as_slice(), &["--json"]].concat());
        assert_eq!(code, 0, "{err}");
        let doc: Value = serde_json::from_str(&out).unwrap();
        let (code, text, err) = reflect_out(&args);
        assert_eq!(code, 0, "{err}");
        let line = text.lines().find(|l| l.starts_with("# verdict: ")).unwrap_or_else(|| panic!("{text}"));
        assert_eq!(&line[2..], doc["verdict"]["line"].as_str().unwrap());
        doc
    };
    let mut flagged = Vec::new();
    for (seed, spp) in [(50, 64), (51, 64), (52, 64), (53, 64), (54, 16384)] {
        let p = render_text(&dir, &format!("lambert{seed}"), &probe(lambert, seed, spp));
        let doc = invert(&p, &[]);
        assert_eq!(doc["verdict"]["dof"], 3 * (7 + 11), "l = 3, 5 in R, G, B: {}", doc["verdict"]);
        if spp > 64 {
            assert_eq!(status(&doc), "consistent", "{}", doc["verdict"]["line"]);
        } else if status(&doc) != "consistent" {
            flagged.push(doc["verdict"]["line"].to_string());
        }
    }
    assert!(flagged.len() <= 1, "{flagged:#?}");
    let phong = render_text(
        &dir,
        "phong",
        &probe("brdf = { type = \"phong\", ks = [0.8, 0.8, 0.8], s = 4.0, horizon = \"ignore\" }", 60, 256),
    );
    let mut img = read_image(&phong).unwrap();
    img.attributes.remove("reflect:objects");
    let told = dir.join("told-lambert.exr");
    write_exr(&told, &img).unwrap();
    let doc = invert(&told, &["--brdf", "lambert", "--albedo", "0.8"]);
    assert_eq!(status(&doc), "contradicts", "{}", doc["verdict"]["line"]);
    assert!(doc["verdict"]["line"].as_str().unwrap().contains("CONTRADICTS the lambert BRDF"), "{doc}");
}
