//! The `DisplayProfile` type and its file format.

use std::path::Path;

use serde::{Deserialize, Serialize};

use lumiwall_core::{BitDepth, Channel, Headroom, Xy};
pub use lumiwall_core::{DisplayKey, Eye};

use crate::ProfileError;

pub use lumiwall_core::files::remove_stale_temp_files;

/// Version of the profile file format this build reads and writes.
pub const FORMAT_VERSION: u32 = 2;

/// Oldest format version this build still reads; older documents are upgraded on reading
/// (version 1 had no [`DisplayModel`]: every display was additive, which is exactly
/// [`DisplayModel::Additive`]).
pub const OLDEST_READABLE_VERSION: u32 = 1;

/// Smallest number of entries an inverse LUT may have.
pub const MIN_LUT_ENTRIES: usize = 1024;

/// How the display's black level is treated (Kresse 2003, 3.3.6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BlackMode {
    /// a) Black is ignored: the display adds its own black to every colour.
    Ignore,
    /// b) Individual black: the display's black is subtracted, colours below it clip at 0.
    Individual,
    /// c) Common black: every display shows the same (worst, raised) black for input 0;
    ///    the input is shown on top of it.
    Common,
}

/// What the post pass does with colours the display cannot show.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum OutOfGamut {
    /// Out-of-gamut colours move toward the display white in xy, over-range colours are
    /// scaled down at constant chromaticity.
    Clip,
    /// Out-of-gamut and over-range pixels are marked with false colours.
    FalseColour,
}

/// One channel's measured tone curve and its inverse.
///
/// "Relative intensity" is the channel's linear light output with black removed,
/// normalised to 1 at full drive; "drive" is the normalised input value 0..=1 sent
/// to the display (code value / max code).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ToneCurve {
    /// Samples `[drive, relative_intensity]` of the fitted, monotone forward curve,
    /// increasing in drive, from `[0, 0]` to `[1, 1]`.
    pub forward: Vec<[f64; 2]>,
    /// Inverse LUT: entry `i` is the drive that gives relative intensity
    /// `i / (len - 1)`. At least [`MIN_LUT_ENTRIES`] entries, non-decreasing, in 0..=1.
    pub inverse_lut: Vec<f32>,
}

impl ToneCurve {
    /// Drive for a relative intensity, by linear interpolation in the inverse LUT.
    /// The intensity is clamped to 0..=1.
    pub fn drive_for(&self, relative_intensity: f32) -> f32 {
        let n = self.inverse_lut.len();
        if n == 0 {
            return 0.0;
        }
        let t = relative_intensity.clamp(0.0, 1.0) * (n - 1) as f32;
        let i = (t.floor() as usize).min(n.saturating_sub(2));
        let f = t - i as f32;
        let a = self.inverse_lut[i];
        let b = self.inverse_lut[(i + 1).min(n - 1)];
        a + (b - a) * f
    }

    /// Relative intensity for a drive, by linear interpolation in the forward samples.
    pub fn intensity_for(&self, drive: f64) -> f64 {
        let s = &self.forward;
        if s.is_empty() {
            return 0.0;
        }
        let d = drive.clamp(0.0, 1.0);
        let k = s.partition_point(|p| p[0] < d);
        if k == 0 {
            return s[0][1];
        }
        if k >= s.len() {
            return s[s.len() - 1][1];
        }
        let (a, b) = (s[k - 1], s[k]);
        let w = if b[0] > a[0] {
            (d - a[0]) / (b[0] - a[0])
        } else {
            0.0
        };
        a[1] + (b[1] - a[1]) * w
    }
}

/// Flat-field attenuation texture (Kresse 3.4.3), applied in linear light.
///
/// `gain[row * width + col][c]` is the relative output of display channel `c` at that
/// texel compared with the calibration spot (the meter's spot, gain 1); the post pass
/// divides by it (bilinear, texel centres at `(i + 0.5) / size`). Texels brighter than
/// the spot (a hotspot off the centre) have gains above 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FlatField {
    /// Texture width in texels.
    pub width: u32,
    /// Texture height in texels.
    pub height: u32,
    /// Row-major gains per display channel, each in (0, [`FlatField::MAX_GAIN`]].
    pub gain: Vec<[f32; 3]>,
}

