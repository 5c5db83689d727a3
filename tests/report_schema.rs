//! The JSON schemas of the typed reports (issue 11): `analyze`, `invert lighting`, `invert brdf`,
//! `invert separate` and `invert factor` print their report structs with `--json`; the top-level keys and the JSON type of each are
//! pinned here, so a renamed or retyped field is a deliberate change (scripts and the Python
//! package read these documents).

mod common;

use analysis::image::{Image, write_exr};
use analysis::sh::{Reconstructor, latlong_direction, num_coefficients};
use common::json::{assert_documented, kind, reflect_json};
use serde_json::Value;

/// `doc` has exactly the keys of `schema`, each of one of the listed types ("number|null").
fn assert_schema(doc: &Value, schema: &[(&str, &str)], what: &str) {
    let obj = doc.as_object().unwrap_or_else(|| panic!("{what}: not an object"));
    let mut keys: Vec<&str> = obj.keys().map(String::as_str).collect();
    keys.sort_unstable();
    let mut want: Vec<&str> = schema.iter().map(|(k, _)| *k).collect();
    want.sort_unstable();
    assert_eq!(keys, want, "{what}: top-level keys");
    for (k, types) in schema {
        let t = kind(&obj[*k]);
        assert!(types.split('|').any(|x| x == t), "{what}.{k}: {t}, expected {types}");
    }
}

/// A Phong (s = 8, ignore) `normal-probe` image under an SH lighting l ≤ 2: B = Λ_l ρ̂_l L_lm (exact).
fn probe(dir: &std::path::Path) -> std::path::PathBuf {
    probe_at(dir, "phong-probe.exr", 0.0, 0.0)
}

/// [`probe`]'s pixels with the camera header of a pixel-centre normal-probe at (θ_o°, φ_o°) (the
/// values are not those of a render at θ_o > 0: the schema tests need only commands that run).
fn probe_at(dir: &std::path::Path, name: &str, theta_o_deg: f64, phi_o_deg: f64) -> std::path::PathBuf {
    let (w, h, lmax) = (64, 32, 2);
    let l: Vec<[f64; 3]> =
        (0..num_coefficients(lmax)).map(|k| if k == 0 { [2.0, 1.5, 1.0] } else { [0.2, -0.1, 0.05] }).collect();
    let f = analysis::transfer::phong::phong(8.0, lmax);
    let b: Vec<[f64; 3]> = l.iter().enumerate().map(|(k, c)| c.map(|v| v * f[analysis::sh::lm(k).0])).collect();
    let mut rec = Reconstructor::new(lmax);
    let px: Vec<[f64; 3]> = (0..w * h).map(|i| rec.eval(&b, latlong_direction(i / w, i % w, w, h))).collect();
    let mut img = Image { width: w, height: h, ..Default::default() };
    for (ch, n) in ["R", "G", "B"].iter().enumerate() {
        img.channels.insert(n.to_string(), px.iter().map(|p| p[ch] as f32).collect());
    }
    img.attributes.insert(
        "reflect:camera".into(),
        serde_json::json!({"type": "normal-probe", "theta_o_deg": theta_o_deg, "phi_o_deg": phi_o_deg, "jitter": false})
            .to_string(),
    );
    img.attributes.insert("reflect:lighting".into(), serde_json::json!({"type": "sh", "coefficients": l}).to_string());
    img.attributes.insert(
        "reflect:objects".into(),
        r#"[{"shape":"sphere","center":[0,0,0],"radius":1,"brdf":{"type":"phong","ks":1,"s":8,"horizon":"ignore"}}]"#
            .into(),
    );
    let p = dir.join(name);
    write_exr(&p, &img).unwrap();
    p
}

