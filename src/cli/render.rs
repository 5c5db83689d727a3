//! `reflect render [SCENE.toml] [--out FILE.exr] [--spp N] [--seed N] [--threads N] [--png FILE]`
//!
//! Renders a scene file (or the built-in default: a Lambertian sphere under a built-in sky) to a
//! float OpenEXR with the AOVs of CONVENTIONS §5, and prints wall time, samples/s and rays/s.

use super::Error;
use renderer::render::{RenderOptions, render};
use renderer::scene::{Scene, SceneFile, build::DEFAULT_SCENE};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(clap::Args, Debug, Clone, Default)]
pub struct RenderArgs {
    /// Scene file (TOML, CONVENTIONS §6). Without it, the built-in default scene.
    pub scene: Option<PathBuf>,
    /// Output OpenEXR file [default: out/SCENE_NAME.exr].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Samples per pixel (overrides render.spp).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Random seed (overrides render.seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Worker threads [default: all cores]. The image does not depend on it.
    #[arg(long, value_parser = parse_threads)]
    pub threads: Option<usize>,
    /// Also write a tone-mapped PNG preview here.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Sampler (overrides render.sampler).
    #[arg(long, value_enum)]
    pub sampler: Option<vocab::Sampler>,
    /// Image width × height, e.g. 256x256 (overrides render.width/height).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Print nothing but errors.
    #[arg(long, short)]
    pub quiet: bool,
}

/// `--threads N`: at least 1, refused while parsing the arguments (before any work or output).
pub fn parse_threads(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(0) => Err("must be at least 1".into()),
        Ok(n) => Ok(n),
        Err(_) => Err("expected a positive integer".into()),
    }
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or("expected WIDTHxHEIGHT")?;
    Ok((w.trim().parse().map_err(|_| "bad width")?, h.trim().parse().map_err(|_| "bad height")?))
}

/// Parses a scene file (or the default scene) and applies command-line overrides.
pub fn load_scene(a: &RenderArgs) -> Result<Scene, Error> {
    let (text, base, path) = match &a.scene {
        Some(p) => {
            let text =
                std::fs::read_to_string(p).map_err(|e| Error::file(p, format!("cannot read scene file: {e}")))?;
            (text, p.parent().map(Path::to_path_buf).unwrap_or_default(), Some(p.clone()))
        }
        None => (DEFAULT_SCENE.to_string(), PathBuf::from("."), None),
    };
    let mut file = SceneFile::parse(&text).map_err(|m| match &path {
        Some(p) => Error::file(p, m),
        None => Error::new(m),
    })?;
    if let Some(s) = a.spp {
        file.render.spp = s;
    }
    if let Some(s) = a.seed {
        file.render.seed = s;
    }
    if let Some(s) = a.sampler {
        file.render.sampler = s;
    }
    if let Some((w, h)) = a.size {
        file.render.width = w;
        file.render.height = h;
    }
    let mut scene = Scene::build(file, &base).map_err(|e| match &path {
        Some(p) => e.in_file(p),
        None => e,
    })?;
    scene.path = path;
    Ok(scene)
}

/// Runs `f` on a rayon pool of `threads` workers (all cores when None).
pub fn with_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> Result<T, Error> {
    match threads {
        None => Ok(f()),
        Some(0) => Err(Error::new("--threads must be at least 1")),
        Some(n) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| Error::new(format!("cannot start {n} threads: {e}")))?;
            Ok(pool.install(f))
        }
    }
}

pub fn run(a: RenderArgs) -> Result<ExitCode, Error> {
    let scene = load_scene(&a)?;
    let stem = a
        .scene
        .as_ref()
        .and_then(|p| p.file_stem())
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "default".into());
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("out").join(format!("{stem}.exr")));
    if out.extension().and_then(|e| e.to_str()).map(|e| e.eq_ignore_ascii_case("exr")) != Some(true) {
        return Err(Error::file(&out, "output file must end in .exr"));
    }
    let s = &scene.settings;
    if !a.quiet {
        eprintln!(
            "rendering {} ({}×{}, {} spp, max_depth {}, seed {})",
            scene.path.as_ref().map(|p| p.display().to_string()).unwrap_or_else(|| "built-in default scene".into()),
            s.width,
            s.height,
            s.spp,
            s.max_depth,
            s.seed
        );
    }
    let opts = RenderOptions { progress: !a.quiet };
    let (film, stats) = with_threads(a.threads, || render(&scene, &opts))?;
    // Both outputs are staged before either is moved into place: a PNG that cannot be written
    // leaves no EXR behind (and no temporary file).
    let exr = renderer::output::stage_exr(&out, &film, &renderer::output::header_attributes(&scene))?;
    let png = a.png.as_ref().map(|p| renderer::output::stage_png(p, &film, 1.0)).transpose()?;
    exr.commit()?;
    if let Some(png) = png
        && let Err(e) = png.commit()
    {
        let _ = std::fs::remove_file(&out);
        return Err(e);
    }
    if !a.quiet {
        eprintln!("wrote {}: {stats}", out.display());
    }
    Ok(ExitCode::SUCCESS)
}
