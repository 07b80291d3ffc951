//! The camera's response curve (Debevec–Malik with Kresse's mask) and HDR
//! captures: exposure series chosen so that every pixel of interest is measured well
//! exposed, merged into relative radiance per second.

use lumiwall_devices::{Camera, DisplayInfo, DriveImage, Frame, PatternOutput};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use super::CameraCalibError;

/// Lowest code (of 255) a pixel may have to count as measured (Kresse: 15).
pub const LOW_CODE_8BIT: u16 = 15;
/// Highest code (of 255) a pixel may have to count as measured (Kresse: 250).
pub const HIGH_CODE_8BIT: u16 = 250;
/// Exposures of the response-curve series, in half stops from the base exposure.
const SERIES_HALF_STOPS: std::ops::RangeInclusive<i32> = -4..=12;
/// Pixels sampled for the Debevec–Malik solve.
const RESPONSE_SAMPLES: usize = 300;
/// Smoothness weight of the Debevec–Malik solve (OpenCV's default is 10; 40 halves the
/// error at 5 % exposure on a noisy camera).
const RESPONSE_LAMBDA: f64 = 40.0;
/// Fraction of the pixels of interest that may stay without a well exposed sample.
const UNCOVERED_FRACTION: f64 = 0.002;

/// A frame's code as a fraction of its largest code, and as the 8-bit code the
/// response curve is indexed by.
fn code8(frame: &Frame, code: u16) -> u8 {
    let shift = frame.bit_depth.saturating_sub(8);
    let rounded = (u32::from(code) + ((1u32 << shift) >> 1)) >> shift;
    rounded.min(255) as u8
}

/// Whether an 8-bit code counts as well exposed.
pub fn well_exposed(code: u8) -> bool {
    (LOW_CODE_8BIT..=HIGH_CODE_8BIT).contains(&u16::from(code))
}

/// The camera's response curve: relative exposure (exposure time × gain × radiance,
/// arbitrary scale) for every 8-bit code, per channel; 12-bit frames are read through
/// it by interpolation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResponseCurve {
    /// `ln` of the relative exposure for codes 0..=255, per channel R, G, B.
    pub ln_exposure: [Vec<f64>; 3],
    /// The exposure series it was recovered from (s).
    pub exposures_s: Vec<f64>,
    /// Pixels used in the solve.
    pub samples: usize,
}

impl ResponseCurve {
    /// Relative exposure for `code` of a frame with `bit_depth` bits, channel `c`
    /// (linear interpolation between the 8-bit codes).
    pub fn relative_exposure(&self, c: usize, code: u16, bit_depth: u32) -> f64 {
        let max = f64::from((1u32 << bit_depth.min(16)) - 1);
        let z = (f64::from(code) / max * 255.0).clamp(0.0, 255.0);
        let i = (z.floor() as usize).min(254);
        let f = z - i as f64;
        let t = &self.ln_exposure[c];
        (t[i] * (1.0 - f) + t[i + 1] * f).exp()
    }

    /// Largest relative deviation of the recovered relative exposure from a true curve
    /// over the codes whose true relative exposure lies in `range` (fractions of
    /// saturation, e.g. 0.05..0.95) and that are measured at all (≤ 250 of 255: higher
    /// codes are never merged), after the free scale of the Debevec–Malik solution is
    /// matched (median of the ratios). `truth(c, code_fraction)` gives the true relative
    /// exposure, 1 at saturation.
    pub fn max_error_against(&self, truth: impl Fn(usize, f64) -> f64, range: [f64; 2]) -> f64 {
        let mut worst: f64 = 0.0;
        for c in 0..3 {
            let mut d: Vec<f64> = (0..=usize::from(HIGH_CODE_8BIT))
                .map(|z| (truth(c, z as f64 / 255.0), self.ln_exposure[c][z]))
                .filter(|(x, _)| (range[0]..=range[1]).contains(x))
                .map(|(x, g)| g - x.ln())
                .collect();
            if d.is_empty() || d.iter().any(|v| !v.is_finite()) {
                return f64::INFINITY;
            }
            d.sort_by(f64::total_cmp);
            let offset = d[d.len() / 2];
            for v in d {
                worst = worst.max(((v - offset).exp() - 1.0).abs());
            }
        }
        worst
    }
}

/// Relative radiance per second (relative exposure / (time × gain)) per pixel, merged
/// from an exposure series; NaN where every sample was saturated.
#[derive(Debug, Clone, PartialEq)]
pub struct HdrImage {
    /// Width (px).
    pub width_px: u32,
    /// Height (px).
    pub height_px: u32,
    /// Row-major camera RGB, linear.
    pub rgb: Vec<[f32; 3]>,
    /// Exposures merged (s).
    pub exposures_s: Vec<f64>,
}

