//! Reading frames into the post pass and writing display images out of it.
//!
//! **OpenEXR convention.** A frame is linear CIE XYZ with Y in cd/m². Accepted channel
//! sets (first valid layer, a `layer.` prefix is ignored): `X, Y, Z`; `R, G, B` holding
//! X, Y, Z in that order (many tools only write RGB — the values are *not* RGB); or a
//! single `Y` (luminance in cd/m²), shown in the chromaticity of the white given in
//! [`ReadOptions::white_for_luminance_xyz`] (the wall's target white). NaN/Inf and
//! negative values are errors naming the count and the first pixel, unless
//! [`ReadOptions::sanitize`] (both replaced by 0) or [`ReadOptions::allow_negative`]
//! (negatives pass through and are handled as out of gamut) is set.
//!
//! **PNG input** is uncalibrated sRGB: decoded with the fixed ideal sRGB curve
//! (Kresse 3.3.5), then mapped to XYZ cd/m² by a matrix such as
//! [`rgb_to_xyz_matrix`](lumiwall_profiles::apply::rgb_to_xyz_matrix) for the wall white.
//!
//! **PNG output**: 8-bit codes as an 8-bit RGB PNG; 10-, 12- and 16-bit codes as a
//! 16-bit RGB PNG with the code in the most significant bits (`value = code << (16 −
//! bits)`, so a 10-bit code 1023 is stored as 65472); the display driver recovers the
//! code with `value >> (16 − bits)`.

use std::path::Path;

use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes, ReadChannels,
    ReadLayers, SmallVec, WritableImage,
};
use lumiwall_profiles::apply::srgb_to_xyz;

use super::{CodeImage, PostError, XyzFrame};

/// How to read an input frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReadOptions {
    /// Pass negative values through (they are shown as out of gamut) instead of failing.
    pub allow_negative: bool,
    /// Replace NaN, ±Inf and negative values with 0 instead of failing.
    pub sanitize: bool,
    /// White (XYZ cd/m², only the chromaticity is used) for a luminance-only EXR.
    pub white_for_luminance_xyz: [f64; 3],
}

/// What [`read_exr`] replaced or let through.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct InputReport {
    /// NaN or infinite values found (replaced by 0 when sanitising).
    pub non_finite: u64,
    /// Negative values found (replaced by 0 when sanitising).
    pub negative: u64,
    /// The file held luminance only.
    pub luminance_only: bool,
}

