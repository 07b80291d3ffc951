//! Input checks and repair of triangle meshes (Kresse 2.2.6).

use super::indexed::{IndexedMesh, dot, len, sub, tri_normal};
use std::collections::{HashMap, HashSet, VecDeque};

/// Tolerances of [`check_and_repair_with`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RepairOptions {
    /// Vertices closer than this (metres) are welded; also the distance within which
    /// a vertex counts as lying on another triangle's edge (T-vertex).
    pub weld_tolerance_m: f64,
    /// Triangles with area below this (m²) are degenerate.
    pub min_area_m2: f64,
}

impl Default for RepairOptions {
    fn default() -> Self {
        Self {
            weld_tolerance_m: 1e-6,
            min_area_m2: 1e-12,
        }
    }
}

/// What [`check_and_repair`] found and changed.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct MeshReport {
    /// Vertices in the input.
    pub input_vertices: usize,
    /// Triangles in the input.
    pub input_triangles: usize,
    /// Triangles dropped because an index was out of range or a corner not finite.
    pub invalid_triangles_removed: usize,
    /// Vertices merged into another one within the weld tolerance.
    pub vertices_welded: usize,
    /// Degenerate triangles removed (repeated vertex or area below the threshold).
    pub degenerate_triangles_removed: usize,
    /// Triangles removed because another triangle had the same three vertices.
    pub duplicate_triangles_removed: usize,
    /// T-vertices found on mesh edges and fixed by splitting the edge's triangle.
    pub t_vertices_fixed: usize,
    /// Edges shared by more than two triangles (reported, not changed).
    pub non_manifold_edges: usize,
    /// Edges used by exactly one triangle.
    pub boundary_edges: usize,
    /// Triangles whose winding was reversed to agree with their neighbours.
    pub triangles_flipped: usize,
    /// Edge-connected components.
    pub components: usize,
    /// Components that cannot be oriented consistently (Möbius-like or across
    /// non-manifold edges); their orientation is left partly inconsistent.
    pub non_orientable_components: usize,
    /// Unreferenced vertices removed.
    pub unused_vertices_removed: usize,
    /// Vertices in the output.
    pub output_vertices: usize,
    /// Triangles in the output.
    pub output_triangles: usize,
}

/// Checks and repairs `mesh` in place with default tolerances (1 µm weld,
/// 1e-12 m² minimum area); see [`check_and_repair_with`].
pub fn check_and_repair(mesh: &mut IndexedMesh) -> MeshReport {
    check_and_repair_with(mesh, &RepairOptions::default())
}

/// Checks and repairs `mesh` in place. Never panics on any input.
///
/// Steps, in order:
/// 1. triangles with an out-of-range index or a non-finite corner are dropped;
/// 2. vertices within `weld_tolerance_m` are welded (first one wins);
/// 3. degenerate triangles (repeated vertex after welding, area < `min_area_m2`) and
///    duplicates (same three vertices in any order) are removed (again after step 4);
/// 4. T-vertices: a vertex lying inside a boundary edge (within the weld tolerance)
///    splits the triangle owning that edge, repeated until none is left;
/// 5. orientation: across manifold edges (exactly two triangles) windings are made
///    consistent by breadth-first propagation; per component the majority winding
///    of the input is kept (a closed shell may be a solid seen from outside or a room
///    seen from inside, so no inside/outside guess is made);
/// 6. unreferenced vertices are removed.
///
/// Non-manifold edges (more than two triangles) are reported but left as they are;
/// orientation is not propagated across them.
pub fn check_and_repair_with(mesh: &mut IndexedMesh, options: &RepairOptions) -> MeshReport {
    let mut report = MeshReport {
        input_vertices: mesh.positions.len(),
        input_triangles: mesh.triangles.len(),
        ..MeshReport::default()
    };
    let tol = non_negative_or_zero(options.weld_tolerance_m);
    let min_area = non_negative_or_zero(options.min_area_m2);

    // 1. invalid triangles
    let finite: Vec<bool> = mesh
        .positions
        .iter()
        .map(|p| p.iter().all(|v| v.is_finite()))
        .collect();
    report.invalid_triangles_removed = remove_invalid_triangles(mesh, &finite);

    // 2. weld
    report.vertices_welded = weld_vertices(mesh, &finite, tol);

    // 3. degenerate and duplicate triangles
    report.degenerate_triangles_removed = remove_degenerate_triangles(mesh, min_area);
    report.duplicate_triangles_removed = remove_duplicates(&mut mesh.triangles);

    // 4. T-vertices (splitting overlapping input can create duplicates: drop them too)
    report.t_vertices_fixed = fix_t_vertices(mesh, tol, min_area);
    report.duplicate_triangles_removed += remove_duplicates(&mut mesh.triangles);

    // 5. orientation
    let topo = orient(mesh);
    report.triangles_flipped = topo.flipped;
    report.components = topo.components;
    report.non_orientable_components = topo.non_orientable;

    // 6. unused vertices
    report.unused_vertices_removed = remove_unused_vertices(mesh) - report.vertices_welded;

    let edges = edge_map(&mesh.triangles);
    report.non_manifold_edges = edges.values().filter(|v| v.len() > 2).count();
    report.boundary_edges = edges.values().filter(|v| v.len() == 1).count();
    report.output_vertices = mesh.positions.len();
    report.output_triangles = mesh.triangles.len();
    report
}

