//! The result of one verification check and the tolerance rule every check uses.
//!
//! A check compares a list of measured quantities (each with its standard error σ, propagated
//! from the renderer's per-pixel `stderr` layer through the linear analysis) with the paper's
//! prediction. Row i passes when
//!
//! |measured_i − expected_i| ≤ k·σ_i + approx_i + floor_i,
//!
//! where k = [`K_SIGMA`] (stated, never tuned), `approx_i` is the *stated* approximation error of
//! the prediction when the paper's formula is itself an approximation (eq. 46, 57; computed, not
//! chosen), and `floor_i` is the float rounding of an f32 renderer for noise-free quantities
//! (deterministic renders such as a mirror or a directional source have σ = 0). A check passes
//! when all its rows pass. Rows marked `informative` are reported but do not decide the verdict
//! (e.g. the Gaussian approximation eq. 46 where it is known not to hold).

use super::picture::{Picture, PictureDoc};
use analysis::special::{normal_two_sided_tail, sidak_k};
use serde::Serialize;

/// k of the k·σ rule for a check with at most [`FAMILY_ROWS`] noisy deciding rows: a two-sided 4σ
/// threshold gives each row a 6.3e-5 chance of a spurious failure, so such a check fails a correct
/// claim with probability ≤ 30 × 6.3e-5 ≈ 1.9e-3.
pub const K_SIGMA: f64 = 4.0;

/// Checks with more noisy deciding rows (e.g. 81 recovered L_lm) keep that same per-check false-alarm
/// rate by the Šidák correction: k(N) is the two-sided Gaussian quantile of the per-row rate
/// 1 − (1 − α)^{1/N}, α = 1 − (1 − 6.3e-5)^30 — the rule pbrt-v4 and Mitsuba 3 apply to their
/// χ² tests. k(81) ≈ 4.2, k(289) ≈ 4.5. Rows with σ = 0 (deterministic renders) are not counted.
pub const FAMILY_ROWS: usize = 30;

/// k of the k·σ rule for a check with `n` noisy deciding rows (see [`FAMILY_ROWS`]).
pub fn k_sigma_for(n: usize) -> f64 {
    if n <= FAMILY_ROWS {
        return K_SIGMA;
    }
    let alpha = 1.0 - (1.0 - normal_two_sided_tail(K_SIGMA)).powi(FAMILY_ROWS as i32);
    sidak_k(n, alpha)
}

/// Relative rounding floor of f32 rendering for noise-free quantities (≈ 100 ulp of f32).
pub const F32_FLOOR: f64 = 1e-5;

/// One compared number.
#[derive(Clone, Debug)]
pub struct Row {
    pub label: String,
    pub expected: f64,
    pub measured: f64,
    pub sigma: f64,
    pub approx: f64,
    pub floor: f64,
    /// Reported but not part of the verdict.
    pub informative: bool,
    /// k of the k·σ rule: [`K_SIGMA`], or the Šidák value set by [`Check::apply_family_k`].
    pub k: f64,
    /// Set (with `informative`) when the prediction is an approximation evaluated outside the
    /// range of validity its source states: the stated range, e.g. "small θ_o (first order in θ_o)".
    pub outside_range: Option<String>,
}

impl Row {
    pub fn new(label: impl Into<String>, expected: f64, measured: f64, sigma: f64) -> Row {
        Row {
            label: label.into(),
            expected,
            measured,
            sigma,
            approx: 0.0,
            floor: 0.0,
            informative: false,
            k: K_SIGMA,
            outside_range: None,
        }
    }
    pub fn approx(mut self, a: f64) -> Row {
        self.approx = a.abs();
        self
    }
    pub fn floor(mut self, f: f64) -> Row {
        self.floor = f.abs();
        self
    }
    pub fn informative(mut self) -> Row {
        self.informative = true;
        self
    }
    /// An informative row whose prediction is used outside its stated range of validity `range`
    /// (the report labels it so instead of showing a failure).
    pub fn outside_range(mut self, range: impl Into<String>) -> Row {
        self.informative = true;
        self.outside_range = Some(range.into());
        self
    }
    /// k·σ + approximation error + rounding floor.
    pub fn tolerance(&self) -> f64 {
        self.k * self.sigma + self.approx + self.floor
    }
    pub fn deviation(&self) -> f64 {
        (self.measured - self.expected).abs()
    }
    pub fn passed(&self) -> bool {
        self.measured.is_finite() && self.deviation() <= self.tolerance()
    }
    /// |Δ| / tolerance: < 1 passes.
    pub fn ratio(&self) -> f64 {
        let t = self.tolerance();
        if t > 0.0 {
            self.deviation() / t
        } else if self.deviation() == 0.0 {
            0.0
        } else {
            f64::INFINITY
        }
    }
}

