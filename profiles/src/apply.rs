//! Scalar f32 reference of the render-time post pass (Kresse 2003, 3.3.6–3.3.7, 3.4.4).
//!
//! Per pixel, with linear-light input `xyz` (Y in cd/m²) at display position `uv`:
//!
//! 1. `m = (xyz_to_drive · xyz) / flat_gain(u, v)` and `a = m + drive_offset`
//!    (linear relative channel intensity, black handled by the offset of the profile's
//!    [`BlackMode`](crate::BlackMode)).
//!    A display with a white segment ([`DisplayModel::WhiteSegment`](crate::DisplayModel))
//!    then takes it out: `s = max(0, min_c a_c·k_c)` and `a_c ← a_c − u_c·s`, with
//!    `u = P⁻¹·W` the white segment in channel intensities and `k_c = 1 / (1 + u_c)`:
//!    the exact inverse of `a + u·min(a)`. For an additive display `u = 0` and the step
//!    is skipped. A channel below 0 means `s = 0`, so the gamut mapping of step 2 works
//!    on the additive part alone, which is what the display shows there.
//! 2. Out of gamut (a channel `a_c < 0` although the grey of the same luminance is
//!    displayable): in [`OutOfGamut::Clip`] mode the colour moves toward the target white
//!    in xy at constant luminance, `m(t) = (1 − t)·m + t·Y·w`, with the smallest `t` that
//!    makes every channel ≥ 0 (closed form per channel). Channels below the display's
//!    own black (grey of that luminance not displayable, [`BlackMode::Individual`](crate::BlackMode::Individual))
//!    clip at 0 (Kresse 3.3.6 b).
//! 3. Over range (a channel `a_c > 1`): `m` is scaled by the largest `s ≤ 1` that brings
//!    every channel to ≤ 1, which keeps the chromaticity of the shown colour. With a
//!    white segment the scaling runs on the linear form of the white-segment step in the region of `a`
//!    (`m_c − u_c·k_j·m_j`, offset likewise, `j` the channel of the minimum), which is
//!    exact while the scaled colour stays in that region (always without a black
//!    offset, the inverse being homogeneous; with `Common` black's offset the region can
//!    change near a boundary, by at most the offset's share).
//! 4. `drive_c = curves[c].drive_for(a_c)` (linear interpolation in the inverse LUT).
//! 5. Quantisation to the bit depth with [`quantise`], optionally with the ordered
//!    dither of [`dither_threshold`].
//!
//! In [`OutOfGamut::FalseColour`] mode steps 2–4 are replaced for marked pixels by a
//! marker drive ([`MARKER_OUT_OF_GAMUT`], [`MARKER_OVER_RANGE`], [`MARKER_INVALID`]).
//! Invalid input (NaN or ±Inf in `xyz` or `uv`) is shown as black (input 0) in clip mode.
//!
//! [`PreparedProfile`] holds the profile converted to f32 with the LUT slopes
//! precomputed; the CPU image path (`lumiwall_render::post`) and the GPU upload use it,
//! so every path runs exactly this arithmetic.

pub mod lut;
pub use lumiwall_core::mat3;
pub mod model;
pub use lumiwall_core::dither::{dither_threshold, quantise};
pub use lumiwall_core::srgb;

use std::ops::BitOr;

use crate::{DisplayKey, DisplayProfile, OutOfGamut, ProfileError};

pub use srgb::{decode_srgb, rgb_to_xyz_matrix, srgb_to_xyz};

/// Largest absolute XYZ component (cd/m²) passed to the matrix; larger finite inputs are
/// scaled down to it at constant chromaticity (they are far over range anyway). Keeps
/// `matrix · xyz` finite in f32 for every accepted matrix.
pub const MAX_INPUT_CD_M2: f32 = 1.0e12;

