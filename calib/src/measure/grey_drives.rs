//! Ramp samples at the drives a display really uses: after a first solve, each channel
//! is read alone at the drive it gets in the display's white and a few greys, through
//! the provisional profile; the samples join the ramps and the wall is solved again.
//! From [`WHOLE_GREY_MIN_BUDGET`] readings per display, the brightest grey given as a
//! share of the white (the white itself by default) is also read whole
//! ([`whole_grey_repeats`]).
//!
//! Why the channel samples: the ramps are spread over each channel's range and the
//! curve is interpolated between samples. Where the white sits between two samples, the
//! interpolation error moves the white's colour: on `mono-2x1` with the realistic meter
//! and 40 readings (some go to repeats of the primaries and to low-light averages), the
//! green ramp had no sample between drive 0.50 and 0.75; the white's green at 0.65 came
//! out 1.2 % low and the white's y 0.0036 off (ΔE2000 3.4). A sample at the white's own
//! drive removes that error where it matters most. Each is a channel alone, read on its
//! channel's line ([`ChannelLine`]), so a meter's xy noise hardly enters.
//!
//! Why the whole grey: with the curves right at the white's drive, what is left of the
//! white's error is the primaries' own (their xy noise, four readings each at most):
//! 0.0004–0.0006 in xy with a CS-100A class meter at any budget, ΔE2000 0.4–0.6. The
//! grey read whole gives the solve per-channel gains that make the model show it as read
//! (`solve::composite_gains`); scaling the primaries moves every grey with the white,
//! so the greys keep their balance. Splitting the grey into three channel knots through
//! `P⁻¹` instead fixed the white alone and left the greys below it off their balance
//! (tried: mean grey balance 0.30 → 0.36 on `mono-2x1`, 0.51 → 0.72 on
//! `weak-channel-3x1`).

use lumiwall_core::Channel;
use lumiwall_devices::{DisplayId, ReadingNoise, Xyz};
use lumiwall_profiles::DisplayKey;
use lumiwall_profiles::apply::PreparedProfile;

use super::{ChannelLine, MeasureError, MeasureOptions, Patch, Progress, Rig, Session};
use crate::solve::CompositeReading;
use crate::verify::drive_for;

/// One grey of the pass: a share of the target white's luminance, or a luminance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GreyLevel {
    /// This share of the target white's luminance, in (0, 1].
    Share(f64),
    /// A grey of this luminance (cd/m², shown in total, black included), e.g. the dark
    /// greys of 0.5–2 cd/m² whose channels sit in the tone curves' toes.
    Luminance(f64),
}

impl GreyLevel {
    /// The grey's XYZ input for target white `white`; `None` for a luminance above the
    /// white's.
    pub fn xyz(self, white: Xyz) -> Option<Xyz> {
        match self {
            GreyLevel::Share(s) => Some(white * s),
            GreyLevel::Luminance(y) => {
                (white.y > 0.0 && y <= white.y).then(|| white * (y / white.y))
            }
        }
    }
}

impl std::str::FromStr for GreyLevel {
    type Err = String;

    /// `0.5` (a share of the white, in (0, 1]) or `1.5cd` (cd/m², greater than 0).
    fn from_str(s: &str) -> Result<Self, String> {
        let t = s.trim();
        let (v, absolute) = match t.strip_suffix("cd") {
            Some(v) => (v, true),
            None => (t, false),
        };
        let bad = || {
            format!(
                "`{s}` is not a grey level: a share of the white's luminance in (0, 1] \
                 (e.g. 0.5) or a luminance in cd/m² (e.g. 1.5cd)"
            )
        };
        let v: f64 = v.trim().parse().map_err(|_| bad())?;
        match absolute {
            true if v.is_finite() && v > 0.0 => Ok(GreyLevel::Luminance(v)),
            false if v.is_finite() && v > 0.0 && v <= 1.0 => Ok(GreyLevel::Share(v)),
            _ => Err(bad()),
        }
    }
}

