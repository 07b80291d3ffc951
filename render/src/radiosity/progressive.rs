//! Progressive refinement radiosity (Cohen et al. 1988; Southwell iteration): a fixed
//! uniform mesh, repeatedly shooting the unshot radiosity of the element with the
//! largest unshot flux. Form factors are evaluated on the fly (exact point-to-polygon
//! at the receiver's 2×2 Gauss points, shadow rays only where the visibility
//! classification says an occluder may intervene). The error estimate is the unshot
//! flux, amplified by the mean reflectance's geometric series, relative to the total.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use crate::scene::{Scene, V3, polygon_area_m2, polygon_normal};

use super::RadiosityError;
use super::curve::{CurvePoint, ErrorCurve, StopReason, StopRule};
use super::form_factor::point_to_polygon;
use super::quadrature;
use super::solution::{Patch, Solution, SolveStats};
use super::visibility::Visibility;

/// Options of the progressive solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProgressiveOptions {
    /// Stop rule (target relative error of the solve, time, shots).
    pub stop: StopRule,
    /// Longest element edge in metres of the uniform mesh.
    pub max_edge_m: f64,
}

impl Default for ProgressiveOptions {
    fn default() -> Self {
        Self {
            stop: StopRule::default(),
            max_edge_m: 0.05,
        }
    }
}

/// An element of a uniform mesh.
#[derive(Debug, Clone)]
pub(crate) struct MeshElem {
    pub verts: Vec<V3>,
    pub normal: V3,
    pub area: f64,
    pub polygon: usize,
    pub points: Vec<(V3, f64)>,
}

/// Subdivides every polygon (midpoint quadtree) until its longest edge is at most
/// `max_edge_m`.
pub(crate) fn uniform_mesh(scene: &Scene, max_edge_m: f64) -> Vec<MeshElem> {
    let mut out = Vec::new();
    for (pi, p) in scene.polygons.iter().enumerate() {
        let longest = (0..p.vertices.len())
            .map(|i| (p.vertices[(i + 1) % p.vertices.len()] - p.vertices[i]).norm())
            .fold(0.0, f64::max);
        let mut level = 0;
        while longest / f64::from(1u32 << level) > max_edge_m && level < 10 {
            level += 1;
        }
        let mut cells = vec![p.vertices.clone()];
        for _ in 0..level {
            cells = cells.iter().flat_map(|c| quadrature::split4(c)).collect();
        }
        for verts in cells {
            let mut points = Vec::new();
            quadrature::points(&verts, 2, &mut points);
            out.push(MeshElem {
                normal: polygon_normal(&verts).unwrap_or_else(V3::z),
                area: polygon_area_m2(&verts),
                polygon: pi,
                points,
                verts,
            });
        }
    }
    out
}

pub(crate) fn facing(a: &MeshElem, b: &MeshElem) -> bool {
    let s = (a.area + b.area).sqrt() * 1e-9;
    a.polygon != b.polygon
        && b.verts.iter().any(|v| a.normal.dot(&(v - a.verts[0])) > s)
        && a.verts.iter().any(|v| b.normal.dot(&(v - b.verts[0])) > s)
}

