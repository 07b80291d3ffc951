//! Calculation grids: illuminance at points a lighting designer chooses, each with the
//! normal of its measuring plane, read from a solved scene.
//!
//! Direct light is computed exactly at the point: point, spot and goniometric lights by
//! the inverse-square cosine law with one shadow ray, daylight sources with one shadow
//! ray each, area emitters by the exact point-to-polygon form factor (subdivided, with
//! a shadow ray per part, only where something may block them). Indirect light comes
//! from the solution: every patch's reflected exitance times the exact form factor from
//! the point to the patch, times the patch's visible fraction.

mod file;

pub use file::{MAX_SENSORS, SensorError, read_sensors_csv, write_sensor_readings_csv};

use std::f64::consts::PI;

use rayon::prelude::*;

use crate::scene::{Scene, V3};

use super::form_factor::{point_to_polygon, targets_in_front};
use super::progressive::scene_extent;
use super::solution::{Patch, Solution};
use super::visibility::Visibility;

/// A measuring point: position and the unit normal of its measuring plane, in metres
/// in the scene's world frame (after `unit_m`).
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    /// Name from the sensor file.
    pub name: String,
    /// Position in metres.
    pub position: V3,
    /// Unit normal of the measuring plane (light arriving from its front counts).
    pub normal: V3,
}

/// Illuminance at one sensor (XYZ, Y in lux), split into its direct and indirect parts.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorReading {
    /// The sensor's name.
    pub name: String,
    /// Direct illuminance from lights, daylight and area emitters (XYZ lux).
    pub direct_xyz_lx: [f64; 3],
    /// Indirect illuminance: light reflected by the scene's surfaces (XYZ lux).
    pub indirect_xyz_lx: [f64; 3],
}

impl SensorReading {
    /// Total illuminance (XYZ lux).
    pub fn total_xyz_lx(&self) -> [f64; 3] {
        std::array::from_fn(|c| self.direct_xyz_lx[c] + self.indirect_xyz_lx[c])
    }

    /// Total photometric illuminance Y in lux.
    pub fn illuminance_lx(&self) -> f64 {
        self.total_xyz_lx()[1]
    }
}

/// Sub-triangles per fan triangle of an area emitter that may be partly occluded
/// (four levels of 4-fold splitting).
const EMITTER_SPLIT_LEVELS: u32 = 4;

/// Illuminance at every sensor from the solved `scene` (`sol`), with `vis` for the
/// shadow rays. Sensors are independent and run in parallel.
pub fn illuminance_at_sensors(
    scene: &Scene,
    sol: &Solution,
    vis: &dyn Visibility,
    sensors: &[Sensor],
) -> Vec<SensorReading> {
    let ctx = Ctx::new(scene, sol, vis);
    sensors.par_iter().map(|s| ctx.reading(s)).collect()
}

/// What every sensor reads from.
struct Ctx<'a> {
    scene: &'a Scene,
    vis: &'a dyn Visibility,
    /// Patches that reflect light, with their reflected exitance (XYZ lm/m²).
    reflecting: Vec<(&'a Patch, [f64; 3])>,
    /// Emissive polygons: index and emitted exitance π·L (XYZ lm/m²).
    emitters: Vec<(usize, [f64; 3])>,
    /// Offset of the sensor point along its normal, off the surface it may lie on.
    lift_m: f64,
    /// A distance beyond the scene, for shadow rays towards distant sources.
    far_m: f64,
}

impl<'a> Ctx<'a> {
    fn new(scene: &'a Scene, sol: &'a Solution, vis: &'a dyn Visibility) -> Self {
        let extent = scene_extent(scene);
        let emitted = |poly: usize| {
            let m = scene.material_of(poly);
            m.emission_cd_m2.map(|l| PI * l)
        };
        let reflecting = sol
            .patches
            .iter()
            .filter_map(|p| {
                let e = emitted(p.polygon);
                let b = p.exitance_at(&centroid(&p.vertices));
                let r: [f64; 3] = std::array::from_fn(|c| (b[c] - e[c]).max(0.0));
                (r.iter().any(|&v| v > 0.0)).then_some((p, r))
            })
            .collect();
        let emitters = (0..scene.polygons.len())
            .filter(|&i| scene.material_of(i).is_emitter())
            .map(|i| (i, emitted(i)))
            .collect();
        Self {
            scene,
            vis,
            reflecting,
            emitters,
            lift_m: 1e-7 * extent.max(1e-3),
            far_m: 4.0 * extent + 1.0,
        }
    }

    fn reading(&self, s: &Sensor) -> SensorReading {
        let x = s.position + s.normal * self.lift_m;
        let n = &s.normal;
        let mut direct = self.point_lights(&x, n);
        add(&mut direct, self.daylight(&x, n));
        add(&mut direct, self.area_emitters(&x, n));
        SensorReading {
            name: s.name.clone(),
            direct_xyz_lx: direct,
            indirect_xyz_lx: self.reflected(&x, n),
        }
    }

