//! Where every display lies in the camera image: a grid of dots is projected through
//! the pattern output on each display, found in the camera frame (OpenCV connected
//! components, intensity-weighted centroids), and fitted by one homography per display
//! (OpenCV `findHomography`, planar screen) and the lens's radial distortion about the
//! image centre, shared by all displays (alternating least squares).

use lumiwall_devices::{Camera, DisplayId, DisplayInfo, DriveImage, PatternOutput};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use opencv::calib3d;
use opencv::core::{Mat, Point2d, Vector, no_array};
use opencv::imgproc;
use opencv::prelude::*;
use serde::{Deserialize, Serialize};

use super::CameraCalibError;
use super::cv::{cv_err, mat_gray8};
use super::hdr::{ResponseCurve, base_exposure};

/// The dot grid shown on each display.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DotGrid {
    /// Dots across.
    pub cols: u32,
    /// Dots down.
    pub rows: u32,
}

impl Default for DotGrid {
    fn default() -> Self {
        Self { cols: 7, rows: 5 }
    }
}

impl DotGrid {
    /// Display coordinates of dot (`i`, `j`).
    pub fn uv(&self, i: u32, j: u32) -> [f64; 2] {
        [
            (f64::from(i) + 0.5) / f64::from(self.cols),
            (f64::from(j) + 0.5) / f64::from(self.rows),
        ]
    }

    /// Every dot's display coordinates, row by row.
    pub fn all_uv(&self) -> Vec<[f64; 2]> {
        (0..self.rows)
            .flat_map(|j| (0..self.cols).map(move |i| (i, j)))
            .map(|(i, j)| self.uv(i, j))
            .collect()
    }

    fn image(&self) -> Result<DriveImage, CameraCalibError> {
        let (ru, rv) = (0.18 / f64::from(self.cols), 0.18 / f64::from(self.rows));
        let g = *self;
        DriveImage::from_fn(640, 480, move |u, v| {
            let i = (u * f64::from(g.cols)).floor().min(f64::from(g.cols - 1));
            let j = (v * f64::from(g.rows)).floor().min(f64::from(g.rows - 1));
            let c = g.uv(i as u32, j as u32);
            let d = ((u - c[0]) / ru).powi(2) + ((v - c[1]) / rv).powi(2);
            if d <= 1.0 { [1.0; 3] } else { [0.0; 3] }
        })
        .map_err(CameraCalibError::device(
            "building the registration pattern",
        ))
    }
}

/// One display's place in the camera image.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DisplayMap {
    /// The display.
    pub display: DisplayId,
    /// Row-major homography from display `uv` to undistorted camera pixels.
    pub homography: [[f64; 3]; 3],
    /// The dots found (camera px), row by row, for the movement check.
    pub dots_px: Vec<[f64; 2]>,
}

/// Every display's place in the camera image and the lens's radial distortion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Registration {
    /// Distortion centre (the image centre, px).
    pub centre_px: [f64; 2],
    /// Radius normalising the distortion polynomial (half the diagonal, px).
    pub norm_px: f64,
    /// Radial distortion `[κ1, κ2]`: distorted = centre + (p − centre)(1 + κ1ρ² + κ2ρ⁴).
    pub kappa: [f64; 2],
    /// Per display.
    pub maps: Vec<DisplayMap>,
    /// Root-mean-square reprojection error over all dots (px).
    pub rms_px: f64,
    /// Largest reprojection error (px).
    pub max_px: f64,
    /// The dot grid used.
    pub grid: [u32; 2],
}

fn apply_h(h: &[[f64; 3]; 3], uv: [f64; 2]) -> [f64; 2] {
    let w = h[2][0] * uv[0] + h[2][1] * uv[1] + h[2][2];
    [
        (h[0][0] * uv[0] + h[0][1] * uv[1] + h[0][2]) / w,
        (h[1][0] * uv[0] + h[1][1] * uv[1] + h[1][2]) / w,
    ]
}

