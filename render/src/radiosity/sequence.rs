//! Radiosity for a whole animation at once: simultaneous progressive refinement
//! (Hahn 2000, ch. 4). Every frame keeps its own radiosity and unshot exitance on one
//! uniform mesh; the element with the largest unshot flux in any frame shoots in all
//! frames together (Hahn's eq. 4.1), so every frame sees the same sequence of steps
//! and the sequence does not flicker. Pairs of elements that do not move are
//! evaluated once for all frames, with shadow rays against the moving objects only
//! in the frames where one can come between them (`sequence::gains`); frames whose objects
//! and lights all sit where an earlier frame's do are solved once (`sequence::frames`).
//!
//! The error estimate is the progressive solver's (unshot flux with the geometric
//! series of the mean reflectance), per frame; the sequence stops when the largest
//! over frames meets the target.

mod coherence;
mod frames;
mod gains;
pub mod time_curve;

use rayon::prelude::*;

use crate::scene::{Animation, Scene, V3};

pub use coherence::{KeySpacing, MAX_KEY_SPACING};
use coherence::{key_spacing, largest_step_m};
pub use frames::MAX_SEQUENCE_STATE_BYTES;
use frames::{FramePlan, PoseGeometry, SweptBoxes, check_state_size, moved_elem, swept_per_object};
use gains::ShotContext;
pub use time_curve::TimeCurve;

use super::curve::{ErrorCurve, ShotCurve, StopReason, StopRule};
use super::progressive::{
    MAX_UNIFORM_ELEMENTS, MeshElem, MeshMaterials, ProgressiveOptions, direct_light,
    patches_from_mesh, scene_extent, uniform_mesh,
};
use super::solution::{Solution, SolveStats};
use super::visibility::{Both, Visibility, occluders_of};
use super::{RadiosityError, RayCounters, SolveClock};

/// A solved animation: one solution per requested frame and the sequence's curve.
#[derive(Debug, Clone)]
pub struct SequenceSolution {
    /// The frame numbers, in the order asked for.
    pub frames: Vec<usize>,
    /// One solution per frame (uniform mesh; curve and stats are the sequence's).
    pub solutions: Vec<Solution>,
    /// Estimated relative error of each frame at the end.
    pub frame_errors: Vec<f64>,
    /// The largest estimated error over frames against time.
    pub curve: ErrorCurve,
    /// Why it stopped.
    pub stop: StopReason,
    /// Counters of the whole sequence.
    pub stats: SolveStats,
    /// Distinct poses among the frames (frames that repeat a pose reuse it).
    pub distinct_poses: usize,
    /// Elements on moving objects.
    pub moving_elements: usize,
    /// Poses between two visibility keys (1: every pose tested).
    pub key_spacing: usize,
}

impl SequenceSolution {
    /// Every element's exitance over the frames as a piecewise-linear function of
    /// time (Hahn 2000, 4.4), each frame within `relative_tolerance` of the dimmest
    /// frame's area-mean luminous exitance (per channel).
    pub fn exitance_in_time(&self, relative_tolerance: f64) -> Vec<TimeCurve> {
        let tolerance = relative_tolerance * self.dimmest_mean_exitance();
        let elements = self.solutions.first().map_or(0, |s| s.patches.len());
        (0..elements)
            .map(|i| {
                let values: Vec<[f64; 3]> = self
                    .solutions
                    .iter()
                    .map(|s| s.patches[i].exitance_xyz)
                    .collect();
                time_curve::fit(&values, tolerance)
            })
            .collect()
    }

    /// The smallest over frames of the area-mean luminous exitance (lm/m²).
    fn dimmest_mean_exitance(&self) -> f64 {
        self.solutions
            .iter()
            .map(|s| {
                let area: f64 = s.patches.iter().map(|p| p.area_m2).sum();
                let flux: f64 = s
                    .patches
                    .iter()
                    .map(|p| p.area_m2 * p.exitance_xyz[1])
                    .sum();
                flux / area
            })
            .fold(f64::INFINITY, f64::min)
    }
}

/// Solves frames `frames` of `anim` over `base` together, testing visibility
/// between moving things at poses `keys` apart.
pub fn solve_sequence(
    base: &Scene,
    anim: &Animation,
    frames: &[usize],
    opts: &ProgressiveOptions,
    keys: KeySpacing,
) -> Result<SequenceSolution, RadiosityError> {
    let clock = SolveClock::start(base, &opts.stop)?;
    check_request(anim, frames, opts)?;
    let mut seq = Sequence::new(base, anim, frames, opts.max_edge_m, clock)?;
    seq.key_spacing = key_spacing(keys, seq.largest_step_m(), opts.max_edge_m);
    let stop = seq.run(&opts.stop)?;
    Ok(seq.finish(stop))
}

