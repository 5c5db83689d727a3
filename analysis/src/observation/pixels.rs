//! What the pixels of an orthographic view say beyond their values, for every command that fits
//! pixels (`analyze`, `invert lighting`, `invert brdf`): whether neighbouring pixels' noise is
//! correlated by a reconstruction filter wider than a pixel ([`noise`], the one function they all
//! use), and which pixels such a filter mixes with the background ([`edge_margin`]).
//!
//! The correlation comes from `--pixel-filter` (the kernel gives ρ and the variance inflation F
//! exactly, `analysis::noise`) or, without it, is measured from the residuals of the fit of the
//! B_lm (the semivariogram of neighbouring pixels' differences with the smooth remainder fitted
//! out, `analysis::noise::estimate_correlation`) and applied when the lag-1 correlation is
//! significant. The noise part of every error bar is then multiplied by √F.
//!
//! Our own renders (a `reflect:render` header) need neither: `reflect render` adds each sample to
//! the one pixel it was drawn in (a one-pixel box, independent pixels), so F = 1 for them, exactly.
//! The residual measurement is still made and shown, but not applied: on our renders a correlation
//! it "detects" is the truncation remainder left in the residuals (a Phong sphere under Grace at
//! l_max 4 measured F̂ 6.8, which would widen every bar 2.6×), not noise.

use super::{Camera, Error};
use crate::image::{Image, RgbImage};
use crate::noise::{MeasuredCorrelation, PixelFilter, ResidualGrid, estimate_correlation, near_lags};
use crate::projection::{
    OrthoCamera, OrthoView, Param, Sample, Sphere, fit_orthographic, ortho_sample_pixels, ortho_samples,
};
use crate::sh::{ShBasis, lmax_of};

/// The noise correlation at one lag: measured from the residuals and, with `--pixel-filter`, the
/// kernel's.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LagCorrelation {
    pub dx: i64,
    pub dy: i64,
    /// ρ̂(dx, dy) from the residuals (`None` when not measurable).
    pub measured: Option<f64>,
    /// ρ(dx, dy) of the `--pixel-filter` kernel.
    pub filter: Option<f64>,
}

/// How the pixels' noise correlation was handled (`pixel_noise` in the JSON of `analyze` and
/// `invert lighting | brdf` on orthographic views).
#[derive(Clone, Debug, serde::Serialize)]
pub struct PixelNoise {
    /// `pixel-filter` (the flag's kernel), `reflect-render` (our renderer's header: one sample
    /// counts in one pixel, F = 1 whatever the residuals show), `residuals` (measured and applied)
    /// or `none` (no correlation detected, or not measurable: F = 1).
    pub source: String,
    /// The `--pixel-filter` given (`box`, `gaussian:STDDEV:RADIUS`, `tent:RADIUS`).
    pub pixel_filter: Option<String>,
    /// Correlation at the lag-1 neighbours (1, 0), (0, 1), (1, 1), (1, −1).
    pub lag1: Vec<LagCorrelation>,
    /// F̂ = Σ_d ρ̂(d) over |dx|, |dy| ≤ 2 from the residuals.
    pub inflation_measured: Option<f64>,
    /// Standard error of one measured ρ̂ (≈ 1/√n, n pixel pairs at lag (1, 0)).
    pub rho_stderr: Option<f64>,
    /// The residuals' short-lag differences are dominated by the image's structure, not its noise:
    /// the measurement is not one of the noise.
    pub signal_dominated: bool,
    /// The variance inflation F applied to the noise covariance of every fit.
    pub inflation: f64,
    /// √F: the factor on the noise part of the error bars.
    pub stderr_scale: f64,
    /// Pixels whose filter footprint reaches within this distance (pixels) of the silhouette are not
    /// used (the filter's radius; 0.5 for a box, as without a filter).
    pub edge_margin_px: f64,
    /// In words, one sentence.
    pub note: String,
    /// The warning this handling calls for ([`PixelNoise::warning`]).
    #[serde(skip)]
    warning: Option<String>,
}

