//! Frames going into the post pass (linear XYZ, Y in cd/m²) and the code images coming
//! out of it.

use lumiwall_profiles::apply::PixelFlags;

use super::PostError;

/// A linear-light frame: per pixel CIE XYZ with Y in cd/m², row-major from the top left.
#[derive(Debug, Clone, PartialEq)]
pub struct XyzFrame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` pixels, XYZ in cd/m².
    pub pixels: Vec<[f32; 3]>,
}

impl XyzFrame {
    /// A frame from its pixels; errors when the count does not match the size.
    pub fn new(width: u32, height: u32, pixels: Vec<[f32; 3]>) -> Result<Self, PostError> {
        if pixels.len() != width as usize * height as usize {
            return Err(PostError::SizeMismatch(format!(
                "{width}×{height} frame given {} pixels",
                pixels.len()
            )));
        }
        Ok(XyzFrame {
            width,
            height,
            pixels,
        })
    }

    /// The part of the frame one tile of a `cols × rows` wall shows (tile `col`, `row`
    /// counted from the top left). The frame must divide evenly into tiles.
    pub fn tile(&self, cols: u32, rows: u32, col: u32, row: u32) -> Result<XyzFrame, PostError> {
        if cols == 0 || rows == 0 || col >= cols || row >= rows {
            return Err(PostError::SizeMismatch(format!(
                "tile col {col} row {row} is not in a {cols}×{rows} wall"
            )));
        }
        if !self.width.is_multiple_of(cols) || !self.height.is_multiple_of(rows) {
            return Err(PostError::SizeMismatch(format!(
                "{}×{} frame does not divide into {cols}×{rows} equal tiles; render at a \
                 multiple of the tile resolution",
                self.width, self.height
            )));
        }
        let (tw, th) = (self.width / cols, self.height / rows);
        let mut pixels = Vec::with_capacity(tw as usize * th as usize);
        for y in 0..th {
            let start = ((row * th + y) * self.width + col * tw) as usize;
            pixels.extend_from_slice(&self.pixels[start..start + tw as usize]);
        }
        XyzFrame::new(tw, th, pixels)
    }
}

/// How many pixels got which flag.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FlagCounts {
    /// Out of the display's gamut.
    pub out_of_gamut: u64,
    /// Too bright for the display.
    pub over_range: u64,
    /// NaN or infinite input.
    pub invalid: u64,
    /// Below the display's own black.
    pub below_black: u64,
}

impl FlagCounts {
    /// Counts one pixel's flags.
    #[inline(always)]
    pub fn add(&mut self, f: PixelFlags) {
        let b = u64::from(f.0);
        self.out_of_gamut += b & 1;
        self.over_range += (b >> 1) & 1;
        self.invalid += (b >> 2) & 1;
        self.below_black += (b >> 3) & 1;
    }

    /// Adds a histogram of flag bytes (`hist[f]` = pixels with flags `f`).
    pub fn add_histogram(&mut self, hist: &[u64; 16]) {
        for (f, n) in hist.iter().enumerate() {
            let f = f as u64;
            self.out_of_gamut += n * (f & 1);
            self.over_range += n * ((f >> 1) & 1);
            self.invalid += n * ((f >> 2) & 1);
            self.below_black += n * ((f >> 3) & 1);
        }
    }

    /// Sum of two counts.
    pub fn merged(self, o: FlagCounts) -> FlagCounts {
        FlagCounts {
            out_of_gamut: self.out_of_gamut + o.out_of_gamut,
            over_range: self.over_range + o.over_range,
            invalid: self.invalid + o.invalid,
            below_black: self.below_black + o.below_black,
        }
    }
}

/// The post pass's output for one display: code values per pixel and channel.
#[derive(Debug, Clone, PartialEq)]
pub struct CodeImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Bits per channel of the codes (8, 10, 12 or 16).
    pub bit_depth: u32,
    /// Row-major code values R, G, B, each in `0..2^bit_depth`.
    pub codes: Vec<[u16; 3]>,
    /// Per-pixel flags (bits of [`PixelFlags`]), same order as `codes`.
    pub flags: Vec<u8>,
    /// Totals of `flags`.
    pub counts: FlagCounts,
}
