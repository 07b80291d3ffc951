//! `lumiwall verify`: show target colours through the profiles on the wall, read them
//! with the meter, print per-patch ΔL %, Δxy, ΔE2000 and a summary table; exit code 3
//! when the results are outside the user's tolerances.

use std::path::{Path, PathBuf};

use indicatif::{ProgressBar, ProgressStyle};
use lumiwall_calib::cli_values::parse_patches;
use lumiwall_calib::measure::Rig;
use lumiwall_calib::measure::meter_matrix::MeterMatrices;
use lumiwall_calib::measure::meter_offset::{CorrectedMeter, MeterCorrection};
use lumiwall_calib::measure::warm_up::progress_line;
use lumiwall_calib::measure::{MeasureOptions, Progress};
use lumiwall_calib::spatial::{GridOptions, MatrixCorrected, Truth, verify_grid};
use lumiwall_calib::station::Station;
use lumiwall_calib::verify::{
    Tolerances, VerifyOptions, VerifyReport, chart_targets, default_targets, wait_if_warming,
};
use lumiwall_devices::Colorimeter;
use lumiwall_profiles::ProfileSet;

use crate::CliError;
use crate::cmd_commission::{MeterArgs, say};
use crate::values;

/// Arguments of `lumiwall verify`.
#[derive(Debug, clap::Args)]
pub(crate) struct VerifyArgs {
    /// Wall description (TOML).
    #[arg(long)]
    wall: PathBuf,
    /// Profile folder written by `lumiwall commission`.
    #[arg(long)]
    profiles: PathBuf,
    /// Number of target colours per display (1 to 100 000).
    #[arg(long, default_value_t = 20, value_parser = parse_patches)]
    patches: usize,
    /// A verification chart instead of `--patches`: `51` (white, eleven greys,
    /// primaries and secondaries at full and half intensity, memory colours, dark
    /// patches, mixes), judged by mean, 95th percentile and max ΔE2000, white ΔE2000
    /// and grey balance.
    #[arg(long, value_parser = parse_chart, conflicts_with = "patches")]
    chart: Option<usize>,
    /// Largest ΔE2000 allowed on any patch (a finite number greater than 0; default
    /// 1.5, with `--chart` DisplayCAL's recommended 3).
    #[arg(long, allow_negative_numbers = true, value_parser = values::positive_finite)]
    max_de: Option<f64>,
    /// Largest median ΔE2000 allowed (per display and overall; greater than 0; default
    /// 0.5, with `--chart` 1, where DisplayCAL's mean of 1 is the measure).
    #[arg(long, allow_negative_numbers = true, value_parser = values::positive_finite)]
    median_de: Option<f64>,
    /// Largest mean ΔE2000 allowed per display (DisplayCAL's recommended value: 1).
    #[arg(long, allow_negative_numbers = true, default_value_t = 1.0, value_parser = values::positive_finite)]
    mean_de: f64,
    /// Largest ΔE2000 of the white patch's colour, its luminance normalised to the
    /// target's as DisplayCAL's "measured vs. assumed target whitepoint" (DisplayCAL: 1;
    /// with a chart that has one). The white's luminance error is printed beside it.
    #[arg(long, allow_negative_numbers = true, default_value_t = 1.0, value_parser = values::positive_finite)]
    white_de: f64,
    /// Largest grey balance: mean |ΔC'| (CIEDE2000 chroma term) over the greys of at
    /// least 1 % of the white, each against the display's measured white (DisplayCAL:
    /// 0.5 recommended).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.5, value_parser = values::positive_finite)]
    grey_balance: f64,
    /// Largest black luminance difference (%) from the common black (common mode;
    /// greater than 0).
    #[arg(long, allow_negative_numbers = true, default_value_t = 5.0, value_parser = values::positive_finite)]
    black_dl: f64,
    /// Largest black chromaticity difference from the common black (common mode;
    /// greater than 0).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.008, value_parser = values::positive_finite)]
    black_dxy: f64,
    #[command(flatten)]
    pub(crate) meter: MeterArgs,
    /// Print only the summary, not every patch.
    #[arg(long)]
    summary_only: bool,
    /// Spatial verification instead of target colours: the wall white at a grid of
    /// cells per display (`5x5`, ISO 14861 style), at both sides of every seam and
    /// (Infitec) left against right eye. On the virtual wall the meter is aimed at every
    /// cell and the simulator's own truth is printed beside it.
    #[arg(long, value_parser = parse_grid)]
    grid: Option<[u32; 2]>,
    /// Virtual wall only: let its lamps age this many hours before verifying (as
    /// `recalibrate --simulate-hours`).
    #[arg(long, allow_negative_numbers = true, value_parser = values::non_negative_finite)]
    simulate_hours: Option<f64>,
    /// Write the spatial verification's heat map (SVG) here (with `--grid`).
    #[arg(long, requires = "grid")]
    heat_map: Option<PathBuf>,
    /// Read the chart at once. By default the station first reads the first display's
    /// white 40 times and, when the wall is still warming (as `commission` judges it),
    /// waits until it is warm: a calibration is made for the warm wall, and lamps still
    /// warming would be judged in a state the wall is not used in (the virtual wall's
    /// lamps start at its file's minutes after switch-on in every run). A wall that does
    /// not settle within the wait is verified as it is, with a warning. The same before
    /// `--grid`'s cells.
    #[arg(long)]
    no_warm_check: bool,
    /// Meter readings each reading of the chart averages: `auto` as `commission
    /// --averaging auto` chooses for the profiles' wall white (the dimmest target
    /// white; 3 on a 12.7 cd/m² wall with a CS-100A class meter, 1 from about 18
    /// cd/m²), so the darkest greys are judged as quietly as they were calibrated; a
    /// number fixes it. The warm check, and `--grid`'s cells, read once.
    #[arg(long, default_value = "auto")]
    averaging: lumiwall_calib::measure::averaging::Averaging,
}