impl HdrImage {
    /// Bilinear value at pixel position `p` (pixel centres at +0.5); `None` outside the
    /// frame or next to a saturated pixel.
    pub fn sample(&self, p: [f64; 2]) -> Option<[f64; 3]> {
        let (w, h) = (self.width_px as usize, self.height_px as usize);
        let x = p[0] - 0.5;
        let y = p[1] - 0.5;
        if !(x >= 0.0 && y >= 0.0 && x <= (w - 1) as f64 && y <= (h - 1) as f64) {
            return None;
        }
        let (x0, y0) = (
            (x as usize).min(w.saturating_sub(2)),
            (y as usize).min(h.saturating_sub(2)),
        );
        let (fx, fy) = (x - x0 as f64, y - y0 as f64);
        let at = |xx: usize, yy: usize| self.rgb[yy * w + xx];
        let mut out = [0.0; 3];
        for (c, o) in out.iter_mut().enumerate() {
            let v = |xx, yy| f64::from(at(xx, yy)[c]);
            *o = (v(x0, y0) * (1.0 - fx) + v(x0 + 1, y0) * fx) * (1.0 - fy)
                + (v(x0, y0 + 1) * (1.0 - fx) + v(x0 + 1, y0 + 1) * fx) * fy;
        }
        out.iter().all(|v| v.is_finite()).then_some(out)
    }
}

/// Merges an exposure series: per pixel and channel the weighted mean (hat weight over
/// the well exposed codes) of relative exposure / (time × gain); where no sample of a
/// channel is well exposed, the longest under-exposed sample, or NaN if all saturate.
pub fn merge(frames: &[Frame], curve: &ResponseCurve) -> HdrImage {
    let (w, h) = frames.first().map_or((0, 0), |f| (f.width_px, f.height_px));
    let n = (w as usize) * (h as usize);
    // Frames of another size (a camera that changed its mode) cannot be merged.
    let frames: Vec<&Frame> = frames.iter().filter(|f| f.rgb.len() == n).collect();
    let mut rgb = vec![[f32::NAN; 3]; n];
    for (i, px) in rgb.iter_mut().enumerate() {
        for (c, out) in px.iter_mut().enumerate() {
            let (mut sum, mut wsum) = (0.0, 0.0);
            let mut under: Option<(f64, f64)> = None;
            for f in &frames {
                let code = f.rgb[i][c];
                let z = code8(f, code);
                let value = curve.relative_exposure(c, code, f.bit_depth) / (f.exposure_s * f.gain);
                if well_exposed(z) {
                    let wt =
                        f64::from((z - LOW_CODE_8BIT as u8 + 1).min(HIGH_CODE_8BIT as u8 + 1 - z));
                    sum += wt * value;
                    wsum += wt;
                } else if u16::from(z) < LOW_CODE_8BIT
                    && under.is_none_or(|(t, _)| f.exposure_s > t)
                {
                    under = Some((f.exposure_s, value));
                }
            }
            *out = if wsum > 0.0 {
                (sum / wsum) as f32
            } else {
                under.map_or(f32::NAN, |(_, v)| v as f32)
            };
        }
    }
    HdrImage {
        width_px: w,
        height_px: h,
        rgb,
        exposures_s: frames.iter().map(|f| f.exposure_s).collect(),
    }
}

/// The brightest channel's 8-bit code at the given quantile over `pixels`.
fn code_quantile(frame: &Frame, pixels: &[usize], q: f64) -> u8 {
    let mut v: Vec<u8> = pixels
        .iter()
        .filter_map(|&i| frame.rgb.get(i))
        .map(|p| p.iter().map(|&c| code8(frame, c)).max().unwrap_or(0))
        .collect();
    if v.is_empty() {
        return 0;
    }
    v.sort_unstable();
    v[((v.len() - 1) as f64 * q).round() as usize]
}

fn capture(cam: &mut dyn Camera, t: f64, what: &str) -> Result<Frame, CameraCalibError> {
    cam.capture(t, 1.0)
        .map_err(CameraCalibError::device(format!(
            "camera capture for {what}"
        )))
}

/// The longest exposure (within the camera's range) at which the brightest of
/// `pixels` stays below the top well exposed code, and its frame.
pub fn base_exposure(
    cam: &mut dyn Camera,
    pixels: &[usize],
    what: &str,
) -> Result<Frame, CameraCalibError> {
    let [t_min, t_max] = cam.info().exposure_range_s;
    let mut t = (t_min * t_max).sqrt();
    for _ in 0..40 {
        let f = capture(cam, t, what)?;
        let top = code_quantile(&f, pixels, 0.9995);
        if u16::from(top) > HIGH_CODE_8BIT {
            if t <= t_min {
                return Err(CameraCalibError::Saturated {
                    what: what.into(),
                    exposure_s: t_min,
                });
            }
            t = (t / 4.0).max(t_min);
        } else if top < 120 && t < t_max {
            // Codes grow at least linearly with exposure in the response's lower half.
            let k = if top < 30 { 8.0 } else { 1.6 };
            t = (t * k).min(t_max);
        } else {
            return Ok(f);
        }
    }
    capture(cam, t, what)
}

