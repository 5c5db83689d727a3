#![allow(clippy::needless_range_loop)]
//! Image loaders on the real-world cases of `../shared/cases` and on generated files of every
//! variant the formats allow: Radiance orientations, EXPOSURE/COLORCORR and encodings; OpenEXR
//! data/display windows, multi-part files, tiled, mip-mapped, half and float storage. And the
//! exact projection of the coarse maps of `env-coarse`.

use analysis::image::{read_image, read_rgb};
use analysis::projection::{Mapping, project_envmap};
use analysis::sh::index;
use std::f64::consts::PI;
use std::path::PathBuf;

const CASES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/cases");

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("reflect-images-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

// ---------------------------------------------------------------- Radiance .hdr

/// RGBE of a float triple (the usual frexp encoding, mantissa truncated).
fn rgbe(p: [f32; 3]) -> [u8; 4] {
    let m = p[0].max(p[1]).max(p[2]);
    if m < 1e-32 {
        return [0; 4];
    }
    let e = (m as f64).log2().floor() as i32 + 1;
    let f = 2f64.powi(8 - e);
    [(p[0] as f64 * f) as u8, (p[1] as f64 * f) as u8, (p[2] as f64 * f) as u8, (e + 128) as u8]
}

/// Decoded value of an RGBE pixel (m · 2^(e−136)).
fn unrgbe(q: [u8; 4]) -> [f32; 3] {
    if q[3] == 0 {
        return [0.0; 3];
    }
    std::array::from_fn(|i| (q[i] as f64 * 2f64.powi(q[3] as i32 - 136)) as f32)
}

/// Writes `img` (row 0 at the top, `w` wide) with the resolution string `orient` (e.g. "+Y", "-X"
/// for "+Y H -X W"), extra header lines, flat or adaptive-RLE scanlines.
fn write_hdr(img: &[[u8; 4]], w: usize, h: usize, major: &str, minor: &str, header: &str, rle: bool) -> Vec<u8> {
    let major_y = major.ends_with('Y');
    let (n1, n2) = if major_y { (h, w) } else { (w, h) };
    let mut out = format!("#?RADIANCE\n{header}FORMAT=32-bit_rle_rgbe\n\n{major} {n1} {minor} {n2}\n").into_bytes();
    for i in 0..n1 {
        let scan: Vec<[u8; 4]> = (0..n2)
            .map(|j| {
                let (row, col) = if major_y {
                    (
                        if major.starts_with('-') { i } else { h - 1 - i },
                        if minor.starts_with('+') { j } else { w - 1 - j },
                    )
                } else {
                    (
                        if minor.starts_with('-') { j } else { h - 1 - j },
                        if major.starts_with('+') { i } else { w - 1 - i },
                    )
                };
                img[row * w + col]
            })
            .collect();
        if rle {
            assert!((8..0x8000).contains(&n2));
            out.extend([2, 2, (n2 >> 8) as u8, (n2 & 0xff) as u8]);
            for ch in 0..4 {
                // Runs where a value repeats ≥ 3 times, literals otherwise.
                let v: Vec<u8> = scan.iter().map(|p| p[ch]).collect();
                let mut x = 0;
                while x < n2 {
                    let mut run = 1;
                    while x + run < n2 && run < 127 && v[x + run] == v[x] {
                        run += 1;
                    }
                    if run >= 3 {
                        out.extend([128 + run as u8, v[x]]);
                        x += run;
                    } else {
                        let n = (n2 - x).min(2);
                        out.push(n as u8);
                        out.extend(&v[x..x + n]);
                        x += n;
                    }
                }
            }
        } else {
            scan.iter().for_each(|p| out.extend(p));
        }
    }
    out
}

fn test_pixels(w: usize, h: usize) -> Vec<[u8; 4]> {
    (0..w * h)
        .map(|i| rgbe([(i % w) as f32 + 1.0, (i / w) as f32 + 0.5, ((i * 7) % 5) as f32 * 0.25 + 0.125]))
        .collect()
}

#[test]
fn hdr_all_eight_orientations_give_the_same_image() {
    let (w, h) = (9, 5);
    let px = test_pixels(w, h);
    let want: Vec<[f32; 3]> = px.iter().map(|&q| unrgbe(q)).collect();
    for (major, minor) in
        [("-Y", "+X"), ("-Y", "-X"), ("+Y", "+X"), ("+Y", "-X"), ("+X", "+Y"), ("+X", "-Y"), ("-X", "+Y"), ("-X", "-Y")]
    {
        for rle in [false, true] {
            if rle && !major.ends_with('Y') && h < 8 {
                continue; // scanlines of 5 pixels cannot be run-length encoded
            }
            let f = tmp(&format!("o{major}{minor}{rle}.hdr"));
            std::fs::write(&f, write_hdr(&px, w, h, major, minor, "", rle)).unwrap();
            let img = read_rgb(&f).unwrap_or_else(|e| panic!("{major} {minor}: {e}"));
            assert_eq!((img.width, img.height), (w, h), "{major} {minor}");
            assert_eq!(img.pixels, want, "{major} {minor} rle={rle}");
        }
    }
    // A resolution string of another form is refused, naming it.
    let f = tmp("bad_orient.hdr");
    std::fs::write(&f, b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +Y 2\n").unwrap();
    let e = read_rgb(&f).unwrap_err().to_string();
    assert!(e.contains("bad_orient.hdr") && e.contains("-Y 2 +Y 2"), "{e}");
}

#[test]
fn hdr_exposure_and_colorcorr_are_divided_out() {
    let (w, h) = (8, 3);
    let px = test_pixels(w, h);
    let header = "EXPOSURE=2\nCOLORCORR=1 0.5 4\n# a comment\nEXPOSURE=1.5\nSOFTWARE=test\n";
    let f = tmp("exposure.hdr");
    std::fs::write(&f, write_hdr(&px, w, h, "-Y", "+X", header, true)).unwrap();
    let img = read_rgb(&f).unwrap();
    for (got, &q) in img.pixels.iter().zip(&px) {
        let v = unrgbe(q);
        let want = [v[0] as f64 / 3.0, v[1] as f64 / 1.5, v[2] as f64 / 12.0];
        for ch in 0..3 {
            assert_eq!(got[ch], want[ch] as f32);
        }
    }
    for bad in ["EXPOSURE=0\n", "EXPOSURE=abc\n", "COLORCORR=1 1\n", "COLORCORR=1 -1 1\n", "FORMAT=32-bit_rle_xyze\n"] {
        let f = tmp("bad_header.hdr");
        let mut data = format!("#?RADIANCE\n{bad}\n-Y 1 +X 1\n").into_bytes();
        data.extend([128, 128, 128, 129]);
        std::fs::write(&f, data).unwrap();
        let e = read_rgb(&f).unwrap_err().to_string();
        assert!(e.contains("bad_header.hdr") && e.contains(bad.split('=').next().unwrap()), "{bad}: {e}");
    }
}

#[test]
fn hdr_old_run_length_pixels_are_read() {
    // (1,1,1,n) repeats the previous pixel n times; a second consecutive code counts n << 8.
    let mut data = b"#?RADIANCE\n\n-Y 1 +X 300\n".to_vec();
    data.extend([128, 64, 32, 129]); // 1 pixel
    data.extend([1, 1, 1, 43]); // + 43
    data.extend([1, 1, 1, 1]); // + 256
    let f = tmp("oldrle.hdr");
    std::fs::write(&f, &data).unwrap();
    let img = read_rgb(&f).unwrap();
    assert_eq!(img.width, 300);
    assert!(img.pixels.iter().all(|p| *p == [1.0, 0.5, 0.25]), "{:?}", &img.pixels[..3]);
}

#[test]
fn hdr_reader_agrees_with_the_image_crate_on_the_grace_probe() {
    use image::ImageDecoder;
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data/grace_probe.hdr");
    let bytes = std::fs::read(path).unwrap();
    let dec = image::codecs::hdr::HdrDecoder::new(std::io::Cursor::new(&bytes)).unwrap();
    let mut buf = vec![0u8; dec.total_bytes() as usize];
    dec.read_image(&mut buf).unwrap();
    let theirs: Vec<f32> = buf.chunks_exact(4).map(|c| f32::from_ne_bytes([c[0], c[1], c[2], c[3]])).collect();
    let ours = read_rgb(path).unwrap();
    let ours: Vec<f32> = ours.pixels.iter().flatten().copied().collect();
    assert_eq!(ours, theirs);
}

#[test]
fn hdr_size_claim_is_refused_before_allocating() {
    let f = format!("{CASES}/hdr-size-claim/claims_32768.hdr");
    let e = read_image(&f).unwrap_err().to_string();
    assert!(e.contains("claims_32768.hdr") && e.contains("32768×32768"), "{e}");
    // Truncated pixel data of a plausible header is an error too, not a panic.
    let (w, h) = (16, 16);
    let full = write_hdr(&test_pixels(w, h), w, h, "-Y", "+X", "", false);
    for cut in [full.len() - 1, full.len() - 100, full.len() / 2] {
        let f = tmp("trunc.hdr");
        std::fs::write(&f, &full[..cut]).unwrap();
        assert!(read_rgb(&f).is_err());
    }
}

// ---------------------------------------------------------------- OpenEXR

#[test]
fn exr_data_window_cases_give_the_same_lighting() {
    for name in ["reference_full", "crop_top_half", "overscan"] {
        let img = read_rgb(format!("{CASES}/exr-data-window/{name}.exr")).unwrap();
        assert_eq!((img.width, img.height), (16, 8), "{name}");
        for r in 0..8 {
            for c in 0..16 {
                assert_eq!(img.get(r, c), if r < 4 { [2.0; 3] } else { [0.0; 3] }, "{name} ({r},{c})");
            }
        }
        let l = project_envmap(&img, Mapping::LatLong, 1).unwrap();
        // Upper hemisphere 2: L00 = 2 · 2π · Y00 = 3.5449, L10 = 2 · π · 0.488603 = 3.0700.
        assert!((l[0][0] - 2.0 * 2.0 * PI / (4.0 * PI).sqrt()).abs() < 1e-12, "{name}: {:?}", l[0]);
        assert!((l[index(1, 0)][0] - 2.0 * PI * (3.0 / (4.0 * PI)).sqrt()).abs() < 1e-12, "{name}");
        assert!(l[index(1, 1)][0].abs() < 1e-14 && l[index(1, -1)][0].abs() < 1e-14, "{name}");
    }
}

use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image as ExrImage, Layer, LayerAttributes, Text, WritableImage,
};

fn layer(
    name: Option<&str>,
    size: (usize, usize),
    pos: (i32, i32),
    chans: &[(&str, bool)],
    enc: Encoding,
) -> Layer<AnyChannels<FlatSamples>> {
    let n = size.0 * size.1;
    let list: Vec<AnyChannel<FlatSamples>> = chans
        .iter()
        .enumerate()
        .map(|(k, (c, half))| {
            let v: Vec<f32> = (0..n).map(|i| (i + 100 * k) as f32 * 0.25).collect();
            let s = if *half {
                FlatSamples::F16(v.iter().map(|&x| exr::prelude::f16::from_f32(x)).collect())
            } else {
                FlatSamples::F32(v)
            };
            AnyChannel::new(Text::from(*c), s)
        })
        .collect();
    let mut attrs = match name {
        Some(n) => LayerAttributes::named(n),
        None => LayerAttributes::default(),
    };
    attrs.layer_position = exr::math::Vec2(pos.0, pos.1);
    Layer::new(size, attrs, enc, AnyChannels::sort(list.into_iter().collect()))
}

fn expected(size: (usize, usize), k: usize) -> Vec<f32> {
    (0..size.0 * size.1).map(|i| (i + 100 * k) as f32 * 0.25).collect()
}

#[test]
fn exr_half_float_tiled_and_compressed_files_are_read() {
    use exr::prelude::{Blocks, Compression, LineOrder};
    let size = (37, 21);
    for (i, (half, blocks, compression)) in [
        (false, Blocks::ScanLines, Compression::Uncompressed),
        (true, Blocks::ScanLines, Compression::ZIP16),
        (true, Blocks::Tiles(exr::math::Vec2(16, 8)), Compression::PIZ),
        (false, Blocks::Tiles(exr::math::Vec2(8, 8)), Compression::RLE),
        (false, Blocks::ScanLines, Compression::PXR24),
    ]
    .into_iter()
    .enumerate()
    {
        let enc = Encoding { compression, blocks, line_order: LineOrder::Increasing };
        let l = layer(None, size, (0, 0), &[("R", half), ("G", half), ("B", half)], enc);
        let f = tmp(&format!("v{i}.exr"));
        ExrImage::from_layer(l).write().to_file(&f).unwrap();
        let img = read_image(&f).unwrap();
        assert_eq!((img.width, img.height), size);
        for (k, c) in ["R", "G", "B"].iter().enumerate() {
            let want = expected(size, k);
            let got = img.channel(c).unwrap();
            // Half: 11-bit mantissa; PXR24 keeps 24 of float's 32 bits (both lossy by design).
            let tol = if half {
                1e-3
            } else if compression == Compression::PXR24 {
                1e-4
            } else {
                0.0
            };
            for j in 0..want.len() {
                assert!((got[j] - want[j]).abs() <= tol * want[j].abs(), "{i} {c}[{j}] {} vs {}", got[j], want[j]);
            }
        }
    }
}

#[test]
fn exr_mip_mapped_file_gives_its_full_resolution() {
    use exr::image::{Levels, RipMaps};
    let _ = std::any::type_name::<RipMaps<()>>();
    let size = (16usize, 8usize);
    let make = |w: usize, h: usize, v: f32| FlatSamples::F32(vec![v; w * h]);
    let levels = Levels::Mip {
        rounding_mode: exr::math::RoundingMode::Down,
        level_data: vec![make(16, 8, 3.0), make(8, 4, 1.0), make(4, 2, 1.0), make(2, 1, 1.0), make(1, 1, 1.0)],
    };
    let chans: Vec<AnyChannel<Levels<FlatSamples>>> =
        ["B", "G", "R"].iter().map(|c| AnyChannel::new(Text::from(*c), levels.clone())).collect();
    let enc = Encoding { blocks: exr::prelude::Blocks::Tiles(exr::math::Vec2(8, 8)), ..Encoding::FAST_LOSSLESS };
    let l = Layer::new(size, LayerAttributes::default(), enc, AnyChannels::sort(chans.into_iter().collect()));
    let f = tmp("mip.exr");
    ExrImage::from_layer(l).write().to_file(&f).unwrap();
    let img = read_rgb(&f).unwrap();
    assert_eq!((img.width, img.height), size);
    assert!(img.pixels.iter().all(|p| *p == [3.0; 3]));
}

#[test]
fn exr_display_window_offset_and_partial_data_window() {
    // Display window (10, 20)–(15, 23) 6×4; data window 3×2 at (12, 21): only those pixels are set.
    let l = layer(None, (3, 2), (12, 21), &[("R", false), ("G", false), ("B", false)], Encoding::SMALL_LOSSLESS);
    let mut im = ExrImage::from_layer(l);
    im.attributes.display_window = exr::meta::attribute::IntegerBounds::new((10, 20), (6, 4));
    let f = tmp("window.exr");
    im.write().to_file(&f).unwrap();
    let img = read_image(&f).unwrap();
    assert_eq!((img.width, img.height), (6, 4));
    let r = img.channel("R").unwrap();
    let want = expected((3, 2), 0);
    for row in 0..4 {
        for col in 0..6 {
            let inside = (1..3).contains(&row) && (2..5).contains(&col);
            let v = if inside { want[(row - 1) * 3 + col - 2] } else { 0.0 };
            assert_eq!(r[row * 6 + col], v, "({row},{col})");
        }
    }
}

#[test]
fn exr_multi_part_uses_the_first_part_with_rgb_and_names_missing_channels() {
    let enc = Encoding::SMALL_LOSSLESS;
    let depth = layer(Some("depth"), (4, 2), (0, 0), &[("Z", false)], enc);
    let beauty = layer(Some("beauty"), (4, 2), (0, 0), &[("R", false), ("G", true), ("B", false)], enc);
    let f = tmp("multipart.exr");
    ExrImage::from_layers(
        exr::meta::header::ImageAttributes::new(exr::meta::attribute::IntegerBounds::from_dimensions((4, 2))),
        vec![depth.clone(), beauty],
    )
    .write()
    .to_file(&f)
    .unwrap();
    let img = read_rgb(&f).unwrap();
    assert_eq!(img.pixels[5], [expected((4, 2), 0)[5], expected((4, 2), 1)[5], expected((4, 2), 2)[5]]);
    // No part with R, G, B or Y: the error names each part and its channels.
    let alpha = layer(Some("alpha"), (4, 2), (0, 0), &[("A", false)], enc);
    let g = tmp("multipart_norgb.exr");
    ExrImage::from_layers(
        exr::meta::header::ImageAttributes::new(exr::meta::attribute::IntegerBounds::from_dimensions((4, 2))),
        vec![depth, alpha],
    )
    .write()
    .to_file(&g)
    .unwrap();
    let e = read_image(&g).unwrap_err().to_string();
    assert!(
        e.contains("multipart_norgb.exr")
            && e.contains("part 0 ('depth') has Z")
            && e.contains("part 1 ('alpha') has A"),
        "{e}"
    );
}

// ---------------------------------------------------------------- exact projection of coarse maps

#[test]
fn env_coarse_maps_give_the_exact_coefficients() {
    let y1 = (3.0 / (4.0 * PI)).sqrt();
    let sqrt_pi = PI.sqrt();
    // 2 × 1 [1, 0]: the half φ ∈ [0, π] is 1: L00 = 2π Y00 = √π, L1,−1 = Y1 ∫ y = y1 · π/2 · 2 … = 1.5350.
    let img = read_rgb(format!("{CASES}/env-coarse/e_2x1.exr")).unwrap();
    let l = project_envmap(&img, Mapping::LatLong, 12).unwrap();
    assert!((l[0][0] - sqrt_pi).abs() < 1e-14, "{:?}", l[0]);
    assert!((l[index(1, -1)][0] - y1 * PI).abs() < 1e-14, "{:?}", l[index(1, -1)]);
    assert!(l[index(1, 0)][0].abs() < 1e-15 && l[index(1, 1)][0].abs() < 1e-15);
    // 1 × 2 [1; 0]: the upper hemisphere is 1: L10 = y1 π, and every m ≠ 0 term is 0.
    let img = read_rgb(format!("{CASES}/env-coarse/f_1x2.exr")).unwrap();
    let l = project_envmap(&img, Mapping::LatLong, 40).unwrap();
    assert!((l[0][0] - sqrt_pi).abs() < 1e-14);
    assert!((l[index(1, 0)][0] - y1 * PI).abs() < 1e-14);
    for lv in 0..=40usize {
        for m in 1..=lv as i64 {
            assert_eq!(l[index(lv, m)], [0.0; 3]);
            assert_eq!(l[index(lv, -m)], [0.0; 3]);
        }
    }
    // Printed to 4 decimals in the README of the case.
    assert_eq!(format!("{:.4} {:.4}", l[0][0], l[index(1, 0)][0]), "1.7725 1.5350");
}

// ---------------------------------------------------------------- colour: chromaticities, PRIMARIES

/// ACES AP0 (SMPTE ST 2065-1): primaries and its ~D60 white.
const AP0: [[f32; 2]; 4] = [[0.7347, 0.2653], [0.0, 1.0], [0.0001, -0.0770], [0.32168, 0.33767]];
const REC709: [[f32; 2]; 4] = [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06], [0.3127, 0.3290]];

