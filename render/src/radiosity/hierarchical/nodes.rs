//! The element hierarchy: a binary cluster tree over the input polygons (binned SAH on
//! their bounding boxes, so clusters are compact) above one quadtree of patch elements
//! per polygon (Kresse 2.5.3: clusters carry energy, patches carry the radiosity
//! function).

use crate::scene::{Scene, V3, polygon_area_m2, polygon_normal};

use rayon::prelude::*;

use super::super::quadrature;
use super::super::visibility::Visibility;
use super::sampling::Samples;

/// Luminous reflectance below which a receiver's error is measured as illuminance
/// (lux) rather than radiosity: black measuring planes must still be resolved.
pub(super) const DARK: f64 = 0.05;

/// Weight of a receiver's irradiance error in its exitance error: ρ for visible
/// surfaces, 1 (illuminance) for dark ones.
pub(super) fn error_weight(rho_y: f64) -> f64 {
    if rho_y > DARK { rho_y } else { 1.0 }
}

/// "No node".
pub(super) const NONE: u32 = u32::MAX;

/// A node of the hierarchy, packed into a `u32` (two tag bits) so links stay small.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash)]
pub(super) struct Node(u32);

const TAG_SHIFT: u32 = 30;
const INDEX_MASK: u32 = (1 << TAG_SHIFT) - 1;

/// What a [`Node`] refers to.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Kind {
    /// A patch element (index into [`Hierarchy::patches`]).
    Patch(usize),
    /// A cluster (index into [`Hierarchy::clusters`]).
    Cluster(usize),
    /// A point-like or directional emitter (index into the emitter list).
    Emitter(usize),
}

impl Node {
    pub(crate) fn patch(i: usize) -> Self {
        Self(i as u32)
    }
    pub(crate) fn cluster(i: usize) -> Self {
        Self((1 << TAG_SHIFT) | i as u32)
    }
    pub(crate) fn emitter(i: usize) -> Self {
        Self((2 << TAG_SHIFT) | i as u32)
    }
    pub(crate) fn kind(self) -> Kind {
        let i = (self.0 & INDEX_MASK) as usize;
        match self.0 >> TAG_SHIFT {
            0 => Kind::Patch(i),
            1 => Kind::Cluster(i),
            _ => Kind::Emitter(i),
        }
    }
}

/// A cluster of input polygons.
#[derive(Debug, Clone)]
pub(super) struct Cluster {
    pub lo: V3,
    pub hi: V3,
    /// Area-weighted centroid of the contents.
    pub centre: V3,
    /// Radius of the bounding sphere about `centre`.
    pub radius: f64,
    /// Total surface area of the contents in m².
    pub area: f64,
    /// Up to two children (clusters or root patches); `n_children` are valid.
    pub children: [Node; 2],
    pub n_children: usize,
    /// Area share of the first child (for area-weighted sampling).
    pub first_share: f64,
    pub parent: u32,
    /// Normal cone of the contents: axis and cosine/sine of the half angle (cos = −1
    /// for normals in every direction).
    pub cone_axis: V3,
    pub cone_cos: f64,
    pub cone_sin: f64,
    /// Largest luminous (Y) reflectance of the contents.
    pub rho_max: f64,
    /// Largest error weight of the contents (see [`error_weight`]).
    pub w_max: f64,
    /// Largest bounding radius of a polygon inside.
    pub poly_radius_max: f64,
    /// Points on the contents, with their surface normals, for visibility rays
    /// (centroids of the largest polygons of up to four sub-trees).
    pub samples: [(V3, V3); 4],
    pub n_samples: usize,
}

/// A patch element: an input polygon (root) or a quadtree child of one.
#[derive(Debug, Clone)]
pub(super) struct Patch {
    pub verts: [V3; 4],
    pub nv: usize,
    pub normal: V3,
    pub area: f64,
    pub centre: V3,
    pub radius: f64,
    pub polygon: u32,
    /// Parent patch, or `NONE` for a root patch (whose parent is `cluster`).
    pub parent: u32,
    /// The cluster holding a root patch (`NONE` below the root).
    pub cluster: u32,
    /// First of four children, or `NONE` for a leaf.
    pub first_child: u32,
    pub level: u8,
    /// Bit i: quadrature point i of the element's [`Samples`] lies inside a closed
    /// solid (see [`Hierarchy::mark_enclosed`]).
    pub enclosed: u16,
}

