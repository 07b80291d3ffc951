//! Nightly recalibration: re-measure what lamps change, refit, re-solve the common
//! white, and write new profiles only when something drifted.
//!
//! A commissioning leaves every display's full measurement in the profile folder
//! (`run/*.measurement.json`). A recalibration reads each display again at its spot,
//! in full on its night of the [`FullCheckRotation`]: black, the three primaries at full
//! drive (repeated as in commissioning), white and each channel at its drive in a grey
//! of half the wall white (the tone-curve check, [`curve_check_drive`]), 8 to 17
//! readings instead of the ~40 of a commissioning; on the other nights one reading of
//! full white, from which the channel factors are inferred along the lamp's ageing
//! that the full checks learned ([`channel_factors`], [`LampAgeing`]; a white that shows
//! what ageing does not do is followed by the full check at once). Each display is
//! compared with its last measurement: the primaries' luminance (%) and chromaticity
//! (Δxy), the black (cd/m²) and the curve-check intensities against the last tone curves
//! (%), and the white the display shows through its current profile, predicted from
//! the readings (ΔE2000). When no display drifted beyond the limits, nothing is written. Otherwise the
//! measurement is refitted: black, primaries and white are the new readings, and each
//! channel's tone curve keeps its shape (every ramp reading keeps its relative
//! intensity `(Y − Y_black)/(Y_full − Y_black)` and is moved onto the new black and
//! primary); a display whose curve moved is measured again in full instead. Then the
//! wall is solved again with the profiles' own settings
//! (target white chromaticity, black mode, out-of-gamut handling). Flat
//! fields are kept from the current profiles, except where the fixed camera measured
//! one again tonight ([`recalibrate_with_camera`]). The current profiles and measurements
//! are moved to `previous/` first, so [`rollback`] can restore them.
//!
//! Before the first display the station checks whether the wall is warming (lamps
//! switched on for the run; [`crate::measure::warm_up::check_warm`]) and waits for it
//! when it is: a wall read cold looks drifted and would be refitted to its cold state.
//!
//! The common white stays what it is (chromaticity and luminance) as long as every
//! display still reaches it at full drive: that is what the headroom's reserve is for
//! (each check reports the reserve left). A display that cannot reach it even at full
//! drive has *left the headroom*: the wall is solved again within the configured
//! headroom and its white is lowered (a lamp change is due; `profiles forecast`
//! predicts when).

use std::path::{Path, PathBuf};

use lumiwall_core::files::FolderLock;
use lumiwall_core::{Channel, Xyz};
use lumiwall_devices::DisplayInfo;
use lumiwall_profiles::store::LampReading;
use lumiwall_profiles::{DisplayKey, DisplayProfile, ProfileError, ProfileSet, write_atomic};

use crate::CalibError;
use crate::commission::{
    CommissionError, RUN_DIR, corrected_measurement, load_measurement, measurement_path, to_json,
};
use crate::measure::averaging::{Averaging, with_averaging};
use crate::measure::warm_up::{WarmCheck, readings_of_run, wait_or_check};
use crate::measure::{
    FullReading, MeasureError, MeasureOptions, MeasuredDisplay, Patch, Progress, Rig, Session,
    display_key, measure_black_and_primaries, measure_display, relative_intensity,
};
use crate::report;
use crate::solve::{SolveOptions, WallSolution, WhiteTarget, now_rfc3339, solve_wall_at};
use crate::spatial::{fit_white_to_flat_fields, flat_field_white_scale};

mod flat_fields;
mod lamp_ageing;

pub use flat_fields::{FlatFieldCheck, FlatFieldFinding, FlatFieldLook};
pub use lamp_ageing::{
    BRIGHTER_SIGMAS, DIRECTION_TOLERANCE_XY, LOSS_TO_USE_SIGMAS, LampAgeing, channel_factors,
};

/// Folder (inside the profile folder) that keeps the profiles and measurements a
/// recalibration replaced.
pub const PREVIOUS_DIR: &str = "previous";

/// Drift beyond which a display is recalibrated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriftLimits {
    /// Largest change of a primary's luminance, percent.
    pub luminance_pct: f64,
    /// Largest change of a primary's chromaticity, CIE 1931 xy.
    pub delta_xy: f64,
    /// Largest change of the black luminance, cd/m².
    pub black_cd_m2: f64,
    /// Largest change of a channel's relative intensity at its curve-check drive (in a
    /// grey of half the wall white, [`curve_check_drive`]) against its tone curve,
    /// percent; beyond it the display is measured again in full.
    pub curve_pct: f64,
    /// Largest ΔE2000 of the white the display shows through its current profile,
    /// predicted from the night's readings, against the common white: the changes
    /// above are each small, yet together they can move the white a viewer sees.
    pub white_de2000: f64,
}

impl Default for DriftLimits {
    /// 2 %, 0.002 and 0.05 cd/m²: below what a viewer sees across a seam (about 2 % in
    /// luminance at a tile border), above a K-10-class meter's repeatability; curves 3 %
    /// (a mid grey 3 % off is about ΔE2000 1); the white 0.25 ΔE2000 (a quarter of
    /// DisplayCAL's white limit: the commissioning's own error and the meter's share
    /// the rest; on `heyewall-48` 0.5 let the truth's white reach 1.09).
    fn default() -> Self {
        Self {
            luminance_pct: 2.0,
            delta_xy: 0.002,
            black_cd_m2: 0.05,
            curve_pct: 3.0,
            white_de2000: 0.25,
        }
    }
}

/// Options of a recalibration.
#[derive(Debug, Clone)]
pub struct RecalibrateOptions {
    /// How to read (spot, repeats, low-light policy, meter matrices). The budget sets
    /// the primaries' repeats as in commissioning and bounds each session on a
    /// display: a check reads its black, primaries, white and a mid-drive sample per
    /// channel at least once each, their repeats within the budget; a display measured
    /// again in full reads as commissioning does (a display can take a white check, a
    /// full check and a full measurement in one night).
    pub measure: MeasureOptions,
    /// When a display counts as drifted.
    pub limits: DriftLimits,
    /// The meter's xy offset the commissioning corrected (its `meter-correction.json`,
    /// `--meter-offset-correction`), applied again to the new readings; `[0, 0]` for
    /// none.
    pub meter_xy_offset: [f64; 2],
    /// The reserve to keep when the white must be lowered; `None`: the current
    /// profiles' headroom. A profile's headroom is the largest usage its solve allowed:
    /// after a recalibration that kept the white it is the usage of the kept white, so
    /// nightly runs should give the commissioning's headroom here.
    pub headroom: Option<f64>,
    /// Which displays are measured in full tonight; the others get the one-reading
    /// white check (see [`FullCheckRotation`]).
    pub rotation: FullCheckRotation,
    /// Without [`MeasureOptions::warm_up`]: check first whether the wall is warming
    /// (lamps switched on for the night's run) and wait for it when it is
    /// ([`crate::measure::warm_up::check_warm`]): a wall read cold looks drifted and
    /// would be refitted to its cold state. `None` starts at once.
    pub warm_check: Option<WarmCheck>,
}

/// Readings a night's run takes per display at most, for the warm check's
/// extrapolation: a full check with a K-10's repeats (the module docs: 8 to 17).
const NIGHT_READINGS_PER_DISPLAY: u32 = 17;

/// Which displays a recalibration measures in full (black, primaries, white, tone-curve
/// check: 14 readings on a K-10 with its repeats) and which it only checks with one
/// reading of full white.
///
/// Lamps age by losing light, little by changing colour: a three-chip projector's
/// primaries are the lamp through fixed dichroic filters, so their chromaticities
/// stay put while each channel's intensity falls by its own factor, and the black and
/// a white segment (the whole lamp through closed or clear paths) fall with the lamp's
/// mean. Each channel keeps its share of the loss, which the full checks learn; with
/// it one white reading gives the three channel factors ([`channel_factors`]: one
/// number from the luminance, the colour as the check; a meter more precise than that
/// model, such as the noiseless one, inverts the white for three free factors). What
/// it cannot see (a
/// primary changing colour, a tone curve moving) the full check finds: every display
/// gets one every `every_nights` nights, in turn, and at once when its white check sees
/// something a lamp's ageing does not do (a channel brightening, as after a lamp change;
/// a factor out of range; a white too dark to read).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FullCheckRotation {
    /// Every display is measured in full once in this many nights (1: every night).
    pub every_nights: u32,
    /// Tonight's number: any count that grows by one a night (the CLI uses days since
    /// 1970-01-01 UTC). Display `i` (wall order) is measured in full when
    /// `(night + i) % every_nights == 0`.
    pub night: u64,
}