impl Registration {
    /// Distorts an undistorted pixel position.
    fn distort(&self, p: [f64; 2]) -> [f64; 2] {
        distort(self.centre_px, self.norm_px, self.kappa, p)
    }

    /// Camera pixel where point `uv` of `display` is seen.
    pub fn to_camera(&self, display: DisplayId, uv: [f64; 2]) -> Option<[f64; 2]> {
        let m = self.maps.iter().find(|m| m.display == display)?;
        Some(self.distort(apply_h(&m.homography, uv)))
    }

    /// Camera pixels (row-major indices) inside `display`, at least `margin_uv` from
    /// its edges.
    pub fn pixels_of(&self, display: DisplayId, width_px: u32, height_px: u32) -> Vec<usize> {
        let Some(m) = self.maps.iter().find(|m| m.display == display) else {
            return Vec::new();
        };
        let Some(inv) = Matrix3::from_row_slice(&m.homography.concat()).try_inverse() else {
            return Vec::new();
        };
        let corners: Vec<[f64; 2]> = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]
            .iter()
            .map(|&uv| self.distort(apply_h(&m.homography, uv)))
            .collect();
        let lo = |k: usize| {
            corners
                .iter()
                .map(|c| c[k])
                .fold(f64::INFINITY, f64::min)
                .max(0.0)
        };
        let hi = |k: usize, n: u32| {
            corners
                .iter()
                .map(|c| c[k])
                .fold(0.0, f64::max)
                .min(f64::from(n))
        };
        let mut out = Vec::new();
        for y in lo(1) as u32..hi(1, height_px).ceil() as u32 {
            for x in lo(0) as u32..hi(0, width_px).ceil() as u32 {
                let p = undistort(
                    self.centre_px,
                    self.norm_px,
                    self.kappa,
                    [f64::from(x) + 0.5, f64::from(y) + 0.5],
                );
                let q = inv * Vector3::new(p[0], p[1], 1.0);
                let (u, v) = (q[0] / q[2], q[1] / q[2]);
                if (0.02..=0.98).contains(&u) && (0.02..=0.98).contains(&v) {
                    out.push(y as usize * width_px as usize + x as usize);
                }
            }
        }
        out
    }
}

fn distort(c: [f64; 2], norm: f64, k: [f64; 2], p: [f64; 2]) -> [f64; 2] {
    let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
    let r2 = (dx * dx + dy * dy) / (norm * norm);
    let s = 1.0 + k[0] * r2 + k[1] * r2 * r2;
    [c[0] + dx * s, c[1] + dy * s]
}

fn undistort(c: [f64; 2], norm: f64, k: [f64; 2], p: [f64; 2]) -> [f64; 2] {
    let mut u = p;
    for _ in 0..30 {
        let d = distort(c, norm, k, u);
        u = [u[0] + (p[0] - d[0]), u[1] + (p[1] - d[1])];
    }
    u
}