impl Patch {
    fn new(verts: &[V3], polygon: u32, parent: u32, cluster: u32, level: u8) -> Self {
        let nv = verts.len().min(4);
        let mut v = [V3::zeros(); 4];
        v[..nv].copy_from_slice(&verts[..nv]);
        let centre = verts.iter().sum::<V3>() / verts.len() as f64;
        let radius = verts
            .iter()
            .map(|p| (p - centre).norm())
            .fold(0.0, f64::max);
        Self {
            verts: v,
            nv,
            normal: polygon_normal(verts).unwrap_or_else(V3::z),
            area: polygon_area_m2(verts),
            centre,
            radius,
            polygon,
            parent,
            cluster,
            first_child: NONE,
            level,
            enclosed: 0,
        }
    }

    /// The corner vertices.
    pub(crate) fn verts(&self) -> &[V3] {
        &self.verts[..self.nv]
    }

    pub(crate) fn is_leaf(&self) -> bool {
        self.first_child == NONE
    }

    /// Whether quadrature point `i` of the element's [`Samples`] lies inside a closed
    /// solid.
    pub(crate) fn is_enclosed(&self, i: usize) -> bool {
        self.enclosed & (1 << i) != 0
    }

    /// A point of the patch for three uniform numbers in [0, 1) (uniform by area).
    pub(crate) fn point_at(&self, r0: f64, r1: f64, r2: f64) -> V3 {
        crate::radiosity::quadrature::uniform_point(self.verts(), r0, r1, r2)
    }
}

/// The enclosed quadrature points of `p` as a bit mask.
fn enclosed_mask(p: &Patch, vis: &dyn Visibility) -> u16 {
    let smp = Samples::of(p.verts());
    (0..smp.n)
        .filter(|&i| vis.enclosed(&smp.pts[i], &p.normal))
        .fold(0, |m, i| m | 1 << i)
}

/// A seed for the rays of the link from `src` to `recv`.
pub(super) fn link_seed(recv: Node, src: Node) -> u64 {
    (u64::from(recv.0) << 32) ^ u64::from(src.0) ^ 0xD1B5_4A32_D192_ED03
}

/// Clusters over polygons, patches per polygon.
#[derive(Debug, Clone)]
pub(super) struct Hierarchy {
    pub clusters: Vec<Cluster>,
    /// Root patches first (index = polygon), then quadtree children in creation order.
    pub patches: Vec<Patch>,
}

const SAH_BINS: usize = 16;
/// Below this depth the split falls back to the median (depth stays O(log n)).
const MAX_SAH_DEPTH: usize = 40;

struct Item {
    polygon: u32,
    lo: V3,
    hi: V3,
    centroid: V3,
}

impl Hierarchy {
    /// Builds the cluster tree over every polygon of `scene` (root cluster 0).
    pub(crate) fn build(scene: &Scene) -> Self {
        let n = scene.polygons.len();
        let mut patches: Vec<Patch> = scene
            .polygons
            .iter()
            .enumerate()
            .map(|(i, p)| Patch::new(&p.vertices, i as u32, NONE, NONE, 0))
            .collect();
        let mut items: Vec<Item> = (0..n)
            .map(|i| {
                let v = patches[i].verts();
                let (lo, hi) = super::super::shaft::bounds(v);
                Item {
                    polygon: i as u32,
                    lo,
                    hi,
                    centroid: patches[i].centre,
                }
            })
            .collect();
        let mut clusters = Vec::with_capacity(n.max(1));
        if n > 0 {
            build_node(&mut items[..], &mut clusters, &mut patches, NONE, 0);
        }
        let mut h = Self { clusters, patches };
        h.finish_clusters(scene);
        h
    }

