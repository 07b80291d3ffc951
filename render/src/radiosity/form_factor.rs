//! Form factors: the exact differential-area-to-polygon form factor (Lambert's contour
//! integral, after clipping the polygon to the receiver's tangent half-space) and the
//! area-to-area form factor by adaptive quadrature over the receiver with the exact
//! inner integral, returning an error estimate.

use crate::scene::V3;

use super::quadrature;

/// [`point_to_polygon`] for a polygon small against its distance from `x`: the
/// kernel cos θ cos θ' / (π r²) at the polygon's quadrature points `pts` (weights
/// summing to 1) times its area `area_m2`, no arc tangents. `None` where the exact
/// form must clip (a point behind `x`'s tangent plane, or `x` behind the polygon).
/// For a polygon whose radius is at most a tenth of its distance the 2×2 Gauss rule
/// is within 1e-3 of the factor the polygon has head-on (8e-4 the worst of a thousand
/// random ones, `form_factors` tests).
pub fn point_to_small_polygon(
    x: &V3,
    n: &V3,
    pts: &[(V3, f64)],
    area_m2: f64,
    poly_normal: &V3,
) -> Option<f64> {
    let mut sum = 0.0;
    for (p, w) in pts {
        let d = p - x;
        let (cos_r, cos_s) = (n.dot(&d), -poly_normal.dot(&d));
        if cos_r <= 0.0 || cos_s <= 0.0 {
            return None;
        }
        let r2 = d.norm_squared();
        sum += w * cos_r * cos_s / (r2 * r2);
    }
    Some(sum * area_m2 / std::f64::consts::PI)
}

/// Differential area at `x` with unit normal `n` to the polygon `poly` (convex, any
/// number of vertices). One-sided: only the polygon's front (right-hand normal
/// `poly_normal`) emits; returns 0 when `x` is behind it. Unoccluded.
pub fn point_to_polygon(x: &V3, n: &V3, poly: &[V3], poly_normal: &V3) -> f64 {
    // one-sided emitter: x must lie in front of the source plane
    if poly_normal.dot(&(x - poly[0])) <= 0.0 {
        return 0.0;
    }
    // clip against the receiver's tangent plane n·(v − x) ≥ 0
    let m = poly.len();
    let mut small = [V3::zeros(); 12];
    let mut big = Vec::new();
    let clipped: &mut [V3] = if m + 2 <= small.len() {
        &mut small[..]
    } else {
        big.resize(m + 2, V3::zeros());
        &mut big[..]
    };
    let k = clip_in_front(x, n, poly, clipped);
    if k < 3 {
        return 0.0;
    }
    let mut sum = 0.0;
    for i in 0..k {
        let ra = clipped[i] - x;
        let rb = clipped[(i + 1) % k] - x;
        let c = ra.cross(&rb);
        let cn = c.norm();
        if cn <= 1e-300 {
            continue;
        }
        let beta = cn.atan2(ra.dot(&rb));
        sum += beta * n.dot(&c) / cn;
    }
    (sum / std::f64::consts::TAU).abs()
}

/// The part of the convex polygon `poly` in front of the plane through `x` with normal
/// `n` (`n·(v − x) ≥ 0`), written into `out` (at least `poly.len() + 2` long); returns
/// its vertex count (below 3: nothing in front).
fn clip_in_front(x: &V3, n: &V3, poly: &[V3], out: &mut [V3]) -> usize {
    let m = poly.len();
    let mut k = 0usize;
    for i in 0..m {
        let a = poly[i];
        let b = poly[(i + 1) % m];
        let da = n.dot(&(a - x));
        let db = n.dot(&(b - x));
        if da >= 0.0 {
            if k < out.len() {
                out[k] = a;
                k += 1;
            }
            if db < 0.0 && da > 0.0 && k < out.len() {
                out[k] = a + (b - a) * (da / (da - db));
                k += 1;
            }
        } else if db > 0.0 && k < out.len() {
            out[k] = a + (b - a) * (da / (da - db));
            k += 1;
        }
    }
    k
}