fn exr_err(path: &Path) -> impl Fn(exr::error::Error) -> PostError + '_ {
    move |e| PostError::Exr {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

fn short_name(full: &str) -> &str {
    full.rsplit('.').next().unwrap_or(full)
}

/// Largest width or height of an input image (pixels).
pub const MAX_INPUT_SIDE: u64 = 65_536;

/// Largest pixel count of an input image: 2²⁸, a 16384×16384 frame (3 GiB as XYZ f32),
/// more than a 48-tile wall of 1920×1200 displays (110 Mpx).
pub const MAX_INPUT_PIXELS: u64 = 1 << 28;

/// Fails with [`PostError::TooLarge`] when a header's `width × height` exceeds the
/// input limits; called before any pixel memory is allocated.
pub fn check_input_size(path: &Path, width: u64, height: u64) -> Result<(), PostError> {
    let pixels = width.checked_mul(height);
    let too_large = width > MAX_INPUT_SIDE
        || height > MAX_INPUT_SIDE
        || pixels.is_none_or(|n| n > MAX_INPUT_PIXELS);
    if too_large {
        return Err(PostError::TooLarge {
            path: path.to_path_buf(),
            width,
            height,
            max_side: MAX_INPUT_SIDE,
            max_pixels: MAX_INPUT_PIXELS,
        });
    }
    Ok(())
}

/// Reads only the headers of an OpenEXR file and checks every layer's size against
/// the input limits.
fn check_exr_header(path: &Path) -> Result<(), PostError> {
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(exr_err(path))?;
    for header in meta.headers.iter() {
        let size = header.layer_size;
        check_input_size(path, size.x() as u64, size.y() as u64)?;
    }
    Ok(())
}

/// Reads an OpenEXR frame (see the module doc for the channel convention). The
/// headers are checked against [`MAX_INPUT_PIXELS`] before any pixel is read.
pub fn read_exr(path: &Path, opts: &ReadOptions) -> Result<(XyzFrame, InputReport), PostError> {
    if !path.exists() {
        return Err(PostError::Io {
            path: path.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
        });
    }
    check_exr_header(path)?;
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(exr_err(path))?;
    let layer = image.layer_data;
    let (w, h) = (layer.size.x(), layer.size.y());
    let list = &layer.channel_data.list;
    let names: Vec<String> = list.iter().map(|c| c.name.to_string()).collect();
    let find = |want: &str| {
        list.iter()
            .find(|c| short_name(&c.name.to_string()) == want)
            .map(|c| &c.sample_data)
    };
    let channels_err = || PostError::Channels {
        path: path.to_path_buf(),
        found: names.join(", "),
    };
    let mut report = InputReport::default();
    let sets: [Option<[&FlatSamples; 3]>; 2] = [
        match (find("X"), find("Y"), find("Z")) {
            (Some(x), Some(y), Some(z)) => Some([x, y, z]),
            _ => None,
        },
        match (find("R"), find("G"), find("B")) {
            (Some(x), Some(y), Some(z)) => Some([x, y, z]),
            _ => None,
        },
    ];
    let n = w * h;
    let mut pixels = vec![[0f32; 3]; n];
    if let Some(chans) = sets.into_iter().flatten().next() {
        for (c, samples) in chans.iter().enumerate() {
            if samples.len() != n {
                return Err(channels_err());
            }
            for (p, v) in pixels.iter_mut().zip(samples.values_as_f32()) {
                p[c] = v;
            }
        }
    } else if let (Some(y), 1) = (find("Y"), list.len()) {
        if y.len() != n {
            return Err(channels_err());
        }
        let wt = opts.white_for_luminance_xyz;
        if !(wt[1] > 0.0 && wt.iter().all(|v| v.is_finite())) {
            return Err(PostError::SizeMismatch(format!(
                "luminance-only EXR {} needs a white with positive luminance, got {wt:?}",
                path.display()
            )));
        }
        let (kx, kz) = ((wt[0] / wt[1]) as f32, (wt[2] / wt[1]) as f32);
        for (p, v) in pixels.iter_mut().zip(y.values_as_f32()) {
            *p = [v * kx, v, v * kz];
        }
        report.luminance_only = true;
    } else {
        return Err(channels_err());
    }
    check_values(path, &mut pixels, w as u32, opts, &mut report)?;
    Ok((XyzFrame::new(w as u32, h as u32, pixels)?, report))
}

/// Counts NaN/Inf and negative values; fails, sanitises or passes them per `opts`.
pub fn check_values(
    path: &Path,
    pixels: &mut [[f32; 3]],
    width: u32,
    opts: &ReadOptions,
    report: &mut InputReport,
) -> Result<(), PostError> {
    let mut first_bad = None;
    let mut first_neg = None;
    for (i, p) in pixels.iter().enumerate() {
        for v in p {
            if !v.is_finite() {
                report.non_finite += 1;
                first_bad.get_or_insert(i);
            } else if *v < 0.0 {
                report.negative += 1;
                first_neg.get_or_insert(i);
            }
        }
    }
    if opts.sanitize {
        for v in pixels.iter_mut().flatten() {
            if !v.is_finite() || *v < 0.0 {
                *v = 0.0;
            }
        }
        return Ok(());
    }
    let bad_values = |i: usize, count: u64, what: &'static str, flag: &'static str| {
        let w = width.max(1) as usize;
        PostError::BadValues {
            path: path.to_path_buf(),
            count,
            what,
            first_x: (i % w) as u32,
            first_y: (i / w) as u32,
            flag,
        }
    };
    if let Some(i) = first_bad {
        return Err(bad_values(
            i,
            report.non_finite,
            "NaN or infinite",
            "--sanitize",
        ));
    }
    if let (Some(i), false) = (first_neg, opts.allow_negative) {
        return Err(bad_values(
            i,
            report.negative,
            "negative",
            "--allow-negative (or --sanitize)",
        ));
    }
    Ok(())
}

/// Writes a frame as a float EXR with channels `X, Y, Z` (or `R, G, B` holding X, Y, Z
/// when `rgb_names`).
pub fn write_exr(path: &Path, frame: &XyzFrame, rgb_names: bool) -> Result<(), PostError> {
    let names = if rgb_names {
        ["R", "G", "B"]
    } else {
        ["X", "Y", "Z"]
    };
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = (0..3)
        .map(|c| {
            AnyChannel::new(
                names[c],
                FlatSamples::F32(frame.pixels.iter().map(|p| p[c]).collect()),
            )
        })
        .collect();
    let layer = Layer::new(
        (frame.width as usize, frame.height as usize),
        LayerAttributes::default(),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(list),
    );
    let mut bytes = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut bytes)
        .map_err(exr_err(path))?;
    lumiwall_core::files::write_atomic(path, bytes.get_ref()).map_err(io_err(path))
}

