//! `lumiwall render` (radiosity solve of a scene → XYZ OpenEXR in cd/m², per-vertex
//! PLY, error/time curve as CSV and PNG) and `lumiwall bench radiosity` (error against
//! time of both solvers on the Cornell box against a dense reference; the saving from
//! skipping visibility work in a scene without occluders), which `lumiwall_bench`
//! runs and this module prints.

use std::path::{Path, PathBuf};
use std::time::Duration;

use lumiwall_bench::image_reference::ImageReference;
use lumiwall_bench::radiosity::{
    self as bench_radiosity, BasisRow, MonteCarloCheck, ScaleRun, SolverRow, VisibilitySaving,
};
use lumiwall_render::radiosity::output::{
    plot_curves_png, render_image, write_curve_csv, write_exr, write_ply, write_preview_png,
};
use lumiwall_render::radiosity::sensors::{
    Sensor, illuminance_at_sensors, read_sensors_csv, write_sensor_readings_csv,
};
use lumiwall_render::radiosity::{
    BvhOccluders, CurvePoint, HierarchicalOptions, KeySpacing, ProgressiveOptions, Solution,
    SolveStats, StopRule, Visibility, occluders_of, solve_hierarchical, solve_progressive,
};
use lumiwall_render::scene::{Scene, load_scene};

use crate::CliError;
use crate::values;

mod frames;
#[cfg(feature = "voxel-gi")]
pub(crate) mod voxel;

/// Radiosity solver choice.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Method {
    /// Hierarchical radiosity with error-bounded refinement.
    Radiosity,
    /// Progressive refinement (shooting) on a uniform mesh. Its estimate is the
    /// light not yet shot, blind to the mesh: it does not bound the error (Cornell
    /// box at `--error 1%`: 6.9 % from Mitsuba, `lumiwall bench radiosity`).
    Progressive,
    /// Voxel-based GI (Thiedemann 2010) for fully dynamic scenes: every frame
    /// voxelised and lit from scratch, direct light and one bounce through VPLs, on
    /// the GPU (`--cpu`: on the CPU); images only, no PLY or error curve.
    #[cfg(feature = "voxel-gi")]
    VoxelGi,
}

/// Receiver representation of the hierarchical solver (Kresse 2.5.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum BasisArg {
    /// One value per patch (what a lighting engineer reads off).
    Constant,
    /// Vertex values on every patch (smooth Gouraud shading).
    Linear,
    /// Constant where it meets the error bound, linear where it does not.
    Auto,
}

impl From<BasisArg> for lumiwall_render::radiosity::hierarchical::Basis {
    fn from(b: BasisArg) -> Self {
        match b {
            BasisArg::Constant => Self::Constant,
            BasisArg::Linear => Self::Linear,
            BasisArg::Auto => Self::Auto,
        }
    }
}

