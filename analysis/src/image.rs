//! Reading images: OpenEXR (any channels, half or float, plus the string attributes of its header)
//! and Radiance RGBE `.hdr`. Used for environment maps (CONVENTIONS §2) and for renders to analyse
//! (CONVENTIONS §5). Every failure becomes an [`Error`] naming the file.
//!
//! NaN or infinite values are rejected here, once, so no analysis or light ever sees them.

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

    /// The per-pixel standard-error layer `stderr.R/G/B` (CONVENTIONS §5), validated once for every
    /// consumer: each value is a standard deviation, so it must be finite and ≥ 0 (a negative one
    /// would be squared into a valid-looking variance) — an error naming the layer (callers add the
    /// file). 0 is allowed here: it is an exact pixel (a deterministic render, e.g. a pixel-centre
    /// `normal-probe` under a directional source, has σ = 0 everywhere), and propagated errors are
    /// then 0. Consumers that *weight* by 1/σ² or invert a covariance built from σ use
    /// [`Image::stderr_layer_for_weights`]. `Ok(None)` when the image has no such layer.
    pub fn stderr_layer(&self) -> Result<Option<RgbImage>> {
        let Some(layer) = self.rgb_layer("stderr.") else { return Ok(None) };
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

/// Reads an `.exr` or `.hdr` file (chosen by its first bytes, not its name) with all its channels.
pub fn read_image(path: impl AsRef<Path>) -> Result<Image> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| Error::file(path, format!("cannot read file: {e}")))?;
    let img = if bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
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
        if let Some(i) = data.iter().position(|v| !v.is_finite()) {
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

fn read_hdr_bytes(bytes: &[u8]) -> Result<Image> {
    use image::ImageDecoder;
    let dec = image::codecs::hdr::HdrDecoder::new(std::io::Cursor::new(bytes))
        .map_err(|e| Error::new(format!("corrupt Radiance .hdr: {e}")))?;
    let (w, h) = dec.dimensions();
    let (w, h) = (w as usize, h as usize);
    check_size(w, h)?;
    let mut buf = vec![0u8; dec.total_bytes() as usize];
    dec.read_image(&mut buf).map_err(|e| Error::new(format!("corrupt Radiance .hdr: {e}")))?;
    let floats: Vec<f32> = buf.chunks_exact(4).map(|c| f32::from_ne_bytes([c[0], c[1], c[2], c[3]])).collect();
    if floats.len() != w * h * 3 {
        return Err(Error::new("corrupt Radiance .hdr: pixel data is truncated"));
    }
    let mut channels = BTreeMap::new();
    for (i, name) in ["R", "G", "B"].iter().enumerate() {
        channels.insert(name.to_string(), floats.iter().skip(i).step_by(3).copied().collect());
    }
    Ok(Image { width: w, height: h, channels, attributes: BTreeMap::new() })
}

fn read_exr_bytes(bytes: &[u8]) -> Result<Image> {
    use exr::prelude::{AttributeValue, FlatSamples, ReadChannels, ReadLayers};
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(|e| Error::new(format!("corrupt OpenEXR file: {e}")))?;
    let layer = &image.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    check_size(w, h)?;
    let mut channels = BTreeMap::new();
    for ch in &layer.channel_data.list {
        let data: Vec<f32> = match &ch.sample_data {
            FlatSamples::F16(v) => v.iter().map(|x| x.to_f32()).collect(),
            FlatSamples::F32(v) => v.clone(),
            FlatSamples::U32(v) => v.iter().map(|&x| x as f32).collect(),
        };
        if data.len() != w * h {
            return Err(Error::new(format!("channel {} is subsampled, which is not supported", ch.name)));
        }
        channels.insert(ch.name.to_string(), data);
    }
    let mut attributes = BTreeMap::new();
    let others = image.attributes.other.iter().chain(layer.attributes.other.iter());
    for (k, v) in others {
        if let AttributeValue::Text(t) = v {
            attributes.insert(k.to_string(), t.to_string());
        }
    }
    Ok(Image { width: w, height: h, channels, attributes })
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
    let layer = Layer::new(
        (img.width, img.height),
        attrs,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels.into_iter().collect()),
    );
    exr::prelude::Image::from_layer(layer)
        .write()
        .to_file(path)
        .map_err(|e| Error::file(path, format!("cannot write OpenEXR: {e}")))
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