/// Default grey levels: the white, and a dark grey of 1 cd/m² (the middle, in
/// luminance ratio, of the 0.5–2 cd/m² dark end) where the meter reads its channels
/// reliably (`commission` drops it otherwise). The white's samples took the noiseless
/// worst white ΔE2000 from 0.08–0.23 to ≤ 0.01; the dark grey's took infitec-pair's
/// worst dark-patch Δxy from 0.0053 to 0.0021 (blue's toe at code 5, between the ramp's
/// 0 and 8). And a middle grey (0.5, read per channel only): a channel the white uses
/// over its whole range (a weak one) has its greys between ramp samples a quarter of
/// the range apart. Realistic meter, 40 readings, 30 unseen seeds (with
/// [`NOISY_DRIVE_GAP`]), runs within every limit of issue 12 without / with it:
/// weak-channel-3x1 4 / 24, mono-2x1 30 / 30 (mean worst ΔE2000 0.85 / 0.76),
/// offaxis-gain-2x1 30 / 30, infitec-pair 30 / 29 (mean grey balance 0.23 / 0.33).
/// Read whole as well at 64 readings it did less than per channel alone (heyewall-48:
/// max ΔE2000 1.80 / 1.13; weak-channel-3x1, 20 seeds: 16 / 18 of 20).
pub const DEFAULT_LEVELS: [GreyLevel; 3] = [
    GreyLevel::Share(1.0),
    GreyLevel::Share(0.5),
    GreyLevel::Luminance(1.0),
];

/// Largest number of grey levels.
pub const MAX_LEVELS: usize = 16;

/// Drives closer than this to a sample already taken (or to 0 or 1) are not read
/// again: the tone fit pools such samples into one knot ([`crate::tone::NEAR_DRIVE`]).
pub const MIN_DRIVE_GAP: f64 = crate::tone::NEAR_DRIVE;

/// With a meter that has noise, a grey's channel drive this close to a ramp sample
/// (2.5 codes at 8 bit) is not read: the curve there is already pinned by that sample,
/// and a second noisy knot so near it makes the spline's slope between them noise
/// (weak-channel-3x1 at 40 readings: the 1 cd/m² grey's red read at 0.094 beside the
/// ramp's 0.090, four readings each). Realistic meter, 40 readings, 30 unseen seeds,
/// against half a code: mean of the worst ΔE2000 weak-channel-3x1 1.45 → 1.22,
/// infitec-pair 0.98 → 0.76, mono-2x1 0.92 → 0.85; mean grey balance 0.67 → 0.61,
/// 0.28 → 0.23, 0.22 → 0.19 (0.005: 1.25, 0.76, 0.91; 0.02: 1.29, 0.88, 0.83).
/// An exact meter's sample is pure information: it keeps [`MIN_DRIVE_GAP`].
pub const NOISY_DRIVE_GAP: f64 = 0.01;

/// Closest a grey's channel drive may be to a ramp sample and still be read, for a
/// meter of this stated noise ([`NOISY_DRIVE_GAP`]; [`MIN_DRIVE_GAP`] for an exact one).
pub fn drive_gap(noise: Option<&ReadingNoise>) -> f64 {
    if noise.is_some_and(ReadingNoise::is_exact) {
        MIN_DRIVE_GAP
    } else {
        NOISY_DRIVE_GAP
    }
}

/// The greys whose channel drives are read: the provisional profile and the target
/// white it shows.
pub struct GreyTargets<'a> {
    /// The display's provisional profile, prepared for the post pass.
    pub prepared: &'a PreparedProfile,
    /// The profile's target white (XYZ input, cd/m²).
    pub white: Xyz,
    /// The greys.
    pub levels: &'a [GreyLevel],
    /// Bits per channel of the display input: samples are read at the nearest code.
    pub bit_depth: u32,
    /// The display's measured black and full-drive primaries: each sample is read and
    /// judged on its channel's line ([`ChannelLine`]).
    pub black: Xyz,
    /// See `black`.
    pub primaries: [Xyz; 3],
    /// Drives of each channel's ramp samples so far: a grey's drive within
    /// [`MIN_DRIVE_GAP`] of one is not read again.
    pub ramp_drives: [Vec<f64>; 3],
    /// Readings averaged for each grey read whole ([`whole_grey_repeats`]; 0: none).
    pub whole_repeats: u32,
}