/// A 4 × 2 single-part EXR with the given channels (values from [`expected`]) and chromaticities.
fn exr_with_chromaticities(name: &str, chans: &[(&str, bool)], chroma: Option<[[f32; 2]; 4]>) -> PathBuf {
    let l = layer(None, (4, 2), (0, 0), chans, Encoding::UNCOMPRESSED);
    let mut im = ExrImage::from_layer(l);
    im.attributes.chromaticities = chroma.map(|c| exr::meta::attribute::Chromaticities {
        red: exr::math::Vec2(c[0][0], c[0][1]),
        green: exr::math::Vec2(c[1][0], c[1][1]),
        blue: exr::math::Vec2(c[2][0], c[2][1]),
        white: exr::math::Vec2(c[3][0], c[3][1]),
    });
    let f = tmp(name);
    im.write().to_file(&f).unwrap();
    f
}

/// `exr-primaries`: pure AP0 red becomes, in linear Rec. 709 with a Bradford adaptation from the
/// AP0 white to D65, the first column of the ACES AP0 → Rec. 709 matrix; the case README's L00.
#[test]
fn exr_primaries_case_is_converted_to_rec709_with_bradford() {
    let img = read_rgb(format!("{CASES}/exr-primaries/red_ap0.exr")).unwrap();
    let l = project_envmap(&img, Mapping::LatLong, 1).unwrap();
    let got = format!("{:.4} {:.4} {:.4}", l[0][0], l[0][1], l[0][2]);
    assert_eq!(got, "8.9391 -0.9801 -0.0545");
}

