//! Reading images: OpenEXR (any channels, half or float, plus the string attributes of its header)
//! and Radiance RGBE `.hdr`. Used for environment maps (docs/src/conventions.md §2) and for renders to analyse
//! (docs/src/conventions.md §5). Every failure becomes an [`Error`] naming the file.
//!
//! NaN or infinite values are rejected here, once, so no analysis or light ever sees them; the one
//! exception is +inf in an error layer (`stderr.*`, `stderr_own.*`): a pixel with no error estimate
//! (fewer than two samples), which [`Image::stderr_layer`] turns into no layer.

use crate::error::{Error, Result};
use std::collections::BTreeMap;
use std::path::Path;

/// A float image with named channels (`R`, `G`, `B`, `normal.X`, `stderr.R`, …), row 0 at the top.
#[derive(Clone, Debug, Default)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    /// Row-major samples of each channel, `width * height` long.
    pub channels: BTreeMap<String, Vec<f32>>,
    /// String attributes of the EXR header (e.g. `reflect:camera`, a JSON object written by the renderer).
    pub attributes: BTreeMap<String, String>,
    /// 4 × 4 float matrix attributes (m44f) of the EXR header, 16 numbers in the file's order (row
    /// by row): e.g. `worldToCamera` and `worldToNDC`, which pbrt-v4 writes.
    pub matrices: BTreeMap<String, [f32; 16]>,
}

/// An RGB float image, row 0 at the top.
#[derive(Clone, Debug, Default)]
pub struct RgbImage {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<[f32; 3]>,
}

impl RgbImage {
    /// For a `stderr` layer (already checked by [`Image::stderr_layer`]) about to weight a fit in
    /// `channels`: a channel that is zero at every pixel is an error naming the layer and the
    /// cause (see [`Image::stderr_layer_for_weights`]).
    pub fn check_weights(&self, channels: &[usize]) -> Result<()> {
        for &ch in channels {
            if self.pixels.iter().all(|p| p[ch] == 0.0) {
                return Err(Error::new(format!(
                    "layer stderr.{} is zero at every pixel: a noise-free image gives no weights (the covariance of the fit is singular); remove the stderr layers to fit with unit weights",
                    ["R", "G", "B"][ch.min(2)]
                )));
            }
        }
        Ok(())
    }

    #[inline]
    pub fn get(&self, row: usize, col: usize) -> [f32; 3] {
        self.pixels[row * self.width + col]
    }
}

impl Image {
    pub fn channel(&self, name: &str) -> Option<&[f32]> {
        self.channels.get(name).map(|v| v.as_slice())
    }

    /// The three channels `{prefix}R/G/B` (prefix "" for the main image, "stderr." for the error layer).
    pub fn rgb_layer(&self, prefix: &str) -> Option<RgbImage> {
        let r = self.channel(&format!("{prefix}R"))?;
        let g = self.channel(&format!("{prefix}G"))?;
        let b = self.channel(&format!("{prefix}B"))?;
        Some(RgbImage {
            width: self.width,
            height: self.height,
            pixels: (0..r.len()).map(|i| [r[i], g[i], b[i]]).collect(),
        })
    }

    /// The per-pixel standard-error layer `stderr.R/G/B` (docs/src/conventions.md §5), validated once for every
    /// consumer: each value is a standard deviation, so it must be finite and ≥ 0 (a negative one
    /// would be squared into a valid-looking variance) — an error naming the layer (callers add the
    /// file). 0 is allowed here: it is an exact pixel (a deterministic render, e.g. a pixel-centre
    /// `normal-probe` under a directional source, has σ = 0 everywhere), and propagated errors are
    /// then 0. Consumers that *weight* by 1/σ² or invert a covariance built from σ use
    /// [`Image::stderr_layer_for_weights`]. `Ok(None)` when the image has no such layer, and when
    /// the layer holds +inf anywhere: a pixel of fewer than two samples has no error estimate (a
    /// render at 1 spp writes +inf), and such a layer is no error bar, so consumers take σ from the
    /// residuals as for an image without the layer (and say so).
    pub fn stderr_layer(&self) -> Result<Option<RgbImage>> {
        let Some(layer) = self.rgb_layer("stderr.") else { return Ok(None) };
        if layer.pixels.iter().flatten().any(|v| *v == f32::INFINITY) {
            return Ok(None);
        }
        for (ch, name) in ["R", "G", "B"].iter().enumerate() {
            if let Some(i) = layer.pixels.iter().position(|p| !(p[ch].is_finite() && p[ch] >= 0.0)) {
                return Err(Error::new(format!(
                    "layer stderr.{name} has the value {} at row {}, column {}: a standard error must be finite and ≥ 0",
                    layer.pixels[i][ch],
                    i / self.width.max(1),
                    i % self.width.max(1)
                )));
            }
        }
        Ok(Some(layer))
    }

    /// [`Image::stderr_layer`] for a consumer that weights by it (a covariance it inverts, weights
    /// 1/σ²): a channel that is zero at every pixel carries no noise estimate, every covariance
    /// built from it is singular, so it is an error naming the layer and the cause.
    pub fn stderr_layer_for_weights(&self) -> Result<Option<RgbImage>> {
        let Some(layer) = self.stderr_layer()? else { return Ok(None) };
        layer.check_weights(&[0, 1, 2])?;
        Ok(Some(layer))
    }

    /// The main RGB image; a luminance-only (`Y`) EXR is replicated to grey.
    pub fn rgb(&self) -> Option<RgbImage> {
        self.rgb_layer("").or_else(|| {
            let y = self.channel("Y")?;
            Some(RgbImage { width: self.width, height: self.height, pixels: y.iter().map(|&v| [v, v, v]).collect() })
        })
    }
}

/// Layer names (the last component of a channel prefix, case-insensitive) that hold something other
/// than radiance: auxiliary outputs (AOVs) of our renderer, Blender, Mitsuba and pbrt. Their RGB
/// channels are never taken as the image.
pub const NON_RADIANCE: &[&str] = &[
    "normal",
    "normals",
    "n",
    "nn",
    "sh_normal",
    "geo_normal",
    "stderr",
    "variance",
    "mask",
    "albedo",
    "diffcol",
    "glosscol",
    "transcol",
    "denoising albedo",
    "denoising normal",
    "position",
    "p",
    "depth",
    "dd",
    "uv",
];