/// Parses `CxR` (e.g. `5x5`), each 1..=64.
fn parse_grid(s: &str) -> Result<[u32; 2], String> {
    let err = || format!("grid {s:?} must be COLSxROWS, each 1 to 64 (e.g. 5x5)");
    let (c, r) = s.split_once(['x', 'X']).ok_or_else(err)?;
    let c: u32 = c.trim().parse().map_err(|_| err())?;
    let r: u32 = r.trim().parse().map_err(|_| err())?;
    if (1..=64).contains(&c) && (1..=64).contains(&r) {
        Ok([c, r])
    } else {
        Err(err())
    }
}

/// The xy correction saved by `lumiwall commission` for this instrument, if any (none
/// for the exact simulated meter, which reads the truth).
pub(crate) fn load_meter_correction(
    meter_args: &MeterArgs,
    dir: &Path,
    meter: &dyn Colorimeter,
) -> Result<Option<[f64; 2]>, CliError> {
    let path = dir.join(MeterCorrection::FILE);
    if meter_args.reads_truth() {
        note_truth_not_corrected(&path);
        return Ok(None);
    }
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => {
            return Err(CliError::input(format!(
                "cannot read {}: {e}",
                path.display()
            )));
        }
    };
    let c: MeterCorrection = serde_json::from_str(&text)
        .map_err(|e| CliError::input(format!("{} is not valid: {e}", path.display())))?;
    let info = meter.info();
    let instrument = format!("{} {}", info.model, info.serial);
    if c.instrument != instrument {
        eprintln!(
            "lumiwall: note: the meter correction in {} is for '{}', this meter is '{instrument}'; not applied",
            path.display(),
            c.instrument
        );
        return Ok(None);
    }
    println!(
        "applying the meter xy correction from commissioning: x {:+.4} y {:+.4}",
        c.xy_offset[0], c.xy_offset[1]
    );
    Ok(Some(c.xy_offset))
}

/// The meter matrices of `--meter-matrix`, or else the copy `commission` kept in the
/// profile folder when it was made for this instrument.
pub(crate) fn meter_matrices(
    meter_args: &MeterArgs,
    profiles: &Path,
    meter: &dyn lumiwall_devices::Colorimeter,
) -> Result<Option<MeterMatrices>, CliError> {
    if let Some(m) = meter_args.meter_matrices()? {
        m.check_instrument(meter)
            .map_err(|e| CliError::input(e.to_string()))?;
        return Ok(Some(m));
    }
    let path = profiles.join(crate::cmd_commission::METER_MATRIX_FILE);
    if !path.exists() {
        return Ok(None);
    }
    if meter_args.reads_truth() {
        note_truth_not_corrected(&path);
        return Ok(None);
    }
    let m = MeterMatrices::load(&path).map_err(|e| CliError::input(e.to_string()))?;
    if let Err(e) = m.check_instrument(meter) {
        eprintln!("lumiwall: note: {} not applied: {e}", path.display());
        return Ok(None);
    }
    println!(
        "applying the meter matrices from commissioning ({})",
        path.display()
    );
    Ok(Some(m))
}