/// Chromaticities equal to Rec. 709 (as stored in f32, and off by less than the tolerance 1e-3)
/// leave every sample bit-identical to the same file without the attribute.
#[test]
fn rec709_chromaticities_read_bit_identical() {
    let chans = [("R", true), ("G", false), ("B", true)];
    let plain = read_image(exr_with_chromaticities("c_none.exr", &chans, None)).unwrap();
    let near = REC709.map(|p| [p[0] + 4e-4, p[1] - 4e-4]);
    for (i, c) in [REC709, near].into_iter().enumerate() {
        let img = read_image(exr_with_chromaticities(&format!("c_709_{i}.exr"), &chans, Some(c))).unwrap();
        for (name, v) in &plain.channels {
            let w = &img.channels[name];
            assert!(v.iter().zip(w).all(|(a, b)| a.to_bits() == b.to_bits()), "{i}: channel {name}");
        }
    }
}

/// Declared AP0 converts every radiance layer (plain and prefixed R, G, B) by the AP0 → Rec. 709
/// matrix; a luminance-only image is achromatic and stays as stored; degenerate chromaticities
/// are refused naming the attribute.
#[test]
fn declared_primaries_convert_radiance_layers_and_degenerate_ones_are_refused() {
    // The ACES reference AP0 → Rec. 709 (Bradford) matrix, 4 decimals.
    let m = [[2.5217, -1.1341, -0.3876], [-0.2765, 1.3727, -0.0962], [-0.0154, -0.1530, 1.1684]];
    let chans =
        [("R", false), ("G", false), ("B", false), ("diffuse.R", false), ("diffuse.G", false), ("diffuse.B", false)];
    let img = read_image(exr_with_chromaticities("c_ap0.exr", &chans, Some(AP0))).unwrap();
    for (prefix, k0) in [("", 0usize), ("diffuse.", 3)] {
        let src: Vec<Vec<f32>> = (0..3).map(|k| expected((4, 2), k0 + k)).collect();
        for (row, ch) in ["R", "G", "B"].iter().enumerate() {
            let got = img.channel(&format!("{prefix}{ch}")).unwrap();
            for i in 0..8 {
                let want: f64 = (0..3).map(|k| m[row][k] * src[k][i] as f64).sum();
                let scale: f64 = (0..3).map(|k| src[k][i] as f64).sum::<f64>() + 1.0;
                assert!((got[i] as f64 - want).abs() < 2e-4 * scale, "{prefix}{ch}[{i}]: {} vs {want}", got[i]);
            }
        }
    }
    let y = read_image(exr_with_chromaticities("c_y.exr", &[("Y", true)], Some(AP0))).unwrap();
    let want = expected((4, 2), 0);
    assert!(y.channel("Y").unwrap().iter().zip(&want).all(|(a, b)| (a - b).abs() <= 1e-3 * b.abs()));
    let line = [[0.2, 0.2], [0.4, 0.4], [0.6, 0.6], [0.3127, 0.329]];
    let f = exr_with_chromaticities("c_line.exr", &[("R", false), ("G", false), ("B", false)], Some(line));
    let e = read_image(&f).unwrap_err().to_string();
    assert!(e.contains("c_line.exr") && e.contains("chromaticities") && e.contains("one line"), "{e}");
}

