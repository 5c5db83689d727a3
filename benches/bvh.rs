//! BVH benchmark: closest-hit throughput (rays/s) of `SceneGeometry::intersect` on unit icospheres
//! of 20,480 (n = 5) and 1,310,720 (n = 8) triangles, with 2 rayon threads, plus build times.
//!
//! Ray sets (1 M rays each, fixed seed):
//! - "box": origins uniform in [−2, 2]³, directions uniform on the sphere (~15% hit);
//! - "aimed": same origins, each ray aimed at a uniform random point inside the unit ball (almost
//!   all hit; origins inside the ball still hit the surface from inside).
//!
//! Each set is traced one ray at a time on each thread, by `SceneGeometry::intersect` (rows `box`
//! and `aimed`: the hit record with its shading normal, as the renderer asks) and by
//! `SceneGeometry::intersect_primitive` (rows `box_primitive` and `aimed_primitive`: t,
//! barycentrics and the primitive, what Embree's `rtcIntersect1` returns and
//! `benches/peers/embree_bvh.py` times; the peer comparison uses these rows).
//!
//! Instruction counts of the build settings (`BVH_COUNT`, see [`count`]): `BVH_COUNT=leaf=2 valgrind
//! --tool=callgrind --toggle-collect='*trace_1t*' target/release/deps/bvh-… --bench` traces 2^16 rays of
//! each set on the 1.31M-triangle icosphere once per ray set, on the calling thread, and exits before
//! criterion (`callgrind_annotate --inclusive=yes` splits the two).
//!
//! Other meshes and thread counts, as `benches/peers/embree_bvh.py --levels … --threads …` takes
//! them: `BVH_LEVELS=5,6,7,8` (subdivision levels n, 20·4ⁿ triangles; default 5,8) and
//! `BVH_THREADS=1` (default 2) in the environment; the group names carry both.
//!
//! Run: `cargo bench --bench bvh` (about 2 minutes). Throughput is printed as elements/s = rays/s.
//! Before each group one untimed-by-criterion pass per ray set prints the hit fraction, the
//! wall-clock rate, and the rate normalised by the process CPU time (what 2 dedicated cores would
//! give; on a machine shared with other jobs the wall-clock numbers understate it).

use criterion::{Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use rayon::prelude::*;
use renderer::geometry::{Ray, SceneGeometry, Shape, icosphere};
use renderer::sampling::chi2::TestRng;
use std::hint::black_box;
use std::time::{Duration, Instant};

const N_RAYS: usize = 1 << 20;
/// Threads of the tracing pool unless `BVH_THREADS` says otherwise.
const THREADS: usize = 2;

/// A comma-separated list of numbers from the environment variable `name`, or `default`.
fn env_list(name: &str, default: &[u32]) -> Vec<u32> {
    match std::env::var(name) {
        Ok(v) => v
            .split(',')
            .map(|x| x.trim().parse().unwrap_or_else(|_| panic!("{name}: {v:?} is not a list of numbers")))
            .collect(),
        Err(_) => default.to_vec(),
    }
}

fn uniform_dir(rng: &mut TestRng) -> Vec3 {
    let z = 1.0 - 2.0 * rng.next_f32();
    let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

fn in_cube(rng: &mut TestRng, half: f32) -> Vec3 {
    (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - Vec3::ONE) * half
}

fn in_unit_ball(rng: &mut TestRng) -> Vec3 {
    loop {
        let p = in_cube(rng, 1.0);
        if p.length_squared() <= 1.0 {
            return p;
        }
    }
}

fn rays(kind: &str, seed: u64) -> Vec<Ray> {
    let mut rng = TestRng::new(seed);
    (0..N_RAYS)
        .map(|_| {
            let o = in_cube(&mut rng, 2.0);
            let d = match kind {
                "box" => uniform_dir(&mut rng),
                _ => loop {
                    let d = in_unit_ball(&mut rng) - o;
                    if d.length_squared() > 1e-12 {
                        break d.normalize();
                    }
                },
            };
            Ray::new(o, d)
        })
        .collect()
}

/// User + system CPU time of this process (all threads) from /proc/self/stat, Linux only.
fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name: state is field 3, utime 14, stime 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0) // USER_HZ = 100 on Linux
}

/// What each ray asks: the hit record (`intersect`: point, geometric and shading normals, as the
/// renderer uses it) or the primitive alone (`intersect_primitive`: t, barycentrics, object and
/// index; the query Embree's `rtcIntersect1` answers, which `embree_bvh.py` times).
#[derive(Clone, Copy)]
enum Query {
    Hit,
    Primitive,
}

#[inline(always)]
fn is_hit(geo: &SceneGeometry, r: &Ray, query: Query) -> bool {
    match query {
        Query::Hit => black_box(geo.intersect(r)).is_some(),
        Query::Primitive => black_box(geo.intersect_primitive(r)).is_some(),
    }
}

/// Closest hits of all rays on the pool; returns the number of hits (each result also passes
/// through `black_box`, so nothing is optimised away).
fn trace(pool: &rayon::ThreadPool, geo: &SceneGeometry, rays: &[Ray], query: Query) -> usize {
    pool.install(|| rays.par_iter().with_min_len(4096).filter(|r| is_hit(geo, r, query)).count())
}

// Closest hits of `rays` on this thread, one function per ray set (not inlined, each with its own
// constant so the compiler cannot merge them: callgrind's `--toggle-collect='*trace_1t*'` counts
// exactly these, and `callgrind_annotate --inclusive=yes` splits them).

