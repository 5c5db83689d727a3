//! Check "subspace" (sec. 3.5; refs. \[1\], \[6\], \[7\]; issue 19): "images of a diffuse object under all
//! possible illumination conditions lie close to a 9D subspace."
//!
//! Image sets: a Lambertian (albedo 1) sphere through the `normal-probe` camera (pixels weighted by
//! their solid angle: the PCA of B over the sphere of normals) and the icosphere mesh of the
//! `convex-shape` check through an orthographic camera (fully covered pixels, equal weights: the PCA
//! of the image as a camera sees it), each under the same set of [`lightings`] drawn at random from
//! the seed: single directional sources, positive sums of 2–5 of them (the sum of their renders —
//! rendering is linear in the lighting, and the renders are independent, so σ² adds), random
//! non-negative band-limited fields (SH l ≤ 4, made non-negative on a fine grid by their constant
//! term) and rotations of the Grace probe (green channel).
//!
//! Rows, per object (X: the P × N image matrix, W the pixel weights):
//! - e_k, the energy captured by the first k principal components (uncentred PCA: eigenvalues of
//!   the Gram matrix XᵀWX, whose diagonal is debiased by the renders' noise Σ_p w_p σ_pj²), for
//!   k = 5, 9, 15 (deciding). σ to first order: δe_k = (2/T) Σ_jp w_p n_pj \[(XQ_k)_pj − e_k X_pj\]
//!   with Q_k the projector on the first k eigenvectors and T the trace.
//! - ρ, the energy fraction of the images outside the span of Y_lm (l ≤ 2) sampled at the pixels'
//!   normals (weighted least squares; deciding), debiased by the noise outside the span
//!   Σ_jp w_p σ_pj² (1 − h_p), h_p the leverage; σ by the same first-order rule.
//! - the principal angles between the first 9 components and that span (informative: the largest
//!   and the rms angle). The mesh view sees one hemisphere of normals, on which the nine Y_lm are
//!   nearly dependent (the weakest direction of their span carries ≈ 1e-3 of the energy), so its
//!   last angles are large even for the analytic images: the energy rows, not the angles, decide.
//!
//! Expected: the same statistics computed from the analytic images of the same lightings on the same
//! pixels, B(n) = Σ_l A_l L_lm Y_lm(n) with eq. 38 (closed form max(n·s, 0)/π for a directional
//! source; Grace's L_lm to l = 16 rotated exactly, [`analysis::sh::rotation`]). The mesh's pixels
//! average B over their footprint: the prediction averages over a 4 × 4 grid of the footprint on
//! the sphere shifted to the render's `normal` layer (as `convex-shape`); its error is stated as the
//! change from a 2 × 2 grid. Also reported (informative): e_k of the isotropic ensemble of
//! directional sources, from the eigenvalues A_l²·(multiplicity 2l+1) — e_9 = 127/128.
//!
//! Wrong prediction: the 9D claim with the Lambertian filter replaced by a Phong s = 8 filter (a
//! BRDF whose images do not lie near a 9D subspace), i.e. e_k and ρ of such an ensemble.

use super::Ctx;
use super::check::{Check, F32_FLOOR, Legend, Plot, Row, Series};
use super::fit::{Channel, dot, latlong_dir, latlong_omega, normalize, view_basis};
use super::picture::Picture;
use super::scenes::lambert;
use super::scenes::{Camera, Lighting, Shape, Spec, render_spec};
use super::{grace, transfer};
use analysis::sh::rotation::{Rotation, rotate_coefficients};
use analysis::sh::{ShBasis, lm, num_coefficients};
use nalgebra::{DMatrix, SymmetricEigen};
use std::f64::consts::PI;

pub const NAME: &str = "subspace";
pub const EQUATION: &str = "sec. 3.5 (eq. 38)";
/// Numbers of components whose captured energy is reported.
pub const KS: [usize; 3] = [5, 9, 15];
/// Band limit of the random non-negative fields.
pub const LMAX_FIELD: usize = 4;
/// Footprint sub-grid of the mesh prediction.
const SUB: usize = 4;
const EXTENT: f64 = 1.05;
const VIEW: ([f64; 3], [f64; 3]) = ([2.0, -1.5, 1.2], [0.0, 0.0, 1.0]);

/// One lighting of the ensemble.
#[derive(Clone, Debug)]
pub enum Light {
    Directional([f64; 3]),
    /// Σ_i weight_i × directional source `index_i` of the set (its image is the sum of renders).
    Sum(Vec<(usize, f64)>),
    /// Grey SH coefficients, l ≤ [`LMAX_FIELD`], non-negative.
    Field(Vec<f64>),
    /// Grace rotated by `rotate_deg` (docs/src/conventions.md §2, "Rotations").
    Grace([f64; 3]),
}

/// Counts of (directional, sums, fields, Grace rotations) per mode.
pub fn counts(quick: bool) -> (usize, usize, usize, usize) {
    if quick { (40, 36, 20, 4) } else { (60, 60, 32, 8) }
}