impl FlatField {
    /// Largest gain a texel may have (four times the spot's output).
    pub const MAX_GAIN: f32 = 4.0;
    /// Largest texture side in texels.
    pub const MAX_SIDE: u32 = 4096;
}

/// How a display mixes its three channels into light.
///
/// With `a` the linear relative channel intensities, `P` the primaries (columns) and `b`
/// the black, a display shows `XYZ = b + P·a` ([`DisplayModel::Additive`], Kresse
/// 2003, 3.3) or `XYZ = b + P·a + W·min(a)` ([`DisplayModel::WhiteSegment`]): a
/// single-chip DLP whose colour wheel has a clear segment adds white light in proportion
/// to the smallest channel (Wyble & Zhang 2003; Wyble & Rosen 2004 found the white
/// channel of DLP projectors driven by the minimum of R, G and B). The post pass applies
/// the exact inverse of either (`apply`, step 1).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum DisplayModel {
    /// Light of the channels adds: `XYZ = b + P·a`.
    #[default]
    Additive,
    /// A white (clear) colour-wheel segment adds `W·min(a)`.
    WhiteSegment {
        /// XYZ (cd/m²) of the white segment at full drive of all three channels.
        white_xyz_cd_m2: [f64; 3],
    },
}

impl DisplayModel {
    /// Smallest `1 + u_c` accepted, with `u = P⁻¹·W` the white segment in channel
    /// intensities: below it the white segment would cancel a whole channel and the
    /// model could not be inverted.
    pub const MIN_ONE_PLUS_U: f64 = 0.05;

    /// Whether a white segment of `u` in channel intensities ([`Self::white_in_channels`])
    /// can be inverted: `1 + u_c ≥` [`Self::MIN_ONE_PLUS_U`] for every channel.
    pub fn invertible(u: [f64; 3]) -> bool {
        u.iter().all(|v| 1.0 + v >= Self::MIN_ONE_PLUS_U)
    }

    /// The white segment in linear relative channel intensities, `u = P⁻¹·W` (zero for
    /// an additive display); `xyz_to_drive` is `P⁻¹`.
    pub fn white_in_channels(&self, xyz_to_drive: &[[f64; 3]; 3]) -> [f64; 3] {
        match self {
            DisplayModel::Additive => [0.0; 3],
            DisplayModel::WhiteSegment { white_xyz_cd_m2: w } => {
                std::array::from_fn(|r| (0..3).map(|k| xyz_to_drive[r][k] * w[k]).sum())
            }
        }
    }

    /// Linear channel intensities `a` that show `m = P⁻¹·(XYZ − b)`: `a = m` for an
    /// additive display; with a white segment `a = m − u·s`, `s = max(0, min_c
    /// m_c / (1 + u_c))` (the closed-form inverse of `m = a + u·min(a)`).
    pub fn channels_for(&self, xyz_to_drive: &[[f64; 3]; 3], m: [f64; 3]) -> [f64; 3] {
        let u = self.white_in_channels(xyz_to_drive);
        let s = (0..3)
            .map(|c| m[c] / (1.0 + u[c]))
            .fold(f64::INFINITY, f64::min)
            .max(0.0);
        std::array::from_fn(|c| m[c] - u[c] * s)
    }
}

/// Facts about how a profile was measured.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MeasurementInfo {
    /// Instrument that measured (model and serial, or "virtual").
    pub instrument: String,
    /// Number of meter readings taken for this display.
    pub readings: u32,
    /// Largest relative additivity error |W − (R+G+B)| / Y_W seen, if checked.
    pub additivity_error: Option<f64>,
}

