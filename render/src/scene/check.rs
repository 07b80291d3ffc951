//! Input checks on polygons: non-finite coordinates, degenerate faces, non-planar or
//! non-convex quads and larger polygons; then, per object, topology (Kresse 2.2.6:
//! T-vertices, duplicate faces, inconsistent windings, non-manifold edges) through
//! `mesh::check_and_repair`. Problems are repaired (split, dropped, flipped) or
//! reported, and counted, never fatal.

use super::geom::{V3, newell, polygon_area_m2};
use super::types::Polygon;

/// What the checks found and did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct CheckReport {
    /// Polygons given to the checks.
    pub input_polygons: usize,
    /// Polygons after the checks.
    pub output_polygons: usize,
    /// Dropped: a coordinate was NaN or infinite.
    pub dropped_non_finite: usize,
    /// Dropped: area (relative to the squared longest edge) below 1e-10, or fewer than
    /// three distinct vertices.
    pub dropped_degenerate: usize,
    /// Quads split into two triangles because they were not planar or not convex.
    pub split_quads: usize,
    /// Polygons with more than four vertices fan-triangulated.
    pub triangulated_ngons: usize,
    /// T-vertices (a vertex inside a neighbour's edge) fixed by splitting.
    pub t_vertices_fixed: usize,
    /// Triangles (of the object's triangulation) whose winding was reversed to agree
    /// with their neighbours.
    pub triangles_flipped: usize,
    /// Faces removed as duplicates of another face of the same object.
    pub duplicate_faces_removed: usize,
    /// Edges shared by more than two faces of one object (reported, not changed).
    pub non_manifold_edges: usize,
    /// Objects whose faces were replaced by the repaired triangles.
    pub objects_repaired: usize,
}

impl CheckReport {
    /// One line for logs and the CLI.
    pub fn summary(&self) -> String {
        format!(
            "{} polygons in, {} out; dropped {} non-finite, {} degenerate; split {} quads; triangulated {} n-gons; topology: {} T-vertices fixed, {} triangles flipped, {} duplicates removed, {} non-manifold edges ({} objects repaired)",
            self.input_polygons,
            self.output_polygons,
            self.dropped_non_finite,
            self.dropped_degenerate,
            self.split_quads,
            self.triangulated_ngons,
            self.t_vertices_fixed,
            self.triangles_flipped,
            self.duplicate_faces_removed,
            self.non_manifold_edges,
            self.objects_repaired
        )
    }
}

/// A polygon is degenerate when its area is at most this fraction of its squared
/// longest edge (a sliver or a collapsed face).
const DEGENERATE_AREA_RATIO: f64 = 1e-10;

/// A quad is planar when every vertex lies within this fraction of its longer
/// diagonal from the plane through the first vertex.
const QUAD_PLANARITY_TOLERANCE: f64 = 1e-6;

fn degenerate(v: &[V3]) -> bool {
    let mut longest: f64 = 0.0;
    for i in 0..v.len() {
        longest = longest.max((v[(i + 1) % v.len()] - v[i]).norm_squared());
    }
    longest <= 0.0 || polygon_area_m2(v) <= DEGENERATE_AREA_RATIO * longest
}

fn quad_ok(v: &[V3]) -> bool {
    let n = newell(v);
    let len = n.norm();
    if len <= 0.0 {
        return false;
    }
    let n = n / len;
    let scale = (v[2] - v[0]).norm().max((v[3] - v[1]).norm());
    // planar and convex (all corner turns agree with n)
    let planar = v
        .iter()
        .all(|p| (p - v[0]).dot(&n).abs() <= QUAD_PLANARITY_TOLERANCE * scale);
    let convex = (0..4).all(|i| {
        let a = v[(i + 1) % 4] - v[i];
        let b = v[(i + 2) % 4] - v[(i + 1) % 4];
        a.cross(&b).dot(&n) > 0.0
    });
    planar && convex
}

/// Checks and repairs polygons; returns the usable ones and what was done.
pub fn check_polygons(input: Vec<Polygon>) -> (Vec<Polygon>, CheckReport) {
    let mut report = CheckReport {
        input_polygons: input.len(),
        ..CheckReport::default()
    };
    let mut out = Vec::with_capacity(input.len());
    for mut p in input {
        if p.vertices.iter().any(|v| !v.iter().all(|c| c.is_finite())) {
            report.dropped_non_finite += 1;
            continue;
        }
        // remove consecutive duplicate vertices
        let mut verts: Vec<V3> = Vec::with_capacity(p.vertices.len());
        for v in &p.vertices {
            if verts.last().is_none_or(|l| l != v) {
                verts.push(*v);
            }
        }
        while verts.len() > 1 && verts.first() == verts.last() {
            verts.pop();
        }
        if verts.len() < 3 {
            report.dropped_degenerate += 1;
            continue;
        }
        let mut pieces: Vec<Vec<V3>> = Vec::new();
        match verts.len() {
            3 => pieces.push(verts),
            4 => {
                if quad_ok(&verts) {
                    pieces.push(verts);
                } else {
                    report.split_quads += 1;
                    pieces.push(vec![verts[0], verts[1], verts[2]]);
                    pieces.push(vec![verts[0], verts[2], verts[3]]);
                }
            }
            n => {
                report.triangulated_ngons += 1;
                for i in 1..n - 1 {
                    pieces.push(vec![verts[0], verts[i], verts[i + 1]]);
                }
            }
        }
        for piece in pieces {
            if degenerate(&piece) {
                report.dropped_degenerate += 1;
                continue;
            }
            p.vertices = piece;
            out.push(p.clone());
        }
    }
    let out = check_topology(out, &mut report);
    report.output_polygons = out.len();
    (out, report)
}