impl PixelNoise {
    /// One text line for the reports.
    /// The one `warning:` the noise handling calls for, or `None`: a correlation measured from the
    /// residuals (the image's own filter, not said), or residuals whose lag-1 correlation is not the
    /// `--pixel-filter` kernel's. A `--pixel-filter` that the residuals agree with is the user's
    /// information, not a warning: it is stated in the report's `# pixel noise` line
    /// ([`PixelNoise::line`]) and `pixel_noise` JSON only.
    pub fn warning(&self) -> Option<String> {
        self.warning.clone()
    }

    pub fn line(&self) -> String {
        let lag = |l: &LagCorrelation| {
            let m = l.measured.map_or("-".into(), |v| format!("{v:.3}"));
            match l.filter {
                Some(f) => format!("ρ({},{}) {m} (filter {f:.3})", l.dx, l.dy),
                None => format!("ρ({},{}) {m}", l.dx, l.dy),
            }
        };
        format!(
            "# pixel noise: {}; variance inflation F = {:.3} applied (noise error bars × {:.3}); measured F̂ {}; {}",
            self.lag1.iter().map(lag).collect::<Vec<_>>().join(", "),
            self.inflation,
            self.stderr_scale,
            self.inflation_measured.map_or("-".into(), |f| format!("{f:.3}")),
            self.note
        )
    }
}

/// The noise of the orthographic views among `images` (cameras `cameras`, fitted in `param` to
/// `lmax`), decided before any fit, for every command: with `filter`, the pixels its footprint
/// mixes with the background are left out ([`edge_margin`]) and its kernel gives ρ and F; without,
/// a first SH fit's residuals give them ([`noise`]), and when they show a correlation the pixels
/// within the reach of the equivalent Gaussian filter (stddev from ρ̂(1, 0) = exp(−1/(4σ²)), radius
/// 4σ, within [0.5, 4] px) are left out too. Returns `None` without orthographic views, and the
/// notes for the user (`note: …` lines: the pixels a given filter left out). Errors: as the fit
/// ([`fit_orthographic`]).
pub fn prepare(
    images: &mut [Image],
    cameras: &[Camera],
    sphere: &Sphere,
    param: Param,
    lmax: usize,
    filter: Option<PixelFilter>,
) -> Result<(Option<PixelNoise>, Vec<String>), Error> {
    let mut notes = Vec::new();
    if !cameras.iter().all(|c| matches!(c, Camera::Ortho(_))) || images.is_empty() {
        return Ok((None, notes));
    }
    if let Some(f) = filter {
        let n = edge_margin(images, cameras, sphere, f);
        if n > 0 {
            notes.push(format!(
                "note: --pixel-filter {f}: {n} pixels within the filter's reach of the silhouette left out"
            ));
        }
    }
    let views: Vec<OrthoView> = images
        .iter()
        .zip(cameras)
        .filter_map(|(image, c)| match c {
            Camera::Ortho(camera) => Some(OrthoView { image, camera: *camera }),
            Camera::NormalProbe { .. } => None,
        })
        .collect();
    // Every view rendered by us: the box filter of `reflect render` (module docs).
    let own = views.iter().all(|v| v.image.attributes.contains_key(vocab::header::RENDER));
    let fit = fit_orthographic(&views, sphere, param, lmax)?;
    let (samples, _) = ortho_samples(&views, sphere, param)?;
    let mut report = noise(&views, sphere, param, &fit.coefficients, &samples, filter, own)?;
    drop(views);
    if report.source == "residuals"
        && let Some(rho) = report.lag1[0].measured.zip(report.lag1[1].measured).map(|(a, b)| 0.5 * (a + b))
    {
        let stddev = if rho > 0.0 && rho < 1.0 { 1.0 / (2.0 * (-rho.ln()).sqrt()) } else { 1.0 };
        let radius = (4.0 * stddev).clamp(0.5, 4.0);
        let equivalent = PixelFilter::Gaussian { stddev, radius };
        let n = edge_margin(images, cameras, sphere, equivalent);
        report.edge_margin_px = radius;
        report.note.push_str(&format!(
            "; {n} pixels within {radius:.1} px of the silhouette left out (the reach of a Gaussian filter with this correlation)"
        ));
    }
    Ok((Some(report), notes))
}

