//! Factorization of the reflected light field into lighting and BRDF, up to a global scale
//! (eq. 18; verified for a directional source in sec. 3.1, eq. 23).
//!
//! Input: the 4D light field B(n; θ'_o, φ'_o) of a sphere of one isotropic, reciprocal BRDF under
//! distant lighting, sampled as lat-long images over the normals n (one image per outgoing node
//! (θ'_o, φ'_o), e.g. `normal-probe` renders, docs/src/conventions.md §6), with quadrature weights over both.
//! Only two slices of the light field's coefficients are needed (eq. 18, lines 2 and 6):
//!
//! - B̃_lm00 (p = q = 0) = M_lm / √(4π), with M(n) = ∫_H B(n, ω'_o) cos θ'_o dω'_o the radiant
//!   exitance map. Swapping the integrals, M(n) = ∫ L(ω) a(θ'_i) cos θ'_i dω, a(θ) = ∫ ρ(θ, ω_o)
//!   cos θ_o dω_o the directional albedo: a radial convolution of L with k(θ) = a(θ) cos θ (θ < π/2,
//!   0 below), so by Funk–Hecke (as eq. 13–15) M_lm = Λ_l k̂_l L_lm, k̂_l = 2π ∫ k Y_l0 sin θ dθ.
//! - B̃_00l0 (l = 0, q = 0) = κ_l / √(4π), with κ_l = ∫_H Y_l0(θ'_o) cos θ'_o [∫_{S²} B dn] dω'_o.
//!   The inner integral over all normals and the azimuth average of dω'_o make the incident
//!   direction cover the sphere uniformly, so ∫dn (1/2π)∫dφ'_o B = P a_o(θ'_o), P = ∫ L dω, with
//!   a_o the albedo for light leaving at θ'_o. Reciprocity (ρ̃_0l0 = ρ̃_l00) makes a_o = a, hence
//!   κ_l = P k̂_l for ANY lighting. (Without the azimuth average a source at the pole would see only
//!   the local incident azimuth π, eq. 21.)
//!
//! Hence (eq. 18, line 6) L_lm / P = Λ_l⁻¹ B̃_lm00 / B̃_00l0 = M_lm / (Λ_l κ_l): the lighting up to
//! the global scale P, and L_00 = 1/√(4π) = Λ_0⁻¹ identically (the paper's gauge: M_00 and Λ_0 κ_0
//! are the same double sum). The BRDF comes with the inverse scale: κ_l = P k̂_l ∝ ρ̃_l00 = ρ̃_0l0
//! (and the albedo profile P a(θ'_o) from the node sums), and at any other slice eq. 16 with the
//! factored lighting, e.g. the normal-exitance filter P Λ_l ρ̂_l(0) = B_lm(0) / (L_lm / P) by least
//! squares over m ([`filter_from_lighting`]). For a directional source L_lm / P = Y_lm(s) (eq. 19,
//! 23), and s = (L_11, L_1,−1, L_10) / |·| (docs/src/conventions.md §3: Y_11 ∝ x, Y_1,−1 ∝ y, Y_10 ∝ z).
//!
//! Orders where κ_l = 0 (a Lambertian a = const gives k̂_l = 0 at odd l ≥ 3, eq. 38) are 0/0: the
//! factorization is ill-posed there (end of sec. 3.1: lighting or BRDF coefficient zero); they are
//! reported [`Status::Ambiguous`] and never divided. The conditioning of order l is its gain
//! g_l = |Λ_l κ_l| / |Λ_0 κ_0| (an error δ in M_lm becomes δ / (g_l Λ_0 κ_0) in L_lm / P);
//! g_l < 1 / `max_amplification` is [`Status::IllConditioned`].
//!
//! Quadrature (all linear in the images, so the renders' standard errors propagate exactly):
//! - outgoing directions: [`hemisphere_nodes`], Gauss–Legendre in μ = cos θ'_o on (0, 1) times
//!   the trapezoid rule in φ'_o (spectrally accurate for periodic integrands; every Fourier mode
//!   0 < |k| < n_φ of the azimuth integrates to 0 exactly, and the k = 0 mode is smooth in μ);
//! - normals: [`NormalRule`], the exact pixel solid angle (midpoint rule, O(h²)) or Fejér's first
//!   rule, whose nodes are exactly the lat-long pixel centres cos θ_r and which integrates
//!   polynomials in cos θ of degree < H exactly, times the trapezoid rule in φ.