/// The radiance layers of `img`: channel prefixes (`""` for plain `R, G, B`; `ViewLayer.Combined`
/// for `ViewLayer.Combined.R`) with R, G and B (or Y) channels, not named as an auxiliary output
/// ([`NON_RADIANCE`]).
pub fn radiance_layers(img: &Image) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for name in img.channels.keys() {
        let (prefix, last) = match name.rsplit_once('.') {
            Some((p, l)) => (p, l),
            None => ("", name.as_str()),
        };
        let layer = prefix.rsplit('.').next().unwrap_or("").to_ascii_lowercase();
        if !prefix.is_empty() && NON_RADIANCE.contains(&layer.as_str()) {
            continue;
        }
        let dot = if prefix.is_empty() { String::new() } else { format!("{prefix}.") };
        let has = |c: &str| img.channels.contains_key(&format!("{dot}{c}"));
        let rgb = (last == "R" || last == "G" || last == "B") && has("R") && has("G") && has("B");
        if (rgb || last == "Y") && !out.iter().any(|p| p == prefix) {
            out.push(prefix.to_string());
        }
    }
    out
}

impl Image {
    /// The image with the radiance layer `layer` (a channel prefix such as `ViewLayer.Combined`; `None`:
    /// the only radiance layer, plain `R, G, B` / `Y` first) moved to the plain channels `R, G, B` (or
    /// `Y`), as every analysis reads them. Other layers stay as they are (our `normal.*`, `stderr.*`,
    /// `mask.Y` are read by name; another renderer's auxiliary outputs are not), and an alpha channel
    /// is ignored. Returns a one-line note naming the layer taken and the layers ignored, when the
    /// image is not in our own layout.
    ///
    /// Errors: `layer` names no radiance layer, or several radiance layers and no `layer` (the message
    /// lists them, for `--layer`).
    pub fn select_layer(mut self, layer: Option<&str>) -> Result<(Image, Option<String>)> {
        let layers = radiance_layers(&self);
        let list = || {
            layers
                .iter()
                .map(|l| if l.is_empty() { "(none: R, G, B)".to_string() } else { format!("'{l}'") })
                .collect::<Vec<_>>()
                .join(", ")
        };
        let chosen = match layer {
            Some(l) => {
                let l = l.trim_end_matches('.');
                // The beauty part of a multi-part file gives the plain channels: its usual names
                // (`rgba`, `beauty`, …) choose them.
                let beauty_alias = BEAUTY_PART_NAMES.contains(&l.to_ascii_lowercase().as_str());
                let l = if beauty_alias && !layers.iter().any(|x| x == l) && layers.iter().any(|x| x.is_empty()) {
                    ""
                } else {
                    l
                };
                if !layers.iter().any(|x| x == l) {
                    return Err(Error::new(format!(
                        "layer '{l}': no radiance layer or part of that name (radiance layers: {})",
                        list()
                    )));
                }
                l.to_string()
            }
            None if layers.iter().any(|x| x.is_empty()) => String::new(),
            None if layers.len() == 1 => layers[0].clone(),
            None if layers.is_empty() => return Ok((self, None)),
            None => {
                return Err(Error::new(format!(
                    "{} radiance layers ({}): choose one with --layer (a scene's envmap lighting: layer = \"...\")",
                    layers.len(),
                    list()
                )));
            }
        };
        if chosen.is_empty() {
            return Ok((self, None));
        }
        let dot = format!("{chosen}.");
        for c in ["R", "G", "B", "Y"] {
            if let Some(v) = self.channels.remove(&format!("{dot}{c}")) {
                self.channels.insert(c.to_string(), v);
            }
        }
        let mut ignored: Vec<String> = Vec::new();
        for name in self.channels.keys() {
            // The chosen layer's own other channels (its alpha) are part of it, not an ignored layer.
            if name.len() == 1
                || name.starts_with(&dot)
                || name.starts_with("normal.")
                || name.starts_with("stderr.")
                || name == "mask.Y"
            {
                continue;
            }
            let p = name.rsplit_once('.').map_or(name.as_str(), |(p, _)| p).to_string();
            if !ignored.contains(&p) {
                ignored.push(p);
            }
        }
        let note = if ignored.is_empty() {
            format!("radiance from layer '{chosen}'")
        } else {
            format!("radiance from layer '{chosen}'; ignored (not radiance, or not chosen): {}", ignored.join(", "))
        };
        Ok((self, Some(note)))
    }
}

/// Reads an `.exr` or `.hdr` file (chosen by its first bytes, not its name) with all its channels;
/// its notes (the part taken, a colour conversion) go to stderr.
pub fn read_image(path: impl AsRef<Path>) -> Result<Image> {
    let path = path.as_ref();
    let (img, notes) = read_image_notes(path)?;
    print_notes(path, &notes);
    Ok(img)
}

fn print_notes(path: &Path, notes: &[String]) {
    // Human text goes to stderr (docs/src/conventions.md §7): the user learns which part lit the scene and
    // what was done to its colours.
    for n in notes {
        eprintln!("note: {}: {n}", path.display());
    }
}

/// [`read_image`] with its notes returned rather than printed (without the `note: FILE: ` prefix),
/// so that a caller that may still refuse the file prints nothing but its error.
pub fn read_image_notes(path: impl AsRef<Path>) -> Result<(Image, Vec<String>)> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| Error::file(path, format!("cannot read file: {e}")))?;
    let (img, notes) = if bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        read_exr_bytes(&bytes)
    } else if bytes.starts_with(b"#?") {
        read_hdr_bytes(&bytes)
    } else {
        Err(Error::new("not an OpenEXR or Radiance .hdr file (unrecognised header)"))
    }
    .map_err(|e| e.in_file(path))?;
    if img.width == 0 || img.height == 0 {
        return Err(Error::file(path, "image has no pixels"));
    }
    for (name, data) in &img.channels {
        let unknown_allowed = name.starts_with("stderr.") || name.starts_with("stderr_own.");
        if let Some(i) = data.iter().position(|v| !(v.is_finite() || (unknown_allowed && *v == f32::INFINITY))) {
            return Err(Error::file(
                path,
                format!(
                    "channel {name} has a non-finite value ({}) at row {}, column {}",
                    data[i],
                    i / img.width,
                    i % img.width
                ),
            ));
        }
    }
    Ok((img, notes))
}

