//! Writes synthetic "renders" with the exact reflected radiance B = Σ albedo Λ_l ρ̂_l L_lm Y_lm
//! (eq. 15) for trying `reflect analyze` without the renderer:
//! - `lambert_ortho.exr`: orthographic view of a Lambertian sphere (headers of docs/src/conventions.md §5);
//! - `lambert_ortho_rgb_only.exr`: the same pixels, R, G, B only, no header attributes;
//! - `phong_probe.exr`: a `normal-probe` image of a Phong (s = 8) sphere, with a stderr layer.
//!
//! The lighting is the grace probe projected to l ≤ 6, given as `sh` lighting in the header.
//!
//! Usage: `cargo run -p reflect-analysis --release --example synth_renders -- OUTDIR`

use analysis::image::{Image, read_rgb, write_exr};
use analysis::predict::predict;
use analysis::projection::{Mapping, project_envmap};
use analysis::sh::{Reconstructor, latlong_direction};
use analysis::transfer::{lambert::lambert, phong::phong};

fn main() {
    let out = std::path::PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    std::fs::create_dir_all(&out).expect("create output dir");
    let probe = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data/grace_probe.hdr");
    let lmax = 6;
    let l = project_envmap(&read_rgb(probe).expect("probe"), Mapping::Angular, lmax).expect("projection");
    let lighting = serde_json::json!({"type": "sh", "coefficients": l}).to_string();

    // Orthographic Lambertian sphere.
    let albedo = [0.8, 0.6, 0.4];
    let b = predict(&l, &lambert(lmax), albedo);
    let (from, to, up, extent, n) = ([3.0f64, 0.0, 1.0], [0.0f64; 3], [0.0f64, 0.0, 1.0], 1.05, 256usize);
    let norm = |a: [f64; 3]| {
        let s = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        [a[0] / s, a[1] / s, a[2] / s]
    };
    let cross =
        |a: [f64; 3], b: [f64; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let f = norm([to[0] - from[0], to[1] - from[1], to[2] - from[2]]);
    let right = norm(cross(f, up));
    let upp = cross(right, f);
    let mut rec = Reconstructor::new(lmax);
    let mut img = Image { width: n, height: n, ..Default::default() };
    let mut ch: Vec<Vec<f32>> = vec![vec![0.0; n * n]; 7];
    for r in 0..n {
        for c in 0..n {
            let x = extent * (2.0 * (c as f64 + 0.5) / n as f64 - 1.0);
            let y = extent * (1.0 - 2.0 * (r as f64 + 0.5) / n as f64);
            let o = [
                from[0] + x * right[0] + y * upp[0],
                from[1] + x * right[1] + y * upp[1],
                from[2] + x * right[2] + y * upp[2],
            ];
            let t0 = -(o[0] * f[0] + o[1] * f[1] + o[2] * f[2]);
            let d2 = o[0] * o[0] + o[1] * o[1] + o[2] * o[2] - t0 * t0;
            if d2 >= 1.0 {
                continue;
            }
            let t = t0 - (1.0 - d2).sqrt();
            let nrm = [o[0] + t * f[0], o[1] + t * f[1], o[2] + t * f[2]];
            let v = rec.eval(&b, nrm);
            let i = r * n + c;
            for k in 0..3 {
                ch[k][i] = v[k] as f32;
                ch[3 + k][i] = nrm[k] as f32;
            }
            ch[6][i] = 1.0;
        }
    }
    for (k, name) in ["R", "G", "B", "normal.X", "normal.Y", "normal.Z", "mask.Y"].iter().enumerate() {
        img.channels.insert(name.to_string(), ch[k].clone());
    }
    let rgb_only = Image {
        width: n,
        height: n,
        channels: img.channels.iter().filter(|(k, _)| k.len() == 1).map(|(k, v)| (k.clone(), v.clone())).collect(),
        attributes: Default::default(),
        matrices: Default::default(),
    };
    img.attributes.insert(
        "reflect:camera".into(),
        serde_json::json!({"type": "orthographic", "from": from, "to": to, "up": up, "extent": extent}).to_string(),
    );
    img.attributes.insert("reflect:lighting".into(), lighting.clone());
    img.attributes.insert(
        "reflect:objects".into(),
        serde_json::json!([{"shape": "sphere", "center": [0, 0, 0], "radius": 1, "brdf": {"type": "lambert", "albedo": albedo}}]).to_string(),
    );
    write_exr(out.join("lambert_ortho.exr"), &img).expect("write");
    write_exr(out.join("lambert_ortho_rgb_only.exr"), &rgb_only).expect("write");

    // Normal-probe Phong sphere, s = 8, with a (nominal) stderr layer.
    let b = predict(&l, &phong(8.0, lmax), [1.0; 3]);
    let (w, h) = (256usize, 128usize);
    let mut img = Image { width: w, height: h, ..Default::default() };
    let mut ch: Vec<Vec<f32>> = vec![vec![0.0; w * h]; 6];
    for r in 0..h {
        for c in 0..w {
            let v = rec.eval(&b, latlong_direction(r, c, w, h));
            for k in 0..3 {
                ch[k][r * w + c] = v[k] as f32;
                ch[3 + k][r * w + c] = 1e-3;
            }
        }
    }
    for (k, name) in ["R", "G", "B", "stderr.R", "stderr.G", "stderr.B"].iter().enumerate() {
        img.channels.insert(name.to_string(), ch[k].clone());
    }
    img.attributes.insert("reflect:camera".into(), r#"{"type":"normal-probe","theta_o_deg":0}"#.into());
    img.attributes.insert("reflect:lighting".into(), lighting);
    img.attributes.insert(
        "reflect:objects".into(),
        r#"[{"shape":"sphere","center":[0,0,0],"radius":1,"brdf":{"type":"phong","ks":[1,1,1],"s":8,"horizon":"ignore"}}]"#.into(),
    );
    write_exr(out.join("phong_probe.exr"), &img).expect("write");
    println!("wrote {}", out.display());
}
