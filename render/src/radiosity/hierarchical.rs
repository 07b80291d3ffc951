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
#![allow(
    clippy::needless_range_loop,
    reason = "per-channel XYZ arithmetic reads clearest with channel indices"
)]

mod emitters;
mod nodes;
mod refine;
mod sampling;
mod sweep;
mod transfer;

use std::sync::atomic::Ordering;

use rayon::prelude::*;

use crate::scene::{Scene, V3};

pub use sweep::Basis;

use super::curve::{CurvePoint, ErrorCurve, StopReason, StopRule};
use super::solution::{Patch, Solution, SolveStats};
use super::visibility::Visibility;
use super::{RadiosityError, RayCounters, SolveClock};
use emitters::Emitter;
use nodes::{Hierarchy, Node};
use sampling::NS;
use sweep::State;
use transfer::{CLink, Ctx, Overlap, PLink, eval_clink};

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
    /// Patch receivers take light from patch senders only at their leaves: no
    /// sender-side averaging over children whose radiosity differs (the default; see
    /// `refine` for what it gains and costs).
    pub leaf_senders: bool,
}

impl Default for HierarchicalOptions {
    fn default() -> Self {
        Self {
            stop: StopRule::default(),
            min_area_m2: 0.0,
            max_level: 12,
            accelerate: true,
            basis: Basis::Auto,
            leaf_senders: true,
        }
    }
}

/// Initial tolerance ε relative to target error × reflectable flux (lm).
const INITIAL_TOLERANCE: f64 = 0.05;
/// Fraction of the daylight's normal illuminance taken to reach the surfaces (a box
/// of random orientation faces a distant source with a quarter of its area).
const DAYLIGHT_EXPOSURE: f64 = 0.25;
/// Ceiling of the extrapolation's geometric series: (1 − q) never below this.
const MIN_CONTRACTION_GAP: f64 = 1e-12;
/// The convergence ratio counts as steady when two successive ones differ by at most
/// this fraction of (1 − q): then the Jacobi error is extrapolated (Lyusternik).
const STEADY_RATIO: f64 = 0.01;
/// Two successive convergence ratios must agree within this fraction of (1 − q)
/// before the solve error uses them instead of the largest reflectance.
const TRUSTED_RATIO: f64 = 0.1;
/// Relative residual below which a sweep's change is rounding (the links hold `f32`):
/// its convergence ratio is not measured, and the contraction stays as measured
/// before. Ratios of such changes agreed by chance and raised the contraction, and
/// with it the discretisation error, by 40 % on an unchanged mesh (Cornell box).
const RATIO_NOISE_FLOOR: f64 = 1e-5;
/// Refine again once the solve error is below this fraction of the target (or of the
/// discretisation error when that is smaller).
const SOLVE_AHEAD: f64 = 0.25;
/// Sweeps after a refinement that may finish the solve on a mesh that already meets
/// the target, before the solver refines again.
const FINISH_SWEEPS: usize = 4;
/// Discretisation errors below this fraction of the target count as the target.
const DISC_FLOOR: f64 = 0.1;
/// Refinements in a row that change nothing before the solve gives up on refining.
const MAX_IDLE_REFINES: usize = 4;
/// Aim of one ε step: this fraction of the ratio (target/error)³.
const EPS_STEP_AIM: f64 = 0.9;
/// Smallest factor of one ε step (at most a factor 4 at a time).
const EPS_STEP_MIN: f64 = 0.25;
/// Largest factor of one ε step (ε shrinks by at least 20 %).
const EPS_STEP_MAX: f64 = 0.8;
/// Share of the scene's total area below which no element is split by default.
const MIN_AREA_SHARE: f64 = 1e-4;
/// The median polygon's area over this (two quadtree levels) bounds the default
/// smallest element area from above.
const MEDIAN_SUBDIVISION: f64 = 16.0;
/// Guards divisions by sums that may be zero.
const TINY: f64 = 1e-300;

