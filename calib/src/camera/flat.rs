//! Flat-field textures by a closed camera loop (Kresse 3.4.3, with a model-based
//! update instead of his bisection).
//!
//! Per display: a dark frame, each channel at full drive (camera) with meter readings
//! at the centre and four off-centre spots (white) for the anchor; the open-loop gain
//! of channel c at each texel is its camera luminance over the spot's, corrected for
//! the camera's vignetting. Then the loop: show channel c at a level L through the
//! candidate texture (drive = inverse tone curve of L / gain), photograph, and multiply
//! the gain by the measured ratio texel / spot, until the RMS residual is below the
//! threshold.

use std::time::Instant;

use lumiwall_devices::{Camera, DisplayInfo, DriveImage, PatternOutput};
use lumiwall_profiles::apply::PreparedFlat;
use lumiwall_profiles::{DisplayProfile, FlatField};
use serde::{Deserialize, Serialize};

use super::CameraCalibError;
use super::anchor::{CameraPhotometry, SpotPair};
use super::checkpoint::{Checkpoint, SavedCalibration};
use super::hdr::{HdrImage, ResponseCurve, calibrate_response, capture_hdr};
use super::registration::{DotGrid, Registration, check_still, register_displays};
use crate::measure::Rig;

/// Spots the meter reads besides the centre (each channel and white), for the anchor's
/// vignetting.
const ANCHOR_SPOTS: [[f64; 2]; 4] = [[0.2, 0.2], [0.8, 0.2], [0.2, 0.8], [0.8, 0.8]];
/// Further spots for walls where [`ANCHOR_SPOTS`] lie at too few distances from the
/// image centre to separate the camera's vignetting (one display, centred): near the
/// corners, so that the fit reaches the image's edge instead of extrapolating to it,
/// and at the middle of each edge.
const EDGE_SPOTS: [[f64; 2]; 8] = [
    [0.08, 0.08],
    [0.92, 0.08],
    [0.08, 0.92],
    [0.92, 0.92],
    [0.5, 0.1],
    [0.1, 0.5],
    [0.9, 0.5],
    [0.5, 0.9],
];
/// Readings averaged per meter spot.
const READINGS_PER_SPOT: u32 = 2;

/// What the flat-field measurement is asked to do.
#[derive(Debug, Clone, PartialEq)]
pub struct FlatFieldOptions {
    /// Texture size (texels across, down); Kresse: 64×32.
    pub texture: [u32; 2],
    /// Stop when the RMS residual |measured/expected − 1| over the texels is below this.
    pub threshold: f64,
    /// Most closed-loop iterations per display and channel.
    pub max_iterations: u32,
    /// Registration dots per display.
    pub grid: DotGrid,
    /// Largest camera movement tolerated between registration and the end (px).
    pub move_limit_px: f64,
    /// Spot of the meter (the profile's calibration spot).
    pub spot_uv: [f64; 2],
    /// Where finished steps are kept (`None`: nowhere).
    pub checkpoint: Option<Checkpoint>,
    /// Continue from the checkpoint of a stopped run (if the camera has not moved);
    /// without it the checkpoint is cleared first.
    pub resume: bool,
}

impl Default for FlatFieldOptions {
    fn default() -> Self {
        Self {
            texture: [64, 32],
            threshold: 0.002,
            max_iterations: 3,
            grid: DotGrid::default(),
            move_limit_px: 1.0,
            spot_uv: [0.5, 0.5],
            checkpoint: None,
            resume: false,
        }
    }
}

/// One display's flat field and how it was reached.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DisplayFlat {
    /// Display index.
    pub display: u32,
    /// Display name.
    pub name: String,
    /// The texture.
    pub flat: FlatField,
    /// Closed-loop iterations per channel R, G, B (the open-loop capture not counted).
    pub iterations: [u32; 3],
    /// RMS residual per channel before the loop (uniform drive, no texture).
    pub residual_open: [f64; 3],
    /// RMS residual per channel after the last iteration.
    pub residual_final: [f64; 3],
    /// RMS residual per channel at every closed-loop iteration, in order: the
    /// loop's error against its captures.
    #[serde(default)]
    pub residual_history: [Vec<f64>; 3],
    /// Smallest gain per channel (the darkest texel against the spot).
    pub min_gain: [f64; 3],
    /// Camera captures (frames) this display cost.
    pub frames: u32,
}

/// Everything the camera stage produced.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FlatFieldOutcome {
    /// The camera's response curve.
    pub response: ResponseCurve,
    /// Where the displays are in the camera image.
    pub registration: Registration,
    /// Camera → XYZ, anchored to the meter.
    pub photometry: CameraPhotometry,
    /// Per display.
    pub displays: Vec<DisplayFlat>,
    /// Wall-clock seconds the whole stage took.
    pub seconds: f64,
    /// Camera movement found at the end (px).
    pub movement_px: f64,
}

/// A camera that counts its frames.
pub(super) struct Counting<'c> {
    pub(super) cam: &'c mut dyn Camera,
    pub(super) frames: u32,
}