#[inline(never)]
fn trace_1t_box(geo: &SceneGeometry, rays: &[Ray]) -> usize {
    black_box(1);
    rays.iter().filter(|r| geo.intersect(r).is_some()).count()
}

#[inline(never)]
fn trace_1t_aimed(geo: &SceneGeometry, rays: &[Ray]) -> usize {
    black_box(2);
    rays.iter().filter(|r| geo.intersect(r).is_some()).count()
}

/// The counting mode: `BVH_COUNT` is a comma-separated list of `leaf=N` (max primitives per leaf),
/// `search=1|medium|2|6|14|24|32`, `reinsert=R`, `depth=N`, `presplit=0|1` overriding
/// `BUILD_PARAMS`; builds the 1.31M-triangle icosphere with them and traces 2^16 rays of each set once.
fn count(spec: &str) {
    use renderer::geometry::bvh::{BUILD_PARAMS, PlocSearchDistance};
    let mut p = BUILD_PARAMS;
    for kv in spec.split(',').filter(|kv| !kv.is_empty()) {
        let (k, v) = kv.split_once('=').expect("BVH_COUNT: key=value");
        match k {
            "leaf" => p.max_prims_per_leaf = v.parse().expect("leaf"),
            "search" => {
                p.ploc_search_distance = match v {
                    "1" => PlocSearchDistance::Minimum,
                    "2" => PlocSearchDistance::VeryLow,
                    "6" => PlocSearchDistance::Low,
                    "14" | "medium" => PlocSearchDistance::Medium,
                    "24" => PlocSearchDistance::High,
                    "32" => PlocSearchDistance::VeryHigh,
                    _ => panic!("BVH_COUNT: search={v}"),
                }
            }
            "reinsert" => p.reinsertion_batch_ratio = v.parse().expect("reinsert"),
            "depth" => p.search_depth_threshold = v.parse().expect("depth"),
            "presplit" => p.pre_split = v == "1",
            _ => panic!("BVH_COUNT: unknown key {k}"),
        }
    }
    let geo = SceneGeometry::with_build_params(vec![Shape::Mesh(icosphere(8))], p);
    let n = 1 << 16;
    let (b, a) = (rays("box", 1), rays("aimed", 2));
    let hb = trace_1t_box(&geo, &b[..n]);
    let ha = trace_1t_aimed(&geo, &a[..n]);
    println!("BVH_COUNT {spec}: build {:.2} s; hits box {hb}, aimed {ha} of {n}", geo.build_time().as_secs_f64());
}

fn bench(c: &mut Criterion) {
    if let Ok(spec) = std::env::var("BVH_COUNT") {
        count(&spec);
        std::process::exit(0);
    }
    let threads = env_list("BVH_THREADS", &[THREADS as u32])[0] as usize;
    assert!((1..=1024).contains(&threads), "BVH_THREADS: {threads} threads");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("thread pool");
    let ray_sets = [("box", rays("box", 1)), ("aimed", rays("aimed", 2))];

    for n in env_list("BVH_LEVELS", &[5, 8]) {
        assert!(n <= 10, "BVH_LEVELS: level {n} (20·4^{n} triangles) is beyond 10");
        let mesh = icosphere(n);
        let tris = mesh.triangles.len();
        let geo = SceneGeometry::new(vec![Shape::Mesh(mesh)]);
        let build = geo.build_time().as_secs_f64();
        println!(
            "icosphere({n}): {tris} triangles, BVH build {build:.3} s wall ({:.2} M tris/s, 1 thread, incl. setup)",
            tris as f64 / build * 1e-6
        );
        for (kind, rs) in &ray_sets {
            let hits = trace(&pool, &geo, rs, Query::Hit); // also warms caches and the pool
            let (c0, t0) = (process_cpu_seconds(), Instant::now());
            black_box(trace(&pool, &geo, rs, Query::Hit));
            let (cpu, wall) = (process_cpu_seconds().map(|c| c - c0.unwrap_or(0.0)), t0.elapsed().as_secs_f64());
            // On a machine shared with other jobs the wall-clock rate understates the code's speed;
            // rays per CPU-second × threads removes the time-sharing (not the cache sharing).
            let cpu_rate = cpu.map_or(String::from("n/a"), |c| {
                format!("{:.2} M rays/s", N_RAYS as f64 / (c / threads as f64) * 1e-6)
            });
            println!(
                "  {kind}: hit fraction {:.4}; one pass {:.2} M rays/s wall, {cpu_rate} CPU-time-normalised to {threads} cores",
                hits as f64 / rs.len() as f64,
                N_RAYS as f64 / wall * 1e-6
            );
        }

        let mut g = c.benchmark_group(format!("bvh_icosphere{n}_{tris}tris_{threads}threads"));
        g.sampling_mode(SamplingMode::Flat)
            .sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(3))
            .throughput(Throughput::Elements(N_RAYS as u64));
        for (query, suffix) in [(Query::Hit, ""), (Query::Primitive, "_primitive")] {
            for (kind, rs) in &ray_sets {
                g.bench_function(format!("{kind}{suffix}"), |b| {
                    b.iter(|| black_box(trace(&pool, &geo, black_box(rs), query)))
                });
            }
        }
        g.finish();
    }

    // Build time of the 20k mesh under criterion (the 1.31 M build is printed above once).
    let mesh = icosphere(5);
    let mut g = c.benchmark_group("bvh_build");
    g.sample_size(10).measurement_time(Duration::from_secs(2));
    g.throughput(Throughput::Elements(mesh.triangles.len() as u64));
    g.bench_function("icosphere5", |b| b.iter(|| black_box(SceneGeometry::new(vec![Shape::Mesh(mesh.clone())]))));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
