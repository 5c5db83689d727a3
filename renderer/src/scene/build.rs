//! From a parsed [`SceneFile`] to a renderable [`Scene`]: validates every value (no NaN, no
//! absurd sizes, positive parameters), loads meshes and environment maps relative to the scene
//! file, and builds the BVH. Every failure is one line naming the scene file (or the data file).

use super::file::{CameraSection, LightingSection, ObjectSection, SceneFile};
use crate::brdf::{self, Brdf};
use crate::camera::{Camera, NormalProbe, Orthographic, Perspective};
use crate::geometry::{SceneGeometry, Shape, Sphere};
use crate::light::{self, Light, Mapping};
use crate::math::{Rgb, Vec3, rotation_xyz_deg};
use crate::sampling::SamplerKind;
use crate::{Error, Result};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Largest accepted image side and samples per pixel: beyond these a request is taken as a typo.
pub const MAX_RESOLUTION: u32 = 16384;
pub const MAX_SPP: u32 = 1 << 20;
pub const MAX_DEPTH: u32 = 1024;

#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u64,
    pub max_depth: u32,
    pub sampler: SamplerKind,
}

/// Everything a render needs.
pub struct Scene {
    pub settings: RenderSettings,
    pub camera: Camera,
    pub light: Light,
    pub geometry: SceneGeometry,
    /// BRDF of object i.
    pub brdfs: Vec<Brdf>,
    /// Albedo texture of object i (None: untextured).
    pub textures: Vec<Option<crate::texture::ShTexture>>,
    /// The parsed description (with paths made absolute), written into the EXR header.
    pub description: SceneFile,
    /// Where the scene came from (None for the built-in default).
    pub path: Option<PathBuf>,
    /// How long each phase of loading took (what `reflect render --json` reports as `phases` and
    /// `reflect bench` compares).
    pub timings: BuildTimings,
}

/// Wall time of each phase of [`Scene::load`] / [`Scene::build`], seconds. They do not overlap;
/// their sum is the load time minus small glue (camera, BRDF tables).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct BuildTimings {
    /// Reading and parsing the scene file (0 for [`Scene::build`] from a parsed description).
    pub parse_seconds: f64,
    /// Reading mesh files (OBJ, glTF) or generating icospheres, and transforming them.
    pub meshes_seconds: f64,
    /// Building the bounding-volume hierarchy over every shape (obvhs).
    pub bvh_seconds: f64,
    /// Reading the environment map's image file (decoding, colour conversion).
    pub lighting_read_seconds: f64,
    /// The environment map's sampling tables (row and column CDFs) and other lighting setup.
    pub lighting_tables_seconds: f64,
}

/// The built-in default scene: a sphere under a built-in sky.
pub const DEFAULT_SCENE: &str = include_str!("default.toml");

impl Scene {
    /// Loads and builds a scene file.
    pub fn load(path: &Path) -> Result<Scene> {
        let t0 = Instant::now();
        let text =
            std::fs::read_to_string(path).map_err(|e| Error::file(path, format!("cannot read scene file: {e}")))?;
        let file = SceneFile::parse(&text).map_err(|m| Error::file(path, m))?;
        let parse_seconds = t0.elapsed().as_secs_f64();
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Scene::build(file, &base).map_err(|e| e.in_file(path)).map(|mut s| {
            s.path = Some(path.to_path_buf());
            s.timings.parse_seconds = parse_seconds;
            s
        })
    }

    /// The built-in default scene.
    pub fn default_scene() -> Scene {
        let file = SceneFile::parse(DEFAULT_SCENE).expect("built-in scene parses");
        Scene::build(file, Path::new(".")).expect("built-in scene builds")
    }