/// Arguments of `lumiwall render`.
#[derive(Debug, clap::Args)]
pub(crate) struct RenderArgs {
    /// Scene file (TOML, see fixtures/scenes/README.md).
    scene: PathBuf,
    /// Solver (default: the scene file's `method`, else radiosity; with --frames:
    /// progressive, the only radiosity solver that solves frames together).
    #[arg(long, value_enum)]
    method: Option<Method>,
    #[cfg(feature = "voxel-gi")]
    #[command(flatten)]
    voxel: voxel::VoxelArgs,
    /// Frames of an animated scene to solve together, `A..B` with both ends included
    /// (e.g. `0..59`), by simultaneous progressive refinement (Hahn 2000): one image
    /// and PLY per frame, `OUT_STEM_FFFF.exr`.
    #[arg(long, value_parser = frames::frame_range, conflicts_with = "sensors")]
    frames: Option<(usize, usize)>,
    /// With --frames: also solve every frame on its own (same mesh and target) and
    /// print both side by side: time, estimated error, and how far the two solutions
    /// lie apart; the frames alone are written as `OUT_STEM_alone_FFFF.exr`.
    #[arg(long, requires = "frames")]
    per_frame: bool,
    /// With --frames: test visibility between moving things at every N-th frame and
    /// bisect where two tests differ (Hahn 2000, 4.3.4), `1` for every frame (exact),
    /// or `auto` (default): the most frames over which nothing moves further than
    /// half an element edge, at most 8.
    #[arg(long, value_parser = frames::key_spacing, requires = "frames")]
    visibility_keys: Option<KeySpacing>,
    /// Requested relative error, e.g. `1%` or `0.01` (between 0 and 100 %).
    #[arg(long, allow_negative_numbers = true, default_value = "1%", value_parser = values::fraction)]
    error: f64,
    /// Wall-time limit, e.g. `60s`, `2m`, `1h` (at most 7 days).
    #[arg(long, allow_negative_numbers = true, value_parser = values::duration)]
    time: Option<Duration>,
    /// Output OpenEXR (channels X, Y, Z in cd/m²); the curve (.csv, .png) and the
    /// per-vertex radiosity (.ply) are written next to it.
    #[arg(long, default_value = "frame.exr")]
    out: PathBuf,
    /// Progressive solver: longest element edge in metres (greater than 0).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.05, value_parser = values::positive_finite)]
    max_edge_m: f64,
    /// Hierarchical solver: smallest element area in m² (0 = automatic).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0, value_parser = values::non_negative_finite)]
    min_area_m2: f64,
    /// Hierarchical solver: receiver representation. The estimate counts every
    /// bounce's transfer error; with the default (auto) it bounded the error measured
    /// against Mitsuba on the Cornell box at 10, 5, 2 and 1 % (7.0, 2.6, 1.5, 0.8 %
    /// measured), a bound checked on that scene and the CIE 171 cases, not proven.
    #[arg(long, value_enum, default_value = "auto")]
    basis: BasisArg,
    /// Hierarchical solver: let patches send light from subdivided elements (their
    /// mean radiosity), as before 2026-12-04. By default only leaves send: that
    /// removed a bias of the indirect light (CIE 171 5.8 at ρ = 0.05: 1.5 % → 0.42 %)
    /// and made the Cornell box at 1 % take 1.8 s instead of 28–41 s.
    #[arg(long)]
    subdivided_senders: bool,
    /// Calculation grid: CSV with columns `name,x_m,y_m,z_m,nx,ny,nz` (metres in the
    /// scene's world frame after `unit_m`; the normal of the measuring plane).
    #[arg(long, requires = "sensors_out")]
    sensors: Option<PathBuf>,
    /// Where the grid's illuminance goes: CSV `name,illuminance_lx,direct_lx,
    /// indirect_lx,indirect_estimated_error_lx,chromaticity_x,chromaticity_y`.
    #[arg(long, requires = "sensors")]
    sensors_out: Option<PathBuf>,
}

/// Loads a scene and reports what was checked on stderr.
fn load(path: &Path) -> Result<Scene, CliError> {
    let (scene, report) = load_scene(path)?;
    eprintln!("scene {}: {}", path.display(), report.summary());
    Ok(scene)
}

/// The visibility queries for `scene`: brute force for a few polygons, else a BVH.
fn occluders_for(scene: &Scene) -> Box<dyn Visibility> {
    occluders_of(scene, &|_| true)
}

/// Solves `scene` with the solver and options of `args`.
fn solve(scene: &Scene, args: &RenderArgs) -> Result<Solution, CliError> {
    let stop = StopRule {
        target_error: args.error,
        time_limit: args.time,
        max_iterations: usize::MAX,
    };
    let occluders = occluders_for(scene);
    let occluders = occluders.as_ref();
    let sol = match args.method.unwrap_or(Method::Radiosity) {
        Method::Radiosity => {
            let opts = HierarchicalOptions {
                stop,
                min_area_m2: args.min_area_m2,
                basis: args.basis.into(),
                leaf_senders: !args.subdivided_senders,
                ..HierarchicalOptions::default()
            };
            solve_hierarchical(scene, occluders, &opts)?
        }
        #[cfg(feature = "voxel-gi")]
        Method::VoxelGi => {
            return Err(CliError::failure(
                "--method voxel-gi is not a radiosity solver (dispatched before)",
            ));
        }
        Method::Progressive => {
            let opts = ProgressiveOptions {
                stop,
                max_edge_m: args.max_edge_m,
            };
            solve_progressive(scene, occluders, &opts)?
        }
    };
    Ok(sol)
}

fn with_ext(p: &Path, suffix: &str) -> PathBuf {
    let stem = p.file_stem().and_then(|s| s.to_str()).unwrap_or("frame");
    p.with_file_name(format!("{stem}{suffix}"))
}

/// Bytes in a MiB.
const MIB: f64 = 1048576.0;

/// Rows of the error/time table `lumiwall render` prints (about; the last is added).
const CURVE_TABLE_ROWS: usize = 40;

