//! `lumiwall commission` (measure a wall, solve, write profiles and report) and
//! `lumiwall bench readings` (verify accuracy against meter readings per display).
//!
//! Also holds the command-line options shared with `lumiwall verify`: the meter path
//! (`--meter emulated` serves the simulated meter through the Klein K-10A protocol on a
//! pseudo-terminal and reads it with the real serial driver; `--meter direct` skips the
//! pty; `--meter serial:/dev/ttyUSB0` opens a real meter). The devices themselves are
//! opened by [`lumiwall_calib::station::Station`].

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};
use lumiwall_bench::readings::{self, ClassSummary, ReadingsBench, ReadingsRow};
use lumiwall_calib::cli_values::{GreyLevels, parse_budget, parse_grey_levels, parse_patches};
use lumiwall_calib::colorimetry::cct_to_xy;
use lumiwall_calib::commission::{CommissionOptions, CommissionOutcome};
use lumiwall_calib::measure::meter_matrix::{MeterMatrices, PatchXyError};
use lumiwall_calib::measure::warm_up::progress_line;
use lumiwall_calib::measure::{LowLight, MeasureOptions, Progress};
use lumiwall_calib::solve::{SolveOptions, WhiteTarget};
use lumiwall_calib::station::{
    AimChoice, MeterChoice, Noise, ReferenceChoice, Station, StationOptions,
};
use lumiwall_core::Headroom;
use lumiwall_devices::DisplayInfo;
use lumiwall_devices::serial::FaultPlan;
use lumiwall_devices::sim::SpectroModel;
use lumiwall_profiles::{BlackMode, MIN_LUT_ENTRIES, OutOfGamut, ProfileSet};

use crate::CliError;
use crate::values;

/// Error model of the simulated meter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum NoiseArg {
    /// The instrument's datasheet error model (CS-100A class: 2 % luminance, ±0.004 xy,
    /// worse below 1 cd/m²).
    Realistic,
    /// Exact readings.
    None,
}

impl From<NoiseArg> for Noise {
    fn from(n: NoiseArg) -> Self {
        match n {
            NoiseArg::Realistic => Noise::Realistic,
            NoiseArg::None => Noise::None,
        }
    }
}

/// Black handling (Kresse 3.3.6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum BlackArg {
    /// Ignore black: every display adds its own.
    Ignore,
    /// Subtract each display's own black.
    Individual,
    /// Raise every display to the common (worst) black.
    Common,
}

impl From<BlackArg> for BlackMode {
    fn from(b: BlackArg) -> Self {
        match b {
            BlackArg::Ignore => BlackMode::Ignore,
            BlackArg::Individual => BlackMode::Individual,
            BlackArg::Common => BlackMode::Common,
        }
    }
}

/// The meter options of `commission` and `verify`.
#[derive(Debug, clap::Args)]
pub(crate) struct MeterArgs {
    /// Meter: emulated (simulated meter through the serial protocol on a pty), direct,
    /// or serial:PATH for a real Klein K-10A.
    #[arg(long, default_value = "emulated")]
    pub(crate) meter: MeterChoice,
    /// Error model of the simulated meter.
    #[arg(long, value_enum, default_value = "realistic")]
    pub(crate) noise: NoiseArg,
    /// Speed of the emulated instrument: factor on its real measurement time
    /// (1 = a real K-10A's timing; greater than 0 and at most 10).
    #[arg(long, allow_negative_numbers = true, default_value_t = lumiwall_calib::station::DEFAULT_TIME_SCALE,
          value_parser = |s: &str| values::positive_at_most(s, MAX_TIME_SCALE))]
    pub(crate) time_scale: f64,
    /// Who aims the meter: auto (a technician with a real meter, the simulator
    /// otherwise), guided (prompted here: Enter = aimed, r = read again, s = skip,
    /// q = stop; --resume continues) or simulated.
    #[arg(long, default_value = "auto")]
    pub(crate) aim: AimChoice,
    /// The meter's display-type correction matrices (from `lumiwall meter-matrix`),
    /// applied to every reading of a display of the matrix's eye. `commission` keeps a
    /// copy in the profile folder, which `verify` then uses when this is not given.
    #[arg(long)]
    pub(crate) meter_matrix: Option<PathBuf>,
    /// Set by the station app to stop the run (no command-line option).
    #[arg(skip)]
    pub(crate) stop: Option<lumiwall_calib::station::StopFlag>,
    /// Set by the station app: guided aiming prompts in its window, not the terminal
    /// (no command-line option).
    #[arg(skip)]
    pub(crate) technician: Option<lumiwall_calib::station::TechnicianLink>,
}

/// Largest `--time-scale`: ten times slower than a real K-10A.
const MAX_TIME_SCALE: f64 = 10.0;

/// Name of the copy of the meter matrices in a profile folder.
pub(crate) const METER_MATRIX_FILE: &str = "meter-matrix.json";

impl MeterArgs {
    /// The matrices of `--meter-matrix`, if given; refused for the exact simulated
    /// meter ([`MeterArgs::reads_truth`]), which a correction fitted to another
    /// meter's errors would only move off the truth.
    pub(crate) fn meter_matrices(&self) -> Result<Option<MeterMatrices>, CliError> {
        if self.meter_matrix.is_some() && self.reads_truth() {
            return Err(CliError::input(
                "--meter-matrix corrects a real meter or the realistic simulated one; with \
                 --noise none the simulated meter reads the simulator's truth, which no \
                 correction may change: leave out --meter-matrix",
            ));
        }
        self.meter_matrix
            .as_ref()
            .map(|p| MeterMatrices::load(p).map_err(|e| CliError::input(e.to_string())))
            .transpose()
    }