    /// Builds a scene from its description; relative paths are resolved against `base`.
    pub fn build(mut file: SceneFile, base: &Path) -> Result<Scene> {
        let r = &file.render;
        if r.width == 0 || r.height == 0 || r.width > MAX_RESOLUTION || r.height > MAX_RESOLUTION {
            return Err(Error::new(format!(
                "absurd resolution {}×{} (each side must be 1..={MAX_RESOLUTION})",
                r.width, r.height
            )));
        }
        if r.spp == 0 || r.spp > MAX_SPP {
            return Err(Error::new(format!("spp = {} is out of range 1..={MAX_SPP}", r.spp)));
        }
        if r.max_depth == 0 || r.max_depth > MAX_DEPTH {
            return Err(Error::new(format!("max_depth = {} is out of range 1..={MAX_DEPTH}", r.max_depth)));
        }
        let settings = RenderSettings {
            width: r.width,
            height: r.height,
            spp: r.spp,
            seed: r.seed,
            max_depth: r.max_depth,
            sampler: r.sampler,
        };

        let mut timings = BuildTimings::default();
        let t_meshes = Instant::now();
        // Objects.
        let mut shapes = Vec::with_capacity(file.objects.len());
        let mut brdfs = Vec::with_capacity(file.objects.len());
        let mut textures = Vec::with_capacity(file.objects.len());
        for (i, obj) in file.objects.iter_mut().enumerate() {
            let ctx = |m: String| Error::new(format!("objects[{i}]: {m}"));
            match obj {
                ObjectSection::Sphere { center, radius, .. } => {
                    let c = vec3(*center, "center").map_err(ctx)?;
                    if !(*radius > 0.0 && radius.is_finite()) {
                        return Err(ctx(format!("radius must be positive, got {radius}")));
                    }
                    shapes.push(Shape::Sphere(Sphere { center: c, radius: *radius }));
                }
                ObjectSection::Icosphere { subdivisions, center, radius, smooth, .. } => {
                    const MAX_SUBDIVISIONS: u32 = 9;
                    if *subdivisions > MAX_SUBDIVISIONS {
                        return Err(ctx(format!(
                            "subdivisions must be at most {MAX_SUBDIVISIONS}, got {subdivisions}"
                        )));
                    }
                    let c = vec3(*center, "center").map_err(ctx)?;
                    if !(*radius > 0.0 && radius.is_finite()) {
                        return Err(ctx(format!("radius must be positive, got {radius}")));
                    }
                    let mut mesh = crate::geometry::icosphere(*subdivisions);
                    if !*smooth {
                        mesh.normals.clear();
                    }
                    mesh.transform(glam::Affine3A::from_scale_rotation_translation(
                        Vec3::splat(*radius),
                        glam::Quat::IDENTITY,
                        c,
                    ));
                    shapes.push(Shape::Mesh(mesh));
                }
                ObjectSection::Mesh { file: f, smooth, translate, scale, rotate_deg, .. } => {
                    let p = resolve(base, f);
                    *f = p.to_string_lossy().into_owned();
                    let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
                    let mut mesh = match ext.as_str() {
                        "obj" => crate::geometry::obj::load_obj(&p, *smooth)?,
                        "gltf" | "glb" => crate::geometry::gltf::load_gltf(&p, *smooth)?,
                        _ => return Err(Error::file(&p, "mesh file must be .obj, .gltf or .glb")),
                    };
                    let t = vec3(*translate, "translate").map_err(ctx)?;
                    if !(*scale > 0.0 && scale.is_finite()) {
                        return Err(ctx(format!("scale must be positive, got {scale}")));
                    }
                    let m = glam::Affine3A::from_scale_rotation_translation(
                        Vec3::splat(*scale),
                        glam::Quat::from_mat3(&rotation_xyz_deg(*rotate_deg)),
                        t,
                    );
                    mesh.transform(m);
                    shapes.push(Shape::Mesh(mesh));
                }
            }
            if let Some(shape) = shapes.last() {
                shape.check_reach().map_err(ctx)?;
            }
            brdfs.push(brdf::build_brdf(obj.brdf()).map_err(ctx)?);
            textures.push(match obj.texture() {
                Some(super::file::TextureSection::Sh { coefficients }) => {
                    Some(crate::texture::ShTexture::new(coefficients).map_err(|e| ctx(format!("texture: {e}")))?)
                }
                None => None,
            });
        }

        timings.meshes_seconds = t_meshes.elapsed().as_secs_f64();
        check_primitive_count(shapes.iter().map(Shape::primitive_count).sum())?;
        // Camera.
        let (w, h) = (settings.width, settings.height);
        let first_sphere = match shapes.first() {
            Some(Shape::Sphere(s)) => Some(*s),
            _ => None,
        };
        let camera = build_camera(&file.camera, first_sphere, w, h).map_err(|m| Error::new(format!("camera: {m}")))?;

        // Lighting.
        let light = build_light(&mut file.lighting, base, &mut timings)?;
        let t_bvh = Instant::now();
        let geometry = SceneGeometry::new(shapes);
        timings.bvh_seconds = t_bvh.elapsed().as_secs_f64();
        Ok(Scene { settings, camera, light, geometry, brdfs, textures, description: file, path: None, timings })
    }
}

/// Refuses a scene of more primitives (triangles and spheres) than its BVH holds
/// ([`crate::geometry::bvh::MAX_PRIMITIVES`]).
fn check_primitive_count(count: usize) -> Result<()> {
    use crate::geometry::bvh::MAX_PRIMITIVES;
    if count > MAX_PRIMITIVES {
        return Err(Error::new(format!(
            "the scene has {count} primitives (triangles and spheres), more than the {MAX_PRIMITIVES} a scene may hold"
        )));
    }
    Ok(())
}

