//! `reflect bench`: a fair benchmark of the renderer on the paper's scenes, alone or beside its
//! peers (docs/src/reference/bench.md).
//!
//! Fair means: **time to equal error**, not time at equal spp (samplers differ in how much error a
//! sample removes); every measurement of ours in a **fresh process** (nothing warm but the OS's file
//! cache), with the per-phase times of that process; the **spread** over seeds; and the host, the
//! build and the load beside every figure ([`host::Fingerprint`]).
//!
//! Per scene: a reference render (independent sampler, calibrated error bars, many spp) of the
//! suite's camera at `size`², cached in the work folder; then, for each seed, a ladder of renders
//! at increasing spp, each compared with the reference ([`convergence::Reference::rms_rel_error`]),
//! and the samples per pixel that reach the target error ([`convergence::SamplesToTarget`]: between
//! the two rungs that bracket it, else extrapolated with a power law), which the sample rate of the
//! ladder's longest render turns into the time to the target. Peers (Mitsuba 3 where its Python
//! package imports) render the same scenes through `benches/peers/mitsuba_worker.py` in the same run, series by series alternated
//! with ours, and are judged against the same reference.

pub mod convergence;
pub mod host;
pub mod peers;
pub mod suite;

use convergence::{Reference, SamplesToTarget};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;
use suite::BenchScene;

/// Our series, one per sampler: `sobol` (the default, 16 replicates: calibrated error bars),
/// `sobol-single` (one sequence per pixel, no replicates: conservative error bars; the fair row
/// against Mitsuba's `ldsampler`, which has no error bars at all) and `independent`.
const OUR_SAMPLERS: [&str; 3] = ["sobol", "sobol-single", "independent"];

/// What one run measures.
#[derive(Clone, Debug)]
pub struct BenchParams {
    pub scenes: Vec<&'static BenchScene>,
    /// Image side, pixels.
    pub size: u32,
    /// The target RMS relative error (0.01 = 1 %).
    pub target: f64,
    /// Seeds per series (the spread is over these).
    pub seeds: u32,
    /// The ladder of spp of every series.
    pub ladder: Vec<u32>,
    /// spp of the reference render.
    pub reference_spp: u32,
    /// Worker threads of every render.
    pub threads: usize,
    /// The folder of references, renders and the report.
    pub work: PathBuf,
    /// The data folder (grace_latlong.exr, sky_latlong.exr).
    pub data: PathBuf,
    /// The `reflect` executable that renders (this one).
    pub exe: PathBuf,
    /// Peers to run beside ours.
    pub peers: peers::PeerChoice,
}

/// Why a bench run failed (bad input or a render that did not run).
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error("{0}: {1}")]
    File(PathBuf, String),
    #[error("a benchmark render failed ({0}): {1}")]
    Render(String, String),
    #[error("{0}: {1}")]
    Convergence(PathBuf, convergence::ConvergenceError),
    #[error("{0}")]
    Peer(String),
}

/// Median, least and largest of a set of measurements.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct Spread {
    pub median: f64,
    pub min: f64,
    pub max: f64,
    pub n: usize,
}

impl Spread {
    pub fn of(values: &[f64]) -> Option<Spread> {
        let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let median = if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) };
        Some(Spread { median, min: v[0], max: v[n - 1], n })
    }
}

/// One render of a series: its spp, times and error against the reference.
#[derive(Clone, Debug, Serialize)]
pub struct Point {
    pub seed: u64,
    pub spp: u32,
    /// The render loop alone, seconds (the time the rates and the time to error use).
    pub render_seconds: f64,
    /// The whole process (ours) or the render call (a warm peer), seconds.
    pub total_seconds: f64,
    pub rms_rel_error: f64,
}

/// The load phases of our fresh processes, seconds (medians over the series' processes).
#[derive(Clone, Debug, Serialize)]
pub struct Phases {
    pub parse: f64,
    pub meshes: f64,
    pub bvh: f64,
    pub lighting_read: f64,
    pub lighting_tables: f64,
    pub render: f64,
    pub write: f64,
    /// The first process of the scene (cold file cache for the map and mesh) and the others.
    pub load_cold: f64,
    pub load_warm: f64,
}

