//! Hierarchical radiosity with clustering (Hanrahan et al. 1991, Smits et al. 1994;
//! Kresse 2003, 2.5–2.7): a cluster tree over the input polygons above a quadtree per
//! polygon, links at whatever level the error bound allows, between clusters, patches,
//! lights (point, spot, goniometric) and daylight (sun, sky cells).
//!
//! The solve alternates refinement at a tolerance ε (`refine`, Kresse's criterion)
//! with Jacobi sweeps of gather/push–pull (`sweep`) until the linear solve is ahead
//! of the mesh, then halves ε, until the estimated error (solve residual plus the
//! discretisation error of every leaf: the shape of its irradiance under the chosen
//! basis and the error bounds of its links) reaches the target. Each sweep reports a
//! point of the error/time curve.
//!
//! Leaves out what a scene does not need: no shadow rays for links classified fully
//! visible (nor for their sub-links), no daylight links without a sky, no linear
//! representation where a constant one meets the bound ([`Basis::Auto`]).

// per-channel XYZ arithmetic reads clearest with channel indices
#![allow(clippy::needless_range_loop)]

mod emitters;
mod nodes;
mod refine;
mod sampling;
mod sweep;
mod transfer;

use std::time::Instant;

use crate::scene::{Scene, V3};

pub use sweep::Basis;

use super::RadiosityError;
use super::curve::{CurvePoint, ErrorCurve, StopReason, StopRule};
use super::solution::{Patch, Solution, SolveStats};
use super::visibility::Visibility;
use emitters::Emitter;
use nodes::{Hierarchy, Node};
use sampling::NS;
use sweep::State;
use transfer::{CLink, Counters, Ctx, Overlap, PLink, eval_clink};

/// Options of the hierarchical solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HierarchicalOptions {
    /// Stop rule (target relative error, time, iterations).
    pub stop: StopRule,
    /// Smallest element area in m²; 0 = 1e-4 of the scene's total area, or the
    /// median polygon's area / 16 (two quadtree levels) when that is smaller.
    pub min_area_m2: f64,
    /// Deepest quadtree level.
    pub max_level: u8,
    /// Geometric-series (Lyusternik) extrapolation of the Jacobi iteration.
    pub accelerate: bool,
    /// Receiver representation.
    pub basis: Basis,
}

impl Default for HierarchicalOptions {
    fn default() -> Self {
        Self {
            stop: StopRule::default(),
            min_area_m2: 0.0,
            max_level: 12,
            accelerate: true,
            basis: Basis::Auto,
        }
    }
}

