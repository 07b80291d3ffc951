//! Common gamut: intersection and largest inscribed triangle against analytic cases and
//! a brute-force search; typed errors for empty intersections and degenerate displays.

use lumiwall_calib::CalibError;
use lumiwall_calib::gamut::{
    common_gamut, gamut_intersection_named, largest_inscribed_triangle, polygon_area, signed_area,
};

const SRGB: [[f64; 2]; 3] = [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]];

fn named(tris: &[[[f64; 2]; 3]]) -> Vec<(String, [[f64; 2]; 3])> {
    tris.iter()
        .enumerate()
        .map(|(i, t)| (format!("display {i}"), *t))
        .collect()
}

#[test]
fn intersection_area_matches_analytic_cases() {
    // A = (0,0),(1,0),(0,1); B = (0,0),(1,0),(1,1): A ∩ B = (0,0),(1,0),(0.5,0.5), area 0.25.
    let a = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
    let b = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]];
    let poly = gamut_intersection_named(&named(&[a, b])).unwrap();
    assert!((polygon_area(&poly) - 0.25).abs() < 1e-12);
    // A triangle and its point reflection through the centroid: a hexagon with 2/3 of
    // the triangle's area.
    let c = [(0.64 + 0.30 + 0.15) / 3.0, (0.33 + 0.60 + 0.06) / 3.0];
    let refl = SRGB.map(|p| [2.0 * c[0] - p[0], 2.0 * c[1] - p[1]]);
    let hex = gamut_intersection_named(&named(&[SRGB, refl])).unwrap();
    assert_eq!(hex.len(), 6);
    let tri_area = signed_area(SRGB[0], SRGB[1], SRGB[2]).abs();
    assert!((polygon_area(&hex) - 2.0 / 3.0 * tri_area).abs() < 1e-12);
    // The largest triangle in that (affinely regular) hexagon uses alternate vertices
    // and covers half of it: 1/3 of the triangle's area.
    let best = largest_inscribed_triangle(&hex).unwrap();
    let best_area = signed_area(best[0], best[1], best[2]).abs();
    assert!(
        (best_area - tri_area / 3.0).abs() < 1e-12,
        "{best_area} vs {}",
        tri_area / 3.0
    );
}

#[test]
fn largest_triangle_beats_brute_force_over_interior_points() {
    let other = [[0.68, 0.31], [0.21, 0.71], [0.16, 0.02]];
    let poly = gamut_intersection_named(&named(&[SRGB, other])).unwrap();
    let best = largest_inscribed_triangle(&poly).unwrap();
    let best_area = signed_area(best[0], best[1], best[2]).abs();
    // Points on the polygon boundary (every 1/40 of each edge).
    let mut pts = Vec::new();
    for i in 0..poly.len() {
        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
        for k in 0..40 {
            let t = k as f64 / 40.0;
            pts.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
        }
    }
    let mut brute = 0.0_f64;
    for i in 0..pts.len() {
        for j in i + 1..pts.len() {
            for k in j + 1..pts.len() {
                brute = brute.max(signed_area(pts[i], pts[j], pts[k]).abs());
            }
        }
    }
    assert!(best_area >= brute - 1e-12, "{best_area} < {brute}");
    // Labels: each common primary is nearest its own colour's originals.
    let g = common_gamut(&[SRGB, other]).unwrap();
    assert!(g[0][0] > 0.5 && g[1][1] > 0.5 && g[2][1] < 0.1, "{g:?}");
}

#[test]
fn empty_intersection_names_the_display() {
    let far = [[0.05, 0.8], [0.02, 0.7], [0.1, 0.75]];
    let err = common_gamut(&[SRGB, SRGB, far]).unwrap_err();
    assert!(matches!(err, CalibError::EmptyGamut { .. }));
    assert!(err.to_string().contains("display 2"), "{err}");
}

#[test]
fn degenerate_display_is_named() {
    let collinear = [[0.64, 0.33], [0.30, 0.60], [0.47, 0.465]];
    let err = common_gamut(&[SRGB, collinear]).unwrap_err();
    assert!(
        matches!(err, CalibError::DegeneratePrimaries { .. }),
        "{err}"
    );
    assert!(err.to_string().contains("display 1"), "{err}");
    let nan = [[f64::NAN, 0.33], [0.30, 0.60], [0.15, 0.06]];
    assert!(matches!(
        common_gamut(&[nan]),
        Err(CalibError::NonFinite { .. })
    ));
    assert!(matches!(
        common_gamut(&[]),
        Err(CalibError::InvalidOption { .. })
    ));
}

#[test]
fn near_identical_displays_give_their_own_gamut() {
    let mut tris = vec![SRGB];
    for k in 1..48 {
        let e = 1e-10 * k as f64;
        tris.push(SRGB.map(|p| [p[0] + e, p[1] - e]));
    }
    let g = common_gamut(&tris).unwrap();
    for c in 0..3 {
        assert!((g[c][0] - SRGB[c][0]).abs() < 1e-8 && (g[c][1] - SRGB[c][1]).abs() < 1e-8);
    }
}
