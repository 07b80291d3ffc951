//! Measuring one display with a spot meter: black, R/G/B at full drive, white (for the
//! additivity check) and per-channel ramps with adaptive sample placement.
//!
//! Everything goes through the device traits ([`PatternOutput`], [`Colorimeter`],
//! [`MeterPositioner`]); nothing here knows whether the meter is a real instrument on a
//! serial port, the pty emulator or the simulator. The result is a
//! [`DisplayMeasurement`] for [`crate::solve::solve_wall`] plus a [`MeasureLog`] that
//! says what was read, repeated or skipped.
//!
//! Reading budget: a full calibration of one display costs at most
//! [`MeasureOptions::budget`] meter readings (default 40). Black, the three primaries
//! and white take five or more (black is averaged when below the meter's reliable
//! limit, the primaries and the white are averaged up to 4× for larger budgets: the
//! white, fused with the primaries under additivity, fixes the white's colour best);
//! the rest is spent on
//! ramp samples, placed one at a time per channel where the current tone-curve
//! estimate is least certain ([`crate::tone::suggest_next_drive`]), with the intensity
//! axis rescaled to the part of the channel the wall white is expected to use
//! ([`RampFocus`]; e.g. only ~15 % of an unadjusted Infitec right-eye green). In
//! `Common` black mode one extra sample per channel lands in the toe near the black
//! level.
//!
//! Low light: below the meter's reliable limit (about 1 cd/m² for a CS-100A class
//! meter) a single reading is noisy. [`LowLight::Average`] repeats such readings and
//! averages them in XYZ (each repeat counts against the budget; in the dark the noise
//! is the sensors' own, Gaussian in X, Y and Z); [`LowLight::Skip`] drops ramp samples
//! below the limit (black and the primaries are always averaged, never skipped). A
//! reading the meter refuses as too dark costs a reading and counts in the mean's
//! luminance as a reading below the meter's floor ([`CensoredReadings`]); every reading
//! of a display's black is pooled in its log ([`MeasureLog::black_readings`]). A ramp
//! sample is put on its channel's line (a channel's chromaticity above
//! black does not change with drive) at its least-squares component along it, X, Y and
//! Z weighted by the meter's stated noise ([`channel_reading`]): the Z of a dim blue,
//! twenty times its Y, then carries the sample. A meter that states no noise is read
//! for the luminance alone ([`luminance_only`]). The raw readings stay in the [`MeasureLog`].
//! Once the ramps are read, each channel's colour is pooled over its full-drive reading
//! and its bright ramp samples, which read the same colour as often again
//! ([`channel_colour`]), and the samples are put on the pooled lines.

// Errors carry the display, the reading and the device error for the technician and
// occur at most once per run, so their size does not matter.
#![allow(
    clippy::result_large_err,
    reason = "errors carry the display, the reading and the device error and occur at most once per run"
)]

pub mod averaging;
pub mod black_readings;
pub mod ccmx;
pub mod channel_colour;
pub mod drift;
pub mod grey_drives;
pub mod meter_matrix;
pub mod meter_offset;
pub mod noise_seen;
pub mod split_grey;
pub mod warm_up;
pub mod wavelength_check;

use lumiwall_core::{BitDepth, Channel};
use lumiwall_devices::{
    AimingAids, CensoredReadings, Colorimeter, DeviceError, DisplayId, DisplayInfo,
    MeterPositioner, PatternOutput, ReadingNoise, Xyz,
};
use lumiwall_profiles::DisplayKey;
use serde::{Deserialize, Serialize};

use crate::solve::DisplayMeasurement;

/// Names of the three channels, for messages (kept for callers; prefer
/// [`Channel::name`]).
pub const CHANNEL_NAMES: [&str; 3] = [
    Channel::Red.name(),
    Channel::Green.name(),
    Channel::Blue.name(),
];

/// Smallest expected channel usage the ramp placement plans for: below it the samples
/// would all crowd into the first few codes.
const MIN_EXPECTED_USAGE: f64 = 0.02;

/// Range of the relative intensity a toe sample aims at: above zero (the drive must
/// show something) and at most half the channel (the toe is where black matters).
const TOE_INTENSITY_RANGE: (f64, f64) = (1e-5, 0.5);

/// Half a code value in normalised drive: samples closer than this to an existing one
/// would repeat the same code.
const HALF_CODE: f64 = 0.5;

/// What to do with readings below the meter's reliable luminance limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LowLight {
    /// Repeat the reading this many times in all (≥ 1) and average; a single-channel
    /// ramp sample at most [`DARK_CHANNEL_REPEATS`] times.
    Average {
        /// Total readings averaged for one low-light sample (the first included).
        repeats: u32,
    },
    /// Drop ramp samples below the limit (the tone curve is interpolated from (0, 0)
    /// there); black and the primaries are still averaged with 4 repeats.
    Skip,
}

impl LowLight {
    /// Readings averaged for a sample below the reliable limit that is never skipped
    /// (the black, the primaries): the policy's repeats, four under [`LowLight::Skip`].
    pub fn black_readings(self) -> u32 {
        match self {
            LowLight::Average { repeats } => repeats.max(1),
            LowLight::Skip => 4,
        }
    }
}

/// How to measure one display.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeasureOptions {
    /// Meter readings allowed per display, repeats included.
    pub budget: u32,
    /// Calibration spot in normalised display coordinates (centre: 0.5, 0.5).
    pub spot_uv: [f64; 2],
    /// Low-light policy.
    pub low_light: LowLight,
    /// Reliable lower luminance limit in cd/m²; `None` takes the meter's own
    /// [`lumiwall_devices::MeterInfo::min_reliable_cd_m2`].
    pub low_light_limit_cd_m2: Option<f64>,
    /// Extra attempts after a transient device error (timeout, garbled answer) before
    /// the display is given up.
    pub max_retries: u32,
    /// Measure full white (needed for the additivity check).
    pub measure_white: bool,
    /// Readings of the budget the ramps leave for a later pass (the grey-drive pass of a
    /// commissioning), unless a channel would otherwise get no ramp sample at all.
    #[serde(default)]
    pub reserved: u32,
    /// Readings averaged for each full-drive primary; `None` chooses from the budget
    /// less what is `reserved` (1 below 24, up to 4 from 48). Averaging matters for very
    /// saturated primaries (an Infitec blue has y ≈ 0.02, so the meter's xy noise
    /// becomes a large relative error in Z).
    pub primary_repeats: Option<u32>,
    /// Where the ramps should be dense: the part of each channel that the common white
    /// will use. `None` spreads samples over the whole ramp.
    pub focus: Option<RampFocus>,
    /// Before the first display: wait until the wall has warmed up ([`warm_up`]);
    /// `None` starts at once.
    #[serde(default)]
    pub warm_up: Option<warm_up::WarmUp>,
    /// The meter's display-type correction ([`meter_matrix`]): every reading of a
    /// display goes through the matrix of its eye. `None`: readings as the meter gives
    /// them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub meter_matrix: Option<meter_matrix::MeterMatrices>,
    /// How many of the meter's readings each reading averages ([`averaging`]): a
    /// commissioning wraps its meter in [`lumiwall_devices::AveragingMeter`]; the budget
    /// counts the averaged readings.
    #[serde(default)]
    pub averaging: averaging::Averaging,
}

/// Information to concentrate ramp samples on the used part of each channel.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RampFocus {
    /// Chromaticity of the wall's target white.
    pub white_xy: [f64; 2],
    /// Largest channel usage the solve allows (headroom).
    pub headroom: f64,
    /// Upper bound of the wall white's luminance known so far (cd/m²), e.g. the
    /// smallest white luminance reachable by the displays measured before; `None` uses
    /// the display's own.
    pub white_y_cd_m2: Option<f64>,
    /// Also sample each channel's toe where it gives about the display's own black
    /// luminance (what a common black adds on top of a display's black), so that
    /// `Common` black mode lands on the common black.
    pub toe_samples: bool,
    /// Estimate of the wall's common black (cd/m²), e.g. the component-wise largest
    /// black measured so far: the toe samples then go where this display's channels
    /// must add `common − own black`.
    pub common_black: Option<Xyz>,
}

impl RampFocus {
    /// The wall white's luminance (cd/m²) this display is expected to show, its own
    /// largest at the focus chromaticity and headroom but at most the wall's so far,
    /// and the display's channel intensities per cd/m² of it; `None` when that white is
    /// outside the display's gamut or its primaries are degenerate.
    pub fn expected_white(&self, black: Xyz, primaries: &[Xyz; 3]) -> Option<(f64, [f64; 3])> {
        let (own_y, per_cd) = white_capacity(black, primaries, self.white_xy, self.headroom)?;
        Some((self.white_y_cd_m2.map_or(own_y, |y| y.min(own_y)), per_cd))
    }
}

impl Default for MeasureOptions {
    fn default() -> Self {
        Self {
            budget: 40,
            spot_uv: [0.5, 0.5],
            low_light: LowLight::Average { repeats: 4 },
            low_light_limit_cd_m2: None,
            max_retries: 2,
            measure_white: true,
            reserved: 0,
            primary_repeats: None,
            focus: None,
            warm_up: None,
            meter_matrix: None,
            averaging: averaging::Averaging::default(),
        }
    }
}

impl MeasureOptions {
    /// Smallest budget that still measures black, R, G, B, W and two ramp samples per
    /// channel.
    pub const MIN_BUDGET: u32 = 11;

    /// Readings per primary for this budget.
    pub fn primary_repeats(&self) -> u32 {
        self.primary_repeats
            .unwrap_or_else(|| {
                let budget = self.budget.saturating_sub(self.reserved);
                (budget.saturating_sub(16) / 8).clamp(1, 4)
            })
            .max(1)
    }