/// A named series for plots: x, y and optional error bars.
#[derive(Clone, Debug, Default)]
pub struct Series {
    pub name: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub err: Option<Vec<f64>>,
    /// Draw dashed (approximations, e.g. eq. 46 and 57).
    pub dashed: bool,
}

/// Where a plot's legend goes (away from the data).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Legend {
    #[default]
    MiddleRight,
    UpperRight,
    LowerLeft,
}

/// A plot attached to a check (rendered to SVG by the report).
#[derive(Clone, Debug, Default)]
pub struct Plot {
    /// No longer used for placement: the legend is drawn in a strip below the chart, where it
    /// cannot cover data. Kept so that checks setting it need not change.
    pub legend: Legend,
    pub file: String,
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    /// Analytic curves (lines).
    pub curves: Vec<Series>,
    /// Measured points (with error bars).
    pub points: Vec<Series>,
}

/// The result of one check.
#[derive(Clone, Debug, Default)]
pub struct Check {
    pub name: String,
    pub equation: String,
    pub description: String,
    pub rows: Vec<Row>,
    /// Free-form notes (what was rendered, the stated approximation errors, what is not checked).
    pub details: Vec<String>,
    pub plots: Vec<Plot>,
    /// Pictures of the renders (measured, predicted, z map): see [`super::picture`].
    pub pictures: Vec<Picture>,
    /// Wall time of the check (renders + analysis), seconds.
    pub seconds: f64,
    /// Set when the check could not run (e.g. a render failed): then it fails.
    pub error: Option<String>,
    /// Rendered pixels flagged `stderr_flag.Y` = 1 (their own error bar rests on one rare sample),
    /// over the check's renders ([`super::run_entry`]).
    pub stderr_flagged: usize,
    /// Rendered pixels whose `stderr` the renderer's bound raised above their own σ (near flagged
    /// pixels, or every pixel at < 16 spp; `renderer::film::Film::pooled_count`).
    pub stderr_pooled: usize,
}

impl Check {
    pub fn new(name: &str, equation: &str, description: &str) -> Check {
        Check { name: name.into(), equation: equation.into(), description: description.into(), ..Default::default() }
    }

    pub fn failed_to_run(name: &str, equation: &str, msg: String) -> Check {
        Check { name: name.into(), equation: equation.into(), error: Some(msg), ..Default::default() }
    }

    pub fn push(&mut self, row: Row) {
        self.rows.push(row);
    }

    pub fn note(&mut self, s: impl Into<String>) {
        self.details.push(s.into());
    }

    /// Number of deciding rows carrying noise (σ > 0).
    pub fn noisy_rows(&self) -> usize {
        self.rows.iter().filter(|r| !r.informative && r.sigma > 0.0).count()
    }

    /// Sets k on every row to [`k_sigma_for`] the number of noisy deciding rows (done once by
    /// `verify::run_entry` when the check is complete).
    pub fn apply_family_k(&mut self) {
        let k = k_sigma_for(self.noisy_rows());
        if k != K_SIGMA {
            self.details.push(format!(
                "{} noisy deciding rows: k = {k:.2} (Šidák, same per-check false-alarm rate as 30 rows at 4σ)",
                self.noisy_rows()
            ));
        }
        self.rows.iter_mut().for_each(|r| r.k = k);
    }

