//! The report of a factorization (`reflect invert factor --json` prints [`InvertFactorReport`]) and
//! of its node rule ([`FactorNodesReport`]), with their text forms.

use crate::sh::lm;

/// A TOML float with 10 decimals (1e-10°, far below f32 headers and
/// [`crate::inverse::factorization::NODE_TOL_DEG`]), trailing zeros trimmed but one decimal kept,
/// e.g. `77.7999959582`, `120.0`.
pub fn toml_float(x: f64) -> String {
    let s = format!("{x:.10}");
    let s = s.trim_end_matches('0');
    if s.ends_with('.') { format!("{s}0") } else { s.to_string() }
}

/// One outgoing node of `--print-nodes`.
#[derive(Clone, Debug, serde::Serialize)]
pub struct NodeReport {
    pub theta_o_deg: f64,
    pub phi_o_deg: f64,
    /// Quadrature weight of the node (μ × φ product rule).
    pub weight: f64,
}

/// The report of `reflect invert factor --print-nodes N_MUxN_PHI` (`--json` prints this struct;
/// the text form is one `THETA_O_DEG PHI_O_DEG` line per node, TOML floats).
#[derive(Clone, Debug, serde::Serialize)]
pub struct FactorNodesReport {
    pub command: String,
    pub nodes: [usize; 2],
    pub outgoing: Vec<NodeReport>,
}

impl std::fmt::Display for FactorNodesReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for n in &self.outgoing {
            writeln!(f, "{} {}", toml_float(n.theta_o_deg), toml_float(n.phi_o_deg))?;
        }
        Ok(())
    }
}

/// Where the light field came from.
#[derive(Clone, Debug, serde::Serialize)]
#[serde(untagged)]
pub enum FactorInput {
    /// IMAGES mode: the node renders and the optional `--normal` view.
    Images { images: Vec<String>, normal: Option<String> },
    /// `--scene` mode: the scene file and the render settings used at every node.
    Scene { scene: String, size: [u32; 2], spp: u32, sampler: vocab::Sampler, max_depth: u32, objects: usize },
}

/// One order l of the factorization.
#[derive(Clone, Debug, serde::Serialize)]
pub struct OrderReport {
    pub l: usize,
    pub kappa: f64,
    /// κ_l / κ_0 = ρ̃_l00 / ρ̃_000 (the BRDF up to scale); `None` when not finite.
    pub kappa_ratio: Option<f64>,
    /// g_l = |Λ_l κ_l| / |Λ_0 κ_0|.
    pub gain: f64,
    /// 1 / g_l; `None` when g_l = 0.
    pub amplification: Option<f64>,
    /// `recovered`, `ill-conditioned` or `ambiguous`.
    pub status: String,
}

/// The direction of the order-1 lighting (meaningful only for a single directional source).
#[derive(Clone, Debug, serde::Serialize)]
pub struct SourceReport {
    pub direction: [f64; 3],
    pub theta_deg: f64,
    pub phi_deg: f64,
    /// |L_1| / √(3/4π): 1 for a single directional source.
    pub directionality: f64,
}

/// P a(θ'_o) of one node ring.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AlbedoRing {
    pub theta_o_deg: f64,
    pub p_albedo: f64,
}

/// The normal-exitance filter ratios Λ_l ρ̂_l / Λ_0 ρ̂_0 (eq. 16), index l.
#[derive(Clone, Debug, serde::Serialize)]
pub struct NormalFilter {
    /// With the factored lighting; `None` where it is ambiguous.
    pub factored_lighting: Vec<Option<f64>>,
    /// With Y_lm(ŝ) of the recovered source direction (a single directional source only).
    pub directional_source: Option<Vec<Option<f64>>>,
}

/// Render count and wall time of `--scene` mode.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RenderCount {
    pub count: usize,
    pub wall_seconds: f64,
}

/// The report of `reflect invert factor` (`--json` prints this struct).
#[derive(Clone, Debug, serde::Serialize)]
pub struct InvertFactorReport {
    pub command: String,
    /// `images` or `scene`.
    pub mode: String,
    pub input: FactorInput,
    /// n_μ × n_φ.
    pub nodes: [usize; 2],
    /// W × H of the normal grid.
    pub grid: [usize; 2],
    /// `fejer` or `pixel`.
    pub rule: String,
    pub channel: String,
    pub lmax: usize,
    pub lmax_carried: Option<usize>,
    pub lmax_carried_rule: String,
    pub max_amplification: f64,
    pub renders: Option<RenderCount>,
    /// Largest per-pixel standard error of the factored channel; null when not recorded and when the
    /// renders have no error estimate (1 spp).
    pub max_stderr: Option<f64>,
    pub orders: Vec<OrderReport>,
    /// L_lm / P in index order; `None` where ambiguous.
    pub lighting: Vec<Option<f64>>,
    /// L_00 / P = 1/√(4π), the gauge.
    pub gauge_l00: f64,
    pub source: Option<SourceReport>,
    pub source_note: String,
    pub albedo_profile: Vec<AlbedoRing>,
    pub filter: Option<NormalFilter>,
    /// Warnings, each one sentence (printed once on stderr as `warning: …`, not in the text report).
    pub warnings: Vec<String>,
}

fn fmt_num(v: Option<f64>) -> String {
    v.map_or("—".to_string(), |x| format!("{x:.5e}"))
}