/// A renderer with one sampler on one scene: the ladder for every seed and what follows from it.
#[derive(Clone, Debug, Serialize)]
pub struct Series {
    /// "reflect" or a peer's name.
    pub renderer: String,
    pub sampler: String,
    pub points: Vec<Point>,
    /// Time of the render loop to reach the target error, seconds, over seeds: `target_spp` times
    /// the seed's render time per spp at the ladder's top (null when no seed's errors fall with
    /// spp above the reference's noise).
    pub time_to_target: Option<Spread>,
    /// Samples per pixel that reach the target error, over seeds.
    pub target_spp: Option<Spread>,
    /// Some seed's `target_spp` lies beyond the ladder's resolvable rungs (extrapolated with the
    /// power law fitted through its rungs, not interpolated between two of them).
    pub extrapolated: bool,
    /// Convergence exponent b of e = a·n^(−b) (n: spp), over seeds.
    pub exponent: Option<Spread>,
    /// Camera samples (pixels × spp) per second of the render loop, at the ladder's top.
    pub samples_per_sec: Option<Spread>,
    /// Rays (camera, shadow, bounce) per second of the render loop, at the ladder's top (ours only).
    pub rays_per_sec: Option<Spread>,
    pub phases: Option<Phases>,
    /// Largest peak resident memory of the series' processes, MB (10⁶ bytes).
    pub peak_rss_mb: Option<f64>,
    /// A peer's first render in its process (JIT compilation included), seconds.
    pub cold_render_seconds: Option<f64>,
}

/// One scene's results.
#[derive(Clone, Debug, Serialize)]
pub struct SceneResult {
    pub name: String,
    pub size: u32,
    pub reference_spp: u32,
    /// The reference's own RMS relative noise (subtracted from every error).
    pub reference_noise: f64,
    /// The least error the reference resolves; smaller errors are left out of the fits.
    pub min_measurable_error: f64,
    /// Object pixels compared.
    pub pixels: usize,
    pub series: Vec<Series>,
}

/// The JSON document of `reflect bench --json`.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub host: host::Fingerprint,
    pub target_rel_error: f64,
    pub size: u32,
    pub ladder: Vec<u32>,
    pub seeds: u32,
    pub peers: Vec<String>,
    /// Why a peer was not run (not installed, timed out), one line each.
    pub notes: Vec<String>,
    pub scenes: Vec<SceneResult>,
    pub wall_seconds: f64,
}

/// What one `reflect render --json` process reported, with the error of its image.
struct OurRun {
    doc: serde_json::Value,
    error: f64,
}

fn num(v: &serde_json::Value, k: &str) -> f64 {
    v[k].as_f64().unwrap_or(f64::NAN)
}

/// Renders `scene_file` in a fresh `reflect render` process; the image is compared with
/// `reference` (when given) and deleted.
fn render_ours(
    p: &BenchParams,
    scene_file: &Path,
    seed: u64,
    spp: u32,
    sampler: &str,
    out: &Path,
    reference: Option<&Reference>,
) -> Result<OurRun, BenchError> {
    let what = format!("{} seed {seed}, {spp} spp, {sampler}", scene_file.display());
    let o = Command::new(&p.exe)
        .arg("render")
        .arg(scene_file)
        .args(["--seed", &seed.to_string(), "--spp", &spp.to_string(), "--sampler", sampler])
        .args(["--threads", &p.threads.to_string(), "--json", "--quiet", "--out"])
        .arg(out)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| BenchError::Render(what.clone(), e.to_string()))?;
    if !o.status.success() {
        return Err(BenchError::Render(what, String::from_utf8_lossy(&o.stderr).trim().to_string()));
    }
    let doc: serde_json::Value =
        serde_json::from_slice(&o.stdout).map_err(|e| BenchError::Render(what.clone(), format!("JSON: {e}")))?;
    let error = match reference {
        Some(r) => {
            let img = vocab::image::read_image(out).map_err(|e| BenchError::File(out.to_path_buf(), e.to_string()))?;
            let e = r.rms_rel_error(&img).map_err(|e| BenchError::Convergence(out.to_path_buf(), e))?;
            let _ = std::fs::remove_file(out);
            e
        }
        None => f64::NAN,
    };
    Ok(OurRun { doc, error })
}

