//! The fixed camera in the nightly run: the flat-field loop of [`super::flat`] used as
//! a check. Each display measured in full tonight shows each channel through the gains
//! the commissioning measured (`camera.json`); where the photograph is uniform within
//! the tolerance, nothing changes (one dark frame and three captures), and where it is
//! not (a new lamp whose arc sits elsewhere, a nudged lens), the loop goes on from
//! those gains until it is below the commissioning's threshold, and the profile's flat
//! field is updated by the same texel ratios (so a perceptual design's gradient is
//! kept). The camera's calibration (response, registration, anchor) is the
//! commissioning's: the camera must not have moved, which is checked first.

use lumiwall_devices::{Camera, DisplayInfo, PatternOutput};
use lumiwall_profiles::{DisplayProfile, FlatField};

use super::CameraCalibError;
use super::flat::{
    ChannelRun, Context, Counting, DisplayFlat, FlatFieldOptions, FlatFieldOutcome, Shown,
    profile_of,
};
use super::registration::check_still;
use crate::recalibrate::{FlatFieldCheck, FlatFieldFinding, RecalibrateError};

/// What the nightly check accepts and how far it refits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NightlyFlatOptions {
    /// A display whose RMS residual through its flat field is below this (every
    /// channel) keeps its flat field.
    pub tolerance_rms: f64,
    /// A refit stops below this RMS residual (the commissioning's threshold).
    pub threshold_rms: f64,
    /// Most captures per channel of a refit (the check's capture included).
    pub max_iterations: u32,
    /// Largest camera movement since the commissioning (px) before the check is
    /// refused.
    pub move_limit_px: f64,
}

impl Default for NightlyFlatOptions {
    fn default() -> Self {
        let loop_defaults = FlatFieldOptions::default();
        Self {
            tolerance_rms: 0.01,
            threshold_rms: loop_defaults.threshold,
            max_iterations: loop_defaults.max_iterations + 1,
            move_limit_px: loop_defaults.move_limit_px,
        }
    }
}

/// The station's fixed camera with the commissioning's camera stage
/// (`camera.json`): a [`FlatFieldCheck`] for
/// [`crate::recalibrate::recalibrate_with_camera`].
pub struct FixedCamera<'c> {
    cam: &'c mut dyn Camera,
    stage: FlatFieldOutcome,
    opts: NightlyFlatOptions,
    /// One line per step, for the log.
    pub lines: Vec<String>,
    /// Frames captured (every exposure of every HDR capture).
    pub frames: u32,
    /// Whether a flat field was measured again (the stage then needs writing back).
    pub refitted: bool,
}

impl<'c> FixedCamera<'c> {
    /// The camera `cam`, calibrated by the commissioning's camera `stage`.
    pub fn new(cam: &'c mut dyn Camera, stage: FlatFieldOutcome, opts: NightlyFlatOptions) -> Self {
        Self {
            cam,
            stage,
            opts,
            lines: Vec::new(),
            frames: 0,
            refitted: false,
        }
    }

    /// The camera stage with tonight's refitted flat fields put in (for `camera.json`).
    pub fn stage(&self) -> &FlatFieldOutcome {
        &self.stage
    }

    /// Checks that the camera sits where the commissioning registered it; `Ok(false)`
    /// (and a line saying so) where it moved.
    fn still(
        &mut self,
        pattern: &mut dyn PatternOutput,
        first: &DisplayInfo,
    ) -> Result<bool, CameraCalibError> {
        let mut counting = Counting {
            cam: &mut *self.cam,
            frames: 0,
        };
        let moved = check_still(
            &self.stage.registration,
            &mut counting,
            pattern,
            &self.stage.response,
            first,
            self.opts.move_limit_px,
        );
        self.frames += counting.frames;
        match moved {
            Ok(_) => Ok(true),
            Err(CameraCalibError::Moved { shift_px, .. }) => {
                self.lines.push(format!(
                    "camera: MOVED {shift_px:.2} px since the commissioning; flat fields kept \
                     unchecked (run `lumiwall commission --camera` again)"
                ));
                Ok(false)
            }
            Err(e) => Err(e),
        }
    }

    /// One display: the check and, where it fails, the refit.
    fn look(
        &mut self,
        pattern: &mut dyn PatternOutput,
        info: &DisplayInfo,
        profiles: &[DisplayProfile],
    ) -> Result<Option<(f64, Option<FlatField>)>, CameraCalibError> {
        let profile = profile_of(profiles, info)?;
        let Some(k) = self.stage.displays.iter().position(|d| d.name == info.name) else {
            self.lines.push(format!(
                "camera: {} has no flat field from the commissioning; not checked",
                info.name
            ));
            return Ok(None);
        };
        let measured = self.stage.displays[k].clone();
        let Some(current) = profile
            .flat_field
            .as_ref()
            .filter(|f| [f.width, f.height] == [measured.flat.width, measured.flat.height])
        else {
            self.lines.push(format!(
                "camera: {}'s profile has no flat field of the size measured; not checked",
                info.name
            ));
            return Ok(None);
        };
        let (refit, frames) = self.run_loops(pattern, info, profile, &measured)?;
        self.frames += frames;
        let residual = refit.residual_open.iter().copied().fold(0.0, f64::max);
        // a channel whose first capture was beyond the tolerance had its gains updated
        let changed = refit
            .residual_open
            .iter()
            .any(|&r| r >= self.opts.tolerance_rms);
        self.lines.push(format!(
            "camera: {} flat field: RMS residual {:.2} %{}",
            info.name,
            100.0 * residual,
            if changed {
                format!(
                    " (over {:.2} %): measured again, {:.2} % after",
                    100.0 * self.opts.tolerance_rms,
                    100.0 * refit.residual_final.iter().copied().fold(0.0, f64::max)
                )
            } else {
                String::new()
            }
        ));
        if !changed {
            return Ok(Some((residual, None)));
        }
        let flat = rescaled(current, &measured.flat, &refit.flat);
        self.stage.displays[k] = DisplayFlat { frames, ..refit };
        self.refitted = true;
        Ok(Some((residual, Some(flat))))
    }

