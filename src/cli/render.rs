//! `reflect render [SCENE.toml] [--out FILE.exr] [--spp N] [--seed N] [--threads N] [--png FILE]`
//!
//! Renders a scene file (or the built-in default: a Lambertian sphere under a built-in sky) to a
//! float OpenEXR with the AOVs of guide "Output images", and prints the stats line (render-loop time,
//! samples/s, rays/s; see `RenderStats`), the load / render / save / whole-command times, and the
//! noise summary of the object's pixels (`renderer::noise`).

use super::Error;
use super::outputs::{Files, Format};
use renderer::progressive::{Finished, NoEstimate, Outcome, Stop};
use renderer::render::{RenderOptions, render};
use renderer::scene::{Scene, SceneFile, build::DEFAULT_SCENE};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(clap::Args, Debug, Clone, Default)]
pub struct RenderArgs {
    /// Scene file (TOML; guide "Scene files"). Without it, the built-in default scene.
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
    /// Also write a tone-mapped PNG preview here (see `reflect png`).
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Exposure of the --png preview in stops [default: the object's median luminance → 0.18].
    #[arg(long, allow_hyphen_values = true, requires = "png")]
    pub exposure: Option<f64>,
    /// Sampler (overrides render.sampler).
    #[arg(long, value_enum)]
    pub sampler: Option<vocab::Sampler>,
    /// Image width × height, e.g. 256x256 (overrides render.width/height).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Print nothing but errors.
    #[arg(long, short)]
    pub quiet: bool,
    /// Print the render's statistics as one JSON document on stdout.
    #[arg(long)]
    pub json: bool,
    /// Render only shard I of N (e.g. 0/4): the samples [I·spp/N, (I+1)·spp/N) of every pixel, written
    /// as a partial render for `reflect merge`.
    #[arg(long, value_parser = super::passes::parse_shard)]
    pub shard: Option<(u32, u32)>,
    /// Render only the samples [A, B) of every pixel (B ≤ spp; a round of a render in rounds), written
    /// as a partial render for `reflect merge`; with --shard I/N, shard I of N of them.
    #[arg(long, value_name = "A:B", value_parser = super::passes::parse_samples)]
    pub samples: Option<(u64, u64)>,
    /// Resume from FILE if it exists (refusing one of another scene), save progress to it atomically
    /// every --checkpoint-every seconds and on SIGINT/SIGTERM, and remove it after the final output.
    #[arg(long)]
    pub checkpoint: Option<PathBuf>,
    /// Seconds between checkpoint saves [default: 60].
    #[arg(long, requires = "checkpoint")]
    pub checkpoint_every: Option<f64>,
    /// Render in passes until the 95th percentile of the object pixels' relative standard error (worst
    /// channel) is at most X (e.g. 0.01); spp is then the most samples per pixel to take.
    #[arg(long)]
    pub target_rel_error: Option<f64>,
    /// Stop after the last pass that fits in SECS seconds of rendering (spp is then the most to take).
    #[arg(long)]
    pub time_limit: Option<f64>,
    /// Continue the render whose state FILE holds (written by --state, a --checkpoint file, or a
    /// --shard 0/N part) to --spp samples: the bits of rendering them all at once. FILE is only read.
    #[arg(long = "continue", value_name = "FILE")]
    pub continue_from: Option<PathBuf>,
    /// Also write the render's state (per-block sums, a partial render) to FILE, for a later --continue.
    #[arg(long, value_name = "FILE")]
    pub state: Option<PathBuf>,
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
    let t0 = std::time::Instant::now();
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
    let parse_seconds = t0.elapsed().as_secs_f64();
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
    scene.timings.parse_seconds = parse_seconds;
    Ok(scene)
}

/// Runs `f` on a rayon pool of `threads` workers (all cores when None).
pub fn with_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> Result<T, Error> {
    renderer::progressive::on_threads(threads, f).map_err(super::passes::cli_error)
}

/// The scene file and the files it reads (environment maps, meshes), for the check of the outputs;
/// a scene that cannot be read or parsed adds only itself (loading it then says why).
pub fn scene_inputs(scene: Option<&Path>) -> Files {
    let Some(p) = scene else { return Files::new() };
    let files = Files::new().input("the scene", p);
    let Some(d) = std::fs::read_to_string(p).ok().and_then(|t| SceneFile::parse(&t).ok()) else { return files };
    let base = p.parent().map(Path::to_path_buf).unwrap_or_default();
    let read = renderer::shard::referenced_files(&d).into_iter().map(|f| base.join(f));
    files.inputs("the scene's file", read)
}

/// The outputs of `reflect render` (`--out`, `--png`, `--checkpoint`) against each other and its
/// inputs (see [`super::outputs`]).
fn check_files(a: &RenderArgs, out: &Path) -> Result<(), Error> {
    let mut files = scene_inputs(a.scene.as_deref()).output("--out", out, Format::Exr);
    if let Some(p) = &a.png {
        files = files.output("--png", p, Format::Png);
    }
    if let Some(p) = &a.checkpoint {
        files = files.output("--checkpoint", p, Format::Exr);
    }
    if let Some(p) = &a.continue_from {
        files = files.input("--continue", p);
    }
    if let Some(p) = &a.state {
        files = files.output("--state", p, Format::Exr);
    }
    files.check()
}

pub fn run(a: RenderArgs) -> Result<ExitCode, Error> {
    let t_start = std::time::Instant::now();
    let stem = a
        .scene
        .as_ref()
        .and_then(|p| p.file_stem())
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "default".into());
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("out").join(format!("{stem}.exr")));
    check_files(&a, &out)?;
    // On the render's pool: decoding the map and building its sampling tables use `--threads` too.
    let mut scene = with_threads(a.threads, || load_scene(&a))??;
    let t_load = t_start.elapsed();
    if let Some(ev) = a.exposure.filter(|e| !e.is_finite() || e.abs() > 100.0) {
        return Err(Error::new(format!("--exposure must be finite and within ±100 stops, got {ev}")));
    }
    let flag = if a.samples.is_some() { "--samples" } else { "--shard" };
    let part = a.shard.is_some() || a.samples.is_some();
    if part && (a.target_rel_error.is_some() || a.time_limit.is_some() || a.png.is_some()) {
        return Err(Error::new(format!(
            "{flag} renders a partial render: it takes no --target-rel-error, --time-limit or --png \
             (to a target error across shards: reflect slurm render --target-rel-error, guide \"Scale-out: shards, merge, checkpoints, target error, continuing, Slurm\")"
        )));
    }
    if part && (a.continue_from.is_some() || a.state.is_some()) {
        return Err(Error::new(format!(
            "{flag} writes a partial render (itself a state): it takes no --continue or --state"
        )));
    }
    for (name, v) in [
        ("--target-rel-error", a.target_rel_error),
        ("--time-limit", a.time_limit),
        ("--checkpoint-every", a.checkpoint_every),
    ] {
        if let Some(v) = v.filter(|v| !v.is_finite() || *v < 0.0 || (*v == 0.0 && name != "--checkpoint-every")) {
            return Err(Error::new(format!("{name} must be a positive number, got {v}")));
        }
    }
    // The state to continue, checked against the scene before anything is rendered or printed.
    let initial = a.continue_from.as_ref().map(|p| super::passes::read_continue(p, &scene)).transpose()?;
    let s = scene.settings.clone();
    let whole = a.samples.unwrap_or((0, s.spp as u64));
    if whole.1 > s.spp as u64 {
        return Err(Error::new(format!(
            "--samples {}:{} ends beyond the render's {} spp (give --spp at least {})",
            whole.0, whole.1, s.spp, whole.1
        )));
    }
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
    let range = a.shard.map_or(whole, |(i, n)| renderer::progressive::split_range(i, n, whole));
    let progressive = a.target_rel_error.is_some() || a.time_limit.is_some();
    let plain = !part && a.checkpoint.is_none() && !progressive && a.continue_from.is_none() && a.state.is_none();
    let mut progressive_report = None;
    let mut final_state = None;
    let (film, stats) = if plain {
        let opts = RenderOptions { progress: !a.quiet, ..Default::default() };
        with_threads(a.threads, || render(&scene, &opts))?
    } else {
        if let (Some(p), Some(st)) = (&a.continue_from, &initial)
            && !a.quiet
        {
            eprintln!("continuing {} from sample {} to {}", p.display(), st.end, s.spp);
        }
        let attrs = renderer::output::header_attributes(&scene);
        match super::passes::run_passes(&scene, &a, range, initial, &attrs)? {
            Outcome::Cancelled { state } => {
                let ck = a.checkpoint.as_ref().map(|p| p.display().to_string()).unwrap_or_default();
                eprintln!(
                    "interrupted: {ck} holds samples [{}, {}) of [{}, {}); run the same command to resume",
                    range.0, state.end, range.0, range.1
                );
                return Ok(ExitCode::from(130));
            }
            Outcome::Done(Finished { mut state, stats, passes, stop, rel_error }) => {
                if part {
                    let header = renderer::shard::partial_header(&scene, &state);
                    renderer::shard::write_partial(&out, &state, &header, &attrs)?;
                    if let Some(ck) = &a.checkpoint {
                        let _ = std::fs::remove_file(ck);
                    }
                    if !a.quiet {
                        eprintln!(
                            "wrote {} (partial render: samples [{}, {}) of {}): {stats}",
                            out.display(),
                            range.0,
                            range.1,
                            s.spp
                        );
                    }
                    return Ok(ExitCode::SUCCESS);
                }
                if progressive {
                    // The image is a plain render of the samples taken: spp = what was reached.
                    let n = state.end as u32;
                    state.spp = n;
                    scene.settings.spp = n;
                    scene.description.render.spp = n;
                    let rel_error = rel_error.unwrap_or(Err(NoEstimate::OneSample));
                    // As the target measures it (flagged pixels infinite): not the noise summary's p95.
                    let mut e = super::passes::percent(rel_error);
                    if rel_error.is_ok() {
                        e.push_str(" (flagged pixels counted as infinite)");
                    }
                    let note = match (stop, a.target_rel_error, a.time_limit) {
                        (Stop::Target, Some(x), _) => {
                            format!("reached: 95th-percentile relative stderr {e} ≤ {:.4} %", 100.0 * x)
                        }
                        (Stop::TimeLimit, _, Some(t)) => {
                            format!("time limit of {t} s reached; 95th-percentile relative stderr {e}")
                        }
                        _ => format!("all {} spp rendered; 95th-percentile relative stderr {e}", s.spp),
                    };
                    if !a.quiet {
                        eprintln!("progressive: {n} spp in {passes} passes; {note}");
                    }
                    progressive_report = Some(ProgressiveReport {
                        target_rel_error: a.target_rel_error,
                        time_limit_seconds: a.time_limit,
                        spp_cap: s.spp,
                        passes,
                        stopped_by: stop.name().to_string(),
                        target_reached: a.target_rel_error.map(|_| stop == Stop::Target),
                        rel_error_p95: rel_error.ok(),
                        rel_error_unknown: rel_error.err().map(|w| w.why().to_string()),
                    });
                }
                let film = state.finish();
                final_state = Some(state);
                (film, stats)
            }
        }
    };
    let t_save = std::time::Instant::now();
    // Both outputs are staged before either is moved into place: a PNG that cannot be written
    // leaves no EXR behind (and no temporary file).
    let exr = renderer::output::stage_exr(&out, &film, &renderer::output::header_attributes(&scene))?;
    let ev = a.exposure.unwrap_or_else(|| {
        let px: Vec<[f32; 3]> = film.pixels.iter().map(|p| p.rgb).collect();
        let mask: Vec<f32> = film.pixels.iter().map(|p| p.mask).collect();
        renderer::output::auto_exposure(&px, Some(&mask)).unwrap_or(0.0)
    });
    let png = a.png.as_ref().map(|p| renderer::output::stage_png(p, &film, ev)).transpose()?;
    if let (Some(p), Some(state)) = (&a.state, &final_state) {
        // Written (atomically) before the image is moved into place: a state that cannot be written
        // leaves no image behind.
        let header = renderer::shard::partial_header(&scene, state);
        renderer::shard::write_partial(p, state, &header, &renderer::output::header_attributes(&scene))?;
    }
    exr.commit()?;
    if let Some(ck) = &a.checkpoint {
        // The final image is in place: the checkpoint has served.
        let _ = std::fs::remove_file(ck);
    }
    if let Some(png) = png
        && let Err(e) = png.commit()
    {
        let _ = std::fs::remove_file(&out);
        return Err(e);
    }
    if let Some(p) = a.state.as_ref().filter(|_| !a.quiet) {
        eprintln!("wrote {} (the render's state, for --continue)", p.display());
    }
    let t_save = t_save.elapsed();
    let report = RenderReport {
        scene: scene.path.as_ref().map(|p| p.display().to_string()),
        output: out.display().to_string(),
        png: a.png.as_ref().map(|p| PngReport {
            file: p.display().to_string(),
            exposure_ev: ev,
            automatic: a.exposure.is_none(),
        }),
        width: s.width,
        height: s.height,
        // The spp reached (a render to a target error or time limit stops at or below the cap).
        spp: scene.settings.spp,
        seed: s.seed,
        threads: stats.threads,
        samples: stats.samples,
        samples_per_sec: stats.samples_per_sec(),
        rays: stats.rays,
        rays_per_sec: stats.rays_per_sec(),
        load_seconds: t_load.as_secs_f64(),
        load_phases: scene.timings,
        render_seconds: stats.wall.as_secs_f64(),
        save_seconds: t_save.as_secs_f64(),
        total_seconds: t_start.elapsed().as_secs_f64(),
        peak_rss_mb: peak_rss_mb(),
        // One sample per pixel has no spread: no error estimate (the stderr layer is +inf).
        noise: if scene.settings.spp >= 2 { renderer::noise::summarize(&film) } else { None },
        unreliable_pixels: film.unreliable_count(),
        progressive: progressive_report,
    };
    if a.json {
        println!("{}", serde_json::to_string(&report).map_err(|e| Error::new(format!("JSON: {e}")))?);
    }
    if !a.quiet {
        eprint!("{report}");
    }
    Ok(ExitCode::SUCCESS)
}

