//! The nightly run's look at the flat fields: a fixed camera photographs the displays
//! measured in full tonight through the flat fields they were commissioned with, and
//! measures them again where the screen's uniformity changed (a new lamp's arc, a
//! nudged lens). The camera itself is `camera::FixedCamera` (the `camera`
//! feature); the recalibration only needs this trait.

use lumiwall_devices::{DisplayInfo, PatternOutput};
use lumiwall_profiles::{DisplayProfile, FlatField};

use super::RecalibrateError;

/// A camera that checks flat fields during [`super::recalibrate_with_camera`].
pub trait FlatFieldCheck {
    /// Looks at the displays `tonight` (indices into `displays` and `profiles`),
    /// showing its patterns on `pattern`: one finding per display it could look at.
    fn check(
        &mut self,
        pattern: &mut dyn PatternOutput,
        tonight: &[usize],
        displays: &[DisplayInfo],
        profiles: &[DisplayProfile],
    ) -> Result<Vec<FlatFieldFinding>, RecalibrateError>;
}

/// What the camera found on one display.
#[derive(Debug, Clone, PartialEq)]
pub struct FlatFieldFinding {
    /// Index of the display (in the wall's order).
    pub index: usize,
    /// Largest RMS residual over the channels, |measured/expected − 1| over the
    /// texels, of the display shown through its flat field.
    pub residual_rms: f64,
    /// The profile's new flat field, where the residual was beyond the tolerance and
    /// the loop measured it again.
    pub flat: Option<FlatField>,
}

/// The camera's look at one display, as the recalibration reports it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlatFieldLook {
    /// Largest RMS residual over the channels (see [`FlatFieldFinding`]).
    pub residual_rms: f64,
    /// Whether the flat field was measured again (and the profile written anew).
    pub refit: bool,
}

/// The flat fields of `current` with the camera's new ones put in; marks each check it
/// looked at (and as drifted where it refitted).
pub(super) fn take_findings(
    findings: Vec<FlatFieldFinding>,
    checks: &mut [super::DisplayCheck],
    current: &mut [DisplayProfile],
) {
    for f in findings {
        let (Some(check), Some(profile)) = (checks.get_mut(f.index), current.get_mut(f.index))
        else {
            continue;
        };
        let refit = f.flat.is_some();
        check.flat_field = Some(FlatFieldLook {
            residual_rms: f.residual_rms,
            refit,
        });
        if let Some(flat) = f.flat {
            profile.flat_field = Some(flat);
            check.drifted = true;
        }
    }
}