/// A tolerance as given when finite, clamped to ≥ 0; zero when not finite.
fn non_negative_or_zero(v: f64) -> f64 {
    if v.is_finite() { v.max(0.0) } else { 0.0 }
}

/// Step 1: drops triangles with an out-of-range index or a non-finite corner;
/// returns how many.
fn remove_invalid_triangles(mesh: &mut IndexedMesh, finite: &[bool]) -> usize {
    let n_pos = mesh.positions.len();
    let before = mesh.triangles.len();
    mesh.triangles.retain(|t| {
        t.iter()
            .all(|&i| (i as usize) < n_pos && finite[i as usize])
    });
    before - mesh.triangles.len()
}

/// Step 2: welds vertices within `tol` (first one wins) in the triangles; returns
/// how many finite vertices were merged into another.
fn weld_vertices(mesh: &mut IndexedMesh, finite: &[bool], tol: f64) -> usize {
    let remap = weld(&mesh.positions, finite, tol);
    for t in &mut mesh.triangles {
        for i in t.iter_mut() {
            *i = remap[*i as usize];
        }
    }
    remap
        .iter()
        .enumerate()
        .filter(|(i, r)| finite[*i] && **r as usize != *i)
        .count()
}

/// Step 3: drops triangles with a repeated vertex or an area below `min_area`;
/// returns how many.
fn remove_degenerate_triangles(mesh: &mut IndexedMesh, min_area: f64) -> usize {
    let before = mesh.triangles.len();
    let positions = &mesh.positions;
    mesh.triangles.retain(|t| {
        t[0] != t[1] && t[1] != t[2] && t[0] != t[2] && area_ok(&corners(positions, t), min_area)
    });
    before - mesh.triangles.len()
}

/// Step 6: keeps only referenced vertices, in order of first use, and renumbers the
/// triangles; returns how many vertices were dropped.
fn remove_unused_vertices(mesh: &mut IndexedMesh) -> usize {
    let mut used = vec![u32::MAX; mesh.positions.len()];
    let mut new_pos = Vec::new();
    for t in &mut mesh.triangles {
        for i in t.iter_mut() {
            let u = &mut used[*i as usize];
            if *u == u32::MAX {
                *u = new_pos.len() as u32;
                new_pos.push(mesh.positions[*i as usize]);
            }
            *i = *u;
        }
    }
    let removed = mesh.positions.len() - new_pos.len();
    mesh.positions = new_pos;
    removed
}

/// Removes triangles with the same three vertices as an earlier one (any order or
/// winding); returns how many.
fn remove_duplicates(tris: &mut Vec<[u32; 3]>) -> usize {
    let before = tris.len();
    let mut seen = HashSet::with_capacity(tris.len());
    tris.retain(|t| {
        let mut k = *t;
        k.sort_unstable();
        seen.insert(k)
    });
    before - tris.len()
}

/// Area is finite (no overflow for huge coordinates) and at least `min_area`.
fn area_ok(c: &[[f64; 3]; 3], min_area: f64) -> bool {
    let a = 0.5 * len(tri_normal(c));
    a.is_finite() && a >= min_area
}

fn corners(p: &[[f64; 3]], t: &[u32; 3]) -> [[f64; 3]; 3] {
    [p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]]
}

type Cell = (i64, i64, i64);

