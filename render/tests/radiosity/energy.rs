//! Energy balance of an open scene: flux absorbed by the surfaces plus flux escaping
//! through the opening equals the flux emitted (area emitter + point light).
//!
//! Escape through the opening is computed independently of the solver's links: the
//! direct part of the point light from the solid angle of the opening (closed form for
//! a rectangle seen from a point on its axis), the reflected part by form factors from
//! every solved patch to the opening polygon.

use std::f64::consts::PI;

use crate::support::stop_rule;
use lumiwall_render::radiosity::form_factor::polygon_to_polygon;
use lumiwall_render::radiosity::{
    HierarchicalOptions, ProgressiveOptions, SceneOccluders, Solution, solve_hierarchical,
    solve_progressive,
};
use lumiwall_render::scene::{Light, LightKind, Material, Polygon, Scene, V3};

const W: f64 = 1.0;
const D: f64 = 0.8;
const H: f64 = 0.6;

/// The floor (glowing) and four walls (two light, two dark) of the box, the top open,
/// with their material indices.
fn box_faces() -> [(Vec<V3>, usize); 5] {
    let floor = vec![
        V3::new(0., 0., 0.),
        V3::new(W, 0., 0.),
        V3::new(W, D, 0.),
        V3::new(0., D, 0.),
    ];
    let west = vec![
        V3::new(0., 0., 0.),
        V3::new(0., D, 0.),
        V3::new(0., D, H),
        V3::new(0., 0., H),
    ];
    let east = vec![
        V3::new(W, 0., 0.),
        V3::new(W, D, 0.),
        V3::new(W, D, H),
        V3::new(W, 0., H),
    ];
    let south = vec![
        V3::new(0., 0., 0.),
        V3::new(W, 0., 0.),
        V3::new(W, 0., H),
        V3::new(0., 0., H),
    ];
    let north = vec![
        V3::new(0., D, 0.),
        V3::new(W, D, 0.),
        V3::new(W, D, H),
        V3::new(0., D, H),
    ];
    [(floor, 1), (west, 0), (east, 0), (south, 2), (north, 2)]
}

/// The faces as polygons, each turned to face the box's centre.
fn facing_inwards(faces: [(Vec<V3>, usize); 5]) -> Vec<Polygon> {
    let c = V3::new(W / 2.0, D / 2.0, H / 2.0);
    faces
        .into_iter()
        .map(|(mut v, m)| {
            let n = (v[1] - v[0]).cross(&(v[2] - v[0]));
            if n.dot(&(c - (v[0] + v[2]) / 2.0)) < 0.0 {
                v.reverse();
            }
            Polygon {
                vertices: v,
                material: m,
                object: "box".into(),
            }
        })
        .collect()
}

/// Wall, glowing floor, dark.
fn box_materials() -> Vec<Material> {
    let material = |name: &str, reflectance_xyz: [f64; 3], emission: f64| Material {
        name: name.into(),
        reflectance_xyz,
        emission_cd_m2: [emission; 3],
    };
    vec![
        material("wall", [0.7, 0.72, 0.6], 0.0),
        material("glowing floor", [0.4, 0.5, 0.3], 20.0),
        material("dark", [0.2, 0.2, 0.25], 0.0),
    ]
}

fn open_box() -> Scene {
    Scene {
        polygons: facing_inwards(box_faces()),
        materials: box_materials(),
        lights: vec![Light {
            name: "bulb".into(),
            position: V3::new(W / 2.0, D / 2.0, 0.3),
            color_xyz: [1.0, 1.0, 1.0],
            kind: LightKind::Isotropic { intensity_cd: 50.0 },
        }],
        ..Scene::default()
    }
}

/// Solid angle of a w×d rectangle seen from a point on its axis at distance h.
fn rect_solid_angle(w: f64, d: f64, h: f64) -> f64 {
    4.0 * (w * d / ((w * w + 4.0 * h * h) * (d * d + 4.0 * h * h)).sqrt()).asin()
}

/// Where the emitted flux (Y lm) goes.
struct Balance {
    emitted: f64,
    absorbed: f64,
    escaped: f64,
}

impl Balance {
    /// |absorbed + escaped − emitted| relative to the emitted flux.
    fn imbalance(&self) -> f64 {
        (self.absorbed + self.escaped - self.emitted).abs() / self.emitted
    }

    /// The fluxes and the imbalance, for the test log.
    fn describe(&self) -> String {
        format!(
            "emitted {:.4} lm, absorbed {:.4} lm, escaped {:.4} lm, imbalance {:.2e}",
            self.emitted,
            self.absorbed,
            self.escaped,
            self.imbalance()
        )
    }
}

fn balance(scene: &Scene, sol: &Solution) -> Balance {
    let emitted = scene.emitted_flux_xyz_lm()[1];
    // the opening, facing down into the box (one-sided source for the form factor)
    let lid = [
        V3::new(0., 0., H),
        V3::new(0., D, H),
        V3::new(W, D, H),
        V3::new(W, 0., H),
    ];
    let mut absorbed = 0.0;
    let mut escaped = 0.0;
    for p in &sol.patches {
        let rho = scene.material_of(p.polygon).reflectance_xyz[1];
        absorbed += (1.0 - rho) * p.irradiance_xyz[1] * p.area_m2;
        let f = polygon_to_polygon(&p.vertices, &lid, 1e-7).value;
        escaped += p.exitance_xyz[1] * p.area_m2 * f;
    }
    let i_cd = match scene.lights[0].kind {
        LightKind::Isotropic { intensity_cd } => intensity_cd,
        _ => unreachable!(),
    };
    escaped += i_cd * rect_solid_angle(W, D, H - scene.lights[0].position.z);
    Balance {
        emitted,
        absorbed,
        escaped,
    }
}

#[test]
fn hierarchical_conserves_energy_in_an_open_box() {
    let scene = open_box();
    let occ = SceneOccluders::new(&scene);
    let opts = HierarchicalOptions {
        stop: stop_rule(0.001, 60, 10_000),
        // the balance is checked to 0.1 %, so the solve is asked for that; a coarse
        // smallest element keeps the CI test quick
        min_area_m2: 2e-3,
        ..HierarchicalOptions::default()
    };
    let sol = solve_hierarchical(&scene, &occ, &opts).unwrap();
    let b = balance(&scene, &sol);
    println!(
        "hierarchical: {}; {} patches, {} links, {} sweeps, {:?}",
        b.describe(),
        sol.stats.patches,
        sol.stats.links,
        sol.stats.iterations,
        sol.stop
    );
    assert!(b.imbalance() < 1e-3, "imbalance {}", b.imbalance());
    assert!(b.emitted > 4.0 * PI * 50.0);
}

#[test]
fn progressive_conserves_energy_in_an_open_box() {
    let scene = open_box();
    let occ = SceneOccluders::new(&scene);
    let opts = ProgressiveOptions {
        stop: stop_rule(1e-4, 60, 100_000),
        max_edge_m: 0.1,
    };
    let sol = solve_progressive(&scene, &occ, &opts).unwrap();
    let b = balance(&scene, &sol);
    println!(
        "progressive: {}; {} shots",
        b.describe(),
        sol.stats.iterations
    );
    assert!(b.imbalance() < 1e-3, "imbalance {}", b.imbalance());
}
