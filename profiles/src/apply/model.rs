//! An analytic display model and the exact profile for it.
//!
//! For tests, benchmarks and what-if studies: a display with known primaries, black and
//! S-shaped per-channel tone curves, the light it emits for a drive, and the profile a
//! perfect calibration of it would produce. The flat-field gain scales everything the
//! lens passes, the black included (`emitted = P · diag(g) · (I(drive) + M·black)`),
//! which is what the post-pass contract `lin = M·xyz / g + offset` assumes. A display
//! with a white segment adds `u·min(I)` to the channel intensities before the gain
//! (`u = M·W`, the white light passing the lens with the channels), the model the post
//! pass inverts ([`crate::DisplayModel::WhiteSegment`]).

use super::{ApplyError, lut, mat3};
use crate::{
    BlackMode, DisplayKey, DisplayModel, DisplayProfile, FORMAT_VERSION, FlatField,
    MeasurementInfo, OutOfGamut, ToneCurve,
};

/// One channel's tone curve: `I(d) = (1 − s)·d^γ + s·(3d² − 2d³)^γ`, monotone, `I(0) = 0`,
/// `I(1) = 1`; `s` blends in an S shape as digital projectors show (Kresse 3.3.4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToneShape {
    /// Power-law exponent γ.
    pub gamma: f64,
    /// Share of the S-shaped part, 0..=1.
    pub s_mix: f64,
}

impl ToneShape {
    /// Relative intensity for a normalised drive (clamped to 0..=1).
    pub fn intensity(&self, drive: f64) -> f64 {
        let d = drive.clamp(0.0, 1.0);
        let s = d * d * (3.0 - 2.0 * d);
        (1.0 - self.s_mix) * d.powf(self.gamma) + self.s_mix * s.powf(self.gamma)
    }
}

/// A display with known primaries, black and tone curves.
#[derive(Debug, Clone, PartialEq)]
pub struct AnalyticDisplay {
    /// XYZ (cd/m²) of R, G, B at full drive, black excluded.
    pub primaries_xyz_cd_m2: [[f64; 3]; 3],
    /// XYZ (cd/m²) at drive 0 (at flat-field gain 1).
    pub black_xyz_cd_m2: [f64; 3],
    /// Tone curves of R, G, B.
    pub tone: [ToneShape; 3],
    /// XYZ (cd/m²) of a single-chip DLP's white segment at full drive (all zero: an
    /// additive display).
    pub white_segment_xyz_cd_m2: [f64; 3],
}

/// What a profile made from an [`AnalyticDisplay`] should hold besides the display.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelProfileSpec {
    /// Which display.
    pub display: DisplayKey,
    /// Black handling.
    pub black_mode: BlackMode,
    /// Common (raised) black of the wall, XYZ cd/m²; used in [`BlackMode::Common`].
    pub common_black_xyz_cd_m2: [f64; 3],
    /// The wall's target white, XYZ cd/m², black excluded.
    pub target_white_xyz_cd_m2: [f64; 3],
    /// Inverse LUT entries per channel (≥ 1024).
    pub lut_entries: usize,
    /// Flat-field texture, if any.
    pub flat_field: Option<FlatField>,
    /// Out-of-gamut handling.
    pub out_of_gamut: OutOfGamut,
    /// Output bit depth.
    pub bit_depth: u32,
}

fn xy(v: &[f64; 3]) -> [f64; 2] {
    let s = v[0] + v[1] + v[2];
    if s > 0.0 {
        [v[0] / s, v[1] / s]
    } else {
        [0.0, 0.0]
    }
}

/// XYZ (cd/m²) of chromaticity `(x, y)` at luminance `lum`: `(x/y·L, L, (1−x−y)/y·L)`.
/// (The analytic fixtures' exact arithmetic; `y` must be positive.)
pub fn xyz_of(x: f64, y: f64, lum: f64) -> [f64; 3] {
    [x / y * lum, lum, (1.0 - x - y) / y * lum]
}

/// XYZ (cd/m²) of Kresse's Infitec common-gamut primaries (Tab. 5: R 0.625/0.370,
/// G 0.286/0.613, B 0.140/0.045) at the luminances of R, G and B.
pub fn infitec_primaries(luminance_cd_m2: [f64; 3]) -> [[f64; 3]; 3] {
    let [r, g, b] = luminance_cd_m2;
    [
        xyz_of(0.625, 0.370, r),
        xyz_of(0.286, 0.613, g),
        xyz_of(0.140, 0.045, b),
    ]
}

impl AnalyticDisplay {
    /// The example display of the tests and `lumiwall bench apply`: a projector with
    /// Kresse's Infitec common-gamut primaries (Tab. 5), a bluish-grey black and
    /// S-shaped tone curves of different gammas per channel.
    pub fn infitec_example() -> Self {
        AnalyticDisplay {
            primaries_xyz_cd_m2: infitec_primaries([21.0, 55.0, 6.5]),
            black_xyz_cd_m2: xyz_of(0.29, 0.31, 0.35),
            tone: [
                ToneShape {
                    gamma: 2.1,
                    s_mix: 0.3,
                },
                ToneShape {
                    gamma: 2.3,
                    s_mix: 0.4,
                },
                ToneShape {
                    gamma: 1.9,
                    s_mix: 0.2,
                },
            ],
            white_segment_xyz_cd_m2: [0.0; 3],
        }
    }