fn cell_of(p: [f64; 3], h: f64) -> Cell {
    // `as` saturates for huge values, which only merges far-away cells (still correct
    // because distances are re-checked).
    (
        (p[0] / h).floor() as i64,
        (p[1] / h).floor() as i64,
        (p[2] / h).floor() as i64,
    )
}

fn neighbours(c: Cell) -> impl Iterator<Item = Cell> {
    (-1i64..=1).flat_map(move |dx| {
        (-1i64..=1).flat_map(move |dy| {
            (-1i64..=1).map(move |dz| {
                (
                    c.0.saturating_add(dx),
                    c.1.saturating_add(dy),
                    c.2.saturating_add(dz),
                )
            })
        })
    })
}

/// Maps each vertex to its representative (the first vertex within `tol`).
fn weld(pos: &[[f64; 3]], finite: &[bool], tol: f64) -> Vec<u32> {
    let mut remap: Vec<u32> = (0..pos.len() as u32).collect();
    if tol > 0.0 {
        let mut grid: HashMap<Cell, Vec<u32>> = HashMap::new();
        for (i, p) in pos.iter().enumerate() {
            if !finite[i] {
                continue;
            }
            let c = cell_of(*p, tol);
            let found = neighbours(c).find_map(|nc| {
                grid.get(&nc).and_then(|v| {
                    v.iter()
                        .copied()
                        .find(|&j| len(sub(pos[j as usize], *p)) <= tol)
                })
            });
            match found {
                Some(j) => remap[i] = j,
                None => grid.entry(c).or_default().push(i as u32),
            }
        }
    } else {
        let mut exact: HashMap<[u64; 3], u32> = HashMap::new();
        for (i, p) in pos.iter().enumerate() {
            if finite[i] {
                let key = [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()];
                remap[i] = *exact.entry(key).or_insert(i as u32);
            }
        }
    }
    remap
}

/// Undirected edge (min, max) → list of (triangle, traversed min→max).
fn edge_map(tris: &[[u32; 3]]) -> HashMap<(u32, u32), Vec<(u32, bool)>> {
    let mut m: HashMap<(u32, u32), Vec<(u32, bool)>> = HashMap::with_capacity(tris.len() * 2);
    for (ti, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let key = (a.min(b), a.max(b));
            m.entry(key).or_default().push((ti as u32, a < b));
        }
    }
    m
}

/// Step 4 stops after this many passes even if splitting keeps exposing T-vertices.
const MAX_T_VERTEX_PASSES: usize = 16;

/// Smallest cell of the T-vertex search grid in metres (keeps the cell positive for
/// zero-length edges and a zero tolerance).
const MIN_GRID_CELL_M: f64 = 1e-12;

/// Most sample points along one boundary edge when gathering candidate vertices
/// (bounds the work for an edge that is huge compared with the grid cell).
const MAX_EDGE_STEPS: usize = 1_000_000;

/// Step 4: splits triangles whose boundary edge has vertices lying on it, pass after
/// pass until none is left; returns how many T-vertices were fixed.
fn fix_t_vertices(mesh: &mut IndexedMesh, tol: f64, min_area: f64) -> usize {
    let mut fixed = 0;
    for _pass in 0..MAX_T_VERTEX_PASSES {
        let boundary = boundary_edges(&mesh.triangles);
        if boundary.is_empty() {
            break;
        }
        let Some(grid) = VertexGrid::of_referenced(mesh, &boundary, tol) else {
            break;
        };
        let splits = find_edge_splits(mesh, &boundary, &grid, tol);
        if splits.is_empty() {
            break;
        }
        fixed += split_triangles(mesh, &splits, min_area);
    }
    fixed
}

/// A boundary edge: its vertices (min, max) and the one triangle using it.
struct BoundaryEdge {
    a: u32,
    b: u32,
    triangle: u32,
}

/// Edges used by exactly one triangle.
fn boundary_edges(tris: &[[u32; 3]]) -> Vec<BoundaryEdge> {
    edge_map(tris)
        .iter()
        .filter(|(_, v)| v.len() == 1)
        .map(|(&(a, b), v)| BoundaryEdge {
            a,
            b,
            triangle: v[0].0,
        })
        .collect()
}

/// Referenced vertices bucketed in a uniform grid.
struct VertexGrid {
    /// Cell size in metres.
    cell: f64,
    cells: HashMap<Cell, Vec<u32>>,
}

