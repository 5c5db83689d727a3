//! Check 10, any convex shape (sec. 2.1): under distant lighting, the reflected light of a convex
//! object depends only on the surface normal, so the same B(n) — and the same Λ_l ρ̂_l — must come
//! out of (a) the `normal-probe` path, (b) orthographic renders of a sphere from six directions
//! (±x, ±y, ±z) analysed by least squares, and (c) the same orthographic views of an icosphere
//! mesh (4 subdivisions, 5120 triangles, smooth vertex normals, through the BVH).
//!
//! Lambertian (albedo 1) under an SH lighting l ≤ 6 (exact L_lm). In the orthographic views each
//! pixel is the box-filtered mean of B over its footprint, so the model column S_l of the fit is
//! averaged over a 4 × 4 grid of the pixel's footprint on the sphere (exact geometry; its midpoint
//! error is far below the noise). For the mesh the footprint normals are shifted so that their
//! mean is the render's `normal` layer (the mesh's interpolated shading normal). Only pixels fully
//! covered and seen at cosθ_o ≥ 0.5 are used (six such caps cover the sphere).
//! Rows: each path's Λ_l ρ̂_l vs eq. 38/π, and the differences orthographic − probe and
//! mesh − probe vs 0 (σ combined: independent renders).
//! Wrong prediction: eq. 38 × 1.05.

use super::Ctx;
use super::check::{Check, Plot, Row};
use super::filter::{self, Measured};
use super::fit::{Channel, dot, fit_filter_probe, lsq, normalize, order_parts, view_basis};
use super::picture::Picture;
use super::scenes::lambert;
use super::scenes::{Camera, Lighting, Shape, Spec, render_spec, sh_lighting};
use super::transfer;
use analysis::sh::{ShBasis, num_coefficients};
use std::fmt::Write;

pub const NAME: &str = "convex-shape";
pub const EQUATION: &str = "sec. 2.1";
pub const LMAX: usize = 6;
const EXTENT: f64 = 1.05;
const SUB: usize = 4;

/// The six view directions (camera position) and their up vectors.
pub fn views() -> [([f64; 3], [f64; 3]); 6] {
    let z = [0.0, 0.0, 1.0];
    let x = [1.0, 0.0, 0.0];
    [
        ([3.0, 0.0, 0.0], z),
        ([-3.0, 0.0, 0.0], z),
        ([0.0, 3.0, 0.0], z),
        ([0.0, -3.0, 0.0], z),
        ([0.0, 0.0, 3.0], x),
        ([0.0, 0.0, -3.0], x),
    ]
}

/// Adds the fit rows of one orthographic view (camera at `from`, looking at the origin).
/// `use_layer`: shift the footprint normals to the render's normal layer (meshes).
/// Design matrix rows, pixel values and their σ accumulated over views.
#[derive(Default)]
pub struct Design {
    pub rows: Vec<Vec<f64>>,
    pub value: Vec<f64>,
    pub sigma: Vec<f64>,
}

pub fn add_view_rows(ch: &Channel, from: [f64; 3], up: [f64; 3], light: &[f64], use_layer: bool, d: &mut Design) {
    let [f, right, upp] = view_basis(from, up);
    let (w, h) = (ch.width, ch.height);
    let basis = ShBasis::new(LMAX);
    let mut y = vec![0.0; num_coefficients(LMAX)];
    let mut s = vec![0.0; LMAX + 1];
    for r in 0..h {
        'pix: for c in 0..w {
            let i = r * w + c;
            if ch.mask[i] < 0.999 {
                continue;
            }
            let mut normals = [[0.0; 3]; SUB * SUB];
            let mut mean = [0.0; 3];
            for a in 0..SUB {
                for b in 0..SUB {
                    let x = EXTENT * (2.0 * (c as f64 + (b as f64 + 0.5) / SUB as f64) / w as f64 - 1.0);
                    let yy = EXTENT
                        * (h as f64 / w as f64)
                        * (1.0 - 2.0 * (r as f64 + (a as f64 + 0.5) / SUB as f64) / h as f64);
                    let q = 1.0 - x * x - yy * yy;
                    if q <= 0.25 {
                        // Outside the disk, or cosθ_o < 0.5 at some footprint point.
                        continue 'pix;
                    }
                    let zc = q.sqrt();
                    let n = [0, 1, 2].map(|k| x * right[k] + yy * upp[k] - zc * f[k]);
                    normals[a * SUB + b] = n;
                    for k in 0..3 {
                        mean[k] += n[k];
                    }
                }
            }
            let mean = normalize(mean);
            let shift = if use_layer {
                let nl = ch.normal[i];
                if dot(nl, nl) < 0.5 {
                    continue;
                }
                [nl[0] - mean[0], nl[1] - mean[1], nl[2] - mean[2]]
            } else {
                [0.0; 3]
            };
            let mut col = vec![0.0; LMAX + 1];
            for n in &normals {
                let n = normalize([n[0] + shift[0], n[1] + shift[1], n[2] + shift[2]]);
                order_parts(&basis, light, n, &mut y, &mut s);
                for l in 0..=LMAX {
                    col[l] += s[l] / (SUB * SUB) as f64;
                }
            }
            d.rows.push(col);
            d.value.push(ch.value[i]);
            d.sigma.push(ch.sigma[i]);
        }
    }
}

