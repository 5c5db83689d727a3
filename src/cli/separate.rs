//! `reflect invert separate DIFFUSE.exr SPECULAR.exr… [--kd X --ks Y] [--lmax L] [--channel r|g|b]
//! [--scan] [--output ENV.exr --width W] [--json]`: diffuse + specular separation (sec. 3.5, the
//! algorithm of reference \[17\]; library `analysis::inverse::separation`).
//!
//! The surface is ρ̂ = k_d · lambert (unit albedo) + k_s · mirror (unit k_r). The inputs are
//! `normal-probe` renders of it (docs/src/conventions.md §6; with the `reflect:camera` header, or another
//! renderer's described by `--theta-o/--phi-o` per image or a `--scene` sidecar, as in every analysis
//! command, [`super::header::load`]): the *diffuse
//! view* first, at normal exitance θ_o = 0 (R = n), which gives the 9 low-order lighting
//! coefficients L̂_lm = B_lm / (k_d Λ_l ρ̂_l + k_s), l ≤ 2; then one or more *specular views* at
//! θ_o > 0 and φ_o ∈ {0°, 180°} (R ≠ n; the two azimuths together cover the sphere of R), from
//! which the 9-term diffuse part (eq. 38–39) is subtracted and the rest fitted as a gazing sphere:
//! the lighting L_lm, l ≤ `lmax`, by least squares weighted by the pixels' exact solid angles about
//! R (`probe_samples`). The consistency d_lm = L̂_lm − c_lm (l ≤ 2) with its χ² (9 dof) tests the
//! split and the 9-term approximation; `--scan` scans the diffuse fraction k_d / (k_d + k_s) at
//! fixed k_d + k_s for the χ² minimum (how \[17\] fixes the split).
//!
//! Parameters: `--kd`, `--ks` (one number or r,g,b; default: the header's BRDF when it is a `mix`
//! of one `lambert` and one `mirror` layer, k_d = weight × albedo, k_s = weight × k_r; else the
//! `--scene` sidecar's), `--lmax`
//! (default 8, at most [`analysis::separate::MAX_LMAX`] and 2(lmax + 1) ≤ H), `--channel` (default all three; JSON
//! coefficients are then `[r, g, b]` triples, else numbers of the one channel), `--scan`,
//! `--output` (the recovered lighting as a W × W/2 lat-long EXR, reconstructed from its SH, one
//! channel replicated to R, G, B) and `--width`, `--json`.
//! Standard errors come from the renders' `stderr.R/G/B` layers; without them (another renderer's
//! images) the noise is estimated from the residuals, as `analyze` and `invert` do: the residual
//! variance σ̂² = Σ_p r_p²/ν of the diffuse view's fit (SH up to `lmax` at n) for its pixels and of
//! the specular views' fit (SH up to `lmax` at R plus the harmonics 1 ≤ l ≤ 2 at n, so whatever the
//! split) for theirs (stated in the output). Both fits are reported with their χ²/ν and p-value
//! when the layers give σ (`fits`); their views cover the whole sphere of the fitted directions, so
//! orders above `lmax` bias no coefficient (up to the grid's aliasing) and no truncation term is
//! added: their power is in the residuals. The output also predicts the 9-term residual's share of d from the recovered
//! lighting's orders 3…lmax (fitted at R as in the algorithm) and gives the χ² with it removed,
//! so that a large χ² at the right split can be told apart from a wrong split.

//!
//! The separation itself is the library's ([`analysis::separate`]); this command turns its flags
//! into [`SeparateParams`], reads and observes the images, prints the report and writes the map.