impl VertexGrid {
    /// A grid of the vertices the triangles refer to, with a cell of about the mean
    /// boundary-edge length (at least four weld tolerances); `None` when that is not
    /// finite.
    fn of_referenced(mesh: &IndexedMesh, boundary: &[BoundaryEdge], tol: f64) -> Option<Self> {
        let pos = &mesh.positions;
        let mean_len = boundary
            .iter()
            .map(|e| len(sub(pos[e.a as usize], pos[e.b as usize])))
            .sum::<f64>()
            / boundary.len() as f64;
        let cell = mean_len.max(tol * 4.0).max(MIN_GRID_CELL_M);
        if !cell.is_finite() {
            return None;
        }
        let mut referenced = vec![false; pos.len()];
        for t in &mesh.triangles {
            for &i in t {
                referenced[i as usize] = true;
            }
        }
        let mut cells: HashMap<Cell, Vec<u32>> = HashMap::new();
        for (i, p) in pos.iter().enumerate() {
            if referenced[i] {
                cells.entry(cell_of(*p, cell)).or_default().push(i as u32);
            }
        }
        Some(Self { cell, cells })
    }

    /// Vertices in the cells along the segment from `pa` over `ab` (length `l`) and
    /// their neighbours, sorted and without repeats.
    fn near_segment(&self, pa: [f64; 3], ab: [f64; 3], l: f64) -> Vec<u32> {
        let steps = ((l / self.cell).ceil() as usize).clamp(1, MAX_EDGE_STEPS);
        let mut cand: Vec<u32> = Vec::new();
        for s in 0..=steps {
            let f = s as f64 / steps as f64;
            let p = [pa[0] + ab[0] * f, pa[1] + ab[1] * f, pa[2] + ab[2] * f];
            for nc in neighbours(cell_of(p, self.cell)) {
                if let Some(v) = self.cells.get(&nc) {
                    cand.extend_from_slice(v);
                }
            }
        }
        cand.sort_unstable();
        cand.dedup();
        cand
    }
}

/// Vertices strictly inside edge (a, b) within `tol`, as (parameter from a, vertex).
fn t_vertices_on_edge(
    pos: &[[f64; 3]],
    grid: &VertexGrid,
    a: u32,
    b: u32,
    tol: f64,
) -> Vec<(f64, u32)> {
    let (pa, pb) = (pos[a as usize], pos[b as usize]);
    let ab = sub(pb, pa);
    let l = len(ab);
    if l.is_nan() || l <= 2.0 * tol {
        return Vec::new();
    }
    let mut on_edge: Vec<(f64, u32)> = Vec::new();
    for v in grid.near_segment(pa, ab, l) {
        if v == a || v == b {
            continue;
        }
        let pv = pos[v as usize];
        let s = dot(sub(pv, pa), ab) / (l * l);
        if s * l <= tol || (1.0 - s) * l <= tol {
            continue;
        }
        let foot = [pa[0] + ab[0] * s, pa[1] + ab[1] * s, pa[2] + ab[2] * s];
        if len(sub(pv, foot)) <= tol {
            on_edge.push((s, v));
        }
    }
    on_edge
}

/// Where one triangle is split.
struct EdgeSplit {
    /// The corner k starting the split edge (k → k+1).
    corner: usize,
    /// The T-vertices on that edge as (parameter from corner k, vertex), in order.
    t_vertices: Vec<(f64, u32)>,
}

/// Per triangle, the first boundary edge found with T-vertices.
fn find_edge_splits(
    mesh: &IndexedMesh,
    boundary: &[BoundaryEdge],
    grid: &VertexGrid,
    tol: f64,
) -> HashMap<u32, EdgeSplit> {
    let mut splits: HashMap<u32, EdgeSplit> = HashMap::new();
    for &BoundaryEdge { a, b, triangle } in boundary {
        let mut on_edge = t_vertices_on_edge(&mesh.positions, grid, a, b, tol);
        if on_edge.is_empty() {
            continue;
        }
        let t = mesh.triangles[triangle as usize];
        let Some(k) = (0..3).find(|&k| {
            let (x, y) = (t[k], t[(k + 1) % 3]);
            (x.min(y), x.max(y)) == (a, b)
        }) else {
            continue;
        };
        // order along the triangle's own direction of the edge
        if t[k] != a {
            for e in &mut on_edge {
                e.0 = 1.0 - e.0;
            }
        }
        on_edge.sort_by(|x, y| x.0.total_cmp(&y.0));
        splits.entry(triangle).or_insert(EdgeSplit {
            corner: k,
            t_vertices: on_edge,
        });
    }
    splits
}