/// Estimated, solve and discretisation error of a curve point, in percent.
fn percent_errors(p: &CurvePoint) -> [f64; 3] {
    [
        100.0 * p.estimated_error,
        100.0 * p.solve_error,
        100.0 * p.discretization_error,
    ]
}

/// Runs `lumiwall render`.
pub(crate) fn run(mut args: RenderArgs) -> Result<(), CliError> {
    args.method = args.method.or(method_of_scene(&args.scene)?);
    #[cfg(feature = "voxel-gi")]
    if args.method == Some(Method::VoxelGi) {
        return voxel::run(&args);
    }
    if let Some(range) = args.frames {
        return frames::run(&args, range);
    }
    check_outputs(&args)?;
    let sensors = args.sensors.as_deref().map(read_sensors_csv).transpose()?;
    let scene = load(&args.scene)?;
    let sol = solve(&scene, &args)?;
    print_curve_table(&sol);
    print_stats(&sol);
    for w in write_outputs(&scene, &sol, &args)? {
        println!("wrote {}", w.display());
    }
    if let (Some(sensors), Some(out)) = (sensors, &args.sensors_out) {
        write_sensors(&scene, &sol, &sensors, out)?;
        println!("wrote {}", out.display());
    }
    Ok(())
}

/// The method the scene file asks for (`method = "…"`), if any.
fn method_of_scene(path: &Path) -> Result<Option<Method>, CliError> {
    use lumiwall_render::scene::{MethodHint, scene_method};
    Ok(match scene_method(path)? {
        None => None,
        // the default anyway; not forced, so that --frames still takes progressive
        Some(MethodHint::Radiosity) => None,
        Some(MethodHint::Progressive) => Some(Method::Progressive),
        #[cfg(feature = "voxel-gi")]
        Some(MethodHint::VoxelGi) => Some(Method::VoxelGi),
        #[cfg(not(feature = "voxel-gi"))]
        Some(MethodHint::VoxelGi) => {
            return Err(CliError::input(format!(
                "{} asks for method voxel-gi, which this lumiwall was built without (cargo \
                 feature voxel-gi); give --method radiosity or progressive",
                path.display()
            )));
        }
    })
}