fn uniform01(rng: &mut renderer::sampling::chi2::TestRng) -> f64 {
    (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64
}

fn random_dir(rng: &mut renderer::sampling::chi2::TestRng) -> [f64; 3] {
    let z = 2.0 * uniform01(rng) - 1.0;
    let p = 2.0 * PI * uniform01(rng);
    let s = (1.0 - z * z).max(0.0).sqrt();
    [s * p.cos(), s * p.sin(), z]
}

/// A random band-limited field l ≤ LMAX_FIELD, per-order rms ∝ 1/(l+1), whose constant term puts its
/// minimum over a 128 × 64 grid at 10 % of its mean (non-negative with margin; the field's gradient
/// is far too small to dip 10 % between grid nodes 2.8° apart).
pub fn random_field(rng: &mut renderer::sampling::chi2::TestRng) -> Vec<f64> {
    let n = num_coefficients(LMAX_FIELD);
    let mut c: Vec<f64> = (0..n).map(|k| (2.0 * uniform01(rng) - 1.0) / (lm(k).0 as f64 + 1.0)).collect();
    c[0] = 0.0;
    let basis = ShBasis::new(LMAX_FIELD);
    let mut y = vec![0.0; n];
    let (gw, gh) = (128, 64);
    let mut min = f64::INFINITY;
    for p in 0..gw * gh {
        basis.eval_into(latlong_dir(p / gw, p % gw, gw, gh), &mut y);
        min = min.min((0..n).map(|k| c[k] * y[k]).sum());
    }
    // f = c_00 Y_00 + g with min g = `min`: choose c_00 Y_00 = −min / 0.9 so min f = 0.1 c_00 Y_00.
    let y00 = 0.5 / PI.sqrt();
    c[0] = (-min / 0.9).max(0.1) / y00;
    c
}

/// The ensemble of lightings (deterministic in the seed).
pub fn lightings(quick: bool, seed: u64) -> Vec<Light> {
    let (nd, ns, nf, ng) = counts(quick);
    let mut rng = renderer::sampling::chi2::TestRng::new(seed ^ 0x5b5_9ace);
    let mut out: Vec<Light> = (0..nd).map(|_| Light::Directional(random_dir(&mut rng))).collect();
    for _ in 0..ns {
        let k = 2 + (rng.next_u64() % 4) as usize;
        let terms = (0..k).map(|_| ((rng.next_u64() % nd as u64) as usize, 0.2 + 0.8 * uniform01(&mut rng))).collect();
        out.push(Light::Sum(terms));
    }
    for _ in 0..nf {
        out.push(Light::Field(random_field(&mut rng)));
    }
    for _ in 0..ng {
        out.push(Light::Grace([360.0 * uniform01(&mut rng), 180.0 * uniform01(&mut rng), 360.0 * uniform01(&mut rng)]));
    }
    out
}

/// An image set: N images of P pixels with weights, noise and normals.
#[derive(Clone, Debug, Default)]
pub struct ImageSet {
    pub weight: Vec<f64>,
    pub normal: Vec<[f64; 3]>,
    /// images\[j\]\[p\]
    pub images: Vec<Vec<f64>>,
    /// The error bars (the renders' `stderr`, the bound of `renderer::film::pool_heavy_tails`):
    /// what the σ of every fraction, hence every tolerance, is computed from.
    pub sigma: Vec<Vec<f64>>,
    /// The pixels' own standard errors (`stderr_own`), whose squares are unbiased for the noise
    /// variance: what the noise energy Σ w σ² subtracted from the Gram matrix and the energies is
    /// computed from (the bound's square is biased high, and subtracting it would bias the fractions).
    pub sigma_own: Vec<Vec<f64>>,
}

/// PCA of a set: eigenvalues (descending) and eigenvectors (columns, image space) of the debiased Gram matrix.
pub struct Pca {
    pub values: Vec<f64>,
    pub vectors: DMatrix<f64>,
}

pub fn pca(s: &ImageSet) -> Pca {
    let n = s.images.len();
    let mut g = DMatrix::<f64>::zeros(n, n);
    for i in 0..n {
        for j in 0..=i {
            let v: f64 = (0..s.weight.len()).map(|p| s.weight[p] * s.images[i][p] * s.images[j][p]).sum();
            g[(i, j)] = v;
            g[(j, i)] = v;
        }
        let noise: f64 = (0..s.weight.len()).map(|p| s.weight[p] * s.sigma_own[i][p].powi(2)).sum();
        g[(i, i)] -= noise;
    }
    let e = SymmetricEigen::new(g);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| e.eigenvalues[b].total_cmp(&e.eigenvalues[a]));
    let values = order.iter().map(|&i| e.eigenvalues[i]).collect();
    let vectors = DMatrix::from_fn(n, n, |r, c| e.eigenvectors[(r, order[c])]);
    Pca { values, vectors }
}

