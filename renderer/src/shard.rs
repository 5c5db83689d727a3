//! Partial renders on disk: shards, merges and checkpoints.
//!
//! A [`Partial`] (the statistics of the canonical dyadic blocks of a sample range, see
//! [`crate::film`]) is written as an OpenEXR file whose channels hold each f64 statistic exactly, as
//! two 32-bit unsigned channels of its IEEE-754 bits (`sJJ.KK.hi`, `sJJ.KK.lo` for block JJ, statistic
//! KK; OpenEXR has no 64-bit sample type). The header carries the usual `reflect:*` attributes of the
//! scene (so a merge writes the same header as a single render) and `reflect:partial`, a JSON object:
//! `{"version", "scene", "seed", "spp", "start", "end", "width", "height", "batch_log2", "replicates",
//! "blocks"}`
//! where `scene` is the [`scene_fingerprint`] and `blocks` the `[start, log2]` pairs of the range.

use crate::Result;
use crate::film::{Block, NSTAT, Partial, Stats, canonical_blocks};
use crate::scene::{Scene, SceneFile};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::path::Path;

/// The header attribute holding a [`PartialHeader`] as JSON.
pub const PARTIAL_ATTRIBUTE: &str = "reflect:partial";
/// 2: the replicate sums of the Sobol sampler's replicates (`replicates`, statistics 16 and on).
const VERSION: u32 = 2;

/// What a partial render file says about itself.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PartialHeader {
    pub version: u32,
    /// [`scene_fingerprint`] of the scene (without spp and seed, which are checked on their own).
    pub scene: String,
    pub seed: u64,
    pub spp: u32,
    pub start: u64,
    pub end: u64,
    pub width: u32,
    pub height: u32,
    pub batch_log2: u32,
    /// The sampler's number of replicates ([`Partial::replicates`]).
    pub replicates: u32,
    pub blocks: Vec<(u64, u32)>,
}

