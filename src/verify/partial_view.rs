//! Check "partial-view" (eq. 17; issue 16): the lighting recovered from orthographic views, which
//! see part of the sphere of normals, by the functions `reflect invert lighting` runs on such views:
//! the file reader, the visible-pixel selection `analysis::projection::ortho_samples` and the
//! pixel-space inversion `analysis::inverse::views::invert_lighting_views` (conditioning from the
//! actual design, error bars = the propagated per-pixel noise ⊕ the estimated truncation).
//!
//! A Lambertian sphere (albedo 0.8) under the Grace probe, l ≤ 2, RGB:
//! - **one view** from +x (the fault: L_00 came out 1.969 ± 0.020 for the map's 2.530, 28 σ,
//!   every order "recovered"): every L_lm within k·σ of the map's projection (as `analyze
//!   --lighting` computes it); the orders the view cannot determine well are said (measured: every
//!   order `ill-conditioned`, amplification 22 > 10) and their error bars are wide accordingly;
//! - **two opposite views** (+x and −x): the same, and every order must be `recovered`;
//! - **conditioning from the design**: the largest amplification of one view must exceed that of
//!   the two views (the filter is the same, so only the design can tell them apart); both are shown;
//! - **undetermined from one view, recovered from two** (the truncation half of the classification):
//!   the same renders inverted at l ≤ [`LMAX_TRUNCATION`] = 1, where one view's design is well
//!   conditioned (amplification 2.6 / 3.9) but the orders above l_max, which one hemisphere of
//!   normals cannot tell from the fitted ones, can move L_00 by 67 % of its size (--quick; its
//!   `truncation_bound`; the threshold is 35 %): l = 0 must be reported `undetermined` from one view
//!   and `recovered` from the two, and every L_lm within its bars in both. Planted error: the
//!   classification before the predicted truncation (status from the amplification alone) called
//!   one view's l = 0 `recovered`, which fails this row.
//!
//! The two views are rendered once and serve all four inversions.
//!
//! Informative rows: χ²/ν of each fit (G). Wrong prediction: the map's L_lm × 1.05.

use super::Ctx;
use super::check::{Check, Row};
use super::fit::Channel;
use super::picture::Picture;
use super::scenes::lambert;
use super::scenes::{Camera, Lighting, Spec, render_spec_to_exr};
use analysis::image::{Image, read_image};
use analysis::inverse::lighting::DEFAULT_MAX_AMPLIFICATION;
use analysis::inverse::views::{UNDETERMINED, UNDETERMINED_TRUNCATION, ViewsLighting, invert_lighting_views};
use analysis::projection::{OrthoCamera, OrthoView, Param, Sphere, ortho_samples};
use analysis::sh::{lm, num_coefficients};
use analysis::transfer::TransferModel;

pub const NAME: &str = "partial-view";
pub const EQUATION: &str = "eq. 17, 38";
/// Orders inverted (the issue's `--lmax 2`).
pub const LMAX: usize = 2;
/// Orders of the second inversion, where one view is well conditioned but truncation-dominated
/// (l = 0 `undetermined` from one view, `recovered` from two).
pub const LMAX_TRUNCATION: usize = 1;
const ALBEDO: f64 = 0.8;
const EXTENT: f64 = 1.05;

/// Renders the views of `specs` and reads them back as `reflect invert lighting` would.
fn render_views(ctx: &Ctx, specs: &[(Spec, &str)]) -> Result<(Vec<Image>, Vec<OrthoCamera>), String> {
    std::fs::create_dir_all(&ctx.out).map_err(|e| format!("{}: {e}", ctx.out.display()))?;
    let mut images = Vec::new();
    let mut cameras = Vec::new();
    for (spec, file) in specs {
        let path = ctx.out.join(file);
        render_spec_to_exr(ctx, spec, &path)?;
        images.push(read_image(&path).map_err(|e| e.to_string())?);
        let Camera::Ortho { from, up, extent } = spec.camera else { return Err("not an orthographic spec".into()) };
        cameras.push(OrthoCamera { from, to: [0.0; 3], up, extent });
    }
    Ok((images, cameras))
}

