//! Sample points of a patch element and the linear representation built on them.
//!
//! The averaging rule is 3×3 Gauss–Legendre on quads (bilinear map) and the 7-point
//! Radon rule of degree 5 on triangles. Its points nearest the corners and its centre
//! double as the shape samples of Kresse 2.5.4: the corner samples carry the linear
//! (vertex) representation — bilinear through them on quads, affine on triangles, in
//! the element's own parameters — and the centre measures how far the function
//! bends. Because quadtree children are the parameter-space quarters of their parent,
//! pushing the representation to a child and extrapolating it to the vertices are
//! fixed weight tables.

use std::sync::OnceLock;

use crate::scene::V3;

use super::super::quadrature;

/// Shape samples per element: up to four corner samples and the centre (last).
pub(super) const NS: usize = 5;
/// Index of the centre among the shape samples.
pub(super) const CENTRE: usize = 4;

/// The points of one element.
#[derive(Debug, Clone)]
pub(super) struct Samples {
    /// Quadrature points (9 on quads, 7 on triangles).
    pub pts: [V3; 9],
    /// Quadrature weights, summing to 1.
    pub w: [f64; 9],
    /// Number of quadrature points.
    pub n: usize,
    /// Quadrature index of each shape sample (corners, then the centre at [`CENTRE`]).
    pub shape: [usize; NS],
}

const RADON_A: f64 = 0.101_286_507_323_456_34; // (6 − √15)/21
const RADON_B: f64 = 0.470_142_064_105_115_1; // (6 + √15)/21
const RADON_WA: f64 = 0.125_939_180_544_827_15; // (155 − √15)/1200
const RADON_WB: f64 = 0.132_394_152_788_506_2; // (155 + √15)/1200

impl Samples {
    /// Samples of a triangle or quad.
    pub fn of(verts: &[V3]) -> Self {
        let mut pts = [V3::zeros(); 9];
        let mut w = [0.0; 9];
        if verts.len() == 4 {
            let gl = quadrature::gauss_legendre_01(3);
            let mut total = 0.0;
            let mut k = 0;
            for &(s, ws) in gl {
                for &(t, wt) in gl {
                    pts[k] = quadrature::map_unit_square(verts, s, t);
                    w[k] = ws * wt * quad_jacobian(verts, s, t);
                    total += w[k];
                    k += 1;
                }
            }
            if total > 0.0 {
                for x in &mut w {
                    *x /= total;
                }
            }
            // index = 3·i_s + i_t; (s, t) = (0, 0) is vertex 0, (1, 0) vertex 1, …
            Self {
                pts,
                w,
                n: 9,
                shape: [0, 6, 8, 2, 4],
            }
        } else {
            let (a, b, c) = (verts[0], verts[1], verts[2]);
            let bary = |l0: f64, l1: f64, l2: f64| a * l0 + b * l1 + c * l2;
            let ta = 1.0 - 2.0 * RADON_A;
            let tb = 1.0 - 2.0 * RADON_B;
            let list = [
                (bary(ta, RADON_A, RADON_A), RADON_WA),
                (bary(RADON_A, ta, RADON_A), RADON_WA),
                (bary(RADON_A, RADON_A, ta), RADON_WA),
                (bary(1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0), 9.0 / 40.0),
                (bary(tb, RADON_B, RADON_B), RADON_WB),
                (bary(RADON_B, tb, RADON_B), RADON_WB),
                (bary(RADON_B, RADON_B, tb), RADON_WB),
            ];
            for (k, (p, wk)) in list.iter().enumerate() {
                pts[k] = *p;
                w[k] = *wk;
            }
            Self {
                pts,
                w,
                n: 7,
                shape: [0, 1, 2, 3, 3],
            }
        }
    }

    /// Shape sample `k` (a corner sample for k < corners, the centre for k = CENTRE).
    #[cfg(test)]
    pub fn shape_point(&self, k: usize) -> V3 {
        self.pts[self.shape[k]]
    }
}

fn quad_jacobian(v: &[V3], s: f64, t: f64) -> f64 {
    let ds = (v[1] - v[0]) * (1.0 - t) + (v[2] - v[3]) * t;
    let dt = (v[3] - v[0]) * (1.0 - s) + (v[2] - v[1]) * s;
    ds.cross(&dt).norm()
}

