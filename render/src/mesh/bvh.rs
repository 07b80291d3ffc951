//! Bounding-volume hierarchy over triangles: binned SAH build (subtrees built in
//! parallel with rayon), stack traversal with slab tests, Möller–Trumbore ray–triangle
//! tests in f64 with a small edge tolerance so that rays through shared edges and
//! vertices of a closed mesh do not slip through.

use super::indexed::{cross, dot, sub};

/// Closest intersection of a ray with the triangles of a [`Bvh`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter: the hit point is `origin + t·dir` (t in units of |dir|).
    pub t: f64,
    /// Index of the triangle in the slice given to [`Bvh::build`].
    pub triangle: u32,
    /// Barycentric coordinate of corner 1.
    pub u: f64,
    /// Barycentric coordinate of corner 2.
    pub v: f64,
    /// True when the ray hit the triangle's front side (dir · normal < 0).
    pub front_face: bool,
}

/// Size figures of a built [`Bvh`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BvhStats {
    /// Number of nodes.
    pub nodes: usize,
    /// Number of leaves.
    pub leaves: usize,
    /// Maximum depth.
    pub max_depth: usize,
    /// Largest triangle count in a leaf.
    pub max_leaf_size: usize,
    /// Heap bytes held by the hierarchy.
    pub memory_bytes: usize,
}

#[derive(Debug, Clone, Copy)]
struct Node {
    bmin: [f64; 3],
    bmax: [f64; 3],
    /// Inner node: index of the right child (left child follows the node). Leaf:
    /// first index into `order`.
    index: u32,
    /// Number of triangles for a leaf, 0 for an inner node.
    count: u32,
}

/// A bounding-volume hierarchy over a triangle soup.
#[derive(Debug, Clone)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Original triangle index of each stored triangle.
    order: Vec<u32>,
    /// Triangles in leaf order.
    tris: Vec<[[f64; 3]; 3]>,
}

/// A node with at most this many triangles becomes a leaf.
const LEAF_MAX: usize = 4;
/// SAH bins per split axis.
const BINS: usize = 16;
/// Subtrees with at least this many triangles are built in parallel.
const PARALLEL_MIN: usize = 4096;
/// Tolerance of the ray–triangle test on the barycentric coordinates (hits just
/// outside an edge still count, so that rays through shared edges do not slip
/// through).
const EDGE_EPS: f64 = 1e-10;
/// A ray counts as parallel to a triangle when the determinant of the hit system is
/// at most this fraction of |e1|·|e2|·|d|.
const PARALLEL_DET_RATIO: f64 = 1e-14;
/// Default relative end margin of shadow segments (see [`Bvh::occluded`]).
const SHADOW_END_MARGIN: f64 = 1e-6;
/// A node whose triangles cannot be split by SAH stays a leaf up to this many
/// triangles (this many times [`LEAF_MAX`]).
const UNSPLIT_LEAF_FACTOR: usize = 4;

#[derive(Clone, Copy)]
struct Aabb {
    min: [f64; 3],
    max: [f64; 3],
}

impl Aabb {
    fn empty() -> Self {
        Self {
            min: [f64::INFINITY; 3],
            max: [f64::NEG_INFINITY; 3],
        }
    }
    fn grow(&mut self, p: [f64; 3]) {
        self.merge(&Aabb { min: p, max: p });
    }
    fn merge(&mut self, o: &Aabb) {
        for (m, v) in self.min.iter_mut().zip(o.min) {
            *m = m.min(v);
        }
        for (m, v) in self.max.iter_mut().zip(o.max) {
            *m = m.max(v);
        }
    }
    fn area(&self) -> f64 {
        let d = sub(self.max, self.min);
        if d[0] < 0.0 {
            return 0.0;
        }
        2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0])
    }
}

enum Step {
    Miss,
    Closer(f64),
}