/// Direct illuminance (XYZ lux) of every element from the scene's point lights and
/// daylight, with shadow rays where needed.
pub(crate) fn direct_light(
    scene: &Scene,
    vis: &dyn Visibility,
    mesh: &[MeshElem],
    rays: &AtomicU64,
) -> Vec<[f64; 3]> {
    let far = 4.0 * scene_extent(scene) + 1.0;
    mesh.par_iter()
        .map(|e| {
            let mut h = [0.0; 3];
            for l in &scene.lights {
                let candidate = vis.may_occlude(&[l.position], usize::MAX, &e.verts, e.polygon);
                let mut irr = 0.0;
                for (x, w) in &e.points {
                    let d = l.position - x;
                    let d2 = d.norm_squared();
                    let dn = d / d2.sqrt();
                    let cos_r = e.normal.dot(&dn);
                    if cos_r <= 0.0 || d2 <= 0.0 {
                        continue;
                    }
                    if candidate {
                        rays.fetch_add(1, Ordering::Relaxed);
                        if vis.occluded(&l.position, x, [usize::MAX, e.polygon]) {
                            continue;
                        }
                    }
                    irr += w * l.intensity_cd(&(-dn)) * cos_r / d2;
                }
                for (c, v) in h.iter_mut().enumerate() {
                    *v += irr * l.color_xyz[c];
                }
            }
            if let Some(d) = &scene.sky {
                // distant sources: shadow rays to a point beyond the scene
                for src in d.sources() {
                    let u = src.direction.normalize();
                    let cos = e.normal.dot(&u);
                    if cos <= 0.0 {
                        continue;
                    }
                    let ends: Vec<V3> = e.verts.iter().map(|v| v + u * far).collect();
                    let candidate = vis.may_occlude(&e.verts, e.polygon, &ends, usize::MAX);
                    let mut seen = 0.0;
                    for (x, w) in &e.points {
                        if candidate {
                            rays.fetch_add(1, Ordering::Relaxed);
                            if vis.occluded(x, &(x + u * far), [usize::MAX, e.polygon]) {
                                continue;
                            }
                        }
                        seen += w;
                    }
                    let irr = src.normal_illuminance_lux * cos * seen;
                    for (c, v) in h.iter_mut().enumerate() {
                        *v += irr * src.color_xyz[c];
                    }
                }
            }
            h
        })
        .collect()
}

/// Diagonal of the scene's bounding box in metres.
pub(crate) fn scene_extent(scene: &Scene) -> f64 {
    let mut lo = V3::repeat(f64::INFINITY);
    let mut hi = V3::repeat(f64::NEG_INFINITY);
    for p in &scene.polygons {
        for v in &p.vertices {
            lo = lo.inf(v);
            hi = hi.sup(v);
        }
    }
    (hi - lo).norm()
}

/// Form factor from receiver `r` to source `s` (area average over r's Gauss points,
/// shadow rays from each point to s's centre and Gauss points when classified
/// possibly occluded).
pub(crate) fn mesh_ff(
    vis: &dyn Visibility,
    r: &MeshElem,
    s: &MeshElem,
    rays: &AtomicU64,
    tested: &AtomicU64,
    skipped: &AtomicU64,
) -> f64 {
    if !facing(r, s) {
        return 0.0;
    }
    let candidate = vis.may_occlude(&r.verts, r.polygon, &s.verts, s.polygon);
    if candidate {
        tested.fetch_add(1, Ordering::Relaxed);
    } else {
        skipped.fetch_add(1, Ordering::Relaxed);
    }
    let mut f = 0.0;
    for (x, w) in &r.points {
        let fp = point_to_polygon(x, &r.normal, &s.verts, &s.normal);
        if fp <= 0.0 {
            continue;
        }
        let v = if candidate {
            let mut seen = 0usize;
            for (y, _) in &s.points {
                if !vis.occluded(x, y, [r.polygon, s.polygon]) {
                    seen += 1;
                }
            }
            rays.fetch_add(s.points.len() as u64, Ordering::Relaxed);
            seen as f64 / s.points.len() as f64
        } else {
            1.0
        };
        f += w * fp * v;
    }
    f
}

pub(crate) fn patches_from_mesh(mesh: &[MeshElem], b: &[[f64; 3]], h: &[[f64; 3]]) -> Vec<Patch> {
    mesh.iter()
        .zip(b.iter().zip(h))
        .map(|(e, (b, h))| Patch {
            polygon: e.polygon,
            vertices: e.verts.clone(),
            normal: e.normal,
            area_m2: e.area,
            exitance_xyz: *b,
            irradiance_xyz: *h,
            vertex_exitance_xyz: Vec::new(),
        })
        .collect()
}

