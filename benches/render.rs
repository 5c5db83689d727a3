//! Render throughput of the benchmark scenes `scenes/bench-lambert-grace.toml` (Lambert 0.8) and
//! `scenes/bench-beckmann-grace.toml` (Beckmann α 0.2, F = 1): a unit sphere filling a 512×512
//! orthographic view (extent 1.05) under the Grace lat-long map, max_depth 1, rendered here at
//! 16 spp (the files say 64; `reflect render SCENE --spp 16` renders exactly what is timed here).
//! Throughput counts every pixel's samples (misses included), as `reflect render`'s samples/s.
//! Run: `cargo bench --bench render`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use renderer::render::{RenderOptions, render};
use renderer::scene::{Scene, SceneFile};
use std::path::PathBuf;
use std::time::Duration;

const SPP: u32 = 16;

/// `scenes/NAME.toml` with spp set to [`SPP`].
fn scene(name: &str) -> Scene {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let path = dir.join(format!("{name}.toml"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut file = SceneFile::parse(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    file.render.spp = SPP;
    Scene::build(file, &dir).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("render_grace_512");
    g.sample_size(10).measurement_time(Duration::from_secs(8)).warm_up_time(Duration::from_secs(1));
    g.throughput(Throughput::Elements(512 * 512 * SPP as u64));
    eprintln!("threads: {}", rayon::current_num_threads());
    for (name, file) in [("lambert", "bench-lambert-grace"), ("beckmann", "bench-beckmann-grace")] {
        let s = scene(file);
        let (_, stats) = render(&s, &RenderOptions::default());
        eprintln!("{name}: {stats}");
        g.bench_function(name, |b| b.iter(|| render(&s, &RenderOptions::default())));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
