//! `reflect compare A B [--seeds B2 B3 …]`: is A the same picture as B up to their noise? Parses,
//! calls [`analysis::compare::compare`] and prints; the statistics live there. Exit status 0 when
//! the images agree, 1 when they do not, 2 for bad input (as `cmp` and `diff`).
//!
//! `reflect compare A --prediction`: B is the image the theory predicts for A's scene (its header,
//! `--scene` or the view, BRDF and lighting flags, as `analyze` reads them),
//! [`analysis::predict::predict_scene`].

use super::Error;
use super::args::{BrdfFlags, ViewArgs};
use super::outputs::{Files, Format};
use analysis::compare::{CompareError, CompareParams, CompareReport, Verdict};
use analysis::image::Image;
use analysis::observation::{Camera, lighting_of};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(clap::Args, Debug, Clone)]
pub struct CompareArgs {
    /// Image A (OpenEXR or Radiance .hdr): a render with its stderr layer, or a reference taken as
    /// exact.
    pub a: PathBuf,
    /// Image B: a render with its stderr layer, or the first seed of B's renderer (with --seeds).
    #[arg(required_unless_present = "prediction")]
    pub b: Option<PathBuf>,
    /// Compare A with the image the theory predicts for its scene (eq. 15 pixel by pixel: a
    /// lambert sphere, or phong with horizon = "ignore", seen by an orthographic camera), from A's
    /// header or --scene, else the view, BRDF and lighting flags; A needs its stderr layer.
    #[arg(long, conflicts_with_all = ["b", "seeds"])]
    pub prediction: bool,
    /// With --prediction: the lighting (a scene .toml's `[lighting]` table, or an environment map) in
    /// place of the header's or --scene's.
    #[arg(long, requires = "prediction")]
    pub lighting: Option<PathBuf>,
    /// With --prediction: the mapping of an environment map given with --lighting (default:
    /// inferred from its aspect ratio).
    #[arg(long, value_enum, requires = "lighting")]
    pub mapping: Option<vocab::Mapping>,
    /// With --prediction: the camera and sphere of an image whose header does not say them.
    #[command(flatten)]
    pub view: ViewArgs,
    /// With --prediction: the BRDF of the sphere when the header and --scene do not say it.
    #[command(flatten)]
    pub brdf: BrdfFlags,
    /// Further seeds of B's renderer (independent renders of the same scene): B's noise is then the
    /// spread of B and the seeds per pixel (n − 1 degrees of freedom for n images), and their stderr
    /// layers are not used (A's is).
    #[arg(long, num_args = 1..)]
    pub seeds: Vec<PathBuf>,
    /// Family-wise false-alarm rate of the verdict (the probability that agreeing images are
    /// called different), 0 < ALPHA < 0.5.
    #[arg(long, default_value_t = 0.01, allow_hyphen_values = true)]
    pub alpha: f64,
    /// Side of the square blocks of the block test, in pixels.
    #[arg(long, default_value_t = 8)]
    pub block: usize,
    /// Leave out every pixel within N − 1 pixels (in rows and columns) of a silhouette pixel (N = 1:
    /// the silhouette only; 3 for a filter of radius 2 px), found from a mask.Y or alpha (A) channel:
    /// for renderers with different pixel filters.
    #[arg(long, default_value_t = 0)]
    pub exclude_edges: usize,
    /// Compare the object only: leave out the background (coverage 0 in A's mask.Y or alpha, else
    /// B's), where another renderer's environment-map lookup may differ from ours with no noise on
    /// either side to absorb it.
    #[arg(long)]
    pub object_only: bool,
    /// Print the report as one JSON document (its `verdict` is "agree" or "disagree").
    #[arg(long)]
    pub json: bool,
    /// Write a report folder: index.html, z.png (per-pixel z, diverging colours), ratio.png
    /// (A/B), histogram.png (the pixels' Gaussian scores of z against N(0, 1)).
    #[arg(long)]
    pub report: Option<PathBuf>,
}

/// The report's files inside `--report DIR`.
const REPORT_FILES: [(&str, Format); 4] =
    [("index.html", Format::Html), ("z.png", Format::Png), ("ratio.png", Format::Png), ("histogram.png", Format::Png)];

