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
                if !layers.iter().any(|x| x == l) {
                    return Err(Error::new(format!(
                        "--layer {l}: no radiance layer of that name (radiance layers: {})",
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
                    "{} radiance layers ({}): choose one with --layer",
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

/// Reads an `.exr` or `.hdr` file (chosen by its first bytes, not its name) with all its channels.
pub fn read_image(path: impl AsRef<Path>) -> Result<Image> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| Error::file(path, format!("cannot read file: {e}")))?;
    let img = if bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        read_exr_bytes(&bytes).map(|(img, note)| {
            if let Some(n) = note {
                // Human text goes to stderr (docs/src/conventions.md §7): the user learns which part lit the scene.
                eprintln!("note: {}: {n}", path.display());
            }
            img
        })
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
    Ok(img)
}

/// Reads the RGB radiance of an `.exr` or `.hdr` file (see [`read_image`]).
pub fn read_rgb(path: impl AsRef<Path>) -> Result<RgbImage> {
    let path = path.as_ref();
    let img = read_image(path)?;
    img.rgb().ok_or_else(|| Error::file(path, "image has no R, G, B (or Y) channels"))
}

/// Reads a Radiance RGBE picture (the `.hdr` / `.pic` format of Ward's Radiance, as written by
/// `ra_*`, Photoshop, HDR Shop, …):
///
/// - header lines up to a blank line: `FORMAT=32-bit_rle_rgbe` (the XYZ variant is refused),
///   `EXPOSURE=e` and `COLORCORR=r g b` (each may appear many times: a stored value was multiplied
///   by all of them, so radiance = stored ÷ the product of every EXPOSURE and every COLORCORR, per
///   channel), other variables and comments ignored;
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
pub(crate) fn read_hdr_bytes(bytes: &[u8]) -> Result<Image> {
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
    Ok(Image { width: w, height: h, channels, attributes: BTreeMap::new(), matrices: BTreeMap::new() })
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

/// Decoded sample bytes (4 per sample) a file of `n` bytes may claim: deflate (ZIP/PXR24)
/// compresses at most ~1032:1 and OpenEXR's RLE 64:1, so 2048 × the file (with a 1 MiB floor for
/// tiny files) admits real images and refuses a small file that claims a huge one before its
/// pixels are allocated.
pub const EXR_MAX_EXPANSION: usize = 2048;

fn exr_decoded_limit(file_bytes: usize) -> u128 {
    (file_bytes as u128 * EXR_MAX_EXPANSION as u128).max(1 << 20)
}

/// Reads an OpenEXR file: scanline or tiled, any compression, half/float/uint samples, the full
/// resolution of a mip- or rip-mapped file.
///
/// - The **display window is the image** (OpenEXR's definition): pixels of the display window that
///   lie outside the data window are 0, data-window pixels outside the display window are dropped.
/// - A **multi-part** file: the part used is the first with R, G, B (or Y) channels; the returned
///   note says which (the caller prints it). If no part has them, the error names each part's channels.
/// - Sizes are checked from the headers before any pixel is decoded ([`MAX_IMAGE_SIDE`] per side,
///   and at most [`exr_decoded_limit`] decoded bytes for the whole file). Deep parts are refused.
pub(crate) fn read_exr_bytes(bytes: &[u8]) -> Result<(Image, Option<String>)> {
    use exr::prelude::{AttributeValue, FlatSamples, ReadChannels, ReadLayers};
    let corrupt = |e: exr::error::Error| Error::new(format!("corrupt OpenEXR file: {e}"));
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false).map_err(corrupt)?;
    let part_name = |i: usize| match &meta.headers[i].own_attributes.layer_name {
        Some(n) => format!("part {i} ('{n}')"),
        None => format!("part {i}"),
    };
    let has = |i: usize, c: &str| meta.headers[i].channels.list.iter().any(|d| d.name.to_string() == c);
    let has_rgb = |i: usize| (has(i, "R") && has(i, "G") && has(i, "B")) || has(i, "Y");
    let mut decoded = 0u128;
    for (i, hd) in meta.headers.iter().enumerate() {
        if hd.deep {
            return Err(Error::new(format!("{} holds deep data, which is not supported", part_name(i))));
        }
        let (w, h) = (hd.layer_size.x(), hd.layer_size.y());
        check_size(w, h).map_err(|e| Error::new(format!("{}: data window: {e}", part_name(i))))?;
        for c in &hd.channels.list {
            if c.sampling.x() != 1 || c.sampling.y() != 1 {
                return Err(Error::new(format!(
                    "{}: channel {} is subsampled ({}×{}), which is not supported",
                    part_name(i),
                    c.name,
                    c.sampling.x(),
                    c.sampling.y()
                )));
            }
            decoded += (w * h) as u128 * 4;
        }
    }
    let display =
        meta.headers.first().ok_or_else(|| Error::new("OpenEXR file has no parts"))?.shared_attributes.display_window;
    let (dw, dh) = (display.size.x(), display.size.y());
    check_size(dw, dh).map_err(|e| Error::new(format!("display window: {e}")))?;
    decoded += (dw * dh) as u128 * 4 * 3;
    if decoded > exr_decoded_limit(bytes.len()) {
        return Err(Error::new(format!(
            "the headers claim {decoded} bytes of samples, more than a {}-byte file can hold",
            bytes.len()
        )));
    }
    let chosen = match (0..meta.headers.len()).find(|&i| has_rgb(i)) {
        Some(i) => i,
        None if meta.headers.len() == 1 => 0,
        None => {
            let parts: Vec<String> = (0..meta.headers.len())
                .map(|i| {
                    let names: Vec<String> = meta.headers[i].channels.list.iter().map(|c| c.name.to_string()).collect();
                    format!("{} has {}", part_name(i), names.join(", "))
                })
                .collect();
            return Err(Error::new(format!("no part has R, G, B (or Y) channels: {}", parts.join("; "))));
        }
    };
    let note = (meta.headers.len() > 1).then(|| {
        format!(
            "multi-part OpenEXR: using {} of {}, the first with R, G, B (or Y)",
            part_name(chosen),
            meta.headers.len()
        )
    });
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
    let layer = layers
        .into_layers()
        .into_iter()
        .nth(chosen)
        .ok_or_else(|| Error::new(format!("{} could not be read", part_name(chosen))))?;
    let (lw, lh) = (layer.size.width(), layer.size.height());
    // Offset of the data window in the display window (both in absolute pixel coordinates).
    let ox = layer.attributes.layer_position.x() as i64 - display.position.x() as i64;
    let oy = layer.attributes.layer_position.y() as i64 - display.position.y() as i64;
    let same_window = ox == 0 && oy == 0 && lw == dw && lh == dh;
    let mut channels = BTreeMap::new();
    for ch in layer.channel_data.list {
        if ch.sample_data.len() != lw * lh {
            return Err(Error::new(format!(
                "channel {} has {} samples for a {lw}×{lh} data window",
                ch.name,
                ch.sample_data.len()
            )));
        }
        let name = ch.name.to_string();
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
        channels.insert(name, data);
    }
    let (mut attributes, mut matrices) = (BTreeMap::new(), BTreeMap::new());
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
    Ok((Image { width: dw, height: dh, channels, attributes, matrices }, note))
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
/// (for tests, tools and the renderer's conventions of §5; attribute text must be ASCII/Latin-1).
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