    /// Bottom-up pass: areas, bounds, normal cones, reflectance, sample points.
    fn finish_clusters(&mut self, scene: &Scene) {
        // clusters are created parent before children: reverse order is bottom-up
        for c in (0..self.clusters.len()).rev() {
            let mut sums = ClusterSums::new();
            for k in 0..self.clusters[c].n_children {
                match self.clusters[c].children[k].kind() {
                    Kind::Patch(p) => sums.add_patch(&self.patches[p], scene),
                    Kind::Cluster(k2) => sums.add_cluster(&self.clusters[k2]),
                    Kind::Emitter(_) => {}
                }
            }
            let first_share = match self.clusters[c].children[0].kind() {
                Kind::Patch(p) => self.patches[p].area,
                Kind::Cluster(k) => self.clusters[k].area,
                Kind::Emitter(_) => 0.0,
            } / sums.area.max(1e-300);
            sums.store(&mut self.clusters[c]);
            self.clusters[c].first_share = first_share;
        }
        for c in 0..self.clusters.len() {
            self.finish_cone_and_radius(c);
        }
    }

    /// Normal cone half angle (the widest content normal from the axis) and the
    /// bounding radius about the centroid of cluster `c`.
    fn finish_cone_and_radius(&mut self, c: usize) {
        let axis = self.clusters[c].cone_axis;
        let centre = self.clusters[c].centre;
        let mut cos_min: f64 = 1.0;
        let mut radius: f64 = 0.0;
        self.for_each_root_patch(c, &mut |p: &Patch| {
            cos_min = cos_min.min(p.normal.dot(&axis));
            for v in p.verts() {
                radius = radius.max((v - centre).norm());
            }
        });
        self.clusters[c].radius = radius;
        let cos_min = cos_min.clamp(-1.0, 1.0);
        self.clusters[c].cone_cos = cos_min;
        self.clusters[c].cone_sin = (1.0 - cos_min * cos_min).max(0.0).sqrt();
    }

    /// Calls `f` for every root patch inside cluster `c`.
    pub(crate) fn for_each_root_patch(&self, c: usize, f: &mut impl FnMut(&Patch)) {
        let mut stack = vec![c];
        while let Some(c) = stack.pop() {
            let cl = &self.clusters[c];
            for k in 0..cl.n_children {
                match cl.children[k].kind() {
                    Kind::Patch(p) => f(&self.patches[p]),
                    Kind::Cluster(c2) => stack.push(c2),
                    Kind::Emitter(_) => {}
                }
            }
        }
    }

    /// Marks the quadrature points of the patches from index `first` on that lie
    /// inside a closed solid ([`Visibility::enclosed`]): the floor under a block
    /// resting on it. Their light would be zero and pull the element's mean down,
    /// while the rays to them already keep them from sending.
    pub(crate) fn mark_enclosed(&mut self, first: usize, vis: &dyn Visibility) {
        let masks: Vec<u16> = self.patches[first..]
            .par_iter()
            .map(|p| enclosed_mask(p, vis))
            .collect();
        for (p, m) in self.patches[first..].iter_mut().zip(masks) {
            p.enclosed = m;
        }
    }

    /// Share of the surface area whose quadrature points are enclosed, each point
    /// standing for its weight: over the input polygons (`leaves == false`, known
    /// before the solve, coarse) or over the leaves (finer where refined).
    pub(crate) fn enclosed_area_share(&self, polygons: usize, leaves: bool) -> f64 {
        let (mut enclosed, mut total) = (0.0, 0.0);
        let chosen = self
            .patches
            .iter()
            .enumerate()
            .filter(|(i, p)| if leaves { p.is_leaf() } else { *i < polygons });
        for (_, p) in chosen {
            total += p.area;
            if p.enclosed != 0 {
                let smp = Samples::of(p.verts());
                let share: f64 = (0..smp.n)
                    .filter(|&i| p.is_enclosed(i))
                    .map(|i| smp.w[i])
                    .sum();
                enclosed += p.area * share;
            }
        }
        if total > 0.0 { enclosed / total } else { 0.0 }
    }

