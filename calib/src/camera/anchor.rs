//! Meter-anchored camera photometry: camera RGB → XYZ (one 3×3 matrix per eye) and the
//! camera lens's vignetting, fitted to spot-meter readings of the same spots.
//!
//! Model: `XYZ = M_eye · rgb · (1 + b1·ρ² + b2·ρ⁴)`, `rgb` the dark-subtracted camera
//! signal per second, ρ the spot's distance from the image centre over half the
//! diagonal. Alternating least squares: the matrices with the vignetting fixed
//! (relative residuals, so dark and bright spots count alike), then the vignetting from
//! the luminance ratios with the matrices fixed.

use lumiwall_core::Eye;
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use super::CameraCalibError;

/// One spot seen by both instruments.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpotPair {
    /// Display name and spot, for the report.
    pub display: u32,
    /// Eye of the display (one matrix per eye: Infitec filters change the spectra).
    pub eye: Eye,
    /// Display coordinates of the spot.
    pub uv: [f64; 2],
    /// Camera signal (linear RGB per second, dark frame subtracted).
    pub camera_rgb: [f64; 3],
    /// Meter XYZ (cd/m², black reading subtracted).
    pub meter_xyz: [f64; 3],
    /// Distance of the spot from the image centre over half the diagonal.
    pub radius: f64,
    /// Which pattern was shown (its drive): pairs with the same display and pattern
    /// share one spectrum.
    pub drive: [f64; 3],
}

/// How well the camera agrees with the meter at one spot.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpotAgreement {
    /// The spot.
    pub display: u32,
    /// Eye.
    pub eye: Eye,
    /// Spot position.
    pub uv: [f64; 2],
    /// Luminance error of the camera against the meter (%).
    pub delta_y_percent: f64,
    /// Chromaticity distance (CIE 1931 xy).
    pub delta_xy: f64,
    /// The pattern shown (drive per channel).
    pub drive: [f64; 3],
}

/// The fitted camera photometry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraPhotometry {
    /// Camera RGB → XYZ per eye (row-major).
    pub matrices: Vec<(Eye, [[f64; 3]; 3])>,
    /// Vignetting correction `[b1, b2]`.
    pub vignetting: [f64; 2],
    /// Agreement at every spot used.
    pub agreement: Vec<SpotAgreement>,
}

fn xy(v: [f64; 3]) -> [f64; 2] {
    let s = v[0] + v[1] + v[2];
    if s > 0.0 {
        [v[0] / s, v[1] / s]
    } else {
        [0.0; 2]
    }
}

impl CameraPhotometry {
    /// The vignetting correction factor at radius `rho`.
    pub fn vignetting_factor(&self, rho: f64) -> f64 {
        let r2 = rho * rho;
        1.0 + self.vignetting[0] * r2 + self.vignetting[1] * r2 * r2
    }

    /// XYZ (cd/m²) of a camera signal at radius `rho` for `eye`; `None` for an eye
    /// without a matrix.
    pub fn xyz(&self, eye: Eye, rgb: [f64; 3], rho: f64) -> Option<[f64; 3]> {
        let m = self.matrices.iter().find(|(e, _)| *e == eye)?.1;
        let k = self.vignetting_factor(rho);
        Some(std::array::from_fn(|r| {
            k * (m[r][0] * rgb[0] + m[r][1] * rgb[1] + m[r][2] * rgb[2])
        }))
    }

    /// Largest luminance (%) and xy disagreement with the meter over the white spots
    /// (every channel on): the camera as a photometer of the wall white.
    pub fn worst(&self) -> (f64, f64) {
        Self::worst_of(self.agreement.iter().filter(|a| a.drive == [1.0; 3]))
    }

    /// Largest disagreement over every spot and pattern (single primaries included,
    /// where a 3×3 matrix meets the camera's departure from the CIE observer).
    pub fn worst_all(&self) -> (f64, f64) {
        Self::worst_of(self.agreement.iter())
    }