    /// Readings averaged for the full white. From [`WHITE_MIN_BUDGET`] readings per
    /// display: as many as the meter's stated xy noise needs for a standard error of
    /// [`WHITE_XY_SE`], at most one in [`WHITE_BUDGET_SHARE`] of the budget and
    /// [`MAX_WHITE_REPEATS`]; never fewer than a primary gets ([`Self::primary_repeats`],
    /// which is also the count below that budget and for a meter that states no noise
    /// or none).
    ///
    /// The white is fused with the primaries (`commission::fuse_with_white`), and one
    /// reading of it fixes its chromaticity far better than one of a saturated blue
    /// (y ≈ 0.3 against 0.06). Realistic meter, 40 readings per display (3 on the
    /// white instead of 1), 40 unseen seeds per class, runs within every limit of
    /// issue 12: mono-2x1 30 → 40, offaxis-gain-2x1 31 → 39, infitec-pair 33 → 37, mean
    /// white ΔE2000 0.73 → 0.65, 0.74 → 0.64, 0.69 → 0.63; weak-channel-3x1, whose grey
    /// balance needs the two readings more, 4 → 1. Below 40 the ramps cannot spare
    /// them: two readings on the white gave mono-2x1 (15 seeds) 1 → 0 runs within the
    /// limits at 24 readings and 13 → 8 at 32.
    pub fn white_repeats(&self, noise: Option<&ReadingNoise>) -> u32 {
        let primary = self.primary_repeats();
        let stated = noise.filter(|n| !n.is_exact());
        let (Some(n), true) = (stated, self.budget >= WHITE_MIN_BUDGET) else {
            return primary;
        };
        let needed = (n.xy / WHITE_XY_SE).powi(2).ceil();
        let needed = if needed.is_finite() {
            needed.clamp(1.0, f64::from(MAX_WHITE_REPEATS)) as u32
        } else {
            MAX_WHITE_REPEATS
        };
        let most = (self.budget / WHITE_BUDGET_SHARE)
            .min(MAX_WHITE_REPEATS)
            .max(primary);
        needed.clamp(primary, most)
    }
}

/// Standard error of the full white's mean x and y that its readings aim at
/// ([`MeasureOptions::white_repeats`]).
pub const WHITE_XY_SE: f64 = 0.0002;

/// Smallest budget per display at which the full white gets more readings than a
/// primary ([`MeasureOptions::white_repeats`]).
pub const WHITE_MIN_BUDGET: u32 = 40;

/// The full white takes at most one reading in this many of the display's budget.
pub const WHITE_BUDGET_SHARE: u32 = 12;

/// Most readings averaged for the full white, unless the primaries get more.
pub const MAX_WHITE_REPEATS: u32 = 6;

/// Largest luminance (cd/m²) of a white of chromaticity `white_xy` that a display with
/// these readings can show with every channel at most `headroom`, and the channel
/// intensities per cd/m² of that white. `None` when the white is outside the display's
/// gamut or the primaries are degenerate.
pub fn white_capacity(
    black: Xyz,
    primaries: &[Xyz; 3],
    white_xy: [f64; 2],
    headroom: f64,
) -> Option<(f64, [f64; 3])> {
    let m = drive_matrix(black, primaries)?;
    let w = Xyz::from_xy_luminance(white_xy[0], white_xy[1], 1.0);
    let lin = m * w.to_vector();
    if lin.iter().any(|v| !v.is_finite() || *v <= 0.0) {
        return None;
    }
    let y = headroom / lin.max();
    Some((y, [lin[0], lin[1], lin[2]]))
}

/// `P⁻¹`: XYZ above black to linear channel intensities, from the black-subtracted
/// primaries; `None` when they are degenerate.
fn drive_matrix(black: Xyz, primaries: &[Xyz; 3]) -> Option<nalgebra::Matrix3<f64>> {
    let cols: Vec<nalgebra::Vector3<f64>> =
        primaries.iter().map(|p| (*p - black).to_vector()).collect();
    nalgebra::Matrix3::from_columns(&cols).try_inverse()
}

/// What a reading was of.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Patch {
    /// All channels at 0.
    Black,
    /// One channel at full drive (serialised as its index 0: red, 1: green, 2: blue).
    Primary(#[serde(with = "channel_index")] Channel),
    /// All channels at full drive.
    White,
    /// One channel at the given drive (channel serialised as its index).
    Ramp(#[serde(with = "channel_index")] Channel, f64),
    /// Any drive triple (verification patches, greys read whole).
    Drive([f64; 3]),
    /// A grey read whole to be split into its channels' intensities
    /// ([`grey_drives::GreyLevel::Split`], [`split_grey::split_greys`]).
    Grey([f64; 3]),
}

impl Patch {
    /// The drive triple that shows this patch.
    pub fn drive(&self) -> [f64; 3] {
        match *self {
            Patch::Black => [0.0; 3],
            Patch::White => [1.0; 3],
            Patch::Primary(c) => unit(c, 1.0),
            Patch::Ramp(c, d) => unit(c, d),
            Patch::Drive(d) | Patch::Grey(d) => d,
        }
    }
}

impl std::fmt::Display for Patch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Patch::Black => f.write_str("black"),
            Patch::White => f.write_str("white"),
            Patch::Primary(c) => write!(f, "full {}", c.name()),
            Patch::Ramp(c, d) => write!(f, "{} ramp at drive {d:.4}", c.name()),
            Patch::Drive(d) => write!(f, "drive ({:.4}, {:.4}, {:.4})", d[0], d[1], d[2]),
            Patch::Grey(d) => write!(f, "grey at drive ({:.4}, {:.4}, {:.4})", d[0], d[1], d[2]),
        }
    }
}

fn unit(c: Channel, d: f64) -> [f64; 3] {
    let mut v = [0.0; 3];
    v[c.index()] = d;
    v
}

/// Serde of a [`Channel`] as its index 0, 1, 2 (the measurement log's format).
mod channel_index {
    use lumiwall_core::Channel;
    use serde::{Deserialize, Deserializer, Serializer, de::Error};

    pub(super) fn serialize<S: Serializer>(c: &Channel, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u64(c.index() as u64)
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Channel, D::Error> {
        let index = usize::deserialize(d)?;
        Channel::from_index(index).map_err(D::Error::custom)
    }
}

/// Running sums of readings in xyY (x, y, Y), for averaging.
fn add_xyy(sum: &mut [f64; 3], xy: [f64; 2], luminance: f64) {
    sum[0] += xy[0];
    sum[1] += xy[1];
    sum[2] += luminance;
}

/// Progress events, for a progress bar.
#[derive(Debug, Clone, PartialEq)]
pub enum Progress {
    /// A reading was taken on `display`.
    Reading {
        /// Display being measured.
        display: DisplayId,
        /// Readings taken on it so far (this one included).
        readings: u32,
        /// Its budget.
        budget: u32,
        /// What was read.
        patch: Patch,
    },
    /// A display is completely measured.
    DisplayDone {
        /// The display.
        display: DisplayId,
        /// Readings it cost.
        readings: u32,
    },
    /// Waiting for a cold wall ([`warm_up`]): the white's luminance trend over the last
    /// window of readings.
    WarmingUp {
        /// Readings so far.
        readings: u32,
        /// Luminance change over the window (percent).
        change_percent: f64,
    },
    /// The wall is warm: the wait is over.
    WarmedUp(warm_up::WarmUpReport),
    /// Whether the wall is warming, checked before the first display
    /// ([`warm_up::check_warm`]); when it is, the wait follows.
    WarmCheck(warm_up::WarmCheckReport),
    /// A display's channels were read at the drives of its provisional white and
    /// greys, and its white read whole ([`grey_drives`]); the readings of that pass are
    /// not reported one by one.
    GreyDrivesRead {
        /// The display.
        display: DisplayId,
        /// Ramp samples added.
        samples: usize,
        /// Greys read whole (all channels together).
        whole: usize,
        /// Readings the pass cost.
        readings: u32,
    },
    /// How many of the meter's readings each reading of the run averages, chosen from
    /// the survey of every display before any ramp ([`averaging`]).
    Averaging(averaging::AveragingChoice),
    /// A display's measurement was taken from an earlier, interrupted run.
    Resumed {
        /// The display.
        display: DisplayId,
        /// Readings it cost in that run.
        readings: u32,
    },
}

/// One sample as recorded in the log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReadingRecord {
    /// What was shown.
    pub patch: Patch,
    /// Averaged XYZ (cd/m²), black included; `None` if the sample was skipped.
    pub xyz: Option<Xyz>,
    /// Readings averaged (0 for none).
    pub repeats: u32,
    /// True when the first reading was below the reliable limit.
    pub low_light: bool,
}

/// What happened while measuring one display.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MeasureLog {
    /// Every sample in order.
    pub samples: Vec<ReadingRecord>,
    /// Successful meter readings (repeats included).
    pub readings: u32,
    /// Failed attempts that a retry recovered from.
    pub retries: u32,
    /// Reliable luminance limit that was applied (cd/m²).
    pub low_light_limit_cd_m2: f64,
    /// Low-light policy that was applied.
    pub low_light: Option<LowLight>,
    /// Readings of the grey-drive pass ([`grey_drives`]), once it ran; its samples are
    /// in `samples` and the ramps.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grey_drive_readings: Option<u32>,
    /// The spread of the repeated readings against the meter's stated noise
    /// ([`noise_seen`]); the default (nothing seen) in logs written before it.
    #[serde(default)]
    pub noise_seen: noise_seen::NoiseSeen,
    /// Meter readings each reading averaged ([`averaging`]); 0 (logs written before it)
    /// and 1: each read once.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub readings_averaged: u32,
    /// Meter readings of a first survey of the display that the run read again with
    /// more readings averaged ([`averaging`]): spent, not in `readings`.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub first_survey_readings: u32,
    /// Every reading of the black as the meter gave it (before its correction), those
    /// it refused as too dark counted: the black is their mean ([`black_of`]), however
    /// many times the run came back to it. Empty in logs written before it.
    #[serde(default, skip_serializing_if = "CensoredReadings::is_empty")]
    pub black_readings: CensoredReadings,
}

