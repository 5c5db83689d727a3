//! Shared checks for the light tests: χ² of `sample` against `pdf`, normalisation of `pdf`, and
//! consistency of the returned sample (`pdf` field and `value = eval/pdf`).

use super::DistantLight;
use crate::math::Vec2;
use crate::sampling::chi2::{Chi2Config, Chi2Result, TestRng, chi2_sphere, integrate_sphere};

/// About ten χ² tests run in the light module: Šidák-corrected alpha ≈ 1e-3 / 10.
pub const ALPHA: f64 = 1e-4;

/// Runs the χ² test of `light.sample` against `light.pdf`, checks ∫pdf dω = `mass` (1, or the
/// probability that `sample` does not refuse), and checks 20 000 samples for `pdf` = pdf(wi) and
/// value = eval(wi)/pdf(wi) to relative 1e-4. Returns the χ² result for further checks.
pub fn check_light<L: DistantLight>(light: &L, name: &str, mass: f64) -> Chi2Result {
    // A fine quadrature of the expected counts (96² points per cell): lights have sharp features
    // (a sun disc, bright windows) that the default 6² midpoint rule integrates badly, and the
    // error of the expected mass is charged to the χ² statistic (via the "refused" cell).
    check_light_with(light, name, mass, 96)
}

/// [`check_light`] with `resolution`² quadrature points per χ² cell.
pub fn check_light_with<L: DistantLight>(light: &L, name: &str, mass: f64, resolution: usize) -> Chi2Result {
    let cfg = Chi2Config { resolution, ..Default::default() };
    let r = chi2_sphere(|_, u| light.sample(u).map(|s| s.wi), |d| light.pdf(d) as f64, &cfg);
    eprintln!("{name}: {r:?}");
    assert!(r.passes(ALPHA), "{name}: χ² rejects the sampler: {r:?}");
    // ∫pdf by a fine midpoint rule (4096 × 8192): a piecewise-constant pdf with a bright spot has
    // an O(h × jump × edge length) quadrature error, ≈ 1e-3 for the test maps at n = 1024.
    let int = integrate_sphere(|d| light.pdf(d) as f64, 4096);
    assert!((int - mass).abs() < 2e-3, "{name}: ∫pdf dω = {int}, expected {mass}");
    let mut rng = TestRng::new(99);
    for _ in 0..20_000 {
        let Some(s) = light.sample(Vec2::new(rng.next_f32(), rng.next_f32())) else { continue };
        assert!((s.wi.length() - 1.0).abs() < 1e-4, "{name}: |wi| = {}", s.wi.length());
        assert!(!s.delta && s.pdf > 0.0 && s.pdf.is_finite(), "{name}: {s:?}");
        let pdf = light.pdf(s.wi);
        assert!((s.pdf - pdf).abs() <= 1e-4 * pdf, "{name}: sample pdf {} vs pdf(wi) {pdf}", s.pdf);
        let expect = light.eval(s.wi) / pdf;
        let err = (s.value - expect).abs().max_element();
        assert!(err <= 1e-4 * expect.abs().max_element().max(1e-12), "{name}: value {} vs eval/pdf {expect}", s.value);
    }
    r
}
