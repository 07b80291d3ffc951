//! `lumiwall render` (radiosity solve of a scene → XYZ OpenEXR in cd/m², per-vertex
//! PLY, error/time curve as CSV and PNG) and `lumiwall bench radiosity` (error against
//! time of both solvers on the Cornell box against a dense reference; the saving from
//! skipping visibility work in a scene without occluders).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use lumiwall_render::radiosity::hierarchical::Basis;
use lumiwall_render::radiosity::output::{
    plot_curves_png, render_image, write_curve_csv, write_exr, write_ply, write_preview_png,
};
use lumiwall_render::radiosity::{
    HierarchicalOptions, ProgressiveOptions, SceneOccluders, Solution, StopRule, Visibility,
    solve_dense_reference, solve_hierarchical, solve_progressive,
};
use lumiwall_render::scene::{Scene, load_scene};

use crate::CliError;

/// Radiosity solver choice.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// Hierarchical radiosity with error-bounded refinement.
    Radiosity,
    /// Progressive refinement (shooting) on a uniform mesh.
    Progressive,
}

/// Receiver representation of the hierarchical solver (Kresse 2.5.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BasisArg {
    /// One value per patch (what a lighting engineer reads off).
    Constant,
    /// Vertex values on every patch (smooth Gouraud shading).
    Linear,
    /// Constant where it meets the error bound, linear where it does not.
    Auto,
}

impl From<BasisArg> for Basis {
    fn from(b: BasisArg) -> Self {
        match b {
            BasisArg::Constant => Basis::Constant,
            BasisArg::Linear => Basis::Linear,
            BasisArg::Auto => Basis::Auto,
        }
    }
}

/// Arguments of `lumiwall render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// Scene file (TOML, see fixtures/scenes/README.md).
    pub scene: PathBuf,
    /// Solver.
    #[arg(long, value_enum, default_value = "radiosity")]
    pub method: Method,
    /// Requested relative error, e.g. `1%` or `0.01`.
    #[arg(long, default_value = "1%", value_parser = parse_fraction)]
    pub error: f64,
    /// Wall-time limit, e.g. `60s`, `2m`.
    #[arg(long, value_parser = parse_duration)]
    pub time: Option<Duration>,
    /// Output OpenEXR (channels X, Y, Z in cd/m²); the curve (.csv, .png) and the
    /// per-vertex radiosity (.ply) are written next to it.
    #[arg(long, default_value = "frame.exr")]
    pub out: PathBuf,
    /// Progressive solver: longest element edge in metres.
    #[arg(long, default_value_t = 0.05)]
    pub max_edge_m: f64,
    /// Hierarchical solver: smallest element area in m² (0 = automatic).
    #[arg(long, default_value_t = 0.0)]
    pub min_area_m2: f64,
    /// Hierarchical solver: receiver representation. The constant basis's error
    /// estimate is conservative; the linear one's is exact for smooth light but can
    /// be optimistic near concave corners (Cornell box at 1 %: 1.7 % measured), so
    /// use `constant` where the bound must hold.
    #[arg(long, value_enum, default_value = "auto")]
    pub basis: BasisArg,
}

fn parse_fraction(s: &str) -> Result<f64, String> {
    let t = s.trim();
    let v = if let Some(p) = t.strip_suffix('%') {
        p.trim().parse::<f64>().map(|v| v / 100.0)
    } else {
        t.parse::<f64>()
    }
    .map_err(|e| format!("`{s}` is not an error like 1% or 0.01: {e}"))?;
    if v > 0.0 && v < 1.0 {
        Ok(v)
    } else {
        Err(format!("error {s} must be between 0 and 100 %"))
    }
}