    /// Point-like lights: E = I·cos ε / d², one shadow ray.
    fn point_lights(&self, x: &V3, n: &V3) -> [f64; 3] {
        let mut e = [0.0; 3];
        for l in &self.scene.lights {
            let d = l.position - x;
            let d2 = d.norm_squared();
            if d2 <= 0.0 {
                continue;
            }
            let dn = d / d2.sqrt();
            let cos = n.dot(&dn);
            if cos <= 0.0 || self.blocked(x, &l.position, usize::MAX) {
                continue;
            }
            let y = l.intensity_cd(&(-dn)) * cos / d2;
            add(&mut e, l.color_xyz.map(|c| c * y));
        }
        e
    }

    /// Sky cells and sun: E = E_n·cos ε, one shadow ray each.
    fn daylight(&self, x: &V3, n: &V3) -> [f64; 3] {
        let mut e = [0.0; 3];
        let Some(d) = &self.scene.sky else {
            return e;
        };
        for src in d.sources() {
            let u = src.direction.normalize();
            let cos = n.dot(&u);
            if cos <= 0.0 || self.blocked(x, &(x + u * self.far_m), usize::MAX) {
                continue;
            }
            let y = src.normal_illuminance_lux * cos;
            add(&mut e, src.color_xyz.map(|c| c * y));
        }
        e
    }

    /// Area emitters: π·L times the exact form factor, per visible part.
    fn area_emitters(&self, x: &V3, n: &V3) -> [f64; 3] {
        let mut e = [0.0; 3];
        for &(i, exitance) in &self.emitters {
            let verts = &self.scene.polygons[i].vertices;
            let f = self.visible_form_factor(x, n, verts, i);
            add(&mut e, exitance.map(|m| m * f));
        }
        e
    }

    /// Form factor from the point to emitter polygon `poly`, counting only its
    /// unoccluded parts: exact when nothing may block it; otherwise summed over
    /// sub-triangles, each seen or not by the ray to its centroid.
    fn visible_form_factor(&self, x: &V3, n: &V3, verts: &[V3], poly: usize) -> f64 {
        let Some(normal) = crate::scene::polygon_normal(verts) else {
            return 0.0;
        };
        if !self.vis.may_occlude(&[*x], usize::MAX, verts, poly) {
            return point_to_polygon(x, n, verts, &normal);
        }
        let mut f = 0.0;
        for k in 1..verts.len() - 1 {
            for tri in split_triangle([verts[0], verts[k], verts[k + 1]], EMITTER_SPLIT_LEVELS) {
                let part = point_to_polygon(x, n, &tri, &normal);
                if part > 0.0 && !self.blocked(x, &centroid(&tri), poly) {
                    f += part;
                }
            }
        }
        f
    }

    /// Light reflected by the solution's patches.
    fn reflected(&self, x: &V3, n: &V3) -> [f64; 3] {
        let mut e = [0.0; 3];
        for (p, r) in &self.reflecting {
            let f = point_to_polygon(x, n, &p.vertices, &p.normal);
            if f <= 0.0 {
                continue;
            }
            let seen = self.visible_fraction(x, n, p);
            add(&mut e, r.map(|m| m * f * seen));
        }
        e
    }

    /// Fraction of shadow rays from `x` to the patch's sample points (its centroid and
    /// four inner points, those in front of `x`'s plane) that reach it.
    fn visible_fraction(&self, x: &V3, n: &V3, p: &Patch) -> f64 {
        if !self
            .vis
            .may_occlude(&[*x], usize::MAX, &p.vertices, p.polygon)
        {
            return 1.0;
        }
        let c = centroid(&p.vertices);
        let mut samples = vec![c];
        samples.extend(p.vertices.iter().map(|v| c + (v - c) * 0.5));
        let targets = targets_in_front(x, n, &samples, &p.vertices);
        if targets.is_empty() {
            return 0.0;
        }
        let seen = targets
            .iter()
            .filter(|t| !self.blocked(x, t, p.polygon))
            .count();
        seen as f64 / targets.len() as f64
    }

    fn blocked(&self, x: &V3, target: &V3, target_poly: usize) -> bool {
        self.vis.occluded(x, target, [usize::MAX, target_poly])
    }
}

fn add(acc: &mut [f64; 3], v: [f64; 3]) {
    for (a, b) in acc.iter_mut().zip(v) {
        *a += b;
    }
}

fn centroid(v: &[V3]) -> V3 {
    v.iter().sum::<V3>() / v.len().max(1) as f64
}

/// A triangle split `levels` times into four (edge midpoints): 4^levels triangles of
/// the same orientation.
fn split_triangle(t: [V3; 3], levels: u32) -> Vec<[V3; 3]> {
    let mut tris = vec![t];
    for _ in 0..levels {
        tris = tris
            .into_iter()
            .flat_map(|[a, b, c]| {
                let (ab, bc, ca) = ((a + b) / 2.0, (b + c) / 2.0, (c + a) / 2.0);
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            })
            .collect();
    }
    tris
}
