//! `mix`: a weighted sum of BRDFs, ρ̂ = Σ_j w_j ρ̂_j (docs/src/conventions.md §4; e.g. diffuse + specular as in
//! the paper's reference \[17\]).
//!
//! Parameters: `layers` = [(w_j, BRDF_j)], weights w_j ≥ 0 (negative weights are not selected by
//! sampling; the scene loader should reject them).
//!
//! Sampling is one-sample MIS over the layers: layer j is chosen with probability
//! p_j = w_j / Σw using `u_lobe` (remapped to [0,1) for the layer's own use), its direction is
//! drawn, and the returned density is the mixture pdf Σ_k p_k pdf_k(ω_i), so the weight
//! ρ̂/pdf stays bounded wherever any layer samples well. Dirac layers (mirror) are not part of
//! `eval`/`pdf`; their draws come back with `delta = true`, weight = w_j·k_r / p_j and pdf = p_j
//! (times the layer's own delta pdf). `is_delta` holds only if every layer is a Dirac;
//! `ignores_horizon` if any layer ignores it.
use super::{BrdfSamples, Bxdf, Outgoing};
use crate::simd::{Float, Float3, Isa, Mask, Sse2};

#[derive(Clone, Debug)]
pub struct Mix {
    pub layers: Vec<(f32, super::Brdf)>,
    /// 1 / Σ max(w_j, 0): turns a weight into a selection probability.
    inv_total: f32,
    all_delta: bool,
    any_ignore: bool,
}
impl Mix {
    pub fn new(layers: Vec<(f32, super::Brdf)>) -> Self {
        let total: f32 = layers.iter().map(|(w, _)| w.max(0.0)).sum();
        let inv_total = if total > 0.0 { 1.0 / total } else { 0.0 };
        let all_delta = !layers.is_empty() && layers.iter().all(|(_, b)| b.is_delta());
        let any_ignore = layers.iter().any(|(_, b)| b.ignores_horizon());
        Mix { layers, inv_total, all_delta, any_ignore }
    }

    /// Selection probability of a layer of weight w.
    #[inline]
    fn prob(&self, w: f32) -> f32 {
        w.max(0.0) * self.inv_total
    }

    /// Picks a layer with probability p_j from u ∈ [0,1); returns its index, p_j and u remapped to
    /// [0,1).
    #[inline]
    fn choose(&self, u: f32) -> Option<(usize, f32, f32)> {
        let mut cdf = 0.0;
        let mut last = None;
        for (j, (w, _)) in self.layers.iter().enumerate() {
            let p = self.prob(*w);
            if p <= 0.0 {
                continue;
            }
            if u < cdf + p {
                return Some((j, p, ((u - cdf) / p).clamp(0.0, 1.0 - f32::EPSILON * 0.5)));
            }
            cdf += p;
            last = Some((j, p, cdf - p));
        }
        // Rounding left u just above the last cdf: give it to the last selectable layer.
        last.map(|(j, p, c)| (j, p, ((u - c) / p).clamp(0.0, 1.0 - f32::EPSILON * 0.5)))
    }
}
impl Bxdf for Mix {
    #[inline]
    fn eval_at<const N: usize, S: Isa>(&self, o: &Outgoing<N, S>, wi: Float3<N, S>) -> Float3<N, S> {
        if S::AVX2 {
            // See `sample_at`.
            return self.eval_at(&o.with_isa::<Sse2>(), wi.with_isa()).with_isa();
        }
        let mut acc = Float3::ZERO;
        for (w, b) in &self.layers {
            acc = acc + b.eval_at(&b.outgoing(o.wo), wi) * *w;
        }
        acc
    }