use crate::error::{Error, Result};
use crate::quadrature::gauss_legendre;
use crate::sh::{ShBasis, index, lambda, latlong_direction, num_coefficients};
use std::f64::consts::PI;

/// Default threshold on the amplification 1/g_l above which an order is ill-conditioned (as
/// [`super::lighting::DEFAULT_MAX_AMPLIFICATION`]: one decimal digit of the data lost).
pub const DEFAULT_MAX_AMPLIFICATION: f64 = super::lighting::DEFAULT_MAX_AMPLIFICATION;

/// g_l below this is an exact zero of κ_l (rounding only): the order is ambiguous.
pub const ZERO_GAIN: f64 = 1e-9;

/// Quadrature over the lat-long grid of normals (rows θ_r = π (r + ½) / H).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalRule {
    /// Exact pixel solid angle (2π/W)(cos θ_top − cos θ_bottom): midpoint rule, O((π/H)²) error.
    PixelSolidAngle,
    /// Fejér's first rule in cos θ (exact for polynomials of degree < H) × trapezoid in φ.
    Fejer,
}

/// Per-pixel weight of each row of a W × H lat-long grid (the φ factor 2π/W included).
pub fn row_weights(width: usize, height: usize, rule: NormalRule) -> Vec<f64> {
    let (w, h) = (width as f64, height as f64);
    (0..height)
        .map(|r| match rule {
            NormalRule::PixelSolidAngle => {
                let (t0, t1) = (PI * r as f64 / h, PI * (r as f64 + 1.0) / h);
                2.0 * PI / w * (t0.cos() - t1.cos())
            }
            NormalRule::Fejer => {
                // w_r = (2/H) [1 − 2 Σ_{j=1}^{⌊H/2⌋} cos(2jθ_r) / (4j² − 1)] (Fejér 1933; Waldvogel 2006).
                let t = PI * (r as f64 + 0.5) / h;
                let s: f64 = (1..=height / 2).map(|j| (2.0 * j as f64 * t).cos() / (4.0 * (j * j) as f64 - 1.0)).sum();
                2.0 / h * (1.0 - 2.0 * s) * 2.0 * PI / w
            }
        })
        .collect()
}

/// One outgoing direction (θ'_o, φ'_o) of the light field (radians) and its solid-angle weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutgoingNode {
    pub theta_o: f64,
    pub phi_o: f64,
    pub weight: f64,
}

/// Product rule over the outgoing hemisphere: `n_mu` Gauss–Legendre nodes in μ = cos θ'_o on (0, 1)
/// times `n_phi` azimuths φ_k = 2πk / n_phi (trapezoid). Weights sum to 2π; every θ'_o < π/2.
pub fn hemisphere_nodes(n_mu: usize, n_phi: usize) -> Result<Vec<OutgoingNode>> {
    if n_mu == 0 || n_phi == 0 {
        return Err(Error::new(format!("factorization needs ≥ 1 node in μ and φ, got {n_mu} × {n_phi}")));
    }
    let (x, w) = gauss_legendre(n_mu);
    let mut out = Vec::with_capacity(n_mu * n_phi);
    for (xi, wi) in x.iter().zip(&w) {
        let mu = 0.5 * (xi + 1.0);
        for k in 0..n_phi {
            out.push(OutgoingNode {
                theta_o: mu.acos(),
                phi_o: 2.0 * PI * k as f64 / n_phi as f64,
                weight: 0.5 * wi * 2.0 * PI / n_phi as f64,
            });
        }
    }
    Ok(out)
}

/// SH projection of a lat-long image over normals, f_k = Σ_p w_p f(n_p) Y_k(n_p), l ≤ lmax.
pub fn project(image: &[f64], width: usize, height: usize, rule: NormalRule, lmax: usize) -> Result<Vec<f64>> {
    check_image(image, width, height)?;
    let rw = row_weights(width, height, rule);
    let basis = ShBasis::new(lmax);
    let n = num_coefficients(lmax);
    let mut y = vec![0.0; n];
    let mut out = vec![0.0; n];
    for r in 0..height {
        for c in 0..width {
            let v = rw[r] * image[r * width + c];
            if v == 0.0 {
                continue;
            }
            basis.eval_into(latlong_direction(r, c, width, height), &mut y);
            for k in 0..n {
                out[k] += v * y[k];
            }
        }
    }
    Ok(out)
}

