//! One byte layout for one image: OpenEXR headers with their attributes in a canonical order.
//!
//! The `exr` crate keeps custom attributes (`reflect:camera`, …) in a `HashMap` and writes them
//! in its iteration order, which is seeded anew for every map, so the same film written twice
//! gave two different files (same pixels, permuted header). Every EXR writer of the project
//! therefore encodes to memory, sorts each header's attributes by name here, and writes those
//! bytes: the same seed gives the same file, byte for byte. The chunks must be written in
//! increasing order too ([`FAST_LOSSLESS`]): with the `exr` crate's "unspecified" line order its
//! compression threads write their chunks as they finish, and the offset table differs.
//!
//! Sorting in place is safe because a permutation of the attributes keeps the header's length,
//! so the offset table that follows (absolute file positions of the chunks) stays valid. The
//! layout read is the one of the OpenEXR file-layout specification: magic number 20000630, a
//! 4-byte version field (bit 12: multi-part), then each header as a list of attributes (name and
//! type as NUL-terminated strings, a little-endian i32 size, the value) closed by a NUL byte; a
//! multi-part file closes its list of headers with one more NUL.

use std::io::Cursor;
use std::path::Path;

const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
const MULTIPART: u32 = 1 << 12;

/// One header: where its attributes start and end, and each attribute's byte span.
type HeaderSpans = (usize, usize, Vec<(usize, usize)>);

/// The byte spans of every header of the OpenEXR file in `bytes`, or `None` when the bytes are not
/// a header layout this module understands.
fn header_spans(bytes: &[u8]) -> Option<Vec<HeaderSpans>> {
    if bytes.len() < 8 || bytes[..4] != MAGIC {
        return None;
    }
    let version = u32::from_le_bytes(bytes[4..8].try_into().ok()?);
    let multipart = version & MULTIPART != 0;
    let mut headers: Vec<HeaderSpans> = Vec::new();
    let mut at = 8;
    loop {
        let start = at;
        let mut spans: Vec<(usize, usize)> = Vec::new();
        while *bytes.get(at)? != 0 {
            let name_end = at + bytes[at..].iter().position(|&b| b == 0)?;
            let type_end = name_end + 1 + bytes[name_end + 1..].iter().position(|&b| b == 0)?;
            let size_at = type_end + 1;
            let size = i32::from_le_bytes(bytes.get(size_at..size_at + 4)?.try_into().ok()?);
            let end = size_at + 4 + usize::try_from(size).ok()?;
            if end > bytes.len() {
                return None;
            }
            spans.push((at, end));
            at = end;
        }
        let header_end = at;
        at += 1; // the header's closing NUL
        if spans.is_empty() {
            // An empty header closes a multi-part file's list (a single-part file has exactly one).
            break;
        }
        headers.push((start, header_end, spans));
        if !multipart {
            break;
        }
    }
    Some(headers)
}

/// The attribute's name: the NUL-terminated string at the start of its span.
fn attribute_name(bytes: &[u8], (s, _): (usize, usize)) -> &[u8] {
    let b = &bytes[s..];
    &b[..b.iter().position(|&c| c == 0).unwrap_or(0)]
}

/// One raw header attribute: (part, name, type, value bytes).
pub(crate) type RawAttribute<'a> = (usize, &'a [u8], &'a [u8], &'a [u8]);

/// Every attribute of every header of the OpenEXR file in `bytes` as (part, name, type, value),
/// or `None` when the bytes are not a header layout this module understands (then the `exr`
/// crate's own parser has the last word).
pub(crate) fn raw_attributes(bytes: &[u8]) -> Option<Vec<RawAttribute<'_>>> {
    let headers = header_spans(bytes)?;
    let mut out = Vec::new();
    for (part, (_, _, spans)) in headers.iter().enumerate() {
        for &(s, e) in spans {
            let name = attribute_name(bytes, (s, e));
            let type_at = s + name.len() + 1;
            let kind = attribute_name(bytes, (type_at, e));
            // The value follows the type's NUL and the 4-byte size (header_spans checked the layout).
            out.push((part, name, kind, &bytes[type_at + kind.len() + 1 + 4..e]));
        }
    }
    Some(out)
}