enum Tree {
    Leaf {
        bounds: Aabb,
        items: Vec<u32>,
    },
    Inner {
        bounds: Aabb,
        left: Box<Tree>,
        right: Box<Tree>,
    },
}

struct Prim {
    bounds: Aabb,
    centroid: [f64; 3],
}

fn build_tree(prims: &[Prim], mut items: Vec<u32>) -> Tree {
    let mut bounds = Aabb::empty();
    let mut cb = Aabb::empty();
    for &i in &items {
        bounds.merge(&prims[i as usize].bounds);
        cb.grow(prims[i as usize].centroid);
    }
    if items.len() <= LEAF_MAX {
        return Tree::Leaf { bounds, items };
    }
    let ext = sub(cb.max, cb.min);
    let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
        0
    } else if ext[1] >= ext[2] {
        1
    } else {
        2
    };
    if ext[axis].is_nan() || ext[axis] <= 0.0 {
        // all centroids coincide (or are not finite): split in the middle of the list
        if items.len() <= UNSPLIT_LEAF_FACTOR * LEAF_MAX {
            return Tree::Leaf { bounds, items };
        }
        let right = items.split_off(items.len() / 2);
        return join(prims, bounds, items, right);
    }
    let lo = cb.min[axis];
    let k = BINS as f64 / ext[axis];
    let bin_of = |c: f64| (((c - lo) * k) as usize).min(BINS - 1);
    let mut bin_box = [Aabb::empty(); BINS];
    let mut bin_n = [0usize; BINS];
    for &i in &items {
        let p = &prims[i as usize];
        let b = bin_of(p.centroid[axis]);
        bin_box[b].merge(&p.bounds);
        bin_n[b] += 1;
    }
    // sweep: cost of splitting after bin s
    let mut right_area = [0.0; BINS];
    let mut right_n = [0usize; BINS];
    let mut acc = Aabb::empty();
    let mut n = 0;
    for s in (1..BINS).rev() {
        acc.merge(&bin_box[s]);
        n += bin_n[s];
        right_area[s] = acc.area();
        right_n[s] = n;
    }
    let mut best = (f64::INFINITY, 0usize);
    let mut accl = Aabb::empty();
    let mut nl = 0;
    for s in 0..BINS - 1 {
        accl.merge(&bin_box[s]);
        nl += bin_n[s];
        let nr = right_n[s + 1];
        if nl == 0 || nr == 0 {
            continue;
        }
        let cost = accl.area() * nl as f64 + right_area[s + 1] * nr as f64;
        if cost < best.0 {
            best = (cost, s);
        }
    }
    let leaf_cost = bounds.area() * items.len() as f64;
    if !best.0.is_finite() {
        let right = items.split_off(items.len() / 2);
        return join(prims, bounds, items, right);
    }
    // a split costs one more box test (≈ one triangle test); keep small leaves
    if best.0 + bounds.area() >= leaf_cost && items.len() <= UNSPLIT_LEAF_FACTOR * LEAF_MAX {
        return Tree::Leaf { bounds, items };
    }
    let split = best.1;
    let (left, right): (Vec<u32>, Vec<u32>) = items
        .into_iter()
        .partition(|&i| bin_of(prims[i as usize].centroid[axis]) <= split);
    join(prims, bounds, left, right)
}

fn join(prims: &[Prim], bounds: Aabb, left: Vec<u32>, right: Vec<u32>) -> Tree {
    let (l, r) = if left.len() + right.len() >= PARALLEL_MIN {
        rayon::join(|| build_tree(prims, left), || build_tree(prims, right))
    } else {
        (build_tree(prims, left), build_tree(prims, right))
    };
    Tree::Inner {
        bounds,
        left: Box::new(l),
        right: Box::new(r),
    }
}