/// For `skip_serializing_if`.
fn is_zero(v: &u32) -> bool {
    *v == 0
}

impl MeasureLog {
    /// Meter readings each reading averaged (at least 1).
    pub fn meter_readings_each(&self) -> u32 {
        self.readings_averaged.max(1)
    }

    /// Samples that were below the reliable limit and averaged.
    pub fn averaged(&self) -> usize {
        self.samples
            .iter()
            .filter(|s| s.low_light && s.xyz.is_some())
            .count()
    }

    /// Samples that were below the reliable limit and skipped.
    pub fn skipped(&self) -> usize {
        self.samples.iter().filter(|s| s.xyz.is_none()).count()
    }

    /// The last record of `patch` that has a reading.
    pub fn last_read(&self, patch: Patch) -> Option<&ReadingRecord> {
        self.samples
            .iter()
            .rev()
            .find(|r| r.patch == patch && r.xyz.is_some())
    }

    /// Readings in every record of `patch` that gave a value.
    pub fn readings_of(&self, patch: Patch) -> u32 {
        self.samples
            .iter()
            .filter(|r| r.patch == patch && r.xyz.is_some())
            .map(|r| r.repeats.max(1))
            .sum()
    }
}

/// A display's measurement and its log, as saved in a commissioning run folder.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MeasuredDisplay {
    /// The input to the solve.
    pub measurement: DisplayMeasurement,
    /// How it was taken.
    pub log: MeasureLog,
    /// The display's last full reading, where the measurement has since been refitted
    /// from white checks alone (see `recalibrate::FullCheckRotation`): the next white
    /// check infers from it, so that the errors of single white readings do not add up
    /// night after night. `None`: the measurement is itself a full reading.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub anchor: Option<FullReading>,
    /// How the display's lamp ages, learned from its full checks
    /// (`recalibrate::LampAgeing`): the white checks infer the channel factors along
    /// it. `None`: not learned yet (commissioning, or too little loss so far).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ageing: Option<crate::recalibrate::LampAgeing>,
}

/// Black, primaries and white of one full reading of a display (cd/m²).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FullReading {
    /// Black.
    pub black: Xyz,
    /// Each primary at full drive, black included.
    pub primaries: [Xyz; 3],
    /// White at full drive (`None`: not read).
    pub white: Option<Xyz>,
}

impl MeasuredDisplay {
    /// The last full reading: the anchor, or the measurement itself.
    pub fn last_full_reading(&self) -> FullReading {
        self.anchor.unwrap_or(FullReading {
            black: self.measurement.black,
            primaries: self.measurement.primaries,
            white: self.measurement.white,
        })
    }

    /// Meter readings the display cost: its readings times the meter readings each
    /// averaged, and a first survey read again ([`MeasureLog::first_survey_readings`]).
    pub fn meter_readings(&self) -> u32 {
        self.measurement
            .readings
            .saturating_mul(self.log.meter_readings_each())
            .saturating_add(self.log.first_survey_readings)
    }
}

/// Errors while measuring, each naming the display and the reading.
#[derive(Debug, thiserror::Error)]
pub enum MeasureError {
    /// A reading failed and retries did not help (or the error is not transient).
    #[error(
        "{display}: reading {reading} ({patch}) failed after {attempts} attempt(s): {source}. {hint}"
    )]
    Reading {
        /// Display being measured.
        display: String,
        /// Number of the reading on this display, 1-based.
        reading: u32,
        /// What was shown.
        patch: Patch,
        /// Attempts made.
        attempts: u32,
        /// The last device error.
        #[source]
        source: DeviceError,
        /// What to check.
        hint: String,
    },
    /// The pattern could not be shown.
    #[error("{display}: cannot show {patch}: {source}; check the display's video input")]
    Pattern {
        /// Display being measured.
        display: String,
        /// What was to be shown.
        patch: Patch,
        /// The device error.
        #[source]
        source: DeviceError,
    },
    /// The meter could not be aimed.
    #[error("{display}: cannot aim the meter at spot {uv:?}: {source}")]
    Aim {
        /// Display being measured.
        display: String,
        /// Spot.
        uv: [f64; 2],
        /// The device error.
        #[source]
        source: DeviceError,
    },
    /// The wall did not settle while waiting for it to warm up.
    #[error(
        "{display}: still drifting after {readings} readings of its white (the luminance \
         changed {change_percent:+.2} % over the last window); check the lamp mode (eco, \
         dynamic iris), room temperature and ventilation, or wait longer"
    )]
    NotWarm {
        /// Display watched.
        display: String,
        /// Readings taken.
        readings: u32,
        /// The last window's change (percent).
        change_percent: f64,
    },
    /// While waiting for the wall to warm up, its white showed no light.
    #[error(
        "{display}: its white reads no light while waiting for the wall to warm up \
         ({readings} readings); is the projector on, its shutter open and the meter aimed at it?"
    )]
    DarkWhileWarming {
        /// Display watched.
        display: String,
        /// Readings taken.
        readings: u32,
    },
    /// The reading budget cannot cover a calibration.
    #[error(
        "a budget of {budget} readings per display is too small: at least {min} are needed \
         (black, R, G, B, W and two ramp samples per channel)"
    )]
    BudgetTooSmall {
        /// Budget asked for.
        budget: u32,
        /// Smallest workable budget.
        min: u32,
    },
    /// A primary reads no brighter than black and below the meter's reliable limit:
    /// the display may work but be too dim for this meter (lamp off, dimmed or aged;
    /// lens cap), or the meter looks elsewhere.
    #[error(
        "{display}: full {channel} reads {y_cd_m2:.4} cd/m², below the reliable limit of the \
         meter ({meter}: {limit_cd_m2} cd/m²); the display is too dim for this meter or shows \
         nothing at the spot: check the lamp (on, eco/dimming mode, hours), lens cap and aim, \
         or use a more sensitive meter"
    )]
    BelowMeterLimit {
        /// Display being measured.
        display: String,
        /// Channel name.
        channel: &'static str,
        /// Primary luminance read.
        y_cd_m2: f64,
        /// The reliable limit applied.
        limit_cd_m2: f64,
        /// The meter's model.
        meter: String,
    },
    /// Every ramp reading of a channel was below the meter's limit (skipped or refused
    /// as too dark), so its tone curve cannot be measured.
    #[error(
        "{display}: every {channel} ramp reading was below the reliable limit of the meter \
         ({limit_cd_m2} cd/m²; full {channel} reads {full_y_cd_m2:.4} cd/m²), so the {channel} \
         tone curve cannot be measured: use --low-light avg:16 to average dark readings, \
         check the lamp (eco/dimming mode, hours), or use a more sensitive meter"
    )]
    RampBelowMeterLimit {
        /// Display being measured.
        display: String,
        /// Channel name.
        channel: &'static str,
        /// Full-drive luminance of the channel.
        full_y_cd_m2: f64,
        /// The reliable limit applied.
        limit_cd_m2: f64,
    },
    /// The budget was spent before a channel's ramp got a single sample (dark readings
    /// averaged several times each take it fastest).
    #[error(
        "{display}: the {budget} readings of the measuring pass ran out before the \
         {channel} ramp got a sample ({taken} readings taken, {low_light} of them in \
         averages of readings below the reliable limit of the meter); raise --budget, \
         check the lamp (eco/dimming mode, hours), or use a more sensitive meter"
    )]
    RampBudgetSpent {
        /// Display being measured.
        display: String,
        /// Channel name.
        channel: &'static str,
        /// Readings the measuring pass had (the budget less the grey-drive pass's).
        budget: u32,
        /// Readings taken (the black and the primaries are read even past the budget).
        taken: u32,
        /// Readings that went to averaging samples below the reliable limit.
        low_light: u32,
    },
    /// A primary is not brighter than black: the display shows nothing, or the meter
    /// looks elsewhere.
    #[error(
        "{display}: full {channel} reads {y_cd_m2:.3} cd/m², not brighter than black \
         {black_cd_m2:.3} cd/m²; check that the display is on, shows the pattern, and that \
         the meter is aimed at it"
    )]
    NoSignal {
        /// Display being measured.
        display: String,
        /// Channel name.
        channel: &'static str,
        /// Primary luminance read.
        y_cd_m2: f64,
        /// Black luminance read.
        black_cd_m2: f64,
    },
    /// The meter returned a non-finite or negative value.
    #[error(
        "{display}: reading {reading} ({patch}) returned an invalid value {xyz:?}; check the meter"
    )]
    Invalid {
        /// Display being measured.
        display: String,
        /// Reading number.
        reading: u32,
        /// What was shown.
        patch: Patch,
        /// What came back.
        xyz: Xyz,
    },
}

impl MeasureError {
    /// True when the technician stopped the run (the station app's Stop): what was
    /// measured is kept, nothing failed.
    pub fn is_stopped(&self) -> bool {
        matches!(
            self,
            MeasureError::Reading {
                source: DeviceError::Stopped(_),
                ..
            } | MeasureError::Pattern {
                source: DeviceError::Stopped(_),
                ..
            } | MeasureError::Aim {
                source: DeviceError::Stopped(_),
                ..
            }
        )
    }

    /// True when the meter itself failed (timeout, garbled, I/O): the run can be resumed
    /// after fixing the instrument.
    pub fn is_meter_failure(&self) -> bool {
        matches!(self, MeasureError::Reading { .. })
    }
}

