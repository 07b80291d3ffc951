//! Point and goniometric lights over a black plane: the solved illuminance of the
//! patches at five points against the inverse-square cosine law (exact patch averages
//! from the solid angle of the patch for the isotropic light; point values at the patch
//! centres for both).

use std::sync::Arc;

use crate::support::{plane_under, stop_rule};
use lumiwall_render::radiosity::{HierarchicalOptions, NoOccluders, solve_hierarchical};
use lumiwall_render::scene::{Light, LightKind, Scene, V3};

/// The plane is black: only direct light.
fn plane_with(light: Light) -> Scene {
    plane_under(light, 0.0)
}

/// Solid angle of a triangle seen from the origin (Van Oosterom & Strackee 1983).
fn tri_solid_angle(a: V3, b: V3, c: V3) -> f64 {
    let (la, lb, lc) = (a.norm(), b.norm(), c.norm());
    let num = a.dot(&b.cross(&c)).abs();
    let den = la * lb * lc + a.dot(&b) * lc + a.dot(&c) * lb + b.dot(&c) * la;
    2.0 * num.atan2(den)
}

const POINTS: [[f64; 2]; 5] = [
    [0.0, 0.0],
    [0.3, -0.2],
    [1.0, 0.5],
    [-1.2, 1.1],
    [1.7, -1.6],
];

fn opts() -> HierarchicalOptions {
    HierarchicalOptions {
        stop: stop_rule(0.002, 60, 100),
        min_area_m2: 1e-5,
        ..HierarchicalOptions::default()
    }
}

#[test]
fn isotropic_point_light_follows_inverse_square_cosine_law() {
    let pos = V3::new(0.3, -0.2, 1.5);
    let i_cd = 100.0;
    let scene = plane_with(Light {
        name: "bulb".into(),
        position: pos,
        color_xyz: [1.0; 3],
        kind: LightKind::Isotropic { intensity_cd: i_cd },
    });
    let sol = solve_hierarchical(&scene, &NoOccluders, &opts()).unwrap();
    for [x, y] in POINTS {
        let p = V3::new(x, y, 0.0);
        let patch = sol.patch_at(0, &p).unwrap();
        let v: Vec<V3> = patch.vertices.iter().map(|v| v - pos).collect();
        let omega: f64 = (1..v.len() - 1)
            .map(|k| tri_solid_angle(v[0], v[k], v[k + 1]))
            .sum();
        let exact_avg = i_cd * omega / patch.area_m2;
        let e = patch.irradiance_xyz[1];
        assert!(
            (e - exact_avg).abs() / exact_avg < 1e-3,
            "patch average at ({x}, {y}): {e} vs {exact_avg}"
        );
        // point value at the patch centre: E = I cos θ / r²
        let c = patch.vertices.iter().sum::<V3>() / patch.vertices.len() as f64;
        let d = pos - c;
        let point = i_cd * d.z / d.norm().powi(3);
        println!(
            "({x}, {y}): patch {e:.4} lx, exact patch average {exact_avg:.4} lx, centre point law {point:.4} lx, patch area {:.2e} m²",
            patch.area_m2
        );
        assert!(
            (e - point).abs() / point < 0.01,
            "point law at ({x}, {y}): {e} vs {point}"
        );
    }
}

#[test]
fn goniometric_light_follows_its_distribution() {
    // a Lambertian downlight: I(θ) = I0 cos θ about the downward axis (local z)
    let i0 = 250.0;
    let pos = V3::new(-0.1, 0.2, 2.0);
    let scene = plane_with(Light {
        name: "downlight".into(),
        position: pos,
        color_xyz: [0.95, 1.0, 1.09],
        kind: LightKind::Goniometric {
            frame: [V3::x(), -V3::y(), -V3::z()],
            distribution: Arc::new(move |d: [f64; 3]| i0 * d[2].max(0.0)),
            total_flux_lm: std::f64::consts::PI * i0,
        },
    });
    let sol = solve_hierarchical(&scene, &NoOccluders, &opts()).unwrap();
    for [x, y] in POINTS {
        let patch = sol.patch_at(0, &V3::new(x, y, 0.0)).unwrap();
        let c = patch.vertices.iter().sum::<V3>() / patch.vertices.len() as f64;
        let d = pos - c;
        let cos = d.z / d.norm();
        let point = i0 * cos * cos / d.norm_squared();
        let e = patch.irradiance_xyz[1];
        assert!(
            (e - point).abs() / point < 0.01,
            "({x}, {y}): {e} vs {point}"
        );
        // colour carried per channel
        assert!((patch.irradiance_xyz[2] / e - 1.09).abs() < 1e-9);
    }
}
