//! Verification: show target colours through each display's profile, read them back
//! with the meter and compare with what the wall should show (Kresse 3.3.8, DESIGN.md
//! step 7).
//!
//! Targets are absolute XYZ inputs (cd/m², what the post pass receives). What the wall
//! should then show depends on the black mode: `Ignore` adds the display's own black,
//! `Individual` shows the input itself, `Common` adds the common black. Per patch the
//! report gives ΔL % (luminance), Δxy and ΔE2000, where CIELAB is taken relative to the
//! wall white as shown (luminance-absolute: a 5 % luminance error is a lightness error).
//! In `Common` black mode the black (input 0) of every display is measured too and
//! compared with the common black.
//!
//! On a dim wall each reading of the chart averages as many meter readings as the
//! commissioning's rule asks for the wall white verified ([`VerifyOptions::averaging`],
//! [`crate::measure::averaging::needed`]): the station meter's verdict on the darkest
//! greys is then as quiet as the readings the calibration was made from.

// Errors carry the display, the reading and the device error for the technician and
// occur at most once per run, so their size does not matter.
#![allow(
    clippy::result_large_err,
    reason = "errors carry the display, the reading and the device error and occur at most once per run"
)]

use lumiwall_devices::{DisplayInfo, Xyz};
use lumiwall_profiles::apply::{ApplyError, ApplyOptions, PreparedProfile};
use lumiwall_profiles::{BlackMode, DisplayKey, DisplayProfile};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::colorimetry::delta_e2000_xyz;
use crate::measure::averaging::{self, Averaging};
use crate::measure::meter_offset::CorrectedMeter;
use crate::measure::{MeasureError, MeasureOptions, Patch, Progress, Rig, Session};
use lumiwall_core::lab::delta_c2000_xyz;

/// One target colour.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Target {
    /// Short name ("grey 50 %", "skin light").
    pub name: String,
    /// Input XYZ in cd/m² (black excluded).
    pub xyz: Xyz,
}

/// Why the default targets could not be made.
#[derive(Debug, thiserror::Error)]
pub enum VerifyError {
    /// No profiles to verify.
    #[error("no profiles given")]
    NoProfiles,
    /// The profiles were not made together (different white or common gamut).
    #[error(
        "profile of {display} has another target white or common gamut than the first one; \
         verify only profiles of one commissioning run"
    )]
    Inconsistent {
        /// The display that differs.
        display: String,
    },
    /// A display of the wall has no profile.
    #[error("no profile for {0} in the profile folder; re-run `lumiwall commission`")]
    MissingProfile(String),
    /// The common primaries do not span a colour space.
    #[error("the profiles' common primaries are degenerate; re-run `lumiwall commission`")]
    Degenerate,
    /// A measurement failed.
    #[error(transparent)]
    Measure(#[from] MeasureError),
    /// A profile cannot be used by the post pass.
    #[error(transparent)]
    Apply(#[from] ApplyError),
}

/// How to verify.
#[derive(Debug, Clone, PartialEq)]
pub struct VerifyOptions {
    /// Number of target colours (20 by default).
    pub patches: usize,
    /// Spot to read (normalised display coordinates).
    pub spot_uv: [f64; 2],
    /// Meter handling (retries, low-light averaging); the budget is ignored.
    pub measure: MeasureOptions,
    /// Readings averaged for the black comparison in `Common` mode.
    pub black_repeats: u32,
    /// The meter's xy correction from commissioning (same instrument), if any.
    pub meter_xy_offset: Option<[f64; 2]>,
    /// Check first whether the wall is still warming, and wait for it when it is
    /// ([`crate::measure::warm_up::wait_or_check`] on the first display; `measure`'s
    /// `warm_up` waits without the check). A calibration is made for the warm wall: on
    /// lamps still warming the chart would judge a state the wall is not used in (and
    /// on the virtual wall, whose lamps start at the wall file's minutes after
    /// switch-on in every process, a commissioning that waited would be verified cold).
    /// `None` (the default): read at once.
    pub warm_check: Option<crate::measure::warm_up::WarmCheck>,
    /// Meter readings each reading of the chart averages (the warm check reads once):
    /// [`Averaging::Auto`] as the commissioning's rule asks for the dimmest profile's
    /// target white ([`readings_per_reading`]); `Fixed(1)`, the default, reads once.
    pub averaging: Averaging,
}

impl Default for VerifyOptions {
    fn default() -> Self {
        Self {
            patches: 20,
            spot_uv: [0.5, 0.5],
            measure: MeasureOptions::default(),
            black_repeats: 8,
            meter_xy_offset: None,
            warm_check: None,
            averaging: Averaging::default(),
        }
    }
}

/// Result of one patch on one display.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PatchResult {
    /// Display.
    pub display: DisplayKey,
    /// Target name.
    pub target: String,
    /// Drive values sent (0..=1).
    pub drive: [f64; 3],
    /// What the wall should show (cd/m², black included).
    pub expected: Xyz,
    /// What the meter read.
    pub measured: Xyz,
    /// Luminance error in percent of the expected luminance.
    pub delta_l_percent: f64,
    /// Chromaticity distance in xy.
    pub delta_xy: f64,
    /// CIEDE2000 relative to the wall white.
    pub delta_e2000: f64,
    /// Its chroma term ΔC'/S_C (signed: positive when more chromatic than expected).
    #[serde(default)]
    pub delta_c2000: f64,
    /// For a grey of at least 1 % of the white's luminance: the chroma term with the
    /// measured colour taken relative to the display's measured white (the expected
    /// one relative to the target white), so that it shows how neutral the grey axis is
    /// against the white the display really shows, as DisplayCAL's "gray balance"
    /// does; the white's own error is the white ΔE2000. `None` for other patches.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grey_delta_c2000: Option<f64>,
    /// For the white patch: ΔE2000 of its colour alone, the measured white scaled to
    /// the target's luminance, as DisplayCAL's "measured vs. assumed target whitepoint"
    /// (its luminance error is [`PatchResult::delta_l_percent`]). `None` for other
    /// patches.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub white_colour_de2000: Option<f64>,
}