fn hint_for(e: &DeviceError) -> String {
    match e {
        DeviceError::Timeout { .. } => {
            "Check the meter's cable, power and port; then re-run with --resume to continue \
             from the last completed display"
                .into()
        }
        DeviceError::Garbled { .. } => {
            "Check baud rate and cable (noise on the line); then re-run with --resume".into()
        }
        DeviceError::OverRange { .. } => {
            "The display is too bright for the meter: fit a neutral-density filter or lower \
             the projector's lamp mode"
                .into()
        }
        DeviceError::TooDark { .. } => {
            "Check that the meter is aimed at the lit display and its lens cap is off".into()
        }
        DeviceError::Io { .. } => "Check that the port still exists (USB unplugged?)".into(),
        _ => "Check the meter and re-run with --resume".into(),
    }
}

/// The XYZ of a mean in xyY. A component a saturated colour does not have (an Infitec
/// red's Z, where x + y = 1) comes out of `(1 − x − y)·Y/y` as a rounding residue that
/// may be just below zero; no light has a negative tristimulus value, so it is 0.
fn xyy_mean(x: f64, y: f64, lum: f64) -> Xyz {
    let v = Xyz::from_xy_luminance(x, y, lum);
    Xyz::new(v.x.max(0.0), v.y.max(0.0), v.z.max(0.0))
}

/// The three devices a measurement talks to.
pub struct Rig<'a> {
    /// Shows patterns.
    pub pattern: &'a mut dyn PatternOutput,
    /// Reads XYZ.
    pub meter: &'a mut dyn Colorimeter,
    /// Aims the meter.
    pub positioner: &'a mut dyn MeterPositioner,
}

/// The meter's correction for `display`'s type that `opts` carries, if any.
fn correction_for(opts: &MeasureOptions, display: &DisplayKey) -> Option<nalgebra::Matrix3<f64>> {
    opts.meter_matrix
        .as_ref()
        .and_then(|m| m.for_display(display.display, display.eye))
}

/// A reading as the meter gave it, with `correction` applied where there is one.
fn corrected(correction: Option<&nalgebra::Matrix3<f64>>, xyz: Xyz) -> Xyz {
    match correction {
        Some(m) => meter_matrix::apply(m, xyz),
        None => xyz,
    }
}

/// `display`'s black from every reading of it in its log
/// ([`MeasureLog::black_readings`]), the display's `primaries` as measured: their mean
/// with those the meter refused as too dark counted ([`CensoredReadings::mean`], the
/// meter's stated `noise`), corrected by the meter's correction in `opts`. Where the
/// meter refused them all, the luminance they leave ([`CensoredReadings::below_floor_y`])
/// at the chromaticity of the display's white: the readings give no colour, and a
/// projector's black is its lamp's light leaking through all three channels. `None`
/// when the log holds none (written before it kept them) or the meter states no noise
/// and refused them all.
pub fn black_of(
    log: &MeasureLog,
    noise: Option<&ReadingNoise>,
    opts: &MeasureOptions,
    display: &DisplayKey,
    primaries: &[Xyz; 3],
) -> Option<Xyz> {
    let correction = correction_for(opts, display);
    black_from(&log.black_readings, noise, correction.as_ref(), primaries)
}

/// [`black_of`] from the readings themselves.
fn black_from(
    readings: &CensoredReadings,
    noise: Option<&ReadingNoise>,
    correction: Option<&nalgebra::Matrix3<f64>>,
    primaries: &[Xyz; 3],
) -> Option<Xyz> {
    if let Some(mean) = readings.mean(noise) {
        return Some(corrected(correction, mean));
    }
    let y = readings.below_floor_y(noise)?;
    let white = primaries[0] + primaries[1] + primaries[2];
    (white.y > 0.0).then(|| white * (y / white.y))
}

/// The `DisplayKey` of a display of wall `wall`.
pub fn display_key(wall: &str, info: &DisplayInfo) -> DisplayKey {
    DisplayKey {
        wall: wall.to_string(),
        display: info.id.0,
        tile_col: info.tile_col,
        tile_row: info.tile_row,
        eye: info.eye,
    }
}

/// Session state for one display: counts readings, retries transient errors, applies
/// the low-light policy.
pub struct Session<'r, 'a> {
    rig: &'r mut Rig<'a>,
    id: DisplayId,
    name: String,
    /// The meter's correction for this display's type, if any.
    correction: Option<nalgebra::Matrix3<f64>>,
    budget: u32,
    max_retries: u32,
    limit_cd_m2: f64,
    low_light: LowLight,
    /// The meter's stated noise, against which the spread of repeated readings is
    /// taken ([`noise_seen`]).
    noise: Option<ReadingNoise>,
    /// The readings of the patch on show so far.
    spread: Option<noise_seen::PatchSpread>,
    /// The same readings as the instrument gave them (before the meter's correction;
    /// behind each averaged reading, its own), with those it refused as too dark: what
    /// their mean is taken from ([`Session::shown_mean`]).
    shown: CensoredReadings,
    /// The stated noise of one of the instrument's own readings
    /// ([`Colorimeter::instrument_noise`]), with which refused ones count.
    instrument_noise: Option<ReadingNoise>,
    /// Each sample's first reading is taken even with the budget spent
    /// ([`Session::essential`]).
    essential: bool,
    /// The log so far.
    pub log: MeasureLog,
}

impl<'r, 'a> Session<'r, 'a> {
    /// Starts a session on `display`: aims the meter at `uv`.
    pub fn start(
        rig: &'r mut Rig<'a>,
        display: &DisplayKey,
        id: DisplayId,
        uv: [f64; 2],
        opts: &MeasureOptions,
    ) -> Result<Self, MeasureError> {
        let name = display.to_string();
        let aim_err = |source| MeasureError::Aim {
            display: name.clone(),
            uv,
            source,
        };
        rig.positioner.aim(id, uv).map_err(aim_err)?;
        let aids = AimingAids {
            pattern: &mut *rig.pattern,
            meter: &mut *rig.meter,
        };
        rig.positioner
            .confirm(id, &name, uv, aids)
            .map_err(aim_err)?;
        let limit_cd_m2 = opts
            .low_light_limit_cd_m2
            .unwrap_or_else(|| rig.meter.info().min_reliable_cd_m2)
            .max(0.0);
        let noise = rig.meter.info().noise;
        let instrument_noise = rig.meter.instrument_noise();
        Ok(Self {
            rig,
            id,
            name,
            correction: correction_for(opts, display),
            budget: opts.budget,
            max_retries: opts.max_retries,
            limit_cd_m2,
            low_light: opts.low_light,
            noise,
            spread: None,
            shown: CensoredReadings::default(),
            instrument_noise,
            essential: false,
            log: MeasureLog {
                low_light_limit_cd_m2: limit_cd_m2,
                low_light: Some(opts.low_light),
                ..MeasureLog::default()
            },
        })
    }

    /// Readings still allowed.
    pub fn remaining(&self) -> u32 {
        self.budget.saturating_sub(self.log.readings)
    }

    /// Runs `read` with each sample's first reading taken even where the budget is
    /// spent (its repeats stay within it): the black and the primaries, without which
    /// there is no display model (a budget too small for the ramps then fails with
    /// [`MeasureError::RampBudgetSpent`]), and a recalibration's check, whose every
    /// sample is compared.
    pub(crate) fn essential<T>(&mut self, read: impl FnOnce(&mut Self) -> T) -> T {
        let was = std::mem::replace(&mut self.essential, true);
        let out = read(self);
        self.essential = was;
        out
    }

