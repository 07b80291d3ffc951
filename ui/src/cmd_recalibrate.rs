//! `lumiwall recalibrate`: the unattended nightly run (see
//! `lumiwall_calib::recalibrate`). Prints one line per display and a one-line summary
//! for logs; the exit code tells monitoring what happened.

use std::path::PathBuf;

use lumiwall_calib::measure::{MeasureOptions, Progress};
use lumiwall_calib::recalibrate::{
    CheckKind, DriftLimits, FullCheckRotation, RecalibrateError, RecalibrateOptions,
    RecalibrationOutcome, Recorded, Verdict, record_in_store,
};
use lumiwall_calib::station::Station;
use lumiwall_profiles::store::{ProfileStore, Timestamp};

use crate::CliError;
use crate::cmd_commission::MeterArgs;
use crate::values;

/// Exit code: new profiles were written, the common white kept.
pub(crate) const EXIT_RECALIBRATED: i32 = 10;
/// Exit code: a display left the headroom, the wall's white was lowered.
pub(crate) const EXIT_LEFT_HEADROOM: i32 = 11;
/// Exit code: a device (meter, pattern output, positioner) failed.
pub(crate) const EXIT_DEVICE_FAILED: i32 = 12;
/// Exit code: the wall was not ready: a display's white kept drifting or showed no light
/// while the run waited for the lamps to warm up (the meter worked; a lamp or projector
/// needs a look).
pub(crate) const EXIT_WALL_NOT_READY: i32 = 13;

/// Arguments of `lumiwall recalibrate`.
#[derive(Debug, clap::Args)]
pub(crate) struct RecalibrateArgs {
    /// Wall description (TOML).
    #[arg(long)]
    wall: PathBuf,
    /// Profile folder written by `lumiwall commission`; new profiles replace the ones in
    /// it (the old ones move to `previous/`, see `lumiwall profiles rollback`).
    #[arg(long)]
    pub(crate) profiles: PathBuf,
    /// Record the run in this profile store: the new profiles when profiles are
    /// written, otherwise every display's readings (for `lumiwall profiles forecast`).
    #[arg(long)]
    store: Option<PathBuf>,
    /// Recalibrate when a primary's luminance changed by more than this (percent).
    #[arg(long, allow_negative_numbers = true, default_value_t = 2.0, value_parser = values::positive_finite)]
    max_luminance_change_pct: f64,
    /// Recalibrate when a primary's chromaticity moved by more than this (CIE 1931 xy).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.002, value_parser = values::positive_finite)]
    max_delta_xy: f64,
    /// Recalibrate when the black changed by more than this (cd/m²).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.05, value_parser = values::positive_finite)]
    max_black_change: f64,
    /// Measure a display again in full (tone curves included) when a channel's light at
    /// its drive in a grey of half the wall white is off its profile's curve by more than
    /// this (percent).
    #[arg(long, allow_negative_numbers = true, default_value_t = 3.0, value_parser = values::positive_finite)]
    max_curve_change_pct: f64,
    /// Recalibrate when the white a display shows through its profile, predicted from
    /// the night's readings, is more than this ΔE2000 off the common white.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.25, value_parser = values::positive_finite)]
    max_white_de: f64,
    /// Reserve to keep when the white must be lowered, in (0, 1]: give the
    /// commissioning's `--headroom` (default: the profiles' own, which after a
    /// recalibration that kept the white is the usage of that white).
    #[arg(long, value_parser = |s: &str| values::positive_at_most(s, 1.0))]
    headroom: Option<f64>,
    /// Measure each display in full (black, primaries, white, tone-curve check) once in
    /// this many nights, in turn; on the other nights one reading of white checks it
    /// (and a full check follows at once where that reading shows what ageing does not
    /// do). 1: every display in full every night.
    #[arg(long, default_value_t = 7, value_parser = clap::value_parser!(u32).range(1..=366))]
    full_check_every: u32,
    /// Meter readings each reading of the night averages: `auto` as the commissioning's
    /// saved measurements did (a dim wall's `commission --averaging`), a number fixes
    /// it.
    #[arg(long, default_value = "auto")]
    averaging: lumiwall_calib::measure::averaging::Averaging,
    /// Tonight's number for the rotation of full checks (default: days since
    /// 1970-01-01 UTC, so a nightly service needs none).
    #[arg(long)]
    night: Option<u64>,
    /// Check the flat fields with this fixed camera (`virtual`, or a V4L2/UVC device:
    /// index, `/dev/videoN` or name), calibrated by `lumiwall commission --camera` (its
    /// camera.json): every display measured in full tonight is photographed through
    /// its flat field, and one that is no longer uniform is measured again. Needs the
    /// `camera` feature (OpenCV).
    #[arg(long)]
    camera: Option<String>,
    /// With `--camera`: measure a flat field again when the display shown through it
    /// is non-uniform by more than this RMS over its texels (percent).
    #[arg(long, allow_negative_numbers = true, default_value_t = 1.0, value_parser = values::positive_finite, requires = "camera")]
    max_flat_field_residual_pct: f64,
    /// Virtual wall only: let its lamps age this many hours before measuring (to try a
    /// recalibration on the simulator).
    #[arg(long, allow_negative_numbers = true, value_parser = values::non_negative_finite)]
    simulate_hours: Option<f64>,
    /// Skip the check for a warming wall made before the first display (40 readings of
    /// its white; where the lamps were switched on for the run, the station waits until
    /// they are warm, since a wall read cold looks drifted).
    #[arg(long)]
    no_warm_check: bool,
    #[command(flatten)]
    pub(crate) meter: MeterArgs,
}

