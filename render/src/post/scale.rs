//! The photometric scale between a rendered scene and the wall that shows it.
//!
//! A rendered room is often far brighter than a projection wall (an office's walls at
//! hundreds of cd/m², a wall's common white at 50). [`LuminanceScale`] is the choice:
//! 1:1 (the default, the scene as it is, what does not fit marked over range by the
//! post pass), a stated factor, or automatic (the largest factor at which a chosen
//! percentile of the pixels fits into the wall's common gamut: every channel of the
//! common primaries at most the common white's). [`resolve`] turns
//! the choice into the factor for the frames at hand and says how it came about;
//! [`stamp_label`] writes it into a corner of a scaled frame, so nobody mistakes a
//! scaled view for a true one.

use std::fmt;
use std::str::FromStr;

use font8x8::UnicodeFonts;

use lumiwall_core::mat3::{self, Mat3};

use crate::post::XyzFrame;

/// Largest factor a scale may have, either way (a factor outside 10⁻⁶..10⁶ is a typo).
pub const MAX_FACTOR: f64 = 1e6;
/// Percentile of the scene luminance `auto` fits to the common white unless told.
pub const DEFAULT_PERCENTILE: f64 = 99.0;
/// Most pixels the automatic scale looks at (evenly strided beyond it).
const MAX_SAMPLES: usize = 1 << 22;
/// Pixel size of one glyph cell of the label (the 8×8 font enlarged).
const GLYPH_SCALE: u32 = 2;

/// How scene luminance maps to the wall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LuminanceScale {
    /// Every luminance multiplied by this factor (1: the scene as it is).
    Factor(f64),
    /// The largest factor at which this percentile (0–100] of the pixels fits into the
    /// wall's common gamut (no channel of the common primaries above the white's).
    Auto {
        /// Percentile of the pixels.
        percentile: f64,
    },
}

impl Default for LuminanceScale {
    fn default() -> Self {
        LuminanceScale::Factor(1.0)
    }
}

impl FromStr for LuminanceScale {
    type Err = String;

    /// `1`, `0.25` (a factor), `auto` or `auto:95` (a percentile).
    fn from_str(s: &str) -> Result<Self, String> {
        let s = s.trim();
        if let Some(rest) = s.strip_prefix("auto") {
            let percentile = match rest.strip_prefix(':') {
                None if rest.is_empty() => DEFAULT_PERCENTILE,
                Some(p) => p
                    .parse::<f64>()
                    .ok()
                    .filter(|p| p.is_finite() && *p > 0.0 && *p <= 100.0)
                    .ok_or_else(|| format!("auto:{p}: the percentile must be in (0, 100]"))?,
                None => return Err(format!("{s}: write auto or auto:PERCENTILE")),
            };
            return Ok(LuminanceScale::Auto { percentile });
        }
        let f: f64 = s
            .parse()
            .map_err(|_| format!("{s}: give a factor such as 0.25, or auto, or auto:99"))?;
        if f.is_finite() && (1.0 / MAX_FACTOR..=MAX_FACTOR).contains(&f) {
            Ok(LuminanceScale::Factor(f))
        } else {
            Err(format!(
                "{s}: the factor must be between {} and {MAX_FACTOR}",
                1.0 / MAX_FACTOR
            ))
        }
    }
}

/// The factor for one run and how it was chosen.
#[derive(Debug, Clone, PartialEq)]
pub struct ResolvedScale {
    /// Scene luminance × factor = wall luminance.
    pub factor: f64,
    /// How the factor came about, for the log line.
    pub how: String,
}

impl ResolvedScale {
    /// True for 1:1 (nothing is scaled, nothing is marked).
    pub fn is_true_scale(&self) -> bool {
        self.factor == 1.0
    }

    /// The label written into scaled frames, e.g. `LUMINANCE x0.250`.
    pub fn label(&self) -> String {
        format!("LUMINANCE x{}", significant(self.factor))
    }
}

impl fmt::Display for ResolvedScale {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_true_scale() {
            write!(f, "luminance scale 1:1 ({})", self.how)
        } else {
            write!(
                f,
                "luminance scale x{} ({}); the images are marked `{}` in their top left corner",
                significant(self.factor),
                self.how,
                self.label()
            )
        }
    }
}

/// `v` with four significant digits and no exponent for everyday factors.
fn significant(v: f64) -> String {
    if !(1e-3..1000.0).contains(&v) {
        format!("{v:.3e}")
    } else {
        let decimals = (3 - v.log10().floor() as i32).clamp(0, 6) as usize;
        format!("{v:.decimals$}")
    }
}

