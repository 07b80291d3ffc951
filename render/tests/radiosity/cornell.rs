//! Cornell box (published geometry and reflectances, fixtures/scenes/cornell) solved by
//! both solvers and compared with a dense brute-force reference on a uniform mesh. The
//! full error-vs-time table is `lumiwall bench radiosity`; this is the fast CI version.

use std::path::PathBuf;

use crate::support::{solve_hierarchical_with, stop_rule};
use lumiwall_render::radiosity::{
    ProgressiveOptions, SceneOccluders, Solution, solve_dense_reference, solve_progressive,
};
use lumiwall_render::scene::{Scene, load_scene};

fn cornell() -> Scene {
    let p =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/scenes/cornell/cornell.toml");
    load_scene(&p).unwrap().0
}

#[test]
fn both_solvers_agree_with_the_dense_reference() {
    let scene = cornell();
    let occ = SceneOccluders::new(&scene);
    let reference = solve_dense_reference(&scene, &occ, 0.07, 5000).unwrap();
    let stop = |target| stop_rule(target, 60, usize::MAX);
    let hr = solve_hierarchical_with(&scene, &occ, stop(0.1));
    let pr = solve_progressive(
        &scene,
        &occ,
        &ProgressiveOptions {
            stop: stop(0.02),
            max_edge_m: 0.14,
        },
    )
    .unwrap();
    let e_hr = hr.relative_error_against(&reference);
    let e_pr = pr.relative_error_against(&reference);
    let est_hr = hr.curve.last().unwrap().estimated_error;
    println!(
        "reference {} elements; hierarchical: true {e_hr:.4}, estimated {est_hr:.4}, {} patches, {:.2} s; progressive: true {e_pr:.4}, {} shots, {:.2} s",
        reference.stats.patches,
        hr.stats.patches,
        hr.stats.time_s,
        pr.stats.iterations,
        pr.stats.time_s
    );
    assert!(e_hr < 0.1, "hierarchical error {e_hr}");
    // the progressive solve meets its 2 % on the coarser mesh (measured 6.0 % against
    // the reference, the mesh's discretisation error)
    assert!(e_pr < 0.08, "progressive error {e_pr}");
    // the reported estimate bounds the error and is of its size (measured 3.5 × the
    // error against this reference, whose own mesh is coarse, since patches send only
    // from their leaves: 2.15 × before, when the error was larger; against Mitsuba
    // 1.6 × at 10 %, 1.27 × at 2 %, 1.05 × at 1 %). It counts every bounce's transfer
    // error (1/(1 − q), q the contraction).
    assert!(
        est_hr >= e_hr && est_hr < 4.0 * e_hr,
        "estimate {est_hr} vs true {e_hr}"
    );
    // occluders exist: some links needed rays, many were classified fully visible
    assert!(hr.stats.shadow_rays > 0 && hr.stats.visibility_skipped > 0);
    // radiosity is physical: non-negative, finite, and the light is the brightest
    for p in hr.patches.iter().chain(&reference.patches) {
        assert!(p.exitance_xyz.iter().all(|v| v.is_finite() && *v >= 0.0));
    }
    for solution in [&hr, &reference] {
        let (light, rest) = brightest_light_and_rest(&scene, solution);
        assert!(
            light > rest,
            "dimmest light patch {light} vs brightest other {rest}"
        );
    }
    // the red wall reflects more X than Z, the green wall more Y than X
    let wall_mean = |name: &str, c: usize| object_mean_exitance(&scene, &hr, name, c);
    assert!(wall_mean("red_wall", 0) > 2.0 * wall_mean("red_wall", 2));
    assert!(wall_mean("green_wall", 1) > wall_mean("green_wall", 0));
}

/// Area-weighted mean exitance in channel `c` over the patches of object `name`.
fn object_mean_exitance(scene: &Scene, solution: &Solution, name: &str, c: usize) -> f64 {
    let (mut s, mut a) = (0.0, 0.0);
    for p in solution
        .patches
        .iter()
        .filter(|p| scene.polygons[p.polygon].object == name)
    {
        s += p.exitance_xyz[c] * p.area_m2;
        a += p.area_m2;
    }
    s / a
}

/// The dimmest patch (Y exitance) of the light and the brightest of everything else.
fn brightest_light_and_rest(scene: &Scene, solution: &Solution) -> (f64, f64) {
    let (mut light, mut rest) = (f64::INFINITY, 0.0_f64);
    for p in &solution.patches {
        let y = p.exitance_xyz[1];
        if scene.polygons[p.polygon].object == "light" {
            light = light.min(y);
        } else {
            rest = rest.max(y);
        }
    }
    (light, rest)
}

#[test]
fn bvh_and_brute_force_visibility_agree() {
    use lumiwall_render::radiosity::{BvhOccluders, Visibility};
    use lumiwall_render::scene::V3;
    let scene = cornell();
    let brute = SceneOccluders::new(&scene);
    let bvh = BvhOccluders::new(&scene);
    // segments from floor points to ceiling points, some passing through the blocks
    let mut differ = 0;
    let mut blocked = 0;
    for i in 0..20 {
        for j in 0..20 {
            let a = V3::new(0.02 + 0.026 * i as f64, 1e-4, 0.03 + 0.025 * j as f64);
            let b = V3::new(0.5 - 0.024 * j as f64, 0.5487, 0.05 + 0.024 * i as f64);
            let x = brute.occluded(&a, &b, [usize::MAX; 2]);
            let y = bvh.occluded(&a, &b, [usize::MAX; 2]);
            differ += usize::from(x != y);
            blocked += usize::from(x);
        }
    }
    assert!(
        blocked > 20,
        "the blocks must shadow some segments ({blocked})"
    );
    assert_eq!(differ, 0);
}

#[test]
fn hierarchical_time_limit_is_kept_and_never_returns_a_worse_solution_than_before() {
    let scene = cornell();
    let occ = SceneOccluders::new(&scene);
    // An unreachable target: the solve refines until the time limit cuts a
    // refinement (several seconds of link making on this scene) short.
    let limit_s = 1.5;
    let stop = lumiwall_render::radiosity::StopRule {
        target_error: 1e-6,
        time_limit: Some(std::time::Duration::from_secs_f64(limit_s)),
        max_iterations: usize::MAX,
    };
    let sol = solve_hierarchical_with(&scene, &occ, stop);
    assert_eq!(sol.stop, lumiwall_render::radiosity::StopReason::TimeLimit);
    // Within one sweep of the limit. A sweep takes milliseconds alone, but in CI this
    // runs beside other tests, the ArgyllCMS and the Python ones on two cores (1.91 s
    // seen): 1 s of slack. A limit checked only between refinements would overshoot by
    // the several seconds one refinement of this scene takes.
    assert!(
        sol.stats.time_s < limit_s + 1.0,
        "time limit {limit_s} s, solve took {:.2} s",
        sol.stats.time_s
    );
    // The estimate of what is returned is the lowest of the whole run (to 10 %: a
    // cut-short refinement would return one ~50 % higher; the estimate wobbles by a few
    // 1e-5 between converged sweeps, and by 3 % between the first sweeps after a
    // refinement, where a loaded 2-core CI machine reached the limit: 0.2218 after
    // 0.2154).
    let points = &sol.curve.points;
    let last = points.last().unwrap();
    let best = points
        .iter()
        .map(|p| p.estimated_error)
        .fold(f64::INFINITY, f64::min);
    assert!(last.estimated_error <= 1.1 * best, "{points:#?}");
    assert_eq!(last.patches, sol.patches.len());
}