fn build_camera(
    c: &CameraSection,
    first_sphere: Option<Sphere>,
    w: u32,
    h: u32,
) -> std::result::Result<Camera, String> {
    Ok(match c {
        CameraSection::Orthographic { from, to, up, extent } => Camera::Orthographic(Orthographic::new(
            vec3(*from, "from")?,
            vec3(*to, "to")?,
            vec3(*up, "up")?,
            *extent,
            w,
            h,
        )?),
        CameraSection::Perspective { from, to, up, fov_deg } => Camera::Perspective(Perspective::new(
            vec3(*from, "from")?,
            vec3(*to, "to")?,
            vec3(*up, "up")?,
            *fov_deg,
            w,
            h,
        )?),
        CameraSection::NormalProbe { theta_o_deg, phi_o_deg, jitter } => {
            let s = first_sphere.ok_or("the normal-probe camera needs objects[0] to be a sphere")?;
            Camera::NormalProbe(NormalProbe::new(*theta_o_deg, *phi_o_deg, *jitter, s.center, s.radius, w, h)?)
        }
    })
}

/// The file `f` of the scene at `base`, as an absolute path: it is written into the render's header
/// (`reflect:lighting`, `reflect:objects`), which `analyze` and `invert` read from any directory, so
/// a path relative to the directory the render ran in would name the wrong file (or none). The
/// canonical path when the file exists; else the absolute, un-normalised one (the loader then names it).
/// The environment variable naming the data folder, searched for a relative data file that is not
/// where the scene file says (docs/src/reference/scene-files.md, "Where files are found").
pub const DATA_ENV: &str = "REFLECT_DATA";

/// A data file named in a scene: an absolute path as given; a relative one against the scene file's
/// folder, and when nothing is there, by its file name in the folder [`DATA_ENV`] names (so a scene
/// file copied elsewhere still finds `../../shared/data/grace_latlong.exr`). A file found nowhere
/// keeps the first path, which the reader's error then names.
fn resolve(base: &Path, f: &str) -> PathBuf {
    let p = Path::new(f);
    let mut joined = if p.is_absolute() { p.to_path_buf() } else { base.join(p) };
    if !p.is_absolute()
        && !joined.exists()
        && let (Some(dir), Some(name)) = (std::env::var_os(DATA_ENV).filter(|d| !d.is_empty()), p.file_name())
    {
        let candidate = Path::new(&dir).join(name);
        if candidate.is_file() {
            joined = candidate;
        }
    }
    joined.canonicalize().or_else(|_| std::path::absolute(&joined)).unwrap_or(joined)
}

fn vec3(v: [f32; 3], what: &str) -> std::result::Result<Vec3, String> {
    if v.iter().all(|x| x.is_finite()) { Ok(Vec3::from(v)) } else { Err(format!("{what} has a non-finite component")) }
}

/// A colour of the scene file, checked finite and non-negative (`what` names its key).
pub(crate) fn color(c: super::file::Color, what: &str) -> std::result::Result<Rgb, String> {
    let v = c.rgb();
    if v.iter().all(|x| x.is_finite() && *x >= 0.0) {
        Ok(Rgb::from(v))
    } else {
        Err(format!("{what} must be finite and non-negative, got {v:?}"))
    }
}