/// Reads the RGB radiance of an `.exr` or `.hdr` file (see [`read_image`]): its beauty, or the only
/// radiance layer ([`read_rgb_layer`] with no layer).
pub fn read_rgb(path: impl AsRef<Path>) -> Result<RgbImage> {
    read_rgb_layer(path, None)
}

/// Reads the RGB radiance of the layer `layer` of an `.exr` or `.hdr` file: a channel prefix
/// (`ViewLayer.Combined`) or the name of a part of a multi-part file (each part is a layer, guide
/// "Bad input"); `None` takes the plain `R, G, B` (or `Y`), else the only radiance layer
/// ([`Image::select_layer`], whose note goes to stderr).
pub fn read_rgb_layer(path: impl AsRef<Path>, layer: Option<&str>) -> Result<RgbImage> {
    let path = path.as_ref();
    let (img, mut notes) = read_image_notes(path)?;
    let (img, note) = img.select_layer(layer).map_err(|e| e.in_file(path))?;
    let rgb = img.rgb().ok_or_else(|| Error::file(path, "image has no R, G, B (or Y) channels"))?;
    notes.extend(note);
    print_notes(path, &notes);
    Ok(rgb)
}

/// Reads a Radiance RGBE picture (the `.hdr` / `.pic` format of Ward's Radiance, as written by
/// `ra_*`, Photoshop, HDR Shop, …):
///
/// - header lines up to a blank line: `FORMAT=32-bit_rle_rgbe` (the XYZ variant is refused),
///   `EXPOSURE=e` and `COLORCORR=r g b` (each may appear many times: a stored value was multiplied
///   by all of them, so radiance = stored ÷ the product of every EXPOSURE and every COLORCORR, per
///   channel), `PRIMARIES=rx ry gx gy bx by wx wy` (pixels converted to the working colour space,
///   [`crate::colour`], unless they are Rec. 709; without the line the pixels are taken as Rec. 709,
///   as every HDR tool writes them), other variables and comments ignored;
/// - the resolution string in any of its eight orientations (`-Y H +X W` is the usual top-down,
///   left-to-right one; `+Y`/`-X` flip, `±X W ±Y H` stores columns), turned into row 0 at the top;
/// - scanlines flat, in the old repeat-pixel run-length encoding, or in the adaptive per-channel
///   encoding (`2 2 hi lo`).
///
/// A pixel is m · 2^(e − 136) (m the mantissa byte; e = 0 is black), as the `image` crate and most
/// readers decode it. Before any pixel memory is allocated the claimed size is checked against the
/// bytes that follow the header: the most compact encoding (the adaptive run-length one) needs
/// at least 12 bytes per scanline (4 for W = 1, 8 for W ≤ 256; see below), so a short file claiming
/// a huge image is refused at once, and the pixels are allocated only once a first scanline decoded.
pub(crate) fn read_hdr_bytes(bytes: &[u8]) -> Result<(Image, Vec<String>)> {
    let bad = |m: String| Error::new(format!("corrupt Radiance .hdr: {m}"));
    let mut pos = 0usize;
    let mut line = || -> Option<&[u8]> {
        if pos >= bytes.len() {
            return None;
        }
        let end = bytes[pos..].iter().position(|&b| b == b'\n').map_or(bytes.len(), |i| pos + i);
        let l = &bytes[pos..end];
        pos = (end + 1).min(bytes.len() + 1);
        Some(l.strip_suffix(b"\r").unwrap_or(l))
    };
    let first = line().ok_or_else(|| bad("empty file".into()))?;
    if !first.starts_with(b"#?") {
        return Err(bad("no #? magic line".into()));
    }
    let mut scale = [1.0f64; 3];
    let mut primaries = None;
    let mut lines = 1usize;
    loop {
        let l = line().ok_or_else(|| bad("the header has no end (blank line)".into()))?;
        lines += 1;
        if lines > 100_000 {
            return Err(bad("header longer than 100000 lines".into()));
        }
        if l.is_empty() {
            break;
        }
        let text = String::from_utf8_lossy(l);
        let text = text.trim();
        if let Some(v) = text.strip_prefix("FORMAT=") {
            if v.trim() != "32-bit_rle_rgbe" {
                return Err(bad(format!("FORMAT={} is not supported (only 32-bit_rle_rgbe)", v.trim())));
            }
        } else if let Some(v) = text.strip_prefix("EXPOSURE=") {
            let e: f64 = v.trim().parse().map_err(|_| bad(format!("EXPOSURE={} is not a number", v.trim())))?;
            if !(e.is_finite() && e > 0.0) {
                return Err(bad(format!("EXPOSURE={e} must be finite and > 0")));
            }
            scale.iter_mut().for_each(|s| *s *= e);
        } else if let Some(v) = text.strip_prefix("COLORCORR=") {
            let c: Vec<f64> = v.split_whitespace().map(|t| t.parse().unwrap_or(f64::NAN)).collect();
            if c.len() != 3 || c.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
                return Err(bad(format!("COLORCORR={} must be three finite numbers > 0", v.trim())));
            }
            (0..3).for_each(|i| scale[i] *= c[i]);
        } else if let Some(v) = text.strip_prefix("PRIMARIES=") {
            let c: Vec<f64> = v.split_whitespace().map(|t| t.parse().unwrap_or(f64::NAN)).collect();
            if c.len() != 8 || c.iter().any(|x| !x.is_finite()) {
                return Err(bad(format!(
                    "PRIMARIES={} must be eight finite numbers (x y of red, green, blue, white)",
                    v.trim()
                )));
            }
            primaries = Some((
                v.trim().to_string(),
                crate::colour::Chromaticities {
                    red: [c[0], c[1]],
                    green: [c[2], c[3]],
                    blue: [c[4], c[5]],
                    white: [c[6], c[7]],
                },
            ));
        }
    }
    let res = line().ok_or_else(|| bad("no resolution string after the header".into()))?;
    let res_text = String::from_utf8_lossy(res).trim().to_string();
    let t: Vec<&str> = res_text.split_whitespace().collect();
    let parse_n = |s: &str| s.parse::<usize>().ok().filter(|&n| n > 0);
    let (o1, n1, o2, n2) = match t.as_slice() {
        [a, n, b, m] => match (parse_n(n), parse_n(m)) {
            (Some(n), Some(m)) => (*a, n, *b, m),
            _ => return Err(bad(format!("resolution string '{res_text}' has no valid sizes"))),
        },
        _ => return Err(bad(format!("resolution string '{res_text}' is not of the form '-Y H +X W'"))),
    };
    // (major axis is Y, sign of the major axis, sign of the minor axis).
    let (major_y, s1, s2) = match (o1, o2) {
        ("-Y", "+X") => (true, -1, 1),
        ("-Y", "-X") => (true, -1, -1),
        ("+Y", "+X") => (true, 1, 1),
        ("+Y", "-X") => (true, 1, -1),
        ("+X", "+Y") => (false, 1, 1),
        ("+X", "-Y") => (false, 1, -1),
        ("-X", "+Y") => (false, -1, 1),
        ("-X", "-Y") => (false, -1, -1),
        _ => return Err(bad(format!("unsupported resolution string '{res_text}' (orientation {o1} {o2})"))),
    };
    let (w, h) = if major_y { (n2, n1) } else { (n1, n2) };
    check_size(w, h)?;
    let (nscan, len) = (n1, n2);
    let data = &bytes[pos.min(bytes.len())..];
    // The most compact scanline any encoding allows: one pixel, then (old run-length encoding) a
    // repeat code of up to 255 and a second, shifted one of up to 255 << 8, which covers any width
    // up to MAX_IMAGE_SIDE. The adaptive encoding needs 4 + 8⌈W/127⌉ ≥ 12 bytes, flat pixels 4W.
    let per_scan: u128 = match len {
        1 => 4,
        2..=256 => 8,
        _ => 12,
    };
    if (data.len() as u128) < nscan as u128 * per_scan {
        return Err(bad(format!(
            "the header claims {w}×{h} pixels, which needs at least {} bytes of scanlines, but only {} follow",
            nscan as u128 * per_scan,
            data.len()
        )));
    }
    // Allocated once a first scanline has decoded: at most W ≤ 32768 pixels per 12 bytes of file.
    let mut rgb: Vec<[f32; 3]> = Vec::new();
    let mut scan = vec![[0u8; 4]; len];
    let mut p = 0usize;
    for i in 0..nscan {
        read_scanline(data, &mut p, &mut scan).map_err(|m| bad(format!("scanline {i}: {m}")))?;
        if i == 0 {
            rgb.resize(w * h, [0.0; 3]);
        }
        for (j, px) in scan.iter().enumerate() {
            let (row, col) = if major_y {
                (if s1 < 0 { i } else { h - 1 - i }, if s2 > 0 { j } else { w - 1 - j })
            } else {
                (if s2 < 0 { j } else { h - 1 - j }, if s1 > 0 { i } else { w - 1 - i })
            };
            let f = if px[3] == 0 { 0.0 } else { 2f64.powi(px[3] as i32 - 136) };
            rgb[row * w + col] = std::array::from_fn(|ch| (px[ch] as f64 * f / scale[ch]) as f32);
        }
    }
    let mut channels = BTreeMap::new();
    for (i, name) in ["R", "G", "B"].iter().enumerate() {
        channels.insert(name.to_string(), rgb.iter().map(|p| p[i]).collect());
    }
    drop(rgb);
    let mut notes = Vec::new();
    if let Some((line, chroma)) = primaries {
        let names = ["R".to_string()];
        let note = to_working_space(&mut channels, &names, &chroma)
            .map_err(|m| Error::new(format!("header line PRIMARIES={line}: {m}")))?;
        notes.extend(note);
    }
    Ok((Image { width: w, height: h, channels, attributes: BTreeMap::new(), matrices: BTreeMap::new() }, notes))
}

