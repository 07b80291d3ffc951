//! Colorimetry used by the calibration: xyY ↔ XYZ, CIELAB against a given reference
//! white, CIEDE2000 colour difference (Sharma, Wu & Dalal 2005), correlated colour
//! temperature → xy on the CIE daylight locus, and Bradford chromatic adaptation.
//!
//! All XYZ values are absolute ([`Xyz`], Y in cd/m²); CIELAB is computed relative to a
//! reference white given on the same absolute scale. The formulas follow CIE 15:2004 and
//! agree with colour-science to better than 1e-4 (checked by `tests/python`).

pub use lumiwall_core::lab::{Lab, delta_e2000, delta_e2000_xyz, lab_to_xyz, xyz_to_lab};
use lumiwall_devices::Xyz;
use nalgebra::Matrix3;

use crate::CalibError;

/// CIE 1931 xy chromaticity of CIE standard illuminant D65 (CIE 15:2004, 4 decimals as
/// colour-science's `CCS_ILLUMINANTS`: 0.3127, 0.3290).
pub const D65_XY: [f64; 2] = [0.3127, 0.3290];
/// CIE 1931 xy chromaticity of CIE illuminant D50 (0.3457, 0.3585).
pub const D50_XY: [f64; 2] = [0.3457, 0.3585];

/// Lowest colour temperature (K) of the CIE daylight locus formula.
pub const DAYLIGHT_MIN_K: f64 = 4000.0;
/// Highest colour temperature (K) of the CIE daylight locus formula.
pub const DAYLIGHT_MAX_K: f64 = 25000.0;

/// XYZ → `[x, y, Y]` (chromaticity and luminance in cd/m²). For black (X+Y+Z = 0) the
/// chromaticity is returned as `fallback_xy` (colour-science uses the illuminant).
pub fn xyz_to_xyy(xyz: Xyz, fallback_xy: [f64; 2]) -> [f64; 3] {
    match xyz.xy() {
        Some([x, y]) => [x, y, xyz.y],
        None => [fallback_xy[0], fallback_xy[1], xyz.y],
    }
}

/// `[x, y, Y]` (Y in cd/m²) → XYZ; black for `y <= 0`.
pub fn xyy_to_xyz(xyy: [f64; 3]) -> Xyz {
    Xyz::from_xy_luminance(xyy[0], xyy[1], xyy[2])
}

/// xy chromaticity of the CIE daylight illuminant (D series) of correlated colour
/// temperature `kelvin` (CIE 15:2004 eq. 3.3–3.4; the same as colour-science's default
/// `CCT_to_xy` method "CIE Illuminant D Series"). Valid for 4000–25000 K.
///
/// Note: the Planckian locus is not used; 8500 K on the daylight locus is
/// (0.2892, 0.3041), while Kresse 2003 quotes (0.291, 0.300) for "8500 K".
pub fn cct_to_xy(kelvin: f64) -> Result<[f64; 2], CalibError> {
    if !kelvin.is_finite() || !(DAYLIGHT_MIN_K..=DAYLIGHT_MAX_K).contains(&kelvin) {
        return Err(CalibError::CctOutOfRange {
            kelvin,
            min_k: DAYLIGHT_MIN_K,
            max_k: DAYLIGHT_MAX_K,
        });
    }
    let t = kelvin;
    let (t2, t3) = (t * t, t * t * t);
    let x = if t <= 7000.0 {
        -4.6070e9 / t3 + 2.9678e6 / t2 + 0.09911e3 / t + 0.244063
    } else {
        -2.0064e9 / t3 + 1.9018e6 / t2 + 0.24748e3 / t + 0.237040
    };
    let y = -3.0 * x * x + 2.870 * x - 0.275;
    Ok([x, y])
}

/// The Bradford cone-response matrix (XYZ → sharpened LMS), Lam 1985 as used by
/// colour-science's `CAT_BRADFORD` (linear Bradford, no blue non-linearity).
pub fn bradford_matrix() -> Matrix3<f64> {
    Matrix3::new(
        0.8951, 0.2664, -0.1614, //
        -0.7502, 1.7135, 0.0367, //
        0.0389, -0.0685, 1.0296,
    )
}

/// The 3×3 von Kries matrix in Bradford space that maps colours seen under
/// `src_white` to corresponding colours under `dst_white`. The whites are used as
/// given (as colour-science does): pass them at equal Y to keep luminance unchanged.
/// Returns `None` when a white has a zero cone response.
pub fn bradford_adaptation_matrix(src_white: Xyz, dst_white: Xyz) -> Option<Matrix3<f64>> {
    let m = bradford_matrix();
    let m_inv = m.try_inverse()?;
    let src = m * src_white.to_vector();
    let dst = m * dst_white.to_vector();
    if src.iter().any(|v| *v == 0.0 || !v.is_finite()) {
        return None;
    }
    let gain = Matrix3::from_diagonal(&dst.component_div(&src));
    Some(m_inv * gain * m)
}

/// Bradford chromatic adaptation of `xyz` from `src_white` to `dst_white` (see
/// [`bradford_adaptation_matrix`]). Returns NaN components for a degenerate white.
pub fn bradford_adapt(xyz: Xyz, src_white: Xyz, dst_white: Xyz) -> Xyz {
    match bradford_adaptation_matrix(src_white, dst_white) {
        Some(cat) => Xyz::from(cat * xyz.to_vector()),
        None => Xyz::new(f64::NAN, f64::NAN, f64::NAN),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cct_outside_locus_is_an_error() {
        assert!(matches!(
            cct_to_xy(3000.0),
            Err(CalibError::CctOutOfRange { .. })
        ));
        assert!(cct_to_xy(f64::NAN).is_err());
    }
}