fn parse_duration(s: &str) -> Result<Duration, String> {
    let t = s.trim();
    let (num, mult) = if let Some(n) = t.strip_suffix("ms") {
        (n, 1e-3)
    } else if let Some(n) = t.strip_suffix('s') {
        (n, 1.0)
    } else if let Some(n) = t.strip_suffix('m') {
        (n, 60.0)
    } else if let Some(n) = t.strip_suffix('h') {
        (n, 3600.0)
    } else {
        (t, 1.0)
    };
    let v: f64 = num
        .trim()
        .parse()
        .map_err(|e| format!("`{s}` is not a duration like 60s or 2m: {e}"))?;
    if v.is_finite() && v > 0.0 {
        Ok(Duration::from_secs_f64(v * mult))
    } else {
        Err(format!("duration {s} must be positive"))
    }
}

fn load(path: &Path) -> Result<Scene, CliError> {
    let (scene, report) = load_scene(path).map_err(|e| CliError::input(e.to_string()))?;
    eprintln!("scene {}: {}", path.display(), report.summary());
    Ok(scene)
}

fn solve(
    scene: &Scene,
    vis: &dyn Visibility,
    method: Method,
    stop: StopRule,
    max_edge_m: f64,
    min_area_m2: f64,
    basis: Basis,
) -> Result<Solution, CliError> {
    let r = match method {
        Method::Radiosity => solve_hierarchical(
            scene,
            vis,
            &HierarchicalOptions {
                stop,
                min_area_m2,
                basis,
                ..HierarchicalOptions::default()
            },
        ),
        Method::Progressive => {
            solve_progressive(scene, vis, &ProgressiveOptions { stop, max_edge_m })
        }
    };
    r.map_err(|e| CliError::failure(e.to_string()))
}

fn with_ext(p: &Path, suffix: &str) -> PathBuf {
    let stem = p.file_stem().and_then(|s| s.to_str()).unwrap_or("frame");
    p.with_file_name(format!("{stem}{suffix}"))
}

/// Runs `lumiwall render`.
pub fn run(args: RenderArgs) -> Result<(), CliError> {
    let scene = load(&args.scene)?;
    let occ = SceneOccluders::new(&scene);
    let stop = StopRule {
        target_error: args.error,
        time_limit: args.time,
        max_iterations: usize::MAX,
    };
    let sol = solve(
        &scene,
        &occ,
        args.method,
        stop,
        args.max_edge_m,
        args.min_area_m2,
        args.basis.into(),
    )?;
    println!(
        "{:>9} {:>7} {:>11} {:>11} {:>11} {:>8} {:>10}",
        "time_s", "iter", "est_error", "solve", "discret.", "patches", "links"
    );
    let n = sol.curve.points.len();
    let step = (n / 40).max(1);
    for (i, p) in sol.curve.points.iter().enumerate() {
        if i % step == 0 || i + 1 == n {
            println!(
                "{:>9.3} {:>7} {:>10.3}% {:>10.3}% {:>10.3}% {:>8} {:>10}",
                p.time_s,
                p.iteration,
                100.0 * p.estimated_error,
                100.0 * p.solve_error,
                100.0 * p.discretization_error,
                p.patches,
                p.links
            );
        }
    }
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
        s.memory_bytes as f64 / 1048576.0,
        s.time_s
    );
    let csv = with_ext(&args.out, ".curve.csv");
    let png = with_ext(&args.out, ".curve.png");
    let ply = with_ext(&args.out, ".ply");
    let fail = |e: lumiwall_render::radiosity::RadiosityError| CliError::failure(e.to_string());
    write_curve_csv(&sol.curve, &csv).map_err(fail)?;
    plot_curves_png(&[(&sol.curve, [200, 30, 30])], Some(args.error), &png).map_err(fail)?;
    write_ply(&sol, &ply).map_err(fail)?;
    let mut wrote = vec![csv, png, ply];
    match &scene.camera {
        Some(cam) => {
            let img = render_image(&sol, cam);
            let (w, h) = (cam.width_px as usize, cam.height_px as usize);
            write_exr(&img, w, h, &args.out).map_err(fail)?;
            let preview = with_ext(&args.out, ".preview.png");
            write_preview_png(&img, w, h, &preview).map_err(fail)?;
            wrote.push(args.out.clone());
            wrote.push(preview);
        }
        None => eprintln!("scene has no [camera]: no image written"),
    }
    for w in wrote {
        println!("wrote {}", w.display());
    }
    Ok(())
}