    /// Splits leaf patch `p` into four children (no-op for an inner patch). Returns
    /// the index of the first child.
    pub(crate) fn split_patch(&mut self, p: usize) -> u32 {
        if !self.patches[p].is_leaf() {
            return self.patches[p].first_child;
        }
        let first = self.patches.len() as u32;
        let kids = quadrature::split4(self.patches[p].verts());
        let (poly, level) = (self.patches[p].polygon, self.patches[p].level + 1);
        for k in kids {
            self.patches
                .push(Patch::new(&k, poly, p as u32, NONE, level));
        }
        self.patches[p].first_child = first;
        first
    }

    /// Children of a node (empty for leaf patches and emitters).
    pub(crate) fn children(&self, n: Node) -> ([Node; 4], usize) {
        let mut out = [Node(0); 4];
        match n.kind() {
            Kind::Patch(p) => {
                let f = self.patches[p].first_child;
                if f == NONE {
                    return (out, 0);
                }
                for (k, o) in out.iter_mut().enumerate() {
                    *o = Node::patch(f as usize + k);
                }
                (out, 4)
            }
            Kind::Cluster(c) => {
                let cl = &self.clusters[c];
                out[..cl.n_children].copy_from_slice(&cl.children[..cl.n_children]);
                (out, cl.n_children)
            }
            Kind::Emitter(_) => (out, 0),
        }
    }

    /// `n` points on the surfaces inside cluster `c`, distributed by area (a child
    /// chosen in proportion to its area at every level, then a uniform point on the
    /// polygon), with their normals; deterministic in `seed`. Shadow rays between
    /// clusters use fresh points per link (Kresse 2.7: rays spread at random over
    /// sender and receiver), so that sampling errors average out over the links
    /// instead of repeating in each.
    pub(crate) fn random_points(&self, c: usize, n: usize, seed: u64) -> Vec<(V3, V3)> {
        self.random_points_where(c, n, n, seed, |_| true)
    }

    /// Like [`Hierarchy::random_points`], keeping only points whose normal passes
    /// `keep`, until `n` are kept or `tries` were drawn.
    pub(crate) fn random_points_where(
        &self,
        c: usize,
        n: usize,
        tries: usize,
        seed: u64,
        keep: impl Fn(&V3) -> bool,
    ) -> Vec<(V3, V3)> {
        let mut rng = crate::rng::SplitMix64(seed);
        let mut out = Vec::with_capacity(n);
        for _ in 0..tries {
            if out.len() == n {
                break;
            }
            let mut node = Node::cluster(c);
            let point = loop {
                match node.kind() {
                    Kind::Cluster(k) => {
                        let cl = &self.clusters[k];
                        node = if cl.n_children == 1 || rng.unit() < cl.first_share {
                            cl.children[0]
                        } else {
                            cl.children[1]
                        };
                    }
                    Kind::Patch(p) => {
                        let pa = &self.patches[p];
                        if !keep(&pa.normal) {
                            break None;
                        }
                        break Some((pa.point_at(rng.unit(), rng.unit(), rng.unit()), pa.normal));
                    }
                    Kind::Emitter(_) => break None,
                }
            };
            out.extend(point);
        }
        out
    }

    /// Bounding sphere (centre, radius) and area of a node.
    pub(crate) fn sphere(&self, n: Node) -> (V3, f64, f64) {
        match n.kind() {
            Kind::Patch(p) => {
                let pa = &self.patches[p];
                (pa.centre, pa.radius, pa.area)
            }
            Kind::Cluster(c) => {
                let cl = &self.clusters[c];
                (cl.centre, cl.radius, cl.area)
            }
            Kind::Emitter(_) => (V3::zeros(), 0.0, 0.0),
        }
    }
}

