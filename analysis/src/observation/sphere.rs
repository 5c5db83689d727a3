//! The sphere an image shows and its BRDF table: the first sphere of the header's `reflect:objects`
//! and of the sidecar scene, with explicit centre and radius.

use super::error::Error;
use super::{Sourced, close, merge, num, v3};
use crate::projection::Sphere;
use std::path::Path;
use vocab::scene::{BrdfSection, ObjectSection, SceneFile, decimal, decimal3};

/// A sphere, displayable in messages.
#[derive(Clone, Copy, Debug)]
struct Shown(Sphere);

impl std::fmt::Display for Shown {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "sphere center {} radius {}", v3(self.0.center), num(self.0.radius))
    }
}

/// A BRDF table, displayable in messages.
struct ShownBrdf(BrdfSection);

impl std::fmt::Display for ShownBrdf {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "the BRDF {}", serde_json::to_string(&self.0).unwrap_or_default())
    }
}

fn first_sphere(objs: &[ObjectSection]) -> Option<(Sphere, BrdfSection)> {
    objs.iter().find_map(|o| match o {
        ObjectSection::Sphere { center, radius, brdf, .. } => {
            Some((Sphere { center: decimal3(*center), radius: decimal(*radius) }, brdf.clone()))
        }
        _ => None,
    })
}

fn same_sphere(a: &Shown, b: &Shown) -> bool {
    let s = a.0.radius.abs().max(b.0.radius.abs());
    (0..3).all(|i| close(a.0.center[i], b.0.center[i], s)) && close(a.0.radius, b.0.radius, s)
}

/// The sphere analysed and its BRDF table with its source, from the header's objects, the sidecar
/// scene (`scene`: its path and contents) and the explicit `center` and `radius`; the unit sphere at
/// the origin where none says. A textured sphere's radiance is T(n) times a uniform sphere's: every
/// analysis here assumes one albedo, so such a sphere is refused rather than analysed as uniform.
pub(super) fn resolve(
    header: Option<&[ObjectSection]>,
    scene: Option<(&Path, &SceneFile)>,
    center: Option<[f64; 3]>,
    radius: Option<f64>,
) -> Result<(Sphere, Sourced<BrdfSection>), Error> {
    let textured = |objs: &[ObjectSection]| {
        objs.iter().find(|o| matches!(o, ObjectSection::Sphere { .. })).is_some_and(|o| o.texture().is_some())
    };
    if header.is_some_and(textured) {
        return Err(Error::Textured { in_header: true });
    }
    if let Some((sp, s)) = scene
        && textured(&s.objects)
    {
        return Err(Error::Textured { in_header: false }.in_file(sp));
    }
    let h_sphere = header.and_then(first_sphere);
    let s_sphere = scene.and_then(|(sp, s)| first_sphere(&s.objects).map(|x| (x, sp.display().to_string())));
    let base = merge(
        h_sphere.as_ref().map(|(s, _)| (Shown(*s), "the header's reflect:objects".to_string())),
        s_sphere.as_ref().map(|((s, _), sp)| (Shown(*s), format!("the [[objects]] of {sp}"))),
        same_sphere,
    )?;
    let default = base.as_ref().map_or(Sphere { center: [0.0; 3], radius: 1.0 }, |(s, _)| s.0);
    let given = Sphere { center: center.unwrap_or(default.center), radius: radius.unwrap_or(default.radius) };
    if let Some((b, src)) = &base
        && (center.is_some() || radius.is_some())
        && !same_sphere(&Shown(given), b)
    {
        return Err(Error::Contradiction {
            one: format!("--center/--radius give {}", Shown(given)),
            other: format!("{src} gives {b}"),
        });
    }
    let json = |b: &BrdfSection| serde_json::to_value(b).unwrap_or_default();
    let brdf = merge(
        h_sphere.map(|(_, b)| (ShownBrdf(b), "the header's reflect:objects".to_string())),
        s_sphere.map(|((_, b), sp)| (ShownBrdf(b), format!("the [[objects]] of {sp}"))),
        |a, b| json(&a.0) == json(&b.0),
    )?
    .map(|(b, s)| (b.0, s));
    Ok((given, brdf))
}