impl FullCheckRotation {
    /// Every display in full, every night.
    pub const EVERY_NIGHT: Self = Self {
        every_nights: 1,
        night: 0,
    };

    /// Whether the display at `index` (wall order) is measured in full tonight.
    pub fn is_full(&self, index: usize) -> bool {
        let every = u64::from(self.every_nights.max(1));
        self.night.wrapping_add(index as u64).is_multiple_of(every)
    }
}

/// How a display was checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CheckKind {
    /// In full: black, primaries (repeated), white and the tone-curve check.
    Full,
    /// One reading of full white; the channel factors inferred from it along the
    /// lamp's ageing as the display's full checks learned it ([`LampAgeing`]).
    White,
    /// One reading of full white before the lamp's ageing is learned, its colour
    /// within the meter's noise of the last full reading: every channel scaled alike
    /// by its luminance. It says nothing of each channel's own decay, so the lamp-life
    /// forecast does not use it.
    WhiteLuminance,
    /// The white check saw something a lamp's ageing does not do, so the display was
    /// measured in full as well.
    Escalated,
}

/// One display's readings against its last measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct DisplayCheck {
    /// The display.
    pub key: DisplayKey,
    /// Change of each primary's luminance (black removed), percent.
    pub luminance_change_pct: [f64; 3],
    /// Change of each primary's chromaticity (black removed), xy.
    pub primary_delta_xy: [f64; 3],
    /// Change of the black luminance, cd/m².
    pub black_change_cd_m2: f64,
    /// ΔE2000 of the white the display shows through its current profile, predicted
    /// from the readings (NaN where the last primaries do not span it).
    pub white_de2000: f64,
    /// Each primary at full drive as read now, black removed (cd/m²).
    pub primaries_xyz_cd_m2: [[f64; 3]; 3],
    /// Whether any change exceeds the limits.
    pub drifted: bool,
    /// Channel usage today's common white needs with the new primaries.
    pub usage_for_current_white: [f64; 3],
    /// The display's headroom (its profile's).
    pub headroom: f64,
    /// Change of each channel's relative intensity at its drive in a grey of half the
    /// wall white ([`curve_check_drive`]) against its profile's tone curve, percent
    /// (NaN where it could not be read).
    pub curve_change_pct: [f64; 3],
    /// Whether a tone curve moved beyond the limit: the display is measured again in
    /// full (curves included) instead of refitted.
    pub curves_moved: bool,
    /// Readings taken.
    pub readings: u32,
    /// How the display was checked.
    pub kind: CheckKind,
    /// The fixed camera's look at its flat field (`None`: no camera, or not tonight).
    pub flat_field: Option<FlatFieldLook>,
}

impl DisplayCheck {
    /// Whether the display can no longer show today's common white (a channel would
    /// need more than full drive).
    pub fn cannot_reach_white(&self) -> bool {
        self.usage_for_current_white
            .iter()
            .any(|&u| exceeds(u, 1.0 + 1e-9))
    }

    /// What the check read, as the lamp-life forecast stores it (measured at `utc`);
    /// `None` where the forecast could not use it (the primaries do not span the white,
    /// see [`LampReading::is_usable`]; a luminance-only white check, which says nothing
    /// of each channel's decay). A white check along the learned ageing gives each
    /// channel its learned share of the loss (with a noiseless meter, the white's own
    /// inversion).
    pub fn lamp_reading(&self, utc: lumiwall_profiles::store::Timestamp) -> Option<LampReading> {
        if self.kind == CheckKind::WhiteLuminance {
            return None;
        }
        let r = LampReading {
            display: self.key.clone(),
            utc,
            primaries_y_cd_m2: std::array::from_fn(|c| self.primaries_xyz_cd_m2[c][1]),
            channel_usage: self.usage_for_current_white,
            headroom: self.headroom,
        };
        r.is_usable().then_some(r)
    }

    /// The reserve left for today's white: 1 minus the most used channel's usage
    /// (negative when the white is out of reach).
    pub fn reserve_left(&self) -> f64 {
        1.0 - self
            .usage_for_current_white
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max)
    }
}

/// What a recalibration concluded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Nothing drifted beyond the limits; no file was written.
    Unchanged,
    /// New profiles were written; the common white is kept (every display still
    /// reaches it, some perhaps using part of the reserve above the headroom).
    Recalibrated,
    /// A display has left the headroom: it can no longer show the common white even at
    /// full drive, so the wall was solved again within the headroom and its white
    /// lowered. New profiles were written.
    LeftHeadroom,
}

/// The result of [`recalibrate`].
#[derive(Debug, Clone)]
pub struct RecalibrationOutcome {
    /// Wall name.
    pub wall: String,
    /// Every display's check, in wall order.
    pub checks: Vec<DisplayCheck>,
    /// The verdict.
    pub verdict: Verdict,
    /// The new solve, when profiles were written.
    pub solution: Option<WallSolution>,
    /// Common white luminance before, cd/m² (the first profile's target).
    pub white_before_cd_m2: f64,
    /// Common white luminance after, cd/m² (unchanged when nothing was written).
    pub white_after_cd_m2: f64,
}

/// What [`record_in_store`] kept of a recalibration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Recorded {
    /// The new profiles, as a run (source `recalibrate`).
    Run(lumiwall_profiles::store::RunId),
    /// No profile was written: this many displays' lamp readings.
    LampReadings(usize),
}

/// Records a recalibration that measured at `utc` in `store`: the new profiles as a
/// run where it wrote some, otherwise every display's readings as lamp readings (the
/// lamp-life forecast needs every night, not only the nights that rewrote profiles).
pub fn record_in_store(
    store: &mut lumiwall_profiles::store::ProfileStore,
    outcome: &RecalibrationOutcome,
    utc: lumiwall_profiles::store::Timestamp,
) -> Result<Recorded, lumiwall_profiles::store::StoreError> {
    if let Some(solution) = &outcome.solution {
        let mut run = lumiwall_profiles::store::CommissionRun::new(outcome.wall.clone(), utc);
        run.source = "recalibrate".into();
        return store.record(&run, &solution.profiles).map(Recorded::Run);
    }
    let readings: Vec<LampReading> = outcome
        .checks
        .iter()
        .filter_map(|c| c.lamp_reading(utc))
        .collect();
    store
        .record_lamp_readings(&outcome.wall, "recalibrate", &readings)
        .map(Recorded::LampReadings)
}

