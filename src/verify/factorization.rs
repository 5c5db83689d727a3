//! Check "factorization" (eq. 18, 23; issue 5): from renders of a sphere under an unknown
//! directional source, at many exitance directions, recover the lighting and the BRDF up to the
//! global scale P = ∫ L dω, with `analysis::inverse::factorization`.
//!
//! Renders: `normal-probe` (docs/src/conventions.md §6) at every node (θ'_o, φ'_o) of a product rule over the
//! outgoing hemisphere (Gauss–Legendre in μ = cos θ'_o × trapezoid in φ'_o), which samples the 4D
//! light field B(n; θ'_o, φ'_o); normals are integrated with Fejér's first rule on the lat-long rows.
//! The source (unit irradiance, direction [`SOURCE`], θ_s = φ_s·(−1) = 36.87°) is not told to the
//! analysis. BRDFs:
//! - `microfacet` Beckmann α = [`ALPHA`], Fresnel none: reciprocal (height-correlated Smith G is
//!   symmetric, F = 1), so eq. 18 applies; its shadowing G → 0 at grazing makes the light field
//!   continuous across the terminator and the horizon, so both quadratures converge (the paper's
//!   `torrance-sparrow` jumps there, and its off-specular lobe narrows at grazing: measured errors
//!   ~10× larger at the same node count); and its albedo falls with angle (single-scattering energy
//!   loss), so κ_3 ≠ 0, unlike Lambert's.
//! - `lambert` (albedo 1): the radiant exitance kernel is the clamped cosine, so κ_l = 0 at odd
//!   l ≥ 3 (eq. 38): those orders are 0/0, the "ill-posed: lighting or BRDF coefficient zero" case
//!   at the end of sec. 3.1.
//!
//! Deterministic: a delta light is sampled by next-event estimation only and the camera looks
//! through pixel centres, so every sample of a pixel is the same number; 1 spp, σ = 0 (the
//! renderer's stderr layer is checked to be 0). The only error is quadrature, stated per row as
//! `approx` = |fine − coarse| + |Fejér − midpoint|: the change between two complete sets of renders
//! ([`plans`]: finer normal grid and more outgoing nodes) plus the change between two rules over the
//! normals on the fine renders (Fejér vs exact pixel solid angles). The first term alone is not a
//! bound: the normal-grid error of an image with a kink (the terminator) is erratic, not monotone in
//! H (measured: Lambert L_2m errs 1e-5 at H = 48 and 1.6e-5 at H = 96), and the full run failed
//! with it; the second term is dominated by the midpoint rule's own O((π/H)²) error, which exceeds
//! Fejér's. Plus the f32 floor `check::F32_FLOOR`. Fine-grid (Fejér) values are compared.
//!
//! Rows (deciding): L_lm / P vs Y_lm(s) (eq. 19, 23) for l ≤ 2 (glossy and Lambert); the angle
//! between the recovered and the true source; the normal-exitance filter ratio
//! Λ_l ρ̂_l / Λ_0 ρ̂_0 from eq. 16 with the factored lighting (l ≤ 2) and with the factored source
//! direction (L_lm / P = Y_lm(ŝ), l ≤ [`LMAX_FILTER`]) against the analytic Beckmann transfer at
//! normal exitance (`analysis::transfer::radial` of ρ̂(θ) = D(θ/2) G / 4); Lambert's gain
//! |Λ_l κ_l| / |Λ_0 κ_0| = 0 at l = 3, 5. Informative: l = 3, 4 (ill-conditioned), κ_l / κ_0, the
//! gauge L_00 = Λ_0⁻¹, the directionality |L_1| / √(3/4π) = 1.
//! Wrong prediction (`ctx.wrong`): the source rotated by 3° and the filter of α × 1.2.