/// The factor `scale` gives for `frames` on a wall whose common gamut is
/// `xyz_to_common_rgb` (XYZ in cd/m² to linear RGB of the common primaries, the common
/// white at 1, 1, 1). `auto` on a scene with nothing above 0 at the percentile keeps
/// 1:1 and says so.
pub fn resolve(
    scale: LuminanceScale,
    frames: &[&XyzFrame],
    xyz_to_common_rgb: &Mat3,
) -> Result<ResolvedScale, String> {
    match scale {
        LuminanceScale::Factor(1.0) => Ok(ResolvedScale {
            factor: 1.0,
            how: "the scene's own luminance".into(),
        }),
        LuminanceScale::Factor(f) => Ok(ResolvedScale {
            factor: f,
            how: "as given".into(),
        }),
        LuminanceScale::Auto { percentile } => Ok(auto(percentile, frames, xyz_to_common_rgb)),
    }
}

fn auto(percentile: f64, frames: &[&XyzFrame], to_rgb: &Mat3) -> ResolvedScale {
    let level = level_percentile(frames, to_rgb, percentile);
    let Some(level) = level.filter(|l| *l > 0.0) else {
        return ResolvedScale {
            factor: 1.0,
            how: format!("auto: {percentile} % of the pixels are black, nothing to scale"),
        };
    };
    let factor = (1.0 / level).clamp(1.0 / MAX_FACTOR, MAX_FACTOR);
    ResolvedScale {
        factor,
        how: format!(
            "auto: {percentile} % of the pixels within the common gamut; they reach {} × \
             the common white",
            significant(level)
        ),
    }
}

/// The `percentile` (0–100], by nearest rank, of the pixels' level: the largest of
/// their channels in the common primaries, 1 at the common white (non-finite pixels
/// left out; evenly strided to at most 4 Mi pixels); `None` without any.
pub fn level_percentile(frames: &[&XyzFrame], to_rgb: &Mat3, percentile: f64) -> Option<f64> {
    let total: usize = frames.iter().map(|f| f.pixels.len()).sum();
    let stride = total.div_ceil(MAX_SAMPLES).max(1);
    let level = |p: &[f32; 3]| {
        if !p.iter().all(|v| v.is_finite()) {
            return f64::NAN;
        }
        let rgb = mat3::mul_vec(to_rgb, &p.map(f64::from));
        rgb[0].max(rgb[1]).max(rgb[2]).max(0.0)
    };
    let mut v: Vec<f64> = frames
        .iter()
        .flat_map(|f| f.pixels.iter().step_by(stride).map(level))
        .filter(|v| v.is_finite())
        .collect();
    if v.is_empty() {
        return None;
    }
    let rank = ((percentile / 100.0) * v.len() as f64).ceil() as usize;
    let k = rank.clamp(1, v.len()) - 1;
    let (_, x, _) = v.select_nth_unstable_by(k, f64::total_cmp);
    Some(*x)
}

/// Multiplies every pixel of `frame` by `factor`.
pub fn scale_frame(frame: &mut XyzFrame, factor: f64) {
    let k = factor as f32;
    for p in &mut frame.pixels {
        *p = p.map(|v| v * k);
    }
}

/// Writes `text` into the top left corner of `frame`: glyphs of the 8×8 font, enlarged
/// twice where the label then fits the frame's width, in `white_xyz`, on
/// a black box with a margin; characters the font lacks show as blanks, and what does
/// not fit the frame is cut off.
pub fn stamp_label(frame: &mut XyzFrame, text: &str, white_xyz: [f32; 3]) {
    let chars: Vec<char> = text.chars().collect();
    let box_size = |g: u32| (chars.len() as u32 * 8 * g + 4 * g, 8 * g + 4 * g);
    let g = if box_size(GLYPH_SCALE).0 <= frame.width {
        GLYPH_SCALE
    } else {
        1
    };
    let (box_w, box_h) = box_size(g);
    let margin = 2 * g;
    for y in 0..box_h.min(frame.height) {
        for x in 0..box_w.min(frame.width) {
            let on = glyph_pixel(&chars, g, x.wrapping_sub(margin), y.wrapping_sub(margin));
            frame.pixels[(y * frame.width + x) as usize] = if on { white_xyz } else { [0.0; 3] };
        }
    }
}