/// One scanline of `scan.len()` RGBE pixels from `data[*p..]`, in any of the three encodings.
fn read_scanline(data: &[u8], p: &mut usize, scan: &mut [[u8; 4]]) -> std::result::Result<(), String> {
    let len = scan.len();
    let take = |p: &mut usize, n: usize| -> std::result::Result<usize, String> {
        if *p + n > data.len() {
            return Err("file ends inside the pixel data".into());
        }
        *p += n;
        Ok(*p - n)
    };
    let s = take(p, 4)?;
    let head = [data[s], data[s + 1], data[s + 2], data[s + 3]];
    if (8..=0x7fff).contains(&len) && head[0] == 2 && head[1] == 2 && head[2] & 0x80 == 0 {
        let n = ((head[2] as usize) << 8) | head[3] as usize;
        if n != len {
            return Err(format!("run-length scanline of {n} pixels in an image {len} wide"));
        }
        for ch in 0..4 {
            let mut x = 0;
            while x < len {
                let c = data[take(p, 1)?] as usize;
                if c > 128 {
                    let run = c - 128;
                    if x + run > len {
                        return Err("a run overflows the scanline".into());
                    }
                    let v = data[take(p, 1)?];
                    scan[x..x + run].iter_mut().for_each(|px| px[ch] = v);
                    x += run;
                } else {
                    if c == 0 || x + c > len {
                        return Err("a literal span is empty or overflows the scanline".into());
                    }
                    let q = take(p, c)?;
                    for (px, &v) in scan[x..x + c].iter_mut().zip(&data[q..q + c]) {
                        px[ch] = v;
                    }
                    x += c;
                }
            }
        }
        return Ok(());
    }
    // Flat pixels, with the old repeat code (1, 1, 1, n): repeat the previous pixel n << shift times,
    // the shift growing by 8 for each consecutive repeat code.
    let mut x = 0usize;
    let mut shift = 0u32;
    let mut px = head;
    loop {
        if px[0] == 1 && px[1] == 1 && px[2] == 1 {
            if x == 0 {
                return Err("a repeat code at the start of a scanline".into());
            }
            let n = (px[3] as usize).checked_shl(shift).filter(|_| shift < 32).ok_or("repeat count overflows")?;
            if x + n > len {
                return Err("a repeat run overflows the scanline".into());
            }
            let prev = scan[x - 1];
            scan[x..x + n].iter_mut().for_each(|q| *q = prev);
            x += n;
            shift += 8;
        } else {
            scan[x] = px;
            x += 1;
            shift = 0;
        }
        if x >= len {
            return Ok(());
        }
        let s = take(p, 4)?;
        px = [data[s], data[s + 1], data[s + 2], data[s + 3]];
    }
}