fn check_image(image: &[f64], width: usize, height: usize) -> Result<()> {
    if width == 0 || height == 0 || image.len() != width * height {
        return Err(Error::new(format!("light-field image has {} values, expected {width} × {height}", image.len())));
    }
    if image.iter().any(|v| !v.is_finite()) {
        return Err(Error::new("light-field image has non-finite values"));
    }
    Ok(())
}

/// The sampled light field, reduced on the fly to what eq. 18 needs: the exitance map
/// M(n_p) = Σ_j w_j cos θ_j B_j(n_p) and, per node j, S_j = Σ_p w_p B_j(n_p) ≈ ∫ B_j dn.
#[derive(Clone, Debug)]
pub struct LightField {
    pub width: usize,
    pub height: usize,
    pub rule: NormalRule,
    row_weight: Vec<f64>,
    exitance: Vec<f64>,
    nodes: Vec<(OutgoingNode, f64)>,
}

impl LightField {
    pub fn new(width: usize, height: usize, rule: NormalRule) -> Result<LightField> {
        if width == 0 || height == 0 {
            return Err(Error::new("light-field grid must be at least 1 × 1"));
        }
        Ok(LightField {
            width,
            height,
            rule,
            row_weight: row_weights(width, height, rule),
            exitance: vec![0.0; width * height],
            nodes: vec![],
        })
    }

    /// Adds the image B(n_p; node) (row-major W × H, docs/src/conventions.md §2).
    pub fn add(&mut self, node: OutgoingNode, image: &[f64]) -> Result<()> {
        check_image(image, self.width, self.height)?;
        if !(node.theta_o >= 0.0 && node.theta_o < 0.5 * PI && node.weight.is_finite() && node.phi_o.is_finite()) {
            return Err(Error::new(format!("outgoing node must have 0 ≤ θ'_o < π/2 and finite weight, got {node:?}")));
        }
        let wc = node.weight * node.theta_o.cos();
        let mut s = 0.0;
        for r in 0..self.height {
            let mut row = 0.0;
            for c in 0..self.width {
                let i = r * self.width + c;
                self.exitance[i] += wc * image[i];
                row += image[i];
            }
            s += self.row_weight[r] * row;
        }
        self.nodes.push((node, s));
        Ok(())
    }

    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The sampled exitance map M(n_p).
    pub fn exitance_map(&self) -> &[f64] {
        &self.exitance
    }

    /// M_lm = √(4π) B̃_lm00, l ≤ lmax.
    pub fn exitance_coefficients(&self, lmax: usize) -> Vec<f64> {
        project(&self.exitance, self.width, self.height, self.rule, lmax)
            .unwrap_or_else(|_| vec![f64::NAN; num_coefficients(lmax)])
    }

    /// κ_l = √(4π) B̃_00l0 = Σ_j w_j cos θ_j Y_l0(θ_j) S_j, l ≤ lmax.
    pub fn kappa(&self, lmax: usize) -> Vec<f64> {
        let mut p = vec![0.0; lmax + 1];
        let mut out = vec![0.0; lmax + 1];
        for (node, s) in &self.nodes {
            let mu = node.theta_o.cos();
            crate::quadrature::legendre_all(mu, &mut p);
            for l in 0..=lmax {
                // Y_l0 = P_l / Λ_l.
                out[l] += node.weight * mu * p[l] / lambda(l) * s;
            }
        }
        out
    }

    /// (θ'_o, P a(θ'_o)): the factored albedo profile, the azimuth average of S_j per θ'_o ring
    /// (4π A(θ'_o) of the module doc), in increasing θ'_o.
    pub fn albedo_profile(&self) -> Vec<(f64, f64)> {
        let mut rings: Vec<(f64, f64, f64)> = vec![];
        for (node, s) in &self.nodes {
            match rings.iter_mut().find(|r| r.0 == node.theta_o) {
                Some(r) => {
                    r.1 += node.weight * s;
                    r.2 += node.weight;
                }
                None => rings.push((node.theta_o, node.weight * s, node.weight)),
            }
        }
        rings.sort_by(|a, b| a.0.total_cmp(&b.0));
        rings.into_iter().map(|(t, s, w)| (t, s / w)).collect()
    }

