//! Commissioning a whole wall: measure every display, keep each display's measurement
//! on disk as soon as it is complete (so an interrupted run resumes), solve the wall,
//! write one profile per display and eye, and the report.
//!
//! Run folder layout (inside the output folder):
//!
//! ```text
//! <out>/run/run.json                     wall name and display list of the run
//! <out>/run/<display>.measurement.json   one per completed display (MeasuredDisplay)
//! <out>/<display>.json, <out>/wall.json  profiles (ProfileSet), written last
//! <out>/report.md, <out>/report.html     the report (+ gamut.svg, usage.svg)
//! <out>/meter-correction.json            the meter's estimated xy offset (if used)
//! ```
//!
//! Before the solve, each display's primaries are fused with its white reading where
//! additivity holds within meter noise, and, if asked for, a constant xy offset of the
//! meter is estimated from the displays' additivity and removed
//! ([`crate::measure::meter_offset`]); the saved run keeps the raw readings.
//!
//! Every file is written atomically (temporary file + rename,
//! [`lumiwall_profiles::write_atomic`]); a display that fails mid-measurement leaves
//! nothing behind, and profiles are only written after all displays are measured and
//! the solve succeeded.

// Errors carry the display, the reading and the device error for the technician and
// occur at most once per run, so their size does not matter.
#![allow(
    clippy::result_large_err,
    reason = "errors carry the display, the reading and the device error and occur at most once per run"
)]

use std::path::{Path, PathBuf};

use lumiwall_devices::{DeviceError, DisplayId, DisplayInfo, ReadingNoise, Xyz};
use lumiwall_profiles::apply::{ApplyError, ApplyOptions, PreparedProfile};
use lumiwall_profiles::{
    BlackMode, DisplayKey, DisplayProfile, ProfileError, ProfileSet, write_atomic,
};
use serde::{Deserialize, Serialize};

use crate::CalibError;
use crate::colorimetry::cct_to_xy;
use crate::measure::averaging::{self, Averaging, AveragingChoice, with_averaging};
use crate::measure::channel_colour::{MIN_POOLED_INTENSITY, pool, ramp_sigma_rel};
use crate::measure::drift::{DriftCheck, recheck};
use crate::measure::grey_drives::{
    GreyLevel, GreyTargets, drive_gap, merged_black, read_grey_drives, readings_needed,
    whole_grey_repeats,
};
use crate::measure::meter_offset::{MeterCorrection, correct, estimate_wall, fuse_with_white};
use crate::measure::split_grey::{SplitDisplay, below_the_samples, split_greys};
use crate::measure::warm_up::{WarmCheck, wait_or_check};
use crate::measure::{
    MeasureError, MeasureOptions, MeasuredDisplay, Patch, Progress, RampFocus, Rig, Survey,
    display_key, luminance_only, measure_display, measure_ramps, survey_display, white_capacity,
};
use crate::report::{self, ReportInputs};
use crate::solve::{
    CompositeReading, DisplayMeasurement, SolveOptions, WallSolution, WhiteTarget, now_rfc3339,
    solve_wall_at,
};
use lumiwall_core::files::FolderLock;

/// Version of the run-folder format.
pub const RUN_FORMAT_VERSION: u32 = 1;

/// Name of the run sub-folder inside the output folder.
pub const RUN_DIR: &str = "run";

pub mod final_white;

/// How to commission.
#[derive(Debug, Clone)]
pub struct CommissionOptions {
    /// Per-display measurement.
    pub measure: MeasureOptions,
    /// Wall solve.
    pub solve: SolveOptions,
    /// Continue an interrupted run: displays already measured in `<out>/run` are not
    /// measured again. Without it, earlier measurements in the run folder are discarded.
    pub resume: bool,
    /// Estimate a systematic xy offset of the meter from the displays' additivity and
    /// correct the readings with it (see [`crate::measure::meter_offset`]). Only for a
    /// meter whose error is a constant xy offset: a filter colorimeter's error keeps
    /// additivity, so additivity cannot reveal it (use meter matrices,
    /// [`crate::measure::meter_matrix`]). The primaries are fused with the white
    /// reading either way.
    pub meter_correction: bool,
    /// Grey levels (shares of the target white's luminance, or luminances): after all
    /// displays are measured, each display's channels are read alone at the drives its
    /// provisional profile gives them for these greys, so the tone curves are sampled
    /// where the white and the greys sit ([`crate::measure::grey_drives`]); the readings
    /// come out of each display's budget. A luminance the meter cannot read reliably is
    /// left out (see `commission`). Empty: no grey-drive pass.
    pub grey_levels: Vec<GreyLevel>,
    /// Without [`MeasureOptions::warm_up`]: check first whether the wall is warming,
    /// and wait for it when it is ([`crate::measure::warm_up::check_warm`]). `None`
    /// starts at once.
    pub warm_check: Option<WarmCheck>,
}

/// The manifest of a run folder.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunManifest {
    /// [`RUN_FORMAT_VERSION`].
    pub format_version: u32,
    /// Wall name.
    pub wall: String,
    /// Displays of the wall, in order.
    pub displays: Vec<DisplayKey>,
    /// Measurement options of the run.
    pub measure: MeasureOptions,
}

/// What a completed commissioning produced.
#[derive(Debug, Clone)]
pub struct CommissionOutcome {
    /// Wall name.
    pub wall: String,
    /// Every display's measurement, in wall order.
    pub measured: Vec<MeasuredDisplay>,
    /// Displays whose measurement came from an earlier run.
    pub resumed: Vec<DisplayId>,
    /// The wall solve (profiles included).
    pub solution: WallSolution,
    /// Profile folder.
    pub out_dir: PathBuf,
    /// Report files written.
    pub reports: Vec<PathBuf>,
    /// The meter correction applied, if any.
    pub meter_correction: Option<MeterCorrection>,
    /// The first display's white re-read after the last display, if any display was
    /// measured in this run.
    pub drift: Option<DriftCheck>,
    /// Meter readings each reading of the run averaged ([`MeasureOptions::averaging`]);
    /// a display's readings in its measurement count the averaged ones.
    pub readings_per_reading: u32,
    /// What [`Averaging::Auto`] chose and why, where it estimated the wall white.
    pub averaging: Option<AveragingChoice>,
}

