//! Mesh tests: BVH against brute force and watertightness, mesh checks and repair on
//! constructed cases and random input (proptest), and the scale-scene generator.

use lumiwall_render::mesh::{
    Bvh, GeneratedLightKind, IndexedMesh, RepairOptions, check_and_repair, check_and_repair_with,
    generate_scale_scene,
};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::HashMap;

fn random_soup(n: usize, seed: u64) -> Vec<[[f64; 3]; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let c = [
                rng.random_range(-10.0..10.0),
                rng.random_range(-10.0..10.0),
                rng.random_range(-10.0..10.0),
            ];
            let mut t = [[0.0; 3]; 3];
            for p in &mut t {
                for (pk, ck) in p.iter_mut().zip(c) {
                    *pk = ck + rng.random_range(-1.0..1.0);
                }
            }
            t
        })
        .collect()
}

#[test]
fn bvh_agrees_with_brute_force() {
    let tris = random_soup(3000, 1);
    let bvh = Bvh::build(&tris);
    let st = bvh.stats();
    assert!(st.leaves > 100 && st.max_leaf_size <= 16, "{st:?}");
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let mut hits = 0;
    for _ in 0..3000 {
        let o = [
            rng.random_range(-15.0..15.0),
            rng.random_range(-15.0..15.0),
            rng.random_range(-15.0..15.0),
        ];
        let d = [
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ];
        let t_max = rng.random_range(1.0..40.0);
        let a = bvh.intersect(o, d, t_max);
        let b = Bvh::intersect_brute_force(&tris, o, d, t_max);
        match (a, b) {
            (Some(a), Some(b)) => {
                hits += 1;
                assert!((a.t - b.t).abs() <= 1e-12 * b.t.max(1.0), "{a:?} vs {b:?}");
            }
            (None, None) => {}
            other => panic!("mismatch {other:?}"),
        }
        // occlusion of the segment o → o + t_max·d agrees with "some hit before the end"
        let end = [
            o[0] + t_max * d[0],
            o[1] + t_max * d[1],
            o[2] + t_max * d[2],
        ];
        let brute = Bvh::intersect_brute_force(&tris, o, d, t_max * (1.0 - 1e-6))
            .is_some_and(|h| h.t > t_max * 1e-6);
        assert_eq!(bvh.occluded(o, end), brute);
    }
    assert!(hits > 300, "too few hits to mean anything: {hits}");
}

/// A closed, subdivided unit cube with shared vertices (outward normals).
fn cube(n: usize) -> IndexedMesh {
    let mut m = IndexedMesh::default();
    let mut index: HashMap<[i64; 3], u32> = HashMap::new();
    let mut vid = |m: &mut IndexedMesh, p: [f64; 3]| -> u32 {
        let key = [
            (p[0] * 1e6).round() as i64,
            (p[1] * 1e6).round() as i64,
            (p[2] * 1e6).round() as i64,
        ];
        *index.entry(key).or_insert_with(|| {
            m.positions.push(p);
            (m.positions.len() - 1) as u32
        })
    };
    // faces: (origin, u, v) with u × v outward
    let faces: [([f64; 3], [f64; 3], [f64; 3]); 6] = [
        ([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]),
        ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]),
        ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
        ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
    ];
    for (o, u, v) in faces {
        for j in 0..n {
            for i in 0..n {
                let p = |a: usize, b: usize| {
                    let (fa, fb) = (a as f64 / n as f64, b as f64 / n as f64);
                    [
                        o[0] + u[0] * fa + v[0] * fb,
                        o[1] + u[1] * fa + v[1] * fb,
                        o[2] + u[2] * fa + v[2] * fb,
                    ]
                };
                let a = vid(&mut m, p(i, j));
                let b = vid(&mut m, p(i + 1, j));
                let c = vid(&mut m, p(i + 1, j + 1));
                let d = vid(&mut m, p(i, j + 1));
                m.triangles.push([a, b, c]);
                m.triangles.push([a, c, d]);
            }
        }
    }
    m
}

fn signed_volume(m: &IndexedMesh) -> f64 {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = [
                m.positions[t[0] as usize],
                m.positions[t[1] as usize],
                m.positions[t[2] as usize],
            ];
            (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]))
                / 6.0
        })
        .sum()
}