fn flatten(tree: Tree, nodes: &mut Vec<Node>, order: &mut Vec<u32>) {
    match tree {
        Tree::Leaf { bounds, items } => {
            nodes.push(Node {
                bmin: bounds.min,
                bmax: bounds.max,
                index: order.len() as u32,
                count: items.len() as u32,
            });
            order.extend(items);
        }
        Tree::Inner {
            bounds,
            left,
            right,
        } => {
            let me = nodes.len();
            nodes.push(Node {
                bmin: bounds.min,
                bmax: bounds.max,
                index: 0,
                count: 0,
            });
            flatten(*left, nodes, order);
            nodes[me].index = nodes.len() as u32;
            flatten(*right, nodes, order);
        }
    }
}

impl Bvh {
    /// Builds the hierarchy. Triangles with non-finite corners are kept in the soup
    /// (so indices stay valid) but never reported as hit.
    pub fn build(tris: &[[[f64; 3]; 3]]) -> Self {
        let prims: Vec<Prim> = tris
            .iter()
            .map(|t| {
                let finite = t.iter().flatten().all(|v| v.is_finite());
                let mut b = Aabb::empty();
                if finite {
                    for p in t {
                        b.grow(*p);
                    }
                }
                let centroid = if finite {
                    [
                        (t[0][0] + t[1][0] + t[2][0]) / 3.0,
                        (t[0][1] + t[1][1] + t[2][1]) / 3.0,
                        (t[0][2] + t[1][2] + t[2][2]) / 3.0,
                    ]
                } else {
                    [0.0; 3]
                };
                Prim {
                    bounds: b,
                    centroid,
                }
            })
            .collect();
        let mut nodes = Vec::new();
        let mut order = Vec::with_capacity(tris.len());
        if !tris.is_empty() {
            let items: Vec<u32> = (0..tris.len() as u32).collect();
            let tree = build_tree(&prims, items);
            flatten(tree, &mut nodes, &mut order);
        }
        // store the triangles in leaf order so that a leaf reads contiguous memory
        let tris = order.iter().map(|&i| tris[i as usize]).collect();
        Self { nodes, order, tris }
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// True when built from no triangles.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// Size figures of the hierarchy.
    pub fn stats(&self) -> BvhStats {
        let mut max_depth = 0;
        let mut leaves = 0;
        let mut max_leaf = 0;
        let mut stack = vec![(0usize, 1usize)];
        while let Some((i, depth)) = stack.pop() {
            let Some(n) = self.nodes.get(i) else { break };
            max_depth = max_depth.max(depth);
            if n.count > 0 {
                leaves += 1;
                max_leaf = max_leaf.max(n.count as usize);
            } else {
                stack.push((i + 1, depth + 1));
                stack.push((n.index as usize, depth + 1));
            }
        }
        BvhStats {
            nodes: self.nodes.len(),
            leaves,
            max_depth,
            max_leaf_size: max_leaf,
            memory_bytes: self.nodes.capacity() * std::mem::size_of::<Node>()
                + self.order.capacity() * 4
                + self.tris.capacity() * std::mem::size_of::<[[f64; 3]; 3]>(),
        }
    }

    /// Nearest hit along `origin + t·dir` with 0 < t < `t_max` (t in units of
    /// |dir|; `dir` need not be normalised). Back faces are reported too.
    pub fn intersect(&self, origin: [f64; 3], dir: [f64; 3], t_max: f64) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        self.traverse(origin, dir, 0.0, t_max, |slot, t_lim| {
            let tri = &self.tris[slot];
            let tri_index = self.order[slot];
            match ray_triangle(origin, dir, tri, 0.0, t_lim) {
                Some((t, u, v, det)) => {
                    best = Some(Hit {
                        t,
                        triangle: tri_index,
                        u,
                        v,
                        front_face: det > 0.0,
                    });
                    Step::Closer(t)
                }
                None => Step::Miss,
            }
        });
        best
    }

    /// True when any triangle blocks the open segment between `from` and `to`
    /// (excluding 1e-6 of the segment length at either end, so that the surfaces at
    /// the end points do not shadow themselves).
    pub fn occluded(&self, from: [f64; 3], to: [f64; 3]) -> bool {
        self.occluded_with_margin(from, to, SHADOW_END_MARGIN)
    }