/// Weights of the linear representation: value at a point = Σᵢ wᵢ · (corner sample i).
type Weights = [f64; 4];

/// Fixed tables: for each child (4) the weights of its shape samples (5) on the
/// parent's corner samples, and the weights of the vertices (4) on the element's own
/// corner samples; one set for quads, one for triangles.
struct Tables {
    quad_push: [[Weights; NS]; 4],
    quad_vertex: [Weights; 4],
    tri_push: [[Weights; NS]; 4],
    tri_vertex: [Weights; 4],
}

/// Bilinear Lagrange weights on the corner-sample grid {g0, g2}² at (s, t); corner
/// order (g0,g0), (g2,g0), (g2,g2), (g0,g2) like the shape samples.
fn quad_weights(s: f64, t: f64) -> Weights {
    let gl = quadrature::gauss_legendre_01(3);
    let (g0, g2) = (gl[0].0, gl[2].0);
    let a = (s - g0) / (g2 - g0);
    let b = (t - g0) / (g2 - g0);
    [(1.0 - a) * (1.0 - b), a * (1.0 - b), a * b, (1.0 - a) * b]
}

/// Affine weights on the three corner samples at barycentric `l`.
fn tri_weights(l: [f64; 3]) -> Weights {
    let d = 1.0 - 3.0 * RADON_A;
    [
        (l[0] - RADON_A) / d,
        (l[1] - RADON_A) / d,
        (l[2] - RADON_A) / d,
        0.0,
    ]
}

fn tables() -> &'static Tables {
    static T: OnceLock<Tables> = OnceLock::new();
    T.get_or_init(|| {
        let gl = quadrature::gauss_legendre_01(3);
        let (g0, g2) = (gl[0].0, gl[2].0);
        // shape samples of an element in its own (s, t)
        let quad_shape = [(g0, g0), (g2, g0), (g2, g2), (g0, g2), (0.5, 0.5)];
        // child k of `quadrature::split4` is the parameter quarter at this offset
        let quad_off = [(0.0, 0.0), (0.5, 0.0), (0.5, 0.5), (0.0, 0.5)];
        let quad_push = std::array::from_fn(|c| {
            std::array::from_fn(|j| {
                let (s, t) = quad_shape[j];
                quad_weights(quad_off[c].0 + 0.5 * s, quad_off[c].1 + 0.5 * t)
            })
        });
        let quad_vertex =
            [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)].map(|(s, t)| quad_weights(s, t));
        // triangle children: their vertices in the parent's barycentrics
        let (v0, v1, v2) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
        let m01 = [0.5, 0.5, 0.0];
        let m12 = [0.0, 0.5, 0.5];
        let m20 = [0.5, 0.0, 0.5];
        let kids = [
            [v0, m01, m20],
            [m01, v1, m12],
            [m20, m12, v2],
            [m01, m12, m20],
        ];
        let ta = 1.0 - 2.0 * RADON_A;
        let tri_shape = [
            [ta, RADON_A, RADON_A],
            [RADON_A, ta, RADON_A],
            [RADON_A, RADON_A, ta],
            [1.0 / 3.0; 3],
            [1.0 / 3.0; 3],
        ];
        let tri_push = std::array::from_fn(|c| {
            std::array::from_fn(|j| {
                let mu = tri_shape[j];
                let k = &kids[c];
                let l: [f64; 3] =
                    std::array::from_fn(|i| mu[0] * k[0][i] + mu[1] * k[1][i] + mu[2] * k[2][i]);
                tri_weights(l)
            })
        });
        let tri_vertex = [tri_weights(v0), tri_weights(v1), tri_weights(v2), [0.0; 4]];
        Tables {
            quad_push,
            quad_vertex,
            tri_push,
            tri_vertex,
        }
    })
}

fn apply(w: &Weights, corners: usize, vals: &[[f64; 3]; NS]) -> [f64; 3] {
    let mut out = [0.0; 3];
    for i in 0..corners {
        for c in 0..3 {
            out[c] += w[i] * vals[i][c];
        }
    }
    out
}