/// Errors of a commissioning run.
#[derive(Debug, thiserror::Error)]
pub enum CommissionError {
    /// Measuring a display failed; the completed displays are saved.
    #[error(
        "{source}\n{saved} of {total} displays are measured and saved in {}; no profiles were \
         written. Fix the cause and re-run with --resume to continue.",
        run_dir.display()
    )]
    Interrupted {
        /// What failed.
        #[source]
        source: MeasureError,
        /// Displays saved so far.
        saved: usize,
        /// Displays of the wall.
        total: usize,
        /// The run folder.
        run_dir: PathBuf,
    },
    /// Reading the channels at the wall's final white failed
    /// ([`final_white::resample_at_final_white`]); the profiles of the first solve stay.
    #[error(
        "{source}\nwhile reading the tone curves at the final white; the profiles written \
         before it stay (without the camera stage's flat fields). Fix the cause and re-run \
         with --resume"
    )]
    FinalWhite {
        /// What failed.
        #[source]
        source: MeasureError,
    },
    /// The technician skipped displays while aiming; the others are measured and saved.
    #[error(
        "the technician skipped {}: {}; {saved} of {total} displays are measured and saved in \
         {}; no profiles were written. Re-run with --resume to measure the skipped ones.",
        if displays.len() == 1 { "1 display".to_string() } else { format!("{} displays", displays.len()) },
        displays.join(", "),
        run_dir.display()
    )]
    Skipped {
        /// The skipped displays.
        displays: Vec<String>,
        /// Displays measured and saved.
        saved: usize,
        /// Displays of the wall.
        total: usize,
        /// The run folder.
        run_dir: PathBuf,
    },
    /// Another process writes into the same output folder.
    #[error(transparent)]
    Locked(#[from] lumiwall_core::files::LockError),
    /// The solve failed.
    #[error("solving the wall failed: {0}")]
    Solve(#[from] CalibError),
    /// Files could not be written or read.
    #[error(transparent)]
    Profile(#[from] ProfileError),
    /// A provisional profile for the grey pass cannot be applied.
    #[error("the provisional profile for the grey pass cannot be applied: {0}")]
    Apply(#[from] ApplyError),
    /// A run folder does not belong to this wall.
    #[error(
        "cannot resume from {}: {reason}. Choose another --out or re-run without --resume to \
         start over",
        run_dir.display()
    )]
    ResumeMismatch {
        /// The run folder.
        run_dir: PathBuf,
        /// What differs.
        reason: String,
    },
    /// A saved measurement cannot be read.
    #[error(
        "saved measurement {} is unreadable ({message}); delete it to measure that display again",
        path.display()
    )]
    BadMeasurementFile {
        /// The file.
        path: PathBuf,
        /// Parser message.
        message: String,
    },
    /// File system error.
    #[error("cannot access {}: {source}", path.display())]
    Io {
        /// Path concerned.
        path: PathBuf,
        /// Underlying error.
        #[source]
        source: std::io::Error,
    },
    /// Nothing to measure.
    #[error("the wall has no displays")]
    NoDisplays,
}

/// Where a display's measurement lives in a run folder.
pub(crate) fn measurement_path(run_dir: &Path, key: &DisplayKey) -> PathBuf {
    run_dir.join(format!("{}.measurement.json", key.file_stem()))
}

pub(crate) fn to_json<T: Serialize>(v: &T) -> Vec<u8> {
    // Plain numbers, strings and enums always serialise.
    serde_json::to_vec_pretty(v).unwrap_or_default()
}

/// Reads a completed display's measurement from a run folder, if present.
pub fn load_measurement(path: &Path) -> Result<Option<MeasuredDisplay>, CommissionError> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => {
            return Err(CommissionError::Io {
                path: path.to_path_buf(),
                source,
            });
        }
    };
    serde_json::from_str(&text)
        .map(Some)
        .map_err(|e| CommissionError::BadMeasurementFile {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
}

/// Prepares the run folder: checks or writes the manifest; without `resume`, removes
/// measurements of earlier runs.
fn prepare_run_dir(
    run_dir: &Path,
    manifest: &RunManifest,
    resume: bool,
) -> Result<(), CommissionError> {
    let path = run_dir.join("run.json");
    if resume && path.exists() {
        let text = std::fs::read_to_string(&path).map_err(|source| CommissionError::Io {
            path: path.clone(),
            source,
        })?;
        let old: RunManifest =
            serde_json::from_str(&text).map_err(|e| CommissionError::ResumeMismatch {
                run_dir: run_dir.to_path_buf(),
                reason: format!("run.json is unreadable: {e}"),
            })?;
        if old.format_version != RUN_FORMAT_VERSION {
            return Err(CommissionError::ResumeMismatch {
                run_dir: run_dir.to_path_buf(),
                reason: format!("run format version {}", old.format_version),
            });
        }
        if old.wall != manifest.wall || old.displays != manifest.displays {
            return Err(CommissionError::ResumeMismatch {
                run_dir: run_dir.to_path_buf(),
                reason: format!(
                    "it holds a run of wall '{}' with {} displays, this is wall '{}' with {}",
                    old.wall,
                    old.displays.len(),
                    manifest.wall,
                    manifest.displays.len()
                ),
            });
        }
        if old.measure.meter_matrix != manifest.measure.meter_matrix {
            return Err(CommissionError::ResumeMismatch {
                run_dir: run_dir.to_path_buf(),
                reason: "its readings were corrected with other meter matrices (or none); \
                         resume with the same --meter-matrix, or start again without --resume"
                    .into(),
            });
        }
        if old.measure != manifest.measure {
            tracing::warn!("resuming with different measurement options than the interrupted run");
        }
        return Ok(());
    }
    if !resume && run_dir.exists() {
        for key in &manifest.displays {
            let p = measurement_path(run_dir, key);
            match std::fs::remove_file(&p) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(source) => return Err(CommissionError::Io { path: p, source }),
            }
        }
    }
    write_atomic(&path, &to_json(manifest))?;
    Ok(())
}

