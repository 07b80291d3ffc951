//! Scenes shared by the radiosity tests.

use lumiwall_render::scene::{Light, Material, Polygon, Scene, V3};

/// A 4 × 4 m plane at z = 0 (facing +z, reflectance `rho` in every channel) under
/// one light, nothing else.
pub fn plane_under(light: Light, rho: f64) -> Scene {
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
