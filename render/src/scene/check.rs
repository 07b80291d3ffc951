//! Input checks on polygons: non-finite coordinates, degenerate faces, non-planar or
//! non-convex quads and larger polygons. Problems are repaired (split, dropped) and
//! counted, never fatal. Topology checks (T-vertices, non-manifold edges, normal
//! consistency) belong to `mesh::check_and_repair`.

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
}

impl CheckReport {
    /// One line for logs and the CLI.
    pub fn summary(&self) -> String {
        format!(
            "{} polygons in, {} out; dropped {} non-finite, {} degenerate; split {} quads; triangulated {} n-gons",
            self.input_polygons,
            self.output_polygons,
            self.dropped_non_finite,
            self.dropped_degenerate,
            self.split_quads,
            self.triangulated_ngons
        )
    }
}

fn degenerate(v: &[V3]) -> bool {
    let mut longest: f64 = 0.0;
    for i in 0..v.len() {
        longest = longest.max((v[(i + 1) % v.len()] - v[i]).norm_squared());
    }
    longest <= 0.0 || polygon_area_m2(v) <= 1e-10 * longest
}

fn quad_ok(v: &[V3]) -> bool {
    let n = newell(v);
    let len = n.norm();
    if len <= 0.0 {
        return false;
    }
    let n = n / len;
    let scale = (v[2] - v[0]).norm().max((v[3] - v[1]).norm());
    // planar to 1e-6 of the diagonal and convex (all corner turns agree with n)
    let planar = v.iter().all(|p| (p - v[0]).dot(&n).abs() <= 1e-6 * scale);
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
    report.output_polygons = out.len();
    (out, report)
}
