//! The report of an analysis ([`AnalyzeReport`]): what `reflect analyze --json` prints, and its
//! text form (`Display`).

use crate::filter::{ChannelFit, OrderStatus, PixelOrder};
use crate::observation::pixels::PixelNoise;
use serde_json::Value;

/// The sphere analysed (world space).
#[derive(Clone, Debug, serde::Serialize)]
pub struct SphereReport {
    pub center: [f64; 3],
    pub radius: f64,
}

/// The lighting compared with: where it came from and its L_lm (RGB, index order, l ≤ lmax).
#[derive(Clone, Debug, serde::Serialize)]
pub struct LightingReport {
    pub source: String,
    pub coefficients: Vec<[f64; 3]>,
}

/// Everything `reflect analyze` computes; `--json` prints this struct, the text output is its
/// [`Display`](std::fmt::Display). Coefficient lists are in index order k = l(l + 1) + m, labelled
/// by `lm`; every RGB channel is carried.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AnalyzeReport {
    pub lmax: usize,
    /// The highest order the input carries (`crate::projection::resolution`).
    pub lmax_carried: usize,
    pub images: Vec<String>,
    pub method: String,
    /// `normal` or `reflection`: the direction B is a function of.
    pub param: String,
    pub sphere: SphereReport,
    pub pixels_used: usize,
    /// `stderr-layer`, `residuals` or `none`.
    pub stderr_source: String,
    /// Weighted RMS residual of the B_lm fit per channel (orthographic views).
    pub rms_residual: Option<[f64; 3]>,
    /// (l, m) of each entry of `coefficients`, `stderr`, `lighting.coefficients`, `predicted`.
    pub lm: Vec<(usize, i64)>,
    /// B_lm.
    pub coefficients: Vec<[f64; 3]>,
    pub stderr: Option<Vec<[f64; 3]>>,
    pub lighting: Option<LightingReport>,
    /// The measured filter A_l = albedo · Λ_l ρ̂_l per order, fitted in pixel space for the known
    /// lighting (`crate::filter::fit_filter_pixels`), with its error budget and conditioning.
    pub filter: Option<Vec<PixelOrder>>,
    /// χ², ν, χ²/ν, p-value, error scale and covariance of the filter fit, per channel R, G, B.
    pub filter_fit: Option<Vec<ChannelFit>>,
    /// The BRDF table of the header (`reflect:objects`), as written there.
    pub brdf: Option<Value>,
    /// Analytic Λ_l ρ̂_l (eq. 38/43/33/50) scaled by the header's albedo / k_s / k_r, per l.
    pub lambda_rho_analytic: Option<Vec<[f64; 3]>>,
    /// B_lm predicted by eq. 15 from the lighting and the analytic filter.
    pub predicted: Option<Vec<[f64; 3]>>,
    /// Orthographic views: the correlation of neighbouring pixels' noise (a reconstruction filter
    /// wider than a pixel) and the variance inflation applied to every error bar's noise part.
    pub pixel_noise: Option<PixelNoise>,
    /// Whether the image contradicts what it was told (lighting, BRDF, camera): the measured
    /// filter against the analytic one, χ² with ν and p, and the most likely wrong assumption
    /// (`crate::verdict`); `None` without a lighting or without a BRDF with a transfer model.
    pub verdict: Option<crate::verdict::Verdict>,
    /// Notes and warnings, each one sentence (printed on stderr, not in the text report).
    pub warnings: Vec<String>,
    /// The `note: …` lines of the pixel-noise decision (what a given pixel filter left out), for
    /// stderr; not in the `--json` document.
    #[serde(skip)]
    pub notes: Vec<String>,
}

