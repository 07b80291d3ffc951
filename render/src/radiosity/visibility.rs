//! Visibility between elements: a conservative classification (can anything block the
//! segments between two patches at all?) that lets fully visible pairs skip all ray
//! work, and shadow rays for the rest. [`Visibility`] is the seam where a BVH plugs in;
//! [`SceneOccluders`] is the built-in brute-force implementation (bounding-box and
//! separating-plane culling, then ray–polygon tests).

use crate::scene::{Scene, V3};

/// Visibility queries used by the solvers. Polygon indices refer to the scene.
pub trait Visibility: Sync {
    /// Conservative: `false` guarantees that nothing blocks any segment between the
    /// convex patches `a` (on polygon `a_poly`) and `b` (on polygon `b_poly`). With
    /// `usize::MAX` as its polygon an end is a point set whose convex hull is meant (a
    /// point light, a cluster's bounding-box corners): no plane tests for that end.
    fn may_occlude(&self, a: &[V3], a_poly: usize, b: &[V3], b_poly: usize) -> bool;
    /// Whether the open segment from `a` to `b` is blocked by any polygon other than
    /// those listed in `skip`.
    fn occluded(&self, a: &V3, b: &V3, skip: [usize; 2]) -> bool;
    /// Whether the surface point `x` (front normal `n`) lies inside a closed solid:
    /// every probe ray leaving its front meets the back of a polygon first (see
    /// [`probe_directions`]). The floor under a block resting on it is such a point:
    /// it neither receives nor sends light. `false` unless the implementation looks.
    fn enclosed(&self, x: &V3, n: &V3) -> bool {
        let _ = (x, n);
        false
    }
}

/// Angle of the tilted probe rays of [`Visibility::enclosed`] from the normal: low
/// enough (20° above the surface) that a point under a one-sided table top sees
/// past its edge.
const PROBE_TILT_DEG: f64 = 70.0;

/// The probe directions of [`Visibility::enclosed`] at a point with unit normal `n`:
/// the normal and six around it at 70° from it (20° above the surface).
pub fn probe_directions(n: &V3) -> [V3; 7] {
    let helper = if n.x.abs() < 0.9 { V3::x() } else { V3::y() };
    let t = n.cross(&helper).normalize();
    let b = n.cross(&t);
    let (sin_tilt, cos_tilt) = PROBE_TILT_DEG.to_radians().sin_cos();
    let mut dirs = [*n; 7];
    for (k, d) in dirs.iter_mut().skip(1).enumerate() {
        let (s, c) = (k as f64 * std::f64::consts::TAU / 6.0).sin_cos();
        *d = n * cos_tilt + (t * c + b * s) * sin_tilt;
    }
    dirs
}

/// [`Visibility::enclosed`] from a first-hit query: `hits_back(origin, dir)` says
/// whether the nearest polygon along the ray shows it its back. The probes start
/// `offset` in front of `x` so that its own polygon is not met.
fn enclosed_by(x: &V3, n: &V3, offset: f64, mut hits_back: impl FnMut(&V3, &V3) -> bool) -> bool {
    let origin = x + n * offset;
    probe_directions(n).iter().all(|d| hits_back(&origin, d))
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
    /// Index of the polygon in the scene.
    polygon: usize,
    verts: Vec<V3>,
    normal: V3,
    lo: V3,
    hi: V3,
}

/// Shadow rays test every polygon up to this many: a loop over a few polygons beats
/// the BVH's traversal (the Cornell box, 20 polygons, at 1 %: 1.1 s against 1.45 s),
/// and a scene of thousands needs the BVH (the brute force costs n per ray).
pub const BRUTE_FORCE_MAX_POLYGONS: usize = 64;

/// The visibility queries of the polygons of `scene` that `keep` selects: brute
/// force for up to [`BRUTE_FORCE_MAX_POLYGONS`], else a BVH.
pub fn occluders_of(scene: &Scene, keep: &dyn Fn(usize) -> bool) -> Box<dyn Visibility + Send> {
    let count = (0..scene.polygons.len()).filter(|&i| keep(i)).count();
    if count <= BRUTE_FORCE_MAX_POLYGONS {
        Box::new(SceneOccluders::of_polygons(scene, keep))
    } else {
        Box::new(BvhOccluders::of_polygons(scene, keep))
    }
}

/// Two occluder sets together (e.g. a scene's static polygons and one frame's moving
/// ones): a segment is blocked when either blocks it. [`Visibility::enclosed`] is not
/// passed on (a probe's nearest hit needs both sets at once): the progressive solvers
/// do not ask for it.
pub struct Both<'a>(pub &'a dyn Visibility, pub &'a dyn Visibility);