/// Solves a scene by hierarchical radiosity with clustering. `vis` answers visibility
/// ([`super::BvhOccluders`] for large scenes, [`super::NoOccluders`] when the caller
/// knows nothing can block).
pub fn solve_hierarchical(
    scene: &Scene,
    vis: &dyn Visibility,
    opts: &HierarchicalOptions,
) -> Result<Solution, RadiosityError> {
    let start = Instant::now();
    let deadline = opts.stop.time_limit.map(|t| start + t);
    super::validate(scene, opts.stop.target_error)?;
    if !(opts.min_area_m2 >= 0.0 && opts.min_area_m2.is_finite()) {
        return Err(RadiosityError::BadOption(format!(
            "smallest element area {} m² must be ≥ 0",
            opts.min_area_m2
        )));
    }
    let mut h = Hierarchy::build(scene);
    let emitters = Emitter::all(scene);
    let (lo, hi) = h
        .clusters
        .first()
        .map_or((V3::zeros(), V3::zeros()), |c| (c.lo, c.hi));
    let ctx = Ctx {
        scene,
        emitters: &emitters,
        vis,
        far: 4.0 * (hi - lo).norm() + 1.0,
        counters: Counters::default(),
    };
    let total_area: f64 = h.patches.iter().map(|p| p.area).sum();
    let min_area = if opts.min_area_m2 > 0.0 {
        opts.min_area_m2
    } else {
        // two quadtree levels below the median polygon in finely meshed scenes
        let mut areas: Vec<f64> = h.patches.iter().map(|p| p.area).collect();
        let mid = areas.len() / 2;
        let median = *areas.select_nth_unstable_by(mid, f64::total_cmp).1;
        (1e-4 * total_area).min(median / 16.0)
    };
    let lim = refine::Limits {
        min_area,
        max_level: opts.max_level,
        basis: opts.basis,
    };
    let mut st = State::new(scene, &h);
    let mut plinks: Vec<Vec<PLink>> = vec![Vec::new(); h.patches.len()];
    let mut clinks: Vec<Vec<CLink>> = vec![Vec::new(); h.clusters.len()];
    if !h.clusters.is_empty() {
        // the root's self-link (Sillion 1995) and every emitter to the root
        clinks[0].push(CLink {
            src: Node::cluster(0),
            d: 0.0,
            k: 0.0,
            v: 0.0,
            rel_src: 0.0,
            rel_vis: 0.0,
            overlap: Overlap::Near,
        });
        for e in 0..emitters.len() {
            if let Some(l) = eval_clink(&ctx, &h, 0, Node::emitter(e)) {
                clinks[0].push(l);
            }
        }
    }
    // tolerance scale (lm): the flux the surfaces can reflect
    let rho_mean = h
        .patches
        .iter()
        .map(|p| p.area * st.rho[p.polygon as usize][1].max(nodes::DARK))
        .sum::<f64>()
        / total_area.max(1e-300);
    let daylight: f64 = scene.sky.as_ref().map_or(0.0, |d| {
        d.sources().map(|s| s.normal_illuminance_lux).sum::<f64>() * 0.25 * total_area
    });
    let flux = scene.emitted_flux_xyz_lm()[1] + daylight;
    let target = opts.stop.target_error;
    let mut eps = target * rho_mean * flux * 0.05;

    let mut curve = ErrorCurve::default();
    let mut iterations = 0usize;
    let mut extrapolations = 0usize;
    let mut q_hist: Vec<f64> = Vec::new();
    let mut res_prev = f64::NAN;
    let mut idle_refines = 0usize;
    let mut needs_refine = true;
    let mut linear_leaves;
    let stop;
    loop {
        if needs_refine {
            let changed = refine::refine(
                &ctx,
                &mut h,
                &mut st,
                &mut plinks,
                &mut clinks,
                eps,
                &lim,
                deadline,
            );
            st.bake_cluster_direct(scene, &h, &emitters, &clinks);
            idle_refines = if changed == 0 { idle_refines + 1 } else { 0 };
            q_hist.clear();
            res_prev = f64::NAN;
            needs_refine = false;
        }
        st.gather(&h, &emitters, &plinks, &clinks);
        let new = st.push(&h);
        let mut num = 0.0;
        let mut den = 0.0;
        let mut delta: Vec<[f64; 3]> = Vec::with_capacity(new.len());
        for (p, b) in &new {
            let p = *p as usize;
            let a = h.patches[p].area;
            let d: [f64; 3] = std::array::from_fn(|c| b[c] - st.b[p][c]);
            num += a * d[1].abs();
            den += a * b[1].abs();
            delta.push(d);
            st.b[p] = *b;
        }
        iterations += 1;
        let res = if den > 0.0 { num / den } else { 0.0 };
        if !res.is_finite() {
            return Err(RadiosityError::Diverged(format!(
                "residual became {res} after {iterations} sweeps"
            )));
        }
        let q = if res_prev.is_finite() && res_prev > 0.0 {
            num / res_prev
        } else {
            f64::NAN
        };
        res_prev = num;
        let rho_max = st.rho.iter().map(|r| r[1]).fold(0.0, f64::max);
        let q_est = if q.is_finite() && q < 1.0 {
            q.max(0.0)
        } else {
            rho_max
        };
        let solve_err = res * q_est / (1.0 - q_est).max(1e-12);
        if q.is_finite() {
            q_hist.push(q);
        }
        if opts.accelerate && q_hist.len() >= 2 {
            let (q1, q2) = (q_hist[q_hist.len() - 2], q_hist[q_hist.len() - 1]);
            if q2 < 1.0 && q2 > 0.0 && (q2 - q1).abs() <= 0.01 * (1.0 - q2) {
                let g = q2 / (1.0 - q2);
                for ((p, _), d) in new.iter().zip(&delta) {
                    let p = *p as usize;
                    let e = st.emit[h.patches[p].polygon as usize];
                    for c in 0..3 {
                        st.b[p][c] = (st.b[p][c] + g * d[c]).max(e[c]);
                    }
                }
                extrapolations += 1;
                q_hist.clear();
                res_prev = f64::NAN;
            }
        }
        st.pull(&h);

        // discretisation error over the leaves
        let (mut esum, mut nsum, mut ssum) = (0.0, 0.0, 0.0);
        linear_leaves = 0;
        for (p, _) in &new {
            let p = *p as usize;
            let le = st.leaf_error(&h, p, opts.basis, eps);
            let a = h.patches[p].area;
            esum += a * le.error;
            ssum += a * le.shape;
            nsum += a * le.norm;
            linear_leaves += usize::from(le.linear);
        }
        let disc = if nsum > 0.0 { esum / nsum } else { 0.0 };
        if tracing::enabled!(tracing::Level::TRACE) {
            let b = st.error_breakdown(&h, &emitters, &plinks, &clinks);
            let n = nsum.max(1e-300);
            tracing::trace!(
                shape = ssum / n,
                patch_spread = b[0] / n,
                cluster_bounds = b[1] / n,
                cluster_extent = b[2] / n,
                visibility = b[3] / n,
                cluster_receivers = b[4] / n,
                "error breakdown (relative)"
            );
        }
        curve.points.push(CurvePoint {
            time_s: start.elapsed().as_secs_f64(),
            iteration: iterations,
            estimated_error: solve_err + disc,
            solve_error: solve_err,
            discretization_error: disc,
            patches: new.len(),
            links: link_count(&plinks, &clinks),
        });
        tracing::debug!(
            iterations,
            solve_err,
            disc,
            shape = ssum / nsum.max(1e-300),
            eps,
            patches = new.len(),
            "sweep"
        );
        if solve_err + disc <= target {
            stop = StopReason::Converged;
            break;
        }
        if deadline.is_some_and(|d| Instant::now() > d) {
            stop = StopReason::TimeLimit;
            break;
        }
        if iterations >= opts.stop.max_iterations {
            stop = StopReason::IterationLimit;
            break;
        }
        if solve_err <= 0.25 * target.min(disc.max(0.1 * target)) {
            if idle_refines >= 4 {
                stop = StopReason::RefinementExhausted;
                break;
            }
            // the error falls about as ε^(1/3) (measured on the scale scenes): aim
            // a little below the target in one step, at most a factor 4
            let r = target / disc.max(1e-300);
            eps *= (0.9 * r * r * r).clamp(0.25, 0.8);
            needs_refine = true;
        }
    }
    let leaves: Vec<usize> = (0..h.patches.len())
        .filter(|&p| h.patches[p].is_leaf())
        .collect();
    let patches: Vec<Patch> = leaves
        .iter()
        .map(|&p| output_patch(&h, &st, p, opts.basis, eps))
        .collect();
    let by_polygon = Solution::index(&patches, scene.polygons.len());
    let n_links = link_count(&plinks, &clinks);
    let memory = h.patches.len()
        * (std::mem::size_of::<nodes::Patch>() + 2 * std::mem::size_of::<sweep::Irr>() + 40)
        + h.clusters.len() * (std::mem::size_of::<nodes::Cluster>() + 300)
        + plinks.iter().map(|l| l.capacity()).sum::<usize>() * std::mem::size_of::<PLink>()
        + clinks.iter().map(|l| l.capacity()).sum::<usize>() * std::mem::size_of::<CLink>();
    let stats = SolveStats {
        patches: patches.len(),
        elements: h.patches.len() + h.clusters.len(),
        links: n_links,
        iterations,
        shadow_rays: ctx.counters.rays.into_inner(),
        visibility_skipped: ctx.counters.skipped.into_inner(),
        visibility_tested: ctx.counters.tested.into_inner(),
        memory_bytes: memory,
        time_s: start.elapsed().as_secs_f64(),
        extrapolations,
        clusters: h.clusters.len(),
        cluster_links: clinks.iter().map(Vec::len).sum(),
        linear_patches: linear_leaves,
    };
    Ok(Solution {
        patches,
        by_polygon,
        curve,
        stop,
        stats,
    })
}

