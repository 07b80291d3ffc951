//! Hahn's simultaneous progressive refinement against each frame solved on its own:
//! the independent answer for every frame is the progressive solver run on that
//! frame's scene.

use std::path::Path;

use lumiwall_render::radiosity::{
    KeySpacing, ProgressiveOptions, SceneOccluders, SequenceSolution, Solution, solve_progressive,
    solve_sequence,
};
use lumiwall_render::scene::{Animation, Scene, load_animated_scene, parse_animated_scene_toml};

use super::support::stop_rule;

fn animated_cornell() -> (Scene, Animation) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/scenes/cornell/cornell_animated.toml");
    let (scene, anim, _) = load_animated_scene(&path).expect("the fixture loads");
    (scene, anim.expect("the fixture is animated"))
}

fn options(target: f64, max_edge_m: f64) -> ProgressiveOptions {
    ProgressiveOptions {
        stop: stop_rule(target, 600, usize::MAX),
        max_edge_m,
    }
}

/// Relative L1 difference of the luminous exitance of two solutions on one mesh.
fn difference(a: &Solution, b: &Solution) -> f64 {
    assert_eq!(a.patches.len(), b.patches.len(), "the same mesh");
    let (mut diff, mut total) = (0.0, 0.0);
    for (p, q) in a.patches.iter().zip(&b.patches) {
        diff += p.area_m2 * (p.exitance_xyz[1] - q.exitance_xyz[1]).abs();
        total += q.area_m2 * q.exitance_xyz[1];
    }
    diff / total
}

/// The largest difference over the frames between the sequence and each frame alone.
fn worst_against_frames_alone(
    scene: &Scene,
    anim: &Animation,
    seq: &SequenceSolution,
    opts: &ProgressiveOptions,
) -> f64 {
    seq.frames
        .iter()
        .zip(&seq.solutions)
        .map(|(&f, sol)| {
            let frame = anim.frame_scene(scene, f);
            let alone = solve_progressive(&frame, &SceneOccluders::new(&frame), opts).unwrap();
            difference(sol, &alone)
        })
        .fold(0.0, f64::max)
}

/// Both solves stop at 0.2 % estimated error (the light not yet shot, amplified by
/// the mean reflectance's series); they agree to 0.017 % on these scenes. Leaving
/// out the moving objects' shadows between static elements puts them 0.37 % (spot
/// scene) and 2.6 % (Cornell box) apart, which 0.1 % catches.
const CONVERGED_AGREEMENT: f64 = 0.001;

#[test]
fn every_frame_of_the_moving_cornell_box_agrees_with_that_frame_solved_alone() {
    let (scene, anim) = animated_cornell();
    let opts = options(0.002, 0.1);
    let frames = [0, 1, 2, 17, 30, 31, 59];
    let seq = solve_sequence(&scene, &anim, &frames, &opts, KeySpacing::Every(1)).unwrap();
    assert_eq!(seq.distinct_poses, frames.len());
    assert!(seq.moving_elements > 0);
    assert!(seq.frame_errors.iter().all(|e| *e <= 0.002));
    let worst = worst_against_frames_alone(&scene, &anim, &seq, &opts);
    assert!(
        worst < CONVERGED_AGREEMENT,
        "worst frame differs by {:.3} %",
        100.0 * worst
    );
}

#[test]
fn visibility_sampled_at_key_frames_stays_within_the_agreement_of_converged_solves() {
    let (scene, anim) = animated_cornell();
    let opts = options(0.002, 0.1);
    let frames: Vec<usize> = (20..40).collect();
    let seq = solve_sequence(&scene, &anim, &frames, &opts, KeySpacing::Auto).unwrap();
    assert!(
        seq.key_spacing > 1,
        "the fixture moves slowly enough to skip frames"
    );
    let worst = worst_against_frames_alone(&scene, &anim, &seq, &opts);
    assert!(
        worst < CONVERGED_AGREEMENT,
        "worst frame differs by {:.3} %",
        100.0 * worst
    );
    time_curves_hold_every_frame(&seq);
}

