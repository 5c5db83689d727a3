//! The render loop: tiles in parallel (rayon), each pixel's samples drawn from the counter-based
//! sampler so the image is bit-identical for any thread count, a progress bar on stderr when it is
//! a terminal, and throughput statistics at the end.

use crate::film::{Film, Partial, PixelAccumulator, Stats, batch_log2, canonical_blocks};
use crate::integrator::PathTracer;
use crate::math::{Rgb, Vec3};
use crate::sampling::{LANES, Sampler};
use crate::scene::Scene;
#[cfg(target_arch = "x86_64")]
use crate::simd::Avx2;
use crate::simd::{Isa, Sse2};
use rayon::prelude::*;
use std::io::IsTerminal;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Side of the square tiles that are the unit of parallel work.
pub const TILE: u32 = 16;

/// Throughput of a finished render.
#[derive(Clone, Debug)]
pub struct RenderStats {
    pub wall: Duration,
    pub samples: u64,
    pub rays: u64,
    pub threads: usize,
    /// The render was stopped through [`RenderOptions::cancel`]; its film is not valid.
    pub cancelled: bool,
}

impl RenderStats {
    pub fn samples_per_sec(&self) -> f64 {
        self.samples as f64 / self.wall.as_secs_f64().max(1e-9)
    }
    pub fn rays_per_sec(&self) -> f64 {
        self.rays as f64 / self.wall.as_secs_f64().max(1e-9)
    }
}

/// The stats line. samples = pixels × spp (every camera sample, misses included); rays = rays
/// actually traced (camera rays, and shadow and bounce rays that were not skipped: above a single
/// sphere's horizon nothing can occlude, so no shadow ray is traced there); both are divided by
/// `wall`, the render loop alone (scene loading and image writing are not in it).
impl std::fmt::Display for RenderStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "render loop {:.3} s on {} threads: {} samples (pixels × spp, misses included) = {:.2} M samples/s, ",
            self.wall.as_secs_f64(),
            self.threads,
            self.samples,
            self.samples_per_sec() / 1e6,
        )?;
        if self.rays == 0 {
            // A normal-probe camera hands the integrator its first hit, and a single sphere needs no shadow ray.
            write!(f, "no rays traced (the camera gives the first hit; no shadow ray was needed)")
        } else {
            write!(f, "{} rays traced = {:.2} M rays/s", self.rays, self.rays_per_sec() / 1e6)
        }
    }
}

/// Options of one render call that are not part of the scene.
#[derive(Clone, Debug, Default)]
pub struct RenderOptions {
    /// Show a progress bar on stderr (only drawn when stderr is a terminal).
    pub progress: bool,
    /// Set to true (e.g. from a Ctrl-C handler) to stop the render: it is checked before each tile,
    /// so a render stops within one tile's work and reports [`RenderStats::cancelled`].
    pub cancel: Option<Arc<AtomicBool>>,
}

impl RenderOptions {
    fn cancelled(&self) -> bool {
        self.cancel.as_ref().is_some_and(|c| c.load(Ordering::Relaxed))
    }
}

/// Renders `scene` on the current rayon pool: all `spp` samples of every pixel. If the render is
/// cancelled (see [`RenderOptions::cancel`]) the film is black and `stats.cancelled` is set.
pub fn render(scene: &Scene, opts: &RenderOptions) -> (Film, RenderStats) {
    let s = &scene.settings;
    match render_range(scene, opts, 0, s.spp as u64) {
        (Some(p), stats) => (p.finish(), stats),
        (None, stats) => (Film::new(s.width, s.height), stats),
    }
}