/// The output of `reflect render` (`--json` prints it on stdout; `Display` is the text on stderr).
/// samples = pixels × spp (misses included), rays = rays traced (skipped shadow rays not counted),
/// both per second of the render loop alone (`render_seconds`: loading and saving excluded).
#[derive(Clone, Debug, serde::Serialize, PartialEq)]
pub struct RenderReport {
    /// The scene file (null for the built-in default scene).
    pub scene: Option<String>,
    /// The OpenEXR file written.
    pub output: String,
    /// The PNG preview written, if any.
    pub png: Option<PngReport>,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel of the image written: with `--target-rel-error` / `--time-limit` the spp
    /// reached (the cap is `progressive.spp_cap`).
    pub spp: u32,
    pub seed: u64,
    /// Worker threads of the render loop.
    pub threads: usize,
    /// Camera samples taken (pixels × spp, misses included).
    pub samples: u64,
    pub samples_per_sec: f64,
    /// Rays traced (camera, shadow and bounce rays; skipped shadow rays not counted).
    pub rays: u64,
    pub rays_per_sec: f64,
    /// Scene, meshes and environment tables, seconds.
    pub load_seconds: f64,
    /// The load's phases: parse, meshes, BVH build, map reading, lighting tables, seconds.
    pub load_phases: renderer::scene::BuildTimings,
    /// The render loop, seconds (the time the rates divide by).
    pub render_seconds: f64,
    /// Writing the EXR (and PNG), seconds.
    pub save_seconds: f64,
    /// The whole command, seconds.
    pub total_seconds: f64,
    /// The process's peak resident memory so far, MB (10⁶ bytes): map, BVH, film and all (Linux's
    /// `VmHWM`; null where the system does not say).
    pub peak_rss_mb: Option<f64>,
    /// Relative standard error of the object's pixels (null when no object pixel is > 0, and at
    /// 1 spp, where one sample per pixel has no spread to estimate an error from).
    pub noise: Option<renderer::noise::NoiseSummary>,
    /// Pixels whose error bar is unreliable (`stderr_flag.Y` = 1: one rare sample dominates).
    pub unreliable_pixels: usize,
    /// How a render to a target error or a time limit went (null for other renders).
    pub progressive: Option<ProgressiveReport>,
}