/// (value, σ) of a fraction f = Σ_j ||Π x_j||² / Σ_j ||x_j||² where `proj(j)` is the part of image j
/// the fraction counts (Π x_j, or (I − Π) x_j): δf = (2/T) Σ_jp w_p n_pj \[proj_pj − f x_pj\].
fn fraction_sigma(s: &ImageSet, f: f64, total: f64, proj: &[Vec<f64>]) -> f64 {
    let mut var = 0.0;
    for (j, x) in s.images.iter().enumerate() {
        for p in 0..s.weight.len() {
            let g = proj[j][p] - f * x[p];
            var += (s.weight[p] * s.sigma[j][p] * g).powi(2);
        }
    }
    2.0 * var.sqrt() / total
}

/// Σ_jp w_p σ_own,pj²: the expected noise energy of the images (debiasing; [`ImageSet::sigma_own`]).
fn noise_energy(s: &ImageSet) -> f64 {
    s.sigma_own.iter().map(|sg| sg.iter().zip(&s.weight).map(|(v, w)| w * v * v).sum::<f64>()).sum()
}

/// e_k ± σ: the energy captured by the first k components.
pub fn captured(s: &ImageSet, pca: &Pca, k: usize) -> (f64, f64) {
    let total: f64 = pca.values.iter().sum();
    let e = pca.values[..k].iter().sum::<f64>() / total;
    // (X Q_k)_j = Σ_i x_i (Q_k)_ij, Q_k = V_k V_kᵀ.
    let q = projector(pca, k);
    let proj: Vec<Vec<f64>> = (0..s.images.len()).map(|j| project(s, &q, j)).collect();
    (e, fraction_sigma(s, e, total, &proj))
}

/// Image j of the set projected onto the span of the first k principal components (the part of it
/// a k-dimensional subspace explains): Σ_i x_i (V_k V_kᵀ)_ij, as in [`captured`].
pub fn reconstruction(s: &ImageSet, pca: &Pca, k: usize, j: usize) -> Vec<f64> {
    project(s, &projector(pca, k), j)
}

/// Q_k = V_k V_kᵀ (n × n, image index space): the projector onto the first k components.
fn projector(pca: &Pca, k: usize) -> DMatrix<f64> {
    let vk = pca.vectors.columns(0, k);
    vk * vk.transpose()
}

/// (X Q)_j = Σ_i x_i Q_ij: image j's part in the span `q` projects onto.
fn project(s: &ImageSet, q: &DMatrix<f64>, j: usize) -> Vec<f64> {
    (0..s.weight.len()).map(|p| (0..s.images.len()).map(|i| s.images[i][p] * q[(i, j)]).sum()).collect()
}

/// The report's picture of one object: its render under lighting j (full W × H image, NaN off the
/// set's pixels) against that image's part in the first 9 principal components of the measured set.
fn picture(stem: &str, object: &str, px: &Pixels, (w, h): (usize, usize), m: &ImageSet, j: usize) -> Picture {
    let nine = reconstruction(m, &pca(m), 9, j);
    let (mut measured, mut predicted, mut sigma) = (vec![f64::NAN; w * h], vec![f64::NAN; w * h], vec![0.0; w * h]);
    for (q, &p) in px.index.iter().enumerate() {
        measured[p] = m.images[j][q];
        predicted[p] = nine[q];
        sigma[p] = m.sigma[j][q];
    }
    Picture::new(
        stem,
        format!("{object}, lighting {} of {} (a rotation of Grace, green)", j + 1, m.images.len()),
        "the image's projection onto the first 9 principal components of all the measured images",
        (w, h),
        measured,
        predicted,
        sigma,
    )
}

/// A W-orthonormal basis (columns P × 9) of Y_lm (l ≤ 2) at the set's normals (modified Gram–Schmidt).
pub fn y_basis(s: &ImageSet) -> Vec<Vec<f64>> {
    let basis = ShBasis::new(2);
    let mut cols: Vec<Vec<f64>> = vec![vec![0.0; s.normal.len()]; 9];
    let mut y = vec![0.0; 9];
    for (p, n) in s.normal.iter().enumerate() {
        basis.eval_into(*n, &mut y);
        for k in 0..9 {
            cols[k][p] = y[k];
        }
    }
    orthonormalize(&mut cols, &s.weight);
    cols
}

fn wdot(a: &[f64], b: &[f64], w: &[f64]) -> f64 {
    a.iter().zip(b).zip(w).map(|((x, y), w)| x * y * w).sum()
}

fn orthonormalize(cols: &mut [Vec<f64>], w: &[f64]) {
    for i in 0..cols.len() {
        for j in 0..i {
            let d = wdot(&cols[i], &cols[j], w);
            let cj = cols[j].clone();
            cols[i].iter_mut().zip(&cj).for_each(|(a, b)| *a -= d * b);
        }
        let n = wdot(&cols[i], &cols[i], w).sqrt();
        cols[i].iter_mut().for_each(|a| *a /= n);
    }
}