impl std::fmt::Display for InvertFactorReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "# invert factor (eq. 18) — {}x{} outgoing nodes (Gauss–Legendre μ × trapezoid φ), {}×{} normals ({}), channel {}",
            self.nodes[0], self.nodes[1], self.grid[0], self.grid[1], self.rule, self.channel
        )?;
        writeln!(
            f,
            "# l_max {}; the grid carries l <= {} ({})",
            self.lmax,
            self.lmax_carried.map_or("—".to_string(), |l| l.to_string()),
            self.lmax_carried_rule
        )?;
        if let FactorInput::Scene { scene, spp, sampler, max_depth, objects, .. } = &self.input {
            writeln!(f, "# scene {scene}: {spp} spp, sampler {sampler}, max_depth {max_depth}, {objects} object(s)")?;
        }
        if let Some(r) = &self.renders {
            writeln!(
                f,
                "# renders: {} ({} nodes + 1 at θ_o = 0), wall time {:.2} s",
                r.count,
                r.count.saturating_sub(1),
                r.wall_seconds
            )?;
        }
        if let Some(se) = self.max_stderr {
            writeln!(f, "# largest per-pixel standard error of the renders: {se:.3e}")?;
        }
        writeln!(
            f,
            "# orders with amplification 1/gain > {} are ill-conditioned; κ_l = 0 is ambiguous (0/0)",
            self.max_amplification
        )?;
        writeln!(f, "{:>4} {:>14} {:>12} {:>16}", "l", "κ_l/κ_0", "gain", "status")?;
        for o in &self.orders {
            writeln!(f, "{:>4} {:>14} {:>12} {:>16}", o.l, fmt_num(o.kappa_ratio), fmt_num(Some(o.gain)), o.status)?;
        }
        writeln!(
            f,
            "\n# lighting L_lm/P up to the global scale P = ∫L dω (L_00/P = 1/√(4π) = {:.6} is the gauge)",
            self.gauge_l00
        )?;
        writeln!(f, "{:>4} {:>4} {:>14}", "l", "m", "L_lm/P")?;
        for (k, v) in self.lighting.iter().enumerate() {
            let (l, mm) = lm(k);
            let cell = if v.is_none() { "ambiguous".to_string() } else { fmt_num(*v) };
            writeln!(f, "{l:>4} {mm:>4} {cell:>14}")?;
        }
        match &self.source {
            Some(s) => {
                let d = s.direction;
                writeln!(
                    f,
                    "\n# source direction (order-1 lighting; meaningful only for a single directional source): [{:.5}, {:.5}, {:.5}], θ = {:.3}°, φ = {:.3}°",
                    d[0], d[1], d[2], s.theta_deg, s.phi_deg
                )?;
                writeln!(
                    f,
                    "# directionality |L_1|/√(3/4π) = {:.5} (1 for a single directional source, < 1 otherwise)",
                    s.directionality
                )?;
            }
            None => {
                writeln!(f, "\n# source direction: none (l_max < 1, or the order-1 lighting is ambiguous or zero)")?
            }
        }
        writeln!(f, "\n# albedo profile P a(θ'_o) per node ring (P = ∫L dω; a the directional albedo)")?;
        writeln!(f, "{:>12} {:>14}", "θ'_o (deg)", "P a(θ'_o)")?;
        for r in &self.albedo_profile {
            writeln!(f, "{:>12.4} {:>14}", r.theta_o_deg, fmt_num(Some(r.p_albedo)))?;
        }
        if let Some(fl) = &self.filter {
            writeln!(f, "\n# normal-exitance filter Λ_l ρ̂_l / Λ_0 ρ̂_0 (θ_o = 0, eq. 16 by least squares over m)")?;
            writeln!(f, "{:>4} {:>20} {:>20}", "l", "factored L_lm", "Y_lm(ŝ) (dir. only)")?;
            for (l, v) in fl.factored_lighting.iter().enumerate() {
                let d = fl.directional_source.as_ref().and_then(|d| d.get(l).copied().flatten());
                writeln!(f, "{l:>4} {:>20} {:>20}", fmt_num(*v), fmt_num(d))?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inverse::factorization::{hemisphere_nodes, match_nodes, node_degrees};

    #[test]
    fn printed_nodes_survive_f32_headers() {
        assert_eq!(toml_float(120.0 - 1e-14), "120.0");
        assert_eq!(toml_float(77.79999595818678), "77.7999959582");
        // --print-nodes prints f64 degrees; the renderer stores f32 (relative 6e-8, ≤ 5e-6° below
        // 90°), well inside NODE_TOL_DEG, so the f32 angles still match the rule exactly once.
        for (n_mu, n_phi) in [(8, 16), (16, 48), (64, 64)] {
            let nodes = hemisphere_nodes(n_mu, n_phi).unwrap();
            // As printed, then parsed as f32 by the scene file.
            let f32_of = |x: f64| toml_float(x).parse::<f32>().unwrap() as f64;
            let angles: Vec<(f64, f64)> = nodes.iter().map(node_degrees).map(|(t, p)| (f32_of(t), f32_of(p))).collect();
            let names: Vec<String> = (0..angles.len()).map(|i| format!("n{i}")).collect();
            let (got, _, idx) = match_nodes(&angles, &names, None).unwrap();
            assert_eq!(got, (n_mu, n_phi));
            assert_eq!(idx, (0..angles.len()).collect::<Vec<_>>());
        }
    }
}