use super::Error;
use super::args::{Channel, ImageArgs};
use super::outputs::{Files, Format};
use analysis::image::write_exr;
use analysis::separate::{InvertSeparateReport, SeparateParams};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args, Debug)]
pub struct SeparateArgs {
    /// normal-probe renders (OpenEXR): the diffuse view at θ_o = 0 first, then specular views at
    /// θ_o > 0 and φ_o = 0 or 180 (both azimuths together cover the sphere).
    #[arg(required = true)]
    pub images: Vec<PathBuf>,
    /// Weight k_d of the unit-albedo lambert part (one number, or r,g,b; default: the header's mix).
    #[arg(long, value_parser = super::flags::parse_rgb)]
    pub kd: Option<[f64; 3]>,
    /// Weight k_s of the unit mirror part (one number, or r,g,b; default: the header's mix).
    #[arg(long, value_parser = super::flags::parse_rgb)]
    pub ks: Option<[f64; 3]>,
    /// Highest SH order of the recovered lighting.
    #[arg(long, default_value_t = 8, value_parser = super::flags::parse_lmax, allow_hyphen_values = true)]
    pub lmax: usize,
    /// Analyse only this channel (default: all three).
    #[arg(long, value_enum)]
    pub channel: Option<Channel>,
    /// Scan the diffuse fraction k_d/(k_d+k_s) at fixed k_d + k_s for the consistency χ² minimum.
    #[arg(long)]
    pub scan: bool,
    /// Write the recovered lighting as a lat-long EXR.
    #[arg(long)]
    pub output: Option<PathBuf>,
    /// Width of the --output map (height = width / 2).
    #[arg(long, default_value_t = 256, value_parser = super::flags::parse_width, allow_hyphen_values = true)]
    pub width: usize,
    /// Print one JSON document to stdout.
    #[arg(long)]
    pub json: bool,
    /// How images without a reflect:camera header are described: --theta-o/--phi-o per image, or a
    /// sidecar --scene whose normal-probe camera and mix BRDF they are renders of; --layer.
    #[command(flatten)]
    pub view: ImageArgs,
}

pub fn run(a: &SeparateArgs) -> Result<ExitCode, Error> {
    let r = separate_report(a)?;
    if a.json {
        println!("{}", serde_json::to_string(&r).map_err(|e| Error::new(format!("JSON output: {e}")))?);
    } else {
        print!("{r}");
    }
    Ok(ExitCode::SUCCESS)
}

