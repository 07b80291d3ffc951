//! Colorimetry against published reference values: all 34 CIEDE2000 test pairs of
//! Sharma, Wu & Dalal (2005), CIELAB and CCT examples from colour-science's
//! documentation, and Lindbloom's published Bradford D65→D50 matrix.

use std::path::PathBuf;

use lumiwall_calib::colorimetry::{
    Lab, bradford_adapt, bradford_adaptation_matrix, cct_to_xy, delta_e2000, delta_e2000_xyz,
    xyy_to_xyz, xyz_to_lab, xyz_to_xyy,
};
use lumiwall_devices::Xyz;

fn sharma() -> Vec<(u32, Lab, Lab, f64)> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/colour/sharma2005.csv");
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("pair"))
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|s| s.parse().unwrap()).collect();
            (
                f[0] as u32,
                Lab::new(f[1], f[2], f[3]),
                Lab::new(f[4], f[5], f[6]),
                f[7],
            )
        })
        .collect()
}

#[test]
fn ciede2000_matches_all_34_published_sharma_pairs() {
    let pairs = sharma();
    assert_eq!(pairs.len(), 34);
    let mut worst = 0.0_f64;
    for (pair, a, b, published) in pairs {
        let de = delta_e2000(a, b);
        let sym = delta_e2000(b, a);
        // Published to 4 decimals.
        assert!(
            (de - published).abs() <= 5e-5,
            "pair {pair}: {de} vs {published}"
        );
        assert!((de - sym).abs() < 1e-9, "pair {pair} not symmetric");
        worst = worst.max((de - published).abs());
    }
    println!("CIEDE2000 max |ours - Sharma 2005| over 34 pairs: {worst:.2e}");
}

#[test]
fn lab_matches_colour_science_doc_example() {
    // colour.XYZ_to_Lab([0.20654008, 0.12197225, 0.05136952]) with D65 xy (0.3127, 0.3290)
    // = [41.5278752, 52.6385830, 26.9231792] (colour-science docs).
    let white = Xyz::from_xy_luminance(0.3127, 0.3290, 1.0);
    let lab = xyz_to_lab(Xyz::new(0.20654008, 0.12197225, 0.05136952), white);
    assert!((lab.l - 41.5278752).abs() < 1e-6);
    assert!((lab.a - 52.6385830).abs() < 1e-6);
    assert!((lab.b - 26.9231792).abs() < 1e-6);
    // Absolute scale: the same colour at 80 cd/m² with an 80 cd/m² white.
    let lab80 = xyz_to_lab(
        Xyz::new(0.20654008, 0.12197225, 0.05136952) * 80.0,
        white * 80.0,
    );
    assert!((lab80.l - lab.l).abs() < 1e-9 && (lab80.a - lab.a).abs() < 1e-9);
}

#[test]
fn xyy_round_trip() {
    let xyz = Xyz::new(41.2, 21.3, 1.9);
    let xyy = xyz_to_xyy(xyz, [0.3127, 0.329]);
    let s = 41.2 + 21.3 + 1.9;
    assert!((xyy[0] - 41.2 / s).abs() < 1e-15 && (xyy[1] - 21.3 / s).abs() < 1e-15);
    assert_eq!(xyy[2], 21.3);
    let back = xyy_to_xyz(xyy);
    assert!((back - xyz).to_array().iter().all(|d| d.abs() < 1e-12));
    // Black keeps the fallback chromaticity.
    assert_eq!(
        xyz_to_xyy(Xyz::default(), [0.3127, 0.329]),
        [0.3127, 0.329, 0.0]
    );
}

#[test]
fn delta_e_xyz_is_zero_for_equal_and_counts_luminance() {
    let white = Xyz::from_xy_luminance(0.3127, 0.329, 80.0);
    let c = Xyz::new(20.0, 18.0, 9.0);
    assert_eq!(delta_e2000_xyz(c, c, white), 0.0);
    // Neutral colours: a* = b* = 0, so CIEDE2000 reduces to ΔL*/S_L (CIE 142-2001).
    let (y1, y2) = (0.2_f64, 0.202_f64);
    let (l1, l2) = (116.0 * y1.cbrt() - 16.0, 116.0 * y2.cbrt() - 16.0);
    let lbar = 0.5 * (l1 + l2);
    let s_l = 1.0 + 0.015 * (lbar - 50.0).powi(2) / (20.0 + (lbar - 50.0).powi(2)).sqrt();
    let de = delta_e2000_xyz(white * y1, white * y2, white);
    assert!((de - (l2 - l1) / s_l).abs() < 1e-9, "{de}");
}

#[test]
fn daylight_locus_matches_colour_science_doc_example() {
    // colour.CCT_to_xy(6504.38938305) = [0.3127077, 0.3291128] (colour-science docs).
    let xy = cct_to_xy(6504.38938305).unwrap();
    assert!((xy[0] - 0.3127077).abs() < 1e-7 && (xy[1] - 0.3291128).abs() < 1e-7);
    // Range limits are accepted, outside is an error.
    assert!(cct_to_xy(4000.0).is_ok() && cct_to_xy(25000.0).is_ok());
    assert!(cct_to_xy(3999.0).is_err() && cct_to_xy(25001.0).is_err());
}

#[test]
fn bradford_d65_to_d50_matches_lindbloom() {
    // B. Lindbloom, "Chromatic Adaptation", Bradford D65 → D50 with whites
    // (0.95047, 1, 1.08883) → (0.96422, 1, 0.82521).
    let expected = [
        [1.0478112, 0.0228866, -0.0501270],
        [0.0295424, 0.9904844, -0.0170491],
        [-0.0092345, 0.0150436, 0.7521316],
    ];
    let m = bradford_adaptation_matrix(
        Xyz::new(0.95047, 1.0, 1.08883),
        Xyz::new(0.96422, 1.0, 0.82521),
    )
    .unwrap();
    for r in 0..3 {
        for c in 0..3 {
            assert!(
                (m[(r, c)] - expected[r][c]).abs() < 1e-6,
                "({r},{c}) {}",
                m[(r, c)]
            );
        }
    }
    // The source white maps to the destination white.
    let w = bradford_adapt(
        Xyz::new(0.95047, 1.0, 1.08883),
        Xyz::new(0.95047, 1.0, 1.08883),
        Xyz::new(0.96422, 1.0, 0.82521),
    );
    assert!(
        (w - Xyz::new(0.96422, 1.0, 0.82521))
            .to_array()
            .iter()
            .all(|d| d.abs() < 1e-12)
    );
}