/// A Radiance file's `PRIMARIES=` line is honoured like the EXR attribute; Rec. 709 primaries
/// leave the pixels as stored; a malformed line is refused naming it.
#[test]
fn hdr_primaries_line_is_honoured() {
    let write = |name: &str, header: &str| {
        let mut f = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n{header}\n-Y 1 +X 2\n").into_bytes();
        f.extend(rgbe([1.0, 0.0, 0.0]));
        f.extend(rgbe([0.5, 0.25, 0.125]));
        let p = tmp(name);
        std::fs::write(&p, f).unwrap();
        p
    };
    let plain = read_image(write("p_none.hdr", "")).unwrap();
    let ap0 = read_rgb(write("p_ap0.hdr", "PRIMARIES=0.7347 0.2653 0 1 0.0001 -0.077 0.32168 0.33767\n")).unwrap();
    let want = [2.5217, -0.2765, -0.0154];
    for c in 0..3 {
        assert!((ap0.pixels[0][c] as f64 - want[c]).abs() < 2e-4, "{:?}", ap0.pixels[0]);
    }
    let rec = read_image(write("p_709.hdr", "PRIMARIES=0.640 0.330 0.300 0.600 0.150 0.060 0.3127 0.3290\n")).unwrap();
    for (name, v) in &plain.channels {
        assert!(v.iter().zip(&rec.channels[name]).all(|(a, b)| a.to_bits() == b.to_bits()), "{name}");
    }
    let e = read_image(write("p_bad.hdr", "PRIMARIES=0.64 0.33 0.3\n")).unwrap_err().to_string();
    assert!(e.contains("p_bad.hdr") && e.contains("PRIMARIES"), "{e}");
}