impl PatchResult {
    /// A neutral target (white, a grey or a dark grey): counts for the grey balance.
    pub fn is_neutral(&self) -> bool {
        self.target == "white"
            || self.target.starts_with("grey")
            || self.target.starts_with("dark grey")
    }
}

/// Median and maximum of the errors of a group of patches.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Patches in the group.
    pub patches: usize,
    /// Median ΔE2000.
    pub median_de: f64,
    /// Largest ΔE2000.
    pub max_de: f64,
    /// Mean ΔE2000.
    #[serde(default)]
    pub mean_de: f64,
    /// 95th percentile of ΔE2000 (nearest rank).
    #[serde(default)]
    pub p95_de: f64,
    /// ΔE2000 of the white patch's colour (luminance normalised,
    /// [`PatchResult::white_colour_de2000`]), when the targets have one.
    #[serde(default)]
    pub white_de: Option<f64>,
    /// Luminance error of the white patch in percent (the largest in magnitude), when
    /// the targets have one.
    #[serde(default)]
    pub white_dl_percent: Option<f64>,
    /// Grey balance: mean |ΔC'| (CIEDE2000 chroma term) over the greys of at least 1 %
    /// of the white's luminance, each relative to its display's measured white
    /// ([`PatchResult::grey_delta_c2000`]), when there are any.
    #[serde(default)]
    pub grey_balance: Option<f64>,
    /// Median |ΔL| in percent.
    pub median_abs_dl_percent: f64,
    /// Largest |ΔL| in percent.
    pub max_abs_dl_percent: f64,
    /// Median Δxy.
    pub median_dxy: f64,
    /// Largest Δxy.
    pub max_dxy: f64,
}

impl Summary {
    /// Summarises a group of patches.
    pub fn of<'a>(patches: impl IntoIterator<Item = &'a PatchResult>) -> Self {
        let mut de = Vec::new();
        let mut dl = Vec::new();
        let mut dxy = Vec::new();
        let mut white_de = None;
        let mut white_dl: Option<f64> = None;
        let mut grey = Vec::new();
        for p in patches {
            de.push(p.delta_e2000);
            dl.push(p.delta_l_percent.abs());
            dxy.push(p.delta_xy);
            if p.target == "white" {
                let de = p.white_colour_de2000.unwrap_or(p.delta_e2000);
                white_de = Some(white_de.map_or(de, |w: f64| w.max(de)));
                let dl = p.delta_l_percent;
                white_dl = Some(white_dl.map_or(dl, |w| if dl.abs() > w.abs() { dl } else { w }));
            }
            if let Some(c) = p.grey_delta_c2000 {
                grey.push(c.abs());
            }
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
        Self {
            patches: de.len(),
            mean_de: mean(&de),
            white_de,
            white_dl_percent: white_dl,
            grey_balance: (!grey.is_empty()).then(|| mean(&grey)),
            median_de: median(&mut de),
            p95_de: percentile(&de, 0.95),
            max_de: max(&de),
            median_abs_dl_percent: median(&mut dl),
            max_abs_dl_percent: max(&dl),
            median_dxy: median(&mut dxy),
            max_dxy: max(&dxy),
        }
    }
}

impl Summary {
    /// The mean, white and grey-balance limits, one line each where exceeded.
    fn displaycal_violations(&self, key: &DisplayKey, tol: &Tolerances) -> Vec<String> {
        let mut v = Vec::new();
        if self.mean_de > tol.mean_de {
            v.push(format!(
                "{key}: mean ΔE2000 {:.2} > {:.2}",
                self.mean_de, tol.mean_de
            ));
        }
        if let Some(w) = self.white_de.filter(|w| *w > tol.white_de) {
            v.push(format!("{key}: white ΔE2000 {w:.2} > {:.2}", tol.white_de));
        }
        if let Some(g) = self.grey_balance.filter(|g| *g > tol.grey_balance) {
            v.push(format!(
                "{key}: grey balance |ΔC'| {g:.2} > {:.2}",
                tol.grey_balance
            ));
        }
        v
    }
}

/// Median (mean of the middle two for even counts); NaN sorts last; 0 when empty.
pub fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The `q` quantile of `v` by nearest rank; 0 when empty.
fn percentile(v: &[f64], q: f64) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let rank = (q * s.len() as f64).ceil() as usize;
    s.get(rank.saturating_sub(1)).copied().unwrap_or(0.0)
}

fn max(v: &[f64]) -> f64 {
    v.iter().copied().fold(0.0, f64::max)
}

/// One display's black compared with the common black.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BlackResult {
    /// Display.
    pub display: DisplayKey,
    /// Expected (common) black, cd/m².
    pub expected: Xyz,
    /// Measured black (averaged), cd/m².
    pub measured: Xyz,
    /// Luminance difference in percent of the expected.
    pub delta_l_percent: f64,
    /// Chromaticity distance.
    pub delta_xy: f64,
}