/// Builds the light of a `[lighting]` table (docs/src/conventions.md §6), data files relative to `base`;
/// errors name the key (`lighting: …`) or the data file. `timings` gets the map's read and table times.
pub fn build_light(l: &mut LightingSection, base: &Path, timings: &mut BuildTimings) -> Result<Light> {
    let t = Instant::now();
    let lerr = |m: String| Error::new(format!("lighting: {m}"));
    let light = match l {
        LightingSection::Uniform { radiance } => {
            Light::Uniform(light::Uniform::new(color(*radiance, "radiance").map_err(lerr)?))
        }
        LightingSection::Directional { direction, irradiance } => {
            let d = vec3(*direction, "direction").map_err(lerr)?;
            if d.length_squared() < 1e-12 {
                return Err(lerr("direction must be non-zero".into()));
            }
            Light::Directional(light::Directional::new(d, color(*irradiance, "irradiance").map_err(lerr)?))
        }
        LightingSection::Axial { axis, profile } => {
            let a = vec3(*axis, "axis").map_err(lerr)?;
            if a.length_squared() < 1e-12 {
                return Err(lerr("axis must be non-zero".into()));
            }
            if profile.is_empty() {
                return Err(lerr("axial profile is empty".into()));
            }
            let mut prev = -1.0;
            let mut table = Vec::with_capacity(profile.len());
            for row in profile.iter() {
                let [t, r, g, b] = *row;
                if !(t > prev && (0.0..=180.0).contains(&t)) {
                    return Err(lerr("axial profile angles must increase within [0, 180] degrees".into()));
                }
                prev = t;
                table
                    .push((t.to_radians(), color(super::file::Color::Rgb([r, g, b]), "axial radiance").map_err(lerr)?));
            }
            Light::Axial(light::Axial::try_new(a, table)?)
        }
        LightingSection::Sh { coefficients } => {
            if coefficients.iter().flatten().any(|v| !v.is_finite()) {
                return Err(lerr("SH coefficients must be finite".into()));
            }
            let c: Vec<Rgb> = coefficients.iter().map(|&v| Rgb::from(v)).collect();
            Light::Sh(light::ShLight::new(c).map_err(|e| lerr(e.message))?)
        }
        LightingSection::Envmap { file, mapping, scale, rotate_deg, layer } => {
            let p = resolve(base, file);
            *file = p.to_string_lossy().into_owned();
            if !(*scale >= 0.0 && scale.is_finite()) {
                return Err(lerr(format!("scale must be finite and non-negative, got {scale}")));
            }
            if rotate_deg.iter().any(|v| !v.is_finite()) {
                return Err(lerr("rotate_deg must be finite".into()));
            }
            if layer.as_deref().is_some_and(|l| l.trim().is_empty() || l.contains(char::is_control)) {
                return Err(lerr(format!("layer {layer:?} must name a layer or part (omit it for the beauty)")));
            }
            let img = vocab::image::read_rgb_layer(&p, layer.as_deref())?;
            timings.lighting_read_seconds = t.elapsed().as_secs_f64();
            let t = Instant::now();
            // An absent mapping is inferred from the aspect ratio, as the analysis does, and written
            // into the description (and so the header).
            let m = match *mapping {
                Some(m) => m,
                None => Mapping::infer(img.width, img.height).map_err(|e| e.in_file(&p))?,
            };
            *mapping = Some(m);
            let env = light::Envmap::new(img, m, *scale, rotation_xyz_deg(*rotate_deg)).map_err(|e| e.in_file(&p))?;
            timings.lighting_tables_seconds = t.elapsed().as_secs_f64();
            Light::Envmap(env)
        }
    };
    if timings.lighting_read_seconds == 0.0 {
        timings.lighting_tables_seconds = t.elapsed().as_secs_f64();
    }
    Ok(light)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;

    fn icosphere_scene(params: &str) -> Result<Scene> {
        let toml = format!(
            "[camera]\ntype = \"orthographic\"\nfrom = [0.0, -3.0, 0.0]\nto = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nextent = 1.0\n[lighting]\ntype = \"uniform\"\nradiance = 1.0\n[[objects]]\nshape = \"icosphere\"\n{params}\nbrdf = {{ type = \"lambert\", albedo = 0.5 }}\n"
        );
        Scene::build(SceneFile::parse(&toml).map_err(Error::new)?, Path::new("."))
    }

    /// The BVH's limit is checked before it is built: a count one past it is refused with a
    /// message naming the limit, the limit itself passes.
    #[test]
    fn primitive_count_beyond_the_bvh_is_refused() {
        use crate::geometry::bvh::MAX_PRIMITIVES;
        assert!(check_primitive_count(MAX_PRIMITIVES).is_ok());
        let e = check_primitive_count(MAX_PRIMITIVES + 1).unwrap_err().to_string();
        assert!(e.contains("536870913 primitives") && e.contains("536870912"), "{e}");
    }

    #[test]
    fn icosphere_shape_builds_and_refuses_bad_parameters() {
        let s = icosphere_scene("subdivisions = 2\ncenter = [1.0, 0.0, 0.0]\nradius = 2.0").unwrap();
        let Shape::Mesh(m) = &s.geometry.shapes[0] else { panic!("not a mesh") };
        assert_eq!(m.triangles.len(), 20 * 4 * 4);
        assert!(m.positions.iter().all(|p| ((*p - Vec3::X).length() - 2.0).abs() < 1e-5));
        assert!(m.normals.iter().zip(&m.positions).all(|(n, p)| (*n - (*p - Vec3::X) / 2.0).length() < 1e-5));
        let flat = icosphere_scene("subdivisions = 1\nsmooth = false").unwrap();
        let Shape::Mesh(m) = &flat.geometry.shapes[0] else { panic!("not a mesh") };
        assert!(m.normals.is_empty());
        for (bad, says) in [("subdivisions = 10", "at most 9"), ("subdivisions = 1\nradius = -1.0", "radius")] {
            let e = icosphere_scene(bad).err().expect(bad).to_string();
            assert!(e.contains("objects[0]") && e.contains(says), "{e}");
        }
    }
}
