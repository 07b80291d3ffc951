//! Haines–Wallace shafts (Kresse 2.7.2, Haines & Wallace 1991): the convex region spanned by two
//! axis-aligned boxes, represented as their union box cut by the planes through
//! corresponding edges of the two boxes. Whatever lies entirely outside one of the
//! faces or planes cannot meet any segment between the two boxes.

use crate::scene::V3;

/// A shaft between two boxes.
#[derive(Debug, Clone)]
pub struct Shaft {
    lo: V3,
    hi: V3,
    /// Planes `n·x ≤ d` bounding the shaft besides the union box (at most 12).
    planes: Vec<(V3, f64)>,
}

/// Bounding box of a point set.
pub fn bounds(points: &[V3]) -> (V3, V3) {
    let mut lo = V3::repeat(f64::INFINITY);
    let mut hi = V3::repeat(f64::NEG_INFINITY);
    for p in points {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    (lo, hi)
}

impl Shaft {
    /// The shaft between the boxes `a` and `b` (min, max corners), grown by `eps`.
    pub fn new(a: (V3, V3), b: (V3, V3), eps: f64) -> Self {
        let lo = a.0.inf(&b.0) - V3::repeat(eps);
        let hi = a.1.sup(&b.1) + V3::repeat(eps);
        let side = |bx: &(V3, V3), axis: usize, up: bool| if up { bx.1[axis] } else { bx.0[axis] };
        // which box is strictly extreme on (axis, side): Some(true) for a
        let extreme = |axis: usize, up: bool| {
            let (va, vb) = (side(&a, axis, up), side(&b, axis, up));
            if va == vb {
                None
            } else {
                Some((va > vb) == up)
            }
        };
        let mut planes = Vec::new();
        for (i, j) in [(0usize, 1usize), (0, 2), (1, 2)] {
            for ui in [false, true] {
                for uj in [false, true] {
                    let (Some(ei), Some(ej)) = (extreme(i, ui), extreme(j, uj)) else {
                        continue;
                    };
                    if ei == ej {
                        continue;
                    }
                    // the hull edge from a's corner to b's corner in the (i, j) plane
                    let p = [side(&a, i, ui), side(&a, j, uj)];
                    let q = [side(&b, i, ui), side(&b, j, uj)];
                    let corner = [if ei { p[0] } else { q[0] }, if ej { p[1] } else { q[1] }];
                    let d = [q[0] - p[0], q[1] - p[1]];
                    let mut n2 = [d[1], -d[0]];
                    if n2[0] * (corner[0] - p[0]) + n2[1] * (corner[1] - p[1]) < 0.0 {
                        n2 = [-n2[0], -n2[1]];
                    }
                    let len = (n2[0] * n2[0] + n2[1] * n2[1]).sqrt();
                    if len <= 0.0 || !len.is_finite() {
                        continue;
                    }
                    let mut n = V3::zeros();
                    n[i] = n2[0] / len;
                    n[j] = n2[1] / len;
                    let offset = n[i] * p[0] + n[j] * p[1] + eps;
                    planes.push((n, offset));
                }
            }
        }
        Self { lo, hi, planes }
    }

    /// True when the box (min, max) lies entirely outside the shaft.
    pub fn box_outside(&self, lo: &[f64; 3], hi: &[f64; 3]) -> bool {
        for k in 0..3 {
            if hi[k] < self.lo[k] || lo[k] > self.hi[k] {
                return true;
            }
        }
        self.planes.iter().any(|(n, d)| {
            let mut m = 0.0;
            for k in 0..3 {
                m += if n[k] > 0.0 {
                    n[k] * lo[k]
                } else {
                    n[k] * hi[k]
                };
            }
            m > *d
        })
    }

    /// True when every point lies outside one and the same face or plane.
    pub fn points_outside(&self, pts: &[[f64; 3]]) -> bool {
        for k in 0..3 {
            if pts.iter().all(|p| p[k] < self.lo[k]) || pts.iter().all(|p| p[k] > self.hi[k]) {
                return true;
            }
        }
        self.planes.iter().any(|(n, d)| {
            pts.iter()
                .all(|p| n[0] * p[0] + n[1] * p[1] + n[2] * p[2] > *d)
        })
    }

    /// Number of extra planes (for tests).
    pub fn plane_count(&self) -> usize {
        self.planes.len()
    }
}
