//! Pins the JSON schema (every key path and the JSON type at it) of each command's `--json`
//! document: `render`, `sh project`, `sh transfer`, `verify` and `compare`. These documents are the typed
//! report structs (`RenderReport`, `ProjectReport`, `TransferReport`, `verify::report::Report`)
//! serialized; a renamed, removed, added or retyped field fails here and must be a deliberate
//! change of this list (and of the guide / the Python package that read them).

mod common;

use common::json::{assert_documented, kind, reflect_json as run};
use serde_json::Value;
use std::collections::BTreeSet;

/// "path: type" for every node; array elements are merged under `path[]`.
fn schema(v: &Value, path: &str, out: &mut BTreeSet<String>) {
    out.insert(format!("{path}: {}", kind(v)));
    match v {
        Value::Object(m) => m.iter().for_each(|(k, x)| schema(x, &format!("{path}.{k}"), out)),
        Value::Array(a) => a.iter().for_each(|x| schema(x, &format!("{path}[]"), out)),
        _ => {}
    }
}

fn assert_schema(doc: &Value, expected: &[&str]) {
    let mut got = BTreeSet::new();
    schema(doc, "", &mut got);
    let want: BTreeSet<String> = expected.iter().map(|s| s.to_string()).collect();
    let missing: Vec<_> = want.difference(&got).collect();
    let extra: Vec<_> = got.difference(&want).collect();
    assert!(missing.is_empty() && extra.is_empty(), "schema changed: missing {missing:#?}, new {extra:#?}");
}

#[test]
fn sh_transfer_schema() {
    let doc = run(&["sh", "transfer", "--brdf", "torrance-sparrow", "--sigma", "0.1", "--lmax", "3", "--json"]);
    assert_documented("sh transfer", &doc);
    assert_schema(
        &doc,
        &[
            ": object",
            ".brdf: string",
            ".lmax: number",
            ".s: null",
            ".sigma: number",
            ".theta_o_deg: null",
            ".method: string",
            ".lambda_rho: array",
            ".lambda_rho[]: number",
            ".approximation: object",
            ".approximation.equation: string",
            ".approximation.lambda_rho: array",
            ".approximation.lambda_rho[]: number",
        ],
    );
    assert_eq!(doc["lambda_rho"].as_array().unwrap().len(), 4);
    // Without an approximation (mirror), the key is null rather than absent.
    let doc = run(&["sh", "transfer", "--brdf", "mirror", "--lmax", "2", "--json"]);
    assert!(doc["approximation"].is_null() && doc["s"].is_null(), "{doc}");
}

#[test]
fn sh_project_schema() {
    let g = common::grace();
    let doc = run(&["sh", "project", g.to_str().unwrap(), "--lmax", "1", "--json"]);
    assert_documented("sh project", &doc);
    assert_schema(
        &doc,
        &[
            ": object",
            ".file: string",
            ".mapping: string",
            ".width: number",
            ".height: number",
            ".lmax: number",
            ".integration: string",
            ".coefficients: array",
            ".coefficients[]: array",
            ".coefficients[][]: number",
        ],
    );
    assert_eq!(doc["coefficients"].as_array().unwrap().len(), 4);
    assert_eq!(doc["mapping"], "angular");
}

/// The keys of every `render --json` document (`progressive` is null or an object).
const RENDER_KEYS: &[&str] = &[
    ": object",
    ".scene: string",
    ".output: string",
    ".png: null",
    ".width: number",
    ".height: number",
    ".spp: number",
    ".seed: number",
    ".threads: number",
    ".samples: number",
    ".samples_per_sec: number",
    ".rays: number",
    ".rays_per_sec: number",
    ".load_seconds: number",
    ".load_phases: object",
    ".load_phases.parse_seconds: number",
    ".load_phases.meshes_seconds: number",
    ".load_phases.bvh_seconds: number",
    ".load_phases.lighting_read_seconds: number",
    ".load_phases.lighting_tables_seconds: number",
    ".render_seconds: number",
    ".save_seconds: number",
    ".total_seconds: number",
    ".peak_rss_mb: number",
    ".noise: object",
    ".noise.pixels: number",
    ".noise.black: number",
    ".noise.median: number",
    ".noise.p95: number",
    ".unreliable_pixels: number",
];