    /// Each channel's loop from the commissioning's gains, with the check's tolerance;
    /// the display's new measurement and the frames it cost.
    fn run_loops(
        &mut self,
        pattern: &mut dyn PatternOutput,
        info: &DisplayInfo,
        profile: &DisplayProfile,
        measured: &DisplayFlat,
    ) -> Result<(DisplayFlat, u32), CameraCalibError> {
        let loop_opts = FlatFieldOptions {
            texture: [measured.flat.width, measured.flat.height],
            threshold: self.opts.threshold_rms,
            max_iterations: self.opts.max_iterations,
            ..FlatFieldOptions::default()
        };
        let ctx = Context {
            response: &self.stage.response,
            registration: &self.stage.registration,
            opts: &loop_opts,
        };
        let mut cam = Counting {
            cam: &mut *self.cam,
            frames: 0,
        };
        let dark = ctx.capture(
            &mut cam,
            pattern,
            info,
            Shown::Uniform([0.0; 3]),
            "dark frame",
        )?;
        let run = ChannelRun {
            phot: &self.stage.photometry,
            info,
            profile,
            dark: &dark,
        };
        let mut out = DisplayFlat {
            residual_history: Default::default(),
            ..measured.clone()
        };
        let mut gains: [Vec<f64>; 3] = Default::default();
        for c in 0..3 {
            let g = measured.flat.gain.iter().map(|t| f64::from(t[c])).collect();
            let level = profile.channel_usage[c].clamp(0.01, 1.0);
            let tolerance = Some(self.opts.tolerance_rms);
            let done = ctx.loop_channel(&mut cam, pattern, &run, c, g, None, level, tolerance)?;
            out.iterations[c] = done.iterations;
            out.residual_open[c] = done.history.first().copied().unwrap_or(f64::NAN);
            out.residual_final[c] = done.history.last().copied().unwrap_or(f64::NAN);
            out.residual_history[c] = done.history;
            out.min_gain[c] = done.gains.iter().copied().fold(f64::INFINITY, f64::min);
            gains[c] = done.gains;
        }
        out.flat.gain = (0..out.flat.gain.len())
            .map(|k| std::array::from_fn(|c| (gains[c][k] as f32).clamp(1e-3, FlatField::MAX_GAIN)))
            .collect();
        Ok((out, cam.frames))
    }
}

/// The profile's flat field `current` moved by what the measurement did, texel by
/// texel and channel by channel (`now / then`): a designed gradient stays in it.
fn rescaled(current: &FlatField, then: &FlatField, now: &FlatField) -> FlatField {
    let gain = current
        .gain
        .iter()
        .zip(then.gain.iter().zip(&now.gain))
        .map(|(g, (a, b))| {
            std::array::from_fn(|c| (g[c] * b[c] / a[c].max(1e-3)).clamp(1e-3, FlatField::MAX_GAIN))
        })
        .collect();
    FlatField {
        width: current.width,
        height: current.height,
        gain,
    }
}

impl FlatFieldCheck for FixedCamera<'_> {
    fn check(
        &mut self,
        pattern: &mut dyn PatternOutput,
        tonight: &[usize],
        displays: &[DisplayInfo],
        profiles: &[DisplayProfile],
    ) -> Result<Vec<FlatFieldFinding>, RecalibrateError> {
        let Some(first) = displays.get(displays.len() / 2) else {
            return Ok(Vec::new());
        };
        if tonight.is_empty() || !self.still(pattern, first).map_err(camera_error)? {
            return Ok(Vec::new());
        }
        let mut findings = Vec::with_capacity(tonight.len());
        for &index in tonight {
            let Some(info) = displays.get(index) else {
                continue;
            };
            if let Some((residual_rms, flat)) =
                self.look(pattern, info, profiles).map_err(camera_error)?
            {
                findings.push(FlatFieldFinding {
                    index,
                    residual_rms,
                    flat,
                });
            }
        }
        Ok(findings)
    }
}

fn camera_error(e: CameraCalibError) -> RecalibrateError {
    RecalibrateError::Camera {
        device: matches!(e, CameraCalibError::Device { .. }),
        message: e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(gain: Vec<[f32; 3]>) -> FlatField {
        FlatField {
            width: 2,
            height: 1,
            gain,
        }
    }

    #[test]
    fn a_refit_moves_the_profiles_flat_field_by_the_measured_ratio_and_keeps_its_designed_gradient()
    {
        // a perceptual design divided texel 0 by 0.8: the profile holds 0.96 / 0.8
        let current = flat(vec![[1.2; 3], [1.0; 3]]);
        let then = flat(vec![[0.96; 3], [1.0; 3]]);
        // tonight the red of texel 0 gives 0.90 of the spot, not 0.96
        let now = flat(vec![[0.90, 0.96, 0.96], [1.0; 3]]);
        let r = rescaled(&current, &then, &now);
        assert!((r.gain[0][0] - 0.90 / 0.8).abs() < 1e-6, "{:?}", r.gain);
        assert!((r.gain[0][1] - 1.2).abs() < 1e-6 && (r.gain[0][2] - 1.2).abs() < 1e-6);
        assert_eq!(r.gain[1], [1.0; 3]);
        assert_eq!([r.width, r.height], [2, 1]);
    }
}
