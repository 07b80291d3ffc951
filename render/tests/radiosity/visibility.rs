//! Visibility classification (Kresse 2.7) is conservative: when the BVH shaft test
//! says nothing may occlude a pair of patches, no segment between them is blocked
//! (checked with shadow rays). And it is useful: pairs with an occluder between them
//! are classified partial, and most pairs in the open are not.

use lumiwall_render::radiosity::quadrature::map_unit_square;
use lumiwall_render::radiosity::{BvhOccluders, SceneOccluders, Visibility};
use lumiwall_render::rng::SplitMix64;
use lumiwall_render::scene::{V3, load_scene};

/// A random sub-patch (parameter rectangle) of polygon `p`.
fn sub_patch(verts: &[V3], rng: &mut SplitMix64) -> Vec<V3> {
    let (s0, t0) = (0.8 * rng.unit(), 0.8 * rng.unit());
    let (ds, dt) = (0.05 + 0.15 * rng.unit(), 0.05 + 0.15 * rng.unit());
    let corners = if verts.len() == 4 {
        vec![(s0, t0), (s0 + ds, t0), (s0 + ds, t0 + dt), (s0, t0 + dt)]
    } else {
        vec![(s0, t0), (s0 + ds, t0), (s0 + ds, t0 + dt)]
    };
    corners
        .into_iter()
        .map(|(s, t)| map_unit_square(verts, s.min(1.0), t.min(1.0)))
        .collect()
}

fn normal(v: &[V3]) -> V3 {
    (v[1] - v[0]).cross(&(v[2] - v[0])).normalize()
}

fn point_in(v: &[V3], rng: &mut SplitMix64) -> V3 {
    // convex combination (inside the convex patch)
    let w: Vec<f64> = v.iter().map(|_| rng.unit() + 1e-3).collect();
    let s: f64 = w.iter().sum();
    v.iter().zip(&w).map(|(p, wi)| p * (wi / s)).sum()
}

#[test]
fn classification_is_conservative_and_useful() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/scenes/cornell/cornell.toml");
    let (scene, _) = load_scene(&path).unwrap();
    let bvh = BvhOccluders::new(&scene);
    let brute = SceneOccluders::new(&scene);
    let mut rng = SplitMix64(7);
    let np = scene.polygons.len();
    let (mut free, mut partial, mut blocked_seen) = (0, 0, 0);
    for _ in 0..6000 {
        let (pa, pb) = (
            (rng.unit() * np as f64) as usize,
            (rng.unit() * np as f64) as usize,
        );
        if pa == pb {
            continue;
        }
        let a = sub_patch(&scene.polygons[pa].vertices, &mut rng);
        let b = sub_patch(&scene.polygons[pb].vertices, &mut rng);
        let may = bvh.may_occlude(&a, pa, &b, pb);
        // only segments that carry light: each end in front of the other's surface
        let (na, nb) = (normal(&a), normal(&b));
        let mut blocked = 0;
        let mut carrying = 0;
        for _ in 0..40 {
            let (x, y) = (point_in(&a, &mut rng), point_in(&b, &mut rng));
            let d = (y - x).normalize();
            if na.dot(&d) <= 1e-3 || nb.dot(&d) >= -1e-3 {
                continue;
            }
            carrying += 1;
            if brute.occluded(&x, &y, [pa, pb]) {
                blocked += 1;
            }
        }
        if carrying == 0 {
            continue;
        }
        if may {
            partial += 1;
            if blocked > 0 {
                blocked_seen += 1;
            }
        } else {
            free += 1;
            assert_eq!(
                blocked, 0,
                "polygons {pa}, {pb}: classified free, {blocked}/{carrying} rays blocked"
            );
        }
    }
    println!("free {free}, partial {partial} (of which rays blocked {blocked_seen})");
    assert!(
        free > 1200,
        "classification saves little: {free} free pairs"
    );
    assert!(
        blocked_seen > 50,
        "too few occluded pairs to test: {blocked_seen}"
    );
}