impl Camera for Counting<'_> {
    fn info(&self) -> lumiwall_devices::CameraInfo {
        self.cam.info()
    }
    fn capture(
        &mut self,
        t: f64,
        g: f64,
    ) -> Result<lumiwall_devices::Frame, lumiwall_devices::DeviceError> {
        self.frames += 1;
        self.cam.capture(t, g)
    }
}

/// What an 8-bit camera costs, said before the camera stage starts.
pub const EIGHT_BIT_NOTE: &str = "camera: 8-bit frames (JPEG or a UVC webcam) leave the flat \
    field 0.1-0.4 % uneven between captures, up to ΔE2000 2-3 across seams on a large \
    Infitec wall; a camera with 12-bit raw output reaches 0.03 %";

/// The camera stage for every display: response curve, registration, anchor, flat
/// fields; `profiles` (matched by display index and eye) give the tone curves the loop
/// drives through. `progress` gets one line per step.
pub fn measure_flat_fields(
    cam: &mut dyn Camera,
    rig: &mut Rig<'_>,
    displays: &[DisplayInfo],
    profiles: &[DisplayProfile],
    opts: &FlatFieldOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<FlatFieldOutcome, CameraCalibError> {
    let start = Instant::now();
    let first = displays
        .get(displays.len() / 2)
        .ok_or_else(|| CameraCalibError::Fit("the wall has no displays".into()))?;
    if cam.info().bit_depth <= 8 {
        progress(EIGHT_BIT_NOTE);
    }
    let (calib, open) = match resumable(cam, rig.pattern, first, profiles, opts, progress)? {
        Some(saved) => (saved, None),
        None => {
            let (calib, open) = calibrate(cam, rig, first, displays, profiles, opts, progress)?;
            if let Some(cp) = &opts.checkpoint {
                cp.save_calibration(&calib)?;
            }
            (calib, Some(open))
        }
    };
    let ctx = Context {
        response: &calib.response,
        registration: &calib.registration,
        opts,
    };
    let out = ctx.close_all(cam, rig.pattern, &calib, displays, profiles, open, progress)?;
    let movement_px = check_still(
        &calib.registration,
        cam,
        rig.pattern,
        &calib.response,
        first,
        opts.move_limit_px,
    )?;
    Ok(FlatFieldOutcome {
        response: calib.response,
        registration: calib.registration,
        photometry: calib.photometry,
        displays: out,
        seconds: start.elapsed().as_secs_f64(),
        movement_px,
    })
}

/// The saved calibration of a stopped run when `opts` asks to resume, the checkpoint
/// has one and the camera has not moved since (checked on `first`); otherwise `None`,
/// with the checkpoint cleared.
fn resumable(
    cam: &mut dyn Camera,
    pattern: &mut dyn PatternOutput,
    first: &DisplayInfo,
    profiles: &[DisplayProfile],
    opts: &FlatFieldOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<Option<SavedCalibration>, CameraCalibError> {
    let Some(cp) = &opts.checkpoint else {
        return Ok(None);
    };
    let saved = if opts.resume { cp.calibration() } else { None };
    let Some(saved) = saved else {
        cp.clear()?;
        return Ok(None);
    };
    if saved.profiles != profiles_fingerprint(profiles) {
        progress(
            "camera: the stopped run's checkpoint belongs to other profiles; starting the camera stage again",
        );
        cp.clear()?;
        return Ok(None);
    }
    match check_still(
        &saved.registration,
        cam,
        pattern,
        &saved.response,
        first,
        opts.move_limit_px,
    ) {
        Ok(px) => {
            progress(&format!(
                "camera: resuming from {}: calibration of the stopped run kept (camera within {px:.2} px)",
                cp.dir().display()
            ));
            Ok(Some(saved))
        }
        Err(CameraCalibError::Moved { shift_px, .. }) => {
            progress(&format!(
                "camera: moved {shift_px:.2} px since the stopped run; starting the camera stage again"
            ));
            cp.clear()?;
            Ok(None)
        }
        Err(CameraCalibError::Device { what, source }) => {
            Err(CameraCalibError::Device { what, source })
        }
        Err(e) => {
            progress(&format!(
                "camera: the stopped run's registration no longer fits ({e}); starting the camera stage again"
            ));
            cp.clear()?;
            Ok(None)
        }
    }
}

/// What the camera stage's loop depends on in the profiles (display, eye, channel
/// usage, white), as a short text: a checkpoint made for other profiles is not reused.
fn profiles_fingerprint(profiles: &[DisplayProfile]) -> String {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for p in profiles {
        p.display.hash(&mut h);
        for v in p.channel_usage.iter().chain(&p.target_white_xyz_cd_m2) {
            v.to_bits().hash(&mut h);
        }
    }
    format!("{:016x}", h.finish())
}

/// Response curve, registration, every display's open loop with the meter, the
/// anchor's fit and the loop level: everything the loops of all displays share.
/// `first` is the display the response curve is measured on.
fn calibrate(
    cam: &mut dyn Camera,
    rig: &mut Rig<'_>,
    first: &DisplayInfo,
    displays: &[DisplayInfo],
    profiles: &[DisplayProfile],
    opts: &FlatFieldOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<(SavedCalibration, Vec<Opened>), CameraCalibError> {
    progress("camera: response curve from an exposure series");
    let response = calibrate_response(cam, rig.pattern, first)?;
    progress("camera: registering every display (dot grids)");
    let registration = register_displays(cam, rig.pattern, &response, displays, opts.grid)?;
    progress(&format!(
        "camera: registration reprojection error rms {:.3} px, max {:.3} px",
        registration.rms_px, registration.max_px
    ));
    let ctx = Context {
        response: &response,
        registration: &registration,
        opts,
    };
    let (open, pairs) = ctx.open_all(cam, rig, displays, progress)?;
    let photometry = CameraPhotometry::fit(&pairs)?;
    let (dy, dxy) = photometry.worst();
    let (ay, axy) = photometry.worst_all();
    progress(&format!(
        "camera: colour matrix fitted; camera vs meter at the white spots: worst ΔY {dy:.2} % \
         Δxy {dxy:.4} (single primaries included: ΔY {ay:.2} % Δxy {axy:.4})"
    ));
    let starts = displays
        .iter()
        .zip(&open)
        .map(|(info, (captured, _))| ctx.start(&photometry, info, captured))
        .collect::<Result<Vec<_>, _>>()?;
    let scale = white_scale(displays, profiles, &starts)?;
    let calib = SavedCalibration {
        response,
        registration,
        photometry,
        scale,
        profiles: profiles_fingerprint(profiles),
    };
    Ok((calib, open))
}

impl Context<'_> {
    /// The open loop of every display, with the meter pairs for the anchor.
    fn open_all(
        &self,
        cam: &mut dyn Camera,
        rig: &mut Rig<'_>,
        displays: &[DisplayInfo],
        progress: &mut dyn FnMut(&str),
    ) -> Result<(Vec<Opened>, Vec<SpotPair>), CameraCalibError> {
        let mut open = Vec::with_capacity(displays.len());
        let mut pairs = Vec::new();
        for info in displays {
            let mut counting = Counting {
                cam: &mut *cam,
                frames: 0,
            };
            let captured = self.open_loop(&mut counting, rig, info, &mut pairs)?;
            open.push((captured, counting.frames));
            progress(&format!(
                "camera: {} captured and read at {} spots",
                info.name,
                self.meter_spots(info).len()
            ));
        }
        Ok((open, pairs))
    }

    /// The closed loop of every display: from `open` (this run's open loops) or, on a
    /// resumed run, from the checkpoint where a display is done and from a new
    /// camera-only open loop where it is not. Each display is saved as it ends.
    #[expect(
        clippy::too_many_arguments,
        reason = "the stage's devices and its inputs"
    )]
    fn close_all(
        &self,
        cam: &mut dyn Camera,
        pattern: &mut dyn PatternOutput,
        calib: &SavedCalibration,
        displays: &[DisplayInfo],
        profiles: &[DisplayProfile],
        open: Option<Vec<Opened>>,
        progress: &mut dyn FnMut(&str),
    ) -> Result<Vec<DisplayFlat>, CameraCalibError> {
        let mut open = open.map(|v| v.into_iter());
        let mut out = Vec::with_capacity(displays.len());
        for info in displays {
            let opened = open.as_mut().and_then(Iterator::next);
            let saved = self
                .opts
                .checkpoint
                .as_ref()
                .and_then(|cp| cp.display(info.id.0, info.eye));
            if let Some(flat) = saved.filter(|_| opened.is_none()) {
                progress(&format!(
                    "camera: {} flat field from the stopped run",
                    info.name
                ));
                out.push(flat);
                continue;
            }
            let flat = self.close_one(cam, pattern, calib, info, profiles, opened)?;
            progress(&format!(
                "camera: {} flat field: iterations R/G/B {:?}, RMS residual {:.2} % → {:.2} %, {} frames",
                info.name,
                flat.iterations,
                100.0 * flat.residual_open.iter().copied().fold(0.0, f64::max),
                100.0 * flat.residual_final.iter().copied().fold(0.0, f64::max),
                flat.frames
            ));
            if let Some(cp) = &self.opts.checkpoint {
                cp.save_display(info.eye, &flat)?;
            }
            out.push(flat);
        }
        Ok(out)
    }

    /// One display's closed loop, from its open loop (captured now if not given).
    fn close_one(
        &self,
        cam: &mut dyn Camera,
        pattern: &mut dyn PatternOutput,
        calib: &SavedCalibration,
        info: &DisplayInfo,
        profiles: &[DisplayProfile],
        opened: Option<Opened>,
    ) -> Result<DisplayFlat, CameraCalibError> {
        let profile = profile_of(profiles, info)?;
        let mut counting = Counting {
            cam: &mut *cam,
            frames: opened.as_ref().map_or(0, |o| o.1),
        };
        let captured = match opened {
            Some((captured, _)) => captured,
            None => self.open_camera(&mut counting, pattern, info)?,
        };
        let mut start = self.start(&calib.photometry, info, &captured)?;
        start.level = profile
            .channel_usage
            .map(|u| (u * calib.scale).clamp(0.01, 1.0));
        let flat = self.close_loop(
            &mut counting,
            pattern,
            &calib.photometry,
            info,
            profile,
            captured,
            start,
        )?;
        Ok(DisplayFlat {
            frames: counting.frames,
            ..flat
        })
    }
}