fn check_request(
    anim: &Animation,
    frames: &[usize],
    opts: &ProgressiveOptions,
) -> Result<(), RadiosityError> {
    if !(opts.max_edge_m.is_finite() && opts.max_edge_m > 0.0) {
        return Err(RadiosityError::BadOption(format!(
            "max edge {} m must be positive",
            opts.max_edge_m
        )));
    }
    if frames.is_empty() {
        return Err(RadiosityError::BadOption("no frames to solve".into()));
    }
    if let Some(f) = frames.iter().find(|&&f| f >= anim.frames()) {
        return Err(RadiosityError::BadOption(format!(
            "frame {f} is past the animation's last frame {}",
            anim.frames() - 1
        )));
    }
    Ok(())
}

/// The state of a sequence solve: the mesh, per pose its radiosities and what is
/// left to shoot (index `element · poses + pose`).
struct Sequence {
    plan: FramePlan,
    poses: Vec<PoseGeometry>,
    /// Elements where the static ones sit (moving ones: see `poses`).
    mesh: Vec<MeshElem>,
    /// Moving slot of each element (index into a pose's `moved`).
    slot: Vec<Option<usize>>,
    static_vis: Box<dyn Visibility>,
    swept: Vec<SweptBoxes>,
    materials: MeshMaterials,
    counters: RayCounters,
    clock: SolveClock,
    irradiance: Vec<[f64; 3]>,
    exitance: Vec<[f64; 3]>,
    unshot: Vec<[f64; 3]>,
    rho_mean: f64,
    eps: f64,
    key_spacing: usize,
    curve: ShotCurve,
    shots: usize,
    form_factor_evals: usize,
}

/// The unshot flux over poses before a shot.
struct Unshot {
    /// The element with the largest unshot flux in any pose.
    largest: usize,
    largest_flux: f64,
    /// Estimated relative error of each pose.
    errors: Vec<f64>,
}

/// Per-pose sums over elements: total and unshot flux, and the element with the
/// largest unshot flux in any pose (the first such element on a tie).
struct PoseSums {
    flux: Vec<f64>,
    left: Vec<f64>,
    largest: (usize, f64),
}

impl PoseSums {
    /// Adds element `i` (area `area_m2`) with its exitance and unshot exitance per pose.
    fn add_element(&mut self, i: usize, area_m2: f64, exitance: &[[f64; 3]], unshot: &[[f64; 3]]) {
        for (p, (b, u)) in exitance.iter().zip(unshot).enumerate() {
            self.flux[p] += area_m2 * b[1];
            let u = area_m2 * u[1];
            self.left[p] += u;
            if u > self.largest.1 {
                self.largest = (i, u);
            }
        }
    }

    fn merge(mut self, other: Self) -> Self {
        for (a, b) in self.flux.iter_mut().zip(&other.flux) {
            *a += b;
        }
        for (a, b) in self.left.iter_mut().zip(&other.left) {
            *a += b;
        }
        let (a, b) = (self.largest, other.largest);
        if b.1 > a.1 || (b.1 == a.1 && b.0 < a.0) {
            self.largest = b;
        }
        self
    }
}

/// Keeps the geometric series 1/(1 − ρ̄) finite for (nearly) white scenes.
const MIN_ABSORPTION: f64 = 1e-9;

