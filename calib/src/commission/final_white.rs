//! The tone curves sampled again where the wall's final white sits.
//!
//! The grey-drive pass of [`super::commission`] reads each channel at the drives of
//! the solved white and greys, so the tone curves are exact there and interpolated
//! between ramp samples elsewhere (about 1 % off in luminance between two samples of a
//! 10-bit LCD ramp). A later stage can move the white: the camera stage's strict
//! uniformity lowers it to what the darkest point of the wall can show (heyewall-48:
//! 49.4 → 33.8 cd/m²), the perceptual one shapes it per texel. Shown through curves
//! sampled at the old white, the new white was up to 1.2 % off at the tile centres of
//! a noiseless commission, and two neighbouring tiles showed a 1.4 % step at their
//! seam. [`resample_at_final_white`] reads every display's channels at the drives its
//! final profile gives the white and the greys at the meter's spot (flat field
//! included), pools them into its ramps and solves the wall again.

use lumiwall_devices::DisplayInfo;
use lumiwall_profiles::DisplayProfile;

use super::{
    CommissionError, CommissionOptions, CommissionOutcome, GreyPass, finish, grey_levels_for,
    read_greys_of,
};
use crate::measure::averaging::with_averaging;
use crate::measure::grey_drives::readings_needed;
use crate::measure::{Progress, Rig};

/// What [`resample_at_final_white`] did.
#[derive(Debug, Clone)]
pub struct Resampled {
    /// The wall solved again with the new samples (profiles and report rewritten).
    pub outcome: CommissionOutcome,
    /// Meter readings taken over the wall.
    pub readings: u32,
}

/// Reads every display's channels at the drives its final profile (`finals`, one per
/// display of `outcome`, flat fields and the final white in them) gives the white and
/// the greys of `opts.grey_levels` at the meter's spot, pools them with its earlier
/// readings and solves the wall again: profiles and report in `outcome.out_dir` are
/// rewritten; flat fields and uniformity are the caller's to apply again. Nothing is
/// read (and the outcome is returned as it was) without grey levels. The new samples
/// are not saved in the run folder: a resumed commission reads them again. Each
/// reading averages as many meter readings as the commissioning's
/// ([`CommissionOutcome::readings_per_reading`]).
pub fn resample_at_final_white(
    displays: &[DisplayInfo],
    rig: &mut Rig<'_>,
    outcome: &CommissionOutcome,
    finals: &[DisplayProfile],
    opts: &CommissionOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Resampled, CommissionError> {
    let levels = grey_levels_for(opts, rig);
    if levels.is_empty() {
        return Ok(Resampled {
            outcome: outcome.clone(),
            readings: 0,
        });
    }
    let pass = GreyPass {
        levels: &levels,
        budget: readings_needed(
            &levels,
            rig.meter.info().noise.as_ref(),
            opts.measure.budget,
        ),
        whole_repeats: 0,
        // The curves are read again where the lowered white sits; the black stays.
        black_with_rest: false,
    };
    let mut measured = outcome.measured.clone();
    let mut readings = 0;
    with_averaging(rig, outcome.readings_per_reading, |rig| {
        for (display, m) in displays.iter().zip(measured.iter_mut()) {
            let key = &m.measurement.key;
            let Some(profile) = finals.iter().find(|p| p.display == *key) else {
                continue;
            };
            readings += read_greys_of(display, m, profile, rig, &pass, opts, progress)
                .map_err(|e| e.into_commission(|source| CommissionError::FinalWhite { source }))?;
        }
        Ok::<_, CommissionError>(())
    })?;
    let resampled = finish(
        &outcome.wall,
        measured,
        outcome.resumed.clone(),
        &outcome.out_dir,
        opts,
        outcome.drift.as_ref(),
    )?;
    let outcome = CommissionOutcome {
        readings_per_reading: outcome.readings_per_reading,
        averaging: outcome.averaging,
        ..resampled
    };
    Ok(Resampled { outcome, readings })
}
