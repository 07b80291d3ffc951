//! Point-like and distant senders: point, spot and goniometric lights (Kresse
//! 2.4.2–2.4.3) and the sun and the cells of a CIE sky (2.4.4). Their emission never
//! changes during a solve, and they are never subdivided.

use crate::scene::{Scene, V3};

/// A sender that is not a surface.
#[derive(Debug, Clone)]
pub(super) enum Emitter {
    /// `scene.lights[light]`.
    Point {
        light: usize,
        position: V3,
        color: [f64; 3],
    },
    /// A distant source: the sun or a sky cell.
    Directional {
        /// Unit vector towards the source.
        direction: V3,
        /// Illuminance on a plane facing the source, lux.
        normal_lux: f64,
        color: [f64; 3],
    },
}

/// Directions sampled across a cone to bound a goniometric distribution (Kresse 2.6.1:
/// "LVK: … muß über das Patch gesampelt werden").
const CONE_SAMPLES: usize = 12;

impl Emitter {
    /// Every light and daylight source of a scene.
    pub(crate) fn all(scene: &Scene) -> Vec<Emitter> {
        let mut out: Vec<Emitter> = scene
            .lights
            .iter()
            .enumerate()
            .map(|(i, l)| Emitter::Point {
                light: i,
                position: l.position,
                color: l.color_xyz,
            })
            .collect();
        if let Some(d) = &scene.sky {
            for s in d.sources() {
                if s.normal_illuminance_lux > 0.0 {
                    out.push(Emitter::Directional {
                        direction: s.direction.normalize(),
                        normal_lux: s.normal_illuminance_lux,
                        color: s.color_xyz,
                    });
                }
            }
        }
        out
    }

    /// Colour (XYZ per unit Y).
    pub(crate) fn color(&self) -> [f64; 3] {
        match self {
            Emitter::Point { color, .. } | Emitter::Directional { color, .. } => *color,
        }
    }

    /// Illuminance (Y, lux per unit colour) at `x` on a surface with unit normal `n`,
    /// unoccluded.
    pub(crate) fn irradiance(&self, scene: &Scene, x: &V3, n: &V3) -> f64 {
        let (e, u) = self.normal_irradiance(scene, x);
        e * n.dot(&u).max(0.0)
    }

    /// Mean illuminance (Y, lux per unit colour) over the polygon `verts` (unit normal
    /// `n`, area `area`), unoccluded: the flux I·Ω into the solid angle Ω the polygon
    /// subtends at a point light, over its area (exact for an isotropic light, the
    /// intensity taken towards the centroid otherwise); a distant source is even.
    pub(crate) fn mean_irradiance(&self, scene: &Scene, verts: &[V3], n: &V3, area: f64) -> f64 {
        match self {
            Emitter::Point {
                light, position, ..
            } => {
                let h = n.dot(&(position - verts[0]));
                if h <= 0.0 || area <= 0.0 {
                    return 0.0;
                }
                let c = verts.iter().sum::<V3>() / verts.len() as f64;
                let dir = (c - position).try_normalize(1e-300).unwrap_or_else(V3::z);
                let rel: Vec<V3> = verts.iter().map(|v| v - position).collect();
                let omega: f64 = (1..rel.len() - 1)
                    .map(|k| triangle_solid_angle(&rel[0], &rel[k], &rel[k + 1]))
                    .sum();
                scene.lights[*light].intensity_cd(&dir) * omega / area
            }
            Emitter::Directional { .. } => {
                let c = verts.iter().sum::<V3>() / verts.len() as f64;
                self.irradiance(scene, &c, n)
            }
        }
    }

    /// Normal illuminance (lux per unit colour) at `x` and the unit direction from `x`
    /// towards the source.
    pub(crate) fn normal_irradiance(&self, scene: &Scene, x: &V3) -> (f64, V3) {
        match self {
            Emitter::Point {
                light, position, ..
            } => {
                let d = position - x;
                let d2 = d.norm_squared();
                if d2 <= 0.0 {
                    return (0.0, V3::z());
                }
                let u = d / d2.sqrt();
                (scene.lights[*light].intensity_cd(&(-u)) / d2, u)
            }
            Emitter::Directional {
                direction,
                normal_lux,
                ..
            } => (*normal_lux, *direction),
        }
    }

    /// Upper bound of the normal illuminance anywhere in the sphere (`c`, `r`);
    /// infinite when the sphere holds a point light.
    pub(crate) fn max_normal_irradiance(&self, scene: &Scene, c: &V3, r: f64) -> f64 {
        match self {
            Emitter::Point {
                light, position, ..
            } => {
                let d = (position - c).norm();
                if d <= r {
                    return f64::INFINITY;
                }
                let axis = (c - position) / d;
                let imax = max_intensity_in_cone(scene, *light, &axis, (r / d).clamp(0.0, 1.0));
                imax / ((d - r) * (d - r))
            }
            Emitter::Directional { normal_lux, .. } => *normal_lux,
        }
    }

    /// Far end of a shadow ray from `x` towards the source (`far`: a length beyond the
    /// scene).
    pub(crate) fn ray_end(&self, x: &V3, far: f64) -> V3 {
        match self {
            Emitter::Point { position, .. } => *position,
            Emitter::Directional { direction, .. } => x + direction * far,
        }
    }

    /// The sender end of a shaft towards the points `recv`: the light's position, or
    /// the receiver moved far towards a distant source.
    pub(crate) fn shaft_end(&self, recv: &[V3], far: f64) -> Vec<V3> {
        match self {
            Emitter::Point { position, .. } => vec![*position],
            Emitter::Directional { direction, .. } => {
                recv.iter().map(|p| p + direction * far).collect()
            }
        }
    }

    /// Position of a point light (for the analytic maximum of Kresse 2.6.1).
    pub(crate) fn position(&self) -> Option<V3> {
        match self {
            Emitter::Point { position, .. } => Some(*position),
            Emitter::Directional { .. } => None,
        }
    }
}

/// Solid angle of the triangle (a, b, c) seen from the origin (Van Oosterom &
/// Strackee 1983).
fn triangle_solid_angle(a: &V3, b: &V3, c: &V3) -> f64 {
    let (la, lb, lc) = (a.norm(), b.norm(), c.norm());
    let num = a.dot(&b.cross(c)).abs();
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * num.atan2(den)
}

/// Largest intensity of `scene.lights[light]` within the cone about the unit `axis`
/// whose half-angle has sine `sin_half`: the axis, two rings and the rim, sampled.
fn max_intensity_in_cone(scene: &Scene, light: usize, axis: &V3, sin_half: f64) -> f64 {
    let l = &scene.lights[light];
    let mut best = l.intensity_cd(axis);
    if sin_half <= 0.0 {
        return best;
    }
    let helper = if axis.x.abs() < 0.9 { V3::x() } else { V3::y() };
    let e1 = axis.cross(&helper).normalize();
    let e2 = axis.cross(&e1);
    let half = sin_half.asin().min(std::f64::consts::FRAC_PI_2);
    for ring in [0.5, 1.0] {
        let a = half * ring;
        let (s, c) = a.sin_cos();
        for k in 0..CONE_SAMPLES {
            let phi = std::f64::consts::TAU * (k as f64 + 0.5 * ring) / CONE_SAMPLES as f64;
            let d = axis * c + (e1 * phi.cos() + e2 * phi.sin()) * s;
            best = best.max(l.intensity_cd(&d));
        }
    }
    // sampled, not exact: a margin for peaks between the samples
    best * 1.05
}
