//! A solved piecewise-constant radiosity: leaf patches with their luminous exitance,
//! looked up by point (for images, comparisons and per-vertex output).

use crate::scene::V3;

use super::curve::{ErrorCurve, StopReason};
use super::visibility::point_in_convex;

/// One leaf patch of a solution.
#[derive(Debug, Clone, PartialEq)]
pub struct Patch {
    /// Input polygon it lies on.
    pub polygon: usize,
    /// Corner vertices in metres (3 or 4, same winding as the polygon).
    pub vertices: Vec<V3>,
    /// Unit normal.
    pub normal: V3,
    /// Area in m².
    pub area_m2: f64,
    /// Radiosity as XYZ luminous exitance (Y in lm/m²); luminance is this / π.
    pub exitance_xyz: [f64; 3],
    /// Irradiance as XYZ (Y in lux) received by the patch.
    pub irradiance_xyz: [f64; 3],
    /// Exitance at each vertex (XYZ, lm/m²) where the patch uses the linear basis;
    /// empty for constant patches.
    pub vertex_exitance_xyz: Vec<[f64; 3]>,
}

impl Patch {
    /// The solution's exitance (XYZ, lm/m²) at `point` of this patch: the mean for a
    /// constant patch; for a linear one the vertex values interpolated over the
    /// patch's fan triangles (as Gouraud shading shows it).
    pub fn exitance_at(&self, point: &V3) -> [f64; 3] {
        let v = &self.vertices;
        let vals = &self.vertex_exitance_xyz;
        if vals.len() != v.len() || v.len() < 3 {
            return self.exitance_xyz;
        }
        let q = point - self.normal * self.normal.dot(&(point - v[0]));
        let mut best = (f64::NEG_INFINITY, [0.0; 3]);
        for k in 1..v.len() - 1 {
            let (a, b, c) = (v[0], v[k], v[k + 1]);
            let area = (b - a).cross(&(c - a)).dot(&self.normal);
            if area.abs() <= 1e-300 {
                continue;
            }
            let l1 = (c - b).cross(&(q - b)).dot(&self.normal) / area;
            let l2 = (a - c).cross(&(q - c)).dot(&self.normal) / area;
            let l3 = 1.0 - l1 - l2;
            // the triangle the point is in (largest smallest coordinate)
            let inside = l1.min(l2).min(l3);
            if inside > best.0 {
                let w = [l1.max(0.0), l2.max(0.0), l3.max(0.0)];
                let sw = (w[0] + w[1] + w[2]).max(1e-300);
                best = (
                    inside,
                    std::array::from_fn(|ch| {
                        (w[0] * vals[0][ch] + w[1] * vals[k][ch] + w[2] * vals[k + 1][ch]) / sw
                    }),
                );
            }
        }
        if best.0.is_finite() {
            best.1
        } else {
            self.exitance_xyz
        }
    }
}

/// Counters of a solve.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct SolveStats {
    /// Leaf patches.
    pub patches: usize,
    /// All elements of the hierarchy (or mesh).
    pub elements: usize,
    /// Links (hierarchical) or form factors evaluated (progressive).
    pub links: usize,
    /// Gather sweeps or shots.
    pub iterations: usize,
    /// Shadow rays cast.
    pub shadow_rays: u64,
    /// Links/pairs that skipped all visibility work (classified fully visible).
    pub visibility_skipped: u64,
    /// Links/pairs that needed shadow rays.
    pub visibility_tested: u64,
    /// Approximate memory of the solver's data structures in bytes.
    pub memory_bytes: usize,
    /// Wall time in seconds.
    pub time_s: f64,
    /// Extrapolation steps applied (geometric-series acceleration).
    pub extrapolations: usize,
    /// Clusters of the hierarchy (0 for solvers without clustering).
    pub clusters: usize,
    /// Links whose receiver is a cluster.
    pub cluster_links: usize,
    /// Leaves represented with the linear basis.
    pub linear_patches: usize,
    /// Share of the surface area inside closed solids, by the quadrature points of the
    /// leaves (hierarchical solver; 0 for the others): it receives and sends no light.
    /// The floor under furniture; most of the scene when surfaces face away from the
    /// room.
    pub enclosed_area_share: f64,
}

/// The result of a solve.
#[derive(Debug, Clone)]
pub struct Solution {
    /// Leaf patches.
    pub patches: Vec<Patch>,
    /// For each input polygon, the indices of its patches.
    pub by_polygon: Vec<Vec<usize>>,
    /// Error against time.
    pub curve: ErrorCurve,
    /// Why it stopped.
    pub stop: StopReason,
    /// Counters.
    pub stats: SolveStats,
}

impl Solution {
    /// Builds the per-polygon index.
    pub fn index(patches: &[Patch], polygons: usize) -> Vec<Vec<usize>> {
        let mut by = vec![Vec::new(); polygons];
        for (i, p) in patches.iter().enumerate() {
            if let Some(v) = by.get_mut(p.polygon) {
                v.push(i);
            }
        }
        by
    }

    /// The patch of polygon `polygon` that contains `point` (projected into its plane);
    /// the nearest patch centre if none contains it (points on the boundary).
    pub fn patch_at(&self, polygon: usize, point: &V3) -> Option<&Patch> {
        let list = self.by_polygon.get(polygon)?;
        let mut best: Option<(f64, usize)> = None;
        for &i in list {
            let p = &self.patches[i];
            let q = point - p.normal * p.normal.dot(&(point - p.vertices[0]));
            if point_in_convex(&p.vertices, &p.normal, &q) {
                return Some(p);
            }
            let c = p.vertices.iter().sum::<V3>() / p.vertices.len() as f64;
            let d = (c - q).norm_squared();
            if best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, i));
            }
        }
        best.map(|(_, i)| &self.patches[i])
    }

    /// Total area of all patches in m².
    pub fn total_area_m2(&self) -> f64 {
        self.patches.iter().map(|p| p.area_m2).sum()
    }

    /// Σ A·E_Y over every patch: the luminous flux the surfaces receive (lm).
    pub fn received_flux_lm(&self) -> f64 {
        self.patches
            .iter()
            .map(|p| p.area_m2 * p.irradiance_xyz[1])
            .sum()
    }

    /// Area-weighted relative L1 difference in Y between `self` and `reference`,
    /// sampled at the reference's patch centres: Σ A |B − B_ref| / Σ A B_ref, with
    /// `self` evaluated by its representation ([`Patch::exitance_at`]).
    pub fn relative_error_against(&self, reference: &Solution) -> f64 {
        let mut num = 0.0;
        let mut den = 0.0;
        for r in &reference.patches {
            let c = r.vertices.iter().sum::<V3>() / r.vertices.len() as f64;
            let b = self
                .patch_at(r.polygon, &c)
                .map(|p| p.exitance_at(&c)[1])
                .unwrap_or(0.0);
            num += r.area_m2 * (b - r.exitance_xyz[1]).abs();
            den += r.area_m2 * r.exitance_xyz[1];
        }
        if den > 0.0 { num / den } else { 0.0 }
    }
}