/// Inverts the views together to l ≤ `lmax` as `invert lighting` does.
fn invert_views(images: &[Image], cameras: &[OrthoCamera], lmax: usize) -> Result<ViewsLighting, String> {
    let views: Vec<OrthoView> =
        images.iter().zip(cameras).map(|(image, camera)| OrthoView { image, camera: *camera }).collect();
    let (samples, have_sigma) = ortho_samples(&views, &Sphere::default(), Param::Normal).map_err(|e| e.to_string())?;
    // The CLI hands the filter up to the truncation sequence's top order (l_max + 2 … 2 l_max).
    let filter = TransferModel::Lambert.lambda_rho(analysis::inverse::views::truncation_lmax(lmax));
    invert_lighting_views(&samples, have_sigma, 1.0, &filter, [ALBEDO; 3], lmax, DEFAULT_MAX_AMPLIFICATION)
        .map_err(|e| e.to_string())
}

/// Largest coefficient amplification of an inversion.
pub fn worst_amplification(v: &ViewsLighting) -> f64 {
    v.amplification.iter().flatten().fold(0.0, |a, &b| a.max(b))
}

/// Rows of one inversion: every L_lm (l ≤ [`LMAX`], RGB) against `truth` within k·σ (σ the total
/// error bar, noise ⊕ truncation). With `require_recovered` an order not `recovered` fails;
/// otherwise its status is reported (a view may say it cannot determine an order: then the value
/// must still lie within its, larger, error bar).
pub fn rows(c: &mut Check, label: &str, v: &ViewsLighting, truth: &[[f64; 3]], require_recovered: bool) {
    for o in &v.orders {
        let a = o.amplification.unwrap_or(f64::INFINITY);
        if o.status != "recovered" {
            let row =
                Row::new(format!("{label}: order l = {} is {} (amplification {a:.1})", o.l, o.status), 1.0, 0.0, 0.0);
            c.push(if require_recovered { row } else { row.informative() });
        }
    }
    for (k, t) in truth.iter().enumerate().take(num_coefficients(v.lmax)) {
        let (l, m) = lm(k);
        for (ch, name) in ["R", "G", "B"].iter().enumerate() {
            match (v.coefficients[k], v.stderr[k]) {
                (Some(x), Some(s)) => {
                    c.push(Row::new(format!("{label}: L_{l},{m} {name}"), t[ch], x[ch], s[ch]));
                }
                _ => c.push(Row::new(format!("{label}: L_{l},{m} {name} not returned"), 1.0, 0.0, 0.0)),
            }
        }
    }
    if let Some(x) = v.channels.get(1).and_then(|f| f.chi2_per_dof) {
        let nu = v.channels[1].dof.max(1) as f64;
        c.push(Row::new(format!("{label}: χ²/ν (G)"), 1.0, x, (2.0 / nu).sqrt()).informative());
    }
}

/// The status of order `l` in an inversion ("missing" when it has no such order).
fn status(v: &ViewsLighting, l: usize) -> &str {
    v.orders.iter().find(|o| o.l == l).map_or("missing", |o| o.status.as_str())
}