// ---------------------------------------------------------------- compression and its guard

/// `exr-compressible`: a flat 2048 × 1024 half map ZIP-compressed over 2000:1 and its PIZ copy
/// both read, as OpenEXR reads them (L00 = 8.05804 in every channel).
#[test]
fn exr_compressible_cases_read() {
    for name in ["studio_2k_ZIP", "studio_2k_PIZ"] {
        let img = read_rgb(format!("{CASES}/exr-compressible/{name}.exr")).unwrap();
        let l = project_envmap(&img, Mapping::LatLong, 0).unwrap();
        for c in 0..3 {
            assert_eq!(format!("{:.5}", l[0][c]), "8.05804", "{name} channel {c}");
        }
    }
}

/// A small file whose headers claim more decoded samples than the absolute budget (a 16384²
/// display window: 1 GiB of f32 for one channel, plus the data) is refused from the headers, at once.
#[test]
fn exr_claim_above_the_decoded_budget_is_refused_at_once() {
    let l = layer(None, (1, 1), (0, 0), &[("Y", true)], Encoding::UNCOMPRESSED);
    let mut im = ExrImage::from_layer(l);
    im.attributes.display_window = exr::meta::attribute::IntegerBounds::from_dimensions((16384, 16384));
    let f = tmp("claim.exr");
    im.write().to_file(&f).unwrap();
    assert!(std::fs::metadata(&f).unwrap().len() < 1000);
    let t = std::time::Instant::now();
    // Not `unwrap_err`: an accepted image would be printed whole (a gigabyte of Debug text).
    let e = match read_image(&f) {
        Ok(img) => panic!("a {}×{} image was read", img.width, img.height),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("claim.exr") && e.contains("limit") && e.contains("16384×16384"), "{e}");
    assert!(t.elapsed().as_secs_f64() < 1.0, "{:?}", t.elapsed());
}

