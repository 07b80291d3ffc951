//! The virtual camera: photographs the virtual wall as a real camera would.
//!
//! Per pixel: the ray through the (radially distorted, `k1`, `k2`) pinhole hits the
//! screen plane; the displays of the tile there emit their spectra (the same model the
//! meter reads, with this camera's position for the screen's view-dependent gain);
//! the camera integrates them with its spectral sensitivities (a published camera,
//! `fixtures/camera/`), loses light to lens vignetting `1/(1 + a·r²)²`, collects
//! electrons over the exposure time (fixed-pattern gain and dark offset, shot and read
//! noise), saturates at its full well and writes codes through a non-linear response
//! curve, 8 or 12 bits.

use std::sync::OnceLock;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::observer::{Spectrum, cie1931, spectra_from_csv};
use super::screen;
use super::wall::{VirtualWall, WallState};
use super::wall_file::{Stereo, WallFile};
use crate::camera::MAX_FRAME_PIXELS;
use crate::{Camera, CameraInfo, DeviceError, DisplayId, Frame};

const NIKON_5100_CSV: &str = include_str!("../../../fixtures/camera/nikon5100_npl_5nm.csv");

/// Spectral sensitivities R, G, B of the Nikon D5100 as measured by the NPL (see
/// `fixtures/camera/nikon5100_npl_5nm.csv`), parsed once.
pub fn nikon_5100() -> Result<&'static [Spectrum; 3], DeviceError> {
    static S: OnceLock<Result<[Spectrum; 3], String>> = OnceLock::new();
    S.get_or_init(|| {
        let v = spectra_from_csv(NIKON_5100_CSV, 3)?;
        <[Spectrum; 3]>::try_from(v).map_err(|_| "expected three channels".to_string())
    })
    .as_ref()
    .map_err(|e| DeviceError::Config(format!("embedded camera sensitivities: {e}")))
}

/// The virtual camera of a wall file (`[camera]`); every field has a default, so a
/// wall file without the table gets a camera centred in front of the wall that sees
/// all of it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraSpec {
    /// Position of the lens (m, wall coordinates: x right, y up from the lower-left
    /// corner, z toward the audience). Absent: centred, far enough to see the whole
    /// wall.
    pub position_m: Option<[f64; 3]>,
    /// Point the camera looks at (m). Absent: the wall's centre.
    pub look_at_m: Option<[f64; 3]>,
    /// Frame width (px).
    pub width_px: u32,
    /// Frame height (px).
    pub height_px: u32,
    /// Horizontal field of view of the undistorted pinhole (degrees).
    pub hfov_deg: f64,
    /// Radial distortion coefficients (Brown model, normalised image coordinates).
    pub k1: f64,
    /// Second radial coefficient.
    pub k2: f64,
    /// Lens vignetting `a` in `1/(1 + a·r²)²`, r = distance from the centre over the
    /// half-diagonal.
    pub vignetting: f64,
    /// Response curve exponents per channel (codes ∝ exposure^(1/γ) near black).
    pub response_gamma: [f64; 3],
    /// Response shoulder `s` (0: a pure power law; larger: a softer roll-off).
    pub response_shoulder: f64,
    /// Bits per channel of the frames: 8 (JPEG-like) or 12 (raw-like).
    pub bits: u32,
    /// Electrons at saturation.
    pub full_well_e: f64,
    /// Read noise (electrons RMS).
    pub read_noise_e: f64,
    /// Fixed-pattern gain scatter per pixel (relative RMS).
    pub prnu_rel: f64,
    /// Fixed-pattern dark offset per pixel (electrons RMS, never below 0).
    pub dark_fpn_e: f64,
    /// Electrons per second in green for an equal-energy white of 1 cd/m² (gain 1).
    pub electrons_per_cd_m2_s: f64,
    /// Shortest and longest exposure (s).
    pub exposure_range_s: [f64; 2],
    /// Smallest and largest analogue gain.
    pub gain_range: [f64; 2],
    /// Simulated seconds each capture takes besides its exposure.
    pub seconds_per_capture: f64,
    /// False: a camera with automatic exposure only (the station must refuse it).
    pub manual_exposure: bool,
}