    /// Like [`Bvh::occluded`] with an explicit relative end margin in [0, 0.5]
    /// (Kresse 2.2.6: the distance around sender and receiver where no visibility is
    /// tested).
    pub fn occluded_with_margin(&self, from: [f64; 3], to: [f64; 3], margin: f64) -> bool {
        let dir = sub(to, from);
        let m = if margin.is_finite() {
            margin.clamp(0.0, 0.5)
        } else {
            SHADOW_END_MARGIN
        };
        if self.nodes.is_empty() || !from.iter().chain(dir.iter()).all(|v| v.is_finite()) {
            return false;
        }
        // any hit ends the query: no front-to-back order, each node's slabs are
        // tested once, when it is popped
        let inv = [1.0 / dir[0], 1.0 / dir[1], 1.0 / dir[2]];
        let (t0, t1) = (m, 1.0 - m);
        self.any_in_leaves(
            |n| slab(n, from, inv, t0, t1).is_some(),
            |k| ray_triangle(from, dir, &self.tris[k], t0, t1).is_some(),
        )
    }

    /// Region query: true as soon as `accept_triangle` accepts a triangle (given its
    /// index in the slice of [`Bvh::build`] and its corners) inside a node whose
    /// bounds `enter_box(min, max)` lets through. `enter_box` must be conservative
    /// (false only when no point of the box can matter), as in shaft culling.
    pub fn any_triangle<B, T>(&self, mut enter_box: B, mut accept_triangle: T) -> bool
    where
        B: FnMut(&[f64; 3], &[f64; 3]) -> bool,
        T: FnMut(u32, &[[f64; 3]; 3]) -> bool,
    {
        if self.nodes.is_empty() {
            return false;
        }
        self.any_in_leaves(
            |n| enter_box(&n.bmin, &n.bmax),
            |k| accept_triangle(self.order[k], &self.tris[k]),
        )
    }

    /// Depth-first search in any order: true as soon as `accept` accepts a triangle
    /// (by storage slot) in a leaf reached through nodes that `enter` lets through.
    /// The tree must not be empty.
    fn any_in_leaves(
        &self,
        mut enter: impl FnMut(&Node) -> bool,
        mut accept: impl FnMut(usize) -> bool,
    ) -> bool {
        let mut stack = Stack::new();
        stack.push(0);
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i];
            if !enter(n) {
                continue;
            }
            if n.count > 0 {
                let first = n.index as usize;
                if (first..first + n.count as usize).any(&mut accept) {
                    return true;
                }
            } else {
                stack.push(n.index as usize);
                stack.push(i + 1);
            }
        }
        false
    }

    /// Visits leaves front to back, calling `test` for every candidate triangle (its
    /// storage slot) with the current t limit.
    fn traverse<F>(&self, origin: [f64; 3], dir: [f64; 3], t_min: f64, t_max: f64, mut test: F)
    where
        F: FnMut(usize, f64) -> Step,
    {
        if self.nodes.is_empty()
            || !origin.iter().chain(dir.iter()).all(|v| v.is_finite())
            || t_max.is_nan()
        {
            return;
        }
        let inv = [1.0 / dir[0], 1.0 / dir[1], 1.0 / dir[2]];
        let mut t_lim = t_max;
        let mut stack = Stack::new();
        stack.push(0);
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i];
            if slab(n, origin, inv, t_min, t_lim).is_none() {
                continue;
            }
            if n.count > 0 {
                let first = n.index as usize;
                for k in first..first + n.count as usize {
                    match test(k, t_lim) {
                        Step::Miss => {}
                        Step::Closer(t) => t_lim = t,
                    }
                }
            } else {
                let (l, r) = (i + 1, n.index as usize);
                let tl = slab(&self.nodes[l], origin, inv, t_min, t_lim);
                let tr = slab(&self.nodes[r], origin, inv, t_min, t_lim);
                match (tl, tr) {
                    (Some(a), Some(b)) => {
                        if a <= b {
                            stack.push(r);
                            stack.push(l);
                        } else {
                            stack.push(l);
                            stack.push(r);
                        }
                    }
                    (Some(_), None) => stack.push(l),
                    (None, Some(_)) => stack.push(r),
                    (None, None) => {}
                }
            }
        }
    }

    /// Brute-force nearest hit over all triangles (reference for tests and the
    /// benchmark).
    pub fn intersect_brute_force(
        tris: &[[[f64; 3]; 3]],
        origin: [f64; 3],
        dir: [f64; 3],
        t_max: f64,
    ) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut t_best = t_max;
        for (i, tri) in tris.iter().enumerate() {
            if let Some((t, u, v, det)) = ray_triangle(origin, dir, tri, 0.0, t_best) {
                t_best = t;
                best = Some(Hit {
                    t,
                    triangle: i as u32,
                    u,
                    v,
                    front_face: det > 0.0,
                });
            }
        }
        best
    }
}