/// Tolerances of a verification.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Tolerances {
    /// Largest ΔE2000 allowed on any patch.
    pub max_de: f64,
    /// Largest median ΔE2000 allowed, per display and overall.
    pub median_de: f64,
    /// Largest mean ΔE2000 allowed, per display (DisplayCAL's recommended: 1).
    pub mean_de: f64,
    /// Largest ΔE2000 of the white patch (DisplayCAL: 1), where the targets have one.
    pub white_de: f64,
    /// Largest grey balance, mean |ΔC'| over the neutral patches.
    pub grey_balance: f64,
    /// Largest black luminance difference (percent) between a display and the common
    /// black (`Common` mode only).
    pub black_dl_percent: f64,
    /// Largest black chromaticity difference (`Common` mode only).
    pub black_dxy: f64,
}

impl Default for Tolerances {
    /// 1.5 / 0.5 ΔE2000 (max, median); mean and white 1 (DisplayCAL's recommended
    /// values), grey balance 0.5; black within a CS-100A's low-light error (5 %, 0.008
    /// xy).
    fn default() -> Self {
        Self {
            max_de: 1.5,
            median_de: 0.5,
            mean_de: 1.0,
            white_de: 1.0,
            grey_balance: 0.5,
            black_dl_percent: 5.0,
            black_dxy: 0.008,
        }
    }
}

/// Everything a verification found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VerifyReport {
    /// Targets used.
    pub targets: Vec<Target>,
    /// Every patch on every display.
    pub patches: Vec<PatchResult>,
    /// Per display, in order.
    pub per_display: Vec<(DisplayKey, Summary)>,
    /// All patches together.
    pub overall: Summary,
    /// Black comparison (`Common` mode only).
    pub black: Vec<BlackResult>,
    /// Readings taken (each the mean of `readings_per_reading` meter readings).
    pub readings: u32,
    /// Infitec walls: ΔE2000 between the left and the right eye's readings of the same
    /// target on the same tile (what a viewer sees as a stereo colour mismatch).
    #[serde(default)]
    pub eyes_delta_e2000: Vec<f64>,
    /// Meter readings each reading averaged ([`VerifyOptions::averaging`]); 1 in
    /// reports written before it.
    #[serde(default = "one")]
    pub readings_per_reading: u32,
}

/// For `#[serde(default)]`.
fn one() -> u32 {
    1
}

impl VerifyReport {
    /// Violations of `tol`, one technician-readable line each; empty when within.
    pub fn violations(&self, tol: &Tolerances) -> Vec<String> {
        let mut v = Vec::new();
        for (key, s) in &self.per_display {
            if s.max_de > tol.max_de {
                v.push(format!(
                    "{key}: max ΔE2000 {:.2} > {:.2}",
                    s.max_de, tol.max_de
                ));
            }
            if s.median_de > tol.median_de {
                v.push(format!(
                    "{key}: median ΔE2000 {:.2} > {:.2}",
                    s.median_de, tol.median_de
                ));
            }
            v.extend(s.displaycal_violations(key, tol));
        }
        if self.overall.median_de > tol.median_de {
            v.push(format!(
                "overall median ΔE2000 {:.2} > {:.2}",
                self.overall.median_de, tol.median_de
            ));
        }
        for b in &self.black {
            if b.delta_l_percent.abs() > tol.black_dl_percent || b.delta_xy > tol.black_dxy {
                v.push(format!(
                    "{}: black {:.3} cd/m² differs from the common black {:.3} cd/m² by {:+.1} % / Δxy {:.4}",
                    b.display, b.measured.y, b.expected.y, b.delta_l_percent, b.delta_xy
                ));
            }
        }
        v
    }

    /// Per-patch table (plain text).
    pub fn patch_table(&self) -> String {
        let mut s = String::from(
            "display          patch            exp Y cd/m²  meas Y cd/m²    ΔL %     Δxy   ΔE2000\n",
        );
        for p in &self.patches {
            s.push_str(&format!(
                "{:<16} {:<16} {:>11.3} {:>13.3} {:>7.2} {:>7.4} {:>8.3}\n",
                p.display.file_stem(),
                p.target,
                p.expected.y,
                p.measured.y,
                p.delta_l_percent,
                p.delta_xy,
                p.delta_e2000
            ));
        }
        s
    }

    /// Summary table (plain text): per display and overall, then the black check.
    pub fn summary_table(&self) -> String {
        let mut s = String::from(
            "display          patches  median ΔE  max ΔE  median |ΔL| %  max |ΔL| %  median Δxy  max Δxy  mean ΔE  p95 ΔE  white ΔE  white ΔL %  grey |ΔC'|\n",
        );
        let opt = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |v| format!("{v:.3}"));
        let row = |name: &str, m: &Summary| {
            format!(
                "{:<16} {:>7} {:>10.3} {:>7.3} {:>14.2} {:>11.2} {:>11.4} {:>8.4} {:>8.3} {:>7.3} {:>9} {:>11} {:>11}\n",
                name,
                m.patches,
                m.median_de,
                m.max_de,
                m.median_abs_dl_percent,
                m.max_abs_dl_percent,
                m.median_dxy,
                m.max_dxy,
                m.mean_de,
                m.p95_de,
                opt(m.white_de),
                m.white_dl_percent
                    .map_or_else(|| "-".to_string(), |v| format!("{v:+.2}")),
                opt(m.grey_balance)
            )
        };
        for (key, m) in &self.per_display {
            s.push_str(&row(&key.file_stem(), m));
        }
        s.push_str(&row("OVERALL", &self.overall));
        if !self.eyes_delta_e2000.is_empty() {
            let mut v = self.eyes_delta_e2000.clone();
            s.push_str(&format!(
                "left/right eyes at the same patches: median ΔE2000 {:.3}, max {:.3} ({} pairs)\n",
                median(&mut v),
                max(&v),
                v.len()
            ));
        }
        if !self.black.is_empty() {
            s.push_str("\ncommon black check (input 0 on every display)\n");
            s.push_str("display          exp Y cd/m²  meas Y cd/m²    ΔL %     Δxy\n");
            for b in &self.black {
                s.push_str(&format!(
                    "{:<16} {:>11.4} {:>13.4} {:>7.2} {:>7.4}\n",
                    b.display.file_stem(),
                    b.expected.y,
                    b.measured.y,
                    b.delta_l_percent,
                    b.delta_xy
                ));
            }
        }
        s
    }
}