/// Largest absolute matrix entry accepted (linear drive per cd/m²). A larger entry means
/// the primaries are (nearly) collinear: the profile is unusable.
pub const MAX_MATRIX_ENTRY: f64 = 1.0e18;

/// Tolerance (linear relative intensity, ≈ 1/100 of a 10-bit code) within which a channel
/// slightly below 0 or above 1 is rounding noise, clamped without a flag: colours on the
/// gamut boundary (e.g. the common gamut's edges, sRGB input with a zero channel) are not
/// marked.
pub const GAMUT_TOLERANCE: f32 = 1.0e-5;

/// Drive shown for out-of-gamut pixels in false-colour mode: magenta.
pub const MARKER_OUT_OF_GAMUT: [f32; 3] = [1.0, 0.0, 1.0];
/// Drive shown for over-range (too bright) pixels in false-colour mode: cyan.
pub const MARKER_OVER_RANGE: [f32; 3] = [0.0, 1.0, 1.0];
/// Drive shown for invalid (NaN/Inf) input in false-colour mode: yellow.
pub const MARKER_INVALID: [f32; 3] = [1.0, 1.0, 0.0];

/// Errors preparing a profile for the post pass.
#[derive(Debug, thiserror::Error)]
pub enum ApplyError {
    /// The profile failed validation.
    #[error(transparent)]
    Profile(#[from] ProfileError),
    /// The XYZ→drive matrix cannot be used.
    #[error(
        "profile for {display}: XYZ→drive matrix is unusable ({reason}); the measured \
         primaries are (nearly) collinear — re-measure the display's primaries"
    )]
    Matrix {
        /// Display concerned.
        display: String,
        /// What is wrong.
        reason: String,
    },
    /// The target white is not a usable colour.
    #[error(
        "profile for {display}: target white XYZ {white:?} cd/m² has no positive luminance \
         or gives a negative drive; re-run the white solve"
    )]
    White {
        /// Display concerned.
        display: String,
        /// The target white found.
        white: [f64; 3],
    },
    /// A bit depth the post pass does not quantise to.
    #[error("bit depth {0} is not supported; use 8, 10, 12 or 16")]
    BitDepth(u32),
    /// Tone-curve samples that cannot be inverted.
    #[error("tone curve cannot be inverted: {0}")]
    Curve(String),
    /// Colour-space parameters that give no matrix.
    #[error("colour space is degenerate: {0}")]
    ColourSpace(String),
}

impl From<lumiwall_core::CoreError> for ApplyError {
    fn from(e: lumiwall_core::CoreError) -> Self {
        ApplyError::ColourSpace(e.to_string())
    }
}

/// What happened to a pixel in the post pass (a small bit set).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct PixelFlags(pub u32);

impl PixelFlags {
    /// Nothing special.
    pub const NONE: PixelFlags = PixelFlags(0);
    /// Outside the display's gamut: moved toward white (clip) or marked.
    pub const OUT_OF_GAMUT: PixelFlags = PixelFlags(1);
    /// Too bright for the display: scaled down (clip) or marked.
    pub const OVER_RANGE: PixelFlags = PixelFlags(2);
    /// NaN or ±Inf input: shown as black (clip) or marked.
    pub const INVALID: PixelFlags = PixelFlags(4);
    /// Darker than the display's own black in some channel: clipped at the black.
    pub const BELOW_BLACK: PixelFlags = PixelFlags(8);

    /// True when every bit of `other` is set.
    pub fn contains(self, other: PixelFlags) -> bool {
        self.0 & other.0 == other.0
    }

    /// True when no bit is set.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }
}

impl BitOr for PixelFlags {
    type Output = PixelFlags;
    fn bitor(self, rhs: PixelFlags) -> PixelFlags {
        PixelFlags(self.0 | rhs.0)
    }
}

impl std::ops::BitOrAssign for PixelFlags {
    fn bitor_assign(&mut self, rhs: PixelFlags) {
        self.0 |= rhs.0;
    }
}