/// Solves a scene by hierarchical radiosity with clustering. `vis` answers visibility
/// ([`super::BvhOccluders`] for large scenes, [`super::NoOccluders`] when the caller
/// knows nothing can block).
pub fn solve_hierarchical(
    scene: &Scene,
    vis: &dyn Visibility,
    opts: &HierarchicalOptions,
) -> Result<Solution, RadiosityError> {
    let clock = SolveClock::start(scene, &opts.stop)?;
    if !(opts.min_area_m2 >= 0.0 && opts.min_area_m2.is_finite()) {
        return Err(RadiosityError::BadOption(format!(
            "smallest element area {} m² must be ≥ 0",
            opts.min_area_m2
        )));
    }
    let mut hierarchy = Hierarchy::build(scene);
    hierarchy.mark_enclosed(0, vis);
    warn_if_mostly_enclosed(hierarchy.enclosed_area_share(scene.polygons.len(), false));
    let emitters = Emitter::all(scene);
    let (lo, hi) = hierarchy
        .clusters
        .first()
        .map_or((V3::zeros(), V3::zeros()), |c| (c.lo, c.hi));
    let ctx = Ctx {
        scene,
        emitters: &emitters,
        vis,
        far: 4.0 * (hi - lo).norm() + 1.0,
        counters: RayCounters::default(),
    };
    let mut solver = Solver::new(&ctx, hierarchy, opts, clock);
    let stop = solver.run()?;
    Ok(solver.finish(stop))
}

/// Enclosed area above this share of the scene is more likely surfaces facing away
/// from the room than furniture standing on a floor.
const ENCLOSED_WARN_SHARE: f64 = 0.1;

/// Warns when much of the scene lies inside closed solids: a room whose walls face
/// out encloses its own floor, which then gets no light.
fn warn_if_mostly_enclosed(share: f64) {
    if share > ENCLOSED_WARN_SHARE {
        tracing::warn!(
            "{:.0} % of the surface area lies inside closed solids (every probe ray from it \
             meets the back of a polygon) and gets no light; if that is not furniture \
             standing on it, check that the surfaces face the room",
            100.0 * share
        );
    }
}

/// The state of a hierarchical solve between sweeps.
struct Solver<'a, 'c> {
    ctx: &'a Ctx<'c>,
    opts: &'a HierarchicalOptions,
    clock: SolveClock,
    h: Hierarchy,
    st: State,
    plinks: Vec<Vec<PLink>>,
    clinks: Vec<Vec<CLink>>,
    lim: refine::Limits,
    /// Refinement tolerance ε (lm).
    eps: f64,
    curve: ErrorCurve,
    iterations: usize,
    extrapolations: usize,
    /// Convergence ratios of the sweeps since the last refinement or extrapolation.
    ratio_history: Vec<f64>,
    /// Area-weighted absolute change (Y) of the previous sweep.
    previous_change: f64,
    /// The light's contraction per bounce q: the latest trusted convergence ratio,
    /// or until one is measured [`Solver::contraction_bound`]. A transfer error made
    /// in every bounce adds up to 1/(1 − q) of itself in the solution.
    contraction: f64,
    /// Whether `contraction` was measured (else it is the bound of the links).
    contraction_measured: bool,
    idle_refines: usize,
    linear_leaves: usize,
    /// Under a time limit: the leaves before the latest refinement and their error,
    /// returned when the limit cuts a refinement short and leaves a worse solution.
    before_refine: Option<Snapshot>,
    /// The latest refinement was cut short by the time limit: its error estimate
    /// misses what was left unrefined, so it cannot count as converged.
    refinement_cut_short: bool,
    /// Sweeps since the latest refinement.
    sweeps_since_refine: usize,
}

/// The solution's leaves at one moment and the curve point that estimated its error.
struct Snapshot {
    patches: Vec<Patch>,
    point: CurvePoint,
}

/// The change a sweep made to the leaves.
struct SweepChange {
    /// New exitance per leaf patch.
    leaves: Vec<(u32, [f64; 3])>,
    /// Its difference to the previous exitance.
    delta: Vec<[f64; 3]>,
    /// Area-weighted absolute change (Y).
    change: f64,
    /// Relative change (the residual).
    residual: f64,
}

/// The error estimate after a sweep.
struct SweepError {
    solve: f64,
    discretization: f64,
}

impl<'a, 'c> Solver<'a, 'c> {
    /// Sets up the state, the root links and the first tolerance.
    fn new(
        ctx: &'a Ctx<'c>,
        h: Hierarchy,
        opts: &'a HierarchicalOptions,
        clock: SolveClock,
    ) -> Self {
        let total_area: f64 = h.patches.iter().map(|p| p.area).sum();
        let min_area = if opts.min_area_m2 > 0.0 {
            opts.min_area_m2
        } else {
            default_min_area(&h, total_area)
        };
        let lim = refine::Limits {
            min_area,
            max_level: opts.max_level,
            basis: opts.basis,
            leaf_senders: opts.leaf_senders,
        };
        let st = State::new(ctx.scene, &h);
        let plinks: Vec<Vec<PLink>> = vec![Vec::new(); h.patches.len()];
        let clinks = root_links(ctx, &h);
        let eps = initial_tolerance(ctx.scene, &h, &st, total_area, opts.stop.target_error);
        Self {
            ctx,
            opts,
            clock,
            h,
            st,
            plinks,
            clinks,
            lim,
            eps,
            curve: ErrorCurve::default(),
            iterations: 0,
            extrapolations: 0,
            ratio_history: Vec::new(),
            previous_change: f64::NAN,
            contraction: f64::NAN,
            contraction_measured: false,
            idle_refines: 0,
            linear_leaves: 0,
            before_refine: None,
            refinement_cut_short: false,
            sweeps_since_refine: 0,
        }
    }