    /// k of this check's rows.
    pub fn k_sigma(&self) -> f64 {
        self.rows.first().map_or(K_SIGMA, |r| r.k)
    }

    /// Passes when it ran, has at least one deciding row, and every deciding row passes.
    pub fn passed(&self) -> bool {
        self.error.is_none()
            && self.rows.iter().any(|r| !r.informative)
            && self.rows.iter().filter(|r| !r.informative).all(Row::passed)
    }

    /// The deciding row with the largest |Δ|/tolerance (the one the table shows).
    pub fn worst(&self) -> Option<&Row> {
        self.rows
            .iter()
            .filter(|r| !r.informative)
            .max_by(|a, b| a.ratio().partial_cmp(&b.ratio()).unwrap_or(std::cmp::Ordering::Equal))
    }

    /// The typed JSON object of this check (docs/src/conventions.md §7 plus rows, details, files).
    pub fn doc(&self) -> CheckDoc {
        let deciding: Vec<&Row> = self.rows.iter().filter(|r| !r.informative).collect();
        CheckDoc {
            name: self.name.clone(),
            equation: self.equation.clone(),
            description: self.description.clone(),
            passed: self.passed(),
            measured: deciding.iter().map(|r| finite(r.measured)).collect(),
            expected: deciding.iter().map(|r| finite(r.expected)).collect(),
            tolerance: deciding.iter().map(|r| finite(r.tolerance())).collect(),
            sigma: deciding.iter().map(|r| finite(r.sigma)).collect(),
            labels: deciding.iter().map(|r| r.label.clone()).collect(),
            k_sigma: self.k_sigma(),
            rows: self.rows.iter().map(Row::doc).collect(),
            details: self.details.clone(),
            plots: self.plots.iter().map(|p| p.file.clone()).collect(),
            pictures: self.pictures.iter().map(Picture::doc).collect(),
            error: self.error.clone(),
            errored: self.error.is_some(),
            seconds: self.seconds,
            stderr_flagged_pixels: self.stderr_flagged,
            stderr_pooled_pixels: self.stderr_pooled,
        }
    }
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

impl Row {
    /// The typed JSON object of this row.
    pub fn doc(&self) -> RowDoc {
        RowDoc {
            label: self.label.clone(),
            expected: finite(self.expected),
            measured: finite(self.measured),
            sigma: finite(self.sigma),
            approx: finite(self.approx),
            floor: finite(self.floor),
            tolerance: finite(self.tolerance()),
            passed: self.passed(),
            informative: self.informative,
            outside_range: self.outside_range.clone(),
        }
    }
}

/// One row of a check in `reflect verify --json` / `report.json`. Non-finite numbers are `null`.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct RowDoc {
    pub label: String,
    pub expected: Option<f64>,
    pub measured: Option<f64>,
    pub sigma: Option<f64>,
    /// Stated approximation error of the prediction.
    pub approx: Option<f64>,
    /// f32 rounding floor (noise-free renders).
    pub floor: Option<f64>,
    /// k·σ + approx + floor.
    pub tolerance: Option<f64>,
    /// |measured − expected| ≤ tolerance (for an informative row: reported, not deciding).
    pub passed: bool,
    /// Reported but not part of the verdict.
    pub informative: bool,
    /// The stated range of validity of an approximation used outside it (then `informative`).
    pub outside_range: Option<String>,
}