#[test]
fn render_schema() {
    let dir = common::temp_dir("json-schema-render");
    let scene = dir.join("s.toml");
    std::fs::write(
        &scene,
        "[render]\nwidth = 8\nheight = 8\nspp = 2\n[camera]\ntype = \"orthographic\"\nfrom = [0.0, 0.0, 5.0]\n\
         to = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0]\nextent = 2.5\n[lighting]\ntype = \"uniform\"\nradiance = 1.0\n\
         [[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nbrdf = { type = \"lambert\", albedo = 0.5 }\n",
    )
    .unwrap();
    let out = dir.join("s.exr");
    let doc = run(&["render", scene.to_str().unwrap(), "--out", out.to_str().unwrap(), "--json", "--quiet"]);
    assert_documented("render", &doc);
    let mut want: Vec<&str> = RENDER_KEYS.to_vec();
    want.push(".progressive: null");
    assert_schema(&doc, &want);
    assert_eq!(doc["samples"], 8 * 8 * 2);
    // A render to a target error: `spp` is the spp reached, `progressive` says how it went.
    let doc = run(&[
        "render",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--spp",
        "64",
        "--size",
        "16x16",
        "--target-rel-error",
        "1e-9",
        "--json",
        "--quiet",
    ]);
    let mut want: Vec<&str> = RENDER_KEYS.to_vec();
    want.extend([
        ".progressive: object",
        ".progressive.target_rel_error: number",
        ".progressive.time_limit_seconds: null",
        ".progressive.spp_cap: number",
        ".progressive.passes: number",
        ".progressive.stopped_by: string",
        ".progressive.target_reached: bool",
        ".progressive.rel_error_p95: number",
        ".progressive.rel_error_unknown: null",
    ]);
    assert_schema(&doc, &want);
    // Passes of 1, 1, 2, 4, …, 32 spp: 7 to reach the cap of 64, never the target of 1e-9. (At 16²,
    // 1 of the 45 object pixels is flagged, so the 95th percentile is finite: a number.)
    assert_eq!((doc["spp"].as_u64(), doc["samples"].as_u64()), (Some(64), Some(16 * 16 * 64)), "{doc}");
    let p = &doc["progressive"];
    assert_eq!((p["spp_cap"].as_u64(), p["passes"].as_u64()), (Some(64), Some(7)), "{doc}");
    assert_eq!((p["stopped_by"].as_str(), p["target_reached"].as_bool()), (Some("spp-cap"), Some(false)), "{doc}");
    // With a PNG preview, `png` is an object.
    let png = dir.join("s.png");
    let doc = run(&[
        "render",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
        "--json",
        "--quiet",
    ]);
    assert!(doc["png"]["exposure_ev"].is_number() && doc["png"]["automatic"] == true, "{doc}");
}

#[test]
fn verify_schema() {
    let dir = common::temp_dir("json-schema-verify");
    let doc = run(&["verify", "--quick", "--check", "mirror", "--json", "--out", dir.to_str().unwrap()]);
    assert_documented("verify", &doc);
    assert_schema(
        &doc,
        &[
            ": object",
            ".passed: bool",
            ".quick: bool",
            ".k_sigma: number",
            ".seconds: number",
            ".checks: array",
            ".checks[]: object",
            ".checks[].name: string",
            ".checks[].equation: string",
            ".checks[].description: string",
            ".checks[].passed: bool",
            ".checks[].measured: array",
            ".checks[].measured[]: number",
            ".checks[].expected: array",
            ".checks[].expected[]: number",
            ".checks[].tolerance: array",
            ".checks[].tolerance[]: number",
            ".checks[].sigma: array",
            ".checks[].sigma[]: number",
            ".checks[].labels: array",
            ".checks[].labels[]: string",
            ".checks[].k_sigma: number",
            ".checks[].rows: array",
            ".checks[].rows[]: object",
            ".checks[].rows[].label: string",
            ".checks[].rows[].expected: number",
            ".checks[].rows[].measured: number",
            ".checks[].rows[].sigma: number",
            ".checks[].rows[].approx: number",
            ".checks[].rows[].floor: number",
            ".checks[].rows[].tolerance: number",
            ".checks[].rows[].passed: bool",
            ".checks[].rows[].informative: bool",
            ".checks[].rows[].outside_range: null",
            ".checks[].details: array",
            ".checks[].details[]: string",
            ".checks[].plots: array",
            ".checks[].plots[]: string",
            ".checks[].pictures: array",
            ".checks[].pictures[]: object",
            ".checks[].pictures[].title: string",
            ".checks[].pictures[].model: string",
            ".checks[].pictures[].width: number",
            ".checks[].pictures[].height: number",
            ".checks[].pictures[].measured_png: string",
            ".checks[].pictures[].predicted_png: string",
            ".checks[].pictures[].z_png: string",
            ".checks[].pictures[].black: number",
            ".checks[].pictures[].white: number",
            ".checks[].pictures[].z: object",
            ".checks[].pictures[].z.pixels: number",
            ".checks[].pictures[].z.mean: number",
            ".checks[].pictures[].z.rms: number",
            ".checks[].pictures[].z.max_abs: number",
            ".checks[].pictures[].z.frac_above_3: number",
            ".checks[].error: null",
            ".checks[].errored: bool",
            ".checks[].seconds: number",
            ".checks[].stderr_flagged_pixels: number",
            ".checks[].stderr_pooled_pixels: number",
        ],
    );
    // The pictures the JSON lists are in the report folder, and the report links them.
    let pic = &doc["checks"][0]["pictures"][0];
    for key in ["measured_png", "predicted_png", "z_png"] {
        let f = dir.join(pic[key].as_str().unwrap());
        assert!(std::fs::metadata(&f).map(|m| m.len() > 100).unwrap_or(false), "{} missing", f.display());
    }
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert!(html.contains(pic["z_png"].as_str().unwrap()) && html.contains("class=\"summary\""));
}