use super::Ctx;
use super::check::{Check, F32_FLOOR, Legend, Plot, Row, Series};
use super::fit::{Channel, dot, latlong_dir, normalize};
use super::picture::Picture;
use super::scenes::{Camera, Lighting, Spec, render_spec};
use super::scenes::{beckmann, lambert};
use analysis::inverse::factorization::{
    DEFAULT_MAX_AMPLIFICATION, Factorization, LightField, NormalRule, Status, directional_lighting,
    filter_from_lighting, hemisphere_nodes, project,
};
use analysis::sh::index;
use analysis::transfer::microfacet::beckmann_lambda;
use std::f64::consts::PI;
use vocab::scene::BrdfSection;

pub const NAME: &str = "factorization";
pub const EQUATION: &str = "eq. 18, 23";
/// The "unknown" source direction (unit; not on an axis).
pub const SOURCE: [f64; 3] = [0.48, -0.36, 0.8];
/// Beckmann width of the glossy sphere.
pub const ALPHA: f64 = 0.4;
/// The glossy sphere: Beckmann D of width [`ALPHA`], no Fresnel term.
pub fn glossy() -> BrdfSection {
    beckmann(ALPHA)
}
/// Lighting orders factored (l ≤ 2 decide, the rest is informative).
pub const LMAX: usize = 5;
/// Orders of the normal-exitance filter compared with the directional-source model.
pub const LMAX_FILTER: usize = 6;
/// Outgoing nodes of the Lambertian sphere (its light field does not depend on ω_o).
pub const LAMBERT_NODES: (usize, usize) = (4, 4);

/// One quadrature resolution: lat-long height H (W = 2H) and the outgoing product rule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plan {
    pub height: usize,
    pub n_mu: usize,
    pub n_phi: usize,
}

/// (coarse, fine). Measured on closed-form light fields of this BRDF and source (see the
/// analysis tests): fine quick (48, 12 × 32) errs ≤ 5e-5 on L_lm, l ≤ 2; coarse (24, 8 × 16) ≈ 2e-3.
pub fn plans(quick: bool) -> (Plan, Plan) {
    if quick {
        (Plan { height: 24, n_mu: 8, n_phi: 16 }, Plan { height: 48, n_mu: 12, n_phi: 32 })
    } else {
        (Plan { height: 48, n_mu: 12, n_phi: 32 }, Plan { height: 96, n_mu: 16, n_phi: 48 })
    }
}

/// What one resolution measures: the factorization and the normal-exitance coefficients B_lm(0),
/// with Fejér's rule over the normals and (for the error estimate) with the midpoint rule
/// (exact pixel solid angles) on the same renders.
#[derive(Clone, Debug)]
pub struct Slice {
    pub factor: Factorization,
    pub normal_b: Vec<f64>,
    pub factor_mid: Factorization,
    pub normal_b_mid: Vec<f64>,
    pub renders: usize,
}

/// Builds a [`Slice`] from an image source `image(θ'_o, φ'_o, H)` (degrees; W = 2H), which is a
/// renderer in [`run`] and a closed form in the tests.
pub fn measure(
    plan: Plan,
    nodes: (usize, usize),
    image: &mut dyn FnMut(f64, f64, usize) -> Result<Vec<f64>, String>,
) -> Result<Slice, String> {
    let (w, h) = (2 * plan.height, plan.height);
    let e = |e: analysis::Error| e.to_string();
    let mut lf = LightField::new(w, h, NormalRule::Fejer).map_err(e)?;
    let mut lf_mid = LightField::new(w, h, NormalRule::PixelSolidAngle).map_err(e)?;
    let mut renders = 0;
    for node in hemisphere_nodes(nodes.0, nodes.1).map_err(e)? {
        let img = image(node.theta_o.to_degrees(), node.phi_o.to_degrees(), h)?;
        lf.add(node, &img).map_err(e)?;
        lf_mid.add(node, &img).map_err(e)?;
        renders += 1;
    }
    let factor = lf.factorize(LMAX, DEFAULT_MAX_AMPLIFICATION).map_err(e)?;
    let factor_mid = lf_mid.factorize(LMAX, DEFAULT_MAX_AMPLIFICATION).map_err(e)?;
    let img0 = image(0.0, 0.0, h)?;
    let normal_b = project(&img0, w, h, NormalRule::Fejer, LMAX_FILTER).map_err(e)?;
    let normal_b_mid = project(&img0, w, h, NormalRule::PixelSolidAngle, LMAX_FILTER).map_err(e)?;
    Ok(Slice { factor, normal_b, factor_mid, normal_b_mid, renders: renders + 1 })
}

