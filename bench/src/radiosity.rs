//! `lumiwall bench radiosity`: error against time of both solvers on the Cornell box
//! against a dense reference, the receiver bases, the saving from skipping visibility
//! work in a room without occluders, and the scale study on the generated cathedral.
//!
//! Each step returns its rows; the command line prints them as they come (the
//! benchmark takes minutes).

use std::path::Path;
use std::time::{Duration, Instant};

use lumiwall_render::mesh::generate_scale_scene;
use lumiwall_render::radiosity::hierarchical::Basis;
use lumiwall_render::radiosity::montecarlo::MonteCarloReference;
use lumiwall_render::radiosity::output::{plot_curves_png, render_image};

use crate::image_reference::{ImageError, ImageReference};
use lumiwall_render::radiosity::{
    BvhOccluders, ErrorCurve, HierarchicalOptions, ProgressiveOptions, RadiosityError,
    SceneOccluders, Solution, SolveStats, StopRule, Visibility, solve_dense_reference,
    solve_hierarchical, solve_progressive,
};
use lumiwall_render::scene::{Scene, V3};

/// Largest mesh the dense reference accepts (its matrix needs 8·n² bytes: 3.2 GB).
pub const REFERENCE_MAX_ELEMENTS: usize = 20_000;

/// The requested errors of the solver comparison.
pub const SOLVER_TARGETS: [f64; 5] = [0.2, 0.1, 0.05, 0.02, 0.01];

/// The target whose error/time curves are plotted.
pub const PLOTTED_TARGET: f64 = 0.01;

/// Longest element edge of the progressive solver's uniform mesh in the comparison (m).
pub const PROGRESSIVE_EDGE_M: f64 = 0.07;

/// Requested error of the basis comparison and the visibility saving.
pub const BASIS_TARGET: f64 = 0.02;

/// Seed of the generated cathedral.
pub const SCALE_SCENE_SEED: u64 = 7;

/// Seed of the first checked patch's paths (patch k uses this + k).
const MONTE_CARLO_SEED: u64 = 1000;

/// Stop at `target_error` or after `time_limit`.
fn stop_rule(target_error: f64, time_limit: Option<Duration>) -> StopRule {
    StopRule {
        target_error,
        time_limit,
        max_iterations: usize::MAX,
    }
}

/// The dense reference solution and its wall time.
#[derive(Debug, Clone)]
pub struct Reference {
    /// Dense Gauss–Seidel on a uniform mesh.
    pub solution: Solution,
    /// Wall time of the solve.
    pub elapsed: Duration,
}

/// Solves `scene` densely on a uniform mesh with edges ≤ `edge_m`.
pub fn dense_reference(scene: &Scene, edge_m: f64) -> Result<Reference, RadiosityError> {
    let started = Instant::now();
    let occluders = SceneOccluders::new(scene);
    let solution = solve_dense_reference(scene, &occluders, edge_m, REFERENCE_MAX_ELEMENTS)?;
    Ok(Reference {
        solution,
        elapsed: started.elapsed(),
    })
}

/// A solution against the Monte Carlo path tracer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MonteCarloCheck {
    /// Patches checked.
    pub patches: usize,
    /// Paths per patch.
    pub paths: usize,
    /// Wall time of the tracer.
    pub elapsed: Duration,
    /// Relative L1 difference of the patch exitances (Y).
    pub l1_difference: f64,
    /// The tracer's own noise on the same scale.
    pub tracer_noise: f64,
    /// Relative RMS difference with the tracer's variance removed.
    pub rms_less_noise: f64,
}

/// Sums over the checked patches.
#[derive(Debug, Default)]
struct CheckSums {
    abs_difference: f64,
    reference: f64,
    noise: f64,
    squared_difference: f64,
    squared_noise: f64,
    squared_reference: f64,
}

