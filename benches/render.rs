//! Render throughput (issue 2): a unit sphere filling a 512×512 orthographic view (extent 1.05)
//! under the Grace Cathedral probe, max_depth 1, for a Lambertian (albedo 0.8) and a Beckmann
//! microfacet (α 0.2, F = 1) sphere. Throughput counts every pixel's samples (misses included),
//! like the reference figures in the issue. Run: `cargo bench --bench render`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use renderer::render::{RenderOptions, render};
use renderer::scene::{Scene, SceneFile};
use std::path::PathBuf;
use std::time::Duration;

const SPP: u32 = 16;

fn scene(brdf: &str) -> Scene {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let toml = format!(
        r#"
[render]
width = 512
height = 512
spp = {SPP}
seed = 0
max_depth = 1
[camera]
type = "orthographic"
from = [0.0, -3.0, 0.0]
to = [0.0, 0.0, 0.0]
up = [0.0, 0.0, 1.0]
extent = 1.05
[lighting]
type = "envmap"
file = "../shared/data/grace_probe.hdr"
mapping = "angular"
[[objects]]
shape = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
brdf = {brdf}
"#
    );
    Scene::build(SceneFile::parse(&toml).expect("bench scene parses"), &root).expect("bench scene builds")
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("render_grace_512");
    g.sample_size(10).measurement_time(Duration::from_secs(8)).warm_up_time(Duration::from_secs(1));
    g.throughput(Throughput::Elements(512 * 512 * SPP as u64));
    eprintln!("threads: {}", rayon::current_num_threads());
    for (name, brdf) in [
        ("lambert", "{ type = \"lambert\", albedo = 0.8 }"),
        ("beckmann", "{ type = \"microfacet\", distribution = \"beckmann\", alpha = 0.2, fresnel = \"none\" }"),
    ] {
        let s = scene(brdf);
        let (_, stats) = render(&s, &RenderOptions::default());
        eprintln!("{name}: {stats}");
        g.bench_function(name, |b| b.iter(|| render(&s, &RenderOptions::default())));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