/// Renders the samples `[start, end)` of every pixel (a shard, or one pass of a progressive render)
/// and returns their mergeable statistics ([`Partial`]; `None` if cancelled). Merging the partials
/// of any partition of `[0, spp)` gives exactly the bits of [`render`].
pub fn render_range(scene: &Scene, opts: &RenderOptions, start: u64, end: u64) -> (Option<Partial>, RenderStats) {
    let s = &scene.settings;
    let (w, h) = (s.width, s.height);
    let end = end.min(s.spp as u64);
    let start = start.min(end);
    let tiles_x = w.div_ceil(TILE);
    let tiles_y = h.div_ceil(TILE);
    let ntiles = (tiles_x * tiles_y) as usize;
    let bar = if opts.progress && std::io::stderr().is_terminal() {
        let b = indicatif::ProgressBar::new(ntiles as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {percent}% tiles, eta {eta}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    } else {
        indicatif::ProgressBar::hidden()
    };
    let tracer = PathTracer::new(scene);
    let blocks = canonical_blocks(start, end);
    let nb = blocks.len();
    // Each tile copies its pixels into the image's statistics as soon as it is done, so that only
    // the tiles in flight hold a second copy (collecting every tile first held the whole image
    // twice: guide, "Performance notes and their history", peak memory).
    let stats = std::sync::Mutex::new(vec![Stats::default(); w as usize * h as usize * nb]);
    let t0 = Instant::now();
    let tiles: Vec<Option<u64>> = (0..ntiles)
        .into_par_iter()
        .map(|t| {
            if opts.cancelled() {
                return None;
            }
            let (tx, ty) = (t as u32 % tiles_x, t as u32 / tiles_x);
            let (x0, y0) = (tx * TILE, ty * TILE);
            let (pixels, rays) =
                render_tile(scene, &tracer, [x0, y0, (x0 + TILE).min(w), (y0 + TILE).min(h)], start, end);
            let tw = (x0 + TILE).min(w) - x0;
            // A panic in another tile's copy is a bug that has already ended the render.
            let mut stats = stats.lock().expect("a tile's copy panicked");
            for (i, px) in pixels.chunks(nb.max(1)).enumerate() {
                let (row, col) = (y0 + i as u32 / tw, x0 + i as u32 % tw);
                let p = (row * w + col) as usize;
                stats[p * nb..(p + 1) * nb].copy_from_slice(&px[..nb]);
            }
            drop(stats);
            bar.inc(1);
            Some(rays)
        })
        .collect();
    let wall = t0.elapsed();
    bar.finish_and_clear();

    let stats = stats.into_inner().expect("a tile's copy panicked");
    let mut rays = 0;
    let mut cancelled = false;
    for tile in tiles {
        match tile {
            Some(r) => rays += r,
            None => cancelled = true,
        }
    }
    let rstats = RenderStats {
        wall,
        samples: if cancelled { 0 } else { w as u64 * h as u64 * (end - start) },
        rays,
        threads: rayon::current_num_threads(),
        cancelled,
    };
    if cancelled {
        return (None, rstats);
    }
    (
        Some(Partial {
            width: w,
            height: h,
            spp: s.spp,
            batch_log2: batch_log2(s.spp),
            replicates: Sampler::replicates(s.sampler),
            start,
            end,
            blocks,
            stats,
        }),
        rstats,
    )
}

/// One tile's pixels, row-major, each as the statistics of the canonical blocks of `[start, end)`.
///
/// Dispatched at run time to the best instruction-set copy of the tile loop this CPU runs
/// ([`x86_64_level`]), with the path tracer and everything else inlined into it:
/// - x86-64-v4 (`render_tile_x86_64_v4`: the v3 features plus AVX-512 F, BW, CD, DQ and VL; Intel
///   Skylake-SP 2017 and AMD Zen 4 2022 onward): as v3, with EVEX encodings, 32 vector registers
///   (fewer spills of the lanes) and mask registers. The lanes stay 8 wide.
/// - x86-64-v3 (`render_tile_x86_64_v3`: AVX2, FMA, BMI1/2, LZCNT, MOVBE, F16C; Intel Haswell 2013
///   and AMD Excavator 2015 onward): the lanes in 256-bit registers (`Isa` `Avx2`), VEX encodings,
///   BMI.
/// - otherwise, or on another architecture, the loop as compiled for the build's target.
///
/// Every copy computes the same bits: Rust never contracts a multiply and an add into an FMA on
/// its own, the code calls `mul_add` nowhere, and out-of-line functions (libm among them) are the
/// same in all. A test renders every scene in `scenes/` in each copy the CPU runs and compares the
/// bits with the baseline's (`render::tests::dispatch_gives_the_baseline_bits`). What each copy
/// gains is in the guide's "Performance notes and their history".
fn render_tile(scene: &Scene, tracer: &PathTracer, rect: [u32; 4], start: u64, end: u64) -> (Vec<Stats>, u64) {
    #[cfg(target_arch = "x86_64")]
    match x86_64_level() {
        // SAFETY: the CPU has every feature `render_tile_x86_64_v4` is compiled for.
        X86Level::V4 => return unsafe { render_tile_x86_64_v4(scene, tracer, rect, start, end) },
        // SAFETY: the CPU has every feature `render_tile_x86_64_v3` is compiled for.
        X86Level::V3 => return unsafe { render_tile_x86_64_v3(scene, tracer, rect, start, end) },
        X86Level::Baseline => {}
    }
    render_tile_body::<Sse2>(scene, tracer, rect, start, end)
}

/// The x86-64 microarchitecture levels the renderer has copies of its hot loops for (psABI
/// names), lowest first.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum X86Level {
    /// x86-64 itself (SSE2).
    Baseline,
    /// Every feature of `render_tile_x86_64_v3`'s `target_feature` list.
    V3,
    /// Every feature of `render_tile_x86_64_v4`'s list (which includes V3's).
    V4,
}