impl Default for CameraSpec {
    fn default() -> Self {
        Self {
            position_m: None,
            look_at_m: None,
            width_px: 960,
            height_px: 600,
            hfov_deg: 50.0,
            k1: -0.06,
            k2: 0.008,
            vignetting: 0.12,
            response_gamma: [2.0, 2.2, 1.9],
            response_shoulder: 1.0,
            bits: 8,
            full_well_e: 20_000.0,
            read_noise_e: 8.0,
            prnu_rel: 0.004,
            dark_fpn_e: 4.0,
            electrons_per_cd_m2_s: 4.0e5,
            exposure_range_s: [1e-5, 4.0],
            gain_range: [1.0, 16.0],
            seconds_per_capture: 0.2,
            manual_exposure: true,
        }
    }
}

impl CameraSpec {
    /// Checks every value before a camera is built.
    pub fn validate(&self) -> Result<(), DeviceError> {
        let bad = |what: &str, why: &str| Err(DeviceError::Config(format!("camera.{what} {why}")));
        let n = u64::from(self.width_px) * u64::from(self.height_px);
        if n == 0 || n > MAX_FRAME_PIXELS {
            return bad(
                "width_px × height_px",
                &format!("must be 1..={MAX_FRAME_PIXELS} pixels"),
            );
        }
        if !(self.hfov_deg.is_finite() && (1.0..=150.0).contains(&self.hfov_deg)) {
            return bad("hfov_deg", "must be 1..=150");
        }
        if self.bits != 8 && self.bits != 12 {
            return bad("bits", "must be 8 or 12");
        }
        let positive = [
            ("full_well_e", self.full_well_e),
            ("electrons_per_cd_m2_s", self.electrons_per_cd_m2_s),
            ("response_shoulder + 1", self.response_shoulder + 1.0),
        ];
        for (what, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return bad(what, "must be finite and > 0");
            }
        }
        let nonneg = [
            ("vignetting", self.vignetting),
            ("read_noise_e", self.read_noise_e),
            ("prnu_rel", self.prnu_rel),
            ("dark_fpn_e", self.dark_fpn_e),
            ("seconds_per_capture", self.seconds_per_capture),
            ("response_shoulder", self.response_shoulder),
        ];
        for (what, v) in nonneg {
            if !(v.is_finite() && v >= 0.0) {
                return bad(what, "must be finite and ≥ 0");
            }
        }
        if self
            .response_gamma
            .iter()
            .any(|g| !(g.is_finite() && (0.2..=5.0).contains(g)))
        {
            return bad("response_gamma", "must be 0.2..=5 per channel");
        }
        if !(self.k1.is_finite()
            && self.k2.is_finite()
            && self.k1.abs() < 1.0
            && self.k2.abs() < 1.0)
        {
            return bad("k1/k2", "must be finite and below 1 in magnitude");
        }
        for (what, [lo, hi]) in [
            ("exposure_range_s", self.exposure_range_s),
            ("gain_range", self.gain_range),
        ] {
            if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi >= lo) {
                return bad(what, "must be two finite values 0 < min ≤ max");
            }
        }
        for (what, p) in [
            ("position_m", self.position_m),
            ("look_at_m", self.look_at_m),
        ] {
            if p.is_some_and(|p| p.iter().any(|v| !v.is_finite())) {
                return bad(what, "must be finite");
            }
        }
        if self.position_m.is_some_and(|p| p[2] <= 0.0) {
            return bad("position_m", "must be in front of the screen (z > 0)");
        }
        Ok(())
    }

    /// The camera's true response: code fraction (0..=1) for relative exposure `x`
    /// (1 = full well) of channel `c`.
    pub fn response(&self, c: usize, x: f64) -> f64 {
        let t = x.clamp(0.0, 1.0).powf(1.0 / self.response_gamma[c]);
        let s = self.response_shoulder;
        (1.0 + s) * t / (s + t)
    }

    /// Inverse of [`CameraSpec::response`]: relative exposure for code fraction `y`.
    pub fn inverse_response(&self, c: usize, y: f64) -> f64 {
        let y = y.clamp(0.0, 1.0);
        let s = self.response_shoulder;
        let t = y * s / (1.0 + s - y);
        t.powf(self.response_gamma[c])
    }
}

/// Where the camera is and how it looks: the pinhole frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraPose {
    /// Lens position (m).
    pub position_m: [f64; 3],
    /// Unit vectors: image right, image down, forward.
    axes: [[f64; 3]; 3],
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalised(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = dot(a, a).sqrt();
    (n > 1e-12 && n.is_finite()).then(|| a.map(|v| v / n))
}

