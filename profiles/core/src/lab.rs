//! CIELAB against an absolute reference white (CIE 15:2004) and the CIEDE2000 colour
//! difference (Sharma, Wu & Dalal 2005).
//!
//! Both XYZ values are absolute ([`Xyz`], Y in cd/m²): CIELAB is computed relative to a
//! reference white given on the same scale, so luminance errors count as lightness
//! errors. The formulas agree with colour-science to better than 1e-4 (checked by
//! `tests/python`).

use serde::{Deserialize, Serialize};

use crate::Xyz;

/// A CIELAB colour (L* 0..100 for colours up to the reference white).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Lab {
    /// Lightness L*.
    pub l: f64,
    /// Red–green opponent a*.
    pub a: f64,
    /// Yellow–blue opponent b*.
    pub b: f64,
}

impl Lab {
    /// Builds from the three components.
    pub const fn new(l: f64, a: f64, b: f64) -> Self {
        Self { l, a, b }
    }
}

/// CIE ε = 216/24389: below it CIELAB's cube root is replaced by a line.
const LAB_EPSILON: f64 = 216.0 / 24389.0;
/// CIE κ = 24389/27.
const LAB_KAPPA: f64 = 24389.0 / 27.0;

fn lab_f(t: f64) -> f64 {
    if t > LAB_EPSILON {
        t.cbrt()
    } else {
        (LAB_KAPPA * t + 16.0) / 116.0
    }
}

fn lab_f_inv(f: f64) -> f64 {
    let t = f * f * f;
    if t > LAB_EPSILON {
        t
    } else {
        (116.0 * f - 16.0) / LAB_KAPPA
    }
}

/// CIE 1976 L*a*b* of `xyz` relative to the reference white `white` (both absolute,
/// same scale). A white with a non-positive component gives NaN components.
pub fn xyz_to_lab(xyz: Xyz, white: Xyz) -> Lab {
    let fx = lab_f(xyz.x / white.x);
    let fy = lab_f(xyz.y / white.y);
    let fz = lab_f(xyz.z / white.z);
    Lab {
        l: 116.0 * fy - 16.0,
        a: 500.0 * (fx - fy),
        b: 200.0 * (fy - fz),
    }
}

/// Inverse of [`xyz_to_lab`]: absolute XYZ of `lab` relative to `white`.
pub fn lab_to_xyz(lab: Lab, white: Xyz) -> Xyz {
    let fy = (lab.l + 16.0) / 116.0;
    let fx = fy + lab.a / 500.0;
    let fz = fy - lab.b / 200.0;
    let yr = if lab.l > LAB_KAPPA * LAB_EPSILON {
        fy * fy * fy
    } else {
        lab.l / LAB_KAPPA
    };
    Xyz::new(
        lab_f_inv(fx) * white.x,
        yr * white.y,
        lab_f_inv(fz) * white.z,
    )
}

/// CIEDE2000 colour difference (kL = kC = kH = 1), implemented as in Sharma, Wu &
/// Dalal (2005), "The CIEDE2000 color-difference formula: implementation notes,
/// supplementary test data, and mathematical observations", Color Res. Appl. 30(1).
///
/// Hue differences of exactly 180° (to 1e-9°) are treated as `≤ 180°` as the paper's
/// equations (10) and (14) state; this reproduces its published value for test pairs
/// 13 and 14 independent of floating-point noise in `atan2`.
pub fn delta_e2000(lab1: Lab, lab2: Lab) -> f64 {
    use std::f64::consts::PI;
    let deg = |r: f64| r * 180.0 / PI;
    let rad = |d: f64| d * PI / 180.0;
    const POW25_7: f64 = 6_103_515_625.0; // 25^7

    let c1 = lab1.a.hypot(lab1.b);
    let c2 = lab2.a.hypot(lab2.b);
    let c_bar = 0.5 * (c1 + c2);
    let c_bar7 = c_bar.powi(7);
    let g = 0.5 * (1.0 - (c_bar7 / (c_bar7 + POW25_7)).sqrt());
    let a1p = (1.0 + g) * lab1.a;
    let a2p = (1.0 + g) * lab2.a;
    let c1p = a1p.hypot(lab1.b);
    let c2p = a2p.hypot(lab2.b);
    let hue = |b: f64, ap: f64| {
        if b == 0.0 && ap == 0.0 {
            0.0
        } else {
            let h = deg(b.atan2(ap));
            if h < 0.0 { h + 360.0 } else { h }
        }
    };
    let h1p = hue(lab1.b, a1p);
    let h2p = hue(lab2.b, a2p);

    const TOL: f64 = 1e-9;
    let dl = lab2.l - lab1.l;
    let dc = c2p - c1p;
    let chroma_product = c1p * c2p;
    let dh_small = if chroma_product == 0.0 {
        0.0
    } else {
        let d = h2p - h1p;
        if d.abs() <= 180.0 + TOL {
            d
        } else if d > 180.0 {
            d - 360.0
        } else {
            d + 360.0
        }
    };
    let dh = 2.0 * chroma_product.sqrt() * rad(dh_small / 2.0).sin();

    let l_bar = 0.5 * (lab1.l + lab2.l);
    let cp_bar = 0.5 * (c1p + c2p);
    let h_bar = if chroma_product == 0.0 {
        h1p + h2p
    } else if (h1p - h2p).abs() <= 180.0 + TOL {
        0.5 * (h1p + h2p)
    } else if h1p + h2p < 360.0 {
        0.5 * (h1p + h2p + 360.0)
    } else {
        0.5 * (h1p + h2p - 360.0)
    };
    let t = 1.0 - 0.17 * rad(h_bar - 30.0).cos()
        + 0.24 * rad(2.0 * h_bar).cos()
        + 0.32 * rad(3.0 * h_bar + 6.0).cos()
        - 0.20 * rad(4.0 * h_bar - 63.0).cos();
    let d_theta = 30.0 * (-((h_bar - 275.0) / 25.0).powi(2)).exp();
    let cp_bar7 = cp_bar.powi(7);
    let r_c = 2.0 * (cp_bar7 / (cp_bar7 + POW25_7)).sqrt();
    let l50 = (l_bar - 50.0).powi(2);
    let s_l = 1.0 + 0.015 * l50 / (20.0 + l50).sqrt();
    let s_c = 1.0 + 0.045 * cp_bar;
    let s_h = 1.0 + 0.015 * cp_bar * t;
    let r_t = -(rad(2.0 * d_theta)).sin() * r_c;

    let tl = dl / s_l;
    let tc = dc / s_c;
    let th = dh / s_h;
    (tl * tl + tc * tc + th * th + r_t * tc * th).sqrt()
}