/// What the pass read on one display: each channel's new `(drive, XYZ)` ramp samples,
/// each put on its channel's line ([`ChannelLine::reading`]), the bright greys read
/// whole, and the readings they cost.
#[derive(Debug, Clone, Default)]
pub struct GreyDrives {
    /// Drives of the new ramp samples per channel R, G, B (their readings are in
    /// `samples`, which the commissioning pools with the display's log:
    /// [`super::channel_colour::pool`]).
    pub drives: [Vec<f64>; 3],
    /// The greys given as a share of the white, each read whole at its drive.
    pub composites: Vec<CompositeReading>,
    /// Meter readings taken.
    pub readings: u32,
    /// The pass's samples as read, for the display's [`super::MeasureLog`].
    pub samples: Vec<super::ReadingRecord>,
}

/// Most readings averaged for a grey read whole (a share of the white), and what a
/// meter that states no noise gets: with a CS-100A class meter's xy noise of 0.0005 per
/// reading, six put the white's chromaticity within [`WHOLE_GREY_XY_SE`], where the
/// primaries' readings had left the white computed from them 0.0004–0.0006 off
/// (ΔE2000 0.4–0.6).
pub const WHOLE_GREY_REPEATS: u32 = 6;

/// Standard error of a whole grey's mean x and y that its readings aim at.
pub const WHOLE_GREY_XY_SE: f64 = 0.0002;

/// Smallest budget per display at which the greys are read whole. Below it the ramps
/// need the readings more: realistic meter, mono-2x1 and offaxis-gain-2x1 with ten
/// unseen seeds each, runs within every limit of issue 12 with / without the whole
/// white: 8 / 14 of 20 at 40 readings (mean grey balance 0.61 / 0.42 on mono-2x1),
/// 16 / 19 at 52, 19 / 17 at 64; over six wall classes with five seeds at 64, 25 / 23
/// of 30 (weak-channel-3x1's mean white ΔE2000 0.63 / 0.71).
pub const WHOLE_GREY_MIN_BUDGET: u32 = 64;

/// Readings averaged for a grey read whole on a display of `budget` readings with a
/// meter of this stated noise: none below [`WHOLE_GREY_MIN_BUDGET`]; else enough for
/// [`WHOLE_GREY_XY_SE`] (one for a meter that states none at all, such as the
/// simulator's exact one), at most [`WHOLE_GREY_REPEATS`]; a meter that states nothing
/// gets the most.
pub fn whole_grey_repeats(noise: Option<&ReadingNoise>, budget: u32) -> u32 {
    if budget < WHOLE_GREY_MIN_BUDGET {
        return 0;
    }
    match noise {
        Some(n) => {
            let needed = (n.xy / WHOLE_GREY_XY_SE).powi(2).ceil();
            if needed.is_finite() {
                (needed as u32).clamp(1, WHOLE_GREY_REPEATS)
            } else {
                WHOLE_GREY_REPEATS
            }
        }
        None => WHOLE_GREY_REPEATS,
    }
}

/// Readings per channel sample of a dark grey level: one for a meter that states it
/// has no noise, else [`DARK_REPEATS`].
fn dark_repeats(noise: Option<&ReadingNoise>) -> u32 {
    if noise.is_some_and(ReadingNoise::is_exact) {
        1
    } else {
        DARK_REPEATS
    }
}

