//! Furnace: a closed box with uniform emission E and reflectance ρ has the exact
//! radiosity B = E / (1 − ρ) everywhere (geometric series of the closed environment).

use std::time::Instant;

use crate::support::stop_rule;
use lumiwall_render::radiosity::{
    HierarchicalOptions, NoOccluders, SceneOccluders, solve_hierarchical,
};
use lumiwall_render::scene::{Material, Polygon, Scene, V3};

/// Six inward-facing quads of an axis-aligned box.
fn box_quads(size: [f64; 3]) -> Vec<Vec<V3>> {
    let [x, y, z] = size;
    let c = V3::new(x / 2.0, y / 2.0, z / 2.0);
    let faces = [
        [
            V3::new(0., 0., 0.),
            V3::new(x, 0., 0.),
            V3::new(x, y, 0.),
            V3::new(0., y, 0.),
        ],
        [
            V3::new(0., 0., z),
            V3::new(x, 0., z),
            V3::new(x, y, z),
            V3::new(0., y, z),
        ],
        [
            V3::new(0., 0., 0.),
            V3::new(0., y, 0.),
            V3::new(0., y, z),
            V3::new(0., 0., z),
        ],
        [
            V3::new(x, 0., 0.),
            V3::new(x, y, 0.),
            V3::new(x, y, z),
            V3::new(x, 0., z),
        ],
        [
            V3::new(0., 0., 0.),
            V3::new(x, 0., 0.),
            V3::new(x, 0., z),
            V3::new(0., 0., z),
        ],
        [
            V3::new(0., y, 0.),
            V3::new(x, y, 0.),
            V3::new(x, y, z),
            V3::new(0., y, z),
        ],
    ];
    faces
        .iter()
        .map(|f| {
            let mut v = f.to_vec();
            let n = (v[1] - v[0]).cross(&(v[2] - v[0]));
            let centre = (v[0] + v[2]) / 2.0;
            if n.dot(&(c - centre)) < 0.0 {
                v.reverse();
            }
            v
        })
        .collect()
}

fn furnace(rho: f64, l_cd_m2: f64) -> Scene {
    Scene {
        polygons: box_quads([1.0, 0.8, 1.3])
            .into_iter()
            .map(|v| Polygon {
                vertices: v,
                material: 0,
                object: "box".into(),
            })
            .collect(),
        materials: vec![Material {
            name: "grey".into(),
            reflectance_xyz: [rho; 3],
            emission_cd_m2: [l_cd_m2; 3],
        }],
        ..Scene::default()
    }
}

#[test]
fn furnace_converges_to_geometric_series_for_stiff_reflectances() {
    let l = 10.0; // cd/m²
    let e = std::f64::consts::PI * l; // lm/m²
    for &rho in &[0.5, 0.9, 0.99, 0.999] {
        let scene = furnace(rho, l);
        let occ = SceneOccluders::new(&scene);
        let opts = HierarchicalOptions {
            stop: stop_rule(1e-3, 30, 20_000),
            ..HierarchicalOptions::default()
        };
        let t = Instant::now();
        let sol = solve_hierarchical(&scene, &occ, &opts).unwrap();
        let exact = e / (1.0 - rho);
        let worst = sol
            .patches
            .iter()
            .map(|p| (p.exitance_xyz[1] - exact).abs() / exact)
            .fold(0.0, f64::max);
        println!(
            "rho {rho}: B/exact-1 worst {worst:.2e}, sweeps {}, extrapolations {}, patches {}, {:.3} s, stop {:?}, est. error {:.2e}",
            sol.stats.iterations,
            sol.stats.extrapolations,
            sol.stats.patches,
            t.elapsed().as_secs_f64(),
            sol.stop,
            sol.curve.last().unwrap().estimated_error
        );
        assert!(
            sol.patches
                .iter()
                .all(|p| p.exitance_xyz.iter().all(|v| v.is_finite()))
        );
        assert!(worst < 0.005, "rho {rho}: worst relative error {worst}");
        // a closed box without occluders needs no visibility work at all
        assert_eq!(sol.stats.shadow_rays, 0);
        // the reported curve ends at or below the target
        assert!(sol.curve.last().unwrap().estimated_error <= 1e-3);
    }
}

#[test]
fn furnace_without_acceleration_is_slower_but_agrees() {
    let scene = furnace(0.9, 1.0);
    let mk = |accelerate| HierarchicalOptions {
        stop: stop_rule(1e-3, 30, 20_000),
        accelerate,
        ..HierarchicalOptions::default()
    };
    let fast = solve_hierarchical(&scene, &NoOccluders, &mk(true)).unwrap();
    let slow = solve_hierarchical(&scene, &NoOccluders, &mk(false)).unwrap();
    let exact = std::f64::consts::PI / 0.1;
    for s in [&fast, &slow] {
        for p in &s.patches {
            assert!((p.exitance_xyz[1] - exact).abs() / exact < 0.005);
        }
    }
    assert!(fast.stats.iterations < slow.stats.iterations);
}