/// Arguments of `lumiwall bench radiosity`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Scene with occluders (default: the Cornell box fixture).
    #[arg(long, default_value = "fixtures/scenes/cornell/cornell.toml")]
    pub scene: PathBuf,
    /// Same room without occluders, for the visibility saving.
    #[arg(long, default_value = "fixtures/scenes/cornell/cornell_empty.toml")]
    pub empty_scene: PathBuf,
    /// Reference mesh: longest element edge in metres.
    #[arg(long, default_value_t = 0.035)]
    pub reference_edge_m: f64,
    /// Time limit per solve in seconds (the scale acceptance: 5 % within 5 minutes).
    #[arg(long, default_value_t = 300.0)]
    pub time_limit_s: f64,
    /// Write the error/time curves of both solvers as a PNG here.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// The scale benchmark (generated cathedral from render::mesh) instead of the
    /// Cornell comparison.
    #[arg(long)]
    pub scale: bool,
    /// Scale benchmark: triangle counts (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "100000")]
    pub sizes: Vec<usize>,
    /// Scale benchmark: number of lights.
    #[arg(long, default_value_t = 100)]
    pub lights: usize,
    /// Scale benchmark: requested error.
    #[arg(long, default_value = "5%", value_parser = parse_fraction)]
    pub scale_error: f64,
    /// Scale benchmark: print the error/time curve of each solve.
    #[arg(long)]
    pub curve: bool,
    /// Scale benchmark: check the solution against an independent Monte Carlo path
    /// tracer at this many patches (picked in proportion to their area; 0 = no check).
    #[arg(long, default_value_t = 0)]
    pub check_patches: usize,
    /// Scale benchmark: paths per checked patch.
    #[arg(long, default_value_t = 20_000)]
    pub check_paths: usize,
}