/// Result of the post pass for one pixel, before quantisation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelOut {
    /// Normalised drive per channel (code value / max code), in 0..=1.
    pub drive: [f32; 3],
    /// What happened on the way.
    pub flags: PixelFlags,
}

/// User choices that override the profile for one run of the post pass.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ApplyOptions {
    /// Out-of-gamut handling; `None` uses the profile's.
    pub out_of_gamut: Option<OutOfGamut>,
    /// Output bit depth; `None` uses the profile's.
    pub bit_depth: Option<u32>,
    /// Ordered dithering before quantisation.
    pub dither: bool,
}

/// One channel's inverse LUT with its slopes precomputed (`slope[i] = base[i+1] − base[i]`).
#[derive(Debug, Clone, PartialEq)]
pub struct PreparedLut {
    /// LUT entries (drive for relative intensity `i / (len − 1)`), as in the profile.
    pub base: Vec<f32>,
    /// Difference to the next entry; the last entry's slope is 0.
    pub slope: Vec<f32>,
    /// `len − 1` as f32: relative intensity → LUT position.
    pub scale: f32,
    /// `[base, slope]` pairs (one cache line fetch per lookup on the CPU); `len − 1`
    /// entries, the last pair covering the final segment.
    pairs: Vec<[f32; 2]>,
}

impl PreparedLut {
    fn new(lut: &[f32]) -> Self {
        let n = lut.len();
        let mut slope = Vec::with_capacity(n);
        for i in 0..n {
            let next = if i + 1 < n { lut[i + 1] } else { lut[i] };
            slope.push(next - lut[i]);
        }
        let pairs = (0..n.saturating_sub(1))
            .map(|i| [lut[i], slope[i]])
            .collect();
        PreparedLut {
            base: lut.to_vec(),
            slope,
            scale: n.saturating_sub(1) as f32,
            pairs,
        }
    }

    /// The `[base, slope]` pairs of the `len − 1` segments.
    pub fn pairs(&self) -> &[[f32; 2]] {
        &self.pairs
    }

    /// Drive for a relative intensity in 0..=1; same arithmetic as
    /// [`ToneCurve::drive_for`](crate::ToneCurve::drive_for).
    #[inline(always)]
    pub fn drive_for(&self, a: f32) -> f32 {
        let segments = self.pairs.len();
        if segments == 0 {
            return self.base.first().copied().unwrap_or(0.0);
        }
        let t = a.clamp(0.0, 1.0) * self.scale;
        let i = (t as usize).min(segments - 1);
        let f = t - i as f32;
        let [base, slope] = self.pairs[i];
        base + slope * f
    }
}

/// The flat-field texture as f32 with its bilinear lookup.
#[derive(Debug, Clone, PartialEq)]
pub struct PreparedFlat {
    /// Width in texels (≥ 1).
    pub width: u32,
    /// Height in texels (≥ 1).
    pub height: u32,
    /// Row-major gains per channel, in (0, `FlatField::MAX_GAIN`].
    pub gain: Vec<[f32; 3]>,
}

/// Texel coordinate along one axis for a normalised position: lower index, upper index
/// and interpolation weight. Texel centres sit at `(i + 0.5) / size`; the edges clamp.
#[inline(always)]
pub fn texel_axis(pos: f32, size: u32) -> (usize, usize, f32) {
    let last = size.saturating_sub(1);
    let x = (pos * size as f32 - 0.5).clamp(0.0, last as f32);
    let i0 = (x as u32).min(last);
    let i1 = (i0 + 1).min(last);
    (i0 as usize, i1 as usize, x - i0 as f32)
}