    fn worst_of<'a>(spots: impl Iterator<Item = &'a SpotAgreement>) -> (f64, f64) {
        spots.fold((0.0, 0.0), |(y, d), a| {
            (
                f64::max(y, a.delta_y_percent.abs()),
                f64::max(d, a.delta_xy),
            )
        })
    }

    /// Fits matrices and vignetting to `pairs` (at least four spots and three
    /// different colours per eye).
    pub fn fit(pairs: &[SpotPair]) -> Result<Self, CameraCalibError> {
        let mut eyes: Vec<Eye> = pairs.iter().map(|p| p.eye).collect();
        eyes.sort_by_key(|e| e.to_string());
        eyes.dedup();
        let mut fit = Self {
            matrices: Vec::new(),
            vignetting: [0.0; 2],
            agreement: Vec::new(),
        };
        for _ in 0..12 {
            fit.matrices = eyes
                .iter()
                .map(|&eye| Ok((eye, fit_matrix(pairs, eye, &fit)?)))
                .collect::<Result<_, CameraCalibError>>()?;
            fit.vignetting = fit_vignetting(pairs, &fit).unwrap_or(fit.vignetting);
        }
        fit.agreement = pairs
            .iter()
            .filter_map(|p| {
                let cam = fit.xyz(p.eye, p.camera_rgb, p.radius)?;
                Some(SpotAgreement {
                    display: p.display,
                    eye: p.eye,
                    uv: p.uv,
                    drive: p.drive,
                    delta_y_percent: 100.0 * (cam[1] / p.meter_xyz[1] - 1.0),
                    delta_xy: {
                        let (a, b) = (xy(cam), xy(p.meter_xyz));
                        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
                    },
                })
            })
            .collect();
        Ok(fit)
    }
}

/// One eye's matrix by relative least squares, vignetting fixed.
fn fit_matrix(
    pairs: &[SpotPair],
    eye: Eye,
    fit: &CameraPhotometry,
) -> Result<[[f64; 3]; 3], CameraCalibError> {
    let mut ata = Matrix3::<f64>::zeros();
    let mut atb = [Vector3::<f64>::zeros(); 3];
    let mut n = 0;
    for p in pairs
        .iter()
        .filter(|p| p.eye == eye && p.meter_xyz[1] > 0.0)
    {
        let w = 1.0 / p.meter_xyz[1];
        let a = Vector3::from(p.camera_rgb) * fit.vignetting_factor(p.radius) * w;
        ata += a * a.transpose();
        for (r, b) in atb.iter_mut().enumerate() {
            *b += a * (p.meter_xyz[r] * w);
        }
        n += 1;
    }
    let inv = (n >= 4)
        .then(|| ata.try_inverse())
        .flatten()
        .ok_or_else(|| {
            CameraCalibError::Fit(format!(
                "camera colour matrix ({eye} eye): {n} spots with light, or too few different \
             colours; the meter and camera need at least red, green, blue and white"
            ))
        })?;
    Ok(std::array::from_fn(|r| {
        let m = inv * atb[r];
        [m[0], m[1], m[2]]
    }))
}

/// Vignetting from the luminance ratios meter / camera with the matrices fixed, one
/// free factor per display and pattern (`ln ratio = c_dp + β1ρ² + β2ρ⁴`): one pattern on
/// one display has one spectrum at every spot, so the matrix's spectral mismatch drops
/// out.
fn fit_vignetting(pairs: &[SpotPair], fit: &CameraPhotometry) -> Option<[f64; 2]> {
    let uncorrected = CameraPhotometry {
        vignetting: [0.0; 2],
        ..fit.clone()
    };
    // One free factor per display and pattern: the same spectrum at every spot.
    let mut groups: Vec<(u32, [u64; 3])> = pairs
        .iter()
        .map(|p| (p.display, p.drive.map(f64::to_bits)))
        .collect();
    groups.sort_unstable();
    groups.dedup();
    let n = 2 + groups.len();
    let mut ata = nalgebra::DMatrix::<f64>::zeros(n, n);
    let mut atb = nalgebra::DVector::<f64>::zeros(n);
    for p in pairs {
        let cam = uncorrected.xyz(p.eye, p.camera_rgb, p.radius)?;
        if cam[1] <= 0.0 || p.meter_xyz[1] <= 0.0 {
            continue;
        }
        let r2 = p.radius * p.radius;
        let g = groups
            .iter()
            .position(|g| *g == (p.display, p.drive.map(f64::to_bits)))?;
        let mut a = nalgebra::DVector::<f64>::zeros(n);
        a[0] = r2;
        a[1] = r2 * r2;
        a[2 + g] = 1.0;
        ata += &a * a.transpose();
        atb += &a * (p.meter_xyz[1] / cam[1]).ln();
    }
    // Spots all at one radius cannot separate vignetting from the matrix.
    let x = ata.try_inverse().map(|inv| inv * atb)?;
    let (b1, b2) = (x[0], x[1]);
    // exp(β1ρ² + β2ρ⁴) as the polynomial 1 + b1ρ² + b2ρ⁴ (second order).
    Some([b1, b2 + 0.5 * b1 * b1])
}