    /// The same display as a single-chip DLP whose white segment adds `share` of the
    /// full R+G+B white (e.g. 0.2), at the white's chromaticity.
    pub fn with_white_segment(self, share: f64) -> Self {
        let w = self.full_white_xyz().map(|v| v * share);
        AnalyticDisplay {
            white_segment_xyz_cd_m2: w,
            ..self
        }
    }

    /// How the display mixes its channels.
    pub fn display_model(&self) -> DisplayModel {
        if self.white_segment_xyz_cd_m2 == [0.0; 3] {
            DisplayModel::Additive
        } else {
            DisplayModel::WhiteSegment {
                white_xyz_cd_m2: self.white_segment_xyz_cd_m2,
            }
        }
    }

    /// XYZ (cd/m²) of all three primaries at full drive, black excluded.
    pub fn full_white_xyz(&self) -> [f64; 3] {
        [0, 1, 2].map(|i| (0..3).map(|c| self.primaries_xyz_cd_m2[c][i]).sum::<f64>())
    }

    /// Row-major primaries matrix `P` (columns R, G, B): linear drive → XYZ cd/m².
    pub fn primaries_matrix(&self) -> [[f64; 3]; 3] {
        mat3::from_columns(&self.primaries_xyz_cd_m2)
    }

    /// XYZ (cd/m²) emitted for normalised drives at a texel of flat-field gain `gain`.
    pub fn emitted_xyz(&self, drive: [f64; 3], gain: [f64; 3]) -> Result<[f64; 3], ApplyError> {
        let p = self.primaries_matrix();
        let m = mat3::inverse(&p).ok_or_else(|| ApplyError::Matrix {
            display: "analytic model".into(),
            reason: "primaries are collinear".into(),
        })?;
        let b = mat3::mul_vec(&m, &self.black_xyz_cd_m2);
        let u = self.display_model().white_in_channels(&m);
        let i = [0, 1, 2].map(|c| self.tone[c].intensity(drive[c]));
        let least = i[0].min(i[1]).min(i[2]);
        let lin = [0, 1, 2].map(|c| gain[c] * (i[c] + u[c] * least + b[c]));
        Ok(mat3::mul_vec(&p, &lin))
    }

    /// The profile an exact calibration of this display gives.
    pub fn profile(&self, spec: &ModelProfileSpec) -> Result<DisplayProfile, ApplyError> {
        let p = self.primaries_matrix();
        let m = mat3::inverse(&p).ok_or_else(|| ApplyError::Matrix {
            display: spec.display.to_string(),
            reason: "primaries are collinear".into(),
        })?;
        let black = self.black_xyz_cd_m2;
        let shown_black = match spec.black_mode {
            BlackMode::Common => spec.common_black_xyz_cd_m2,
            BlackMode::Ignore | BlackMode::Individual => black,
        };
        let drive_offset = match spec.black_mode {
            BlackMode::Ignore => [0.0; 3],
            BlackMode::Individual => mat3::mul_vec(&m, &black).map(|v| -v),
            BlackMode::Common => {
                let d = [0, 1, 2].map(|c| spec.common_black_xyz_cd_m2[c] - black[c]);
                mat3::mul_vec(&m, &d)
            }
        };
        let curves = self.tone.map(|t| {
            let forward: Vec<[f64; 2]> = (0..=1024)
                .map(|i| {
                    let d = f64::from(i) / 1024.0;
                    [d, t.intensity(d)]
                })
                .collect();
            (
                forward.clone(),
                lut::invert_forward(&forward, spec.lut_entries),
            )
        });
        let [c0, c1, c2] = curves;
        let curve = |c: (Vec<[f64; 2]>, Result<Vec<f32>, ApplyError>)| {
            c.1.map(|inverse_lut| ToneCurve {
                forward: c.0,
                inverse_lut,
            })
        };
        let profile = DisplayProfile {
            format_version: FORMAT_VERSION,
            display: spec.display.clone(),
            created_utc: "1970-01-01T00:00:00Z".into(),
            primaries_xyz_cd_m2: self.primaries_xyz_cd_m2,
            black_xyz_cd_m2: black,
            display_model: self.display_model(),
            black_mode: spec.black_mode,
            shown_black_xyz_cd_m2: shown_black,
            target_white_xyz_cd_m2: spec.target_white_xyz_cd_m2,
            common_primaries_xy: self.primaries_xyz_cd_m2.map(|v| xy(&v)),
            xyz_to_drive: m,
            drive_offset,
            channel_usage: self
                .display_model()
                .channels_for(&m, mat3::mul_vec(&m, &spec.target_white_xyz_cd_m2)),
            headroom: 1.0,
            curves: [curve(c0)?, curve(c1)?, curve(c2)?],
            flat_field: spec.flat_field.clone(),
            out_of_gamut: spec.out_of_gamut,
            bit_depth: spec.bit_depth,
            measurement: MeasurementInfo {
                instrument: "analytic model".into(),
                readings: 0,
                additivity_error: None,
            },
        };
        profile.validate()?;
        Ok(profile)
    }
}
