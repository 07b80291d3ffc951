//! `lumiwall bench random-walls`: issue 12's acceptance on walls drawn at random from
//! its classes (`lumiwall_bench::random_walls`), each commissioned and verified against
//! the truth as `bench readings` does, one row per wall and the counts per class.

use std::ops::RangeInclusive;
use std::path::PathBuf;

use lumiwall_bench::random_walls::{RandomWall, random_wall};
use lumiwall_bench::readings::{self, ReadingsBench, ReadingsRow};
use lumiwall_calib::cli_values::parse_budget;
use lumiwall_calib::solve::SolveOptions;
use lumiwall_calib::station::{MeterChoice, Noise};
use lumiwall_calib::verify::CHART_PATCHES;

use crate::CliError;
use crate::cmd_commission::SolveArgs;
use crate::values;

/// Arguments of `lumiwall bench random-walls`.
#[derive(Debug, clap::Args)]
pub(crate) struct RandomWallsArgs {
    /// Which drawn walls (`0-79`, at most 10 000): wall `n` is the same on every machine.
    #[arg(long, default_value = "0-39", value_parser = parse_walls)]
    walls: RangeInclusive<u64>,
    /// Readings per display on a wall whose displays are all additive (issue 12's
    /// target: 40).
    #[arg(long, default_value_t = 40, value_parser = parse_budget)]
    budget: u32,
    /// Readings per display on a wall with a white segment (issue 12's target: 64).
    #[arg(long, default_value_t = 64, value_parser = parse_budget)]
    budget_non_additive: u32,
    /// Meter error model: `realistic` (judged against the truth) or `none`.
    #[arg(long, default_value = "realistic")]
    noise: Noise,
    /// Meter path (direct is fastest; emulated goes through the pty).
    #[arg(long, default_value = "direct")]
    meter: MeterChoice,
    /// Meter readings each reading averages, as `commission --averaging` (`auto`: from
    /// the wall white).
    #[arg(long, default_value = "auto")]
    averaging: lumiwall_calib::measure::averaging::Averaging,
    /// The wall solve, as `bench readings` (the same defaults, so that a wall's file
    /// runs again there as it ran here).
    #[command(flatten)]
    solve: SolveArgs,
    /// Folder for the drawn wall files, kept so that a wall can be run again with
    /// `bench readings --wall`, and each run's scratch profiles (removed after it).
    #[arg(long, default_value = "out/bench-random-walls")]
    out: PathBuf,
}

/// Most walls one run draws.
const MAX_WALLS: u64 = 10_000;

/// Wall luminance below which a wall counts as dim in the summary (cd/m²): the dim
/// bench walls' class (`bench/walls/README.md`), where the meter's dark noise limits the
/// darkest greys.
const DIM_WALL_CD_M2: f64 = 12.0;

/// `--walls`: a range of at most [`MAX_WALLS`].
fn parse_walls(s: &str) -> Result<RangeInclusive<u64>, String> {
    values::seed_range(s, MAX_WALLS)
}

/// One drawn wall's outcome: its row, or why its commissioning or verification failed.
type WallOutcome = Result<ReadingsRow, String>;

/// Runs `lumiwall bench random-walls`. A wall whose run ends in an error is printed as
/// such and counted outside the limits, and the other walls still run; the command then
/// fails (exit 1) after the counts.
pub(crate) fn run(args: RandomWallsArgs) -> Result<(), CliError> {
    values::check_output_dir("--out", &args.out)?;
    let solve = args.solve.solve_options()?;
    let walls_dir = args.out.join("walls");
    std::fs::create_dir_all(&walls_dir)
        .map_err(|e| CliError::input(format!("cannot create {}: {e}", walls_dir.display())))?;
    println!(
        "issue 12's acceptance on drawn walls {}-{} ({} meter, {} / {} readings per display \
         additive / with a white segment); wall files in {}",
        args.walls.start(),
        args.walls.end(),
        args.noise.name(),
        args.budget,
        args.budget_non_additive,
        walls_dir.display()
    );
    println!(
        "{:<6} {:>8} {:>6} {:>7} {:>7} {:>7} {:>9} {:>6}  class",
        "wall", "white", "budget", "median", "max", "white", "grey", "limits"
    );
    let mut results = Vec::new();
    for n in args.walls.clone() {
        let wall = random_wall(n);
        let path = walls_dir.join(format!("random-{n}.toml"));
        lumiwall_core::files::write_atomic(&path, wall.toml.as_bytes())
            .map_err(|e| CliError::input(format!("cannot write {}: {e}", path.display())))?;
        let outcome = run_wall(&args, solve, &wall, path);
        print_row(&wall, &outcome);
        results.push((wall.non_additive, outcome));
    }
    print_counts(&results);
    let errors = results.iter().filter(|(_, o)| o.is_err()).count();
    if errors > 0 {
        return Err(CliError::failure(format!(
            "the runs of {errors} of {} drawn walls ended in an error (the ERROR rows)",
            results.len()
        )));
    }
    Ok(())
}