/// Traversal stack: fixed array, spilling to the heap only for very deep trees.
struct Stack {
    fixed: [u32; 64],
    len: usize,
    spill: Vec<u32>,
}

impl Stack {
    fn new() -> Self {
        Self {
            fixed: [0; 64],
            len: 0,
            spill: Vec::new(),
        }
    }
    fn push(&mut self, v: usize) {
        if self.len < self.fixed.len() {
            self.fixed[self.len] = v as u32;
            self.len += 1;
        } else {
            self.spill.push(v as u32);
        }
    }
    fn pop(&mut self) -> Option<usize> {
        if let Some(v) = self.spill.pop() {
            return Some(v as usize);
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        Some(self.fixed[self.len] as usize)
    }
}

fn slab(n: &Node, o: [f64; 3], inv: [f64; 3], t_min: f64, t_max: f64) -> Option<f64> {
    let mut t0 = t_min;
    let mut t1 = t_max;
    for k in 0..3 {
        let a = (n.bmin[k] - o[k]) * inv[k];
        let b = (n.bmax[k] - o[k]) * inv[k];
        // NaN (0·∞ when the ray lies in a slab plane) must not reject the box
        let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
        if !lo.is_nan() {
            t0 = t0.max(lo);
        }
        if !hi.is_nan() {
            t1 = t1.min(hi * (1.0 + 4.0 * f64::EPSILON));
        }
        if t0 > t1 {
            return None;
        }
    }
    Some(t0)
}

/// Möller–Trumbore. Returns (t, u, v, det) for t_min < t < t_max.
fn ray_triangle(
    o: [f64; 3],
    d: [f64; 3],
    tri: &[[f64; 3]; 3],
    t_min: f64,
    t_max: f64,
) -> Option<(f64, f64, f64, f64)> {
    let e1 = sub(tri[1], tri[0]);
    let e2 = sub(tri[2], tri[0]);
    let p = cross(d, e2);
    let det = dot(e1, p);
    let scale = dot(e1, e1).sqrt() * dot(e2, e2).sqrt() * dot(d, d).sqrt();
    if det.is_nan() || det.abs() <= PARALLEL_DET_RATIO * scale {
        return None;
    }
    let inv = 1.0 / det;
    let s = sub(o, tri[0]);
    let u = dot(s, p) * inv;
    if !(-EDGE_EPS..=1.0 + EDGE_EPS).contains(&u) {
        return None;
    }
    let q = cross(s, e1);
    let v = dot(d, q) * inv;
    if v < -EDGE_EPS || u + v > 1.0 + EDGE_EPS {
        return None;
    }
    let t = dot(e2, q) * inv;
    if t > t_min && t < t_max {
        // det = −d · (e1 × e2): det > 0 ⇔ the ray meets the front face
        Some((t, u, v, det))
    } else {
        None
    }
}