/// Compares a solution with the Monte Carlo path tracer at `n` patches picked with
/// probability proportional to area (deterministic, stratified over the cumulative
/// area, so plain sums estimate area-weighted ones).
pub fn monte_carlo_check(scene: &Scene, sol: &Solution, n: usize, paths: usize) -> MonteCarloCheck {
    let started = Instant::now();
    let tracer = MonteCarloReference::new(scene);
    let cumulative_area: Vec<f64> = sol
        .patches
        .iter()
        .scan(0.0, |acc, p| {
            *acc += p.area_m2;
            Some(*acc)
        })
        .collect();
    let total = cumulative_area.last().copied().unwrap_or(0.0);
    let mut sums = CheckSums::default();
    // A solution without patches has nothing to check.
    let n = if sol.patches.is_empty() { 0 } else { n };
    for k in 0..n {
        let u = (k as f64 + 0.5) / n as f64 * total;
        let i = cumulative_area
            .partition_point(|&c| c < u)
            .min(sol.patches.len() - 1);
        let p = &sol.patches[i];
        let m = scene.material_of(p.polygon);
        let est =
            tracer.patch_irradiance(&p.vertices, p.polygon, paths, MONTE_CARLO_SEED + k as u64);
        let rho = m.reflectance_xyz[1];
        let reference = std::f64::consts::PI * m.emission_cd_m2[1] + rho * est.irradiance_xyz[1];
        let sigma = rho * est.std_error_y;
        let d = p.exitance_xyz[1] - reference;
        sums.abs_difference += d.abs();
        sums.reference += reference;
        sums.noise += sigma;
        sums.squared_difference += d * d;
        sums.squared_noise += sigma * sigma;
        sums.squared_reference += reference * reference;
    }
    MonteCarloCheck {
        patches: n,
        paths,
        elapsed: started.elapsed(),
        l1_difference: sums.abs_difference / sums.reference,
        tracer_noise: sums.noise / sums.reference,
        rms_less_noise: ((sums.squared_difference - sums.squared_noise).max(0.0)
            / sums.squared_reference)
            .sqrt(),
    }
}

/// The estimated error at the end of a solve (NaN without a curve).
pub fn final_estimated_error(sol: &Solution) -> f64 {
    sol.curve
        .last()
        .map(|p| p.estimated_error)
        .unwrap_or(f64::NAN)
}

/// One solve of the solver comparison.
#[derive(Debug, Clone)]
pub struct SolverRow {
    /// `hierarchical` or `progressive`.
    pub solver: &'static str,
    /// Requested error.
    pub target: f64,
    /// The solver's own error estimate at the end.
    pub estimated_error: f64,
    /// Relative error against the dense reference.
    pub true_error: f64,
    /// Error of the rendered image against the independent reference image, when
    /// one was given.
    pub image_error: Option<ImageError>,
    /// Counters of the solve.
    pub stats: SolveStats,
}

/// Both solvers at every [`SOLVER_TARGETS`] error within `limit` each; `on_row` sees
/// each row, with the image error against `image` (rendered by the scene's camera)
/// when given. Returns the curves of the [`PLOTTED_TARGET`] solves (hierarchical first).
pub fn solver_comparison(
    scene: &Scene,
    reference: &Solution,
    image: Option<&ImageReference>,
    limit: Option<Duration>,
    on_row: &mut dyn FnMut(&SolverRow),
) -> Result<Vec<ErrorCurve>, RadiosityError> {
    let occluders = SceneOccluders::new(scene);
    let mut curves = Vec::new();
    for solver in ["hierarchical", "progressive"] {
        for target in SOLVER_TARGETS {
            let stop = stop_rule(target, limit);
            let sol = if solver == "hierarchical" {
                hierarchical(scene, &occluders, stop, Basis::Auto)?
            } else {
                let opts = ProgressiveOptions {
                    stop,
                    max_edge_m: PROGRESSIVE_EDGE_M,
                };
                solve_progressive(scene, &occluders, &opts)?
            };
            on_row(&SolverRow {
                solver,
                target,
                estimated_error: final_estimated_error(&sol),
                true_error: sol.relative_error_against(reference),
                image_error: image.and_then(|r| image_error(scene, &sol, r)),
                stats: sol.stats.clone(),
            });
            if target == PLOTTED_TARGET {
                curves.push(sol.curve);
            }
        }
    }
    Ok(curves)
}

/// The solution rendered by the scene's camera against `reference` (`None` without a
/// camera or when the sizes differ).
fn image_error(scene: &Scene, sol: &Solution, reference: &ImageReference) -> Option<ImageError> {
    let cam = scene.camera.as_ref()?;
    let y: Vec<f64> = render_image(sol, cam)
        .iter()
        .map(|p| f64::from(p[1]))
        .collect();
    reference.error_of(&y)
}

/// The hierarchical solver with `basis` and the default options otherwise.
fn hierarchical(
    scene: &Scene,
    vis: &dyn Visibility,
    stop: StopRule,
    basis: Basis,
) -> Result<Solution, RadiosityError> {
    let opts = HierarchicalOptions {
        stop,
        basis,
        ..HierarchicalOptions::default()
    };
    solve_hierarchical(scene, vis, &opts)
}

