//! Progressive refinement radiosity (Cohen et al. 1988; Southwell iteration): a fixed
//! uniform mesh, repeatedly shooting the unshot radiosity of the element with the
//! largest unshot flux. Form factors are evaluated on the fly (exact point-to-polygon
//! at the receiver's 2×2 Gauss points, shadow rays only where the visibility
//! classification says an occluder may intervene). The error estimate is the unshot
//! flux, amplified by the mean reflectance's geometric series, relative to the total.

use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::scene::{Scene, V3, polygon_area_m2, polygon_normal};

pub(crate) use super::RayCounters;
use super::curve::{ShotCurve, StopReason, StopRule};
use super::form_factor::{point_to_polygon, targets_in_front};
use super::quadrature;
use super::solution::{Patch, Solution, SolveStats};
use super::visibility::Visibility;
use super::{RadiosityError, SolveClock};

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

/// Most elements a uniform mesh may have (about 0.5 GB of elements with their
/// quadrature points, before any form factor).
pub const MAX_UNIFORM_ELEMENTS: u64 = 1 << 20;

/// Deepest midpoint subdivision of one polygon (4¹⁰ cells).
const MAX_SUBDIVISION_LEVEL: u32 = 10;

/// The subdivision level of each polygon for `max_edge_m`.
fn subdivision_levels(scene: &Scene, max_edge_m: f64) -> Vec<u32> {
    scene
        .polygons
        .iter()
        .map(|p| {
            let longest = (0..p.vertices.len())
                .map(|i| (p.vertices[(i + 1) % p.vertices.len()] - p.vertices[i]).norm())
                .fold(0.0, f64::max);
            let mut level = 0;
            while longest / f64::from(1u32 << level) > max_edge_m && level < MAX_SUBDIVISION_LEVEL {
                level += 1;
            }
            level
        })
        .collect()
}

