//! The in-memory scene: polygons, materials, lights, camera.

use std::sync::Arc;

use super::geom::V3;

/// Luminous intensity distribution of a goniometric light: candela for a unit
/// direction given in the light's local frame (z = optical axis). This is the hook
/// through which `photometry::IntensityDistribution` (IES LM-63, EULUMDAT) plugs in.
pub type IntensityFn = Arc<dyn Fn([f64; 3]) -> f64 + Send + Sync>;

/// A distant directional source: the sun, or one cell of a discretised sky (a cell of
/// luminance L and solid angle ω gives L·ω lux on a plane facing it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectionalSource {
    /// Unit vector from the scene towards the source (world frame).
    pub direction: V3,
    /// Illuminance on an unobstructed plane facing the source, lux (Y).
    pub normal_illuminance_lux: f64,
    /// Colour as XYZ relative to Y = 1.
    pub color_xyz: [f64; 3],
}

/// Daylight: a CIE sky as a set of distant cells (`photometry::Sky::patches`) and,
/// optionally, the sun. The ground below the horizon is black.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Daylight {
    /// Sky cells (without the sun).
    pub sky_cells: Vec<DirectionalSource>,
    /// The sun, if above the horizon.
    pub sun: Option<DirectionalSource>,
}

impl Daylight {
    /// Every directional source: the sky cells, then the sun.
    pub fn sources(&self) -> impl Iterator<Item = &DirectionalSource> {
        self.sky_cells.iter().chain(self.sun.iter())
    }

    /// Illuminance (XYZ, Y in lux) on an unobstructed plane with unit normal `n`.
    pub fn illuminance_on_plane_xyz(&self, n: &V3) -> [f64; 3] {
        let mut e = [0.0; 3];
        for s in self.sources() {
            let c = s.normal_illuminance_lux * n.dot(&s.direction).max(0.0);
            for (k, v) in e.iter_mut().enumerate() {
                *v += c * s.color_xyz[k];
            }
        }
        e
    }
}

/// A diffuse (Lambertian) material.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Name used in the scene file.
    pub name: String,
    /// Reflectance per XYZ channel; Y is the luminous reflectance, each in [0, 1).
    pub reflectance_xyz: [f64; 3],
    /// Emitted luminance of an area emitter as XYZ, Y in cd/m² (zero for non-emitters).
    /// Lambertian: the emitted luminous exitance is π·L lm/m².
    pub emission_cd_m2: [f64; 3],
}

impl Material {
    /// True when the material emits light.
    pub fn is_emitter(&self) -> bool {
        self.emission_cd_m2.iter().any(|&e| e > 0.0)
    }
}

/// A planar convex polygon (triangle or quad) of the input geometry.
#[derive(Debug, Clone, PartialEq)]
pub struct Polygon {
    /// Vertices in metres, counter-clockwise seen from the lit (front) side; 3 or 4.
    pub vertices: Vec<V3>,
    /// Index into [`Scene::materials`].
    pub material: usize,
    /// OBJ object or group name, for messages.
    pub object: String,
}

/// How a point-like light distributes its intensity.
#[derive(Clone)]
pub enum LightKind {
    /// The same intensity in every direction.
    Isotropic {
        /// Luminous intensity in cd.
        intensity_cd: f64,
    },
    /// A spot: full intensity inside `inner_half_angle_rad` of the axis, falling
    /// linearly (in angle) to zero at `outer_half_angle_rad`.
    Spot {
        /// Unit axis direction.
        axis: V3,
        /// Luminous intensity on the axis in cd.
        intensity_cd: f64,
        /// Half angle of full intensity in radians.
        inner_half_angle_rad: f64,
        /// Half angle at which the intensity reaches zero in radians.
        outer_half_angle_rad: f64,
    },
    /// Goniometric data (the photometry module's distributions).
    Goniometric {
        /// Local frame: unit x, y and z (optical axis) in world coordinates.
        frame: [V3; 3],
        /// Intensity in cd for a local unit direction.
        distribution: IntensityFn,
        /// Total flux in lm (for energy balances), as reported by the data.
        total_flux_lm: f64,
    },
}

impl std::fmt::Debug for LightKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LightKind::Isotropic { intensity_cd } => {
                write!(f, "Isotropic {{ intensity_cd: {intensity_cd} }}")
            }
            LightKind::Spot {
                intensity_cd,
                inner_half_angle_rad,
                outer_half_angle_rad,
                ..
            } => write!(
                f,
                "Spot {{ intensity_cd: {intensity_cd}, inner: {inner_half_angle_rad}, outer: {outer_half_angle_rad} }}"
            ),
            LightKind::Goniometric { total_flux_lm, .. } => {
                write!(f, "Goniometric {{ total_flux_lm: {total_flux_lm} }}")
            }
        }
    }
}

/// A point-like light source.
#[derive(Debug, Clone)]
pub struct Light {
    /// Name, for messages.
    pub name: String,
    /// Position in metres.
    pub position: V3,
    /// Colour as XYZ relative to Y = 1 (multiplies the photometric intensity).
    pub color_xyz: [f64; 3],
    /// Intensity distribution.
    pub kind: LightKind,
}

