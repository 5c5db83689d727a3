//! The orthographic camera of an image's standard OpenEXR attributes `worldToNDC` and (optionally)
//! `worldToCamera` (m44f), as pbrt-v4 writes them, and the image axes they imply (guide "Analysing
//! another renderer's images").

use super::orthographic::OrthoCamera;
use crate::error::{Error, Result};
use crate::image::Image;
use glam::DVec3;

/// A camera read from an image's matrices.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExrCamera {
    /// The camera in our conventions (docs/src/conventions.md §5), for the image once
    /// [`mirror_columns`] has been applied when `mirrored`.
    pub camera: OrthoCamera,
    /// The matrices' camera sees the mirror image of ours (pbrt-v4's left-handed LookAt: camera
    /// x = up × dir): the image's columns must be mirrored to show what ours would.
    pub mirrored: bool,
}

/// The orthographic camera of `worldToNDC` and `worldToCamera`: each the 4 × 4 matrix M with
/// p' = M (p, 1)ᵀ (column vectors, M stored row by row; a matrix stored the other way round, Imath's
/// row-vector convention with the translation in the last row, is transposed). NDC x ∈ [0, 1] runs
/// left to right over the image, NDC y ∈ [0, 1] bottom to top, NDC z grows away from the camera
/// (pbrt-v4's NDCFromWorld = Translate(½, ½, ½) · Scale(½, ½, ½) · screenFromWorld).
///
/// An orthographic camera maps world points affinely: ndc_x = a_x·p + b_x, ndc_y = a_y·p + b_y, so
/// right = a_x/|a_x|, up' = a_y/|a_y|, extent = 1/(2|a_x|) and our forward f = up' × right; the
/// direction the camera looks (`worldToCamera`'s +z row, else NDC z) opposite to f means the image
/// is mirrored ([`ExrCamera::mirrored`]). `to` is the point of the central ray (ndc = (½, ½)) nearest
/// the world origin and `from` lies 4 extents (at least 4) before it: an orthographic view does not
/// depend on where `from` lies on its axis, this only makes the camera read like one a user writes.
///
/// `Ok(None)`: no `worldToNDC`. Errors: a projective (perspective) matrix, image axes that are not
/// perpendicular in the world, or pixels that are not square, each said in words.
pub fn camera_of_matrices(img: &Image) -> Result<Option<ExrCamera>> {
    let Some(ndc) = img.matrices.get("worldToNDC") else { return Ok(None) };
    let m = column_convention(ndc);
    let row = |i: usize| DVec3::new(m[4 * i] as f64, m[4 * i + 1] as f64, m[4 * i + 2] as f64);
    let w_row = [m[12] as f64, m[13] as f64, m[14] as f64, m[15] as f64];
    if w_row[0].abs() + w_row[1].abs() + w_row[2].abs() > 1e-6 * w_row[3].abs().max(1e-30) {
        return Err(Error::new(
            "worldToNDC is a perspective projection (its last row is not (0, 0, 0, 1)); the analysis models orthographic views only: render the sphere with an orthographic camera",
        ));
    }
    let s = w_row[3];
    let (ax, ay, az) = (row(0) / s, row(1) / s, row(2) / s);
    let (bx, by) = (m[3] as f64 / s, m[7] as f64 / s);
    let (nx, ny) = (ax.length(), ay.length());
    if !(nx > 0.0 && ny > 0.0) || ax.dot(ay).abs() > 1e-4 * nx * ny {
        return Err(Error::new("worldToNDC: the image's x and y axes are not perpendicular in the world"));
    }
    let (w, h) = (img.width as f64, img.height as f64);
    // Square pixels: |a_y| / |a_x| = W / H.
    if ((ny / nx) - w / h).abs() > 1e-4 * (w / h) {
        return Err(Error::new(format!(
            "worldToNDC: pixels are not square ({}×{} image, NDC scales {nx} and {ny} per world unit)",
            img.width, img.height
        )));
    }
    let (right, up) = (ax / nx, ay / ny);
    let extent = 1.0 / (2.0 * nx);
    let ours = up.cross(right); // forward of a camera that sees the image as ours does: right = f × up'
    let look = match img.matrices.get("worldToCamera") {
        Some(c) => {
            let c = column_convention(c);
            DVec3::new(c[8] as f64, c[9] as f64, c[10] as f64)
        }
        None => az,
    };
    let mirrored = look.dot(ours) < 0.0;
    let f = if mirrored { -ours } else { ours };
    let p0 = ax * ((0.5 - bx) / (nx * nx)) + ay * ((0.5 - by) / (ny * ny));
    let to = p0 - f * p0.dot(f);
    let from = to - f * (4.0 * extent.max(1.0));
    // A mirrored camera: the columns are flipped, so the image's right is −right.
    debug_assert!(f.cross(up).dot(if mirrored { -right } else { right }) > 0.0);
    Ok(Some(ExrCamera {
        camera: OrthoCamera { from: from.to_array(), to: to.to_array(), up: up.to_array(), extent },
        mirrored,
    }))
}

