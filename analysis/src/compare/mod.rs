//! Is image A the same picture as image B, up to their Monte Carlo noise? (`reflect compare`,
//! guide "Comparing two renderers".)
//!
//! Each side is an [`Estimate`] per pixel and channel: a render with its `stderr` layer (σ² of the
//! degrees of freedom its header's sampler gives: 15 for Sobol, spp − 1 for the independent
//! sampler), several seeds of one renderer
//! (mean and s²/n, n − 1 degrees of freedom), or an image without error layer (taken as exact:
//! a converged reference). Pixels without estimate (+inf) on either side, and optionally those
//! near the silhouette (`exclude_edges`), are left out. Pixels flagged (`stderr_flag.Y` = 1) are
//! compared and counted: leaving them out of one side would select on its values (see
//! [`Estimate::flagged`]).
//!
//! For each difference Δ = A − B the z is Δ / √(σ_A² + σ_B²), a Student t of Welch–Satterthwaite's
//! ν degrees of freedom under Gaussian noise, turned into its N(0, 1) score u
//! ([`crate::special::normal_score`]) so that χ² tests keep their nominal rate with few seeds. The
//! tests, each at the Šidák level α' = 1 − (1 − α)^{1/m} for m tests (so that the family's
//! false-alarm rate is α when the tests are independent; Šidák's inequality keeps it ≤ α for the
//! positively dependent two-sided tests here):
//!
//! - **scale** per channel with signal: ln(Σ A / Σ B) / √(var Σ A / (Σ A)² + var Σ B / (Σ B)²)
//!   over the compared pixels (the delta method), two-sided Student t. The sums are unweighted:
//!   weights 1/σ̂² from estimated variances correlate with the values under a skewed estimator (a
//!   pixel that missed a rare bright sample has both a low value and a low σ̂) and would bias the
//!   ratio;
//! - **pixels** per channel: χ² = Σ u² over the compared pixels, ν their count, upper tail. One
//!   test per channel, not one over all three: the channels of a pixel share its samples, so their
//!   u are correlated (a grey object: nearly equal) and a pooled χ² would have about a third of its
//!   nominal ν (its spread measured 1.7× the nominal on grey renders);
//! - **blocks** per channel: the same over the means of `block` × `block` tiles (a tile counts when at least
//!   half its pixels are compared), which sees a bias of 1/block of the per-pixel noise that the
//!   pixel χ² dilutes. With seeds, the variance of a block mean (and of a channel sum) is the
//!   spread of the seeds' own block means, which includes the correlation that a Gaussian
//!   reconstruction filter gives neighbouring pixels; from error layers it is Σ σ² / n² (pixels
//!   independent: a box film, as ours).
//!
//! Diagnostics that name a cause without being tests: the scale-corrected block χ²/ν (a pure
//! exposure or scale difference leaves the blocks agreeing once divided out), and, where an image
//! has a coverage layer (`mask.Y`, else an alpha channel `A`), the pixel χ²/ν on the silhouette
//! against the interior (a box against a Gaussian film differs at the silhouette: guide "Comparing
//! two renderers", "Pixel filters"), and the curvature fit A − B = c ∇² away from the silhouette
//! ([`CurvatureFit`]: one image blurred relative to the other, as a wider pixel filter makes it).

mod estimate;
mod statistics;

pub use estimate::{Estimate, Excluded};
pub use statistics::Difference;

use crate::special::{chi2_survival, student_t_two_sided_tail};
use serde::Serialize;
use vocab::image::Image;

/// What [`compare`] is asked to do.
#[derive(Clone, Debug, PartialEq)]
pub struct CompareParams {
    /// Family-wise false-alarm rate of the verdict, 0 < α < 0.5 (default 0.01).
    pub alpha: f64,
    /// Side of the square blocks of the block test, in pixels, ≥ 1 (default 8).
    pub block: usize,
    /// Leave out every pixel at a Chebyshev distance < N from a silhouette pixel (N = 1: the
    /// silhouette pixels only); 0 leaves none out. Needs a coverage layer in A or B.
    pub exclude_edges: usize,
    /// Compare the object only: leave out every pixel whose coverage (A's `mask.Y` or alpha, else
    /// B's) is 0, the background, where another renderer's map lookup may differ from ours
    /// without noise on either side. Needs a coverage layer in A or B.
    pub object_only: bool,
    /// A bound on B's systematic error per pixel and channel (row-major, `width × height`), as a
    /// prediction's truncation ([`crate::predict::PredictedImage::systematic`]): it is not noise
    /// and does not average down, so it is added in quadrature to each pixel's standard error and,
    /// summed over the pixels (as if all of one sign), to each block mean's and channel sum's. With
    /// it B is a prediction, whose +inf error marks the pixels it does not predict: left out and
    /// counted in `no_estimate`, without the warning about too few samples.
    pub b_systematic: Option<Vec<[f64; 3]>>,
}