/// Commissions and verifies the drawn `wall` (its file at `path`) once; its scratch
/// profiles are removed after, whatever the outcome.
fn run_wall(
    args: &RandomWallsArgs,
    solve: SolveOptions,
    wall: &RandomWall,
    path: PathBuf,
) -> WallOutcome {
    let budget = if wall.non_additive {
        args.budget_non_additive
    } else {
        args.budget
    };
    let scratch = args.out.join(format!("run-{}", wall.index));
    let bench = ReadingsBench {
        wall: path,
        budgets: vec![budget],
        meter: args.meter.clone(),
        solve,
        patches: CHART_PATCHES,
        out: scratch.clone(),
        warm_up: false,
        warm_check: true,
        per_display_matrix: None,
        reference: readings::default_reference(),
        grey_levels: None,
        averaging: args.averaging,
        noises: vec![args.noise],
        seeds: None,
    };
    let rows = readings::run(&bench, &mut |_| {});
    if scratch.exists()
        && let Err(e) = std::fs::remove_dir_all(&scratch)
    {
        tracing::warn!(
            "cannot remove the scratch folder {}: {e}",
            scratch.display()
        );
    }
    rows.map_err(|e| e.to_string())?
        .into_iter()
        .next()
        .ok_or_else(|| "the benchmark gave no row".to_string())
}

/// One wall's row, or the error its run ended with.
fn print_row(wall: &RandomWall, outcome: &WallOutcome) {
    let r = match outcome {
        Ok(r) => r,
        Err(e) => {
            println!("{:<6} ERROR  {}: {e}", wall.index, wall.summary);
            return;
        }
    };
    println!(
        "{:<6} {:>8.2} {:>6} {:>7.3} {:>7.3} {:>7.3} {:>9.3} {:>6}  {}",
        wall.index,
        r.wall_white_cd_m2,
        r.budget,
        r.truth.median_de,
        r.truth.max_de,
        r.worst_white_de,
        r.worst_grey_balance,
        if r.meets_limits() { "meet" } else { "FAIL" },
        wall.summary
    );
}

/// Walls within every limit: all, additive and not, dim and not (a wall whose run
/// ended in an error counts in the first three only).
fn print_counts(results: &[(bool, WallOutcome)]) {
    let count = |keep: &dyn Fn(&(bool, WallOutcome)) -> bool| {
        let group: Vec<_> = results.iter().filter(|r| keep(r)).collect();
        let meet = group
            .iter()
            .filter(|(_, o)| o.as_ref().is_ok_and(ReadingsRow::meets_limits))
            .count();
        format!("{meet} of {}", group.len())
    };
    let white = |r: &(bool, WallOutcome)| r.1.as_ref().map_or(f64::NAN, |r| r.wall_white_cd_m2);
    println!("walls within every limit of issue 12:");
    println!("  all:                         {}", count(&|_| true));
    println!("  additive:                    {}", count(&|r| !r.0));
    println!("  with a white segment:        {}", count(&|r| r.0));
    println!(
        "  wall white {DIM_WALL_CD_M2} cd/m² or more:  {}",
        count(&|r| white(r) >= DIM_WALL_CD_M2)
    );
    println!(
        "  dimmer:                      {}",
        count(&|r| white(r) < DIM_WALL_CD_M2)
    );
}