/// The most bytes of decoded samples the headers of an OpenEXR file may claim: the decoder's
/// buffers (2 bytes per half sample, 4 per float or uint, every part's data window) plus the f32
/// copies this reader makes on the display window. This bounds memory and time whatever the
/// compression ratio (flat maps compress far beyond 1000:1) and admits an 8192 × 4096 RGBA map in
/// half or float.
pub const EXR_MAX_DECODED_BYTES: u64 = 1 << 30;

/// Compression values of the OpenEXR specification that the decoder does not implement, by the
/// byte of the `compression` attribute.
fn unsupported_compression_name(value: u8) -> Option<String> {
    match value {
        0..=9 => None,
        10 => Some("HTJ2K256 (compression 10, OpenEXR 3.4)".into()),
        11 => Some("HTJ2K32 (compression 11, OpenEXR 3.4)".into()),
        12 => Some("ZSTD (compression 12)".into()),
        v => Some(format!("unknown compression {v}")),
    }
}

/// Refuses a `compression` the decoder does not implement, naming it, from the raw header
/// attributes ([`crate::exr_order`] walks them) before the exr crate parses the header (it fails on
/// values it does not know with a message that names no method). Headers that module cannot walk are
/// left to the crate's own parser.
fn check_exr_compression(bytes: &[u8]) -> Result<()> {
    let multi_part = bytes.get(5).is_some_and(|v| v & 0x10 != 0);
    for (part, name, kind, value) in crate::exr_order::raw_attributes(bytes).unwrap_or_default() {
        if name == b"compression"
            && kind == b"compression"
            && let [v] = value
            && let Some(method) = unsupported_compression_name(*v)
        {
            let which = if multi_part { format!("part {part} uses ") } else { String::new() };
            return Err(Error::new(format!(
                "unsupported compression: {which}{method}, which this reader cannot decode (it reads none, RLE, ZIPS, ZIP, PIZ, PXR24, B44, B44A, DWAA, DWAB)"
            )));
        }
    }
    Ok(())
}

/// Bytes of decoded samples the headers of an OpenEXR file claim (see [`EXR_MAX_DECODED_BYTES`]):
/// `None` when the headers cannot be read. For tests and tools that bound a reader's memory.
pub fn exr_claimed_bytes(bytes: &[u8]) -> Option<u64> {
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false).ok()?;
    Some(claimed_bytes(&meta.headers))
}

fn claimed_bytes(headers: &[exr::meta::header::Header]) -> u64 {
    use exr::meta::attribute::SampleType;
    let Some(first) = headers.first() else { return 0 };
    let display = first.shared_attributes.display_window.size;
    let display_px = display.x() as u64 * display.y() as u64;
    let mut total = 0u64;
    for hd in headers {
        let px = hd.layer_size.x() as u64 * hd.layer_size.y() as u64;
        let same_window = hd.layer_size == display
            && hd.own_attributes.layer_position == first.shared_attributes.display_window.position;
        for c in &hd.channels.list {
            let (native, copy) = match c.sample_type {
                SampleType::F16 => (2, true),
                SampleType::F32 => (4, !same_window),
                SampleType::U32 => (4, true),
            };
            total = total.saturating_add(px.saturating_mul(native));
            if copy {
                total = total.saturating_add(display_px.saturating_mul(4));
            }
        }
    }
    total
}

/// Part names (case-insensitive) that compositors and renderers give the main image of a multi-part
/// file (Nuke's `rgba`, a `beauty` or `combined` pass). The first part so named (an unnamed part
/// too) is read as the plain `R, G, B` channels.
pub const BEAUTY_PART_NAMES: &[&str] = &["", "rgba", "rgb", "beauty", "combined", "main", "default"];