#[test]
fn compare_schema() {
    // Two seeds of a small Lambert sphere under SH lighting (no data files), independent sampler.
    let dir = common::temp_dir("schema-compare");
    let scene = |seed: u64| {
        format!(
            "[render]\nwidth = 24\nheight = 24\nspp = 16\nseed = {seed}\nmax_depth = 1\nsampler = \"independent\"\n\
             [camera]\ntype = \"orthographic\"\nfrom = [3.0, 0.0, 1.0]\nto = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nextent = 1.05\n\
             [lighting]\ntype = \"sh\"\ncoefficients = [[1.0, 0.9, 0.8], [0.1, 0.0, -0.1], [0.3, 0.2, 0.1], [0.0, 0.05, 0.0]]\n\
             [[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nbrdf = {{ type = \"lambert\", albedo = [0.8, 0.7, 0.6] }}\n"
        )
    };
    let a = common::render_to(&dir, "a.exr", &scene(1));
    let b = common::render_to(&dir, "b.exr", &scene(2));
    let (code, out, err) = common::reflect_out(&["compare", &a, &b, "--json"]);
    assert!(code == 0 || code == 1, "{err}");
    let doc: Value = serde_json::from_str(&out).unwrap();
    assert_documented("compare", &doc);
    assert!(doc["verdict"] == "agree" || doc["verdict"] == "disagree", "{doc}");
    assert_schema(
        &doc,
        &[
            ".a.images: number",
            ".a.noise: string",
            ".a: object",
            ".alpha: number",
            ".alpha_per_test: number",
            ".b.images: number",
            ".b.noise: string",
            ".b: object",
            ".blocks.chi2: number",
            ".blocks.chi2_nu: number",
            ".blocks.chi2_nu_scale_removed: number",
            ".blocks.count: number",
            ".blocks.max_abs_z: number",
            ".blocks.nu: number",
            ".blocks.size: number",
            ".blocks: object",
            ".edges.chi2_nu: number",
            ".edges.interior_chi2_nu: number",
            ".edges.pixels: number",
            ".edges: object",
            ".curvature: array",
            ".curvature[]: object",
            ".curvature[].c: number",
            ".curvature[].channel: string",
            ".curvature[].explained: number",
            ".curvature[].pixels: number",
            ".curvature[].stderr: number",
            ".curvature[].z: number",
            ".height: number",
            ".histogram.above: number",
            ".histogram.below: number",
            ".histogram.counts: array",
            ".histogram.counts[]: number",
            ".histogram.edges: array",
            ".histogram.edges[]: number",
            ".histogram.expected: array",
            ".histogram.expected[]: number",
            ".histogram: object",
            ".pixels.beyond_k_family: number",
            ".pixels.chi2: number",
            ".pixels.chi2_nu: number",
            ".pixels.compared: number",
            ".pixels.exact: number",
            ".pixels.exact_differing: number",
            ".pixels.flagged: number",
            ".pixels.k_family: number",
            ".pixels.max_abs_z: number",
            ".pixels.max_column: number",
            ".pixels.max_row: number",
            ".pixels.near_edges: number",
            ".pixels.background: number",
            ".pixels.no_estimate: number",
            ".pixels.nu: number",
            ".pixels: object",
            ".reason: string",
            ".scale: array",
            ".scale[].channel: string",
            ".scale[].dof: number",
            ".scale[].ratio: number",
            ".scale[].stderr: number",
            ".scale[].z: number",
            ".scale[]: object",
            ".tests: array",
            ".tests[].dof: number",
            ".tests[].name: string",
            ".tests[].p: number",
            ".tests[].rejected: bool",
            ".tests[].statistic: number",
            ".tests[]: object",
            ".verdict: string",
            ".warnings: array",
            ".warnings[]: string",
            ".width: number",
            ": object",
        ],
    );
}