    /// Alternates refinement and sweeps until a stop rule applies.
    fn run(&mut self) -> Result<StopReason, RadiosityError> {
        let target = self.opts.stop.target_error;
        let mut needs_refine = true;
        loop {
            if needs_refine {
                self.keep_before_refine();
                self.refine();
                needs_refine = false;
            }
            let error = self.sweep()?;
            if let Some(stop) = self.stop_reason(&error) {
                return Ok(stop);
            }
            if !self.finishing_by_sweeps(&error)
                && error.solve
                    <= SOLVE_AHEAD * target.min(error.discretization.max(DISC_FLOOR * target))
            {
                if self.idle_refines >= MAX_IDLE_REFINES {
                    return Ok(StopReason::RefinementExhausted);
                }
                self.tighten(error.discretization);
                needs_refine = true;
            }
        }
    }

    /// Whether the mesh already meets the target and a few more sweeps, not a finer
    /// mesh, will bring the solve error under what is left of it (each sweep cuts it
    /// by the light's contraction per bounce).
    fn finishing_by_sweeps(&self, error: &SweepError) -> bool {
        error.discretization < self.opts.stop.target_error
            && self.sweeps_since_refine < FINISH_SWEEPS
    }

    /// Under a time limit, keeps the current leaves if their estimated error is the
    /// lowest so far: a refinement the deadline cuts short can leave a solution whose
    /// new links have not converged yet.
    fn keep_before_refine(&mut self) {
        let Some(point) = self.curve.points.last().copied() else {
            return;
        };
        let better = self
            .before_refine
            .as_ref()
            .is_none_or(|b| point.estimated_error < b.point.estimated_error);
        if self.clock.deadline.is_some() && better {
            self.before_refine = Some(Snapshot {
                patches: self.leaves(),
                point,
            });
        }
    }

    /// The leaf patches of the current solution.
    fn leaves(&self) -> Vec<Patch> {
        let h = &self.h;
        (0..h.patches.len())
            .filter(|&p| h.patches[p].is_leaf())
            .map(|p| output_patch(h, &self.st, p, self.opts.basis, self.eps))
            .collect()
    }

    /// Refines at the current ε and restarts the convergence history.
    fn refine(&mut self) {
        let params = refine::RefineParams {
            ctx: self.ctx,
            eps: self.eps,
            lim: self.lim,
            deadline: self.clock.deadline,
        };
        let refined = refine::refine(
            &params,
            &mut self.h,
            &mut self.st,
            &mut self.plinks,
            &mut self.clinks,
        );
        let changed = refined.changed;
        self.refinement_cut_short = refined.cut_short;
        release_spare_capacity(&mut self.plinks, &mut self.clinks);
        self.st
            .bake_cluster_direct(self.ctx.scene, &self.h, self.ctx.emitters, &self.clinks);
        self.sweeps_since_refine = 0;
        self.idle_refines = if changed == 0 {
            self.idle_refines + 1
        } else {
            0
        };
        self.ratio_history.clear();
        self.previous_change = f64::NAN;
        if !self.contraction_measured {
            self.contraction = self.contraction_bound();
        }
    }