/// Reads an OpenEXR file: scanline or tiled, any compression the `exr` crate decodes, half/float/uint
/// samples, the full resolution of a mip- or rip-mapped file.
///
/// - The **display window is the image** (OpenEXR's definition): pixels of the display window that
///   lie outside the data window are 0, data-window pixels outside the display window are dropped.
/// - A **multi-part** file becomes one image with layers, as OpenEXR's single-part layer naming
///   writes them: the beauty part (the first named as in [`BEAUTY_PART_NAMES`], or unnamed) gives the
///   plain channels, every other part's channels are prefixed with its name (`diffuse.R`), unless
///   they already carry it. A layer is then chosen by [`Image::select_layer`]. The returned notes
///   say which part is the image; with no part holding R, G, B (or Y) the error names each part's channels.
/// - **Colour**: a part whose `chromaticities` differ from Rec. 709 has its radiance layers converted
///   to the working space ([`crate::colour`]), with a note; chromaticities that define no RGB space
///   are refused, naming the attribute.
/// - Sizes are checked from the headers before any pixel is decoded ([`MAX_IMAGE_SIDE`] per side,
///   and at most [`EXR_MAX_DECODED_BYTES`] decoded bytes for the whole file); a compression the
///   decoder lacks (HTJ2K, ZSTD) is refused by name. Deep parts are refused.
pub(crate) fn read_exr_bytes(bytes: &[u8]) -> Result<(Image, Vec<String>)> {
    use exr::prelude::{AttributeValue, FlatSamples, ReadChannels, ReadLayers};
    let corrupt = |e: exr::error::Error| Error::new(format!("corrupt OpenEXR file: {e}"));
    check_exr_compression(bytes)?;
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false).map_err(corrupt)?;
    let part_label = |i: usize| match &meta.headers[i].own_attributes.layer_name {
        Some(n) => format!("part {i} ('{n}')"),
        None => format!("part {i}"),
    };
    let has = |i: usize, c: &str| meta.headers[i].channels.list.iter().any(|d| d.name.to_string() == c);
    let has_rgb = |i: usize| (has(i, "R") && has(i, "G") && has(i, "B")) || has(i, "Y");
    for (i, hd) in meta.headers.iter().enumerate() {
        if hd.deep {
            return Err(Error::new(format!("{} holds deep data, which is not supported", part_label(i))));
        }
        let (w, h) = (hd.layer_size.x(), hd.layer_size.y());
        check_size(w, h).map_err(|e| Error::new(format!("{}: data window: {e}", part_label(i))))?;
        for c in &hd.channels.list {
            if c.sampling.x() != 1 || c.sampling.y() != 1 {
                return Err(Error::new(format!(
                    "{}: channel {} is subsampled ({}×{}), which is not supported",
                    part_label(i),
                    c.name,
                    c.sampling.x(),
                    c.sampling.y()
                )));
            }
        }
    }
    let display =
        meta.headers.first().ok_or_else(|| Error::new("OpenEXR file has no parts"))?.shared_attributes.display_window;
    let (dw, dh) = (display.size.x(), display.size.y());
    check_size(dw, dh).map_err(|e| Error::new(format!("display window: {e}")))?;
    let claimed = claimed_bytes(&meta.headers);
    if claimed > EXR_MAX_DECODED_BYTES {
        return Err(Error::new(format!(
            "the headers claim {claimed} bytes of decoded samples ({dw}×{dh} display window), more than the reader's limit of {EXR_MAX_DECODED_BYTES} (1 GiB)"
        )));
    }
    let parts = meta.headers.len();
    if parts > 1 && !(0..parts).any(has_rgb) {
        let list: Vec<String> = (0..parts)
            .map(|i| {
                let names: Vec<String> = meta.headers[i].channels.list.iter().map(|c| c.name.to_string()).collect();
                format!("{} has {}", part_label(i), names.join(", "))
            })
            .collect();
        return Err(Error::new(format!("no part has R, G, B (or Y) channels: {}", list.join("; "))));
    }
    // The channel prefix of each part: "" for the beauty part (the only part of a single-part file).
    let name_of =
        |i: usize| meta.headers[i].own_attributes.layer_name.as_ref().map(|n| n.to_string()).unwrap_or_default();
    let beauty = if parts == 1 {
        Some(0)
    } else {
        (0..parts).find(|&i| BEAUTY_PART_NAMES.contains(&name_of(i).to_ascii_lowercase().as_str()))
    };
    let prefixes: Vec<String> =
        (0..parts).map(|i| if Some(i) == beauty { String::new() } else { name_of(i) }).collect();
    if let Some(i) = (0..parts).find(|&i| Some(i) != beauty && prefixes[i].is_empty()) {
        return Err(Error::new(format!(
            "{} has no name, and neither does another part: parts must be named",
            part_label(i)
        )));
    }
    let mut notes = Vec::new();
    if parts > 1 {
        let others: Vec<String> =
            (0..parts).filter(|&i| Some(i) != beauty).map(|i| format!("'{}'", prefixes[i])).collect();
        notes.push(match beauty {
            Some(b) if has_rgb(b) => format!(
                "multi-part OpenEXR: {} of {parts} is the image (R, G, B); the other parts are layers {} (choose one with --layer or the lighting's layer key)",
                part_label(b),
                others.join(", ")
            ),
            _ => format!(
                "multi-part OpenEXR with no beauty part (named {}): its parts are layers {}",
                BEAUTY_PART_NAMES[1..].join(", "),
                others.join(", ")
            ),
        });
    }
    // Decoded by the exr crate's own pieces rather than its `from_buffered`, whose parallel reader
    // builds a pool of one thread per CPU whatever `--threads` says: here the blocks decompress on
    // a pool of the caller's rayon thread count (on this thread alone when that is 1).
    use exr::block::reader::{ChunksReader, ParallelBlockDecompressor};
    use exr::image::read::image::LayersReader;
    let chunks = exr::block::read(std::io::Cursor::new(bytes), false).map_err(corrupt)?;
    let image_other = chunks.headers().first().map(|h| h.shared_attributes.other.clone()).unwrap_or_default();
    let mut layers = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .create_layers_reader(chunks.headers())
        .map_err(corrupt)?;
    let chunks =
        chunks.filter_chunks(false, |meta, tile, block| layers.filter_block(meta, tile, block)).map_err(corrupt)?;
    let threads = rayon::current_num_threads();
    let sequential = |chunks: exr::block::reader::FilteredChunksReader<_>, layers: &mut _| {
        chunks.decompress_sequential(false, |meta, block| LayersReader::read_block(layers, &meta.headers, block))
    };
    if threads > 1 {
        let pool = || rayon::ThreadPoolBuilder::new().num_threads(threads).build();
        match ParallelBlockDecompressor::new_with_thread_pool(chunks, false, pool) {
            Ok(mut blocks) => {
                while let Some(block) = blocks.next() {
                    layers.read_block(&blocks.meta_data().headers, block.map_err(corrupt)?).map_err(corrupt)?;
                }
            }
            Err(chunks) => sequential(chunks, &mut layers).map_err(corrupt)?,
        }
    } else {
        sequential(chunks, &mut layers).map_err(corrupt)?;
    }
    let decoded = layers.into_layers();
    if decoded.len() != parts {
        return Err(Error::new(format!("{parts} parts in the header, {} decoded", decoded.len())));
    }
    let mut channels: BTreeMap<String, Vec<f32>> = BTreeMap::new();
    let (mut attributes, mut matrices) = (BTreeMap::new(), BTreeMap::new());
    // The beauty part last, so its attributes win over another part's of the same name.
    let mut order: Vec<usize> = (0..parts).filter(|&i| Some(i) != beauty).collect();
    order.extend(beauty);
    let mut decoded: Vec<Option<_>> = decoded.into_iter().map(Some).collect();
    for &i in &order {
        let layer = decoded[i].take().expect("each part once");
        let prefix = &prefixes[i];
        let (lw, lh) = (layer.size.width(), layer.size.height());
        // Offset of the data window in the display window (both in absolute pixel coordinates).
        let ox = layer.attributes.layer_position.x() as i64 - display.position.x() as i64;
        let oy = layer.attributes.layer_position.y() as i64 - display.position.y() as i64;
        let same_window = ox == 0 && oy == 0 && lw == dw && lh == dh;
        let mut names = Vec::new();
        for ch in layer.channel_data.list {
            if ch.sample_data.len() != lw * lh {
                return Err(Error::new(format!(
                    "channel {} has {} samples for a {lw}×{lh} data window",
                    ch.name,
                    ch.sample_data.len()
                )));
            }
            let own = ch.name.to_string();
            let name = if prefix.is_empty() || own.starts_with(&format!("{prefix}.")) {
                own
            } else {
                format!("{prefix}.{own}")
            };
            if channels.contains_key(&name) {
                return Err(Error::new(format!(
                    "{} gives the channel {name}, which another part gives too (rename a part to read it)",
                    part_label(i)
                )));
            }
            let data = match ch.sample_data {
                // The usual case: no copy.
                FlatSamples::F32(v) if same_window => v,
                samples => {
                    let get = |i: usize| -> f32 {
                        match &samples {
                            FlatSamples::F16(v) => v[i].to_f32(),
                            FlatSamples::F32(v) => v[i],
                            FlatSamples::U32(v) => v[i] as f32,
                        }
                    };
                    let mut data = vec![0.0f32; dw * dh];
                    for (r, row) in data.chunks_exact_mut(dw).enumerate() {
                        let sy = r as i64 - oy;
                        if sy < 0 || sy >= lh as i64 {
                            continue;
                        }
                        for (c, v) in row.iter_mut().enumerate() {
                            let sx = c as i64 - ox;
                            if sx >= 0 && sx < lw as i64 {
                                *v = get(sy as usize * lw + sx as usize);
                            }
                        }
                    }
                    data
                }
            };
            names.push(name.clone());
            channels.insert(name, data);
        }
        if let Some(c) = meta.headers[i].shared_attributes.chromaticities {
            let v = |p: exr::math::Vec2<f32>| [p.x() as f64, p.y() as f64];
            let chroma =
                crate::colour::Chromaticities { red: v(c.red), green: v(c.green), blue: v(c.blue), white: v(c.white) };
            let note = to_working_space(&mut channels, &names, &chroma).map_err(|m| {
                Error::new(format!("{}: attribute chromaticities ({}): {m}", part_label(i), chroma.describe()))
            })?;
            if let Some(n) = note {
                notes.push(if parts > 1 { format!("{}: {n}", part_label(i)) } else { n });
            }
        }
        let others = image_other.iter().chain(layer.attributes.other.iter());
        for (k, v) in others {
            match v {
                AttributeValue::Text(t) => {
                    attributes.insert(k.to_string(), t.to_string());
                }
                AttributeValue::Matrix4x4(m) => {
                    matrices.insert(k.to_string(), *m);
                }
                _ => {}
            }
        }
        // The standard attributes (reserved names, so the exr crate keeps them out of `other`).
        let standard = [
            ("worldToCamera", layer.attributes.world_to_camera),
            ("worldToNDC", layer.attributes.world_to_normalized_device),
        ];
        for (k, m) in standard {
            if let Some(m) = m {
                matrices.insert(k.to_string(), m);
            }
        }
    }
    Ok((Image { width: dw, height: dh, channels, attributes, matrices }, notes))
}