    /// True for the simulated meter without errors (`--noise none` on the emulated or
    /// direct meter): its readings are the simulator's truth, so the corrections kept
    /// from a commissioning with a real or realistic meter do not apply to it.
    pub(crate) fn reads_truth(&self) -> bool {
        self.noise == NoiseArg::None && !matches!(self.meter, MeterChoice::Serial(_))
    }

    /// The station's meter as these options name it.
    pub(crate) fn station_options(&self) -> StationOptions {
        StationOptions {
            time_scale: self.time_scale,
            aim: self.aim,
            stop: self.stop.clone(),
            technician: self.technician.clone(),
            ..StationOptions::new(self.meter.clone(), self.noise.into())
        }
    }
}

/// The wall-solve options of `commission` and `bench readings`.
#[derive(Debug, clap::Args)]
pub(crate) struct SolveArgs {
    /// Target white: a CCT (8500K, CIE daylight locus), xy:0.291,0.300, or native:N
    /// (the native white of display N).
    #[arg(long, default_value = "8500K")]
    pub(crate) white: WhiteTarget,
    /// Black handling.
    #[arg(long, value_enum, default_value = "individual")]
    pub(crate) black: BlackArg,
    /// Largest channel usage for the common white (e.g. 0.9 leaves room for lamp ageing).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub(crate) headroom: f64,
}

/// Entries of every inverse LUT the command line writes.
const LUT_ENTRIES: usize = 4096;

/// Relative additivity error above which the solve warns (2 %).
const MAX_ADDITIVITY_ERROR: f64 = 0.02;

impl SolveArgs {
    /// Solve options from the command line, validated.
    pub(crate) fn solve_options(&self) -> Result<SolveOptions, CliError> {
        let headroom = self.headroom;
        Headroom::new(headroom)
            .map_err(|_| CliError::input(format!("--headroom {headroom} must be in (0, 1]")))?;
        if let WhiteTarget::Cct(k) = self.white {
            cct_to_xy(k).map_err(|e| CliError::input(e.to_string()))?;
        }
        Ok(SolveOptions {
            white: self.white,
            headroom,
            black_mode: self.black.into(),
            out_of_gamut: OutOfGamut::Clip,
            lut_entries: MIN_LUT_ENTRIES.max(LUT_ENTRIES),
            max_additivity_error: MAX_ADDITIVITY_ERROR,
        })
    }
}

/// `--uniformity`.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub(crate) enum UniformityArg {
    /// The same luminance everywhere.
    Strict,
    /// A smooth gradient below the visibility threshold.
    Perceptual,
}

/// File of the camera stage's results in the profile folder (`--camera`; read again
/// by `recalibrate --camera`).
pub(crate) const CAMERA_FILE: &str = "camera.json";

/// Arguments of `lumiwall commission`.
#[derive(Debug, clap::Args)]
pub(crate) struct CommissionArgs {
    /// Wall description (TOML), e.g. fixtures/walls/heyewall-48.toml.
    #[arg(long)]
    wall: PathBuf,
    /// Output folder: profiles, report and the run folder (for --resume).
    #[arg(long)]
    pub(crate) out: PathBuf,
    #[command(flatten)]
    solve: SolveArgs,
    #[command(flatten)]
    pub(crate) meter: MeterArgs,
    /// Meter readings allowed per display (11 to 10 000).
    #[arg(long, default_value_t = 40, value_parser = parse_budget)]
    budget: u32,
    /// Below the meter's reliable limit: average N readings (avg:N; a single-channel
    /// ramp sample at most 2) or skip ramp samples (skip).
    #[arg(long, default_value = "avg:4")]
    low_light: LowLight,
    /// Meter readings each reading averages: `auto` chooses from the wall white that
    /// the survey of every display's black, primaries and white allows, where the
    /// meter revisits displays at no cost (a dim wall's darkest chart grey needs the
    /// meter quieter: 3 on a 12.7 cd/m² wall with a CS-100A class meter, 1 from about
    /// 18 cd/m²; the displays are then surveyed again), and otherwise reads once and
    /// says after the solve what the wall needed; a number fixes it. The budget counts
    /// averaged readings.
    #[arg(long, default_value = "auto")]
    averaging: lumiwall_calib::measure::averaging::Averaging,
    /// After every display is measured: each channel read alone at the code each
    /// display's provisional profile gives it for these greys (a share of the target
    /// white's luminance, e.g. `1` or `0.5`, or a luminance, e.g. `1cd`), so the tone
    /// curves are sampled where the white and the greys sit; `gap` reads each channel
    /// in the middle of the widest gap between its samples over the drives the greys
    /// use; a share with `split` (e.g. `0.02split`) is read whole, once or as the
    /// low-light policy averages it, where one of its channels sits below that
    /// channel's samples (a dim wall's toe), its first reading aiming it again where
    /// it shows the grey more than 10 % off in luminance above black, and split into
    /// three channel samples through the primaries; then the wall is solved again. Up to three readings per
    /// grey out of each display's budget, and the meter visits every display a second
    /// time. A luminance is read only where the meter is reliable at a third of it; the
    /// brightest share (from 64 readings) is also read whole. `none` skips the pass.
    /// Default: `1,gap,1cd,0.02split` where software aims the meter, `none` where a
    /// technician aims it (guided aiming, a real meter with `--aim auto`), who would
    /// have to aim at every display again.
    #[arg(long, value_parser = parse_grey_levels)]
    grey_levels: Option<GreyLevels>,
    /// Continue an interrupted run from the measurements saved in OUT/run.
    #[arg(long)]
    pub(crate) resume: bool,
    /// A cold wall: before measuring, read the first display's white until its
    /// luminance changes by less than 0.05 % over 120 readings (printed as it goes), so
    /// that the first and the last display are measured at the same lamp state.
    #[arg(long)]
    warm_up: bool,
    /// Without `--warm-up` the station first reads the white of the first display still
    /// to measure 40 times and waits as `--warm-up` does when the wall is warming: when
    /// the trend, by more than 4σ of its own noise, would drift more than 1 % over the
    /// run or more than the wait calls stable (0.05 % per 120 readings). This skips
    /// that check (the drift over the run is still reported).
    #[arg(long, conflicts_with = "warm_up")]
    no_warm_check: bool,
    /// Fault injection for demonstrations and tests: the emulated meter stops answering
    /// after this many readings (`--meter emulated` only).
    #[arg(long, hide = true)]
    fault_stop_after: Option<u32>,
    /// Estimate a constant xy offset of the meter from the displays' additivity and
    /// correct every reading by it. Off by default: a filter colorimeter's error depends
    /// on the spectrum and keeps additivity, so additivity cannot reveal it; use
    /// `--meter-matrix` (from `lumiwall meter-matrix`) instead.
    #[arg(long)]
    meter_offset_correction: bool,
    /// Accepted for old scripts; the offset correction is off unless
    /// `--meter-offset-correction` asks for it.
    #[arg(long, hide = true)]
    no_meter_correction: bool,
    /// After the meter: the camera stage with this camera (`virtual`, or a V4L2/UVC
    /// device: index, `/dev/videoN` or name) for flat fields. Needs a build with the
    /// `camera` feature (OpenCV).
    #[arg(long)]
    camera: Option<String>,
    /// With `--camera`: `strict` (one luminance everywhere: the common white drops to
    /// the darkest point of the wall) or `perceptual` (a smooth gradient below the
    /// visibility threshold, 1.5 % per degree at 2.5 m, keeps the bright centres).
    #[arg(long, value_enum, default_value = "strict", requires = "camera")]
    pub(crate) uniformity: UniformityArg,
}