    /// An upper bound of the light's contraction per bounce from the links: the
    /// largest ρ·(form factors gathered) over the leaves, the row-sum bound of the
    /// spectral radius of ρF (ρ itself where a cluster sends or receives, whose
    /// coefficients are not form factors). A lone plane gets 0, a closed room ρ.
    fn contraction_bound(&self) -> f64 {
        let n = self.h.patches.len();
        let mut gathered = vec![0.0f64; n];
        let mut unknown = vec![!self.clinks.iter().all(Vec::is_empty); n];
        for (r, links) in self.plinks.iter().enumerate() {
            for l in links {
                match l.src.kind() {
                    nodes::Kind::Patch(_) => gathered[r] += f64::from(l.k),
                    nodes::Kind::Cluster(_) => unknown[r] = true,
                    nodes::Kind::Emitter(_) => {}
                }
            }
        }
        let mut bound: f64 = 0.0;
        for (p, patch) in self.h.patches.iter().enumerate() {
            if !patch.is_leaf() {
                continue;
            }
            let (mut sum, mut any_unknown, mut q) = (0.0, false, p);
            loop {
                sum += gathered[q];
                any_unknown |= unknown[q];
                match self.h.patches[q].parent {
                    nodes::NONE => break,
                    parent => q = parent as usize,
                }
            }
            let reach = if any_unknown { 1.0 } else { sum.min(1.0) };
            bound = bound.max(self.st.rho[patch.polygon as usize][1] * reach);
        }
        bound
    }

    /// One Jacobi sweep (gather, push, extrapolation, pull) and its error estimate.
    fn sweep(&mut self) -> Result<SweepError, RadiosityError> {
        self.st
            .gather(&self.h, self.ctx.emitters, &self.plinks, &self.clinks);
        let change = self.apply_push();
        self.iterations += 1;
        self.sweeps_since_refine += 1;
        if !change.residual.is_finite() {
            return Err(RadiosityError::Diverged(format!(
                "residual became {} after {} sweeps",
                change.residual, self.iterations
            )));
        }
        let solve = self.solve_error(&change);
        self.extrapolate(&change);
        self.st.pull(&self.h);
        let discretization = self.discretization_error(&change.leaves, solve);
        self.curve.points.push(CurvePoint {
            time_s: self.clock.elapsed_s(),
            iteration: self.iterations,
            estimated_error: solve + discretization,
            solve_error: solve,
            discretization_error: discretization,
            patches: change.leaves.len(),
            links: link_count(&self.plinks, &self.clinks),
        });
        Ok(SweepError {
            solve,
            discretization,
        })
    }

    /// Pushes the gathered irradiance down to the leaves and stores their new
    /// exitance.
    fn apply_push(&mut self) -> SweepChange {
        let leaves = self.st.push(&self.h);
        let mut change = 0.0;
        let mut total = 0.0;
        let mut delta: Vec<[f64; 3]> = Vec::with_capacity(leaves.len());
        for (p, b) in &leaves {
            let p = *p as usize;
            let a = self.h.patches[p].area;
            let d: [f64; 3] = std::array::from_fn(|c| b[c] - self.st.b[p][c]);
            change += a * d[1].abs();
            total += a * b[1].abs();
            delta.push(d);
            self.st.b[p] = *b;
        }
        let residual = if total > 0.0 { change / total } else { 0.0 };
        SweepChange {
            leaves,
            delta,
            change,
            residual,
        }
    }

    /// The solve error from the residual and the convergence ratio; records the
    /// ratio. A measured ratio counts only once two in a row agree (within
    /// [`TRUSTED_RATIO`] of 1 − q); until then the largest reflectance bounds it. The
    /// first ratio after a refinement or an extrapolation compares a sweep with the
    /// jump the new links or the extrapolation caused: far below the contraction, it
    /// let a ρ = 0.95 room stop at 4 % below its inter-reflected light with 0.7 %
    /// estimated (CIE 171 5.8).
    fn solve_error(&mut self, change: &SweepChange) -> f64 {
        if self.previous_change.is_finite() && self.previous_change > 0.0 {
            self.ratio_history
                .push(change.change / self.previous_change);
        }
        self.previous_change = change.change;
        let rho_max = self.st.rho.iter().map(|r| r[1]).fold(0.0, f64::max);
        let above_noise = change.residual >= RATIO_NOISE_FLOOR;
        let q = match self.ratio_history.as_slice() {
            [.., q1, q2]
                if above_noise && *q2 < 1.0 && (q2 - q1).abs() <= TRUSTED_RATIO * (1.0 - q2) =>
            {
                let q = q1.max(*q2).max(0.0);
                self.contraction = q;
                self.contraction_measured = true;
                q
            }
            _ if !above_noise && self.contraction_measured => self.contraction,
            _ => rho_max,
        };
        change.residual * q / (1.0 - q).max(MIN_CONTRACTION_GAP)
    }

