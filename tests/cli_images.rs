//! The image cases of `../shared/cases` through the real binary: right values from `sh project`
//! and `render`, and bad input refused (exit 2, one stderr line naming the file, no output), the
//! oversized Radiance claim also under an address-space limit.

mod common;
use common::*;
use std::path::Path;
use std::process::Command;

fn cases() -> std::path::PathBuf {
    root().join("../shared/cases")
}

fn project(file: &Path, lmax: usize) -> Vec<[f64; 3]> {
    let args = ["sh", "project", file.to_str().unwrap(), "--mapping", "latlong", "--lmax", &lmax.to_string(), "--json"];
    let (code, out, err) = reflect_out(&args);
    assert_eq!(code, 0, "{file:?}: {err}");
    let doc: serde_json::Value = serde_json::from_str(&out).unwrap();
    serde_json::from_value(doc["coefficients"].clone()).unwrap()
}

fn assert_refused(args: &[&str], names: &str) {
    let (code, out, err) = reflect_out(args);
    assert_eq!(code, 2, "{args:?}: {err}");
    assert!(out.is_empty(), "{args:?} printed {out}");
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{args:?}: {err}");
    assert!(lines[0].contains(names), "{err}");
}

#[test]
fn exr_data_window_cases_project_alike() {
    for name in ["reference_full", "crop_top_half", "overscan"] {
        let c = project(&cases().join(format!("exr-data-window/{name}.exr")), 1);
        assert_eq!(format!("{:.4} {:.4}", c[0][0], c[2][0]), "3.5449 3.0700", "{name}");
        assert!(c[1][0].abs() < 1e-14 && c[3][0].abs() < 1e-14, "{name}: {c:?}");
    }
}

#[test]
fn env_coarse_cases_project_exactly() {
    let e = project(&cases().join("env-coarse/e_2x1.exr"), 1);
    assert_eq!(format!("{:.4} {:.4}", e[0][0], e[1][0]), "1.7725 1.5350");
    let f = project(&cases().join("env-coarse/f_1x2.exr"), 8);
    assert_eq!(format!("{:.4} {:.4}", f[0][0], f[2][0]), "1.7725 1.5350");
    for l in 1..=8i64 {
        for m in 1..=l {
            assert_eq!(f[(l * (l + 1) + m) as usize], [0.0; 3]);
            assert_eq!(f[(l * (l + 1) - m) as usize], [0.0; 3]);
        }
    }
}

#[test]
fn env_coarse_renders_give_the_half_space_irradiance() {
    // A Lambert sphere (albedo 1) under half-space radiance 1 has B(n) = (1 + n·a)/2, a = +y for the
    // 2 × 1 map, +z for the 1 × 2 one; every pixel within 5 of its own standard errors (+1e-6).
    // At 1024 spp, not the case's 64: a pixel facing away from the lit half within ~8° sees the light
    // through a sliver that a few % of its light samples reach, and at 64 spp such a pixel can draw
    // none (value 0, σ 0, true 0.005: an event never drawn is invisible to any error bar from the
    // pixel's own samples, guide "Error bars", "Heavy tails"). One Sobol sequence of 64 points used to
    // hit it by stratification; the replicated sampler's 16 scrambles of 4 points do not.
    let d = temp_dir("env-coarse-render");
    for (name, axis) in [("e_2x1", 1usize), ("f_1x2", 2)] {
        let out = d.join(format!("{name}.exr"));
        let scene = cases().join(format!("env-coarse/{name}.toml"));
        let (code, _, err) =
            reflect_out(&["render", scene.to_str().unwrap(), "--out", out.to_str().unwrap(), "-q", "--spp", "1024"]);
        assert_eq!(code, 0, "{err}");
        let img = analysis::image::read_image(&out).unwrap();
        let (b, se) = (img.rgb().unwrap(), img.rgb_layer("stderr.").unwrap());
        let mut worst = 0.0f64;
        for r in 0..img.height {
            for c in 0..img.width {
                let n = analysis::sh::latlong_direction(r, c, img.width, img.height);
                let want = 0.5 * (1.0 + n[axis]);
                let (got, s) = (b.get(r, c)[0] as f64, se.get(r, c)[0] as f64);
                worst = worst.max((got - want).abs() / (5.0 * s + 1e-6));
            }
        }
        assert!(worst <= 1.0, "{name}: worst |B − (1 + n·a)/2| / (5σ + 1e-6) = {worst}");
    }
}