impl Default for CompareParams {
    fn default() -> Self {
        CompareParams { alpha: 0.01, block: 8, exclude_edges: 0, object_only: false, b_systematic: None }
    }
}

/// Bad input: each names the input by its index (0 = A, 1 = B, 2… = further seeds of B) so that
/// a front-end can name the file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CompareError {
    #[error(
        "the image is {width}×{height} but input {other} is {other_width}×{other_height}: the images must show the same pixels (no crop, same resolution)"
    )]
    SizeMismatch { input: usize, width: usize, height: usize, other: usize, other_width: usize, other_height: usize },
    #[error(
        "the image has {layout} channels but input {other} has {other_layout}: compare images of one channel layout"
    )]
    ChannelLayout { input: usize, layout: &'static str, other: usize, other_layout: &'static str },
    #[error("the image has no R, G, B (or Y) channels")]
    NoRadiance { input: usize },
    #[error(
        "layer stderr has the value {value} at row {row}, column {column}: a standard error must be finite and ≥ 0 (or +inf: no estimate)"
    )]
    BadStderr { input: usize, value: f64, row: usize, column: usize },
    #[error(
        "its attribute reflect:stderr_dof is '{value}': the degrees of freedom of the stderr layer must be a number ≥ 1 (or inf)"
    )]
    BadStderrDof { input: usize, value: String },
    #[error(
        "neither image has an error estimate (a stderr layer, or several seeds of B): the noise of the images is unknown, so no difference can be judged"
    )]
    NoErrorEstimate,
    #[error(
        "its coverage (mask or alpha) disagrees with input {other}'s on {count} of {object} object pixels: a different camera, crop or object, not noise"
    )]
    Misaligned { input: usize, other: usize, count: usize, object: usize },
    #[error("{0} needs a coverage layer (mask.Y or an alpha channel A) in A or B to find the object; neither has one")]
    NoMask(&'static str),
    #[error(
        "no pixel is left to compare ({no_estimate} without estimate, {edges} near the silhouette, {background} background)"
    )]
    NoPixels { no_estimate: usize, edges: usize, background: usize },
    #[error("{0}")]
    BadParam(String),
}

impl CompareError {
    /// The input the error is about (0 = A, 1 = B, 2… = further seeds), when it is about one.
    pub fn input(&self) -> Option<usize> {
        match self {
            CompareError::SizeMismatch { input, .. }
            | CompareError::ChannelLayout { input, .. }
            | CompareError::NoRadiance { input }
            | CompareError::BadStderr { input, .. }
            | CompareError::BadStderrDof { input, .. }
            | CompareError::Misaligned { input, .. } => Some(*input),
            _ => None,
        }
    }
}

/// The outcome of a comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Verdict {
    /// No test rejects at its Šidák level: the images agree within their noise.
    Agree,
    /// Some test rejects: the images differ beyond their noise (a false alarm has probability α).
    Disagree,
}

/// One test of the verdict's family.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TestResult {
    /// `scale R`, `pixels R`, `blocks R` (and G, B): one per channel with signal or variance.
    pub name: String,
    /// z of a scale test; χ²/ν of a χ² test.
    pub statistic: f64,
    /// Degrees of freedom: the Student t's of a scale test (null for ∞), ν of a χ².
    pub dof: Option<f64>,
    /// p-value (two-sided for a scale, upper tail for a χ²).
    pub p: f64,
    /// p < the per-test level `alpha_per_test`.
    pub rejected: bool,
}

/// The global scale A/B of one channel.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ScaleResult {
    pub channel: String,
    /// Σ A / Σ B over the compared pixels.
    pub ratio: f64,
    /// Its standard error (delta method).
    pub stderr: f64,
    /// ln(ratio) in units of its standard error.
    pub z: f64,
    /// Welch–Satterthwaite degrees of freedom (null: ∞).
    pub dof: Option<f64>,
}

