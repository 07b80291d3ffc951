//! Quadrature on planar convex polygons (Gauss–Legendre on the unit square, mapped
//! bilinearly onto quads and by the Duffy collapse onto triangles) and the split of a
//! polygon into four children (the quadtree of hierarchical radiosity).

use std::sync::OnceLock;

use crate::scene::V3;

/// Largest Gauss–Legendre order provided.
pub const MAX_ORDER: usize = 12;

fn legendre_tables() -> &'static Vec<Vec<(f64, f64)>> {
    static T: OnceLock<Vec<Vec<(f64, f64)>>> = OnceLock::new();
    T.get_or_init(|| {
        (0..=MAX_ORDER)
            .map(|n| {
                // nodes and weights on [0, 1] by Newton iteration on P_n
                let mut out = Vec::with_capacity(n);
                for i in 0..n {
                    let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
                    let mut dp = 1.0;
                    for _ in 0..100 {
                        let (mut p0, mut p1) = (1.0, x);
                        for k in 2..=n {
                            let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                            p0 = p1;
                            p1 = p2;
                        }
                        let p = if n == 0 { 1.0 } else { p1 };
                        let pm1 = if n == 1 { 1.0 } else { p0 };
                        dp = n as f64 * (x * p - pm1) / (x * x - 1.0);
                        let dx = p / dp;
                        x -= dx;
                        if dx.abs() < 1e-15 {
                            break;
                        }
                    }
                    let w = 2.0 / ((1.0 - x * x) * dp * dp);
                    out.push((0.5 * (1.0 - x), 0.5 * w));
                }
                out
            })
            .collect()
    })
}

/// Gauss–Legendre nodes and weights on [0, 1] (weights sum to 1); `n` is clamped to
/// 1..=[`MAX_ORDER`].
pub fn gauss_legendre_01(n: usize) -> &'static [(f64, f64)] {
    &legendre_tables()[n.clamp(1, MAX_ORDER)]
}

/// Point on a triangle or quad for unit-square parameters (s, t): bilinear for quads,
/// the Duffy collapse (s, t) → v0 + s(v1 − v0) + s·t(v2 − v1) for triangles.
pub fn map_unit_square(v: &[V3], s: f64, t: f64) -> V3 {
    if v.len() == 4 {
        v[0] * ((1.0 - s) * (1.0 - t))
            + v[1] * (s * (1.0 - t))
            + v[2] * (s * t)
            + v[3] * ((1.0 - s) * t)
    } else {
        v[0] + (v[1] - v[0]) * s + (v[2] - v[1]) * (s * t)
    }
}

fn jacobian(v: &[V3], s: f64, t: f64) -> f64 {
    if v.len() == 4 {
        let ds = (v[1] - v[0]) * (1.0 - t) + (v[2] - v[3]) * t;
        let dt = (v[3] - v[0]) * (1.0 - s) + (v[2] - v[1]) * s;
        ds.cross(&dt).norm()
    } else {
        (v[1] - v[0]).cross(&(v[2] - v[1])).norm() * s
    }
}

/// Quadrature points on a triangle or quad with weights that sum to 1 (area average).
/// Other convex polygons are fanned into triangles weighted by area.
pub fn points(v: &[V3], n: usize, out: &mut Vec<(V3, f64)>) {
    out.clear();
    if v.len() == 3 || v.len() == 4 {
        let gl = gauss_legendre_01(n);
        let mut total = 0.0;
        for &(s, weight_s) in gl {
            for &(t, wt) in gl {
                let w = weight_s * wt * jacobian(v, s, t);
                total += w;
                out.push((map_unit_square(v, s, t), w));
            }
        }
        if total > 0.0 {
            for p in out.iter_mut() {
                p.1 /= total;
            }
        }
    } else {
        let mut tmp = Vec::new();
        let mut total = 0.0;
        for i in 1..v.len().saturating_sub(1) {
            let tri = [v[0], v[i], v[i + 1]];
            let a = 0.5 * (tri[1] - tri[0]).cross(&(tri[2] - tri[0])).norm();
            points(&tri, n, &mut tmp);
            total += a;
            out.extend(tmp.iter().map(|&(p, w)| (p, w * a)));
        }
        if total > 0.0 {
            for p in out.iter_mut() {
                p.1 /= total;
            }
        }
    }
}

/// Splits a triangle or quad into four children (midpoint subdivision, which is the
/// parameter-space quadtree split). Vertex order keeps the winding.
pub fn split4(v: &[V3]) -> Vec<Vec<V3>> {
    if v.len() == 4 {
        let m01 = (v[0] + v[1]) * 0.5;
        let m12 = (v[1] + v[2]) * 0.5;
        let m23 = (v[2] + v[3]) * 0.5;
        let m30 = (v[3] + v[0]) * 0.5;
        let c = map_unit_square(v, 0.5, 0.5);
        vec![
            vec![v[0], m01, c, m30],
            vec![m01, v[1], m12, c],
            vec![c, m12, v[2], m23],
            vec![m30, c, m23, v[3]],
        ]
    } else {
        let m01 = (v[0] + v[1]) * 0.5;
        let m12 = (v[1] + v[2]) * 0.5;
        let m20 = (v[2] + v[0]) * 0.5;
        vec![
            vec![v[0], m01, m20],
            vec![m01, v[1], m12],
            vec![m20, m12, v[2]],
            vec![m01, m12, m20],
        ]
    }
}

/// A cosine-distributed direction about the unit normal `n` (Malley's method) from two
/// uniform numbers in [0, 1); unit up to rounding.
pub fn cosine_direction(n: &V3, u1: f64, u2: f64) -> V3 {
    let helper = if n.x.abs() < 0.9 { V3::x() } else { V3::y() };
    let t = n.cross(&helper).normalize();
    let b = n.cross(&t);
    let r = u1.sqrt();
    let phi = std::f64::consts::TAU * u2;
    t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt()
}

/// A point uniformly distributed by area on a triangle or planar convex quad, from
/// three uniform numbers in [0, 1): `r0` picks the quad's half (by area), `r1`, `r2`
/// the point in the triangle (folded square).
pub fn uniform_point(v: &[V3], r0: f64, r1: f64, r2: f64) -> V3 {
    let tri = |a: &V3, b: &V3, c: &V3| {
        let (mut s, mut t) = (r1, r2);
        if s + t > 1.0 {
            s = 1.0 - s;
            t = 1.0 - t;
        }
        a + (b - a) * s + (c - a) * t
    };
    if v.len() == 4 {
        let a1 = (v[1] - v[0]).cross(&(v[2] - v[0])).norm();
        let a2 = (v[2] - v[0]).cross(&(v[3] - v[0])).norm();
        if r0 * (a1 + a2) < a1 {
            tri(&v[0], &v[1], &v[2])
        } else {
            tri(&v[0], &v[2], &v[3])
        }
    } else {
        tri(&v[0], &v[1], &v[2])
    }
}