/// Captures `pixels` so that each is well exposed in at least one frame: the base
/// exposure (and one half a stop shorter), then ×4 steps while more than 0.2 % of them are still below code 15, up to
/// the camera's longest exposure; merged with `curve`.
pub fn capture_hdr(
    cam: &mut dyn Camera,
    curve: &ResponseCurve,
    pixels: &[usize],
    what: &str,
) -> Result<HdrImage, CameraCalibError> {
    let [t_min, t_max] = cam.info().exposure_range_s;
    let base = base_exposure(cam, pixels, what)?;
    // A second frame half a stop shorter: its codes fall elsewhere on the response
    // curve, which halves the 8-bit quantisation in the merged image.
    let shorter = (base.exposure_s / std::f64::consts::SQRT_2).max(t_min);
    let mut frames = Vec::with_capacity(4);
    if shorter < base.exposure_s {
        frames.push(capture(cam, shorter, what)?);
    }
    frames.push(base);
    let mut covered: Vec<bool> = vec![false; pixels.len()];
    while let Some(last) = frames.last() {
        for (k, &i) in pixels.iter().enumerate() {
            covered[k] |= last
                .rgb
                .get(i)
                .is_some_and(|p| p.iter().any(|&c| well_exposed(code8(last, c))));
        }
        let open = covered.iter().filter(|c| !**c).count();
        if (open as f64) <= UNCOVERED_FRACTION * pixels.len() as f64 || last.exposure_s >= t_max {
            break;
        }
        let t = (last.exposure_s * 4.0).min(t_max);
        frames.push(capture(cam, t, what)?);
    }
    Ok(merge(&frames, curve))
}

/// The calibration scene: 48 vertical bands from black to full drive.
fn ramp_image() -> Result<DriveImage, CameraCalibError> {
    DriveImage::from_fn(480, 270, |u, _| {
        let band = (u * 48.0).floor().min(47.0);
        [band / 47.0; 3]
    })
    .map_err(CameraCalibError::device(
        "building the response-curve pattern",
    ))
}

/// Pixels whose codes in `frame` spread evenly over 2..=252 (brightest channel),
/// `n` of them, deterministic.
fn spread_samples(frame: &Frame, n: usize) -> Vec<usize> {
    let bins = 50usize;
    let per_bin = n.div_ceil(bins);
    let mut chosen: Vec<Vec<usize>> = vec![Vec::new(); bins];
    let stride = (frame.rgb.len() / 40_000).max(1);
    for i in (0..frame.rgb.len()).step_by(stride) {
        let z = frame.rgb[i]
            .iter()
            .map(|&c| code8(frame, c))
            .max()
            .unwrap_or(0);
        if !(2..=252).contains(&z) {
            continue;
        }
        let b = (usize::from(z - 2) * bins / 251).min(bins - 1);
        if chosen[b].len() < per_bin {
            chosen[b].push(i);
        }
    }
    chosen.into_iter().flatten().take(n).collect()
}

/// Recovers the camera's response curve from an exposure series of a ramp shown on
/// `display` (Debevec–Malik with Kresse's mask, [`debevec_channel`]).
pub fn calibrate_response(
    cam: &mut dyn Camera,
    pattern: &mut dyn PatternOutput,
    display: &DisplayInfo,
) -> Result<ResponseCurve, CameraCalibError> {
    let frames = response_series(cam, pattern, display)?;
    response_from_series(&frames, &display.name)
}

/// The exposure series of the response curve: a ramp on `display`, half-stop steps
/// from two stops below to six above the exposure where the brightest pixel is just
/// well exposed.
pub fn response_series(
    cam: &mut dyn Camera,
    pattern: &mut dyn PatternOutput,
    display: &DisplayInfo,
) -> Result<Vec<Frame>, CameraCalibError> {
    let what = format!("the response-curve exposure series on {}", display.name);
    let what = what.as_str();
    pattern
        .show_image(display.id, &ramp_image()?)
        .map_err(CameraCalibError::device(what))?;
    let all: Vec<usize> =
        (0..cam.info().width_px as usize * cam.info().height_px as usize).collect();
    let base = base_exposure(cam, &all, what)?;
    let [t_min, t_max] = cam.info().exposure_range_s;
    let mut frames = Vec::new();
    for k in SERIES_HALF_STOPS {
        let t = (base.exposure_s * 2f64.powf(f64::from(k) / 2.0)).clamp(t_min, t_max);
        if frames.last().is_none_or(|f: &Frame| f.exposure_s < t) {
            frames.push(capture(cam, t, what)?);
        }
    }
    Ok(frames)
}

