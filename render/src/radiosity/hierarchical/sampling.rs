//! Sample points of a patch element and the representations built on them.
//!
//! The averaging rule is 3×3 Gauss–Legendre on quads (bilinear map) and the 7-point
//! Radon rule of degree 5 on triangles. Its points double as the shape samples of
//! Kresse 2.5.4: the samples nearest the corners carry the linear (vertex)
//! representation — bilinear through them on quads, affine on triangles, in the
//! element's own parameters — and all of them together determine a quadratic
//! (biquadratic on quads, least squares on triangles), which is what the error of a
//! constant or linear representation is measured against and what is pushed to
//! children. Because quadtree children are the parameter-space quarters of their
//! parent, pushing, extrapolating to the vertices and measuring are fixed weight
//! tables.

use std::sync::OnceLock;

use crate::scene::V3;

use super::super::quadrature;

/// Shape samples per element: up to four corner samples, the centre, and the
/// points between (edge samples on quads, the inner ring on triangles; slots a
/// triangle lacks repeat its centre).
pub(super) const NS: usize = 9;

/// The points of one element.
#[derive(Debug, Clone)]
pub(super) struct Samples {
    /// Quadrature points (9 on quads, 7 on triangles).
    pub pts: [V3; 9],
    /// Quadrature weights, summing to 1.
    pub w: [f64; 9],
    /// Number of quadrature points.
    pub n: usize,
    /// Quadrature index of each shape sample (corners, centre, the points between).
    pub shape: [usize; NS],
}

const RADON_A: f64 = 0.101_286_507_323_456_34; // (6 − √15)/21
const RADON_B: f64 = 0.470_142_064_105_115_1; // (6 + √15)/21
const RADON_WA: f64 = 0.125_939_180_544_827_15; // (155 − √15)/1200
const RADON_WB: f64 = 0.132_394_152_788_506_2; // (155 + √15)/1200