impl std::fmt::Display for AnalyzeReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "# {} — {}", self.images.join(", "), self.method)?;
        writeln!(
            f,
            "# pixels used {}, standard errors from {}; the input carries l <= {}",
            self.pixels_used, self.stderr_source, self.lmax_carried
        )?;
        if let Some(r) = self.rms_residual {
            writeln!(f, "# weighted RMS residual of the fit: {:.3e} {:.3e} {:.3e}", r[0], r[1], r[2])?;
        }
        if let Some(n) = &self.pixel_noise {
            writeln!(f, "{}", n.line())?;
        }
        if let Some(l) = &self.lighting {
            writeln!(f, "# lighting: {}", l.source)?;
        }
        if let Some(b) = &self.brdf {
            writeln!(f, "# brdf: {}", shown_json(b))?;
        }
        writeln!(f, "{:>4} {:>4} {:>26} {:>26} {:>26}", "l", "m", "B_lm R ± se", "G ± se", "B ± se")?;
        for (k, v) in self.coefficients.iter().enumerate() {
            let (l, m) = self.lm[k];
            let se = self.stderr.as_ref().map(|s| s[k]);
            let cell = |ch: usize| match se {
                Some(s) => format!("{:.5e} ± {:.1e}", v[ch], s[ch]),
                None => format!("{:.5e}", v[ch]),
            };
            writeln!(f, "{l:>4} {m:>4} {:>26} {:>26} {:>26}", cell(0), cell(1), cell(2))?;
        }
        if let (Some(orders), Some(fits)) = (&self.filter, &self.filter_fit) {
            writeln!(
                f,
                "\n# measured filter A_l = albedo · Λ_l ρ̂_l, fitted in pixel space: B(d) = Σ_l A_l Σ_m L_lm Y_lm(d) \
                 over the used pixels; ± total (noise ⊕ truncation)"
            )?;
            writeln!(
                f,
                "{:>4} {:>26} {:>26} {:>26} {:>14}",
                "l",
                "R ± se",
                "G ± se",
                "B ± se",
                if self.lambda_rho_analytic.is_some() { "analytic (R)" } else { "" }
            )?;
            for o in orders {
                let cell = |ch: usize| match (o.estimate[ch], o.stderr[ch]) {
                    (Some(e), Some(s)) => {
                        // Ill-conditioned or undetermined (truncation): the warnings say which.
                        let flag = if matches!(o.status[ch], OrderStatus::IllConditioned | OrderStatus::Undetermined) {
                            " !"
                        } else {
                            ""
                        };
                        format!("{e:.5e} ± {s:.1e}{flag}")
                    }
                    (Some(e), None) => format!("{e:.5e}"),
                    _ => "unobservable".to_string(),
                };
                let an = self.lambda_rho_analytic.as_ref().map(|a| format!("{:.5e}", a[o.l][0])).unwrap_or_default();
                writeln!(f, "{:>4} {:>26} {:>26} {:>26} {:>14}", o.l, cell(0), cell(1), cell(2), an)?;
            }
            writeln!(f, "# error budget (R): noise, truncation, amplification of the design")?;
            for o in orders {
                let g = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.1e}"));
                writeln!(
                    f,
                    "{:>4} {:>10} {:>10} {:>8}",
                    o.l,
                    g(o.stderr_noise[0]),
                    g(o.truncation[0]),
                    o.amplification[0].map_or("-".to_string(), |v| format!("{v:.2}"))
                )?;
            }
            let chi = |c: &ChannelFit| match (c.chi2_per_dof, c.p_value) {
                (Some(x), Some(p)) => {
                    format!(
                        "{x:.3} (ν {}, p {p:.1e}, robust {:.3}, misfit {:.1} %)",
                        c.dof,
                        c.robust_chi2_per_dof.unwrap_or(f64::NAN),
                        100.0 * c.relative_misfit
                    )
                }
                (Some(x), None) => format!("{x:.3e} (ν {})", c.dof),
                _ => "-".to_string(),
            };
            if fits.iter().all(|c| c.p_value.is_none()) {
                // Without per-pixel standard errors Σ r²/ν is not a χ² (there is no σ to divide by):
                // it is the residual variance the noise is estimated from.
                writeln!(
                    f,
                    "# filter fit residual variance σ̂² = Σ_p r_p²/ν (no stderr layer: the noise estimate, not a χ² test): \
                     R {}, G {}, B {}",
                    chi(&fits[0]),
                    chi(&fits[1]),
                    chi(&fits[2])
                )?;
            } else {
                writeln!(
                    f,
                    "# filter fit χ²/ν at l <= {} (the orders above it are signal this fit leaves in the residual, so \
                     it exceeds 1 by the truncation; not the verdict's test): R {}, G {}, B {}",
                    self.lmax,
                    chi(&fits[0]),
                    chi(&fits[1]),
                    chi(&fits[2])
                )?;
            }
            if let Some(top) = fits.iter().filter_map(|c| c.truncation_lmax).max() {
                let x = |c: &ChannelFit| c.truncation_chi2_per_dof.map_or("-".to_string(), |x| format!("{x:.3}"));
                let what = if fits.iter().all(|c| c.p_value.is_none()) {
                    "residual variance (the noise σ̂² of the error bars)"
                } else {
                    "χ²/ν (truncation_chi2_per_dof: above 2 is scatter beyond the σ, said in a warning)"
                };
                writeln!(
                    f,
                    "# with the orders up to l = {top}, {what}: R {}, G {}, B {}",
                    x(&fits[0]),
                    x(&fits[1]),
                    x(&fits[2])
                )?;
            }
        }
        if let Some(v) = &self.verdict {
            writeln!(f, "# {}", v.line)?;
        }
        Ok(())
    }
}

/// A JSON value (a scene's BRDF table) for a text report, its numbers with the precision they have:
/// a value stored as f32 (0.800000011920929) is printed as that f32's shortest decimal (0.8).
pub fn shown_json(v: &serde_json::Value) -> String {
    fn tidy(v: &serde_json::Value) -> serde_json::Value {
        use serde_json::Value;
        match v {
            Value::Number(n) => match n.as_f64() {
                Some(x) if n.is_f64() && (x as f32) as f64 == x => {
                    format!("{}", x as f32).parse::<f64>().map_or(v.clone(), |y| serde_json::json!(y))
                }
                _ => v.clone(),
            },
            Value::Array(a) => Value::Array(a.iter().map(tidy).collect()),
            Value::Object(o) => Value::Object(o.iter().map(|(k, x)| (k.clone(), tidy(x))).collect()),
            _ => v.clone(),
        }
    }
    tidy(v).to_string()
}
