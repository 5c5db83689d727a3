//! Check 2, the 9-term irradiance approximation (sec. 3.5).
//!
//! (a) A Lambertian sphere (albedo 1) under the Grace probe through the `normal-probe` camera; its
//! 9-coefficient reconstruction B₉ (weighted least squares of the image on Y_lm, l ≤ 2) and the
//! relative error e = (B − B₉)/B over the sphere: its solid-angle rms with the noise's share
//! subtracted (deciding; unbiased), mean |e| and max |e| (informative: both are biased upward by
//! the pixel noise). Expected: the same
//! numbers computed from the analytic prediction B(n) = Σ_{l≤16} (Λ_l ρ̂_l) L_lm Y_lm(n) sampled on
//! the same grid and processed identically (so the grid's quadrature error cancels). σ of the
//! rms by propagation of the pixel σ through e (delta method; B₉'s own noise neglected: it
//! averages the whole image).
//! (b) The kernel's energy share in l ≤ 2, Σ_{l≤2} ρ̂_l² / ∫ρ̂² = 127/128, measured on the
//! (deterministic) directional-source render of the same sphere by lat-long quadrature of B and
//! B²; the quadrature error (same quadrature of the exact kernel − 127/128) is stated.
//! Wrong prediction: rms error × 1.05 and energy share 0.99.

use super::Ctx;
use super::check::{Check, F32_FLOOR, Row};
use super::fit::{Channel, latlong_dir, latlong_omega, order_parts, project_probe};
use super::picture::Picture;
use super::scenes::lambert;
use super::scenes::{Lighting, Spec, render_spec};
use super::{grace, transfer};
use analysis::sh::{ShBasis, index, num_coefficients};

pub const NAME: &str = "irradiance9";
pub const EQUATION: &str = "sec. 3.5 (eq. 38-39)";

pub use analysis::fit::NineTerm;

/// [`analysis::fit::nine_term_error`] of a probe channel.
pub fn nine_term_error(ch: &Channel) -> Option<NineTerm> {
    analysis::fit::nine_term_error(&ch.value, &ch.sigma, ch.width, ch.height)
}