/// SHA-256 (hex) of the scene's canonical form (its description re-serialized as TOML, with
/// `render.spp` and `render.seed` zeroed) and of the bytes of every file it reads (every `file` key,
/// resolved like the scene builder does, relative to the scene file's folder). Two shards with the
/// same fingerprint, seed and spp render the same image.
pub fn scene_fingerprint(scene: &Scene) -> String {
    let mut d = scene.description.clone();
    d.render.spp = 0;
    d.render.seed = 0;
    let mut h = Sha256::new();
    h.update(b"reflect scene v1\n");
    h.update(toml::to_string(&d).unwrap_or_default().as_bytes());
    let base = scene.path.as_ref().and_then(|p| p.parent()).map(Path::to_path_buf).unwrap_or_default();
    for f in referenced_files(&d) {
        h.update(b"\nfile ");
        h.update(f.as_bytes());
        h.update(b"\n");
        match std::fs::read(base.join(&f)) {
            Ok(bytes) => h.update(Sha256::digest(&bytes)),
            Err(_) => h.update(b"unreadable"),
        }
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// The files a scene description reads (every `file` key: environment maps, meshes), as written
/// in it (relative to the scene file's folder).
pub fn referenced_files(d: &SceneFile) -> Vec<String> {
    let value = toml::Value::try_from(d).unwrap_or(toml::Value::Boolean(false));
    let mut files = Vec::new();
    collect_files(&value, &mut files);
    files
}

fn collect_files(v: &toml::Value, out: &mut Vec<String>) {
    match v {
        toml::Value::Table(t) => {
            for (k, v) in t {
                match v {
                    toml::Value::String(s) if k == "file" => out.push(s.clone()),
                    _ => collect_files(v, out),
                }
            }
        }
        toml::Value::Array(a) => a.iter().for_each(|v| collect_files(v, out)),
        _ => {}
    }
}

/// The header of a partial render of `scene`.
pub fn partial_header(scene: &Scene, p: &Partial) -> PartialHeader {
    PartialHeader {
        version: VERSION,
        scene: scene_fingerprint(scene),
        seed: scene.settings.seed,
        spp: p.spp,
        start: p.start,
        end: p.end,
        width: p.width,
        height: p.height,
        batch_log2: p.batch_log2,
        replicates: p.replicates,
        blocks: p.blocks.iter().map(|b| (b.start, b.log2)).collect(),
    }
}

fn channel_name(block: usize, stat: usize, hi: bool) -> String {
    format!("s{block:02}.{stat:02}.{}", if hi { "hi" } else { "lo" })
}

/// Writes a partial render atomically (temporary file, then rename), with `attributes` (the scene's
/// `reflect:*` attributes, see [`crate::output::header_attributes`]) and the [`PartialHeader`].
pub fn write_partial(path: &Path, p: &Partial, header: &PartialHeader, attributes: &[(String, String)]) -> Result<()> {
    use exr::prelude::*;
    let (w, h) = (p.width as usize, p.height as usize);
    let nb = p.blocks.len();
    let npix = w * h;
    let mut list: smallvec::SmallVec<[AnyChannel<FlatSamples>; 4]> = smallvec::SmallVec::new();
    for j in 0..nb {
        for k in 0..NSTAT {
            let bits: Vec<u64> = (0..npix).map(|px| p.stats[px * nb + j].0[k].to_bits()).collect();
            let hi = bits.iter().map(|b| (b >> 32) as u32).collect();
            let lo = bits.iter().map(|b| *b as u32).collect();
            list.push(AnyChannel::new(channel_name(j, k, true).as_str(), FlatSamples::U32(hi)));
            list.push(AnyChannel::new(channel_name(j, k, false).as_str(), FlatSamples::U32(lo)));
        }
    }
    if list.is_empty() {
        // An empty range: one channel so that the file is a valid image.
        list.push(AnyChannel::new("empty", FlatSamples::U32(vec![0; npix])));
    }
    let mut layer = Layer::new(
        (w.max(1), h.max(1)),
        LayerAttributes::default(),
        vocab::exr_order::FAST_LOSSLESS,
        AnyChannels::sort(list),
    );
    let json =
        serde_json::to_string(header).map_err(|e| crate::Error::file(path, format!("cannot encode header: {e}")))?;
    for (k, v) in attributes.iter().map(|(k, v)| (k.as_str(), v.as_str())).chain([(PARTIAL_ATTRIBUTE, json.as_str())]) {
        if let (Some(k), Some(v)) = (Text::new_or_none(k), Text::new_or_none(v)) {
            layer.attributes.other.insert(k, AttributeValue::Text(v));
        }
    }
    let image = Image::from_layer(layer);
    crate::output::stage(path, |tmp| vocab::exr_order::write_exr_canonical(tmp, |c| image.write().to_buffered(c)))?
        .commit()
}

/// A partial render read back: its statistics, header, and the other `reflect:*` attributes.
pub struct PartialFile {
    pub partial: Partial,
    pub header: PartialHeader,
    pub attributes: Vec<(String, String)>,
}

/// Reads a partial render written by [`write_partial`]; refuses (naming the file) anything else or a
/// file whose header and channels disagree.
pub fn read_partial(path: &Path) -> Result<PartialFile> {
    use exr::prelude::*;
    let bad = |m: String| crate::Error::file(path, m);
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| bad(format!("cannot read OpenEXR: {e}")))?;
    let layer = image.layer_data;
    let mut attributes = Vec::new();
    let mut header = None;
    for (k, v) in &layer.attributes.other {
        if let AttributeValue::Text(t) = v {
            let (k, v) = (k.to_string(), t.to_string());
            if k == PARTIAL_ATTRIBUTE {
                header = Some(v);
            } else if k.starts_with("reflect:") {
                attributes.push((k, v));
            }
        }
    }
    attributes.sort();
    let header = header.ok_or_else(|| bad(format!("not a partial render (no {PARTIAL_ATTRIBUTE} attribute)")))?;
    let header: PartialHeader =
        serde_json::from_str(&header).map_err(|e| bad(format!("bad {PARTIAL_ATTRIBUTE} attribute: {e}")))?;
    if header.version != VERSION {
        return Err(bad(format!("partial render version {} (this reflect reads {VERSION})", header.version)));
    }
    if header.start > header.end || header.end > header.spp as u64 || header.batch_log2 > 31 {
        return Err(bad(format!("bad sample range [{}, {}) of {} spp", header.start, header.end, header.spp)));
    }
    if header.replicates != 1 && header.replicates != crate::sampling::sampler::REPLICATES {
        return Err(bad(format!(
            "{} replicates (this reflect has 1 or {})",
            header.replicates,
            crate::sampling::sampler::REPLICATES
        )));
    }
    let blocks: Vec<Block> = header.blocks.iter().map(|&(start, log2)| Block { start, log2 }).collect();
    if blocks != canonical_blocks(header.start, header.end) {
        return Err(bad("its blocks are not the canonical blocks of its sample range".into()));
    }
    let (w, h) = (header.width as usize, header.height as usize);
    if (layer.size.width(), layer.size.height()) != (w.max(1), h.max(1)) {
        return Err(bad(format!("{}×{} pixels, header says {w}×{h}", layer.size.width(), layer.size.height())));
    }
    let npix = w * h;
    let nb = blocks.len();
    let mut stats = vec![Stats::default(); npix * nb];
    let mut found = vec![false; nb * NSTAT * 2];
    for ch in &layer.channel_data.list {
        let name = ch.name.to_string();
        let Some((j, k, hi)) = parse_channel(&name) else { continue };
        if j >= nb || k >= NSTAT {
            return Err(bad(format!("channel {name} is outside the header's {nb} blocks")));
        }
        let FlatSamples::U32(v) = &ch.sample_data else {
            return Err(bad(format!("channel {name} is not 32-bit unsigned")));
        };
        if v.len() != npix {
            return Err(bad(format!("channel {name} has {} samples for {npix} pixels", v.len())));
        }
        found[(j * NSTAT + k) * 2 + hi as usize] = true;
        for (px, &word) in v.iter().enumerate() {
            let s = &mut stats[px * nb + j].0[k];
            let bits = s.to_bits();
            let bits =
                if hi { (bits & 0xffff_ffff) | ((word as u64) << 32) } else { (bits & !0xffff_ffff) | word as u64 };
            *s = f64::from_bits(bits);
        }
    }
    if let Some(i) = found.iter().position(|f| !f) {
        return Err(bad(format!("channel {} is missing", channel_name(i / 2 / NSTAT, i / 2 % NSTAT, i % 2 == 1))));
    }
    let partial = Partial {
        width: header.width,
        height: header.height,
        spp: header.spp,
        batch_log2: header.batch_log2,
        replicates: header.replicates,
        start: header.start,
        end: header.end,
        blocks,
        stats,
    };
    Ok(PartialFile { partial, header, attributes })
}

fn parse_channel(name: &str) -> Option<(usize, usize, bool)> {
    let rest = name.strip_prefix('s')?;
    let mut it = rest.split('.');
    let j = it.next()?.parse().ok()?;
    let k = it.next()?.parse().ok()?;
    let hi = match it.next()? {
        "hi" => true,
        "lo" => false,
        _ => return None,
    };
    it.next().is_none().then_some((j, k, hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(edit: impl FnOnce(&mut crate::scene::SceneFile)) -> Scene {
        let mut f = crate::scene::SceneFile::parse(crate::scene::build::DEFAULT_SCENE).unwrap();
        edit(&mut f);
        Scene::build(f, Path::new(".")).unwrap()
    }

    #[test]
    fn partial_round_trips_bit_exactly() {
        let s = scene(|f| {
            f.render.width = 5;
            f.render.height = 3;
            f.render.spp = 13;
        });
        let opts = crate::render::RenderOptions::default();
        let (p, _) = crate::render::render_range(&s, &opts, 3, 11);
        let p = p.unwrap();
        let dir = std::env::temp_dir().join(format!("reflect-shard-{}", std::process::id()));
        let path = dir.join("part.exr");
        let header = partial_header(&s, &p);
        write_partial(&path, &p, &header, &[("reflect:x".into(), "y".into())]).unwrap();
        let back = read_partial(&path).unwrap();
        assert_eq!(back.header, header);
        assert_eq!(back.attributes, vec![("reflect:x".to_string(), "y".to_string())]);
        assert!(back.partial.stats.iter().zip(&p.stats).all(|(a, b)| a.0.map(f64::to_bits) == b.0.map(f64::to_bits)));
        assert_eq!(back.partial, p);
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn fingerprint_ignores_spp_and_seed_but_not_the_scene() {
        let a = scene(|_| {});
        let b = scene(|f| {
            f.render.spp += 1;
            f.render.seed += 1;
        });
        assert_eq!(scene_fingerprint(&a), scene_fingerprint(&b));
        let c = scene(|f| f.render.max_depth += 1);
        assert_ne!(scene_fingerprint(&a), scene_fingerprint(&c));
    }
}