#[test]
fn bvh_is_watertight_through_vertices_and_edges_of_a_closed_mesh() {
    let m = cube(8);
    let bvh = Bvh::build(&m.triangle_soup());
    let inside = [0.37, 0.52, 0.41];
    let mut targets: Vec<[f64; 3]> = m.positions.clone();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (
                m.positions[t[k] as usize],
                m.positions[t[(k + 1) % 3] as usize],
            );
            targets.push([
                (a[0] + b[0]) / 2.0,
                (a[1] + b[1]) / 2.0,
                (a[2] + b[2]) / 2.0,
            ]);
        }
    }
    for p in targets {
        let d = [p[0] - inside[0], p[1] - inside[1], p[2] - inside[2]];
        let hit = bvh
            .intersect(inside, d, 10.0)
            .unwrap_or_else(|| panic!("ray to {p:?} escaped"));
        assert!((hit.t - 1.0).abs() < 1e-9, "{p:?}: t = {}", hit.t);
        assert!(
            !hit.front_face,
            "from inside we see back faces of an outward cube"
        );
    }
    // the segment between two points on opposite faces is not occluded by the faces it ends on
    assert!(!bvh.occluded([0.5, 0.5, 0.0], [0.5, 0.5, 1.0]));
    // but a point outside is shadowed from the inside
    assert!(bvh.occluded(inside, [3.0, 0.5, 0.5]));
    // empty and non-finite input
    assert!(
        Bvh::build(&[])
            .intersect(inside, [1.0, 0.0, 0.0], 1.0)
            .is_none()
    );
    assert!(
        bvh.intersect([f64::NAN, 0.0, 0.0], [1.0, 0.0, 0.0], 10.0)
            .is_none()
    );
    assert!(bvh.intersect(inside, [0.0, 0.0, 0.0], 10.0).is_none());
}

#[test]
fn repair_makes_orientation_consistent_keeping_the_majority() {
    let mut m = cube(2);
    let n = m.triangles.len();
    for t in [0usize, 5, 17] {
        m.triangles[t].swap(1, 2);
    }
    let r = check_and_repair(&mut m);
    assert_eq!(r.triangles_flipped, 3, "{r:?}");
    assert_eq!(r.components, 1);
    assert_eq!(r.boundary_edges, 0);
    assert_eq!(r.non_manifold_edges, 0);
    assert_eq!(r.output_triangles, n);
    assert!(
        (signed_volume(&m) - 1.0).abs() < 1e-12,
        "outward again: {}",
        signed_volume(&m)
    );
    // every edge now used once in each direction
    let mut directed: HashMap<(u32, u32), i32> = HashMap::new();
    for t in &m.triangles {
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    assert!(
        directed
            .keys()
            .all(|&(a, b)| directed.get(&(b, a)) == Some(&1))
    );
    assert!(directed.values().all(|&c| c == 1));
}

#[test]
fn repair_removes_invalid_degenerate_and_duplicate_triangles() {
    let mut m = IndexedMesh {
        positions: vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [2.0, 0.0, 0.0], // collinear with 0, 1
            [f64::NAN, 0.0, 0.0],
            [5.0, 5.0, 5.0], // unused
        ],
        triangles: vec![
            [0, 1, 2],
            [0, 0, 2],  // repeated index
            [0, 1, 3],  // zero area
            [0, 1, 4],  // NaN corner
            [0, 1, 99], // out of range
            [2, 1, 0],  // duplicate (reversed)
        ],
    };
    let r = check_and_repair(&mut m);
    assert_eq!(r.invalid_triangles_removed, 2, "{r:?}");
    assert_eq!(r.degenerate_triangles_removed, 2);
    assert_eq!(r.duplicate_triangles_removed, 1);
    assert_eq!(r.output_triangles, 1);
    assert_eq!(r.output_vertices, 3);
    assert_eq!(m.positions.len(), 3);
    assert_eq!(r.boundary_edges, 3);
}

#[test]
fn repair_welds_close_vertices_within_tolerance_only() {
    // two unit quads side by side, each with its own vertices; the shared edge is
    // off by 1e-8 m (welded) — a third quad 1e-3 m away stays separate.
    let quad = |x0: f64, dx: f64| -> Vec<[f64; 3]> {
        vec![
            [x0, 0.0, 0.0],
            [x0 + 1.0, dx, 0.0],
            [x0 + 1.0, 1.0 + dx, 0.0],
            [x0, 1.0, 0.0],
        ]
    };
    let mut positions = quad(0.0, 0.0);
    positions.extend(quad(1.0 + 1e-8, 0.0));
    positions.extend(quad(2.0 + 1e-8 + 1e-3, 0.0));
    let mut triangles = Vec::new();
    for q in 0..3u32 {
        let b = 4 * q;
        triangles.push([b, b + 1, b + 2]);
        triangles.push([b, b + 2, b + 3]);
    }
    let mut m = IndexedMesh {
        positions,
        triangles,
    };
    let r = check_and_repair(&mut m);
    assert_eq!(r.vertices_welded, 2, "{r:?}");
    assert_eq!(r.output_vertices, 10);
    // quads 1+2 form a 2×1 strip (6 boundary edges), quad 3 alone has 4
    assert_eq!(r.boundary_edges, 10);
    assert_eq!(r.components, 2);
}