/// The noise correlation of the pixels `samples` of `views` (as [`crate::projection::ortho_samples`]
/// returns them) and the variance inflation every fit over them applies (module docs): from
/// `filter` when given, else F = 1 when every view is our own render (`own`), else measured from the
/// residuals of the SH fit `coefficients` (RGB, index order, up to any l_max). Errors: as
/// `ortho_samples` (a view without R, G, B, a degenerate camera).
pub fn noise(
    views: &[OrthoView],
    sphere: &Sphere,
    param: Param,
    coefficients: &[[f64; 3]],
    samples: &[Sample],
    filter: Option<PixelFilter>,
    own: bool,
) -> Result<PixelNoise, Error> {
    let at = ortho_sample_pixels(views, sphere, param)?;
    let measured = lmax_of(coefficients.len()).filter(|_| at.len() == samples.len()).and_then(|lmax| {
        let basis = ShBasis::new(lmax);
        let mut y = vec![0.0; coefficients.len()];
        let mut grids: Vec<Vec<ResidualGrid>> = (0..3)
            .map(|_| {
                views
                    .iter()
                    .map(|v| ResidualGrid {
                        width: v.image.width,
                        height: v.image.height,
                        values: vec![f64::NAN; v.image.width * v.image.height],
                    })
                    .collect()
            })
            .collect();
        for (s, &[k, row, col]) in samples.iter().zip(&at) {
            basis.eval_into(s.dir, &mut y);
            for (ch, g) in grids.iter_mut().enumerate() {
                let pred: f64 = coefficients.iter().zip(&y).map(|(c, y)| c[ch] * y).sum();
                let w = g[k].width;
                g[k].values[row * w + col] = s.b[ch] - pred;
            }
        }
        estimate_correlation(&grids)
    });
    Ok(decide(measured.as_ref(), filter, own))
}

/// The report from the measurement and the flag: the flag's kernel when given, else F = 1 for our
/// own renders (`own`), else the measurement when it detects a correlation (module docs).
fn decide(m: Option<&MeasuredCorrelation>, filter: Option<PixelFilter>, own: bool) -> PixelNoise {
    let lags = &near_lags()[..4];
    let lag1 = lags
        .iter()
        .enumerate()
        .map(|(i, &(dx, dy))| LagCorrelation {
            dx,
            dy,
            measured: m.map(|m| m.rho[i].1),
            filter: filter.map(|f| f.correlation(dx, dy)),
        })
        .collect();
    let mut warn = false;
    let (source, inflation, note) = match (filter, m) {
        (Some(f), _) => {
            let mut note = format!("from --pixel-filter {f}: its kernel's autocorrelation gives ρ and F");
            if let Some(m) = m.filter(|m| !m.signal_dominated)
                && (m.lag1() - f.correlation(1, 0)).abs() > 0.1 + 4.0 * m.rho_stderr
            {
                warn = true;
                note.push_str(&format!(
                    " — but the residuals' lag-1 correlation {:.3} is not the filter's {:.3}: check --pixel-filter (pbrt-v4 samples its filter: its pixels' noise is independent, pass box)",
                    m.lag1(),
                    f.correlation(1, 0)
                ));
            }
            ("pixel-filter", f.inflation(), note)
        }
        (None, _) if own => (
            "reflect-render",
            1.0,
            format!(
                "the reflect:render header: each sample counts in the one pixel it was drawn in, independent pixels, F = 1{}",
                m.map_or(String::new(), |m| format!(
                    " (the residuals' lag-1 correlation {:.3} ± {:.3} is the fit's truncation remainder, not noise: not applied)",
                    m.lag1(),
                    m.rho_stderr
                ))
            ),
        ),
        (None, Some(m)) if m.detected() => (
            {
                warn = true;
                "residuals"
            },
            m.inflation,
            format!(
                "measured from the residuals (lag-1 correlation {:.3} ± {:.3}): a reconstruction filter wider than a pixel; \
                 pass --pixel-filter to use the kernel's F and leave out the pixels it mixes with the background",
                m.lag1(),
                m.rho_stderr
            ),
        ),
        (None, Some(m)) if m.signal_dominated => (
            "none",
            1.0,
            "not measurable: the residuals' differences between neighbouring pixels are the image's structure, not noise; \
             if the renderer's filter is wider than a pixel, pass --pixel-filter"
                .to_string(),
        ),
        (None, Some(m)) => (
            "none",
            1.0,
            format!("no correlation between neighbouring pixels detected (lag-1 {:.3} ± {:.3})", m.lag1(), m.rho_stderr),
        ),
        (None, None) => ("none", 1.0, "not measurable: too few pixels".to_string()),
    };
    let inflation = inflation.max(1.0);
    PixelNoise {
        source: source.to_string(),
        pixel_filter: filter.map(|f| f.to_string()),
        lag1,
        inflation_measured: m.map(|m| m.inflation),
        rho_stderr: m.map(|m| m.rho_stderr),
        signal_dominated: m.is_some_and(|m| m.signal_dominated),
        inflation,
        stderr_scale: inflation.sqrt(),
        edge_margin_px: filter.map_or(0.5, |f| f.radius().max(0.5)),
        warning: warn.then(|| format!("pixel noise correlated between neighbouring pixels: {note}")),
        note,
    }
}