/// Sorts the attributes of every header of the OpenEXR file in `bytes` by name (byte order), in
/// place. Returns `None`, leaving `bytes` untouched, when the bytes are not a header layout this
/// function understands (then they are written as they are: a permuted header is still a valid
/// file).
pub fn sort_header_attributes(bytes: &mut [u8]) -> Option<()> {
    // Parse every header first, so that bytes this function does not understand stay untouched.
    let headers = header_spans(bytes)?;
    for (start, end, mut spans) in headers {
        spans.sort_by(|&a, &b| attribute_name(bytes, a).cmp(attribute_name(bytes, b)));
        let sorted: Vec<u8> = spans.iter().flat_map(|&(s, e)| bytes[s..e].iter().copied()).collect();
        bytes[start..end].copy_from_slice(&sorted);
    }
    Some(())
}

/// Whether every header of the file says `lineOrder` = INCREASING_Y (value 0). With any other line
/// order the `exr` crate writes the chunks that its threads compress in the order they finish, so
/// the offset table (and the chunks' places) differ from one run to the next.
pub fn chunks_in_increasing_order(bytes: &[u8]) -> bool {
    header_spans(bytes).is_some_and(|headers| {
        headers.iter().all(|(_, _, spans)| {
            spans.iter().any(|&(s, e)| attribute_name(bytes, (s, e)) == b"lineOrder" && e > s && bytes[e - 1] == 0)
        })
    })
}

/// The project's lossless encoding of renders and partial renders: the `exr` crate's fast lossless
/// choice (RLE, 64 × 64 tiles), with the chunks in increasing order so that the file's bytes do not
/// depend on which compression thread finishes first.
pub const FAST_LOSSLESS: exr::prelude::Encoding =
    exr::prelude::Encoding { line_order: exr::prelude::LineOrder::Increasing, ..exr::prelude::Encoding::FAST_LOSSLESS };

