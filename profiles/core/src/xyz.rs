//! The measured quantity, CIE 1931 XYZ in absolute units, and its chromaticity.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::CoreError;
use crate::macros::array_conversions;

/// CIE 1931 2° tristimulus values in absolute units: `y` is luminance in cd/m²,
/// `x` and `z` are on the same scale.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Xyz {
    /// X (cd/m² scale).
    pub x: f64,
    /// Y, luminance in cd/m².
    pub y: f64,
    /// Z (cd/m² scale).
    pub z: f64,
}

impl Xyz {
    /// Builds from the three components (Y in cd/m²).
    pub const fn new(x: f64, y: f64, z: f64) -> Self {
        Self { x, y, z }
    }

    /// From chromaticity `(x, y)` and luminance `Y` in cd/m².
    /// Returns black for `y_chroma <= 0`.
    pub fn from_xy_luminance(x_chroma: f64, y_chroma: f64, y_cd_m2: f64) -> Self {
        Xy::new(x_chroma, y_chroma).with_luminance(y_cd_m2)
    }

    /// Luminance in cd/m².
    pub fn luminance_cd_m2(&self) -> f64 {
        self.y
    }

    /// Chromaticity; `None` when X+Y+Z is not positive and finite.
    pub fn chromaticity(&self) -> Option<Xy> {
        let s = self.x + self.y + self.z;
        (s > 0.0 && s.is_finite()).then(|| Xy::new(self.x / s, self.y / s))
    }

    /// Chromaticity `[x, y]`; `None` when X+Y+Z is not positive and finite.
    pub fn xy(&self) -> Option<[f64; 2]> {
        self.chromaticity().map(Xy::to_array)
    }

    /// As an array `[X, Y, Z]`.
    pub fn to_array(self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }

    /// From an array `[X, Y, Z]`.
    pub fn from_array(a: [f64; 3]) -> Self {
        Self::new(a[0], a[1], a[2])
    }

    /// As single-precision `[X, Y, Z]` (frames, the post pass).
    pub fn to_f32_array(self) -> [f32; 3] {
        self.to_array().map(|v| v as f32)
    }

    /// As a nalgebra column vector.
    pub fn to_vector(self) -> Vector3<f64> {
        Vector3::new(self.x, self.y, self.z)
    }

    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }
}

array_conversions!(Xyz, [f64; 3]);

impl From<Vector3<f64>> for Xyz {
    fn from(v: Vector3<f64>) -> Self {
        Self::new(v[0], v[1], v[2])
    }
}

impl From<Xyz> for Vector3<f64> {
    fn from(v: Xyz) -> Self {
        v.to_vector()
    }
}

impl std::ops::Add for Xyz {
    type Output = Xyz;
    fn add(self, o: Xyz) -> Xyz {
        Xyz::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl std::ops::Sub for Xyz {
    type Output = Xyz;
    fn sub(self, o: Xyz) -> Xyz {
        Xyz::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl std::ops::Mul<f64> for Xyz {
    type Output = Xyz;
    fn mul(self, k: f64) -> Xyz {
        Xyz::new(self.x * k, self.y * k, self.z * k)
    }
}

/// CIE 1931 xy chromaticity. Serialised as `[x, y]`, as every lumiwall file writes it.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(from = "[f64; 2]", into = "[f64; 2]")]
pub struct Xy {
    /// x = X / (X+Y+Z).
    pub x: f64,
    /// y = Y / (X+Y+Z).
    pub y: f64,
}

impl Xy {
    /// Builds from the two coordinates (unchecked; see [`Xy::checked`]).
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }

    /// From `[x, y]`.
    pub const fn from_array(a: [f64; 2]) -> Self {
        Self::new(a[0], a[1])
    }

    /// As `[x, y]`.
    pub const fn to_array(self) -> [f64; 2] {
        [self.x, self.y]
    }

    /// True inside the chromaticity diagram's bounding triangle: finite, x ≥ 0, y > 0,
    /// x + y ≤ 1 (so that XYZ from it is finite and non-negative).
    pub fn is_valid(&self) -> bool {
        self.x.is_finite()
            && self.y.is_finite()
            && self.x >= 0.0
            && self.y > 0.0
            && self.x + self.y <= 1.0
    }

    /// `self` when [`Xy::is_valid`], else an error naming `what`.
    pub fn checked(self, what: &str) -> Result<Self, CoreError> {
        if self.is_valid() {
            Ok(self)
        } else {
            Err(CoreError::Chromaticity {
                what: what.to_string(),
                x: self.x,
                y: self.y,
            })
        }
    }

    /// XYZ of this chromaticity at luminance `y_cd_m2`; black for `y <= 0`.
    pub fn with_luminance(self, y_cd_m2: f64) -> Xyz {
        if self.y <= 0.0 {
            return Xyz::default();
        }
        Xyz {
            x: self.x * y_cd_m2 / self.y,
            y: y_cd_m2,
            z: (1.0 - self.x - self.y) * y_cd_m2 / self.y,
        }
    }

    /// Euclidean distance in the xy diagram.
    pub fn distance(self, other: Xy) -> f64 {
        (self.x - other.x).hypot(self.y - other.y)
    }
}

array_conversions!(Xy, [f64; 2]);

impl std::fmt::Display for Xy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "({:.4}, {:.4})", self.x, self.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xy_and_luminance_round_trip_through_xyz() {
        let xyz = Xy::new(0.64, 0.33).with_luminance(21.26);
        assert!((xyz.y - 21.26).abs() < 1e-12);
        let back = xyz.chromaticity().unwrap();
        assert!((back.x - 0.64).abs() < 1e-12 && (back.y - 0.33).abs() < 1e-12);
    }

    #[test]
    fn black_has_no_chromaticity_and_zero_y_gives_black() {
        assert_eq!(Xyz::default().chromaticity(), None);
        assert_eq!(Xy::new(0.3, 0.0).with_luminance(5.0), Xyz::default());
    }

    #[test]
    fn chromaticity_check_rejects_points_outside_the_triangle() {
        assert!(Xy::new(0.3127, 0.329).checked("white").is_ok());
        for bad in [
            [f64::NAN, 0.3],
            [-0.1, 0.3],
            [0.3, 0.0],
            [0.6, 0.5],
            [0.3, f64::INFINITY],
        ] {
            let e = Xy::from(bad).checked("white").unwrap_err();
            assert!(e.to_string().starts_with("white: xy"), "{e}");
        }
    }

    #[test]
    fn xy_serialises_as_a_two_element_array() {
        let s = serde_json::to_string(&Xy::new(0.25, 0.5)).unwrap();
        assert_eq!(s, "[0.25,0.5]");
        let back: Xy = serde_json::from_str(&s).unwrap();
        assert_eq!(back, Xy::new(0.25, 0.5));
    }
}