/// Common-RGB (linear, 1 = target white) → XYZ matrix of a set of profiles.
fn common_rgb_to_xyz(p: &DisplayProfile) -> Option<Matrix3<f64>> {
    let cols: Vec<Vector3<f64>> = p
        .common_primaries_xy
        .iter()
        .map(|[x, y]| {
            if *y <= 0.0 {
                Vector3::zeros()
            } else {
                Vector3::new(x / y, 1.0, (1.0 - x - y) / y)
            }
        })
        .collect();
    let m = Matrix3::from_columns(&cols);
    let w = Vector3::from(p.target_white_xyz_cd_m2);
    let s = m.try_inverse()? * w;
    Some(m * Matrix3::from_diagonal(&s))
}

/// What `profile`'s display should show (cd/m², black included) for input `xyz`.
pub fn expected_shown(profile: &DisplayProfile, xyz: Xyz) -> Xyz {
    match profile.black_mode {
        BlackMode::Ignore => xyz + Xyz::from_array(profile.black_xyz_cd_m2),
        BlackMode::Individual => xyz,
        BlackMode::Common => xyz + Xyz::from_array(profile.shown_black_xyz_cd_m2),
    }
}

/// Linear relative channel intensities the profile asks for input `xyz`
/// (`xyz_to_drive · xyz + drive_offset`, then the display model's white segment taken
/// out; no flat field at the calibration spot).
pub fn linear_intensity(profile: &DisplayProfile, xyz: Xyz) -> [f64; 3] {
    let m = &profile.xyz_to_drive;
    let v = xyz.to_array();
    let lin = std::array::from_fn(|r| {
        m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2] + profile.drive_offset[r]
    });
    profile.display_model.channels_for(m, lin)
}

/// Drive values (0..=1) for input `xyz` at spot `uv` through the post pass
/// ([`lumiwall_profiles::apply`], the same arithmetic the renderer runs).
pub fn drive_for(prepared: &PreparedProfile, xyz: Xyz, uv: [f64; 2]) -> [f64; 3] {
    let out = prepared.apply(
        [xyz.x as f32, xyz.y as f32, xyz.z as f32],
        [uv[0] as f32, uv[1] as f32],
    );
    out.drive.map(f64::from)
}

/// The default target colours (in common linear RGB, 1 = wall white), by name.
const RGB_TARGETS: [(&str, [f64; 3]); 16] = [
    ("grey 90 %", [0.9, 0.9, 0.9]),
    ("grey 50 %", [0.5, 0.5, 0.5]),
    ("grey 20 %", [0.2, 0.2, 0.2]),
    ("grey 5 %", [0.05, 0.05, 0.05]),
    ("red", [0.8, 0.08, 0.08]),
    ("green", [0.08, 0.8, 0.08]),
    ("blue", [0.08, 0.08, 0.8]),
    ("cyan", [0.08, 0.7, 0.7]),
    ("magenta", [0.7, 0.08, 0.7]),
    ("yellow", [0.7, 0.7, 0.08]),
    ("skin light", [0.7, 0.45, 0.33]),
    ("skin dark", [0.32, 0.18, 0.12]),
    ("foliage", [0.12, 0.25, 0.05]),
    ("sky", [0.3, 0.45, 0.75]),
    ("orange", [0.8, 0.35, 0.05]),
    ("violet", [0.3, 0.1, 0.5]),
];

/// Dark targets: (name, colour in common RGB, luminance in cd/m²).
const DARK_TARGETS: [(&str, [f64; 3], f64); 4] = [
    ("dark grey 2", [1.0, 1.0, 1.0], 2.0),
    ("dark grey 1", [1.0, 1.0, 1.0], 1.0),
    ("dark red 1.5", [0.6, 0.15, 0.15], 1.5),
    ("dark blue 1.5", [0.15, 0.2, 0.6], 1.5),
];

/// The 51-patch chart (`verify --chart 51`), in the spirit of DisplayCAL's
/// verification charts: white, eleven greys, the primaries and secondaries at full and
/// half intensity, memory colours, and the dark patches of [`DARK_TARGETS`]; the rest
/// of the 51 from the quasi-random mixes.
const CHART_51: [(&str, [f64; 3]); 30] = [
    ("white", [1.0, 1.0, 1.0]),
    ("grey 95 %", [0.95, 0.95, 0.95]),
    ("grey 90 %", [0.9, 0.9, 0.9]),
    ("grey 80 %", [0.8, 0.8, 0.8]),
    ("grey 65 %", [0.65, 0.65, 0.65]),
    ("grey 50 %", [0.5, 0.5, 0.5]),
    ("grey 35 %", [0.35, 0.35, 0.35]),
    ("grey 20 %", [0.2, 0.2, 0.2]),
    ("grey 10 %", [0.1, 0.1, 0.1]),
    ("grey 5 %", [0.05, 0.05, 0.05]),
    ("grey 2 %", [0.02, 0.02, 0.02]),
    ("red", [1.0, 0.0, 0.0]),
    ("green", [0.0, 1.0, 0.0]),
    ("blue", [0.0, 0.0, 1.0]),
    ("cyan", [0.0, 1.0, 1.0]),
    ("magenta", [1.0, 0.0, 1.0]),
    ("yellow", [1.0, 1.0, 0.0]),
    ("red 50 %", [0.5, 0.0, 0.0]),
    ("green 50 %", [0.0, 0.5, 0.0]),
    ("blue 50 %", [0.0, 0.0, 0.5]),
    ("cyan 50 %", [0.0, 0.5, 0.5]),
    ("magenta 50 %", [0.5, 0.0, 0.5]),
    ("yellow 50 %", [0.5, 0.5, 0.0]),
    ("skin light", [0.7, 0.45, 0.33]),
    ("skin medium", [0.5, 0.3, 0.2]),
    ("skin dark", [0.32, 0.18, 0.12]),
    ("foliage", [0.12, 0.25, 0.05]),
    ("sky", [0.3, 0.45, 0.75]),
    ("orange", [0.8, 0.35, 0.05]),
    ("violet", [0.3, 0.1, 0.5]),
];