/// Runs `lumiwall recalibrate`; returns the exit code (0: nothing drifted, 10:
/// recalibrated, 11: a display left the headroom, 12: a device failed, 13: the wall was
/// not ready).
pub(crate) fn run(args: RecalibrateArgs) -> Result<i32, CliError> {
    let mut readings = 0u32;
    let done = recalibrate_with(&args, &mut |p| match p {
        Progress::Reading { .. } => readings += 1,
        Progress::WarmCheck(r) => println!("{}", r.summary()),
        Progress::WarmedUp(r) => println!("{}", r.summary()),
        _ => {}
    })?;
    match done {
        Recalibrated::DeviceFailed { wall, error } => {
            println!("recalibrate {wall}: DEVICE FAILED: {error}");
            eprintln!("lumiwall: error: {error}");
            Ok(EXIT_DEVICE_FAILED)
        }
        Recalibrated::WallNotReady { wall, error } => {
            println!("recalibrate {wall}: WALL NOT READY: {error}; no profile was written");
            eprintln!("lumiwall: error: {error}");
            Ok(EXIT_WALL_NOT_READY)
        }
        Recalibrated::Done {
            outcome,
            recorded,
            camera,
        } => {
            print!("{}", display_lines(&outcome));
            for line in camera.iter().flat_map(|c| &c.lines) {
                println!("{line}");
            }
            match recorded {
                Some(Ok(line)) => println!("{line}"),
                // the profiles are what the wall needs; the store's loss is said loudly
                Some(Err(e)) => eprintln!("lumiwall: warning: the run was not recorded: {e}"),
                None => {}
            }
            println!(
                "{}",
                summary(&outcome, readings, camera.as_ref().map(|c| c.frames))
            );
            Ok(exit_code(outcome.verdict))
        }
    }
}

/// The exit code of a verdict.
pub(crate) fn exit_code(v: Verdict) -> i32 {
    match v {
        Verdict::Unchanged => 0,
        Verdict::Recalibrated => EXIT_RECALIBRATED,
        Verdict::LeftHeadroom => EXIT_LEFT_HEADROOM,
    }
}

/// What [`recalibrate_with`] ended with.
pub(crate) enum Recalibrated {
    /// The run went through; `recorded` says what the store kept.
    Done {
        /// The outcome.
        outcome: Box<RecalibrationOutcome>,
        /// What was recorded in the store, as a line for the log, or why nothing was
        /// (`None`: no store given).
        recorded: Option<Result<String, String>>,
        /// What the fixed camera did (`None`: no `--camera`).
        camera: Option<CameraNight>,
    },
    /// A device failed (the profiles are untouched).
    DeviceFailed {
        /// Wall name.
        wall: String,
        /// What failed.
        error: String,
    },
    /// The wall did not settle or showed no light while the run waited for it (the
    /// profiles are untouched).
    WallNotReady {
        /// Wall name.
        wall: String,
        /// What the wait saw.
        error: String,
    },
}