#[test]
fn repair_fixes_t_vertices_by_splitting_the_long_edge() {
    // upper 2×1 rectangle with a vertex at (1, 0) on its bottom edge; the lower big
    // triangle has the edge (0,0)–(2,0) without that vertex: a T-vertex.
    let positions = vec![
        [0.0, 0.0, 0.0],  // 0
        [1.0, 0.0, 0.0],  // 1  (T-vertex)
        [2.0, 0.0, 0.0],  // 2
        [0.0, 1.0, 0.0],  // 3
        [1.0, 1.0, 0.0],  // 4
        [2.0, 1.0, 0.0],  // 5
        [1.0, -1.0, 0.0], // 6
    ];
    let triangles = vec![[0, 1, 3], [1, 4, 3], [1, 2, 4], [2, 5, 4], [0, 6, 2]];
    let mut m = IndexedMesh {
        positions,
        triangles,
    };
    let area_before = m.total_area_m2();
    let r = check_and_repair(&mut m);
    assert_eq!(r.t_vertices_fixed, 1, "{r:?}");
    assert_eq!(r.output_triangles, 6);
    assert_eq!(r.boundary_edges, 6, "only the outer outline is left open");
    assert_eq!(r.non_manifold_edges, 0);
    assert_eq!(r.triangles_flipped, 0);
    assert!((m.total_area_m2() - area_before).abs() < 1e-12);
    for t in 0..m.triangles.len() {
        assert!(m.triangle_normal(t).unwrap()[2] > 0.0, "all still face +z");
    }
    // several T-vertices on one edge, within a tolerance of 1e-7 m off the line
    let positions = vec![
        [0.0, 0.0, 0.0],
        [4.0, 0.0, 0.0],
        [2.0, -2.0, 0.0],
        [1.0, 5e-8, 0.0],
        [2.5, -5e-8, 0.0],
        [2.0, 3.0, 0.0],
    ];
    let triangles = vec![[0, 2, 1], [0, 3, 5], [3, 4, 5], [4, 1, 5]];
    let mut m = IndexedMesh {
        positions,
        triangles,
    };
    let r = check_and_repair_with(
        &mut m,
        &RepairOptions {
            weld_tolerance_m: 1e-7,
            min_area_m2: 1e-12,
        },
    );
    assert_eq!(r.t_vertices_fixed, 2, "{r:?}");
    assert_eq!(r.output_triangles, 6);
    assert_eq!(r.boundary_edges, 4);
}

#[test]
fn repair_reports_non_manifold_edges_and_non_orientable_components() {
    // three fins on one edge
    let mut m = IndexedMesh {
        positions: vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, 1.0, 0.0],
            [0.5, -1.0, 0.0],
            [0.5, 0.0, 1.0],
        ],
        triangles: vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
    };
    let r = check_and_repair(&mut m);
    assert_eq!(r.non_manifold_edges, 1, "{r:?}");
    assert_eq!(r.output_triangles, 3);
    // Möbius strip: 8 quads around a half-twisted loop
    let n = 8usize;
    let mut positions = Vec::new();
    for i in 0..n {
        let a = i as f64 / n as f64 * std::f64::consts::TAU;
        let tw = a / 2.0;
        for s in [-0.3, 0.3] {
            let r = 2.0 + s * tw.cos();
            positions.push([r * a.cos(), r * a.sin(), s * tw.sin()]);
        }
    }
    let mut triangles = Vec::new();
    for i in 0..n {
        let (a0, a1) = (2 * i as u32, 2 * i as u32 + 1);
        let (b0, b1) = if i + 1 < n {
            (2 * (i + 1) as u32, 2 * (i + 1) as u32 + 1)
        } else {
            (1, 0) // the half twist swaps the sides
        };
        triangles.push([a0, b0, b1]);
        triangles.push([a0, b1, a1]);
    }
    let mut m = IndexedMesh {
        positions,
        triangles,
    };
    let r = check_and_repair(&mut m);
    assert_eq!(r.non_orientable_components, 1, "{r:?}");
    assert_eq!(r.components, 1);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]
    #[test]
    fn repair_never_panics_and_leaves_a_clean_mesh(
        raw_pos in prop::collection::vec((0u8..6, 0u8..6, 0u8..6, 0u8..40), 0..40),
        raw_tris in prop::collection::vec((0u32..45, 0u32..45, 0u32..45), 0..80),
        tol_exp in -9i32..0,
    ) {
        let positions: Vec<[f64; 3]> = raw_pos
            .iter()
            .map(|&(x, y, z, w)| match w {
                0 => [f64::NAN, 0.0, 0.0],
                1 => [f64::INFINITY, 1.0, 0.0],
                2 => [1e300, -1e300, 0.0],
                _ => [x as f64 * 0.5 + w as f64 * 1e-9, y as f64 * 0.5, z as f64 * 0.5],
            })
            .collect();
        let triangles: Vec<[u32; 3]> = raw_tris.iter().map(|&(a, b, c)| [a, b, c]).collect();
        let mut m = IndexedMesh { positions, triangles };
        let opts = RepairOptions { weld_tolerance_m: 10f64.powi(tol_exp), min_area_m2: 1e-12 };
        let r = check_and_repair_with(&mut m, &opts);
        prop_assert_eq!(r.output_triangles, m.triangles.len());
        prop_assert_eq!(r.output_vertices, m.positions.len());
        for t in &m.triangles {
            prop_assert!(t.iter().all(|&i| (i as usize) < m.positions.len()));
            prop_assert!(t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
        }
        for t in 0..m.triangles.len() {
            let a = m.triangle_area_m2(t).unwrap();
            prop_assert!(a.is_finite() && a >= 1e-12);
        }
        // a second pass finds nothing left to weld or remove
        let r2 = check_and_repair_with(&mut m, &opts);
        prop_assert_eq!(r2.invalid_triangles_removed, 0);
        prop_assert_eq!(r2.vertices_welded, 0);
        prop_assert_eq!(r2.degenerate_triangles_removed, 0);
        prop_assert_eq!(r2.duplicate_triangles_removed, 0);
    }
}

