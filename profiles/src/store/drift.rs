//! Drift of one display between two of its profiles (nightly drift tracking).
//!
//! The display's white here is its *native* full-drive white with black removed,
//! the sum of the measured primaries `primaries_xyz_cd_m2`: that is what a lamp's
//! ageing or a colour wheel's wear changes. The wall's target white stays fixed
//! between re-solves and so would hide drift.

use jiff::Timestamp;

use lumiwall_core::Xyz;

use crate::{DisplayKey, DisplayProfile};

/// How one display changed between a baseline profile and a current one.
#[derive(Debug, Clone, PartialEq)]
pub struct Drift {
    /// The display (from the current profile).
    pub display: DisplayKey,
    /// Time of the run that measured the baseline profile.
    pub baseline_utc: Timestamp,
    /// Time of the run that measured the current profile.
    pub current_utc: Timestamp,
    /// Number of profiles of this display from baseline to current, both included.
    pub profiles: usize,
    /// Native white luminance Y (cd/m², black excluded) of the baseline.
    pub baseline_white_y_cd_m2: f64,
    /// Native white luminance Y (cd/m², black excluded) now.
    pub current_white_y_cd_m2: f64,
    /// `100 · (Y_now − Y_base) / Y_base`; `None` if the baseline white is not positive.
    pub white_luminance_change_pct: Option<f64>,
    /// Euclidean distance of the native white's CIE 1931 xy, baseline to now; `None`
    /// if either white has no chromaticity (X + Y + Z ≤ 0).
    pub white_delta_xy: Option<f64>,
    /// Black luminance Y (cd/m²) of the baseline, all channels at drive 0.
    pub baseline_black_y_cd_m2: f64,
    /// Black luminance Y (cd/m²) now.
    pub current_black_y_cd_m2: f64,
    /// `Y_black_now − Y_black_base` in cd/m².
    pub black_change_cd_m2: f64,
    /// Channel usage now minus channel usage of the baseline, per channel R, G, B, in
    /// linear relative intensity (0.05 = five percentage points more of the channel
    /// is needed for the target white).
    pub channel_usage_change: [f64; 3],
    /// Channel usage now, R, G, B (1.0 = the channel is at full drive for white).
    pub current_channel_usage: [f64; 3],
}

/// Native white XYZ (cd/m², black excluded): the sum of the measured primaries.
pub fn native_white_xyz_cd_m2(p: &DisplayProfile) -> [f64; 3] {
    let m = &p.primaries_xyz_cd_m2;
    [
        m[0][0] + m[1][0] + m[2][0],
        m[0][1] + m[1][1] + m[2][1],
        m[0][2] + m[1][2] + m[2][2],
    ]
}

/// CIE 1931 xy of an XYZ triple; `None` where X + Y + Z is not positive.
pub fn xy_of(xyz: [f64; 3]) -> Option<[f64; 2]> {
    Xyz::from_array(xyz).xy()
}

impl Drift {
    /// Drift from `baseline` (measured at `baseline_utc`) to `current` (at
    /// `current_utc`); `profiles` is how many profiles the window held.
    pub fn between(
        baseline: &DisplayProfile,
        baseline_utc: Timestamp,
        current: &DisplayProfile,
        current_utc: Timestamp,
        profiles: usize,
    ) -> Drift {
        let wb = native_white_xyz_cd_m2(baseline);
        let wc = native_white_xyz_cd_m2(current);
        let white_luminance_change_pct = (wb[1] > 0.0).then(|| 100.0 * (wc[1] - wb[1]) / wb[1]);
        let white_delta_xy = match (
            Xyz::from_array(wb).chromaticity(),
            Xyz::from_array(wc).chromaticity(),
        ) {
            (Some(a), Some(b)) => Some(b.distance(a)),
            _ => None,
        };
        let bu = baseline.channel_usage;
        let cu = current.channel_usage;
        Drift {
            display: current.display.clone(),
            baseline_utc,
            current_utc,
            profiles,
            baseline_white_y_cd_m2: wb[1],
            current_white_y_cd_m2: wc[1],
            white_luminance_change_pct,
            white_delta_xy,
            baseline_black_y_cd_m2: baseline.black_xyz_cd_m2[1],
            current_black_y_cd_m2: current.black_xyz_cd_m2[1],
            black_change_cd_m2: current.black_xyz_cd_m2[1] - baseline.black_xyz_cd_m2[1],
            channel_usage_change: [cu[0] - bu[0], cu[1] - bu[1], cu[2] - bu[2]],
            current_channel_usage: cu,
        }
    }
}

/// The drift a technician accepts before re-commissioning (`None`: not checked).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DriftLimits {
    /// Largest |white luminance change| in percent.
    pub max_luminance_change_pct: Option<f64>,
    /// Largest white Δxy (CIE 1931).
    pub max_delta_xy: Option<f64>,
}

impl DriftLimits {
    /// One line per display and quantity over its limit, e.g.
    /// `display 3 left: white Δxy 0.0061 (limit 0.005)`; empty when all are within.
    pub fn violations(&self, drifts: &[Drift]) -> Vec<String> {
        let mut over = Vec::new();
        for d in drifts {
            if let (Some(limit), Some(v)) =
                (self.max_luminance_change_pct, d.white_luminance_change_pct)
                && v.abs() > limit
            {
                over.push(format!(
                    "display {} {}: white luminance {v:+.2} % (limit ±{limit} %)",
                    d.display.display, d.display.eye
                ));
            }
            if let (Some(limit), Some(v)) = (self.max_delta_xy, d.white_delta_xy)
                && v > limit
            {
                over.push(format!(
                    "display {} {}: white Δxy {v:.4} (limit {limit})",
                    d.display.display, d.display.eye
                ));
            }
        }
        over
    }
}
