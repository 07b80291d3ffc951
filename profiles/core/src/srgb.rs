//! Uncalibrated (sRGB) input: the fixed ideal decoding curve and the mapping of decoded
//! relative RGB to absolute XYZ (Kresse 2003, 3.3.5).
//!
//! Kresse: uncalibrated input is linearised with a fixed, ideal function — never the
//! display's measured curve, which would only bring the curves' irregularities back.
//! We use the sRGB EOTF of IEC 61966-2-1 (a 2.4 power with a linear toe).

use crate::{CoreError, Mat3, Xy, mat3};

/// xy chromaticities of the sRGB / Rec. 709 primaries `[R, G, B]`.
pub const SRGB_PRIMARIES_XY: [[f64; 2]; 3] = [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]];

/// The ideal sRGB decoding curve (IEC 61966-2-1): encoded 0..=1 → linear relative 0..=1.
/// Input outside 0..=1 is clamped; NaN gives 0.
pub fn decode_srgb(encoded: f32) -> f32 {
    let v = if encoded.is_nan() {
        0.0
    } else {
        encoded.clamp(0.0, 1.0)
    };
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Row-major matrix from linear relative RGB (1, 1, 1 = white) to XYZ in cd/m², for the
/// primaries `primaries_xy` and the white `white_xyz_cd_m2` (e.g. the wall's target
/// white): the usual `M = [P · diag(S)]` with `S = P⁻¹ · W`.
pub fn rgb_to_xyz_matrix(
    primaries_xy: &[[f64; 2]; 3],
    white_xyz_cd_m2: &[f64; 3],
) -> Result<Mat3, CoreError> {
    let mut cols = [[0.0; 3]; 3];
    for (c, p) in primaries_xy.iter().enumerate() {
        let [x, y] = *p;
        if !Xy::new(x, y).is_valid() {
            return Err(CoreError::ColourSpace(format!(
                "primary {c} has chromaticity x={x}, y={y}"
            )));
        }
        cols[c] = [x / y, 1.0, (1.0 - x - y) / y];
    }
    if !(white_xyz_cd_m2.iter().all(|v| v.is_finite()) && white_xyz_cd_m2[1] > 0.0) {
        return Err(CoreError::ColourSpace(format!(
            "white XYZ {white_xyz_cd_m2:?} cd/m² has no positive luminance"
        )));
    }
    let p = mat3::from_columns(&cols);
    let inv = mat3::inverse(&p)
        .ok_or_else(|| CoreError::ColourSpace("the primaries are collinear".into()))?;
    let s = mat3::mul_vec(&inv, white_xyz_cd_m2);
    if s.iter().any(|v| *v <= 0.0) {
        return Err(CoreError::ColourSpace(
            "the white lies outside the primaries' triangle".into(),
        ));
    }
    let scaled = [0, 1, 2].map(|c| cols[c].map(|v| v * s[c]));
    Ok(mat3::from_columns(&scaled))
}

/// Encoded sRGB (0..=1 per channel) → XYZ in cd/m² through `rgb_to_xyz` (from
/// [`rgb_to_xyz_matrix`]).
pub fn srgb_to_xyz(encoded: [f32; 3], rgb_to_xyz: &[[f64; 3]; 3]) -> [f32; 3] {
    let lin = encoded.map(|v| f64::from(decode_srgb(v)));
    mat3::mul_vec(rgb_to_xyz, &lin).map(|v| v as f32)
}

#[cfg(test)]
#[allow(
    clippy::needless_range_loop,
    reason = "the tests index matrices and arrays side by side"
)]
mod tests {
    use super::*;

    #[test]
    fn decode_matches_iec_61966_2_1() {
        // Reference values of the standard's formula, computed independently.
        assert_eq!(decode_srgb(0.0), 0.0);
        assert!((decode_srgb(1.0) - 1.0).abs() < 1e-6);
        assert!((decode_srgb(0.5) - 0.214_041_14).abs() < 1e-6);
        assert!((decode_srgb(0.04) - 0.04 / 12.92).abs() < 1e-9);
        assert!((decode_srgb(128.0 / 255.0) - 0.215_860_53).abs() < 1e-6);
        assert_eq!(decode_srgb(f32::NAN), 0.0);
        assert_eq!(decode_srgb(-1.0), 0.0);
        // Continuous at the toe joint.
        let a = decode_srgb(0.040_45);
        let b = decode_srgb(0.040_450_1);
        assert!((a - b).abs() < 1e-6);
    }

    #[test]
    fn srgb_d65_matrix_matches_the_standard() {
        // D65 white with Y = 1: the published sRGB→XYZ matrix (IEC 61966-2-1).
        let d65 = [0.3127 / 0.3290, 1.0, (1.0 - 0.3127 - 0.3290) / 0.3290];
        let m = rgb_to_xyz_matrix(&SRGB_PRIMARIES_XY, &d65).unwrap();
        let expected = [
            [0.4124, 0.3576, 0.1805],
            [0.2126, 0.7152, 0.0722],
            [0.0193, 0.1192, 0.9505],
        ];
        for i in 0..3 {
            for j in 0..3 {
                assert!((m[i][j] - expected[i][j]).abs() < 2e-4, "{m:?}");
            }
        }
    }

    #[test]
    fn white_maps_to_the_wall_white_in_cd_m2() {
        let white = [75.0, 77.86, 85.0];
        let m = rgb_to_xyz_matrix(&SRGB_PRIMARIES_XY, &white).unwrap();
        let xyz = srgb_to_xyz([1.0; 3], &m);
        for c in 0..3 {
            assert!((f64::from(xyz[c]) - white[c]).abs() < 1e-3);
        }
        assert_eq!(srgb_to_xyz([0.0; 3], &m), [0.0; 3]);
    }

    #[test]
    fn degenerate_colour_spaces_are_errors() {
        let w = [95.0, 100.0, 108.0];
        let collinear = [[0.2, 0.2], [0.3, 0.3], [0.4, 0.4]];
        assert!(rgb_to_xyz_matrix(&collinear, &w).is_err());
        assert!(rgb_to_xyz_matrix(&SRGB_PRIMARIES_XY, &[1.0, 0.0, 1.0]).is_err());
        assert!(rgb_to_xyz_matrix(&[[0.64, 0.0], [0.3, 0.6], [0.15, 0.06]], &w).is_err());
    }
}