/// The check from the one-view and two-view inversions at l ≤ [`LMAX`] (`one`, `two`) and at
/// l ≤ [`LMAX_TRUNCATION`] (`one_t`, `two_t`), and the truth (l ≤ [`LMAX`]).
pub fn evaluate(
    one: &ViewsLighting,
    two: &ViewsLighting,
    one_t: &ViewsLighting,
    two_t: &ViewsLighting,
    truth: &[[f64; 3]],
) -> Check {
    let mut c = Check::new(
        NAME,
        EQUATION,
        "lighting from orthographic views that see part of the sphere, inverted in pixel space as `invert lighting` does",
    );
    rows(&mut c, "one view", one, truth, false);
    rows(&mut c, "two views", two, truth, true);
    let (a1, a2) = (worst_amplification(one), worst_amplification(two));
    c.push(Row::new("largest amplification, one view (filter × design)", a1, a1, 0.0).informative());
    c.push(Row::new("largest amplification, two opposite views", a2, a2, 0.0).informative());
    c.push(Row::new(
        "one view's design amplifies the noise more than two opposite views' (1 = yes)",
        1.0,
        if a1 > a2 { 1.0 } else { 0.0 },
        0.0,
    ));
    // Truncation, not conditioning: at l ≤ 1 one view is well conditioned, but the orders above
    // l_max it cannot separate from the fitted ones make l = 0 undetermined; two views recover it.
    let lt = LMAX_TRUNCATION;
    let share = |v: &ViewsLighting| -> f64 {
        (0..3)
            .map(|ch| {
                let b = v.truncation_bound.first().copied().flatten().map_or(f64::NAN, |b| b[ch]);
                let x = v.coefficients.first().copied().flatten().map_or(f64::NAN, |x| x[ch]);
                (b / x).abs()
            })
            .fold(0.0, f64::max)
    };
    let (s1, s2) = (status(one_t, 0), status(two_t, 0));
    c.push(Row::new(
        format!(
            "one view, l ≤ {lt}: l = 0 is undetermined (1 = yes; status {s1}, amplification {:.1}, truncation bound \
             {:.0} % of L_00, threshold {:.0} %)",
            worst_amplification(one_t),
            100.0 * share(one_t),
            100.0 * UNDETERMINED_TRUNCATION
        ),
        1.0,
        if s1 == UNDETERMINED { 1.0 } else { 0.0 },
        0.0,
    ));
    c.push(Row::new(
        format!(
            "two views, l ≤ {lt}: l = 0 is recovered (1 = yes; status {s2}, truncation bound {:.0} %)",
            100.0 * share(two_t)
        ),
        1.0,
        if s2 == "recovered" { 1.0 } else { 0.0 },
        0.0,
    ));
    rows(&mut c, &format!("one view, l ≤ {lt}"), one_t, truth, false);
    rows(&mut c, &format!("two views, l ≤ {lt}"), two_t, truth, true);
    c
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let size = if ctx.quick { 96 } else { 192 };
    let spp = ctx.spp(32, 64);
    let view = |from: [f64; 3], seed: u64| Spec {
        width: size,
        height: size,
        spp,
        seed: ctx.seed + seed,
        camera: Camera::Ortho { from, up: [0.0, 0.0, 1.0], extent: EXTENT },
        lighting: Lighting::Grace(1.0),
        shape: super::scenes::Shape::Sphere,
        brdf: lambert(ALBEDO),
    };
    let front = (view([3.0, 0.0, 0.0], 31), "partial_view_front.exr");
    let back = (view([-3.0, 0.0, 0.0], 32), "partial_view_back.exr");
    let (images, cameras) = render_views(ctx, &[front, back])?;
    let one = invert_views(&images[..1], &cameras[..1], LMAX)?;
    let two = invert_views(&images, &cameras, LMAX)?;
    let one_t = invert_views(&images[..1], &cameras[..1], LMAX_TRUNCATION)?;
    let two_t = invert_views(&images, &cameras, LMAX_TRUNCATION)?;
    // The truth: L_lm of the map as `analyze --lighting grace_probe.hdr` computes them.
    let grace = analysis::lighting::Lighting::from_envmap_file(&super::scenes::grace_path(ctx), None);
    let scale = if ctx.wrong { 1.05 } else { 1.0 };
    let truth: Vec<[f64; 3]> =
        grace.coefficients(LMAX).map_err(|e| e.to_string())?.iter().map(|c| c.map(|v| v * scale)).collect();
    let mut c = evaluate(&one, &two, &one_t, &two_t, &truth);
    // Pictures: each view against Lambert's filter applied to the map's L_lm (green, l ≤ l_max + 2):
    // the two halves of the normal sphere the inversion has to work from.
    let green: Vec<f64> = grace.coefficients(LMAX + 2).map_err(|e| e.to_string())?.iter().map(|c| c[1]).collect();
    let a: Vec<f64> = TransferModel::Lambert.lambda_rho(LMAX + 2).iter().map(|v| ALBEDO * v * scale).collect();
    for (image, side) in images.iter().zip(["front (+x)", "back (−x)"]) {
        c.pictures.push(Picture::normals_filter(
            format!("partial_view_{}", &side[..side.find(' ').unwrap_or(side.len())]),
            format!("Lambert {ALBEDO} sphere under Grace, orthographic view from the {side}, {size}² (green)"),
            format!("0.8 · Λ_l ρ̂_l applied to the map's L_lm, l ≤ {}", LMAX + 2),
            &Channel::from_image(image, 1),
            &green,
            &a,
        ));
    }
    c.note(format!(
        "Lambert albedo {ALBEDO} under Grace, orthographic {size}×{size}, {spp} spp, views from +x and −x; l ≤ {LMAX}; \
         σ = propagated per-pixel noise ⊕ truncation bias estimated from the fit to l ≤ {}",
        LMAX + 2
    ));
    for w in one.warnings.iter().chain(&two.warnings).chain(&one_t.warnings) {
        c.note(format!("analysis: {w}"));
    }
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use analysis::inverse::views::ViewOrder;

    fn inversion_at(lmax: usize, coef: f64, se: f64, amp: f64) -> ViewsLighting {
        let n = num_coefficients(lmax);
        ViewsLighting {
            lmax,
            orders: (0..=lmax)
                .map(|l| ViewOrder { l, lambda_rho: 1.0, amplification: Some(amp), status: "recovered".into() })
                .collect(),
            coefficients: vec![Some([coef; 3]); n],
            stderr: vec![Some([se; 3]); n],
            stderr_noise: vec![Some([se; 3]); n],
            truncation: vec![None; n],
            truncation_bound: vec![Some([0.05 * coef; 3]); n],
            amplification: vec![Some(amp); n],
            channels: vec![],
            warnings: vec![],
        }
    }

    fn inversion(coef: f64, se: f64, amp: f64) -> ViewsLighting {
        inversion_at(LMAX, coef, se, amp)
    }

    /// One view at l ≤ 1 as measured: well conditioned, l = 0 undetermined (truncation bound 50 %).
    fn one_view_truncated() -> ViewsLighting {
        let mut v = inversion_at(LMAX_TRUNCATION, 1.0, 0.3, 3.0);
        v.orders[0].status = UNDETERMINED.into();
        v.truncation_bound[0] = Some([0.5; 3]);
        v
    }

    fn two_views_truncated() -> ViewsLighting {
        inversion_at(LMAX_TRUNCATION, 1.0, 0.01, 1.5)
    }

    fn check(one: &ViewsLighting, two: &ViewsLighting, truth: &[[f64; 3]]) -> Check {
        evaluate(one, two, &one_view_truncated(), &two_views_truncated(), truth)
    }

    #[test]
    fn passes_on_the_truth_and_fails_on_a_bias_a_lost_order_or_a_blind_design() {
        let truth = vec![[1.0; 3]; num_coefficients(LMAX)];
        let ok = check(&inversion(1.01, 0.01, 8.0), &inversion(1.0, 0.01, 4.0), &truth);
        assert!(ok.passed(), "{:?}", ok.rows);
        // The fault: one view 28 σ off.
        assert!(!check(&inversion(0.72, 0.01, 8.0), &inversion(1.0, 0.01, 4.0), &truth).passed());
        // Two opposite views see the whole sphere: an order they call ill-conditioned fails; one
        // view may say so (reported, not failed).
        let mut lost = inversion(1.0, 0.01, 4.0);
        lost.orders[2].status = "ill-conditioned".into();
        assert!(!check(&inversion(1.0, 0.01, 8.0), &lost, &truth).passed());
        let mut said = inversion(1.0, 0.01, 8.0);
        said.orders[2].status = "ill-conditioned".into();
        assert!(check(&said, &inversion(1.0, 0.01, 4.0), &truth).passed());
        // Conditioning that ignores the design (the same amplification for one and two views).
        assert!(!check(&inversion(1.0, 0.01, 4.0), &inversion(1.0, 0.01, 4.0), &truth).passed());
    }

    /// The truncation rows: one view must call l = 0 `undetermined` at l ≤ 1 and two views must
    /// recover it. Planted errors: the classification from the amplification alone (one view's
    /// l = 0 `recovered`, as before the predicted truncation), and two views that cannot recover it.
    #[test]
    fn one_view_must_say_undetermined_and_two_views_must_recover() {
        let truth = vec![[1.0; 3]; num_coefficients(LMAX)];
        let (one, two) = (inversion(1.0, 0.01, 8.0), inversion(1.0, 0.01, 4.0));
        let ok = evaluate(&one, &two, &one_view_truncated(), &two_views_truncated(), &truth);
        assert!(ok.passed(), "{:?}", ok.rows.iter().filter(|r| !r.passed()).collect::<Vec<_>>());
        let row = ok.rows.iter().find(|r| r.label.starts_with("one view, l ≤ 1: l = 0 is undetermined")).unwrap();
        assert!(row.label.contains("50 %") && !row.informative, "{}", row.label);
        let mut blind = one_view_truncated();
        blind.orders[0].status = "recovered".into();
        let bad = evaluate(&one, &two, &blind, &two_views_truncated(), &truth);
        assert!(!bad.passed());
        let failed: Vec<_> = bad.rows.iter().filter(|r| !r.passed()).map(|r| r.label.as_str()).collect();
        assert_eq!(failed.len(), 1, "{failed:?}");
        assert!(failed[0].starts_with("one view, l ≤ 1: l = 0 is undetermined"), "{failed:?}");
        let mut lost = two_views_truncated();
        lost.orders[0].status = UNDETERMINED.into();
        assert!(!evaluate(&one, &two, &one_view_truncated(), &lost, &truth).passed());
    }
}