#[test]
fn scale_scene_has_the_requested_size_and_mixed_lights() {
    let s = generate_scale_scene(100_000, 120, 42);
    let nt = s.mesh.triangles.len();
    assert!(nt >= 100_000, "{nt}");
    assert!(nt < 115_000, "should not overshoot much: {nt}");
    assert_eq!(s.lights.len(), 120);
    assert_eq!(s.triangle_material.len(), nt);
    for kind in [
        GeneratedLightKind::Point,
        GeneratedLightKind::Spot,
        GeneratedLightKind::Goniometric,
    ] {
        assert!(
            s.lights.iter().filter(|l| l.kind == kind).count() >= 30,
            "{kind:?}"
        );
    }
    for l in &s.lights {
        let f = l.distribution.total_flux_lm();
        assert!((500.0..5000.0).contains(&f), "{f}");
    }
    assert!(
        s.materials
            .iter()
            .all(|m| m.reflectance > 0.0 && m.reflectance < 1.0)
    );
    assert!(
        s.triangle_material
            .iter()
            .all(|&m| (m as usize) < s.materials.len())
    );
    // deterministic per seed
    let again = generate_scale_scene(100_000, 120, 42);
    assert_eq!(again, s);
    let other = generate_scale_scene(100_000, 120, 43);
    assert_ne!(other.lights, s.lights);
}

#[test]
fn scale_scene_is_clean_input_for_the_solver() {
    let mut s = generate_scale_scene(20_000, 10, 5);
    let n = s.mesh.triangles.len();
    let r = check_and_repair(&mut s.mesh);
    assert_eq!(r.invalid_triangles_removed, 0, "{r:?}");
    assert_eq!(r.degenerate_triangles_removed, 0);
    assert_eq!(r.duplicate_triangles_removed, 0);
    assert_eq!(r.non_manifold_edges, 0);
    assert_eq!(r.t_vertices_fixed, 0);
    assert_eq!(
        r.triangles_flipped, 0,
        "generator orients every surface consistently"
    );
    assert_eq!(r.output_triangles, n);
    // lights of the nave see the floor: shoot a ray straight down from each light
    let bvh = Bvh::build(&s.mesh.triangle_soup());
    for l in &s.lights {
        let hit = bvh
            .intersect(l.position, [0.0, 0.0, -1.0], 100.0)
            .expect("floor below");
        assert!(hit.front_face, "floors face up into the rooms");
    }
}

#[test]
fn scale_scene_converts_to_the_solver_scene_with_the_same_lights() {
    use lumiwall_render::photometry::PointLight;
    use lumiwall_render::scene::V3;
    let g = generate_scale_scene(5_000, 9, 3);
    let s = g.to_scene();
    assert_eq!(s.polygons.len(), g.mesh.triangles.len());
    assert_eq!(s.lights.len(), 9);
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    for (gl, sl) in g.lights.iter().zip(&s.lights) {
        let p = PointLight {
            distribution: gl.distribution.clone(),
            position: gl.position,
            frame: gl.frame,
        };
        assert!((sl.total_flux_lm() - gl.distribution.total_flux_lm()).abs() < 1e-9);
        for _ in 0..200 {
            let d: [f64; 3] = [
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            ];
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let d = [d[0] / n, d[1] / n, d[2] / n];
            let want = p.intensity_towards_cd(d);
            let got = sl.intensity_cd(&V3::new(d[0], d[1], d[2]));
            assert!(
                (got - want).abs() <= 1e-9 * want.max(1.0),
                "{:?}: {got} vs {want}",
                gl.kind
            );
        }
    }
}