/// Illuminance at the calculation grid's sensors, written as CSV, with a summary.
fn write_sensors(
    scene: &Scene,
    sol: &Solution,
    sensors: &[Sensor],
    out: &Path,
) -> Result<(), CliError> {
    let start = std::time::Instant::now();
    let occluders = BvhOccluders::new(scene);
    let readings = illuminance_at_sensors(scene, sol, &occluders, sensors);
    let estimate = sol.curve.points.last().map_or(0.0, |p| p.estimated_error);
    write_sensor_readings_csv(out, &readings, estimate)?;
    let lux: Vec<f64> = readings.iter().map(|r| r.illuminance_lx()).collect();
    let (lo, hi) = lux
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let mean = lux.iter().sum::<f64>() / lux.len().max(1) as f64;
    println!(
        "sensors: {} points, illuminance min {lo:.4} / mean {mean:.4} / max {hi:.4} lx, uniformity min/mean {:.3}, {:.3} s",
        lux.len(),
        if mean > 0.0 { lo / mean } else { 0.0 },
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// About [`CURVE_TABLE_ROWS`] points of the error/time curve, the last included.
fn print_curve_table(sol: &Solution) {
    println!(
        "{:>9} {:>7} {:>11} {:>11} {:>11} {:>8} {:>10}",
        "time_s", "iter", "est_error", "solve", "discret.", "patches", "links"
    );
    let n = sol.curve.points.len();
    let step = (n / CURVE_TABLE_ROWS).max(1);
    for (i, p) in sol.curve.points.iter().enumerate() {
        if i % step == 0 || i + 1 == n {
            let [est, solve, disc] = percent_errors(p);
            println!(
                "{:>9.3} {:>7} {:>10.3}% {:>10.3}% {:>10.3}% {:>8} {:>10}",
                p.time_s, p.iteration, est, solve, disc, p.patches, p.links
            );
        }
    }
}

fn print_stats(sol: &Solution) {
    let s = &sol.stats;
    println!(
        "stop: {:?}; {} patches, {} elements, {} links, {} shadow rays, visibility skipped/tested {}/{}, ~{:.1} MiB, {:.3} s",
        sol.stop,
        s.patches,
        s.elements,
        s.links,
        s.shadow_rays,
        s.visibility_skipped,
        s.visibility_tested,
        s.memory_bytes as f64 / MIB,
        s.time_s
    );
    if s.enclosed_area_share > 0.0 {
        println!(
            "enclosed: {:.2} % of the surface area lies inside closed solids (no light there)",
            100.0 * s.enclosed_area_share
        );
    }
}

/// The files `render --out OUT` writes: OUT and its siblings.
fn output_paths(out: &Path) -> [PathBuf; 5] {
    [
        out.to_path_buf(),
        with_ext(out, ".curve.csv"),
        with_ext(out, ".curve.png"),
        with_ext(out, ".ply"),
        with_ext(out, ".preview.png"),
    ]
}

/// Checks before the solve that every output of `--out` and `--sensors-out` can be
/// written.
fn check_outputs(args: &RenderArgs) -> Result<(), CliError> {
    let paths = output_paths(&args.out);
    let refs: Vec<&Path> = paths.iter().map(PathBuf::as_path).collect();
    values::check_output_files("--out", &refs)?;
    if let Some(out) = &args.sensors_out {
        values::check_output_files("--sensors-out", &[out.as_path()])?;
    }
    Ok(())
}

/// Writes the curve (CSV, PNG), the per-vertex PLY and, with a camera, the image and
/// its preview; returns the paths written.
fn write_outputs(
    scene: &Scene,
    sol: &Solution,
    args: &RenderArgs,
) -> Result<Vec<PathBuf>, CliError> {
    let [_, csv, png, ply, preview] = output_paths(&args.out);
    write_curve_csv(&sol.curve, &csv)?;
    plot_curves_png(&[(&sol.curve, [200, 30, 30])], Some(args.error), &png)?;
    write_ply(sol, &ply)?;
    let mut wrote = vec![csv, png, ply];
    match &scene.camera {
        Some(cam) => {
            let img = render_image(sol, cam);
            let (w, h) = (cam.width_px as usize, cam.height_px as usize);
            write_exr(&img, w, h, &args.out)?;
            write_preview_png(&img, w, h, &preview)?;
            wrote.push(args.out.clone());
            wrote.push(preview);
        }
        None => eprintln!("scene has no [camera]: no image written"),
    }
    Ok(wrote)
}

/// Arguments of `lumiwall bench radiosity`.
#[derive(Debug, clap::Args)]
pub(crate) struct BenchArgs {
    /// Scene with occluders (default: the Cornell box fixture).
    #[arg(long, default_value = "fixtures/scenes/cornell/cornell.toml")]
    scene: PathBuf,
    /// An independent reference image of the scene (Y in cd/m² as a 2-D `.npy`, the
    /// scene camera's size): every solve's image is measured against it (16×16-pixel
    /// block means, `image_err`, and the mean Y ratio). Skipped when the file is absent.
    #[arg(
        long,
        default_value = "fixtures/scenes/cornell/mitsuba/reference_y.npy"
    )]
    image_reference: Option<PathBuf>,
    /// Same room without occluders, for the visibility saving.
    #[arg(long, default_value = "fixtures/scenes/cornell/cornell_empty.toml")]
    empty_scene: PathBuf,
    /// Reference mesh: longest element edge in metres (greater than 0).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.035, value_parser = values::positive_finite)]
    reference_edge_m: f64,
    /// Time limit per solve in seconds (the scale acceptance: 5 % within 5 minutes; at
    /// most 7 days).
    #[arg(long, allow_negative_numbers = true, default_value = "300", value_parser = values::duration_s)]
    time_limit_s: Duration,
    /// Write the error/time curves of both solvers as a PNG here.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// The scale benchmark (generated cathedral from render::mesh) instead of the
    /// Cornell comparison.
    #[arg(long)]
    scale: bool,
    /// Scale benchmark: triangle counts (comma-separated; each 1 to 10 000 000).
    #[arg(long, value_delimiter = ',', default_value = "100000",
          value_parser = |s: &str| values::count_in(s, 1, MAX_SCALE_TRIANGLES))]
    sizes: Vec<usize>,
    /// Scale benchmark: number of lights (1 to 100 000).
    #[arg(long, default_value_t = 100,
          value_parser = |s: &str| values::count_in(s, 1, MAX_SCALE_LIGHTS))]
    lights: usize,
    /// Scale benchmark: requested error (between 0 and 100 %).
    #[arg(long, allow_negative_numbers = true, default_value = "5%", value_parser = values::fraction)]
    scale_error: f64,
    /// Scale benchmark: print the error/time curve of each solve.
    #[arg(long)]
    curve: bool,
    /// Check the solution (the Cornell reference, or each scale solve) against an
    /// independent Monte Carlo path tracer at this many patches (picked in proportion
    /// to their area; 0 = no check; at most 100 000).
    #[arg(long, default_value_t = 0,
          value_parser = |s: &str| values::count_in(s, 0, MAX_CHECK_PATCHES))]
    check_patches: usize,
    /// Paths per checked patch (1 to 10 000 000).
    #[arg(long, default_value_t = 20_000,
          value_parser = |s: &str| values::count_in(s, 1, MAX_CHECK_PATHS))]
    check_paths: usize,
}