    /// [`Session::sample`], always averaged in the dark, read once even where the
    /// budget is spent (its repeats stay within it): a sample without which a display
    /// model or a recalibration's check cannot do (the black, the primaries, the
    /// check's white and mid-drive samples).
    pub fn essential_sample(
        &mut self,
        patch: Patch,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<Option<Xyz>, MeasureError> {
        self.essential(|s| s.sample(patch, true, progress))
    }

    /// One meter reading with bounded retries of transient errors. A reading the meter
    /// refuses as too dark ([`DeviceError::TooDark`]) costs a reading and gives `None`.
    fn read_once(
        &mut self,
        patch: Patch,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<Option<Xyz>, MeasureError> {
        let reading = self.log.readings + 1;
        let mut attempts = 0;
        loop {
            attempts += 1;
            let result = match self.rig.meter.measure() {
                Ok(xyz) if !xyz.is_finite() || xyz.y < -1e-6 => {
                    return Err(MeasureError::Invalid {
                        display: self.name.clone(),
                        reading,
                        patch,
                        xyz,
                    });
                }
                Ok(xyz) => {
                    self.tally(patch, Ok(xyz));
                    let xyz = self.corrected(xyz);
                    let seen = &mut self.log.noise_seen;
                    noise_seen::PatchSpread::add(&mut self.spread, seen, self.noise.as_ref(), xyz);
                    Some(xyz)
                }
                Err(DeviceError::TooDark { limit_cd_m2, .. }) => {
                    self.tally(patch, Err(limit_cd_m2));
                    None
                }
                Err(e) if e.is_transient() && attempts <= self.max_retries => {
                    tracing::warn!(display = %self.name, %patch, "transient meter error, retrying: {e}");
                    self.log.retries += 1;
                    continue;
                }
                Err(source) => {
                    return Err(MeasureError::Reading {
                        display: self.name.clone(),
                        reading,
                        patch,
                        attempts,
                        hint: hint_for(&source),
                        source,
                    });
                }
            };
            self.log.readings += 1;
            progress(Progress::Reading {
                display: self.id,
                readings: self.log.readings,
                budget: self.budget,
                patch,
            });
            return Ok(result);
        }
    }

    /// Shows `patch` and reads it, applying the low-light policy. A reading below the
    /// reliable limit (or refused as too dark) is repeated and the readings averaged,
    /// the refused ones counted ([`CensoredReadings::mean`]), under [`LowLight::Average`],
    /// or always when `always_average` is set
    /// (black, primaries); under [`LowLight::Skip`] the sample is dropped. Returns
    /// `None` when the sample was skipped, every reading was refused as too dark, or
    /// the display's budget was already spent (then nothing is shown or read): no
    /// reading, the first included, exceeds the budget (except an essential sample's
    /// first: [`Session::essential_sample`]).
    pub fn sample(
        &mut self,
        patch: Patch,
        always_average: bool,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<Option<Xyz>, MeasureError> {
        self.sample_until(patch, always_average, None, Repeats::ANY, progress)
    }

    /// [`Session::sample`] of one channel alone, averaged in the dark only as often as
    /// its line's stated noise needs ([`ChannelLine::repeats_needed`]), at most as the
    /// low-light policy says and at most [`DARK_CHANNEL_REPEATS`] (exactly that when the
    /// meter states no noise).
    pub fn sample_channel(
        &mut self,
        patch: Patch,
        line: &ChannelLine,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<Option<Xyz>, MeasureError> {
        self.sample_until(patch, false, Some(line), Repeats::ANY, progress)
    }

    /// [`Session::sample_channel`] averaged over at least `repeats.at_least` readings,
    /// in the light too, and over at most `repeats.at_most` (at least one), whatever the
    /// low-light policy or the line asks: a sample that must leave readings for others.
    /// Never more than the budget leaves.
    pub fn sample_channel_averaged(
        &mut self,
        patch: Patch,
        line: &ChannelLine,
        repeats: Repeats,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<Option<Xyz>, MeasureError> {
        self.sample_until(patch, false, Some(line), repeats, progress)
    }

    fn sample_until(
        &mut self,
        patch: Patch,
        always_average: bool,
        line: Option<&ChannelLine>,
        bounds: Repeats,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<Option<Xyz>, MeasureError> {
        if self.remaining() == 0 && !self.essential {
            tracing::debug!(display = %self.name, %patch, "budget spent: not read");
            return Ok(None);
        }
        let at_most = bounds.at_most.max(1);
        self.show(patch)?;
        let first = self.read_once(patch, progress)?;
        if let Some(x) = first.filter(|x| x.y >= self.limit_cd_m2) {
            let more = bounds.at_least.min(at_most).saturating_sub(1);
            let (more, _) = self.read_into(patch, more, progress)?;
            let mean = self.shown_mean().unwrap_or(x);
            self.log.samples.push(ReadingRecord {
                patch,
                xyz: Some(mean),
                repeats: 1 + more,
                low_light: false,
            });
            return Ok(Some(mean));
        }
        let repeats = self.dark_repeats(always_average);
        let repeats = if line.is_some() {
            repeats.min(DARK_CHANNEL_REPEATS)
        } else {
            repeats
        };
        let repeats = match (line, first) {
            (Some(l), Some(x)) if repeats > 0 => repeats.min(l.repeats_needed(x)),
            _ => repeats,
        };
        let repeats = if repeats > 0 {
            repeats.max(bounds.at_least).min(at_most)
        } else {
            repeats
        };
        // Average in XYZ: in the dark a colorimeter's noise is its sensors' zero-light
        // noise, Gaussian in X, Y and Z (in x and y it has heavy tails: x = X/(X+Y+Z)).
        // Readings refused as too dark count in the mean's luminance.
        let (more, _) = self.read_into(patch, repeats.saturating_sub(1), progress)?;
        let mean = if repeats > 0 { self.shown_mean() } else { None };
        self.log.samples.push(ReadingRecord {
            patch,
            xyz: mean,
            repeats: 1 + more,
            low_light: true,
        });
        Ok(mean)
    }

    /// Readings the low-light policy averages for a patch whose first reading of `y_cd_m2`
    /// (cd/m²) says what it shows: one at or above the reliable limit; below it the
    /// policy's repeats under [`LowLight::Average`], and under [`LowLight::Skip`] four
    /// where the patch is always averaged (black, primaries) and none otherwise.
    fn readings_for(&self, y_cd_m2: f64, always_average: bool) -> u32 {
        if y_cd_m2 >= self.limit_cd_m2 {
            1
        } else {
            self.dark_repeats(always_average)
        }
    }

    /// The low-light policy's readings for a patch below the reliable limit
    /// ([`Session::readings_for`]).
    fn dark_repeats(&self, always_average: bool) -> u32 {
        match (self.low_light, always_average) {
            (LowLight::Skip, false) => 0,
            _ => self.low_light.black_readings(),
        }
    }

    /// Reads the patch `patch` already shown `n` more times (what the budget leaves at
    /// most) and averages them with its reading `first` in XYZ, in the log's last
    /// record.
    fn average_more(
        &mut self,
        patch: Patch,
        first: Xyz,
        n: u32,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<(), MeasureError> {
        let (more, _) = self.read_into(patch, n, progress)?;
        let mean = self.shown_mean().unwrap_or(first);
        if let Some(r) = self.log.samples.last_mut() {
            r.xyz = Some(mean);
            r.repeats = 1 + more;
        }
        Ok(())
    }

    /// Reads the patch already shown up to `n` times (at most what the budget leaves),
    /// each reading into the patch's readings ([`Session::shown_mean`]). Returns the
    /// readings taken and those that gave a value (the others were refused as too
    /// dark), both in the session's readings (an averaged reading is one).
    fn read_into(
        &mut self,
        patch: Patch,
        n: u32,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<(u32, u32), MeasureError> {
        let n = n.min(self.remaining());
        let mut given = 0;
        for _ in 0..n {
            if self.read_once(patch, progress)?.is_some() {
                given += 1;
            }
        }
        Ok((n, given))
    }

    /// The mean of the readings of the patch on show, with the meter's correction
    /// (applied to the mean, where the old per-reading average clamped each corrected
    /// reading at 0): where the meter refused some as too dark, their luminance counts
    /// ([`CensoredReadings::mean`] with the noise of one of the instrument's readings),
    /// so a black near the meter's floor is not biased high by the readings its noise
    /// lifted. An averaged reading ([`lumiwall_devices::AveragingMeter`]) counts as the
    /// instrument's readings behind it. `None` when every reading was refused or none
    /// was taken.
    fn shown_mean(&self) -> Option<Xyz> {
        let mean = self.shown.mean(self.instrument_noise.as_ref())?;
        Some(self.corrected(mean))
    }

    /// Adds the last reading of `patch`, given (`Ok`) or refused below the floor
    /// (`Err`), to the patch's readings and, for the black, to the log's: the
    /// instrument's own readings behind it where the meter averages
    /// ([`Colorimeter::readings_behind_last`]), else the reading itself.
    fn tally(&mut self, patch: Patch, reading: Result<Xyz, f64>) {
        let mut one = CensoredReadings::default();
        match (self.rig.meter.readings_behind_last(), reading) {
            (Some(behind), _) => one = behind,
            (None, Ok(xyz)) => one.add(xyz),
            (None, Err(floor_cd_m2)) => one.add_refused(floor_cd_m2),
        }
        self.shown.merge(&one);
        if patch == Patch::Black {
            self.log.black_readings.merge(&one);
        }
    }

    /// A reading as the meter gave it, with the meter's correction for this display's
    /// type where there is one.
    fn corrected(&self, xyz: Xyz) -> Xyz {
        corrected(self.correction.as_ref(), xyz)
    }

    /// The black from every reading of it in this session, of a display with these
    /// `primaries` ([`black_of`]).
    fn black_estimate(&self, primaries: &[Xyz; 3]) -> Option<Xyz> {
        black_from(
            &self.log.black_readings,
            self.instrument_noise.as_ref(),
            self.correction.as_ref(),
            primaries,
        )
    }
}

impl Session<'_, '_> {
    /// Shows `patch` on the session's display.
    fn show(&mut self, patch: Patch) -> Result<(), MeasureError> {
        self.spread = None;
        self.shown = CensoredReadings::default();
        self.rig
            .pattern
            .show(self.id, patch.drive())
            .map_err(|source| MeasureError::Pattern {
                display: self.name.clone(),
                patch,
                source,
            })
    }

    /// Shows `patch` and averages `repeats` readings in XYZ (at most what the budget
    /// leaves), whatever their light: re-reads whose number is decided elsewhere (the
    /// black, with what the grey-drive pass leaves of a display's budget). Logs one
    /// record. Returns the mean and the readings in it; `None` when none came (every
    /// one refused as too dark, or no budget left).
    pub fn averaged(
        &mut self,
        patch: Patch,
        repeats: u32,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<Option<(Xyz, u32)>, MeasureError> {
        let n = repeats.min(self.remaining());
        if n == 0 {
            return Ok(None);
        }
        self.show(patch)?;
        let (n, ok) = self.read_into(patch, n, progress)?;
        let mean = self.shown_mean();
        self.log.samples.push(ReadingRecord {
            patch,
            xyz: mean,
            repeats: n,
            low_light: mean.is_none_or(|m| m.y < self.limit_cd_m2),
        });
        Ok(mean.map(|m| (m, ok)))
    }

    /// Shows `patch` and averages `repeats` readings (in xyY), or more under the
    /// low-light policy when the patch is dark, never more than the budget leaves.
    /// `None` when every reading was refused as too dark or the budget was spent.
    pub fn repeated(
        &mut self,
        patch: Patch,
        repeats: u32,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<Option<Xyz>, MeasureError> {
        let first = self.sample(patch, true, progress)?;
        let Some(first) = first else {
            return Ok(None);
        };
        if first.y < self.limit_cd_m2 || repeats <= 1 {
            return Ok(Some(first));
        }
        let mut sum = [0.0f64; 3];
        let mut n = 0.0;
        let more = (repeats - 1).min(self.remaining());
        for x in std::iter::once(Some(first)).chain(
            (0..more)
                .map(|_| self.read_once(patch, progress))
                .collect::<Result<Vec<_>, _>>()?,
        ) {
            if let (Some(x), Some(c)) = (x, x.and_then(|v| v.xy())) {
                add_xyy(&mut sum, c, x.y);
                n += 1.0;
            }
        }
        let mean = xyy_mean(sum[0] / n, sum[1] / n, sum[2] / n);
        if let Some(r) = self.log.samples.last_mut() {
            r.xyz = Some(mean);
            r.repeats = n as u32;
        }
        Ok(Some(mean))
    }
}

/// A dark single-channel reading with its unreliable chromaticity replaced: black plus
/// the channel's full-drive colour scaled to the reading's luminance above black.
/// Below the meter's reliable limit only the luminance of a reading is kept (a
/// channel's chromaticity above black is constant; the meter's xy noise at low light
/// is not).
pub fn luminance_only(reading: Xyz, black: Xyz, full: Xyz) -> Xyz {
    let span = full.y - black.y;
    if span <= 0.0 {
        return reading;
    }
    let k = ((reading.y - black.y) / span).max(0.0);
    black + (full - black) * k
}

/// A single-channel reading on the channel's line: black plus the channel's
/// black-subtracted full-drive XYZ scaled by the reading's weighted least-squares
/// component along it, each of X, Y and Z weighted by the inverse of its variance under
/// the meter's stated `noise`. In the dark a filter colorimeter's noise is its sensors'
/// zero-light noise, the same few mcd/m² in X, Y and Z, so the strongest component of a
/// dim saturated channel carries it (the Z of a dark blue, whose Y is a few per cent
/// of it); at high light Y's small relative noise does. Without stated noise, or for a
/// noiseless meter, only the luminance counts ([`luminance_only`]).
pub fn channel_reading(reading: Xyz, black: Xyz, full: Xyz, noise: Option<&ReadingNoise>) -> Xyz {
    let Some(noise) = noise else {
        return luminance_only(reading, black, full);
    };
    let sigma = noise.sigma_xyz(reading);
    if sigma.iter().any(|s| s.is_nan() || *s <= 0.0) {
        return luminance_only(reading, black, full);
    }
    let p = (full - black).to_array();
    let m = (reading - black).to_array();
    let (mut num, mut den) = (0.0, 0.0);
    for k in 0..3 {
        let w = 1.0 / (sigma[k] * sigma[k]);
        num += w * p[k] * m[k];
        den += w * p[k] * p[k];
    }
    if den.is_nan() || den <= 0.0 {
        return luminance_only(reading, black, full);
    }
    black + (full - black) * (num / den).max(0.0)
}

/// Largest relative standard error of a dark single-channel sample's intensity that
/// needs no repeat: 1 % of a channel's intensity moves a dark grey by about 0.002 in
/// xy, which at the lightness of 1–5 % of the white is 0.2–0.4 ΔC' (a* and b* are steep
/// there: on heyewall-48 a green 3 % low put a 5 % grey 1.1 off). Tighter costs the
/// ramps more than it gives at 40 readings (0.5 % and up to 8 repeats: heyewall-48's
/// worst grey balance 0.43 → 1.1).
pub const DARK_SAMPLE_REL_SIGMA: f64 = 0.01;

/// Most readings a single-channel sample averages below the meter's reliable limit,
/// however many the low-light policy gives a dark black, primary or grey: two samples
/// at two drives pin a dark tone curve better than four readings at one, where one
/// reading alone leaves a dim channel's sample too noisy. A dim wall's toes are all
/// below the limit (a 12 cd/m² white's red at drive 0.5 shows about 0.9 cd/m²), so
/// there every ramp sample took four readings and 40 left each channel three or four
/// samples. Realistic meter, 40 readings, unseen seeds 101–340 (heyewall-48: 101–160),
/// runs within every limit of issue 12 with four / two / one: dim-mono-2x1 135 / 141 /
/// 132 of 240 (mean worst grey balance 0.500 / 0.482 / 0.497), dim-infitec-pair 160 /
/// 180 / 187 (0.466 / 0.437 / 0.419), dim-lcd-3x2 230 / 229 / 233, weak-channel-3x1
/// 237 / 239 / 234 (0.311 / 0.300 / 0.314), heyewall-48 60 / 60 / 60 of 60 (0.385 /
/// 0.378 / 0.371). Two for every dark reading (`--low-light avg:2`: the black, a dim
/// primary and the split grey as well) took heyewall-48 to 55 of 60 (mean worst grey
/// balance 0.403; its black read twice instead of four times) and dim-lcd-3x2 to 214.
pub const DARK_CHANNEL_REPEATS: u32 = 2;

/// How many readings a sample averages at least and at most, whatever the low-light
/// policy asks ([`Session::sample_channel_averaged`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Repeats {
    /// Readings averaged at least, in the light too.
    pub at_least: u32,
    /// Readings averaged at most (at least one is always taken).
    pub at_most: u32,
}

impl Repeats {
    /// One reading, or as many as the low-light policy asks in the dark.
    pub const ANY: Repeats = Repeats {
        at_least: 1,
        at_most: u32::MAX,
    };
}

/// A channel's line in XYZ (its black and full-drive readings) and the meter's stated
/// noise: what a single-channel sample is judged against.
#[derive(Debug, Clone, Copy)]
pub struct ChannelLine {
    /// The display's black.
    pub black: Xyz,
    /// The channel at full drive.
    pub full: Xyz,
    /// The meter's stated noise of one reading (`None`: not stated).
    pub noise: Option<ReadingNoise>,
}

impl ChannelLine {
    /// A reading of the channel alone put on the line ([`channel_reading`]).
    pub fn reading(&self, raw: Xyz) -> Xyz {
        channel_reading(raw, self.black, self.full, self.noise.as_ref())
    }

    /// Standard error of one reading's weighted intensity along the line (in shares of
    /// the full drive's light above black), for a reading near `raw`: `1/√(Σ pₖ²/σₖ²)`,
    /// the Fisher information along the channel's black-subtracted colour `p` with each
    /// sensor's `σₖ` as the stated noise gives it for `raw`. `None` without stated
    /// noise, or where no sensor carries information.
    pub fn intensity_sigma(&self, raw: Xyz) -> Option<f64> {
        let sigma = self.noise?.sigma_xyz(raw);
        let p = (self.full - self.black).to_array();
        let info: f64 = (0..3)
            .filter(|&k| sigma[k] > 0.0)
            .map(|k| (p[k] / sigma[k]).powi(2))
            .sum();
        (info.is_finite() && info > 0.0).then(|| 1.0 / info.sqrt())
    }

    /// Readings to average for a sample whose first reading is `first`, so that the
    /// standard error of its weighted intensity ([`channel_reading`]) is at most
    /// [`DARK_SAMPLE_REL_SIGMA`] of the intensity: from the Fisher information
    /// Σ pₖ²/σₖ² of one reading along the channel's black-subtracted colour `p`.
    /// Without stated noise, `u32::MAX` (the low-light policy decides).
    pub fn repeats_needed(&self, first: Xyz) -> u32 {
        let Some(sigma) = self.intensity_sigma(first) else {
            return u32::MAX;
        };
        let r = relative_intensity(self.reading(first), self.black, self.full);
        if r.is_nan() || r <= 0.0 {
            return u32::MAX;
        }
        let rel = sigma / r;
        let n = (rel / DARK_SAMPLE_REL_SIGMA).powi(2).ceil();
        if n >= f64::from(u32::MAX) {
            u32::MAX
        } else {
            (n as u32).max(1)
        }
    }
}

/// Relative intensity of a channel reading: the least-squares component of
/// `reading − black` along the channel's black-subtracted full-drive XYZ.
pub fn relative_intensity(reading: Xyz, black: Xyz, full: Xyz) -> f64 {
    let p = (full - black).to_array();
    let m = (reading - black).to_array();
    let pp: f64 = p.iter().map(|v| v * v).sum();
    if pp <= 0.0 {
        return 0.0;
    }
    p.iter().zip(m.iter()).map(|(a, b)| a * b).sum::<f64>() / pp
}

/// Measures one display in one visit: black, primaries, white (as
/// [`survey_display`]), then adaptive ramps until the budget is spent or every
/// channel's ramp is good enough (as [`measure_ramps`]).
pub fn measure_display(
    rig: &mut Rig<'_>,
    info: &DisplayInfo,
    key: &DisplayKey,
    opts: &MeasureOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<MeasuredDisplay, MeasureError> {
    let mut s = start_within_budget(rig, info, key, opts)?;
    let survey = survey_in(&mut s, key, opts, progress)?;
    ramps_in(&mut s, info, key, survey, opts, progress)
}

/// What [`survey_display`] read: black, the primaries and white at full drive, and the
/// log of those readings.
#[derive(Debug, Clone)]
pub struct Survey {
    /// Reading at drive (0, 0, 0).
    pub black: Xyz,
    /// Readings at full drive of R, G, B alone, black included.
    pub primaries: [Xyz; 3],
    /// Reading at full drive W (`None` unless [`MeasureOptions::measure_white`]).
    pub white: Option<Xyz>,
    /// The readings so far: the ramps continue it within the same budget.
    pub log: MeasureLog,
}

/// The first half of [`measure_display`]: black, the primaries and (if asked) white.
/// Where the meter can be aimed again at no cost (a mount, the simulator:
/// [`lumiwall_devices::MeterPositioner::revisits_cheaply`]), a wall's displays are all
/// surveyed before any ramp is read, so that every display's ramps are focused on the
/// part of its channels the wall white will use ([`MeasureOptions::focus`]), the first
/// display's too.
pub fn survey_display(
    rig: &mut Rig<'_>,
    info: &DisplayInfo,
    key: &DisplayKey,
    opts: &MeasureOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Survey, MeasureError> {
    let mut s = start_within_budget(rig, info, key, opts)?;
    survey_in(&mut s, key, opts, progress)
}

/// The second half of [`measure_display`]: the adaptive ramps of a surveyed display,
/// within what the survey left of the budget.
pub fn measure_ramps(
    rig: &mut Rig<'_>,
    info: &DisplayInfo,
    key: &DisplayKey,
    survey: Survey,
    opts: &MeasureOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<MeasuredDisplay, MeasureError> {
    let mut s = Session::start(rig, key, info.id, opts.spot_uv, opts)?;
    ramps_in(&mut s, info, key, survey, opts, progress)
}

/// A session on `info` once the budget is known to be workable
/// ([`MeasureOptions::MIN_BUDGET`]).
fn start_within_budget<'r, 'a>(
    rig: &'r mut Rig<'a>,
    info: &DisplayInfo,
    key: &DisplayKey,
    opts: &MeasureOptions,
) -> Result<Session<'r, 'a>, MeasureError> {
    if opts.budget < MeasureOptions::MIN_BUDGET {
        return Err(MeasureError::BudgetTooSmall {
            budget: opts.budget,
            min: MeasureOptions::MIN_BUDGET,
        });
    }
    Session::start(rig, key, info.id, opts.spot_uv, opts)
}

/// Black, primaries and white in session `s`; the survey takes the session's log.
fn survey_in(
    s: &mut Session<'_, '_>,
    key: &DisplayKey,
    opts: &MeasureOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Survey, MeasureError> {
    let (black, primaries) = measure_black_and_primaries(s, key, opts, progress)?;
    let white = if opts.measure_white {
        let noise = s.rig.meter.info().noise;
        s.repeated(Patch::White, opts.white_repeats(noise.as_ref()), progress)?
    } else {
        None
    };
    Ok(Survey {
        black,
        primaries,
        white,
        log: std::mem::take(&mut s.log),
    })
}

/// The ramps of a surveyed display in session `s`, continuing the survey's log.
fn ramps_in(
    s: &mut Session<'_, '_>,
    info: &DisplayInfo,
    key: &DisplayKey,
    survey: Survey,
    opts: &MeasureOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<MeasuredDisplay, MeasureError> {
    let instrument = {
        let i = s.rig.meter.info();
        format!("{} {}", i.model, i.serial)
    };
    let Survey {
        black,
        primaries,
        white,
        log,
    } = survey;
    s.log = log;
    let black = black_for_darkest_grey(s, black, &primaries, opts, progress)?;
    let noise = s.rig.meter.info().noise;
    let mut ramps = RampPlanner::new(black, primaries, info.bit_depth, opts, noise);
    ramps.measure(s, opts, progress)?;
    ramps.check_measurable(key, s)?;
    let (primaries, ramps) = channel_colour::pool(&s.log, black, primaries, noise);
    let ramp_sigma_rel = channel_colour::ramp_sigma_rel(&s.log, black, primaries, noise);
    let readings = s.log.readings;
    let log = std::mem::take(&mut s.log);
    progress(Progress::DisplayDone {
        display: info.id,
        readings,
    });
    Ok(MeasuredDisplay {
        measurement: DisplayMeasurement {
            key: key.clone(),
            bit_depth: info.bit_depth,
            black,
            primaries,
            white,
            ramps,
            readings,
            instrument,
            composites: Vec::new(),
            ramp_sigma_rel,
        },
        log,
        anchor: None,
        ageing: None,
    })
}

/// Black (always averaged when dark, as it usually is; a black the meter refuses as too
/// dark on every repeat takes the luminance the refusals leave, [`black_of`]) and the
/// three full-drive primaries, each of which must be brighter than black.
pub(crate) fn measure_black_and_primaries(
    s: &mut Session<'_, '_>,
    key: &DisplayKey,
    opts: &MeasureOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<(Xyz, [Xyz; 3]), MeasureError> {
    s.essential(|s| black_and_primaries_in(s, key, opts, progress))
}

/// [`measure_black_and_primaries`] inside [`Session::essential`].
fn black_and_primaries_in(
    s: &mut Session<'_, '_>,
    key: &DisplayKey,
    opts: &MeasureOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<(Xyz, [Xyz; 3]), MeasureError> {
    let read_black = s.sample(Patch::Black, true, progress)?;
    let black = read_black.unwrap_or_default();
    let mut primaries = [Xyz::default(); 3];
    let primary_repeats = opts.primary_repeats();
    for c in Channel::ALL {
        let p = s
            .repeated(Patch::Primary(c), primary_repeats, progress)?
            .unwrap_or_default();
        primaries[c.index()] = p;
        // Not brighter than black: below the meter's limit the meter is the likelier
        // cause (a dim display reads as nothing); above it, the display or the aim.
        if p.y <= black.y && p.y < s.limit_cd_m2 {
            return Err(MeasureError::BelowMeterLimit {
                display: key.to_string(),
                channel: c.name(),
                y_cd_m2: p.y,
                limit_cd_m2: s.limit_cd_m2,
                meter: s.rig.meter.info().model,
            });
        }
        if p.y <= black.y {
            return Err(MeasureError::NoSignal {
                display: key.to_string(),
                channel: c.name(),
                y_cd_m2: p.y,
                black_cd_m2: black.y,
            });
        }
    }
    // Every reading of the black refused as too dark: the luminance they leave.
    let black = read_black
        .or_else(|| s.black_estimate(&primaries))
        .unwrap_or_default();
    Ok((black, primaries))
}

/// The black from its first readings and as many more as the darkest grey of the wall
/// white this display is expected to show needs ([`black_readings::for_darkest_grey`]),
/// all pooled ([`black_of`]):
/// the white of `opts.focus` at the luminance the display reaches (at most the wall's
/// so far). Unchanged without a focus or a meter that states its noise.
fn black_for_darkest_grey(
    s: &mut Session<'_, '_>,
    black: Xyz,
    primaries: &[Xyz; 3],
    opts: &MeasureOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Xyz, MeasureError> {
    let (Some(noise), Some(f)) = (s.rig.meter.info().noise, opts.focus) else {
        return Ok(black);
    };
    let Some((white_y, _)) = f.expected_white(black, primaries) else {
        return Ok(black);
    };
    let grey = black_readings::darkest_grey(f.white_xy, white_y);
    let (needed, allowed) = black_readings::for_darkest_grey(&noise, black, grey, opts.budget);
    let have = s.log.readings_of(Patch::Black);
    if needed > allowed && needed > have {
        warn_black_short(
            &s.name,
            grey.y,
            white_y,
            needed,
            allowed.max(have),
            opts.budget,
        );
    }
    let want = needed.min(allowed);
    if want <= have {
        return Ok(black);
    }
    s.averaged(Patch::Black, want - have, progress)?;
    Ok(s.black_estimate(primaries).unwrap_or(black))
}

/// Tells the technician that display `name`'s black gets fewer readings (`allowed`)
/// than the darkest grey of a `white_y_cd_m2` wall white needs (`needed`).
fn warn_black_short(
    name: &str,
    grey_y_cd_m2: f64,
    white_y_cd_m2: f64,
    needed: u32,
    allowed: u32,
    budget: u32,
) {
    tracing::warn!(
        display = %name,
        "the black needs {needed} readings for the chart's darkest grey ({grey_y_cd_m2:.2} \
         cd/m², {:.0} % of the wall white of {white_y_cd_m2:.1} cd/m²) to within {:.1} %; \
         {budget} readings per display allow {allowed}, so the darkest greys will carry \
         the meter's noise (more readings per display, or a meter quieter in the dark, \
         help)",
        100.0 * black_readings::DARKEST_GREY_SHARE,
        100.0 * black_readings::BLACK_REL_SE,
    );
}

/// Adaptive placement of the ramp samples of one display, one sample per channel in
/// turn, and the samples taken so far.
struct RampPlanner {
    black: Xyz,
    primaries: [Xyz; 3],
    /// Expected usage of each channel for the wall white: ramp samples are placed as if
    /// that were the full range.
    usage: [f64; 3],
    depth: BitDepth,
    /// Raw (luminance-only) samples per channel, in the order taken.
    ramps: [Vec<(f64, Xyz)>; 3],
    /// `(drive, relative intensity)` per channel, sorted by drive, with (0, 0) and (1, 1).
    rel: [Vec<(f64, f64)>; 3],
    /// The meter's stated noise, weighting each sample's X, Y and Z.
    noise: Option<ReadingNoise>,
}

impl RampPlanner {
    fn new(
        black: Xyz,
        primaries: [Xyz; 3],
        bit_depth: u32,
        opts: &MeasureOptions,
        noise: Option<ReadingNoise>,
    ) -> Self {
        let usage = opts
            .focus
            .and_then(|f| f.expected_white(black, &primaries))
            .map(|(y, per_cd)| per_cd.map(|v| (v * y).clamp(MIN_EXPECTED_USAGE, 1.0)))
            .unwrap_or([1.0; 3]);
        Self {
            black,
            primaries,
            usage,
            depth: crate::solve::clamped_bit_depth(bit_depth),
            ramps: Default::default(),
            rel: std::array::from_fn(|_| vec![(0.0, 0.0), (1.0, 1.0)]),
            noise,
        }
    }

    /// Adaptive ramps, then (Common black mode) the toe samples and the rest of the
    /// budget adaptively again.
    fn measure(
        &mut self,
        s: &mut Session<'_, '_>,
        opts: &MeasureOptions,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<(), MeasureError> {
        // Toe samples (Common black mode) are taken once the adaptive ramps have given
        // a first estimate of each curve. The reserve is three low-light averages of the
        // policy's repeats, though a toe sample averages at most DARK_CHANNEL_REPEATS:
        // what the toe samples leave goes to the adaptive ramps after them, placed
        // knowing the toe. Reserving only what they take (realistic meter, 40
        // readings, `--black common`, seeds 101–160; heyewall-48 101–120; means of the
        // worst display's figure) left heyewall-48's grey balance at 0.343 instead of
        // 0.298 and infitec-pair's white ΔE2000 at 0.49 instead of 0.44; dim-mono-2x1
        // met every limit on 26 runs instead of 22, dim-infitec-pair on 55 instead of
        // 56.
        let toe = opts.focus.is_some_and(|f| f.toe_samples);
        let repeats_dark = match opts.low_light {
            LowLight::Average { repeats } => repeats.max(1),
            LowLight::Skip => 1,
        };
        let reserve = if toe { 3 * repeats_dark } else { 0 };
        self.adaptive(s, reserve + opts.reserved, progress)?;
        if toe {
            self.toe(s, opts, progress)?;
            self.adaptive(s, opts.reserved, progress)?;
        }
        Ok(())
    }

    /// Fails for a channel whose every ramp sample was too dark to read (the solve
    /// would have no curve to fit, and the cause is the meter's range, not the ramp),
    /// or that got no sample before the budget was spent.
    fn check_measurable(&self, key: &DisplayKey, s: &Session<'_, '_>) -> Result<(), MeasureError> {
        for c in Channel::ALL {
            let i = c.index();
            if !self.ramps[i].is_empty() {
                continue;
            }
            let tried = self.rel[i].len() > 2;
            return Err(if tried {
                MeasureError::RampBelowMeterLimit {
                    display: key.to_string(),
                    channel: c.name(),
                    full_y_cd_m2: self.primaries[i].y,
                    limit_cd_m2: s.limit_cd_m2,
                }
            } else {
                MeasureError::RampBudgetSpent {
                    display: key.to_string(),
                    channel: c.name(),
                    budget: s.budget,
                    taken: s.log.readings,
                    low_light: s
                        .log
                        .samples
                        .iter()
                        .filter(|r| r.low_light)
                        .map(|r| r.repeats)
                        .sum(),
                }
            });
        }
        Ok(())
    }

    /// Half a code value of the display, in normalised drive.
    fn half_code(&self) -> f64 {
        HALF_CODE / self.depth.max_code_f64()
    }

    /// True when channel `c` already has a sample within half a code of `d`.
    fn has_sample_near(&self, c: Channel, d: f64) -> bool {
        let lsb = self.half_code();
        self.rel[c.index()].iter().any(|(x, _)| (x - d).abs() < lsb)
    }

    /// Channel `c`'s line, which its samples are read and judged against.
    fn line(&self, c: Channel) -> ChannelLine {
        ChannelLine {
            black: self.black,
            full: self.primaries[c.index()],
            noise: self.noise,
        }
    }

    /// Feeds a ramp reading into the curve estimate.
    fn record(&mut self, c: Channel, d: f64, raw: Xyz) {
        let i = c.index();
        let xyz = self.line(c).reading(raw);
        self.ramps[i].push((d, xyz));
        let r = relative_intensity(xyz, self.black, self.primaries[i]);
        insert_sorted(&mut self.rel[i], (d, r));
    }

    fn step(
        &mut self,
        s: &mut Session<'_, '_>,
        c: Channel,
        d: f64,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<(), MeasureError> {
        match s.sample_channel(Patch::Ramp(c, d), &self.line(c), progress)? {
            Some(raw) => self.record(c, d, raw),
            None => {
                // Skipped as too dark: record the drive so it is not proposed again,
                // with the intensity interpolated between its neighbours.
                let rel = &mut self.rel[c.index()];
                let r = interpolate(rel, d);
                insert_sorted(rel, (d, r));
            }
        }
        Ok(())
    }

    /// One sample per channel in turn until `keep` readings are left or every channel
    /// is good enough; a channel that has not been tried yet may still take one of the
    /// `keep` readings (without a ramp sample it has no curve at all).
    fn adaptive(
        &mut self,
        s: &mut Session<'_, '_>,
        keep: u32,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<(), MeasureError> {
        let mut done = [false; 3];
        let mut k = 0usize;
        loop {
            let free = s.remaining() > keep;
            let untried: [bool; 3] = std::array::from_fn(|j| !done[j] && self.rel[j].len() <= 2);
            if done.iter().all(|d| *d) || s.remaining() == 0 || !(free || untried.contains(&true)) {
                break;
            }
            let c = Channel::ALL[k];
            if !done[k] && (free || untried[k]) {
                match next_drive(&self.rel[k], self.usage[k]) {
                    None => done[k] = true,
                    Some(d) => {
                        let d = self.depth.quantise(d);
                        if self.has_sample_near(c, d) {
                            done[k] = true;
                        } else {
                            self.step(s, c, d, progress)?;
                        }
                    }
                }
            }
            k = (k + 1) % 3;
        }
        Ok(())
    }

    /// Channel intensities this display must add to reach the common black, where an
    /// estimate exists and is above its own black.
    fn common_black_lift(&self, opts: &MeasureOptions) -> Option<[f64; 3]> {
        let black = self.black;
        opts.focus
            .and_then(|f| f.common_black)
            .filter(|cb| cb.y > black.y)
            .and_then(|cb| {
                let m = drive_matrix(black, &self.primaries)?;
                let l = m * (cb - black).to_vector();
                Some([l[0], l[1], l[2]])
            })
    }

    /// One sample per channel in its toe, where it adds the common black's lift (or
    /// about the display's own black luminance).
    fn toe(
        &mut self,
        s: &mut Session<'_, '_>,
        opts: &MeasureOptions,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<(), MeasureError> {
        let lift = self.common_black_lift(opts);
        for c in Channel::ALL {
            let i = c.index();
            let span = self.primaries[i].y - self.black.y;
            if span <= 0.0 || s.remaining() == 0 {
                continue;
            }
            let target = lift
                .map(|l| l[i])
                .filter(|l| *l > 0.0)
                .unwrap_or(self.black.y / span)
                .clamp(TOE_INTENSITY_RANGE.0, TOE_INTENSITY_RANGE.1);
            let d = self.depth.quantise(drive_at(&self.rel[i], target));
            if d > 0.0 && !self.has_sample_near(c, d) {
                // A skipped toe sample leaves the curve as it is.
                if let Some(raw) = s.sample_channel(Patch::Ramp(c, d), &self.line(c), progress)? {
                    self.record(c, d, raw);
                }
            }
        }
        Ok(())
    }
}

/// Drive where the samples, interpolated linearly in drive and cube-root intensity,
/// reach relative intensity `target`.
fn drive_at(v: &[(f64, f64)], target: f64) -> f64 {
    let t = target.max(0.0).cbrt();
    for w in v.windows(2) {
        let (a, b) = (w[0].1.max(0.0).cbrt(), w[1].1.max(0.0).cbrt());
        if t <= b && b > a {
            return w[0].0 + (w[1].0 - w[0].0) * ((t - a) / (b - a)).clamp(0.0, 1.0);
        }
    }
    v.last().map_or(1.0, |p| p.0)
}

fn insert_sorted(v: &mut Vec<(f64, f64)>, s: (f64, f64)) {
    let k = v.partition_point(|p| p.0 < s.0);
    v.insert(k, s);
}

fn interpolate(v: &[(f64, f64)], d: f64) -> f64 {
    let k = v.partition_point(|p| p.0 < d);
    if k == 0 {
        return v.first().map_or(0.0, |p| p.1);
    }
    if k >= v.len() {
        return v.last().map_or(1.0, |p| p.1);
    }
    let (a, b) = (v[k - 1], v[k]);
    if b.0 > a.0 {
        a.1 + (b.1 - a.1) * (d - a.0) / (b.0 - a.0)
    } else {
        a.1
    }
}

/// Next ramp drive for a channel from the tone module's adaptive placement, with the
/// intensities rescaled so that the expected `usage` counts as the full range. Above
/// [`USED_MARGIN`] times the usage (drives no colour of the common gamut reaches) the
/// drive axis is compressed by [`UNUSED_DRIVE_WEIGHT`]: the curve there is still
/// sampled, but a sample in the used part counts several times as much.
fn next_drive(samples: &[(f64, f64)], usage: f64) -> Option<f64> {
    if usage >= 1.0 {
        return crate::tone::suggest_next_drive(samples);
    }
    // Piecewise linear map of [0, 1] onto itself, UNUSED_DRIVE_WEIGHT times flatter
    // above `edge` than below.
    let edge = drive_at(samples, (usage * USED_MARGIN).min(1.0)).clamp(0.0, 1.0);
    let k = 1.0 / (edge + (1.0 - edge) * UNUSED_DRIVE_WEIGHT);
    let squeeze = |d: f64| {
        if d <= edge {
            d * k
        } else {
            k * (edge + (d - edge) * UNUSED_DRIVE_WEIGHT)
        }
    };
    let unsqueeze = |d: f64| {
        if d <= edge * k {
            d / k
        } else {
            edge + (d / k - edge) / UNUSED_DRIVE_WEIGHT
        }
    };
    let scaled: Vec<(f64, f64)> = samples
        .iter()
        .map(|&(d, r)| {
            if d >= 1.0 {
                (d, 1.0)
            } else {
                (squeeze(d).min(1.0), (r / usage).min(1.0))
            }
        })
        .collect();
    crate::tone::suggest_next_drive(&scaled).map(unsqueeze)
}

/// Share of a channel's expected usage above which its drives are sampled sparsely
/// ([`next_drive`]): a colour of the common gamut can ask a channel for somewhat more
/// than the white does.
const USED_MARGIN: f64 = 1.5;

/// Weight of a drive step above the used part of a channel in the ramp placement.
const UNUSED_DRIVE_WEIGHT: f64 = 0.3;