/// Runs `lumiwall bench radiosity`.
pub fn bench(args: BenchArgs) -> Result<(), CliError> {
    if args.scale {
        return scale_study(&args);
    }
    let scene = load(&args.scene)?;
    let occ = SceneOccluders::new(&scene);
    let t = Instant::now();
    let reference = solve_dense_reference(&scene, &occ, args.reference_edge_m, 20_000)
        .map_err(|e| CliError::failure(e.to_string()))?;
    println!(
        "reference: dense Gauss–Seidel on a uniform mesh, {} elements, {} form factors, {} shadow rays, {:.1} s",
        reference.stats.patches,
        reference.stats.links,
        reference.stats.shadow_rays,
        t.elapsed().as_secs_f64()
    );
    if args.check_patches > 0 {
        println!("reference against the Monte Carlo path tracer:");
        monte_carlo_check(&scene, &reference, args.check_patches, args.check_paths);
    }
    println!(
        "{:<12} {:>7} {:>9} {:>10} {:>10} {:>8} {:>9} {:>10} {:>9}",
        "solver", "target", "time_s", "est_err", "true_err", "patches", "links", "rays", "MiB"
    );
    let limit = Some(Duration::from_secs_f64(args.time_limit_s));
    let mut curves = Vec::new();
    for (method, name, targets, edge) in [
        (
            Method::Radiosity,
            "hierarchical",
            &[0.2, 0.1, 0.05, 0.02, 0.01][..],
            0.0,
        ),
        (
            Method::Progressive,
            "progressive",
            &[0.2, 0.1, 0.05, 0.02, 0.01][..],
            0.07,
        ),
    ] {
        for &target in targets {
            let stop = StopRule {
                target_error: target,
                time_limit: limit,
                max_iterations: usize::MAX,
            };
            let sol = solve(&scene, &occ, method, stop, edge, 0.0, Basis::Auto)?;
            let est = sol
                .curve
                .last()
                .map(|p| p.estimated_error)
                .unwrap_or(f64::NAN);
            let err = sol.relative_error_against(&reference);
            println!(
                "{:<12} {:>6.1}% {:>9.3} {:>9.2}% {:>9.2}% {:>8} {:>9} {:>10} {:>9.1}",
                name,
                100.0 * target,
                sol.stats.time_s,
                100.0 * est,
                100.0 * err,
                sol.stats.patches,
                sol.stats.links,
                sol.stats.shadow_rays,
                sol.stats.memory_bytes as f64 / 1048576.0
            );
            if target == 0.01 {
                curves.push(sol.curve.clone());
            }
        }
    }
    // receiver bases at one target: what the linear representation saves
    println!("receiver bases (hierarchical, 2 %; true error of the represented function):");
    println!(
        "  {:<9} {:>9} {:>10} {:>10} {:>8} {:>8} {:>9}",
        "basis", "time_s", "est_err", "true_err", "patches", "linear", "links"
    );
    for (name, basis) in [
        ("constant", Basis::Constant),
        ("linear", Basis::Linear),
        ("auto", Basis::Auto),
    ] {
        let stop = StopRule {
            target_error: 0.02,
            time_limit: limit,
            max_iterations: usize::MAX,
        };
        let sol = solve(&scene, &occ, Method::Radiosity, stop, 0.0, 0.0, basis)?;
        let est = sol
            .curve
            .last()
            .map(|p| p.estimated_error)
            .unwrap_or(f64::NAN);
        println!(
            "  {:<9} {:>9.3} {:>9.2}% {:>9.2}% {:>8} {:>8} {:>9}",
            name,
            sol.stats.time_s,
            100.0 * est,
            100.0 * sol.relative_error_against(&reference),
            sol.stats.patches,
            sol.stats.linear_patches,
            sol.stats.links
        );
    }
    if let Some(p) = &args.plot {
        let pairs: Vec<_> = curves.iter().zip([[200, 30, 30], [30, 30, 200]]).collect();
        plot_curves_png(&pairs, Some(0.01), p).map_err(|e| CliError::failure(e.to_string()))?;
        println!(
            "wrote {} (red: hierarchical, blue: progressive)",
            p.display()
        );
    }
    // visibility saving in a room without occluders
    let empty = load(&args.empty_scene)?;
    let stop = StopRule {
        target_error: 0.02,
        time_limit: limit,
        max_iterations: usize::MAX,
    };
    let with_culling = solve(
        &empty,
        &SceneOccluders::new(&empty),
        Method::Radiosity,
        stop,
        0.0,
        0.0,
        Basis::Auto,
    )?;
    let always = AlwaysTest(SceneOccluders::new(&empty));
    let without = solve(
        &empty,
        &always,
        Method::Radiosity,
        stop,
        0.0,
        0.0,
        Basis::Auto,
    )?;
    println!("no occluders (cornell_empty, hierarchical, 2 %):");
    for (name, s) in [
        ("classification skips rays", &with_culling),
        ("rays for every link", &without),
    ] {
        println!(
            "  {:<27} {:>8.3} s, {:>10} shadow rays, {} links skipped visibility",
            name, s.stats.time_s, s.stats.shadow_rays, s.stats.visibility_skipped
        );
    }
    Ok(())
}