/// Shadow-ray targets on a sender polygon `poly` for a receiver point `x` with normal
/// `n`: those of `targets` in front of `x`'s tangent plane. Light from the part of the
/// sender behind that plane does not reach `x` (the form factor clips it away), so a
/// ray there must not count either: from a face of a solid such a ray runs through the
/// solid and would count as blocked, darkening every pair where one patch crosses the
/// plane of the other. When no target is in front, the centroid of the sender's part
/// in front stands for it; empty when nothing of the sender is in front.
pub fn targets_in_front(x: &V3, n: &V3, targets: &[V3], poly: &[V3]) -> Vec<V3> {
    let front: Vec<V3> = targets
        .iter()
        .filter(|t| n.dot(&(*t - x)) > 0.0)
        .copied()
        .collect();
    if !front.is_empty() {
        return front;
    }
    let mut clipped = vec![V3::zeros(); poly.len() + 2];
    let k = clip_in_front(x, n, poly, &mut clipped);
    if k < 3 {
        return Vec::new();
    }
    let centroid = clipped[..k].iter().fold(V3::zeros(), |a, v| a + v) / k as f64;
    vec![centroid]
}

/// An area-averaged form factor with an estimate of its quadrature error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FormFactor {
    /// F from the receiver to the source (fraction of the receiver's outgoing flux
    /// reaching the source; the receiver-area average of the point form factor).
    pub value: f64,
    /// Estimated absolute quadrature error of `value`.
    pub error: f64,
}

fn unit_normal(v: &[V3]) -> V3 {
    crate::scene::polygon_normal(v).unwrap_or_else(V3::z)
}

fn average(
    recv: &[V3],
    rn: &V3,
    src: &[V3],
    sn: &V3,
    order: usize,
    buf: &mut Vec<(V3, f64)>,
) -> f64 {
    quadrature::points(recv, order, buf);
    buf.iter()
        .map(|(p, w)| w * point_to_polygon(p, rn, src, sn))
        .sum()
}

#[allow(
    clippy::too_many_arguments,
    reason = "the two polygons and their quadrature are the natural inputs"
)]
fn adaptive(
    recv: &[V3],
    rn: &V3,
    src: &[V3],
    sn: &V3,
    coarse: f64,
    tol: f64,
    depth: u32,
    buf: &mut Vec<(V3, f64)>,
) -> (f64, f64) {
    let kids = quadrature::split4(recv);
    let areas: Vec<f64> = kids
        .iter()
        .map(|k| crate::scene::polygon_area_m2(k))
        .collect();
    let total: f64 = areas.iter().sum();
    let vals: Vec<f64> = kids
        .iter()
        .map(|k| average(k, rn, src, sn, 4, buf))
        .collect();
    let fine: f64 = vals.iter().zip(&areas).map(|(v, a)| v * a).sum::<f64>() / total;
    let diff = (fine - coarse).abs();
    if diff <= tol || depth == 0 {
        return (fine, diff);
    }
    let mut value = 0.0;
    let mut err = 0.0;
    for ((k, v), a) in kids.iter().zip(&vals).zip(&areas) {
        let (fv, fe) = adaptive(k, rn, src, sn, *v, tol, depth - 1, buf);
        value += fv * a / total;
        err += fe * a / total;
    }
    (value, err)
}

/// Form factor from polygon `recv` to polygon `src` (both convex, triangles/quads or
/// fanned n-gons), unoccluded, to an absolute tolerance `tol` by adaptive receiver
/// subdivision (order-4 Gauss–Legendre per cell, exact inner contour integral).
pub fn polygon_to_polygon(recv: &[V3], src: &[V3], tol: f64) -> FormFactor {
    let rn = unit_normal(recv);
    let sn = unit_normal(src);
    let mut buf = Vec::new();
    if recv.len() > 4 {
        // fan into triangles, area-weighted
        let mut value = 0.0;
        let mut err = 0.0;
        let total = crate::scene::polygon_area_m2(recv);
        for i in 1..recv.len() - 1 {
            let tri = [recv[0], recv[i], recv[i + 1]];
            let a = crate::scene::polygon_area_m2(&tri);
            let f = polygon_to_polygon(&tri, src, tol);
            value += f.value * a / total;
            err += f.error * a / total;
        }
        return FormFactor { value, error: err };
    }
    let coarse = average(recv, &rn, src, &sn, 4, &mut buf);
    let (value, error) = adaptive(recv, &rn, src, &sn, coarse, tol, 10, &mut buf);
    FormFactor { value, error }
}