    /// Geometric-series extrapolation of the sweep's change once the convergence
    /// ratio is steady.
    fn extrapolate(&mut self, change: &SweepChange) {
        let history = &self.ratio_history;
        if !self.opts.accelerate || history.len() < 2 {
            return;
        }
        let (q1, q2) = (history[history.len() - 2], history[history.len() - 1]);
        if !(q2 < 1.0 && q2 > 0.0 && (q2 - q1).abs() <= STEADY_RATIO * (1.0 - q2)) {
            return;
        }
        let gain = q2 / (1.0 - q2);
        for ((p, _), d) in change.leaves.iter().zip(&change.delta) {
            let p = *p as usize;
            let e = self.st.emit[self.h.patches[p].polygon as usize];
            for c in 0..3 {
                self.st.b[p][c] = (self.st.b[p][c] + gain * d[c]).max(e[c]);
            }
        }
        self.extrapolations += 1;
        self.ratio_history.clear();
        self.previous_change = f64::NAN;
    }

    /// Relative discretisation error over the leaves; counts the linear ones.
    fn discretization_error(&mut self, leaves: &[(u32, [f64; 3])], solve_err: f64) -> f64 {
        let (mut error_sum, mut norm_sum, mut shape_sum) = (0.0, 0.0, 0.0);
        self.linear_leaves = 0;
        for (p, _) in leaves {
            let p = *p as usize;
            let le = self.st.leaf_error(&self.h, p, self.opts.basis, self.eps);
            let a = self.h.patches[p].area;
            error_sum += a * le.error;
            shape_sum += a * le.shape;
            norm_sum += a * le.norm;
            self.linear_leaves += usize::from(le.linear);
        }
        // the leaves' errors are those of one bounce; every bounce repeats them
        let amplification = 1.0 / (1.0 - self.contraction).max(MIN_CONTRACTION_GAP);
        let disc = if norm_sum > 0.0 {
            amplification * error_sum / norm_sum
        } else {
            0.0
        };
        self.trace_breakdown(shape_sum, norm_sum);
        tracing::debug!(
            iterations = self.iterations,
            solve_err,
            disc,
            shape = shape_sum / norm_sum.max(TINY),
            eps = self.eps,
            contraction = self.contraction,
            patches = leaves.len(),
            "sweep"
        );
        disc
    }

    /// Traces where the discretisation error comes from.
    fn trace_breakdown(&self, shape_sum: f64, norm_sum: f64) {
        if !tracing::enabled!(tracing::Level::TRACE) {
            return;
        }
        let b = self
            .st
            .error_breakdown(&self.h, self.ctx.emitters, &self.plinks, &self.clinks);
        let n = norm_sum.max(TINY);
        tracing::trace!(
            shape = shape_sum / n,
            patch_spread = b[0] / n,
            cluster_bounds = b[1] / n,
            cluster_extent = b[2] / n,
            visibility = b[3] / n,
            cluster_receivers = b[4] / n,
            "error breakdown (relative)"
        );
    }

    /// Why the solve stops after this sweep, if it does.
    fn stop_reason(&self, error: &SweepError) -> Option<StopReason> {
        let met = error.solve + error.discretization <= self.opts.stop.target_error;
        if met && !self.refinement_cut_short {
            Some(StopReason::Converged)
        } else if self.clock.past_deadline() {
            Some(StopReason::TimeLimit)
        } else if self.iterations >= self.opts.stop.max_iterations {
            Some(StopReason::IterationLimit)
        } else {
            None
        }
    }

    /// Shrinks ε towards the target: the error falls about as ε^(1/3) (measured on
    /// the scale scenes), so aim a little below the target in one step, at most a
    /// factor 4.
    fn tighten(&mut self, discretization: f64) {
        let r = self.opts.stop.target_error / discretization.max(TINY);
        self.eps *= (EPS_STEP_AIM * r * r * r).clamp(EPS_STEP_MIN, EPS_STEP_MAX);
    }