pub(super) fn profile_of<'p>(
    profiles: &'p [DisplayProfile],
    info: &DisplayInfo,
) -> Result<&'p DisplayProfile, CameraCalibError> {
    profiles
        .iter()
        .find(|p| p.display.display == info.id.0 && p.display.eye == info.eye)
        .ok_or_else(|| CameraCalibError::Fit(format!("no profile for {}", info.name)))
}

/// Where one display's loop starts: the open-loop gains, the camera channel that sees
/// each display channel best, and the level to run at.
struct Start {
    gains: [Vec<f64>; 3],
    cam_channels: [usize; 3],
    level: [f64; 3],
}

/// The strict white's expected scale: the smallest `headroom · gain / usage` over every
/// display, channel and texel (the open-loop gains).
fn white_scale(
    displays: &[DisplayInfo],
    profiles: &[DisplayProfile],
    starts: &[Start],
) -> Result<f64, CameraCalibError> {
    let mut scale: f64 = 1.0;
    for (info, start) in displays.iter().zip(starts) {
        let p = profile_of(profiles, info)?;
        for c in 0..3 {
            let min_g = start.gains[c].iter().copied().fold(f64::INFINITY, f64::min);
            scale = scale.min(p.headroom * min_g / p.channel_usage[c].max(1e-9));
        }
    }
    Ok(scale.clamp(0.05, 1.0))
}