/// Compares a solution with the Monte Carlo path tracer at `n` patches picked with
/// probability proportional to area (so plain sums estimate area-weighted ones) and
/// prints the relative L1 difference of the patch exitances, with the tracer's own
/// noise beside it.
fn monte_carlo_check(scene: &Scene, sol: &Solution, n: usize, paths: usize) {
    use lumiwall_render::radiosity::montecarlo::MonteCarloReference;
    let t = Instant::now();
    let mc = MonteCarloReference::new(scene);
    let total: f64 = sol.patches.iter().map(|p| p.area_m2).sum();
    // deterministic area-proportional picks (stratified over the cumulative area)
    let mut cum = Vec::with_capacity(sol.patches.len());
    let mut acc = 0.0;
    for p in &sol.patches {
        acc += p.area_m2;
        cum.push(acc);
    }
    let (mut diff, mut sum_ref, mut noise, mut d2, mut s2, mut r2) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for k in 0..n {
        let u = (k as f64 + 0.5) / n as f64 * total;
        let i = cum.partition_point(|&c| c < u).min(sol.patches.len() - 1);
        let p = &sol.patches[i];
        let m = scene.material_of(p.polygon);
        let est = mc.patch_irradiance(&p.vertices, p.polygon, paths, 1000 + k as u64);
        let rho = m.reflectance_xyz[1];
        let reference = std::f64::consts::PI * m.emission_cd_m2[1] + rho * est.irradiance_xyz[1];
        let sigma = rho * est.std_error_y;
        let d = p.exitance_xyz[1] - reference;
        diff += d.abs();
        sum_ref += reference;
        noise += sigma;
        d2 += d * d;
        s2 += sigma * sigma;
        r2 += reference * reference;
    }
    println!(
        "  Monte Carlo check ({n} patches × {paths} paths, {:.1} s): L1 difference {:.2}% (tracer noise {:.2}%), RMS difference less noise {:.2}%",
        t.elapsed().as_secs_f64(),
        100.0 * diff / sum_ref,
        100.0 * noise / sum_ref,
        100.0 * ((d2 - s2).max(0.0) / r2).sqrt()
    );
}

/// Visibility that never classifies a pair as fully visible (the cost without the
/// classification).
struct AlwaysTest(SceneOccluders);

impl Visibility for AlwaysTest {
    fn may_occlude(
        &self,
        _: &[lumiwall_render::scene::V3],
        _: usize,
        _: &[lumiwall_render::scene::V3],
        _: usize,
    ) -> bool {
        true
    }
    fn occluded(
        &self,
        a: &lumiwall_render::scene::V3,
        b: &lumiwall_render::scene::V3,
        skip: [usize; 2],
    ) -> bool {
        self.0.occluded(a, b, skip)
    }
}

/// The scale study: the generated cathedral (render::mesh) at the given triangle
/// counts with `--lights` lights, solved by the hierarchical solver with clustering to
/// `--scale-error` within the time limit; one row per size.
fn scale_study(args: &BenchArgs) -> Result<(), CliError> {
    use lumiwall_render::mesh::generate_scale_scene;
    use lumiwall_render::radiosity::BvhOccluders;
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
        let t0 = Instant::now();
        let scene = generate_scale_scene(n, args.lights, 7).to_scene();
        let vis = BvhOccluders::new(&scene);
        let setup = t0.elapsed().as_secs_f64();
        let stop = StopRule {
            target_error: args.scale_error,
            time_limit: Some(Duration::from_secs_f64(args.time_limit_s)),
            max_iterations: usize::MAX,
        };
        let sol = solve(&scene, &vis, Method::Radiosity, stop, 0.0, 0.0, Basis::Auto)?;
        let s = &sol.stats;
        println!(
            "{:>9} {:>6} {:>8} {:>9} {:>10} {:>9} {:>8.1} {:>11} {:>7.2}% {:>8.2} {:>9.2} {:>8}",
            scene.polygons.len(),
            scene.lights.len(),
            s.clusters,
            s.patches,
            s.links,
            s.cluster_links,
            s.memory_bytes as f64 / 1048576.0,
            s.shadow_rays,
            100.0
                * sol
                    .curve
                    .last()
                    .map(|p| p.estimated_error)
                    .unwrap_or(f64::NAN),
            setup,
            s.time_s,
            format!("{:?}", sol.stop)
        );
        if args.check_patches > 0 {
            monte_carlo_check(&scene, &sol, args.check_patches, args.check_paths);
        }
        if args.curve {
            for p in &sol.curve.points {
                println!(
                    "    t {:>8.2} s  sweep {:>4}  est {:>7.3}%  solve {:>7.3}%  disc {:>7.3}%  patches {:>8}  links {:>9}",
                    p.time_s,
                    p.iteration,
                    100.0 * p.estimated_error,
                    100.0 * p.solve_error,
                    100.0 * p.discretization_error,
                    p.patches,
                    p.links
                );
            }
        }
    }
    Ok(())
}