    /// Each lane draws from the layer its `u_lobe` chooses: every layer chosen by some lane samples
    /// all lanes, and each lane keeps its own layer's draw.
    #[inline]
    fn sample_at<const N: usize, S: Isa>(
        &self,
        o: &Outgoing<N, S>,
        u_lobe: Float<N, S>,
        u: [Float<N, S>; 2],
    ) -> BrdfSamples<N, S> {
        if S::AVX2 {
            // A mix calls its layers through `Brdf`, which may be a mix: recursive, hence out of
            // line, hence compiled without AVX2, where 256-bit operations would be calls. Its
            // lanes run in SSE registers instead, with the same bits.
            let u = [u[0].with_isa(), u[1].with_isa()];
            return self.sample_at(&o.with_isa::<Sse2>(), u_lobe.with_isa(), u).with_isa();
        }
        let wo = o.wo;
        let (mut layer, mut p, mut u_sub) = ([usize::MAX; N], [0.0f32; N], [0.0f32; N]);
        for k in 0..N {
            if let Some((j, pj, us)) = self.choose(u_lobe.0[k]) {
                (layer[k], p[k], u_sub[k]) = (j, pj, us);
            }
        }
        let (p, u_sub) = (Float::from_array(p), Float::from_array(u_sub));
        let mut s = BrdfSamples::NONE;
        for (j, (_, b)) in self.layers.iter().enumerate() {
            let mut chosen = [false; N];
            for k in 0..N {
                chosen[k] = layer[k] == j;
            }
            let chosen = Mask::from_bools(chosen);
            if chosen.any() {
                s = BrdfSamples::select(chosen, &b.sample_at(&b.outgoing(wo), u_sub, u), &s);
            }
        }
        // A Dirac layer: w_j k_r / p_j = k_r Σw. The others: the mixture's ρ̂ and density.
        let pdf = self.pdf_at(o, s.wi);
        let weight = self.eval_at(o, s.wi) / pdf;
        let continuous = pdf.is_finite() & pdf.gt(Float::ZERO);
        BrdfSamples {
            wi: s.wi,
            weight: Float3::select(s.delta, s.weight * (1.0 / self.inv_total), weight),
            pdf: s.delta.select(s.pdf * p, pdf),
            delta: s.delta,
            valid: !wo.z.le(Float::ZERO) & s.valid & (s.delta | continuous),
        }
    }

    #[inline]
    fn pdf_at<const N: usize, S: Isa>(&self, o: &Outgoing<N, S>, wi: Float3<N, S>) -> Float<N, S> {
        if S::AVX2 {
            // See `sample_at`.
            return self.pdf_at(&o.with_isa::<Sse2>(), wi.with_isa()).with_isa();
        }
        let mut acc = Float::ZERO;
        for (w, b) in &self.layers {
            acc = acc + self.prob(*w) * b.pdf_at(&b.outgoing(o.wo), wi);
        }
        acc
    }

    #[inline]
    fn ignores_horizon(&self) -> bool {
        self.any_ignore
    }

    #[inline]
    fn is_delta(&self) -> bool {
        self.all_delta
    }