impl Visibility for Both<'_> {
    fn may_occlude(&self, a: &[V3], a_poly: usize, b: &[V3], b_poly: usize) -> bool {
        self.0.may_occlude(a, a_poly, b, b_poly) || self.1.may_occlude(a, a_poly, b, b_poly)
    }
    fn occluded(&self, a: &V3, b: &V3, skip: [usize; 2]) -> bool {
        self.0.occluded(a, b, skip) || self.1.occluded(a, b, skip)
    }
}

/// Brute-force occluder set built from a scene's polygons.
#[derive(Debug, Clone)]
pub struct SceneOccluders {
    polys: Vec<Occluder>,
    eps: f64,
}

use super::shaft::bounds as bbox;

impl SceneOccluders {
    /// Builds the occluder set from every polygon of the scene.
    pub fn new(scene: &Scene) -> Self {
        Self::of_polygons(scene, &|_| true)
    }

    /// Builds the occluder set from the polygons `keep` selects (by scene index).
    pub fn of_polygons(scene: &Scene, keep: &dyn Fn(usize) -> bool) -> Self {
        let mut scale: f64 = 0.0;
        let polys = scene
            .polygons
            .iter()
            .enumerate()
            .filter(|(i, _)| keep(*i))
            .map(|(i, p)| {
                let (lo, hi) = bbox(&p.vertices);
                scale = scale.max((hi - lo).norm());
                Occluder {
                    polygon: i,
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

/// Whether two axis-aligned boxes (lo, hi) overlap (touching counts).
fn boxes_overlap(a: (&V3, &V3), b: (&V3, &V3)) -> bool {
    !(a.1.x < b.0.x
        || a.0.x > b.1.x
        || a.1.y < b.0.y
        || a.0.y > b.1.y
        || a.1.z < b.0.z
        || a.0.z > b.1.z)
}

impl Visibility for SceneOccluders {
    fn may_occlude(&self, a: &[V3], a_poly: usize, b: &[V3], b_poly: usize) -> bool {
        let (alo, ahi) = bbox(a);
        let (blo, bhi) = bbox(b);
        let lo = alo.inf(&blo) - V3::repeat(self.eps);
        let hi = ahi.sup(&bhi) + V3::repeat(self.eps);
        let na = plane_of(a, a_poly);
        let nb = plane_of(b, b_poly);
        for o in &self.polys {
            if o.polygon == a_poly || o.polygon == b_poly {
                continue;
            }
            if !boxes_overlap((&o.lo, &o.hi), (&lo, &hi)) {
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
        for o in &self.polys {
            if o.polygon == skip[0] || o.polygon == skip[1] {
                continue;
            }
            if !boxes_overlap((&o.lo, &o.hi), (&lo, &hi)) {
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

    fn enclosed(&self, x: &V3, n: &V3) -> bool {
        enclosed_by(x, n, ENCLOSED_OFFSET * self.eps, |o, d| {
            self.nearest(o, d).is_some_and(|(_, back)| back)
        })
    }
}

/// Start of an enclosure probe in front of its point, in units of the occluders'
/// epsilon (1e-9 of the scene size): 1e-6 of the scene size.
const ENCLOSED_OFFSET: f64 = 1e3;

impl SceneOccluders {
    /// Nearest polygon along the ray `o + t·d` (t > 0): its distance parameter and
    /// whether the ray meets its back.
    fn nearest(&self, o: &V3, d: &V3) -> Option<(f64, bool)> {
        let mut best: Option<(f64, bool)> = None;
        for p in &self.polys {
            let denom = p.normal.dot(d);
            if denom.abs() < 1e-300 {
                continue;
            }
            let t = p.normal.dot(&(p.verts[0] - o)) / denom;
            if t <= 0.0 || best.is_some_and(|(tb, _)| t >= tb) {
                continue;
            }
            if point_in_convex(&p.verts, &p.normal, &(o + d * t)) {
                best = Some((t, denom > 0.0));
            }
        }
        best
    }
}

/// Unit normal of an end that is a patch (not a point set, see [`Visibility`]).
fn plane_of(points: &[V3], polygon: usize) -> Option<V3> {
    if polygon == usize::MAX || points.len() < 3 {
        None
    } else {
        crate::scene::polygon_normal(points)
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

/// Shadow rays and shaft culling through the `mesh::Bvh` of the scene's triangles
/// (quads split): the classification traverses only the BVH nodes that meet the
/// Haines–Wallace shaft between the two ends, so it costs about log n per query
/// instead of the brute force's n.
#[derive(Debug)]
pub struct BvhOccluders {
    bvh: crate::mesh::Bvh,
    /// Input polygon of each BVH triangle.
    tri_polygon: Vec<u32>,
    /// Unit normal of each BVH triangle.
    tri_normal: Vec<V3>,
    eps: f64,
}

impl BvhOccluders {
    /// Builds the BVH over every polygon of the scene.
    pub fn new(scene: &Scene) -> Self {
        Self::of_polygons(scene, &|_| true)
    }

    /// Builds the BVH over the polygons `keep` selects (by scene index).
    pub fn of_polygons(scene: &Scene, keep: &dyn Fn(usize) -> bool) -> Self {
        let mut tris = Vec::new();
        let mut tri_polygon = Vec::new();
        let mut tri_normal = Vec::new();
        let mut scale: f64 = 0.0;
        for (pi, p) in scene.polygons.iter().enumerate().filter(|(i, _)| keep(*i)) {
            let n = crate::scene::polygon_normal(&p.vertices).unwrap_or_else(V3::z);
            let (lo, hi) = bbox(&p.vertices);
            scale = scale.max((hi - lo).norm());
            for k in 1..p.vertices.len().saturating_sub(1) {
                let t = [p.vertices[0], p.vertices[k], p.vertices[k + 1]];
                tris.push(t.map(|v| [v.x, v.y, v.z]));
                tri_polygon.push(pi as u32);
                tri_normal.push(n);
            }
        }
        Self {
            bvh: crate::mesh::Bvh::build(&tris),
            tri_polygon,
            tri_normal,
            eps: 1e-9 * scale.max(1e-3),
        }
    }
}

impl Visibility for BvhOccluders {
    fn may_occlude(&self, a: &[V3], a_poly: usize, b: &[V3], b_poly: usize) -> bool {
        let eps = self.eps;
        let shaft = super::shaft::Shaft::new(bbox(a), bbox(b), eps);
        let pa = plane_of(a, a_poly).map(|n| (n, n.dot(&a[0])));
        let pb = plane_of(b, b_poly).map(|n| (n, n.dot(&b[0])));
        // largest n·x over a box
        let box_max = |n: &V3, lo: &[f64; 3], hi: &[f64; 3]| -> f64 {
            (0..3)
                .map(|k| {
                    if n[k] > 0.0 {
                        n[k] * hi[k]
                    } else {
                        n[k] * lo[k]
                    }
                })
                .sum()
        };
        let in_front = |plane: &Option<(V3, f64)>, t: &[[f64; 3]; 3]| {
            plane.is_none_or(|(n, d)| {
                t.iter()
                    .any(|v| n.x * v[0] + n.y * v[1] + n.z * v[2] > d + eps)
            })
        };
        self.bvh.any_triangle(
            |lo, hi| {
                !shaft.box_outside(lo, hi)
                    && pa.is_none_or(|(n, d)| box_max(&n, lo, hi) > d + eps)
                    && pb.is_none_or(|(n, d)| box_max(&n, lo, hi) > d + eps)
            },
            |ti, t| {
                let poly = self.tri_polygon[ti as usize] as usize;
                if poly == a_poly || poly == b_poly {
                    return false;
                }
                if shaft.points_outside(t) || !in_front(&pa, t) || !in_front(&pb, t) {
                    return false;
                }
                // a and b on the same side of the occluder's plane
                let n = self.tri_normal[ti as usize];
                let o = V3::new(t[0][0], t[0][1], t[0][2]);
                let (fa, ba) = SceneOccluders::side(a, &o, &n, eps);
                let (fb, bb) = SceneOccluders::side(b, &o, &n, eps);
                (ba || bb) && (fa || fb)
            },
        )
    }

    /// The end polygons are excluded by the BVH's relative end margin (1e-6 of the
    /// segment), not by index.
    fn occluded(&self, a: &V3, b: &V3, _skip: [usize; 2]) -> bool {
        self.bvh.occluded([a.x, a.y, a.z], [b.x, b.y, b.z])
    }

    fn enclosed(&self, x: &V3, n: &V3) -> bool {
        enclosed_by(x, n, ENCLOSED_OFFSET * self.eps, |o, d| {
            self.bvh
                .intersect([o.x, o.y, o.z], [d.x, d.y, d.z], f64::INFINITY)
                .is_some_and(|hit| !hit.front_face)
        })
    }
}