/// An uncompressed file of `parts` parts whose last header's `compression` byte is set to `value`.
fn with_compression(name: &str, value: u8, parts: usize) -> PathBuf {
    let f = parts_file(name, &["rgba", "diffuse"][..parts]);
    let mut bytes = std::fs::read(&f).unwrap();
    let key = b"compression\0compression\0\x01\0\0\0";
    let mut at: Vec<usize> = bytes.windows(key.len()).enumerate().filter(|(_, w)| w == key).map(|(i, _)| i).collect();
    assert_eq!(at.len(), parts, "{name}");
    let i = at.pop().unwrap() + key.len();
    assert_eq!(bytes[i], 0);
    bytes[i] = value;
    std::fs::write(&f, bytes).unwrap();
    f
}

/// HTJ2K (OpenEXR 3.4) and ZSTD files are refused as an unsupported compression named, not as corrupt.
#[test]
fn htj2k_and_zstd_are_refused_by_name() {
    for (value, parts, method) in
        [(10u8, 1usize, "HTJ2K256"), (11, 1, "HTJ2K32"), (12, 2, "ZSTD"), (40, 1, "unknown compression 40")]
    {
        let f = with_compression(&format!("comp{value}.exr"), value, parts);
        let e = read_image(&f).unwrap_err().to_string();
        assert!(
            e.contains(&format!("comp{value}.exr")) && e.contains("unsupported compression") && e.contains(method),
            "{e}"
        );
        assert!(!e.contains("corrupt"), "{e}");
        if parts == 2 {
            assert!(e.contains("part 1"), "{e}");
        }
    }
}