/// Maps an image codec error on `path` to [`PostError::Png`].
fn png_err(path: &Path) -> impl Fn(image::ImageError) -> PostError + '_ {
    move |e| PostError::Png {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Maps an I/O error on `path` to [`PostError::Io`].
fn io_err(path: &Path) -> impl Fn(std::io::Error) -> PostError + '_ {
    move |source| PostError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Opens and decodes an image; `guess_format` trusts its bytes over its extension.
/// Decodes an image after checking its header's size against the input limits.
fn decode_image(path: &Path, guess_format: bool) -> Result<image::DynamicImage, PostError> {
    let open = || -> Result<image::ImageReader<_>, PostError> {
        let mut reader = image::ImageReader::open(path).map_err(io_err(path))?;
        if guess_format {
            reader = reader.with_guessed_format().map_err(io_err(path))?;
        }
        Ok(reader)
    };
    let (w, h) = open()?.into_dimensions().map_err(png_err(path))?;
    check_input_size(path, u64::from(w), u64::from(h))?;
    let mut reader = open()?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(w);
    limits.max_image_height = Some(h);
    // RGBA at 16 bit is the largest buffer a PNG decodes into.
    limits.max_alloc = Some(MAX_INPUT_PIXELS * 8);
    reader.limits(limits);
    reader.decode().map_err(png_err(path))
}

/// Reads an 8- or 16-bit PNG as uncalibrated sRGB and maps it to XYZ cd/m² with
/// `rgb_to_xyz` (linear relative RGB → XYZ, e.g. for the wall white).
pub fn read_png_srgb(path: &Path, rgb_to_xyz: &[[f64; 3]; 3]) -> Result<XyzFrame, PostError> {
    let img = decode_image(path, true)?;
    let rgb = img.to_rgb32f();
    let (w, h) = rgb.dimensions();
    let pixels = rgb.pixels().map(|p| srgb_to_xyz(p.0, rgb_to_xyz)).collect();
    XyzFrame::new(w, h, pixels)
}

/// Writes display codes as a PNG (8-bit, or 16-bit with the code in the high bits; see
/// the module doc), atomically: the image is encoded in memory and written through a
/// temporary file ([`lumiwall_core::files::write_atomic`]), so an interruption never
/// turns a complete earlier image into a truncated one.
pub fn write_png(path: &Path, img: &CodeImage) -> Result<(), PostError> {
    let bytes = encode_png(img).map_err(png_err(path))?;
    lumiwall_core::files::write_atomic(path, &bytes).map_err(io_err(path))
}

/// Encodes display codes as PNG bytes (see [`write_png`]).
pub fn encode_png(img: &CodeImage) -> Result<Vec<u8>, image::ImageError> {
    let size_err = || {
        image::ImageError::Parameter(image::error::ParameterError::from_kind(
            image::error::ParameterErrorKind::DimensionMismatch,
        ))
    };
    let dynamic = if img.bit_depth == 8 {
        let data: Vec<u8> = img.codes.iter().flatten().map(|v| *v as u8).collect();
        image::DynamicImage::ImageRgb8(
            image::RgbImage::from_raw(img.width, img.height, data).ok_or_else(size_err)?,
        )
    } else {
        let shift = 16 - img.bit_depth.min(16);
        let data: Vec<u16> = img.codes.iter().flatten().map(|v| v << shift).collect();
        image::DynamicImage::ImageRgb16(
            image::ImageBuffer::from_raw(img.width, img.height, data).ok_or_else(size_err)?,
        )
    };
    let mut bytes = std::io::Cursor::new(Vec::new());
    dynamic.write_to(&mut bytes, image::ImageFormat::Png)?;
    Ok(bytes.into_inner())
}

/// Reads a PNG written by [`write_png`] back into code values of `bit_depth` bits.
pub fn read_png_codes(path: &Path, bit_depth: u32) -> Result<(u32, u32, Vec<[u16; 3]>), PostError> {
    let img = decode_image(path, false)?;
    let (w, h) = (img.width(), img.height());
    let codes = if bit_depth == 8 {
        img.to_rgb8().pixels().map(|p| p.0.map(u16::from)).collect()
    } else {
        let shift = 16 - bit_depth.min(16);
        img.to_rgb16()
            .pixels()
            .map(|p| p.0.map(|v| v >> shift))
            .collect()
    };
    Ok((w, h, codes))
}