pub use analysis::transfer::microfacet::beckmann_normal_exitance;

/// The source rotated by `deg` about an axis perpendicular to it (the wrong prediction).
pub fn rotated(s: [f64; 3], deg: f64) -> [f64; 3] {
    let s = normalize(s);
    let a = normalize([-s[1], s[0], 0.0]);
    let b = [s[1] * a[2] - s[2] * a[1], s[2] * a[0] - s[0] * a[2], s[0] * a[1] - s[1] * a[0]];
    let (sn, cs) = deg.to_radians().sin_cos();
    std::array::from_fn(|i| cs * s[i] + sn * b[i])
}

fn angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
    dot(normalize(a), normalize(b)).clamp(-1.0, 1.0).acos().to_degrees()
}

/// The prediction: source direction and the normal-exitance filter Λ_l ρ̂_l, l ≤ LMAX_FILTER.
#[derive(Clone, Debug)]
pub struct Prediction {
    pub source: [f64; 3],
    pub filter: Vec<f64>,
}

impl Prediction {
    pub fn new(wrong: bool) -> Prediction {
        if wrong {
            Prediction { source: rotated(SOURCE, 3.0), filter: beckmann_normal_exitance(1.2 * ALPHA, LMAX_FILTER) }
        } else {
            Prediction { source: normalize(SOURCE), filter: beckmann_normal_exitance(ALPHA, LMAX_FILTER) }
        }
    }
}

/// Filter ratios x_l / x_0 with the factored lighting (orders with a lighting) or the factored
/// source direction (all orders).
fn filter_ratios(factor: &Factorization, normal_b: &[f64], directional: bool) -> Vec<Option<f64>> {
    let light: Vec<Option<f64>> = if directional {
        match factor.source_direction() {
            Some(src) => directional_lighting(src.direction, LMAX_FILTER).into_iter().map(Some).collect(),
            None => vec![None; (LMAX_FILTER + 1) * (LMAX_FILTER + 1)],
        }
    } else {
        factor.lighting.clone()
    };
    let x = filter_from_lighting(normal_b, &light, if directional { LMAX_FILTER } else { LMAX });
    let x0 = x[0];
    x.iter().map(|v| Some((*v)? / x0?)).collect()
}