/// The cache key of a reference: the first 8 bytes of the SHA-256 of the scene's text and the
/// build's version string.
fn reference_key(scene_text: &str, version: &str) -> u64 {
    use sha2::{Digest, Sha256};
    let digest = Sha256::new().chain_update(scene_text).chain_update([0]).chain_update(version).finalize();
    let mut first = [0u8; 8];
    first.copy_from_slice(&digest[..8]);
    u64::from_be_bytes(first)
}

/// Fits each seed's ladder and summarises a series.
pub fn summarise(mut s: Series, target: f64, min_error: f64, seeds: &[u64], pixels: f64) -> Series {
    let (mut times, mut spps, mut exps) = (Vec::new(), Vec::new(), Vec::new());
    for seed in seeds {
        let ladder: Vec<&Point> = s.points.iter().filter(|q| q.seed == *seed).collect();
        let pts: Vec<(f64, f64)> = ladder.iter().map(|q| (f64::from(q.spp), q.rms_rel_error)).collect();
        let Some(top) = ladder.iter().max_by_key(|q| q.spp) else { continue };
        if let Some(n) = SamplesToTarget::find(&pts, target, min_error) {
            times.push(n.spp * top.render_seconds / f64::from(top.spp));
            spps.push(n.spp);
            exps.push(n.law.b);
            s.extrapolated |= n.extrapolated;
        }
    }
    if s.samples_per_sec.is_none() {
        let top = s.points.iter().map(|q| q.spp).max().unwrap_or(0);
        let rates: Vec<f64> =
            s.points.iter().filter(|q| q.spp == top).map(|q| pixels * f64::from(q.spp) / q.render_seconds).collect();
        s.samples_per_sec = Spread::of(&rates);
    }
    s.time_to_target = Spread::of(&times);
    s.target_spp = Spread::of(&spps);
    s.exponent = Spread::of(&exps);
    s
}

