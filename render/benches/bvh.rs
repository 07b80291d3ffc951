//! BVH against a brute-force loop over all triangles, on the generated scale scene
//! (≥ 100 000 triangles): build time, closest-hit rays and shadow rays.
//!
//! Run: `cargo bench -p lumiwall-render --bench bvh`. Criterion prints the time per
//! batch of rays for both; the speed-up is the ratio of the per-ray times (the brute
//! force batch is 20× smaller, see the group names).
//!
//! Measured 2026-11-22 on the shared 2-core build machine (other builds running):
//! 101 184 triangles, build 132 ms; closest hit 2.6 µs/ray with the BVH vs
//! 2.09 ms/ray brute force (≈ 800×); shadow ray 2.1 µs/segment.

#![expect(
    missing_docs,
    reason = "criterion_group! generates an undocumented `pub fn benches`"
)]

use criterion::{Criterion, criterion_group, criterion_main};
use lumiwall_render::mesh::{Bvh, generate_scale_scene};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

type Ray = ([f64; 3], [f64; 3]);

fn rays(n: usize, seed: u64) -> Vec<Ray> {
    // origins inside the nave, random directions
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let o = [
                rng.random_range(1.0..60.0),
                rng.random_range(-5.0..5.0),
                rng.random_range(0.5..14.0),
            ];
            let d = [
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            ];
            (o, d)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let scene = generate_scale_scene(100_000, 100, 1);
    let tris = scene.mesh.triangle_soup();
    eprintln!("scale scene: {} triangles", tris.len());
    let bvh = Bvh::build(&tris);
    eprintln!("{:?}", bvh.stats());
    let many = rays(2000, 7);
    let few: Vec<Ray> = many[..100].to_vec();

    let mut g = c.benchmark_group("bvh");
    g.sample_size(10);
    g.bench_function("build 100k triangles", |b| {
        b.iter(|| Bvh::build(black_box(&tris)))
    });
    g.bench_function("closest hit, 2000 rays, bvh", |b| {
        b.iter(|| {
            many.iter()
                .filter(|(o, d)| bvh.intersect(*o, *d, f64::INFINITY).is_some())
                .count()
        })
    });
    g.bench_function("closest hit, 100 rays, brute force", |b| {
        b.iter(|| {
            few.iter()
                .filter(|(o, d)| Bvh::intersect_brute_force(&tris, *o, *d, f64::INFINITY).is_some())
                .count()
        })
    });
    g.bench_function("shadow rays, 2000 segments, bvh", |b| {
        b.iter(|| {
            many.iter()
                .filter(|(o, d)| {
                    bvh.occluded(
                        *o,
                        [o[0] + 10.0 * d[0], o[1] + 10.0 * d[1], o[2] + 10.0 * d[2]],
                    )
                })
                .count()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