/// Calibration profile of one display (one projector, one eye).
///
/// Post-pass maths, per pixel with linear-light input `xyz` (Y in cd/m²):
/// `lin = (xyz_to_drive · xyz) / flat_gain(u, v) + drive_offset`, then out-of-gamut
/// handling, then `drive_c = curves[c].drive_for(lin_c)`, then quantisation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DisplayProfile {
    /// Always [`FORMAT_VERSION`] when written by this build.
    pub format_version: u32,
    /// Which display this is.
    pub display: DisplayKey,
    /// When the profile was made, RFC 3339 UTC.
    pub created_utc: String,
    /// Measured XYZ (cd/m²) of R, G, B at full drive, black subtracted: `[R, G, B]`.
    pub primaries_xyz_cd_m2: [[f64; 3]; 3],
    /// Measured black (all channels at drive 0), XYZ in cd/m².
    pub black_xyz_cd_m2: [f64; 3],
    /// How the channels mix (format version 2; version 1 profiles are additive).
    #[serde(default)]
    pub display_model: DisplayModel,
    /// Black handling chosen for the wall.
    pub black_mode: BlackMode,
    /// XYZ (cd/m²) the wall shows for input 0: the common black in `Common` mode, the
    /// display's own black in `Ignore` and `Individual` mode.
    pub shown_black_xyz_cd_m2: [f64; 3],
    /// XYZ (cd/m²) of the wall's target white (common RGB = 1,1,1), black excluded.
    pub target_white_xyz_cd_m2: [f64; 3],
    /// xy chromaticities of the wall's common primaries `[R, G, B]`.
    pub common_primaries_xy: [[f64; 2]; 3],
    /// Row-major 3×3 matrix from XYZ (cd/m²) to linear relative channel intensity.
    pub xyz_to_drive: [[f64; 3]; 3],
    /// Black term added after the matrix, in linear relative channel intensity.
    pub drive_offset: [f64; 3],
    /// Linear relative intensity of each channel used for the target white.
    pub channel_usage: [f64; 3],
    /// Largest channel usage allowed by the solve (1.0, or e.g. 0.9 for lamp ageing).
    pub headroom: f64,
    /// Tone curves of R, G, B.
    pub curves: [ToneCurve; 3],
    /// Optional flat-field texture; `None` means no texture fetch at all.
    pub flat_field: Option<FlatField>,
    /// Out-of-gamut handling.
    pub out_of_gamut: OutOfGamut,
    /// Bits per channel of the display input (8, 10 or 16).
    pub bit_depth: u32,
    /// How it was measured.
    pub measurement: MeasurementInfo,
}