/// Largest triangle count of the scale benchmark's generated cathedral.
const MAX_SCALE_TRIANGLES: usize = 10_000_000;
/// Largest number of lights of the scale benchmark.
const MAX_SCALE_LIGHTS: usize = 100_000;
/// Largest number of patches checked against the Monte Carlo path tracer.
const MAX_CHECK_PATCHES: usize = 100_000;
/// Largest number of Monte Carlo paths per checked patch.
const MAX_CHECK_PATHS: usize = 10_000_000;

impl BenchArgs {
    /// The per-solve limit (already bounded to a week by its value parser).
    fn time_limit(&self) -> Option<Duration> {
        Some(self.time_limit_s)
    }
}

/// Runs `lumiwall bench radiosity`.
pub(crate) fn bench(args: BenchArgs) -> Result<(), CliError> {
    if let Some(p) = &args.plot {
        values::check_output_files("--plot", &[p])?;
    }
    if args.scale {
        return scale_study(&args);
    }
    let scene = load(&args.scene)?;
    let reference = bench_radiosity::dense_reference(&scene, args.reference_edge_m)?;
    let r = &reference.solution.stats;
    println!(
        "reference: dense Gauss–Seidel on a uniform mesh, {} elements, {} form factors, {} shadow rays, {:.1} s",
        r.patches,
        r.links,
        r.shadow_rays,
        reference.elapsed.as_secs_f64()
    );
    if args.check_patches > 0 {
        println!("reference against the Monte Carlo path tracer:");
        let check = bench_radiosity::monte_carlo_check(
            &scene,
            &reference.solution,
            args.check_patches,
            args.check_paths,
        );
        print_monte_carlo_check(&check);
    }
    compare_solvers(&args, &scene, &reference.solution)?;
    compare_bases(&args, &scene, &reference.solution)?;
    let empty = load(&args.empty_scene)?;
    print_visibility_saving(&bench_radiosity::visibility_saving(
        &empty,
        args.time_limit(),
    )?);
    Ok(())
}

/// Both solvers at several targets, and the plot of their curves.
fn compare_solvers(args: &BenchArgs, scene: &Scene, reference: &Solution) -> Result<(), CliError> {
    println!(
        "{:<12} {:>7} {:>9} {:>10} {:>10} {:>10} {:>7} {:>8} {:>9} {:>10} {:>9}",
        "solver",
        "target",
        "time_s",
        "est_err",
        "true_err",
        "image_err",
        "mean_Y",
        "patches",
        "links",
        "rays",
        "MiB"
    );
    let image = match &args.image_reference {
        Some(p) if p.is_file() => Some(ImageReference::read(p).map_err(CliError::input)?),
        Some(p) => {
            println!(
                "no independent reference image at {}: image_err not measured",
                p.display()
            );
            None
        }
        None => None,
    };
    let curves = bench_radiosity::solver_comparison(
        scene,
        reference,
        image.as_ref(),
        args.time_limit(),
        &mut print_solver_row,
    )?;
    if let Some(p) = &args.plot {
        bench_radiosity::plot_solver_curves(&curves, p)?;
        println!(
            "wrote {} (red: hierarchical, blue: progressive)",
            p.display()
        );
    }
    Ok(())
}

fn print_solver_row(r: &SolverRow) {
    let s = &r.stats;
    println!(
        "{:<12} {:>6.1}% {:>9.3} {:>9.2}% {:>9.2}% {:>10} {:>7} {:>8} {:>9} {:>10} {:>9.1}",
        r.solver,
        100.0 * r.target,
        s.time_s,
        100.0 * r.estimated_error,
        100.0 * r.true_error,
        r.image_error
            .map_or("-".into(), |e| format!("{:.2}%", 100.0 * e.rel_l1)),
        r.image_error
            .map_or("-".into(), |e| format!("{:.4}", e.mean_ratio)),
        s.patches,
        s.links,
        s.shadow_rays,
        s.memory_bytes as f64 / MIB
    );
}

