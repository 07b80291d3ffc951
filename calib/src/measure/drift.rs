//! Drift over a commissioning run: after the last display, the first display measured
//! in the run is read again at full white and compared with its white from the start
//! of the run. A wall that was not warm (or whose lamps drift) shows it here, so the
//! report says how far the first and the last displays' calibrations are apart in
//! lamp state (ArgyllCMS re-reads white during long runs for the same reason).

use lumiwall_devices::{DisplayInfo, Xyz};
use serde::{Deserialize, Serialize};

use super::{MeasureError, MeasureOptions, Patch, Progress, Rig, Session};
use lumiwall_profiles::DisplayKey;

/// Luminance change (percent) above which the drift is reported as a warning.
pub const WARN_LUMINANCE_PERCENT: f64 = 1.0;
/// Chromaticity change above which the drift is reported as a warning.
pub const WARN_DELTA_XY: f64 = 0.002;

/// The first display's white at the start and at the end of the run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DriftCheck {
    /// The display re-read.
    pub display: String,
    /// Its white when it was measured.
    pub white_then: Xyz,
    /// Its white after the last display.
    pub white_now: Xyz,
}

impl DriftCheck {
    /// Luminance change in percent.
    pub fn luminance_change_percent(&self) -> f64 {
        100.0 * (self.white_now.y / self.white_then.y - 1.0)
    }

    /// Chromaticity change (Euclidean CIE 1931 xy distance); `None` for a dark white.
    pub fn delta_xy(&self) -> Option<f64> {
        let then = self.white_then.chromaticity()?;
        Some(then.distance(self.white_now.chromaticity()?))
    }

    /// True when the change exceeds [`WARN_LUMINANCE_PERCENT`] or [`WARN_DELTA_XY`].
    pub fn is_significant(&self) -> bool {
        self.luminance_change_percent().abs() > WARN_LUMINANCE_PERCENT
            || self.delta_xy().is_some_and(|d| d > WARN_DELTA_XY)
    }

    /// One line for the console and the report.
    pub fn summary(&self) -> String {
        let xy = self
            .delta_xy()
            .map_or_else(|| "-".to_string(), |d| format!("{d:.4}"));
        let verdict = if self.is_significant() {
            "the wall drifted during the run: the first and last displays were measured at \
             different lamp states; re-run with --warm-up"
        } else {
            "within the drift limits"
        };
        format!(
            "drift over the run ({} white re-read at the end): luminance {:+.2} %, Δxy {xy} ({verdict})",
            self.display,
            self.luminance_change_percent()
        )
    }
}

/// Reads `display`'s white again and compares it with `white_then` (a white now too
/// dark for the meter counts as no light). A `white_then` that is not positive gives
/// `None` (nothing to compare).
pub fn recheck(
    rig: &mut Rig<'_>,
    display: &DisplayInfo,
    key: &DisplayKey,
    white_then: Xyz,
    opts: &MeasureOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Option<DriftCheck>, MeasureError> {
    if white_then.y.is_nan() || white_then.y <= 0.0 {
        return Ok(None);
    }
    let mut session = Session::start(rig, key, display.id, opts.spot_uv, opts)?;
    // Too dark for the meter now: the lamp went out or dimmed far; a -100 % drift.
    let white_now = session
        .sample(Patch::White, true, progress)?
        .unwrap_or_default();
    Ok(Some(DriftCheck {
        display: key.to_string(),
        white_then,
        white_now,
    }))
}