/// One display's open-loop captures and the frames they cost.
type Opened = (OpenLoop, u32);

/// The open-loop captures of one display.
struct OpenLoop {
    dark: HdrImage,
    channels: [HdrImage; 3],
}

pub(super) struct Context<'a> {
    pub(super) response: &'a ResponseCurve,
    pub(super) registration: &'a Registration,
    pub(super) opts: &'a FlatFieldOptions,
}

impl Context<'_> {
    fn rho(&self, p: [f64; 2]) -> f64 {
        let r = self.registration;
        ((p[0] - r.centre_px[0]).powi(2) + (p[1] - r.centre_px[1]).powi(2)).sqrt() / r.norm_px
    }

    /// Where the meter reads `info`: its centre and [`ANCHOR_SPOTS`], plus
    /// [`EDGE_SPOTS`] when those lie at fewer than three distances from the image
    /// centre (the vignetting's two terms need three, since each display and pattern
    /// has its own free factor).
    fn meter_spots(&self, info: &DisplayInfo) -> Vec<[f64; 2]> {
        let mut spots: Vec<[f64; 2]> = std::iter::once(self.opts.spot_uv)
            .chain(ANCHOR_SPOTS)
            .collect();
        let radii: Vec<f64> = spots
            .iter()
            .filter_map(|&uv| self.registration.to_camera(info.id, uv))
            .map(|p| self.rho(p).powi(2))
            .collect();
        // ρ², as the anchor's fit counts them (`vignetting_terms`).
        if crate::camera::anchor::distinct_levels(&radii) < 3 {
            spots.extend(EDGE_SPOTS);
        }
        spots
    }

    /// Mean HDR signal over a few pixels around `uv` of `info` (dark not removed).
    fn signal_at(
        &self,
        img: &HdrImage,
        info: &DisplayInfo,
        uv: [f64; 2],
    ) -> Option<([f64; 3], f64)> {
        // 4×4 samples over the texel's footprint, kept off the display's edges.
        let margin = self.edge_margin(info);
        let half = self.opts.texture.map(|n| 0.5 / f64::from(n.max(1)));
        let mut acc = [0.0; 3];
        let mut n = 0.0;
        for k in 0..16 {
            let (a, b) = (f64::from(k % 4) - 1.5, f64::from(k / 4) - 1.5);
            let q = [
                (uv[0] + a / 1.5 * half[0] * 0.75).clamp(margin[0], 1.0 - margin[0]),
                (uv[1] + b / 1.5 * half[1] * 0.75).clamp(margin[1], 1.0 - margin[1]),
            ];
            let p = self.registration.to_camera(info.id, q)?;
            let s = img.sample(p)?;
            for c in 0..3 {
                acc[c] += s[c];
            }
            n += 1.0;
        }
        let p = self.registration.to_camera(info.id, uv)?;
        Some((acc.map(|v| v / n), self.rho(p)))
    }

    pub(super) fn capture(
        &self,
        cam: &mut dyn Camera,
        pattern: &mut dyn PatternOutput,
        info: &DisplayInfo,
        show: Shown<'_>,
        what: &str,
    ) -> Result<HdrImage, CameraCalibError> {
        let what = format!("{what} of {}", info.name);
        match show {
            Shown::Uniform(d) => pattern.show(info.id, d),
            Shown::Image(img) => pattern.show_image(info.id, img),
        }
        .map_err(CameraCalibError::device(what.clone()))?;
        let ci = cam.info();
        let pixels = self
            .registration
            .pixels_of(info.id, ci.width_px, ci.height_px);
        capture_hdr(cam, self.response, &pixels, &what)
    }

    /// Dark frame and each channel at full drive, without the meter (what a resumed
    /// run needs; [`Self::open_loop`] adds the meter).
    fn open_camera(
        &self,
        cam: &mut dyn Camera,
        pattern: &mut dyn PatternOutput,
        info: &DisplayInfo,
    ) -> Result<OpenLoop, CameraCalibError> {
        let shot = |cam: &mut dyn Camera, pattern: &mut dyn PatternOutput, d: [f64; 3]| {
            self.capture(cam, pattern, info, Shown::Uniform(d), "open-loop capture")
        };
        Ok(OpenLoop {
            dark: self.capture(cam, pattern, info, Shown::Uniform([0.0; 3]), "dark frame")?,
            channels: [
                shot(cam, pattern, [1.0, 0.0, 0.0])?,
                shot(cam, pattern, [0.0, 1.0, 0.0])?,
                shot(cam, pattern, [0.0, 0.0, 1.0])?,
            ],
        })
    }

    /// The camera's open loop ([`Self::open_camera`]) plus white, and the meter at the
    /// anchor spots showing black, each channel and white.
    fn open_loop(
        &self,
        cam: &mut dyn Camera,
        rig: &mut Rig<'_>,
        info: &DisplayInfo,
        pairs: &mut Vec<SpotPair>,
    ) -> Result<OpenLoop, CameraCalibError> {
        let open = self.open_camera(cam, rig.pattern, info)?;
        let white = self.capture(
            cam,
            rig.pattern,
            info,
            Shown::Uniform([1.0; 3]),
            "open-loop capture",
        )?;
        let spots = self.meter_spots(info);
        let blacks = spots
            .iter()
            .map(|&uv| read_meter(rig, info, uv, [0.0; 3]))
            .collect::<Result<Vec<_>, _>>()?;
        let shots = [
            ([1.0, 0.0, 0.0], &open.channels[0]),
            ([0.0, 1.0, 0.0], &open.channels[1]),
            ([0.0, 0.0, 1.0], &open.channels[2]),
            ([1.0; 3], &white),
        ];
        for (drive, img) in shots {
            for (&uv, &black) in spots.iter().zip(&blacks) {
                self.pair(rig, info, img, &open.dark, drive, uv, black, pairs)?;
            }
        }
        Ok(open)
    }

    /// Reads the meter at `uv` showing `drive` and pairs it with the camera there.
    #[expect(
        clippy::too_many_arguments,
        reason = "one reading pairs the display, both images, the pattern and the spot"
    )]
    fn pair(
        &self,
        rig: &mut Rig<'_>,
        info: &DisplayInfo,
        img: &HdrImage,
        dark: &HdrImage,
        drive: [f64; 3],
        uv: [f64; 2],
        black: [f64; 3],
        pairs: &mut Vec<SpotPair>,
    ) -> Result<(), CameraCalibError> {
        let xyz = read_meter(rig, info, uv, drive)?;
        let (Some((s, rho)), Some((d, _))) = (
            self.signal_at(img, info, uv),
            self.signal_at(dark, info, uv),
        ) else {
            return Err(CameraCalibError::NoLight {
                display: info.name.clone(),
                signal: 0.0,
            });
        };
        let rgb: [f64; 3] = std::array::from_fn(|c| s[c] - d[c]);
        if rgb.iter().all(|v| *v <= 0.0) {
            return Err(CameraCalibError::NoLight {
                display: info.name.clone(),
                signal: 0.0,
            });
        }
        pairs.push(SpotPair {
            display: info.id.0,
            eye: info.eye,
            uv,
            camera_rgb: rgb,
            meter_xyz: std::array::from_fn(|k| xyz[k] - black[k]),
            radius: rho,
            drive,
        });
        Ok(())
    }

    /// Relative output texture of one display channel: the camera channel that sees it
    /// best (`cam_c`; one display channel has one spectrum, so any camera channel is
    /// proportional to its luminance), dark removed and vignetting corrected, per
    /// texel over the spot's; smoothed over 3×3 texels against the camera's
    /// quantisation.
    fn ratios(
        &self,
        phot: &CameraPhotometry,
        info: &DisplayInfo,
        img: &HdrImage,
        dark: &HdrImage,
        cam_c: usize,
    ) -> Result<Vec<f64>, CameraCalibError> {
        let lum = |uv: [f64; 2]| -> Option<f64> {
            let (s, rho) = self.signal_at(img, info, uv)?;
            let (d, _) = self.signal_at(dark, info, uv)?;
            Some((s[cam_c] - d[cam_c]) * phot.vignetting_factor(rho))
        };
        let spot = lum(self.opts.spot_uv).filter(|v| *v > 0.0).ok_or_else(|| {
            CameraCalibError::NoLight {
                display: info.name.clone(),
                signal: 0.0,
            }
        })?;
        let [w, h] = self.opts.texture;
        let margin = self.edge_margin(info);
        let mut out = Vec::with_capacity((w * h) as usize);
        for j in 0..h {
            for i in 0..w {
                let uv = [
                    ((f64::from(i) + 0.5) / f64::from(w)).clamp(margin[0], 1.0 - margin[0]),
                    ((f64::from(j) + 0.5) / f64::from(h)).clamp(margin[1], 1.0 - margin[1]),
                ];
                let v = lum(uv).ok_or_else(|| CameraCalibError::NoLight {
                    display: info.name.clone(),
                    signal: 0.0,
                })?;
                out.push(v / spot);
            }
        }
        Ok(smooth3(&out, w as usize, h as usize))
    }

    /// Display coordinates 2.5 camera pixels from each edge: closer, the camera's
    /// interpolation would mix in the neighbouring tile.
    fn edge_margin(&self, info: &DisplayInfo) -> [f64; 2] {
        let r = self.registration;
        let len = |a: [f64; 2], b: [f64; 2]| -> f64 {
            match (r.to_camera(info.id, a), r.to_camera(info.id, b)) {
                (Some(p), Some(q)) => ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt(),
                _ => 1.0,
            }
        };
        let w = len([0.0, 0.5], [1.0, 0.5]).max(1.0);
        let h = len([0.5, 0.0], [0.5, 1.0]).max(1.0);
        [(2.5 / w).min(0.2), (2.5 / h).min(0.2)]
    }

    /// The closed loop for every channel of one display.
    #[expect(
        clippy::too_many_arguments,
        reason = "the loop's devices, the anchor, the display, its profile and its start"
    )]
    fn close_loop(
        &self,
        cam: &mut dyn Camera,
        pattern: &mut dyn PatternOutput,
        phot: &CameraPhotometry,
        info: &DisplayInfo,
        profile: &DisplayProfile,
        open: OpenLoop,
        start: Start,
    ) -> Result<DisplayFlat, CameraCalibError> {
        let [w, h] = self.opts.texture;
        let Start {
            gains: initial,
            cam_channels,
            level,
        } = start;
        let mut gains: [Vec<f64>; 3] = Default::default();
        let mut iterations = [0; 3];
        let mut residual_open = [0.0; 3];
        let mut residual_final = [0.0; 3];
        let mut residual_history: [Vec<f64>; 3] = Default::default();
        let run = ChannelRun {
            phot,
            info,
            profile,
            dark: &open.dark,
        };
        for (c, g) in initial.into_iter().enumerate() {
            residual_open[c] = rms_residual(&g);
            let done = self.loop_channel(
                cam,
                pattern,
                &run,
                c,
                g,
                Some(cam_channels[c]),
                level[c],
                None,
            )?;
            iterations[c] = done.iterations;
            residual_final[c] = done.history.last().copied().unwrap_or(residual_open[c]);
            residual_history[c] = done.history;
            gains[c] = done.gains;
        }
        let texels = (0..(w * h) as usize)
            .map(|k| std::array::from_fn(|c| (gains[c][k] as f32).clamp(1e-3, FlatField::MAX_GAIN)))
            .collect();
        let flat = FlatField {
            width: w,
            height: h,
            gain: texels,
        };
        let min_gain =
            std::array::from_fn(|c| gains[c].iter().copied().fold(f64::INFINITY, f64::min));
        Ok(DisplayFlat {
            display: info.id.0,
            name: info.name.clone(),
            flat,
            iterations,
            residual_open,
            residual_final,
            residual_history,
            min_gain,
            frames: 0,
        })
    }
}