/// Encodes an image with `encode` (e.g. `|c| image.write().to_buffered(c)`), puts its header
/// attributes in canonical order ([`sort_header_attributes`]) and writes the bytes to `path`.
/// Errors are the encoder's or the file system's, as text without the file name (callers add it).
pub fn write_exr_canonical(
    path: &Path,
    encode: impl FnOnce(&mut Cursor<Vec<u8>>) -> exr::error::UnitResult,
) -> Result<(), String> {
    let mut cursor = Cursor::new(Vec::new());
    encode(&mut cursor).map_err(|e| format!("cannot write OpenEXR: {e}"))?;
    let mut bytes = cursor.into_inner();
    if !chunks_in_increasing_order(&bytes) {
        // A writer chose an encoding whose chunk order depends on thread timing.
        return Err("cannot write OpenEXR: the encoding's line order is not increasing (the file's bytes would \
                    depend on thread timing)"
            .to_string());
    }
    sort_header_attributes(&mut bytes);
    std::fs::write(path, &bytes).map_err(|e| format!("cannot write OpenEXR: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use exr::prelude::*;

    fn encode(attributes: &[(&str, &str)]) -> Vec<u8> {
        let mut layer = Layer::new(
            (2, 2),
            LayerAttributes::default(),
            Encoding::UNCOMPRESSED,
            AnyChannels::sort(
                std::iter::once(AnyChannel::new("Y", FlatSamples::F32(vec![1.0, 2.0, 3.0, 4.0]))).collect(),
            ),
        );
        for (k, v) in attributes {
            layer.attributes.other.insert(Text::from(*k), AttributeValue::Text(Text::from(*v)));
        }
        let mut c = Cursor::new(Vec::new());
        Image::from_layer(layer).write().to_buffered(&mut c).unwrap();
        c.into_inner()
    }

    const ATTRS: [(&str, &str); 6] =
        [("reflect:camera", "c"), ("reflect:scene", "s"), ("a", "1"), ("zz", "2"), ("reflect:seed", "7"), ("m", "x")];

    /// The crate's order changes from one map to the next (a fresh hash seed each); sorted, every
    /// encoding is the same bytes, and it still reads back with every attribute.
    #[test]
    fn encodings_of_one_image_become_identical_and_stay_readable() {
        let raw: Vec<Vec<u8>> = (0..16).map(|_| encode(&ATTRS)).collect();
        // Without the sort, 16 encodings of six attributes are not all the same bytes (a planted
        // check that the test can fail: the chance of one order 16 times is (1/720)^15).
        assert!(raw.iter().any(|r| r != &raw[0]), "the crate's own order did not vary");
        let sorted: Vec<Vec<u8>> = raw
            .into_iter()
            .map(|mut b| {
                sort_header_attributes(&mut b).expect("a header this module understands");
                b
            })
            .collect();
        assert!(sorted.iter().all(|s| s == &sorted[0]));
        let read = exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .all_layers()
            .all_attributes()
            .from_buffered(Cursor::new(&sorted[0]))
            .unwrap();
        let other = &read.layer_data[0].attributes.other;
        for (k, v) in ATTRS {
            assert_eq!(other.get(&Text::from(k)), Some(&AttributeValue::Text(Text::from(v))), "{k}");
        }
        if let AnyChannel { sample_data: FlatSamples::F32(d), .. } = &read.layer_data[0].channel_data.list[0] {
            assert_eq!(d, &vec![1.0, 2.0, 3.0, 4.0]);
        } else {
            panic!("the channel changed type");
        }
    }

    #[test]
    fn other_bytes_are_left_alone() {
        let mut junk = b"not an exr file".to_vec();
        assert!(sort_header_attributes(&mut junk).is_none());
        assert_eq!(junk, b"not an exr file");
        let mut truncated = encode(&ATTRS)[..40].to_vec();
        let before = truncated.clone();
        assert!(sort_header_attributes(&mut truncated).is_none());
        assert_eq!(truncated, before);
    }

    /// Tiles compressed by several threads: with the crate's "unspecified" line order the chunk
    /// order depends on which thread finishes first, so such an encoding is refused outright (a
    /// deterministic check, where comparing files would only fail by chance); the project's
    /// encoding gives the same bytes every time, with the offset table increasing.
    #[test]
    fn only_increasing_chunk_orders_are_written() {
        let (w, h) = (320, 200); // 5 × 4 tiles of 64²
        let samples: Vec<f32> = (0..w * h).map(|i| ((i * 7919) % 1013) as f32 * 0.25).collect();
        let write = |enc: Encoding| {
            let layer = Layer::new(
                (w, h),
                LayerAttributes::default(),
                enc,
                AnyChannels::sort(std::iter::once(AnyChannel::new("Y", FlatSamples::F32(samples.clone()))).collect()),
            );
            let image = Image::from_layer(layer);
            let path = std::env::temp_dir().join(format!("reflect-exr-order-{}.exr", std::process::id()));
            let r =
                write_exr_canonical(&path, |c| image.write().to_buffered(c)).map(|()| std::fs::read(&path).unwrap());
            let _ = std::fs::remove_file(&path);
            r
        };
        let err = write(Encoding::FAST_LOSSLESS).unwrap_err();
        assert!(err.contains("line order"), "{err}");
        let files: Vec<Vec<u8>> = (0..8).map(|_| write(FAST_LOSSLESS).unwrap()).collect();
        assert!(files.iter().all(|f| f == &files[0]));
        assert!(chunks_in_increasing_order(&files[0]));
        // The offset table follows the header: 20 little-endian u64 positions, increasing.
        let headers = header_spans(&files[0]).unwrap();
        let table = headers[0].1 + 1;
        let offsets: Vec<u64> = (0..20)
            .map(|i| u64::from_le_bytes(files[0][table + 8 * i..table + 8 * i + 8].try_into().unwrap()))
            .collect();
        assert!(offsets.windows(2).all(|p| p[0] < p[1]), "{offsets:?}");
    }
}