/// A render in passes to `--target-rel-error` and/or `--time-limit` (see `cli::passes`).
#[derive(Clone, Debug, serde::Serialize, PartialEq)]
pub struct ProgressiveReport {
    /// The relative standard error asked (`--target-rel-error`; null without one).
    pub target_rel_error: Option<f64>,
    /// `--time-limit` in seconds (null without one).
    pub time_limit_seconds: Option<f64>,
    /// The most samples per pixel allowed (the scene's spp, or `--spp`).
    pub spp_cap: u32,
    /// Passes rendered by this command (a resumed checkpoint's earlier passes not counted).
    pub passes: u32,
    /// Why it stopped: "target", "time-limit" or "spp-cap".
    pub stopped_by: String,
    /// Whether the target was reached (null without `--target-rel-error`).
    pub target_reached: Option<bool>,
    /// The error reached, as the target measures it: the 95th percentile over the object's pixels of the
    /// worst channel's stderr / value, flagged pixels (`stderr_flag.Y` = 1) counting as infinite; null
    /// where there is no estimate (`rel_error_unknown` says why).
    pub rel_error_p95: Option<f64>,
    /// Why `rel_error_p95` is null: one sample per pixel (no spread), no object pixel > 0, or more
    /// than 5 % of the object's pixels flagged; null when there is an estimate.
    pub rel_error_unknown: Option<String>,
}

