//! Orientation of a luminaire: the map between its local photometric frame
//! (−z = nadir, +x = C0°, +y = C90°) and world coordinates.

/// Orthonormal, right-handed frame of a luminaire. `x`, `y`, `z` are the world-space
/// directions of the local axes; the photometric axis (γ = 0°, nadir) is `-z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightFrame {
    /// World direction of local +x (C = 0°).
    pub x: [f64; 3],
    /// World direction of local +y (C = 90°).
    pub y: [f64; 3],
    /// World direction of local +z (γ = 180°, straight up for a ceiling downlight).
    pub z: [f64; 3],
}

impl Default for LightFrame {
    fn default() -> Self {
        Self::identity()
    }
}

pub(crate) use crate::mesh::{cross, dot};

/// Shortest vector [`normalize`] accepts (near the smallest normal f64, so that the
/// division stays finite).
const MIN_NORMALIZABLE_LENGTH: f64 = 1e-300;

pub(crate) fn normalize(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = dot(a, a).sqrt();
    if n.is_finite() && n > MIN_NORMALIZABLE_LENGTH {
        Some([a[0] / n, a[1] / n, a[2] / n])
    } else {
        None
    }
}

impl LightFrame {
    /// Local axes equal world axes: a luminaire hanging from a ceiling whose world
    /// up is +z shines down along −z.
    pub fn identity() -> Self {
        Self {
            x: [1.0, 0.0, 0.0],
            y: [0.0, 1.0, 0.0],
            z: [0.0, 0.0, 1.0],
        }
    }

    /// A frame whose photometric axis (local −z, γ = 0°) points along `aim_world`.
    /// Local +x (C0°) is chosen as the projection of world +x (or +y when the aim is
    /// parallel to x) onto the plane normal to the aim. Returns the identity frame
    /// if `aim_world` is zero or not finite.
    pub fn aimed(aim_world: [f64; 3]) -> Self {
        let Some(down) = normalize(aim_world) else {
            return Self::identity();
        };
        let z = [-down[0], -down[1], -down[2]];
        let helper = if down[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let d = dot(helper, z);
        let x = normalize([
            helper[0] - d * z[0],
            helper[1] - d * z[1],
            helper[2] - d * z[2],
        ])
        .unwrap_or([1.0, 0.0, 0.0]);
        let y = cross(z, x);
        Self { x, y, z }
    }

    /// A frame whose photometric axis (local −z, γ = 0°) points along `axis_world`
    /// and whose C0° direction (local +x) is `c0_world` made orthogonal to the axis.
    /// Use this to convert a frame given as "x, y, z = optical axis" (as in
    /// `scene::LightKind::Goniometric`): `LightFrame::from_axis(x, z)`. Falls back
    /// to [`LightFrame::aimed`] when `c0_world` is parallel to the axis or zero.
    pub fn from_axis(c0_world: [f64; 3], axis_world: [f64; 3]) -> Self {
        let Some(down) = normalize(axis_world) else {
            return Self::identity();
        };
        let z = [-down[0], -down[1], -down[2]];
        let d = dot(c0_world, z);
        match normalize([
            c0_world[0] - d * z[0],
            c0_world[1] - d * z[1],
            c0_world[2] - d * z[2],
        ]) {
            Some(x) => Self {
                x,
                y: cross(z, x),
                z,
            },
            None => Self::aimed(axis_world),
        }
    }

    /// Expresses a world direction in the local frame.
    pub fn to_local(&self, dir_world: [f64; 3]) -> [f64; 3] {
        [
            dot(dir_world, self.x),
            dot(dir_world, self.y),
            dot(dir_world, self.z),
        ]
    }

    /// Expresses a local direction in world coordinates.
    pub fn to_world(&self, dir_local: [f64; 3]) -> [f64; 3] {
        let mut out = [0.0; 3];
        for (k, o) in out.iter_mut().enumerate() {
            *o = self.x[k] * dir_local[0] + self.y[k] * dir_local[1] + self.z[k] * dir_local[2];
        }
        out
    }
}
