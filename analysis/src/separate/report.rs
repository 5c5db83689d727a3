//! The report of a separation ([`InvertSeparateReport`]): what `reflect invert separate --json`
//! prints, and its text form (`Display`).

use super::CHANNELS;
use crate::image::Image;
use crate::sh::{lm, reconstruct_latlong};

/// A value per analysed channel: with one `--channel` the value itself, with all three an
/// [r, g, b] triple (the JSON keeps that shape: numbers for one channel, triples for three).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(untagged)]
pub enum PerChannel<T> {
    One(T),
    Rgb(Vec<T>),
}

impl<T> PerChannel<T> {
    /// One value per analysed channel (in [`InvertSeparateReport::channels`] order).
    pub(super) fn of(mut v: Vec<T>) -> PerChannel<T> {
        if v.len() == 1 { PerChannel::One(v.remove(0)) } else { PerChannel::Rgb(v) }
    }

    /// The values in channel order.
    pub fn cells(&self) -> &[T] {
        match self {
            PerChannel::One(x) => std::slice::from_ref(x),
            PerChannel::Rgb(v) => v,
        }
    }
}

impl std::fmt::Display for PerChannel<f64> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PerChannel::One(x) => write!(f, "{x}"),
            PerChannel::Rgb(v) => write!(f, "[{}]", v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", ")),
        }
    }
}

/// The diffuse view (the first image, θ_o = 0).
#[derive(Clone, Debug, serde::Serialize)]
pub struct DiffuseView {
    pub file: String,
    pub theta_o_deg: f64,
}

/// A specular view (θ_o > 0, φ_o ∈ {0°, 180°}).
#[derive(Clone, Debug, serde::Serialize)]
pub struct SpecularView {
    pub file: String,
    pub theta_o_deg: f64,
    pub phi_o_deg: f64,
}

/// The diffuse side's low-order lighting L̂_lm = B_lm / (k_d Λ_l ρ̂_l + k_s), l ≤ 2 (index order).
#[derive(Clone, Debug, serde::Serialize)]
pub struct DiffuseSide {
    pub description: String,
    pub coefficients: Vec<PerChannel<f64>>,
    pub stderr: Vec<PerChannel<f64>>,
}

/// The share of d predicted from the 9-term subtraction's residual (eq. 38–39) and the χ² of d
/// minus it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct NineTermShare {
    pub description: String,
    pub d: Vec<PerChannel<f64>>,
    pub chi2_removed: PerChannel<Option<f64>>,
    /// P(χ²_9 ≥ χ²) of `chi2_removed`; `None` without χ².
    pub p_value_removed: PerChannel<Option<f64>>,
}

/// The consistency d_lm = L̂_lm − c_lm, l ≤ 2, of the two sides and its χ² (9 dof).
#[derive(Clone, Debug, serde::Serialize)]
pub struct Consistency {
    pub description: String,
    pub d: Vec<PerChannel<f64>>,
    pub stderr: Vec<PerChannel<f64>>,
    /// `None` when d's covariance is singular (noise-free data).
    pub chi2: PerChannel<Option<f64>>,
    pub dof: usize,
    /// P(χ²_9 ≥ χ²) (σ from the stderr layers, else the residual variance); `None` without χ².
    pub p_value: PerChannel<Option<f64>>,
    /// p ≥ `threshold_p`; `None` where there is no p-value.
    pub consistent: PerChannel<Option<bool>>,
    pub threshold_p: f64,
    /// A plain statement of what the χ² says, per channel.
    pub meaning: PerChannel<String>,
    pub nine_term_residual: NineTermShare,
}

/// One side's least-squares fit of its pixels ([`crate::inverse::separation::fit_residuals`]), per channel.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SideFit {
    pub description: String,
    /// χ² = Σ_p (r_p/σ_p)² against the stderr layers (against σ = 1 without them).
    pub chi2: PerChannel<Option<f64>>,
    /// ν = pixels − fitted coefficients.
    pub dof: PerChannel<Option<f64>>,
    /// χ²/ν with stderr layers; `None` without (σ̂² is then the noise estimate, χ²/ν = 1 by construction).
    pub chi2_per_dof: PerChannel<Option<f64>>,
    /// P(χ²_ν ≥ χ²) with stderr layers; `None` without.
    pub p_value: PerChannel<Option<f64>>,
    /// σ̂² = Σ_p r_p²/ν (radiance²): the noise estimate without stderr layers.
    pub residual_variance: PerChannel<Option<f64>>,
    pub pixels: PerChannel<Option<f64>>,
}