/// Why a recalibration stopped.
#[derive(Debug, thiserror::Error)]
pub enum RecalibrateError {
    /// The folder was not commissioned (or its measurements are missing).
    #[error(
        "{} has no measurement of {display} ({}); recalibrate needs a profile folder \
         written by `lumiwall commission` (with its run/ folder)",
        dir.display(), path.display()
    )]
    NotCommissioned {
        /// Profile folder.
        dir: PathBuf,
        /// The display without a measurement.
        display: String,
        /// Where its measurement should be.
        path: PathBuf,
    },
    /// The profile folder belongs to another wall or display layout.
    #[error("{} holds {found}, the wall file describes {expected}", dir.display())]
    WallMismatch {
        /// Profile folder.
        dir: PathBuf,
        /// What the folder holds.
        found: String,
        /// What the wall file says.
        expected: String,
    },
    /// No rollback is possible.
    #[error(
        "{} has no previous profiles to roll back to (a recalibration that wrote profiles \
         keeps them in {PREVIOUS_DIR}/)",
        dir.display()
    )]
    NothingToRollBack {
        /// Profile folder.
        dir: PathBuf,
    },
    /// A display could not be measured (meter, pattern output, aiming).
    #[error("{0}")]
    Measure(Box<MeasureError>),
    /// A measurement file could not be read.
    #[error(transparent)]
    Commission(Box<CommissionError>),
    /// The solve failed.
    #[error("solving the wall again failed: {0}")]
    Solve(#[from] CalibError),
    /// Profiles could not be read or written.
    #[error(transparent)]
    Profile(#[from] ProfileError),
    /// The camera's check of the flat fields failed.
    #[error("camera: {message}")]
    Camera {
        /// What failed.
        message: String,
        /// Whether the camera or pattern output stopped answering (as opposed to a
        /// fit).
        device: bool,
    },
    /// Another process writes into the folder.
    #[error(transparent)]
    Locked(#[from] lumiwall_core::files::LockError),
    /// File system error.
    #[error("cannot access {}: {source}", path.display())]
    Io {
        /// Path concerned.
        path: PathBuf,
        /// Underlying error.
        #[source]
        source: std::io::Error,
    },
}

impl From<MeasureError> for RecalibrateError {
    fn from(e: MeasureError) -> Self {
        Self::Measure(Box::new(e))
    }
}

impl From<CommissionError> for RecalibrateError {
    fn from(e: CommissionError) -> Self {
        Self::Commission(Box::new(e))
    }
}

impl RecalibrateError {
    /// Whether a device (meter, pattern output, positioner) failed, as opposed to the
    /// files or the solve.
    pub fn is_device_failure(&self) -> bool {
        matches!(self, Self::Measure(_) | Self::Camera { device: true, .. })
            && !self.is_stopped()
            && !self.is_wall_not_ready()
    }

    /// Whether the wall was not ready to be measured: while waiting for it to warm up, a
    /// display's white kept drifting ([`MeasureError::NotWarm`]: a lamp in an eco or
    /// dynamic mode, or failing) or showed no light ([`MeasureError::DarkWhileWarming`]:
    /// a projector off or its shutter closed). The meter worked; the wall needs a look.
    pub fn is_wall_not_ready(&self) -> bool {
        matches!(
            self,
            Self::Measure(m) if matches!(
                **m,
                MeasureError::NotWarm { .. } | MeasureError::DarkWhileWarming { .. }
            )
        )
    }

    /// Whether the technician stopped the run (nothing was written).
    pub fn is_stopped(&self) -> bool {
        matches!(self, Self::Measure(m) if m.is_stopped())
    }
}

/// Recalibrates the wall whose profiles are in `dir` (see the module documentation).
pub fn recalibrate(
    wall: &str,
    displays: &[DisplayInfo],
    rig: &mut Rig<'_>,
    dir: &Path,
    opts: &RecalibrateOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<RecalibrationOutcome, RecalibrateError> {
    recalibrate_with_camera(wall, displays, rig, None, dir, opts, progress)
}

/// [`recalibrate`], and with `camera` a look at the flat fields of the displays
/// measured in full tonight: where one changed, the camera measures it again and the
/// new profiles carry it (see [`FlatFieldCheck`]).
pub fn recalibrate_with_camera(
    wall: &str,
    displays: &[DisplayInfo],
    rig: &mut Rig<'_>,
    camera: Option<&mut dyn FlatFieldCheck>,
    dir: &Path,
    opts: &RecalibrateOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<RecalibrationOutcome, RecalibrateError> {
    let _lock = FolderLock::acquire(dir, &format!("recalibration of wall {wall}"))?;
    let (profiles, last) = load_commissioned(wall, displays, dir)?;
    if let Some(first) = displays.first() {
        let run_readings = readings_of_run(NIGHT_READINGS_PER_DISPLAY, displays.len());
        let check = opts.warm_check.as_ref();
        // a technician who skips the first display skips the check with it; the
        // display itself then fails as a skipped one does
        wait_or_check(
            rig,
            wall,
            first,
            &opts.measure,
            check,
            run_readings,
            progress,
        )
        .map_err(|e| RecalibrateError::Measure(Box::new(e)))?;
    }
    let mut checks = Vec::with_capacity(displays.len());
    let mut refitted = Vec::with_capacity(displays.len());
    let n = night_averaging(opts.measure.averaging, &last);
    with_averaging(rig, n, |rig| {
        for (i, ((info, old), profile)) in displays.iter().zip(&last).zip(&profiles).enumerate() {
            let key = display_key(wall, info);
            let full = opts.rotation.is_full(i);
            let (c, mut m) = check_display(rig, info, &key, old, profile, full, opts, progress)?;
            m.log.readings_averaged = n;
            checks.push(c);
            refitted.push(m);
        }
        Ok::<_, RecalibrateError>(())
    })?;
    let mut current = profiles.clone();
    if let Some(camera) = camera {
        let tonight: Vec<usize> = checks
            .iter()
            .enumerate()
            .filter(|(_, c)| matches!(c.kind, CheckKind::Full | CheckKind::Escalated))
            .map(|(i, _)| i)
            .collect();
        let findings = camera.check(rig.pattern, &tonight, displays, &profiles)?;
        flat_fields::take_findings(findings, &mut checks, &mut current);
    }
    let white_before_cd_m2 = profiles[0].target_white_xyz_cd_m2[1];
    let mut outcome = RecalibrationOutcome {
        wall: wall.to_string(),
        verdict: Verdict::Unchanged,
        solution: None,
        white_before_cd_m2,
        white_after_cd_m2: white_before_cd_m2,
        checks,
    };
    if !outcome.checks.iter().any(|c| c.drifted) {
        return Ok(outcome);
    }
    let (solution, kept) = solve_again(&refitted, &current, opts)?;
    keep_previous(dir, &profiles, &last)?;
    write_new(dir, wall, &refitted, &solution)?;
    outcome.white_after_cd_m2 = solution.profiles[0].target_white_xyz_cd_m2[1];
    outcome.verdict = if kept {
        Verdict::Recalibrated
    } else {
        Verdict::LeftHeadroom
    };
    write_report(dir, &outcome, &refitted, &solution)?;
    outcome.solution = Some(solution);
    Ok(outcome)
}

/// Meter readings each reading of the night averages: a fixed count as given; under
/// [`crate::measure::averaging::Averaging::Auto`] as the last measurements did (the
/// commissioning's choice for a dim wall, `MeasureLog::readings_averaged`), so that the
/// night compares like with like and a full check or a measurement again keeps the
/// commissioning's noise.
fn night_averaging(averaging: Averaging, last: &[MeasuredDisplay]) -> u32 {
    match averaging {
        Averaging::Auto => crate::measure::averaging::of_saved(last),
        fixed => fixed.count_or_one(),
    }
}

/// One display's check (full, or the white check escalated to a full one where it saw
/// something ageing does not do) and its refitted measurement.
#[allow(
    clippy::too_many_arguments,
    reason = "the recalibration's state, passed through"
)]
fn check_display(
    rig: &mut Rig<'_>,
    info: &DisplayInfo,
    key: &DisplayKey,
    old: &MeasuredDisplay,
    profile: &DisplayProfile,
    full: bool,
    opts: &RecalibrateOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<(DisplayCheck, MeasuredDisplay), RecalibrateError> {
    let mut spent = 0;
    let noise = rig.meter.info().noise;
    if !full {
        let (white, readings) = read_white(rig, info, key, &opts.measure, progress)?;
        spent = readings;
        let anchor = old.last_full_reading();
        let inferred = white.and_then(|w| {
            let ageing = old.ageing.as_ref();
            readings_from_white(&anchor, w, noise.as_ref(), ageing, &opts.limits)
        });
        if let Some((new, kind)) = inferred {
            let c = check(key, &old.measurement, &new, profile, readings, &opts.limits);
            let c = DisplayCheck { kind, ..c };
            let mut m = refit(old, new, readings);
            m.anchor = Some(anchor);
            return Ok((c, m));
        }
    }
    let (new, readings) = read_display(rig, info, key, profile, &opts.measure, progress)?;
    // the black first: a primary keeping its colour is rebuilt on tonight's black
    let new = steady_black(&old.measurement, new, noise);
    let new = steady_chromaticities(&old.measurement, new, opts.limits.delta_xy);
    let new = steady_white(&old.measurement, new, noise);
    let before = old.last_full_reading();
    let ageing = LampAgeing::learn(old.ageing, &before, &new.full_reading(), noise.as_ref());
    let mut c = check(key, &old.measurement, &new, profile, readings, &opts.limits);
    c.readings += spent;
    if !full {
        c.kind = CheckKind::Escalated;
    }
    if c.curves_moved {
        let mut m = measure_display(rig, info, key, &opts.measure, progress)?;
        c.readings += m.measurement.readings;
        m.ageing = ageing;
        return Ok((c, m));
    }
    let mut m = refit(old, new, readings);
    m.ageing = ageing;
    Ok((c, m))
}

/// Tonight's primaries with the last measurement's chromaticities where they moved by
/// no more than `delta_xy` (the drift limit, above the meter's repeatability), at
/// tonight's luminance: a deadband, so that the meter's colour noise on a dim primary
/// (the blue of a UHP projector reads a few cd/m², where a colorimeter's xy noise grows)
/// is not written into the profiles night after night. A change beyond it is taken
/// whole.
fn steady_chromaticities(
    old: &crate::solve::DisplayMeasurement,
    mut new: Readings,
    delta_xy: f64,
) -> Readings {
    for c in 0..3 {
        let (o, n) = (old.primaries[c] - old.black, new.primaries[c] - new.black);
        let Some(moved) = xy_distance(o, n) else {
            continue;
        };
        if moved <= delta_xy && o.y > 0.0 {
            new.primaries[c] = new.black + o * (n.y / o.y);
        }
    }
    new
}

/// Tonight's black, or the last measurement's black dimmed with the lamp (the mean of
/// the primaries' luminance factors) where tonight's differs from that in no
/// tristimulus value by more than the meter's noise explains (3σ of the difference of
/// two single readings, from its stated zero-light and relative noise): a
/// commissioning reads the black as often as the darkest grey needs, a night reads it
/// once, and a single reading's noise written into the profile moved the dark
/// patches of a display that had not drifted from 1.0 to 2.0 ΔE2000 (heyewall-48,
/// `bench season --noise realistic`: 0.011 cd/m² in X). Tonight's as read for a meter
/// that states no noise.
fn steady_black(
    old: &crate::solve::DisplayMeasurement,
    mut new: Readings,
    noise: Option<lumiwall_devices::ReadingNoise>,
) -> Readings {
    let Some(noise) = noise else {
        return new;
    };
    let lamp = (0..3)
        .map(|c| (new.primaries[c] - new.black).y / (old.primaries[c] - old.black).y)
        .sum::<f64>()
        / 3.0;
    if !lamp.is_finite() {
        return new;
    }
    let expected = old.black * lamp;
    let (e, n) = (expected.to_array(), new.black.to_array());
    let within = (0..3).all(|i| {
        let sigma = noise.dark_xyz_cd_m2[i] + noise.luminance_rel * e[i].abs();
        (n[i] - e[i]).abs() <= lamp_ageing::two_reading_limit(sigma)
    });
    if within {
        new.black = expected;
    }
    new
}

/// Tonight's white, or at its luminance the chromaticity tonight's black and primaries
/// predict from the last measurement (what its white had beyond them, a single-chip
/// DLP's white segment or the display's non-additivity, dimmed with the lamp) where the
/// reading's is within the meter's noise of it (3σ of the difference of two readings):
/// the white is read once a night, and on a DLP its noise goes whole into the white
/// segment (dlp-infitec-cold-8bit-2x2, `bench season --noise realistic`: a display's
/// white from 0.7 to 1.4 ΔE2000 after its full check). Tonight's as read for a meter
/// that states no noise, or where the last measurement has no white.
fn steady_white(
    old: &crate::solve::DisplayMeasurement,
    mut new: Readings,
    noise: Option<lumiwall_devices::ReadingNoise>,
) -> Readings {
    let (Some(noise), Some(read), Some(was)) = (noise, new.white, old.white) else {
        return new;
    };
    let channels =
        |black: Xyz, p: &[Xyz; 3]| (0..3).fold(Xyz::default(), |acc, c| acc + (p[c] - black));
    let old_sum = channels(old.black, &old.primaries);
    let new_sum = channels(new.black, &new.primaries);
    if old_sum.y <= 0.0 {
        return new;
    }
    let lamp = new_sum.y / old_sum.y;
    let predicted = new_sum + (was - old_sum) * lamp;
    let within =
        xy_distance(read, predicted).is_some_and(|d| d <= lamp_ageing::two_reading_limit(noise.xy));
    if let (true, Some(xy)) = (within, predicted.chromaticity()) {
        new.white = Some(Xyz::from_xy_luminance(xy.x, xy.y, read.y));
    }
    new
}

/// One reading of full white (`None`: too dark to read).
fn read_white(
    rig: &mut Rig<'_>,
    info: &DisplayInfo,
    key: &DisplayKey,
    opts: &MeasureOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<(Option<Xyz>, u32), RecalibrateError> {
    let mut s = Session::start(rig, key, info.id, opts.spot_uv, opts)?;
    let white = s.essential_sample(Patch::White, progress)?;
    let readings = s.log.readings;
    progress(Progress::DisplayDone {
        display: info.id,
        readings,
    });
    Ok((white, readings))
}

/// Tonight's black, primaries and white inferred from one white reading and the
/// display's last full reading (see [`FullCheckRotation`]); `None` where the white shows something
/// a lamp's ageing does not do: a channel brighter by more than the luminance limit, a
/// factor not positive, or primaries that do not span the white.
fn readings_from_white(
    old: &FullReading,
    white: Xyz,
    noise: Option<&lumiwall_devices::ReadingNoise>,
    ageing: Option<&LampAgeing>,
    limits: &DriftLimits,
) -> Option<(Readings, CheckKind)> {
    let s = channel_factors(old, white, noise, ageing)?;
    let brightest = 1.0 + limits.luminance_pct / 100.0;
    if s.iter().any(|&k| !(k > 0.0 && k <= brightest)) {
        return None;
    }
    let lamp = (s[0] + s[1] + s[2]) / 3.0;
    let black = old.black * lamp;
    let kind = if s[0] == s[1] && s[1] == s[2] {
        CheckKind::WhiteLuminance
    } else {
        CheckKind::White
    };
    // the white the factors model, not the reading: the reading's colour noise, which
    // the factors were checked to explain, would otherwise enter the refitted white
    // and, on a single-chip DLP, its white segment (white less the primaries)
    let modelled = old
        .white
        .map_or(white, |_| lamp_ageing::modelled_white(old, s));
    let readings = Readings {
        black,
        primaries: std::array::from_fn(|c| black + (old.primaries[c] - old.black) * s[c]),
        white: Some(modelled),
        mid: [None; 3],
    };
    Some((readings, kind))
}

/// The folder's profiles (wall order) and last measurements, checked against the wall.
fn load_commissioned(
    wall: &str,
    displays: &[DisplayInfo],
    dir: &Path,
) -> Result<(Vec<DisplayProfile>, Vec<MeasuredDisplay>), RecalibrateError> {
    let (set_wall, mut profiles) = ProfileSet::load_dir(dir)?;
    profiles.sort_by(|a, b| a.display.cmp(&b.display));
    let keys: Vec<DisplayKey> = displays.iter().map(|d| display_key(wall, d)).collect();
    let found: Vec<&DisplayKey> = profiles.iter().map(|p| &p.display).collect();
    if set_wall != wall || found != keys.iter().collect::<Vec<_>>() {
        return Err(RecalibrateError::WallMismatch {
            dir: dir.to_path_buf(),
            found: format!("{} profiles of wall {set_wall}", profiles.len()),
            expected: format!("{} displays of wall {wall}", keys.len()),
        });
    }
    let run_dir = dir.join(RUN_DIR);
    let last = keys
        .iter()
        .map(|key| {
            let path = measurement_path(&run_dir, key);
            match load_measurement(&path)? {
                Some(m) if m.measurement.key == *key => Ok(m),
                _ => Err(RecalibrateError::NotCommissioned {
                    dir: dir.to_path_buf(),
                    display: key.to_string(),
                    path,
                }),
            }
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok((profiles, last))
}

/// Black, primaries (repeated as commissioning does) and white of one display.
fn read_display(
    rig: &mut Rig<'_>,
    info: &DisplayInfo,
    key: &DisplayKey,
    profile: &DisplayProfile,
    opts: &MeasureOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<(Readings, u32), RecalibrateError> {
    let mut s = Session::start(rig, key, info.id, opts.spot_uv, opts)?;
    let (black, primaries) = measure_black_and_primaries(&mut s, key, opts, progress)?;
    // Every sample of the check is compared: none is left out for the budget.
    let white = s.essential_sample(Patch::White, progress)?;
    let mut mid = [None; 3];
    for c in Channel::ALL {
        let drive = curve_check_drive(profile, c, info.bit_depth);
        let patch = Patch::Ramp(c, drive);
        mid[c.index()] = s.essential_sample(patch, progress)?.map(|xyz| (drive, xyz));
    }
    let readings = s.log.readings;
    progress(Progress::DisplayDone {
        display: info.id,
        readings,
    });
    Ok((
        Readings {
            black,
            primaries,
            white,
            mid,
        },
        readings,
    ))
}

/// What a recalibration reads of one display.
struct Readings {
    black: Xyz,
    primaries: [Xyz; 3],
    white: Option<Xyz>,
    /// Each channel alone at the curve-check drive, with that drive (`None`: too dark
    /// to read).
    mid: [Option<(f64, Xyz)>; 3],
}

impl Readings {
    /// Black, primaries and white as a full reading.
    fn full_reading(&self) -> FullReading {
        FullReading {
            black: self.black,
            primaries: self.primaries,
            white: self.white,
        }
    }
}

/// Drive of channel `c`'s tone-curve check: one reading where the wall uses the channel
/// and its curve is pinned by the commissioning's samples, the channel's drive in a grey
/// of half the wall white ([`CURVE_CHECK_GREY`] of its usage in the white, on the
/// profile's curve), on a code the display's input shows exactly (a drive between
/// codes is shown as the nearest: on 8 bits 0.5 is 128/255, alone 0.9 % more light on
/// a gamma-2.2 channel). Mid drive where the profile states no usage.
///
/// Why not mid drive for every display: where a dimmer display sets the wall white,
/// the others use a third of their drive range, their ramps are read there, and their
/// fitted curves at mid drive come from the segment up to full drive. On
/// `weak-channel-3x1` the check at mid drive found every display's curves 2–5 % off
/// with the exact meter (4–8 % with the realistic one) on the night after
/// commissioning, so every night measured every display again in full.
pub fn curve_check_drive(profile: &DisplayProfile, c: Channel, bit_depth: u32) -> f64 {
    let top = f64::from((1u32 << bit_depth.clamp(1, 16)) - 1);
    let usage = profile.channel_usage[c.index()];
    let drive = if usage.is_finite() && usage > 0.0 {
        let share = (CURVE_CHECK_GREY * usage.min(1.0)) as f32;
        f64::from(profile.curves[c.index()].drive_for(share))
    } else {
        0.5
    };
    ((drive.clamp(0.0, 1.0) * top).round() / top).max(1.0 / top)
}

/// The grey of the tone-curve check as a share of the wall white
/// ([`curve_check_drive`]).
pub const CURVE_CHECK_GREY: f64 = 0.5;

/// A channel's relative intensity `(Y − Y_black)/(Y_full − Y_black)` at `drive` on the
/// profile's fitted tone curve: the intensity whose drive (the curve's inverse LUT) is
/// `drive`, by bisection (the curve is monotone).
fn curve_at(profile: &DisplayProfile, c: usize, drive: f64) -> f64 {
    let curve = &profile.curves[c];
    let (mut lo, mut hi) = (0.0f32, 1.0f32);
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if f64::from(curve.drive_for(mid)) < drive {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    f64::from(0.5 * (lo + hi))
}

/// The display's drift against its last measurement, and the usage today's white needs.
fn check(
    key: &DisplayKey,
    old: &crate::solve::DisplayMeasurement,
    new: &Readings,
    profile: &DisplayProfile,
    readings: u32,
    limits: &DriftLimits,
) -> DisplayCheck {
    let channel = |m: &[Xyz; 3], b: Xyz, c: usize| m[c] - b;
    let mut luminance_change_pct = [0.0; 3];
    let mut primary_delta_xy = [0.0; 3];
    for c in 0..3 {
        let (o, n) = (
            channel(&old.primaries, old.black, c),
            channel(&new.primaries, new.black, c),
        );
        luminance_change_pct[c] = 100.0 * (n.y / o.y - 1.0);
        primary_delta_xy[c] = xy_distance(o, n).unwrap_or(f64::INFINITY);
    }
    let black_change_cd_m2 = new.black.y - old.black.y;
    let curve_change_pct: [f64; 3] = std::array::from_fn(|c| match new.mid[c] {
        Some((drive, xyz)) => {
            // luminance only: a dark blue's X and Z carry the meter's xy noise amplified
            // by 1/y (a few percent per reading at 1 cd/m² on a K-10)
            let seen = (xyz.y - new.black.y) / (new.primaries[c].y - new.black.y);
            let expected = curve_at(profile, c, drive);
            if expected > 0.0 {
                100.0 * (seen / expected - 1.0)
            } else {
                f64::NAN
            }
        }
        None => f64::NAN,
    });
    let curves_moved = curve_change_pct.iter().any(|d| d.abs() > limits.curve_pct);
    let usage_for_current_white = usage_for(new, profile);
    let white_de2000 = white_shown_de2000(old, new, profile);
    let out_of_reach = usage_for_current_white
        .iter()
        .any(|&u| exceeds(u, 1.0 + 1e-9));
    let drifted = curves_moved
        || out_of_reach
        || luminance_change_pct
            .iter()
            .any(|d| exceeds(d.abs(), limits.luminance_pct))
        || primary_delta_xy
            .iter()
            .any(|d| exceeds(*d, limits.delta_xy))
        || exceeds(black_change_cd_m2.abs(), limits.black_cd_m2)
        || exceeds(white_de2000, limits.white_de2000);
    DisplayCheck {
        key: key.clone(),
        luminance_change_pct,
        primary_delta_xy,
        black_change_cd_m2,
        white_de2000,
        primaries_xyz_cd_m2: std::array::from_fn(|c| {
            channel(&new.primaries, new.black, c).to_array()
        }),
        drifted,
        usage_for_current_white,
        headroom: profile.headroom,
        curve_change_pct,
        curves_moved,
        readings,
        kind: CheckKind::Full,
        flat_field: None,
    }
}

/// ΔE2000 between the white the display shows now through its current profile and
/// the white it should show: the mix of the last primaries that made the white
/// (profile's target plus the black it shows), shown with tonight's primaries and
/// black (additivity). NaN where the last primaries do not span the white.
fn white_shown_de2000(
    old: &crate::solve::DisplayMeasurement,
    new: &Readings,
    profile: &DisplayProfile,
) -> f64 {
    let target = Xyz::from_array(profile.target_white_xyz_cd_m2)
        + Xyz::from_array(profile.shown_black_xyz_cd_m2);
    let cols: [[f64; 3]; 3] = std::array::from_fn(|c| (old.primaries[c] - old.black).to_array());
    let Some(inv) = lumiwall_core::mat3::inverse(&lumiwall_core::mat3::from_columns(&cols)) else {
        return f64::NAN;
    };
    let mix = lumiwall_core::mat3::mul_vec(&inv, &(target - old.black).to_array());
    let shown = (0..3).fold(new.black, |acc, c| {
        acc + (new.primaries[c] - new.black) * mix[c]
    });
    lumiwall_core::lab::delta_e2000_xyz(target, shown, target)
}

/// CIE 1931 xy distance between two colours (`None` where either has no chromaticity).
fn xy_distance(a: Xyz, b: Xyz) -> Option<f64> {
    Some(a.chromaticity()?.distance(b.chromaticity()?))
}

/// `v` above `limit`, or not a number (an unreadable change counts as a change).
fn exceeds(v: f64, limit: f64) -> bool {
    v.is_nan() || v > limit
}

/// Linear channel intensities with which the display, as read now, shows what the wall
/// shows for white: the target white plus the black the profile shows (own or common,
/// by black mode), less the display's own black now; through the profile's display
/// model (a white segment takes part of the load). Infinite where the primaries do not
/// span it.
fn usage_for(new: &Readings, profile: &DisplayProfile) -> [f64; 3] {
    usage_for_white(new.black, new.primaries, profile)
}

/// Linear channel intensities with which a display whose black and primaries at full
/// drive (black included) read `black` and `primaries` shows the white of `profile`
/// (see the recalibration's checks); infinite where the primaries do not span it.
pub fn usage_for_white(black: Xyz, primaries: [Xyz; 3], profile: &DisplayProfile) -> [f64; 3] {
    let cols: [[f64; 3]; 3] = std::array::from_fn(|c| (primaries[c] - black).to_array());
    let p = lumiwall_core::mat3::from_columns(&cols);
    let shown = Xyz::from_array(profile.target_white_xyz_cd_m2)
        + Xyz::from_array(profile.shown_black_xyz_cd_m2)
        - black;
    lumiwall_core::mat3::inverse(&p).map_or([f64::INFINITY; 3], |inv| {
        let m = lumiwall_core::mat3::mul_vec(&inv, &shown.to_array());
        profile.display_model.channels_for(&profile.xyz_to_drive, m)
    })
}

/// The last measurement moved onto the new readings: new black, primaries and white;
/// every ramp reading keeps its relative intensity on the new black and primary, and
/// every grey read whole at commissioning ([`moved_composites`]) its mix of them.
fn refit(old: &MeasuredDisplay, new: Readings, readings: u32) -> MeasuredDisplay {
    let o = &old.measurement;
    let mut m = o.clone();
    for c in Channel::ALL {
        let i = c.index();
        for sample in &mut m.ramps[i] {
            let t = relative_intensity(sample.1, o.black, o.primaries[i]);
            sample.1 = new.black + (new.primaries[i] - new.black) * t;
        }
    }
    m.black = new.black;
    m.primaries = new.primaries;
    m.white = new.white;
    m.readings = readings;
    m.composites = moved_composites(o, &new);
    MeasuredDisplay {
        measurement: m,
        log: old.log.clone(),
        anchor: None,
        ageing: old.ageing,
    }
}

/// The greys the last measurement read whole, moved onto the new black and primaries:
/// each keeps the mix of the old primaries (less black) that shows it, `W' = K' +
/// P'·P⁻¹·(W − K)`, so that their gains against the primaries (the solve's
/// `composite_gains`: what the display shows beyond the sum of its channels, and what
/// the primaries' own readings missed) stay what the commissioning measured instead of
/// being dropped. None where the old primaries do not span the colour space, and none
/// on a display whose white holds a white segment
/// ([`crate::solve::MIN_WHITE_SEGMENT_SHARE`] of it beyond the primaries): its share of
/// a grey follows the lamp's mean and the grey's smallest channel, which the mix of the
/// primaries does not carry.
fn moved_composites(
    old: &crate::solve::DisplayMeasurement,
    new: &Readings,
) -> Vec<crate::solve::CompositeReading> {
    let columns = |black: Xyz, p: &[Xyz; 3]| {
        let cols: [[f64; 3]; 3] = std::array::from_fn(|c| (p[c] - black).to_array());
        lumiwall_core::mat3::from_columns(&cols)
    };
    let Some(inv) = lumiwall_core::mat3::inverse(&columns(old.black, &old.primaries)) else {
        return Vec::new();
    };
    let beyond_primaries = old.white.map_or(0.0, |w| {
        let sum = (0..3).fold(w, |acc, c| acc - (old.primaries[c] - old.black));
        (sum - old.black).y / w.y
    });
    if beyond_primaries.abs() >= crate::solve::MIN_WHITE_SEGMENT_SHARE {
        return Vec::new();
    }
    let map = lumiwall_core::mat3::mul(&columns(new.black, &new.primaries), &inv);
    old.composites
        .iter()
        .map(|r| {
            let rest = lumiwall_core::mat3::mul_vec(&map, &(r.xyz - old.black).to_array());
            crate::solve::CompositeReading {
                xyz: new.black + Xyz::from_array(rest),
                ..*r
            }
        })
        .collect()
}

/// The wall solved again with the current profiles' settings (white chromaticity,
/// black mode, out-of-gamut handling) and flat fields, keeping today's white
/// luminance when every display still reaches it at full drive at every texel, else
/// the brightest white within the configured headroom that every texel reaches within
/// it. Returns the solve and whether the white was kept.
fn solve_again(
    refitted: &[MeasuredDisplay],
    profiles: &[DisplayProfile],
    opts: &RecalibrateOptions,
) -> Result<(WallSolution, bool), RecalibrateError> {
    let first = &profiles[0];
    let configured = opts.headroom.unwrap_or(first.headroom);
    let inputs: Vec<_> = refitted
        .iter()
        .map(|m| {
            corrected_measurement(
                &m.measurement,
                opts.meter_xy_offset,
                f64::from(opts.measure.primary_repeats()),
                // a night reads the white once, a display measured again as the
                // commissioning does
                crate::commission::white_readings(m, 1),
            )
        })
        .collect();
    let created = now_rfc3339();
    let solve = |headroom: f64| solve_wall_at(&inputs, &options_of(first, headroom), &created);
    let y_today = first.target_white_xyz_cd_m2[1];
    let y_full = solve(1.0)?.white_xyz_cd_m2.y;
    let (mut solution, mut kept) = if y_full >= y_today {
        // the white's luminance is affine in the headroom (a black offset shifts it):
        // a proportional first guess, then the secant through it and full drive
        let h1 = (y_today / y_full).min(1.0);
        let y1 = solve(h1)?.white_xyz_cd_m2.y;
        let h = if (y_full - y1).abs() > 1e-12 && h1 < 1.0 {
            h1 + (y_today - y1) * (1.0 - h1) / (y_full - y1)
        } else {
            h1
        };
        (solve(h.clamp(f64::MIN_POSITIVE, 1.0))?, true)
    } else {
        (solve(configured)?, false)
    };
    let with_flats = |mut solution: WallSolution| {
        for (new, old) in solution.profiles.iter_mut().zip(profiles) {
            new.flat_field.clone_from(&old.flat_field);
        }
        solution
    };
    solution = with_flats(solution);
    // Every texel must reach the kept white at full drive (a flat field measured again
    // tonight may be darker somewhere); where one cannot, the white is lowered as at
    // the commissioning: solved within the headroom, then down to the darkest texel.
    if kept && flat_field_white_scale(&solution.profiles, |_| 1.0) < 1.0 {
        (solution, kept) = (with_flats(solve(configured)?), false);
    }
    if !kept {
        fit_white_to_flat_fields(&mut solution.profiles);
    }
    Ok((solution, kept))
}

/// Moves the current profiles, manifest and measurements to `previous/` (replacing an
/// older one) by writing a fresh copy next to it and renaming it into place.
fn keep_previous(
    dir: &Path,
    profiles: &[DisplayProfile],
    last: &[MeasuredDisplay],
) -> Result<(), RecalibrateError> {
    let staging = dir.join(format!("{PREVIOUS_DIR}.new"));
    let target = dir.join(PREVIOUS_DIR);
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| RecalibrateError::Io { path, source }
    };
    remove_dir_if_present(&staging)?;
    std::fs::create_dir_all(staging.join(RUN_DIR)).map_err(io(&staging))?;
    let wall = &profiles[0].display.wall;
    ProfileSet::save_dir(&staging, wall, profiles)?;
    for m in last {
        let path = measurement_path(&staging.join(RUN_DIR), &m.measurement.key);
        write_atomic(&path, &to_json(m))?;
    }
    remove_dir_if_present(&target)?;
    std::fs::rename(&staging, &target).map_err(io(&target))
}

fn remove_dir_if_present(path: &Path) -> Result<(), RecalibrateError> {
    remove_dir_all_if_present(path).map_err(|source| RecalibrateError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Removes `path` and everything in it; a folder that is not there is no error.
pub(crate) fn remove_dir_all_if_present(path: &Path) -> std::io::Result<()> {
    match std::fs::remove_dir_all(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        other => other,
    }
}

/// The new profiles, then the refitted measurements (so the next recalibration
/// compares with them). In this order a run stopped halfway leaves new profiles with
/// (some) old measurements: the next run sees the drift again and solves again,
/// instead of old profiles with new measurements, which would hide the drift.
fn write_new(
    dir: &Path,
    wall: &str,
    refitted: &[MeasuredDisplay],
    solution: &WallSolution,
) -> Result<(), RecalibrateError> {
    ProfileSet::save_dir(dir, wall, &solution.profiles)?;
    for m in refitted {
        let path = measurement_path(&dir.join(RUN_DIR), &m.measurement.key);
        write_atomic(&path, &to_json(m))?;
    }
    Ok(())
}

/// The commissioning report of the new solve (gamut, usage, tables) with the
/// recalibration's section (first in `report.md`, last in `report.html`): verdict,
/// white before and after, and every display's drift, curve check and reserve.
fn write_report(
    dir: &Path,
    outcome: &RecalibrationOutcome,
    refitted: &[MeasuredDisplay],
    solution: &WallSolution,
) -> Result<(), RecalibrateError> {
    let first = &solution.profiles[0];
    let solve = options_of(first, first.headroom);
    let inputs = report::ReportInputs {
        wall: &outcome.wall,
        measured: refitted,
        solution,
        solve: &solve,
        meter_correction: None,
        drift: None,
    };
    let section = recalibration_markdown(outcome);
    write_atomic(
        &dir.join("gamut.svg"),
        report::gamut_svg(&inputs).as_bytes(),
    )?;
    write_atomic(
        &dir.join("usage.svg"),
        report::usage_svg(&inputs).as_bytes(),
    )?;
    let md = format!("{section}\n{}", report::markdown(&inputs));
    write_atomic(&dir.join("report.md"), md.as_bytes())?;
    let html = report::html_with_section(&report::html(&inputs), &section, &[]);
    write_atomic(&dir.join("report.html"), html.as_bytes())?;
    Ok(())
}

/// The solve options a profile was made with (its white chromaticity, black mode and
/// out-of-gamut handling), at `headroom`.
fn options_of(p: &DisplayProfile, headroom: f64) -> SolveOptions {
    SolveOptions {
        white: WhiteTarget::Xy(
            Xyz::from_array(p.target_white_xyz_cd_m2)
                .xy()
                .unwrap_or([0.3127, 0.3290]),
        ),
        headroom,
        black_mode: p.black_mode,
        out_of_gamut: p.out_of_gamut,
        ..SolveOptions::default()
    }
}

/// The recalibration's section of the report (markdown).
pub fn recalibration_markdown(o: &RecalibrationOutcome) -> String {
    let mut s = format!(
        "## Recalibration of {} ({})\n\n{:?}: common white {:.2} → {:.2} cd/m², {} readings.\n\n\
         | display | ΔY R/G/B % | Δxy primaries (max) | black Δ cd/m² | curve in the half grey R/G/B % | white shown ΔE2000 | reserve left | checked | status |\n\
         |---|---|---|---|---|---|---|---|---|\n",
        o.wall,
        now_rfc3339(),
        o.verdict,
        o.white_before_cd_m2,
        o.white_after_cd_m2,
        o.checks.iter().map(|c| c.readings).sum::<u32>()
    );
    for c in &o.checks {
        let three = |v: [f64; 3]| format!("{:+.2} / {:+.2} / {:+.2}", v[0], v[1], v[2]);
        let status = if c.cannot_reach_white() {
            "white out of reach"
        } else if c.curves_moved {
            "curve moved: measured in full"
        } else if c.flat_field.is_some_and(|f| f.refit) {
            "flat field changed: measured again with the camera"
        } else if c.drifted {
            "drifted: refitted"
        } else {
            "ok"
        };
        let camera = c.flat_field.map_or(String::new(), |f| {
            format!(
                "; camera: flat field residual {:.2} %",
                100.0 * f.residual_rms
            )
        });
        s += &format!(
            "| {} | {} | {:.4} | {:+.3} | {} | {:.2} | {:.3} | {}{camera} | {status} |\n",
            c.key,
            three(c.luminance_change_pct),
            c.primary_delta_xy.iter().copied().fold(0.0, f64::max),
            c.black_change_cd_m2,
            three(c.curve_change_pct),
            c.white_de2000,
            c.reserve_left(),
            match c.kind {
                CheckKind::Full => "in full",
                CheckKind::White => "white (factors inferred)",
                CheckKind::WhiteLuminance => "white (luminance only)",
                CheckKind::Escalated => "white, then in full",
            }
        );
    }
    s
}

/// Restores the profiles and measurements a recalibration replaced (`previous/`) and
/// removes `previous/`; returns the restored profiles.
pub fn rollback(dir: &Path) -> Result<Vec<DisplayProfile>, RecalibrateError> {
    let _lock = FolderLock::acquire(dir, "rollback")?;
    let previous = dir.join(PREVIOUS_DIR);
    if !previous.join(ProfileSet::MANIFEST).is_file() {
        return Err(RecalibrateError::NothingToRollBack {
            dir: dir.to_path_buf(),
        });
    }
    let (wall, profiles) = ProfileSet::load_dir(&previous)?;
    for p in &profiles {
        let from = measurement_path(&previous.join(RUN_DIR), &p.display);
        if let Some(m) = load_measurement(&from)? {
            write_atomic(
                &measurement_path(&dir.join(RUN_DIR), &p.display),
                &to_json(&m),
            )?;
        }
    }
    ProfileSet::save_dir(dir, &wall, &profiles)?;
    remove_dir_if_present(&previous)?;
    Ok(profiles)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A display key for the checks below.
    fn test_key() -> DisplayKey {
        DisplayKey {
            wall: "w".into(),
            display: 0,
            tile_col: 0,
            tile_row: 0,
            eye: lumiwall_core::Eye::Mono,
        }
    }

    /// heyewall-48's display 1 as a realistic meter read it at commissioning (cd/m²).
    pub(super) fn commissioned() -> FullReading {
        FullReading {
            black: Xyz::new(0.1729, 0.0875, 0.4526),
            primaries: [
                Xyz::new(85.519, 41.953, 0.4734),
                Xyz::new(4.9416, 35.383, 3.3672),
                Xyz::new(28.849, 4.8377, 156.03),
            ],
            white: Some(Xyz::new(118.88, 81.81, 159.23)),
        }
    }

    /// The commissioning's white with its chromaticity moved by `dx` and its luminance
    /// scaled by `k`.
    pub(super) fn white_moved(dx: f64, k: f64) -> Xyz {
        let w = commissioned().white.unwrap();
        let xy = w.chromaticity().unwrap();
        Xyz::from_xy_luminance(xy.x + dx, xy.y, w.y * k)
    }

    /// A full check's readings: the commissioning's with blue moved by `dx` in x and
    /// 2 % darker.
    fn full_check_with_blue_moved(dx: f64) -> (crate::solve::DisplayMeasurement, Readings) {
        let c = commissioned();
        let old = crate::solve::DisplayMeasurement {
            key: test_key(),
            bit_depth: 8,
            black: c.black,
            primaries: c.primaries,
            white: c.white,
            ramps: Default::default(),
            readings: 0,
            instrument: String::new(),
            composites: Vec::new(),
            ramp_sigma_rel: Default::default(),
        };
        let mut primaries = c.primaries;
        let b = primaries[2] - c.black;
        let xy = b.chromaticity().unwrap();
        primaries[2] = c.black + Xyz::from_xy_luminance(xy.x + dx, xy.y, b.y * 0.98);
        let new = Readings {
            black: c.black,
            primaries,
            white: c.white,
            mid: [None; 3],
        };
        (old, new)
    }

    #[test]
    fn a_primary_whose_colour_moved_within_the_drift_limit_keeps_its_colour_at_its_new_luminance() {
        let (old, new) = full_check_with_blue_moved(0.0015);
        let steady = steady_chromaticities(&old, new, 0.002);
        let (o, n) = (
            old.primaries[2] - old.black,
            steady.primaries[2] - steady.black,
        );
        assert!(
            o.chromaticity()
                .unwrap()
                .distance(n.chromaticity().unwrap())
                < 1e-12
        );
        assert!((n.y / o.y - 0.98).abs() < 1e-12);
        // red and green did not move: unchanged
        assert_eq!(steady.primaries[0], old.primaries[0]);
        // beyond the limit the reading is taken whole
        let (old, new) = full_check_with_blue_moved(0.004);
        let read = new.primaries[2];
        let taken = steady_chromaticities(&old, new, 0.002);
        assert_eq!(taken.primaries[2], read);
    }

    /// A full check's readings of a lamp dimmed by 2 % in every channel, its black
    /// read `dx_cd_m2` off in X from the old black dimmed alike.
    fn full_check_with_black_off(dx_cd_m2: f64) -> (crate::solve::DisplayMeasurement, Readings) {
        let (old, _) = full_check_with_blue_moved(0.0);
        let black = old.black * 0.98 + Xyz::new(dx_cd_m2, 0.0, 0.0);
        let primaries = std::array::from_fn(|c| black + (old.primaries[c] - old.black) * 0.98);
        let new = Readings {
            black,
            primaries,
            white: old.white,
            mid: [None; 3],
        };
        (old, new)
    }

    #[test]
    fn a_black_read_within_the_meter_noise_is_the_last_black_dimmed_with_the_lamp() {
        let noise = lumiwall_devices::ReadingNoise::CS100A_CLASS;
        // 0.011 cd/m² in X: what one night's black reading was off on heyewall-48
        let (old, new) = full_check_with_black_off(0.011);
        let steady = steady_black(&old, new, Some(noise));
        let expected = old.black * 0.98;
        assert!(
            (steady.black - expected)
                .to_array()
                .iter()
                .all(|d| d.abs() < 1e-12)
        );
    }

    #[test]
    fn a_black_that_moved_beyond_the_meter_noise_or_read_by_a_meter_without_stated_noise_is_taken_as_read()
     {
        let noise = lumiwall_devices::ReadingNoise::CS100A_CLASS;
        // 3·√2·0.008 = 0.034 cd/m²: 0.05 is beyond it
        let (old, new) = full_check_with_black_off(0.05);
        let read = new.black;
        assert_eq!(steady_black(&old, new, Some(noise)).black, read);
        let (old, new) = full_check_with_black_off(0.011);
        let read = new.black;
        assert_eq!(steady_black(&old, new, None).black, read);
    }

    /// A full check's readings of a lamp dimmed by 2 %, its white read `dx` off in x
    /// from what the lamp predicts.
    fn full_check_with_white_off(dx: f64) -> (crate::solve::DisplayMeasurement, Readings) {
        let (old, mut new) = full_check_with_black_off(0.0);
        let w = old.white.unwrap() * 0.98;
        let xy = w.chromaticity().unwrap();
        new.white = Some(Xyz::from_xy_luminance(xy.x + dx, xy.y, w.y));
        (old, new)
    }

    #[test]
    fn a_white_read_within_the_meter_noise_has_the_colour_tonight_s_primaries_predict() {
        let noise = lumiwall_devices::ReadingNoise::CS100A_CLASS;
        let (old, new) = full_check_with_white_off(0.0015);
        let steady = steady_white(&old, new, Some(noise)).white.unwrap();
        let expected = old.white.unwrap() * 0.98;
        let off = (steady - expected).to_array();
        assert!(
            off.iter().all(|d| d.abs() < 1e-9),
            "{steady:?} vs {expected:?}"
        );
    }

    #[test]
    fn a_white_beyond_the_meter_noise_or_read_by_a_meter_without_stated_noise_is_taken_as_read() {
        let noise = lumiwall_devices::ReadingNoise::CS100A_CLASS;
        // 3·√2·0.0005 = 0.0021: 0.004 is beyond it
        let (old, new) = full_check_with_white_off(0.004);
        let read = new.white;
        assert_eq!(steady_white(&old, new, Some(noise)).white, read);
        let (old, new) = full_check_with_white_off(0.0015);
        let read = new.white;
        assert_eq!(steady_white(&old, new, None).white, read);
    }

    #[test]
    fn a_white_check_writes_the_white_its_factors_model_not_the_reading() {
        // 1 % darker, 1σ off in x: all channels alike; the white keeps its colour
        let old = commissioned();
        let read = white_moved(0.0005, 0.99);
        let noise = lumiwall_devices::ReadingNoise::CS100A_CLASS;
        let limits = DriftLimits::default();
        let (r, kind) = readings_from_white(&old, read, Some(&noise), None, &limits).unwrap();
        assert_eq!(kind, CheckKind::WhiteLuminance);
        let white = r.white.unwrap();
        let was = old.white.unwrap();
        assert!((white.y - read.y).abs() < 1e-9 * read.y);
        let moved = white
            .chromaticity()
            .unwrap()
            .distance(was.chromaticity().unwrap());
        assert!(moved < 1e-12, "{white:?} vs {was:?}");
    }

    #[test]
    fn a_refit_keeps_each_grey_read_whole_as_the_same_mix_of_the_primaries() {
        let (mut old, mut new) = full_check_with_blue_moved(0.0);
        let mix = [0.3, 0.5, 0.2];
        let shown =
            |black: Xyz, p: &[Xyz; 3]| (0..3).fold(black, |acc, c| acc + (p[c] - black) * mix[c]);
        old.composites = vec![crate::solve::CompositeReading {
            drive: [0.5; 3],
            xyz: shown(old.black, &old.primaries),
            readings: 4,
        }];
        // the lamp lost 5 % of red, 8 % of green, 12 % of blue; the black 8 %
        new.black = old.black * 0.92;
        new.primaries = std::array::from_fn(|c| {
            new.black + (old.primaries[c] - old.black) * [0.95, 0.92, 0.88][c]
        });
        let moved = moved_composites(&old, &new);
        let expected = shown(new.black, &new.primaries);
        assert_eq!(moved.len(), 1);
        assert_eq!((moved[0].drive, moved[0].readings), ([0.5; 3], 4));
        let off = (moved[0].xyz - expected).to_array();
        assert!(
            off.iter().all(|d| d.abs() < 1e-9),
            "{:?} vs {expected:?}",
            moved[0].xyz
        );
    }

    #[test]
    fn a_refit_drops_the_greys_read_whole_of_a_display_with_a_white_segment() {
        let (mut old, new) = full_check_with_blue_moved(0.0);
        old.composites = vec![crate::solve::CompositeReading {
            drive: [0.5; 3],
            xyz: old.white.unwrap() * 0.2,
            readings: 4,
        }];
        let sum = (0..3).fold(old.black, |acc, c| acc + (old.primaries[c] - old.black));
        // a white 20 % beyond its primaries: an RGBW wheel's white segment
        old.white = Some(sum + (sum - old.black) * 0.25);
        assert!(moved_composites(&old, &new).is_empty());
    }

    #[test]
    fn a_luminance_only_white_check_gives_the_forecast_no_lamp_reading() {
        let check = |kind| DisplayCheck {
            key: test_key(),
            luminance_change_pct: [-1.0; 3],
            primary_delta_xy: [0.0; 3],
            black_change_cd_m2: 0.0,
            white_de2000: 0.1,
            primaries_xyz_cd_m2: [[40.0, 20.0, 1.0], [30.0, 60.0, 10.0], [15.0, 6.0, 80.0]],
            drifted: false,
            usage_for_current_white: [0.8, 0.7, 0.6],
            headroom: 0.85,
            curve_change_pct: [f64::NAN; 3],
            curves_moved: false,
            readings: 1,
            kind,
            flat_field: None,
        };
        let utc = "2026-01-01T02:00:00Z".parse().unwrap();
        assert!(check(CheckKind::White).lamp_reading(utc).is_some());
        assert!(check(CheckKind::Full).lamp_reading(utc).is_some());
        assert!(check(CheckKind::WhiteLuminance).lamp_reading(utc).is_none());
    }
}