    /// Eq. 18: L_lm / P = M_lm / (Λ_l κ_l) per order l ≤ lmax, with its conditioning.
    pub fn factorize(&self, lmax: usize, max_amplification: f64) -> Result<Factorization> {
        if self.nodes.is_empty() {
            return Err(Error::new("factorization needs at least one outgoing node"));
        }
        let m = self.exitance_coefficients(lmax);
        let kappa = self.kappa(lmax);
        let g0 = lambda(0) * kappa[0];
        if !(g0 > 0.0) {
            return Err(Error::new(format!("factorization: the light field has no energy (Λ_0 κ_0 = {g0})")));
        }
        let mut orders = Vec::with_capacity(lmax + 1);
        let mut lighting = vec![None; num_coefficients(lmax)];
        for l in 0..=lmax {
            let f = lambda(l) * kappa[l];
            let gain = (f / g0).abs();
            let status = if !(gain > ZERO_GAIN) {
                Status::Ambiguous
            } else if 1.0 / gain > max_amplification {
                Status::IllConditioned
            } else {
                Status::Recovered
            };
            if status != Status::Ambiguous {
                for mm in -(l as i64)..=(l as i64) {
                    let k = index(l, mm);
                    lighting[k] = Some(m[k] / f);
                }
            }
            orders.push(FactorOrder { l, kappa: kappa[l], gain, status });
        }
        Ok(Factorization { lmax, exitance: m, kappa, orders, lighting })
    }
}

/// How an order of the lighting comes out of the factorization.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    Recovered,
    IllConditioned,
    /// κ_l = 0: 0/0, the lighting or the BRDF coefficient is zero (sec. 3.1).
    Ambiguous,
}

impl Status {
    pub fn name(&self) -> &'static str {
        match self {
            Status::Recovered => "recovered",
            Status::IllConditioned => "ill-conditioned",
            Status::Ambiguous => "ambiguous",
        }
    }
}

/// One order of a factorization.
#[derive(Clone, Debug, PartialEq)]
pub struct FactorOrder {
    pub l: usize,
    /// κ_l = P k̂_l (the BRDF's ρ̃_0l0 up to the scale P √(4π)).
    pub kappa: f64,
    /// g_l = |Λ_l κ_l| / |Λ_0 κ_0|.
    pub gain: f64,
    pub status: Status,
}

/// Result of [`LightField::factorize`].
#[derive(Clone, Debug)]
pub struct Factorization {
    pub lmax: usize,
    /// M_lm (= √(4π) B̃_lm00).
    pub exitance: Vec<f64>,
    /// κ_l (= √(4π) B̃_00l0).
    pub kappa: Vec<f64>,
    pub orders: Vec<FactorOrder>,
    /// L_lm / P, `None` at ambiguous orders. L_00 / P = 1/√(4π) (the paper's gauge).
    pub lighting: Vec<Option<f64>>,
}

/// A directional source recovered from the order-1 lighting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Source {
    /// Unit direction toward the source.
    pub direction: [f64; 3],
    /// |L_1| / √(3/4π) for L / P: 1 for a single directional source, < 1 for any other lighting.
    pub directionality: f64,
}

impl Factorization {
    /// The direction of the order-1 lighting (eq. 19: L_1m / P = Y_1m(s) for a directional source).
    pub fn source_direction(&self) -> Option<Source> {
        if self.lmax < 1 {
            return None;
        }
        let (x, y, z) = (self.lighting[index(1, 1)]?, self.lighting[index(1, -1)]?, self.lighting[index(1, 0)]?);
        let n = (x * x + y * y + z * z).sqrt();
        if !(n > 0.0) {
            return None;
        }
        Some(Source { direction: [x / n, y / n, z / n], directionality: n / (3.0 / (4.0 * PI)).sqrt() })
    }

    /// κ_l / κ_0 = k̂_l / k̂_0 = ρ̃_l00 / ρ̃_000 (scale-free BRDF coefficients).
    pub fn brdf_ratios(&self) -> Vec<f64> {
        self.kappa.iter().map(|k| k / self.kappa[0]).collect()
    }
}

/// L_lm = Y_lm(s), l ≤ lmax: a unit directional source (eq. 19).
pub fn directional_lighting(s: [f64; 3], lmax: usize) -> Vec<f64> {
    ShBasis::new(lmax).eval(s)
}

/// Eq. 16 per order with a known (or factored) lighting: the filter x_l minimising
/// Σ_m (B_lm − x_l L_lm)², x_l = Σ_m B_lm L_lm / Σ_m L_lm², l ≤ lmax (B, L in index order k).
/// `None` where the lighting of that order is unknown or zero (Σ_m L_lm² = 0: nothing to divide).
pub fn filter_from_lighting(b: &[f64], light: &[Option<f64>], lmax: usize) -> Vec<Option<f64>> {
    (0..=lmax)
        .map(|l| {
            let (mut num, mut den) = (0.0, 0.0);
            for mm in -(l as i64)..=(l as i64) {
                let k = index(l, mm);
                let lk = (*light.get(k)?)?;
                num += b.get(k)? * lk;
                den += lk * lk;
            }
            (den > 0.0).then(|| num / den)
        })
        .collect()
}