/// `lumiwall recalibrate` without printing (the station app runs it too).
pub(crate) fn recalibrate_with(
    args: &RecalibrateArgs,
    progress: &mut dyn FnMut(Progress),
) -> Result<Recalibrated, CliError> {
    refuse_simulation_on_a_real_meter(&args.meter, args.simulate_hours)?;
    let mut station = Station::open(&args.wall, &args.meter.station_options())?;
    if let Some(h) = args.simulate_hours {
        station.wall.advance_hours(h);
    }
    let opts = options(args, &station)?;
    let started = Timestamp::now();
    let (outcome, camera) = match run_checks(&mut station, args, &opts, progress)? {
        Ok(o) => o,
        Err(e) if e.is_stopped() => {
            return Err(CliError::failure(format!("{e}; no profile was written")));
        }
        Err(e) if e.is_wall_not_ready() => {
            return Ok(Recalibrated::WallNotReady {
                wall: station.wall.name(),
                error: e.to_string(),
            });
        }
        Err(e) if e.is_device_failure() => {
            return Ok(Recalibrated::DeviceFailed {
                wall: station.wall.name(),
                error: e.to_string(),
            });
        }
        Err(e) => return Err(CliError::failure(e.to_string())),
    };
    let recorded = args
        .store
        .as_ref()
        .map(|store| record(store, &outcome, started));
    Ok(Recalibrated::Done {
        outcome: Box::new(outcome),
        recorded,
        camera,
    })
}

/// What the fixed camera did in a recalibration.
pub(crate) struct CameraNight {
    /// One line per step.
    pub(crate) lines: Vec<String>,
    /// Frames captured.
    pub(crate) frames: u32,
}

/// The recalibration's measurements and solve: a run's error is the caller's to sort
/// (device, stopped, other); a camera that cannot be used is an error at once.
type Checked = Result<(RecalibrationOutcome, Option<CameraNight>), RecalibrateError>;

/// The recalibration, with the fixed camera where `--camera` names one.
fn run_checks(
    station: &mut Station,
    args: &RecalibrateArgs,
    opts: &RecalibrateOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Checked, CliError> {
    match &args.camera {
        Some(choice) => with_camera(station, args, choice, opts, progress),
        None => Ok(station
            .recalibrate(&args.profiles, opts, progress)
            .map(|o| (o, None))),
    }
}

/// The recalibration with the fixed camera `choice`; its refitted flat fields are
/// written back to camera.json once the new profiles are written.
#[cfg(feature = "camera")]
fn with_camera(
    station: &mut Station,
    args: &RecalibrateArgs,
    choice: &str,
    opts: &RecalibrateOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Checked, CliError> {
    use lumiwall_calib::camera::{FixedCamera, NightlyFlatOptions};
    let stage = crate::cmd_camera::load_stage(&args.profiles)?;
    let noiseless = matches!(args.meter.noise, crate::cmd_commission::NoiseArg::None);
    let mut cam = crate::cmd_camera::open_photometric(station, choice, noiseless)?;
    let nightly = NightlyFlatOptions {
        tolerance_rms: args.max_flat_field_residual_pct / 100.0,
        ..NightlyFlatOptions::default()
    };
    let mut fixed = FixedCamera::new(cam.as_mut(), stage, nightly);
    let outcome = match station.recalibrate_with_camera(&args.profiles, &mut fixed, opts, progress)
    {
        Ok(o) => o,
        Err(e) => return Ok(Err(e)),
    };
    if fixed.refitted && outcome.solution.is_some() {
        crate::cmd_camera::save_stage(&args.profiles, fixed.stage())?;
    }
    let night = CameraNight {
        lines: std::mem::take(&mut fixed.lines),
        frames: fixed.frames,
    };
    Ok(Ok((outcome, Some(night))))
}

#[cfg(not(feature = "camera"))]
fn with_camera(
    _station: &mut Station,
    _args: &RecalibrateArgs,
    choice: &str,
    _opts: &RecalibrateOptions,
    _progress: &mut dyn FnMut(Progress),
) -> Result<Checked, CliError> {
    Err(crate::cmd_commission::camera_not_built(choice))
}

/// Records the outcome in the store at `path`; the line for the log, or what failed.
fn record(
    path: &std::path::Path,
    outcome: &RecalibrationOutcome,
    started: Timestamp,
) -> Result<String, String> {
    let mut store = ProfileStore::open(path).map_err(|e| e.to_string())?;
    let at = store.path().display().to_string();
    match record_in_store(&mut store, outcome, started).map_err(|e| e.to_string())? {
        Recorded::Run(id) => Ok(format!("recorded run {} in {at}", id.0)),
        Recorded::LampReadings(n) => Ok(format!("recorded {n} lamp readings in {at}")),
    }
}

/// The recalibration's options from the command line and the profile folder.
fn options(args: &RecalibrateArgs, station: &Station) -> Result<RecalibrateOptions, CliError> {
    Ok(RecalibrateOptions {
        measure: MeasureOptions {
            meter_matrix: crate::cmd_verify::meter_matrices(
                &args.meter,
                &args.profiles,
                station.meter.as_ref(),
            )?,
            averaging: args.averaging,
            ..MeasureOptions::default()
        },
        limits: DriftLimits {
            luminance_pct: args.max_luminance_change_pct,
            delta_xy: args.max_delta_xy,
            black_cd_m2: args.max_black_change,
            curve_pct: args.max_curve_change_pct,
            white_de2000: args.max_white_de,
        },
        meter_xy_offset: crate::cmd_verify::load_meter_correction(
            &args.meter,
            &args.profiles,
            station.meter.as_ref(),
        )?
        .unwrap_or([0.0; 2]),
        headroom: args.headroom,
        rotation: FullCheckRotation {
            every_nights: args.full_check_every,
            night: args.night.unwrap_or_else(days_since_epoch),
        },
        warm_check: (!args.no_warm_check)
            .then(lumiwall_calib::measure::warm_up::WarmCheck::default),
    })
}

/// Days since 1970-01-01 UTC by the system clock (0 if the clock is before it).
fn days_since_epoch() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() / 86_400)
}