/// What one channel's loop runs on besides its gains: the anchor, the display, its
/// profile and its dark frame.
pub(super) struct ChannelRun<'r> {
    pub(super) phot: &'r CameraPhotometry,
    pub(super) info: &'r DisplayInfo,
    pub(super) profile: &'r DisplayProfile,
    pub(super) dark: &'r HdrImage,
}

/// The end of one channel's loop.
pub(super) struct ChannelLoop {
    /// The gains (unchanged when the first capture was within `keep_below`).
    pub(super) gains: Vec<f64>,
    /// Captures made.
    pub(super) iterations: u32,
    /// RMS residual of every capture, in order.
    pub(super) history: Vec<f64>,
}

impl Context<'_> {
    /// The closed loop of channel `c` from `gains`: show the channel through them,
    /// photograph, multiply by the measured ratio, until the residual is below the
    /// threshold or the iterations are spent. With `keep_below`, a first capture whose
    /// residual is below it ends the loop with the gains as they were (the nightly
    /// check). `cam_c`: the camera channel to read (`None`: the one with the most
    /// signal in the first capture).
    #[expect(
        clippy::too_many_arguments,
        reason = "the loop's devices, its display and one channel's state"
    )]
    pub(super) fn loop_channel(
        &self,
        cam: &mut dyn Camera,
        pattern: &mut dyn PatternOutput,
        run: &ChannelRun<'_>,
        c: usize,
        mut g: Vec<f64>,
        mut cam_c: Option<usize>,
        level: f64,
        keep_below: Option<f64>,
    ) -> Result<ChannelLoop, CameraCalibError> {
        let size = self.opts.texture;
        let margin = self.edge_margin(run.info);
        let mut history = Vec::new();
        let dither = cam.info().bit_depth <= 8;
        // the nightly check captures at least once
        let most = self
            .opts
            .max_iterations
            .max(u32::from(keep_below.is_some()));
        for _ in 0..most {
            let img = loop_pattern(run.profile, c, &g, size, level, dither)?;
            let shot = self.capture(
                cam,
                pattern,
                run.info,
                Shown::Image(&img),
                "flat-field loop",
            )?;
            let cc = *cam_c.get_or_insert_with(|| self.dominant_channel(run.info, &shot, run.dark));
            let r = self.ratios(run.phot, run.info, &shot, run.dark, cc)?;
            let residual = rms_residual(&r);
            history.push(residual);
            if history.len() == 1 && keep_below.is_some_and(|k| residual < k) {
                break;
            }
            for (gk, rk) in g.iter_mut().zip(&r) {
                *gk *= rk;
            }
            extrapolate_edges(&mut g, size, margin);
            normalise_at(&mut g, size, self.opts.spot_uv);
            if residual < self.opts.threshold {
                break;
            }
        }
        Ok(ChannelLoop {
            gains: g,
            iterations: history.len() as u32,
            history,
        })
    }
}