impl Samples {
    /// Samples of a triangle or quad.
    pub(crate) fn of(verts: &[V3]) -> Self {
        let mut pts = [V3::zeros(); 9];
        let mut w = [0.0; 9];
        if verts.len() == 4 {
            let gl = quadrature::gauss_legendre_01(3);
            let mut total = 0.0;
            let mut k = 0;
            for &(s, weight_s) in gl {
                for &(t, wt) in gl {
                    pts[k] = quadrature::map_unit_square(verts, s, t);
                    w[k] = weight_s * wt * quad_jacobian(verts, s, t);
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
                shape: [0, 6, 8, 2, 4, 3, 7, 5, 1],
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
                shape: [0, 1, 2, 3, 3, 4, 5, 6, 3],
            }
        }
    }

    /// Shape sample `k` (a corner sample for k < corners, the centre for k = 4).
    #[cfg(test)]
    pub(crate) fn shape_point(&self, k: usize) -> V3 {
        self.pts[self.shape[k]]
    }
}

fn quad_jacobian(v: &[V3], s: f64, t: f64) -> f64 {
    let ds = (v[1] - v[0]) * (1.0 - t) + (v[2] - v[3]) * t;
    let dt = (v[3] - v[0]) * (1.0 - s) + (v[2] - v[1]) * s;
    ds.cross(&dt).norm()
}

/// Weights on the shape samples: value at a point = Σⱼ wⱼ · (shape sample j).
type Weights = [f64; NS];

/// Subdivisions per side of the grid where the representation error is measured.
const SUB: usize = 6;
/// Points of that grid (equal areas: a square grid on quads, the centroids of the
/// triangles of a regular subdivision on triangles).
const M: usize = SUB * SUB;

/// Fixed tables, one set for quads and one for triangles.
struct Tables {
    quad: ShapeTables,
    tri: ShapeTables,
}

struct ShapeTables {
    /// For each child (4), its shape samples from the parent's quadratic fit.
    push: [[Weights; NS]; 4],
    /// For each child, the mean of the parent's fit over the child minus its mean
    /// over the parent (the four shifts sum to zero: pushing conserves flux).
    shift: [Weights; 4],
    /// The vertices (up to 4) of the linear representation.
    vertex: [Weights; 4],
    /// At the error points: quadratic fit minus the mean (constant basis).
    err_constant: [Weights; M],
    /// At the error points: quadratic fit minus the shown linear representation.
    err_linear: [Weights; M],
}

/// Lagrange weights on the nodes {g0, ½, g2} at `x`.
fn lagrange3(x: f64) -> [f64; 3] {
    let gl = quadrature::gauss_legendre_01(3);
    let n = [gl[0].0, 0.5, gl[2].0];
    std::array::from_fn(|a| {
        let mut w = 1.0;
        for b in 0..3 {
            if b != a {
                w *= (x - n[b]) / (n[a] - n[b]);
            }
        }
        w
    })
}

/// Node indices (along s, along t) of the quad's shape samples.
const QUAD_NODES: [(usize, usize); NS] = [
    (0, 0),
    (2, 0),
    (2, 2),
    (0, 2),
    (1, 1),
    (1, 0),
    (2, 1),
    (1, 2),
    (0, 1),
];

/// Biquadratic interpolation of the nine quad samples at (s, t).
fn quad_fit(s: f64, t: f64) -> Weights {
    let (ls, lt) = (lagrange3(s), lagrange3(t));
    QUAD_NODES.map(|(a, b)| ls[a] * lt[b])
}

/// Bilinear Lagrange weights on the corner-sample grid {g0, g2}² at (s, t).
fn quad_bilinear(s: f64, t: f64) -> Weights {
    let gl = quadrature::gauss_legendre_01(3);
    let (g0, g2) = (gl[0].0, gl[2].0);
    let a = (s - g0) / (g2 - g0);
    let b = (t - g0) / (g2 - g0);
    let mut w = [0.0; NS];
    w[..4].copy_from_slice(&[(1.0 - a) * (1.0 - b), a * (1.0 - b), a * b, (1.0 - a) * b]);
    w
}

/// The quad's shown linear representation at (s, t): the vertex values (bilinear
/// through the corner samples) interpolated over the fan triangles (v0, v1, v2) and
/// (v0, v2, v3), as [`crate::radiosity::Patch::exitance_at`] and Gouraud shading do.
fn quad_shown(vertex: &[Weights; 4], s: f64, t: f64) -> Weights {
    let [v0, v1, v2, v3] = vertex;
    std::array::from_fn(|j| {
        if s >= t {
            v0[j] + (v1[j] - v0[j]) * s + (v2[j] - v1[j]) * t
        } else {
            v0[j] + (v2[j] - v3[j]) * s + (v3[j] - v0[j]) * t
        }
    })
}

/// Barycentrics of the triangle's shape samples.
fn tri_shape() -> [[f64; 3]; NS] {
    let (ta, tb) = (1.0 - 2.0 * RADON_A, 1.0 - 2.0 * RADON_B);
    let c = [1.0 / 3.0; 3];
    [
        [ta, RADON_A, RADON_A],
        [RADON_A, ta, RADON_A],
        [RADON_A, RADON_A, ta],
        c,
        c,
        [tb, RADON_B, RADON_B],
        [RADON_B, tb, RADON_B],
        [RADON_B, RADON_B, tb],
        c,
    ]
}

/// The distinct samples of a triangle (slots 3 and 8 repeat the centre at 4).
const TRI_DISTINCT: [usize; 7] = [0, 1, 2, 4, 5, 6, 7];

fn quadratic_terms(l: &[f64; 3]) -> [f64; 6] {
    let (x, y) = (l[1], l[2]);
    [1.0, x, y, x * x, x * y, y * y]
}

/// Least-squares quadratic through the seven triangle samples, as weights at `l`.
fn tri_fit(pinv: &nalgebra::SMatrix<f64, 6, 7>, l: &[f64; 3]) -> Weights {
    let phi = nalgebra::SVector::<f64, 6>::from(quadratic_terms(l));
    let w = pinv.transpose() * phi;
    let mut out = [0.0; NS];
    for (k, &slot) in TRI_DISTINCT.iter().enumerate() {
        out[slot] = w[k];
    }
    out
}

/// Affine weights on the three corner samples at barycentric `l`.
fn tri_linear(l: &[f64; 3]) -> Weights {
    let d = 1.0 - 3.0 * RADON_A;
    let mut w = [0.0; NS];
    for i in 0..3 {
        w[i] = (l[i] - RADON_A) / d;
    }
    w
}

fn sub(a: &Weights, b: &Weights) -> Weights {
    std::array::from_fn(|j| a[j] - b[j])
}

/// Shifts of the children's means from the pushed samples, with `w` the element's
/// own quadrature weight per shape sample (exact for the fit on quads and
/// triangles alike: both rules integrate quadratics exactly).
fn mean_shifts(push: &[[Weights; NS]; 4], w: &Weights) -> [Weights; 4] {
    let means: [Weights; 4] = std::array::from_fn(|c| {
        std::array::from_fn(|i| (0..NS).map(|j| w[j] * push[c][j][i]).sum::<f64>())
    });
    let all: Weights = std::array::from_fn(|i| means.iter().map(|m| m[i]).sum::<f64>() / 4.0);
    means.map(|m| sub(&m, &all))
}

impl ShapeTables {
    /// The tables from the push and vertex weights, the quadratic fit and the shown
    /// linear representation at the error points, and the element's quadrature
    /// weight per shape sample.
    fn assemble(
        push: [[Weights; NS]; 4],
        vertex: [Weights; 4],
        fit: &[Weights; M],
        shown: &[Weights; M],
        w: &Weights,
    ) -> Self {
        // constant basis: the fit against its mean over the error points
        let mean: Weights =
            std::array::from_fn(|j| fit.iter().map(|f| f[j]).sum::<f64>() / M as f64);
        Self {
            shift: mean_shifts(&push, w),
            push,
            vertex,
            err_constant: fit.map(|f| sub(&f, &mean)),
            err_linear: std::array::from_fn(|m| sub(&fit[m], &shown[m])),
        }
    }
}

fn quad_tables() -> ShapeTables {
    let gl = quadrature::gauss_legendre_01(3);
    let (g0, g2) = (gl[0].0, gl[2].0);
    let param = |n: usize| [g0, 0.5, g2][n];
    // child k of `quadrature::split4` is the parameter quarter at this offset
    let off = [(0.0, 0.0), (0.5, 0.0), (0.5, 0.5), (0.0, 0.5)];
    let push = std::array::from_fn(|c| {
        std::array::from_fn(|j| {
            let (a, b) = QUAD_NODES[j];
            quad_fit(off[c].0 + 0.5 * param(a), off[c].1 + 0.5 * param(b))
        })
    });
    let vertex = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)].map(|(s, t)| quad_bilinear(s, t));
    let h = 1.0 / SUB as f64;
    let pts: [(f64, f64); M] =
        std::array::from_fn(|m| (((m / SUB) as f64 + 0.5) * h, ((m % SUB) as f64 + 0.5) * h));
    let fit = pts.map(|(s, t)| quad_fit(s, t));
    let shown = pts.map(|(s, t)| quad_shown(&vertex, s, t));
    let w = QUAD_NODES.map(|(a, b)| gl[a].1 * gl[b].1);
    ShapeTables::assemble(push, vertex, &fit, &shown, &w)
}