/// Patches of the chart `verify --chart` names.
pub const CHART_PATCHES: usize = 51;

/// The 51-patch chart for a wall (white, greys, primaries and secondaries at full and
/// half intensity, memory colours, then dark patches, then mixes), each checked as
/// [`default_targets`] checks its own.
pub fn chart_targets(profiles: &[DisplayProfile]) -> Result<Vec<Target>, VerifyError> {
    targets_from(profiles, &CHART_51, CHART_PATCHES)
}

/// Van der Corput radical inverse, for deterministic extra targets.
fn radical_inverse(mut i: u32, base: u32) -> f64 {
    let mut f = 1.0;
    let mut r = 0.0;
    while i > 0 {
        f /= f64::from(base);
        r += f * f64::from(i % base);
        i /= base;
    }
    r
}

/// True when every profile can show `xyz` with channel intensities in 0..=headroom
/// (small tolerance).
fn showable(profiles: &[DisplayProfile], xyz: Xyz) -> bool {
    profiles.iter().all(|p| {
        linear_intensity(p, xyz)
            .iter()
            .all(|l| *l >= -1e-6 && *l <= p.headroom + 1e-6)
    })
}

/// The default `n` target colours for a wall: greys, primaries, secondaries, skin,
/// foliage and sky, dark colours near 1–2 cd/m²; beyond 20, quasi-random colours.
/// Every target is inside the common gamut, below the white and showable on every
/// display; a target that is not (e.g. a dark colour below a display's black in
/// `Individual` mode) is replaced by a brighter one.
pub fn default_targets(profiles: &[DisplayProfile], n: usize) -> Result<Vec<Target>, VerifyError> {
    targets_from(profiles, &RGB_TARGETS, n)
}

/// `n` targets: `named` first, then the dark ones, then quasi-random mixes.
fn targets_from(
    profiles: &[DisplayProfile],
    named: &[(&str, [f64; 3])],
    n: usize,
) -> Result<Vec<Target>, VerifyError> {
    let first = profiles.first().ok_or(VerifyError::NoProfiles)?;
    for p in profiles {
        let same = p
            .target_white_xyz_cd_m2
            .iter()
            .zip(first.target_white_xyz_cd_m2.iter())
            .all(|(a, b)| (a - b).abs() <= 1e-9 * b.abs().max(1.0))
            && p.common_primaries_xy == first.common_primaries_xy;
        if !same {
            return Err(VerifyError::Inconsistent {
                display: p.display.to_string(),
            });
        }
    }
    let m = common_rgb_to_xyz(first).ok_or(VerifyError::Degenerate)?;
    let to_xyz = |rgb: [f64; 3]| Xyz::from(m * Vector3::from(rgb));
    let mut out = Vec::with_capacity(n);
    let push = |name: String, xyz: Xyz, out: &mut Vec<Target>| {
        if out.len() < n && showable(profiles, xyz) {
            out.push(Target { name, xyz });
        }
    };
    for &(name, rgb) in named {
        push(name.to_string(), to_xyz(rgb), &mut out);
    }
    let white_y = first.target_white_xyz_cd_m2[1];
    for (name, rgb, y) in DARK_TARGETS {
        let c = to_xyz(rgb);
        if c.y <= 0.0 {
            continue;
        }
        // Raise a dark target step by step until every display can show it.
        let mut level = y;
        while level < 0.5 * white_y {
            let xyz = c * (level / c.y);
            if showable(profiles, xyz) {
                let label = if (level - y).abs() < 1e-9 {
                    name.to_string()
                } else {
                    format!("{name} @{level:.1}")
                };
                push(label, xyz, &mut out);
                break;
            }
            level *= 1.25;
        }
    }
    let mut i = 1u32;
    while out.len() < n && i < 100_000 {
        let rgb = [
            0.05 + 0.85 * radical_inverse(i, 2),
            0.05 + 0.85 * radical_inverse(i, 3),
            0.05 + 0.85 * radical_inverse(i, 5),
        ];
        push(format!("mix {i}"), to_xyz(rgb), &mut out);
        i += 1;
    }
    Ok(out)
}

fn delta_xy(a: Xyz, b: Xyz) -> f64 {
    match (a.xy(), b.xy()) {
        (Some(p), Some(q)) => ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt(),
        _ => f64::NAN,
    }
}

fn delta_l_percent(expected: Xyz, measured: Xyz) -> f64 {
    if expected.y > 0.0 {
        100.0 * (measured.y - expected.y) / expected.y
    } else {
        f64::NAN
    }
}