/// The sphere's disc in an orthographic view, in pixel coordinates: centre (column, row) measured
/// from the top-left corner of the image to the pixel centres (pixel (0, 0) has centre (0, 0)) and
/// radius, from docs/src/conventions.md §5's pixel → ray mapping. `None` for a degenerate camera.
pub fn disc(camera: &OrthoCamera, sphere: &Sphere, width: usize, height: usize) -> Option<([f64; 2], f64)> {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    // The frame the fits sample pixels with (one definition, `OrthoCamera::basis`).
    let [_, right, up] = camera.basis().ok()?;
    if camera.extent.is_nan() || camera.extent <= 0.0 || width == 0 || height == 0 {
        return None;
    }
    let (w, h) = (width as f64, height as f64);
    let oc = sub(sphere.center, camera.from);
    let (x, y) = (dot(oc, right), dot(oc, up));
    let col = (x / camera.extent + 1.0) * w / 2.0 - 0.5;
    let row = (1.0 - y / (camera.extent * h / w)) * h / 2.0 - 0.5;
    Some(([col, row], sphere.radius * w / (2.0 * camera.extent)))
}

/// Leaves out (through the `mask.Y` channel every fit honours) the pixels of orthographic views
/// whose `filter` footprint, a square of half-width its radius, reaches the silhouette: there the
/// filter mixes in the background. A box of one pixel changes nothing (the fits already use only
/// pixels whose footprint lies on the sphere). Returns the number of pixels left out.
pub fn edge_margin(images: &mut [Image], cameras: &[Camera], sphere: &Sphere, filter: PixelFilter) -> usize {
    let reach = filter.radius() * std::f64::consts::SQRT_2;
    if reach <= std::f64::consts::FRAC_1_SQRT_2 {
        return 0;
    }
    let mut dropped = 0;
    for (img, cam) in images.iter_mut().zip(cameras) {
        let Camera::Ortho(c) = cam else { continue };
        let Some(([cx, cy], r)) = disc(c, sphere, img.width, img.height) else { continue };
        let (w, h) = (img.width, img.height);
        let mut mask = img.channel("mask.Y").map_or_else(|| vec![1.0f32; w * h], |m| m.to_vec());
        for row in 0..h {
            for col in 0..w {
                let d = ((col as f64 - cx).powi(2) + (row as f64 - cy).powi(2)).sqrt();
                let i = row * w + col;
                if d < r && d + reach >= r && mask[i] >= 0.999 {
                    mask[i] = 0.0;
                    dropped += 1;
                }
            }
        }
        img.channels.insert("mask.Y".to_string(), mask);
    }
    dropped
}

/// The sphere's silhouette measured in an image, in pixel coordinates (as [`disc`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Silhouette {
    /// Centroid (column, row) of the covered pixels.
    pub center: [f64; 2],
    /// √(covered pixels / π).
    pub radius: f64,
    /// What told covered pixels from the rest: `alpha` (channel ≥ 0.5) or `background` (differs
    /// from the uniform background value).
    pub from: &'static str,
}