/// The check from the glossy and Lambertian slices (coarse, fine) and a prediction.
pub fn evaluate(glossy: (&Slice, &Slice), lambert: (&Slice, &Slice), p: &Prediction) -> Check {
    let mut c = Check::new(
        NAME,
        EQUATION,
        "factor the light field of a sphere under an unknown directional source into L_lm (up to scale) and the BRDF",
    );
    let y = directional_lighting(p.source, LMAX);
    let floor = F32_FLOOR / (4.0 * PI).sqrt();
    for (name, (coarse, fine)) in [("microfacet", glossy), ("lambert", lambert)] {
        for o in &fine.factor.orders {
            for m in -(o.l as i64)..=(o.l as i64) {
                let k = index(o.l, m);
                let label = format!("{name}: L_{},{m}/P vs Y_lm(s) ({}, gain {:.3e})", o.l, o.status.name(), o.gain);
                match (fine.factor.lighting[k], coarse.factor.lighting[k], fine.factor_mid.lighting[k]) {
                    (Some(f), Some(q), Some(mid)) => {
                        let mut row =
                            Row::new(label, y[k], f, 0.0).approx((f - q).abs() + (f - mid).abs()).floor(floor);
                        if o.l == 0 {
                            row.label = format!("{name}: L_00/P = Λ_0⁻¹ (gauge, identity)");
                            row = row.informative();
                        } else if o.l > 2 {
                            row = row.informative();
                        }
                        c.push(row);
                    }
                    (Some(f), _, _) => c.push(Row::new(label + " [coarse ambiguous]", y[k], f, 0.0).informative()),
                    _ if o.l <= 2 => c.push(Row::new(label + " [not recovered]", y[k], f64::NAN, 0.0)),
                    _ => {}
                }
            }
            c.note(format!(
                "{name} l = {}: κ_l/κ_0 = {:.5} (coarse {:.5}), gain |Λ_l κ_l|/|Λ_0 κ_0| = {:.3e} → {}",
                o.l,
                o.kappa / fine.factor.kappa[0],
                coarse.factor.kappa[o.l] / coarse.factor.kappa[0],
                o.gain,
                o.status.name()
            ));
        }
        // The source direction from l = 1 (eq. 19) and its directionality.
        match (fine.factor.source_direction(), coarse.factor.source_direction(), fine.factor_mid.source_direction()) {
            (Some(f), Some(q), Some(mid)) => {
                c.push(
                    Row::new(
                        format!("{name}: angle(recovered, true source) (deg)"),
                        0.0,
                        angle_deg(f.direction, p.source),
                        0.0,
                    )
                    .approx(angle_deg(f.direction, q.direction) + angle_deg(f.direction, mid.direction))
                    .floor(F32_FLOOR.to_degrees()),
                );
                c.push(
                    Row::new(format!("{name}: directionality |L_1|/√(3/4π)"), 1.0, f.directionality, 0.0)
                        .approx(
                            (f.directionality - q.directionality).abs() + (f.directionality - mid.directionality).abs(),
                        )
                        .floor(F32_FLOOR)
                        .informative(),
                );
            }
            _ => c.push(Row::new(format!("{name}: angle(recovered, true source) (deg)"), 0.0, f64::NAN, 0.0)),
        }
    }
    // Lambert: the odd orders l ≥ 3 are 0/0 (eq. 38).
    for o in lambert.1.factor.orders.iter().filter(|o| o.l >= 3 && o.l % 2 == 1) {
        c.push(
            Row::new(format!("lambert: gain |Λ_{0} κ_{0}|/|Λ_0 κ_0| = 0 (eq. 38: ambiguous)", o.l), 0.0, o.gain, 0.0)
                .floor(F32_FLOOR),
        );
        c.note(format!("lambert l = {}: {} (L_lm not returned)", o.l, o.status.name()));
    }
    // Lambert's BRDF coefficients ρ̃_0l0 ∝ κ_l (the normal-averaged outgoing profile, B̃_00l0), which
    // equal ρ̃_l00 ∝ k̂_l = Λ_l⁻¹ Λ_l ρ̂_l by reciprocity: κ_l/κ_0 = (Λ_0/Λ_l) (Λ_l ρ̂_l)/(Λ_0 ρ̂_0)
    // with eq. 38 (2/√3, √5/4, …; the odd l ≥ 3 are the zero-gain rows above).
    let a = analysis::transfer::lambert::lambert(LMAX);
    let kappa_ratio = |s: &Slice, l: usize| s.factor.kappa[l] / s.factor.kappa[0];
    let mid_ratio = |s: &Slice, l: usize| s.factor_mid.kappa[l] / s.factor_mid.kappa[0];
    for l in (1..=LMAX).filter(|&l| l <= 2 || l % 2 == 0) {
        let expected = analysis::sh::lambda(0) / analysis::sh::lambda(l) * a[l] / a[0];
        let (f, q, m) = (kappa_ratio(lambert.1, l), kappa_ratio(lambert.0, l), mid_ratio(lambert.1, l));
        c.push(
            Row::new(format!("lambert: κ_{l}/κ_0 = ρ̃_0{l}0/ρ̃_000 vs eq. 38 (reciprocity)"), expected, f, 0.0)
                .approx((f - q).abs() + (f - m).abs())
                .floor(F32_FLOOR),
        );
    }
    for o in lambert.1.factor.orders.iter().filter(|o| o.status == Status::Ambiguous) {
        c.note(format!("lambert l = {} reported ambiguous: the factorization is ill-posed there (lighting or BRDF coefficient zero)", o.l));
    }
    // BRDF: the normal-exitance filter by eq. 16 with the factored lighting / source.
    let ratio = |l: usize| p.filter[l] / p.filter[0];
    for (directional, top) in [(false, 2usize), (true, LMAX_FILTER)] {
        let f = filter_ratios(&glossy.1.factor, &glossy.1.normal_b, directional);
        let q = filter_ratios(&glossy.0.factor, &glossy.0.normal_b, directional);
        let mid = filter_ratios(&glossy.1.factor_mid, &glossy.1.normal_b_mid, directional);
        let how = if directional { "Y_lm(ŝ)" } else { "factored L_lm" };
        for l in 1..=top {
            let label = format!("microfacet: Λ_{l}ρ̂_{l}/Λ_0ρ̂_0 at θ_o = 0, eq. 16 with {how}");
            match (f.get(l).copied().flatten(), q.get(l).copied().flatten(), mid.get(l).copied().flatten()) {
                (Some(a), Some(b), Some(m)) => {
                    c.push(Row::new(label, ratio(l), a, 0.0).approx((a - b).abs() + (a - m).abs()).floor(F32_FLOOR))
                }
                _ => c.push(Row::new(label, ratio(l), f64::NAN, 0.0)),
            }
        }
    }
    c.note(format!(
        "renders: {} + {} (microfacet coarse + fine), {} + {} (lambert); 1 spp each, deterministic (σ = 0)",
        glossy.0.renders, glossy.1.renders, lambert.0.renders, lambert.1.renders
    ));
    c.plots.extend(plots(glossy.1, lambert.1, &y));
    c
}