impl CommissionArgs {
    /// The station with the fault plan of `--fault-stop-after`.
    fn open_station(&self) -> Result<Station, CliError> {
        let opts = StationOptions {
            faults: FaultPlan {
                stop_after_readings: self.fault_stop_after,
                ..FaultPlan::default()
            },
            ..self.meter.station_options()
        };
        Ok(Station::open(&self.wall, &opts)?)
    }

    /// `--grey-levels`, or its default for who aims the meter.
    fn grey_levels(&self) -> Vec<lumiwall_calib::measure::grey_drives::GreyLevel> {
        let technician_aims = match self.meter.aim {
            AimChoice::Guided => true,
            AimChoice::Auto => matches!(self.meter.meter, MeterChoice::Serial(_)),
            AimChoice::Simulated => false,
        };
        match &self.grey_levels {
            Some(levels) => levels.0.clone(),
            None if technician_aims => Vec::new(),
            None => lumiwall_calib::measure::grey_drives::default_levels(),
        }
    }

    pub(crate) fn commission_options(&self) -> Result<CommissionOptions, CliError> {
        Ok(CommissionOptions {
            measure: MeasureOptions {
                budget: self.budget,
                low_light: self.low_light,
                averaging: self.averaging,
                warm_up: self
                    .warm_up
                    .then(lumiwall_calib::measure::warm_up::WarmUp::default),
                meter_matrix: self.meter.meter_matrices()?,
                ..MeasureOptions::default()
            },
            solve: self.solve.solve_options()?,
            resume: self.resume,
            meter_correction: self.meter_offset_correction && !self.no_meter_correction,
            grey_levels: self.grey_levels(),
            warm_check: (!self.no_warm_check)
                .then(lumiwall_calib::measure::warm_up::WarmCheck::default),
        })
    }
}

/// Prints a line above the progress bar, or plainly when the bar is hidden (output
/// not a terminal).
pub(crate) fn say(pb: &ProgressBar, line: String) {
    if pb.is_hidden() {
        println!("{line}");
    } else {
        pb.println(line);
    }
}

/// Shows the commissioning's progress: a bar over every display's reading budget and
/// one line per finished display.
struct ProgressReport {
    bar: ProgressBar,
    names: Vec<(u32, String)>,
    budget: u64,
    done_readings: u64,
}