/// The pixel-level comparison.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PixelSummary {
    /// Pixels compared (not left out).
    pub compared: usize,
    /// Compared pixels flagged in A or B (`stderr_flag.Y` = 1; compared, not left out).
    pub flagged: usize,
    /// Left out: no error estimate (+inf) in A or B.
    pub no_estimate: usize,
    /// Left out: within `exclude_edges` − 1 pixels (Chebyshev distance) of a silhouette pixel.
    pub near_edges: usize,
    /// Left out: background (coverage 0), with `object_only`.
    pub background: usize,
    /// Pixel-channels (a pixel counts once per channel) with zero variance on both sides (exact
    /// values), not in the χ².
    pub exact: usize,
    /// Of those, how many differ (relative difference > 1e-4): each is a disagreement.
    pub exact_differing: usize,
    /// Σ u² over the compared pixel-channels with a variance, all channels pooled (descriptive:
    /// the channels are correlated, so the tests are per channel).
    pub chi2: f64,
    pub nu: usize,
    pub chi2_nu: f64,
    /// The largest |u| and where (row from the top, column from the left).
    pub max_abs_z: f64,
    pub max_row: usize,
    pub max_column: usize,
    /// How many |u| exceed the Šidák k over all pixel-channels (`k_family`): expected 0 with
    /// probability 1 − α under agreement (not a test of the verdict: heavy-tailed estimators).
    pub beyond_k_family: usize,
    pub k_family: f64,
}

/// The block-level comparison.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BlockSummary {
    pub size: usize,
    /// Blocks with at least half their pixels compared.
    pub count: usize,
    /// Σ u² over blocks and channels, pooled (descriptive; the tests are per channel).
    pub chi2: f64,
    pub nu: usize,
    pub chi2_nu: f64,
    pub max_abs_z: f64,
    /// χ²/ν of the blocks with A divided by each channel's scale ratio: near 1 when the images
    /// differ by a scale only.
    pub chi2_nu_scale_removed: f64,
}

/// The silhouette diagnostic (an image with a coverage layer).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EdgeSummary {
    /// Compared pixels within 2 px of the silhouette (a pixel of partial coverage, or with a
    /// 4-neighbour on the other side of coverage ½): the reach of a filter of radius ≤ 2 px.
    pub pixels: usize,
    pub chi2_nu: f64,
    /// χ²/ν of the other compared pixels.
    pub interior_chi2_nu: f64,
}

/// The curvature diagnostic of one channel: the weighted least-squares fit A − B = c ∇²M over the
/// compared pixels away from the silhouette, with M = (A + B)/2 and ∇² its discrete Laplacian
/// taken from the 8 neighbours only (diagonals minus the 4-neighbours, h² ∇² for a smooth image),
/// so that the regressor holds none of the pixel's own noise. A pixel filter of variance s² per
/// axis makes an image I + (s²/2) ∇²I to second order, so two filters differ by
/// c = (s_A² − s_B²)/2 px²: a box pixel has s² = 1/12, Mitsuba 3's and pbrt-v4's default Gaussian
/// film s² ≈ 0.25, so c ≈ −0.083 px² when B is the Gaussian film (noise in ∇²M shrinks the fitted
/// c towards 0).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CurvatureFit {
    pub channel: String,
    /// c in px².
    pub c: f64,
    /// Its standard error (from the pixels' variances).
    pub stderr: f64,
    /// c / stderr: the χ² the fit removes is z².
    pub z: f64,
    /// The share of the channel's excess pixel χ² (χ² − ν) that z² explains, in [0, 1]; 0 without
    /// an excess.
    pub explained: f64,
    /// Pixels in the fit.
    pub pixels: usize,
}

/// How one side's noise was estimated.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SideSummary {
    /// "stderr layer (64 spp, sobol sampler: 15 degrees of freedom)", "8 seeds (…)", "no error layer: taken as exact".
    pub noise: String,
    /// The number of images making up this side.
    pub images: usize,
}

/// Histogram of the pixel scores u (all channels) in bins of 0.25 over [−6, 6], with the counts
/// N(0, 1) predicts.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Histogram {
    /// Bin edges, `counts.len() + 1` long.
    pub edges: Vec<f64>,
    pub counts: Vec<u64>,
    /// The count N(0, 1) predicts in each bin.
    pub expected: Vec<f64>,
    pub below: u64,
    pub above: u64,
}

/// The result of [`compare`]. Serialises as `reflect compare --json` (the maps are not part of it).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CompareReport {
    pub verdict: Verdict,
    /// One line: which tests rejected and the most likely cause, or that none did.
    pub reason: String,
    /// Family-wise false-alarm rate of the verdict.
    pub alpha: f64,
    /// The Šidák level of each test: 1 − (1 − α)^{1/m}.
    pub alpha_per_test: f64,
    pub width: usize,
    pub height: usize,
    pub a: SideSummary,
    pub b: SideSummary,
    pub tests: Vec<TestResult>,
    pub scale: Vec<ScaleResult>,
    pub pixels: PixelSummary,
    pub blocks: BlockSummary,
    pub edges: Option<EdgeSummary>,
    /// The curvature diagnostic per channel ([`CurvatureFit`]): one image blurred relative to the
    /// other (a different pixel filter) shows as differences that follow ∇² of the image.
    pub curvature: Vec<CurvatureFit>,
    pub histogram: Histogram,
    pub warnings: Vec<String>,
    /// Per pixel, the z of the channel sum (R + G + B), NaN where not compared; row-major.
    #[serde(skip)]
    pub z_map: Vec<f32>,
    /// Per pixel, (R + G + B) of A over that of B, NaN where not compared or B's sum is ≤ 0.
    #[serde(skip)]
    pub ratio_map: Vec<f32>,
}