/// Converts the radiance layers (R, G, B triples of layers not named as auxiliary outputs,
/// [`NON_RADIANCE`]) among `names` from the primaries `chroma` to the working space. Returns the
/// note to print, `None` when `chroma` is Rec. 709 (nothing changes); an error when it defines no
/// RGB space. A luminance-only (`Y`) layer is achromatic: it needs no conversion.
fn to_working_space(
    channels: &mut BTreeMap<String, Vec<f32>>,
    names: &[String],
    chroma: &crate::colour::Chromaticities,
) -> std::result::Result<Option<String>, String> {
    let Some(m) = chroma.to_working()? else { return Ok(None) };
    let mut converted = Vec::new();
    for name in names {
        let Some(prefix) = name.strip_suffix('R') else { continue };
        let layer = prefix.trim_end_matches('.').rsplit('.').next().unwrap_or("").to_ascii_lowercase();
        if !prefix.is_empty() && (!prefix.ends_with('.') || NON_RADIANCE.contains(&layer.as_str())) {
            continue;
        }
        let (g, b) = (format!("{prefix}G"), format!("{prefix}B"));
        if !(channels.contains_key(&g) && channels.contains_key(&b)) {
            continue;
        }
        let mut r = channels.remove(name).expect("listed");
        let mut gv = channels.remove(&g).expect("checked");
        let mut bv = channels.remove(&b).expect("checked");
        crate::colour::convert_rgb(&m, &mut r, &mut gv, &mut bv);
        channels.insert(name.clone(), r);
        channels.insert(g, gv);
        channels.insert(b, bv);
        converted.push(if prefix.is_empty() { "R, G, B".to_string() } else { format!("{prefix}R/G/B") });
    }
    if converted.is_empty() {
        return Ok(None);
    }
    Ok(Some(format!(
        "chromaticities {} converted to the working colour space (linear Rec. 709 primaries, D65 white; Bradford adaptation) in {}",
        chroma.describe(),
        converted.join("; ")
    )))
}

/// Images larger than this many pixels per side are refused as absurd rather than allocated.
pub const MAX_IMAGE_SIDE: usize = 1 << 15;

fn check_size(w: usize, h: usize) -> Result<()> {
    if w == 0 || h == 0 || w > MAX_IMAGE_SIDE || h > MAX_IMAGE_SIDE {
        return Err(Error::new(format!("absurd image size {w}×{h}")));
    }
    Ok(())
}