impl Sequence {
    fn new(
        base: &Scene,
        anim: &Animation,
        frames: &[usize],
        max_edge_m: f64,
        clock: SolveClock,
    ) -> Result<Self, RadiosityError> {
        let plan = FramePlan::new(base, anim, frames)?;
        let base_mesh = uniform_mesh(base, max_edge_m, MAX_UNIFORM_ELEMENTS)?;
        let moving: Vec<usize> = (0..base_mesh.len())
            .filter(|&i| plan.moving_polygon[base_mesh[i].polygon])
            .collect();
        check_state_size(
            base_mesh.len(),
            moving.len(),
            base.polygons.len(),
            plan.poses.len(),
            frames.len(),
        )?;
        let mut slot = vec![None; base_mesh.len()];
        for (k, &i) in moving.iter().enumerate() {
            slot[i] = Some(k);
        }
        let poses: Vec<PoseGeometry> = plan
            .poses
            .par_iter()
            .map(|&f| PoseGeometry::new(base, anim, f, &plan, &base_mesh, &moving))
            .collect();
        let mesh = static_pose(base, anim, plan.poses[0], base_mesh);
        let static_vis = occluders_of(&poses[0].scene, &|p| !plan.moving_polygon[p]);
        let eps = 1e-9 * scene_extent(base).max(1e-3);
        let boxes: Vec<_> = poses.iter().map(|p| p.moving_bounds(&plan)).collect();
        let swept = swept_per_object(&boxes, eps);
        let materials = MeshMaterials::of(base, &mesh);
        let rho_mean = mean_reflectance(&mesh, &materials);
        let mut seq = Self {
            plan,
            poses,
            mesh,
            slot,
            static_vis,
            swept,
            materials,
            counters: RayCounters::default(),
            clock,
            irradiance: Vec::new(),
            exitance: Vec::new(),
            unshot: Vec::new(),
            rho_mean,
            eps,
            key_spacing: 1,
            curve: ShotCurve::default(),
            shots: 0,
            form_factor_evals: 0,
        };
        seq.light_directly();
        Ok(seq)
    }

    fn pose_count(&self) -> usize {
        self.poses.len()
    }

    /// The largest distance a moving element's vertex travels from one pose to the
    /// next.
    fn largest_step_m(&self) -> f64 {
        self.poses
            .windows(2)
            .flat_map(|w| w[0].moved.iter().zip(&w[1].moved))
            .map(|(a, b)| largest_step_m(&a.verts, &b.verts))
            .fold(0.0, f64::max)
    }

    /// Element `i` where it is in pose `p`.
    fn elem(&self, i: usize, p: usize) -> &MeshElem {
        match self.slot[i] {
            Some(k) => &self.poses[p].moved[k],
            None => &self.mesh[i],
        }
    }

    /// The whole mesh of pose `p`.
    fn pose_mesh(&self, p: usize) -> Vec<MeshElem> {
        (0..self.mesh.len())
            .map(|i| self.elem(i, p).clone())
            .collect()
    }

    /// Direct light of the point lights and daylight in every pose, and the emitters'
    /// exitance: the first unshot exitance.
    fn light_directly(&mut self) {
        let (n, m) = (self.mesh.len(), self.pose_count());
        self.irradiance = vec![[0.0; 3]; n * m];
        let lit = !self.poses[0].scene.lights.is_empty() || self.poses[0].scene.sky.is_some();
        if lit {
            for p in 0..m {
                let mesh = self.pose_mesh(p);
                let vis = Both(
                    self.static_vis.as_ref(),
                    self.poses[p].moving_occluders.as_ref(),
                );
                let h = direct_light(&self.poses[p].scene, &vis, &mesh, &self.counters.rays);
                for (i, hi) in h.into_iter().enumerate() {
                    self.irradiance[i * m + p] = hi;
                }
            }
        }
        self.exitance = (0..n * m)
            .map(|k| self.materials.exitance(k / m, &self.irradiance[k]))
            .collect();
        self.unshot = self.exitance.clone();
    }

    /// Shoots until the stop rule says stop.
    fn run(&mut self, rule: &StopRule) -> Result<StopReason, RadiosityError> {
        loop {
            let unshot = self.unshot_flux();
            // the largest over poses; a NaN in any pose stays NaN (f64::max drops it)
            let error = unshot
                .errors
                .iter()
                .fold(0.0, |a: f64, &e| if e > a || e.is_nan() { e } else { a });
            let past_deadline = self.clock.past_deadline();
            let nothing_left = unshot.largest_flux <= 0.0;
            let verdict = rule.after_shots(error, nothing_left, self.shots, past_deadline);
            self.report(error, verdict.last);
            if !error.is_finite() {
                return Err(RadiosityError::Diverged(format!(
                    "the unshot flux became {error} of the total"
                )));
            }
            if let Some(stop) = verdict.stop {
                return Ok(stop);
            }
            self.shoot(unshot.largest);
        }
    }

    /// The shooter (largest unshot flux in any pose, Hahn's eq. 4.1) and the error
    /// each pose has left.
    fn unshot_flux(&self) -> Unshot {
        let m = self.pose_count();
        let empty = || PoseSums {
            flux: vec![0.0; m],
            left: vec![0.0; m],
            largest: (0, f64::NEG_INFINITY),
        };
        let sums = self
            .exitance
            .par_chunks(m)
            .zip(self.unshot.par_chunks(m))
            .enumerate()
            .fold(empty, |mut acc, (i, (exitance, unshot))| {
                acc.add_element(i, self.mesh[i].area, exitance, unshot);
                acc
            })
            .reduce(empty, PoseSums::merge);
        let series = self.rho_mean / (1.0 - self.rho_mean).max(MIN_ABSORPTION);
        let errors = sums
            .flux
            .iter()
            .zip(&sums.left)
            .map(|(f, u)| if *f > 0.0 { u * series / f } else { 0.0 })
            .collect();
        Unshot {
            largest: sums.largest.0,
            largest_flux: sums.largest.1,
            errors,
        }
    }