/// The two sides' fits and what is said of their truncation.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Fits {
    /// Why no truncation term is added to the bars.
    pub truncation: String,
    pub diffuse: SideFit,
    pub specular: SideFit,
}

/// `--scan`: consistency χ² against the diffuse fraction k_d/(k_d+k_s) at fixed k_d + k_s.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SplitScan {
    pub channel: String,
    pub total: f64,
    /// (fraction, χ²) on the grid 0.01 … 0.99.
    pub points: Vec<[f64; 2]>,
    /// The minimum refined on a 5e-4 grid.
    pub best_fraction: Option<f64>,
    pub best_chi2: Option<f64>,
    pub assumed_fraction: f64,
}

/// The report of `reflect invert separate` (`--json` prints this struct; coefficient lists are in
/// index order k = l(l+1)+m, each entry a [`PerChannel`]).
#[derive(Clone, Debug, serde::Serialize)]
pub struct InvertSeparateReport {
    pub command: String,
    pub lmax: usize,
    /// Highest order the specular views' grid carries at R ([`crate::projection::resolution::LATLONG_REFLECTION_RULE`]).
    pub lmax_carried: Option<usize>,
    pub lmax_carried_rule: String,
    pub channels: Vec<String>,
    pub layout: String,
    pub diffuse_view: DiffuseView,
    pub specular_views: Vec<SpecularView>,
    pub width: usize,
    pub height: usize,
    pub kd: PerChannel<f64>,
    pub ks: PerChannel<f64>,
    pub split_source: String,
    pub sigma_source: String,
    pub weighted_by_stderr: bool,
    pub diffuse: DiffuseSide,
    /// The recovered lighting L_lm, l ≤ `lmax` (the specular side).
    pub coefficients: Vec<PerChannel<f64>>,
    pub stderr: Vec<PerChannel<f64>>,
    pub consistency: Consistency,
    /// Each side's fit quality (χ²/ν and p with stderr layers) and noise estimate.
    pub fits: Fits,
    pub scan: Option<Vec<SplitScan>>,
    /// The lat-long map written by `--output`.
    pub output: Option<String>,
}

fn table(
    f: &mut std::fmt::Formatter<'_>,
    title: &str,
    channels: &[String],
    val: &[PerChannel<f64>],
    se: &[PerChannel<f64>],
) -> std::fmt::Result {
    writeln!(f, "\n## {title}")?;
    write!(f, "{:>4} {:>3} {:>3}", "k", "l", "m")?;
    for c in channels {
        write!(f, " {:>26}", format!("{c} ± σ"))?;
    }
    writeln!(f)?;
    for (k, (v, s)) in val.iter().zip(se).enumerate() {
        let (l, m) = lm(k);
        write!(f, "{k:>4} {l:>3} {m:>3}")?;
        for (v, s) in v.cells().iter().zip(s.cells()) {
            write!(f, " {:>26}", format!("{v:+.4e} ± {s:.4e}"))?;
        }
        writeln!(f)?;
    }
    Ok(())
}