/// Writes the curves of [`solver_comparison`] as a PNG (red: hierarchical, blue:
/// progressive) with the plotted target marked.
pub fn plot_solver_curves(curves: &[ErrorCurve], path: &Path) -> Result<(), RadiosityError> {
    let pairs: Vec<_> = curves.iter().zip([[200, 30, 30], [30, 30, 200]]).collect();
    plot_curves_png(&pairs, Some(PLOTTED_TARGET), path)
}

/// One receiver basis at [`BASIS_TARGET`].
#[derive(Debug, Clone)]
pub struct BasisRow {
    /// `constant`, `linear` or `auto`.
    pub basis: &'static str,
    /// The solver's own error estimate at the end.
    pub estimated_error: f64,
    /// Relative error of the represented function against the dense reference.
    pub true_error: f64,
    /// Counters of the solve.
    pub stats: SolveStats,
}

/// The hierarchical solver with each receiver basis; `on_row` sees each row.
pub fn basis_comparison(
    scene: &Scene,
    reference: &Solution,
    limit: Option<Duration>,
    on_row: &mut dyn FnMut(&BasisRow),
) -> Result<Vec<BasisRow>, RadiosityError> {
    let occluders = SceneOccluders::new(scene);
    let mut rows = Vec::new();
    for (name, basis) in [
        ("constant", Basis::Constant),
        ("linear", Basis::Linear),
        ("auto", Basis::Auto),
    ] {
        let sol = hierarchical(scene, &occluders, stop_rule(BASIS_TARGET, limit), basis)?;
        let row = BasisRow {
            basis: name,
            estimated_error: final_estimated_error(&sol),
            true_error: sol.relative_error_against(reference),
            stats: sol.stats,
        };
        on_row(&row);
        rows.push(row);
    }
    Ok(rows)
}

/// The hierarchical solve of a room without occluders with and without the
/// classification that skips shadow rays.
#[derive(Debug, Clone)]
pub struct VisibilitySaving {
    /// With the classification (links between mutually visible patches skip rays).
    pub with_classification: SolveStats,
    /// With rays for every link.
    pub rays_for_every_link: SolveStats,
}

/// Solves `empty` (a room without occluders) at [`BASIS_TARGET`] both ways.
pub fn visibility_saving(
    empty: &Scene,
    limit: Option<Duration>,
) -> Result<VisibilitySaving, RadiosityError> {
    let stop = stop_rule(BASIS_TARGET, limit);
    let with = hierarchical(empty, &SceneOccluders::new(empty), stop, Basis::Auto)?;
    let always = AlwaysTest(SceneOccluders::new(empty));
    let without = hierarchical(empty, &always, stop, Basis::Auto)?;
    Ok(VisibilitySaving {
        with_classification: with.stats,
        rays_for_every_link: without.stats,
    })
}

/// Visibility that never classifies a pair as fully visible (the cost without the
/// classification).
struct AlwaysTest(SceneOccluders);

impl Visibility for AlwaysTest {
    fn may_occlude(&self, _: &[V3], _: usize, _: &[V3], _: usize) -> bool {
        true
    }

    fn occluded(&self, a: &V3, b: &V3, skip: [usize; 2]) -> bool {
        self.0.occluded(a, b, skip)
    }
}

/// One size of the scale study.
#[derive(Clone)]
pub struct ScaleRun {
    /// The generated cathedral.
    pub scene: Scene,
    /// Its hierarchical solution (with clustering).
    pub solution: Solution,
    /// Wall time of generating the scene and building the BVH, in s.
    pub setup_s: f64,
}

/// The generated cathedral (render::mesh) with `triangles` triangles and `lights`
/// lights, solved by the hierarchical solver to `target_error` within `limit`.
pub fn scale_run(
    triangles: usize,
    lights: usize,
    target_error: f64,
    limit: Option<Duration>,
) -> Result<ScaleRun, RadiosityError> {
    let started = Instant::now();
    let scene = generate_scale_scene(triangles, lights, SCALE_SCENE_SEED).to_scene();
    let occluders = BvhOccluders::new(&scene);
    let setup_s = started.elapsed().as_secs_f64();
    let solution = hierarchical(
        &scene,
        &occluders,
        stop_rule(target_error, limit),
        Basis::Auto,
    )?;
    Ok(ScaleRun {
        scene,
        solution,
        setup_s,
    })
}