/// The best [`X86Level`] this CPU has, asked once and kept (std caches each CPUID answer too, but
/// asking for the thirteen features costs a load, a test and two branches each; this is one load
/// per tile).
#[cfg(target_arch = "x86_64")]
#[inline]
pub(crate) fn x86_64_level() -> X86Level {
    use std::sync::atomic::AtomicU8;
    // 0: not asked yet, else 1 + the level. Relaxed suffices: every thread computes the same.
    static LEVEL: AtomicU8 = AtomicU8::new(0);
    #[cold]
    fn ask() -> X86Level {
        use std::arch::is_x86_feature_detected as has;
        let v3 = has!("avx2")
            && has!("popcnt")
            && has!("fma")
            && has!("bmi1")
            && has!("bmi2")
            && has!("lzcnt")
            && has!("movbe")
            && has!("f16c");
        let v4 = v3 && has!("avx512f") && has!("avx512bw") && has!("avx512cd") && has!("avx512dq") && has!("avx512vl");
        let level = if v4 {
            X86Level::V4
        } else if v3 {
            X86Level::V3
        } else {
            X86Level::Baseline
        };
        LEVEL.store(1 + level as u8, Ordering::Relaxed);
        level
    }
    match LEVEL.load(Ordering::Relaxed) {
        0 => ask(),
        1 => X86Level::Baseline,
        2 => X86Level::V3,
        _ => X86Level::V4,
    }
}

/// Whether this CPU has the features of `render_tile_x86_64_v3`, for the tests' own v3 copies.
#[cfg(all(test, target_arch = "x86_64"))]
#[inline]
pub(crate) fn has_x86_64_v3() -> bool {
    x86_64_level() >= X86Level::V3
}

/// `render_tile_body` compiled for x86-64-v3 (see `render_tile`); call only where
/// [`x86_64_level`] is at least [`X86Level::V3`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,movbe,f16c,popcnt")]
fn render_tile_x86_64_v3(
    scene: &Scene,
    tracer: &PathTracer,
    rect: [u32; 4],
    start: u64,
    end: u64,
) -> (Vec<Stats>, u64) {
    render_tile_body::<Avx2>(scene, tracer, rect, start, end)
}

/// `render_tile_body` compiled for x86-64-v4 (see `render_tile`); call only where
/// [`x86_64_level`] is [`X86Level::V4`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,movbe,f16c,popcnt,avx512f,avx512bw,avx512cd,avx512dq,avx512vl")]
fn render_tile_x86_64_v4(
    scene: &Scene,
    tracer: &PathTracer,
    rect: [u32; 4],
    start: u64,
    end: u64,
) -> (Vec<Stats>, u64) {
    render_tile_body::<Avx2>(scene, tracer, rect, start, end)
}