fn finite3(v: &[f64; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

impl DisplayProfile {
    /// Checks internal consistency; returns a technician-readable reason on failure.
    pub fn validate(&self) -> Result<(), ProfileError> {
        self.check_numbers()
            .and_then(|()| self.check_settings())
            .and_then(|()| self.check_curves())
            .and_then(|()| self.check_flat_field())
            .map_err(|reason| ProfileError::Invalid {
                display: self.display.to_string(),
                reason,
            })
    }

    /// Format version, then every vector and matrix finite.
    fn check_numbers(&self) -> Result<(), String> {
        if self.format_version != FORMAT_VERSION {
            return Err(format!(
                "format version {} (expected {FORMAT_VERSION})",
                self.format_version
            ));
        }
        let arrays = [
            ("black_xyz_cd_m2", &self.black_xyz_cd_m2),
            ("shown_black_xyz_cd_m2", &self.shown_black_xyz_cd_m2),
            ("target_white_xyz_cd_m2", &self.target_white_xyz_cd_m2),
            ("drive_offset", &self.drive_offset),
            ("channel_usage", &self.channel_usage),
        ];
        for (name, v) in arrays {
            if !finite3(v) {
                return Err(format!("{name} has a non-finite value"));
            }
        }
        if !self.xyz_to_drive.iter().all(finite3) || !self.primaries_xyz_cd_m2.iter().all(finite3) {
            return Err("matrix has a non-finite value".into());
        }
        Ok(())
    }

    /// Wall name, common primaries, display model, additivity error, headroom and bit
    /// depth.
    fn check_settings(&self) -> Result<(), String> {
        self.check_display_model()?;
        if self.display.wall.is_empty() {
            return Err("display.wall (the wall name) is empty".into());
        }
        for (ch, [x, y]) in Channel::ALL.into_iter().zip(self.common_primaries_xy) {
            if !Xy::new(x, y).is_valid() {
                return Err(format!(
                    "common_primaries_xy of {ch} is ({x}, {y}), not a chromaticity \
                     (x, y finite, x >= 0, y > 0, x + y <= 1)"
                ));
            }
        }
        if let Some(e) = self.measurement.additivity_error
            && !e.is_finite()
        {
            return Err(format!(
                "measurement.additivity_error is {e}, must be a finite number or null"
            ));
        }
        Headroom::new(self.headroom).map_err(|e| e.to_string())?;
        if !BitDepth::is_profile_depth(self.bit_depth) {
            return Err(format!(
                "bit depth {} is not 8, 10, 12 or 16",
                self.bit_depth
            ));
        }
        Ok(())
    }

    /// A white segment: finite, not negative in luminance, and invertible
    /// (`1 + u_c ≥ DisplayModel::MIN_ONE_PLUS_U`).
    fn check_display_model(&self) -> Result<(), String> {
        let DisplayModel::WhiteSegment { white_xyz_cd_m2: w } = self.display_model else {
            return Ok(());
        };
        if !finite3(&w) || w[1] < 0.0 {
            return Err(format!(
                "display_model.white_xyz_cd_m2 {w:?} must be finite with Y ≥ 0"
            ));
        }
        let u = self.display_model.white_in_channels(&self.xyz_to_drive);
        if !DisplayModel::invertible(u) {
            return Err(format!(
                "display_model: the white segment in channel intensities {u:?} would cancel a \
                 channel (1 + u must be ≥ {}); re-measure the display's white",
                DisplayModel::MIN_ONE_PLUS_U
            ));
        }
        Ok(())
    }

    /// Per channel: finite forward samples, a long enough monotone inverse LUT in 0..=1.
    fn check_curves(&self) -> Result<(), String> {
        for (ch, curve) in Channel::ALL.into_iter().zip(&self.curves) {
            if let Some(i) = curve
                .forward
                .iter()
                .position(|s| !(s[0].is_finite() && s[1].is_finite()))
            {
                return Err(format!(
                    "{ch} forward curve sample {i} is {:?}, not finite",
                    curve.forward[i]
                ));
            }
            if curve.inverse_lut.len() < MIN_LUT_ENTRIES {
                return Err(format!(
                    "{ch} inverse LUT has {} entries, at least {MIN_LUT_ENTRIES} needed",
                    curve.inverse_lut.len()
                ));
            }
            if curve
                .inverse_lut
                .iter()
                .any(|v| !v.is_finite() || !(0.0..=1.0).contains(v))
            {
                return Err(format!("{ch} inverse LUT has a value outside 0..=1"));
            }
            if curve.inverse_lut.windows(2).any(|w| w[1] < w[0]) {
                return Err(format!("{ch} inverse LUT is not monotone"));
            }
        }
        Ok(())
    }

    /// The flat-field texture, if any: its size matches its texels, gains in
    /// (0, [`FlatField::MAX_GAIN`]].
    fn check_flat_field(&self) -> Result<(), String> {
        let Some(ff) = &self.flat_field else {
            return Ok(());
        };
        // u32 × u32 always fits u64: exact on every platform.
        let n = u64::from(ff.width) * u64::from(ff.height);
        if ff.width == 0
            || ff.height == 0
            || ff.width > FlatField::MAX_SIDE
            || ff.height > FlatField::MAX_SIDE
            || ff.gain.len() as u64 != n
        {
            return Err(format!(
                "flat-field texture is {}×{} but holds {} texels",
                ff.width,
                ff.height,
                ff.gain.len()
            ));
        }
        if ff
            .gain
            .iter()
            .flatten()
            .any(|g| !g.is_finite() || *g <= 0.0 || *g > FlatField::MAX_GAIN)
        {
            return Err(format!(
                "flat-field gain outside (0, {}]",
                FlatField::MAX_GAIN
            ));
        }
        Ok(())
    }

    /// Serialises to the profile JSON document.
    pub fn to_json(&self) -> String {
        // Serialising plain numbers and strings cannot fail.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// Parses and validates a profile document; `origin` names it in errors.
    pub fn from_json(text: &str, origin: &Path) -> Result<Self, ProfileError> {
        let parse = |e: serde_json::Error| ProfileError::Parse {
            path: origin.to_path_buf(),
            message: e.to_string(),
        };
        let value: serde_json::Value = serde_json::from_str(text).map_err(parse)?;
        let found = value
            .get("format_version")
            .and_then(|v| v.as_u64())
            .ok_or_else(|| ProfileError::Parse {
                path: origin.to_path_buf(),
                message: "missing `format_version`".into(),
            })?;
        if !(u64::from(OLDEST_READABLE_VERSION)..=u64::from(FORMAT_VERSION)).contains(&found) {
            return Err(ProfileError::Version {
                path: origin.to_path_buf(),
                found: u32::try_from(found).unwrap_or(u32::MAX),
                expected: FORMAT_VERSION,
            });
        }
        let mut profile: DisplayProfile = serde_json::from_value(value).map_err(parse)?;
        // Version 1 → 2: no `display_model` field, i.e. additive (the serde default).
        profile.format_version = FORMAT_VERSION;
        profile.validate()?;
        Ok(profile)
    }

    /// Reads and validates a profile file.
    pub fn load(path: &Path) -> Result<Self, ProfileError> {
        let text = std::fs::read_to_string(path).map_err(|source| ProfileError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_json(&text, path)
    }

    /// Writes the profile atomically (temporary file, then rename), so a crash never
    /// leaves a half-written profile behind.
    pub fn save(&self, path: &Path) -> Result<(), ProfileError> {
        self.validate()?;
        write_atomic(path, self.to_json().as_bytes())
    }
}

/// Writes `bytes` to `path` atomically ([`lumiwall_core::files::write_atomic`]: a
/// temporary file, synced, then renamed; no leftovers on failure).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), ProfileError> {
    lumiwall_core::files::write_atomic(path, bytes).map_err(|source| ProfileError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// All profiles of one wall, as written by `lumiwall commission` into one folder:
/// one `<display>.json` per display and eye, and `wall.json` listing them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProfileSet {
    /// Format version of the set manifest.
    pub format_version: u32,
    /// Wall name.
    pub wall: String,
    /// Profile file names relative to the folder, in display order.
    pub files: Vec<String>,
}

impl ProfileSet {
    /// Name of the manifest file inside a profile folder.
    pub const MANIFEST: &'static str = "wall.json";

    /// Writes every profile and then the manifest into `dir`. The old manifest is
    /// removed first, so an interruption while saving leaves a folder that
    /// [`ProfileSet::load_dir`] refuses ([`ProfileError::NoManifest`]) instead of one
    /// that mixes the profiles of two solves.
    pub fn save_dir(
        dir: &Path,
        wall: &str,
        profiles: &[DisplayProfile],
    ) -> Result<(), ProfileError> {
        let manifest = dir.join(Self::MANIFEST);
        match std::fs::remove_file(&manifest) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(source) => {
                return Err(ProfileError::Io {
                    path: manifest,
                    source,
                });
            }
        }
        let mut files = Vec::with_capacity(profiles.len());
        for p in profiles {
            let name = format!("{}.json", p.display.file_stem());
            p.save(&dir.join(&name))?;
            files.push(name);
        }
        let set = ProfileSet {
            format_version: FORMAT_VERSION,
            wall: wall.to_string(),
            files,
        };
        let text = serde_json::to_string_pretty(&set).unwrap_or_default();
        write_atomic(&manifest, text.as_bytes())
    }

    /// Reads the manifest and every profile it lists, and checks that they are one
    /// solve of one wall ([`ProfileSet::check_one_solve`]).
    pub fn load_dir(dir: &Path) -> Result<(String, Vec<DisplayProfile>), ProfileError> {
        let set = Self::load_manifest(dir)?;
        let profiles = set
            .files
            .iter()
            .map(|f| DisplayProfile::load(&dir.join(f)))
            .collect::<Result<Vec<_>, _>>()?;
        set.check_one_solve(dir, &profiles)?;
        Ok((set.wall, profiles))
    }

    /// Reads and checks `dir/wall.json`: version, and file names that are plain names
    /// inside the folder.
    fn load_manifest(dir: &Path) -> Result<ProfileSet, ProfileError> {
        let path = dir.join(Self::MANIFEST);
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound && dir.is_dir() => {
                return Err(ProfileError::NoManifest {
                    dir: dir.to_path_buf(),
                });
            }
            Err(source) => return Err(ProfileError::Io { path, source }),
        };
        let set: ProfileSet = serde_json::from_str(&text).map_err(|e| ProfileError::Parse {
            path: path.clone(),
            message: e.to_string(),
        })?;
        if !(OLDEST_READABLE_VERSION..=FORMAT_VERSION).contains(&set.format_version) {
            return Err(ProfileError::Version {
                path,
                found: set.format_version,
                expected: FORMAT_VERSION,
            });
        }
        let mixed = |reason: String| ProfileError::MixedFolder {
            dir: dir.to_path_buf(),
            reason,
        };
        if set.files.is_empty() {
            return Err(mixed("wall.json lists no profile".into()));
        }
        for f in &set.files {
            let plain = Path::new(f).file_name().is_some_and(|n| n == f.as_str());
            if !plain || f.starts_with('.') {
                return Err(mixed(format!(
                    "wall.json lists {f:?}, which is not a file name inside the folder"
                )));
            }
        }
        Ok(set)
    }

    /// The wall identity check every command shares: every profile belongs to this
    /// manifest's wall, no display appears twice, and all come from one solve (same
    /// creation time, target white, common primaries and black mode).
    pub fn check_one_solve(
        &self,
        dir: &Path,
        profiles: &[DisplayProfile],
    ) -> Result<(), ProfileError> {
        let mixed = |reason: String| ProfileError::MixedFolder {
            dir: dir.to_path_buf(),
            reason,
        };
        let mut seen = std::collections::HashSet::new();
        for (file, p) in self.files.iter().zip(profiles) {
            if p.display.wall != self.wall {
                return Err(mixed(format!(
                    "{file} is a profile of wall {:?}, but wall.json is wall {:?}",
                    p.display.wall, self.wall
                )));
            }
            if !seen.insert(p.display.clone()) {
                return Err(mixed(format!(
                    "{file}: display {} appears twice",
                    p.display
                )));
            }
        }
        let (Some(first_file), Some(first)) = (self.files.first(), profiles.first()) else {
            return Ok(());
        };
        for (file, p) in self.files.iter().zip(profiles).skip(1) {
            if let Some(what) = solve_difference(first, p) {
                return Err(mixed(format!(
                    "{file} and {first_file} come from different solves ({what} differ); a \
                     commission into this folder was interrupted or two ran at once: re-run \
                     `lumiwall commission` into it"
                )));
            }
        }
        Ok(())
    }
}

/// What differs between two profiles that one solve would have made alike, if anything.
fn solve_difference(a: &DisplayProfile, b: &DisplayProfile) -> Option<&'static str> {
    let close = |u: &[f64; 3], v: &[f64; 3]| {
        u.iter()
            .zip(v)
            .all(|(x, y)| (x - y).abs() <= 1e-9 * x.abs().max(y.abs()).max(1.0))
    };
    if a.created_utc != b.created_utc {
        Some("creation times")
    } else if !close(&a.target_white_xyz_cd_m2, &b.target_white_xyz_cd_m2) {
        Some("target whites")
    } else if a.common_primaries_xy != b.common_primaries_xy {
        Some("common primaries")
    } else if a.black_mode != b.black_mode {
        Some("black modes")
    } else {
        None
    }
}