const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// Compares `a` with `b`: `b` is one image, or n ≥ 2 seeds of one renderer (see the module docs).
///
/// Errors ([`CompareError`]): sizes or channel layouts that differ, coverage layers that disagree
/// (a crop or another camera), an invalid error layer, no error estimate on either side, no pixel
/// left, `exclude_edges` without a coverage layer, α outside (0, 0.5) or block = 0.
pub fn compare(a: &Image, b: &[Image], params: &CompareParams) -> Result<CompareReport, CompareError> {
    if !(params.alpha > 0.0 && params.alpha < 0.5) {
        return Err(CompareError::BadParam(format!("alpha must be in (0, 0.5), got {}", params.alpha)));
    }
    if params.block == 0 {
        return Err(CompareError::BadParam("block must be ≥ 1".into()));
    }
    if b.is_empty() {
        return Err(CompareError::BadParam("no image B to compare with".into()));
    }
    estimate::check_alignment(a, 0, a, 0)?;
    for (k, img) in b.iter().enumerate() {
        estimate::check_alignment(img, k + 1, a, 0)?;
    }
    let ea = Estimate::of_image(a, 0)?;
    let mut eb = if b.len() >= 2 { Estimate::of_seeds(b, 1)? } else { Estimate::of_image(&b[0], 1)? };
    if let Some(t) = &params.b_systematic {
        if t.len() != eb.mean.len() || t.iter().flatten().any(|x| !(*x >= 0.0 && x.is_finite())) {
            return Err(CompareError::BadParam(
                "b_systematic must hold one finite, non-negative RGB bound per pixel".into(),
            ));
        }
        eb.systematic = Some(t.clone());
    }
    if !ea.has_error && !eb.has_error {
        return Err(CompareError::NoErrorEstimate);
    }
    if let (Some(ma), Some(mb)) = (&ea.mask, &eb.mask) {
        let object = ma.iter().zip(mb).filter(|(x, y)| x.max(**y) > 0.5).count();
        let count = ma.iter().zip(mb).filter(|(x, y)| (**x < 0.01 && **y > 0.99) || (**y < 0.01 && **x > 0.99)).count();
        if count > 4 && count * 100 > object {
            return Err(CompareError::Misaligned { input: 1, other: 0, count, object });
        }
    }
    let (w, h) = (a.width, a.height);
    let n = w * h;
    let mut warnings = Vec::new();
    for (name, e) in [("A", &ea), ("B", &eb)] {
        if !e.has_error {
            warnings.push(format!("{name} has no error layer: taken as exact (a converged reference); any noise it has counts as disagreement"));
        }
    }
    if b.len() >= 2 && b.len() < 5 {
        warnings.push(format!(
            "B's noise comes from only {} seeds: its z are Student t with {} degrees of freedom, and the tests assume Gaussian seed noise",
            b.len(),
            b.len() - 1
        ));
    }

    // Which pixels take part.
    let silhouette = ea.mask.as_ref().or(eb.mask.as_ref()).map(|m| silhouette_pixels(m, w, h));
    let near_edge: Vec<bool> = match (params.exclude_edges, &silhouette) {
        (0, _) => vec![false; n],
        (_, None) => return Err(CompareError::NoMask("exclude_edges")),
        (r, Some(s)) => dilate(s, w, h, r - 1),
    };
    let background: Option<Vec<bool>> = match (params.object_only, ea.mask.as_ref().or(eb.mask.as_ref())) {
        (false, _) => None,
        (true, None) => return Err(CompareError::NoMask("object_only")),
        (true, Some(m)) => Some(m.iter().map(|&c| c <= 0.0).collect()),
    };
    let mut in_background = 0;
    let (mut flagged, mut no_estimate, mut near_edges) = (0, 0, 0);
    // A prediction (B with a systematic bound) has no estimate where it predicts nothing (+inf):
    // those pixels are left out as well, but not for want of samples.
    let prediction = params.b_systematic.is_some();
    let mut unpredicted = 0;
    let mut used = vec![false; n];
    for i in 0..n {
        match (ea.excluded[i], eb.excluded[i]) {
            (_, Some(Excluded::NoEstimate)) if prediction => {
                (no_estimate, unpredicted) = (no_estimate + 1, unpredicted + 1)
            }
            (Some(Excluded::NoEstimate), _) | (_, Some(Excluded::NoEstimate)) => no_estimate += 1,
            _ if near_edge[i] => near_edges += 1,
            _ if background.as_ref().is_some_and(|b| b[i]) => in_background += 1,
            _ => {
                used[i] = true;
                flagged += usize::from(ea.flagged[i] || eb.flagged[i]);
            }
        }
    }
    let idx: Vec<usize> = (0..n).filter(|&i| used[i]).collect();
    if idx.is_empty() {
        return Err(CompareError::NoPixels { no_estimate, edges: near_edges, background: in_background });
    }
    if flagged > 0 {
        warnings.push(format!(
            "{flagged} compared pixels are flagged (stderr_flag.Y = 1: a rare heavy sample dominates their own error bar); they are not left out, which would bias the comparison towards the side whose flags removed its low pixels"
        ));
    }
    let without = no_estimate - unpredicted;
    if without > 0 {
        warnings
            .push(format!("{without} pixels without error estimate (stderr +inf: fewer than 2 samples) are left out"));
    }

    // Pixels.
    let mut scores: Vec<f64> = Vec::with_capacity(idx.len() * 3);
    let mut score_at = vec![[f64::NAN; 3]; n];
    let (mut pchi2, mut pnu) = ([0.0f64; 3], [0usize; 3]);
    let (mut exact, mut exact_differing) = (0, 0);
    let (mut max_abs, mut max_at) = (0.0f64, [0, 0]);
    let mut z_map = vec![f32::NAN; n];
    let mut ratio_map = vec![f32::NAN; n];
    for &i in &idx {
        let (ma, mb, va, vb) = (ea.mean[i], eb.mean[i], ea.pixel_var(i), eb.pixel_var(i));
        for c in 0..3 {
            match Difference::new(ma[c] - mb[c], va[c], vb[c], ea.dof, eb.dof) {
                Some(d) => {
                    let u = d.score();
                    scores.push(u);
                    score_at[i][c] = u;
                    pchi2[c] += u * u;
                    pnu[c] += 1;
                    if u.abs() > max_abs {
                        (max_abs, max_at) = (u.abs(), [i / w, i % w]);
                    }
                }
                None => {
                    exact += 1;
                    if (ma[c] - mb[c]).abs() > 1e-4 * ma[c].abs().max(mb[c].abs()) {
                        exact_differing += 1;
                    }
                }
            }
        }
        let (sa, sb) = (ma.iter().sum::<f64>(), mb.iter().sum::<f64>());
        let v: f64 = va.iter().chain(&vb).sum();
        z_map[i] = if v > 0.0 { ((sa - sb) / v.sqrt()) as f32 } else { 0.0 };
        if sb > 0.0 {
            ratio_map[i] = (sa / sb) as f32;
        }
    }
    let chi2: f64 = scores.iter().map(|u| u * u).sum();
    let nu = scores.len();
    let k_family = crate::special::sidak_k(nu.max(1), params.alpha);
    let pixels = PixelSummary {
        compared: idx.len(),
        flagged,
        no_estimate,
        near_edges,
        background: in_background,
        exact,
        exact_differing,
        chi2,
        nu,
        chi2_nu: chi2 / nu.max(1) as f64,
        max_abs_z: max_abs,
        max_row: max_at[0],
        max_column: max_at[1],
        beyond_k_family: scores.iter().filter(|u| u.abs() > k_family).count(),
        k_family,
    };

    // Global scale per channel.
    let mut scale = Vec::new();
    for c in 0..3 {
        let (sa, va, da) = ea.sum(&idx, c);
        let (sb, vb, db) = eb.sum(&idx, c);
        if !(sa > 0.0 && sb > 0.0) {
            continue;
        }
        let (ra, rb) = (va / (sa * sa), vb / (sb * sb));
        let Some(d) = Difference::new((sa / sb).ln(), ra, rb, da, db) else { continue };
        let ratio = sa / sb;
        scale.push(ScaleResult {
            channel: CHANNELS[c].to_string(),
            ratio,
            stderr: ratio * (ra + rb).sqrt(),
            z: d.z,
            dof: d.dof.is_finite().then_some(d.dof),
        });
    }

    // Blocks.
    let k = params.block;
    let ratios: [f64; 3] =
        std::array::from_fn(|c| scale.iter().find(|s| s.channel == CHANNELS[c]).map_or(1.0, |s| s.ratio));
    let (mut bchi2, mut bchi2_scaled, mut bnu, mut bcount, mut bmax) = ([0.0f64; 3], 0.0, [0usize; 3], 0usize, 0.0f64);
    for by in (0..h).step_by(k) {
        for bx in (0..w).step_by(k) {
            let tile: Vec<usize> = (by..(by + k).min(h))
                .flat_map(|y| (bx..(bx + k).min(w)).map(move |x| y * w + x))
                .filter(|&i| used[i])
                .collect();
            if tile.is_empty() || tile.len() * 2 < k.min(h - by) * k.min(w - bx) {
                continue;
            }
            bcount += 1;
            let m = tile.len() as f64;
            for c in 0..3 {
                let (sa, va, da) = ea.sum(&tile, c);
                let (sb, vb, db) = eb.sum(&tile, c);
                let (va, vb) = (va / (m * m), vb / (m * m));
                let (ma, mb) = (sa / m, sb / m);
                if let Some(d) = Difference::new(ma - mb, va, vb, da, db) {
                    let u = d.score();
                    bchi2[c] += u * u;
                    bmax = bmax.max(u.abs());
                    bnu[c] += 1;
                    let r = ratios[c];
                    if let Some(d) = Difference::new(ma / r - mb, va / (r * r), vb, da, db) {
                        bchi2_scaled += d.score().powi(2);
                    }
                }
            }
        }
    }
    let (bchi2_all, bnu_all) = (bchi2.iter().sum::<f64>(), bnu.iter().sum::<usize>());
    let blocks = BlockSummary {
        size: k,
        count: bcount,
        chi2: bchi2_all,
        nu: bnu_all,
        chi2_nu: bchi2_all / bnu_all.max(1) as f64,
        max_abs_z: bmax,
        chi2_nu_scale_removed: bchi2_scaled / bnu_all.max(1) as f64,
    };

    // The silhouette diagnostic.
    // The band a reconstruction filter of radius ≤ 2 px (Mitsuba's gaussian; pbrt-v4's is 1.5)
    // reaches from the silhouette.
    let band = silhouette.as_ref().map(|s| dilate(s, w, h, 2));
    let edges = band.as_ref().map(|s| {
        let (mut e2, mut en, mut i2, mut inn) = (0.0, 0usize, 0.0, 0usize);
        let mut epx = 0;
        for &i in &idx {
            let on = s[i];
            epx += on as usize;
            for u in score_at[i].iter().filter(|u| u.is_finite()) {
                if on {
                    (e2, en) = (e2 + u * u, en + 1);
                } else {
                    (i2, inn) = (i2 + u * u, inn + 1);
                }
            }
        }
        EdgeSummary { pixels: epx, chi2_nu: e2 / en.max(1) as f64, interior_chi2_nu: i2 / inn.max(1) as f64 }
    });

    // The curvature diagnostic, away from the silhouette (whose jump dominates any Laplacian).
    let curvature: Vec<CurvatureFit> = (0..3)
        .filter_map(|c| {
            let excess = pchi2[c] - pnu[c] as f64;
            curvature_fit(&ea, &eb, &idx, &used, band.as_deref(), c, excess)
        })
        .collect();

    // The family of tests and the verdict.
    let mut tests: Vec<TestResult> = scale
        .iter()
        .map(|s| TestResult {
            name: format!("scale {}", s.channel),
            statistic: s.z,
            dof: s.dof,
            p: student_t_two_sided_tail(s.z, s.dof.unwrap_or(f64::INFINITY)),
            rejected: false,
        })
        .collect();
    for (what, chi2, nu) in [("pixels", pchi2, pnu), ("blocks", bchi2, bnu)] {
        for c in (0..3).filter(|&c| nu[c] > 0) {
            tests.push(TestResult {
                name: format!("{what} {}", CHANNELS[c]),
                statistic: chi2[c] / nu[c] as f64,
                dof: Some(nu[c] as f64),
                p: chi2_survival(chi2[c], nu[c] as f64),
                rejected: false,
            });
        }
    }
    let m = tests.len().max(1) as f64;
    let alpha_per_test = 1.0 - (1.0 - params.alpha).powf(1.0 / m);
    for t in &mut tests {
        t.rejected = t.p < alpha_per_test;
    }
    let disagree = tests.iter().any(|t| t.rejected) || exact_differing > 0;
    let reason = reason(&tests, &scale, &pixels, &blocks, edges.as_ref(), &curvature, params, alpha_per_test);
    let histogram = histogram(&scores);
    Ok(CompareReport {
        verdict: if disagree { Verdict::Disagree } else { Verdict::Agree },
        reason,
        alpha: params.alpha,
        alpha_per_test,
        width: w,
        height: h,
        a: SideSummary { noise: ea.source.clone(), images: 1 },
        b: SideSummary { noise: eb.source.clone(), images: b.len() },
        tests,
        scale,
        pixels,
        blocks,
        edges,
        curvature,
        histogram,
        warnings,
        z_map,
        ratio_map,
    })
}