/// The tile loop itself, inlined into each instruction-set version of `render_tile`.
#[inline(always)]
fn render_tile_body<S: Isa>(
    scene: &Scene,
    tracer: &PathTracer,
    [x0, y0, x1, y1]: [u32; 4],
    start: u64,
    end: u64,
) -> (Vec<Stats>, u64) {
    let s = &scene.settings;
    let sampler = Sampler::new(s.sampler, s.seed);
    let jitter = scene.camera.jitters();
    let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize * 2);
    let mut rays = 0u64;
    let mut acc = PixelAccumulator::new(start, batch_log2(s.spp), Sampler::replicates(s.sampler));
    for row in y0..y1 {
        for col in x0..x1 {
            let pixel_id = row as u64 * s.width as u64 + col as u64;
            acc.reset(start);
            // The pixel's samples in batches of LANES (the last one partial), each traced stage by
            // stage (`PathTracer::li_lanes`) and accumulated in sample order, so that the
            // statistics keep their bits.
            // A range that starts inside an aligned octet takes that octet's rest first, so that
            // the following batches are aligned octets the film sums in registers (`film`, "Blocks
            // of lanes"); the batching changes no sample's numbers.
            let mut i = start;
            while i < end {
                let n = (end - i).min(LANES as u64 - i % LANES as u64) as usize;
                let results = tracer.li_lanes::<S>(&sampler, pixel_id, row, col, i, n, jitter);
                for r in &results[..n] {
                    rays += r.rays as u64;
                }
                if n == LANES {
                    // Plain loops, not `array::map` (a guard and a copy per call on this path).
                    let (mut radiance, mut normal, mut hit) = ([Rgb::ZERO; LANES], [Vec3::ZERO; LANES], [false; LANES]);
                    for k in 0..LANES {
                        (radiance[k], normal[k], hit[k]) = (results[k].radiance, results[k].normal, results[k].hit);
                    }
                    acc.add_8(&radiance, &normal, &hit);
                } else {
                    for r in &results[..n] {
                        acc.add(r.radiance, r.normal, r.hit);
                    }
                }
                i += n as u64;
            }
            out.extend(acc.blocks().map(|(_, st)| *st));
        }
    }
    (out, rays)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SceneFile;
    use std::path::PathBuf;

    /// The tile loop of the one-sample-at-a-time path tracer (`li_reference`), as the renderer ran it
    /// before the batched integrator: the oracle of `batched_integrator_gives_the_reference_bits`.
    fn render_tile_reference(
        scene: &Scene,
        tracer: &PathTracer,
        [x0, y0, x1, y1]: [u32; 4],
        start: u64,
        end: u64,
    ) -> (Vec<Stats>, u64) {
        let s = &scene.settings;
        let mut sampler = Sampler::new(s.sampler, s.seed);
        let jitter = scene.camera.jitters();
        let mut out = Vec::new();
        let mut rays = 0u64;
        let mut acc = PixelAccumulator::new(start, batch_log2(s.spp), Sampler::replicates(s.sampler));
        for row in y0..y1 {
            for col in x0..x1 {
                let pixel_id = row as u64 * s.width as u64 + col as u64;
                acc.reset(start);
                for i in start..end {
                    sampler.start(pixel_id, i as u32);
                    let u = sampler.next_2d();
                    let u = if jitter { u } else { crate::math::Vec2::splat(0.5) };
                    let r = tracer.li_reference(scene.camera.generate(row, col, u), &mut sampler);
                    rays += r.rays as u64;
                    acc.add(r.radiance, r.normal, r.hit);
                }
                out.extend(acc.blocks().map(|(_, st)| *st));
            }
        }
        (out, rays)
    }

    fn scene_files() -> Vec<PathBuf> {
        let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenes");
        let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
        paths.sort();
        assert!(paths.len() >= 20, "scenes/ has {} scene files", paths.len());
        paths
    }

    /// Three objects in contact, so that bounce and shadow rays hit other objects at every depth
    /// (each scene in `scenes/` is one convex object, whose rays, once reflected, escape): a Lambert
    /// sphere, a mirror icosphere and a Beckmann sphere on a row, with the camera looking along the
    /// row's side.
    const CLUSTER: &str = r#"
        [render]
        width = 16
        height = 16
        spp = 16
        max_depth = 5
        [camera]
        type = "perspective"
        from = [0.5, -4.0, 1.5]
        to = [0.0, 0.0, 0.0]
        up = [0.0, 0.0, 1.0]
        fov_deg = 45.0
        [lighting]
        type = "envmap"
        file = "../../shared/data/grace_latlong.exr"
        mapping = "latlong"
        [[objects]]
        shape = "sphere"
        center = [-1.0, 0.0, 0.0]
        radius = 1.0
        brdf = { type = "lambert", albedo = 0.8 }
        [[objects]]
        shape = "icosphere"
        subdivisions = 2
        center = [0.8, 0.3, 0.0]
        radius = 0.8
        brdf = { type = "mirror" }
        [[objects]]
        shape = "sphere"
        center = [0.2, 1.2, -0.2]
        radius = 0.7
        brdf = { type = "microfacet", distribution = "beckmann", alpha = 0.3, fresnel = "none" }
    "#;

    /// Every scene file of `scenes/` and [`CLUSTER`] (whose map path is relative to `scenes/`):
    /// (name, scene file, the directory its paths are relative to).
    fn test_scenes() -> Vec<(String, SceneFile, PathBuf)> {
        let mut scenes: Vec<_> = scene_files()
            .into_iter()
            .map(|path| {
                let file = SceneFile::parse(&std::fs::read_to_string(&path).unwrap()).unwrap();
                (path.display().to_string(), file, path.parent().unwrap().to_path_buf())
            })
            .collect();
        let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenes");
        scenes.push(("cluster".into(), SceneFile::parse(CLUSTER).unwrap(), dir));
        scenes
    }

    fn bits(v: &[Stats]) -> Vec<u64> {
        v.iter().flat_map(|s| s.0.map(f64::to_bits)).collect()
    }

    /// The batched integrator (`PathTracer::li_lanes`, through the tile loop the renderer runs)
    /// gives, on every scene in `scenes/` (every camera, BRDF, light, texture and mesh there), the
    /// bits and ray counts of the one-sample-at-a-time path tracer it replaced; and on [`CLUSTER`],
    /// whose paths meet other objects (the last vertex's bounce rays are any-hit rays in the
    /// batched integrator, closest-hit rays in the reference). 16², depth as the scene says (at
    /// least 5, so that Russian roulette runs), samples [3, 14) of 16 (a full batch of 8 with its
    /// numbers drawn ahead, then a partial one of 3) and [0, 16).
    #[test]
    fn batched_integrator_gives_the_reference_bits() {
        for (name, mut file, dir) in test_scenes() {
            file.render.width = 16;
            file.render.height = 16;
            file.render.spp = 16;
            file.render.max_depth = file.render.max_depth.max(5);
            let scene = Scene::build(file, &dir).unwrap();
            let tracer = PathTracer::new(&scene);
            let rect = [0, 0, 16, 16];
            for (start, end) in [(3, 14), (0, 16)] {
                let (a, ra) = render_tile(&scene, &tracer, rect, start, end);
                let (b, rb) = render_tile_reference(&scene, &tracer, rect, start, end);
                assert_eq!(ra, rb, "{name}: ray counts");
                assert!(bits(&a) == bits(&b), "{name}: the batched integrator changed bits");
            }
        }
    }

    /// Every scene in `scenes/` and [`CLUSTER`] (24², samples 3–15: every camera, BRDF, light,
    /// texture and mesh there) gives the same bits through the dispatched tile loop, and through
    /// each instruction-set copy this CPU runs (x86-64-v3, x86-64-v4), as through the loop compiled for the build's baseline.
    /// Copies the CPU lacks are not compared (the test says so on stderr).
    /// Rust's semantics give every copy the same values (no multiply-add contraction; `mul_add` is
    /// fused in both, an `fmaf` call or an FMA instruction), so this guards the claim against a
    /// mis-compilation and against feature-dependent code added to the tile loop later.
    #[test]
    fn dispatch_gives_the_baseline_bits() {
        #[cfg(target_arch = "x86_64")]
        let level = x86_64_level();
        #[cfg(target_arch = "x86_64")]
        if level < X86Level::V4 {
            // The copies this CPU cannot run are not compared here; say so.
            eprintln!("dispatch_gives_the_baseline_bits: this CPU is {level:?}; the copies above it are not compared");
        }
        for (name, mut file, dir) in test_scenes() {
            file.render.width = 24;
            file.render.height = 24;
            file.render.spp = 16;
            let scene = Scene::build(file, &dir).unwrap();
            let tracer = PathTracer::new(&scene);
            let rect = [0, 0, 24, 24];
            // From sample 3: a partial batch first, then aligned octets (the film's octet sums).
            let (a, ra) = render_tile_body::<Sse2>(&scene, &tracer, rect, 3, 16);
            let mut copies: Vec<(&str, (Vec<Stats>, u64))> =
                vec![("dispatched", render_tile(&scene, &tracer, rect, 3, 16))];
            #[cfg(target_arch = "x86_64")]
            {
                if level >= X86Level::V3 {
                    // SAFETY: the CPU has the features (x86_64_level).
                    copies.push(("x86-64-v3", unsafe { render_tile_x86_64_v3(&scene, &tracer, rect, 3, 16) }));
                }
                if level >= X86Level::V4 {
                    // SAFETY: as above.
                    copies.push(("x86-64-v4", unsafe { render_tile_x86_64_v4(&scene, &tracer, rect, 3, 16) }));
                }
            }
            for (copy, (b, rb)) in copies {
                assert_eq!(ra, rb, "{name}: {copy}");
                assert!(bits(&a) == bits(&b), "{name}: the {copy} tile loop changed bits");
            }
        }
    }
}