/// Commissions a wall: measures every display (resuming if asked), solves, writes the
/// profiles into `out_dir` and the report. The output folder is locked for the whole
/// run ([`FolderLock`]): a second commission into it fails at once with
/// [`CommissionError::Locked`].
pub fn commission(
    wall: &str,
    displays: &[DisplayInfo],
    rig: &mut Rig<'_>,
    out_dir: &Path,
    opts: &CommissionOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<CommissionOutcome, CommissionError> {
    let _lock = FolderLock::acquire(out_dir, &format!("commission of wall {wall}"))?;
    let opts = &CommissionOptions {
        grey_levels: grey_levels_for(opts, rig),
        ..opts.clone()
    };
    let WallMeasured {
        mut measured,
        resumed,
        readings_per_reading: n,
        averaging: choice,
    } = measure_wall(wall, displays, rig, out_dir, opts, progress)?;
    let noise = rig.meter.info().noise;
    let drift = with_averaging(rig, n, |rig| {
        read_greys(displays, rig, out_dir, opts, &mut measured, progress)?;
        Ok::<_, CommissionError>(drift_over_run(
            displays, rig, &measured, &resumed, opts, progress,
        ))
    })?;
    let mut outcome = finish(wall, measured, resumed, out_dir, opts, drift.as_ref())?;
    outcome.readings_per_reading = n;
    outcome.averaging = choice;
    warn_if_too_few_averaged(&outcome, noise.as_ref(), opts);
    Ok(outcome)
}

/// Under [`Averaging::Auto`], where the run chose nothing before the ramps (a
/// technician aims the meter; the target white is a display's native one, unknown
/// before measuring) and read each reading once: tells the technician when the solved
/// wall white needed more, and what to run.
fn warn_if_too_few_averaged(
    outcome: &CommissionOutcome,
    noise: Option<&ReadingNoise>,
    opts: &CommissionOptions,
) {
    let (Averaging::Auto, Some(noise), None, 1) = (
        opts.measure.averaging,
        noise,
        outcome.averaging,
        outcome.readings_per_reading,
    ) else {
        return;
    };
    let Some(profile) = outcome.solution.profiles.first() else {
        return;
    };
    let white = Xyz::from_array(profile.target_white_xyz_cd_m2);
    let Some(xy) = white.xy() else {
        return;
    };
    let (n, _) = averaging::needed(noise, xy, white.y);
    if n > outcome.readings_per_reading {
        tracing::warn!(
            "the wall white of {:.1} cd/m² is dim for this meter: each reading should have \
             averaged {n} meter readings for the chart's darkest greys, and this run read \
             each {} time(s); run again with --averaging {n}",
            white.y,
            outcome.readings_per_reading,
        );
    }
}

/// [`CommissionOptions::grey_levels`]: the wall solved once as measured, then every
/// display's channels read at the drives of its provisional white and greys, added to
/// its ramps and saved with its measurement (a resumed run does not read them again).
fn read_greys(
    displays: &[DisplayInfo],
    rig: &mut Rig<'_>,
    out_dir: &Path,
    opts: &CommissionOptions,
    measured: &mut [MeasuredDisplay],
    progress: &mut dyn FnMut(Progress),
) -> Result<(), CommissionError> {
    if !measured.iter().any(|m| grey_pass_left(m, opts)) {
        return Ok(());
    }
    let (_, inputs) = solve_inputs(measured, opts);
    let provisional = solve_wall_at(&inputs, &opts.solve, &now_rfc3339())?;
    let run_dir = out_dir.join(RUN_DIR);
    let total = displays.len();
    let noise = rig.meter.info().noise;
    for (info, m) in displays.iter().zip(measured.iter_mut()) {
        let key = &m.measurement.key;
        let Some(profile) = provisional.profiles.iter().find(|p| p.display == *key) else {
            continue;
        };
        if !grey_pass_left(m, opts) {
            continue;
        }
        let pass = GreyPass {
            levels: &opts.grey_levels,
            budget: opts.measure.budget.saturating_sub(m.measurement.readings),
            whole_repeats: whole_grey_repeats(noise.as_ref(), opts.measure.budget),
            black_with_rest: true,
        };
        // Every display's measurement is saved; --resume reads the rest of the grey
        // drives.
        let interrupted = |source| CommissionError::Interrupted {
            source,
            saved: total,
            total,
            run_dir: run_dir.clone(),
        };
        let readings = read_greys_of(info, m, profile, rig, &pass, opts, progress)
            .map_err(|e| e.into_commission(interrupted))?;
        m.log.grey_drive_readings = Some(readings);
        write_atomic(&measurement_path(&run_dir, &m.measurement.key), &to_json(m))?;
    }
    Ok(())
}

/// Whether `m`'s grey-drive pass is still to read: the run has grey levels and the
/// measurement holds no grey-drive readings yet.
fn grey_pass_left(m: &MeasuredDisplay, opts: &CommissionOptions) -> bool {
    !opts.grey_levels.is_empty() && m.log.grey_drive_readings.is_none()
}

/// What one grey-drive pass over a display reads.
struct GreyPass<'l> {
    /// The greys.
    levels: &'l [GreyLevel],
    /// Readings it may take.
    budget: u32,
    /// Readings averaged for each grey read whole (0: none).
    whole_repeats: u32,
    /// Whether what the pass leaves of `budget` re-reads the black
    /// ([`GreyTargets::black_with_rest`]).
    black_with_rest: bool,
}

/// Why a grey-drive pass over one display stopped.
enum GreyPassError {
    /// Its profile cannot be applied.
    Profile(ApplyError),
    /// A reading failed.
    Measure(MeasureError),
}

impl GreyPassError {
    /// The commissioning error, a failed reading turned into one by `interrupted`.
    fn into_commission(
        self,
        interrupted: impl FnOnce(MeasureError) -> CommissionError,
    ) -> CommissionError {
        match self {
            Self::Profile(e) => e.into(),
            Self::Measure(e) => interrupted(e),
        }
    }
}