/// Replaces each split triangle by the fan from its opposite corner over the
/// T-vertices (dropping slivers below `min_area`); returns how many T-vertices.
fn split_triangles(
    mesh: &mut IndexedMesh,
    splits: &HashMap<u32, EdgeSplit>,
    min_area: f64,
) -> usize {
    let mut fixed = 0;
    let mut new_tris = Vec::with_capacity(mesh.triangles.len() + splits.len() * 2);
    for (ti, t) in mesh.triangles.iter().enumerate() {
        match splits.get(&(ti as u32)) {
            None => new_tris.push(*t),
            Some(EdgeSplit {
                corner: k,
                t_vertices: verts,
            }) => {
                let (x, y, z) = (t[*k], t[(*k + 1) % 3], t[(*k + 2) % 3]);
                let mut chain = vec![x];
                chain.extend(verts.iter().map(|v| v.1));
                chain.push(y);
                for w in chain.windows(2) {
                    let nt = [w[0], w[1], z];
                    if area_ok(&corners(&mesh.positions, &nt), min_area) {
                        new_tris.push(nt);
                    }
                }
                fixed += verts.len();
            }
        }
    }
    mesh.triangles = new_tris;
    fixed
}

struct Orientation {
    flipped: usize,
    components: usize,
    non_orientable: usize,
}

fn orient(mesh: &mut IndexedMesh) -> Orientation {
    let n = mesh.triangles.len();
    let edges = edge_map(&mesh.triangles);
    // adjacency over manifold edges: (neighbour, same direction on the shared edge)
    let mut adj: Vec<Vec<(u32, bool)>> = vec![Vec::new(); n];
    // connectivity over any shared edge (for the component count)
    let mut uf = UnionFind::new(n);
    for v in edges.values() {
        for w in v.windows(2) {
            uf.union(w[0].0 as usize, w[1].0 as usize);
        }
        if v.len() == 2 && v[0].0 != v[1].0 {
            let same = v[0].1 == v[1].1;
            adj[v[0].0 as usize].push((v[1].0, same));
            adj[v[1].0 as usize].push((v[0].0, same));
        }
    }
    let mut flip: Vec<Option<bool>> = vec![None; n];
    let mut flipped = 0;
    let mut non_orientable_roots = HashSet::new();
    let mut queue = VecDeque::new();
    for seed in 0..n {
        if flip[seed].is_some() {
            continue;
        }
        flip[seed] = Some(false);
        queue.push_back(seed);
        let mut members = vec![seed];
        let mut conflict = false;
        while let Some(t) = queue.pop_front() {
            let ft = flip[t].unwrap_or(false);
            for &(nb, same) in &adj[t] {
                let want = ft ^ same;
                match flip[nb as usize] {
                    None => {
                        flip[nb as usize] = Some(want);
                        members.push(nb as usize);
                        queue.push_back(nb as usize);
                    }
                    Some(f) if f != want => conflict = true,
                    Some(_) => {}
                }
            }
        }
        if conflict {
            non_orientable_roots.insert(uf.find(seed));
        }
        // keep the majority winding of the input
        let to_flip = members.iter().filter(|&&m| flip[m] == Some(true)).count();
        let invert = 2 * to_flip > members.len();
        for &m in &members {
            let f = flip[m].unwrap_or(false) ^ invert;
            if f {
                mesh.triangles[m].swap(1, 2);
                flipped += 1;
            }
        }
    }
    let components: HashSet<usize> = (0..n).map(|i| uf.find(i)).collect();
    Orientation {
        flipped,
        components: components.len(),
        non_orientable: non_orientable_roots.len(),
    }
}

struct UnionFind {
    parent: Vec<usize>,
}

impl UnionFind {
    fn new(n: usize) -> Self {
        Self {
            parent: (0..n).collect(),
        }
    }
    fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] != x {
            self.parent[x] = self.parent[self.parent[x]];
            x = self.parent[x];
        }
        x
    }
    fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            self.parent[ra.max(rb)] = ra.min(rb);
        }
    }
}