#[test]
fn hdr_size_claim_is_refused_at_once_even_under_an_address_space_limit() {
    let f = cases().join("hdr-size-claim/claims_32768.hdr");
    assert_refused(&["sh", "project", f.to_str().unwrap(), "--lmax", "2"], "claims_32768.hdr");
    // Under `ulimit -v 2000000` (2 GB), as the case's README asks: still exit 2, not an abort.
    let cmd =
        format!("ulimit -v 2000000; exec '{}' sh project '{}' --lmax 2", env!("CARGO_BIN_EXE_reflect"), f.display());
    let out = Command::new("sh").args(["-c", &cmd]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(out.stdout.is_empty());
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("claims_32768.hdr") && err.contains("32768×32768"), "{err}");
    // And the render of a scene that lights with it writes nothing.
    let d = temp_dir("hdr-claim-render");
    let scene = d.join("s.toml");
    std::fs::write(
        &scene,
        format!(
            "[render]\nwidth = 4\nheight = 4\nspp = 1\n[camera]\ntype = \"normal-probe\"\n[lighting]\ntype = \"envmap\"\nfile = \"{}\"\nmapping = \"latlong\"\n[[objects]]\nshape = \"sphere\"\nbrdf = {{ type = \"lambert\", albedo = 1.0 }}\n",
            f.display()
        ),
    )
    .unwrap();
    let out_exr = d.join("o.exr");
    assert_refused(&["render", scene.to_str().unwrap(), "--out", out_exr.to_str().unwrap()], "claims_32768.hdr");
    assert!(!out_exr.exists());
}