/// The peak resident set size of this process in MB (10⁶ bytes), from `VmHWM` in
/// `/proc/self/status` (Linux); `None` elsewhere or if it cannot be read. `VmHWM` belongs to the
/// address space this process got at `exec`, so, unlike the `ru_maxrss` a parent reads from
/// `wait4`, it does not include the memory of a large process that spawned it (Linux keeps the
/// pre-`exec` peak in `ru_maxrss`).
fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.trim_start_matches("VmHWM:").trim().trim_end_matches("kB").trim().parse().ok()?;
    Some(kib * 1024.0 / 1e6)
}

/// The PNG preview of a render.
#[derive(Clone, Debug, serde::Serialize, PartialEq)]
pub struct PngReport {
    pub file: String,
    /// Exposure applied before the tone curve x/(1+x), in stops (EV).
    pub exposure_ev: f64,
    /// True when chosen automatically (the object's median → 0.18), false when set by `--exposure`.
    pub automatic: bool,
}

impl std::fmt::Display for RenderReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(p) = &self.png {
            let how = if p.automatic { "automatic: object's median → 0.18" } else { "set by --exposure" };
            writeln!(f, "wrote {}: exposure {:+.2} EV ({how}), tone curve x/(1+x), sRGB", p.file, p.exposure_ev)?;
        }
        writeln!(f, "wrote {}", self.output)?;
        let stats = renderer::render::RenderStats {
            wall: std::time::Duration::from_secs_f64(self.render_seconds),
            samples: self.samples,
            rays: self.rays,
            threads: self.threads,
            // `reflect render` never cancels its render.
            cancelled: false,
        };
        writeln!(f, "{stats}")?;
        write!(
            f,
            "time: load {:.3} s (scene, meshes, environment tables), render loop {:.3} s, save {:.3} s; whole command {:.3} s",
            self.load_seconds, self.render_seconds, self.save_seconds, self.total_seconds
        )?;
        match self.peak_rss_mb {
            Some(mb) => writeln!(f, "; peak memory {mb:.0} MB")?,
            None => writeln!(f)?,
        }
        match &self.noise {
            Some(n) => writeln!(f, "{n}")?,
            None if self.spp < 2 => writeln!(
                f,
                "noise: no error estimate at 1 spp (one sample per pixel has no spread, the stderr layer is +inf, unknown; \
                 render at 2 spp or more for error bars)"
            )?,
            None => writeln!(f, "noise: no object pixel with a value > 0 (nothing hit, or a black object)")?,
        }
        if self.unreliable_pixels > 0 {
            writeln!(
                f,
                "{} pixels have an unreliable error bar (stderr_flag.Y = 1: one rare sample dominates)",
                self.unreliable_pixels
            )?;
        }
        Ok(())
    }
}
