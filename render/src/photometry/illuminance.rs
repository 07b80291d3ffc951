//! Direct illuminance from a point-like goniometric source: the inverse-square cosine
//! law E = I(θ)·cos ε / d², shared by tests and the radiosity solver.

use super::distribution::IntensityDistribution;
use super::frame::{LightFrame, dot, normalize};

/// Illuminance in lux at `point` on a surface with normal `normal` (need not be unit)
/// from a source with intensity distribution `light` at `light_pos`, oriented by
/// `frame`, multiplied by `visibility` (1 = unoccluded, 0 = fully shadowed; clamped to
/// [0, 1]). Points behind the surface (cos ε ≤ 0), a zero normal and a point at the
/// source itself (d = 0, singular) give 0.
pub fn direct_illuminance_lux(
    light: &IntensityDistribution,
    light_pos: [f64; 3],
    frame: &LightFrame,
    point: [f64; 3],
    normal: [f64; 3],
    visibility: f64,
) -> f64 {
    let to_light = [
        light_pos[0] - point[0],
        light_pos[1] - point[1],
        light_pos[2] - point[2],
    ];
    let d2 = dot(to_light, to_light);
    let (Some(n), Some(l)) = (normalize(normal), normalize(to_light)) else {
        return 0.0;
    };
    if !(d2 > 0.0 && d2.is_finite()) {
        return 0.0;
    }
    let cos_e = dot(n, l);
    if cos_e <= 0.0 {
        return 0.0;
    }
    let emit_dir_world = [-l[0], -l[1], -l[2]];
    let intensity = light.intensity_cd(frame.to_local(emit_dir_world));
    let vis = if visibility.is_finite() {
        visibility.clamp(0.0, 1.0)
    } else {
        0.0
    };
    intensity * cos_e / d2 * vis
}

/// A point-like luminaire placed in the world.
#[derive(Debug, Clone, PartialEq)]
pub struct PointLight {
    /// Intensity distribution in the luminaire's local frame.
    pub distribution: IntensityDistribution,
    /// Photometric centre, world coordinates (metres).
    pub position: [f64; 3],
    /// Orientation of the local frame.
    pub frame: LightFrame,
}

impl PointLight {
    /// Illuminance in lux at `point` with surface normal `normal`; see
    /// [`direct_illuminance_lux`].
    pub fn illuminance_lux(&self, point: [f64; 3], normal: [f64; 3], visibility: f64) -> f64 {
        direct_illuminance_lux(
            &self.distribution,
            self.position,
            &self.frame,
            point,
            normal,
            visibility,
        )
    }

    /// Luminous intensity (cd) this light sends towards a world direction.
    pub fn intensity_towards_cd(&self, dir_world: [f64; 3]) -> f64 {
        self.distribution
            .intensity_cd(self.frame.to_local(dir_world))
    }
}