    /// The solution: the leaves and the statistics. When the time limit cut the latest
    /// refinement short (or stopped the solve with a higher estimated error than the
    /// solution before it), the solution before that refinement is returned, and the
    /// curve ends with a point for it (its error, now).
    fn finish(mut self, stop: StopReason) -> Solution {
        let last_error = self.curve.points.last().map(|p| p.estimated_error);
        let patches = match self.before_refine.take() {
            Some(b)
                if stop == StopReason::TimeLimit
                    && (self.refinement_cut_short
                        || last_error.is_some_and(|e| b.point.estimated_error < e)) =>
            {
                tracing::info!(
                    error = b.point.estimated_error,
                    "time limit cut a refinement short; returning the solution before it"
                );
                self.curve.points.push(CurvePoint {
                    time_s: self.clock.elapsed_s(),
                    iteration: self.iterations,
                    patches: b.patches.len(),
                    ..b.point
                });
                b.patches
            }
            _ => self.leaves(),
        };
        let h = &self.h;
        let by_polygon = Solution::index(&patches, self.ctx.scene.polygons.len());
        let counters = &self.ctx.counters;
        let stats = SolveStats {
            patches: patches.len(),
            elements: h.patches.len() + h.clusters.len(),
            links: link_count(&self.plinks, &self.clinks),
            iterations: self.iterations,
            shadow_rays: counters.rays.load(Ordering::Relaxed),
            visibility_skipped: counters.skipped.load(Ordering::Relaxed),
            visibility_tested: counters.tested.load(Ordering::Relaxed),
            memory_bytes: memory_estimate(h, &self.plinks, &self.clinks),
            time_s: self.clock.elapsed_s(),
            extrapolations: self.extrapolations,
            clusters: h.clusters.len(),
            cluster_links: self.clinks.iter().map(Vec::len).sum(),
            linear_patches: self.linear_leaves,
            enclosed_area_share: h.enclosed_area_share(self.ctx.scene.polygons.len(), true),
        };
        Solution {
            patches,
            by_polygon,
            curve: self.curve,
            stop,
            stats,
        }
    }
}

/// Default smallest element area: 1e-4 of the total area, or two quadtree levels
/// below the median polygon in finely meshed scenes.
fn default_min_area(h: &Hierarchy, total_area: f64) -> f64 {
    let mut areas: Vec<f64> = h.patches.iter().map(|p| p.area).collect();
    let mid = areas.len() / 2;
    let median = *areas.select_nth_unstable_by(mid, f64::total_cmp).1;
    (MIN_AREA_SHARE * total_area).min(median / MEDIAN_SUBDIVISION)
}

/// The root's self-link (Sillion 1995) and every emitter to the root.
fn root_links(ctx: &Ctx, h: &Hierarchy) -> Vec<Vec<CLink>> {
    let mut clinks: Vec<Vec<CLink>> = vec![Vec::new(); h.clusters.len()];
    if !h.clusters.is_empty() {
        clinks[0].push(CLink {
            src: Node::cluster(0),
            d: 0.0,
            k: 0.0,
            v: 0.0,
            rel_src: 0.0,
            rel_vis: 0.0,
            overlap: Overlap::Near,
        });
        for e in 0..ctx.emitters.len() {
            if let Some(l) = eval_clink(ctx, h, 0, Node::emitter(e)) {
                clinks[0].push(l);
            }
        }
    }
    clinks
}

/// First tolerance ε (lm): a share of the target error of the flux the surfaces can
/// reflect.
fn initial_tolerance(
    scene: &Scene,
    h: &Hierarchy,
    st: &State,
    total_area: f64,
    target: f64,
) -> f64 {
    let rho_mean = h
        .patches
        .iter()
        .map(|p| p.area * st.rho[p.polygon as usize][1].max(nodes::DARK))
        .sum::<f64>()
        / total_area.max(TINY);
    let daylight: f64 = scene.sky.as_ref().map_or(0.0, |d| {
        d.sources().map(|s| s.normal_illuminance_lux).sum::<f64>() * DAYLIGHT_EXPOSURE * total_area
    });
    let flux = scene.emitted_flux_xyz_lm()[1] + daylight;
    target * rho_mean * flux * INITIAL_TOLERANCE
}

/// Gives back the room the link lists grew into while refining (a third of their
/// memory on the scale scene): they do not change until the next refinement.
fn release_spare_capacity(plinks: &mut [Vec<PLink>], clinks: &mut [Vec<CLink>]) {
    plinks.par_iter_mut().for_each(Vec::shrink_to_fit);
    clinks.par_iter_mut().for_each(Vec::shrink_to_fit);
}

/// Approximate memory held by the hierarchy and its links, in bytes.
fn memory_estimate(h: &Hierarchy, plinks: &[Vec<PLink>], clinks: &[Vec<CLink>]) -> usize {
    h.patches.len()
        * (std::mem::size_of::<nodes::Patch>() + 2 * std::mem::size_of::<sweep::Irr>() + 40)
        + h.clusters.len() * (std::mem::size_of::<nodes::Cluster>() + 300)
        + plinks.iter().map(|l| l.capacity()).sum::<usize>() * std::mem::size_of::<PLink>()
        + clinks.iter().map(|l| l.capacity()).sum::<usize>() * std::mem::size_of::<CLink>()
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