impl CameraPose {
    /// A camera at `position_m` looking at `look_at_m`, image up = wall up.
    pub fn looking_at(position_m: [f64; 3], look_at_m: [f64; 3]) -> Result<Self, DeviceError> {
        let forward = normalised([
            look_at_m[0] - position_m[0],
            look_at_m[1] - position_m[1],
            look_at_m[2] - position_m[2],
        ]);
        let right = forward.and_then(|f| normalised(cross(f, [0.0, 1.0, 0.0])));
        match (forward, right) {
            (Some(f), Some(r)) if f[2] < -0.05 => Ok(Self {
                position_m,
                axes: [r, cross(f, r), f],
            }),
            _ => Err(DeviceError::Config(format!(
                "camera at {position_m:?} looking at {look_at_m:?} does not face the screen"
            ))),
        }
    }
}

/// What one camera pixel sees, fixed for a pose.
#[derive(Debug, Clone, Copy)]
struct PixelView {
    /// Tile index `row * cols + col`, or `u32::MAX` off the wall.
    tile: u32,
    /// Display coordinates on that tile.
    uv: [f64; 2],
    /// Vignetting of the camera lens at this pixel.
    vignetting: f64,
    /// Wall point seen (m).
    spot_m: [f64; 3],
}

/// The camera's fixed-pattern noise: per-pixel gain and dark offset.
#[derive(Debug, Clone)]
struct FixedPattern {
    gain: Vec<f32>,
    dark_e: Vec<f32>,
}

/// A camera photographing a [`VirtualWall`].
#[derive(Debug, Clone)]
pub struct VirtualCamera {
    wall: VirtualWall,
    spec: CameraSpec,
    pose: CameraPose,
    noisy: bool,
    /// Per display: `[R, G, B, black, white segment]` in electrons per second.
    basis: Vec<[[f64; 3]; 5]>,
    views: Vec<PixelView>,
    pattern: FixedPattern,
    captures: u64,
}

/// Focal length in pixels.
fn focal_px(spec: &CameraSpec) -> f64 {
    0.5 * f64::from(spec.width_px) / (0.5 * spec.hfov_deg.to_radians()).tan()
}

/// The default pose: centred, at the distance where the wall fills 92 % of the
/// undistorted frame in its tighter direction.
fn default_pose(file: &WallFile, spec: &CameraSpec) -> Result<CameraPose, DeviceError> {
    let w = f64::from(file.tiles.cols) * file.tiles.width_m;
    let h = f64::from(file.tiles.rows) * file.tiles.height_m;
    let f = focal_px(spec);
    let d_w = 0.5 * w / (0.46 * f64::from(spec.width_px) / f);
    let d_h = 0.5 * h / (0.46 * f64::from(spec.height_px) / f);
    let centre = [0.5 * w, 0.5 * h, 0.0];
    let position = spec
        .position_m
        .unwrap_or([centre[0], centre[1], d_w.max(d_h)]);
    CameraPose::looking_at(position, spec.look_at_m.unwrap_or(centre))
}

impl VirtualCamera {
    /// A camera as the wall file's `[camera]` table describes it; `noisy = false`
    /// makes it noiseless (no shot, read or fixed-pattern noise; quantisation stays).
    pub fn new(wall: &VirtualWall, noisy: bool) -> Result<Self, DeviceError> {
        let file = wall.wall_file();
        let spec = file.camera.clone();
        spec.validate()?;
        let pose = default_pose(&file, &spec)?;
        let basis = camera_basis(wall, &spec)?;
        let pattern = fixed_pattern(&spec, file.seed, noisy);
        let mut cam = Self {
            wall: wall.clone(),
            spec,
            pose,
            noisy,
            basis,
            views: Vec::new(),
            pattern,
            captures: 0,
        };
        cam.views = cam.pixel_views(&file);
        Ok(cam)
    }

    /// The camera's description.
    pub fn spec(&self) -> &CameraSpec {
        &self.spec
    }

    /// Where the camera is.
    pub fn pose(&self) -> CameraPose {
        self.pose
    }

    /// Moves the camera (a bumped tripod); what it sees is recomputed.
    pub fn set_pose(&mut self, pose: CameraPose) {
        self.pose = pose;
        self.views = self.pixel_views(&self.wall.wall_file());
    }

    /// Pixel position (x right, y down, pixel centres at +0.5) where the camera sees
    /// point `uv` of display `id`: the truth a registration should recover.
    pub fn project(&self, id: DisplayId, uv: [f64; 2]) -> Result<[f64; 2], DeviceError> {
        let spot = {
            let s = self.wall.lock();
            let d = s
                .displays
                .get(id.0 as usize)
                .ok_or_else(|| DeviceError::NoSuchDisplay(format!("{id} (camera projection)")))?;
            d.spot_m(uv)
        };
        Ok(self.project_point(spot))
    }