impl Light {
    /// Luminous intensity in cd towards the unit world direction `dir`.
    pub fn intensity_cd(&self, dir: &V3) -> f64 {
        match &self.kind {
            LightKind::Isotropic { intensity_cd } => *intensity_cd,
            LightKind::Spot {
                axis,
                intensity_cd,
                inner_half_angle_rad,
                outer_half_angle_rad,
            } => {
                let angle = axis.dot(dir).clamp(-1.0, 1.0).acos();
                if angle <= *inner_half_angle_rad {
                    *intensity_cd
                } else if angle >= *outer_half_angle_rad {
                    0.0
                } else {
                    let span =
                        (outer_half_angle_rad - inner_half_angle_rad).max(MIN_FALLOFF_SPAN_RAD);
                    intensity_cd * (outer_half_angle_rad - angle) / span
                }
            }
            LightKind::Goniometric {
                frame,
                distribution,
                ..
            } => {
                let local = [frame[0].dot(dir), frame[1].dot(dir), frame[2].dot(dir)];
                let i = distribution(local);
                if i.is_finite() && i > 0.0 { i } else { 0.0 }
            }
        }
    }

    /// Total luminous flux in lm.
    pub fn total_flux_lm(&self) -> f64 {
        match &self.kind {
            LightKind::Isotropic { intensity_cd } => 4.0 * std::f64::consts::PI * intensity_cd,
            LightKind::Spot {
                intensity_cd,
                inner_half_angle_rad,
                outer_half_angle_rad,
                ..
            } => spot_flux_per_cd(*inner_half_angle_rad, *outer_half_angle_rad) * intensity_cd,
            LightKind::Goniometric { total_flux_lm, .. } => *total_flux_lm,
        }
    }
}

/// Smallest angular width of a spot's fall-off in radians (avoids 0/0 when the
/// inner and outer half angles are equal).
const MIN_FALLOFF_SPAN_RAD: f64 = 1e-12;

/// Simpson intervals (even) over a spot's fall-off ring in [`spot_flux_per_cd`].
const SPOT_FALLOFF_SIMPSON_INTERVALS: usize = 512;

/// Flux in lm of a [`LightKind::Spot`] of 1 cd on the axis (numerical integral of the
/// linear angular falloff; exact 2π(1 − cos θ) when inner = outer).
pub(super) fn spot_flux_per_cd(inner: f64, outer: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    let full = tau * (1.0 - inner.cos());
    if outer <= inner {
        return full;
    }
    // Simpson on the falloff ring: ∫ profile(θ) 2π sin θ dθ.
    let n = SPOT_FALLOFF_SIMPSON_INTERVALS;
    let h = (outer - inner) / n as f64;
    let f = |t: f64| (outer - t) / (outer - inner) * tau * t.sin();
    let mut s = f(inner) + f(outer);
    for k in 1..n {
        let w = if k % 2 == 1 { 4.0 } else { 2.0 };
        s += w * f(inner + k as f64 * h);
    }
    full + s * h / 3.0
}

/// A pinhole camera.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// Eye position in metres.
    pub position: V3,
    /// Point looked at.
    pub look_at: V3,
    /// Up direction (need not be orthogonal to the view direction).
    pub up: V3,
    /// Vertical field of view in degrees.
    pub vfov_deg: f64,
    /// Image width in pixels.
    pub width_px: u32,
    /// Image height in pixels.
    pub height_px: u32,
}

/// A complete scene.
#[derive(Clone, Default)]
pub struct Scene {
    /// Input polygons (after the checks).
    pub polygons: Vec<Polygon>,
    /// Materials referenced by the polygons.
    pub materials: Vec<Material>,
    /// Point-like lights.
    pub lights: Vec<Light>,
    /// Camera for images, if the scene file defines one.
    pub camera: Option<Camera>,
    /// Daylight (sky and sun), if the scene is lit by one.
    pub sky: Option<Daylight>,
}

impl std::fmt::Debug for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scene")
            .field("polygons", &self.polygons.len())
            .field("materials", &self.materials)
            .field("lights", &self.lights)
            .field("camera", &self.camera)
            .field("sky", &self.sky.as_ref().map(|d| d.sky_cells.len()))
            .finish()
    }
}

impl Scene {
    /// Material of polygon `i`.
    pub fn material_of(&self, polygon: usize) -> &Material {
        &self.materials[self.polygons[polygon].material]
    }

    /// True when anything lights the scene: an area emitter, a light with flux, or
    /// daylight.
    pub fn has_emission(&self) -> bool {
        self.emitted_flux_xyz_lm()[1] > 0.0
            || self
                .sky
                .as_ref()
                .is_some_and(|d| d.sources().any(|s| s.normal_illuminance_lux > 0.0))
    }

    /// Total flux emitted by area emitters and lights, per XYZ channel (Y in lm);
    /// daylight, which has no finite flux, is not included.
    pub fn emitted_flux_xyz_lm(&self) -> [f64; 3] {
        let mut phi = [0.0; 3];
        for p in &self.polygons {
            let m = &self.materials[p.material];
            let a = super::geom::polygon_area_m2(&p.vertices);
            for (c, v) in phi.iter_mut().enumerate() {
                *v += std::f64::consts::PI * m.emission_cd_m2[c] * a;
            }
        }
        for l in &self.lights {
            let f = l.total_flux_lm();
            for (c, v) in phi.iter_mut().enumerate() {
                *v += f * l.color_xyz[c];
            }
        }
        phi
    }
}
