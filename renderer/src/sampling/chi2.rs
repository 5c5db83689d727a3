//! Chi-square goodness-of-fit of a direction sampler against its claimed pdf (the test pbrt-v4 and
//! Mitsuba 3 apply to every sampling routine).
//!
//! The sphere is cut into `theta_bins × phi_bins` cells of equal solid angle (uniform in cosθ and
//! φ). Observed counts come from `samples` draws; expected counts integrate the pdf over each cell by
//! a fine midpoint rule. Cells with fewer than `min_expected` expected draws are pooled, and the
//! statistic is compared with the χ² distribution. A routine whose pdf disagrees with what it
//! samples (wrong normalisation, wrong shape, missing Jacobian) gives p ≈ 0.

use crate::math::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Chi2Config {
    pub theta_bins: usize,
    pub phi_bins: usize,
    pub samples: usize,
    pub seed: u64,
    /// Cells expecting fewer draws than this are pooled together (5 is the textbook value).
    pub min_expected: f64,
    /// Midpoint sub-cells per cell side when integrating the pdf.
    pub resolution: usize,
}

impl Default for Chi2Config {
    fn default() -> Self {
        Chi2Config { theta_bins: 32, phi_bins: 64, samples: 1_000_000, seed: 7, min_expected: 5.0, resolution: 6 }
    }
}

#[derive(Clone, Debug)]
pub struct Chi2Result {
    pub statistic: f64,
    pub dof: usize,
    pub p_value: f64,
    /// Draws that came back as `None` (sampler refused).
    pub rejected: usize,
    /// Integral of the pdf over the sphere by the same quadrature (1 for a normalised pdf with all
    /// its mass representable; less when the routine may refuse).
    pub pdf_integral: f64,
    /// Mass fraction actually sampled (1 − rejected/samples).
    pub sampled_fraction: f64,
}

impl Chi2Result {
    /// True when the test does not reject at significance `alpha` (use a Šidák-corrected alpha when
    /// running many tests).
    pub fn passes(&self, alpha: f64) -> bool {
        self.p_value > alpha
    }
}

/// A small counter-based generator for tests: SplitMix64.
pub struct TestRng(u64);
impl TestRng {
    pub fn new(seed: u64) -> Self {
        TestRng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }
}

fn cell_of(d: Vec3, cfg: &Chi2Config) -> usize {
    let z = d.z.clamp(-1.0, 1.0) as f64;
    let ti = (((1.0 - z) * 0.5) * cfg.theta_bins as f64) as usize;
    let mut phi = (d.y as f64).atan2(d.x as f64);
    if phi < 0.0 {
        phi += 2.0 * std::f64::consts::PI;
    }
    let pi = ((phi / (2.0 * std::f64::consts::PI)) * cfg.phi_bins as f64) as usize;
    ti.min(cfg.theta_bins - 1) * cfg.phi_bins + pi.min(cfg.phi_bins - 1)
}

