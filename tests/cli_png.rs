//! `reflect png` (and `render --png --exposure`) through the binary: the exposure arithmetic on a
//! known pixel value, and bad input (exit 2, one line naming the file, no output). Also
//! `sh project`'s refusal of a render.

mod common;
use analysis::image::{Image, write_exr};
use common::*;
use std::path::Path;

fn assert_refused(args: &[&str], names: &str, mentions: &str, no_output: &Path) {
    assert_bad_input(args, names, mentions, no_output);
    let dir = no_output.parent().unwrap();
    let stray: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
        .collect();
    assert!(stray.is_empty(), "temporary files left: {stray:?}");
}

/// A 4×2 EXR with the value 0.25 in R, G, B everywhere, object mask on the left half.
fn flat_exr(path: &Path, attrs: &[(&str, &str)]) {
    let mut img = Image { width: 4, height: 2, ..Default::default() };
    for c in ["R", "G", "B"] {
        img.channels.insert(c.into(), vec![0.25; 8]);
    }
    img.channels.insert("mask.Y".into(), vec![1.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0]);
    for (k, v) in attrs {
        img.attributes.insert(k.to_string(), v.to_string());
    }
    write_exr(path, &img).unwrap();
}

fn png_bytes(path: &Path) -> Vec<u8> {
    image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgb8().into_raw()
}

