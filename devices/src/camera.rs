//! Cameras: what the calibration asks of one. A frame at an exposure time and gain
//! the station chooses (never the camera's own automatic exposure, which makes
//! photometry impossible), with the settings it was taken with.

use serde::{Deserialize, Serialize};

use crate::DeviceError;

/// Largest frame a camera may deliver, in pixels (a 64-megapixel sensor); larger
/// sizes from a device or a configuration are refused before allocating.
pub const MAX_FRAME_PIXELS: u64 = 64 << 20;

/// Static facts about a camera and the controls the station needs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraInfo {
    /// Model or device name.
    pub name: String,
    /// Frame width in pixels.
    pub width_px: u32,
    /// Frame height in pixels.
    pub height_px: u32,
    /// Bits per channel of the delivered frames (8 or 12 here).
    pub bit_depth: u32,
    /// Shortest and longest exposure time the camera accepts (s).
    pub exposure_range_s: [f64; 2],
    /// Smallest and largest analogue gain (1 = unity).
    pub gain_range: [f64; 2],
    /// Whether exposure time can be set by the station (false: automatic only).
    pub manual_exposure: bool,
}

impl CameraInfo {
    /// Largest code value of a frame channel.
    pub fn max_code(&self) -> u32 {
        (1u32 << self.bit_depth.min(16)) - 1
    }

    /// Checks an exposure request against the camera's controls: manual exposure
    /// must exist, and time and gain must be within range.
    pub fn check_request(&self, exposure_s: f64, gain: f64) -> Result<(), DeviceError> {
        if !self.manual_exposure {
            return Err(DeviceError::AutoExposureOnly(self.name.clone()));
        }
        let [t0, t1] = self.exposure_range_s;
        let [g0, g1] = self.gain_range;
        if !(exposure_s.is_finite() && (t0..=t1).contains(&exposure_s)) {
            return Err(DeviceError::Config(format!(
                "camera {}: exposure {exposure_s} s is outside its range {t0}..{t1} s",
                self.name
            )));
        }
        if !(gain.is_finite() && (g0..=g1).contains(&gain)) {
            return Err(DeviceError::Config(format!(
                "camera {}: gain {gain} is outside its range {g0}..{g1}",
                self.name
            )));
        }
        Ok(())
    }
}

/// One captured frame, row-major, top row first, with the settings it was taken with.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width_px: u32,
    /// Height in pixels.
    pub height_px: u32,
    /// Bits per channel; codes run 0..=2^bit_depth − 1.
    pub bit_depth: u32,
    /// Camera RGB codes per pixel (not linear: the camera's response curve applies).
    pub rgb: Vec<[u16; 3]>,
    /// Exposure time it was taken with (s).
    pub exposure_s: f64,
    /// Analogue gain it was taken with.
    pub gain: f64,
    /// When it was taken, seconds on the camera's (or the simulation's) clock.
    pub timestamp_s: f64,
}

impl Frame {
    /// Largest code value.
    pub fn max_code(&self) -> u16 {
        ((1u32 << self.bit_depth.min(16)) - 1) as u16
    }

    /// Codes of pixel (`x`, `y`), or `None` outside the frame.
    pub fn at(&self, x: u32, y: u32) -> Option<[u16; 3]> {
        if x >= self.width_px || y >= self.height_px {
            return None;
        }
        self.rgb
            .get(y as usize * self.width_px as usize + x as usize)
            .copied()
    }
}

/// A camera the station controls: a real one (V4L2/UVC through `nokhwa`) or the
/// virtual wall's.
pub trait Camera {
    /// Facts and controls.
    fn info(&self) -> CameraInfo;
    /// Takes one frame at `exposure_s` seconds and analogue `gain`; fails with
    /// [`DeviceError::AutoExposureOnly`] on a camera whose exposure cannot be set.
    fn capture(&mut self, exposure_s: f64, gain: f64) -> Result<Frame, DeviceError>;
}

/// A pattern image in display drive values: the input a display shows, row-major,
/// top row first, each channel 0..=1 (code / max code).
#[derive(Debug, Clone, PartialEq)]
pub struct DriveImage {
    /// Width in pixels.
    pub width_px: u32,
    /// Height in pixels.
    pub height_px: u32,
    /// Drive per pixel.
    pub drive: Vec<[f32; 3]>,
}

impl DriveImage {
    /// Largest image the pattern outputs accept, in pixels (an 8K frame).
    pub const MAX_PIXELS: u64 = 7680 * 4320;

    /// An image of `width_px` × `height_px` whose pixel (x, y) is `f(u, v)` at its
    /// centre, `u`, `v` in 0..1; fails on an empty or oversized image or a drive
    /// outside 0..=1.
    pub fn from_fn(
        width_px: u32,
        height_px: u32,
        f: impl Fn(f64, f64) -> [f64; 3],
    ) -> Result<Self, DeviceError> {
        let n = u64::from(width_px) * u64::from(height_px);
        if n == 0 || n > Self::MAX_PIXELS {
            return Err(DeviceError::Config(format!(
                "pattern image {width_px}×{height_px} is empty or larger than {} pixels",
                Self::MAX_PIXELS
            )));
        }
        let mut drive = Vec::with_capacity(n as usize);
        for y in 0..height_px {
            for x in 0..width_px {
                let u = (f64::from(x) + 0.5) / f64::from(width_px);
                let v = (f64::from(y) + 0.5) / f64::from(height_px);
                let d = f(u, v);
                crate::traits::check_drive(d)?;
                drive.push(d.map(|c| c as f32));
            }
        }
        Ok(Self {
            width_px,
            height_px,
            drive,
        })
    }

    /// Drive of the pixel under `uv` (nearest pixel, as a projector shows it).
    pub fn sample(&self, uv: [f64; 2]) -> [f64; 3] {
        let x = ((uv[0] * f64::from(self.width_px)) as i64).clamp(0, i64::from(self.width_px) - 1);
        let y =
            ((uv[1] * f64::from(self.height_px)) as i64).clamp(0, i64::from(self.height_px) - 1);
        self.drive[y as usize * self.width_px as usize + x as usize].map(f64::from)
    }
}