pub fn run(a: CompareArgs) -> Result<ExitCode, Error> {
    if !a.prediction
        && let Some(flag) = description_flag(&a)
    {
        return Err(Error::new(format!(
            "{flag} describes the scene of --prediction; without --prediction the images are compared as they are"
        )));
    }
    let mut paths = vec![a.a.clone()];
    paths.extend(a.b.iter().cloned());
    paths.extend(a.seeds.iter().cloned());
    let mut files = Files::new().input("image A", &a.a).inputs("image B", a.b.as_slice()).inputs("--seeds", &a.seeds);
    if let Some(dir) = &a.report {
        for (name, f) in REPORT_FILES {
            files = files.output("--report", dir.join(name), f);
        }
    }
    files.check()?;
    let mut params = CompareParams {
        alpha: a.alpha,
        block: a.block,
        exclude_edges: a.exclude_edges,
        object_only: a.object_only,
        b_systematic: None,
    };
    let (report, notes) = if a.prediction {
        let (image, predicted, warnings) = prediction(&a)?;
        params.b_systematic = Some(predicted.systematic.clone());
        let mut report =
            analysis::compare::compare(&image, &[predicted.to_image()], &params).map_err(|e| error_of(e, &paths))?;
        report.b.noise = format!(
            "the prediction of eq. 15 summed to l = {}: exact but for its truncation, a systematic error bounded by \
             2 max |B(l ≤ {}) − B(l ≤ {})| nearby (at most {:.1e} of the mean radiance), added to every error bar",
            predicted.lmax,
            predicted.lmax,
            predicted.lmax_check,
            predicted.max_relative_systematic()
        );
        report.warnings.splice(0..0, warnings);
        (report, Vec::new())
    } else {
        let mut images: Vec<Image> = Vec::with_capacity(paths.len());
        let mut notes = Vec::new();
        for p in &paths {
            let (img, n) = renderer::render_file::read_image_notes(p)?;
            let (mut img, note) = img.select_layer(a.view.image.layer.as_deref()).map_err(|e| e.in_file(p))?;
            notes.extend(n.into_iter().chain(note).map(|n| format!("note: {}: {n}", p.display())));
            if let Some(n) = to_our_image_axes(&mut img) {
                notes.push(format!("note: {}: {n}", p.display()));
            }
            // Flagged pixels are compared, with the error bars near them bounded as every analysis
            // reads a render (leaving them out would select on the image's values).
            crate::images::bound_near_flags(&mut img);
            images.push(img);
        }
        let report = analysis::compare::compare(&images[0], &images[1..], &params).map_err(|e| error_of(e, &paths))?;
        (report, notes)
    };
    let shown: Vec<String> = match &a.b {
        Some(_) => paths.iter().map(|p| p.display().to_string()).collect(),
        None => vec![a.a.display().to_string(), "the prediction".to_string()],
    };
    let staged = match &a.report {
        Some(dir) => stage_report(dir, &report, &shown)?,
        None => Vec::new(),
    };
    for n in &notes {
        eprintln!("{n}");
    }
    for s in staged {
        s.commit()?;
    }
    super::print_warnings(&report.warnings);
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report).expect("the report serialises"));
    } else {
        print_text(&report, &shown);
    }
    if let Some(dir) = &a.report {
        eprintln!("wrote {}", dir.join("index.html").display());
    }
    Ok(match report.verdict {
        Verdict::Agree => ExitCode::SUCCESS,
        Verdict::Disagree => ExitCode::from(1),
    })
}

/// The first flag given that describes the scene of `--prediction` (camera, sphere, BRDF, lighting),
/// if any: without `--prediction` they would be ignored, so they are refused.
fn description_flag(a: &CompareArgs) -> Option<&'static str> {
    let v = &a.view;
    let b = &a.brdf;
    [
        (!v.from.is_empty(), "--from"),
        (!v.to.is_empty(), "--to"),
        (!v.up.is_empty(), "--up"),
        (!v.extent.is_empty(), "--extent"),
        (v.center.is_some(), "--center"),
        (v.radius.is_some(), "--radius"),
        (v.pixel_filter.is_some(), "--pixel-filter"),
        (v.image.scene.is_some(), "--scene"),
        (!v.image.theta_o.is_empty(), "--theta-o"),
        (!v.image.phi_o.is_empty(), "--phi-o"),
        (b.brdf.is_some(), "--brdf"),
        (b.s.is_some(), "--s"),
        (b.sigma.is_some(), "--sigma"),
        (!b.brdf_param.is_empty(), "--brdf-param"),
        (b.albedo.is_some(), "--albedo"),
    ]
    .into_iter()
    .find_map(|(given, flag)| given.then_some(flag))
}