/// Rows: each path vs the prediction, and the orthographic paths minus the probe.
pub fn evaluate(probe: &Measured, ortho: &Measured, mesh: &Measured, pred: &[f64]) -> Check {
    let mut c = Check::new(
        NAME,
        EQUATION,
        "normal-probe, orthographic multi-view sphere and icosphere mesh give the same Λ_l ρ̂_l",
    );
    filter::rows(&mut c, "normal-probe", probe, pred, None, false);
    filter::rows(&mut c, "ortho sphere", ortho, pred, None, false);
    filter::rows(&mut c, "ortho icosphere", mesh, pred, None, false);
    for (label, m) in [("ortho sphere − probe", ortho), ("ortho icosphere − probe", mesh)] {
        for l in 0..probe.a.len() {
            c.push(Row::new(format!("{label} l={l}"), 0.0, m.a[l] - probe.a[l], m.sigma[l].hypot(probe.sigma[l])));
        }
    }
    c
}

/// Writes the icosphere OBJ (positions and normals) used by the mesh renders.
pub fn write_icosphere(path: &std::path::Path, subdivisions: u32) -> Result<(), String> {
    let m = renderer::geometry::icosphere::icosphere(subdivisions);
    let mut s = String::new();
    let _ = writeln!(s, "# icosphere, {subdivisions} subdivisions, written by reflect verify");
    for p in &m.positions {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    for p in &m.positions {
        let n = p.normalize();
        let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
    }
    for t in &m.triangles {
        let _ = writeln!(s, "f {0}//{0} {1}//{1} {2}//{2}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(path, s).map_err(|e| format!("{}: {e}", path.display()))
}

/// The per-order fit over the six views, and the first view's render (for the report's picture).
fn fit_views(ctx: &Ctx, light: &[f64], shape: Shape, use_layer: bool) -> Result<(Measured, Channel), String> {
    let size = if ctx.quick { 64 } else { 128 };
    let mut d = Design::default();
    let mut first = None;
    for (from, up) in views() {
        let spec = Spec {
            width: size,
            height: size,
            spp: ctx.spp(32, 256),
            seed: ctx.seed + 10,
            camera: Camera::Ortho { from, up, extent: EXTENT },
            lighting: Lighting::Sh(light.to_vec()),
            shape: shape.clone(),
            brdf: lambert(1.0),
        };
        let ch = Channel::from_film(&render_spec(ctx, &spec)?, 0);
        add_view_rows(&ch, from, up, light, use_layer, &mut d);
        first.get_or_insert(ch);
    }
    let weight = vec![1.0; d.rows.len()];
    let fit = lsq(&d.rows, &d.value, &d.sigma, &weight).ok_or("singular orthographic fit")?;
    Ok((Measured::from_fit(&fit, LMAX), first.unwrap_or_default()))
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let light = sh_lighting(LMAX, 0.5, ctx.seed + 5);
    let spec = Spec::probe(ctx, ctx.spp(128, 256), Lighting::Sh(light.clone()), lambert(1.0));
    let film = render_spec(ctx, &spec)?;
    let probe =
        Measured::from_fit(&fit_filter_probe(&Channel::from_film(&film, 0), &light, LMAX).ok_or("singular fit")?, LMAX);
    let (ortho, _) = fit_views(ctx, &light, Shape::Sphere, false)?;
    std::fs::create_dir_all(&ctx.out).map_err(|e| format!("{}: {e}", ctx.out.display()))?;
    let obj = ctx.out.join("icosphere4.obj");
    write_icosphere(&obj, 4)?;
    let obj_abs = std::fs::canonicalize(&obj).map_err(|e| format!("{}: {e}", obj.display()))?;
    let (mesh, view) = fit_views(ctx, &light, Shape::Mesh(obj_abs.display().to_string()), true)?;
    let pred: Vec<f64> = transfer::lambert(LMAX).iter().map(|v| v * if ctx.wrong { 1.05 } else { 1.0 }).collect();
    let mut c = evaluate(&probe, &ortho, &mesh, &pred);
    c.pictures.push(Picture::normals_filter(
        "convex_shape_icosphere",
        format!(
            "Lambertian icosphere (5120 triangles, smooth normals), orthographic view {0}×{0}, {1} spp",
            view.width,
            ctx.spp(32, 256)
        ),
        "eq. 38/π filter applied to the lighting at each pixel's normal layer (pixels the mesh fully covers)",
        &view,
        &light,
        &pred,
    ));
    c.note(format!(
        "Lambert under SH lighting l ≤ {LMAX}; six orthographic views {0}×{0}, {1} spp; icosphere: 4 subdivisions (5120 triangles) written to {2}",
        if ctx.quick { 64 } else { 128 },
        ctx.spp(32, 256),
        obj.display()
    ));
    c.plots.push(Plot {
        legend: super::check::Legend::MiddleRight,
        file: "convex_shape.svg".into(),
        title: "Any convex shape: Λ_l ρ̂_l from three paths (Lambert)".into(),
        x_label: "l".into(),
        y_label: "Λ_l ρ̂_l".into(),
        curves: vec![filter::curve("eq. 38 / π", &transfer::lambert(LMAX))],
        points: vec![
            probe.series("normal-probe"),
            ortho.series("orthographic sphere"),
            mesh.series("orthographic icosphere"),
        ],
    });
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differences_and_wrong_predictions_fail() {
        // Three independent paths: eq. 38/π's closed values (docs/src/conventions.md §4), each with its own
        // scatter of ±σ (σ = 0.005), so both the per-path rows and the difference rows see noise.
        let exact = [1.0, 2.0 / 3.0, 0.25, 0.0, -1.0 / 24.0, 0.0, 1.0 / 64.0];
        let path = |shift: usize| {
            let a: Vec<f64> = (0..=LMAX).map(|l| exact[l] + 0.005 * [-1.0, 1.0, 0.5, -0.5][(l + shift) % 4]).collect();
            Measured { sigma: vec![0.005; a.len()], a }
        };
        let (probe, ortho, mesh) = (path(0), path(1), path(2));
        let a = transfer::lambert(LMAX);
        assert!(evaluate(&probe, &ortho, &mesh, &a).passed());
        let m = probe.clone();
        let wrong: Vec<f64> = a.iter().map(|v| v * 1.05).collect();
        assert!(!evaluate(&probe, &ortho, &mesh, &wrong).passed());
        // A mesh path that reflects differently (e.g. flat-shaded facets) fails the difference rows.
        let mut other = m.clone();
        other.a[2] += 0.05;
        assert!(!evaluate(&m, &m, &other, &a).passed());
    }

    #[test]
    fn view_columns_match_the_probe_columns_for_a_smooth_image() {
        // A synthetic orthographic image of B(n) = S(n) (a_l = 1) fitted by add_view_rows gives a_l = 1.
        let light = sh_lighting(LMAX, 0.5, 2);
        let basis = ShBasis::new(LMAX);
        let (from, up) = views()[0];
        let w = 48;
        let mut ch = Channel { width: w, height: w, ..Default::default() };
        let [f, right, upp] = view_basis(from, up);
        let mut y = vec![0.0; num_coefficients(LMAX)];
        let mut s = vec![0.0; LMAX + 1];
        for r in 0..w {
            for c in 0..w {
                // Box-filtered value by a fine 8 × 8 average.
                let (mut v, mut inside) = (0.0, true);
                for a in 0..8 {
                    for b in 0..8 {
                        let x = EXTENT * (2.0 * (c as f64 + (b as f64 + 0.5) / 8.0) / w as f64 - 1.0);
                        let yy = EXTENT * (1.0 - 2.0 * (r as f64 + (a as f64 + 0.5) / 8.0) / w as f64);
                        let q = 1.0 - x * x - yy * yy;
                        if q <= 0.0 {
                            inside = false;
                            continue;
                        }
                        let n = [0, 1, 2].map(|k| x * right[k] + yy * upp[k] - q.sqrt() * f[k]);
                        order_parts(&basis, &light, n, &mut y, &mut s);
                        v += s.iter().sum::<f64>() / 64.0;
                    }
                }
                ch.value.push(v);
                ch.sigma.push(1e-3);
                ch.mask.push(if inside { 1.0 } else { 0.0 });
                ch.normal.push([0.0; 3]);
            }
        }
        let mut d = Design::default();
        add_view_rows(&ch, from, up, &light, false, &mut d);
        let fit = lsq(&d.rows, &d.value, &d.sigma, &vec![1.0; d.rows.len()]).unwrap();
        // Only one cap is seen, so high orders are poorly conditioned; l ≤ 2 are well determined.
        for l in 0..=2 {
            assert!((fit.coef[l] - 1.0).abs() < 1e-3, "l={l}: {}", fit.coef[l]);
        }
    }
}