    /// Pixel position of a wall point (m).
    pub fn project_point(&self, p: [f64; 3]) -> [f64; 2] {
        let rel = [
            p[0] - self.pose.position_m[0],
            p[1] - self.pose.position_m[1],
            p[2] - self.pose.position_m[2],
        ];
        let [r, d, f] = self.pose.axes;
        let z = dot(rel, f);
        let (xn, yn) = (dot(rel, r) / z, dot(rel, d) / z);
        let r2 = xn * xn + yn * yn;
        let s = 1.0 + self.spec.k1 * r2 + self.spec.k2 * r2 * r2;
        let fp = focal_px(&self.spec);
        [
            0.5 * f64::from(self.spec.width_px) + fp * xn * s,
            0.5 * f64::from(self.spec.height_px) + fp * yn * s,
        ]
    }

    /// Undistorts normalised image coordinates (fixed-point iteration of the Brown
    /// model; converges for the distortions [`CameraSpec::validate`] allows).
    fn undistort(&self, xd: f64, yd: f64) -> (f64, f64) {
        let (mut x, mut y) = (xd, yd);
        for _ in 0..20 {
            let r2 = x * x + y * y;
            let s = 1.0 + self.spec.k1 * r2 + self.spec.k2 * r2 * r2;
            (x, y) = (xd / s, yd / s);
        }
        (x, y)
    }

    /// What every pixel sees from the current pose.
    fn pixel_views(&self, file: &WallFile) -> Vec<PixelView> {
        let (w, h) = (self.spec.width_px, self.spec.height_px);
        let fp = focal_px(&self.spec);
        let (cx, cy) = (0.5 * f64::from(w), 0.5 * f64::from(h));
        let half_diag2 = cx * cx + cy * cy;
        let t = &file.tiles;
        let [r, d, f] = self.pose.axes;
        let o = self.pose.position_m;
        (0..u64::from(w) * u64::from(h))
            .into_par_iter()
            .map(|i| {
                let (px, py) = (
                    (i % u64::from(w)) as f64 + 0.5,
                    (i / u64::from(w)) as f64 + 0.5,
                );
                let vig = 1.0
                    / (1.0
                        + self.spec.vignetting * ((px - cx).powi(2) + (py - cy).powi(2))
                            / half_diag2)
                        .powi(2);
                let (xn, yn) = self.undistort((px - cx) / fp, (py - cy) / fp);
                let dir: [f64; 3] = std::array::from_fn(|k| f[k] + xn * r[k] + yn * d[k]);
                let off = PixelView {
                    tile: u32::MAX,
                    uv: [0.0; 2],
                    vignetting: vig,
                    spot_m: [0.0; 3],
                };
                if dir[2] >= 0.0 {
                    return off;
                }
                let s = -o[2] / dir[2];
                let (x, y) = (o[0] + s * dir[0], o[1] + s * dir[1]);
                let (col, rfb) = ((x / t.width_m).floor(), (y / t.height_m).floor());
                if col < 0.0 || rfb < 0.0 || col >= f64::from(t.cols) || rfb >= f64::from(t.rows) {
                    return off;
                }
                let (col, row) = (col as u32, t.rows - 1 - rfb as u32);
                let u = x / t.width_m - f64::from(col);
                let v = 1.0 - (y / t.height_m - rfb);
                PixelView {
                    tile: row * t.cols + col,
                    uv: [u.clamp(0.0, 1.0), v.clamp(0.0, 1.0)],
                    vignetting: vig,
                    spot_m: [x, y, 0.0],
                }
            })
            .collect()
    }

    /// Electrons per second collected by each pixel, without noise.
    fn electron_rates(&self, s: &WallState) -> Vec<[f64; 3]> {
        let tiles = s.file.tiles.cols * s.file.tiles.rows;
        let eyes = if s.file.stereo == Stereo::Infitec {
            2
        } else {
            1
        };
        let conds: Vec<_> = s.displays.iter().map(|d| s.conditions(d)).collect();
        let cam = self.pose.position_m;
        self.views
            .par_iter()
            .map(|v| {
                if v.tile == u32::MAX {
                    return [0.0; 3];
                }
                let mut acc = [0.0; 3];
                for eye in 0..eyes {
                    let idx = (eye * tiles + v.tile) as usize;
                    let Some(d) = s.displays.get(idx) else {
                        continue;
                    };
                    let drive = match &s.shown {
                        Some((id, shown)) if id.0 as usize == idx => shown.drive_at(v.uv),
                        _ => [0.0; 3],
                    };
                    let g = screen::gain(&s.file.screen, d.lens_m(), v.spot_m, cam);
                    let e = d.emitted_in(&self.basis[idx], drive, v.uv, conds[idx]);
                    for k in 0..3 {
                        acc[k] += e[k] * g * v.vignetting;
                    }
                }
                acc
            })
            .collect()
    }

