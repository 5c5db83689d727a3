//! The guide's main flow: `reflect render SCENE --out DIR/x.exr`, then `reflect analyze DIR/x.exr`
//! with nothing else, from another working directory. The header names the lighting file the render
//! used; that name must still find it (it was the scene-relative path joined to the render's working
//! directory, which `analyze` then looked for next to the EXR: "cannot read file").

mod common;

#[test]
fn a_render_is_analysed_from_its_header_alone_from_any_directory() {
    let dir = common::temp_dir("render-then-analyze");
    let out = dir.join("sub").join("l.exr");
    // Render from the checkout's root with the scene path relative to it (as the guide does).
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_reflect"))
        .current_dir(common::root())
        .args(["render", "scenes/lambert-grace.toml", "--size", "48x48", "--spp", "8", "--out"])
        .arg(&out)
        .output()
        .expect("run reflect");
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    // Analyse from the output's directory, with no --lighting: the header's lighting must be found.
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_reflect"))
        .current_dir(dir.join("sub"))
        .args(["analyze", "l.exr", "--lmax", "2", "--json"])
        .output()
        .expect("run reflect");
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "analyze of a fresh render failed: {err}");
    let doc: serde_json::Value = serde_json::from_slice(&run.stdout).expect("JSON");
    assert_eq!(doc["lighting"]["source"], "reflect:lighting header", "{:.400}", doc.to_string());
    // Grace's L_00 (red) as the map gives it: the header named the right file.
    let l00 = doc["lighting"]["coefficients"][0][0].as_f64().unwrap();
    assert!((l00 - 2.53).abs() < 0.01, "L_00 R = {l00}");
    assert!(doc["lambda_rho_analytic"].is_array(), "the header's BRDF gives the analytic column");
    // Our render's header says one sample counts in one pixel: F = 1, not measured from residuals
    // that carry the fit's truncation remainder.
    assert_eq!(doc["pixel_noise"]["source"], "reflect-render", "{}", doc["pixel_noise"]);
    assert_eq!(doc["pixel_noise"]["inflation"], 1.0);
}
