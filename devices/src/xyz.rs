//! The measured quantity: CIE 1931 XYZ tristimulus values in absolute units.

use serde::{Deserialize, Serialize};

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
        if y_chroma <= 0.0 {
            return Self::default();
        }
        Self {
            x: x_chroma * y_cd_m2 / y_chroma,
            y: y_cd_m2,
            z: (1.0 - x_chroma - y_chroma) * y_cd_m2 / y_chroma,
        }
    }

    /// Luminance in cd/m².
    pub fn luminance_cd_m2(&self) -> f64 {
        self.y
    }

    /// Chromaticity `(x, y)`; `None` when X+Y+Z is not positive.
    pub fn xy(&self) -> Option<[f64; 2]> {
        let s = self.x + self.y + self.z;
        (s > 0.0 && s.is_finite()).then(|| [self.x / s, self.y / s])
    }

    /// As an array `[X, Y, Z]`.
    pub fn to_array(self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }

    /// From an array `[X, Y, Z]`.
    pub fn from_array(a: [f64; 3]) -> Self {
        Self::new(a[0], a[1], a[2])
    }

    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
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
