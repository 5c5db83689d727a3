//! Distant lighting given by its spherical-harmonic coefficients (docs/src/conventions.md §3):
//! L(ω) = Σ_k L_k Y_k(ω), k = l(l+1) + m, l ≤ l_max — the lighting of the paper's eq. 15 tests.
//!
//! Parameters: `coefficients`, (l_max + 1)² RGB triples, l_max ≤ `MAX_LMAX` = 30. A truncated
//! series can be negative somewhere; the light is then sampled by |L| and `value` = L/pdf keeps the
//! sign, so Monte Carlo estimates of linear functionals (the reflected light B_lm) stay unbiased.
//!
//! Evaluation uses [`analysis::sh::ShBasis`] into a fixed-size stack buffer (no allocation).
//! Sampling tabulates the luminance of |L| (`super::sampling_weight`) at the centres of a
//! `GRID_H` × `GRID_W` lat-long grid, adds a floor worth 10 % of the mass (so every direction has
//! pdf > 0, including where the centre value happens to vanish), and draws cells with `LatLongGrid`
//! (`light/latlong_grid.rs`): the density is constant on each cell.

use super::latlong_grid::LatLongGrid;
use super::{DistantLight, LightSample};
use crate::math::{PI, Rgb, Vec2, Vec3};
use analysis::sh::ShBasis;
use rayon::prelude::*;

/// Largest supported order (961 coefficients): the stack buffer of `eval` is sized for it.
pub const MAX_LMAX: usize = 30;
const MAX_COEFFICIENTS: usize = (MAX_LMAX + 1) * (MAX_LMAX + 1);
/// Sampling grid: 1.4° cells, finer than the ~6° lobes of l = 30.
const GRID_H: usize = 128;
const GRID_W: usize = 256;
/// Fraction of the sampling mass spread uniformly over the sphere.
const UNIFORM_FRACTION: f64 = 0.1;

#[derive(Clone, Debug)]
pub struct ShLight {
    /// L_lm in flat index order k = l(l+1) + m (docs/src/conventions.md §3).
    pub coefficients: Vec<Rgb>,
    lmax: usize,
    basis: ShBasis,
    /// The coefficients in f64 for the sum.
    coeff64: Vec<[f64; 3]>,
    grid: LatLongGrid,
}

impl ShLight {
    /// Fails unless the count is a perfect square (l_max + 1)² with l_max ≤ 30 and every
    /// coefficient is finite.
    pub fn new(coefficients: Vec<Rgb>) -> crate::Result<Self> {
        let n = coefficients.len();
        let side = (n as f64).sqrt().round() as usize;
        if n == 0 || side * side != n {
            return Err(crate::Error::new(format!(
                "sh lighting: {n} coefficients given; the count must be (lmax+1)² (1, 4, 9, 16, …)"
            )));
        }
        let lmax = side - 1;
        if lmax > MAX_LMAX {
            return Err(crate::Error::new(format!(
                "sh lighting: lmax = {lmax} ({n} coefficients) exceeds the supported maximum {MAX_LMAX}"
            )));
        }
        if let Some(k) = coefficients.iter().position(|c| !c.is_finite()) {
            return Err(crate::Error::new(format!("sh lighting: coefficient {k} is not finite ({})", coefficients[k])));
        }
        let coeff64 = coefficients.iter().map(|c| [c.x as f64, c.y as f64, c.z as f64]).collect();
        let mut light =
            ShLight { coefficients, lmax, basis: ShBasis::new(lmax), coeff64, grid: LatLongGrid::new(&[1.0], 1, 1) };
        light.grid = light.build_grid();
        Ok(light)
    }

    /// l_max of the series.
    pub fn lmax(&self) -> usize {
        self.lmax
    }

    /// L(dir) in double precision (for analysis tests); `dir` need not be normalised.
    #[inline]
    pub fn eval_f64(&self, dir: Vec3) -> [f64; 3] {
        let (x, y, z) = (dir.x as f64, dir.y as f64, dir.z as f64);
        let len = (x * x + y * y + z * z).sqrt();
        if len.is_nan() || len <= 0.0 {
            return [0.0; 3];
        }
        let d = [x / len, y / len, z / len];
        // Buffer sized by order class so low orders do not clear 961 doubles per call.
        match self.coeff64.len() {
            0..=25 => self.eval_with::<25>(d),
            26..=81 => self.eval_with::<81>(d),
            82..=289 => self.eval_with::<289>(d),
            _ => self.eval_with::<MAX_COEFFICIENTS>(d),
        }
    }