#[test]
fn bad_images_are_refused_with_one_line() {
    let d = temp_dir("bad-images");
    let good = std::fs::read(cases().join("exr-data-window/reference_full.exr")).unwrap();
    let trunc = d.join("trunc.exr");
    std::fs::write(&trunc, &good[..good.len() - 40]).unwrap();
    assert_refused(&["sh", "project", trunc.to_str().unwrap(), "--lmax", "1"], "trunc.exr");
    let hdr = d.join("orient.hdr");
    std::fs::write(&hdr, b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Z 2 +X 2\n\x80\x80\x80\x81").unwrap();
    assert_refused(&["sh", "project", hdr.to_str().unwrap(), "--lmax", "1"], "orient.hdr");
    let xyz = d.join("xyz.hdr");
    std::fs::write(&xyz, b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 2\n\x80\x80\x80\x81\x80\x80\x80\x81").unwrap();
    assert_refused(&["sh", "project", xyz.to_str().unwrap(), "--lmax", "1"], "xyz.hdr");
}

#[test]
fn multi_part_exr_names_the_part_it_uses() {
    use exr::prelude::*;
    let d = temp_dir("multipart-cli");
    let f = d.join("parts.exr");
    let ch = |names: &[&str], v: f32| {
        AnyChannels::sort(
            names
                .iter()
                .map(|n| AnyChannel::new(Text::from(*n), FlatSamples::F32(vec![v; 8])))
                .collect::<Vec<_>>()
                .into(),
        )
    };
    let z = Layer::new((4, 2), LayerAttributes::named("depth"), Encoding::UNCOMPRESSED, ch(&["Z"], 9.0));
    let rgb = Layer::new((4, 2), LayerAttributes::named("beauty"), Encoding::UNCOMPRESSED, ch(&["R", "G", "B"], 1.0));
    Image::from_layers(ImageAttributes::new(IntegerBounds::from_dimensions((4, 2))), vec![z, rgb])
        .write()
        .to_file(&f)
        .unwrap();
    let (code, out, err) = reflect_out(&["sh", "project", f.to_str().unwrap(), "--lmax", "0", "--json"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("parts.exr") && err.contains("part 1 ('beauty')"), "{err}");
    let doc: serde_json::Value = serde_json::from_str(&out).unwrap();
    let l00 = doc["coefficients"][0][0].as_f64().unwrap();
    assert!((l00 - (4.0 * std::f64::consts::PI).sqrt()).abs() < 1e-12, "{l00}");
}

#[test]
fn exr_primaries_and_compressible_cases_give_the_right_values() {
    let f = cases().join("exr-primaries/red_ap0.exr");
    let (code, out, err) =
        reflect_out(&["sh", "project", f.to_str().unwrap(), "--mapping", "latlong", "--lmax", "1", "--json"]);
    assert_eq!(code, 0, "{err}");
    let doc: serde_json::Value = serde_json::from_str(&out).unwrap();
    let c: Vec<[f64; 3]> = serde_json::from_value(doc["coefficients"].clone()).unwrap();
    assert_eq!(format!("{:.4} {:.4} {:.4}", c[0][0], c[0][1], c[0][2]), "8.9391 -0.9801 -0.0545");
    // The user is told: one note naming the file, the attribute and the conversion.
    let notes: Vec<&str> = err.lines().filter(|l| l.starts_with("note:")).collect();
    assert_eq!(notes.len(), 1, "{err}");
    assert!(notes[0].contains("red_ap0.exr") && notes[0].contains("chromaticities") && notes[0].contains("Bradford"));
    for name in ["studio_2k_ZIP", "studio_2k_PIZ"] {
        let c = project(&cases().join(format!("exr-compressible/{name}.exr")), 0);
        assert_eq!(format!("{:.5} {:.5} {:.5}", c[0][0], c[0][1], c[0][2]), "8.05804 8.05804 8.05804", "{name}");
    }
}

/// A 4 × 2 lat-long multi-part file: an AOV `diffuse` of value 1 first, the beauty `rgba` of value 2.
fn aov_first(dir: &Path) -> std::path::PathBuf {
    use exr::prelude::*;
    let part = |name: &str, v: f32| {
        let ch: Vec<AnyChannel<FlatSamples>> =
            ["R", "G", "B"].iter().map(|c| AnyChannel::new(Text::from(*c), FlatSamples::F32(vec![v; 8]))).collect();
        Layer::new(
            (4, 2),
            LayerAttributes::named(name),
            Encoding::UNCOMPRESSED,
            AnyChannels::sort(ch.into_iter().collect()),
        )
    };
    let f = dir.join("aov_first.exr");
    Image::from_layers(
        ImageAttributes::new(IntegerBounds::from_dimensions((4, 2))),
        vec![part("diffuse", 1.0), part("rgba", 2.0)],
    )
    .write()
    .to_file(&f)
    .unwrap();
    f
}

/// Every command that reads a map chooses its part: `sh project` and `png` take the beauty by
/// default and a part by `--layer`; an unknown part is refused with the list of layers.
#[test]
fn multi_part_commands_take_the_beauty_or_the_part_asked() {
    let d = temp_dir("multipart-choose");
    let f = aov_first(&d);
    let fs = f.to_str().unwrap();
    let l00 = |extra: &[&str]| {
        let mut args = vec!["sh", "project", fs, "--lmax", "0", "--json"];
        args.extend(extra);
        let (code, out, err) = reflect_out(&args);
        assert_eq!(code, 0, "{err}");
        let doc: serde_json::Value = serde_json::from_str(&out).unwrap();
        doc["coefficients"][0][0].as_f64().unwrap() / (4.0 * std::f64::consts::PI).sqrt()
    };
    assert!((l00(&[]) - 2.0).abs() < 1e-12);
    assert!((l00(&["--layer", "diffuse"]) - 1.0).abs() < 1e-12);
    assert!((l00(&["--layer", "rgba"]) - 2.0).abs() < 1e-12);
    assert_refused(&["sh", "project", fs, "--lmax", "0", "--layer", "specular"], "'diffuse'");
    // png: the beauty at EV 0 is 2/(1+2) → sRGB 0.667 (213), the AOV 1/2 → 188.
    for (layer, want) in [(None, 213u8), (Some("diffuse"), 188)] {
        let png = d.join(format!("{}.png", layer.unwrap_or("beauty")));
        let mut args = vec!["png", fs, "--exposure", "0", "--out", png.to_str().unwrap()];
        if let Some(l) = layer {
            args.extend(["--layer", l]);
        }
        let (code, _, err) = reflect_out(&args);
        assert_eq!(code, 0, "{err}");
        let px = image::open(&png).unwrap().to_rgb8();
        assert_eq!(px.get_pixel(0, 0).0, [want; 3], "{layer:?}");
    }
}

/// The scene's envmap `layer` key chooses the part that lights the render: the beauty (2) lights
/// exactly twice as bright as the AOV (1), bit for bit (the sampler's distribution is the same and
/// × 2 is exact), and an unknown layer is refused before any output.
#[test]
fn scene_envmap_layer_key_chooses_the_part() {
    let d = temp_dir("multipart-scene");
    aov_first(&d);
    let render = |layer: &str| {
        let toml = format!(
            "[render]\nwidth = 8\nheight = 4\nspp = 4\nseed = 3\nmax_depth = 1\n[camera]\ntype = \"normal-probe\"\n\
             [lighting]\ntype = \"envmap\"\nfile = \"aov_first.exr\"\nmapping = \"latlong\"\n{layer}\n\
             [[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nbrdf = {{ type = \"lambert\", albedo = 0.5 }}\n"
        );
        let name = if layer.is_empty() { "default".to_string() } else { layer.replace(['"', ' ', '='], "") };
        let scene = d.join(format!("{name}.toml"));
        std::fs::write(&scene, toml).unwrap();
        let out = d.join(format!("{name}.exr"));
        (reflect_out(&["render", scene.to_str().unwrap(), "--out", out.to_str().unwrap(), "-q"]), out)
    };
    let pixels = |layer: &str| {
        let ((code, _, err), out) = render(layer);
        assert_eq!(code, 0, "{layer}: {err}");
        analysis::image::read_rgb(&out).unwrap().pixels
    };
    let (beauty, named, aov) = (pixels(""), pixels("layer = \"rgba\""), pixels("layer = \"diffuse\""));
    assert!(aov.iter().all(|p| p[0] > 0.0));
    for ((b, n), a) in beauty.iter().zip(&named).zip(&aov) {
        assert_eq!(b, n);
        assert_eq!(*b, a.map(|v| 2.0 * v));
    }
    let ((code, out, err), exr) = render("layer = \"specular\"");
    assert_eq!(code, 2, "{err}");
    assert!(out.is_empty() && !exr.exists());
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(
        lines[0].contains("aov_first.exr") && lines[0].contains("'specular'") && lines[0].contains("'diffuse'"),
        "{err}"
    );
}
