//! Ramp samples at the drives a display really uses: after a first solve, each channel
//! is read alone at the drive it gets in the display's white and a few greys, through
//! the provisional profile; the samples join the ramps and the wall is solved again.
//!
//! Why: the ramps are spread over each channel's range and the curve is interpolated
//! between samples. Where the white sits between two samples, the interpolation error
//! moves the white's colour: on `mono-2x1` with the realistic meter and 40 readings
//! (some go to repeats of the primaries and to low-light averages), the green ramp had
//! no sample between drive 0.50 and 0.75; the white's green at 0.65 came out 1.2 % low
//! and the white's y 0.0036 off (ΔE2000 3.4). A sample at the white's own drive
//! removes that error where it matters most.
//!
//! Each sample is a channel alone, read for its luminance only like every ramp sample
//! (its chromaticity is the channel's), so a meter's xy noise does not enter. Reading
//! the greys themselves and splitting each into three channel intensities through `P⁻¹`
//! needs a third of the readings, but turns a colorimeter's xy noise (0.0005) into 0.9 %
//! noise on a red intensity: tried, it made the white worse than the interpolation did
//! on walls with dim greys.

use lumiwall_core::Channel;
use lumiwall_devices::{DisplayId, Xyz};
use lumiwall_profiles::DisplayKey;
use lumiwall_profiles::apply::PreparedProfile;

use super::{MeasureError, MeasureOptions, Patch, Progress, Rig, Session};
use crate::verify::drive_for;

/// Default grey levels, as shares of the target white's luminance: the white alone.
/// Adding a middle grey (0.5) gave no better verification with the realistic meter on
/// six walls of each of two classes (its three readings came out of the ramps).
pub const DEFAULT_LEVELS: [f64; 1] = [1.0];

/// Largest number of grey levels.
pub const MAX_LEVELS: usize = 16;

/// Drives closer than this to a sample already taken (or to 0 or 1) are not read again.
pub const MIN_DRIVE_GAP: f64 = 1.0 / 1024.0;

/// The greys whose channel drives are read: the provisional profile and the target
/// white it shows.
pub struct GreyTargets<'a> {
    /// The display's provisional profile, prepared for the post pass.
    pub prepared: &'a PreparedProfile,
    /// The profile's target white (XYZ input, cd/m²).
    pub white: Xyz,
    /// Shares of the white's luminance, each in (0, 1].
    pub levels: &'a [f64],
    /// Bits per channel of the display input: samples are read at the nearest code.
    pub bit_depth: u32,
}

/// What the pass read on one display: each channel's new `(drive, raw XYZ)` ramp
/// samples and the readings they cost.
#[derive(Debug, Clone, Default)]
pub struct GreyDrives {
    /// New ramp samples per channel R, G, B.
    pub ramps: [Vec<(f64, Xyz)>; 3],
    /// Meter readings taken.
    pub readings: u32,
}

/// Reads each channel of display `id` alone at the code nearest the drive the
/// provisional profile gives it for each grey of `targets`, at the calibration spot, skipping drives at 0, 1 or
/// within [`MIN_DRIVE_GAP`] of one already read. Samples below the meter's reliable
/// limit follow the low-light policy. At most `opts.budget` readings.
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
    let mut s = Session::start(rig, key, id, opts.spot_uv, opts)?;
    let mut out = GreyDrives::default();
    let inside = MIN_DRIVE_GAP..=1.0 - MIN_DRIVE_GAP;
    let max_code = crate::solve::clamped_bit_depth(targets.bit_depth).max_code_f64();
    for &level in targets.levels {
        let drive = drive_for(targets.prepared, targets.white * level, opts.spot_uv);
        for c in Channel::ALL {
            // At a code, as every ramp sample is: shown exactly, with no dither.
            let d = (drive[c.index()] * max_code).round() / max_code;
            let taken = &mut out.ramps[c.index()];
            let new =
                inside.contains(&d) && taken.iter().all(|(t, _)| (t - d).abs() >= MIN_DRIVE_GAP);
            if !new || s.remaining() == 0 {
                continue;
            }
            if let Some(xyz) = s.sample(Patch::Ramp(c, d), false, &mut quiet)? {
                taken.push((d, xyz));
            }
        }
    }
    out.readings = s.log.readings;
    progress(Progress::GreyDrivesRead {
        display: id,
        samples: out.ramps.iter().map(Vec::len).sum(),
        readings: out.readings,
    });
    Ok(out)
}

/// Checks grey levels: each finite and in (0, 1], at most [`MAX_LEVELS`].
pub fn check_levels(levels: &[f64]) -> Result<(), String> {
    if levels.len() > MAX_LEVELS {
        return Err(format!(
            "{} grey levels: at most {MAX_LEVELS}",
            levels.len()
        ));
    }
    match levels
        .iter()
        .find(|l| !(l.is_finite() && **l > 0.0 && **l <= 1.0))
    {
        Some(l) => Err(format!(
            "grey level {l}: a share of the white's luminance in (0, 1]"
        )),
        None => Ok(()),
    }
}

/// Readings the pass needs at most per display: one per channel and level.
pub fn readings_needed(levels: &[f64]) -> u32 {
    u32::try_from(levels.len() * 3).unwrap_or(u32::MAX)
}
