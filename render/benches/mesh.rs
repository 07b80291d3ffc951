//! Mesh preprocessing cost on the scale scene: generation and check_and_repair.
//!
//! Run: `cargo bench -p lumiwall-render --bench mesh`.

#![expect(
    missing_docs,
    reason = "criterion_group! generates an undocumented `pub fn benches`"
)]

use criterion::{Criterion, criterion_group, criterion_main};
use lumiwall_render::mesh::{check_and_repair, generate_scale_scene};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let scene = generate_scale_scene(100_000, 100, 1);
    eprintln!(
        "scale scene: {} triangles, {} vertices, {} lights",
        scene.mesh.triangles.len(),
        scene.mesh.positions.len(),
        scene.lights.len()
    );
    let mut g = c.benchmark_group("mesh");
    g.sample_size(10);
    g.bench_function("generate 100k triangles, 100 lights", |b| {
        b.iter(|| generate_scale_scene(black_box(100_000), 100, 1))
    });
    g.bench_function("check_and_repair 100k triangles", |b| {
        b.iter_batched(
            || scene.mesh.clone(),
            |mut m| check_and_repair(&mut m),
            criterion::BatchSize::LargeInput,
        )
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