/// Tolerance (degrees) on a header's θ_o and φ_o against a node: f32 degrees are exact to
/// ~5e-6° below 90°, and distinct nodes of any accepted rule are ≥ 0.01° apart.
pub const NODE_TOL_DEG: f64 = 1e-3;
/// Largest accepted n_μ, n_φ and n_μ n_φ (beyond, a request is taken as a typo).
pub const MAX_MU: usize = 64;
pub const MAX_PHI: usize = 256;
pub const MAX_NODES: usize = 4096;

/// Refuses a rule outside n_μ ∈ 1..=[`MAX_MU`], n_φ ∈ 1..=[`MAX_PHI`], n_μ n_φ ≤ [`MAX_NODES`].
pub fn check_nodes(n_mu: usize, n_phi: usize) -> Result<()> {
    if !(1..=MAX_MU).contains(&n_mu) || !(1..=MAX_PHI).contains(&n_phi) || n_mu * n_phi > MAX_NODES {
        return Err(Error::new(format!(
            "nodes {n_mu}x{n_phi} out of range (n_mu 1..={MAX_MU}, n_phi 1..={MAX_PHI}, at most {MAX_NODES} nodes)"
        )));
    }
    Ok(())
}

/// Node angles (θ_o, φ_o) in degrees, as printed (f64 shortest round-trip representation).
pub fn node_degrees(n: &OutgoingNode) -> (f64, f64) {
    (n.theta_o.to_degrees(), n.phi_o.to_degrees())
}

/// Angular distance (degrees, in [0, 180]) between two azimuths in degrees.
pub fn circular_deg(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    d.min(360.0 - d)
}

/// "θ_o = …°, φ_o = …°" for messages.
pub fn fmt_node(t: f64, p: f64) -> String {
    format!("θ_o = {t:.4}°, φ_o = {p:.4}°")
}

/// (n_μ, n_φ), the rule's nodes, and the node index of each image.
pub type NodeMatch = ((usize, usize), Vec<OutgoingNode>, Vec<usize>);

