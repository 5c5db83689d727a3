//! The `reflect:*` attributes of a render's EXR header: the scene it was made from, written as
//! JSON of the [`crate::scene`] types (`reflect:camera`, `reflect:render`, `reflect:lighting`,
//! `reflect:objects`), the whole scene as TOML (`reflect:scene`) and the integrator's name
//! (`reflect:integrator`), and read back into the same types. A present but malformed value is an
//! error naming the key (never a silent default); an absent key is `None` (an image written by
//! another renderer has none of them).

use crate::error::{Error, Result};
use crate::scene::{BrdfSection, CameraSection, LightingSection, ObjectSection, RenderSection, SceneFile};
use serde::de::DeserializeOwned;
use std::collections::BTreeMap;

/// Header key of the camera table (JSON of [`CameraSection`]).
pub const CAMERA: &str = "reflect:camera";
/// Header key of the render settings (JSON of [`RenderSection`]).
pub const RENDER: &str = "reflect:render";
/// Header key of the lighting table (JSON of [`LightingSection`]).
pub const LIGHTING: &str = "reflect:lighting";
/// Header key of the objects (JSON array of [`ObjectSection`]).
pub const OBJECTS: &str = "reflect:objects";
/// Header key of the whole scene as TOML.
pub const SCENE: &str = "reflect:scene";
/// Header key of the integrator's one-line description.
pub const INTEGRATOR: &str = "reflect:integrator";
/// The degrees of freedom of the `stderr` layer of an image written by another renderer (a
/// number ≥ 1, or `inf` for an exact σ): e.g. k − 1 for the spread of k replicate images,
/// spp − 1 for the per-pixel spread of spp independent samples. Our renders state theirs in
/// [`RENDER`] (its sampler and spp).
pub const STDERR_DOF: &str = "reflect:stderr_dof";

/// JSON with every non-ASCII character escaped, because EXR text attributes are byte strings.
fn ascii_json(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        if ch.is_ascii() {
            out.push(ch);
        } else {
            let mut buf = [0u16; 2];
            for u in ch.encode_utf16(&mut buf) {
                out.push_str(&format!("\\u{u:04x}"));
            }
        }
    }
    out
}

fn json<T: serde::Serialize>(v: &T) -> String {
    ascii_json(&serde_json::to_string(v).unwrap_or_else(|_| "null".into()))
}

/// The header attributes describing how an image was made from `scene` by `integrator`.
pub fn attributes(scene: &SceneFile, integrator: &str) -> Vec<(String, String)> {
    let scene_toml = toml::to_string(scene).unwrap_or_default();
    let scene_toml: String = scene_toml.chars().map(|c| if c.is_ascii() { c } else { '?' }).collect();
    vec![
        (CAMERA.into(), json(&scene.camera)),
        (RENDER.into(), json(&scene.render)),
        (LIGHTING.into(), json(&scene.lighting)),
        (OBJECTS.into(), json(&scene.objects)),
        (SCENE.into(), scene_toml),
        (INTEGRATOR.into(), integrator.chars().filter(char::is_ascii).collect()),
    ]
}

/// What a render's header says about how it was made; each field is `None` when its key is absent.
#[derive(Clone, Debug, Default)]
pub struct Header {
    pub camera: Option<CameraSection>,
    pub render: Option<RenderSection>,
    pub lighting: Option<LightingSection>,
    pub objects: Option<Vec<ObjectSection>>,
}

/// The value of `key` parsed as JSON of `T`, `None` when absent; malformed → an error naming `key`.
pub fn read_key<T: DeserializeOwned>(attributes: &BTreeMap<String, String>, key: &str) -> Result<Option<T>> {
    let Some(text) = attributes.get(key) else { return Ok(None) };
    let mut value: serde_json::Value =
        serde_json::from_str(text).map_err(|e| Error::new(format!("header {key} is not JSON: {e}")))?;
    if key == RENDER {
        // Renders written before `reflect:integrator` existed carried the integrator's name here.
        if let Some(o) = value.as_object_mut() {
            o.remove("integrator");
        }
    }
    serde_json::from_value(value).map(Some).map_err(|e| Error::new(format!("header {key}: {e}")))
}

impl Header {
    /// Reads the `reflect:*` keys of an image's header attributes.
    pub fn read(attributes: &BTreeMap<String, String>) -> Result<Header> {
        Ok(Header {
            camera: read_key(attributes, CAMERA)?,
            render: read_key(attributes, RENDER)?,
            lighting: read_key(attributes, LIGHTING)?,
            objects: read_key(attributes, OBJECTS)?,
        })
    }

