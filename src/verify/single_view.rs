//! Check "single-view" (eq. 15; issue 11): the filter `reflect analyze` measures from ONE
//! orthographic view of a sphere, which sees one hemisphere of normals. Each render is written as
//! `reflect render` writes it and analysed by the functions `analyze` runs: the file reader, the
//! visible-pixel selection of `analysis::projection::ortho_samples` and the pixel-space filter fit
//! `analysis::filter::fit_filter_pixels` (B(d) = Σ_l A_l Σ_m L_lm Y_lm(d) for the known lighting,
//! error bars: the propagated per-pixel noise ⊕ the estimated truncation bias).
//!
//! - **Lambert** (albedo 0.8) under the Grace probe (L_lm from the map, as `analyze --lighting`
//!   computes them), view from (3, 0, 1), l ≤ 2: A_l = 0.8 · eq. 38/π = 0.8, 0.533, 0.2, every RGB
//!   channel. (Dividing B_lm fitted on the hemisphere by L_lm gave 0.64, 0.38, 0.12, 50 σ off.)
//! - **Phong** (s = 8, k_s = 1, `horizon = "ignore"`, so eq. 43 is exact) under an SH lighting
//!   l ≤ 8, view from +x, reflection parameterization, l ≤ 6: A_l = eq. 43.
//!
//! Informative rows: χ²/ν of each fit (≈ 1 when the model and the σ are right).
//! Wrong prediction: the analytic filters × 1.05.

use super::Ctx;
use super::check::{Check, Plot, Row};
use super::filter::{self, Measured};
use super::fit::Channel;
use super::picture::Picture;
use super::scenes::{Camera, Lighting, Spec, render_spec_to_exr, sh_lighting};
use super::scenes::{lambert, phong};
use super::transfer;
use analysis::filter::{PixelFilterFit, fit_filter_pixels};
use analysis::image::{Image, read_image};
use analysis::projection::{OrthoCamera, OrthoView, Param, Sphere, ortho_samples};
use vocab::Horizon;
use vocab::scene::BrdfSection;

pub const NAME: &str = "single-view";
pub const EQUATION: &str = "eq. 15, 38, 43";
/// Orders of the Lambert fit (the fault's `--lmax 2`).
pub const LMAX_LAMBERT: usize = 2;
/// Orders of the Phong fit.
pub const LMAX_PHONG: usize = 6;
/// Orders of the Phong scene's SH lighting.
pub const LMAX_LIGHT: usize = 8;
const ALBEDO: f64 = 0.8;
const PHONG_S: f64 = 8.0;
const EXTENT: f64 = 1.05;

/// Renders one orthographic view, writes it, reads it back and fits the filter as `analyze` does.
fn analyse_view(
    ctx: &Ctx,
    spec: &Spec,
    file: &str,
    param: Param,
    light: &[[f64; 3]],
    lmax: usize,
) -> Result<(PixelFilterFit, Image), String> {
    std::fs::create_dir_all(&ctx.out).map_err(|e| format!("{}: {e}", ctx.out.display()))?;
    let path = ctx.out.join(file);
    render_spec_to_exr(ctx, spec, &path)?;
    let image = read_image(&path).map_err(|e| e.to_string())?;
    let Camera::Ortho { from, up, extent } = spec.camera else { return Err("not an orthographic spec".into()) };
    let views = [OrthoView { image: &image, camera: OrthoCamera { from, to: [0.0; 3], up, extent } }];
    let (samples, have_sigma) = ortho_samples(&views, &Sphere::default(), param).map_err(|e| e.to_string())?;
    Ok((fit_filter_pixels(&samples, have_sigma, 1.0, light, lmax).map_err(|e| e.to_string())?, image))
}

/// Channel `ch` of a fit as a measured filter (total standard error).
pub fn measured(fit: &PixelFilterFit, ch: usize) -> Option<Measured> {
    let a = fit.orders.iter().map(|o| o.estimate[ch]).collect::<Option<Vec<f64>>>()?;
    let sigma = fit.orders.iter().map(|o| o.stderr[ch]).collect::<Option<Vec<f64>>>()?;
    Some(Measured { a, sigma })
}