/// The verdict's one line: the rejecting tests, most significant first, with the likely cause.
#[allow(clippy::too_many_arguments)] // the report's parts, each read once
fn reason(
    tests: &[TestResult],
    scale: &[ScaleResult],
    pixels: &PixelSummary,
    blocks: &BlockSummary,
    edges: Option<&EdgeSummary>,
    curvature: &[CurvatureFit],
    params: &CompareParams,
    alpha_per_test: f64,
) -> String {
    let mut rejected: Vec<&TestResult> = tests.iter().filter(|t| t.rejected).collect();
    if rejected.is_empty() && pixels.exact_differing == 0 {
        return format!(
            "no test rejects at its level {alpha_per_test:.3e} ({} tests, family-wise false-alarm rate α = {})",
            tests.len(),
            params.alpha
        );
    }
    rejected.sort_by(|x, y| x.p.total_cmp(&y.p));
    let mut parts: Vec<String> = Vec::new();
    // Named once, at the most significant channel it explains.
    let mut curvature_named = false;
    if pixels.exact_differing > 0 {
        parts.push(format!("{} pixel values with zero error bars on both sides differ", pixels.exact_differing));
    }
    let scale_rejected: Vec<&ScaleResult> =
        scale.iter().filter(|s| rejected.iter().any(|t| t.name == format!("scale {}", s.channel))).collect();
    if !scale_rejected.is_empty() {
        let list: Vec<String> = scale_rejected
            .iter()
            .map(|s| format!("{} {:.5} ± {:.5} ({:+.1}σ)", s.channel, s.ratio, s.stderr, s.z))
            .collect();
        // The pooled χ²/ν has about a third of its ν (correlated channels): 3σ of that.
        let after = if blocks.chi2_nu_scale_removed < 1.0 + 3.0 * (6.0 / blocks.nu.max(1) as f64).sqrt() {
            format!(
                "; with the scale divided out the blocks agree (χ²/ν {:.2}): a scale or exposure difference only",
                blocks.chi2_nu_scale_removed
            )
        } else {
            format!("; with the scale divided out the blocks still differ (χ²/ν {:.2})", blocks.chi2_nu_scale_removed)
        };
        parts.push(format!("global scale A/B {}{after}", list.join(", ")));
    }
    for t in &rejected {
        match t.name.split_once(' ').map_or("", |(w, _)| w) {
            "pixels" => {
                let mut s = format!(
                    "{} pixel χ²/ν = {:.3} (ν = {}, p = {:.2e})",
                    &t.name[7..],
                    t.statistic,
                    t.dof.unwrap_or(0.0),
                    t.p
                );
                if let Some(e) = edges
                    && e.pixels > 0
                    && e.chi2_nu > 3.0 * e.interior_chi2_nu.max(1.0)
                {
                    s.push_str(&format!(
                        ", concentrated within 2 px of the silhouette (χ²/ν {:.1} on {} pixels, {:.2} elsewhere): a different pixel filter (box against Gaussian film)? exclude_edges = 3 leaves out the reach of a filter of radius 2 px (Mitsuba 3's default gaussian)",
                        e.chi2_nu, e.pixels, e.interior_chi2_nu
                    ));
                }
                if !curvature_named
                    && let Some(f) = curvature.iter().find(|f| f.channel == t.name[7..])
                    && f.z.abs() > crate::special::sidak_k(3, params.alpha)
                    && f.explained >= 0.25
                {
                    curvature_named = true;
                    let (smoother, sharper) = if f.c < 0.0 { ("B", "A") } else { ("A", "B") };
                    s.push_str(&format!(
                        ", and the differences follow the image's curvature (A − B = c ∇², away from any silhouette: c = {:+.3} ± {:.3} px², z {:+.1}, {:.0} % of the excess χ²): {smoother} is smoother than {sharper}, as a wider pixel filter makes it (a Gaussian film of σ 0.5 px against a box gives c ≈ {}0.083 px²); render both with the same filter",
                        f.c,
                        f.stderr,
                        f.z,
                        100.0 * f.explained,
                        if f.c < 0.0 { "−" } else { "+" }
                    ));
                }
                parts.push(s);
            }
            "blocks" => parts.push(format!(
                "{} {}×{} block χ²/ν = {:.3} (ν = {}, p = {:.2e})",
                &t.name[7..],
                blocks.size,
                blocks.size,
                t.statistic,
                t.dof.unwrap_or(0.0),
                t.p
            )),
            _ => {}
        }
    }
    format!("{} (each test at level {alpha_per_test:.3e}, family-wise α = {})", parts.join("; "), params.alpha)
}

