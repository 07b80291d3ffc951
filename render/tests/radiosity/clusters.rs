//! Clustering against an independent answer: a closed room tessellated into many
//! small quads (so the long-range exchange runs through clusters), lit by one point
//! light, solved by the hierarchical solver and compared patch by patch with the Monte
//! Carlo path tracer (`radiosity::montecarlo`), which shares no code with it.

use std::time::Duration;

use lumiwall_render::radiosity::montecarlo::MonteCarloReference;
use lumiwall_render::radiosity::{
    BvhOccluders, HierarchicalOptions, Solution, StopRule, solve_hierarchical,
};
use lumiwall_render::scene::{Light, LightKind, Material, Polygon, Scene, V3};

/// An axis-aligned room [0, size] with inward faces, each split into n × n quads;
/// `pillar` adds a square pillar (an occluder) in the middle.
fn room(size: [f64; 3], n: usize, rho: f64, pillar: bool) -> Scene {
    let mut polygons = Vec::new();
    let mut quad = |o: V3, a: V3, b: V3, parts: usize| {
        for i in 0..parts {
            for j in 0..parts {
                let (s0, s1) = (i as f64 / parts as f64, (i + 1) as f64 / parts as f64);
                let (t0, t1) = (j as f64 / parts as f64, (j + 1) as f64 / parts as f64);
                polygons.push(Polygon {
                    vertices: vec![
                        o + a * s0 + b * t0,
                        o + a * s1 + b * t0,
                        o + a * s1 + b * t1,
                        o + a * s0 + b * t1,
                    ],
                    material: 0,
                    object: "room".into(),
                });
            }
        }
    };
    let [x, y, z] = size;
    let (ex, ey, ez) = (V3::x() * x, V3::y() * y, V3::z() * z);
    let o = V3::zeros();
    // a × b is the (inward) normal
    quad(o, ex, ey, n); // floor, normal +z
    quad(o + ez, ey, ex, n); // ceiling, normal −z
    quad(o, ey, ez, n); // x = 0, normal +x
    quad(o + ex, ez, ey, n); // x = X, normal −x
    quad(o, ez, ex, n); // y = 0, normal +y
    quad(o + ey, ex, ez, n); // y = Y, normal −y
    if pillar {
        let (w, h) = (0.15 * x, 0.7 * z);
        let c = V3::new(0.5 * x, 0.5 * y, 0.0);
        let p0 = c - V3::new(w / 2.0, w / 2.0, 0.0);
        let (px, py, pz) = (V3::x() * w, V3::y() * w, V3::z() * h);
        let m = (n / 4).max(1);
        // outward faces
        quad(p0, px, pz, m); // y = min side, normal −y
        quad(p0 + py, pz, px, m); // normal +y
        quad(p0, pz, py, m); // normal −x
        quad(p0 + px, py, pz, m); // normal +x
        quad(p0 + pz, px, py, m); // top, normal +z
    }
    Scene {
        polygons,
        materials: vec![Material {
            name: "grey".into(),
            reflectance_xyz: [rho; 3],
            emission_cd_m2: [0.0; 3],
        }],
        lights: vec![Light {
            name: "bulb".into(),
            position: V3::new(0.3 * x, 0.35 * y, 0.8 * z),
            color_xyz: [1.0; 3],
            kind: LightKind::Isotropic {
                intensity_cd: 200.0,
            },
        }],
        ..Scene::default()
    }
}

/// Area-weighted relative L1 difference of the patch exitances against the tracer at
/// `n` area-stratified patches, and the tracer's noise on the same scale.
fn against_tracer(scene: &Scene, sol: &Solution, n: usize, paths: usize) -> (f64, f64, f64) {
    let mc = MonteCarloReference::new(scene);
    let total: f64 = sol.patches.iter().map(|p| p.area_m2).sum();
    let mut cum = Vec::new();
    let mut acc = 0.0;
    for p in &sol.patches {
        acc += p.area_m2;
        cum.push(acc);
    }
    let (mut diff, mut signed, mut sum, mut noise) = (0.0, 0.0, 0.0, 0.0);
    for k in 0..n {
        let u = (k as f64 + 0.5) / n as f64 * total;
        let i = cum.partition_point(|&c| c < u).min(sol.patches.len() - 1);
        let p = &sol.patches[i];
        let rho = scene.material_of(p.polygon).reflectance_xyz[1];
        let est = mc.patch_irradiance(&p.vertices, p.polygon, paths, 77 + k as u64);
        let r = rho * est.irradiance_xyz[1];
        diff += (p.exitance_xyz[1] - r).abs();
        signed += p.exitance_xyz[1] - r;
        sum += r;
        noise += rho * est.std_error_y;
    }
    (diff / sum, signed / sum, noise / sum)
}

fn solve(scene: &Scene, target: f64) -> Solution {
    let vis = BvhOccluders::new(scene);
    solve_hierarchical(
        scene,
        &vis,
        &HierarchicalOptions {
            stop: StopRule {
                target_error: target,
                time_limit: Some(Duration::from_secs(120)),
                max_iterations: 10_000,
            },
            ..HierarchicalOptions::default()
        },
    )
    .unwrap()
}

#[test]
fn clustered_room_agrees_with_path_tracing() {
    for pillar in [false, true] {
        let scene = room([6.0, 4.0, 3.0], 16, 0.6, pillar);
        let sol = solve(&scene, 0.05);
        let est = sol.curve.last().unwrap().estimated_error;
        let (l1, bias, noise) = against_tracer(&scene, &sol, 60, 16000);
        println!(
            "pillar {pillar}: {} polygons, {} patches, {} links ({} at clusters), estimated {:.2}%, against the tracer {:.2}% (bias {:+.2}%, tracer noise {:.2}%), {:.2} s",
            scene.polygons.len(),
            sol.stats.patches,
            sol.stats.links,
            sol.stats.cluster_links,
            100.0 * est,
            100.0 * l1,
            100.0 * bias,
            100.0 * noise,
            sol.stats.time_s
        );
        assert!(
            sol.stats.cluster_links > 0,
            "the test must exercise clusters"
        );
        // the estimate is of the right size and the solution is not biased
        assert!(
            l1 < (2.0 * est).max(0.03) + 2.0 * noise,
            "{l1} vs estimate {est}"
        );
        assert!(bias.abs() < est + 2.0 * noise, "bias {bias}");
    }
}
