//! The wall's common gamut in CIE xy (Kresse 2003, 3.3.2): the intersection of all
//! displays' primary triangles (Sutherland–Hodgman clipping of convex polygons) and the
//! largest triangle inscribed in it, labelled R, G, B by the nearest original primaries.
//!
//! For a convex polygon the maximum-area inscribed triangle has its corners on polygon
//! vertices, so an exhaustive search over vertex triples is exact (O(n³), n ≤ 3 × the
//! number of displays). Kresse's alternative, pairwise mapping of primaries into the
//! other display's RGB, gives the same result and is not needed here.

use crate::CalibError;
use lumiwall_core::Channel;

/// Smallest xy triangle area (in xy units²) accepted as a real display gamut. sRGB has
/// 0.112, a narrow-band Infitec eye about 0.1; a dead channel or three identical
/// readings give (almost) 0.
pub const MIN_TRIANGLE_AREA: f64 = 1e-4;

/// Smallest area of the intersection polygon that still counts as a common gamut.
pub const MIN_COMMON_AREA: f64 = 1e-7;

/// A point of the xy chromaticity plane as the polygon clipping works on it: the plain
/// `[x, y]` form of [`lumiwall_core::Xy`] (convert with `Xy::from` / `to_array`).
pub type XyPoint = [f64; 2];

/// Signed area of the triangle `a b c` (positive when counter-clockwise).
pub fn signed_area(a: XyPoint, b: XyPoint, c: XyPoint) -> f64 {
    0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
}

/// Area of a simple polygon (shoelace formula), always ≥ 0.
pub fn polygon_area(poly: &[XyPoint]) -> f64 {
    let n = poly.len();
    if n < 3 {
        return 0.0;
    }
    let mut s = 0.0;
    for i in 0..n {
        let (p, q) = (poly[i], poly[(i + 1) % n]);
        s += p[0] * q[1] - q[0] * p[1];
    }
    0.5 * s.abs()
}

fn ccw(tri: &[XyPoint; 3]) -> [XyPoint; 3] {
    if signed_area(tri[0], tri[1], tri[2]) < 0.0 {
        [tri[0], tri[2], tri[1]]
    } else {
        *tri
    }
}

/// Clips a convex counter-clockwise polygon by the half-plane left of `a → b`.
fn clip_half_plane(poly: &[XyPoint], a: XyPoint, b: XyPoint) -> Vec<XyPoint> {
    let side = |p: XyPoint| (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
    let n = poly.len();
    let mut out = Vec::with_capacity(n + 1);
    for i in 0..n {
        let (p, q) = (poly[i], poly[(i + 1) % n]);
        let (sp, sq) = (side(p), side(q));
        if sp >= 0.0 {
            out.push(p);
        }
        if (sp >= 0.0) != (sq >= 0.0) {
            let t = sp / (sp - sq);
            out.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
        }
    }
    // Drop (near-)duplicate consecutive vertices created when the clip line passes
    // through a vertex (near-identical displays).
    let mut dedup: Vec<XyPoint> = Vec::with_capacity(out.len());
    for p in out {
        let dup = dedup
            .last()
            .is_some_and(|l| (l[0] - p[0]).abs() < 1e-12 && (l[1] - p[1]).abs() < 1e-12);
        if !dup {
            dedup.push(p);
        }
    }
    while dedup.len() > 1 {
        let (f, l) = (dedup[0], dedup[dedup.len() - 1]);
        if (f[0] - l[0]).abs() < 1e-12 && (f[1] - l[1]).abs() < 1e-12 {
            dedup.pop();
        } else {
            break;
        }
    }
    dedup
}

fn check_triangle(name: &str, tri: &[XyPoint; 3]) -> Result<(), CalibError> {
    for (c, p) in Channel::ALL.iter().zip(tri) {
        for v in p {
            if !v.is_finite() {
                return Err(CalibError::NonFinite {
                    what: format!("{name} {} primary chromaticity", c.name()),
                    value: *v,
                });
            }
        }
    }
    let area = signed_area(tri[0], tri[1], tri[2]).abs();
    if area < MIN_TRIANGLE_AREA {
        return Err(CalibError::DegeneratePrimaries {
            display: name.to_string(),
            area,
            min_area: MIN_TRIANGLE_AREA,
        });
    }
    Ok(())
}

/// Intersection polygon (counter-clockwise) of named xy triangles `(name, [R, G, B])`.
/// Errors: a degenerate triangle (named), or an empty intersection (names the display
/// whose triangle emptied it).
pub fn gamut_intersection_named(
    displays: &[(String, [XyPoint; 3])],
) -> Result<Vec<XyPoint>, CalibError> {
    let Some((first_name, first)) = displays.first() else {
        return Err(CalibError::InvalidOption {
            option: "displays".into(),
            reason: "no display given for the common gamut".into(),
        });
    };
    check_triangle(first_name, first)?;
    let mut poly: Vec<XyPoint> = ccw(first).to_vec();
    for (name, tri) in &displays[1..] {
        check_triangle(name, tri)?;
        let t = ccw(tri);
        for i in 0..3 {
            poly = clip_half_plane(&poly, t[i], t[(i + 1) % 3]);
        }
        if poly.len() < 3 || polygon_area(&poly) < MIN_COMMON_AREA {
            return Err(CalibError::EmptyGamut {
                display: name.clone(),
            });
        }
    }
    Ok(poly)
}

/// Largest-area triangle with corners on the vertices of a convex polygon (exact for
/// convex polygons). Returns `None` for fewer than 3 vertices.
pub fn largest_inscribed_triangle(poly: &[XyPoint]) -> Option<[XyPoint; 3]> {
    let n = poly.len();
    if n < 3 {
        return None;
    }
    let mut best = (f64::NEG_INFINITY, [0usize, 1, 2]);
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let a = signed_area(poly[i], poly[j], poly[k]).abs();
                if a > best.0 {
                    best = (a, [i, j, k]);
                }
            }
        }
    }
    let [i, j, k] = best.1;
    Some([poly[i], poly[j], poly[k]])
}

