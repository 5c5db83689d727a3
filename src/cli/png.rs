//! `reflect png IMAGE.exr [--exposure EV] [--layer NAME] [--out FILE.png]`: a tone-mapped sRGB
//! preview of an image (never an analysis input, docs/src/conventions.md §5).
//!
//! The value v of each channel is shown as sRGB(x / (1 + x)) with x = v · 2^EV
//! (`renderer::output::tone_map`): Reinhard's curve, so bright values approach white instead of
//! clipping at 1. Without `--exposure`, EV maps the median luminance of the object's pixels
//! (`mask.Y` > 0 when the image has that channel, every pixel otherwise) to 0.18 (mid-grey);
//! the EV used is printed either way. The PNG is written to a temporary file and renamed.

use super::Error;
use super::outputs::{Files, Format};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args, Debug, Clone)]
pub struct PngArgs {
    /// Input image (OpenEXR or Radiance .hdr).
    pub image: PathBuf,
    /// Exposure in stops: values are multiplied by 2^EV before the tone curve [default: the object's median
    /// luminance → 0.18].
    #[arg(long, allow_hyphen_values = true)]
    pub exposure: Option<f64>,
    /// Layer to show: "" for the radiance (default: R, G, B, else the only radiance layer), or a prefix such
    /// as "stderr", "normal", "mask" or a part of a multi-part EXR (its R/G/B, X/Y/Z or Y channels).
    #[arg(long)]
    pub layer: Option<String>,
    /// Output PNG [default: IMAGE with the extension .png].
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// The three channels shown for `layer` ("" = the main R, G, B): `{layer}.R/G/B`, else
/// `{layer}.X/Y/Z`, else a single `{layer}.Y` (or `Y`) as grey.
fn layer_pixels(img: &analysis::image::Image, layer: &str) -> Result<Vec<[f32; 3]>, String> {
    let prefix = if layer.is_empty() { String::new() } else { format!("{layer}.") };
    let three = |names: [&str; 3]| -> Option<Vec<[f32; 3]>> {
        let ch: Vec<&[f32]> = names.iter().map(|n| img.channel(&format!("{prefix}{n}"))).collect::<Option<_>>()?;
        Some((0..img.width * img.height).map(|i| [ch[0][i], ch[1][i], ch[2][i]]).collect())
    };
    if let Some(p) = three(["R", "G", "B"]).or_else(|| three(["X", "Y", "Z"])) {
        return Ok(p);
    }
    if let Some(y) = img.channel(&format!("{prefix}Y")) {
        return Ok(y.iter().map(|&v| [v; 3]).collect());
    }
    let layers: std::collections::BTreeSet<&str> =
        img.channels.keys().map(|k| k.rsplit_once('.').map_or("\"\"", |(l, _)| l)).collect();
    Err(format!(
        "no layer {:?} (R/G/B, X/Y/Z or Y channels); the file has layers {}",
        layer,
        layers.into_iter().collect::<Vec<_>>().join(", ")
    ))
}

pub fn run(a: PngArgs) -> Result<ExitCode, Error> {
    let out = a.out.clone().unwrap_or_else(|| a.image.with_extension("png"));
    Files::new().input("the image", &a.image).output("--out", &out, Format::Png).check()?;
    if let Some(ev) = a.exposure.filter(|e| !e.is_finite() || e.abs() > 100.0) {
        return Err(Error::new(format!("--exposure must be finite and within ±100 stops, got {ev}")));
    }
    let (mut img, mut notes) = renderer::render_file::read_image_notes(&a.image)?;
    let mut layer = a.layer.clone().unwrap_or_default();
    if layer.is_empty() || analysis::image::BEAUTY_PART_NAMES.contains(&layer.to_ascii_lowercase().as_str()) {
        // The radiance: the beauty, else the only radiance layer (several: the error lists them).
        let (chosen, note) = img
            .select_layer(Some(&layer).filter(|l| !l.is_empty()).map(|l| l.as_str()))
            .map_err(|e| e.in_file(&a.image))?;
        (img, layer) = (chosen, String::new());
        notes.extend(note);
    }
    let px = layer_pixels(&img, &layer).map_err(|m| Error::file(&a.image, m))?;
    if px.iter().flatten().any(|v| !v.is_finite()) {
        // Only an error layer may hold +inf (the reader refuses it elsewhere): no estimate to show.
        return Err(Error::file(
            &a.image,
            format!(
                "layer {layer:?} is +inf (no error estimate: fewer than 2 samples per pixel); there is nothing to show"
            ),
        ));
    }
    for n in notes {
        eprintln!("note: {}: {n}", a.image.display());
    }
    let (ev, how) = match a.exposure {
        Some(ev) => (ev, "set by --exposure".to_string()),
        None => {
            let mask = img.channel("mask.Y");
            let whose = if mask.is_some() { "the object's (mask > 0)" } else { "the" };
            match renderer::output::auto_exposure(&px, mask) {
                Some(ev) => (ev, format!("automatic: {whose} median luminance → 0.18")),
                None => (0.0, format!("automatic: {whose} median luminance is 0, so none applied")),
            }
        }
    };
    let (w, h) = (u32::try_from(img.width), u32::try_from(img.height));
    let (Ok(w), Ok(h)) = (w, h) else { return Err(Error::file(&a.image, "image too large for PNG")) };
    renderer::output::write_png_rgb(&out, w, h, &px, ev)?;
    eprintln!("wrote {}: exposure {ev:+.2} EV ({how}), tone curve x/(1+x), sRGB", out.display());
    Ok(ExitCode::SUCCESS)
}