    /// Adds a curve point for the last shot when it is due (or `last`).
    fn report(&mut self, error: f64, last: bool) {
        let now = self.clock.elapsed_s();
        let size = (self.mesh.len(), self.form_factor_evals);
        self.curve.report(now, self.shots, error, size, last);
    }

    /// Shoots the unshot exitance of element `shooter` in every pose at once.
    fn shoot(&mut self, shooter: usize) {
        let m = self.pose_count();
        let shot: Vec<[f64; 3]> = (0..m)
            .map(|p| std::mem::take(&mut self.unshot[shooter * m + p]))
            .collect();
        let shooting: Vec<bool> = shot
            .iter()
            .map(|s| s[1] > 0.0 || s[0] > 0.0 || s[2] > 0.0)
            .collect();
        let gains = self.gains_of(shooter, &shooting);
        self.form_factor_evals += self.mesh.len() * shooting.iter().filter(|s| **s).count();
        let rho = &self.materials.rho;
        self.irradiance
            .par_chunks_mut(m)
            .zip(self.exitance.par_chunks_mut(m))
            .zip(self.unshot.par_chunks_mut(m))
            .zip(gains.par_chunks(m))
            .enumerate()
            .for_each(|(i, (((irradiance, exitance), unshot), gains))| {
                for (p, &g) in gains.iter().enumerate().filter(|(_, g)| **g > 0.0) {
                    for c in 0..3 {
                        let gained = g * shot[p][c];
                        irradiance[p][c] += gained;
                        exitance[p][c] += rho[i][c] * gained;
                        unshot[p][c] += rho[i][c] * gained;
                    }
                }
            });
        self.shots += 1;
    }

    /// Form factors from `shooter` to every element in every shooting pose.
    fn gains_of(&self, shooter: usize, shooting: &[bool]) -> Vec<f64> {
        let m = self.pose_count();
        let ctx = ShotContext {
            static_vis: self.static_vis.as_ref(),
            poses: &self.poses,
            swept: &self.swept,
            shooting,
            key_spacing: self.key_spacing,
            eps: self.eps,
            counters: &self.counters,
        };
        let mut gains = vec![0.0; self.mesh.len() * m];
        let shooter_moves = self.slot[shooter].is_some();
        gains.par_chunks_mut(m).enumerate().for_each(|(r, out)| {
            if shooter_moves || self.slot[r].is_some() {
                ctx.moving_pair(r, shooter, |i, p| self.elem(i, p), out);
            } else {
                ctx.static_pair(&self.mesh[r], &self.mesh[shooter], out);
            }
        });
        gains
    }

    /// One solution per requested frame.
    fn finish(self, stop: StopReason) -> SequenceSolution {
        let m = self.pose_count();
        let errors = self.unshot_flux().errors;
        let stats = self.stats();
        let per_pose: Vec<Solution> = (0..m)
            .map(|p| {
                let column = |v: &[[f64; 3]]| -> Vec<[f64; 3]> {
                    (0..self.mesh.len()).map(|i| v[i * m + p]).collect()
                };
                let patches = patches_from_mesh(
                    &self.pose_mesh(p),
                    &column(&self.exitance),
                    &column(&self.irradiance),
                );
                let by_polygon = Solution::index(&patches, self.poses[p].scene.polygons.len());
                Solution {
                    patches,
                    by_polygon,
                    curve: self.curve.curve.clone(),
                    stop,
                    stats: stats.clone(),
                }
            })
            .collect();
        let plan = &self.plan;
        SequenceSolution {
            frames: plan.requested.clone(),
            solutions: plan.pose_of.iter().map(|&p| per_pose[p].clone()).collect(),
            frame_errors: plan.pose_of.iter().map(|&p| errors[p]).collect(),
            curve: self.curve.curve,
            stop,
            stats,
            distinct_poses: m,
            moving_elements: self.slot.iter().filter(|s| s.is_some()).count(),
            key_spacing: self.key_spacing,
        }
    }

