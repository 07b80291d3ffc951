//! `lumiwall render SCENE --frames A..B`: an animated scene's frames solved together
//! by simultaneous progressive refinement (Hahn 2000, ch. 4), one image and PLY per
//! frame, and with `--per-frame` every frame also solved on its own, side by side in
//! one table (time, estimated error, and how far the two solutions lie apart).

use std::path::{Path, PathBuf};
use std::time::Instant;

use lumiwall_render::radiosity::output::{
    render_image, write_exr, write_ply, write_time_curves_csv,
};
use lumiwall_render::radiosity::{
    KeySpacing, ProgressiveOptions, SequenceSolution, Solution, StopRule, solve_progressive,
    solve_sequence,
};
use lumiwall_render::scene::{Animation, Scene, load_animated_scene};

use super::{Method, RenderArgs, occluders_for, print_curve_table, with_ext};
use crate::CliError;
use crate::values;

/// Parses `A..B` (both included, also written `A..=B`) or a single frame `A`.
pub(crate) fn frame_range(s: &str) -> Result<(usize, usize), String> {
    let number = |t: &str| -> Result<usize, String> {
        t.trim()
            .parse()
            .map_err(|_| format!("`{t}` is not a frame number; write A..B, e.g. 0..59"))
    };
    let (a, b) = match s.split_once("..") {
        Some((a, b)) => (number(a)?, number(b.trim_start_matches('='))?),
        None => (number(s)?, number(s)?),
    };
    if a > b {
        return Err(format!("{s}: the first frame must not come after the last"));
    }
    Ok((a, b))
}

/// Parses `auto` or a number of frames of at least 1.
pub(crate) fn key_spacing(s: &str) -> Result<KeySpacing, String> {
    if s.trim() == "auto" {
        return Ok(KeySpacing::Auto);
    }
    match s.trim().parse::<usize>() {
        Ok(n) if n >= 1 => Ok(KeySpacing::Every(n)),
        _ => Err(format!(
            "`{s}`: give `auto` or a number of frames of at least 1"
        )),
    }
}

/// One frame solved on its own.
struct SingleRun {
    solution: Solution,
    time_s: f64,
}

/// Runs `lumiwall render --frames`.
pub(crate) fn run(args: &RenderArgs, (first, last): (usize, usize)) -> Result<(), CliError> {
    if args.method == Some(Method::Radiosity) {
        return Err(CliError::input(
            "--frames solves by simultaneous progressive refinement; leave out --method \
             radiosity (or give --method progressive)",
        ));
    }
    let (scene, anim) = load(&args.scene)?;
    check_range(&anim, first, last)?;
    let frames: Vec<usize> = (first..=last).collect();
    check_out(&args.out)?;
    let mut paths = frame_paths(&args.out, &frames, args.per_frame);
    paths.push(time_path(&args.out));
    values::check_output_files(
        "--out",
        &paths.iter().map(PathBuf::as_path).collect::<Vec<_>>(),
    )?;
    let opts = progressive_options(args);
    println!(
        "animation: frames {first}..{last} ({} frames at {} fps), moving: {}",
        frames.len(),
        anim.fps(),
        anim.track_names().join(", ")
    );
    let keys = args.visibility_keys.unwrap_or(KeySpacing::Auto);
    let seq = solve_sequence(&scene, &anim, &frames, &opts, keys)?;
    print_curve_table(&as_solution(&seq));
    print_sequence_stats(&seq);
    let singles = if args.per_frame {
        Some(solve_each(&scene, &anim, &frames, &opts)?)
    } else {
        None
    };
    print_frame_table(&seq, &anim, singles.as_deref());
    if let Some(s) = &singles {
        print_cost_summary(&seq, s);
    }
    write_frames(&scene, &anim, &seq, singles.as_deref(), &args.out)?;
    write_time_curves(&seq, &time_path(&args.out))?;
    Ok(())
}

/// How closely the piecewise-linear curves in time follow every frame: a tenth of a
/// percent of the dimmest frame's mean exitance.
const TIME_CURVE_TOLERANCE: f64 = 1e-3;

/// `OUT`'s exitance over time: `STEM.time.csv`.
fn time_path(out: &Path) -> PathBuf {
    with_ext(out, ".time.csv")
}