/// The separation of `a.images` (see the module docs): the report `--json` prints, the `--output`
/// map written once everything is computed, so that a failure leaves no partial output. Errors: bad
/// input (named file and problem), or a separation the views cannot solve.
pub fn separate_report(a: &SeparateArgs) -> Result<InvertSeparateReport, Error> {
    if let Some(out) = &a.output {
        let files = Files::new().inputs("the image", &a.images).inputs("the scene", &a.view.scene);
        files.output("--output", out, Format::Exr).check()?;
    }
    let params = SeparateParams {
        kd: a.kd,
        ks: a.ks,
        lmax: a.lmax,
        channel: a.channel.map(Channel::index),
        scan: a.scan,
        map: a.output.clone().map(|p| (p, a.width)),
        spelling: analysis::observation::Spelling::Flags,
    };
    analysis::separate::validate(&params, a.images.len())?;
    let (images, observed) = super::header::load(&a.images, &a.view.view(), "separated")?;
    let r = analysis::separate::separate(&params, &images, &a.images, &observed)?;
    if let Some(out) = &a.output {
        write_exr(out, &r.lighting_map(a.width))?;
    }
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use analysis::image::{Image, read_image};
    use analysis::inverse::separation::{LOW, probe_samples};
    use analysis::sh::{lm, num_coefficients};
    use serde_json::Value;
    use std::path::Path;

    const CHANNELS: [&str; 3] = ["R", "G", "B"];
    use analysis::sh::ShBasis;
    use renderer::sampling::chi2::TestRng;
    use serde_json::json;

    fn tmp(name: &str) -> PathBuf {
        crate::cli::test_path("separate", name)
    }

    /// The report as the JSON document `--json` prints.
    fn separate_doc(a: &SeparateArgs) -> Result<Value, Error> {
        separate_report(a).map(|r| serde_json::to_value(r).unwrap())
    }

    const MIX: &str = r#"{"type":"mix","layers":[{"weight":0.5,"brdf":{"type":"lambert","albedo":1.0}},{"weight":0.5,"brdf":{"type":"mirror"}}]}"#;
    /// Per-channel scale of the synthetic lighting (so R, G, B differ).
    const TINT: [f64; 3] = [1.0, 0.8, 0.5];

    /// A lighting with orders 0–3 and 5 only: Lambert's Λ_l ρ̂_l vanishes at odd l ≥ 3 (eq. 38),
    /// so the 9-term diffuse part is the whole diffuse part and the separation has no 9-term bias.
    /// Orders 1–2 get a lighting-like strength (up to ≈ 0.5 L_00) so that the split shows.
    fn light() -> Vec<f64> {
        (0..num_coefficients(5))
            .map(|k| {
                let (l, m) = lm(k);
                let v = (((7 * k + 3 * (m + 8) as usize) % 13) as f64 / 13.0 - 0.4) / (1.0 + l as f64);
                match l {
                    0 => 2.0,
                    1 | 2 => 4.0 * v,
                    3 | 5 => 0.4 * v,
                    _ => 0.0,
                }
            })
            .collect()
    }

    /// A synthetic normal-probe render (W × H, pixel centres) of k_d·lambert + k_s·mirror under
    /// `light` × TINT at exitance (θ_o, φ_o ∈ {0°, 180°}), Gaussian noise σ per pixel (seeded) and
    /// a stderr layer σ unless `stderr` is false.
    #[allow(clippy::too_many_arguments)]
    fn render(
        path: &Path,
        light: &[f64],
        kd: f64,
        ks: f64,
        theta_o_deg: f64,
        phi_o_deg: f64,
        (w, h): (usize, usize),
        sigma: f64,
        seed: u64,
        stderr: bool,
        brdf: &str,
    ) {
        let lmax = analysis::sh::lmax_of(light.len()).unwrap();
        let basis = ShBasis::new(lmax);
        let f = analysis::transfer::lambert::lambert(lmax);
        let geo =
            probe_samples(&vec![0.0; w * h], &vec![0.0; w * h], w, h, theta_o_deg.to_radians(), phi_o_deg == 180.0);
        let mut y = vec![0.0; light.len()];
        let mut rng = TestRng::new(seed);
        let mut gauss = || {
            // Box–Muller.
            let mut u = || (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
            let (u1, u2) = (u().max(1e-300), u());
            (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
        };
        let mut img = Image { width: w, height: h, ..Default::default() };
        let mut px = vec![[0f32; 3]; w * h];
        for (i, p) in px.iter_mut().enumerate() {
            basis.eval_into(geo.normal[i], &mut y);
            let d: f64 = (0..light.len()).map(|k| f[lm(k).0] * light[k] * y[k]).sum();
            basis.eval_into(geo.reflected[i], &mut y);
            let g: f64 = (0..light.len()).map(|k| light[k] * y[k]).sum();
            for ch in 0..3 {
                p[ch] = (TINT[ch] * (kd * d + ks * g) + sigma * gauss()) as f32;
            }
        }
        for (ch, n) in CHANNELS.iter().enumerate() {
            img.channels.insert(n.to_string(), px.iter().map(|p| p[ch]).collect());
            if stderr {
                img.channels.insert(format!("stderr.{n}"), vec![sigma as f32; w * h]);
            }
        }
        img.attributes.insert(
            "reflect:camera".into(),
            json!({"type": "normal-probe", "theta_o_deg": theta_o_deg, "phi_o_deg": phi_o_deg}).to_string(),
        );
        img.attributes.insert(
            "reflect:objects".into(),
            format!(r#"[{{"shape":"sphere","center":[0,0,0],"radius":1,"brdf":{brdf}}}]"#),
        );
        write_exr(path, &img).unwrap();
    }

    const SIZE: (usize, usize) = (256, 128);
    const SIGMA: f64 = 0.05;

    /// The three views of the example scenes (0°; 50° at φ_o 0° and 180°), true split 0.5 : 0.5.
    fn views(tag: &str) -> Vec<PathBuf> {
        let lt = light();
        [(0.0, 0.0), (50.0, 0.0), (50.0, 180.0)]
            .iter()
            .enumerate()
            .map(|(i, &(t, p))| {
                let path = tmp(&format!("{tag}-{i}.exr"));
                render(&path, &lt, 0.5, 0.5, t, p, SIZE, SIGMA, 11 + i as u64, true, MIX);
                path
            })
            .collect()
    }

    fn args(images: Vec<PathBuf>) -> SeparateArgs {
        SeparateArgs {
            images,
            kd: None,
            ks: None,
            lmax: 5,
            channel: None,
            scan: false,
            output: None,
            width: 64,
            json: true,
            view: ImageArgs::default(),
        }
    }

    fn f(v: &Value) -> f64 {
        v.as_f64().unwrap_or(f64::NAN)
    }

    #[test]
    fn recovers_band_limited_lighting_and_flags_a_wrong_split() {
        let lt = light();
        let mut a = args(views("known"));
        a.scan = true;
        a.output = Some(tmp("known-env.exr"));
        let doc = separate_doc(&a).unwrap();
        assert_eq!(doc["split_source"], "the first image's header (mix of lambert and mirror)");
        assert_eq!(doc["weighted_by_stderr"], true);
        // Tolerance: 4σ (σ propagated from the stderr layers, validated against the spread of
        // repeated draws in analysis::inverse::separation's tests) + the bias of the diffuse view's
        // lat-long midpoint quadrature. The lighting has no 9-term residual (no even order ≥ 4) and
        // the least squares at R is exact for a lighting inside its span (l ≤ 5), so that
        // quadrature is the only bias: O((π (L+2)/H)²/24) ≈ 1.2e-4 (L + 2 = 7: the degree of
        // Y_lm × B, l ≤ 2; H = 128) of the largest coefficient (≈ 2 × tint), amplified by at most
        // 1 + k_d/k_s · |H F| ≈ 2 in c: bias allowance 2.5e-4 × |L_00|. Measured on noise-free
        // images: worst 2.1e-5 (at (1, 0), R); with noise the worst error is 0.7σ.
        // Able to fail: the wrong split below moves c_lm by ≫ this.
        for ch in 0..3 {
            let bias = 2.5e-4 * TINT[ch] * lt[0];
            for k in 0..lt.len() {
                let (got, se) = (f(&doc["coefficients"][k][ch]), f(&doc["stderr"][k][ch]));
                let want = TINT[ch] * lt[k];
                assert!((got - want).abs() <= 4.0 * se + bias, "ch {ch} k {k}: {got} vs {want} (σ {se})");
                assert!(se > 0.0 && se < 0.01, "σ {se}");
            }
            for k in 0..LOW {
                let (got, se) = (f(&doc["diffuse"]["coefficients"][k][ch]), f(&doc["diffuse"]["stderr"][k][ch]));
                assert!((got - TINT[ch] * lt[k]).abs() <= 4.0 * se + bias, "diffuse ch {ch} k {k}");
            }
            // At the true split the consistency χ² follows χ²_9: P(χ²_9 > 33.7) = 1e-4.
            let chi2 = f(&doc["consistency"]["chi2"][ch]);
            assert!(chi2 < 33.7, "ch {ch}: χ² {chi2}");
            assert_eq!(doc["consistency"]["consistent"][ch], true);
            // No even order ≥ 4 in the lighting: the predicted 9-term share of d is only what the
            // noise in the recovered l = 4 coefficients (σ ≈ 1e-3, × |Λ_4 ρ̂_4| = 1/24) makes of it.
            for k in 0..LOW {
                let r = f(&doc["consistency"]["nine_term_residual"]["d"][k][ch]);
                assert!(r.abs() < 0.25 * f(&doc["consistency"]["stderr"][k][ch]), "ch {ch} k {k}: {r}");
            }
            // The scan's minimum is at the true fraction (one coarse step).
            let best = f(&doc["scan"][ch]["best_fraction"]);
            assert!((best - 0.5).abs() <= 0.01, "ch {ch}: scan minimum {best}");
        }
        // The map is the recovered lighting reconstructed from SH: check a few pixels (f32 rounding).
        let env = read_image(tmp("known-env.exr")).unwrap();
        assert_eq!((env.width, env.height), (64, 32));
        let mut rec = analysis::sh::Reconstructor::new(5);
        let c: Vec<[f64; 3]> = (0..lt.len()).map(|k| [0, 1, 2].map(|ch| f(&doc["coefficients"][k][ch]))).collect();
        for (r, col) in [(0, 0), (7, 40), (31, 63)] {
            let want = rec.eval(&c, analysis::sh::latlong_direction(r, col, 64, 32));
            for (ch, n) in CHANNELS.iter().enumerate() {
                let got = env.channel(n).unwrap()[r * 64 + col] as f64;
                assert!((got - want[ch]).abs() < 1e-5 * (1.0 + want[ch].abs()), "{n} ({r},{col})");
            }
        }
        // A wrong split (0.6 : 0.4 instead of 0.5 : 0.5): χ²_9 > 100 has probability ≈ 1e-16 for a
        // consistent split. One channel: the coefficients are then numbers. The split by flags
        // contradicts the header's mix (an error naming both), so it is given for the same pixels
        // without a header (another renderer's files: angles by flags).
        let mut wrong = args(a.images.clone());
        wrong.kd = Some([0.6; 3]);
        wrong.ks = Some([0.4; 3]);
        wrong.channel = Some(Channel::G);
        let e = separate_doc(&wrong).unwrap_err().to_string();
        assert!(e.contains("--kd 0.6,0.6,0.6") && e.contains("k_d = 0.5,0.5,0.5") && e.contains("contradict"), "{e}");
        wrong.images =
            a.images.iter().enumerate().map(|(i, p)| foreign_copy(p, &format!("known-foreign-{i}.exr"))).collect();
        wrong.view.theta_o = vec![0.0, 50.0, 50.0];
        wrong.view.phi_o = vec![0.0, 0.0, 180.0];
        wrong.view.layer = Some("ViewLayer.Combined".into());
        let w = separate_doc(&wrong).unwrap();
        assert_eq!(w["split_source"], "command line");
        assert!(w["coefficients"][0].is_number() && w["channels"] == json!(["G"]));
        let chi2 = f(&w["consistency"]["chi2"]);
        assert!(chi2 > 100.0, "wrong split: χ² {chi2}");
        assert_eq!(w["consistency"]["consistent"], false);
        assert!(w["consistency"]["meaning"].as_str().unwrap().starts_with("inconsistent"));
    }

    /// `path` rewritten as another renderer writes it: no `reflect:` attribute, RGB(+stderr) under
    /// a Blender-style layer prefix, beside a depth AOV.
    fn foreign_copy(path: &Path, name: &str) -> PathBuf {
        let img = read_image(path).unwrap();
        let mut out = Image { width: img.width, height: img.height, ..Default::default() };
        for (n, data) in &img.channels {
            let n = if n.starts_with("stderr") { n.clone() } else { format!("ViewLayer.Combined.{n}") };
            out.channels.insert(n, data.clone());
        }
        out.channels.insert("ViewLayer.Depth.Z".into(), vec![1.0; img.width * img.height]);
        let p = tmp(name);
        write_exr(&p, &out).unwrap();
        p
    }

    #[test]
    fn headerless_views_described_by_flags_or_sidecar_separate_as_the_originals() {
        let ours = views("ours");
        let want = separate_doc(&args(ours.clone())).unwrap();
        let foreign: Vec<PathBuf> =
            ours.iter().enumerate().map(|(i, p)| foreign_copy(p, &format!("foreign-{i}.exr"))).collect();
        // By flags: the angles per image, the split by --kd/--ks, the layer by --layer.
        let mut a = args(foreign.clone());
        a.view.theta_o = vec![0.0, 50.0, 50.0];
        a.view.phi_o = vec![0.0, 0.0, 180.0];
        a.view.layer = Some("ViewLayer.Combined".into());
        a.kd = Some([0.5; 3]);
        a.ks = Some([0.5; 3]);
        let by_flags = separate_doc(&a).unwrap();
        // By a sidecar: its mix BRDF gives the split, its normal-probe camera the angles' default.
        let scene = tmp("sidecar.toml");
        std::fs::write(
            &scene,
            format!(
                "[render]\nwidth = {}\nheight = {}\n[camera]\ntype = \"normal-probe\"\n[lighting]\ntype = \"uniform\"\nradiance = 1.0\n\
                 [[objects]]\nshape = \"sphere\"\nbrdf = {}\n",
                SIZE.0,
                SIZE.1,
                r#"{ type = "mix", layers = [{ weight = 0.5, brdf = { type = "lambert", albedo = 1.0 } }, { weight = 0.5, brdf = { type = "mirror" } }] }"#
            ),
        )
        .unwrap();
        let mut b = args(foreign.clone());
        b.view.theta_o = vec![0.0, 50.0, 50.0];
        b.view.phi_o = vec![0.0, 0.0, 180.0];
        b.view.layer = Some("ViewLayer.Combined".into());
        b.view.scene = Some(scene.clone());
        let by_scene = separate_doc(&b).unwrap();
        assert!(by_scene["split_source"].as_str().unwrap().contains("sidecar.toml"), "{}", by_scene["split_source"]);
        for doc in [&by_flags, &by_scene] {
            for key in ["coefficients", "stderr", "diffuse", "consistency", "kd", "ks"] {
                assert_eq!(doc[key], want[key], "{key}");
            }
        }
        // Contradictions name both sides; orthographic-only flags are refused by name.
        let mut c = args(ours.clone());
        c.view.theta_o = vec![0.0, 40.0, 50.0];
        let e = separate_doc(&c).unwrap_err().to_string();
        assert!(
            e.contains("--theta-o/--phi-o give") && e.contains("reflect:camera") && e.contains("contradict"),
            "{e}"
        );
        let mut d = args(foreign.clone());
        d.view.layer = Some("ViewLayer.Combined".into());
        let e = separate_doc(&d).unwrap_err().to_string();
        assert!(e.contains("no reflect:camera") && e.contains("--theta-o"), "{e}");
    }

    /// Without stderr layers the noise is the residual variance of each side's fit (issue 14): on
    /// band-limited views (no truncation at lmax 5) with noise σ = 0.05, the bars are those the
    /// stderr layers give within 7 % (σ̂/σ has standard error 1/√(2ν) ≤ 1.6 % here, ν ≥ 2012:
    /// 4.4 se), said in the output. With the layers each fit's χ²/ν is within 4·√(2/ν) of 1. The
    /// planted error is the old σ = 1 per pixel: bars 20× too wide.
    #[test]
    fn without_stderr_layers_sigma_is_the_residual_variance_and_said_so() {
        let lt = light();
        let mut docs = vec![];
        for stderr in [true, false] {
            let mut images = vec![];
            for (i, (t, p)) in [(0.0, 0.0), (40.0, 0.0), (40.0, 180.0)].into_iter().enumerate() {
                let path = tmp(&format!("nostderr-{stderr}-{i}.exr"));
                render(&path, &lt, 0.5, 0.5, t, p, (64, 32), SIGMA, 1 + i as u64, stderr, MIX);
                images.push(path);
            }
            let mut a = args(images.clone());
            a.channel = Some(Channel::R);
            let doc = separate_doc(&a).unwrap();
            assert_eq!(doc["weighted_by_stderr"], stderr);
            if !stderr {
                let src = doc["sigma_source"].as_str().unwrap();
                assert!(src.contains("residual variance") && src.contains(&images[1].display().to_string()), "{src}");
                assert!(doc["fits"]["specular"]["chi2_per_dof"].is_null());
                assert!(doc["consistency"]["p_value"].is_number(), "{}", doc["consistency"]);
            }
            for side in ["diffuse", "specular"] {
                let fit = &doc["fits"][side];
                let nu = f(&fit["dof"]);
                let var = f(&fit["residual_variance"]);
                assert!((var.sqrt() / SIGMA - 1.0).abs() < 4.0 / (2.0 * nu).sqrt(), "{side}: σ̂ {}", var.sqrt());
                if stderr {
                    let x = f(&fit["chi2_per_dof"]);
                    assert!((x - 1.0).abs() < 4.0 * (2.0 / nu).sqrt(), "{side}: χ²/ν {x} (ν {nu})");
                    assert!(f(&fit["p_value"]) > 1e-4);
                }
            }
            docs.push(doc);
        }
        for key in ["stderr", "/diffuse/stderr", "/consistency/stderr"] {
            let ptr = if key.starts_with('/') { key.to_string() } else { format!("/{key}") };
            let (with, without) = (docs[0].pointer(&ptr).unwrap(), docs[1].pointer(&ptr).unwrap());
            for (x, y) in with.as_array().unwrap().iter().zip(without.as_array().unwrap()) {
                let r = f(y) / f(x);
                assert!((r - 1.0).abs() < 0.07, "{key}: residual-σ bar / stderr-layer bar = {r}");
            }
        }
        // The same pixels, so the same estimates.
        assert_eq!(docs[0]["coefficients"], docs[1]["coefficients"]);
    }

    #[test]
    fn bad_input_is_a_one_line_error_naming_the_file() {
        let lt = light();
        let small = (32, 16);
        let mk = |name: &str, t: f64, p: f64, size: (usize, usize), brdf: &str| {
            let path = tmp(name);
            render(&path, &lt, 0.5, 0.5, t, p, size, 0.01, 3, true, brdf);
            path
        };
        let d0 = mk("bad-d0.exr", 0.0, 0.0, small, MIX);
        let d0_copy = d0.with_file_name("bad-d0-copy.exr");
        std::fs::copy(&d0, &d0_copy).unwrap();
        let s1 = mk("bad-s1.exr", 40.0, 0.0, small, MIX);
        let s2 = mk("bad-s2.exr", 40.0, 180.0, small, MIX);
        let s90 = mk("bad-s90.exr", 40.0, 90.0, small, MIX);
        let big = mk("bad-big.exr", 40.0, 180.0, (64, 32), MIX);
        let lam = mk("bad-lambert.exr", 0.0, 0.0, small, r#"{"type":"lambert","albedo":0.5}"#);
        let mut ortho = read_image(&d0).unwrap();
        ortho.attributes.insert(
            "reflect:camera".into(),
            r#"{"type":"orthographic","from":[3,0,1],"to":[0,0,0],"up":[0,0,1],"extent":1.05}"#.into(),
        );
        let ortho_path = tmp("bad-ortho.exr");
        write_exr(&ortho_path, &ortho).unwrap();
        let missing = tmp("bad-missing.exr");
        let out = tmp("bad-out.exr");
        let ok = args(vec![d0.clone(), s1.clone(), s2.clone()]);
        assert!(separate_doc(&SeparateArgs { lmax: 3, ..args(ok.images.clone()) }).is_ok());
        let cases: Vec<(SeparateArgs, Option<&PathBuf>, &str)> = vec![
            (args(vec![d0.clone(), missing.clone()]), Some(&missing), "cannot read"),
            (args(vec![ortho_path.clone(), s1.clone()]), Some(&ortho_path), "not a normal-probe render"),
            (args(vec![s1.clone(), s2.clone()]), Some(&s1), "θ_o = 0"),
            (args(vec![d0.clone(), d0_copy.clone()]), Some(&d0_copy), "θ_o > 0"),
            (args(vec![d0.clone(), d0.clone()]), Some(&d0), "given more than once"),
            (args(vec![d0.clone(), s1.clone(), big.clone()]), Some(&big), "differs"),
            (args(vec![d0.clone(), s90.clone()]), Some(&s90), "φ_o"),
            (args(vec![d0.clone()]), None, "at least one specular view"),
            (args(vec![lam.clone(), s1.clone(), s2.clone()]), None, "--kd is required"),
            (
                SeparateArgs { kd: Some([0.5; 3]), ..args(vec![lam.clone(), s1.clone(), s2.clone()]) },
                None,
                "--ks is required",
            ),
            (SeparateArgs { kd: Some([0.0; 3]), ..args(ok.images.clone()) }, None, "must be > 0"),
            (
                SeparateArgs { ks: Some([0.5, -1.0, 0.5]), channel: Some(Channel::G), ..args(ok.images.clone()) },
                None,
                "must be > 0",
            ),
            (SeparateArgs { lmax: 1000, ..args(ok.images.clone()) }, None, "maximum"),
            // 16 rows cannot carry l = 8.
            (SeparateArgs { lmax: 8, ..args(ok.images.clone()) }, Some(&d0), "highest order"),
            (SeparateArgs { output: Some(out.clone()), width: 3, ..args(ok.images.clone()) }, None, "--width"),
        ];
        for (a, file, what) in cases {
            let e = separate_doc(&a).expect_err(what);
            let line = e.to_string();
            assert!(!line.contains('\n') && line.contains(what), "{line} (expected '{what}')");
            if let Some(fp) = file {
                assert_eq!(e.path.as_ref(), Some(fp), "{line}");
            }
        }
        assert!(!out.exists(), "no partial output");
    }
}
