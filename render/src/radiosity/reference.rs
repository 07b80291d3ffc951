//! Brute-force reference: a fine uniform mesh, the dense form-factor matrix (exact
//! point-to-polygon at 2×2 Gauss points of each receiver, 4×4 shadow rays per pair
//! that may be occluded) and Gauss–Seidel to a residual of 1e-9. Quadratic in memory
//! and time: for acceptance comparisons on small scenes only.

use std::sync::atomic::AtomicU64;
use std::time::Instant;

use rayon::prelude::*;

use super::RadiosityError;
use super::curve::{CurvePoint, ErrorCurve, StopReason};
use super::progressive::{direct_light, mesh_ff, patches_from_mesh, uniform_mesh};
use super::solution::{Solution, SolveStats};
use super::visibility::Visibility;
use crate::scene::Scene;

/// Solves `scene` densely on a uniform mesh with edges ≤ `max_edge_m`. Refuses meshes
/// above `max_elements` (the matrix needs 8·n² bytes).
pub fn solve_dense_reference(
    scene: &Scene,
    vis: &dyn Visibility,
    max_edge_m: f64,
    max_elements: usize,
) -> Result<Solution, RadiosityError> {
    let start = Instant::now();
    super::validate(scene, 0.5)?;
    let mesh = uniform_mesh(scene, max_edge_m);
    let n = mesh.len();
    if n > max_elements {
        return Err(RadiosityError::BadOption(format!(
            "reference mesh has {n} elements, more than the allowed {max_elements}; use a larger max edge"
        )));
    }
    let (rays, tested, skipped) = (AtomicU64::new(0), AtomicU64::new(0), AtomicU64::new(0));
    let h_direct = direct_light(scene, vis, &mesh, &rays);
    let rows: Vec<Vec<(u32, f64)>> = mesh
        .par_iter()
        .map(|r| {
            mesh.iter()
                .enumerate()
                .filter_map(|(j, s)| {
                    let f = mesh_ff(vis, r, s, &rays, &tested, &skipped);
                    (f > 0.0).then_some((j as u32, f))
                })
                .collect()
        })
        .collect();
    let rho: Vec<[f64; 3]> = mesh
        .iter()
        .map(|e| scene.material_of(e.polygon).reflectance_xyz)
        .collect();
    let emit: Vec<[f64; 3]> = mesh
        .iter()
        .map(|e| {
            scene
                .material_of(e.polygon)
                .emission_cd_m2
                .map(|l| std::f64::consts::PI * l)
        })
        .collect();
    let mut b: Vec<[f64; 3]> = (0..n)
        .map(|i| std::array::from_fn(|c| emit[i][c] + rho[i][c] * h_direct[i][c]))
        .collect();
    let mut h = h_direct.clone();
    let mut curve = ErrorCurve::default();
    let mut sweeps = 0;
    loop {
        let mut change = 0.0;
        let mut total = 0.0;
        for i in 0..n {
            let mut hi = h_direct[i];
            for &(j, f) in &rows[i] {
                for c in 0..3 {
                    hi[c] += f * b[j as usize][c];
                }
            }
            let new: [f64; 3] = std::array::from_fn(|c| emit[i][c] + rho[i][c] * hi[c]);
            change += mesh[i].area * (new[1] - b[i][1]).abs();
            total += mesh[i].area * new[1];
            b[i] = new;
            h[i] = hi;
        }
        sweeps += 1;
        let rel = if total > 0.0 { change / total } else { 0.0 };
        curve.points.push(CurvePoint {
            time_s: start.elapsed().as_secs_f64(),
            iteration: sweeps,
            estimated_error: rel,
            solve_error: rel,
            discretization_error: 0.0,
            patches: n,
            links: rows.iter().map(Vec::len).sum(),
        });
        if !rel.is_finite() {
            return Err(RadiosityError::Diverged("reference Gauss–Seidel".into()));
        }
        if rel < 1e-9 || sweeps >= 100_000 {
            break;
        }
    }
    let patches = patches_from_mesh(&mesh, &b, &h);
    let by_polygon = Solution::index(&patches, scene.polygons.len());
    let links = rows.iter().map(Vec::len).sum();
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
            shadow_rays: rays.into_inner(),
            visibility_skipped: skipped.into_inner(),
            visibility_tested: tested.into_inner(),
            memory_bytes: links * 12 + n * 200,
            time_s: start.elapsed().as_secs_f64(),
            extrapolations: 0,
            ..SolveStats::default()
        },
    })
}