/// Finds the dots in a frame: threshold at half the bright level, connected
/// components, intensity-weighted centroids with the background removed.
fn find_dots(
    frame: &lumiwall_devices::Frame,
    curve: &ResponseCurve,
) -> Result<Vec<[f64; 2]>, CameraCalibError> {
    let what = "finding the registration dots";
    let (w, h) = (frame.width_px as usize, frame.height_px as usize);
    let lum: Vec<f64> = frame
        .rgb
        .iter()
        .map(|p| {
            (0..3)
                .map(|c| curve.relative_exposure(c, p[c], frame.bit_depth))
                .sum()
        })
        .collect();
    let mut sorted = lum.clone();
    sorted.sort_by(f64::total_cmp);
    let bg = sorted[sorted.len() / 2];
    let top = sorted[((sorted.len() - 1) as f64 * 0.9995) as usize];
    let thr = bg + 0.35 * (top - bg);
    let mask: Vec<u8> = lum.iter().map(|&v| if v > thr { 255 } else { 0 }).collect();
    let mask = mat_gray8(h, w, &mask)?;
    let (mut labels, mut stats, mut centroids) = (Mat::default(), Mat::default(), Mat::default());
    let n = imgproc::connected_components_with_stats(
        &mask,
        &mut labels,
        &mut stats,
        &mut centroids,
        8,
        opencv::core::CV_32S,
    )
    .map_err(cv_err(what))?;
    let mut dots = Vec::new();
    for label in 1..n {
        let s = |k: i32| stats.at_2d::<i32>(label, k).copied().map_err(cv_err(what));
        let (x0, y0, bw, bh, area) = (s(0)?, s(1)?, s(2)?, s(3)?, s(4)?);
        if area < 3 {
            continue;
        }
        let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
        for y in (y0 - 2).max(0)..(y0 + bh + 2).min(h as i32) {
            for x in (x0 - 2).max(0)..(x0 + bw + 2).min(w as i32) {
                let v = (lum[y as usize * w + x as usize] - bg).max(0.0);
                sx += v * (f64::from(x) + 0.5);
                sy += v * (f64::from(y) + 0.5);
                sw += v;
            }
        }
        if sw > 0.0 {
            dots.push([sx / sw, sy / sw]);
        }
    }
    Ok(dots)
}

/// Orders found dots as the grid: by rows (sorted by y, chunked), each by x.
fn order_dots(mut dots: Vec<[f64; 2]>, grid: DotGrid) -> Vec<[f64; 2]> {
    dots.sort_by(|a, b| a[1].total_cmp(&b[1]));
    dots.chunks(grid.cols as usize)
        .flat_map(|row| {
            let mut r = row.to_vec();
            r.sort_by(|a, b| a[0].total_cmp(&b[0]));
            r
        })
        .collect()
}

/// Shows the dots on `info` and finds them.
fn dots_of(
    cam: &mut dyn Camera,
    pattern: &mut dyn PatternOutput,
    curve: &ResponseCurve,
    info: &DisplayInfo,
    grid: DotGrid,
) -> Result<Vec<[f64; 2]>, CameraCalibError> {
    let what = format!("registration of {}", info.name);
    pattern
        .show_image(info.id, &grid.image()?)
        .map_err(CameraCalibError::device(what.clone()))?;
    let ci = cam.info();
    let all: Vec<usize> = (0..ci.width_px as usize * ci.height_px as usize).collect();
    let frame = base_exposure(cam, &all, &what)?;
    let dots = find_dots(&frame, curve)?;
    let expected = (grid.cols * grid.rows) as usize;
    if dots.len() != expected {
        return Err(CameraCalibError::Registration {
            display: info.name.clone(),
            found: dots.len(),
            expected,
        });
    }
    Ok(order_dots(dots, grid))
}

/// Homography from `uv` to `px` (OpenCV `findHomography`, all points, least squares).
fn homography(uv: &[[f64; 2]], px: &[[f64; 2]]) -> Result<[[f64; 3]; 3], CameraCalibError> {
    let what = "fitting a display's homography";
    let src: Vector<Point2d> = uv.iter().map(|p| Point2d::new(p[0], p[1])).collect();
    let dst: Vector<Point2d> = px.iter().map(|p| Point2d::new(p[0], p[1])).collect();
    let h = calib3d::find_homography(&src, &dst, &mut no_array(), 0, 3.0).map_err(cv_err(what))?;
    let mut out = [[0.0; 3]; 3];
    for (r, row) in out.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = *h.at_2d::<f64>(r as i32, c as i32).map_err(cv_err(what))?;
        }
    }
    Ok(out)
}

