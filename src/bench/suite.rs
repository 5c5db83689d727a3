//! The scenes of `reflect bench`: every BRDF of the paper under measured lighting, one analytic
//! light, and a large mesh. All share the peer benchmarks' camera (docs/src/reference/bench.md):
//! an orthographic view of the unit sphere from 5·normalize(1, 0, 0.3), extent 1.05, one bounce
//! (`max_depth = 1`), the map visible behind.

/// One benchmark scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BenchScene {
    /// Name on the command line and in the table.
    pub name: &'static str,
    /// The object: `sphere` or a 1.31M-triangle icosphere.
    pub mesh: bool,
    /// The `brdf = { … }` inline table.
    pub brdf: &'static str,
    /// The `[lighting]` table's body; `{DATA}` stands for the data folder.
    pub lighting: &'static str,
    /// In `--quick`.
    pub quick: bool,
    /// The scene Mitsuba 3 renders for the peer columns (`benches/peers/mitsuba_worker.py`), if any.
    pub mitsuba: Option<&'static str>,
}

const GRACE: &str = "type = \"envmap\"\nfile = \"{DATA}/grace_latlong.exr\"\nmapping = \"latlong\"";
const SKY: &str = "type = \"envmap\"\nfile = \"{DATA}/sky_latlong.exr\"\nmapping = \"latlong\"";

/// The suite, in the order of the table.
pub const SUITE: &[BenchScene] = &[
    BenchScene {
        name: "lambert-grace",
        mesh: false,
        brdf: "{ type = \"lambert\", albedo = 0.8 }",
        lighting: GRACE,
        quick: true,
        mitsuba: Some("lambert-grace"),
    },
    BenchScene {
        name: "beckmann-grace",
        mesh: false,
        brdf: "{ type = \"microfacet\", distribution = \"beckmann\", alpha = 0.2, fresnel = \"none\" }",
        lighting: GRACE,
        quick: true,
        mitsuba: Some("beckmann-grace"),
    },
    BenchScene {
        name: "ggx-grace",
        mesh: false,
        brdf: "{ type = \"microfacet\", distribution = \"ggx\", alpha = 0.2, fresnel = \"none\" }",
        lighting: GRACE,
        quick: false,
        mitsuba: None,
    },
    BenchScene {
        name: "phong-grace",
        mesh: false,
        brdf: "{ type = \"phong\", ks = 1.0, s = 32.0 }",
        lighting: GRACE,
        quick: false,
        mitsuba: None,
    },
    BenchScene {
        name: "torrance-sparrow-grace",
        mesh: false,
        brdf: "{ type = \"torrance-sparrow\", ks = 1.0, sigma = 0.1 }",
        lighting: GRACE,
        quick: false,
        mitsuba: None,
    },
    BenchScene {
        name: "mirror-grace",
        mesh: false,
        brdf: "{ type = \"mirror\", kr = 1.0 }",
        lighting: GRACE,
        quick: false,
        mitsuba: None,
    },
    BenchScene {
        name: "lambert-directional",
        mesh: false,
        brdf: "{ type = \"lambert\", albedo = 0.8 }",
        lighting: "type = \"directional\"\ndirection = [1.0, -1.0, 1.5]\nirradiance = 3.0",
        quick: false,
        mitsuba: None,
    },
    BenchScene {
        name: "mesh-sky",
        mesh: true,
        brdf: "{ type = \"lambert\", albedo = 0.8 }",
        lighting: SKY,
        quick: true,
        mitsuba: Some("mesh-sky"),
    },
];

/// The scenes a run takes: `names` (comma-separated) if given, else the quick set or all.
pub fn select(names: Option<&str>, quick: bool) -> Result<Vec<&'static BenchScene>, String> {
    match names {
        None => Ok(SUITE.iter().filter(|s| s.quick || !quick).collect()),
        Some(list) => list
            .split(',')
            .map(str::trim)
            .filter(|n| !n.is_empty())
            .map(|n| {
                SUITE.iter().find(|s| s.name == n).ok_or_else(|| {
                    format!(
                        "unknown bench scene '{n}'; known: {}",
                        SUITE.iter().map(|s| s.name).collect::<Vec<_>>().join(", ")
                    )
                })
            })
            .collect(),
    }
}

impl BenchScene {
    /// The scene file's text at `size`² pixels and `spp`, reading maps from `data`.
    pub fn toml(&self, data: &std::path::Path, size: u32, spp: u32) -> String {
        let object = if self.mesh {
            "shape = \"icosphere\"\nsubdivisions = 8\n"
        } else {
            "shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n"
        };
        // A TOML basic string holds the folder: backslashes and quotes escaped.
        let data = data.display().to_string().replace('\\', "\\\\").replace('"', "\\\"");
        format!(
            "[render]\nwidth = {size}\nheight = {size}\nspp = {spp}\nseed = 0\nmax_depth = 1\n\n\
             [camera]\ntype = \"orthographic\"\nfrom = [4.789131426105757, 0.0, 1.436739427831727]\n\
             to = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nextent = 1.05\n\n\
             [lighting]\n{}\n\n[[objects]]\n{object}brdf = {}\n",
            self.lighting.replace("{DATA}", &data),
            self.brdf
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_scene_parses_and_the_selection_refuses_unknown_names() {
        for s in SUITE {
            let text = s.toml(std::path::Path::new("/data"), 16, 4);
            renderer::scene::SceneFile::parse(&text).unwrap_or_else(|e| panic!("{}: {e}\n{text}", s.name));
        }
        let quick: Vec<_> = select(None, true).unwrap().iter().map(|s| s.name).collect();
        assert_eq!(quick, ["lambert-grace", "beckmann-grace", "mesh-sky"]);
        assert_eq!(select(None, false).unwrap().len(), SUITE.len());
        assert!(select(Some("lambert-grace,nope"), false).unwrap_err().contains("'nope'"));
    }
}