/// Runs the benchmark; `progress` gets a line per finished step.
pub fn run(p: &BenchParams, mut progress: impl FnMut(&str)) -> Result<BenchReport, BenchError> {
    let t0 = Instant::now();
    let started = host_time();
    let cpu_before = host::cpu_times();
    let mut fingerprint = host::Fingerprint::start(p.threads, started);
    std::fs::create_dir_all(&p.work)
        .map_err(|e| BenchError::File(p.work.clone(), format!("cannot create the work folder: {e}")))?;
    let mut notes = Vec::new();
    let peer = peers::prepare(&p.peers, &p.work, &mut notes);
    if peer.is_none()
        && let peers::PeerChoice::Mitsuba { .. } = p.peers
    {
        return Err(BenchError::Peer(format!("--peers mitsuba: {}", notes.join("; "))));
    }
    let seeds: Vec<u64> = (1..=p.seeds as u64).collect();
    let mut scenes = Vec::new();
    for sc in &p.scenes {
        let file = p.work.join(format!("{}.toml", sc.name));
        let text = sc.toml(&p.data, p.size, p.reference_spp);
        std::fs::write(&file, &text).map_err(|e| BenchError::File(file.clone(), e.to_string()))?;
        // The reference, cached in the work folder under a key of the scene's text (size, spp, the
        // maps' folder) and the build (version and commit): a reference of another scene or
        // another build is never reused.
        let key = reference_key(&text, &fingerprint.version);
        let ref_path = p.work.join(format!("{}-reference-{}-{}-{key:016x}.exr", sc.name, p.size, p.reference_spp));
        let t = Instant::now();
        if !ref_path.is_file() {
            render_ours(p, &file, 1_000_003, p.reference_spp, "independent", &ref_path, None)?;
            progress(&format!(
                "{}: reference at {} spp in {:.1} s",
                sc.name,
                p.reference_spp,
                t.elapsed().as_secs_f64()
            ));
        }
        let ref_img =
            vocab::image::read_image(&ref_path).map_err(|e| BenchError::File(ref_path.clone(), e.to_string()))?;
        let reference = Reference::new(&ref_img).map_err(|e| BenchError::Convergence(ref_path.clone(), e))?;
        let floor = reference.noise_floor();
        let mut series: Vec<Series> = Vec::new();
        for sampler in OUR_SAMPLERS {
            series.push(Series {
                renderer: "reflect".into(),
                sampler: sampler.into(),
                points: Vec::new(),
                time_to_target: None,
                target_spp: None,
                extrapolated: false,
                exponent: None,
                samples_per_sec: None,
                rays_per_sec: None,
                phases: None,
                peak_rss_mb: None,
                cold_render_seconds: None,
            });
        }
        let mut docs: Vec<Vec<serde_json::Value>> = vec![Vec::new(); OUR_SAMPLERS.len()];
        for &seed in &seeds {
            // Ours, then the peer's, for each seed: a change of the machine's speed falls on both.
            for (k, sampler) in OUR_SAMPLERS.iter().enumerate() {
                for &spp in &p.ladder {
                    let out = p.work.join(format!("{}-{sampler}-{seed}-{spp}.exr", sc.name));
                    let r = render_ours(p, &file, seed, spp, sampler, &out, Some(&reference))?;
                    series[k].points.push(Point {
                        seed,
                        spp,
                        render_seconds: num(&r.doc, "render_seconds"),
                        total_seconds: num(&r.doc, "total_seconds"),
                        rms_rel_error: r.error,
                    });
                    docs[k].push(r.doc);
                }
            }
            if let (Some(peer), Some(mname)) = (&peer, sc.mitsuba) {
                for s in peer.run_series(mname, p, seed, &reference, &mut notes)? {
                    match series.iter_mut().find(|x| x.renderer == s.renderer && x.sampler == s.sampler) {
                        Some(x) => {
                            x.points.extend(s.points);
                            x.cold_render_seconds = x.cold_render_seconds.or(s.cold_render_seconds);
                            x.peak_rss_mb = x.peak_rss_mb.into_iter().chain(s.peak_rss_mb).reduce(f64::max);
                        }
                        None => series.push(s),
                    }
                }
            }
            progress(&format!("{}: seed {seed} done ({:.0} s so far)", sc.name, t0.elapsed().as_secs_f64()));
        }
        for (k, d) in docs.iter().enumerate() {
            let top = *p.ladder.iter().max().unwrap_or(&1);
            let at_top: Vec<&serde_json::Value> = d.iter().filter(|v| v["spp"].as_u64() == Some(top as u64)).collect();
            let med = |f: &dyn Fn(&serde_json::Value) -> f64| {
                Spread::of(&d.iter().map(f).collect::<Vec<_>>()).map_or(f64::NAN, |s| s.median)
            };
            let ph = |key: &'static str| move |v: &serde_json::Value| num(&v["load_phases"], key);
            series[k].samples_per_sec =
                Spread::of(&at_top.iter().map(|v| num(v, "samples_per_sec")).collect::<Vec<_>>());
            series[k].rays_per_sec = Spread::of(&at_top.iter().map(|v| num(v, "rays_per_sec")).collect::<Vec<_>>());
            series[k].peak_rss_mb = d.iter().map(|v| num(v, "peak_rss_mb")).filter(|x| x.is_finite()).reduce(f64::max);
            series[k].phases = Some(Phases {
                parse: med(&ph("parse_seconds")),
                meshes: med(&ph("meshes_seconds")),
                bvh: med(&ph("bvh_seconds")),
                lighting_read: med(&ph("lighting_read_seconds")),
                lighting_tables: med(&ph("lighting_tables_seconds")),
                render: med(&|v| num(v, "render_seconds")),
                write: med(&|v| num(v, "save_seconds")),
                load_cold: if k == 0 { d.first().map_or(f64::NAN, |v| num(v, "load_seconds")) } else { f64::NAN },
                load_warm: Spread::of(
                    &d.iter().skip(usize::from(k == 0)).map(|v| num(v, "load_seconds")).collect::<Vec<_>>(),
                )
                .map_or(f64::NAN, |s| s.median),
            });
        }
        let pixels = f64::from(p.size).powi(2);
        let min_error = reference.min_measurable();
        let series = series.into_iter().map(|s| summarise(s, p.target, min_error, &seeds, pixels)).collect();
        scenes.push(SceneResult {
            name: sc.name.into(),
            size: p.size,
            reference_spp: p.reference_spp,
            reference_noise: floor,
            min_measurable_error: reference.min_measurable(),
            pixels: reference.pixel_count(),
            series,
        });
    }
    fingerprint.finish(cpu_before);
    Ok(BenchReport {
        host: fingerprint,
        target_rel_error: p.target,
        size: p.size,
        ladder: p.ladder.clone(),
        seeds: p.seeds,
        peers: peer.map(|x| x.describe()).into_iter().collect(),
        notes,
        scenes,
        wall_seconds: t0.elapsed().as_secs_f64(),
    })
}

