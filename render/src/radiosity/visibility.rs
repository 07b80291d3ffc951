//! Visibility between elements: a conservative classification (can anything block the
//! segments between two patches at all?) that lets fully visible pairs skip all ray
//! work, and shadow rays for the rest. [`Visibility`] is the seam where a BVH plugs in;
//! [`SceneOccluders`] is the built-in brute-force implementation (bounding-box and
//! separating-plane culling, then ray–polygon tests).

use crate::scene::{Scene, V3};

/// Visibility queries used by the solvers. Polygon indices refer to the scene.
pub trait Visibility: Sync {
    /// Conservative: `false` guarantees that nothing blocks any segment between the
    /// convex patches `a` (on polygon `a_poly`) and `b` (on polygon `b_poly`). A patch
    /// may be a single point (a point light; pass `usize::MAX` as its polygon).
    fn may_occlude(&self, a: &[V3], a_poly: usize, b: &[V3], b_poly: usize) -> bool;
    /// Whether the open segment from `a` to `b` is blocked by any polygon other than
    /// those listed in `skip`.
    fn occluded(&self, a: &V3, b: &V3, skip: [usize; 2]) -> bool;
}

/// No occluders at all (the caller asserts it): every pair is fully visible.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoOccluders;

impl Visibility for NoOccluders {
    fn may_occlude(&self, _: &[V3], _: usize, _: &[V3], _: usize) -> bool {
        false
    }
    fn occluded(&self, _: &V3, _: &V3, _: [usize; 2]) -> bool {
        false
    }
}

#[derive(Debug, Clone)]
struct Occluder {
    verts: Vec<V3>,
    normal: V3,
    lo: V3,
    hi: V3,
}

/// Brute-force occluder set built from a scene's polygons.
#[derive(Debug, Clone)]
pub struct SceneOccluders {
    polys: Vec<Occluder>,
    eps: f64,
}

fn bbox(points: &[V3]) -> (V3, V3) {
    let mut lo = V3::repeat(f64::INFINITY);
    let mut hi = V3::repeat(f64::NEG_INFINITY);
    for p in points {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    (lo, hi)
}

impl SceneOccluders {
    /// Builds the occluder set from every polygon of the scene.
    pub fn new(scene: &Scene) -> Self {
        let mut scale: f64 = 0.0;
        let polys = scene
            .polygons
            .iter()
            .map(|p| {
                let (lo, hi) = bbox(&p.vertices);
                scale = scale.max((hi - lo).norm());
                Occluder {
                    verts: p.vertices.clone(),
                    normal: crate::scene::polygon_normal(&p.vertices).unwrap_or_else(V3::z),
                    lo,
                    hi,
                }
            })
            .collect();
        Self {
            polys,
            eps: 1e-9 * scale.max(1e-3),
        }
    }

    fn side(points: &[V3], origin: &V3, n: &V3, eps: f64) -> (bool, bool) {
        let mut front = false;
        let mut back = false;
        for p in points {
            let d = n.dot(&(p - origin));
            front |= d > eps;
            back |= d < -eps;
        }
        (front, back)
    }
}

impl Visibility for SceneOccluders {
    fn may_occlude(&self, a: &[V3], a_poly: usize, b: &[V3], b_poly: usize) -> bool {
        let (alo, ahi) = bbox(a);
        let (blo, bhi) = bbox(b);
        let lo = alo.inf(&blo) - V3::repeat(self.eps);
        let hi = ahi.sup(&bhi) + V3::repeat(self.eps);
        let na = crate::scene::polygon_normal(a);
        let nb = crate::scene::polygon_normal(b);
        for (i, o) in self.polys.iter().enumerate() {
            if i == a_poly || i == b_poly {
                continue;
            }
            if o.hi.x < lo.x
                || o.lo.x > hi.x
                || o.hi.y < lo.y
                || o.lo.y > hi.y
                || o.hi.z < lo.z
                || o.lo.z > hi.z
            {
                continue;
            }
            // occluder entirely behind (or on) the plane of a or of b
            if na.is_some_and(|na| !Self::side(&o.verts, &a[0], &na, self.eps).0) {
                continue;
            }
            if nb.is_some_and(|nb| !Self::side(&o.verts, &b[0], &nb, self.eps).0) {
                continue;
            }
            // a and b on the same side of the occluder's plane
            let (fa, ba) = Self::side(a, &o.verts[0], &o.normal, self.eps);
            let (fb, bb) = Self::side(b, &o.verts[0], &o.normal, self.eps);
            if !(ba || bb) || !(fa || fb) {
                continue;
            }
            return true;
        }
        false
    }

    fn occluded(&self, a: &V3, b: &V3, skip: [usize; 2]) -> bool {
        let d = b - a;
        let (lo, hi) = (a.inf(b), a.sup(b));
        for (i, o) in self.polys.iter().enumerate() {
            if i == skip[0] || i == skip[1] {
                continue;
            }
            if o.hi.x < lo.x
                || o.lo.x > hi.x
                || o.hi.y < lo.y
                || o.lo.y > hi.y
                || o.hi.z < lo.z
                || o.lo.z > hi.z
            {
                continue;
            }
            let denom = o.normal.dot(&d);
            if denom.abs() < 1e-300 {
                continue;
            }
            let t = o.normal.dot(&(o.verts[0] - a)) / denom;
            if t <= 1e-9 || t >= 1.0 - 1e-9 {
                continue;
            }
            let p = a + d * t;
            if point_in_convex(&o.verts, &o.normal, &p) {
                return true;
            }
        }
        false
    }
}

/// Whether `p` (in the polygon's plane) lies inside the convex polygon.
pub fn point_in_convex(verts: &[V3], normal: &V3, p: &V3) -> bool {
    let m = verts.len();
    (0..m).all(|i| {
        let e = verts[(i + 1) % m] - verts[i];
        e.cross(&(p - verts[i])).dot(normal) >= 0.0
    })
}

/// Shadow rays through the `mesh::Bvh` of the scene's triangles (quads split), with the
/// same conservative classification as [`SceneOccluders`] (which is linear in the
/// number of polygons per query; a BVH shaft query would remove that).
#[derive(Debug)]
pub struct BvhOccluders {
    bvh: crate::mesh::Bvh,
    cull: SceneOccluders,
}

impl BvhOccluders {
    /// Builds the BVH over every polygon of the scene.
    pub fn new(scene: &Scene) -> Self {
        let mut tris = Vec::new();
        for p in &scene.polygons {
            for k in 1..p.vertices.len().saturating_sub(1) {
                let t = [p.vertices[0], p.vertices[k], p.vertices[k + 1]];
                tris.push(t.map(|v| [v.x, v.y, v.z]));
            }
        }
        Self {
            bvh: crate::mesh::Bvh::build(&tris),
            cull: SceneOccluders::new(scene),
        }
    }
}

impl Visibility for BvhOccluders {
    fn may_occlude(&self, a: &[V3], a_poly: usize, b: &[V3], b_poly: usize) -> bool {
        self.cull.may_occlude(a, a_poly, b, b_poly)
    }

    /// The end polygons are excluded by the BVH's relative end margin (1e-6 of the
    /// segment), not by index.
    fn occluded(&self, a: &V3, b: &V3, _skip: [usize; 2]) -> bool {
        self.bvh.occluded([a.x, a.y, a.z], [b.x, b.y, b.z])
    }
}