/// Solves a scene by progressive refinement (shooting) on a uniform mesh.
pub fn solve_progressive(
    scene: &Scene,
    vis: &dyn Visibility,
    opts: &ProgressiveOptions,
) -> Result<Solution, RadiosityError> {
    let start = Instant::now();
    super::validate(scene, opts.stop.target_error)?;
    if !(opts.max_edge_m.is_finite() && opts.max_edge_m > 0.0) {
        return Err(RadiosityError::BadOption(format!(
            "max edge {} m must be positive",
            opts.max_edge_m
        )));
    }
    let deadline = opts.stop.time_limit.map(|t| start + t);
    let mesh = uniform_mesh(scene, opts.max_edge_m);
    let n = mesh.len();
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
    let (rays, tested, skipped) = (AtomicU64::new(0), AtomicU64::new(0), AtomicU64::new(0));
    let mut h = direct_light(scene, vis, &mesh, &rays);
    let mut b: Vec<[f64; 3]> = (0..n)
        .map(|i| std::array::from_fn(|c| emit[i][c] + rho[i][c] * h[i][c]))
        .collect();
    let mut unshot = b.clone();
    let total_area: f64 = mesh.iter().map(|e| e.area).sum();
    let rho_mean = mesh
        .iter()
        .zip(&rho)
        .map(|(e, r)| e.area * r[1])
        .sum::<f64>()
        / total_area;
    let mut curve = ErrorCurve::default();
    let mut shots = 0usize;
    let mut ff_evals = 0usize;
    let mut last_report = f64::NEG_INFINITY;
    let stop;
    loop {
        let flux_total: f64 = mesh.iter().zip(&b).map(|(e, b)| e.area * b[1]).sum();
        let (j, flux_unshot_max) = mesh
            .iter()
            .zip(&unshot)
            .enumerate()
            .map(|(i, (e, u))| (i, e.area * u[1]))
            .fold((0, f64::NEG_INFINITY), |a, x| if x.1 > a.1 { x } else { a });
        let flux_unshot: f64 = mesh.iter().zip(&unshot).map(|(e, u)| e.area * u[1]).sum();
        let err = if flux_total > 0.0 {
            flux_unshot * rho_mean / (1.0 - rho_mean).max(1e-9) / flux_total
        } else {
            0.0
        };
        let now = start.elapsed().as_secs_f64();
        let done = err <= opts.stop.target_error;
        let timeout = deadline.is_some_and(|d| Instant::now() > d);
        let capped = shots >= opts.stop.max_iterations;
        if done || timeout || capped || now - last_report > 0.05 || shots < 10 {
            last_report = now;
            curve.points.push(CurvePoint {
                time_s: now,
                iteration: shots,
                estimated_error: err,
                solve_error: err,
                discretization_error: 0.0,
                patches: n,
                links: ff_evals,
            });
        }
        if !err.is_finite() {
            return Err(RadiosityError::Diverged(format!(
                "unshot flux became {flux_unshot}"
            )));
        }
        if done || flux_unshot_max <= 0.0 {
            stop = StopReason::Converged;
            break;
        }
        if timeout {
            stop = StopReason::TimeLimit;
            break;
        }
        if capped {
            stop = StopReason::IterationLimit;
            break;
        }
        let shooter = &mesh[j];
        let db = unshot[j];
        unshot[j] = [0.0; 3];
        let gains: Vec<f64> = mesh
            .par_iter()
            .map(|r| mesh_ff(vis, r, shooter, &rays, &tested, &skipped))
            .collect();
        ff_evals += n;
        for i in 0..n {
            let f = gains[i];
            if f <= 0.0 {
                continue;
            }
            for c in 0..3 {
                let dh = f * db[c];
                h[i][c] += dh;
                b[i][c] += rho[i][c] * dh;
                unshot[i][c] += rho[i][c] * dh;
            }
        }
        shots += 1;
    }
    let patches = patches_from_mesh(&mesh, &b, &h);
    let by_polygon = super::Solution::index(&patches, scene.polygons.len());
    let stats = SolveStats {
        patches: n,
        elements: n,
        links: ff_evals,
        iterations: shots,
        shadow_rays: rays.load(Ordering::Relaxed),
        visibility_skipped: skipped.load(Ordering::Relaxed),
        visibility_tested: tested.load(Ordering::Relaxed),
        memory_bytes: n
            * (std::mem::size_of::<MeshElem>() + 8 * std::mem::size_of::<V3>() + 5 * 24),
        time_s: start.elapsed().as_secs_f64(),
        extrapolations: 0,
        ..SolveStats::default()
    };
    Ok(Solution {
        patches,
        by_polygon,
        curve,
        stop,
        stats,
    })
}