/// The check from the two fits and the predictions (`lambert`: 0.8 Λ_l ρ̂_l, l ≤ 2; `phong`: eq. 43).
pub fn evaluate(lambert: &PixelFilterFit, phong: &PixelFilterFit, pred_lambert: &[f64], pred_phong: &[f64]) -> Check {
    let mut c = Check::new(NAME, EQUATION, "filter of one orthographic view, fitted in pixel space as `analyze` does");
    for (ch, name) in ["R", "G", "B"].iter().enumerate() {
        match measured(lambert, ch) {
            Some(m) => filter::rows(&mut c, &format!("Lambert Grace {name}"), &m, pred_lambert, None, false),
            None => c.push(Row::new(format!("Lambert Grace {name} unobservable"), 1.0, 0.0, 0.0)),
        }
    }
    match measured(phong, 0) {
        Some(m) => filter::rows(&mut c, "Phong s=8", &m, pred_phong, None, false),
        None => c.push(Row::new("Phong s=8 unobservable", 1.0, 0.0, 0.0)),
    }
    for (label, fit) in [("Lambert", lambert), ("Phong", phong)] {
        if let Some(x) = fit.channels[0].chi2_per_dof {
            c.push(
                Row::new(format!("{label} χ²/ν (R)"), 1.0, x, (2.0 / fit.channels[0].dof.max(1) as f64).sqrt())
                    .informative(),
            );
        }
    }
    c
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let size = if ctx.quick { 96 } else { 256 };
    let scale = if ctx.wrong { 1.05 } else { 1.0 };
    let ortho = |from: [f64; 3], lighting: Lighting, brdf: BrdfSection, spp: u32| Spec {
        width: size,
        height: size,
        spp,
        seed: ctx.seed + 21,
        camera: Camera::Ortho { from, up: [0.0, 0.0, 1.0], extent: EXTENT },
        lighting,
        shape: super::scenes::Shape::Sphere,
        brdf,
    };

    // Lambert under Grace: L_lm as `analyze --lighting grace_probe.hdr` computes them (two orders
    // beyond l_max for the truncation estimate).
    let grace = analysis::lighting::Lighting::from_envmap_file(&super::scenes::grace_path(ctx), None);
    let l_grace = grace.coefficients(LMAX_LAMBERT + 2).map_err(|e| e.to_string())?;
    let spec_l = ortho([3.0, 0.0, 1.0], Lighting::Grace(1.0), lambert(ALBEDO), ctx.spp(32, 64));
    let (lambert, img_l) =
        analyse_view(ctx, &spec_l, "single_view_lambert.exr", Param::Normal, &l_grace, LMAX_LAMBERT)?;

    // Phong under a band-limited SH lighting (exact L_lm).
    let light = sh_lighting(LMAX_LIGHT, 0.5, ctx.seed + 22);
    let l_sh: Vec<[f64; 3]> = light.iter().map(|&v| [v; 3]).collect();
    let spec_p =
        ortho([1.0, 0.0, 0.0], Lighting::Sh(light.clone()), phong(1.0, PHONG_S, Horizon::Ignore), ctx.spp(32, 64));
    let (phong, img_p) = analyse_view(ctx, &spec_p, "single_view_phong.exr", Param::Reflection, &l_sh, LMAX_PHONG)?;

    let pred_l: Vec<f64> = transfer::lambert(LMAX_LAMBERT).iter().map(|v| ALBEDO * v * scale).collect();
    let pred_p: Vec<f64> = transfer::phong(PHONG_S, LMAX_PHONG).iter().map(|v| v * scale).collect();
    let mut c = evaluate(&lambert, &phong, &pred_l, &pred_p);
    c.note(format!(
        "one orthographic view {size}×{size}, {} spp, independent sampler; Lambert albedo {ALBEDO} under Grace from \
         (3, 0, 1), l ≤ {LMAX_LAMBERT}; Phong s = {PHONG_S} (ignore) under SH lighting l ≤ {LMAX_LIGHT} from +x, \
         l ≤ {LMAX_PHONG}; σ = noise ⊕ estimated truncation",
        ctx.spp(32, 64)
    ));
    for w in lambert.warnings.iter().chain(&phong.warnings) {
        c.note(format!("analysis: {w}"));
    }
    // Pictures: each view against the analytic filter applied to its lighting (red channel), Grace
    // to l ≤ l_max + 2 as the fit knows it; the Phong light is band-limited, so its prediction is exact.
    let grace_r: Vec<f64> = l_grace.iter().map(|v| v[0]).collect();
    let a_l: Vec<f64> = transfer::lambert(LMAX_LAMBERT + 2).iter().map(|v| ALBEDO * v * scale).collect();
    c.pictures.push(Picture::normals_filter(
        "single_view_lambert",
        format!("Lambert {ALBEDO} sphere under Grace, one orthographic view from (3, 0, 1), {size}² (red)"),
        format!("0.8 · eq. 38/π filter applied to the map's L_lm, l ≤ {}", LMAX_LAMBERT + 2),
        &Channel::from_image(&img_l, 0),
        &grace_r,
        &a_l,
    ));
    let a_p: Vec<f64> = transfer::phong(PHONG_S, LMAX_LIGHT).iter().map(|v| v * scale).collect();
    c.pictures.push(Picture::reflected_filter(
        "single_view_phong",
        format!("Phong s = {PHONG_S} sphere under SH light l ≤ {LMAX_LIGHT}, one orthographic view from +x, {size}²"),
        "eq. 43 filter applied at the reflection vector (exact: the light is band-limited)",
        &Channel::from_image(&img_p, 0),
        &light,
        &a_p,
        [1.0, 0.0, 0.0],
    ));
    let series = |name: &str, fit: &PixelFilterFit| measured(fit, 0).map(|m| m.series(name));
    c.plots.push(Plot {
        legend: super::check::Legend::UpperRight,
        file: "single_view.svg".into(),
        title: "One orthographic view: filter fitted in pixel space".into(),
        x_label: "l".into(),
        y_label: "A_l".into(),
        curves: vec![filter::curve("0.8 · eq. 38/π", &pred_l), filter::curve("eq. 43, s = 8", &pred_p)],
        points: [series("Lambert, Grace (R)", &lambert), series("Phong, SH light", &phong)]
            .into_iter()
            .flatten()
            .collect(),
    });
    Ok(c)
}