/// ρ ± σ: the energy fraction outside span{Y_lm(n_p), l ≤ 2}.
pub fn outside_span(s: &ImageSet, yb: &[Vec<f64>]) -> (f64, f64) {
    let np = s.weight.len();
    let leverage: Vec<f64> = (0..np).map(|p| s.weight[p] * yb.iter().map(|c| c[p] * c[p]).sum::<f64>()).collect();
    let mut resid = vec![];
    let (mut out, mut tot) = (0.0, 0.0);
    for x in &s.images {
        let mut r = x.clone();
        for c in yb {
            let d = wdot(x, c, &s.weight);
            r.iter_mut().zip(c).for_each(|(a, b)| *a -= d * b);
        }
        out += wdot(&r, &r, &s.weight);
        tot += wdot(x, x, &s.weight);
        resid.push(r);
    }
    for sg in &s.sigma_own {
        for p in 0..np {
            out -= s.weight[p] * sg[p] * sg[p] * (1.0 - leverage[p]);
        }
    }
    tot -= noise_energy(s);
    let f = out / tot;
    (f, fraction_sigma(s, f, tot, &resid))
}

/// Principal angles (degrees, ascending) between the first k components and the span `yb`.
pub fn principal_angles(s: &ImageSet, pca: &Pca, k: usize, yb: &[Vec<f64>]) -> Vec<f64> {
    let np = s.weight.len();
    let mut u: Vec<Vec<f64>> = (0..k)
        .map(|c| (0..np).map(|p| (0..s.images.len()).map(|j| s.images[j][p] * pca.vectors[(j, c)]).sum()).collect())
        .collect();
    orthonormalize(&mut u, &s.weight);
    let m = DMatrix::from_fn(k, yb.len(), |i, j| wdot(&u[i], &yb[j], &s.weight));
    let mut angles: Vec<f64> = m.singular_values().iter().map(|c| c.clamp(-1.0, 1.0).acos().to_degrees()).collect();
    angles.sort_by(|a, b| a.total_cmp(b));
    angles
}

/// e_k of the isotropic ensemble of directional sources for a transfer function a_l (l ≤ lmax):
/// eigenvalues a_l² with multiplicity 2l+1.
pub fn isotropic_captured(a: &[f64], k: usize) -> f64 {
    let mut ev: Vec<f64> = a.iter().enumerate().flat_map(|(l, v)| std::iter::repeat_n(v * v, 2 * l + 1)).collect();
    ev.sort_by(|x, y| y.total_cmp(x));
    ev[..k].iter().sum::<f64>() / ev.iter().sum::<f64>()
}

/// Statistics of one set.
#[derive(Clone, Debug)]
pub struct Stats {
    pub captured: Vec<(f64, f64)>,
    pub outside: (f64, f64),
    pub angles: Vec<f64>,
    pub spectrum: Vec<f64>,
}

pub fn stats(s: &ImageSet) -> Stats {
    let p = pca(s);
    let yb = y_basis(s);
    Stats {
        captured: KS.iter().map(|&k| captured(s, &p, k)).collect(),
        outside: outside_span(s, &yb),
        angles: principal_angles(s, &p, 9, &yb),
        spectrum: p.values.clone(),
    }
}

/// Rows of one object: measured vs predicted statistics (`approx`: stated prediction error per
/// statistic, \[e_5, e_9, e_15, ρ\]).
pub fn rows(c: &mut Check, object: &str, m: &Stats, pred: &Stats, approx: [f64; 4], iso: &[f64]) {
    for (i, &k) in KS.iter().enumerate() {
        let (v, s) = m.captured[i];
        c.push(
            Row::new(format!("{object}: energy in the first {k} components e_{k}"), pred.captured[i].0, v, s)
                .approx(approx[i])
                .floor(F32_FLOOR),
        );
        c.push(Row::new(format!("{object}: e_{k} of the isotropic directional ensemble"), iso[i], v, s).informative());
    }
    let (v, s) = m.outside;
    c.push(
        Row::new(format!("{object}: energy outside span Y_lm (l ≤ 2)"), pred.outside.0, v, s)
            .approx(approx[3])
            .floor(F32_FLOOR),
    );
    let last = |a: &[f64]| a.last().copied().unwrap_or(f64::NAN);
    let rms = |a: &[f64]| (a.iter().map(|v| v * v).sum::<f64>() / a.len().max(1) as f64).sqrt();
    c.push(
        Row::new(
            format!("{object}: largest principal angle, 9 PCs vs Y_lm (l ≤ 2) (deg)"),
            last(&pred.angles),
            last(&m.angles),
            0.0,
        )
        .informative(),
    );
    c.push(
        Row::new(format!("{object}: rms principal angle (deg)"), rms(&pred.angles), rms(&m.angles), 0.0).informative(),
    );
}