/// The alpha (coverage) channel of `img`: `A`, the chosen layer's `LAYER.A`, the only `*.A`
/// channel, or our `mask.Y`.
fn alpha<'a>(img: &'a Image, layer: Option<&str>) -> Option<&'a [f32]> {
    if let Some(a) = img.channel("A") {
        return Some(a);
    }
    if let Some(a) = layer.and_then(|l| img.channel(&format!("{}.A", l.trim_end_matches('.')))) {
        return Some(a);
    }
    let mut dotted = img.channels.iter().filter(|(k, _)| k.ends_with(".A"));
    match (dotted.next(), dotted.next()) {
        (Some((_, v)), None) => Some(v),
        _ => img.channel("mask.Y"),
    }
}

/// The RGB values of the pixels on the image's border (each once); `None` for an image narrower than
/// 3 pixels.
fn border_pixels(rgb: &RgbImage) -> Option<Vec<[f32; 3]>> {
    let (w, h) = (rgb.width, rgb.height);
    if w < 3 || h < 3 {
        return None;
    }
    Some(
        (0..w)
            .flat_map(|c| [rgb.pixels[c], rgb.pixels[(h - 1) * w + c]])
            .chain((1..h - 1).flat_map(|r| [rgb.pixels[r * w], rgb.pixels[r * w + w - 1]]))
            .collect(),
    )
}

/// The uniform background of `img`, if it has one: the RGB value of at least half of the pixels on
/// the image's border (a renderer's miss value, e.g. 0 with the environment hidden).
fn background(img: &Image) -> Option<[f32; 3]> {
    let border = border_pixels(&img.rgb()?)?;
    let mut counts: Vec<([f32; 3], usize)> = Vec::new();
    for p in &border {
        let same = |v: &[f32; 3]| v.iter().zip(p).all(|(a, b)| a.to_bits() == b.to_bits());
        match counts.iter().position(|(v, _)| same(v)) {
            Some(k) => counts[k].1 += 1,
            None if counts.len() < 64 => counts.push((*p, 1)),
            None => {}
        }
    }
    let (v, n) = counts.into_iter().max_by_key(|(_, n)| *n)?;
    (2 * n >= border.len()).then_some(v)
}

/// A background that is nearly uniform and dark next to the image: the border's per-channel median
/// and a tolerance 8 × the 75th percentile of the border's deviations from it (at least 1e-6
/// relative), when that tolerance is below 1e-3 of the image's largest radiance; `None` otherwise.
fn dark_border(img: &Image) -> Option<([f32; 3], f32)> {
    let rgb = img.rgb()?;
    let border = border_pixels(&rgb)?;
    let mut bg = [0.0f32; 3];
    for ch in 0..3 {
        let mut v: Vec<f32> = border.iter().map(|p| p[ch]).filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f32::total_cmp);
        bg[ch] = v[v.len() / 2];
    }
    // The border's spread robustly: its 75th-percentile deviation (the sphere, or a filter's tails,
    // may reach a few border pixels, where the silhouette nearly touches the frame).
    let mut dev: Vec<f32> = border.iter().flat_map(|p| (0..3).map(move |c| (p[c] - bg[c]).abs())).collect();
    dev.sort_by(f32::total_cmp);
    let spread = dev[(3 * dev.len()) / 4];
    let peak = rgb.pixels.iter().flatten().filter(|x| x.is_finite()).fold(0.0f32, |a, b| a.max(b.abs()));
    let tol = (8.0 * spread).max(1e-6 * (1.0 + bg.iter().fold(0.0f32, |a, b| a.max(b.abs()))));
    (peak > 0.0 && tol < 1e-3 * peak).then_some((bg, tol))
}

/// Centroid and equivalent radius √(n/π) of the pixels where `covered(index)` holds; `None` when none is.
fn blob(w: usize, h: usize, covered: impl Fn(usize) -> bool) -> Option<([f64; 2], f64)> {
    let (mut n, mut sx, mut sy) = (0usize, 0.0, 0.0);
    for row in 0..h {
        for col in 0..w {
            if covered(row * w + col) {
                n += 1;
                sx += col as f64;
                sy += row as f64;
            }
        }
    }
    (n > 0).then(|| ([sx / n as f64, sy / n as f64], (n as f64 / std::f64::consts::PI).sqrt()))
}