impl Context<'_> {
    /// The open-loop gains of one display (edges extrapolated, 1 at the spot).
    fn start(
        &self,
        phot: &CameraPhotometry,
        info: &DisplayInfo,
        open: &OpenLoop,
    ) -> Result<Start, CameraCalibError> {
        let [w, h] = self.opts.texture;
        let margin = self.edge_margin(info);
        let mut gains: [Vec<f64>; 3] = Default::default();
        let mut cam_channels = [1; 3];
        for c in 0..3 {
            cam_channels[c] = self.dominant_channel(info, &open.channels[c], &open.dark);
            let mut g = self.ratios(phot, info, &open.channels[c], &open.dark, cam_channels[c])?;
            extrapolate_edges(&mut g, [w, h], margin);
            normalise_at(&mut g, [w, h], self.opts.spot_uv);
            gains[c] = g;
        }
        Ok(Start {
            gains,
            cam_channels,
            level: [1.0; 3],
        })
    }

    /// The camera channel with the most signal at the spot.
    fn dominant_channel(&self, info: &DisplayInfo, img: &HdrImage, dark: &HdrImage) -> usize {
        let s = self
            .signal_at(img, info, self.opts.spot_uv)
            .map(|v| v.0)
            .unwrap_or([0.0; 3]);
        let d = self
            .signal_at(dark, info, self.opts.spot_uv)
            .map(|v| v.0)
            .unwrap_or([0.0; 3]);
        (0..3)
            .max_by(|&a, &b| (s[a] - d[a]).total_cmp(&(s[b] - d[b])))
            .unwrap_or(1)
    }
}