impl PreparedFlat {
    /// Bilinear gain at `uv` (0..=1 across the display). The interpolation runs along v
    /// first, then along u; the image path relies on that order.
    #[inline(always)]
    pub fn gain_at(&self, uv: [f32; 2]) -> [f32; 3] {
        let (x0, x1, fx) = texel_axis(uv[0], self.width);
        let (y0, y1, fy) = texel_axis(uv[1], self.height);
        let w = self.width as usize;
        let c0 = lerp3(self.gain[y0 * w + x0], self.gain[y1 * w + x0], fy);
        let c1 = lerp3(self.gain[y0 * w + x1], self.gain[y1 * w + x1], fy);
        lerp3(c0, c1, fx)
    }
}

/// `a + (b − a)·f` per component.
#[inline(always)]
pub fn lerp3(a: [f32; 3], b: [f32; 3], f: f32) -> [f32; 3] {
    [
        a[0] + (b[0] - a[0]) * f,
        a[1] + (b[1] - a[1]) * f,
        a[2] + (b[2] - a[2]) * f,
    ]
}

/// A profile converted for the post pass: f32 matrix, LUTs with slopes, texture.
#[derive(Debug, Clone, PartialEq)]
pub struct PreparedProfile {
    /// Display (and eye) the profile belongs to.
    pub display: DisplayKey,
    /// Row-major XYZ (cd/m²) → linear relative drive.
    pub matrix: [[f32; 3]; 3],
    /// Black term added after the matrix and the flat-field division.
    pub offset: [f32; 3],
    /// Linear relative drive per cd/m² of the target white (`matrix · W / Y_W`).
    pub white_dir: [f32; 3],
    /// The display's white segment in channel intensities, `u = P⁻¹·W` (zero when
    /// additive).
    pub white_u: [f32; 3],
    /// `1 / (1 + u_c)` per channel (one when additive).
    pub white_k: [f32; 3],
    /// True when the display has a white segment (the white-segment step of step 1 runs).
    pub white_segment: bool,
    /// Inverse LUTs of R, G, B.
    pub luts: [PreparedLut; 3],
    /// Flat-field texture; `None`: no texture fetch at all.
    pub flat: Option<PreparedFlat>,
    /// Out-of-gamut handling in effect.
    pub out_of_gamut: OutOfGamut,
    /// Output bit depth in effect (8, 10, 12 or 16).
    pub bit_depth: u32,
    /// Ordered dithering before quantisation.
    pub dither: bool,
}

impl PreparedProfile {
    /// Validates the profile and converts it; `opts` override its choices.
    pub fn new(profile: &DisplayProfile, opts: &ApplyOptions) -> Result<Self, ApplyError> {
        profile.validate()?;
        let display = profile.display.to_string();
        let m = &profile.xyz_to_drive;
        let largest = m.iter().flatten().fold(0.0f64, |acc, v| acc.max(v.abs()));
        if largest > MAX_MATRIX_ENTRY {
            return Err(ApplyError::Matrix {
                display,
                reason: format!("entry of magnitude {largest:.3e} drive per cd/m²"),
            });
        }
        if m.iter().flatten().all(|v| *v == 0.0) {
            return Err(ApplyError::Matrix {
                display,
                reason: "all entries are zero".into(),
            });
        }
        let w = profile.target_white_xyz_cd_m2;
        let wd = mat3::mul_vec(m, &w);
        if w[1] <= 0.0 || wd.iter().any(|v| v.is_nan() || *v < -1e-9) {
            return Err(ApplyError::White { display, white: w });
        }
        let bit_depth = opts.bit_depth.unwrap_or(profile.bit_depth);
        if !matches!(bit_depth, 8 | 10 | 12 | 16) {
            return Err(ApplyError::BitDepth(bit_depth));
        }
        let f = |v: f64| v as f32;
        let u = profile.display_model.white_in_channels(m).map(f);
        let white_segment = u != [0.0; 3];
        Ok(PreparedProfile {
            white_u: u,
            white_k: u.map(|v| 1.0 / (1.0 + v)),
            white_segment,
            display: profile.display.clone(),
            matrix: m.map(|row| row.map(f)),
            offset: profile.drive_offset.map(f),
            white_dir: wd.map(|v| f((v / w[1]).max(0.0))),
            luts: [
                PreparedLut::new(&profile.curves[0].inverse_lut),
                PreparedLut::new(&profile.curves[1].inverse_lut),
                PreparedLut::new(&profile.curves[2].inverse_lut),
            ],
            flat: profile.flat_field.as_ref().map(|ff| PreparedFlat {
                width: ff.width,
                height: ff.height,
                gain: ff.gain.clone(),
            }),
            out_of_gamut: opts.out_of_gamut.unwrap_or(profile.out_of_gamut),
            bit_depth,
            dither: opts.dither,
        })
    }