/// Subdivides every polygon (midpoint quadtree) until its longest edge is at most
/// `max_edge_m`. The element count is computed first and refused above
/// `max_elements` (at most [`MAX_UNIFORM_ELEMENTS`]) before anything is allocated.
pub(crate) fn uniform_mesh(
    scene: &Scene,
    max_edge_m: f64,
    max_elements: u64,
) -> Result<Vec<MeshElem>, RadiosityError> {
    let levels = subdivision_levels(scene, max_edge_m);
    let count: u64 = levels.iter().map(|l| 1u64 << (2 * l)).sum();
    let limit = max_elements.min(MAX_UNIFORM_ELEMENTS);
    if count > limit {
        return Err(RadiosityError::BadOption(format!(
            "a max edge of {max_edge_m} m cuts this scene into {count} elements, more than \
             the {limit} allowed; give a larger max edge (--max-edge-m)"
        )));
    }
    let mut out = Vec::with_capacity(count as usize);
    for ((pi, p), level) in scene.polygons.iter().enumerate().zip(levels) {
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
    Ok(out)
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

/// Reflectance and emitted exitance (π·L, lm/m²) of every element of a uniform mesh.
pub(crate) struct MeshMaterials {
    /// Reflectance per element (XYZ).
    pub(crate) rho: Vec<[f64; 3]>,
    /// Emitted exitance per element (XYZ lm/m²).
    pub(crate) emit: Vec<[f64; 3]>,
}

impl MeshMaterials {
    /// Looks up the material of each element's polygon.
    pub(crate) fn of(scene: &Scene, mesh: &[MeshElem]) -> Self {
        let rho = mesh
            .iter()
            .map(|e| scene.material_of(e.polygon).reflectance_xyz)
            .collect();
        let emit = mesh
            .iter()
            .map(|e| {
                scene
                    .material_of(e.polygon)
                    .emission_cd_m2
                    .map(|l| std::f64::consts::PI * l)
            })
            .collect();
        Self { rho, emit }
    }

    /// Exitance of element `i` under irradiance `irradiance`: E + ρ·H per channel.
    pub(crate) fn exitance(&self, i: usize, irradiance: &[f64; 3]) -> [f64; 3] {
        std::array::from_fn(|c| self.emit[i][c] + self.rho[i][c] * irradiance[c])
    }
}

/// Form factor from receiver `r` to source `s` (area average over r's Gauss points,
/// shadow rays from each point to s's centre and Gauss points when classified
/// possibly occluded).
pub(crate) fn mesh_ff(
    vis: &dyn Visibility,
    r: &MeshElem,
    s: &MeshElem,
    counters: &RayCounters,
) -> f64 {
    if !facing(r, s) {
        return 0.0;
    }
    let candidate = vis.may_occlude(&r.verts, r.polygon, &s.verts, s.polygon);
    if candidate {
        counters.tested.fetch_add(1, Ordering::Relaxed);
    } else {
        counters.skipped.fetch_add(1, Ordering::Relaxed);
    }
    let all: Vec<V3> = if candidate {
        s.points.iter().map(|(y, _)| *y).collect()
    } else {
        Vec::new()
    };
    let mut f = 0.0;
    for (x, w) in &r.points {
        let fp = point_to_polygon(x, &r.normal, &s.verts, &s.normal);
        if fp <= 0.0 {
            continue;
        }
        let v = if candidate {
            let front = targets_in_front(x, &r.normal, &all, &s.verts);
            let seen = front
                .iter()
                .filter(|y| !vis.occluded(x, y, [r.polygon, s.polygon]))
                .count();
            counters
                .rays
                .fetch_add(front.len() as u64, Ordering::Relaxed);
            seen as f64 / front.len().max(1) as f64
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

/// Keeps the geometric series 1/(1 − ρ̄) finite for (nearly) white scenes.
const MIN_ABSORPTION: f64 = 1e-9;

/// Solves a scene by progressive refinement (shooting) on a uniform mesh.
pub fn solve_progressive(
    scene: &Scene,
    vis: &dyn Visibility,
    opts: &ProgressiveOptions,
) -> Result<Solution, RadiosityError> {
    let clock = SolveClock::start(scene, &opts.stop)?;
    if !(opts.max_edge_m.is_finite() && opts.max_edge_m > 0.0) {
        return Err(RadiosityError::BadOption(format!(
            "max edge {} m must be positive",
            opts.max_edge_m
        )));
    }
    let mut solver = Shooter::new(scene, vis, opts.max_edge_m, clock)?;
    let stop = solver.run(&opts.stop)?;
    Ok(solver.finish(scene, stop))
}

/// The state of a progressive solve: the mesh, its radiosities and what is left to
/// shoot.
struct Shooter<'a> {
    vis: &'a dyn Visibility,
    clock: SolveClock,
    mesh: Vec<MeshElem>,
    materials: MeshMaterials,
    counters: RayCounters,
    /// Irradiance per element (XYZ lux).
    irradiance: Vec<[f64; 3]>,
    /// Exitance per element (XYZ lm/m²).
    exitance: Vec<[f64; 3]>,
    /// Exitance received but not yet shot.
    unshot: Vec<[f64; 3]>,
    /// Area-weighted mean reflectance (Y).
    rho_mean: f64,
    curve: ShotCurve,
    shots: usize,
    form_factor_evals: usize,
}

/// The unshot flux before a shot.
struct UnshotFlux {
    /// Element with the largest unshot flux (the next shooter).
    largest: usize,
    /// Its unshot flux (Y lm).
    largest_flux: f64,
    /// Unshot flux over all elements (Y lm).
    total: f64,
    /// Estimated relative error of the solve.
    error: f64,
}

impl<'a> Shooter<'a> {
    /// Meshes the scene and lights it directly.
    fn new(
        scene: &Scene,
        vis: &'a dyn Visibility,
        max_edge_m: f64,
        clock: SolveClock,
    ) -> Result<Self, RadiosityError> {
        let mesh = uniform_mesh(scene, max_edge_m, MAX_UNIFORM_ELEMENTS)?;
        let materials = MeshMaterials::of(scene, &mesh);
        let counters = RayCounters::default();
        let irradiance = direct_light(scene, vis, &mesh, &counters.rays);
        let exitance: Vec<[f64; 3]> = (0..mesh.len())
            .map(|i| materials.exitance(i, &irradiance[i]))
            .collect();
        let unshot = exitance.clone();
        let total_area: f64 = mesh.iter().map(|e| e.area).sum();
        let rho_mean = mesh
            .iter()
            .zip(&materials.rho)
            .map(|(e, r)| e.area * r[1])
            .sum::<f64>()
            / total_area;
        Ok(Self {
            vis,
            clock,
            mesh,
            materials,
            counters,
            irradiance,
            exitance,
            unshot,
            rho_mean,
            curve: ShotCurve::default(),
            shots: 0,
            form_factor_evals: 0,
        })
    }

    /// Shoots until the stop rule says stop.
    fn run(&mut self, rule: &StopRule) -> Result<StopReason, RadiosityError> {
        loop {
            let unshot = self.unshot_flux();
            let past_deadline = self.clock.past_deadline();
            let nothing_left = unshot.largest_flux <= 0.0;
            let verdict = rule.after_shots(unshot.error, nothing_left, self.shots, past_deadline);
            self.report(unshot.error, verdict.last);
            if !unshot.error.is_finite() {
                return Err(RadiosityError::Diverged(format!(
                    "unshot flux became {}",
                    unshot.total
                )));
            }
            if let Some(stop) = verdict.stop {
                return Ok(stop);
            }
            self.shoot(unshot.largest);
        }
    }

    /// The unshot flux and the error it leaves.
    fn unshot_flux(&self) -> UnshotFlux {
        let mesh = &self.mesh;
        let flux_total: f64 = mesh
            .iter()
            .zip(&self.exitance)
            .map(|(e, b)| e.area * b[1])
            .sum();
        let (largest, largest_flux) = mesh
            .iter()
            .zip(&self.unshot)
            .enumerate()
            .map(|(i, (e, u))| (i, e.area * u[1]))
            .fold((0, f64::NEG_INFINITY), |a, x| if x.1 > a.1 { x } else { a });
        let total: f64 = mesh
            .iter()
            .zip(&self.unshot)
            .map(|(e, u)| e.area * u[1])
            .sum();
        let error = if flux_total > 0.0 {
            total * self.rho_mean / (1.0 - self.rho_mean).max(MIN_ABSORPTION) / flux_total
        } else {
            0.0
        };
        UnshotFlux {
            largest,
            largest_flux,
            total,
            error,
        }
    }

    /// Adds a curve point for the last shot when it is due (or `last`).
    fn report(&mut self, error: f64, last: bool) {
        let now = self.clock.elapsed_s();
        let size = (self.mesh.len(), self.form_factor_evals);
        self.curve.report(now, self.shots, error, size, last);
    }

    /// Shoots the unshot exitance of element `shooter` to every element.
    fn shoot(&mut self, shooter: usize) {
        let source = &self.mesh[shooter];
        let shot = self.unshot[shooter];
        self.unshot[shooter] = [0.0; 3];
        let (vis, counters) = (self.vis, &self.counters);
        let gains: Vec<f64> = self
            .mesh
            .par_iter()
            .map(|r| mesh_ff(vis, r, source, counters))
            .collect();
        self.form_factor_evals += self.mesh.len();
        let rho = &self.materials.rho;
        for (i, &f) in gains.iter().enumerate() {
            if f <= 0.0 {
                continue;
            }
            for c in 0..3 {
                let gained = f * shot[c];
                self.irradiance[i][c] += gained;
                self.exitance[i][c] += rho[i][c] * gained;
                self.unshot[i][c] += rho[i][c] * gained;
            }
        }
        self.shots += 1;
    }

    /// The solution with its statistics.
    fn finish(self, scene: &Scene, stop: StopReason) -> Solution {
        let n = self.mesh.len();
        let patches = patches_from_mesh(&self.mesh, &self.exitance, &self.irradiance);
        let by_polygon = super::Solution::index(&patches, scene.polygons.len());
        let stats = SolveStats {
            patches: n,
            elements: n,
            links: self.form_factor_evals,
            iterations: self.shots,
            shadow_rays: self.counters.rays.into_inner(),
            visibility_skipped: self.counters.skipped.into_inner(),
            visibility_tested: self.counters.tested.into_inner(),
            memory_bytes: n
                * (std::mem::size_of::<MeshElem>() + 8 * std::mem::size_of::<V3>() + 5 * 24),
            time_s: self.clock.elapsed_s(),
            extrapolations: 0,
            ..SolveStats::default()
        };
        Solution {
            patches,
            by_polygon,
            curve: self.curve.curve,
            stop,
            stats,
        }
    }
}

#[cfg(test)]
mod straddle_tests {
    use super::*;

    /// The solid cube (0, 1) × (0, 1) × (−1, 0): its top face is the receiver below.
    struct SolidUnderReceiver;

    impl Visibility for SolidUnderReceiver {
        fn may_occlude(&self, _: &[V3], _: usize, _: &[V3], _: usize) -> bool {
            true
        }

        /// Whether the open segment a→b enters the open cube (slab test).
        fn occluded(&self, a: &V3, b: &V3, _: [usize; 2]) -> bool {
            let (lo, hi) = (V3::new(0.0, 0.0, -1.0), V3::new(1.0, 1.0, 0.0));
            let d = b - a;
            let (mut t0, mut t1) = (0.0f64, 1.0f64);
            for k in 0..3 {
                if d[k].abs() < 1e-15 {
                    if a[k] <= lo[k] || a[k] >= hi[k] {
                        return false;
                    }
                    continue;
                }
                let (ta, tb) = ((lo[k] - a[k]) / d[k], (hi[k] - a[k]) / d[k]);
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
            t0 < t1
        }
    }

    fn elem(verts: Vec<V3>, polygon: usize, order: usize) -> MeshElem {
        let normal = polygon_normal(&verts).expect("a plane");
        let mut points = Vec::new();
        quadrature::points(&verts, order, &mut points);
        MeshElem {
            area: polygon_area_m2(&verts),
            verts,
            normal,
            polygon,
            points,
        }
    }

    /// Issue 13: the top face R of a solid (unit square z = 0, normal +z) and a unit
    /// square S that crosses R's plane (y = 1.2, z from −0.5 to 0.5, facing R). Only the
    /// part of S above the plane sends light to R; rays to S's part below the plane run
    /// through the solid. Analytic F(R→S) = 1.2·F(1.2, 0.5, 1) − 0.2·F(0.2, 0.5, 1) for
    /// perpendicular rectangles sharing an edge (Howell C-14) = 0.078578; a 3×3 Gauss
    /// rule on R gives −0.16 %. Counting the rays into the solid as blocked gave about
    /// half (0.039).
    #[test]
    fn a_sender_crossing_the_receivers_plane_is_not_shadowed_by_the_receivers_own_solid() {
        let r = elem(
            vec![
                V3::new(0.0, 0.0, 0.0),
                V3::new(1.0, 0.0, 0.0),
                V3::new(1.0, 1.0, 0.0),
                V3::new(0.0, 1.0, 0.0),
            ],
            0,
            3,
        );
        let s = elem(
            vec![
                V3::new(0.0, 1.2, -0.5),
                V3::new(1.0, 1.2, -0.5),
                V3::new(1.0, 1.2, 0.5),
                V3::new(0.0, 1.2, 0.5),
            ],
            1,
            2,
        );
        assert!(s.normal.y < 0.0, "S faces R");
        let f = mesh_ff(&SolidUnderReceiver, &r, &s, &RayCounters::default());
        let exact = 0.078578;
        assert!(
            (f / exact - 1.0).abs() < 0.01,
            "F = {f:.6}, analytic {exact}"
        );
    }
}