fn build_node(
    items: &mut [Item],
    clusters: &mut Vec<Cluster>,
    patches: &mut [Patch],
    parent: u32,
    depth: usize,
) -> Node {
    let me = clusters.len();
    clusters.push(Cluster {
        lo: V3::zeros(),
        hi: V3::zeros(),
        centre: V3::zeros(),
        radius: 0.0,
        area: 0.0,
        children: [Node(0); 2],
        n_children: 0,
        first_share: 1.0,
        parent,
        cone_axis: V3::z(),
        cone_cos: -1.0,
        cone_sin: 0.0,
        rho_max: 0.0,
        w_max: 0.0,
        poly_radius_max: 0.0,
        samples: [(V3::zeros(), V3::z()); 4],
        n_samples: 0,
    });
    let (left, right) = if items.len() <= 2 {
        let mid = items.len().min(1);
        items.split_at_mut(mid)
    } else if depth > MAX_SAH_DEPTH {
        // a degenerate SAH sequence must not grow the tree (and the recursion) deeper
        let axis = {
            let (lo, hi) = items.iter().fold(
                (V3::repeat(f64::INFINITY), V3::repeat(f64::NEG_INFINITY)),
                |(lo, hi), it| (lo.inf(&it.centroid), hi.sup(&it.centroid)),
            );
            (hi - lo).imax()
        };
        items.sort_by(|a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
        let mid = items.len() / 2;
        items.split_at_mut(mid)
    } else {
        let mid = sah_split(items);
        items.split_at_mut(mid)
    };
    let mut children = [Node(0); 2];
    let mut nc = 0;
    for part in [left, right] {
        if part.is_empty() {
            continue;
        }
        children[nc] = if part.len() == 1 {
            let p = part[0].polygon as usize;
            patches[p].cluster = me as u32;
            Node::patch(p)
        } else {
            build_node(part, clusters, patches, me as u32, depth + 1)
        };
        nc += 1;
    }
    clusters[me].children = children;
    clusters[me].n_children = nc;
    Node::cluster(me)
}

/// Reorders `items` and returns the split position (binned SAH over the centroids'
/// longest axis; the median when the centroids coincide).
fn sah_split(items: &mut [Item]) -> usize {
    let mut clo = V3::repeat(f64::INFINITY);
    let mut chi = V3::repeat(f64::NEG_INFINITY);
    for it in items.iter() {
        clo = clo.inf(&it.centroid);
        chi = chi.sup(&it.centroid);
    }
    let ext = chi - clo;
    let axis = ext.imax();
    if ext[axis].is_nan() || ext[axis] <= 0.0 || !ext[axis].is_finite() {
        return items.len() / 2;
    }
    let k = SAH_BINS as f64 / ext[axis];
    let bin_of = |c: f64| (((c - clo[axis]) * k) as usize).min(SAH_BINS - 1);
    let mut bin_lo = [V3::repeat(f64::INFINITY); SAH_BINS];
    let mut bin_hi = [V3::repeat(f64::NEG_INFINITY); SAH_BINS];
    let mut bin_n = [0usize; SAH_BINS];
    for it in items.iter() {
        let b = bin_of(it.centroid[axis]);
        bin_lo[b] = bin_lo[b].inf(&it.lo);
        bin_hi[b] = bin_hi[b].sup(&it.hi);
        bin_n[b] += 1;
    }
    let area = |lo: &V3, hi: &V3| {
        let d = hi - lo;
        if d.x < 0.0 {
            0.0
        } else {
            d.x * d.y + d.y * d.z + d.z * d.x
        }
    };
    let mut right = [(0.0, 0usize); SAH_BINS];
    let (mut lo, mut hi, mut n) = (V3::repeat(f64::INFINITY), V3::repeat(f64::NEG_INFINITY), 0);
    for s in (1..SAH_BINS).rev() {
        lo = lo.inf(&bin_lo[s]);
        hi = hi.sup(&bin_hi[s]);
        n += bin_n[s];
        right[s] = (area(&lo, &hi), n);
    }
    let (mut lo, mut hi, mut nl) = (V3::repeat(f64::INFINITY), V3::repeat(f64::NEG_INFINITY), 0);
    let mut best = (f64::INFINITY, usize::MAX);
    for s in 0..SAH_BINS - 1 {
        lo = lo.inf(&bin_lo[s]);
        hi = hi.sup(&bin_hi[s]);
        nl += bin_n[s];
        let (ar, nr) = right[s + 1];
        if nl == 0 || nr == 0 {
            continue;
        }
        let cost = area(&lo, &hi) * nl as f64 + ar * nr as f64;
        if cost < best.0 {
            best = (cost, s);
        }
    }
    if best.1 == usize::MAX {
        return items.len() / 2;
    }
    let split = best.1;
    // partition in place
    let mut i = 0;
    for j in 0..items.len() {
        if bin_of(items[j].centroid[axis]) <= split {
            items.swap(i, j);
            i += 1;
        }
    }
    i.clamp(1, items.len() - 1)
}

/// What a cluster sums over its children in the bottom-up pass.
struct ClusterSums {
    area: f64,
    lo: V3,
    hi: V3,
    /// Area-weighted sum of the normals.
    axis: V3,
    rho_max: f64,
    w_max: f64,
    poly_radius_max: f64,
    /// Area-weighted sum of the centres.
    moment: V3,
    /// Candidate samples (point, normal) with the area they stand for.
    child_reps: Vec<((V3, V3), f64)>,
}

impl ClusterSums {
    fn new() -> Self {
        Self {
            area: 0.0,
            lo: V3::repeat(f64::INFINITY),
            hi: V3::repeat(f64::NEG_INFINITY),
            axis: V3::zeros(),
            rho_max: 0.0,
            w_max: 0.0,
            poly_radius_max: 0.0,
            moment: V3::zeros(),
            child_reps: Vec::new(),
        }
    }

    fn add_patch(&mut self, pa: &Patch, scene: &Scene) {
        self.area += pa.area;
        self.moment += pa.centre * pa.area;
        for v in pa.verts() {
            self.lo = self.lo.inf(v);
            self.hi = self.hi.sup(v);
        }
        self.axis += pa.normal * pa.area;
        let rho = scene.material_of(pa.polygon as usize).reflectance_xyz[1];
        self.rho_max = self.rho_max.max(rho);
        self.w_max = self.w_max.max(error_weight(rho));
        self.poly_radius_max = self.poly_radius_max.max(pa.radius);
        self.child_reps.push(((pa.centre, pa.normal), pa.area));
    }

    fn add_cluster(&mut self, ch: &Cluster) {
        self.area += ch.area;
        self.moment += ch.centre * ch.area;
        self.lo = self.lo.inf(&ch.lo);
        self.hi = self.hi.sup(&ch.hi);
        self.axis += ch.cone_axis * ch.area;
        self.rho_max = self.rho_max.max(ch.rho_max);
        self.w_max = self.w_max.max(ch.w_max);
        self.poly_radius_max = self.poly_radius_max.max(ch.poly_radius_max);
        // samples of the child become candidates for this cluster's
        for s in &ch.samples[..ch.n_samples] {
            self.child_reps.push((*s, ch.area / ch.n_samples as f64));
        }
    }

    /// Writes the sums into the cluster: bounds, area centroid, cone axis, the
    /// reflectance bounds and up to four samples spread over the children.
    fn store(mut self, cl: &mut Cluster) {
        self.child_reps.sort_by(|a, b| b.1.total_cmp(&a.1));
        let mut samples = [(V3::zeros(), V3::z()); 4];
        let mut n_samples = 0;
        for r in self.child_reps.iter().take(4) {
            samples[n_samples] = r.0;
            n_samples += 1;
        }
        let area = self.area;
        // the area centroid: a uniformly bright cluster's light leaves from there
        let centre = if area > 0.0 {
            self.moment / area
        } else {
            (self.lo + self.hi) * 0.5
        };
        let len = self.axis.norm();
        let cone_axis = if len > 1e-12 * area.max(1e-300) {
            self.axis / len
        } else {
            V3::z()
        };
        cl.lo = self.lo;
        cl.hi = self.hi;
        cl.centre = centre;
        cl.area = area;
        cl.cone_axis = cone_axis;
        cl.rho_max = self.rho_max;
        cl.w_max = self.w_max;
        cl.poly_radius_max = self.poly_radius_max;
        cl.samples = samples;
        cl.n_samples = n_samples;
    }
}