/// The [`CurvatureFit`] of channel `c` over the compared pixels `idx` (`used` as a mask) outside the silhouette band
/// whose 8 neighbours are all compared; `None` with fewer than 16 such pixels or no curvature.
fn curvature_fit(
    ea: &Estimate,
    eb: &Estimate,
    idx: &[usize],
    used: &[bool],
    band: Option<&[bool]>,
    c: usize,
    excess: f64,
) -> Option<CurvatureFit> {
    let (w, h) = (ea.width, ea.height);
    let m = |i: usize| 0.5 * (ea.mean[i][c] + eb.mean[i][c]);
    let (mut sxy, mut sxx, mut count) = (0.0f64, 0.0f64, 0usize);
    for &i in idx {
        let (y, x) = (i / w, i % w);
        if y == 0 || x == 0 || y + 1 >= h || x + 1 >= w || band.is_some_and(|b| b[i]) {
            continue;
        }
        let ring = [i - w - 1, i - w, i - w + 1, i - 1, i + 1, i + w - 1, i + w, i + w + 1];
        if !ring.iter().all(|&j| used[j]) {
            continue;
        }
        let var = ea.var[i][c] + eb.var[i][c];
        if !(var > 0.0) {
            continue;
        }
        let diagonal = m(i - w - 1) + m(i - w + 1) + m(i + w - 1) + m(i + w + 1);
        let cross = m(i - w) + m(i - 1) + m(i + 1) + m(i + w);
        let lap = diagonal - cross;
        let d = ea.mean[i][c] - eb.mean[i][c];
        sxy += d * lap / var;
        sxx += lap * lap / var;
        count += 1;
    }
    if count < 16 || !(sxx > 0.0) {
        return None;
    }
    let (coef, stderr) = (sxy / sxx, sxx.sqrt().recip());
    let z = coef / stderr;
    Some(CurvatureFit {
        channel: CHANNELS[c].to_string(),
        c: coef,
        stderr,
        z,
        explained: if excess > 0.0 { (z * z / excess).min(1.0) } else { 0.0 },
        pixels: count,
    })
}