/// One check in `reflect verify --json` / `report.json` (docs/src/conventions.md §7: `name`, `equation`,
/// `passed`, `measured`, `expected`, `tolerance` over the deciding rows, in row order).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct CheckDoc {
    pub name: String,
    pub equation: String,
    /// The claim checked, in one line.
    pub description: String,
    pub passed: bool,
    /// Deciding rows only, in order (also `sigma`, `labels`); null for a non-finite value.
    pub measured: Vec<Option<f64>>,
    pub expected: Vec<Option<f64>>,
    pub tolerance: Vec<Option<f64>>,
    pub sigma: Vec<Option<f64>>,
    pub labels: Vec<String>,
    /// k of the k·σ rule in this check (Šidák-corrected above [`FAMILY_ROWS`] noisy rows).
    pub k_sigma: f64,
    /// Every row, deciding and informative.
    pub rows: Vec<RowDoc>,
    pub details: Vec<String>,
    /// SVG plot files in the report folder.
    pub plots: Vec<String>,
    /// Pictures of the renders (PNG files in the report folder, z-map summary).
    pub pictures: Vec<PictureDoc>,
    /// Why the check could not run.
    pub error: Option<String>,
    /// True when the check could not run (its rows, if any, decide nothing): a failure that is not
    /// a verdict on the claim.
    pub errored: bool,
    /// Wall time of the check (renders + analysis), seconds.
    pub seconds: f64,
    /// Rendered pixels flagged `stderr_flag.Y` = 1 over the check's renders.
    pub stderr_flagged_pixels: usize,
    /// Rendered pixels whose `stderr` the renderer's bound raised above their own σ; the check's error
    /// bars use the bound, its noise debiasing the own σ, and it excludes no pixel.
    pub stderr_pooled_pixels: usize,
}

#[cfg(test)]
mod tests {
    use super::*;
    use analysis::special::erfc;

    #[test]
    fn tolerance_rule() {
        let r = Row::new("a", 1.0, 1.03, 0.01);
        assert!(r.passed(), "3σ < 4σ");
        let r = Row::new("a", 1.0, 1.05, 0.01);
        assert!(!r.passed(), "5σ > 4σ");
        let r = Row::new("a", 1.0, 1.05, 0.01).approx(0.02);
        assert!(r.passed(), "4σ + 0.02 ≥ 0.05");
        let r = Row::new("a", 1.0, f64::NAN, 0.01);
        assert!(!r.passed(), "NaN never passes");
    }

    #[test]
    fn informative_rows_do_not_decide_and_empty_checks_fail() {
        let mut c = Check::new("x", "eq. 1", "");
        assert!(!c.passed(), "a check with nothing compared must not pass");
        c.push(Row::new("a", 1.0, 2.0, 0.01).informative());
        assert!(!c.passed());
        c.push(Row::new("b", 1.0, 1.0, 0.01));
        assert!(c.passed());
        c.push(Row::new("c", 1.0, 1.5, 0.01));
        assert!(!c.passed());
        assert_eq!(c.worst().map(|r| r.label.as_str()), Some("c"));
    }

    #[test]
    fn family_k_keeps_the_per_check_false_alarm_rate() {
        assert_eq!(k_sigma_for(1), K_SIGMA);
        assert_eq!(k_sigma_for(FAMILY_ROWS), K_SIGMA);
        // Two-sided Gaussian tails: P(|Z| > 4) = 6.334e-5 (tables).
        assert!((erfc(4.0 / std::f64::consts::SQRT_2) - 6.334e-5).abs() < 1e-8);
        let tail = |k: f64| erfc(k / std::f64::consts::SQRT_2);
        for n in [31, 81, 289, 1000] {
            let k = k_sigma_for(n);
            let fam = 1.0 - (1.0 - tail(k)).powi(n as i32);
            let fam30 = 1.0 - (1.0 - tail(K_SIGMA)).powi(30);
            assert!((fam / fam30 - 1.0).abs() < 1e-6, "n {n}: k {k}, {fam} vs {fam30}");
            assert!(k > K_SIGMA && k < 5.0);
        }
        let mut c = Check::new("x", "", "");
        for i in 0..81 {
            c.push(Row::new(format!("{i}"), 0.0, 4.1, 1.0));
        }
        assert!(!c.passed(), "4.1σ fails at k = 4");
        c.apply_family_k();
        assert!((c.k_sigma() - 4.23).abs() < 0.01, "{}", c.k_sigma());
        assert!(c.passed(), "4.1σ is within k(81)");
    }
}