/// The analytic image of a lighting at a normal, for a transfer a_l (Lambert: eq. 38 / π).
struct Predictor {
    a: Vec<f64>,
    basis: ShBasis,
    /// Lambert's closed form for directional sources (exact) or the SH series (the wrong filter).
    closed_form: bool,
}

impl Predictor {
    fn value(&self, light: &Light, dirs: &[[f64; 3]], coeffs: &[Vec<f64>], n: [f64; 3], y: &mut [f64]) -> f64 {
        let series = |c: &[f64], y: &mut [f64]| -> f64 {
            self.basis.eval_into(n, y);
            c.iter().enumerate().take(y.len()).map(|(k, v)| self.a[lm(k).0] * v * y[k]).sum()
        };
        let dir = |s: [f64; 3], y: &mut [f64]| -> f64 {
            if self.closed_form {
                dot(n, s).max(0.0) / PI
            } else {
                let c = self.basis.eval(s);
                series(&c, y)
            }
        };
        match light {
            Light::Directional(s) => dir(*s, y),
            Light::Sum(t) => t.iter().map(|(i, wt)| wt * dir(dirs[*i], y)).sum(),
            Light::Field(_) | Light::Grace(_) => series(&coeffs[0], y),
        }
    }
}

/// Pixel geometry of one object: weights, normals, and per pixel the footprint normals used by the
/// prediction (one entry for the probe).
pub struct Pixels {
    pub index: Vec<usize>,
    pub weight: Vec<f64>,
    pub normal: Vec<[f64; 3]>,
    pub footprint: Vec<Vec<[f64; 3]>>,
    pub footprint_coarse: Vec<Vec<[f64; 3]>>,
}

/// Footprint normals of orthographic pixel (r, c) on the unit sphere, `sub` × `sub`, shifted so their
/// mean is `layer`. None when a footprint point misses the sphere.
fn footprint(r: usize, c: usize, w: usize, h: usize, sub: usize, layer: [f64; 3]) -> Option<Vec<[f64; 3]>> {
    let (from, up) = VIEW;
    let [f, right, upp] = view_basis(from, up);
    let mut ns = vec![];
    let mut mean = [0.0; 3];
    for a in 0..sub {
        for b in 0..sub {
            let x = EXTENT * (2.0 * (c as f64 + (b as f64 + 0.5) / sub as f64) / w as f64 - 1.0);
            let yy =
                EXTENT * (h as f64 / w as f64) * (1.0 - 2.0 * (r as f64 + (a as f64 + 0.5) / sub as f64) / h as f64);
            let q = 1.0 - x * x - yy * yy;
            if q <= 0.0 {
                return None;
            }
            let n = [0, 1, 2].map(|k| x * right[k] + yy * upp[k] - q.sqrt() * f[k]);
            (0..3).for_each(|k| mean[k] += n[k]);
            ns.push(n);
        }
    }
    let mean = normalize(mean);
    let shift = [0, 1, 2].map(|k| layer[k] - mean[k]);
    Some(ns.into_iter().map(|n| normalize([0, 1, 2].map(|k| n[k] + shift[k]))).collect())
}

/// The probe's pixels (every pixel, solid-angle weights).
pub fn probe_pixels(w: usize, h: usize) -> Pixels {
    let normal: Vec<[f64; 3]> = (0..w * h).map(|p| latlong_dir(p / w, p % w, w, h)).collect();
    Pixels {
        index: (0..w * h).collect(),
        weight: (0..w * h).map(|p| latlong_omega(p / w, w, h)).collect(),
        footprint: normal.iter().map(|n| vec![*n]).collect(),
        footprint_coarse: normal.iter().map(|n| vec![*n]).collect(),
        normal,
    }
}

/// The mesh view's pixels: fully covered (mask ≥ 0.999) with a normal layer, equal weights.
pub fn mesh_pixels(ch: &Channel) -> Pixels {
    let (w, h) = (ch.width, ch.height);
    let mut px = Pixels { index: vec![], weight: vec![], normal: vec![], footprint: vec![], footprint_coarse: vec![] };
    for p in 0..w * h {
        let nl = ch.normal[p];
        if ch.mask[p] < 0.999 || dot(nl, nl) < 0.5 {
            continue;
        }
        let nl = normalize(nl);
        let (Some(fine), Some(coarse)) = (footprint(p / w, p % w, w, h, SUB, nl), footprint(p / w, p % w, w, h, 2, nl))
        else {
            continue;
        };
        px.index.push(p);
        px.weight.push(1.0);
        px.normal.push(nl);
        px.footprint.push(fine);
        px.footprint_coarse.push(coarse);
    }
    px
}