impl ProgressReport {
    fn new(displays: &[DisplayInfo], budget: u32) -> Self {
        let bar = ProgressBar::new(displays.len() as u64 * u64::from(budget));
        bar.set_style(
            ProgressStyle::with_template(
                "{bar:40} {pos}/{len} readings {msg} [{elapsed}, eta {eta}]",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        Self {
            bar,
            names: displays.iter().map(|d| (d.id.0, d.name.clone())).collect(),
            budget: u64::from(budget),
            done_readings: 0,
        }
    }

    fn name_of(&self, id: u32) -> String {
        self.names
            .iter()
            .find(|(i, _)| *i == id)
            .map(|(_, n)| n.clone())
            .unwrap_or_default()
    }

    fn on(&mut self, p: Progress) {
        match p {
            Progress::Reading {
                display, readings, ..
            } => {
                self.bar
                    .set_position(self.done_readings + u64::from(readings));
                self.bar
                    .set_message(format!("display {}", self.name_of(display.0)));
            }
            Progress::DisplayDone { display, readings } => {
                self.display_finished(format!(
                    "{:<28} {readings:>3} readings",
                    self.name_of(display.0)
                ));
            }
            p @ (Progress::WarmingUp { .. } | Progress::WarmCheck(_) | Progress::WarmedUp(_)) => {
                if let Some(line) = progress_line(&p) {
                    say(&self.bar, line);
                }
            }
            Progress::GreyDrivesRead {
                display,
                samples,
                whole,
                readings,
            } => say(
                &self.bar,
                format!(
                    "{:<28} {samples} ramp samples at the drives of its white and greys, {whole} read whole ({readings} readings)",
                    self.name_of(display.0)
                ),
            ),
            Progress::Averaging(choice) => say(&self.bar, choice.summary()),
            Progress::Resumed { display, readings } => {
                self.display_finished(format!(
                    "{:<28} {readings:>3} readings (saved by the interrupted run)",
                    self.name_of(display.0)
                ));
            }
        }
    }

    fn display_finished(&mut self, line: String) {
        self.done_readings += self.budget;
        self.bar.set_position(self.done_readings);
        say(&self.bar, line);
    }
}

/// Runs `lumiwall commission`.
pub(crate) fn run(args: CommissionArgs) -> Result<(), CliError> {
    let mut report: Option<ProgressReport> = None;
    let started = Instant::now();
    let done = commission_with(&args, &mut |step| match step {
        CommissionStep::Started { wall, displays } => {
            println!(
                "commissioning {wall}: {} displays, budget {} readings per display, meter {:?}",
                displays.len(),
                args.budget,
                args.meter.meter
            );
            report = Some(ProgressReport::new(displays, args.budget));
        }
        CommissionStep::Progress(p) => {
            if let Some(r) = &mut report {
                r.on(p);
            }
        }
    });
    if let Some(r) = &report {
        r.bar.finish_and_clear();
    }
    let (mut station, outcome) = done?;
    print_outcome(&outcome, started.elapsed());
    if let Some(camera) = &args.camera {
        camera_stage(&mut station, &outcome, &args, camera)?;
    }
    Ok(())
}

/// What [`commission_with`] reports as it goes.
pub(crate) enum CommissionStep<'a> {
    /// The station is open and checked; the measurement starts.
    Started {
        /// Wall name.
        wall: &'a str,
        /// Its displays.
        displays: &'a [DisplayInfo],
    },
    /// A step of the measurement.
    Progress(Progress),
}

/// `lumiwall commission` up to the camera stage (the station app runs it too):
/// measures and solves the wall, keeps the meter matrix beside the profiles and drops
/// an earlier verification. `progress` hears when the measurement starts and every
/// step of it.
pub(crate) fn commission_with(
    args: &CommissionArgs,
    progress: &mut dyn FnMut(CommissionStep<'_>),
) -> Result<(Station, CommissionOutcome), CliError> {
    let opts = args.commission_options()?;
    values::check_output_dir("--out", &args.out)?;
    let mut station = args.open_station()?;
    if let Some(m) = &opts.measure.meter_matrix {
        m.check_instrument(station.meter.as_ref())
            .map_err(|e| CliError::input(e.to_string()))?;
        if opts.meter_correction {
            return Err(CliError::input(
                "--meter-offset-correction and --meter-matrix correct the same error two ways; \
                 use the matrix",
            ));
        }
    }
    if let Some(camera) = &args.camera {
        camera_stage_possible(&station, args, camera)?;
    }
    let (wall, displays) = (station.wall.name(), station.displays());
    progress(CommissionStep::Started {
        wall: &wall,
        displays: &displays,
    });
    let outcome = station.commission(&args.out, &opts, &mut |p| {
        progress(CommissionStep::Progress(p));
    })?;
    keep_meter_matrix(&args.out, opts.measure.meter_matrix.as_ref())?;
    // An earlier verification judged other profiles (the MPCDI export carries it).
    let verified = args.out.join(crate::cmd_verify::VERIFY_FILE);
    match std::fs::remove_file(&verified) {
        Ok(()) => println!("removed the earlier verification {}", verified.display()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => println!("warning: cannot remove {}: {e}", verified.display()),
    }
    Ok((station, outcome))
}

/// A copy of the meter matrix beside the profiles (verify and recalibrate use it); a
/// copy from an earlier commission is removed, it must not correct these profiles.
fn keep_meter_matrix(out: &Path, matrix: Option<&MeterMatrices>) -> Result<(), CliError> {
    let copy = out.join(METER_MATRIX_FILE);
    match matrix {
        Some(m) => m.save(&copy).map_err(|e| CliError::failure(e.to_string())),
        None => match std::fs::remove_file(&copy) {
            Ok(()) => Ok(()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
            Err(e) => Err(CliError::failure(format!(
                "cannot remove the old {}: {e}",
                copy.display()
            ))),
        },
    }
}

#[cfg(feature = "camera")]
fn camera_stage(
    station: &mut Station,
    outcome: &CommissionOutcome,
    args: &CommissionArgs,
    camera: &str,
) -> Result<(), CliError> {
    crate::cmd_camera::run(station, outcome, args, camera)
}

/// Opens the camera once before the meter starts, so a missing or unusable camera is
/// reported at once, not after the measurement.
#[cfg(feature = "camera")]
fn camera_stage_possible(
    station: &Station,
    args: &CommissionArgs,
    camera: &str,
) -> Result<(), CliError> {
    let noiseless = matches!(args.meter.noise, NoiseArg::None);
    crate::cmd_camera::check(station, camera, noiseless)
}

#[cfg(not(feature = "camera"))]
fn camera_stage_possible(
    _station: &Station,
    _args: &CommissionArgs,
    camera: &str,
) -> Result<(), CliError> {
    Err(camera_not_built(camera))
}

/// The refusal of `--camera` by a build without the `camera` feature.
#[cfg(not(feature = "camera"))]
pub(crate) fn camera_not_built(camera: &str) -> CliError {
    CliError::input(format!(
        "--camera {camera}: this lumiwall was built without the camera stage; build it with \
         `cargo build --release --features camera` (needs Debian libopencv-dev and clang)"
    ))
}

#[cfg(not(feature = "camera"))]
fn camera_stage(
    _station: &mut Station,
    _outcome: &CommissionOutcome,
    _args: &CommissionArgs,
    camera: &str,
) -> Result<(), CliError> {
    camera_stage_possible(_station, _args, camera)
}

fn print_outcome(o: &CommissionOutcome, elapsed: Duration) {
    print_readings(o, elapsed);
    print_white_and_gamut(o);
    let s = &o.solution;
    if let Some(p) = s.profiles.get(s.limiting.display) {
        println!(
            "limiting: {} {} channel",
            p.display,
            s.limiting.channel.name()
        );
    }
    if let Some(c) = &o.meter_correction {
        println!(
            "meter xy correction: x {:+.4} y {:+.4} (median additivity error {:.2} % -> {:.2} %)",
            c.xy_offset[0],
            c.xy_offset[1],
            c.additivity_before * 100.0,
            c.additivity_after * 100.0
        );
    }
    if let Some(d) = &o.drift {
        let tag = if d.is_significant() { "warning: " } else { "" };
        println!("{tag}{}", d.summary());
    }
    for w in &s.warnings {
        println!("warning: {w}");
    }
    println!("profiles: {}/{}", o.out_dir.display(), ProfileSet::MANIFEST);
    for r in &o.reports {
        println!("report: {}", r.display());
    }
}

fn print_readings(o: &CommissionOutcome, elapsed: Duration) {
    let per: Vec<u32> = o.measured.iter().map(|m| m.measurement.readings).collect();
    let max = per.iter().copied().max().unwrap_or(0);
    let total: u32 = per.iter().sum();
    let meter: u32 = o.measured.iter().map(|m| m.meter_readings()).sum();
    let averaged = match o.readings_per_reading {
        1 => String::new(),
        n => format!(" (each the mean of {n} meter readings: {meter} meter readings in all)"),
    };
    println!(
        "measured {} displays ({} resumed) in {:.1} s: {total} readings, at most {max} per \
         display{averaged}",
        o.measured.len(),
        o.resumed.len(),
        elapsed.as_secs_f64()
    );
}

fn print_white_and_gamut(o: &CommissionOutcome) {
    let s = &o.solution;
    let w = s.white_xyz_cd_m2;
    let wxy = w.xy().unwrap_or([f64::NAN; 2]);
    let [r, g, b] = s.common_primaries_xy;
    println!(
        "common white: xy {:.4} {:.4}, {:.2} cd/m²; common gamut R {:.3}/{:.3} G {:.3}/{:.3} B {:.3}/{:.3}",
        wxy[0], wxy[1], w.y, r[0], r[1], g[0], g[1], b[0], b[1]
    );
}

/// Arguments of `lumiwall bench readings`.
#[derive(Debug, clap::Args)]
pub(crate) struct BenchArgs {
    /// Wall description (TOML).
    #[arg(long, default_value = "fixtures/walls/heyewall-48.toml")]
    wall: PathBuf,
    /// Reading budgets per display to compare (comma-separated; each 11 to 10 000).
    #[arg(long, value_delimiter = ',', default_value = "16,24,40,80", value_parser = parse_budget)]
    budgets: Vec<u32>,
    /// Meter path (direct is fastest; emulated goes through the pty).
    #[arg(long, default_value = "direct")]
    meter: MeterChoice,
    #[command(flatten)]
    solve: SolveArgs,
    /// Kept for old scripts (1 to 100 000); the bench reads the 51-patch chart.
    #[arg(long, default_value_t = 20, value_parser = parse_patches)]
    patches: usize,
    /// Scratch folder for the profiles of each run.
    #[arg(long, default_value = "out/bench-readings")]
    out: PathBuf,
    /// Before each commissioning, wait until the wall has warmed up (as `commission
    /// --warm-up`; its readings are not counted in the budget).
    #[arg(long)]
    warm_up: bool,
    /// Skip the check for a warming wall that each commissioning makes without
    /// `--warm-up` (as `commission --no-warm-check`).
    #[arg(long, conflicts_with = "warm_up")]
    no_warm_check: bool,
    /// Match the realistic meter to the reference on every display (as `meter-matrix
    /// --per-display`), not once per eye. The default on an Infitec wall.
    #[arg(long, conflicts_with = "per_eye_matrix")]
    per_display_matrix: bool,
    /// Match the realistic meter to the reference once per eye (as `meter-matrix
    /// --per-eye`), also on an Infitec wall.
    #[arg(long)]
    per_eye_matrix: bool,
    /// The simulated reference spectroradiometer the realistic meter is matched to:
    /// `cs2000`, `specbos` or `ideal` (a perfect one: what the station reaches when the
    /// reference adds no error of its own).
    #[arg(long, default_value = "cs2000", value_parser = parse_reference)]
    reference: ReferenceArg,
    /// Serial number of the simulated reference (its systematic errors: wavelength
    /// offset, gain and spectral tilt), as `meter-matrix --reference-seed`.
    #[arg(long, default_value_t = readings::DEFAULT_REFERENCE_SEED)]
    reference_seed: u64,
    /// The grey-drive pass's greys, as `commission --grey-levels` (`none` skips the
    /// pass). Default: commission's where software aims the meter
    /// (`1,gap,1cd,0.02split`).
    #[arg(long, value_parser = parse_grey_levels)]
    grey_levels: Option<GreyLevels>,
    /// Run every budget on the wall built with each of these seeds in place of the
    /// file's (`101-160`, at most 10 000): unseen instances of the wall's class, its
    /// manufacturing scatter and meter noise drawn again, the virtual wall's own
    /// patterns shown. A table per meter model and budget then counts the runs within
    /// the limits. Each seed's scratch folder under `--out` is removed after its run.
    #[arg(long, value_parser = parse_seeds)]
    seeds: Option<std::ops::RangeInclusive<u64>>,
    /// Meter readings each reading averages, as `commission --averaging` (`auto`: from
    /// the wall white; the readings column counts every meter reading).
    #[arg(long, default_value = "auto")]
    averaging: lumiwall_calib::measure::averaging::Averaging,
    /// Run only this meter error model (`none` or `realistic`); default: both.
    #[arg(long)]
    noise: Option<Noise>,
}

/// `--seeds`: a seed range of at most [`readings::MAX_SEEDS`].
fn parse_seeds(s: &str) -> Result<std::ops::RangeInclusive<u64>, String> {
    values::seed_range(s, readings::MAX_SEEDS)
}

/// Whether the meter is matched on every display: `Some(true)` for `--per-display`,
/// `Some(false)` for `--per-eye`, `None` (the station's default for the wall) for
/// neither.
fn matrix_scope(per_display: bool, per_eye: bool) -> Option<bool> {
    (per_display || per_eye).then_some(per_display)
}

/// The simulated reference `bench readings` matches the realistic meter to: the one
/// `meter-matrix` would read directly ([`ReferenceArg::choice`]).
fn bench_reference(arg: &ReferenceArg, seed: u64) -> Result<SpectroModel, CliError> {
    match arg.choice(seed, 1.0) {
        ReferenceChoice::Simulated(model) => Ok(model),
        ReferenceChoice::Emulated { .. } | ReferenceChoice::Serial(_) => Err(CliError::input(
            "bench readings reads its reference directly on the virtual wall: give \
             --reference cs2000, specbos or ideal"
                .to_string(),
        )),
    }
}

/// Runs `lumiwall bench readings`: for each budget and each meter error model,
/// commissions the wall and verifies it with the same meter model.
pub(crate) fn bench(args: BenchArgs) -> Result<(), CliError> {
    values::check_output_dir("--out", &args.out)?;
    let bench = ReadingsBench {
        solve: args.solve.solve_options()?,
        wall: args.wall,
        budgets: args.budgets,
        meter: args.meter,
        patches: args.patches,
        out: args.out,
        warm_up: args.warm_up,
        warm_check: !args.no_warm_check,
        per_display_matrix: matrix_scope(args.per_display_matrix, args.per_eye_matrix),
        reference: bench_reference(&args.reference, args.reference_seed)?,
        grey_levels: args.grey_levels.map(|l| l.0),
        averaging: args.averaging,
        noises: args.noise.map_or(Noise::ALL.to_vec(), |n| vec![n]),
        seeds: args.seeds,
    };
    println!(
        "accuracy against meter readings per display ({}): the 51-patch chart read by a \
         perfect meter (the truth); the realistic meter matched to the reference first \
         (meter-matrix, {}{})",
        bench.wall.display(),
        bench.reference.model,
        if args.reference == ReferenceArg::Ideal {
            String::new()
        } else {
            format!(" SIM-{}", args.reference_seed)
        }
    );
    println!(
        "limits: noiseless median ≤ 0.5, max ≤ 2.0; realistic median ≤ 1.0, max ≤ 3.0, \
         white ≤ 1.0, grey balance ≤ 0.5 (white and grey: worst display)"
    );
    println!(
        "{}{:<10} {:>7} {:>9} {:>7} {:>7} {:>7} {:>7} {:>7} {:>9} {:>7} {:>6}",
        if bench.seeds.is_some() { "seed   " } else { "" },
        "noise",
        "budget",
        "readings",
        "median",
        "mean",
        "p95",
        "max",
        "white",
        "grey |ΔC'|",
        "time s",
        "limits"
    );
    let rows = readings::run(&bench, &mut print_readings_row)?;
    let failed = rows.iter().filter(|r| !r.meets_limits()).count();
    println!("{failed} of {} runs outside the limits", rows.len());
    if let Some(seeds) = &bench.seeds {
        print_class_summaries(seeds, &readings::class_summaries(&rows));
    }
    Ok(())
}

/// The class table of a run over `seeds`: per meter model and budget, the runs within
/// the limits and the worst figures.
fn print_class_summaries(seeds: &std::ops::RangeInclusive<u64>, summaries: &[ClassSummary]) {
    println!(
        "the class over seeds {}-{}: runs within every limit, mean of the worst display's \
         grey balance, and the largest worst white, max and median of any run",
        seeds.start(),
        seeds.end()
    );
    println!(
        "{:<10} {:>7} {:>9} {:>11} {:>7} {:>7} {:>7}",
        "noise", "budget", "within", "grey |ΔC'|", "white", "max", "median"
    );
    for c in summaries {
        println!(
            "{:<10} {:>7} {:>9} {:>11.3} {:>7.3} {:>7.3} {:>7.3}",
            c.noise.name(),
            c.budget,
            format!("{}/{}", c.within, c.runs),
            c.mean_worst_grey_balance,
            c.worst_white_de,
            c.max_de,
            c.worst_median_de
        );
    }
}

fn print_readings_row(r: &ReadingsRow) {
    if let Some(seed) = r.seed {
        print!("{seed:<7}");
    }
    println!(
        "{:<10} {:>7} {:>9} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>10.3} {:>7.1} {:>6}",
        r.noise.name(),
        r.budget,
        r.max_readings,
        r.truth.median_de,
        r.truth.mean_de,
        r.truth.p95_de,
        r.truth.max_de,
        r.worst_white_de,
        r.worst_grey_balance,
        r.elapsed.as_secs_f64(),
        if r.meets_limits() { "meet" } else { "FAIL" }
    );
}

/// Options of `lumiwall meter-matrix`.
#[derive(Debug, clap::Args)]
pub(crate) struct MeterMatrixArgs {
    /// Wall description (TOML).
    #[arg(long)]
    wall: PathBuf,
    #[command(flatten)]
    pub(crate) meter: MeterArgs,
    /// Output file (JSON), e.g. meter-matrix.json.
    #[arg(long)]
    out: PathBuf,
    /// The reference spectroradiometer: `cs2000` or `specbos` (simulated on the
    /// virtual wall, read directly), `ideal` (a simulated perfect one: what the meter
    /// and the station reach when the reference adds no error of its own),
    /// `specbos-emulated` (the simulated specbos served on
    /// a pty and read through lumiwall's specbos driver), or `serial:PATH` (a JETI
    /// specbos 1201/1211 beside a real meter).
    #[arg(long, default_value = "cs2000", value_parser = parse_reference)]
    reference: ReferenceArg,
    /// Serial number of the simulated reference spectroradiometer (its systematic
    /// errors: wavelength offset, responsivity).
    #[arg(long, default_value_t = readings::DEFAULT_REFERENCE_SEED)]
    reference_seed: u64,
    /// Also one matrix per display (the reference reads every display): for walls
    /// whose displays of one eye differ in spectrum, e.g. Infitec comb filters. The
    /// default on an Infitec wall.
    #[arg(long, conflicts_with = "per_eye")]
    per_display: bool,
    /// Only one matrix per eye (the reference reads one display of each eye), also on
    /// an Infitec wall: quicker, but it leaves each projector's comb-filter offset in
    /// the meter's readings.
    #[arg(long)]
    per_eye: bool,
    /// Check the reference's wavelength scale with a line lamp first and correct its
    /// readings by it: `hg-ar` (a mercury–argon pen lamp; a real reference prompts
    /// to hold it before the lens) or `none` (take the instrument's scale as it is;
    /// ±0.3–0.5 nm, up to 0.003 in xy on an Infitec green).
    #[arg(long, default_value = "hg-ar", value_parser = ["hg-ar", "none"])]
    wavelength_check: String,
}

/// The reference instrument of `lumiwall meter-matrix`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ReferenceArg {
    /// A simulated Konica Minolta CS-2000, read directly.
    Cs2000,
    /// A simulated JETI specbos 1211, read directly.
    Specbos,
    /// A simulated perfect spectroradiometer (the simulator's truth), read directly.
    Ideal,
    /// A simulated JETI specbos 1211 served on a pty and read through the driver.
    SpecbosEmulated,
    /// A JETI specbos on this serial port.
    Serial(String),
}

impl ReferenceArg {
    /// The station's choice for the simulated instrument with serial number `seed`.
    fn choice(&self, seed: u64, time_scale: f64) -> ReferenceChoice {
        match self {
            ReferenceArg::Cs2000 => ReferenceChoice::Simulated(SpectroModel::cs2000(seed)),
            ReferenceArg::Specbos => ReferenceChoice::Simulated(SpectroModel::specbos_1211(seed)),
            ReferenceArg::Ideal => ReferenceChoice::Simulated(SpectroModel::noiseless()),
            ReferenceArg::SpecbosEmulated => ReferenceChoice::Emulated {
                model: SpectroModel::specbos_1211(seed),
                time_scale,
            },
            ReferenceArg::Serial(port) => ReferenceChoice::Serial(port.clone()),
        }
    }
}

/// Parses `--reference`.
fn parse_reference(s: &str) -> Result<ReferenceArg, String> {
    match s {
        "cs2000" => Ok(ReferenceArg::Cs2000),
        "specbos" => Ok(ReferenceArg::Specbos),
        "ideal" => Ok(ReferenceArg::Ideal),
        "specbos-emulated" => Ok(ReferenceArg::SpecbosEmulated),
        _ => match s.strip_prefix("serial:") {
            Some(p) if !p.is_empty() => Ok(ReferenceArg::Serial(p.to_string())),
            _ => Err(format!(
                "`{s}` is no reference spectroradiometer; use cs2000, specbos, \
                 ideal, specbos-emulated or serial:/dev/ttyUSB1 (a JETI specbos 1201/1211)"
            )),
        },
    }
}

/// Runs `lumiwall meter-matrix`: reads black, red, green, blue and white of the middle
/// display of each eye with the station's meter and a reference spectroradiometer and
/// fits one correction matrix per eye. On the virtual wall it then prints both
/// instruments' chromaticity errors against the simulator's truth.
pub(crate) fn meter_matrix(args: MeterMatrixArgs) -> Result<(), CliError> {
    let parent = check_meter_matrix_args(&args)?;
    let real_meter = matches!(args.meter.meter, MeterChoice::Serial(_));
    let mut station = Station::open(&args.wall, &args.meter.station_options())?;
    let mut reference = station
        .open_reference(
            &args
                .reference
                .choice(args.reference_seed, args.meter.time_scale),
        )
        .map_err(|e| CliError::failure(format!("the reference spectroradiometer: {e}")))?;
    if args.wavelength_check == "hg-ar" {
        check_reference_wavelengths(&mut reference)?;
    }
    let per_display = matrix_scope(args.per_display, args.per_eye)
        .unwrap_or_else(|| station.per_display_matrices_by_default());
    let matrices = station
        .meter_matrices(&mut reference, [0.5, 0.5], per_display)
        .map_err(|e| CliError::failure(e.to_string()))?;
    print_matrices(&matrices, &station.wall.name());
    if real_meter {
        println!("  (no truth to check the matrices against on a real wall)");
    } else {
        let errors = station
            .meter_matrix_xy_errors(&matrices, &mut reference, [0.5, 0.5])
            .map_err(|e| CliError::failure(format!("checking the matrices: {e}")))?;
        print_xy_errors(&errors);
    }
    if let Some(parent) = &parent {
        std::fs::create_dir_all(parent)
            .map_err(|e| CliError::failure(format!("cannot create {}: {e}", parent.display())))?;
    }
    matrices
        .save(&args.out)
        .map_err(|e| CliError::failure(e.to_string()))?;
    println!("written: {}", args.out.display());
    for path in write_ccmx_files(&matrices, &args.out, &station.wall.name())? {
        println!("written: {} (ArgyllCMS CCMX)", path.display());
    }
    Ok(())
}

/// Checks the reference's wavelength scale with a Hg-Ar lamp and prints what it found
/// (on the virtual wall beside the simulated instrument's true offset).
fn check_reference_wavelengths(
    reference: &mut lumiwall_calib::station::Reference,
) -> Result<(), CliError> {
    let truth = reference.simulated_offset_nm();
    let check = reference
        .check_wavelengths(&lumiwall_devices::LineLamp::hg_ar())
        .map_err(|e| {
            CliError::failure(format!(
                "{e}; without a line lamp, run with --wavelength-check none (the reference's \
                 scale as it is)"
            ))
        })?;
    let lines: Vec<String> = check
        .lines
        .iter()
        .map(|l| format!("{:.1}", l.true_nm))
        .collect();
    println!(
        "wavelength check ({}, lines {} nm): offset {:+.3} nm{}, {:.3} nm RMS between the lines{}",
        check.lamp,
        lines.join(", "),
        check.scale.offset_nm,
        if check.slope_fitted {
            format!(", slope {:+.2e}", check.scale.slope)
        } else {
            String::new()
        },
        check.rms_nm,
        truth.map_or(String::new(), |t| format!(
            " (the simulated instrument's true offset: {t:+.3} nm)"
        ))
    );
    Ok(())
}

/// Refuses what `meter-matrix` cannot do before any device is opened; returns the
/// output's folder (checked writable) when `--out` names one.
fn check_meter_matrix_args(args: &MeterMatrixArgs) -> Result<Option<PathBuf>, CliError> {
    let real_meter = matches!(args.meter.meter, MeterChoice::Serial(_));
    let real_reference = matches!(args.reference, ReferenceArg::Serial(_));
    if real_meter != real_reference {
        return Err(CliError::input(if real_meter {
            "a real meter is matched on the real wall to a real reference: give \
             --reference serial:/dev/ttyUSBn (a JETI specbos 1201/1211 beside the meter)"
                .to_string()
        } else {
            "a real reference reads the real wall: give the real meter too \
             (--meter serial:/dev/ttyUSBn), or a simulated reference on the virtual wall"
                .to_string()
        }));
    }
    if args.meter.meter_matrix.is_some() {
        return Err(CliError::input(
            "--meter-matrix is what this command makes; leave it out".to_string(),
        ));
    }
    if args.out.is_dir() {
        return Err(CliError::input(format!(
            "--out {} is a folder; give a file name, e.g. {}",
            args.out.display(),
            args.out.join("meter-matrix.json").display()
        )));
    }
    let parent = args
        .out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .map(PathBuf::from);
    if let Some(parent) = &parent {
        values::check_output_dir("--out's folder", parent)?;
    }
    Ok(parent)
}

/// Each eye's matrix and fit residual, and the largest residual of the displays' own.
fn print_matrices(matrices: &MeterMatrices, wall: &str) {
    println!(
        "{} matched to {} on {wall}:",
        matrices.instrument, matrices.reference
    );
    for m in matrices.matrices.iter().filter(|m| m.display.is_none()) {
        println!(
            "  {} eye: fit residual {:.3} %, matrix {:?}",
            m.eye,
            100.0 * m.fit_residual,
            m.matrix.map(|r| r.map(|v| (v * 1e4).round() / 1e4))
        );
    }
    let own: Vec<f64> = matrices
        .matrices
        .iter()
        .filter(|m| m.display.is_some())
        .map(|m| m.fit_residual)
        .collect();
    if !own.is_empty() {
        println!(
            "  and {} displays' own matrices: largest fit residual {:.3} %",
            own.len(),
            100.0 * own.iter().cloned().fold(0.0, f64::max)
        );
    }
}

/// The meter's chromaticity error against the virtual wall's truth per eye and patch
/// (largest over the displays): as read, corrected, and the reference's own.
fn print_xy_errors(errors: &[PatchXyError]) {
    println!("  Δxy against the simulator's truth (display centres, largest over the displays):");
    println!(
        "    {:<6} {:<6} {:>8} {:>10} {:>10}",
        "eye", "patch", "meter", "corrected", "reference"
    );
    let mut keys: Vec<(lumiwall_core::Eye, &str)> = Vec::new();
    for e in errors {
        if !keys.contains(&(e.eye, e.patch)) {
            keys.push((e.eye, e.patch));
        }
    }
    for (eye, patch) in keys {
        let of = || {
            errors
                .iter()
                .filter(move |e| e.eye == eye && e.patch == patch)
        };
        let max = |f: fn(&PatchXyError) -> f64| of().map(f).fold(0.0, f64::max);
        println!(
            "    {:<6} {:<6} {:>8.4} {:>10.4} {:>10.4}",
            eye.to_string(),
            patch,
            max(|e| e.meter),
            max(|e| e.corrected),
            max(|e| e.reference)
        );
    }
}

/// Each eye's matrix also as an ArgyllCMS `.ccmx` beside `out` (`STEM.EYE.ccmx`), so
/// ArgyllCMS and DisplayCAL apply the same correction (`spotread -X`).
fn write_ccmx_files(
    matrices: &lumiwall_calib::measure::meter_matrix::MeterMatrices,
    out: &std::path::Path,
    wall: &str,
) -> Result<Vec<PathBuf>, CliError> {
    use lumiwall_calib::measure::ccmx::{CcmxInfo, to_ccmx};
    let stem = out
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("meter-matrix");
    let created = lumiwall_calib::solve::now_rfc3339();
    let mut written = Vec::new();
    for m in matrices.matrices.iter().filter(|m| m.display.is_none()) {
        let info = CcmxInfo {
            instrument: matrices.instrument.clone(),
            display: format!("{wall} {} eye", m.eye),
            reference: matrices.reference.clone(),
        };
        let path = out.with_file_name(format!("{stem}.{}.ccmx", m.eye));
        lumiwall_profiles::write_atomic(&path, to_ccmx(m, &info, &created).as_bytes())
            .map_err(|e| CliError::failure(format!("cannot write {}: {e}", path.display())))?;
        written.push(path);
    }
    Ok(written)
}