fn link_count(p: &[Vec<PLink>], c: &[Vec<CLink>]) -> usize {
    p.iter().map(Vec::len).sum::<usize>() + c.iter().map(Vec::len).sum::<usize>()
}

/// A solved leaf, with vertex radiosities where the linear basis is used.
fn output_patch(h: &Hierarchy, st: &State, p: usize, basis: Basis, eps: f64) -> Patch {
    let pa = &h.patches[p];
    let poly = pa.polygon as usize;
    let (rho, e) = (st.rho[poly], st.emit[poly]);
    let t = &st.tot[p];
    let linear = st.leaf_error(h, p, basis, eps).linear;
    let vertex_exitance_xyz = if linear {
        let bs: [[f64; 3]; NS] =
            std::array::from_fn(|j| std::array::from_fn(|c| e[c] + rho[c] * t.s[j][c]));
        sampling::at_vertices(pa.nv.min(4), &bs)
            .into_iter()
            .map(|v| v.map(|x| x.max(0.0)))
            .collect()
    } else {
        Vec::new()
    };
    Patch {
        polygon: poly,
        vertices: pa.verts().to_vec(),
        normal: pa.normal,
        area_m2: pa.area,
        exitance_xyz: st.b[p],
        irradiance_xyz: t.avg,
        vertex_exitance_xyz,
    }
}
