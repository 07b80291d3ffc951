//! Brute-force reference: a fine uniform mesh, the dense form-factor matrix (exact
//! point-to-polygon at 2×2 Gauss points of each receiver, 4×4 shadow rays per pair
//! that may be occluded) and Gauss–Seidel to a residual of 1e-9. Quadratic in memory
//! and time: for acceptance comparisons on small scenes only.

use std::time::Instant;

use rayon::prelude::*;

use super::RadiosityError;
use super::curve::{CurvePoint, ErrorCurve, StopReason};
use super::progressive::{
    MeshElem, MeshMaterials, RayCounters, direct_light, mesh_ff, patches_from_mesh, uniform_mesh,
};
use super::solution::{Solution, SolveStats};
use super::visibility::Visibility;
use crate::scene::Scene;

/// Gauss–Seidel stops when the relative change of a sweep falls below this.
const CONVERGED_CHANGE: f64 = 1e-9;
/// Gauss–Seidel gives up after this many sweeps.
const MAX_SWEEPS: usize = 100_000;
/// Validation target passed for the reference, which has no target error of its own.
const NOMINAL_TARGET: f64 = 0.5;

/// Solves `scene` densely on a uniform mesh with edges ≤ `max_edge_m`. Refuses meshes
/// above `max_elements` (the matrix needs 8·n² bytes).
pub fn solve_dense_reference(
    scene: &Scene,
    vis: &dyn Visibility,
    max_edge_m: f64,
    max_elements: usize,
) -> Result<Solution, RadiosityError> {
    let start = Instant::now();
    super::validate(scene, NOMINAL_TARGET)?;
    let mesh = uniform_mesh(scene, max_edge_m, max_elements as u64)?;
    let n = mesh.len();
    let counters = RayCounters::default();
    let direct = direct_light(scene, vis, &mesh, &counters.rays);
    let rows = form_factor_rows(vis, &mesh, &counters);
    let materials = MeshMaterials::of(scene, &mesh);
    let mut gs = GaussSeidel {
        mesh: &mesh,
        rows: &rows,
        materials: &materials,
        direct: &direct,
        exitance: (0..n).map(|i| materials.exitance(i, &direct[i])).collect(),
        irradiance: direct.clone(),
    };
    let links = rows.iter().map(Vec::len).sum();
    let mut curve = ErrorCurve::default();
    let mut sweeps = 0;
    loop {
        let rel = gs.sweep();
        sweeps += 1;
        curve.points.push(CurvePoint {
            time_s: start.elapsed().as_secs_f64(),
            iteration: sweeps,
            estimated_error: rel,
            solve_error: rel,
            discretization_error: 0.0,
            patches: n,
            links,
        });
        if !rel.is_finite() {
            return Err(RadiosityError::Diverged("reference Gauss–Seidel".into()));
        }
        if rel < CONVERGED_CHANGE || sweeps >= MAX_SWEEPS {
            break;
        }
    }
    let patches = patches_from_mesh(&mesh, &gs.exitance, &gs.irradiance);
    let by_polygon = Solution::index(&patches, scene.polygons.len());
    Ok(Solution {
        patches,
        by_polygon,
        curve,
        stop: StopReason::Converged,
        stats: SolveStats {
            patches: n,
            elements: n,
            links,
            iterations: sweeps,
            shadow_rays: counters.rays.into_inner(),
            visibility_skipped: counters.skipped.into_inner(),
            visibility_tested: counters.tested.into_inner(),
            memory_bytes: links * 12 + n * 200,
            time_s: start.elapsed().as_secs_f64(),
            extrapolations: 0,
            ..SolveStats::default()
        },
    })
}

/// The dense form-factor matrix, one sparse row (source, factor) per receiver.
fn form_factor_rows(
    vis: &dyn Visibility,
    mesh: &[MeshElem],
    counters: &RayCounters,
) -> Vec<Vec<(u32, f64)>> {
    mesh.par_iter()
        .map(|r| {
            mesh.iter()
                .enumerate()
                .filter_map(|(j, s)| {
                    let f = mesh_ff(vis, r, s, counters);
                    (f > 0.0).then_some((j as u32, f))
                })
                .collect()
        })
        .collect()
}

/// Gauss–Seidel iteration of B = E + ρ·(H_direct + F·B).
struct GaussSeidel<'a> {
    mesh: &'a [MeshElem],
    rows: &'a [Vec<(u32, f64)>],
    materials: &'a MeshMaterials,
    direct: &'a [[f64; 3]],
    exitance: Vec<[f64; 3]>,
    irradiance: Vec<[f64; 3]>,
}

impl GaussSeidel<'_> {
    /// One sweep in place; returns the area-weighted relative change of Y.
    fn sweep(&mut self) -> f64 {
        let mut change = 0.0;
        let mut total = 0.0;
        for i in 0..self.mesh.len() {
            let mut gathered = self.direct[i];
            for &(j, f) in &self.rows[i] {
                for (g, b) in gathered.iter_mut().zip(&self.exitance[j as usize]) {
                    *g += f * b;
                }
            }
            let new = self.materials.exitance(i, &gathered);
            change += self.mesh[i].area * (new[1] - self.exitance[i][1]).abs();
            total += self.mesh[i].area * new[1];
            self.exitance[i] = new;
            self.irradiance[i] = gathered;
        }
        if total > 0.0 { change / total } else { 0.0 }
    }
}