/// A floor and a wall lit by a spot that swings and moves, with a panel gliding
/// between them: the point light's direct light and its shadow per frame.
const SPOT_SCENE: &str = r#"
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
type = "spot"
position = [1.0, 0.8, 1.8]
intensity_cd = 500.0
axis = [0, 0, -1]
inner_deg = 40
outer_deg = 60
[animation]
frames = 10
[[animation.tracks]]
object = "panel"
keys = [{ frame = 0 }, { frame = 9, translate = [0.5, 0.3, 0.2] }]
[[animation.tracks]]
light = "spot"
axis = [1, 0, 0]
keys = [{ frame = 0 }, { frame = 9, translate = [0.2, 0, 0], rotate_deg = -30 }]
"#;

#[test]
fn a_moving_spot_and_its_moving_shadow_agree_with_each_frame_solved_alone() {
    let (scene, anim, _) =
        parse_animated_scene_toml(SPOT_SCENE, Path::new("."), Path::new("spot.toml")).unwrap();
    let anim = anim.unwrap();
    let opts = options(0.002, 0.1);
    let frames: Vec<usize> = (0..10).collect();
    let seq = solve_sequence(&scene, &anim, &frames, &opts, KeySpacing::Every(1)).unwrap();
    let worst = worst_against_frames_alone(&scene, &anim, &seq, &opts);
    assert!(
        worst < CONVERGED_AGREEMENT,
        "worst frame differs by {:.3} %",
        100.0 * worst
    );
    // the frames differ from each other far more than from their own solves
    let first_to_last = difference(&seq.solutions[0], &seq.solutions[9]);
    assert!(
        first_to_last > 0.05,
        "first and last frame differ by {first_to_last}"
    );
}

#[test]
fn frames_that_repeat_a_pose_are_solved_once() {
    let text = SPOT_SCENE
        .replace(
            "keys = [{ frame = 0 }, { frame = 9, translate = [0.5, 0.3, 0.2] }]",
            "keys = [{ frame = 4 }, { frame = 9, translate = [0.5, 0.3, 0.2] }]",
        )
        .replace(
            "keys = [{ frame = 0 }, { frame = 9, translate = [0.2, 0, 0], rotate_deg = -30 }]",
            "keys = [{ frame = 4 }, { frame = 9, translate = [0.2, 0, 0], rotate_deg = -30 }]",
        );
    let (scene, anim, _) =
        parse_animated_scene_toml(&text, Path::new("."), Path::new("spot.toml")).unwrap();
    let anim = anim.unwrap();
    let opts = options(0.01, 0.2);
    // frames 0..=4 hold the first key's pose
    let still = solve_sequence(&scene, &anim, &[0, 1, 2, 3, 4], &opts, KeySpacing::Auto).unwrap();
    assert_eq!(still.distinct_poses, 1);
    assert_eq!(
        still.moving_elements, 0,
        "nothing moves between these frames"
    );
    let alone = solve_progressive(&scene, &SceneOccluders::new(&scene), &opts).unwrap();
    for sol in &still.solutions {
        assert!(
            difference(sol, &alone) < 1e-9,
            "a still sequence is the frame alone"
        );
    }
    let moving = solve_sequence(&scene, &anim, &[3, 4, 5, 6], &opts, KeySpacing::Auto).unwrap();
    assert_eq!(moving.distinct_poses, 3, "frames 3 and 4 share a pose");
}

/// The piecewise-linear exitance in time reproduces every frame within its tolerance
/// and needs fewer values than the frames.
fn time_curves_hold_every_frame(seq: &SequenceSolution) {
    let relative = 1e-3;
    let curves = seq.exitance_in_time(relative);
    let dimmest = seq
        .solutions
        .iter()
        .map(|s| {
            let a: f64 = s.patches.iter().map(|p| p.area_m2).sum();
            s.patches
                .iter()
                .map(|p| p.area_m2 * p.exitance_xyz[1])
                .sum::<f64>()
                / a
        })
        .fold(f64::INFINITY, f64::min);
    for (i, curve) in curves.iter().enumerate() {
        for (k, sol) in seq.solutions.iter().enumerate() {
            let (got, want) = (curve.at(k), sol.patches[i].exitance_xyz);
            for c in 0..3 {
                assert!((got[c] - want[c]).abs() <= relative * dimmest * (1.0 + 1e-12));
            }
        }
    }
    let knots: usize = curves.iter().map(|c| c.knots.len()).sum();
    assert!(knots < curves.len() * seq.frames.len(), "{knots} knots");
}