/// The measured set from per-lighting renders (value, σ, own σ per image pixel), and the two predicted sets
/// (fine and coarse footprint) with transfer `a` (closed form for Lambert).
pub fn build_sets(
    px: &Pixels,
    lights: &[Light],
    renders: &[Render],
    field_coeffs: &[Vec<f64>],
    wrong: bool,
) -> (ImageSet, ImageSet, ImageSet) {
    let dirs: Vec<[f64; 3]> =
        lights.iter().filter_map(|l| if let Light::Directional(s) = l { Some(*s) } else { None }).collect();
    let lmax = grace::LMAX;
    let a: Vec<f64> = if wrong { transfer::phong(8.0, lmax) } else { transfer::lambert(lmax) };
    let pr = Predictor { a, basis: ShBasis::new(lmax), closed_form: !wrong };
    let mut measured = ImageSet { weight: px.weight.clone(), normal: px.normal.clone(), ..Default::default() };
    let mut fine = ImageSet { weight: px.weight.clone(), normal: px.normal.clone(), ..Default::default() };
    let mut coarse = fine.clone();
    let mut y = vec![0.0; num_coefficients(lmax)];
    for (j, light) in lights.iter().enumerate() {
        let (mut v, mut s, mut so) = (vec![], vec![], vec![]);
        for &p in &px.index {
            let (x, s2, so2) = match light {
                Light::Sum(t) => t.iter().fold((0.0, 0.0, 0.0), |(x, s2, so2), (i, wt)| {
                    let r = &renders[*i];
                    (x + wt * r.value[p], s2 + (wt * r.sigma[p]).powi(2), so2 + (wt * r.sigma_own[p]).powi(2))
                }),
                _ => {
                    let r = &renders[j];
                    (r.value[p], r.sigma[p].powi(2), r.sigma_own[p].powi(2))
                }
            };
            v.push(x);
            s.push(s2.sqrt());
            so.push(so2.sqrt());
        }
        measured.images.push(v);
        measured.sigma.push(s);
        measured.sigma_own.push(so);
        let coeffs = std::slice::from_ref(&field_coeffs[j]);
        let mut predict = |fp: &[Vec<[f64; 3]>]| -> Vec<f64> {
            fp.iter()
                .map(|ns| ns.iter().map(|n| pr.value(light, &dirs, coeffs, *n, &mut y)).sum::<f64>() / ns.len() as f64)
                .collect()
        };
        fine.images.push(predict(&px.footprint));
        coarse.images.push(predict(&px.footprint_coarse));
    }
    fine.sigma = vec![vec![0.0; px.index.len()]; lights.len()];
    fine.sigma_own = fine.sigma.clone();
    coarse.sigma = fine.sigma.clone();
    coarse.sigma_own = fine.sigma.clone();
    (measured, fine, coarse)
}

/// One render's channel: value, error bar (`stderr`) and own σ (`stderr_own`) per image pixel.
#[derive(Clone, Debug, Default)]
pub struct Render {
    pub value: Vec<f64>,
    pub sigma: Vec<f64>,
    pub sigma_own: Vec<f64>,
}

/// The renders of each lighting, in the ensemble's order.
type Renders = Vec<Render>;

/// Renders every lighting of the ensemble for one camera (sums: empty).
fn render_all(
    ctx: &Ctx,
    lights: &[Light],
    mk: &dyn Fn(Lighting, u32, u64) -> Spec,
    spp: (u32, u32),
) -> Result<Renders, String> {
    let mut out = vec![];
    for (j, l) in lights.iter().enumerate() {
        let seed = ctx.seed + 7000 + j as u64;
        let (lighting, n, channel) = match l {
            Light::Directional(s) => (Lighting::Directional { direction: *s, irradiance: 1.0 }, spp.0, 0),
            Light::Sum(_) => {
                out.push(Render::default());
                continue;
            }
            Light::Field(c) => (Lighting::Sh(c.clone()), spp.1, 0),
            Light::Grace(r) => (Lighting::GraceRotated { scale: 1.0, rotate_deg: *r }, spp.1, grace::CHANNEL),
        };
        let ch = Channel::from_film(&render_spec(ctx, &mk(lighting, n, seed))?, channel);
        out.push(Render { value: ch.value, sigma: ch.sigma, sigma_own: ch.sigma_own });
    }
    Ok(out)
}

/// SH coefficients of each lighting where it is a field or Grace (l ≤ grace::LMAX; empty otherwise).
fn field_coefficients(ctx: &Ctx, lights: &[Light]) -> Result<Vec<Vec<f64>>, String> {
    let g = if lights.iter().any(|l| matches!(l, Light::Grace(_))) { grace::coefficients(ctx)? } else { vec![] };
    Ok(lights
        .iter()
        .map(|l| match l {
            Light::Field(c) => c.clone(),
            Light::Grace(r) => {
                let rgb: Vec<[f64; 3]> = g.iter().map(|v| [*v; 3]).collect();
                rotate_coefficients(&rgb, &Rotation::from_xyz_deg(*r)).iter().map(|v| v[0]).collect()
            }
            _ => vec![],
        })
        .collect())
}