/// Texels whose centres lie closer to the edge than `margin` (the camera cannot read
/// them without the neighbouring tile) get the linear extrapolation of the two nearest
/// readable texels, along columns, then along rows.
fn extrapolate_edges(g: &mut [f64], size: [u32; 2], margin: [f64; 2]) {
    let (w, h) = (size[0] as usize, size[1] as usize);
    let safe = |i: usize, n: usize, m: f64| {
        let c = (i as f64 + 0.5) / n as f64;
        c >= m && c <= 1.0 - m
    };
    let first = |n: usize, m: f64| (0..n).find(|&i| safe(i, n, m));
    let last = |n: usize, m: f64| (0..n).rev().find(|&i| safe(i, n, m));
    if let (Some(a), Some(b)) = (first(w, margin[0]), last(w, margin[0]))
        && b > a
    {
        for j in 0..h {
            let row = &mut g[j * w..(j + 1) * w];
            let (s0, s1) = (row[a + 1] - row[a], row[b] - row[b - 1]);
            for i in 0..a {
                row[i] = row[a] - s0 * (a - i) as f64;
            }
            for i in b + 1..w {
                row[i] = row[b] + s1 * (i - b) as f64;
            }
        }
    }
    if let (Some(a), Some(b)) = (first(h, margin[1]), last(h, margin[1]))
        && b > a
    {
        for i in 0..w {
            let (s0, s1) = (
                g[(a + 1) * w + i] - g[a * w + i],
                g[b * w + i] - g[(b - 1) * w + i],
            );
            for j in 0..a {
                g[j * w + i] = g[a * w + i] - s0 * (a - j) as f64;
            }
            for j in b + 1..h {
                g[j * w + i] = g[b * w + i] + s1 * (j - b) as f64;
            }
        }
    }
}

