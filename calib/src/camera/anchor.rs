//! Meter-anchored camera photometry: camera RGB → XYZ (one 3×3 matrix per eye, and per
//! display for the agreement, each spot predicted from its display's other spots) and
//! the camera lens's vignetting, fitted to spot-meter readings of the same spots.
//!
//! Model: `XYZ = M_eye · rgb · exp(β1·ρ² + β2·ρ⁴)`, `rgb` the dark-subtracted camera
//! signal per second, ρ the spot's distance from the image centre over half the
//! diagonal. Alternating least squares: the matrices with the vignetting fixed
//! (relative residuals, so dark and bright spots count alike), then the vignetting from
//! the luminance ratios with the matrices fixed. The vignetting has as many terms as
//! the spots' distances allow: each display and pattern has its own free factor, so
//! only distances within one display count (two terms need three distances, one term
//! two; with one, the camera's vignetting cannot be seen and is left at none).

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
    /// Vignetting correction `[β1, β2]`: the factor is `exp(β1·ρ² + β2·ρ⁴)`.
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
        (self.vignetting[0] * r2 + self.vignetting[1] * r2 * r2).exp()
    }

    /// XYZ (cd/m²) of a camera signal at radius `rho` for `eye`; `None` for an eye
    /// without a matrix.
    pub fn xyz(&self, eye: Eye, rgb: [f64; 3], rho: f64) -> Option<[f64; 3]> {
        let m = self.matrices.iter().find(|(e, _)| *e == eye)?.1;
        Some(self.through(&m, rgb, rho))
    }

    /// `rgb` at radius `rho` through matrix `m`, vignetting corrected.
    fn through(&self, m: &[[f64; 3]; 3], rgb: [f64; 3], rho: f64) -> [f64; 3] {
        let k = self.vignetting_factor(rho);
        std::array::from_fn(|r| k * (m[r][0] * rgb[0] + m[r][1] * rgb[1] + m[r][2] * rgb[2]))
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
                let cam = fit.held_out_xyz(pairs, p)?;
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

impl CameraPhotometry {
    /// The camera's XYZ at spot `p` through a matrix of `p`'s own display fitted to
    /// that display's other spots (one display has one set of primary spectra, so
    /// its own matrix is exact where one matrix per eye is not); the eye's matrix where
    /// the display has too few other spots. Held out, so the agreement it gives is a
    /// prediction, not a fit residual.
    fn held_out_xyz(&self, pairs: &[SpotPair], p: &SpotPair) -> Option<[f64; 3]> {
        let own = fit_matrix_where(pairs, self, |q| {
            q.display == p.display && q.eye == p.eye && q.uv != p.uv
        })
        .ok();
        match own {
            Some(m) => Some(self.through(&m, p.camera_rgb, p.radius)),
            None => self.xyz(p.eye, p.camera_rgb, p.radius),
        }
    }
}

/// One eye's matrix by relative least squares, vignetting fixed.
fn fit_matrix(
    pairs: &[SpotPair],
    eye: Eye,
    fit: &CameraPhotometry,
) -> Result<[[f64; 3]; 3], CameraCalibError> {
    fit_matrix_where(pairs, fit, |p| p.eye == eye).map_err(|n| {
        CameraCalibError::Fit(format!(
            "camera colour matrix ({eye} eye): {n} spots with light, or too few different \
             colours; the meter and camera need at least red, green, blue and white"
        ))
    })
}

/// The matrix by relative least squares over the pairs `keep` selects, vignetting
/// fixed; `Err(n)` with the number of usable pairs when they cannot determine it.
fn fit_matrix_where(
    pairs: &[SpotPair],
    fit: &CameraPhotometry,
    keep: impl Fn(&SpotPair) -> bool,
) -> Result<[[f64; 3]; 3], usize> {
    let mut ata = Matrix3::<f64>::zeros();
    let mut atb = [Vector3::<f64>::zeros(); 3];
    let mut n: usize = 0;
    for p in pairs.iter().filter(|p| keep(p) && p.meter_xyz[1] > 0.0) {
        let w = 1.0 / p.meter_xyz[1];
        let a = Vector3::from(p.camera_rgb) * fit.vignetting_factor(p.radius) * w;
        ata += a * a.transpose();
        for (r, b) in atb.iter_mut().enumerate() {
            *b += a * (p.meter_xyz[r] * w);
        }
        n += 1;
    }
    let inv = (n >= 4).then(|| ata.try_inverse()).flatten().ok_or(n)?;
    Ok(std::array::from_fn(|r| {
        let m = inv * atb[r];
        [m[0], m[1], m[2]]
    }))
}

/// How many distinct values `v` holds (closer than 0.02 counts as one).
pub(crate) fn distinct_levels(v: &[f64]) -> usize {
    let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    s.sort_by(f64::total_cmp);
    s.windows(2).filter(|w| w[1] - w[0] > 0.02).count() + usize::from(!s.is_empty())
}

/// How many vignetting terms the spots can carry: distances within one display and
/// pattern count (each has its own free factor), so the largest number of distinct
/// distances in one group, less one, at most two.
fn vignetting_terms(pairs: &[SpotPair]) -> usize {
    let mut best = 0;
    for p in pairs {
        let radii: Vec<f64> = pairs
            .iter()
            .filter(|q| q.display == p.display && q.drive == p.drive)
            .map(|q| q.radius * q.radius)
            .collect();
        best = best.max(distinct_levels(&radii));
    }
    best.saturating_sub(1).min(2)
}

/// Vignetting from the luminance ratios meter / camera with the matrices fixed, one
/// free factor per display and pattern (`ln ratio = c_dp + β1ρ² + β2ρ⁴`): one pattern on
/// one display has one spectrum at every spot, so the matrix's spectral mismatch drops
/// out. Fits as many terms as [`vignetting_terms`] allows.
fn fit_vignetting(pairs: &[SpotPair], fit: &CameraPhotometry) -> Option<[f64; 2]> {
    // A lens loses light towards the edge: a correction that does not grow from the
    // centre to the corner (ρ = 1) is the screen's view dependence or noise, not the
    // lens, and drops to fewer terms.
    let lens_like = |b: &[f64; 2]| {
        (1..=20).all(|k| {
            let r2 = (f64::from(k) / 20.0).powi(2);
            b[0] + 2.0 * b[1] * r2 >= 0.0
        })
    };
    for terms in (1..=vignetting_terms(pairs)).rev() {
        if let Some(b) = fit_vignetting_terms(pairs, fit, terms).filter(lens_like) {
            return Some(b);
        }
    }
    Some([0.0; 2])
}

/// [`fit_vignetting`] with `terms` (1 or 2) terms.
fn fit_vignetting_terms(
    pairs: &[SpotPair],
    fit: &CameraPhotometry,
    terms: usize,
) -> Option<[f64; 2]> {
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
    let n = terms + groups.len();
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
        if terms == 2 {
            a[1] = r2 * r2;
        }
        a[terms + g] = 1.0;
        ata += &a * a.transpose();
        atb += &a * (p.meter_xyz[1] / cam[1]).ln();
    }
    // Spots all at one radius cannot separate vignetting from the matrix.
    let x = ata.try_inverse().map(|inv| inv * atb)?;
    Some(if terms == 2 {
        [x[0], x[1]]
    } else {
        [x[0], 0.0]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The virtual camera's lens law (`devices::sim::camera`): it keeps
    /// `1/(1 + a·ρ²)²` of the light, so the correction is its inverse.
    fn lens_correction(a: f64, rho: f64) -> f64 {
        (1.0 + a * rho * rho).powi(2)
    }

    /// Spot pairs of one display at `radii`: the meter sees `XYZ = M·rgb_true`, the
    /// camera `rgb_true` darkened by the lens law with `a`.
    fn pairs_at(radii: &[f64], a: f64) -> Vec<SpotPair> {
        let m = Matrix3::new(0.41, 0.36, 0.18, 0.21, 0.72, 0.07, 0.02, 0.12, 0.95);
        let mut out = Vec::new();
        for drive in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0; 3]] {
            for &rho in radii {
                // The display is darker away from its centre too; meter and camera
                // both see that, so none of it may end up in the camera's vignetting.
                let screen = 100.0 * (1.0 - 0.2 * rho * rho);
                let rgb_true = Vector3::from(drive) * screen;
                let xyz = m * rgb_true;
                let cam = rgb_true / lens_correction(a, rho);
                out.push(SpotPair {
                    display: 0,
                    eye: Eye::Mono,
                    uv: [0.5, 0.5],
                    camera_rgb: [cam[0], cam[1], cam[2]],
                    meter_xyz: [xyz[0], xyz[1], xyz[2]],
                    radius: rho,
                    drive,
                });
            }
        }
        out
    }

    #[test]
    fn spots_at_five_distances_recover_the_lens_law_within_0_2_percent() {
        let fit = CameraPhotometry::fit(&pairs_at(&[0.0, 0.3, 0.55, 0.8, 1.0], 0.12)).unwrap();
        for k in 0..=20 {
            let rho = f64::from(k) / 20.0;
            let err = fit.vignetting_factor(rho) / lens_correction(0.12, rho) - 1.0;
            assert!(err.abs() < 0.002, "ρ {rho}: {:.4} %", 100.0 * err);
        }
    }

    #[test]
    fn spots_at_two_distances_fit_one_term_that_stays_near_the_lens_law() {
        // One centred display: the centre and four corners at one distance.
        let fit = CameraPhotometry::fit(&pairs_at(&[0.0, 0.485], 0.12)).unwrap();
        assert_eq!(fit.vignetting[1], 0.0, "{:?}", fit.vignetting);
        let err = fit.vignetting_factor(1.0) / lens_correction(0.12, 1.0) - 1.0;
        assert!(err.abs() < 0.02, "at the corner {:.3} %", 100.0 * err);
        let (dy, dxy) = fit.worst_all();
        assert!(dy < 0.01 && dxy < 1e-6, "{dy} {dxy}");
    }

    #[test]
    fn spots_at_one_distance_leave_the_vignetting_at_none() {
        let fit = CameraPhotometry::fit(&pairs_at(&[0.4], 0.12)).unwrap();
        assert_eq!(fit.vignetting, [0.0; 2]);
    }
}