    /// Largest code value at the bit depth in effect.
    pub fn max_code(&self) -> u32 {
        (1u32 << self.bit_depth) - 1
    }

    /// Flat-field gain at `uv`, `[1, 1, 1]` without a texture.
    #[inline(always)]
    pub fn gain_at(&self, uv: [f32; 2]) -> [f32; 3] {
        match &self.flat {
            Some(ff) => ff.gain_at(uv),
            None => [1.0; 3],
        }
    }

    /// The post pass for one pixel at `uv`.
    #[inline]
    pub fn apply(&self, xyz_cd_m2: [f32; 3], uv: [f32; 2]) -> PixelOut {
        if !(uv[0].is_finite() && uv[1].is_finite()) {
            return self.invalid();
        }
        match &self.flat {
            Some(ff) => self.apply_gain(xyz_cd_m2, Some(ff.gain_at(uv))),
            None => self.apply_gain(xyz_cd_m2, None),
        }
    }

    fn invalid(&self) -> PixelOut {
        match self.out_of_gamut {
            OutOfGamut::FalseColour => PixelOut {
                drive: MARKER_INVALID,
                flags: PixelFlags::INVALID,
            },
            OutOfGamut::Clip => {
                let a = self.white_step(self.offset).map(|o| o.clamp(0.0, 1.0));
                PixelOut {
                    drive: self.drives(a),
                    flags: PixelFlags::INVALID,
                }
            }
        }
    }

    #[inline(always)]
    fn drives(&self, a: [f32; 3]) -> [f32; 3] {
        [
            self.luts[0].drive_for(a[0]),
            self.luts[1].drive_for(a[1]),
            self.luts[2].drive_for(a[2]),
        ]
    }

    /// The post pass for one pixel whose flat-field gain is already known (`None`: no
    /// texture). The image paths call this with the gain of [`PreparedFlat::gain_at`].
    #[inline(always)]
    pub fn apply_gain(&self, xyz_cd_m2: [f32; 3], gain: Option<[f32; 3]>) -> PixelOut {
        let [x, y, z] = xyz_cd_m2;
        if !(x.is_finite() && y.is_finite() && z.is_finite()) {
            return self.invalid();
        }
        let xyz = limit_input(xyz_cd_m2);
        let m = self.linear(xyz, gain);
        let a = self.white_step(self.with_offset(m));
        let fast =
            a[0] >= 0.0 && a[1] >= 0.0 && a[2] >= 0.0 && a[0] <= 1.0 && a[1] <= 1.0 && a[2] <= 1.0;
        if fast {
            return PixelOut {
                drive: self.drives(a),
                flags: PixelFlags::NONE,
            };
        }
        self.outside(xyz, gain, m, a)
    }

    /// `M·xyz / gain`: linear drives before the black offset.
    #[inline(always)]
    fn linear(&self, xyz: [f32; 3], gain: Option<[f32; 3]>) -> [f32; 3] {
        let mm = &self.matrix;
        let m = [
            mm[0][0] * xyz[0] + mm[0][1] * xyz[1] + mm[0][2] * xyz[2],
            mm[1][0] * xyz[0] + mm[1][1] * xyz[1] + mm[1][2] * xyz[2],
            mm[2][0] * xyz[0] + mm[2][1] * xyz[1] + mm[2][2] * xyz[2],
        ];
        match gain {
            Some(g) => divide_gain(m, g),
            None => m,
        }
    }