/// The receiver bases at one target: what the linear representation saves.
fn compare_bases(args: &BenchArgs, scene: &Scene, reference: &Solution) -> Result<(), CliError> {
    println!("receiver bases (hierarchical, 2 %; true error of the represented function):");
    println!(
        "  {:<9} {:>9} {:>10} {:>10} {:>8} {:>8} {:>9}",
        "basis", "time_s", "est_err", "true_err", "patches", "linear", "links"
    );
    bench_radiosity::basis_comparison(scene, reference, args.time_limit(), &mut print_basis_row)?;
    Ok(())
}

fn print_basis_row(r: &BasisRow) {
    let s = &r.stats;
    println!(
        "  {:<9} {:>9.3} {:>9.2}% {:>9.2}% {:>8} {:>8} {:>9}",
        r.basis,
        s.time_s,
        100.0 * r.estimated_error,
        100.0 * r.true_error,
        s.patches,
        s.linear_patches,
        s.links
    );
}

fn print_visibility_saving(v: &VisibilitySaving) {
    println!("no occluders (cornell_empty, hierarchical, 2 %):");
    let rows: [(&str, &SolveStats); 2] = [
        ("classification skips rays", &v.with_classification),
        ("rays for every link", &v.rays_for_every_link),
    ];
    for (name, s) in rows {
        println!(
            "  {:<27} {:>8.3} s, {:>10} shadow rays, {} links skipped visibility",
            name, s.time_s, s.shadow_rays, s.visibility_skipped
        );
    }
}

fn print_monte_carlo_check(c: &MonteCarloCheck) {
    println!(
        "  Monte Carlo check ({} patches × {} paths, {:.1} s): L1 difference {:.2}% (tracer noise {:.2}%), RMS difference less noise {:.2}%",
        c.patches,
        c.paths,
        c.elapsed.as_secs_f64(),
        100.0 * c.l1_difference,
        100.0 * c.tracer_noise,
        100.0 * c.rms_less_noise
    );
}

/// The scale study: the generated cathedral (render::mesh) at the given triangle
/// counts with `--lights` lights, solved by the hierarchical solver with clustering to
/// `--scale-error` within the time limit; one row per size.
fn scale_study(args: &BenchArgs) -> Result<(), CliError> {
    println!(
        "{:>9} {:>6} {:>8} {:>9} {:>10} {:>9} {:>8} {:>11} {:>8} {:>8} {:>9} {:>8}",
        "triangles",
        "lights",
        "clusters",
        "patches",
        "links",
        "clus.lnk",
        "MiB",
        "rays",
        "est_err",
        "setup_s",
        "solve_s",
        "stop"
    );
    for &n in &args.sizes {
        let run = bench_radiosity::scale_run(n, args.lights, args.scale_error, args.time_limit())?;
        print_scale_row(&run);
        if args.check_patches > 0 {
            print_monte_carlo_check(&bench_radiosity::monte_carlo_check(
                &run.scene,
                &run.solution,
                args.check_patches,
                args.check_paths,
            ));
        }
        if args.curve {
            print_scale_curve(&run.solution);
        }
    }
    Ok(())
}

fn print_scale_row(run: &ScaleRun) {
    let s = &run.solution.stats;
    println!(
        "{:>9} {:>6} {:>8} {:>9} {:>10} {:>9} {:>8.1} {:>11} {:>7.2}% {:>8.2} {:>9.2} {:>8}",
        run.scene.polygons.len(),
        run.scene.lights.len(),
        s.clusters,
        s.patches,
        s.links,
        s.cluster_links,
        s.memory_bytes as f64 / MIB,
        s.shadow_rays,
        100.0 * bench_radiosity::final_estimated_error(&run.solution),
        run.setup_s,
        s.time_s,
        format!("{:?}", run.solution.stop)
    );
}

fn print_scale_curve(sol: &Solution) {
    for p in &sol.curve.points {
        let [est, solve, disc] = percent_errors(p);
        println!(
            "    t {:>8.2} s  sweep {:>4}  est {:>7.3}%  solve {:>7.3}%  disc {:>7.3}%  patches {:>8}  links {:>9}",
            p.time_s, p.iteration, est, solve, disc, p.patches, p.links
        );
    }
}