    #[inline]
    fn uses_lobe_choice(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brdf::Brdf;
    use crate::brdf::testutil::*;
    use crate::brdf::{Horizon, Lambert, Microfacet, MicrofacetDistribution, Mirror, Phong, TorranceSparrow};
    use crate::math::{Rgb, Vec2, Vec3};
    use crate::sampling::chi2::chi2_sphere;

    const THETAS: [f32; 3] = [0.0, 30.0, 70.0];

    fn diffuse_glossy() -> Mix {
        Mix::new(vec![
            (0.6, Brdf::Lambert(Lambert::new(Rgb::new(0.8, 0.6, 0.4)))),
            (0.4, Brdf::Phong(Phong::new(Rgb::ONE, 8.0, Horizon::Clamp))),
        ])
    }

    fn diffuse_ts_mirror() -> Mix {
        Mix::new(vec![
            (0.5, Brdf::Lambert(Lambert::new(Rgb::ONE))),
            (0.3, Brdf::TorranceSparrow(TorranceSparrow::new(Rgb::ONE, 0.3, Horizon::Clamp))),
            (0.2, Brdf::Mirror(Mirror::new(Rgb::new(0.9, 0.8, 0.7)))),
        ])
    }

    #[test]
    fn eval_is_weighted_sum() {
        let m = diffuse_glossy();
        let wo = dir_theta_deg(30.0);
        let wi = dir_theta_deg(-25.0);
        let want = 0.6 * m.layers[0].1.eval(wo, wi) + 0.4 * m.layers[1].1.eval(wo, wi);
        assert!((m.eval(wo, wi) - want).abs().max_element() < 1e-6);
        let pw = 0.6 * m.layers[0].1.pdf(wo, wi) + 0.4 * m.layers[1].1.pdf(wo, wi);
        assert!((m.pdf(wo, wi) - pw).abs() < 1e-6);
    }

    /// Chi-square of the mixture; delta draws (mirror) are turned into refusals, whose expected
    /// count is then the pdf's missing mass (= the mirror's selection probability).
    #[test]
    fn chi2_mixtures() {
        for m in [diffuse_glossy(), diffuse_ts_mirror()] {
            for t in THETAS {
                let wo = dir_theta_deg(t);
                let r = chi2_sphere(
                    |ul, u| m.sample(wo, ul, u).filter(|s| !s.delta).map(|s| s.wi),
                    |wi| m.pdf(wo, wi) as f64,
                    &chi2_cfg(),
                );
                assert!(r.passes(ALPHA), "θo={t}: {r:?}");
            }
        }
    }

    /// Claiming only the Lambert layer's pdf for the whole mixture must fail.
    #[test]
    fn chi2_rejects_wrong_pdf() {
        let m = diffuse_glossy();
        let wo = dir_theta_deg(30.0);
        let r =
            chi2_sphere(|ul, u| m.sample(wo, ul, u).map(|s| s.wi), |wi| m.layers[0].1.pdf(wo, wi) as f64, &chi2_cfg());
        assert!(!r.passes(ALPHA), "{r:?}");
    }

    #[test]
    fn pdf_mass_weights_and_delta_samples() {
        let m = diffuse_ts_mirror();
        for t in THETAS {
            let wo = dir_theta_deg(t);
            check_sample_consistency(&m, wo, 20_000, 4);
            check_sample_consistency(&diffuse_glossy(), wo, 20_000, 4);
            // Non-delta mass: pdf integral = fraction of draws that are kept and non-delta.
            let (mass, qe) = integrate_zoomed_err(|wi| m.pdf(wo, wi) as f64, Vec3::Z, 1.0, 1024, 1e-6);
            let mut rng = crate::sampling::chi2::TestRng::new(12);
            let n = 1_000_000;
            let (mut kept, mut deltas) = (0usize, 0usize);
            for _ in 0..n {
                let ul = rng.next_f32();
                match m.sample(wo, ul, Vec2::new(rng.next_f32(), rng.next_f32())) {
                    Some(s) if s.delta => {
                        deltas += 1;
                        assert!((s.wi - refl(wo)).length() < 1e-6);
                        assert!((s.pdf - 0.2).abs() < 1e-6);
                        // w·k_r/p = 0.2 k_r / 0.2.
                        assert!((s.weight - Rgb::new(0.9, 0.8, 0.7)).abs().max_element() < 1e-5);
                    }
                    Some(_) => kept += 1,
                    None => {}
                }
            }
            let f = kept as f64 / n as f64;
            let sf = (f * (1.0 - f) / n as f64).sqrt();
            // 5σ binomial + the quadrature's stated error.
            assert!((mass - f).abs() < 5.0 * sf + qe, "θo={t}: mass {mass} ± {qe:.1e} vs {f}");
            let fd = deltas as f64 / n as f64;
            assert!((fd - 0.2).abs() < 5.0 * (0.2f64 * 0.8 / n as f64).sqrt(), "{fd}");
        }
    }

    /// Lambert (albedo 1, w = 0.5) + Phong ignore (k_s = 1, w = 0.5) has albedo exactly 1; with a
    /// mirror layer the Dirac adds w·k_r. MC with 5σ (σ from the sample variance).
    #[test]
    fn albedo() {
        let m = Mix::new(vec![
            (0.5, Brdf::Lambert(Lambert::new(Rgb::ONE))),
            (0.5, Brdf::Phong(Phong::new(Rgb::ONE, 16.0, Horizon::Ignore))),
        ]);
        for t in THETAS {
            let (a, e) = albedo_mc(&m, dir_theta_deg(t), 1_000_000, 2);
            assert!((a.x - 1.0).abs() < 5.0 * e.x + 1e-6, "θo={t}: {a} ± {e}");
        }
        let m = Mix::new(vec![
            (0.7, Brdf::Lambert(Lambert::new(Rgb::ONE))),
            (0.3, Brdf::Mirror(Mirror::new(Rgb::new(1.0, 0.5, 0.0)))),
        ]);
        let (a, e) = albedo_mc(&m, dir_theta_deg(40.0), 1_000_000, 3);
        let want = glam::DVec3::new(1.0, 0.85, 0.7);
        assert!((a - want).abs().max_element() < 5.0 * e.max_element(), "{a} ± {e}");
        // Energy: every mixture of unit layers with Σw = 1 stays ≤ 1.
        for mm in [diffuse_glossy(), diffuse_ts_mirror()] {
            for t in THETAS {
                let (a, e) = albedo_mc(&mm, dir_theta_deg(t), 1_000_000, 5);
                assert!((a - 5.0 * e).max_element() <= 1.0, "θo={t}: {a}");
            }
        }
    }

    #[test]
    fn flags_and_reciprocity() {
        let mirrors = Mix::new(vec![
            (0.5, Brdf::Mirror(Mirror::new(Rgb::ONE))),
            (0.5, Brdf::Mirror(Mirror::new(Rgb::splat(0.5)))),
        ]);
        assert!(mirrors.is_delta() && !diffuse_ts_mirror().is_delta());
        let ign = Mix::new(vec![
            (0.5, Brdf::Lambert(Lambert::new(Rgb::ONE))),
            (0.5, Brdf::Phong(Phong::new(Rgb::ONE, 16.0, Horizon::Ignore))),
        ]);
        assert!(ign.ignores_horizon() && !diffuse_glossy().ignores_horizon());
        assert!(!Mix::new(vec![]).is_delta());
        assert!(Mix::new(vec![]).sample(Vec3::Z, 0.5, Vec2::splat(0.5)).is_none());
        check_reciprocity(
            &Mix::new(vec![
                (0.5, Brdf::Lambert(Lambert::new(Rgb::ONE))),
                (
                    0.5,
                    Brdf::Microfacet(Microfacet::new(
                        MicrofacetDistribution::Ggx,
                        0.3,
                        crate::brdf::Fresnel::Schlick { f0: Rgb::splat(0.04) },
                    )),
                ),
            ]),
            3,
        );
    }

    /// u_lobe is remapped: a layer sees the full [0,1) range of its own u_lobe (nested mixes).
    #[test]
    fn lobe_selection_remap() {
        let m = diffuse_glossy();
        let (j, p, u) = m.choose(0.3).unwrap();
        assert!(j == 0 && (p - 0.6).abs() < 1e-6 && (u - 0.5).abs() < 1e-6);
        let (j, p, u) = m.choose(0.8).unwrap();
        assert!(j == 1 && (p - 0.4).abs() < 1e-6 && (u - 0.5).abs() < 1e-5);
        let (_, _, u) = m.choose(1.0 - 1e-7).unwrap();
        assert!(u < 1.0);
    }
}