impl std::fmt::Display for InvertSeparateReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let lmax = self.lmax;
        writeln!(f, "# invert separate — diffuse + specular separation (sec. 3.5, ref. [17]), {}", self.layout)?;
        let carried = self.lmax_carried.map_or("—".to_string(), |l| l.to_string());
        writeln!(f, "# l_max {lmax}; the views carry l <= {carried} ({})", self.lmax_carried_rule)?;
        writeln!(f, "# diffuse view: {} (θ_o = 0)", self.diffuse_view.file)?;
        for v in &self.specular_views {
            writeln!(f, "# specular view: {} (θ_o = {}°, φ_o = {}°)", v.file, v.theta_o_deg, v.phi_o_deg)?;
        }
        writeln!(
            f,
            "# {}×{} pixels; k_d = {}, k_s = {} ({}); σ from {}",
            self.width, self.height, self.kd, self.ks, self.split_source, self.sigma_source
        )?;
        for (name, fit) in [("diffuse view", &self.fits.diffuse), ("specular views", &self.fits.specular)] {
            let cells = |v: &PerChannel<Option<f64>>, fmt: &dyn Fn(f64) -> String| {
                v.cells().iter().map(|x| x.map_or("—".to_string(), fmt)).collect::<Vec<_>>().join(" ")
            };
            if self.weighted_by_stderr {
                writeln!(
                    f,
                    "# {name} fit: χ²/ν = {} (ν = {}), P(χ²_ν ≥ χ²) = {}",
                    cells(&fit.chi2_per_dof, &|x| format!("{x:.3}")),
                    cells(&fit.dof, &|x| format!("{x}")),
                    cells(&fit.p_value, &|x| format!("{x:.2e}"))
                )?;
            } else {
                writeln!(
                    f,
                    "# {name} fit: residual variance σ̂² = {} (ν = {}; the noise estimate, not a χ² test)",
                    cells(&fit.residual_variance, &|x| format!("{x:.3e}")),
                    cells(&fit.dof, &|x| format!("{x}"))
                )?;
            }
        }
        writeln!(f, "# truncation: {}", self.fits.truncation)?;
        let ch = &self.channels;
        table(
            f,
            "diffuse side L̂_lm = B_lm / (k_d Λ_l ρ̂_l + k_s), l ≤ 2",
            ch,
            &self.diffuse.coefficients,
            &self.diffuse.stderr,
        )?;
        table(
            f,
            &format!("recovered lighting L_lm (specular side), l ≤ {lmax}"),
            ch,
            &self.coefficients,
            &self.stderr,
        )?;
        let cons = &self.consistency;
        table(f, "consistency d_lm = L̂_lm − c_lm, l ≤ 2", ch, &cons.d, &cons.stderr)?;
        let nr = &cons.nine_term_residual;
        table(
            f,
            "9-term residual's predicted share of d (eq. 38–39, from the recovered orders 3…lmax; σ is d's)",
            ch,
            &nr.d,
            &cons.stderr,
        )?;
        writeln!(f)?;
        for (((c, m), x), p) in
            ch.iter().zip(cons.meaning.cells()).zip(nr.chi2_removed.cells()).zip(nr.p_value_removed.cells())
        {
            writeln!(f, "# consistency, {c}: {m}")?;
            let x = x.map_or("—".into(), |x| format!("{x:.1}"));
            let p = p.map_or("—".into(), |p| format!(", P(χ²_9 ≥ χ²) = {p:.2e}"));
            writeln!(f, "#   with the predicted 9-term residual removed from d: χ² = {x}{p}")?;
        }
        for s in self.scan.iter().flatten() {
            writeln!(
                f,
                "\n## split scan, channel {}: consistency χ² vs k_d/(k_d+k_s) at k_d + k_s = {}",
                s.channel, s.total
            )?;
            // Every 0.05, and the grid points next to the minimum.
            let bx = s.best_fraction.unwrap_or(f64::NAN);
            for [x, c] in &s.points {
                let i = (x * 100.0).round() as i64;
                if i % 5 == 0 || (x - bx).abs() <= 0.0151 {
                    writeln!(f, "{x:>8.2} {c:>14.4}")?;
                }
            }
            writeln!(
                f,
                "# minimum χ² = {} at k_d/(k_d+k_s) = {} (refined on a 5e-4 grid); assumed {:.4}",
                s.best_chi2.map_or("—".into(), |c| format!("{c:.2}")),
                s.best_fraction.map_or("—".into(), |x| format!("{x:.4}")),
                s.assumed_fraction
            )?;
        }
        if let Some(o) = &self.output {
            writeln!(f, "# wrote the recovered lighting (l ≤ {lmax}) to {o}")?;
        }
        Ok(())
    }
}

impl InvertSeparateReport {
    /// The recovered lighting as a `width` × `width`/2 lat-long image reconstructed from its SH
    /// coefficients (one analysed channel replicated to R, G, B), with the
    /// `reflect:lighting-source` attribute saying what it is.
    pub fn lighting_map(&self, width: usize) -> Image {
        let coeffs: Vec<[f64; 3]> = self
            .coefficients
            .iter()
            .map(|c| match c.cells() {
                [r, g, b] => [*r, *g, *b],
                cells => [cells[0]; 3],
            })
            .collect();
        let (ow, oh) = (width, width / 2);
        let px = reconstruct_latlong(&coeffs, ow, oh);
        let mut img = Image { width: ow, height: oh, ..Default::default() };
        for (ch, name) in CHANNELS.iter().enumerate() {
            img.channels.insert(name.to_string(), px.iter().map(|p| p[ch] as f32).collect());
        }
        let what = if self.channels.len() == 3 {
            "R, G, B".to_string()
        } else {
            format!("channel {} replicated to R, G, B", self.channels[0])
        };
        img.attributes.insert(
            "reflect:lighting-source".into(),
            format!("invert separate (sec. 3.5), l <= {}, {what}", self.lmax),
        );
        img
    }
}