/// Image A as every analysis reads it, and the image the theory predicts for its scene, with the
/// warnings of reading A's description: A's description from its header, `--scene` or the flags (`super::header::load`).
fn prediction(a: &CompareArgs) -> Result<(Image, analysis::predict::PredictedImage, Vec<String>), Error> {
    let (mut images, d) = super::header::load(std::slice::from_ref(&a.a), &a.view, "compared")?;
    let image = images.remove(0);
    let in_a = |e: Error| e.in_file(&a.a);
    let Camera::Ortho(camera) = d.cameras[0] else {
        return Err(Error::file(
            &a.a,
            "is a normal-probe render: --prediction predicts orthographic views of a sphere (analyze compares a \
             normal probe with the theory)",
        ));
    };
    if image.stderr_layer().map_err(in_a)?.is_none() {
        return Err(Error::file(
            &a.a,
            "has no stderr layer: a comparison with the prediction judges the image by its own error bars",
        ));
    }
    let resolved = d.transfer(&a.brdf.values(), 0.0).map_err(|e| e.in_file(&a.a))?.ok_or_else(|| {
        Error::file(&a.a, "the sphere's BRDF is not known (no reflect:objects header, --scene or --brdf)")
    })?;
    let transfer = resolved.transfer.ok_or_else(|| {
        Error::file(&a.a, format!("the sphere's BRDF ({}, {}) has no transfer model", resolved.kind, resolved.source))
    })?;
    let (lighting, _) = lighting_of(a.lighting.as_deref(), a.mapping, &d)
        .map_err(|e| if a.lighting.is_none() { e.in_file(&a.a) } else { e })?
        .ok_or_else(|| {
            Error::file(&a.a, "the lighting is not known (no reflect:lighting header or --scene): give --lighting")
        })?;
    let scene = analysis::predict::OrthoScene { camera, sphere: d.sphere, width: image.width, height: image.height };
    let predicted =
        analysis::predict::predict_scene(&scene, &lighting, transfer.model, transfer.scale, transfer.horizon)
            .map_err(in_a)?;
    let mut warnings = d.stderr_notes.clone();
    warnings.extend(d.warnings.iter().cloned());
    Ok((image, predicted, warnings))
}

/// Brings an image whose `worldToNDC` camera sees the mirror image of ours (pbrt-v4's left-handed
/// LookAt) to our image axes by mirroring its columns, as `analyze` does
/// ([`analysis::projection::camera_of_matrices`]), so that a pbrt image compares pixel for pixel
/// with ours. Returns the note to print: the mirroring, or why the matrices were not used (a
/// perspective or skewed `worldToNDC` says nothing `compare` can use about the axes, and the images
/// are compared as they are).
pub fn to_our_image_axes(img: &mut Image) -> Option<String> {
    match analysis::projection::camera_of_matrices(img) {
        Ok(Some(m)) if m.mirrored => {
            analysis::projection::mirror_columns(img);
            Some(
                "the worldToNDC camera sees the mirror image of ours (a left-handed camera, as pbrt-v4's LookAt builds); columns mirrored before comparing"
                    .to_string(),
            )
        }
        Ok(_) => None,
        Err(e) => Some(format!("worldToNDC not used to check the image axes ({e}); compared as stored")),
    }
}

/// A [`CompareError`] as the CLI's one-line error, naming the file it is about.
fn error_of(e: CompareError, paths: &[PathBuf]) -> Error {
    let mut msg = e.to_string();
    for (i, p) in paths.iter().enumerate() {
        msg = msg.replace(&format!("input {i}"), &p.display().to_string());
    }
    let msg = msg
        .replace("exclude_edges = 3", "--exclude-edges 3")
        .replace("exclude_edges", "--exclude-edges")
        .replace("object_only", "--object-only")
        .replace("alpha must", "--alpha must")
        .replace("block must", "--block must");
    match e.input().and_then(|i| paths.get(i)) {
        Some(p) => Error::file(p, msg),
        None => Error::new(msg),
    }
}