fn plots(glossy: &Slice, lambert: &Slice, y: &[f64]) -> Vec<Plot> {
    let n = y.len();
    let pts = |s: &Slice, name: &str| {
        let ks: Vec<usize> = (1..n).filter(|&k| s.factor.lighting[k].is_some()).collect();
        Series {
            name: name.into(),
            x: ks.iter().map(|&k| k as f64).collect(),
            y: ks.iter().map(|&k| s.factor.lighting[k].unwrap_or(f64::NAN)).collect(),
            err: None,
            dashed: false,
        }
    };
    let truth = Series {
        name: "Y_lm(s) (eq. 19)".into(),
        x: (1..n).map(|k| k as f64).collect(),
        y: y[1..].to_vec(),
        err: None,
        dashed: false,
    };
    let coeffs = Plot {
        legend: Legend::UpperRight,
        file: "factorization_lighting.svg".into(),
        title: "Factorization: recovered L_lm/P vs k = l(l+1)+m (Lambert: odd l ≥ 3 ambiguous)".into(),
        x_label: "k".into(),
        y_label: "L_lm / P".into(),
        curves: vec![truth],
        points: vec![pts(glossy, "microfacet α = 0.4"), pts(lambert, "lambert")],
    };
    let err = |s: &Slice, name: &str| {
        let ls: Vec<usize> = (1..=LMAX).filter(|&l| s.factor.lighting[index(l, 0)].is_some()).collect();
        Series {
            name: name.into(),
            x: ls.iter().map(|&l| l as f64).collect(),
            y: ls
                .iter()
                .map(|&l| {
                    let e = (-(l as i64)..=(l as i64))
                        .map(|m| (s.factor.lighting[index(l, m)].unwrap_or(0.0) - y[index(l, m)]).abs())
                        .fold(0.0, f64::max);
                    e.max(1e-16).log10()
                })
                .collect(),
            err: None,
            dashed: false,
        }
    };
    let gain = |s: &Slice, name: &str| Series {
        name: name.into(),
        x: (1..=LMAX).map(|l| l as f64).collect(),
        y: (1..=LMAX).map(|l| s.factor.orders[l].gain.max(1e-16).log10()).collect(),
        err: None,
        dashed: true,
    };
    let errors = Plot {
        legend: Legend::LowerLeft,
        file: "factorization_error.svg".into(),
        title: "Factorization: log10 max_m |L_lm/P − Y_lm(s)| and log10 gain |Λ_l κ_l|/|Λ_0 κ_0| vs l".into(),
        x_label: "l".into(),
        y_label: "log10".into(),
        curves: vec![gain(glossy, "gain, microfacet"), gain(lambert, "gain, lambert")],
        points: vec![err(glossy, "error, microfacet"), err(lambert, "error, lambert")],
    };
    vec![coeffs, errors]
}