    #[inline(always)]
    fn with_offset(&self, m: [f32; 3]) -> [f32; 3] {
        let off = self.offset;
        [m[0] + off[0], m[1] + off[1], m[2] + off[2]]
    }

    /// The white-segment step: the white segment taken out of the channel intensities `a` (identity for
    /// an additive display).
    #[inline(always)]
    pub fn white_step(&self, a: [f32; 3]) -> [f32; 3] {
        if !self.white_segment {
            return a;
        }
        let (u, k) = (self.white_u, self.white_k);
        let s = (a[0] * k[0]).min(a[1] * k[1]).min(a[2] * k[2]).max(0.0);
        [a[0] - u[0] * s, a[1] - u[1] * s, a[2] - u[2] * s]
    }

    /// The linear part and offset of the white-segment step in the region of `a = m + offset`: `(m', o')`
    /// with `white_step(m + o) = m' + o'` for every `m` whose minimum `m_j·k_j` is in
    /// the same channel and positive (the identity for an additive display or `s = 0`).
    #[inline(always)]
    fn white_region(&self, m: [f32; 3], a: [f32; 3]) -> ([f32; 3], [f32; 3]) {
        let off = self.offset;
        if !self.white_segment {
            return (m, off);
        }
        let (u, k) = (self.white_u, self.white_k);
        let t = [a[0] * k[0], a[1] * k[1], a[2] * k[2]];
        let j = if t[0] <= t[1] && t[0] <= t[2] {
            0
        } else if t[1] <= t[2] {
            1
        } else {
            2
        };
        if t[j] <= 0.0 {
            return (m, off);
        }
        let f = |v: [f32; 3]| {
            let r = v[j] * k[j];
            [v[0] - u[0] * r, v[1] - u[1] * r, v[2] - u[2] * r]
        };
        (f(m), f(off))
    }

    /// A pixel whose drives `a` (linear part `m`) are not all in 0..=1: gamut mapping,
    /// range scaling, clamping and, in false-colour mode, the markers.
    #[inline]
    fn outside(
        &self,
        xyz: [f32; 3],
        gain: Option<[f32; 3]>,
        mut m: [f32; 3],
        mut a: [f32; 3],
    ) -> PixelOut {
        let mut flags = PixelFlags::NONE;
        if a.iter().any(|v| *v < -GAMUT_TOLERANCE) {
            m = self.toward_white(xyz, gain, m, a, &mut flags);
            a = self.white_step(self.with_offset(m));
        }
        if a.iter().any(|v| *v > 1.0 + GAMUT_TOLERANCE) {
            flags |= PixelFlags::OVER_RANGE;
            a = self.scale_into_range(m, a);
        }
        let a = a.map(|v| v.clamp(0.0, 1.0));
        if self.out_of_gamut == OutOfGamut::FalseColour {
            if flags.contains(PixelFlags::OUT_OF_GAMUT) {
                return PixelOut {
                    drive: MARKER_OUT_OF_GAMUT,
                    flags,
                };
            }
            if flags.contains(PixelFlags::OVER_RANGE) {
                return PixelOut {
                    drive: MARKER_OVER_RANGE,
                    flags,
                };
            }
        }
        PixelOut {
            drive: self.drives(a),
            flags,
        }
    }