/// The camera-consistency check of an orthographic view whose camera does not come from our own
/// header: the sphere's silhouette in the image against the disc `camera` and `sphere` predict.
///
/// Covered pixels are those with alpha ≥ 0.5 (`alpha`, when some pixels have alpha < 0.5), else those whose radiance differs from the
/// uniform background (`background`); the predicted disc is rasterized by the same rule (pixel
/// centres within r of the centre for alpha; within r + the filter's reach for the background
/// rule, as a filter spreads the sphere into every pixel it reaches, `filter` or, unknown, a box,
/// with up to 1.5 px more allowed for an unknown filter as wide as Mitsuba's default), both clipped
/// to the image, and compared by centroid and equivalent radius. Returns `Ok(None)` when they agree
/// within 1 pixel (the radius within [r − 1, r + reach + 1.5] for the edge found above a
/// non-uniform dark background, `dark_border`), `Ok(Some(warning))` when the image has neither
/// alpha nor a uniform or dark background
/// (nothing to check against), and an error naming the measured and predicted centre and radius
/// when they disagree by more.
pub fn check_silhouette(
    img: &Image,
    layer: Option<&str>,
    camera: &OrthoCamera,
    sphere: &Sphere,
    filter: Option<PixelFilter>,
) -> Result<Option<String>, Error> {
    let (w, h) = (img.width, img.height);
    let Some(([cx, cy], r)) = disc(camera, sphere, w, h) else { return Ok(None) };
    let dist = |i: usize| (((i % w) as f64 - cx).powi(2) + ((i / w) as f64 - cy).powi(2)).sqrt();
    // An alpha that is ≥ 0.5 everywhere (a renderer showing its environment, Blender's opaque film)
    // or nowhere says nothing about the silhouette.
    let alpha = alpha(img, layer).filter(|a| a.iter().any(|&v| v >= 0.5) && a.iter().any(|&v| v < 0.5));
    let (measured, predicted, slack) = if let Some(a) = alpha {
        let m = blob(w, h, |i| a[i] >= 0.5);
        let p = blob(w, h, |i| dist(i) < r);
        (m.map(|(c, r)| Silhouette { center: c, radius: r, from: "alpha" }), p, 0.0)
    } else if let Some(bg) = background(img) {
        let Some(rgb) = img.rgb() else { return Ok(None) };
        let differs = |i: usize| {
            rgb.pixels[i].iter().zip(&bg).any(|(v, b)| (v - b).abs() > 1e-6 * (1.0 + b.abs()) || !v.is_finite())
        };
        let reach = filter.map_or(0.5, |f| f.radius().max(0.5));
        let Some(m) = blob(w, h, differs) else {
            return Ok(Some(
                "every pixel has the background's value, so the camera and sphere given cannot be checked against the \
                 sphere's silhouette"
                    .to_string(),
            ));
        };
        let m = Some(m);
        let p = blob(w, h, |i| dist(i) < r + reach);
        (
            m.map(|(c, r)| Silhouette { center: c, radius: r, from: "background" }),
            p,
            if filter.is_some() { 0.0 } else { 1.5 },
        )
    } else if let Some((bg, tol)) = dark_border(img) {
        // A background that is not exactly uniform (a Gaussian film's tails, a renderer's noise
        // floor) but small next to the sphere: the silhouette is where the image rises above the
        // border's own spread. Filter tails below that spread are not counted, so the measured
        // radius lies between the disc's r and r + the filter's reach (+ 1.5 px for an unknown one).
        let Some(rgb) = img.rgb() else { return Ok(None) };
        let differs = |i: usize| rgb.pixels[i].iter().zip(&bg).any(|(v, b)| (v - b).abs() > tol || !v.is_finite());
        let reach = filter.map_or(2.0, |f| f.radius().max(0.5));
        let m = blob(w, h, differs);
        let p = blob(w, h, |i| dist(i) < r);
        (m.map(|(c, r)| Silhouette { center: c, radius: r, from: "the image's own edge" }), p, reach + 1.5)
    } else {
        return Ok(Some(
            "the image has no alpha channel and no uniform background, so the camera and sphere given cannot be \
             checked against the sphere's silhouette: a wrong --extent or --from gives wrong numbers without a warning"
                .to_string(),
        ));
    };
    let fmt = |c: [f64; 2], r: f64| format!("centre ({:.1}, {:.1}) px, radius {r:.1} px", c[0], c[1]);
    let predicted_text = predicted.map_or("no pixel of the image".to_string(), |(c, r)| fmt(c, r));
    let bad = match (&measured, predicted) {
        (Some(m), Some((pc, pr))) => {
            let dc = ((m.center[0] - pc[0]).powi(2) + (m.center[1] - pc[1]).powi(2)).sqrt();
            dc > 1.0 || m.radius - pr > 1.0 + slack || pr - m.radius > 1.0
        }
        (None, None) => false,
        _ => true,
    };
    if !bad {
        return Ok(None);
    }
    let measured_text = measured.as_ref().map_or("no covered pixel".to_string(), |m| {
        format!(
            "{} (from {})",
            fmt(m.center, m.radius),
            match m.from {
                "alpha" => "alpha",
                "background" => "the uniform background",
                other => other,
            }
        )
    });
    Err(Error::Silhouette {
        measured: measured_text,
        told: format!(
            "the camera ({}) and sphere (centre {}, radius {})",
            Camera::Ortho(*camera),
            sphere.center.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(","),
            sphere.radius
        ),
        predicted: predicted_text,
        suspect: suspect(measured.as_ref(), predicted, slack, camera.extent),
    })
}