/// `--simulate-hours` ages the virtual wall only: with a real meter it would age
/// nothing and mislead.
pub(crate) fn refuse_simulation_on_a_real_meter(
    meter: &MeterArgs,
    simulate_hours: Option<f64>,
) -> Result<(), CliError> {
    if simulate_hours.is_some()
        && matches!(meter.meter, lumiwall_calib::station::MeterChoice::Serial(_))
    {
        return Err(CliError::input(
            "--simulate-hours ages the virtual wall's lamps; it cannot be used with a real \
             meter (--meter serial:…)",
        ));
    }
    Ok(())
}

/// One line per display: drift, reserve left, whether it drifted.
pub(crate) fn display_lines(o: &RecalibrationOutcome) -> String {
    let mut s = String::new();
    for c in &o.checks {
        let worst_dy = c
            .luminance_change_pct
            .iter()
            .copied()
            .fold(0.0, |a: f64, b| if b.abs() > a.abs() { b } else { a });
        let worst_dxy = c.primary_delta_xy.iter().copied().fold(0.0, f64::max);
        let worst_curve = c.curve_change_pct.iter().copied().fold(0.0, |a: f64, b| {
            if b.is_nan() || b.abs() > a.abs() {
                b
            } else {
                a
            }
        });
        let (checked, curve) = match c.kind {
            CheckKind::Full => ("full", format!("{worst_curve:+5.1} %")),
            CheckKind::Escalated => ("white+full", format!("{worst_curve:+5.1} %")),
            CheckKind::White => ("white", "   –   ".to_string()),
            CheckKind::WhiteLuminance => ("white lum", "   –   ".to_string()),
        };
        s += &format!(
            "{:<44} {checked:<10} ΔY {:+6.2} %  Δxy {:.4}  black {:+.3} cd/m²  curve {curve}  white ΔE {:.2}  reserve {:+.3}  {}\n",
            c.key.to_string(),
            worst_dy,
            worst_dxy,
            c.black_change_cd_m2,
            c.white_de2000,
            c.reserve_left(),
            if c.cannot_reach_white() {
                "OUT OF REACH"
            } else if c.curves_moved {
                "curve moved: measured in full"
            } else if c.flat_field.is_some_and(|f| f.refit) {
                "flat field measured again"
            } else if c.drifted {
                "drifted"
            } else {
                "ok"
            }
        );
    }
    s
}

/// The one-line summary for logs.
pub(crate) fn summary(o: &RecalibrationOutcome, readings: u32, frames: Option<u32>) -> String {
    let drifted = o.checks.iter().filter(|c| c.drifted).count();
    let least_reserve = o
        .checks
        .iter()
        .map(|c| c.reserve_left())
        .fold(f64::INFINITY, f64::min);
    let what = match o.verdict {
        Verdict::Unchanged => "unchanged, no profiles written".to_string(),
        Verdict::Recalibrated => format!(
            "recalibrated, common white kept at {:.2} cd/m²",
            o.white_after_cd_m2
        ),
        Verdict::LeftHeadroom => format!(
            "LEFT HEADROOM: common white lowered {:.2} → {:.2} cd/m²",
            o.white_before_cd_m2, o.white_after_cd_m2
        ),
    };
    let camera = frames.map_or(String::new(), |n| format!(", {n} camera captures"));
    format!(
        "recalibrate {}: {} displays, {readings} readings{camera}, {drifted} drifted, least \
         reserve {least_reserve:.3}; {what}",
        o.wall,
        o.checks.len()
    )
}