/// Assigns image i (angles in degrees, named `names[i]`) to node `out[i]` of
/// `hemisphere_nodes(n_mu, n_phi)`. Without `given`, n_μ is the number of distinct θ_o (or, if
/// those are not all Gauss–Legendre nodes of that count, the smallest larger count whose nodes they
/// are: a whole missing ring) and n_φ the smallest count whose azimuth grid holds every φ_o seen. Every node must be hit exactly once.
pub fn match_nodes(angles: &[(f64, f64)], names: &[String], given: Option<(usize, usize)>) -> Result<NodeMatch> {
    let thetas_of = |n_mu: usize| -> Result<Vec<f64>> {
        Ok(hemisphere_nodes(n_mu, 1)?.iter().map(|n| n.theta_o.to_degrees()).collect())
    };
    let (n_mu, n_phi) = match given {
        Some(g) => g,
        None => {
            // Rings: θ_o values within the tolerance, each with its distinct φ_o (so that a
            // duplicate is reported as such rather than inflating n_φ).
            let mut rings: Vec<(f64, Vec<f64>)> = vec![];
            for &(t, p) in angles {
                match rings.iter_mut().find(|r| (r.0 - t).abs() <= NODE_TOL_DEG) {
                    Some(r) if r.1.iter().any(|&q| circular_deg(p, q) <= NODE_TOL_DEG) => {}
                    Some(r) => r.1.push(p),
                    None => rings.push((t, vec![p])),
                }
            }
            // n_φ: the smallest count whose azimuths 360°k/n_φ hold every φ_o seen (so a ring
            // with gaps is not mistaken for a coarser rule), at least the fullest ring.
            let fullest = rings.iter().map(|r| r.1.len()).max().unwrap_or(0);
            let on_grid = |n: usize| {
                rings
                    .iter()
                    .flat_map(|r| &r.1)
                    .all(|&p| circular_deg(p, (p / (360.0 / n as f64)).round() * 360.0 / n as f64) <= NODE_TOL_DEG)
            };
            let n_phi = (fullest.max(1)..=MAX_PHI).find(|&n| on_grid(n)).unwrap_or(fullest);
            let fits = |n: usize| {
                thetas_of(n).map(|ts| rings.iter().all(|r| ts.iter().any(|t| (t - r.0).abs() <= NODE_TOL_DEG)))
            };
            let mut n_mu = rings.len();
            while n_mu < MAX_MU && !fits(n_mu)? {
                n_mu += 1;
            }
            if !fits(n_mu)? {
                n_mu = rings.len();
            }
            (n_mu, n_phi)
        }
    };
    check_nodes(n_mu, n_phi)
        .map_err(|e| Error::new(format!("inferred from {} images: {}", angles.len(), e.message)))?;
    let nodes = hemisphere_nodes(n_mu, n_phi)?;
    let deg: Vec<(f64, f64)> = nodes.iter().map(node_degrees).collect();
    let mut owner: Vec<Option<usize>> = vec![None; nodes.len()];
    let mut out = Vec::with_capacity(angles.len());
    for (i, &(t, p)) in angles.iter().enumerate() {
        let j = deg.iter().position(|&(nt, np)| (nt - t).abs() <= NODE_TOL_DEG && circular_deg(np, p) <= NODE_TOL_DEG).ok_or_else(|| {
            Error::file(
                &names[i],
                format!(
                    "{} is not a node of the {n_mu}x{n_phi} rule (Gauss–Legendre in cos θ_o × φ_o = 360°k/{n_phi}, tolerance {NODE_TOL_DEG}°; \
                     see reflect invert factor --print-nodes {n_mu}x{n_phi})",
                    fmt_node(t, p)
                ),
            )
        })?;
        if let Some(k) = owner[j] {
            return Err(Error::file(
                &names[i],
                format!("same node {} as {} (every node exactly once)", fmt_node(deg[j].0, deg[j].1), names[k]),
            ));
        }
        owner[j] = Some(i);
        out.push(j);
    }
    let missing: Vec<usize> = (0..nodes.len()).filter(|&j| owner[j].is_none()).collect();
    if let Some(&j) = missing.first() {
        return Err(Error::new(format!(
            "incomplete node set: missing node {} of the {n_mu}x{n_phi} rule ({} of {} nodes missing; see --print-nodes {n_mu}x{n_phi})",
            fmt_node(deg[j].0, deg[j].1),
            missing.len(),
            nodes.len()
        )));
    }
    Ok(((n_mu, n_phi), nodes, out))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }

    fn unit(a: [f64; 3]) -> [f64; 3] {
        let n = dot(a, a).sqrt();
        [a[0] / n, a[1] / n, a[2] / n]
    }

    /// A BRDF as ρ̂ = ρ cos θ_i for (n, ω_i, ω_o), zero below either horizon.
    type Rho = fn([f64; 3], [f64; 3], [f64; 3]) -> f64;

    fn lambert(n: [f64; 3], wi: [f64; 3], _wo: [f64; 3]) -> f64 {
        0.8 / PI * dot(n, wi)
    }

    /// Normalised Blinn–Phong in the half vector, (s+2)/(8π) cos^s θ_h / max(cos_i, cos_o)-free:
    /// ρ = c cos^s θ_h is symmetric in (ω_i, ω_o), hence reciprocal.
    fn blinn(n: [f64; 3], wi: [f64; 3], wo: [f64; 3]) -> f64 {
        let h = unit([wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]]);
        (12.0 + 2.0) / (8.0 * PI) * dot(n, h).max(0.0).powi(12) * dot(n, wi)
    }

    /// Not reciprocal: ρ = (3/(2π)) cos²θ_o depends only on the outgoing angle, so the albedo for
    /// light arriving at θ (const) differs from that for light leaving at θ (∝ cos²θ).
    fn outgoing_only(n: [f64; 3], wi: [f64; 3], wo: [f64; 3]) -> f64 {
        1.5 / PI * dot(n, wo).powi(2) * dot(n, wi)
    }

    /// Light field of a unit directional source at `s` on a W × H grid.
    fn synthetic(rho: Rho, s: [f64; 3], w: usize, h: usize, n_mu: usize, n_phi: usize, rule: NormalRule) -> LightField {
        let mut lf = LightField::new(w, h, rule).unwrap();
        let normals: Vec<[f64; 3]> = (0..w * h).map(|i| latlong_direction(i / w, i % w, w, h)).collect();
        for node in hemisphere_nodes(n_mu, n_phi).unwrap() {
            let img: Vec<f64> = normals
                .iter()
                .map(|&n| {
                    if dot(n, s) > 0.0 {
                        rho(n, s, crate::projection::normal_probe_outgoing(n, node.theta_o, node.phi_o))
                    } else {
                        0.0
                    }
                })
                .collect();
            lf.add(node, &img).unwrap();
        }
        lf
    }

    const S: [f64; 3] = [0.48, -0.36, 0.8]; // unit, not on an axis

    #[test]
    fn fejer_and_solid_angle_weights_integrate_the_sphere() {
        for rule in [NormalRule::PixelSolidAngle, NormalRule::Fejer] {
            let w = row_weights(64, 32, rule);
            assert!((w.iter().sum::<f64>() * 64.0 - 4.0 * PI).abs() < 1e-12, "{rule:?}");
        }
        // Fejér: ∫ z^d dω = 4π/(d+1) (even d) exactly for d < H.
        let (wd, h) = (8, 16);
        let w = row_weights(wd, h, NormalRule::Fejer);
        for d in [2, 6, 10, 14] {
            let s: f64 = (0..h).map(|r| w[r] * wd as f64 * (PI * (r as f64 + 0.5) / h as f64).cos().powi(d)).sum();
            assert!((s - 4.0 * PI / (d as f64 + 1.0)).abs() < 1e-12, "d = {d}: {s}");
        }
        let nodes = hemisphere_nodes(6, 8).unwrap();
        assert!((nodes.iter().map(|n| n.weight).sum::<f64>() - 2.0 * PI).abs() < 1e-12);
        let proj: f64 = nodes.iter().map(|n| n.weight * n.theta_o.cos()).sum();
        assert!((proj - PI).abs() < 1e-12, "∫ cos θ dω = π");
    }

    #[test]
    fn lambert_recovers_low_orders_and_reports_odd_orders_ambiguous() {
        let lf = synthetic(lambert, S, 128, 64, 4, 4, NormalRule::Fejer);
        let f = lf.factorize(6, DEFAULT_MAX_AMPLIFICATION).unwrap();
        let y = directional_lighting(S, 6);
        assert!((f.lighting[0].unwrap() - 1.0 / (4.0 * PI).sqrt()).abs() < 1e-14, "gauge L_00 = Λ_0⁻¹");
        // κ_l = P k̂_l with k = 0.8 cos θ (θ < π/2): Λ_l κ_l / Λ_0 κ_0 = eq. 38 ratios 1, 2/3, 1/4, 0, −1/24.
        let lam = crate::transfer::lambert::lambert(6);
        for o in &f.orders {
            assert!((o.gain - lam[o.l].abs()).abs() < 1e-12, "l = {}: gain {} vs {}", o.l, o.gain, lam[o.l]);
        }
        for l in [3, 5] {
            assert_eq!(f.orders[l].status, Status::Ambiguous, "odd l = {l} must be 0/0");
            assert!((-(l as i64)..=(l as i64)).all(|m| f.lighting[index(l, m)].is_none()));
        }
        assert_eq!(f.orders[4].status, Status::IllConditioned);
        // l ≤ 2: only the normal quadrature of a kinked image (max(n·s, 0)) errs, O(h²) ≈ 1e-4 here.
        for k in 0..9 {
            let v = f.lighting[k].unwrap();
            assert!((v - y[k]).abs() < 5e-4, "k = {k}: {v} vs {}", y[k]);
        }
        let src = f.source_direction().unwrap();
        assert!(dot(src.direction, S) > (0.05f64).to_radians().cos(), "{:?}", src);
        assert!((src.directionality - 1.0).abs() < 1e-3);
    }

    #[test]
    fn reciprocal_glossy_brdf_factors_into_source_and_filter() {
        let lf = synthetic(blinn, S, 128, 64, 10, 24, NormalRule::Fejer);
        let f = lf.factorize(4, DEFAULT_MAX_AMPLIFICATION).unwrap();
        let y = directional_lighting(S, 4);
        for k in 0..9 {
            let v = f.lighting[k].unwrap();
            assert!((v - y[k]).abs() < 5e-4, "k = {k}: {v} vs {}", y[k]);
        }
        // The albedo varies with angle, so κ_3 ≠ 0 (unlike Lambert): not ambiguous.
        assert_ne!(f.orders[3].status, Status::Ambiguous);
        let src = f.source_direction().unwrap();
        assert!(dot(src.direction, S) > (0.05f64).to_radians().cos());
        // Albedo profile: P a(θ) from the node sums (∫ over normals, reciprocity) equals a(θ) by
        // direct quadrature over ω_i at one normal. Up to θ'_o = 70° the 128 × 64 normal grid
        // resolves the lobe (measured relative error ≤ 5e-6); closer to grazing the lobe narrows
        // across the terminator (off-specular narrowing) and the grid's error grows (1.6e-4 at 74°, 1e-3 at 81°),
        // so those rings are not compared here.
        let (x, wq) = gauss_legendre(64);
        for (t, pa) in lf.albedo_profile().into_iter().filter(|p| p.0 < 70f64.to_radians()) {
            let wo = [t.sin(), 0.0, t.cos()];
            let mut a = 0.0;
            for (xi, wi) in x.iter().zip(&wq) {
                let mu = 0.5 * (xi + 1.0);
                for k in 0..128 {
                    let ph = 2.0 * PI * k as f64 / 128.0;
                    let st = (1.0 - mu * mu).sqrt();
                    a += 0.5 * wi * 2.0 * PI / 128.0 * blinn([0.0, 0.0, 1.0], [st * ph.cos(), st * ph.sin(), mu], wo);
                }
            }
            assert!((pa - a).abs() < 1e-4 * a, "θ = {t}: {pa} vs {a}");
        }
    }

    #[test]
    fn broken_reciprocity_or_a_wrong_source_is_detected() {
        // Non-reciprocal BRDF: κ_l ≠ P k̂_l, so the recovered l = 1, 2 lighting is wrong.
        let lf = synthetic(outgoing_only, S, 128, 64, 6, 8, NormalRule::Fejer);
        let f = lf.factorize(2, DEFAULT_MAX_AMPLIFICATION).unwrap();
        let y = directional_lighting(S, 2);
        let worst = (1..9).map(|k| (f.lighting[k].unwrap() - y[k]).abs()).fold(0.0, f64::max);
        assert!(worst > 0.05, "non-reciprocal BRDF should not factor: worst |ΔL| = {worst}");
        // Reciprocal data, but the prediction uses a source 3° away: |ΔL_1m| ≈ 0.49 sin 3° ≫ 5e-4.
        let lf = synthetic(lambert, S, 128, 64, 4, 4, NormalRule::Fejer);
        let f = lf.factorize(2, DEFAULT_MAX_AMPLIFICATION).unwrap();
        let r = 3f64.to_radians();
        let s2 = unit([S[0] * r.cos() - S[1] * r.sin(), S[0] * r.sin() + S[1] * r.cos(), S[2]]);
        let y2 = directional_lighting(s2, 2);
        let worst = (1..9).map(|k| (f.lighting[k].unwrap() - y2[k]).abs()).fold(0.0, f64::max);
        assert!(worst > 1e-2, "{worst}");
    }

    #[test]
    fn filter_from_factored_lighting_recovers_a_radial_filter() {
        // B_lm = x_l L_lm exactly: x_l back; unknown lighting → None.
        let y = directional_lighting(S, 3);
        let x = [1.0, 0.6, 0.3, 0.1];
        let b: Vec<f64> = (0..16).map(|k| x[crate::sh::lm(k).0] * y[k]).collect();
        let light: Vec<Option<f64>> = (0..16).map(|k| if k < 9 { Some(y[k]) } else { None }).collect();
        let got = filter_from_lighting(&b, &light, 3);
        for l in 0..3 {
            assert!((got[l].unwrap() - x[l]).abs() < 1e-14);
        }
        assert!(got[3].is_none());
    }

    #[test]
    fn bad_input_is_an_error() {
        let mut lf = LightField::new(8, 4, NormalRule::Fejer).unwrap();
        let node = OutgoingNode { theta_o: 0.3, phi_o: 0.0, weight: 1.0 };
        assert!(lf.add(node, &[0.0; 31]).is_err());
        assert!(lf.add(node, &[f64::NAN; 32]).is_err());
        assert!(lf.add(OutgoingNode { theta_o: 2.0, ..node }, &[0.0; 32]).is_err());
        assert!(lf.factorize(2, 10.0).is_err(), "no nodes");
        lf.add(node, &[0.0; 32]).unwrap();
        assert!(lf.factorize(2, 10.0).is_err(), "no energy");
        assert!(hemisphere_nodes(0, 4).is_err());
    }
}