/// The response curve of an exposure series (`name`: the display it shows, for
/// messages).
pub fn response_from_series(
    frames: &[Frame],
    name: &str,
) -> Result<ResponseCurve, CameraCalibError> {
    if frames.windows(2).any(|f| f[0].rgb.len() != f[1].rgb.len()) {
        return Err(CameraCalibError::Fit(format!(
            "the response-curve exposure series on {name}: the camera changed its frame size \
             between exposures"
        )));
    }
    let samples = frames
        .get(frames.len() / 2)
        .map(|f| spread_samples(f, RESPONSE_SAMPLES))
        .unwrap_or_default();
    if samples.len() < 50 || frames.len() < 4 {
        return Err(CameraCalibError::Fit(format!(
            "the response-curve exposure series on {name}: only {} usable pixels in {} \
             exposures; is the projector on and in the camera's view?",
            samples.len(),
            frames.len()
        )));
    }
    let ln_exposure = debevec(frames, &samples)?;
    Ok(ResponseCurve {
        ln_exposure,
        exposures_s: frames.iter().map(|f| f.exposure_s).collect(),
        samples: samples.len(),
    })
}

/// The Debevec–Malik solve for one channel, with Kresse's mask: only observations
/// with codes 15..=250 enter (hat weight), the curve is smooth (second differences
/// weighted by `lambda`), and `g(128) = 0` fixes the free scale. OpenCV's
/// `CalibrateDebevec` has no mask: the clipped observations of a stack bend the top of
/// its curve (2.7 % at code 250 on the noiseless virtual camera, against 0.1 % here), so the
/// solve is written out; `tests/python` cross-checks it against OpenCV-Python.
pub fn debevec_channel(
    codes: &[Vec<u8>],
    ln_times: &[f64],
    lambda: f64,
) -> Result<Vec<f64>, CameraCalibError> {
    let n = codes.first().map_or(0, Vec::len);
    let unknowns = 256 + n;
    let mut ata = DMatrix::<f64>::zeros(unknowns, unknowns);
    let mut atb = DVector::<f64>::zeros(unknowns);
    let mut add_row = |idx: &[(usize, f64)], rhs: f64| {
        for &(i, a) in idx {
            atb[i] += a * rhs;
            for &(j, b) in idx {
                ata[(i, j)] += a * b;
            }
        }
    };
    let weight = |z: u8| -> f64 {
        let z = f64::from(z);
        let (lo, hi) = (f64::from(LOW_CODE_8BIT), f64::from(HIGH_CODE_8BIT));
        if z < lo || z > hi {
            0.0
        } else {
            (z - lo + 1.0).min(hi - z + 1.0)
        }
    };
    let mut used = 0usize;
    for (frame, &lt) in codes.iter().zip(ln_times) {
        for (i, &z) in frame.iter().enumerate() {
            let w = weight(z);
            if w > 0.0 {
                add_row(&[(usize::from(z), w), (256 + i, -w)], w * lt);
                used += 1;
            }
        }
    }
    add_row(&[(128, 1.0)], 0.0);
    // A vanishing prior keeps pixels without a well exposed observation solvable.
    for i in 0..n {
        add_row(&[(256 + i, 1e-6)], 0.0);
    }
    for z in 1..255u8 {
        let w = lambda * weight(z).max(1.0);
        let z = usize::from(z);
        add_row(&[(z - 1, w), (z, -2.0 * w), (z + 1, w)], 0.0);
    }
    if used < 4 * 256 {
        return Err(CameraCalibError::Fit(format!(
            "response curve: only {used} well exposed observations (codes 15..250); \
             the exposure series did not cover the codes"
        )));
    }
    let x = ata
        .cholesky()
        .map(|c| c.solve(&atb))
        .ok_or_else(|| CameraCalibError::Fit("response curve: the solve is singular".into()))?;
    Ok((0..256).map(|z| x[z]).collect())
}

/// Debevec–Malik per channel on the sampled pixels.
fn debevec(frames: &[Frame], samples: &[usize]) -> Result<[Vec<f64>; 3], CameraCalibError> {
    let ln_times: Vec<f64> = frames
        .iter()
        .map(|f| (f.exposure_s * f.gain).ln())
        .collect();
    let mut out: [Vec<f64>; 3] = Default::default();
    for (c, o) in out.iter_mut().enumerate() {
        let codes: Vec<Vec<u8>> = frames
            .iter()
            .map(|f| samples.iter().map(|&i| code8(f, f.rgb[i][c])).collect())
            .collect();
        *o = debevec_channel(&codes, &ln_times, RESPONSE_LAMBDA)?;
    }
    Ok(out)
}
