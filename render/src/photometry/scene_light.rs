//! Bridge to the solver's scene types: a photometry light as a `scene::Light`.

use super::distribution::IntensityDistribution;
use super::frame::LightFrame;
use crate::scene::{Light, LightKind, V3};
use std::sync::Arc;

/// Wraps a distribution placed at `position` (m) with orientation `frame` as a
/// [`crate::scene::Light`] of kind `Goniometric` with equal-energy white colour.
///
/// `scene::LightKind::Goniometric` takes a frame whose z is the optical axis; ours has
/// the optical axis along local −z, so the scene frame is (x, −y, −z) of `frame` (a
/// rotation by 180° about x) and the local direction (a, b, c) maps back to (a, −b, −c).
pub fn to_scene_light(
    name: &str,
    distribution: &IntensityDistribution,
    position: [f64; 3],
    frame: &LightFrame,
) -> Light {
    let v = |a: [f64; 3]| V3::new(a[0], a[1], a[2]);
    let neg = |a: [f64; 3]| [-a[0], -a[1], -a[2]];
    let total_flux_lm = distribution.total_flux_lm();
    let dist = distribution.clone();
    Light {
        name: name.to_string(),
        position: v(position),
        color_xyz: [1.0, 1.0, 1.0],
        kind: LightKind::Goniometric {
            frame: [v(frame.x), v(neg(frame.y)), v(neg(frame.z))],
            distribution: Arc::new(move |d: [f64; 3]| dist.intensity_cd([d[0], -d[1], -d[2]])),
            total_flux_lm,
        },
    }
}