/// Mirrors every channel's columns (x → W − 1 − x): a pbrt-v4 image to our image axes.
pub fn mirror_columns(img: &mut Image) {
    let w = img.width;
    for data in img.channels.values_mut() {
        data.chunks_exact_mut(w).for_each(|row| row.reverse());
    }
}

/// `m` in the column-vector convention (translation in the last column): a matrix whose last
/// column is (0, 0, 0, 1) and whose last row is not (Imath's row-vector layout) is transposed.
fn column_convention(m: &[f32; 16]) -> [f32; 16] {
    let last_col_unit = m[3] == 0.0 && m[7] == 0.0 && m[11] == 0.0 && m[15] != 0.0;
    let last_row_unit = m[12] == 0.0 && m[13] == 0.0 && m[14] == 0.0;
    if last_col_unit && !last_row_unit { std::array::from_fn(|k| m[(k % 4) * 4 + k / 4]) } else { *m }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// pbrt-v4's `worldToCamera` and `worldToNDC` of an orthographic LookAt camera (camera x =
    /// up × dir, left-handed), column vectors stored row by row.
    fn pbrt(from: DVec3, to: DVec3, up: DVec3, extent: f64) -> ([f32; 16], [f32; 16]) {
        let dir = (to - from).normalize();
        let x = up.cross(dir).normalize();
        let y = dir.cross(x);
        let (mut cam, mut ndc) = ([0f32; 16], [0f32; 16]);
        for (i, r) in [x, y, dir].iter().enumerate() {
            let s = if i < 2 { 0.5 / extent } else { 0.05 };
            for j in 0..3 {
                cam[4 * i + j] = r[j] as f32;
                ndc[4 * i + j] = (s * r[j]) as f32;
            }
            cam[4 * i + 3] = -r.dot(from) as f32;
            ndc[4 * i + 3] = (-s * r.dot(from) + 0.5) as f32;
        }
        cam[15] = 1.0;
        ndc[15] = 1.0;
        (cam, ndc)
    }

    fn image(cam: [f32; 16], ndc: [f32; 16]) -> Image {
        let mut img = Image { width: 8, height: 8, ..Default::default() };
        img.matrices.insert("worldToCamera".into(), cam);
        img.matrices.insert("worldToNDC".into(), ndc);
        img
    }

    #[test]
    fn a_pbrt_lookat_camera_is_ours_mirrored_in_either_storage_order() {
        let (from, up) = (DVec3::new(3.0, 0.0, 1.0), DVec3::Z);
        let want = OrthoCamera { from: from.to_array(), to: [0.0; 3], up: up.to_array(), extent: 1.05 };
        let (cam, ndc) = pbrt(from, DVec3::ZERO, up, 1.05);
        let got = camera_of_matrices(&image(cam, ndc)).unwrap().unwrap();
        assert!(got.mirrored && got.camera.same_view(&want), "{got:?}");
        // Imath's row-vector layout (the transpose) gives the same camera.
        let t = |m: [f32; 16]| std::array::from_fn(|k| m[(k % 4) * 4 + k / 4]);
        let got_t = camera_of_matrices(&image(t(cam), t(ndc))).unwrap().unwrap();
        assert!(got_t.mirrored && got_t.camera.same_view(&want), "{got_t:?}");
        // A right-handed camera (x = dir × up, as ours) is not mirrored; another extent is another view.
        let (mut cam_r, mut ndc_r) = (cam, ndc);
        for k in 0..4 {
            cam_r[k] = -cam[k];
            ndc_r[k] = if k == 3 { 1.0 - ndc[k] } else { -ndc[k] };
        }
        let got_r = camera_of_matrices(&image(cam_r, ndc_r)).unwrap().unwrap();
        assert!(!got_r.mirrored && got_r.camera.same_view(&want), "{got_r:?}");
        assert!(!got.camera.same_view(&OrthoCamera { extent: 1.2, ..want }));
        // A perspective matrix is refused in words.
        let mut persp = ndc;
        persp[14] = 1.0;
        let e = camera_of_matrices(&image(cam, persp)).unwrap_err();
        assert!(e.to_string().contains("perspective"), "{e}");
    }
}
