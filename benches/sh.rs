//! Spherical-harmonic benchmarks (targets in guide "Performance notes and their history"):
//! - evaluation of all 441 Y_lm of l_max = 20 at one direction (target < 1 µs);
//! - projection of a 2048 × 1024 lat-long environment to l_max = 20 (target well under 1 s on 2 cores);
//! - projection of a 1000 × 1000 angular map (the grace probe's size) to l_max = 20;
//! - transfer coefficients: Phong eq. 43 (s = 10⁴, l ≤ 100) and Torrance–Sparrow eq. 50.
//!
//! Run: `cargo bench --bench sh`.

use analysis::image::RgbImage;
use analysis::projection::{Mapping, project_envmap};
use analysis::sh::ShBasis;
use analysis::transfer::{phong, torrance_sparrow};
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

fn test_image(w: usize, h: usize) -> RgbImage {
    let pixels = (0..w * h)
        .map(|i| {
            let (r, c) = ((i / w) as f32, (i % w) as f32);
            [1.0 + (0.01 * r).sin() * (0.02 * c).cos(), 0.5 + 0.001 * r, 0.25 + 0.0005 * c]
        })
        .collect();
    RgbImage { width: w, height: h, pixels }
}

fn bench(c: &mut Criterion) {
    let basis = ShBasis::new(20);
    let mut out = vec![0.0; 441];
    let d = [0.36f64, -0.48, 0.8];
    c.bench_function("sh_eval_all_441_lmax20", |b| b.iter(|| basis.eval_into(black_box(d), black_box(&mut out))));

    let mut g = c.benchmark_group("projection");
    g.sample_size(10);
    let latlong = test_image(2048, 1024);
    g.bench_function("latlong_2048x1024_lmax20", |b| {
        b.iter(|| project_envmap(black_box(&latlong), Mapping::LatLong, 20).unwrap())
    });
    let angular = test_image(1000, 1000);
    g.bench_function("angular_1000x1000_lmax20", |b| {
        b.iter(|| project_envmap(black_box(&angular), Mapping::Angular, 20).unwrap())
    });
    g.finish();

    c.bench_function("phong_eq43_s1e4_l100", |b| b.iter(|| phong::phong(black_box(1.0e4), 100)));
    c.bench_function("torrance_sparrow_eq50_sigma0.1_l100", |b| {
        b.iter(|| torrance_sparrow::normal_exitance(black_box(0.1), 100))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
