//! A presented frame: RGB code values at a surface bit depth, and its PNG form (16-bit,
//! codes in the high bits, the convention `lumiwall apply` writes).

use crate::limits::{MAX_OUTPUT_PIXELS, MAX_OUTPUT_SIDE};

/// One output's frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Framebuffer {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Bits per channel of the codes.
    pub bits: u32,
    /// Row-major RGB codes, each below `2^bits`.
    pub codes: Vec<[u16; 3]>,
}

/// Largest code at `bits` bits per channel.
pub fn max_code(bits: u32) -> u32 {
    (1u32 << bits.clamp(1, 16)) - 1
}

/// `code` at `from` bits rounded to the nearest code at `to` bits.
pub fn requantise(code: u32, from: u32, to: u32) -> u16 {
    if from == to {
        return code as u16;
    }
    let v = f64::from(code) * f64::from(max_code(to)) / f64::from(max_code(from));
    v.round() as u16
}

/// Whether `width × height` is a frame this crate holds.
pub(crate) fn size_ok(width: u32, height: u32) -> bool {
    width > 0
        && height > 0
        && width <= MAX_OUTPUT_SIDE
        && height <= MAX_OUTPUT_SIDE
        && u64::from(width) * u64::from(height) <= MAX_OUTPUT_PIXELS
}

impl Framebuffer {
    /// A black frame.
    pub fn black(width: u32, height: u32, bits: u32) -> Framebuffer {
        Framebuffer::uniform(width, height, bits, [0; 3])
    }

    /// A frame of one colour.
    pub fn uniform(width: u32, height: u32, bits: u32, code: [u16; 3]) -> Framebuffer {
        Framebuffer {
            width,
            height,
            bits,
            codes: vec![code; width as usize * height as usize],
        }
    }

    /// The colour of every pixel, if the frame is uniform.
    pub fn uniform_code(&self) -> Option<[u16; 3]> {
        let first = *self.codes.first()?;
        self.codes.iter().all(|c| *c == first).then_some(first)
    }

    /// The frame as a 16-bit RGB PNG with the codes in the high bits.
    pub fn to_png(&self) -> Result<Vec<u8>, String> {
        let shift = 16 - self.bits.min(16);
        let data: Vec<u16> = self.codes.iter().flatten().map(|v| v << shift).collect();
        let img = image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::from_raw(
            self.width,
            self.height,
            data,
        )
        .ok_or("frame size and pixel count differ")?;
        let mut out = std::io::Cursor::new(Vec::new());
        image::DynamicImage::ImageRgb16(img)
            .write_to(&mut out, image::ImageFormat::Png)
            .map_err(|e| e.to_string())?;
        Ok(out.into_inner())
    }

    /// Decodes a PNG (8- or 16-bit; 16-bit values hold codes in the high bits) that must
    /// be `width × height`, into codes at `bits` bits. The size is checked from the
    /// header before any pixel is decoded.
    pub fn from_png(bytes: &[u8], width: u32, height: u32, bits: u32) -> Result<Self, String> {
        let reader = || {
            image::ImageReader::with_format(std::io::Cursor::new(bytes), image::ImageFormat::Png)
        };
        let (w, h) = reader()
            .into_dimensions()
            .map_err(|e| format!("not a PNG: {e}"))?;
        if (w, h) != (width, height) {
            return Err(format!(
                "the image is {w}×{h}, the output is {width}×{height}"
            ));
        }
        let mut r = reader();
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(width);
        limits.max_image_height = Some(height);
        limits.max_alloc = Some(u64::from(width) * u64::from(height) * 8 + (1 << 20));
        r.limits(limits);
        let img = r
            .decode()
            .map_err(|e| format!("the PNG cannot be decoded: {e}"))?;
        let codes = match img {
            image::DynamicImage::ImageRgb16(_) | image::DynamicImage::ImageRgba16(_) => {
                let shift = 16 - bits.min(16);
                img.to_rgb16()
                    .pixels()
                    .map(|p| p.0.map(|v| v >> shift))
                    .collect()
            }
            _ => img
                .to_rgb8()
                .pixels()
                .map(|p| p.0.map(|v| requantise(u32::from(v), 8, bits)))
                .collect(),
        };
        Ok(Framebuffer {
            width,
            height,
            bits,
            codes,
        })
    }

    /// Decodes a PNG written by [`Framebuffer::to_png`] (any size within the limits).
    pub fn read_png(bytes: &[u8], bits: u32) -> Result<Self, String> {
        let (w, h) =
            image::ImageReader::with_format(std::io::Cursor::new(bytes), image::ImageFormat::Png)
                .into_dimensions()
                .map_err(|e| format!("not a PNG: {e}"))?;
        if !size_ok(w, h) {
            return Err(format!("a {w}×{h} frame is larger than this station reads"));
        }
        Framebuffer::from_png(bytes, w, h, bits)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_round_trip_through_png_at_every_depth() {
        for bits in [8, 10, 12, 16] {
            let top = max_code(bits) as u16;
            let mut f = Framebuffer::uniform(3, 2, bits, [top, 1, 0]);
            f.codes[4] = [0, top / 2, top];
            let back = Framebuffer::read_png(&f.to_png().unwrap(), bits).unwrap();
            assert_eq!(back, f, "{bits} bit");
            assert_eq!(f.uniform_code(), None);
        }
        assert_eq!(requantise(1023, 10, 8), 255);
        assert_eq!(requantise(512, 10, 8), 128);
        assert_eq!(requantise(255, 8, 10), 1023);
    }

    #[test]
    fn a_png_of_the_wrong_size_is_refused_from_its_header() {
        let f = Framebuffer::black(4, 4, 8);
        let err = Framebuffer::from_png(&f.to_png().unwrap(), 1920, 1080, 8).unwrap_err();
        assert!(err.contains("4×4") && err.contains("1920×1080"), "{err}");
        assert!(Framebuffer::from_png(b"not a png", 4, 4, 8).is_err());
    }
}