/// Writes every element's exitance as knots of a piecewise-linear function of time
/// and says how many knots that took.
fn write_time_curves(seq: &SequenceSolution, path: &Path) -> Result<(), CliError> {
    let curves = seq.exitance_in_time(TIME_CURVE_TOLERANCE);
    write_time_curves_csv(&seq.frames, &curves, path)?;
    let knots: usize = curves.iter().map(|c| c.knots.len()).sum();
    let per_element = knots as f64 / curves.len().max(1) as f64;
    println!(
        "exitance in time: {per_element:.1} knots per element over {} frames ({:.0} % of one value per frame), each frame within {:.1} % of the dimmest frame's mean; wrote {}",
        seq.frames.len(),
        100.0 * per_element / seq.frames.len() as f64,
        100.0 * TIME_CURVE_TOLERANCE,
        path.display()
    );
    Ok(())
}

/// `--out` names the frames: a file name (not a folder) whose images do not take the
/// PLYs' names.
fn check_out(out: &Path) -> Result<(), CliError> {
    values::check_output_files("--out", &[out])?;
    if out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("ply"))
    {
        return Err(CliError::input(format!(
            "--out {}: the frames' PLYs are written beside the images; give an image name such as anim.exr",
            out.display()
        )));
    }
    Ok(())
}

fn load(path: &Path) -> Result<(Scene, Animation), CliError> {
    let (scene, anim, report) = load_animated_scene(path)?;
    eprintln!("scene {}: {}", path.display(), report.summary());
    let anim = anim.ok_or_else(|| {
        CliError::input(format!(
            "{} has no [animation] entry; --frames needs one (see fixtures/scenes/README.md)",
            path.display()
        ))
    })?;
    Ok((scene, anim))
}

fn check_range(anim: &Animation, first: usize, last: usize) -> Result<(), CliError> {
    if last >= anim.frames() {
        return Err(CliError::input(format!(
            "--frames {first}..{last}: the animation has frames 0..{}",
            anim.frames() - 1
        )));
    }
    Ok(())
}

fn progressive_options(args: &RenderArgs) -> ProgressiveOptions {
    ProgressiveOptions {
        stop: StopRule {
            target_error: args.error,
            time_limit: args.time,
            max_iterations: usize::MAX,
        },
        max_edge_m: args.max_edge_m,
    }
}

/// The sequence's curve and counters as a solution, for the shared printers.
fn as_solution(seq: &SequenceSolution) -> Solution {
    Solution {
        patches: Vec::new(),
        by_polygon: Vec::new(),
        curve: seq.curve.clone(),
        stop: seq.stop,
        stats: seq.stats.clone(),
    }
}

fn print_sequence_stats(seq: &SequenceSolution) {
    let s = &seq.stats;
    println!(
        "sequence: stop {:?}; {} frames, {} distinct poses, visibility every {} poses, {} elements ({} moving), {} shots, {} shadow rays, {:.3} s",
        seq.stop,
        seq.frames.len(),
        seq.distinct_poses,
        seq.key_spacing,
        s.elements,
        seq.moving_elements,
        s.iterations,
        s.shadow_rays,
        s.time_s
    );
}

/// Every frame solved on its own with the same options.
fn solve_each(
    scene: &Scene,
    anim: &Animation,
    frames: &[usize],
    opts: &ProgressiveOptions,
) -> Result<Vec<SingleRun>, CliError> {
    let mut runs = Vec::with_capacity(frames.len());
    for (k, &f) in frames.iter().enumerate() {
        let frame = anim.frame_scene(scene, f);
        let start = Instant::now();
        let occluders = occluders_for(&frame);
        let solution = solve_progressive(&frame, occluders.as_ref(), opts)?;
        runs.push(SingleRun {
            solution,
            time_s: start.elapsed().as_secs_f64(),
        });
        progress(k + 1, frames.len());
    }
    Ok(runs)
}

/// Progress of the frames solved alone on stderr: one updating line on a terminal,
/// every tenth frame otherwise.
fn progress(done: usize, total: usize) {
    use std::io::IsTerminal;
    if std::io::stderr().is_terminal() {
        eprint!("\rsolving each frame on its own: {done}/{total}");
        if done == total {
            eprintln!();
        }
    } else if done.is_multiple_of(10) || done == total {
        eprintln!("solving each frame on its own: {done}/{total}");
    }
}

/// Relative L1 difference of two solutions on the same mesh: Σ A·|ΔY| / Σ A·Y (None
/// when the meshes differ: a frame alone is meshed from its own scene).
fn solution_difference(a: &Solution, b: &Solution) -> Option<f64> {
    let same_mesh = a.patches.len() == b.patches.len()
        && a.patches
            .iter()
            .zip(&b.patches)
            .all(|(p, q)| p.polygon == q.polygon);
    if !same_mesh {
        return None;
    }
    let (mut diff, mut total) = (0.0, 0.0);
    for (p, q) in a.patches.iter().zip(&b.patches) {
        diff += p.area_m2 * (p.exitance_xyz[1] - q.exitance_xyz[1]).abs();
        total += q.area_m2 * q.exitance_xyz[1];
    }
    Some(if total > 0.0 { diff / total } else { 0.0 })
}