#[test]
fn report_schemas_are_pinned() {
    let dir = std::env::temp_dir().join(format!("reflect-it-report-schema-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = probe(&dir);
    let p = p.to_str().unwrap();

    let a = reflect_json(&["analyze", p, "--lmax", "2", "--json"]);
    assert_documented("analyze", &a);
    assert_schema(
        &a,
        &[
            ("lmax", "number"),
            ("lmax_carried", "number"),
            ("images", "array"),
            ("method", "string"),
            ("param", "string"),
            ("sphere", "object"),
            ("pixels_used", "number"),
            ("pixel_noise", "object|null"),
            ("stderr_source", "string"),
            ("rms_residual", "array|null"),
            ("lm", "array"),
            ("coefficients", "array"),
            ("stderr", "array|null"),
            ("lighting", "object|null"),
            ("filter", "array|null"),
            ("filter_fit", "array|null"),
            ("brdf", "object|null"),
            ("lambda_rho_analytic", "array|null"),
            ("predicted", "array|null"),
            ("verdict", "object|null"),
            ("warnings", "array"),
        ],
        "analyze",
    );
    assert_eq!(a["lm"][5], serde_json::json!([2, -1]));
    let order = &a["filter"][1];
    for k in ["l", "estimate", "stderr_noise", "truncation", "stderr", "amplification", "status"] {
        assert!(order.get(k).is_some(), "analyze.filter[1].{k}: {order}");
    }
    assert_eq!(order["estimate"].as_array().unwrap().len(), 3, "every channel");
    let fit = &a["filter_fit"][0];
    for k in [
        "chi2",
        "dof",
        "chi2_per_dof",
        "robust_chi2_per_dof",
        "p_value",
        "relative_misfit",
        "stderr_scale",
        "fitted_orders",
        "covariance",
    ] {
        assert!(fit.get(k).is_some(), "analyze.filter_fit[0].{k}: {fit}");
    }

    let l = reflect_json(&["invert", "lighting", p, "--lmax", "2", "--json"]);
    assert_documented("invert lighting", &l);
    assert_schema(
        &l,
        &[
            ("command", "string"),
            ("lmax", "number"),
            ("lmax_carried", "number"),
            ("images", "array"),
            ("method", "string"),
            ("brdf", "string"),
            ("lambda_rho", "array"),
            ("albedo", "array"),
            ("max_amplification", "number"),
            ("orders", "array"),
            ("lm", "array"),
            ("coefficients", "array"),
            ("stderr", "array"),
            ("stderr_noise", "array|null"),
            ("truncation", "array|null"),
            ("truncation_bound", "array|null"),
            ("coefficient_amplification", "array|null"),
            ("channel_fits", "array|null"),
            ("pixel_noise", "object|null"),
            ("regularised", "object"),
            ("output", "string|null"),
            ("verdict", "object|null"),
            ("warnings", "array"),
        ],
        "invert lighting",
    );
    assert_eq!(l["lm"].as_array().unwrap().len(), 9);

    let b = reflect_json(&["invert", "brdf", p, "--model", "phong", "--lmax", "2", "--json"]);
    assert_documented("invert brdf", &b);
    assert_schema(
        &b,
        &[
            ("fit", "string"),
            ("channels", "array"),
            ("command", "string"),
            ("lmax", "number"),
            ("lmax_carried", "number"),
            ("images", "array"),
            ("method", "string"),
            ("lighting", "string"),
            ("model", "string"),
            ("parameter", "string"),
            ("estimate", "number"),
            ("interval", "array"),
            ("relative_width", "number|null"),
            ("range", "array"),
            ("scale", "array"),
            ("chi2_min", "number"),
            ("dof", "number"),
            ("weighted_by_stderr", "bool"),
            ("points", "number"),
            ("filter", "array"),
            ("profile", "array"),
            ("filter_fit", "object|null"),
            ("pixel_noise", "object|null"),
            ("verdict", "object|null"),
            ("warnings", "array"),
        ],
        "invert brdf",
    );

    let s0 = probe_at(&dir, "s0.exr", 0.0, 0.0);
    let s1 = probe_at(&dir, "s1.exr", 50.0, 0.0);
    let s2 = probe_at(&dir, "s2.exr", 50.0, 180.0);
    let (s0, s1, s2) = (s0.to_str().unwrap(), s1.to_str().unwrap(), s2.to_str().unwrap());
    let sep = ["invert", "separate", s0, s1, s2, "--kd", "0.5", "--ks", "0.5", "--lmax", "2", "--scan", "--json"];
    let s = reflect_json(&sep);
    assert_documented("invert separate", &s);
    assert_schema(
        &s,
        &[
            ("command", "string"),
            ("lmax", "number"),
            ("lmax_carried", "number"),
            ("lmax_carried_rule", "string"),
            ("channels", "array"),
            ("layout", "string"),
            ("diffuse_view", "object"),
            ("specular_views", "array"),
            ("width", "number"),
            ("height", "number"),
            ("kd", "array"),
            ("ks", "array"),
            ("split_source", "string"),
            ("sigma_source", "string"),
            ("weighted_by_stderr", "bool"),
            ("diffuse", "object"),
            ("coefficients", "array"),
            ("stderr", "array"),
            ("consistency", "object"),
            ("fits", "object"),
            ("scan", "array"),
            ("output", "null"),
        ],
        "invert separate",
    );
    assert_eq!(s["coefficients"].as_array().unwrap().len(), 9);
    assert_eq!(s["coefficients"][4].as_array().unwrap().len(), 3, "an [r, g, b] triple per coefficient");
    let c = &s["consistency"];
    for k in ["d", "stderr", "chi2", "dof", "p_value", "consistent", "threshold_p", "meaning", "nine_term_residual"] {
        assert!(c.get(k).is_some(), "invert separate.consistency.{k}: {c}");
    }
    // One channel: numbers instead of triples.
    let one = reflect_json(&[&sep[..sep.len() - 2], &["--channel", "g", "--json"]].concat());
    assert!(one["coefficients"][4].is_number() && one["kd"].is_number(), "{}", one["coefficients"]);
    assert!(one["consistency"]["meaning"].is_string());

    // invert factor: the four nodes of the 1 × 4 rule (θ_o = 60°, φ_o = 0, 90, 180, 270).
    let nodes: Vec<String> = (0..4)
        .map(|k| probe_at(&dir, &format!("n{k}.exr"), 60.0, 90.0 * k as f64).to_str().unwrap().to_string())
        .collect();
    let mut args: Vec<&str> = vec!["invert", "factor"];
    args.extend(nodes.iter().map(String::as_str));
    args.extend(["--normal", s0, "--lmax", "1", "--json"]);
    let f = reflect_json(&args);
    assert_documented("invert factor", &f);
    assert_schema(
        &f,
        &[
            ("command", "string"),
            ("mode", "string"),
            ("input", "object"),
            ("nodes", "array"),
            ("grid", "array"),
            ("rule", "string"),
            ("channel", "string"),
            ("lmax", "number"),
            ("lmax_carried", "number"),
            ("lmax_carried_rule", "string"),
            ("max_amplification", "number"),
            ("renders", "null"),
            ("max_stderr", "null"),
            ("orders", "array"),
            ("lighting", "array"),
            ("gauge_l00", "number"),
            ("source", "object|null"),
            ("source_note", "string"),
            ("albedo_profile", "array"),
            ("filter", "object"),
            ("warnings", "array"),
        ],
        "invert factor",
    );
    assert_eq!(f["input"]["images"].as_array().unwrap().len(), 4);
    for k in ["l", "kappa", "kappa_ratio", "gain", "amplification", "status"] {
        assert!(f["orders"][1].get(k).is_some(), "invert factor.orders[1].{k}");
    }
    let n = reflect_json(&["invert", "factor", "--print-nodes", "2x3", "--json"]);
    assert_documented("invert factor", &n);
    assert_schema(
        &n,
        &[("command", "string"), ("nodes", "array"), ("outgoing", "array")],
        "invert factor --print-nodes",
    );
    assert_eq!(n["outgoing"].as_array().unwrap().len(), 6);
}