/// Runs the test. `sample(u_lobe, u)` draws a unit direction (or refuses); `pdf(d)` is its
/// solid-angle density.
pub fn chi2_sphere<S, P>(mut sample: S, pdf: P, cfg: &Chi2Config) -> Chi2Result
where
    S: FnMut(f32, Vec2) -> Option<Vec3>,
    P: Fn(Vec3) -> f64,
{
    let ncell = cfg.theta_bins * cfg.phi_bins;
    let mut observed = vec![0f64; ncell];
    let mut rng = TestRng::new(cfg.seed);
    let mut rejected = 0;
    for _ in 0..cfg.samples {
        let ul = rng.next_f32();
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        match sample(ul, u) {
            Some(d) if d.is_finite() => observed[cell_of(d.normalize(), cfg)] += 1.0,
            _ => rejected += 1,
        }
    }
    // Expected counts: ∫_cell pdf dω, cells uniform in z = cosθ and φ, so dω = dz dφ.
    let res = cfg.resolution.max(1);
    let dz = 2.0 / (cfg.theta_bins * res) as f64;
    let dphi = 2.0 * std::f64::consts::PI / (cfg.phi_bins * res) as f64;
    let mut expected = vec![0f64; ncell];
    let mut total = 0.0;
    for ti in 0..cfg.theta_bins * res {
        let z = 1.0 - (ti as f64 + 0.5) * dz;
        let r = (1.0 - z * z).max(0.0).sqrt();
        for pj in 0..cfg.phi_bins * res {
            let phi = (pj as f64 + 0.5) * dphi;
            let d = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
            let p = pdf(d) * dz * dphi;
            expected[(ti / res) * cfg.phi_bins + pj / res] += p;
            total += p;
        }
    }
    for e in expected.iter_mut() {
        *e *= cfg.samples as f64;
    }
    // Pool small cells (sorted by expectation) so each pooled cell reaches min_expected.
    let mut order: Vec<usize> = (0..ncell).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut stat, mut dof) = (0.0, 0usize);
    let (mut pool_e, mut pool_o) = (0.0, 0.0);
    for &i in &order {
        if expected[i] < cfg.min_expected {
            pool_e += expected[i];
            pool_o += observed[i];
            continue;
        }
        stat += (observed[i] - expected[i]).powi(2) / expected[i];
        dof += 1;
    }
    if pool_e > 0.0 {
        if pool_e >= cfg.min_expected {
            stat += (pool_o - pool_e).powi(2) / pool_e;
            dof += 1;
        } else if pool_o > cfg.min_expected * 4.0 + 10.0 {
            // Many draws where the pdf says almost none: that is a failure in itself.
            stat = f64::INFINITY;
        }
    }
    // Rejected draws form one more cell whose expectation is the pdf's missing mass.
    let miss_e = (1.0 - total).max(0.0) * cfg.samples as f64;
    if miss_e >= cfg.min_expected {
        stat += (rejected as f64 - miss_e).powi(2) / miss_e;
        dof += 1;
    }
    let dof = dof.saturating_sub(1).max(1);
    Chi2Result {
        statistic: stat,
        dof,
        p_value: chi2_survival(stat, dof as f64),
        rejected,
        pdf_integral: total,
        sampled_fraction: 1.0 - rejected as f64 / cfg.samples as f64,
    }
}

/// Integral of a density over the sphere by the midpoint rule on an n × 2n (cosθ, φ) grid.
pub fn integrate_sphere<P: Fn(Vec3) -> f64>(f: P, n: usize) -> f64 {
    let dz = 2.0 / n as f64;
    let dphi = std::f64::consts::PI / n as f64;
    let mut sum = 0.0;
    for i in 0..n {
        let z = 1.0 - (i as f64 + 0.5) * dz;
        let r = (1.0 - z * z).max(0.0).sqrt();
        for j in 0..2 * n {
            let phi = (j as f64 + 0.5) * dphi;
            sum += f(Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32));
        }
    }
    sum * dz * dphi
}

/// P(χ²_k > x) and the regularized upper incomplete gamma Q(a, x): one implementation, in
/// [`analysis::special`], shared with the analysis and the verifier.
pub use analysis::special::{chi2_survival, gamma_q};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn survival_function_known_values() {
        // χ²_1: P(X > 3.841) = 0.05; χ²_10: P(X > 18.307) = 0.05; χ²_100: P(X > 124.342) = 0.05.
        assert!((chi2_survival(3.841459, 1.0) - 0.05).abs() < 1e-5);
        assert!((chi2_survival(18.307038, 10.0) - 0.05).abs() < 1e-5);
        assert!((chi2_survival(124.342113, 100.0) - 0.05).abs() < 1e-5);
    }

    fn uniform_sphere(u: Vec2) -> Vec3 {
        let z = 1.0 - 2.0 * u.x;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * std::f32::consts::PI * u.y;
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    #[test]
    fn accepts_a_correct_sampler_and_rejects_a_wrong_pdf() {
        let cfg = Chi2Config { samples: 200_000, ..Default::default() };
        let good = chi2_sphere(|_, u| Some(uniform_sphere(u)), |_| 1.0 / (4.0 * std::f64::consts::PI), &cfg);
        assert!(good.passes(1e-3), "{good:?}");
        assert!((good.pdf_integral - 1.0).abs() < 1e-6);
        // Claim a cosine-weighted density for uniform samples: must fail.
        let bad = chi2_sphere(|_, u| Some(uniform_sphere(u)), |d| (d.z.max(0.0) as f64) / std::f64::consts::PI, &cfg);
        assert!(!bad.passes(1e-3), "{bad:?}");
    }
}