/// Now as UTC `YYYY-MM-DDTHH:MM:SSZ` (from the system clock, no time-zone data needed).
fn host_time() -> String {
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z", rem / 3600, rem % 3600 / 60, rem % 60)
}

impl std::fmt::Display for BenchReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "{}", self.host)?;
        writeln!(
            f,
            "{}² pixels, spp ladder {:?}, {} seed(s); time to {} % RMS relative error against an independent-sampler \
             reference (its own noise subtracted); median [min–max] over seeds",
            self.size,
            self.ladder,
            self.seeds,
            100.0 * self.target_rel_error
        )?;
        for n in &self.notes {
            writeln!(f, "note: {n}")?;
        }
        writeln!(f)?;
        writeln!(
            f,
            "| scene | renderer | sampler | time to {0} % (s) | spp to {0} % | exponent b | M samples/s | M rays/s | load: parse / meshes / BVH / map / tables (s) | peak MB |",
            100.0 * self.target_rel_error
        )?;
        writeln!(f, "|---|---|---|---|---|---|---|---|---|---|")?;
        let sp = |s: &Option<Spread>, scale: f64, digits: usize| match s {
            Some(s) if s.n > 1 => {
                format!("{:.d$} [{:.d$}–{:.d$}]", s.median * scale, s.min * scale, s.max * scale, d = digits)
            }
            Some(s) => format!("{:.d$}", s.median * scale, d = digits),
            None => "–".into(),
        };
        for sc in &self.scenes {
            for s in &sc.series {
                let phases = s.phases.as_ref().map_or("–".into(), |p| {
                    format!(
                        "{:.3} / {:.2} / {:.2} / {:.2} / {:.2}",
                        p.parse, p.meshes, p.bvh, p.lighting_read, p.lighting_tables
                    )
                });
                // † marks a figure found beyond the ladder (the footnote below).
                let mark = if s.extrapolated && s.target_spp.is_some() { " †" } else { "" };
                writeln!(
                    f,
                    "| {} | {} | {} | {}{mark} | {}{mark} | {} | {} | {} | {} | {} |",
                    sc.name,
                    s.renderer,
                    s.sampler,
                    sp(&s.time_to_target, 1.0, 3),
                    sp(&s.target_spp, 1.0, 0),
                    sp(&s.exponent, 1.0, 2),
                    sp(&s.samples_per_sec, 1e-6, 2),
                    sp(&s.rays_per_sec, 1e-6, 2),
                    phases,
                    s.peak_rss_mb.map_or("–".into(), |m| format!("{m:.0}"))
                )?;
            }
        }
        if self.scenes.iter().flat_map(|sc| &sc.series).any(|s| s.extrapolated && s.target_spp.is_some()) {
            writeln!(
                f,
                "\n† some seed's spp to the target lies above the ladder's top rung or below its first: \
                 extrapolated with the power law fitted through its rungs; elsewhere interpolated between the two \
                 rungs that bracket the target"
            )?;
        }
        write!(f, "\nwall time {:.0} s", self.wall_seconds)
    }
}
