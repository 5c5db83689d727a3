//! BVH benchmark: closest-hit throughput (rays/s) of `SceneGeometry::intersect` on unit icospheres
//! of 20,480 (n = 5) and 1,310,720 (n = 8) triangles, with 2 rayon threads, plus build times.
//!
//! Ray sets (1 M rays each, fixed seed):
//! - "box": origins uniform in [−2, 2]³, directions uniform on the sphere (~15% hit);
//! - "aimed": same origins, each ray aimed at a uniform random point inside the unit ball (almost
//!   all hit; origins inside the ball still hit the surface from inside).
//!
//! Run: `cargo bench --bench bvh` (about 2 minutes). Throughput is printed as elements/s = rays/s.

use criterion::{Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use rayon::prelude::*;
use renderer::geometry::{Ray, SceneGeometry, Shape, icosphere};
use renderer::sampling::chi2::TestRng;
use std::hint::black_box;
use std::time::{Duration, Instant};

const N_RAYS: usize = 1 << 20;
const THREADS: usize = 2;

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

/// Closest hits of all rays on the pool; returns the number of hits so nothing is optimised away.
fn trace(pool: &rayon::ThreadPool, geo: &SceneGeometry, rays: &[Ray]) -> usize {
    pool.install(|| rays.par_iter().with_min_len(4096).filter(|r| geo.intersect(r).is_some()).count())
}

fn bench(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(THREADS).build().expect("thread pool");
    let ray_sets = [("box", rays("box", 1)), ("aimed", rays("aimed", 2))];

    for n in [5u32, 8] {
        let mesh = icosphere(n);
        let tris = mesh.triangles.len();
        let t0 = Instant::now();
        let geo = SceneGeometry::new(vec![Shape::Mesh(mesh)]);
        println!(
            "icosphere({n}): {tris} triangles, BVH build {:.3} s ({:.2} M tris/s, wall incl. setup, 1 thread)",
            t0.elapsed().as_secs_f64(),
            tris as f64 / t0.elapsed().as_secs_f64() * 1e-6
        );
        for (kind, rs) in &ray_sets {
            let hits = trace(&pool, &geo, rs);
            println!("  {kind}: hit fraction {:.4}", hits as f64 / rs.len() as f64);
        }

        let mut g = c.benchmark_group(format!("bvh_icosphere{n}_{tris}tris_{THREADS}threads"));
        g.sampling_mode(SamplingMode::Flat)
            .sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(3))
            .throughput(Throughput::Elements(N_RAYS as u64));
        for (kind, rs) in &ray_sets {
            g.bench_function(*kind, |b| b.iter(|| black_box(trace(&pool, &geo, black_box(rs)))));
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