fn print_frame_table(seq: &SequenceSolution, anim: &Animation, singles: Option<&[SingleRun]>) {
    print!("{:>6} {:>8} {:>10}", "frame", "time_s", "seq_est");
    if singles.is_some() {
        print!(
            " {:>10} {:>9} {:>7} {:>10}",
            "alone_est", "alone_s", "shots", "seq_vs_alone"
        );
    }
    println!();
    for (k, &f) in seq.frames.iter().enumerate() {
        print!(
            "{f:>6} {:>8.3} {:>9.3}%",
            f as f64 / anim.fps(),
            100.0 * seq.frame_errors[k]
        );
        if let Some(runs) = singles {
            let r = &runs[k];
            let est = r.solution.curve.last().map_or(0.0, |p| p.estimated_error);
            let apart = solution_difference(&seq.solutions[k], &r.solution)
                .map_or("other mesh".to_string(), |d| format!("{:.3}%", 100.0 * d));
            print!(
                " {:>9.3}% {:>9.3} {:>7} {apart:>12}",
                100.0 * est,
                r.time_s,
                r.solution.stats.iterations,
            );
        }
        println!();
    }
}

/// What a frame costs in the sequence against solving it alone.
fn print_cost_summary(seq: &SequenceSolution, singles: &[SingleRun]) {
    let n = singles.len() as f64;
    let alone_total: f64 = singles.iter().map(|r| r.time_s).sum();
    let alone_mean = alone_total / n;
    let seq_s = seq.stats.time_s;
    println!(
        "cost: sequence {seq_s:.2} s for {} frames; each frame alone {alone_mean:.2} s on average ({alone_total:.1} s in all, {:.1}x the sequence)",
        singles.len(),
        alone_total / seq_s
    );
    if singles.len() > 1 {
        let extra = (seq_s - alone_mean) / (n - 1.0);
        println!(
            "cost: each frame after the first adds {extra:.3} s = {:.1} % of a single-frame solve",
            100.0 * extra / alone_mean
        );
    }
}

/// `OUT` of frame `f`: `STEM_FFFF.exr` beside it (`STEM_alone_FFFF.exr` for the
/// frame solved on its own).
fn frame_path(out: &Path, f: usize, alone: bool) -> PathBuf {
    let ext = out.extension().and_then(|e| e.to_str()).unwrap_or("exr");
    let tag = if alone { "_alone" } else { "" };
    with_ext(out, &format!("{tag}_{f:04}.{ext}"))
}

/// Every file `--frames` writes: image and PLY per frame (and per frame alone).
fn frame_paths(out: &Path, frames: &[usize], per_frame: bool) -> Vec<PathBuf> {
    let mut paths = Vec::new();
    for &f in frames {
        for alone in [false, true] {
            if alone && !per_frame {
                continue;
            }
            let img = frame_path(out, f, alone);
            paths.push(img.with_extension("ply"));
            paths.push(img);
        }
    }
    paths
}

fn write_frames(
    scene: &Scene,
    anim: &Animation,
    seq: &SequenceSolution,
    singles: Option<&[SingleRun]>,
    out: &Path,
) -> Result<(), CliError> {
    for (k, &f) in seq.frames.iter().enumerate() {
        let frame = anim.frame_scene(scene, f);
        write_frame(&frame, &seq.solutions[k], &frame_path(out, f, false))?;
        if let Some(runs) = singles {
            write_frame(&frame, &runs[k].solution, &frame_path(out, f, true))?;
        }
    }
    println!(
        "wrote {} frames as {} … (image and PLY each)",
        seq.frames.len(),
        frame_path(out, seq.frames[0], false).display()
    );
    Ok(())
}

fn write_frame(frame: &Scene, sol: &Solution, path: &Path) -> Result<(), CliError> {
    write_ply(sol, &path.with_extension("ply"))?;
    if let Some(cam) = &frame.camera {
        let img = render_image(sol, cam);
        write_exr(&img, cam.width_px as usize, cam.height_px as usize, path)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_range_includes_both_ends_and_refuses_a_reversed_one() {
        assert_eq!(frame_range("0..59"), Ok((0, 59)));
        assert_eq!(frame_range("3..=7"), Ok((3, 7)));
        assert_eq!(frame_range("12"), Ok((12, 12)));
        assert!(frame_range("9..2").is_err());
        assert!(frame_range("a..2").is_err());
    }
}