    /// The first sphere among the objects: (centre, radius, BRDF).
    pub fn first_sphere(&self) -> Option<([f32; 3], f32, &BrdfSection)> {
        self.objects.iter().flatten().find_map(|o| match o {
            ObjectSection::Sphere { center, radius, brdf, .. } => Some((*center, *radius, brdf)),
            _ => None,
        })
    }

    /// The number of objects (0 when the header has none).
    pub fn object_count(&self) -> usize {
        self.objects.as_ref().map_or(0, Vec::len)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENE_TOML: &str = r#"
[camera]
type = "normal-probe"
theta_o_deg = 30.0
[lighting]
type = "envmap"
file = "map.hdr"
mapping = "latlong"
[[objects]]
shape = "sphere"
brdf = { type = "phong", s = 8.0, horizon = "ignore" }
"#;

    #[test]
    fn attributes_read_back_into_the_same_types() {
        let scene = SceneFile::parse(SCENE_TOML).unwrap();
        let attrs: BTreeMap<String, String> = attributes(&scene, "path").into_iter().collect();
        let h = Header::read(&attrs).unwrap();
        assert!(matches!(h.camera, Some(CameraSection::NormalProbe { theta_o_deg: 30.0, .. })));
        let (c, r, b) = h.first_sphere().unwrap();
        assert_eq!((c, r), ([0.0; 3], 1.0));
        assert!(matches!(b, BrdfSection::Phong { s: 8.0, horizon: crate::Horizon::Ignore, .. }));
        assert_eq!(h.render.unwrap().spp, scene.render.spp);
        assert_eq!(attrs[INTEGRATOR], "path");
    }

    /// A camera table without `to` looks at the origin, and without `up` has +z up, in a scene file
    /// and in a header alike: the one default every front-end (CLI flags, Python dicts) gets.
    #[test]
    fn a_camera_without_to_looks_at_the_origin() {
        let text = "[camera]\ntype = \"orthographic\"\nfrom = [3.0, 0.0, 1.0]\nextent = 1.05\n[lighting]\ntype = \"uniform\"\nradiance = 1.0\n";
        let scene = SceneFile::parse(text).unwrap();
        assert!(matches!(scene.camera, CameraSection::Orthographic { to: [0.0, 0.0, 0.0], up: [0.0, 0.0, 1.0], .. }));
        let attrs: BTreeMap<String, String> =
            [(CAMERA.to_string(), r#"{"type":"perspective","from":[1,2,3],"fov_deg":30}"#.to_string())].into();
        let h = Header::read(&attrs).unwrap();
        assert!(matches!(h.camera, Some(CameraSection::Perspective { to: [0.0, 0.0, 0.0], .. })));
    }

    /// A malformed value is an error naming the header key and the bad value, never a silent default
    /// (serde's messages for internally tagged enums do not name the field inside the table).
    #[test]
    fn malformed_values_name_the_key() {
        for (key, value, says) in [
            (CAMERA, r#"{"type":"orthographic","from":[1,0,0],"to":[0,0,0],"extent":"wide"}"#, "wide"),
            (CAMERA, r#"{"type":"normal-probe","theta_o_deg":"x"}"#, "\"x\""),
            (OBJECTS, r#"[{"shape":"sphere","radius":"one","brdf":{"type":"lambert","albedo":1}}]"#, "one"),
            (OBJECTS, r#"[{"shape":"sphere","brdf":{"type":"phong","s":8,"horizon":"sometimes"}}]"#, "sometimes"),
            (LIGHTING, r#"{"type":"envmap","file":"a.hdr","mapping":"mercator"}"#, "mercator"),
            (LIGHTING, "{not json", "not JSON"),
        ] {
            let attrs = BTreeMap::from([(key.to_string(), value.to_string())]);
            let e = Header::read(&attrs).unwrap_err().to_string();
            assert!(e.contains(key) && e.contains(says), "{key} = {value}: {e}");
        }
    }

    #[test]
    fn an_older_render_header_with_the_integrator_inside_still_reads() {
        let attrs = BTreeMap::from([(
            RENDER.to_string(),
            r#"{"width":4,"height":4,"spp":1,"seed":0,"max_depth":1,"sampler":"sobol","integrator":"path"}"#
                .to_string(),
        )]);
        assert_eq!(Header::read(&attrs).unwrap().render.unwrap().width, 4);
    }
}