/// One display being verified: its profile, prepared for the post pass.
struct DisplayUnderTest<'p> {
    profile: &'p DisplayProfile,
    prepared: PreparedProfile,
    spot_uv: [f64; 2],
    /// The white ΔE2000 is relative to: the profile's target white as shown.
    reference_white: Xyz,
}

impl<'p> DisplayUnderTest<'p> {
    /// `info`'s profile among `profiles`, prepared for the post pass, read at
    /// `spot_uv`.
    fn of(
        info: &DisplayInfo,
        profiles: &'p [DisplayProfile],
        spot_uv: [f64; 2],
    ) -> Result<Self, VerifyError> {
        let profile = profiles
            .iter()
            .find(|p| p.display.display == info.id.0 && p.display.eye == info.eye)
            .ok_or_else(|| VerifyError::MissingProfile(info.name.clone()))?;
        Ok(Self {
            profile,
            prepared: PreparedProfile::new(profile, &ApplyOptions::default())?,
            spot_uv,
            reference_white: expected_shown(
                profile,
                Xyz::from_array(profile.target_white_xyz_cd_m2),
            ),
        })
    }
}

impl DisplayUnderTest<'_> {
    /// Shows `target` through the profile, reads it and compares with what the
    /// display should show.
    fn read_target(
        &self,
        s: &mut Session<'_, '_>,
        target: &Target,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<PatchResult, VerifyError> {
        let drive = drive_for(&self.prepared, target.xyz, self.spot_uv);
        let measured = s
            .sample(Patch::Drive(drive), true, progress)?
            .unwrap_or_default();
        let expected = expected_shown(self.profile, target.xyz);
        Ok(PatchResult {
            display: self.profile.display.clone(),
            target: target.name.clone(),
            drive,
            expected,
            measured,
            delta_l_percent: delta_l_percent(expected, measured),
            delta_xy: delta_xy(expected, measured),
            delta_e2000: delta_e2000_xyz(expected, measured, self.reference_white),
            delta_c2000: delta_c2000_xyz(expected, measured, self.reference_white),
            grey_delta_c2000: None,
            white_colour_de2000: None,
        })
    }

    /// Reads the black (input 0) `n` times ([`common_black_readings`]), all pooled, so
    /// that readings refused below the meter's floor count once each
    /// ([`Session::averaged`]), against the common black; every reading refused reads
    /// as 0.
    fn read_black(
        &self,
        s: &mut Session<'_, '_>,
        n: u32,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<BlackResult, VerifyError> {
        let drive = drive_for(&self.prepared, Xyz::default(), self.spot_uv);
        let patch = Patch::Drive(drive);
        let measured = s
            .averaged(patch, n, progress)?
            .map_or_else(Xyz::default, |(mean, _)| mean);
        let expected = Xyz::from_array(self.profile.shown_black_xyz_cd_m2);
        Ok(BlackResult {
            display: self.profile.display.clone(),
            expected,
            measured,
            delta_l_percent: delta_l_percent(expected, measured),
            delta_xy: delta_xy(expected, measured),
        })
    }
}

/// Verifies every display: shows each target through its profile, reads it and
/// compares. `displays` and `profiles` are matched by display index. The warm check
/// reads once; the chart's readings average as `opts.averaging` says.
pub fn verify_wall(
    rig: &mut Rig<'_>,
    displays: &[DisplayInfo],
    profiles: &[DisplayProfile],
    targets: &[Target],
    opts: &VerifyOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<VerifyReport, VerifyError> {
    let mut corrected = CorrectedMeter {
        inner: &mut *rig.meter,
        xy_offset: opts.meter_xy_offset.unwrap_or([0.0; 2]),
    };
    let mut rig = Rig {
        pattern: &mut *rig.pattern,
        meter: &mut corrected,
        positioner: &mut *rig.positioner,
    };
    let rig = &mut rig;
    let under_test = displays
        .iter()
        .map(|info| DisplayUnderTest::of(info, profiles, opts.spot_uv))
        .collect::<Result<Vec<_>, _>>()?;
    let each = readings_per_reading(opts.averaging, rig.meter.info().noise.as_ref(), profiles);
    let per_display_readings =
        readings_per_display(targets.len(), opts, profiles).saturating_mul(each);
    wait_if_warming(
        rig,
        displays,
        profiles,
        per_display_readings,
        opts,
        progress,
    )?;
    averaging::with_averaging(rig, each, |rig| {
        read_charts(rig, displays, &under_test, targets, opts, each, progress)
    })
}

/// Meter readings each reading of a verification of `profiles` averages with a meter
/// of this stated `noise`: a fixed count as it is (1 to
/// [`lumiwall_devices::averaging::MAX_AVERAGED`]); [`Averaging::Auto`] the most
/// [`averaging::needed`] asks for any profile's target white (an Infitec wall's eyes
/// differ in colour as well as luminance); 1 for a meter that states no noise, or
/// profiles without a white.
pub fn readings_per_reading(
    averaging: Averaging,
    noise: Option<&lumiwall_devices::ReadingNoise>,
    profiles: &[DisplayProfile],
) -> u32 {
    let Some(noise) = noise.filter(|_| averaging == Averaging::Auto) else {
        return averaging.count_or_one();
    };
    profiles
        .iter()
        .map(|p| Xyz::from_array(p.target_white_xyz_cd_m2))
        .filter(|w| w.y.is_finite() && w.y > 0.0)
        .filter_map(|w| Some(averaging::needed(noise, w.xy()?, w.y).0))
        .max()
        .unwrap_or(1)
}

/// Reads every display's chart ([`verify_wall`] after its warm check) with `rig`'s
/// meter, each of its readings the mean of `readings_per_reading` meter readings.
fn read_charts(
    rig: &mut Rig<'_>,
    displays: &[DisplayInfo],
    under_test: &[DisplayUnderTest<'_>],
    targets: &[Target],
    opts: &VerifyOptions,
    readings_per_reading: u32,
    progress: &mut dyn FnMut(Progress),
) -> Result<VerifyReport, VerifyError> {
    let mut patches = Vec::new();
    let mut per_display = Vec::new();
    let mut black = Vec::new();
    let mut whites = Vec::new();
    let mut readings = 0;
    let mut mopts = opts.measure.clone();
    mopts.budget = u32::MAX;
    for (info, display) in displays.iter().zip(under_test) {
        let profile = display.profile;
        let key = &profile.display;
        whites.push((key.clone(), display.reference_white));
        let mut s = Session::start(rig, key, info.id, opts.spot_uv, &mopts)?;
        let start = patches.len();
        for t in targets {
            patches.push(display.read_target(&mut s, t, progress)?);
        }
        if profile.black_mode == BlackMode::Common {
            let n = common_black_readings(opts);
            black.push(display.read_black(&mut s, n, progress)?);
        }
        readings += s.log.readings;
        judge_against_the_white(&mut patches[start..], display.reference_white);
        per_display.push((key.clone(), Summary::of(&patches[start..])));
        progress(Progress::DisplayDone {
            display: info.id,
            readings: s.log.readings,
        });
    }
    let overall = Summary::of(&patches);
    let eyes_delta_e2000 = eye_differences(&patches, &whites);
    Ok(VerifyReport {
        targets: targets.to_vec(),
        patches,
        per_display,
        overall,
        black,
        readings,
        eyes_delta_e2000,
        readings_per_reading,
    })
}

/// Readings of one display's chart for the warm check's extrapolation: its patches and,
/// where a profile keeps the common black, the black's readings (its repeats, each as
/// many as the low-light policy averages; the darker patches' low-light averages come
/// on top).
fn readings_per_display(patches: usize, opts: &VerifyOptions, profiles: &[DisplayProfile]) -> u32 {
    let common = profiles.iter().any(|p| p.black_mode == BlackMode::Common);
    let black = if common {
        common_black_readings(opts)
    } else {
        0
    };
    u32::try_from(patches)
        .unwrap_or(u32::MAX)
        .saturating_add(black)
}

/// Readings of a display's black in common black mode: `opts.black_repeats` dark
/// samples' worth, each as many readings as the low-light policy averages
/// ([`crate::measure::LowLight::black_readings`]), even where the black is above the
/// reliable limit.
fn common_black_readings(opts: &VerifyOptions) -> u32 {
    let repeats = opts.black_repeats.max(1);
    repeats.saturating_mul(opts.measure.low_light.black_readings())
}

/// Before a verification: [`VerifyOptions::warm_check`] (or the wait
/// `opts.measure.warm_up`) on the first display the technician does not skip while
/// aiming, extrapolated over `per_display` readings of every display (`profiles` name
/// the wall). A wall whose lamps do not settle within the wait is verified as it is,
/// with a warning: the verdict then shows the drift. [`verify_wall`] calls it; the
/// spatial verification's caller calls it before the grid.
pub fn wait_if_warming(
    rig: &mut Rig<'_>,
    displays: &[DisplayInfo],
    profiles: &[DisplayProfile],
    per_display: u32,
    opts: &VerifyOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<(), VerifyError> {
    let wall = profiles.first().map_or("", |p| p.display.wall.as_str());
    let run = crate::measure::warm_up::readings_of_run(per_display, displays.len());
    for first in displays {
        let checked = crate::measure::warm_up::wait_or_check(
            rig,
            wall,
            first,
            &opts.measure,
            opts.warm_check.as_ref(),
            run,
            progress,
        );
        match checked {
            Ok(true) => return Ok(()),
            Ok(false) => continue,
            Err(MeasureError::NotWarm {
                display: name,
                readings,
                change_percent,
            }) => {
                tracing::warn!(
                    "{name}: after {readings} readings of the wait the luminance still \
                     changes {change_percent:+.2} % over its last window; verifying the wall \
                     as it is"
                );
                return Ok(());
            }
            Err(e) => return Err(e.into()),
        }
    }
    Ok(())
}

/// DisplayCAL's judgement of one display's white and greys: on the white patch
/// [`PatchResult::white_colour_de2000`] (the measured white scaled to the target's
/// luminance), and on the greys of at least 1 % of `reference_white` (the target white
/// as shown) [`PatchResult::grey_delta_c2000`]: the expected grey in CIELAB of
/// `reference_white`, the measured one in CIELAB of the display's measured white.
/// Without a white patch (or a usable reading of it, e.g. the default targets) the
/// greys are judged against the target white instead.
fn judge_against_the_white(patches: &mut [PatchResult], reference_white: Xyz) {
    let Some(white) = patches
        .iter()
        .find(|p| p.target == "white")
        .map(|p| p.measured)
        .filter(|w| w.y > 0.0 && w.is_finite())
    else {
        for p in patches.iter_mut() {
            if p.is_neutral() && p.expected.y >= 0.01 * reference_white.y {
                p.grey_delta_c2000 = Some(p.delta_c2000);
            }
        }
        return;
    };
    for p in patches.iter_mut().filter(|p| p.target == "white") {
        let scaled = p.measured * (p.expected.y / white.y);
        p.white_colour_de2000 = Some(delta_e2000_xyz(p.expected, scaled, reference_white));
    }
    for p in patches.iter_mut() {
        let grey = p.is_neutral() && p.target != "white";
        if grey && p.expected.y >= 0.01 * reference_white.y {
            let target = lumiwall_core::lab::xyz_to_lab(p.expected, reference_white);
            let measured = lumiwall_core::lab::xyz_to_lab(p.measured, white);
            p.grey_delta_c2000 = Some(lumiwall_core::lab::delta_c2000(target, measured));
        }
    }
}

/// ΔE2000 between each left-eye patch and the right-eye patch of the same target on the
/// same tile, in CIELAB of the left display's reference white (`whites`).
fn eye_differences(patches: &[PatchResult], whites: &[(DisplayKey, Xyz)]) -> Vec<f64> {
    use lumiwall_core::Eye;
    let right: std::collections::HashMap<(u32, u32, &str), &PatchResult> = patches
        .iter()
        .filter(|r| r.display.eye == Eye::Right)
        .map(|r| {
            (
                (r.display.tile_col, r.display.tile_row, r.target.as_str()),
                r,
            )
        })
        .collect();
    let whites: std::collections::HashMap<&DisplayKey, Xyz> =
        whites.iter().map(|(k, w)| (k, *w)).collect();
    patches
        .iter()
        .filter(|l| l.display.eye == Eye::Left)
        .filter_map(|l| {
            let r = right.get(&(l.display.tile_col, l.display.tile_row, l.target.as_str()))?;
            let white = *whites.get(&l.display)?;
            Some(delta_e2000_xyz(l.measured, r.measured, white))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumiwall_core::{Eye, Xy};

    fn patch(target: &str, expected: Xyz, measured: Xyz, white: Xyz) -> PatchResult {
        PatchResult {
            display: DisplayKey {
                wall: "w".into(),
                display: 0,
                tile_col: 0,
                tile_row: 0,
                eye: Eye::Left,
            },
            target: target.into(),
            drive: [0.0; 3],
            expected,
            measured,
            delta_l_percent: delta_l_percent(expected, measured),
            delta_xy: delta_xy(expected, measured),
            delta_e2000: delta_e2000_xyz(expected, measured, white),
            delta_c2000: delta_c2000_xyz(expected, measured, white),
            grey_delta_c2000: None,
            white_colour_de2000: None,
        }
    }

    /// A display whose white and greys are all off by the same chromaticity has a
    /// white error but a neutral grey axis: grey balance ≈ 0. A grey off against its
    /// own white counts; greys below 1 % of the white do not.
    #[test]
    fn grey_balance_is_judged_against_the_displays_measured_white() {
        let target = Xy::new(0.2850, 0.2930);
        let shifted = Xy::new(0.2870, 0.2950);
        let white = target.with_luminance(80.0);
        let mut patches = vec![patch("white", white, shifted.with_luminance(80.0), white)];
        for (name, y) in [
            ("grey 50 %", 40.0),
            ("grey 10 %", 8.0),
            ("dark grey 1", 1.0),
        ] {
            let expected = target.with_luminance(y);
            patches.push(patch(name, expected, shifted.with_luminance(y), white));
        }
        let below = target.with_luminance(0.5);
        patches.push(patch(
            "dark grey 0.5",
            below,
            Xy::new(0.30, 0.31).with_luminance(0.5),
            white,
        ));
        judge_against_the_white(&mut patches, white);
        let s = Summary::of(&patches);
        assert!(s.white_de.unwrap() > 1.0, "white ΔE2000 {:?}", s.white_de);
        assert!(
            s.grey_balance.unwrap() < 0.02,
            "grey balance {:?}",
            s.grey_balance
        );
        assert_eq!(patches[4].grey_delta_c2000, None, "below 1 % of the white");

        // One grey 0.003 in y off against the white: its chroma counts.
        patches[2].measured = Xy::new(0.2870, 0.2980).with_luminance(8.0);
        judge_against_the_white(&mut patches, white);
        let s = Summary::of(&patches);
        let off = patches[2].grey_delta_c2000.unwrap().abs();
        assert!(off > 1.0, "the off grey's ΔC' {off}");
        assert!((s.grey_balance.unwrap() - off / 3.0).abs() < 0.02);

        // Without a white patch (the default targets) greys are judged against the
        // target white.
        let mut no_white = patches[1..].to_vec();
        judge_against_the_white(&mut no_white, white);
        assert_eq!(no_white[0].grey_delta_c2000, Some(no_white[0].delta_c2000));
        assert!(Summary::of(&no_white).white_de.is_none());
    }

    /// DisplayCAL's white ΔE2000 judges the white's colour: a white 2 % too bright in
    /// the right colour has none (its luminance error is the white ΔL), one 0.002 off
    /// in y at the right luminance has about one.
    #[test]
    fn the_white_de2000_is_its_colour_and_its_luminance_error_is_reported_beside_it() {
        let target = Xy::new(0.2850, 0.2930);
        let white = target.with_luminance(80.0);
        let mut bright = vec![patch("white", white, target.with_luminance(81.6), white)];
        judge_against_the_white(&mut bright, white);
        let s = Summary::of(&bright);
        assert!(s.white_de.unwrap() < 1e-9, "{:?}", s.white_de);
        assert!((s.white_dl_percent.unwrap() - 2.0).abs() < 1e-9);
        assert!(
            bright[0].delta_e2000 > 0.3,
            "the patch's own ΔE2000 keeps the luminance"
        );
        let off = Xy::new(0.2850, 0.2950).with_luminance(80.0);
        let mut tinted = vec![patch("white", white, off, white)];
        judge_against_the_white(&mut tinted, white);
        let de = Summary::of(&tinted).white_de.unwrap();
        assert!((0.5..2.0).contains(&de), "white ΔE2000 {de}");
    }
}