/// Mean over each texel's 3×3 neighbourhood (fewer at the edges).
fn smooth3(v: &[f64], w: usize, h: usize) -> Vec<f64> {
    (0..h)
        .flat_map(|j| (0..w).map(move |i| (i, j)))
        .map(|(i, j)| {
            let (mut sum, mut n) = (0.0, 0.0);
            for jj in j.saturating_sub(1)..=(j + 1).min(h - 1) {
                for ii in i.saturating_sub(1)..=(i + 1).min(w - 1) {
                    sum += v[jj * w + ii];
                    n += 1.0;
                }
            }
            sum / n
        })
        .collect()
}

/// Scales the gains so their bilinear value at the spot is exactly 1.
fn normalise_at(g: &mut [f64], size: [u32; 2], spot: [f64; 2]) {
    let flat = PreparedFlat {
        width: size[0],
        height: size[1],
        gain: g.iter().map(|&v| [v as f32; 3]).collect(),
    };
    let at = f64::from(flat.gain_at([spot[0] as f32, spot[1] as f32])[0]);
    if at > 0.0 {
        g.iter_mut().for_each(|v| *v /= at);
    }
}

pub(super) enum Shown<'i> {
    Uniform([f64; 3]),
    Image(&'i DriveImage),
}

/// Root-mean-square of `r − 1`.
fn rms_residual(r: &[f64]) -> f64 {
    (r.iter().map(|v| (v - 1.0).powi(2)).sum::<f64>() / r.len().max(1) as f64).sqrt()
}

/// The 4×4 Bayer ordered-dither matrix.
const BAYER4: [u8; 16] = [0, 8, 2, 10, 12, 4, 14, 6, 3, 11, 1, 9, 15, 7, 13, 5];

/// The loop's pattern for channel `c`: relative intensity `L / gain(uv)` through the
/// profile's inverse tone curve; `L` is the level the wall white will ask of this
/// channel at the spot (so the tone curve is exercised where it will be used), at most
/// the smallest gain so no pixel clips. Drives between codes are shown by the pattern
/// output as the post pass's dither at the display's own pixels. With `dither` the
/// pattern is ordered-dithered to codes itself, at 8 pixels per texel: an 8-bit camera
/// needs that pattern's variation to break up its own quantisation of a smooth field
/// (without it the Lambertian infitec-pair's loop floors at 0.2–0.4 % and mono-2x1's
/// seams grow); a 12-bit camera sees it only as aliasing (a 0.1–0.3 % floor against
/// 0.03 % without it; `camera_flat_field`'s probes).
fn loop_pattern(
    profile: &DisplayProfile,
    c: usize,
    g: &[f64],
    size: [u32; 2],
    level: f64,
    dither: bool,
) -> Result<DriveImage, CameraCalibError> {
    let level = level
        .min(g.iter().copied().fold(f64::INFINITY, f64::min))
        .clamp(0.01, 1.0);
    let flat = PreparedFlat {
        width: size[0],
        height: size[1],
        gain: g.iter().map(|&v| [v as f32; 3]).collect(),
    };
    let curve = &profile.curves[c];
    let max = f64::from((1u32 << profile.bit_depth.clamp(1, 16)) - 1);
    let (pw, ph) = (8 * size[0], 8 * size[1]);
    DriveImage::from_fn(pw, ph, |u, v| {
        let gain = f64::from(flat.gain_at([u as f32, v as f32])[0]).max(1e-3);
        let lin = (level / gain).clamp(0.0, 1.0);
        let drive = f64::from(curve.drive_for(lin as f32)).clamp(0.0, 1.0);
        let mut d = [0.0; 3];
        d[c] = if dither {
            let (x, y) = ((u * f64::from(pw)) as usize, (v * f64::from(ph)) as usize);
            let t = (f64::from(BAYER4[(y % 4) * 4 + x % 4]) + 0.5) / 16.0;
            ((drive * max + t).floor() / max).clamp(0.0, 1.0)
        } else {
            drive
        };
        d
    })
    .map_err(CameraCalibError::device("building the flat-field pattern"))
}

/// Averaged meter reading at `uv` of `info` showing `drive`.
fn read_meter(
    rig: &mut Rig<'_>,
    info: &DisplayInfo,
    uv: [f64; 2],
    drive: [f64; 3],
) -> Result<[f64; 3], CameraCalibError> {
    let what = format!("meter reading at {uv:?} of {}", info.name);
    rig.pattern
        .show(info.id, drive)
        .map_err(CameraCalibError::device(what.clone()))?;
    rig.positioner
        .aim(info.id, uv)
        .map_err(CameraCalibError::device(what.clone()))?;
    let mut acc = [0.0; 3];
    for _ in 0..READINGS_PER_SPOT {
        let xyz = rig
            .meter
            .measure()
            .map_err(CameraCalibError::device(what.clone()))?;
        for (a, v) in acc.iter_mut().zip(xyz.to_array()) {
            *a += v;
        }
    }
    Ok(acc.map(|v| v / f64::from(READINGS_PER_SPOT)))
}