/// One display's channels read at the drives `profile` gives its white and greys at
/// the meter's spot (flat field included), the readings pooled with its log into its
/// primaries and ramps ([`pool`]), the greys read whole added to its composites.
/// Returns the readings taken.
fn read_greys_of(
    info: &DisplayInfo,
    m: &mut MeasuredDisplay,
    profile: &DisplayProfile,
    rig: &mut Rig<'_>,
    pass: &GreyPass<'_>,
    opts: &CommissionOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<u32, GreyPassError> {
    let noise = rig.meter.info().noise;
    let prepared =
        PreparedProfile::new(profile, &ApplyOptions::default()).map_err(GreyPassError::Profile)?;
    let mut mopts = opts.measure.clone();
    mopts.budget = pass.budget;
    let targets = GreyTargets {
        prepared: &prepared,
        white: Xyz::from_array(profile.target_white_xyz_cd_m2),
        levels: pass.levels,
        bit_depth: m.measurement.bit_depth,
        black: m.measurement.black,
        primaries: m.measurement.primaries,
        ramp_drives: std::array::from_fn(|c| m.measurement.ramps[c].iter().map(|s| s.0).collect()),
        whole_repeats: pass.whole_repeats,
        black_with_rest: pass.black_with_rest,
    };
    let read = read_grey_drives(rig, &m.measurement.key, info.id, &targets, &mopts, progress)
        .map_err(GreyPassError::Measure)?;
    let readings = read.readings;
    let instrument_noise = rig.meter.instrument_noise();
    let pooled = black_read_again(m, &read.black_readings, instrument_noise, &mopts);
    match (pooled, read.black) {
        (Some(black), _) => m.measurement.black = black,
        (None, Some((again, n))) => {
            let first = m.log.readings_of(Patch::Black);
            m.measurement.black = merged_black(m.measurement.black, first, again, n);
        }
        (None, None) => {}
    }
    m.log.samples.extend(read.samples);
    m.log.noise_seen.merge(read.noise_seen);
    let (primaries, ramps) = pool(&m.log, m.measurement.black, m.measurement.primaries, noise);
    m.measurement.ramp_sigma_rel = ramp_sigma_rel(&m.log, m.measurement.black, primaries, noise);
    (m.measurement.primaries, m.measurement.ramps) = (primaries, ramps);
    add_split_greys(m, profile, noise);
    m.measurement.composites.extend(read.composites);
    m.measurement.readings += readings;
    m.log.readings += readings;
    Ok(readings)
}

/// `m`'s black from its log's readings of it and those of the grey-drive pass
/// (`again`, its refusals counted too), added to its log ([`crate::measure::black_of`],
/// `noise` that of one of the instrument's readings); `None` where the pass read no
/// black, or for a log written before it kept them (then the two means are weighted by
/// readings: [`merged_black`]).
fn black_read_again(
    m: &mut MeasuredDisplay,
    again: &lumiwall_devices::CensoredReadings,
    noise: Option<ReadingNoise>,
    opts: &MeasureOptions,
) -> Option<Xyz> {
    if m.log.black_readings.is_empty() || again.is_empty() {
        return None;
    }
    m.log.black_readings.merge(again);
    let m = &*m;
    let primaries = &m.measurement.primaries;
    crate::measure::black_of(&m.log, noise.as_ref(), opts, &m.measurement.key, primaries)
}

/// The greys of `m`'s log read whole ([`GreyLevel::Split`]) split into channel samples
/// on its pooled lines ([`split_greys`], the white segment of the provisional `profile`
/// inverted) and added to its ramps, each weighted by its noise where the ramps are
/// ([`ramp_sigma_rel`]): only a channel's samples below its ramp samples
/// ([`below_the_samples`], where its curve is extrapolated), and none within
/// [`drive_gap`] of another.
fn add_split_greys(m: &mut MeasuredDisplay, profile: &DisplayProfile, noise: Option<ReadingNoise>) {
    let display = SplitDisplay {
        black: m.measurement.black,
        primaries: m.measurement.primaries,
        model: profile.display_model,
    };
    let gap = drive_gap(noise.as_ref());
    // As `ramp_sigma_rel` weighs the ramps: with a stated, non-zero noise only.
    let weighted = noise.is_some_and(|n| !n.is_exact());
    let seen = m.log.noise_seen.scale();
    for (c, samples) in split_greys(&m.log, &display, noise).into_iter().enumerate() {
        let ramp_drives: Vec<f64> = m.measurement.ramps[c].iter().map(|(d, _)| *d).collect();
        // The last read first: a grey aimed again lands nearer the chart's than the
        // reading that aimed it, which then only joins where it is not beside it.
        for s in samples.into_iter().rev() {
            let ramp = &mut m.measurement.ramps[c];
            let beside = ramp.iter().any(|(d, _)| (d - s.drive).abs() < gap);
            let wanted = below_the_samples(s.drive, &ramp_drives, gap)
                && !beside
                && (!weighted || s.sigma_rel > 0.0);
            if !wanted {
                continue;
            }
            ramp.push((s.drive, s.xyz));
            if weighted {
                m.measurement.ramp_sigma_rel[c].push(s.sigma_rel * seen);
            }
        }
    }
}

/// The grey levels of `opts` worth reading with the rig's meter ([`usable_grey_levels`]
/// at its low-light limit, or the one `opts` sets).
fn grey_levels_for(opts: &CommissionOptions, rig: &Rig<'_>) -> Vec<GreyLevel> {
    let info = rig.meter.info();
    let limit = opts
        .measure
        .low_light_limit_cd_m2
        .unwrap_or(info.min_reliable_cd_m2);
    usable_grey_levels(&opts.grey_levels, limit, info.noise.is_some())
}

/// The grey levels worth reading with a meter reliable down to `limit_cd_m2`: every
/// share of the white; a grey of luminance `y` always when the meter states its noise
/// (`noise_stated`: each channel sample is then weighted by it, so a dim saturated
/// channel is read through its strongest tristimulus value), else only if
/// `y ≥ 3·limit`. Its channels alone show about a third of it each (one of them less):
/// read through its luminance alone, below that the meter's low-light noise in a toe
/// sample costs more than the toe's interpolation error (on six classes of wall with a
/// CS-100A class meter, a 1 cd/m² level made the grey balance worse on five; weighted,
/// it took dlp-infitec-2x1's worst white ΔE2000 at 64 readings from 1.24 to 0.76).
fn usable_grey_levels(
    levels: &[GreyLevel],
    limit_cd_m2: f64,
    noise_stated: bool,
) -> Vec<GreyLevel> {
    levels
        .iter()
        .copied()
        .filter(|l| match l {
            GreyLevel::Share(_) | GreyLevel::WidestGap => true,
            GreyLevel::Luminance(y) => noise_stated || *y >= 3.0 * limit_cd_m2,
            // Its samples come from the reading's colour through `P⁻¹`, which a meter
            // that states no noise is not trusted with in the dark (`luminance_only`).
            GreyLevel::Split(_) => noise_stated,
        })
        .collect()
}

/// The readings each display's ramps leave for the grey-drive pass (read with a meter
/// of stated `noise`), unless the budget is too small for both (then the pass reads
/// only what is left, if anything).
fn grey_reserve(opts: &CommissionOptions, noise: Option<&ReadingNoise>) -> u32 {
    let n = readings_needed(&opts.grey_levels, noise, opts.measure.budget);
    if opts.measure.budget.saturating_sub(n) >= MeasureOptions::MIN_BUDGET {
        n
    } else {
        0
    }
}

/// The first display measured in this run, read again at full white after the last
/// ([`crate::measure::drift`]); `None` when every display came from an earlier run, or
/// when the re-read fails (the measurements are complete, so the profiles are made
/// anyway; the failure is logged).
fn drift_over_run(
    displays: &[DisplayInfo],
    rig: &mut Rig<'_>,
    measured: &[MeasuredDisplay],
    resumed: &[DisplayId],
    opts: &CommissionOptions,
    progress: &mut dyn FnMut(Progress),
) -> Option<DriftCheck> {
    let (info, m) = displays
        .iter()
        .zip(measured)
        .find(|(d, _)| !resumed.contains(&d.id))?;
    let white = m.measurement.white?;
    match recheck(
        rig,
        info,
        &m.measurement.key,
        white,
        &opts.measure,
        progress,
    ) {
        Ok(d) => d,
        Err(e) => {
            tracing::warn!("the drift re-read of {} failed: {e}", info.name);
            None
        }
    }
}

/// Where the ramps should concentrate: on the part of each channel the common white
/// will use, given every display's black and primaries (`(black, primaries)`): the
/// wall white can be no brighter than what the dimmest display reaches.
fn ramp_focus<'m>(
    opts: &CommissionOptions,
    white_xy: [f64; 2],
    readings: impl Iterator<Item = (Xyz, &'m [Xyz; 3])> + Clone,
) -> RampFocus {
    RampFocus {
        white_xy,
        headroom: opts.solve.headroom,
        white_y_cd_m2: readings
            .clone()
            .filter_map(|(black, primaries)| {
                white_capacity(black, primaries, white_xy, opts.solve.headroom).map(|c| c.0)
            })
            .reduce(f64::min),
        toe_samples: opts.solve.black_mode == BlackMode::Common,
        common_black: readings
            .map(|(black, _)| black)
            .reduce(|a, b| Xyz::new(a.x.max(b.x), a.y.max(b.y), a.z.max(b.z))),
    }
}

/// One display of the wall after the survey.
enum Slot {
    /// Measured completely by an earlier run (`--resume`).
    Saved(Box<MeasuredDisplay>),
    /// Its black, primaries and white, read in this run; the ramps are still to come.
    Surveyed(Box<Survey>),
    /// The technician skipped it at the aim.
    Skipped,
}

impl Slot {
    /// Black and primaries, where read.
    fn readings(&self) -> Option<(Xyz, &[Xyz; 3])> {
        match self {
            Slot::Saved(m) => Some((m.measurement.black, &m.measurement.primaries)),
            Slot::Surveyed(s) => Some((s.black, &s.primaries)),
            Slot::Skipped => None,
        }
    }
}

/// The displays of a commissioning and where their measurements are saved.
struct WallPass<'p> {
    displays: &'p [DisplayInfo],
    keys: &'p [DisplayKey],
    run_dir: &'p Path,
    opts: &'p CommissionOptions,
}