fn tri_tables() -> ShapeTables {
    let shape = tri_shape();
    let design =
        nalgebra::SMatrix::<f64, 7, 6>::from_fn(|r, c| quadratic_terms(&shape[TRI_DISTINCT[r]])[c]);
    // the seven Radon points are unisolvent for quadratics: AᵀA is invertible
    let normal = design.transpose() * design;
    let pinv = normal
        .try_inverse()
        .map(|inv| inv * design.transpose())
        .unwrap_or_else(nalgebra::SMatrix::<f64, 6, 7>::zeros);
    let (v0, v1, v2) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
    let m01 = [0.5, 0.5, 0.0];
    let m12 = [0.0, 0.5, 0.5];
    let m20 = [0.5, 0.0, 0.5];
    // triangle children (`quadrature::split4` order): vertices in the parent's
    // barycentrics
    let kids = [
        [v0, m01, m20],
        [m01, v1, m12],
        [m20, m12, v2],
        [m01, m12, m20],
    ];
    let push = std::array::from_fn(|c| {
        std::array::from_fn(|j| {
            let mu = shape[j];
            let k = &kids[c];
            let l: [f64; 3] =
                std::array::from_fn(|i| mu[0] * k[0][i] + mu[1] * k[1][i] + mu[2] * k[2][i]);
            tri_fit(&pinv, &l)
        })
    });
    let vertex = [tri_linear(&v0), tri_linear(&v1), tri_linear(&v2), [0.0; NS]];
    // centroids of the SUB² triangles of a regular subdivision
    let n = SUB as f64;
    let mut pts = Vec::with_capacity(M);
    for i in 0..SUB {
        for j in 0..SUB - i {
            pts.push([(i as f64 + 1.0 / 3.0) / n, (j as f64 + 1.0 / 3.0) / n]);
            if i + j + 1 < SUB {
                pts.push([(i as f64 + 2.0 / 3.0) / n, (j as f64 + 2.0 / 3.0) / n]);
            }
        }
    }
    let bary = |m: usize| [1.0 - pts[m][0] - pts[m][1], pts[m][0], pts[m][1]];
    let fit: [Weights; M] = std::array::from_fn(|m| tri_fit(&pinv, &bary(m)));
    let shown: [Weights; M] = std::array::from_fn(|m| tri_linear(&bary(m)));
    let w = [
        RADON_WA,
        RADON_WA,
        RADON_WA,
        0.0,
        9.0 / 40.0,
        RADON_WB,
        RADON_WB,
        RADON_WB,
        0.0,
    ];
    ShapeTables::assemble(push, vertex, &fit, &shown, &w)
}