/// Says that a correction kept in the profile folder is left out because the exact
/// simulated meter reads the truth (silent when there is none).
fn note_truth_not_corrected(path: &Path) {
    if path.exists() {
        eprintln!(
            "lumiwall: note: {} not applied: with --noise none the simulated meter reads the \
             truth, which the commissioning meter's correction would move",
            path.display()
        );
    }
}

/// Runs `lumiwall verify`.
pub(crate) fn run(args: VerifyArgs) -> Result<(), CliError> {
    if let Some(cells) = args.grid {
        let (mut station, profiles) = open_checked(&args)?;
        return run_grid(&mut station, &profiles, cells, &args);
    }
    let mut pb: Option<ProgressBar> = None;
    let verified = verify_with(&args, &mut |p, total| {
        let bar = pb.get_or_insert_with(|| {
            let b = ProgressBar::new(total);
            b.set_style(
                ProgressStyle::with_template(
                    "{bar:40} {pos}/{len} readings [{elapsed}, eta {eta}]",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            b
        });
        match p {
            Progress::Reading { .. } => bar.inc(1),
            _ => {
                if let Some(line) = progress_line(&p) {
                    say(bar, line);
                }
            }
        }
    });
    if let Some(b) = &pb {
        b.finish_and_clear();
    }
    let Verified {
        report,
        profiles,
        targets,
        wall,
    } = verified?;
    let verdict = print_report(&report, &args);
    match truth_report(&args, wall, &profiles, &targets) {
        Ok(Some(t)) => print_truth(&t, &args),
        Ok(None) => {}
        Err(e) => println!("\nthe simulator's truth could not be read: {e}"),
    }
    verdict
}

/// What [`verify_with`] read.
pub(crate) struct Verified {
    /// The verification, also kept in the profile folder ([`VERIFY_FILE`]).
    pub(crate) report: VerifyReport,
    /// The profiles verified.
    pub(crate) profiles: Vec<lumiwall_profiles::DisplayProfile>,
    /// The targets shown.
    pub(crate) targets: Vec<lumiwall_calib::verify::Target>,
    /// The virtual wall as the verification left it (its lamps' state, for the truth's
    /// reading).
    pub(crate) wall: lumiwall_devices::sim::VirtualWall,
}

/// The station and the folder's profiles, checked to be of the same wall.
fn open_checked(
    args: &VerifyArgs,
) -> Result<(Station, Vec<lumiwall_profiles::DisplayProfile>), CliError> {
    let (wall_name, profiles) = ProfileSet::load_dir(&args.profiles).map_err(|e| {
        CliError::input(format!(
            "cannot read profiles in {}: {e}",
            args.profiles.display()
        ))
    })?;
    crate::cmd_recalibrate::refuse_simulation_on_a_real_meter(&args.meter, args.simulate_hours)?;
    let station = Station::open(&args.wall, &args.meter.station_options())?;
    if let Some(h) = args.simulate_hours {
        station.wall.advance_hours(h);
    }
    if station.wall.name() != wall_name {
        return Err(CliError::input(format!(
            "the profiles in {} are for wall '{wall_name}', the wall file is '{}'",
            args.profiles.display(),
            station.wall.name()
        )));
    }
    Ok((station, profiles))
}

/// `lumiwall verify` without printing (the station app runs it too): reads the targets
/// through the profiles and keeps the verification in the profile folder. `progress`
/// sees every step with the number of readings to expect.
pub(crate) fn verify_with(
    args: &VerifyArgs,
    progress: &mut dyn FnMut(Progress, u64),
) -> Result<Verified, CliError> {
    let (mut station, profiles) = open_checked(args)?;
    let targets = match args.chart {
        Some(_) => chart_targets(&profiles)?,
        None => default_targets(&profiles, args.patches)?,
    };
    let opts = VerifyOptions {
        patches: targets.len(),
        meter_xy_offset: load_meter_correction(
            &args.meter,
            &args.profiles,
            station.meter.as_ref(),
        )?,
        measure: MeasureOptions {
            meter_matrix: meter_matrices(&args.meter, &args.profiles, station.meter.as_ref())?,
            ..MeasureOptions::default()
        },
        warm_check: warm_check(args),
        averaging: args.averaging,
        ..VerifyOptions::default()
    };
    let total = (station.displays().len() * targets.len()) as u64;
    let report = station.verify(&profiles, &targets, &opts, &mut |p| progress(p, total))?;
    save_report(&args.profiles, &report);
    Ok(Verified {
        report,
        profiles,
        targets,
        wall: station.wall.clone(),
    })
}

/// Name of the last verification's record in the profile folder (read by `export
/// --format mpcdi`).
pub(crate) const VERIFY_FILE: &str = "verify.json";

/// Keeps the verification beside the profiles it verified ([`VERIFY_FILE`]); a failure
/// to write it is reported and does not change the verdict.
fn save_report(profiles: &std::path::Path, report: &VerifyReport) {
    let path = profiles.join(VERIFY_FILE);
    let written = serde_json::to_vec_pretty(report)
        .map_err(std::io::Error::other)
        .and_then(|bytes| lumiwall_core::files::write_atomic(&path, &bytes));
    match written {
        Ok(()) => println!("verification kept in {}", path.display()),
        Err(e) => eprintln!(
            "warning: cannot keep the verification in {}: {e}",
            path.display()
        ),
    }
}

/// On the virtual wall with a noisy simulated meter: the same verification with a
/// perfect meter (the simulator's truth) on `wall` as the station's verification left
/// it, lamps as warm as they were then, so the station meter's own error does not
/// vanish from the verdict. `None` for a real meter or `--noise none`.
fn truth_report(
    args: &VerifyArgs,
    wall: lumiwall_devices::sim::VirtualWall,
    profiles: &[lumiwall_profiles::DisplayProfile],
    targets: &[lumiwall_calib::verify::Target],
) -> Result<Option<VerifyReport>, CliError> {
    use lumiwall_calib::station::{MeterChoice, Noise, StationOptions};
    let simulated = !matches!(args.meter.meter, MeterChoice::Serial(_));
    if !simulated || matches!(args.meter.noise, crate::cmd_commission::NoiseArg::None) {
        return Ok(None);
    }
    let mut truth =
        Station::with_wall(wall, &StationOptions::new(MeterChoice::Direct, Noise::None))?;
    let opts = VerifyOptions {
        patches: targets.len(),
        ..VerifyOptions::default()
    };
    Ok(Some(truth.verify(profiles, targets, &opts, &mut |_| {})?))
}

/// The warm check (and wait) before `--grid`'s `cells` on every display, printed.
fn wait_before_grid(
    rig: &mut Rig<'_>,
    displays: &[lumiwall_devices::DisplayInfo],
    profiles: &[lumiwall_profiles::DisplayProfile],
    cells: [u32; 2],
    args: &VerifyArgs,
) -> Result<(), CliError> {
    let warm = VerifyOptions {
        warm_check: warm_check(args),
        ..VerifyOptions::default()
    };
    let per_display = cells[0].saturating_mul(cells[1]);
    wait_if_warming(rig, displays, profiles, per_display, &warm, &mut |p| {
        if let Some(line) = progress_line(&p) {
            println!("{line}");
        }
    })?;
    Ok(())
}

/// The warm check before the chart, unless `--no-warm-check`.
fn warm_check(args: &VerifyArgs) -> Option<lumiwall_calib::measure::warm_up::WarmCheck> {
    (!args.no_warm_check).then(lumiwall_calib::measure::warm_up::WarmCheck::default)
}

/// The truth's summary and its verdict against the same tolerances (printed; the exit
/// code stays the station meter's).
fn print_truth(report: &VerifyReport, args: &VerifyArgs) {
    println!("\nas a perfect meter sees it (the simulator's truth, noiseless):");
    print!("{}", report.summary_table());
    let violations = report.violations(&tolerances(args));
    if violations.is_empty() {
        println!("truth: PASS");
    } else {
        println!("truth: outside tolerance:\n  {}", violations.join("\n  "));
    }
}

/// The tolerances the arguments set.
fn tolerances(args: &VerifyArgs) -> Tolerances {
    Tolerances {
        max_de: args.max_de(),
        median_de: args.median_de(),
        mean_de: args.mean_de,
        white_de: args.white_de,
        grey_balance: args.grey_balance,
        black_dl_percent: args.black_dl,
        black_dxy: args.black_dxy,
    }
}

/// `verify --grid`: the spatial verification with the station's meter, and on the
/// virtual wall with a simulated meter the simulator's truth beside it.
fn run_grid(
    station: &mut Station,
    profiles: &[lumiwall_profiles::DisplayProfile],
    cells: [u32; 2],
    args: &VerifyArgs,
) -> Result<(), CliError> {
    let displays = station.displays();
    let opts = GridOptions {
        cells,
        ..GridOptions::default()
    };
    let offset = load_meter_correction(&args.meter, &args.profiles, station.meter.as_ref())?;
    let mut corrected = CorrectedMeter {
        inner: station.meter.as_mut(),
        xy_offset: offset.unwrap_or([0.0; 2]),
    };
    let matrices = meter_matrices(&args.meter, &args.profiles, corrected.inner)?;
    let mut rig = Rig {
        pattern: station.pattern.as_mut(),
        meter: &mut corrected,
        positioner: station.positioner.as_mut(),
    };
    wait_before_grid(&mut rig, &displays, profiles, cells, args)?;
    let report = match &matrices {
        Some(m) => verify_grid(
            &mut MatrixCorrected {
                inner: rig,
                matrices: m,
            },
            &displays,
            profiles,
            &opts,
        ),
        None => verify_grid(&mut { rig }, &displays, profiles, &opts),
    }
    .map_err(|e| CliError::failure(format!("spatial verification: {e}")))?;
    print!("{}", report.per_display_table());
    println!("{}", report.overall_line());
    if !matches!(
        args.meter.meter,
        lumiwall_calib::station::MeterChoice::Serial(_)
    ) {
        let truth = verify_grid(&mut Truth(&station.wall), &displays, profiles, &opts)
            .map_err(|e| CliError::failure(format!("spatial verification (truth): {e}")))?;
        println!("as the simulator sees it (a perfect meter at every cell):");
        println!("{}", truth.overall_line());
    }
    if let Some(path) = &args.heat_map {
        let wf = station.wall.wall_file();
        let svg = report.heat_map_svg([wf.tiles.cols, wf.tiles.rows], cells);
        lumiwall_core::files::write_atomic(path, svg.as_bytes())
            .map_err(|e| CliError::input(format!("cannot write {}: {e}", path.display())))?;
        println!("heat map written to {}", path.display());
    }
    let de: Vec<f64> = report.cells.iter().map(|c| c.delta_e2000).collect();
    let mut sorted = de.clone();
    let median = lumiwall_calib::verify::median(&mut sorted);
    let max = de.iter().copied().fold(0.0, f64::max);
    if median > args.median_de() || max > args.max_de() {
        return Err(CliError::tolerance(format!(
            "spatial verification outside tolerance: median ΔE {median:.2} (limit {}), max ΔE {max:.2} (limit {})",
            args.median_de(),
            args.max_de()
        )));
    }
    Ok(())
}

impl VerifyArgs {
    /// `--max-de`, or its default: 1.5 for target colours, DisplayCAL's recommended 3
    /// for a chart (issue 12).
    fn max_de(&self) -> f64 {
        self.max_de
            .unwrap_or(if self.chart.is_some() { 3.0 } else { 1.5 })
    }

    /// `--median-de`, or its default: 0.5 for target colours, 1 for a chart (judged by
    /// DisplayCAL's mean of 1 besides).
    fn median_de(&self) -> f64 {
        self.median_de
            .unwrap_or(if self.chart.is_some() { 1.0 } else { 0.5 })
    }
}

/// `--chart`: the charts there are (51).
fn parse_chart(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(n) if n == lumiwall_calib::verify::CHART_PATCHES => Ok(n),
        _ => Err(format!(
            "unknown chart '{s}'; the chart there is: {}",
            lumiwall_calib::verify::CHART_PATCHES
        )),
    }
}

/// Prints the tables and checks the tolerances (exit code 3 outside them).
fn print_report(report: &VerifyReport, args: &VerifyArgs) -> Result<(), CliError> {
    if !args.summary_only {
        print!("{}", report.patch_table());
        println!();
    }
    print!("{}", report.summary_table());
    match report.readings_per_reading {
        0 | 1 => println!("{} meter readings", report.readings),
        n => println!(
            "{} readings, each the mean of {n} meter readings ({} meter readings)",
            report.readings,
            u64::from(report.readings) * u64::from(n)
        ),
    }
    let tol = tolerances(args);
    let violations = report.violations(&tol);
    if violations.is_empty() {
        println!(
            "PASS: within max ΔE2000 {}, median {}, mean {}, white {}, grey balance {}",
            tol.max_de, tol.median_de, tol.mean_de, tol.white_de, tol.grey_balance
        );
        Ok(())
    } else {
        Err(CliError::tolerance(format!(
            "verification outside tolerance:\n  {}",
            violations.join("\n  ")
        )))
    }
}