/// Writes `img` as a 32-bit float OpenEXR with all its channels and its string attributes
/// (for tests, tools and the renderer's outputs of docs/src/conventions.md §5; attribute text must be ASCII/Latin-1).
pub fn write_exr(path: impl AsRef<Path>, img: &Image) -> Result<()> {
    use exr::prelude::{
        AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Layer, LayerAttributes, Text, WritableImage,
    };
    let path = path.as_ref();
    let mut channels: Vec<AnyChannel<FlatSamples>> = Vec::new();
    for (name, data) in &img.channels {
        if data.len() != img.width * img.height {
            return Err(Error::file(
                path,
                format!("channel {name} has {} samples, expected {}", data.len(), img.width * img.height),
            ));
        }
        let text = Text::new_or_none(name.as_str())
            .ok_or_else(|| Error::file(path, format!("channel name {name} is not representable")))?;
        channels.push(AnyChannel::new(text, FlatSamples::F32(data.clone())));
    }
    let mut attrs = LayerAttributes::default();
    for (k, v) in &img.attributes {
        let (Some(k), Some(v)) = (Text::new_or_none(k.as_str()), Text::new_or_none(v.as_str())) else {
            return Err(Error::file(path, format!("attribute {k} is not representable in OpenEXR text")));
        };
        attrs.other.insert(k, AttributeValue::Text(v));
    }
    for (k, m) in &img.matrices {
        // The standard attributes have their own fields (the exr crate refuses them as custom ones).
        match k.as_str() {
            "worldToCamera" => attrs.world_to_camera = Some(*m),
            "worldToNDC" => attrs.world_to_normalized_device = Some(*m),
            _ => {
                let k = Text::new_or_none(k.as_str())
                    .ok_or_else(|| Error::file(path, format!("attribute {k} is not representable in OpenEXR text")))?;
                attrs.other.insert(k, AttributeValue::Matrix4x4(*m));
            }
        }
    }
    let layer = Layer::new(
        (img.width, img.height),
        attrs,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels.into_iter().collect()),
    );
    // Atomic: written to a hidden temporary file next to `path`, then renamed onto it, so a failed
    // write leaves neither a partial file nor a temporary behind (and never truncates an old file).
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "out.exr".into());
    let tmp = path.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    let image = exr::prelude::Image::from_layer(layer);
    let written = crate::exr_order::write_exr_canonical(&tmp, |c| image.write().to_buffered(c))
        .map_err(|e| Error::file(path, e))
        .and_then(|()| {
            std::fs::rename(&tmp, path).map_err(|e| Error::file(path, format!("cannot move output into place: {e}")))
        });
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

/// The string attributes of an OpenEXR file's header, read without its pixels (e.g.
/// `reflect:camera`, which a render carries); empty for anything that is not OpenEXR. Errors say
/// why the header could not be read, without the file name (callers add it).
pub fn header_attributes(path: impl AsRef<Path>) -> Result<BTreeMap<String, String>> {
    use std::io::Read;
    let path = path.as_ref();
    let mut f = std::fs::File::open(path).map_err(|e| Error::new(format!("cannot read file: {e}")))?;
    let mut magic = [0u8; 4];
    if f.read_exact(&mut magic).is_err() || magic != [0x76, 0x2f, 0x31, 0x01] {
        return Ok(BTreeMap::new());
    }
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| Error::new(format!("corrupt OpenEXR header: {e}")))?;
    let mut out = BTreeMap::new();
    for h in meta.headers.iter() {
        for (k, v) in h.shared_attributes.other.iter().chain(h.own_attributes.other.iter()) {
            if let exr::prelude::AttributeValue::Text(t) = v {
                out.insert(k.to_string(), t.to_string());
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_grace_probe() {
        let p = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data/grace_probe.hdr");
        let img = read_rgb(p).expect("grace probe");
        assert_eq!((img.width, img.height), (1000, 1000));
        // Centre of the probe (world +z, up) is bright-ish and finite.
        let c = img.get(500, 500);
        assert!(c.iter().all(|v| v.is_finite() && *v >= 0.0));
    }

    /// The Grace lat-long map (PIZ-compressed blocks) decodes to the same bits on this thread alone
    /// (a 1-thread pool: the sequential branch) and on a 2-thread pool (the parallel branch, whose
    /// pool is sized by the caller's thread count).
    #[test]
    fn exr_decodes_the_same_on_one_and_two_threads() {
        let p = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data/grace_latlong.exr");
        let read = |n: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
            pool.install(|| read_image(p).expect("grace lat-long"))
        };
        let (one, two) = (read(1), read(2));
        assert_eq!((one.width, one.height), (two.width, two.height));
        assert!(one.width > 0 && !one.channels.is_empty());
        for (name, a) in &one.channels {
            let b = &two.channels[name];
            assert!(a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()), "channel {name}");
        }
    }

    #[test]
    fn corrupt_hdr_is_an_error_naming_the_file() {
        let dir = std::env::temp_dir().join(format!("reflect-img-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("bad.hdr");
        std::fs::write(&f, b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 10 +X 10\n\x01\x02").unwrap();
        let e = read_rgb(&f).unwrap_err();
        assert!(e.to_string().contains("bad.hdr"), "{e}");
        let g = dir.join("bad.exr");
        std::fs::write(&g, b"garbage").unwrap();
        assert!(read_rgb(&g).unwrap_err().to_string().contains("unrecognised"));
    }

    #[test]
    fn exr_round_trip_keeps_channels_and_attributes() {
        let dir = std::env::temp_dir().join(format!("reflect-img-rt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("rt.exr");
        let mut img = Image { width: 3, height: 2, ..Default::default() };
        for (i, n) in ["R", "G", "B", "normal.X", "stderr.R"].iter().enumerate() {
            img.channels.insert(n.to_string(), (0..6).map(|j| (i * 10 + j) as f32 * 0.5).collect());
        }
        img.attributes.insert("reflect:camera".into(), r#"{"type":"normal-probe","theta_o_deg":0}"#.into());
        write_exr(&f, &img).unwrap();
        let back = read_image(&f).unwrap();
        assert_eq!((back.width, back.height), (3, 2));
        assert_eq!(back.channels, img.channels);
        assert_eq!(back.attributes.get("reflect:camera"), img.attributes.get("reflect:camera"));
    }
}