    #[inline]
    fn eval_with<const N: usize>(&self, d: [f64; 3]) -> [f64; 3] {
        let n = self.coeff64.len();
        let mut y = [0.0f64; N];
        self.basis.eval_into(d, &mut y[..n]);
        let mut s = [0.0f64; 3];
        for (yk, c) in y[..n].iter().zip(&self.coeff64) {
            s[0] += yk * c[0];
            s[1] += yk * c[1];
            s[2] += yk * c[2];
        }
        s
    }

    /// The luminance of |L| at the cell centres, plus the uniform floor.
    fn build_grid(&self) -> LatLongGrid {
        let mut g = vec![0f32; GRID_H * GRID_W];
        g.par_chunks_mut(GRID_W).enumerate().for_each(|(r, row)| {
            let theta = PI * (r as f32 + 0.5) / GRID_H as f32;
            for (c, v) in row.iter_mut().enumerate() {
                let phi = 2.0 * PI * (c as f32 + 0.5) / GRID_W as f32;
                let l = self.eval_f64(crate::math::spherical_direction(theta, phi));
                *v = super::sampling_weight(Rgb::new(l[0] as f32, l[1] as f32, l[2] as f32));
            }
        });
        // Σ g ΔΩ with ΔΩ = (2π/W)(cosθ_top − cosθ_bottom), then c·4π = α/(1−α) · Σ g ΔΩ.
        let mass: f64 = g
            .chunks_exact(GRID_W)
            .enumerate()
            .map(|(r, row)| {
                let h = std::f64::consts::PI / GRID_H as f64;
                let dz = (h * r as f64).cos() - (h * (r + 1) as f64).cos();
                row.iter().map(|&v| v as f64).sum::<f64>() * 2.0 * std::f64::consts::PI / GRID_W as f64 * dz
            })
            .sum();
        let floor = if mass > 0.0 {
            UNIFORM_FRACTION / (1.0 - UNIFORM_FRACTION) * mass / (4.0 * std::f64::consts::PI)
        } else {
            1.0
        };
        g.iter_mut().for_each(|v| *v = (*v as f64 + floor) as f32);
        LatLongGrid::new(&g, GRID_W, GRID_H)
    }
}

impl DistantLight for ShLight {
    #[inline]
    fn eval(&self, wi: Vec3) -> Rgb {
        let [r, g, b] = self.eval_f64(wi);
        Rgb::new(r as f32, g as f32, b as f32)
    }

    #[inline]
    fn sample(&self, u: Vec2) -> Option<LightSample> {
        let (wi, _) = self.grid.sample(u)?;
        // Recomputed from wi so that (pdf, value) agree exactly with pdf(wi) and eval(wi).
        let pdf = self.grid.pdf(wi);
        if pdf <= 0.0 {
            return None;
        }
        Some(LightSample { wi, value: self.eval(wi) / pdf, pdf, delta: false })
    }