fn print_text(r: &CompareReport, paths: &[String]) {
    let verdict = match r.verdict {
        Verdict::Agree => "AGREE",
        Verdict::Disagree => "DISAGREE",
    };
    println!("{verdict}: {}", r.reason);
    println!("A: {} — {}", paths[0], r.a.noise);
    println!(
        "B: {}{} — {}",
        paths[1],
        if r.b.images > 1 { format!(" and {} more seeds", r.b.images - 1) } else { String::new() },
        r.b.noise
    );
    let p = &r.pixels;
    println!(
        "pixels: {} compared of {}×{} ({} flagged, {} without estimate, {} near the silhouette and {} of background left out); {} pixel-channels with zero error on both sides",
        p.compared, r.width, r.height, p.flagged, p.no_estimate, p.near_edges, p.background, p.exact
    );
    println!("tests (each at level {:.3e}, family-wise false-alarm rate α = {}):", r.alpha_per_test, r.alpha);
    for t in &r.tests {
        let stat = if t.name.starts_with("scale") {
            format!("z = {:+.2}", t.statistic)
        } else {
            format!("χ²/ν = {:.4}", t.statistic)
        };
        let dof = t.dof.map_or("∞".to_string(), |d| format!("{d:.0}"));
        println!(
            "  {:<8} {stat:<16} ν = {dof:<8} p = {:.3e}{}",
            t.name,
            t.p,
            if t.rejected { "  REJECTED" } else { "" }
        );
    }
    for s in &r.scale {
        println!("scale A/B {}: {:.5} ± {:.5}", s.channel, s.ratio, s.stderr);
    }
    println!(
        "blocks {}×{}: {} blocks, χ²/ν = {:.3} (scale divided out: {:.3}), max |z| = {:.2}",
        r.blocks.size,
        r.blocks.size,
        r.blocks.count,
        r.blocks.chi2_nu,
        r.blocks.chi2_nu_scale_removed,
        r.blocks.max_abs_z
    );
    println!(
        "pixel z: max |z| = {:.2} at row {}, column {}; {} beyond the family's k = {:.2}",
        p.max_abs_z, p.max_row, p.max_column, p.beyond_k_family, p.k_family
    );
    if let Some(e) = &r.edges {
        println!(
            "within 2 px of the silhouette: {} pixels, χ²/ν = {:.3} (elsewhere {:.3})",
            e.pixels, e.chi2_nu, e.interior_chi2_nu
        );
    }
}

/// A diverging colour (colorous' RdBu: red for t = 0, blue for t = 1) for v in [−1, 1], red where
/// A is above B; grey for NaN (not compared).
fn diverging(v: f32) -> [u8; 3] {
    if !v.is_finite() {
        return [128, 128, 128];
    }
    let c = colorous::RED_BLUE.eval_continuous(0.5 - 0.5 * f64::from(v.clamp(-1.0, 1.0)));
    [c.r, c.g, c.b]
}

fn stage_png(path: &Path, w: usize, h: usize, px: Vec<u8>) -> Result<renderer::output::Staged, Error> {
    let img = image::RgbImage::from_raw(w as u32, h as u32, px).ok_or_else(|| Error::file(path, "bad image size"))?;
    renderer::output::stage(path, |tmp| {
        img.save_with_format(tmp, image::ImageFormat::Png).map_err(|e| format!("cannot write PNG: {e}"))
    })
}