/// Every display measured (saved or resumed), those taken from an earlier run, and
/// the names of those the technician skipped.
type PassOutcome = (Vec<MeasuredDisplay>, Vec<DisplayId>, Vec<String>);

impl WallPass<'_> {
    /// The saved measurement of display `k` when resuming (reported as resumed).
    fn saved(
        &self,
        k: usize,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<Option<MeasuredDisplay>, CommissionError> {
        if !self.opts.resume {
            return Ok(None);
        }
        let key = &self.keys[k];
        let Some(m) = load_measurement(&measurement_path(self.run_dir, key))? else {
            return Ok(None);
        };
        if m.measurement.key != *key {
            return Ok(None);
        }
        progress(Progress::Resumed {
            display: self.displays[k].id,
            readings: m.measurement.readings,
        });
        Ok(Some(m))
    }

    fn interrupted(&self, source: MeasureError, saved: usize) -> CommissionError {
        CommissionError::Interrupted {
            source,
            saved,
            total: self.displays.len(),
            run_dir: self.run_dir.to_path_buf(),
        }
    }

    /// Two visits per display: first every display's black, primaries and white
    /// ([`survey_display`]), then each display's ramps focused on the wall white that
    /// all of them allow ([`measure_ramps`]), the first display's too. Each reading
    /// averages the meter readings [`MeasureOptions::averaging`] asks; under
    /// [`Averaging::Auto`] the survey's wall white chooses ([`AveragingChoice`]), and
    /// where it asks for more than one the displays are surveyed again with it (the
    /// first survey's readings counted in the choice). Returns the readings each reading
    /// averaged and the choice.
    fn survey_first(
        &self,
        rig: &mut Rig<'_>,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<(PassOutcome, u32, Option<AveragingChoice>), CommissionError> {
        let fixed = match self.opts.measure.averaging {
            Averaging::Fixed(_) => Some(self.opts.measure.averaging.count_or_one()),
            Averaging::Auto => None,
        };
        let mut n = fixed.unwrap_or(1);
        let mut slots = with_averaging(rig, n, |rig| {
            let mopts = self.measure_options(rig);
            self.survey_all(rig, &mopts, n, None, progress)
        })?;
        let noise = rig.meter.info().noise;
        let choice = match (fixed, noise) {
            (None, Some(noise)) if !noise.is_exact() => self.averaging_choice(&noise, &slots),
            _ => None,
        };
        match choice {
            Some(c) => {
                progress(Progress::Averaging(c));
                if c.readings_per_reading > 1 {
                    n = c.readings_per_reading;
                    slots = with_averaging(rig, n, |rig| {
                        let mopts = self.measure_options(rig);
                        self.survey_all(rig, &mopts, n, Some(slots), progress)
                    })?;
                }
            }
            // A resumed run with every display saved: as the saved ones averaged.
            None if fixed.is_none() => n = saved_averaging(&slots),
            None => {}
        }
        let outcome = with_averaging(rig, n, |rig| {
            let mopts = self.measure_options(rig);
            self.ramps_after_survey(rig, mopts, slots, progress)
        })?;
        Ok((outcome, n, choice))
    }

    /// The run's measuring options with `rig`'s meter: the readings the grey-drive pass
    /// reserves follow its stated noise.
    fn measure_options(&self, rig: &Rig<'_>) -> MeasureOptions {
        MeasureOptions {
            reserved: grey_reserve(self.opts, rig.meter.info().noise.as_ref()),
            ..self.opts.measure.clone()
        }
    }

    /// Every display's slot: its saved measurement when resuming, else its survey; with
    /// `again` (an earlier survey's slots), only the surveyed displays are surveyed
    /// anew.
    fn survey_all(
        &self,
        rig: &mut Rig<'_>,
        mopts: &MeasureOptions,
        n: u32,
        again: Option<Vec<Slot>>,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<Vec<Slot>, CommissionError> {
        let mut earlier = again.map(Vec::into_iter);
        let mut slots = Vec::with_capacity(self.displays.len());
        for (k, info) in self.displays.iter().enumerate() {
            let (kept, first_survey) = match earlier.as_mut().and_then(Iterator::next) {
                Some(Slot::Surveyed(first)) => (None, first.log.readings),
                Some(slot) => (Some(slot), 0),
                None => (
                    self.saved(k, progress)?.map(|m| Slot::Saved(Box::new(m))),
                    0,
                ),
            };
            if let Some(slot) = kept {
                slots.push(slot);
                continue;
            }
            match survey_display(rig, info, &self.keys[k], mopts, progress) {
                Ok(mut s) => {
                    s.log.readings_averaged = n;
                    s.log.first_survey_readings = first_survey;
                    slots.push(Slot::Surveyed(Box::new(s)));
                }
                Err(e) if is_skip(&e) => slots.push(Slot::Skipped),
                Err(source) => {
                    let saved = slots.iter().filter(|s| matches!(s, Slot::Saved(_))).count();
                    return Err(self.interrupted(source, saved));
                }
            }
        }
        Ok(slots)
    }

    /// What [`Averaging::Auto`] chooses for the wall white the surveyed and saved
    /// displays allow at the target white, with a meter of this stated noise; `None`
    /// when no display was surveyed in this run or the wall white is not known.
    fn averaging_choice(&self, noise: &ReadingNoise, slots: &[Slot]) -> Option<AveragingChoice> {
        let xy = target_white_xy(self.opts)?;
        let readings: u32 = slots
            .iter()
            .map(|s| match s {
                Slot::Surveyed(s) => s.log.readings,
                _ => 0,
            })
            .sum();
        if readings == 0 {
            return None;
        }
        let focus = ramp_focus(self.opts, xy, slots.iter().filter_map(Slot::readings));
        let white_y = focus.white_y_cd_m2?;
        Some(AveragingChoice::for_wall(noise, xy, white_y, readings))
    }

    /// The ramps of every surveyed display, focused on the wall white all of them
    /// allow; saved displays as they are.
    fn ramps_after_survey(
        &self,
        rig: &mut Rig<'_>,
        mut mopts: MeasureOptions,
        slots: Vec<Slot>,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<PassOutcome, CommissionError> {
        if mopts.focus.is_none() {
            mopts.focus = target_white_xy(self.opts)
                .map(|xy| ramp_focus(self.opts, xy, slots.iter().filter_map(Slot::readings)));
        }
        let (mut measured, mut resumed, mut skipped) = (Vec::new(), Vec::new(), Vec::new());
        for ((info, key), slot) in self.displays.iter().zip(self.keys).zip(slots) {
            let survey = match slot {
                Slot::Saved(m) => {
                    resumed.push(info.id);
                    measured.push(*m);
                    continue;
                }
                Slot::Skipped => {
                    skipped.push(info.name.clone());
                    continue;
                }
                Slot::Surveyed(survey) => survey,
            };
            let m = measure_ramps(rig, info, key, *survey, &mopts, progress)
                .map_err(|source| self.interrupted(source, measured.len()))?;
            write_atomic(&measurement_path(self.run_dir, key), &to_json(&m))?;
            measured.push(m);
        }
        Ok((measured, resumed, skipped))
    }

    /// One visit per display (a technician aims): each display measured whole, its
    /// ramps focused on the wall white that the displays measured before it allow.
    fn one_visit_each(
        &self,
        rig: &mut Rig<'_>,
        mopts: MeasureOptions,
        n: u32,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<PassOutcome, CommissionError> {
        let (mut measured, mut resumed, mut skipped) = (Vec::new(), Vec::new(), Vec::new());
        let white_xy = target_white_xy(self.opts);
        for (k, info) in self.displays.iter().enumerate() {
            if let Some(m) = self.saved(k, progress)? {
                resumed.push(info.id);
                measured.push(m);
                continue;
            }
            let mut o = mopts.clone();
            if o.focus.is_none() {
                let so_far = measured
                    .iter()
                    .map(|m: &MeasuredDisplay| (m.measurement.black, &m.measurement.primaries));
                o.focus = white_xy.map(|xy| ramp_focus(self.opts, xy, so_far));
            }
            let key = &self.keys[k];
            match measure_display(rig, info, key, &o, progress) {
                Ok(mut m) => {
                    m.log.readings_averaged = n;
                    write_atomic(&measurement_path(self.run_dir, key), &to_json(&m))?;
                    measured.push(m);
                }
                Err(e) if is_skip(&e) => skipped.push(info.name.clone()),
                Err(source) => return Err(self.interrupted(source, measured.len())),
            }
        }
        Ok((measured, resumed, skipped))
    }
}

/// The technician skipped the display at the aim.
fn is_skip(e: &MeasureError) -> bool {
    matches!(
        e,
        MeasureError::Aim {
            source: DeviceError::AimSkipped(_),
            ..
        }
    )
}

/// The measuring half of [`commission`].
pub fn measure_wall(
    wall: &str,
    displays: &[DisplayInfo],
    rig: &mut Rig<'_>,
    out_dir: &Path,
    opts: &CommissionOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<WallMeasured, CommissionError> {
    if displays.is_empty() {
        return Err(CommissionError::NoDisplays);
    }
    let run_dir = out_dir.join(RUN_DIR);
    let keys: Vec<DisplayKey> = displays.iter().map(|d| display_key(wall, d)).collect();
    let manifest = RunManifest {
        format_version: RUN_FORMAT_VERSION,
        wall: wall.to_string(),
        displays: keys.clone(),
        measure: opts.measure.clone(),
    };
    prepare_run_dir(&run_dir, &manifest, opts.resume)?;

    warm_up_first(wall, displays, rig, &run_dir, &keys, opts, progress)?;
    let pass = WallPass {
        displays,
        keys: &keys,
        run_dir: &run_dir,
        opts,
    };
    let ((measured, resumed, skipped), n, choice) = if rig.positioner.revisits_cheaply() {
        pass.survey_first(rig, progress)?
    } else {
        let n = opts.measure.averaging.count_or_one();
        let outcome = with_averaging(rig, n, |rig| {
            let mopts = pass.measure_options(rig);
            pass.one_visit_each(rig, mopts, n, progress)
        })?;
        (outcome, n, None)
    };
    if !skipped.is_empty() {
        return Err(CommissionError::Skipped {
            displays: skipped,
            saved: measured.len(),
            total: displays.len(),
            run_dir,
        });
    }
    Ok(WallMeasured {
        measured,
        resumed,
        readings_per_reading: n,
        averaging: choice,
    })
}

/// What [`measure_wall`] measured.
#[derive(Debug)]
pub struct WallMeasured {
    /// Every display's measurement, in wall order.
    pub measured: Vec<MeasuredDisplay>,
    /// The displays taken from an earlier run.
    pub resumed: Vec<DisplayId>,
    /// Meter readings each reading averaged ([`MeasureOptions::averaging`]; the
    /// grey-drive pass, the drift re-read and the camera stage's re-read at the final
    /// white average as many; the warm check reads once).
    pub readings_per_reading: u32,
    /// What [`Averaging::Auto`] chose and why, where it chose.
    pub averaging: Option<AveragingChoice>,
}

/// Meter readings each reading averaged in the saved measurements of `slots` (the
/// most of any; 1 where none is saved): what a resumed run's remaining passes average
/// when it surveys nothing and so chooses nothing.
fn saved_averaging(slots: &[Slot]) -> u32 {
    averaging::of_saved(slots.iter().filter_map(|s| match s {
        Slot::Saved(m) => Some(m.as_ref()),
        _ => None,
    }))
}

/// The target white's chromaticity when it is known before measuring.
fn target_white_xy(opts: &CommissionOptions) -> Option<[f64; 2]> {
    match opts.solve.white {
        WhiteTarget::Xy(xy) => Some(xy),
        WhiteTarget::Cct(k) => cct_to_xy(k).ok(),
        WhiteTarget::NativeOf(_) => None,
    }
}

/// Before the first display still to measure: waits for the wall
/// ([`MeasureOptions::warm_up`]), or checks whether it is warming and waits if it is
/// ([`CommissionOptions::warm_check`]; [`wait_or_check`]); on the next one where the
/// technician skips it while aiming. A display taken from an earlier run whose
/// grey-drive pass is still to read counts as still to measure (its pass reads the
/// rest of its budget): a run resumed the next morning on lamps just switched on would
/// otherwise read those channels cold. Nothing when every display is taken from an
/// earlier run whole.
fn warm_up_first(
    wall: &str,
    displays: &[DisplayInfo],
    rig: &mut Rig<'_>,
    run_dir: &Path,
    keys: &[DisplayKey],
    opts: &CommissionOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<(), CommissionError> {
    if opts.measure.warm_up.is_none() && opts.warm_check.is_none() {
        return Ok(());
    }
    let to_measure = still_to_measure(displays, keys, run_dir, opts);
    let saved = displays.len() - to_measure.iter().filter(|p| !p.saved).count();
    let run_readings = to_measure
        .iter()
        .fold(0u32, |sum, p| sum.saturating_add(p.readings));
    let check = opts.warm_check.as_ref();
    for Pending { info: first, .. } in &to_measure {
        let done = wait_or_check(
            rig,
            wall,
            first,
            &opts.measure,
            check,
            run_readings,
            progress,
        )
        .map_err(|source| CommissionError::Interrupted {
            source,
            saved,
            total: displays.len(),
            run_dir: run_dir.to_path_buf(),
        })?;
        if done {
            break;
        }
    }
    Ok(())
}

/// A display the run still reads ([`still_to_measure`]).
struct Pending<'d> {
    info: &'d DisplayInfo,
    /// The readings it will take.
    readings: u32,
    /// Whether its measurement is saved (only its grey-drive pass is left).
    saved: bool,
}

/// The displays a run still reads, in order: the whole budget where no measurement is
/// saved (or the run is not resumed), what the grey-drive pass leaves of it where a
/// saved measurement still waits for that pass.
fn still_to_measure<'d>(
    displays: &'d [DisplayInfo],
    keys: &[DisplayKey],
    run_dir: &Path,
    opts: &CommissionOptions,
) -> Vec<Pending<'d>> {
    let budget = opts.measure.budget;
    let saved = |k: &DisplayKey| {
        opts.resume
            .then(|| {
                load_measurement(&measurement_path(run_dir, k))
                    .ok()
                    .flatten()
            })
            .flatten()
    };
    displays
        .iter()
        .zip(keys)
        .filter_map(|(info, k)| match saved(k) {
            None => Some(Pending {
                info,
                readings: budget,
                saved: false,
            }),
            Some(m) if grey_pass_left(&m, opts) => Some(Pending {
                info,
                readings: budget.saturating_sub(m.measurement.readings).max(1),
                saved: true,
            }),
            Some(_) => None,
        })
        .collect()
}

/// The solving half of [`commission`]: solve, write profiles and report.
pub fn finish(
    wall: &str,
    measured: Vec<MeasuredDisplay>,
    resumed: Vec<DisplayId>,
    out_dir: &Path,
    opts: &CommissionOptions,
    drift: Option<&DriftCheck>,
) -> Result<CommissionOutcome, CommissionError> {
    let correction_path = out_dir.join(MeterCorrection::FILE);
    let (correction, inputs) = solve_inputs(&measured, opts);
    let solution = solve_wall_at(&inputs, &opts.solve, &now_rfc3339())?;
    match &correction {
        Some(c) => write_atomic(&correction_path, &to_json(c))?,
        None => match std::fs::remove_file(&correction_path) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(source) => {
                return Err(CommissionError::Io {
                    path: correction_path,
                    source,
                });
            }
        },
    }
    ProfileSet::save_dir(out_dir, wall, &solution.profiles)?;
    drop_previous(out_dir)?;
    let report_in = ReportInputs {
        wall,
        measured: &measured,
        solution: &solution,
        solve: &opts.solve,
        meter_correction: correction.as_ref(),
        drift,
    };
    let reports = write_reports(out_dir, &report_in)?;
    Ok(CommissionOutcome {
        wall: wall.to_string(),
        measured,
        resumed,
        solution,
        out_dir: out_dir.to_path_buf(),
        reports,
        meter_correction: correction,
        drift: drift.cloned(),
        readings_per_reading: 1,
        averaging: None,
    })
}

/// The solve's inputs: each display's measurement with the meter's xy offset
/// estimated from the wall's additivity removed, when asked for
/// ([`CommissionOptions::meter_correction`]), and the primaries fused with the white.
fn solve_inputs(
    measured: &[MeasuredDisplay],
    opts: &CommissionOptions,
) -> (Option<MeterCorrection>, Vec<DisplayMeasurement>) {
    let correction = if opts.meter_correction {
        let instrument = measured
            .first()
            .map(|m| m.measurement.instrument.clone())
            .unwrap_or_default();
        let readings: Vec<_> = measured
            .iter()
            .map(|m| {
                let mm = &m.measurement;
                (mm.black, mm.primaries, mm.white)
            })
            .collect();
        estimate_wall(&instrument, &readings)
    } else {
        None
    };
    let inputs: Vec<_> = measured
        .iter()
        .map(|m| {
            corrected_measurement(
                &m.measurement,
                correction.as_ref().map_or([0.0; 2], |c| c.xy_offset),
                f64::from(opts.measure.primary_repeats()),
                white_readings(m, opts.measure.primary_repeats()),
            )
        })
        .collect();
    (correction, inputs)
}

/// Readings averaged in display `m`'s full white, as its log records them
/// (`otherwise` where it records none).
pub(crate) fn white_readings(m: &MeasuredDisplay, otherwise: u32) -> f64 {
    let logged = m.log.last_read(crate::measure::Patch::White);
    f64::from(logged.map_or(otherwise, |r| r.repeats.max(1)))
}

/// Removes a recalibration's `previous/`: it belongs to the profiles this
/// commissioning replaced, and `profiles rollback` must not bring them back over the
/// new ones.
fn drop_previous(out_dir: &Path) -> Result<(), CommissionError> {
    let previous = out_dir.join(crate::recalibrate::PREVIOUS_DIR);
    crate::recalibrate::remove_dir_all_if_present(&previous).map_err(|source| CommissionError::Io {
        path: previous.clone(),
        source,
    })
}

/// The report's plots, markdown and HTML into `out_dir`; returns the report files.
fn write_reports(
    out_dir: &Path,
    report_in: &ReportInputs<'_>,
) -> Result<Vec<PathBuf>, CommissionError> {
    write_atomic(
        &out_dir.join("gamut.svg"),
        report::gamut_svg(report_in).as_bytes(),
    )?;
    write_atomic(
        &out_dir.join("usage.svg"),
        report::usage_svg(report_in).as_bytes(),
    )?;
    let md = out_dir.join("report.md");
    write_atomic(&md, report::markdown(report_in).as_bytes())?;
    let html = out_dir.join("report.html");
    write_atomic(&html, report::html(report_in).as_bytes())?;
    Ok(vec![md, html])
}

/// Readings each primary's colour stands on, for [`fuse_with_white`]: its
/// `primary_repeats` full-drive readings and the ramp samples the measurement pooled
/// into the channel's colour (at least
/// [`crate::measure::channel_colour::MIN_POOLED_INTENSITY`] of the channel's light),
/// whose chromaticity a colorimeter reads as well as the full drive's. Where it did not pool them
/// (a meter that states no noise, a colour that changes with drive) the samples lie on
/// the full-drive reading's line and their number overstates the primary's certainty:
/// the fusion then moves it a little less towards the white than it could.
fn primary_readings(m: &DisplayMeasurement, primary_repeats: f64) -> [f64; 3] {
    std::array::from_fn(|c| {
        let span = m.primaries[c].y - m.black.y;
        let bright = m.ramps[c]
            .iter()
            .filter(|(_, xyz)| span > 0.0 && (xyz.y - m.black.y) / span >= MIN_POOLED_INTENSITY)
            .count();
        primary_repeats + bright as f64
    })
}

/// Largest additivity residual (χ², 3 degrees of freedom, ≈ 5σ) that
/// [`fuse_with_white`] attributes to meter noise; above it the display is treated as
/// non-additive and left to the solve's additivity warning.
pub const MAX_FUSION_CHI2: f64 = 25.0;

/// A measurement with every reading corrected by the meter's xy offset, the primaries
/// fused with the white reading ([`fuse_with_white`]; `primary_repeats` and
/// `white_repeats` readings averaged in each), and the ramps keeping their luminance
/// with the corrected channel colour.
pub fn corrected_measurement(
    m: &DisplayMeasurement,
    offset: [f64; 2],
    primary_repeats: f64,
    white_repeats: f64,
) -> DisplayMeasurement {
    let black = correct(m.black, offset);
    let mut primaries = m.primaries.map(|p| correct(p, offset));
    let white = m.white.map(|w| correct(w, offset));
    if let Some(fused) = white.and_then(|w| {
        fuse_with_white(
            black,
            &primaries,
            w,
            primary_readings(m, primary_repeats),
            white_repeats,
            MAX_FUSION_CHI2,
        )
    }) {
        primaries = fused;
    }
    let mut ramps = m.ramps.clone();
    for (c, ramp) in ramps.iter_mut().enumerate() {
        for s in ramp.iter_mut() {
            s.1 = luminance_only(s.1, black, primaries[c]);
        }
    }
    let composites = m
        .composites
        .iter()
        .map(|r| CompositeReading {
            xyz: correct(r.xyz, offset),
            ..*r
        })
        .collect();
    DisplayMeasurement {
        black,
        primaries,
        white,
        ramps,
        composites,
        ..m.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_dark_grey_is_read_where_the_meter_states_its_noise_or_reads_a_third_of_it_reliably() {
        let levels = [GreyLevel::Share(1.0), GreyLevel::Luminance(1.0)];
        assert_eq!(usable_grey_levels(&levels, 0.0, false), levels.to_vec());
        assert_eq!(usable_grey_levels(&levels, 0.3, false), levels.to_vec());
        // a CS-100A class meter, reliable down to 1 cd/m², its noise not stated
        assert_eq!(
            usable_grey_levels(&levels, 1.0, false),
            vec![GreyLevel::Share(1.0)]
        );
        // ... and stated: its channel samples are weighted by it
        assert_eq!(usable_grey_levels(&levels, 1.0, true), levels.to_vec());
    }

    #[test]
    fn a_grey_is_split_into_its_channels_only_with_a_meter_that_states_its_noise() {
        let levels = [GreyLevel::Share(1.0), GreyLevel::Split(0.02)];
        assert_eq!(usable_grey_levels(&levels, 0.0, true), levels.to_vec());
        assert_eq!(
            usable_grey_levels(&levels, 0.0, false),
            vec![GreyLevel::Share(1.0)]
        );
    }
}