/// Registers every display: dots found per display, then homographies and the shared
/// distortion fitted by alternation (homographies on undistorted dots; distortion by
/// linear least squares with the homographies fixed).
pub fn register_displays(
    cam: &mut dyn Camera,
    pattern: &mut dyn PatternOutput,
    curve: &ResponseCurve,
    displays: &[DisplayInfo],
    grid: DotGrid,
) -> Result<Registration, CameraCalibError> {
    let uv = grid.all_uv();
    let mut found = Vec::with_capacity(displays.len());
    for info in displays {
        found.push((info.id, dots_of(cam, pattern, curve, info, grid)?));
    }
    let ci = cam.info();
    let centre = [0.5 * f64::from(ci.width_px), 0.5 * f64::from(ci.height_px)];
    let norm = (centre[0] * centre[0] + centre[1] * centre[1]).sqrt();
    let mut reg = Registration {
        centre_px: centre,
        norm_px: norm,
        kappa: [0.0; 2],
        maps: Vec::new(),
        rms_px: 0.0,
        max_px: 0.0,
        grid: [grid.cols, grid.rows],
    };
    for _ in 0..15 {
        reg.maps = found
            .iter()
            .map(|(id, dots)| {
                let und: Vec<[f64; 2]> = dots
                    .iter()
                    .map(|&p| undistort(centre, norm, reg.kappa, p))
                    .collect();
                Ok(DisplayMap {
                    display: *id,
                    homography: homography(&uv, &und)?,
                    dots_px: dots.clone(),
                })
            })
            .collect::<Result<_, CameraCalibError>>()?;
        reg.kappa = fit_kappa(&reg, &uv);
    }
    let errors: Vec<f64> = reg
        .maps
        .iter()
        .flat_map(|m| {
            m.dots_px.iter().zip(&uv).map(|(d, q)| {
                let p = reg.distort(apply_h(&m.homography, *q));
                ((p[0] - d[0]).powi(2) + (p[1] - d[1]).powi(2)).sqrt()
            })
        })
        .collect();
    reg.rms_px = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len().max(1) as f64).sqrt();
    reg.max_px = errors.iter().copied().fold(0.0, f64::max);
    Ok(reg)
}

/// Radial distortion by linear least squares with the homographies fixed.
fn fit_kappa(reg: &Registration, uv: &[[f64; 2]]) -> [f64; 2] {
    let mut ata = Matrix2::<f64>::zeros();
    let mut atb = Vector2::<f64>::zeros();
    for m in &reg.maps {
        for (d, q) in m.dots_px.iter().zip(uv) {
            let p = apply_h(&m.homography, *q);
            let (dx, dy) = (p[0] - reg.centre_px[0], p[1] - reg.centre_px[1]);
            let r2 = (dx * dx + dy * dy) / (reg.norm_px * reg.norm_px);
            for (delta, res) in [(dx, d[0] - p[0]), (dy, d[1] - p[1])] {
                let a = Vector2::new(delta * r2, delta * r2 * r2);
                ata += a * a.transpose();
                atb += a * res;
            }
        }
    }
    ata.try_inverse()
        .map(|inv| inv * atb)
        .map_or(reg.kappa, |k| [k[0], k[1]])
}

/// Shows the dots on `info` again and fails with [`CameraCalibError::Moved`] when they
/// are more than `limit_px` from where they were registered.
pub fn check_still(
    reg: &Registration,
    cam: &mut dyn Camera,
    pattern: &mut dyn PatternOutput,
    curve: &ResponseCurve,
    info: &DisplayInfo,
    limit_px: f64,
) -> Result<f64, CameraCalibError> {
    let grid = DotGrid {
        cols: reg.grid[0],
        rows: reg.grid[1],
    };
    let now = dots_of(cam, pattern, curve, info, grid)?;
    let then = reg
        .maps
        .iter()
        .find(|m| m.display == info.id)
        .map(|m| m.dots_px.clone())
        .unwrap_or_default();
    let shift = now
        .iter()
        .zip(&then)
        .map(|(a, b)| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt())
        .fold(0.0, f64::max);
    if shift > limit_px {
        return Err(CameraCalibError::Moved {
            display: info.name.clone(),
            shift_px: shift,
            limit_px,
        });
    }
    Ok(shift)
}