// ---------------------------------------------------------------- multi-part: the beauty and layers

/// A multi-part file of 4 × 2 RGB parts, part k filled with the value k + 1.
fn parts_file(name: &str, names: &[&str]) -> PathBuf {
    let ls: Vec<_> = names
        .iter()
        .enumerate()
        .map(|(k, n)| {
            let v = (k + 1) as f32;
            let list: Vec<AnyChannel<FlatSamples>> =
                ["R", "G", "B"].iter().map(|c| AnyChannel::new(Text::from(*c), FlatSamples::F32(vec![v; 8]))).collect();
            Layer::new(
                (4, 2),
                LayerAttributes::named(*n),
                Encoding::UNCOMPRESSED,
                AnyChannels::sort(list.into_iter().collect()),
            )
        })
        .collect();
    let f = tmp(name);
    ExrImage::from_layers(
        exr::meta::header::ImageAttributes::new(exr::meta::attribute::IntegerBounds::from_dimensions((4, 2))),
        ls,
    )
    .write()
    .to_file(&f)
    .unwrap();
    f
}

/// An AOV part first and the beauty second: the beauty is the image whatever its usual name, and
/// every part can be chosen by name (the beauty also by its own name).
#[test]
fn multi_part_reads_the_beauty_not_the_first_aov() {
    use analysis::image::read_rgb_layer;
    for beauty in ["rgba", "RGBA", "beauty", "combined", "rgb"] {
        let f = parts_file(&format!("aov_first_{beauty}.exr"), &["diffuse", beauty, "specular"]);
        assert_eq!(read_rgb(&f).unwrap().pixels[3], [2.0; 3], "{beauty}");
        assert_eq!(read_rgb_layer(&f, Some("diffuse")).unwrap().pixels[3], [1.0; 3], "{beauty}");
        assert_eq!(read_rgb_layer(&f, Some("specular")).unwrap().pixels[3], [3.0; 3], "{beauty}");
        assert_eq!(read_rgb_layer(&f, Some(beauty)).unwrap().pixels[3], [2.0; 3], "{beauty}");
        let e = read_rgb_layer(&f, Some("albedo")).unwrap_err().to_string();
        assert!(e.contains("'albedo'") && e.contains("'diffuse'") && e.contains("'specular'"), "{e}");
        // Every part is a layer of the image: `diffuse.R` beside the beauty's `R`.
        let img = read_image(&f).unwrap();
        assert_eq!(img.channel("diffuse.G").unwrap()[0], 1.0);
        assert_eq!(img.channel("G").unwrap()[0], 2.0);
    }
    // No part named as a beauty: the choice is the user's, and the error lists the parts.
    let f = parts_file("aovs_only.exr", &["diffuse", "specular"]);
    let e = read_rgb(&f).unwrap_err().to_string();
    assert!(e.contains("aovs_only.exr") && e.contains("'diffuse', 'specular'") && e.contains("--layer"), "{e}");
    assert_eq!(read_rgb_layer(&f, Some("specular")).unwrap().pixels[0], [2.0; 3]);
}
