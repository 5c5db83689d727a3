//! An independent check of the frame and mapping conventions (docs/src/conventions.md §1–§3) against real
//! data: the nine lighting coefficients of the Grace Cathedral probe that Ramamoorthi & Hanrahan
//! published ("An Efficient Representation for Irradiance Environment Maps", SIGGRAPH 2001,
//! Table 1, two decimals). Their probe file was exposed differently from `grace_probe.hdr`, so one
//! global scale is fitted by least squares; after it, every coefficient must agree to the
//! published rounding (±0.005) plus a small allowance for the fitted scale (0.003 of the largest
//! coefficient). A wrong axis, sign, mapping or phase convention moves several coefficients by
//! far more than that.

use analysis::image::read_rgb;
use analysis::projection::envmap::{Mapping, project_envmap};

const PUBLISHED: [[f64; 3]; 9] = [
    [0.79, 0.44, 0.54],
    [0.39, 0.35, 0.60],
    [-0.34, -0.18, -0.27],
    [-0.29, -0.06, 0.01],
    [-0.11, -0.05, -0.12],
    [-0.26, -0.22, -0.47],
    [-0.16, -0.09, -0.15],
    [0.56, 0.21, 0.14],
    [0.21, -0.05, -0.30],
];

#[test]
fn grace_coefficients_match_the_published_table() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data/grace_probe.hdr");
    let img = read_rgb(path).expect("grace probe");
    let ours = project_envmap(&img, Mapping::Angular, 2).expect("projection");
    let (mut num, mut den) = (0.0, 0.0);
    for k in 0..9 {
        for c in 0..3 {
            num += ours[k][c] * PUBLISHED[k][c];
            den += PUBLISHED[k][c] * PUBLISHED[k][c];
        }
    }
    let scale = num / den;
    assert!(scale > 0.0);
    for k in 0..9 {
        for c in 0..3 {
            let v = ours[k][c] / scale;
            assert!(
                (v - PUBLISHED[k][c]).abs() <= 0.005 + 0.003 * 0.79,
                "k={k} channel {c}: {v:.4} (scaled by 1/{scale:.4}) vs published {}",
                PUBLISHED[k][c]
            );
        }
    }
}