#[test]
fn exposure_arithmetic_on_a_known_pixel() {
    let dir = temp_dir("png-exposure");
    let exr = dir.join("flat.exr");
    flat_exr(&exr, &[]);
    // 0.25 · 2^2 = 1 → Reinhard 1/(1+1) = 0.5 → sRGB 1.055·0.5^(1/2.4) − 0.055 = 0.735357 → 187.5 → 188.
    let out = dir.join("ev2.png");
    let (code, err) = reflect(&["png", exr.to_str().unwrap(), "--exposure", "2", "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("+2.00 EV"), "the exposure used is printed: {err}");
    assert!(png_bytes(&out).iter().all(|&b| b == 188));
    // Negative EV: 0.25 · 2^-1 = 0.125 → 1/9 → sRGB 1.055·(1/9)^(1/2.4) − 0.055 = 0.367331 → 93.67 → 94.
    let out = dir.join("evm1.png");
    let (code, err) = reflect(&["png", exr.to_str().unwrap(), "--exposure", "-1", "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(png_bytes(&out).iter().all(|&b| b == 94));
    // Automatic: the object's median 0.25 → 0.18 is EV log2(0.72) = −0.474; 0.18 → 0.18/1.18 → sRGB 0.426968 → 108.88 → 109.
    let out = dir.join("auto.png");
    let (code, err) = reflect(&["png", exr.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("-0.47 EV") && err.contains("automatic"), "{err}");
    assert!(png_bytes(&out).iter().all(|&b| b == 109));
    // Another layer: mask.Y as grey, 1 at EV 0 → 0.5 → 188; 0 → 0.
    let out = dir.join("mask.png");
    let (code, err) =
        reflect(&["png", exr.to_str().unwrap(), "--layer", "mask", "--exposure", "0", "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(&png_bytes(&out)[..12], &[188, 188, 188, 188, 188, 188, 0, 0, 0, 0, 0, 0]);
}

#[test]
fn automatic_exposure_of_a_layer_whose_median_is_zero_says_none_was_applied() {
    // A 0/1 layer (as `stderr_flag` with few flags): the object's median is 0, so there is nothing to
    // scale; the message must not claim the median went to 0.18.
    let dir = temp_dir("png-zero-median");
    let exr = dir.join("flags.exr");
    let mut img = Image { width: 4, height: 2, ..Default::default() };
    for c in ["R", "G", "B"] {
        img.channels.insert(c.into(), vec![0.25; 8]);
    }
    img.channels.insert("mask.Y".into(), vec![1.0; 8]);
    img.channels.insert("stderr_flag.Y".into(), vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0]);
    write_exr(&exr, &img).unwrap();
    let out = dir.join("flags.png");
    let (code, err) =
        reflect(&["png", exr.to_str().unwrap(), "--layer", "stderr_flag", "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("+0.00 EV") && err.contains("median luminance is 0, so none applied"), "{err}");
    assert!(!err.contains("→ 0.18"), "{err}");
}

#[test]
fn render_png_takes_an_exposure() {
    let dir = temp_dir("png-render");
    let scene = dir.join("s.toml");
    std::fs::write(
        &scene,
        "[render]\nwidth = 8\nheight = 8\nspp = 2\nmax_depth = 1\n[camera]\ntype = \"normal-probe\"\n\
         [lighting]\ntype = \"uniform\"\nradiance = 1.0\n[[objects]]\nshape = \"sphere\"\n\
         brdf = { type = \"lambert\", albedo = 0.5 }\n",
    )
    .unwrap();
    let (exr, png) = (dir.join("s.exr"), dir.join("s.png"));
    let args = ["render", scene.to_str().unwrap(), "--out", exr.to_str().unwrap(), "--png", png.to_str().unwrap()];
    let (code, err) = reflect(&[&args[..], &["--exposure", "1"]].concat());
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("+1.00 EV"), "{err}");
    // Every byte is the tone map of the EXR's value at EV 1: sRGB(x/(1+x)), x = 2v, to the nearest byte.
    let img = analysis::image::read_image(&exr).unwrap();
    let bytes = png_bytes(&png);
    for (i, b) in bytes.iter().enumerate() {
        let v = img.channel(["R", "G", "B"][i % 3]).unwrap()[i / 3] as f64;
        let y = 2.0 * v / (1.0 + 2.0 * v);
        let s = if y <= 0.0031308 { 12.92 * y } else { 1.055 * y.powf(1.0 / 2.4) - 0.055 };
        assert!((s * 255.0 - *b as f64).abs() <= 0.5 + 1e-3, "byte {i}: {b} vs {}", s * 255.0);
    }
}

#[test]
fn png_bad_input_is_refused() {
    let dir = temp_dir("png-bad");
    let out = dir.join("out.png");
    let o = out.to_str().unwrap();
    let missing = dir.join("missing.exr");
    assert_refused(&["png", missing.to_str().unwrap(), "--out", o], "missing.exr", "cannot read", &out);
    let garbage = dir.join("garbage.exr");
    std::fs::write(&garbage, b"this is not an image").unwrap();
    assert_refused(&["png", garbage.to_str().unwrap(), "--out", o], "garbage.exr", "not an openexr", &out);
    let truncated = dir.join("truncated.exr");
    flat_exr(&truncated, &[]);
    let bytes = std::fs::read(&truncated).unwrap();
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    assert_refused(&["png", truncated.to_str().unwrap(), "--out", o], "truncated.exr", "", &out);
    let flat = dir.join("flat.exr");
    flat_exr(&flat, &[]);
    assert_refused(&["png", flat.to_str().unwrap(), "--layer", "nope", "--out", o], "flat.exr", "no layer", &out);
    assert_refused(
        &["png", flat.to_str().unwrap(), "--out", dir.join("x.jpg").to_str().unwrap()],
        "x.jpg",
        "png",
        &out,
    );
    assert_refused(&["png", flat.to_str().unwrap(), "--exposure", "inf", "--out", o], "exposure", "finite", &out);
}

#[test]
fn sh_project_refuses_a_render() {
    let dir = temp_dir("sh-project-render");
    let render = dir.join("render.exr");
    flat_exr(&render, &[("reflect:camera", r#"{"type":"orthographic","from":[3,0,0],"to":[0,0,0],"extent":1.05}"#)]);
    let (code, err) = reflect(&["sh", "project", render.to_str().unwrap(), "--mapping", "latlong", "--lmax", "1"]);
    assert_eq!(code, 2, "{err}");
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(lines[0].contains("render.exr") && lines[0].contains("orthographic") && lines[0].contains("render"));
    // The same pixels without the attribute, or with an environment camera, are projected.
    let env = dir.join("env.exr");
    flat_exr(&env, &[]);
    let (code, err) = reflect(&["sh", "project", env.to_str().unwrap(), "--mapping", "latlong", "--lmax", "1"]);
    assert_eq!(code, 0, "{err}");
    flat_exr(&env, &[("reflect:camera", r#"{"type":"environment"}"#)]);
    let (code, err) = reflect(&["sh", "project", env.to_str().unwrap(), "--mapping", "latlong", "--lmax", "1"]);
    assert_eq!(code, 0, "{err}");
}