fn tables(corners: usize) -> &'static ShapeTables {
    static T: OnceLock<Tables> = OnceLock::new();
    let t = T.get_or_init(|| Tables {
        quad: quad_tables(),
        tri: tri_tables(),
    });
    if corners == 4 { &t.quad } else { &t.tri }
}

fn apply(w: &Weights, vals: &[[f64; 3]; NS]) -> [f64; 3] {
    let mut out = [0.0; 3];
    for (wj, v) in w.iter().zip(vals) {
        for c in 0..3 {
            out[c] += wj * v[c];
        }
    }
    out
}

/// The shape samples of child `child` (0..4, in `quadrature::split4` order) from the
/// parent's samples through their quadratic fit (`corners` = 4 for quads, 3 for
/// triangles).
pub(super) fn push_to_child(
    corners: usize,
    child: usize,
    parent: &[[f64; 3]; NS],
) -> [[f64; 3]; NS] {
    let w = &tables(corners).push[child];
    std::array::from_fn(|j| apply(&w[j], parent))
}

/// Estimated mean error of the linear representation: its deviation from the
/// quadratic fit, `q`, plus what the fit itself misses. The latter is taken as the
/// next term of the series: `q` times the ratio `q / c` of the quadratic part to the
/// variation `c` about the mean (at most `q`). Where the function is smooth at the
/// element's scale the ratio is small and the estimate is the quadratic one; where
/// it bends as much as it slopes (near a light, in a corner) it is doubled.
/// `c` is the constant estimate `shape_error(corners, vals, false)`, which every
/// caller has already computed.
pub(super) fn linear_error(corners: usize, vals: &[f64; NS], c: f64) -> f64 {
    let q = shape_error(corners, vals, true);
    if q <= 0.0 || c <= 0.0 {
        return q;
    }
    q * (1.0 + (q / c).min(1.0))
}