    /// Gamut mapping: the linear drives moved toward the target white at constant
    /// luminance until no channel is below 0 (black without positive luminance).
    #[inline]
    fn toward_white(
        &self,
        xyz: [f32; 3],
        gain: Option<[f32; 3]>,
        m: [f32; 3],
        a: [f32; 3],
        flags: &mut PixelFlags,
    ) -> [f32; 3] {
        let off = self.offset;
        let lum = xyz[1];
        if lum <= 0.0 {
            // No positive luminance: nothing to show but black.
            if xyz != [0.0; 3] {
                *flags |= PixelFlags::OUT_OF_GAMUT;
            }
            if off.iter().any(|o| *o < 0.0) {
                *flags |= PixelFlags::BELOW_BLACK;
            }
            return [0.0; 3];
        }
        let wd = self.white_dir;
        let mut mw = [lum * wd[0], lum * wd[1], lum * wd[2]];
        if let Some(g) = gain {
            mw = divide_gain(mw, g);
        }
        let mut t = 0.0f32;
        for c in 0..3 {
            let aw = mw[c] + off[c];
            if a[c] < -GAMUT_TOLERANCE {
                if aw >= 0.0 {
                    // a_c(t) = a_c + t (aw − a_c) = 0.
                    t = t.max(-a[c] / (aw - a[c]));
                } else {
                    *flags |= PixelFlags::BELOW_BLACK;
                }
            }
        }
        if t <= 0.0 {
            return m;
        }
        *flags |= PixelFlags::OUT_OF_GAMUT;
        let t = t.min(1.0);
        [
            m[0] + t * (mw[0] - m[0]),
            m[1] + t * (mw[1] - m[1]),
            m[2] + t * (mw[2] - m[2]),
        ]
    }

    /// Range: the drives scaled at constant chromaticity until every channel ≤ 1.
    #[inline]
    fn scale_into_range(&self, m: [f32; 3], a: [f32; 3]) -> [f32; 3] {
        let (m, off) = self.white_region(m, self.with_offset(m));
        let mut s = 1.0f32;
        for c in 0..3 {
            if a[c] > 1.0 {
                let sc = if m[c] > 0.0 {
                    ((1.0 - off[c]) / m[c]).max(0.0)
                } else {
                    0.0
                };
                s = s.min(sc);
            }
        }
        [s * m[0] + off[0], s * m[1] + off[1], s * m[2] + off[2]]
    }

    /// Code values for one pixel at integer position `(px, py)` of the output (the
    /// position only selects the dither threshold).
    #[inline(always)]
    pub fn quantise_pixel(&self, drive: [f32; 3], px: u32, py: u32) -> [u16; 3] {
        let thr = if self.dither {
            dither_threshold(px, py)
        } else {
            0.5
        };
        let max = self.max_code();
        [
            quantise(drive[0], max, thr),
            quantise(drive[1], max, thr),
            quantise(drive[2], max, thr),
        ]
    }
}

/// Input scaled down (at constant chromaticity) so that no component's magnitude
/// exceeds [`MAX_INPUT_CD_M2`].
#[inline(always)]
fn limit_input(xyz: [f32; 3]) -> [f32; 3] {
    let [x, y, z] = xyz;
    let big = x.abs().max(y.abs()).max(z.abs());
    if big > MAX_INPUT_CD_M2 {
        let k = MAX_INPUT_CD_M2 / big;
        [x * k, y * k, z * k]
    } else {
        xyz
    }
}

/// `v / g` per channel.
#[inline(always)]
fn divide_gain(v: [f32; 3], g: [f32; 3]) -> [f32; 3] {
    [v[0] / g[0], v[1] / g[1], v[2] / g[2]]
}

/// The post pass for one pixel, straight from a profile (prepares it first; for many
/// pixels prepare once with [`PreparedProfile::new`] and call [`PreparedProfile::apply`]).
pub fn apply_pixel(
    profile: &DisplayProfile,
    xyz_cd_m2: [f32; 3],
    uv: [f32; 2],
    opts: &ApplyOptions,
) -> Result<PixelOut, ApplyError> {
    Ok(PreparedProfile::new(profile, opts)?.apply(xyz_cd_m2, uv))
}

#[cfg(test)]
mod tests;
