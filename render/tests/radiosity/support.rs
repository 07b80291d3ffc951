//! Scenes and solver settings shared by the radiosity tests.

use std::time::Duration;

use lumiwall_render::radiosity::{
    HierarchicalOptions, Solution, StopRule, Visibility, solve_hierarchical,
};
use lumiwall_render::scene::{Light, Material, Polygon, Scene, V3};

/// A stop rule: relative error `target`, at most `time_limit_s` seconds and
/// `max_iterations` sweeps or shots.
pub(crate) fn stop_rule(target: f64, time_limit_s: u64, max_iterations: usize) -> StopRule {
    StopRule {
        target_error: target,
        time_limit: Some(Duration::from_secs(time_limit_s)),
        max_iterations,
    }
}

/// Solves `scene` hierarchically with default options but the stop rule `stop`.
pub(crate) fn solve_hierarchical_with(
    scene: &Scene,
    vis: &dyn Visibility,
    stop: StopRule,
) -> Solution {
    solve_hierarchical(
        scene,
        vis,
        &HierarchicalOptions {
            stop,
            ..Default::default()
        },
    )
    .unwrap()
}

/// A 4 × 4 m plane at z = 0 (facing +z, reflectance `rho` in every channel) under
/// one light, nothing else.
pub(crate) fn plane_under(light: Light, rho: f64) -> Scene {
    Scene {
        polygons: vec![Polygon {
            vertices: vec![
                V3::new(-2., -2., 0.),
                V3::new(2., -2., 0.),
                V3::new(2., 2., 0.),
                V3::new(-2., 2., 0.),
            ],
            material: 0,
            object: "floor".into(),
        }],
        materials: vec![Material {
            name: "plane".into(),
            reflectance_xyz: [rho; 3],
            emission_cd_m2: [0.0; 3],
        }],
        lights: vec![light],
        ..Scene::default()
    }
}