/// Pixels on the silhouette of a coverage layer: partial coverage (0.01 < m < 0.99), or a
/// 4-neighbour on the other side of 0.5.
fn silhouette_pixels(mask: &[f32], w: usize, h: usize) -> Vec<bool> {
    let inside = |i: usize| mask[i] > 0.5;
    (0..w * h)
        .map(|i| {
            let (y, x) = (i / w, i % w);
            let partial = mask[i] > 0.01 && mask[i] < 0.99;
            let mut other = false;
            if x > 0 {
                other |= inside(i - 1) != inside(i)
            }
            if x + 1 < w {
                other |= inside(i + 1) != inside(i)
            }
            if y > 0 {
                other |= inside(i - w) != inside(i)
            }
            if y + 1 < h {
                other |= inside(i + w) != inside(i)
            }
            partial || other
        })
        .collect()
}

/// `set` grown by `r` pixels in every direction (a (2r + 1)² square).
fn dilate(set: &[bool], w: usize, h: usize, r: usize) -> Vec<bool> {
    let mut out = vec![false; w * h];
    for (i, _) in set.iter().enumerate().filter(|(_, s)| **s) {
        let (y, x) = (i / w, i % w);
        for yy in y.saturating_sub(r)..(y + r + 1).min(h) {
            for xx in x.saturating_sub(r)..(x + r + 1).min(w) {
                out[yy * w + xx] = true;
            }
        }
    }
    out
}

/// [`Histogram`] of the scores.
fn histogram(scores: &[f64]) -> Histogram {
    let edges: Vec<f64> = (0..=48).map(|i| -6.0 + 0.25 * i as f64).collect();
    let mut counts = vec![0u64; 48];
    let (mut below, mut above) = (0, 0);
    for &u in scores {
        if u < -6.0 {
            below += 1;
        } else if u >= 6.0 {
            above += 1;
        } else {
            counts[(((u + 6.0) / 0.25) as usize).min(47)] += 1;
        }
    }
    let cdf = |x: f64| {
        if x < 0.0 {
            0.5 * crate::special::erfc(-x / std::f64::consts::SQRT_2)
        } else {
            1.0 - 0.5 * crate::special::erfc(x / std::f64::consts::SQRT_2)
        }
    };
    let expected = edges.windows(2).map(|e| scores.len() as f64 * (cdf(e[1]) - cdf(e[0]))).collect();
    Histogram { edges, counts, expected, below, above }
}