    #[inline]
    fn pdf(&self, wi: Vec3) -> f32 {
        self.grid.pdf(wi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::testutil::check_light;
    use crate::sampling::chi2::{TestRng, integrate_sphere};

    /// An l_max = 4 lighting with strong higher orders: negative over a large part of the sphere.
    fn signed_light() -> ShLight {
        let mut rng = TestRng::new(21);
        let c = (0..25)
            .map(|k| {
                let mut v = || 2.0 * rng.next_f32() - 1.0;
                if k == 0 { Rgb::new(1.0, 0.8, 0.6) } else { Rgb::new(v(), v(), v()) * 0.9 }
            })
            .collect();
        ShLight::new(c).unwrap()
    }

    #[test]
    fn sh_eval_matches_closed_form_of_order_two() {
        // Check values of docs/src/conventions.md §3 for l ≤ 2.
        let c: Vec<Rgb> = (0..9).map(|k| Rgb::new(1.0 + k as f32, -0.5 * k as f32, (k as f32).sin())).collect();
        let l = ShLight::new(c.clone()).unwrap();
        let d = Vec3::new(0.3, -0.5, 0.7).normalize();
        let (x, y, z) = (d.x as f64, d.y as f64, d.z as f64);
        let yk = [
            0.282095,
            0.488603 * y,
            0.488603 * z,
            0.488603 * x,
            1.092548 * x * y,
            1.092548 * y * z,
            0.315392 * (3.0 * z * z - 1.0),
            1.092548 * x * z,
            0.546274 * (x * x - y * y),
        ];
        let got = l.eval_f64(d);
        for ch in 0..3 {
            let expect: f64 = (0..9).map(|k| yk[k] * c[k][ch] as f64).sum();
            assert!((got[ch] - expect).abs() < 1e-4, "channel {ch}: {} vs {expect}", got[ch]);
        }
        let e = l.eval(d * 3.0);
        assert!((e.x as f64 - got[0]).abs() < 1e-5, "eval normalises its argument");
    }

    #[test]
    fn sh_sampling_matches_pdf_and_keeps_the_sign() {
        let l = signed_light();
        check_light(&l, "sh lmax 4", 1.0);
        let mut rng = TestRng::new(4);
        let negative = (0..10_000)
            .filter_map(|_| l.sample(Vec2::new(rng.next_f32(), rng.next_f32())))
            .filter(|s| s.value.x < 0.0)
            .count();
        assert!(negative > 100, "the test lighting must have negative lobes ({negative} negative samples)");
    }

    #[test]
    fn sh_projection_recovers_coefficients() {
        // ∫ L Y_k dω = L_k by the midpoint rule on a 512 × 1024 (z, φ) grid: the integrand is a
        // polynomial of degree ≤ 8, so the error is O((2/512)² · 8²/24) ≈ 4e-5 relative.
        let l = signed_light();
        let basis = ShBasis::new(4);
        for k in [0usize, 3, 7, 12, 20, 24] {
            let p = integrate_sphere(
                |d| {
                    let y = basis.eval([d.x as f64, d.y as f64, d.z as f64]);
                    l.eval_f64(d)[1] * y[k]
                },
                512,
            );
            let expect = l.coefficients[k].y as f64;
            assert!((p - expect).abs() < 1e-3, "k={k}: {p} vs {expect}");
        }
    }

    #[test]
    fn sh_integral_by_sampling_is_unbiased() {
        // ∫ L dω = √(4π) L_00. MC with the light's samples (values signed): 4σ, σ = sqrt(var/n).
        let l = signed_light();
        let exact = (4.0 * std::f64::consts::PI).sqrt() * l.coefficients[0].x as f64;
        let mut rng = TestRng::new(8);
        let n = 200_000;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let v = l.sample(Vec2::new(rng.next_f32(), rng.next_f32())).map_or(0.0, |s| s.value.x as f64);
            s += v;
            s2 += v * v;
        }
        let mean = s / n as f64;
        let sigma = ((s2 / n as f64 - mean * mean) / n as f64).sqrt();
        assert!((mean - exact).abs() < 4.0 * sigma, "{mean} ± {sigma} vs {exact}");
    }

    #[test]
    fn sh_high_order_builds_and_evaluates() {
        // l_max = 30 (the largest allowed): a single Y_30,0 evaluates to its closed form at the pole,
        // Y_l0(+z) = √((2l+1)/4π).
        let mut c = vec![Rgb::ZERO; 961];
        c[30 * 31] = Rgb::ONE;
        let l = ShLight::new(c).unwrap();
        assert_eq!(l.lmax(), 30);
        let expect = (61.0 / (4.0 * std::f64::consts::PI)).sqrt();
        assert!((l.eval_f64(Vec3::Z)[0] - expect).abs() < 1e-9);
        let int = integrate_sphere(|d| l.pdf(d) as f64, 512);
        assert!((int - 1.0).abs() < 2e-3, "∫pdf = {int}");
    }

    #[test]
    fn sh_rejects_bad_coefficient_lists() {
        for n in [0usize, 2, 5, 10, 1024] {
            let e = ShLight::new(vec![Rgb::ONE; n]).unwrap_err().to_string();
            assert!(e.contains("sh lighting") && e.contains(&n.to_string()), "{e}");
        }
        let mut c = vec![Rgb::ONE; 4];
        c[2].y = f32::NAN;
        assert!(ShLight::new(c).unwrap_err().to_string().contains("coefficient 2"));
        // 31² = 961 is accepted, 32² = 1024 (l_max 31) is not (checked above).
        assert!(ShLight::new(vec![Rgb::ZERO; 961]).is_ok());
    }
}