fn spectrum_plot(file: &str, object: &str, m: &Stats, pred: &Stats) -> Plot {
    let lg = |v: &[f64]| -> Vec<f64> {
        let t: f64 = v.iter().sum();
        v.iter().take(30).map(|x| (x / t).max(1e-12).log10()).collect()
    };
    let xs = |n: usize| (1..=n.min(30)).map(|i| i as f64).collect::<Vec<_>>();
    Plot {
        legend: Legend::UpperRight,
        file: file.into(),
        title: format!("Subspace: PCA spectrum of the {object} images (λ_i / Σλ), first 30"),
        x_label: "component i".into(),
        y_label: "log10 λ_i/Σλ".into(),
        curves: vec![Series {
            name: "analytic images".into(),
            x: xs(pred.spectrum.len()),
            y: lg(&pred.spectrum),
            err: None,
            dashed: false,
        }],
        points: vec![Series {
            name: "renders".into(),
            x: xs(m.spectrum.len()),
            y: lg(&m.spectrum),
            err: None,
            dashed: false,
        }],
    }
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let lights = lightings(ctx.quick, ctx.seed);
    let coeffs = field_coefficients(ctx, &lights)?;
    let lambert = lambert(1.0);
    // The sphere through the normal probe.
    let h = if ctx.quick { 16 } else { 24 };
    let probe = |lighting: Lighting, spp: u32, seed: u64| Spec {
        width: 2 * h,
        height: h,
        spp,
        seed,
        camera: Camera::Probe { theta_o_deg: 0.0, phi_o_deg: 0.0 },
        lighting,
        shape: Shape::Sphere,
        brdf: lambert.clone(),
    };
    let probe_renders = render_all(ctx, &lights, &probe, (2, ctx.spp(64, 128)))?;
    // The icosphere mesh through an orthographic camera.
    std::fs::create_dir_all(&ctx.out).map_err(|e| format!("{}: {e}", ctx.out.display()))?;
    let obj = ctx.out.join("icosphere4.obj");
    super::convex_shape::write_icosphere(&obj, 4)?;
    let obj = std::fs::canonicalize(&obj).map_err(|e| format!("{}: {e}", obj.display()))?.display().to_string();
    let size = if ctx.quick { 24 } else { 40 };
    let ortho = |lighting: Lighting, spp: u32, seed: u64| Spec {
        width: size,
        height: size,
        spp,
        seed,
        camera: Camera::Ortho { from: VIEW.0, up: VIEW.1, extent: EXTENT },
        lighting,
        shape: Shape::Mesh(obj.clone()),
        brdf: lambert.clone(),
    };
    let mesh_renders = render_all(ctx, &lights, &ortho, (ctx.spp(16, 32), ctx.spp(32, 64)))?;
    // The pixel geometry of the mesh view, from one render's mask and normal layers.
    let spec = ortho(Lighting::Uniform(1.0), 16, ctx.seed);
    let mesh_ch = Channel::from_film(&render_spec(ctx, &spec)?, 0);

    let mut c =
        Check::new(NAME, EQUATION, "images of a Lambertian object under ≥ 100 lightings lie close to a 9D subspace");
    let iso_a = if ctx.wrong { transfer::phong(8.0, 40) } else { transfer::lambert(40) };
    let iso: Vec<f64> = KS.iter().map(|&k| isotropic_captured(&iso_a, k)).collect();
    for (object, px, renders, file, dims) in [
        (
            "sphere (normal probe)",
            probe_pixels(2 * h as usize, h as usize),
            &probe_renders,
            "subspace_sphere",
            (2 * h as usize, h as usize),
        ),
        (
            "icosphere mesh (orthographic)",
            mesh_pixels(&mesh_ch),
            &mesh_renders,
            "subspace_mesh",
            (size as usize, size as usize),
        ),
    ] {
        let (m, fine, coarse) = build_sets(&px, &lights, renders, &coeffs, ctx.wrong);
        c.pictures.push(picture(file, object, &px, dims, &m, lights.len() - 1));
        let file = format!("{file}.svg");
        let (sm, sf, sc) = (stats(&m), stats(&fine), stats(&coarse));
        let approx = [
            (sf.captured[0].0 - sc.captured[0].0).abs(),
            (sf.captured[1].0 - sc.captured[1].0).abs(),
            (sf.captured[2].0 - sc.captured[2].0).abs(),
            (sf.outside.0 - sc.outside.0).abs(),
        ];
        rows(&mut c, object, &sm, &sf, approx, &iso);
        c.note(format!(
            "{object}: {} pixels; e_5/e_9/e_15 = {:.5}/{:.5}/{:.5} (analytic images {:.5}/{:.5}/{:.5}); outside span Y_l≤2: {:.2e} ± {:.1e}; principal angles (deg): {}",
            px.index.len(),
            sm.captured[0].0,
            sm.captured[1].0,
            sm.captured[2].0,
            sf.captured[0].0,
            sf.captured[1].0,
            sf.captured[2].0,
            sm.outside.0,
            sm.outside.1,
            sm.angles.iter().map(|a| format!("{a:.2}")).collect::<Vec<_>>().join(", ")
        ));
        c.plots.push(spectrum_plot(&file, object, &sm, &sf));
    }
    let (nd, ns, nf, ng) = counts(ctx.quick);
    c.note(format!(
        "{} lightings: {nd} directional, {ns} positive sums of 2–5 of them (sums of their renders), {nf} non-negative SH fields l ≤ {LMAX_FIELD}, {ng} rotations of Grace (green); probe {}×{h}, mesh view {size}×{size} from {:?}",
        lights.len(),
        2 * h,
        VIEW.0
    ));
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn synthetic(a: &[f64], lights: &[Light], coeffs: &[Vec<f64>], w: usize, h: usize) -> ImageSet {
        let px = probe_pixels(w, h);
        let lmax = a.len() - 1;
        let pr = Predictor { a: a.to_vec(), basis: ShBasis::new(lmax), closed_form: false };
        let dirs: Vec<[f64; 3]> =
            lights.iter().filter_map(|l| if let Light::Directional(s) = l { Some(*s) } else { None }).collect();
        let mut y = vec![0.0; num_coefficients(lmax)];
        let images = lights
            .iter()
            .enumerate()
            .map(|(j, l)| {
                px.normal.iter().map(|n| pr.value(l, &dirs, std::slice::from_ref(&coeffs[j]), *n, &mut y)).collect()
            })
            .collect();
        let sigma = vec![vec![0.0; w * h]; lights.len()];
        ImageSet { weight: px.weight, normal: px.normal, images, sigma_own: sigma.clone(), sigma }
    }

    #[test]
    fn a_band_limited_ensemble_lies_in_the_9d_span_and_a_glossy_one_does_not() {
        let lights = lightings(true, 3);
        let coeffs: Vec<Vec<f64>> =
            lights.iter().map(|l| if let Light::Field(c) = l { c.clone() } else { vec![] }).collect();
        let lights: Vec<Light> = lights.into_iter().filter(|l| !matches!(l, Light::Grace(_))).collect();
        // Lambert filter truncated at l = 2: exactly 9D.
        let mut a = transfer::lambert(4);
        a[3] = 0.0;
        a[4] = 0.0;
        let s = stats(&synthetic(&a, &lights, &coeffs, 64, 32));
        assert!(s.outside.0.abs() < 1e-10, "{:?}", s.outside);
        assert!((s.captured[1].0 - 1.0).abs() < 1e-10);
        assert!(s.angles.iter().all(|&t| t < 1e-3), "{:?}", s.angles);
        // Phong s = 8: far from 9D.
        let s = stats(&synthetic(&transfer::phong(8.0, 16), &lights, &coeffs, 64, 32));
        assert!(s.outside.0 > 0.05 && s.captured[1].0 < 0.97, "{:?}", s.captured);
    }

    #[test]
    fn isotropic_directional_ensemble_captures_127_over_128_in_9() {
        let a = transfer::lambert(60);
        assert!((isotropic_captured(&a, 9) - 127.0 / 128.0).abs() < 1e-5);
    }

    #[test]
    fn random_fields_are_non_negative() {
        let mut rng = renderer::sampling::chi2::TestRng::new(9);
        let basis = ShBasis::new(LMAX_FIELD);
        for _ in 0..20 {
            let c = random_field(&mut rng);
            for p in 0..256 * 128 {
                let v: f64 =
                    basis.eval(latlong_dir(p / 256, p % 256, 256, 128)).iter().zip(&c).map(|(a, b)| a * b).sum();
                assert!(v > 0.0);
            }
        }
    }

    #[test]
    fn noise_is_debiased_and_its_sigma_is_honest() {
        // Exactly 9D images plus noise σ: ρ = 0 within its σ, e_9 = 1 within its σ.
        let lights = lightings(true, 4);
        let coeffs: Vec<Vec<f64>> =
            lights.iter().map(|l| if let Light::Field(c) = l { c.clone() } else { vec![] }).collect();
        let lights: Vec<Light> = lights.into_iter().filter(|l| matches!(l, Light::Field(_))).collect();
        let coeffs: Vec<Vec<f64>> = coeffs.into_iter().filter(|c| !c.is_empty()).collect();
        let mut a = transfer::lambert(4);
        a[4] = 0.0;
        let mut s = synthetic(&a, &lights, &coeffs, 64, 32);
        let mut rng = renderer::sampling::chi2::TestRng::new(11);
        let mut u = || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        for ((x, sg), so) in s.images.iter_mut().zip(s.sigma.iter_mut()).zip(s.sigma_own.iter_mut()) {
            for ((v, e), eo) in x.iter_mut().zip(sg.iter_mut()).zip(so.iter_mut()) {
                let (u1, u2) = (u().max(1e-300), u());
                *e = 0.01;
                *eo = 0.01;
                *v += 0.01 * (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos();
            }
        }
        let st = stats(&s);
        assert!(st.outside.0.abs() < 4.0 * st.outside.1, "{:?}", st.outside);
        assert!(st.outside.1 > 0.0);
    }
}