/// The shape samples of child `child` (0..4, in `quadrature::split4` order) from the
/// parent's linear representation (`corners` = 4 for quads, 3 for triangles).
pub(super) fn push_to_child(
    corners: usize,
    child: usize,
    parent: &[[f64; 3]; NS],
) -> [[f64; 3]; NS] {
    let t = tables();
    let w = if corners == 4 {
        &t.quad_push[child]
    } else {
        &t.tri_push[child]
    };
    std::array::from_fn(|j| apply(&w[j], corners, parent))
}

/// The linear representation at the element's vertices.
pub(super) fn at_vertices(corners: usize, vals: &[[f64; 3]; NS]) -> Vec<[f64; 3]> {
    let t = tables();
    let w = if corners == 4 {
        &t.quad_vertex
    } else {
        &t.tri_vertex
    };
    w[..corners]
        .iter()
        .map(|w| apply(w, corners, vals))
        .collect()
}

/// The linear representation's value at the centre (the mean of the corner samples
/// for both shapes).
pub(super) fn linear_centre(corners: usize, vals: &[f64; NS]) -> f64 {
    vals[..corners].iter().sum::<f64>() / corners as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn linear(x: &V3) -> [f64; 3] {
        [1.0 + 2.0 * x.x - 0.5 * x.y, 3.0 * x.z, -x.x + x.y + x.z]
    }

    fn check(verts: &[V3]) {
        let s = Samples::of(verts);
        let corners = verts.len();
        let vals: [[f64; 3]; NS] = std::array::from_fn(|j| linear(&s.shape_point(j)));
        // an affine function is reproduced at the vertices and in every child
        for (v, got) in verts.iter().zip(at_vertices(corners, &vals)) {
            let want = linear(v);
            for c in 0..3 {
                assert!((got[c] - want[c]).abs() < 1e-12, "{got:?} vs {want:?}");
            }
        }
        let kids = quadrature::split4(verts);
        for (k, kv) in kids.iter().enumerate() {
            let ks = Samples::of(kv);
            let pushed = push_to_child(corners, k, &vals);
            for j in 0..NS {
                let want = linear(&ks.shape_point(j));
                for c in 0..3 {
                    assert!(
                        (pushed[j][c] - want[c]).abs() < 1e-12,
                        "child {k} sample {j}"
                    );
                }
            }
        }
        let centre: [f64; NS] = std::array::from_fn(|j| vals[j][0]);
        assert!(
            (linear_centre(corners, &centre) - linear(&s.shape_point(CENTRE))[0]).abs() < 1e-12
        );
        // weights average
        assert!((s.w[..s.n].iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn linear_representation_is_exact_for_affine_functions() {
        // a parallelogram (bilinear map affine) and a triangle
        check(&[
            V3::new(0.0, 0.0, 0.0),
            V3::new(2.0, 0.5, 0.0),
            V3::new(2.5, 1.5, 0.3),
            V3::new(0.5, 1.0, 0.3),
        ]);
        check(&[
            V3::new(0.0, 0.0, 1.0),
            V3::new(1.0, 0.2, 1.0),
            V3::new(0.3, 1.1, 1.2),
        ]);
    }

    #[test]
    fn rules_integrate_polynomials() {
        // ∫ x² over the unit square = 1/3; over the triangle (0,0),(1,0),(0,1): mean 1/6
        let sq = Samples::of(&[
            V3::new(0.0, 0.0, 0.0),
            V3::new(1.0, 0.0, 0.0),
            V3::new(1.0, 1.0, 0.0),
            V3::new(0.0, 1.0, 0.0),
        ]);
        let m: f64 = (0..sq.n).map(|i| sq.w[i] * sq.pts[i].x.powi(2)).sum();
        assert!((m - 1.0 / 3.0).abs() < 1e-12);
        let tr = Samples::of(&[
            V3::new(0.0, 0.0, 0.0),
            V3::new(1.0, 0.0, 0.0),
            V3::new(0.0, 1.0, 0.0),
        ]);
        let m: f64 = (0..tr.n)
            .map(|i| tr.w[i] * tr.pts[i].x.powi(2) * tr.pts[i].y)
            .sum();
        // mean of x²y over the triangle = 2 · 1/60
        assert!((m - 1.0 / 30.0).abs() < 1e-12, "{m}");
    }
}