/// Whether pixel `(x, y)` of the text (origin at its top left), glyphs enlarged `g`
/// times, is set.
fn glyph_pixel(chars: &[char], g: u32, x: u32, y: u32) -> bool {
    let cell = 8 * g;
    if y >= cell {
        return false;
    }
    let Some(c) = chars.get((x / cell) as usize) else {
        return false;
    };
    let Some(rows) = font8x8::BASIC_FONTS.get(*c) else {
        return false;
    };
    let (gx, gy) = ((x % cell) / g, y / g);
    rows[gy as usize] >> gx & 1 == 1
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(ys: &[f32]) -> XyzFrame {
        XyzFrame::new(
            ys.len() as u32,
            1,
            ys.iter().map(|y| [*y, *y, *y]).collect(),
        )
        .unwrap()
    }

    #[test]
    fn scales_parse_and_bad_ones_say_what_is_allowed() {
        assert_eq!("1".parse(), Ok(LuminanceScale::Factor(1.0)));
        assert_eq!("0.25".parse(), Ok(LuminanceScale::Factor(0.25)));
        assert_eq!(
            "auto".parse(),
            Ok(LuminanceScale::Auto {
                percentile: DEFAULT_PERCENTILE
            })
        );
        assert_eq!(
            "auto:95".parse(),
            Ok(LuminanceScale::Auto { percentile: 95.0 })
        );
        for bad in [
            "0", "-1", "NaN", "inf", "1e7", "auto:0", "auto:101", "autox", "x",
        ] {
            assert!(bad.parse::<LuminanceScale>().is_err(), "{bad}");
        }
    }

    #[test]
    fn auto_fits_the_percentile_into_the_common_gamut_by_its_largest_channel() {
        // Common primaries = XYZ itself, white (45, 45, 45) cd/m².
        let to_rgb = [
            [1.0 / 45.0, 0.0, 0.0],
            [0.0, 1.0 / 45.0, 0.0],
            [0.0, 0.0, 1.0 / 45.0],
        ];
        let mut ys: Vec<f32> = (1..=100).map(|i| i as f32 * 10.0).collect();
        ys[0] = f32::NAN;
        let mut f = frame(&ys);
        // A saturated pixel: its Z alone is far above the white.
        f.pixels[1] = [0.0, 0.0, 1e5];
        let s = resolve(LuminanceScale::Auto { percentile: 90.0 }, &[&f], &to_rgb).unwrap();
        // 99 finite pixels; the 90th percentile by nearest rank is the 90th smallest
        // level: 920 cd/m² (the saturated pixel ranks last, the NaN not at all).
        assert!((s.factor - 45.0 / 920.0).abs() < 1e-12, "{s:?}");
        assert!(s.to_string().contains("x0.04891"), "{s}");
        let dark = frame(&[0.0; 10]);
        let s = resolve(LuminanceScale::Auto { percentile: 99.0 }, &[&dark], &to_rgb).unwrap();
        assert!(s.is_true_scale(), "{s:?}");
    }

    #[test]
    fn the_label_is_drawn_in_white_on_black_in_the_top_left_corner_only() {
        // 15 glyphs: 16 px each plus 4 px margins (248 × 24) fit a 300 px frame.
        let mut f = XyzFrame::new(300, 40, vec![[5.0; 3]; 300 * 40]).unwrap();
        stamp_label(&mut f, "LUMINANCE x0.25", [9.0, 10.0, 11.0]);
        let at = |f: &XyzFrame, x: u32, y: u32| f.pixels[(y * f.width + x) as usize];
        let (mut lit, mut black) = (0, 0);
        for y in 0..40u32 {
            for x in 0..300u32 {
                let p = at(&f, x, y);
                if x < 248 && y < 24 {
                    lit += usize::from(p == [9.0, 10.0, 11.0]);
                    black += usize::from(p == [0.0; 3]);
                } else {
                    assert_eq!(p, [5.0; 3], "{x},{y} outside the label");
                }
            }
        }
        assert_eq!(lit + black, 248 * 24);
        assert!(lit > 400, "{lit} label pixels");
        // Narrower frames get the font at its own size (128 + 4 by 12 px).
        let mut narrow = XyzFrame::new(200, 20, vec![[5.0; 3]; 200 * 20]).unwrap();
        stamp_label(&mut narrow, "LUMINANCE x0.25", [1.0; 3]);
        assert_eq!(at(&narrow, 123, 11), [0.0; 3]);
        assert_eq!(at(&narrow, 124, 0), [5.0; 3]);
        assert_eq!(at(&narrow, 0, 12), [5.0; 3]);
        // A frame smaller than the label is cut, not overrun.
        let mut small = XyzFrame::new(7, 3, vec![[1.0; 3]; 21]).unwrap();
        stamp_label(&mut small, "LUMINANCE x0.25", [1.0; 3]);
        assert_eq!(small.pixels.len(), 21);
    }
}