/// How much child `child`'s mean differs from the parent's, by the parent's
/// quadratic fit (zero on average over the four children).
pub(super) fn mean_shift(corners: usize, child: usize, parent: &[[f64; 3]; NS]) -> [f64; 3] {
    apply(&tables(corners).shift[child], parent)
}

/// The linear representation at the element's vertices.
pub(super) fn at_vertices(corners: usize, vals: &[[f64; 3]; NS]) -> Vec<[f64; 3]> {
    tables(corners).vertex[..corners]
        .iter()
        .map(|w| apply(w, vals))
        .collect()
}

/// Mean absolute difference over the element between the quadratic fit of the
/// samples and their representation: the mean for a constant element, the shown
/// vertex interpolation for a linear one. Exact for quadratic functions.
pub(super) fn shape_error(corners: usize, vals: &[f64; NS], linear: bool) -> f64 {
    let t = tables(corners);
    let rows = if linear {
        &t.err_linear
    } else {
        &t.err_constant
    };
    rows.iter()
        .map(|w| w.iter().zip(vals).map(|(a, b)| a * b).sum::<f64>().abs())
        .sum::<f64>()
        / M as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A quadratic in space, one per channel (the third is affine).
    fn quadratic(x: &V3) -> [f64; 3] {
        [
            1.0 + 2.0 * x.x - 0.5 * x.y + 0.7 * x.x * x.x - 1.3 * x.y * x.y,
            3.0 * x.z + x.x * x.y,
            -x.x + x.y + x.z,
        ]
    }

    fn samples(s: &Samples) -> [[f64; 3]; NS] {
        std::array::from_fn(|j| quadratic(&s.shape_point(j)))
    }

    /// Dense reference of the mean |f − representation| for channel `c`.
    fn dense_error(verts: &[V3], c: usize, rep: impl Fn(&V3) -> f64) -> f64 {
        let n = 300;
        let h = 1e-6;
        let (mut num, mut den) = (0.0, 0.0);
        for i in 0..n {
            for j in 0..n {
                let (s, t) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                let x = quadrature::map_unit_square(verts, s, t);
                let ds = quadrature::map_unit_square(verts, s + h, t) - x;
                let dt = quadrature::map_unit_square(verts, s, t + h) - x;
                let w = ds.cross(&dt).norm();
                num += w * (quadratic(&x)[c] - rep(&x)).abs();
                den += w;
            }
        }
        num / den
    }

    /// Relative tolerance of the constant basis's sampled error measure against a
    /// dense integration (it estimates a mean absolute deviation from nine samples;
    /// measured at most 2.8 % on the three shapes below).
    const CONSTANT_ERROR_TOLERANCE: f64 = 0.05;
    /// The same for the linear basis (measured at most 5.6 %).
    const LINEAR_ERROR_TOLERANCE: f64 = 0.08;

    fn check(verts: &[V3]) {
        check_affine_at_vertices(verts);
        check_push_to_children(verts);
        check_error_measures(verts);
        check_weights_and_shape_samples(verts);
    }

    /// The affine channel is reproduced at the vertices.
    fn check_affine_at_vertices(verts: &[V3]) {
        let vals = samples(&Samples::of(verts));
        for (v, got) in verts.iter().zip(at_vertices(verts.len(), &vals)) {
            assert!((got[2] - quadratic(v)[2]).abs() < 1e-12, "{got:?}");
        }
    }

    /// The quadratic fit is exact: pushed samples equal the function's own, and the
    /// child's mean follows from the parent's mean and the shift.
    fn check_push_to_children(verts: &[V3]) {
        let s = Samples::of(verts);
        let corners = verts.len();
        let vals = samples(&s);
        let kids = quadrature::split4(verts);
        for (k, kv) in kids.iter().enumerate() {
            let want = samples(&Samples::of(kv));
            let pushed = push_to_child(corners, k, &vals);
            let ks = Samples::of(kv);
            let shift = mean_shift(corners, k, &vals);
            for c in 0..3 {
                let mean = |s: &Samples| {
                    (0..s.n)
                        .map(|i| s.w[i] * quadratic(&s.pts[i])[c])
                        .sum::<f64>()
                };
                let got = mean(&s) + shift[c];
                assert!(
                    (got - mean(&ks)).abs() < 1e-12,
                    "child {k} mean: {got} vs {}",
                    mean(&ks)
                );
            }
            for j in 0..NS {
                for c in 0..3 {
                    assert!(
                        (pushed[j][c] - want[j][c]).abs() < 1e-12,
                        "child {k} sample {j}: {:?} vs {:?}",
                        pushed[j],
                        want[j]
                    );
                }
            }
        }
    }

    /// The error measures match a dense integration of the represented functions
    /// within [`CONSTANT_ERROR_TOLERANCE`] and [`LINEAR_ERROR_TOLERANCE`].
    fn check_error_measures(verts: &[V3]) {
        let s = Samples::of(verts);
        let corners = verts.len();
        let vals = samples(&s);
        let vertex = at_vertices(corners, &vals);
        for c in 0..3 {
            let ys: [f64; NS] = std::array::from_fn(|j| vals[j][c]);
            let mean = s.w[..s.n]
                .iter()
                .zip(&s.pts)
                .map(|(w, x)| w * quadratic(x)[c])
                .sum::<f64>();
            let want_const = dense_error(verts, c, |_| mean);
            let got_const = shape_error(corners, &ys, false);
            assert!(
                (got_const - want_const).abs() <= CONSTANT_ERROR_TOLERANCE * want_const + 1e-12,
                "constant, channel {c}: {got_const} vs {want_const}"
            );
            let patch = crate::radiosity::Patch {
                polygon: 0,
                vertices: verts.to_vec(),
                normal: (verts[1] - verts[0])
                    .cross(&(verts[2] - verts[0]))
                    .normalize(),
                area_m2: 1.0,
                exitance_xyz: [0.0; 3],
                irradiance_xyz: [0.0; 3],
                vertex_exitance_xyz: vertex.clone(),
            };
            let want_lin = dense_error(verts, c, |x| patch.exitance_at(x)[c]);
            let got_lin = shape_error(corners, &ys, true);
            assert!(
                (got_lin - want_lin).abs() <= LINEAR_ERROR_TOLERANCE * want_lin + 1e-9,
                "linear, channel {c}: {got_lin} vs {want_lin}"
            );
        }
    }

    /// The weights average, and every quadrature point is a shape sample
    /// (visibility relies on it).
    fn check_weights_and_shape_samples(verts: &[V3]) {
        let s = Samples::of(verts);
        assert!((s.w[..s.n].iter().sum::<f64>() - 1.0).abs() < 1e-12);
        let mut seen = [false; 9];
        for &i in &s.shape {
            seen[i] = true;
        }
        assert!(seen[..s.n].iter().all(|&b| b));
    }

    #[test]
    fn representations_are_exact_for_quadratics_and_error_measures_match_dense_integration() {
        // a square, a parallelogram (bilinear map affine) and a triangle
        check(&[
            V3::new(0.0, 0.0, 0.0),
            V3::new(1.0, 0.0, 0.0),
            V3::new(1.0, 1.0, 0.0),
            V3::new(0.0, 1.0, 0.0),
        ]);
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
}