/// Closed-form images of a unit directional source: B = ρ̂ (Beckmann α, F = 1, or Lambert) on the
/// normal-probe grid at exitance (θ_o, φ_o) in degrees, rounded to f32 like a render (tests and the
/// report's picture).
pub fn closed_form(lambert: bool) -> impl FnMut(f64, f64, usize) -> Result<Vec<f64>, String> {
    let s = normalize(SOURCE);
    move |to: f64, po: f64, h: usize| {
        let w = 2 * h;
        Ok((0..w * h)
            .map(|i| {
                let n = latlong_dir(i / w, i % w, w, h);
                let ci = dot(n, s);
                if ci <= 0.0 {
                    return 0.0;
                }
                if lambert {
                    return ci / PI;
                }
                let wo = analysis::projection::normal_probe_outgoing(n, to.to_radians(), po.to_radians());
                let hv = normalize([s[0] + wo[0], s[1] + wo[1], s[2] + wo[2]]);
                let ch = dot(n, hv);
                let d = (-(1.0 - ch * ch) / (ch * ch) / (ALPHA * ALPHA)).exp() / (PI * ALPHA * ALPHA * ch.powi(4));
                let co = dot(n, wo);
                let g = 1.0
                    / (1.0
                        + beckmann_lambda(co.clamp(-1.0, 1.0).acos(), ALPHA)
                        + beckmann_lambda(ci.clamp(-1.0, 1.0).acos(), ALPHA));
                (d * g / (4.0 * co)) as f32 as f64
            })
            .collect())
    }
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let (coarse, fine) = plans(ctx.quick);
    let render = |brdf: BrdfSection| {
        move |theta_o_deg: f64, phi_o_deg: f64, h: usize| -> Result<Vec<f64>, String> {
            let spec = Spec {
                width: 2 * h as u32,
                height: h as u32,
                spp: 1,
                seed: ctx.seed,
                camera: Camera::Probe { theta_o_deg, phi_o_deg },
                lighting: Lighting::Directional { direction: SOURCE, irradiance: 1.0 },
                shape: super::scenes::Shape::Sphere,
                brdf: brdf.clone(),
            };
            let film = render_spec(ctx, &spec)?;
            Ok(Channel::from_film(&film, 0).value)
        }
    };
    let t = std::time::Instant::now();
    let g = (
        measure(coarse, (coarse.n_mu, coarse.n_phi), &mut render(glossy()))?,
        measure(fine, (fine.n_mu, fine.n_phi), &mut render(glossy()))?,
    );
    let l = (
        measure(coarse, LAMBERT_NODES, &mut render(lambert(1.0)))?,
        measure(fine, LAMBERT_NODES, &mut render(lambert(1.0)))?,
    );
    let secs = t.elapsed().as_secs_f64();
    // Determinism: the renderer's own standard error of one node must be 0 (σ = 0 is claimed).
    let spec = Spec {
        width: 2 * fine.height as u32,
        height: fine.height as u32,
        spp: 4,
        seed: ctx.seed,
        camera: Camera::Probe { theta_o_deg: 40.0, phi_o_deg: 100.0 },
        lighting: Lighting::Directional { direction: SOURCE, irradiance: 1.0 },
        shape: super::scenes::Shape::Sphere,
        brdf: glossy(),
    };
    let film = render_spec(ctx, &spec)?;
    let ch = Channel::from_film(&film, 0);
    let worst_se = ch.sigma.iter().cloned().fold(0.0, f64::max);
    let mut c = evaluate((&g.0, &g.1), (&l.0, &l.1), &Prediction::new(ctx.wrong));
    let predicted = closed_form(false)(40.0, 100.0, fine.height)?;
    c.pictures.push(Picture::new(
        "factorization_glossy",
        format!(
            "Beckmann α = {ALPHA} (F = 1) sphere under one directional source, θ_o = 40°, φ_o = 100° (normal probe, \
             4 spp, exact)"
        ),
        "the closed-form BRDF slice ρ(ω_i, ω_o) cos θ_i of one outgoing node (what eq. 18 factors), f32-rounded",
        (ch.width, ch.height),
        ch.value.clone(),
        predicted.clone(),
        predicted.iter().map(|v| (F32_FLOOR * v.abs()).max(1e-12)).collect(),
    ));
    c.push(
        Row::new("determinism: max per-pixel stderr of a 4-spp render (σ = 0 claimed)", 0.0, worst_se, 0.0)
            .floor(F32_FLOOR * 1e-3),
    );
    c.note(format!(
        "coarse: {}×{} normals (Fejér), {} μ × {} φ nodes; fine: {}×{}, {} × {}; lambert {} × {} nodes; source {:?} (unit irradiance), renders {:.1} s",
        2 * coarse.height,
        coarse.height,
        coarse.n_mu,
        coarse.n_phi,
        2 * fine.height,
        fine.height,
        fine.n_mu,
        fine.n_phi,
        LAMBERT_NODES.0,
        LAMBERT_NODES.1,
        normalize(SOURCE),
        secs
    ));
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn right_prediction_passes_and_wrong_ones_fail() {
        // The quick mode's two resolutions, on closed-form images (f32-rounded like a render).
        let (coarse, fine) = plans(true);
        let g = (
            measure(coarse, (coarse.n_mu, coarse.n_phi), &mut closed_form(false)).unwrap(),
            measure(fine, (fine.n_mu, fine.n_phi), &mut closed_form(false)).unwrap(),
        );
        let l = (
            measure(coarse, LAMBERT_NODES, &mut closed_form(true)).unwrap(),
            measure(fine, LAMBERT_NODES, &mut closed_form(true)).unwrap(),
        );
        let good = evaluate((&g.0, &g.1), (&l.0, &l.1), &Prediction::new(false));
        assert!(good.passed(), "{:?}", good.rows.iter().filter(|r| !r.informative && !r.passed()).collect::<Vec<_>>());
        assert!(good.rows.iter().any(|r| r.label.contains("ambiguous") && !r.informative));
        let bad = evaluate((&g.0, &g.1), (&l.0, &l.1), &Prediction::new(true));
        assert!(!bad.passed());
        // Each wrong part fails on its own.
        let p = Prediction::new(false);
        let off = Prediction { source: rotated(SOURCE, 3.0), ..p.clone() };
        assert!(!evaluate((&g.0, &g.1), (&l.0, &l.1), &off).passed(), "source 3° off must fail");
        let soft = Prediction { filter: beckmann_normal_exitance(1.2 * ALPHA, LMAX_FILTER), ..p };
        assert!(!evaluate((&g.0, &g.1), (&l.0, &l.1), &soft).passed(), "α × 1.2 must fail");
        // A glossy light field fed as "Lambert" has κ_3 ≠ 0: the ambiguity row fails.
        let mixed = evaluate((&g.0, &g.1), (&g.0, &g.1), &Prediction::new(false));
        assert!(mixed.rows.iter().any(|r| r.label.contains("ambiguous") && !r.passed()));
    }
}