/// Energy share in l ≤ 2 of a probe image: Σ_{l≤2} Σ_m B_lm² / ∫ B² (quadrature).
pub fn energy_share(ch: &Channel) -> f64 {
    let (b, _) = project_probe(ch, 2);
    let (w, h) = (ch.width, ch.height);
    let tot: f64 = (0..w * h).map(|i| latlong_omega(i / w, w, h) * ch.value[i].powi(2)).sum();
    b.iter().map(|v| v * v).sum::<f64>() / tot
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let mut c = Check::new(
        NAME,
        EQUATION,
        "9-term (l ≤ 2) approximation of Lambertian reflection under Grace; energy share 127/128",
    );
    let lg = grace::coefficients(ctx)?;
    let spec = Spec::probe(ctx, ctx.spp(256, 512), Lighting::Grace(1.0), lambert(1.0));
    let ch = Channel::from_film(&render_spec(ctx, &spec)?, grace::CHANNEL);
    let m = nine_term_error(&ch).ok_or("non-positive pixel or singular fit")?;
    // The prediction on the same grid.
    let a = transfer::lambert(grace::LMAX);
    let basis = ShBasis::new(grace::LMAX);
    let mut y = vec![0.0; num_coefficients(grace::LMAX)];
    let mut s = vec![0.0; grace::LMAX + 1];
    let pred = Channel {
        value: (0..ch.width * ch.height)
            .map(|i| {
                order_parts(&basis, &lg, latlong_dir(i / ch.width, i % ch.width, ch.width, ch.height), &mut y, &mut s);
                (0..=grace::LMAX).map(|l| a[l] * s[l]).sum()
            })
            .collect(),
        sigma: vec![0.0; ch.width * ch.height],
        ..ch.clone()
    };
    let p = nine_term_error(&pred).ok_or("prediction not positive")?;
    c.pictures.push(Picture::probe_filter(
        "irradiance9",
        format!("Lambertian sphere under Grace (green), normal probe {}×{}, {} spp", ch.width, ch.height, spec.spp),
        "the 9-term approximation B₉: eq. 38/π filter on the Grace L_lm, l ≤ 2 only (its error is the claim's few %)",
        &ch,
        &lg,
        &a[..3],
        |_| 0.0,
    ));
    let wrong = if ctx.wrong { 1.05 } else { 1.0 };
    c.push(Row::new("rms relative error of B₉ (noise-debiased)", wrong * p.rms(), m.rms(), m.sigma_rms()));
    c.push(
        Row::new(
            "mean |B − B₉|/B of the render (measured) vs of the predicted image (expected)",
            p.mean_abs,
            m.mean_abs,
            0.0,
        )
        .informative(),
    );
    c.push(
        Row::new(
            "max |B − B₉|/B of the render (measured) vs of the predicted image (expected)",
            p.max_abs,
            m.max_abs,
            0.0,
        )
        .informative(),
    );

    // Energy share on the directional (impulse-response) render.
    let spec = Spec::probe(ctx, 4, Lighting::Directional { direction: [0.0, 0.0, 1.0], irradiance: 1.0 }, lambert(1.0));
    let dch = Channel::from_film(&render_spec(ctx, &spec)?, 0);
    let share = energy_share(&dch);
    let exact_img = Channel {
        value: (0..dch.width * dch.height)
            .map(|i| {
                transfer::lambert_lobe(
                    latlong_dir(i / dch.width, i % dch.width, dch.width, dch.height)[2].clamp(-1.0, 1.0).acos(),
                )
            })
            .collect(),
        ..dch.clone()
    };
    let qshare = energy_share(&exact_img);
    let expected = if ctx.wrong { 0.99 } else { 127.0 / 128.0 };
    c.push(
        Row::new("kernel energy share in l ≤ 2", expected, share, 0.0)
            .approx(qshare - 127.0 / 128.0)
            .floor(10.0 * F32_FLOOR),
    );
    c.note(format!(
        "Grace (green), normal-probe {}×{}, {} spp; predicted rms/mean/max 9-term relative error {:.4}/{:.4}/{:.4}, measured {:.4} ± {:.4} / {:.4} / {:.4} (mean and max of |e| are biased up by the noise)",
        spec.width, spec.height, ctx.spp(256, 512), p.rms(), p.mean_abs, p.max_abs, m.rms(), m.sigma_rms(), m.mean_abs, m.max_abs
    ));
    c.note(format!(
        "energy share: measured {share:.6}, same quadrature of the exact kernel {qshare:.6}, 127/128 = {:.6}",
        127.0 / 128.0
    ));
    let _ = index(0, 0);
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn energy_share_of_the_clamped_cosine_is_127_over_128() {
        let ch = Channel::synthetic_probe(512, 256, |n| transfer::lambert_lobe(n[2].clamp(-1.0, 1.0).acos()), 0.0, 1);
        assert!((energy_share(&ch) - 127.0 / 128.0).abs() < 2e-4);
        // A sharper kernel (Phong s = 8) has much less of its energy in l ≤ 2: the check can fail.
        let ch =
            Channel::synthetic_probe(512, 256, |n| transfer::phong_lobe(8.0, n[2].clamp(-1.0, 1.0).acos()), 0.0, 1);
        assert!(energy_share(&ch) < 0.9);
    }

    #[test]
    fn nine_term_error_of_a_band_limited_image_is_zero_and_grows_with_structure() {
        let ch = Channel::synthetic_probe(96, 48, |n| 2.0 + n[0] + 0.5 * n[1] * n[2], 0.0, 1);
        let m = nine_term_error(&ch).unwrap();
        assert!(m.rms() < 1e-10 && m.max_abs < 1e-10);
        let ch = Channel::synthetic_probe(96, 48, |n| 2.0 + n[0] * n[0] * n[0] * n[1], 0.0, 1);
        assert!(nine_term_error(&ch).unwrap().rms() > 1e-3);
    }
}