    /// Codes of one pixel from its collected electrons.
    fn code(&self, c: usize, electrons: f64, gain: f64) -> u16 {
        let max = f64::from((1u32 << self.spec.bits) - 1);
        let x = (electrons * gain / self.spec.full_well_e).clamp(0.0, 1.0);
        (self.spec.response(c, x) * max).round() as u16
    }
}

/// Each display's five spectra integrated with the camera's sensitivities, in
/// electrons per second (gain 1): scaled so that an equal-energy white of 1 cd/m² gives
/// `electrons_per_cd_m2_s` in green.
fn camera_basis(wall: &VirtualWall, spec: &CameraSpec) -> Result<Vec<[[f64; 3]; 5]>, DeviceError> {
    let sens = nikon_5100()?;
    let obs = cie1931()?;
    let ee_y = obs.tristimulus(&Spectrum::constant(1.0))[1];
    let ee_g: f64 = sens[1].values.iter().sum();
    let k = spec.electrons_per_cd_m2_s * ee_y / ee_g;
    let integrate = |s: &Spectrum| -> [f64; 3] {
        std::array::from_fn(|c| {
            k * s
                .values
                .iter()
                .zip(&sens[c].values)
                .map(|(a, b)| a * b)
                .sum::<f64>()
        })
    };
    Ok(wall.integrated_spectra(integrate))
}

/// Per-pixel gain and dark offset, drawn once from the wall's seed.
fn fixed_pattern(spec: &CameraSpec, seed: u64, noisy: bool) -> FixedPattern {
    let n = (u64::from(spec.width_px) * u64::from(spec.height_px)) as usize;
    if !noisy {
        return FixedPattern {
            gain: vec![1.0; n],
            dark_e: vec![0.0; n],
        };
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xCA3E_5A11);
    let mut z = move || -> f64 { StandardNormal.sample(&mut rng) };
    let gain = (0..n).map(|_| (1.0 + spec.prnu_rel * z()) as f32).collect();
    let dark_e = (0..n)
        .map(|_| (spec.dark_fpn_e * z()).abs() as f32)
        .collect();
    FixedPattern { gain, dark_e }
}

impl Camera for VirtualCamera {
    fn info(&self) -> CameraInfo {
        CameraInfo {
            name: "virtual camera".into(),
            width_px: self.spec.width_px,
            height_px: self.spec.height_px,
            bit_depth: self.spec.bits,
            exposure_range_s: self.spec.exposure_range_s,
            gain_range: self.spec.gain_range,
            manual_exposure: self.spec.manual_exposure,
        }
    }

    fn capture(&mut self, exposure_s: f64, gain: f64) -> Result<Frame, DeviceError> {
        self.info().check_request(exposure_s, gain)?;
        let (rates, timestamp_s) = {
            let mut s = self.wall.lock();
            let rates = self.electron_rates(&s);
            let t = s.clock_s;
            s.clock_s += exposure_s + self.spec.seconds_per_capture;
            (rates, t)
        };
        self.captures += 1;
        let mut rng = ChaCha8Rng::seed_from_u64(self.wall.seed() ^ 0xF4A3_E000);
        rng.set_stream(self.captures);
        let read_e = self.spec.read_noise_e;
        let rgb = rates
            .iter()
            .enumerate()
            .map(|(i, rate)| {
                std::array::from_fn(|c| {
                    let mut e = rate[c] * exposure_s;
                    if self.noisy {
                        e = e * f64::from(self.pattern.gain[i]) + f64::from(self.pattern.dark_e[i]);
                        let (z1, z2): (f64, f64) = (
                            StandardNormal.sample(&mut rng),
                            StandardNormal.sample(&mut rng),
                        );
                        e += e.max(0.0).sqrt() * z1 + read_e * z2;
                    }
                    self.code(c, e, gain)
                })
            })
            .collect();
        Ok(Frame {
            width_px: self.spec.width_px,
            height_px: self.spec.height_px,
            bit_depth: self.spec.bits,
            rgb,
            exposure_s,
            gain,
            timestamp_s,
        })
    }
}