/// Topology per object (faces with the same object name and material): the
/// object's faces as one triangle mesh through [`crate::mesh::check_and_repair`].
/// An object that needs no repair keeps its polygons (quads stay quads); one with
/// T-vertices, duplicates or flipped faces is replaced by the repaired triangles.
fn check_topology(polygons: Vec<Polygon>, report: &mut CheckReport) -> Vec<Polygon> {
    let mut out = Vec::new();
    for group in group_by_object_and_layer(polygons) {
        if group.faces.len() < 2 {
            out.extend(group.faces);
            continue;
        }
        repair_group(group, report, &mut out);
    }
    out
}

/// Faces of one object with one material, in one layer (see
/// [`group_by_object_and_layer`]).
struct FaceGroup {
    object: String,
    material: usize,
    faces: Vec<Polygon>,
}

/// Groups faces by object, material and layer, in order of first appearance.
///
/// A face with the same corners as an earlier one but the opposite winding is a
/// deliberate back face (a two-sided sheet of one-sided polygons): it goes into a
/// layer of its own, so that neither is dropped as a duplicate nor flipped.
fn group_by_object_and_layer(polygons: Vec<Polygon>) -> Vec<FaceGroup> {
    use std::collections::HashMap;
    type Key = (String, usize, usize);
    let mut groups: Vec<FaceGroup> = Vec::new();
    let mut index: HashMap<Key, usize> = HashMap::new();
    let mut seen: HashMap<(String, usize, Vec<[u64; 3]>), V3> = HashMap::new();
    for p in polygons {
        let mut corners: Vec<[u64; 3]> = p
            .vertices
            .iter()
            .map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
            .collect();
        corners.sort_unstable();
        let n = newell(&p.vertices);
        let sig = (p.object.clone(), p.material, corners);
        let layer = match seen.get(&sig) {
            Some(first) if first.dot(&n) < 0.0 => 1,
            Some(_) => 0,
            None => {
                seen.insert(sig, n);
                0
            }
        };
        let key = (p.object.clone(), p.material, layer);
        let g = *index.entry(key).or_insert_with(|| {
            groups.push(FaceGroup {
                object: p.object.clone(),
                material: p.material,
                faces: Vec::new(),
            });
            groups.len() - 1
        });
        groups[g].faces.push(p);
    }
    groups
}

/// Runs the mesh repair on one group's faces and appends the result to `out`: the
/// faces unchanged when nothing needed repair, else the repaired triangles.
fn repair_group(group: FaceGroup, report: &mut CheckReport, out: &mut Vec<Polygon>) {
    use crate::mesh::{IndexedMesh, check_and_repair};
    let mut mesh = IndexedMesh {
        positions: Vec::new(),
        triangles: Vec::new(),
    };
    for f in &group.faces {
        let base = mesh.positions.len() as u32;
        mesh.positions
            .extend(f.vertices.iter().map(|v| [v.x, v.y, v.z]));
        for k in 1..f.vertices.len().saturating_sub(1) as u32 {
            mesh.triangles.push([base, base + k, base + k + 1]);
        }
    }
    let r = check_and_repair(&mut mesh);
    report.non_manifold_edges += r.non_manifold_edges;
    let changed = r.t_vertices_fixed + r.triangles_flipped + r.duplicate_triangles_removed > 0;
    if !changed {
        out.extend(group.faces);
        return;
    }
    report.t_vertices_fixed += r.t_vertices_fixed;
    report.triangles_flipped += r.triangles_flipped;
    report.duplicate_faces_removed += r.duplicate_triangles_removed;
    report.objects_repaired += 1;
    for t in 0..mesh.triangles.len() {
        let Some(tri) = mesh.triangle_positions(t) else {
            continue;
        };
        let vertices: Vec<V3> = tri.iter().map(|c| V3::new(c[0], c[1], c[2])).collect();
        if degenerate(&vertices) {
            report.dropped_degenerate += 1;
            continue;
        }
        out.push(Polygon {
            vertices,
            material: group.material,
            object: group.object.clone(),
        });
    }
}