/// Reads each channel of display `id` alone at the code nearest the drive the
/// provisional profile gives it for each grey of `targets`, at the calibration spot,
/// skipping drives at 0, 1 or within [`MIN_DRIVE_GAP`] of one already read (in this
/// pass or the ramps). Samples below the meter's reliable limit are averaged as their
/// channel's stated noise needs ([`super::ChannelLine`]), or as the low-light policy
/// says. At most `opts.budget` readings.
pub fn read_grey_drives(
    rig: &mut Rig<'_>,
    key: &DisplayKey,
    id: DisplayId,
    targets: &GreyTargets<'_>,
    opts: &MeasureOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<GreyDrives, MeasureError> {
    // One line per display instead of a progress step per sample.
    let mut quiet = |p: Progress| {
        if !matches!(p, Progress::Reading { .. }) {
            progress(p);
        }
    };
    let noise = rig.meter.info().noise;
    let mut s = Session::start(rig, key, id, opts.spot_uv, opts)?;
    let mut out = GreyDrives::default();
    let inside = MIN_DRIVE_GAP..=1.0 - MIN_DRIVE_GAP;
    let gap = drive_gap(noise.as_ref());
    let brightest = brightest_share(targets.levels);
    let max_code = crate::solve::clamped_bit_depth(targets.bit_depth).max_code_f64();
    for level in targets.levels {
        let Some(xyz) = level.xyz(targets.white) else {
            continue;
        };
        // At codes, as every ramp sample is: shown exactly, with no dither.
        let drive = drive_for(targets.prepared, xyz, opts.spot_uv)
            .map(|d| (d * max_code).round() / max_code);
        if let GreyLevel::Share(v) = level
            && *v >= brightest
        {
            let n = targets.whole_repeats.min(s.remaining());
            if n > 0
                && let Some(xyz) = s.repeated(Patch::Drive(drive), n, &mut quiet)?
            {
                let readings = s.log.samples.last().map_or(n, |r| r.repeats.max(1));
                out.composites.push(CompositeReading {
                    drive,
                    xyz,
                    readings,
                });
            }
        }
        for c in Channel::ALL {
            let d = drive[c.index()];
            let taken = &mut out.drives[c.index()];
            let far = |t: &f64| (t - d).abs() >= MIN_DRIVE_GAP;
            let far_from_ramp = |t: &f64| (t - d).abs() >= gap;
            let new = inside.contains(&d)
                && taken.iter().all(far)
                && targets.ramp_drives[c.index()].iter().all(far_from_ramp);
            if !new || s.remaining() == 0 {
                continue;
            }
            let line = ChannelLine {
                black: targets.black,
                full: targets.primaries[c.index()],
                noise,
            };
            if s.sample_channel(Patch::Ramp(c, d), &line, &mut quiet)?
                .is_some()
            {
                taken.push(d);
            }
        }
    }
    out.readings = s.log.readings;
    out.samples = std::mem::take(&mut s.log.samples);
    progress(Progress::GreyDrivesRead {
        display: id,
        samples: out.drives.iter().map(Vec::len).sum(),
        whole: out.composites.len(),
        readings: out.readings,
    });
    Ok(out)
}

/// The largest share of the white among `levels` (0 without one): the one grey read
/// whole.
fn brightest_share(levels: &[GreyLevel]) -> f64 {
    levels
        .iter()
        .filter_map(|l| match l {
            GreyLevel::Share(v) => Some(*v),
            GreyLevel::Luminance(_) => None,
        })
        .fold(0.0, f64::max)
}

/// Checks the number of grey levels: at most [`MAX_LEVELS`].
pub fn check_levels(levels: &[GreyLevel]) -> Result<(), String> {
    if levels.len() > MAX_LEVELS {
        return Err(format!(
            "{} grey levels: at most {MAX_LEVELS}",
            levels.len()
        ));
    }
    Ok(())
}

/// Readings the pass reserves per display of `budget` readings read with a meter of
/// stated `noise`: for a share of the white, one per channel at its drive, and
/// [`whole_grey_repeats`] for the brightest, read whole; two per channel of a dark grey given
/// as a luminance (one with an exact meter), whose samples the low-light policy
/// averages (reserving one left heyewall-48's dark greys without their own samples at
/// 40 readings, realistic meter: 1 cd/m² grey +8–16 % on the right-eye displays, max
/// ΔE2000 5.1; with two, 3.6). Readings an exact meter does not need stay with the
/// ramps.
pub fn readings_needed(levels: &[GreyLevel], noise: Option<&ReadingNoise>, budget: u32) -> u32 {
    let brightest = brightest_share(levels);
    let per_level = |l: &GreyLevel| match l {
        GreyLevel::Share(v) if *v >= brightest => 3 + whole_grey_repeats(noise, budget),
        GreyLevel::Share(_) => 3,
        GreyLevel::Luminance(_) => 3 * dark_repeats(noise),
    };
    levels.iter().map(per_level).sum()
}

/// Readings reserved per channel sample of a dark grey level (the weighted samples of
/// a CS-100A class meter need one or two).
const DARK_REPEATS: u32 = 2;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grey_levels_parse_as_shares_of_the_white_or_as_luminances() {
        assert_eq!("0.5".parse(), Ok(GreyLevel::Share(0.5)));
        assert_eq!(" 1.5cd".parse(), Ok(GreyLevel::Luminance(1.5)));
        for bad in ["0", "1.2", "-1cd", "0cd", "nan", "cd", "1 cd/m2"] {
            assert!(bad.parse::<GreyLevel>().is_err(), "{bad}");
        }
    }

    fn cs100a_class() -> ReadingNoise {
        ReadingNoise {
            luminance_rel: 0.001,
            xy: 0.0005,
            dark_xyz_cd_m2: [0.008, 0.004, 0.008],
        }
    }

    #[test]
    fn a_noisy_meter_skips_grey_drives_beside_a_ramp_sample_and_an_exact_one_does_not() {
        let exact = ReadingNoise {
            luminance_rel: 0.0,
            xy: 0.0,
            dark_xyz_cd_m2: [0.0; 3],
        };
        assert_eq!(drive_gap(Some(&exact)), MIN_DRIVE_GAP);
        assert_eq!(drive_gap(Some(&cs100a_class())), NOISY_DRIVE_GAP);
        assert_eq!(drive_gap(None), NOISY_DRIVE_GAP);
        // Two codes at 8 bit: read for the exact meter, not for a noisy one.
        let apart = 2.0 / 255.0;
        assert!(apart >= drive_gap(Some(&exact)) && apart < drive_gap(Some(&cs100a_class())));
    }

    #[test]
    fn only_the_brightest_share_is_read_whole() {
        let n = cs100a_class();
        let whole = whole_grey_repeats(Some(&n), 64);
        assert_eq!(whole, 6);
        // White: 3 channels + 6 whole; middle grey: 3 channels; 1 cd/m²: 3 × 2.
        assert_eq!(
            readings_needed(&DEFAULT_LEVELS, Some(&n), 64),
            3 + whole + 3 + 6
        );
        // Below 64 nothing is read whole.
        assert_eq!(readings_needed(&DEFAULT_LEVELS, Some(&n), 40), 3 + 3 + 6);
        // A user's levels: only 0.8, the brightest share, is read whole.
        let levels = [GreyLevel::Share(0.4), GreyLevel::Share(0.8)];
        assert_eq!(readings_needed(&levels, Some(&n), 64), 3 + 3 + whole);
        assert_eq!(brightest_share(&[GreyLevel::Luminance(1.0)]), 0.0);
    }

    #[test]
    fn a_luminance_above_the_white_gives_no_grey() {
        let white = Xyz::new(95.0, 100.0, 109.0);
        assert_eq!(GreyLevel::Luminance(150.0).xyz(white), None);
        let g = GreyLevel::Luminance(1.0).xyz(white).unwrap();
        assert!((g.y - 1.0).abs() < 1e-12 && (g.x - 0.95).abs() < 1e-12);
        assert_eq!(GreyLevel::Share(0.5).xyz(white), Some(white * 0.5));
    }
}