/// The chroma term of CIEDE2000, `ΔC'/S_C` (k_C = 1), from `lab1` to `lab2`: positive
/// when `lab2` is more chromatic. Its magnitude over greys is the grey balance a
/// verification reports (DisplayCAL's "gray balance ΔC'").
pub fn delta_c2000(lab1: Lab, lab2: Lab) -> f64 {
    const POW25_7: f64 = 6_103_515_625.0; // 25^7
    let c_bar = 0.5 * (lab1.a.hypot(lab1.b) + lab2.a.hypot(lab2.b));
    let c_bar7 = c_bar.powi(7);
    let g = 0.5 * (1.0 - (c_bar7 / (c_bar7 + POW25_7)).sqrt());
    let c1p = ((1.0 + g) * lab1.a).hypot(lab1.b);
    let c2p = ((1.0 + g) * lab2.a).hypot(lab2.b);
    (c2p - c1p) / (1.0 + 0.045 * 0.5 * (c1p + c2p))
}

/// [`delta_c2000`] between a target and a measured absolute colour, in CIELAB relative
/// to `reference_white` as [`delta_e2000_xyz`].
pub fn delta_c2000_xyz(target: Xyz, measured: Xyz, reference_white: Xyz) -> f64 {
    delta_c2000(
        xyz_to_lab(target, reference_white),
        xyz_to_lab(measured, reference_white),
    )
}

/// CIEDE2000 between a target and a measured absolute colour, both converted to
/// CIELAB relative to `reference_white` (absolute, e.g. the wall's white in cd/m²), so
/// that luminance errors count as lightness errors.
pub fn delta_e2000_xyz(target: Xyz, measured: Xyz, reference_white: Xyz) -> f64 {
    delta_e2000(
        xyz_to_lab(target, reference_white),
        xyz_to_lab(measured, reference_white),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Xy;

    /// Two colours of equal lightness and hue differ only in chroma: then CIEDE2000 is
    /// exactly its chroma term (ΔL' = ΔH' = 0 and the rotation term vanishes).
    #[test]
    fn the_chroma_term_is_the_whole_de2000_at_equal_lightness_and_hue() {
        for (h_deg, c1, c2) in [(30.0_f64, 2.0, 5.0), (200.0, 20.0, 24.0), (275.0, 0.5, 1.5)] {
            let (c, s) = (h_deg.to_radians().cos(), h_deg.to_radians().sin());
            let lab = |ch: f64| Lab {
                l: 60.0,
                a: ch * c,
                b: ch * s,
            };
            let (a, b) = (lab(c1), lab(c2));
            let dc = delta_c2000(a, b);
            assert!(
                dc > 0.0 && (dc - delta_e2000(a, b)).abs() < 1e-9,
                "{dc} {}",
                delta_e2000(a, b)
            );
            assert!((delta_c2000(b, a) + dc).abs() < 1e-12);
        }
    }

    #[test]
    fn lab_round_trip_and_white() {
        let white = Xy::new(0.3127, 0.3290).with_luminance(80.0);
        let lab = xyz_to_lab(white, white);
        assert!((lab.l - 100.0).abs() < 1e-12 && lab.a.abs() < 1e-12 && lab.b.abs() < 1e-12);
        for xyz in [Xyz::new(20.0, 30.0, 5.0), Xyz::new(0.1, 0.2, 0.05)] {
            let back = lab_to_xyz(xyz_to_lab(xyz, white), white);
            assert!((back - xyz).to_array().iter().all(|d| d.abs() < 1e-9));
        }
    }
}