/// Orders three points as R, G, B: the permutation closest (least summed squared xy
/// distance) to the mean of the displays' own R, G, B primaries.
fn label_rgb(tri: [XyPoint; 3], reference: [XyPoint; 3]) -> [XyPoint; 3] {
    // The six orderings of (0, 1, 2), lexicographic (ties keep the first).
    let perms: Vec<[usize; 3]> = (0..27)
        .map(|k| [k / 9, k / 3 % 3, k % 3])
        .filter(|p| p[0] != p[1] && p[1] != p[2] && p[0] != p[2])
        .collect();
    let cost = |p: &[usize; 3]| -> f64 {
        (0..3)
            .map(|c| {
                let (a, b) = (tri[p[c]], reference[c]);
                (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
            })
            .sum()
    };
    let mut best = perms[0];
    for p in perms.iter().skip(1) {
        if cost(p) < cost(&best) {
            best = *p;
        }
    }
    [tri[best[0]], tri[best[1]], tri[best[2]]]
}

/// Common gamut of named displays: the largest triangle inscribed in the intersection of
/// their xy triangles `[R, G, B]`, labelled R, G, B. Errors name the display.
pub fn common_gamut_named(displays: &[(String, [XyPoint; 3])]) -> Result<[XyPoint; 3], CalibError> {
    let poly = gamut_intersection_named(displays)?;
    let tri = largest_inscribed_triangle(&poly).ok_or_else(|| CalibError::EmptyGamut {
        display: displays
            .last()
            .map(|d| d.0.clone())
            .unwrap_or_else(|| "display 0".into()),
    })?;
    let n = displays.len() as f64;
    let mut mean = [[0.0; 2]; 3];
    for (_, t) in displays {
        for c in 0..3 {
            mean[c][0] += t[c][0] / n;
            mean[c][1] += t[c][1] / n;
        }
    }
    Ok(label_rgb(tri, mean))
}

/// Common gamut of displays given as xy triangles `[R, G, B]`; errors name displays by
/// their index ("display 3").
pub fn common_gamut(displays: &[[XyPoint; 3]]) -> Result<[XyPoint; 3], CalibError> {
    let named: Vec<(String, [XyPoint; 3])> = displays
        .iter()
        .enumerate()
        .map(|(i, t)| (format!("display {i}"), *t))
        .collect();
    common_gamut_named(&named)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_triangle_is_its_own_gamut() {
        let srgb = [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]];
        let g = common_gamut(&[srgb]).unwrap();
        assert_eq!(g, srgb);
    }

    #[test]
    fn vertex_order_does_not_matter() {
        let srgb = [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]];
        let inner = [[0.60, 0.34], [0.31, 0.55], [0.16, 0.08]];
        let b = common_gamut(&[srgb, inner]).unwrap();
        let c = common_gamut(&[inner, srgb]).unwrap();
        for k in 0..3 {
            assert!((b[k][0] - c[k][0]).abs() < 1e-12 && (b[k][1] - c[k][1]).abs() < 1e-12);
            assert!((b[k][0] - inner[k][0]).abs() < 1e-12 && (b[k][1] - inner[k][1]).abs() < 1e-12);
        }
    }
}