/// The assumption a silhouette mismatch most likely comes from. The same centre and another
/// radius: the extent (or the sphere's radius), whose value the measured radius gives — the image
/// shows the sphere r_m / r_p times the size predicted, so the extent is the told one × r_p / r_m,
/// a range when the measured edge may include up to `slack` px of a filter's tail. A moved centre:
/// the camera's position or the sphere's centre. (Clipping at the image's edge biases both; the
/// words say "likely".)
fn suspect(measured: Option<&Silhouette>, predicted: Option<([f64; 2], f64)>, slack: f64, extent: f64) -> String {
    let generic = "check the camera (--extent, --from/--to/--up, or the [camera] of --scene) and the sphere \
                   (--center/--radius)";
    let (Some(m), Some((pc, pr))) = (measured, predicted) else { return generic.to_string() };
    let dc = ((m.center[0] - pc[0]).powi(2) + (m.center[1] - pc[1]).powi(2)).sqrt();
    if dc <= 1.0 && m.radius > 0.0 {
        // The sphere's own radius lies between the measured one less the slack and the measured one.
        let at = |r: f64| extent * pr / r;
        let range = if slack > 0.0 && m.radius > slack {
            format!("{:.3}–{:.3}", at(m.radius), at(m.radius - slack))
        } else {
            format!("{:.3}", at(m.radius))
        };
        format!(
            "the likely wrong assumption is the extent (or the sphere's radius): the sphere appears {:.3}× the size \
             predicted, as with an extent of {range} for the told {extent}; check --extent (or the [camera] of \
             --scene) and --radius",
            m.radius / pr
        )
    } else {
        format!(
            "the likely wrong assumption is the camera's position or the sphere's centre (the centre is {dc:.1} px \
             off): check --from/--to/--up (or the [camera] of --scene) and --center; {generic}"
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A residual measurement that detects a strong lag-1 correlation (F̂ = 4.2).
    fn correlated() -> MeasuredCorrelation {
        let rho = near_lags().into_iter().enumerate().map(|(i, d)| (d, if i < 4 { 0.4 } else { 0.0 })).collect();
        MeasuredCorrelation { rho, inflation: 4.2, rho_stderr: 0.01, pairs: 10_000, signal_dominated: false }
    }

    #[test]
    fn own_renders_keep_f_one_whatever_the_residuals_show() {
        let m = correlated();
        assert!(m.detected());
        // Another renderer's image: the measured F̂ is applied.
        let foreign = decide(Some(&m), None, false);
        assert_eq!(foreign.source, "residuals");
        assert_eq!(foreign.inflation, 4.2);
        // Our render: F = 1, the measurement only shown.
        let own = decide(Some(&m), None, true);
        assert_eq!(own.source, "reflect-render");
        assert_eq!(own.inflation, 1.0);
        assert!(own.note.contains("not applied"), "{}", own.note);
        // An explicit --pixel-filter still wins on our render.
        let flagged = decide(Some(&m), Some(PixelFilter::Tent { radius: 1.0 }), true);
        assert_eq!(flagged.source, "pixel-filter");
        assert!(flagged.inflation > 1.0);
    }
}