    fn stats(&self) -> SolveStats {
        let (n, m) = (self.mesh.len(), self.pose_count());
        let moved: usize = self.poses.iter().map(|p| p.moved.len()).sum();
        SolveStats {
            patches: n,
            elements: n,
            links: self.form_factor_evals,
            iterations: self.shots,
            shadow_rays: self
                .counters
                .rays
                .load(std::sync::atomic::Ordering::Relaxed),
            visibility_skipped: self
                .counters
                .skipped
                .load(std::sync::atomic::Ordering::Relaxed),
            visibility_tested: self
                .counters
                .tested
                .load(std::sync::atomic::Ordering::Relaxed),
            memory_bytes: (n + moved)
                * (std::mem::size_of::<MeshElem>() + 8 * std::mem::size_of::<V3>())
                + n * m * 80,
            time_s: self.clock.elapsed_s(),
            ..SolveStats::default()
        }
    }
}

/// The base mesh with the static polygons where they sit in pose frame `frame`
/// (a polygon that does not move between the frames may still be displaced).
fn static_pose(base: &Scene, anim: &Animation, frame: usize, mesh: Vec<MeshElem>) -> Vec<MeshElem> {
    let motions = anim.polygon_motions(base, frame);
    mesh.into_iter()
        .map(|e| {
            let m = &motions[e.polygon];
            if m.is_identity() {
                e
            } else {
                moved_elem(&e, m)
            }
        })
        .collect()
}

/// Area-weighted mean luminous reflectance.
fn mean_reflectance(mesh: &[MeshElem], materials: &MeshMaterials) -> f64 {
    let area: f64 = mesh.iter().map(|e| e.area).sum();
    mesh.iter()
        .zip(&materials.rho)
        .map(|(e, r)| e.area * r[1])
        .sum::<f64>()
        / area
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::radiosity::progressive::mesh_ff;
    use crate::scene::parse_animated_scene_toml;

    /// A floor, a wall and a panel that glides and turns between a moving spot and
    /// the floor.
    const SCENE: &str = r#"
[materials.grey]
reflectance_y = 0.6
[[polygons]]
name = "floor"
material = "grey"
vertices = [[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0]]
[[polygons]]
name = "wall"
material = "grey"
vertices = [[0, 2, 0], [2, 2, 0], [2, 2, 2], [0, 2, 2]]
[[polygons]]
name = "panel"
material = "grey"
vertices = [[0.6, 0.6, 0.8], [1.2, 0.6, 0.8], [1.2, 1.2, 0.8], [0.6, 1.2, 0.8]]
[[lights]]
name = "spot"
type = "point"
position = [1.0, 0.8, 1.8]
intensity_cd = 500.0
[animation]
frames = 6
[[animation.tracks]]
object = "panel"
axis = [1, 0, 0]
keys = [{ frame = 0 }, { frame = 5, translate = [0.5, 0.3, 0.2], rotate_deg = 40 }]
"#;

    /// With visibility tested in every pose, each pose's form factors are those of
    /// the single-frame solver on that pose's geometry (static polygons and that
    /// pose's moving ones as occluders), for static and moving senders alike.
    #[test]
    fn every_poses_form_factors_are_the_single_frame_solvers_on_that_pose() {
        let (scene, anim, _) =
            parse_animated_scene_toml(SCENE, std::path::Path::new("."), std::path::Path::new("t"))
                .unwrap();
        let anim = anim.unwrap();
        let stop = StopRule::default();
        let clock = SolveClock::start(&scene, &stop).unwrap();
        let frames: Vec<usize> = (0..6).collect();
        let mut seq = Sequence::new(&scene, &anim, &frames, 0.25, clock).unwrap();
        seq.key_spacing = 1;
        let m = seq.pose_count();
        let all = vec![true; m];
        let moving = (0..seq.mesh.len())
            .find(|&i| seq.slot[i].is_some())
            .unwrap();
        for shooter in [0, seq.mesh.len() / 2, moving] {
            let gains = seq.gains_of(shooter, &all);
            for r in 0..seq.mesh.len() {
                for p in 0..m {
                    let vis = Both(
                        seq.static_vis.as_ref(),
                        seq.poses[p].moving_occluders.as_ref(),
                    );
                    let want = mesh_ff(&vis, seq.elem(r, p), seq.elem(shooter, p), &seq.counters);
                    let got = gains[r * m + p];
                    assert!(
                        (got - want).abs() <= 1e-12 * want.abs().max(1e-9),
                        "shooter {shooter}, receiver {r}, pose {p}: {got} against {want}"
                    );
                }
            }
        }
    }
}