/// The histogram of the pixel scores u (grey bars) against N(0, 1) (red line), counts on a log scale.
fn histogram_png(r: &CompareReport) -> (usize, usize, Vec<u8>) {
    let (w, h, bar) = (480usize, 240usize, 10usize);
    let mut px = vec![255u8; w * h * 3];
    let hist = &r.histogram;
    let top = hist.counts.iter().map(|&c| c as f64).chain(hist.expected.iter().copied()).fold(1.0f64, f64::max);
    let y_of = |v: f64| -> usize { h - 1 - (((1.0 + v).log10() / (1.0 + top).log10()) * (h as f64 - 10.0)) as usize };
    let put = |x: usize, y: usize, c: [u8; 3], px: &mut Vec<u8>| {
        if x < w && y < h {
            px[(y * w + x) * 3..][..3].copy_from_slice(&c);
        }
    };
    for (i, &c) in hist.counts.iter().enumerate() {
        let y0 = y_of(c as f64);
        for x in i * bar..i * bar + bar - 1 {
            for y in y0..h {
                put(x, y, [150, 150, 150], &mut px);
            }
        }
    }
    // The line of N(0, 1)'s counts through the bin centres, and the axis at z = 0.
    for i in 0..hist.expected.len().saturating_sub(1) {
        let (x0, x1) = (i * bar + bar / 2, (i + 1) * bar + bar / 2);
        let (y0, y1) = (y_of(hist.expected[i]) as f64, y_of(hist.expected[i + 1]) as f64);
        for x in x0..=x1 {
            let y = y0 + (y1 - y0) * (x - x0) as f64 / (x1 - x0) as f64;
            put(x, y as usize, [200, 0, 0], &mut px);
            put(x, y as usize + 1, [200, 0, 0], &mut px);
        }
    }
    for y in 0..h {
        put(w / 2, y, [0, 0, 0], &mut px);
    }
    (w, h, px)
}

fn stage_report(dir: &Path, r: &CompareReport, paths: &[String]) -> Result<Vec<renderer::output::Staged>, Error> {
    let (w, h) = (r.width, r.height);
    let z: Vec<u8> = r.z_map.iter().flat_map(|&v| diverging(v / 5.0)).collect();
    let ratio: Vec<u8> = r.ratio_map.iter().flat_map(|&v| diverging(v.ln() / 0.1)).collect();
    let (hw, hh, hist) = histogram_png(r);
    let mut staged = vec![
        stage_png(&dir.join("z.png"), w, h, z)?,
        stage_png(&dir.join("ratio.png"), w, h, ratio)?,
        stage_png(&dir.join("histogram.png"), hw, hh, hist)?,
    ];
    let esc = |s: &str| s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;");
    let mut rows = String::new();
    for t in &r.tests {
        rows.push_str(&format!(
            "<tr><td>{}</td><td>{:.4}</td><td>{}</td><td>{:.3e}</td><td>{}</td></tr>\n",
            t.name,
            t.statistic,
            t.dof.map_or("∞".into(), |d| format!("{d:.0}")),
            t.p,
            if t.rejected { "<b>rejected</b>" } else { "passed" }
        ));
    }
    let verdict = if r.verdict == Verdict::Agree { "agree" } else { "disagree" };
    let html = format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>reflect compare: {verdict}</title>\n<style>body{{font-family:sans-serif;max-width:60em}} img.map{{width:256px;image-rendering:pixelated}} td,th{{padding:0 .6em}}</style></head><body>\n<h1>The images {verdict}</h1>\n<p>{}</p>\n<p>A: {} ({})<br>B: {} ({} image{}, {})</p>\n<table><tr><th>test</th><th>z or χ²/ν</th><th>ν</th><th>p</th><th>at level {:.3e}</th></tr>\n{rows}</table>\n<p>Family-wise false-alarm rate α = {} (Šidák over {} tests).</p>\n<figure><img class=\"map\" src=\"z.png\"><figcaption>z of R + G + B per pixel, blue −5 … red +5 (A above B); grey: not compared.</figcaption></figure>\n<figure><img class=\"map\" src=\"ratio.png\"><figcaption>A / B (R + G + B) per pixel, blue 0.905 … red 1.105 (log scale).</figcaption></figure>\n<figure><img src=\"histogram.png\"><figcaption>Pixel scores u (each channel's z turned into the N(0, 1) value of the same tail probability under its Student t, so that agreeing images give N(0, 1); bins of 0.25 over −6 … 6, log counts) against N(0, 1) (red); black: u = 0. Beyond the range: {} below, {} above.</figcaption></figure>\n</body></html>\n",
        esc(&r.reason),
        esc(&paths[0]),
        esc(&r.a.noise),
        esc(&paths[1]),
        r.b.images,
        if r.b.images == 1 { "" } else { "s" },
        esc(&r.b.noise),
        r.alpha_per_test,
        r.alpha,
        r.tests.len(),
        r.histogram.below,
        r.histogram.above,
    );
    let index = dir.join("index.html");
    staged.push(renderer::output::stage(&index, |tmp| {
        std::fs::write(tmp, html).map_err(|e| format!("cannot write: {e}"))
    })?);
    Ok(staged)
}
