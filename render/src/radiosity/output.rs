//! Writing results: the error/time curve (CSV, PNG plot), per-vertex radiosity (PLY),
//! and an XYZ float OpenEXR image (channels X, Y, Z; Y = luminance in cd/m²) from a
//! pinhole camera by z-buffered rasterisation of the solved patches with per-vertex
//! (Gouraud) interpolation.

use std::collections::HashMap;
use std::f64::consts::PI;
use std::path::Path;

use crate::scene::{Camera, V3};
use crate::view::LitMesh;

use super::RadiosityError;
use super::curve::ErrorCurve;
use super::solution::Solution;

fn out_err(path: &Path, e: impl std::fmt::Display) -> RadiosityError {
    RadiosityError::Output {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Writes `bytes` to `path` atomically (temporary file, then rename).
fn save(path: &Path, bytes: &[u8]) -> Result<(), RadiosityError> {
    lumiwall_core::files::write_atomic(path, bytes).map_err(|e| out_err(path, e))
}

/// Encodes an RGB image as PNG and saves it atomically.
fn save_png(img: image::RgbImage, path: &Path) -> Result<(), RadiosityError> {
    let mut bytes = std::io::Cursor::new(Vec::new());
    image::DynamicImage::ImageRgb8(img)
        .write_to(&mut bytes, image::ImageFormat::Png)
        .map_err(|e| out_err(path, e))?;
    save(path, bytes.get_ref())
}

/// Writes the curve as CSV.
pub fn write_curve_csv(curve: &ErrorCurve, path: &Path) -> Result<(), RadiosityError> {
    save(path, curve.to_csv().as_bytes())
}

/// Writes an animation's exitance in time (`SequenceSolution::exitance_in_time`) as
/// CSV: `element,frame,x_lm_m2,y_lm_m2,z_lm_m2`, one line per knot, `frame` the
/// frame number (`frames[knot]`), elements in the order of the frames' patches.
pub fn write_time_curves_csv(
    frames: &[usize],
    curves: &[super::sequence::TimeCurve],
    path: &Path,
) -> Result<(), RadiosityError> {
    let mut csv = String::from("element,frame,x_lm_m2,y_lm_m2,z_lm_m2\n");
    for (i, c) in curves.iter().enumerate() {
        for (k, v) in &c.knots {
            csv += &format!(
                "{i},{},{:.6e},{:.6e},{:.6e}\n",
                frames[*k], v[0], v[1], v[2]
            );
        }
    }
    save(path, csv.as_bytes())
}

/// Per-vertex luminance: for every patch corner the area-weighted mean luminance
/// (XYZ, Y in cd/m²) of the patches of the same polygon that share that corner.
pub fn vertex_luminance(sol: &Solution) -> Vec<Vec<[f64; 3]>> {
    let key = |poly: usize, v: &V3| {
        let q = |c: f64| (c * 1e6).round() as i64;
        (poly, q(v.x), q(v.y), q(v.z))
    };
    type Key = (usize, i64, i64, i64);
    let mut acc: HashMap<Key, ([f64; 3], f64)> = HashMap::new();
    for p in &sol.patches {
        for (k, v) in p.vertices.iter().enumerate() {
            // linear patches bring their own vertex value, constant ones their mean
            let b = p.vertex_exitance_xyz.get(k).unwrap_or(&p.exitance_xyz);
            let e = acc.entry(key(p.polygon, v)).or_insert(([0.0; 3], 0.0));
            for (acc, v) in e.0.iter_mut().zip(b) {
                *acc += p.area_m2 * v / PI;
            }
            e.1 += p.area_m2;
        }
    }
    sol.patches
        .iter()
        .map(|p| {
            p.vertices
                .iter()
                .map(|v| {
                    let (s, a) = acc[&key(p.polygon, v)];
                    s.map(|x| x / a.max(1e-300))
                })
                .collect()
        })
        .collect()
}

/// Writes an ASCII PLY: one face per patch, wound counter-clockwise seen from the
/// patch's lit side ([`crate::view::LitMesh::from_solution`]); vertex properties X, Y,
/// Z luminance in cd/m².
pub fn write_ply(sol: &Solution, path: &Path) -> Result<(), RadiosityError> {
    let mesh = crate::view::LitMesh::from_solution(sol);
    let mut s = format!(
        "ply\nformat ascii 1.0\ncomment lumiwall radiosity; X Y Z are luminance in cd/m2 (Y photometric), positions in m\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty float lum_X\nproperty float lum_Y\nproperty float lum_Z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.faces.len()
    );
    for (v, c) in mesh.positions.iter().zip(&mesh.luminance_xyz) {
        s.push_str(&format!(
            "{} {} {} {} {} {}\n",
            v.x, v.y, v.z, c[0], c[1], c[2]
        ));
    }
    for face in &mesh.faces {
        s.push_str(&face.len().to_string());
        for k in face {
            s.push_str(&format!(" {k}"));
        }
        s.push('\n');
    }
    save(path, s.as_bytes())
}

/// Points closer to the camera than this (m along the view axis) are not projected.
const NEAR_PLANE_M: f64 = 1e-4;
/// Triangles with a smaller doubled screen area (px²) are skipped as degenerate.
const MIN_SCREEN_AREA: f64 = 1e-12;
/// Barycentric slack that keeps pixels on shared triangle edges.
const EDGE_SLACK: f64 = 1e-9;

/// A projected vertex: pixel x, pixel y, depth along the view axis.
pub(crate) type Projected = (f64, f64, f64);

/// A pinhole camera's projection to pixels.
struct Pinhole<'a> {
    camera: &'a Camera,
    forward: V3,
    right: V3,
    up: V3,
    /// Focal length in pixels.
    focal_px: f64,
    width: usize,
    height: usize,
}

impl<'a> Pinhole<'a> {
    fn new(camera: &'a Camera) -> Self {
        let (width, height) = (camera.width_px as usize, camera.height_px as usize);
        let forward = (camera.look_at - camera.position).normalize();
        let right = forward.cross(&camera.up).normalize();
        let up = right.cross(&forward);
        let focal_px = 0.5 * height as f64 / (0.5 * camera.vfov_deg.to_radians()).tan();
        Self {
            camera,
            forward,
            right,
            up,
            focal_px,
            width,
            height,
        }
    }

    /// The pixel position and depth of `p`, `None` behind the near plane.
    fn project(&self, p: &V3) -> Option<Projected> {
        let d = p - self.camera.position;
        let z = d.dot(&self.forward);
        if z < NEAR_PLANE_M {
            return None;
        }
        Some((
            0.5 * self.width as f64 + self.focal_px * d.dot(&self.right) / z,
            0.5 * self.height as f64 - self.focal_px * d.dot(&self.up) / z,
            z,
        ))
    }
}

/// An image with a depth buffer.
struct Raster {
    width: usize,
    height: usize,
    img: Vec<[f32; 3]>,
    zbuf: Vec<f64>,
}

/// Pixel indices covered by the coordinates `c` (floor of the least to ceiling of
/// the largest), clipped to `0..limit`.
fn pixel_span(c: [f64; 3], limit: usize) -> std::ops::Range<usize> {
    let lo = c
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
        .floor()
        .max(0.0) as usize;
    let hi = c
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max)
        .ceil()
        .min(limit as f64) as usize;
    lo..hi
}

impl Raster {
    fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            img: vec![[0f32; 3]; width * height],
            zbuf: vec![f64::INFINITY; width * height],
        }
    }

    /// Fills a triangle, interpolating `val` perspective-correctly, nearest wins.
    fn fill_triangle(&mut self, tri: [Projected; 3], val: [[f64; 3]; 3]) {
        let xs = pixel_span(tri.map(|v| v.0), self.width);
        let ys = pixel_span(tri.map(|v| v.1), self.height);
        let area = (tri[1].0 - tri[0].0) * (tri[2].1 - tri[0].1)
            - (tri[2].0 - tri[0].0) * (tri[1].1 - tri[0].1);
        if area.abs() < MIN_SCREEN_AREA {
            return;
        }
        for y in ys {
            for x in xs.clone() {
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                let e = |a: Projected, b: Projected| {
                    (b.0 - a.0) * (py - a.1) - (px - a.0) * (b.1 - a.1)
                };
                let b0 = e(tri[1], tri[2]) / area;
                let b1 = e(tri[2], tri[0]) / area;
                let b2 = e(tri[0], tri[1]) / area;
                if b0 < -EDGE_SLACK || b1 < -EDGE_SLACK || b2 < -EDGE_SLACK {
                    continue;
                }
                // perspective-correct interpolation
                let iz = b0 / tri[0].2 + b1 / tri[1].2 + b2 / tri[2].2;
                let z = 1.0 / iz;
                let i = y * self.width + x;
                if z >= self.zbuf[i] {
                    continue;
                }
                self.zbuf[i] = z;
                self.img[i] = std::array::from_fn(|k| {
                    (z * (b0 * val[0][k] / tri[0].2
                        + b1 * val[1][k] / tri[1].2
                        + b2 * val[2][k] / tri[2].2)) as f32
                });
            }
        }
    }
}

/// Rasterises the solution seen from `camera`: XYZ luminance per pixel (cd/m²), row
/// major from the top-left; background 0.
pub fn render_image(sol: &Solution, camera: &Camera) -> Vec<[f32; 3]> {
    let pinhole = Pinhole::new(camera);
    let mesh = LitMesh::from_solution(sol);
    let size = (pinhole.width, pinhole.height);
    rasterise(&mesh, &camera.position, size, |p| pinhole.project(p))
}

/// `mesh` seen from `eye` through `project` (a scene point to its pixel and depth,
/// `None` behind the near plane): XYZ luminance per pixel (cd/m²), `size` = (width,
/// height), row major from the top-left, background 0, z-buffered with
/// perspective-correct interpolation. Faces turned away from the eye are not drawn
/// (one-sided surfaces); a face with a vertex behind the near plane is left out; each
/// face is fanned into triangles from its first vertex.
pub(crate) fn rasterise(
    mesh: &LitMesh,
    eye: &V3,
    size: (usize, usize),
    project: impl Fn(&V3) -> Option<Projected>,
) -> Vec<[f32; 3]> {
    let mut raster = Raster::new(size.0, size.1);
    let projected: Vec<Option<Projected>> = mesh.positions.iter().map(project).collect();
    for face in &mesh.faces {
        if !mesh.faces_eye(face, eye) {
            continue;
        }
        let proj: Option<Vec<Projected>> = face.iter().map(|&i| projected[i as usize]).collect();
        let Some(proj) = proj else { continue };
        let lum = |k: usize| mesh.luminance_xyz[face[k] as usize];
        for t in 1..proj.len() - 1 {
            raster.fill_triangle(
                [proj[0], proj[t], proj[t + 1]],
                [lum(0), lum(t), lum(t + 1)],
            );
        }
    }
    raster.img
}

/// Writes an XYZ float OpenEXR (channels X, Y, Z; cd/m²), atomically
/// ([`crate::post::io::write_exr`]).
pub fn write_exr(
    img: &[[f32; 3]],
    width: usize,
    height: usize,
    path: &Path,
) -> Result<(), RadiosityError> {
    let size = |v: usize| u32::try_from(v).map_err(|e| out_err(path, e));
    let frame = crate::post::XyzFrame::new(size(width)?, size(height)?, img.to_vec())
        .map_err(|e| out_err(path, e))?;
    crate::post::io::write_exr(path, &frame, false).map_err(|e| out_err(path, e))
}

// --- a tiny 3×5 bitmap font for the plot labels ---
/// A 3×5 bitmap glyph (rows top down, bit 4 = left column): digits and the few
/// letters the axis labels use.
fn glyph(c: char) -> [u8; 5] {
    match c {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 1, 1],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        '.' => [0, 0, 0, 0, 2],
        '%' => [5, 1, 2, 4, 5],
        's' => [0, 7, 4, 1, 7],
        'e' => [0, 7, 7, 4, 7],
        '-' => [0, 0, 7, 0, 0],
        'a' => [0, 6, 3, 5, 7],
        'd' => [1, 1, 7, 5, 7],
        'g' => [7, 5, 7, 1, 6],
        'i' => [2, 0, 2, 2, 2],
        'l' => [6, 2, 2, 2, 7],
        'm' => [0, 7, 7, 5, 5],
        'o' => [0, 7, 5, 5, 7],
        'r' => [0, 7, 4, 4, 4],
        't' => [2, 7, 2, 2, 3],
        'w' => [0, 5, 5, 7, 7],
        '(' => [1, 2, 2, 2, 1],
        ')' => [4, 2, 2, 2, 4],
        _ => [0; 5],
    }
}

fn text(img: &mut image::RgbImage, x: i64, y: i64, s: &str, scale: i64, col: [u8; 3]) {
    for (k, c) in s.chars().enumerate() {
        let g = glyph(c);
        for (row, bits) in g.iter().enumerate() {
            for bit in 0..3 {
                if bits & (4 >> bit) != 0 {
                    for dy in 0..scale {
                        for dx in 0..scale {
                            let px = x + (k as i64 * 4 + bit) * scale + dx;
                            let py = y + row as i64 * scale + dy;
                            if px >= 0
                                && py >= 0
                                && (px as u32) < img.width()
                                && (py as u32) < img.height()
                            {
                                img.put_pixel(px as u32, py as u32, image::Rgb(col));
                            }
                        }
                    }
                }
            }
        }
    }
}

fn line(img: &mut image::RgbImage, a: (f64, f64), b: (f64, f64), col: [u8; 3]) {
    let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as usize).max(1);
    for i in 0..=n {
        let t = i as f64 / n as f64;
        let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
        for (dx, dy) in [(0, 0), (1, 0), (0, 1)] {
            let (px, py) = (x as i64 + dx, y as i64 + dy);
            if px >= 0 && py >= 0 && (px as u32) < img.width() && (py as u32) < img.height() {
                img.put_pixel(px as u32, py as u32, image::Rgb(col));
            }
        }
    }
}

/// Plot size in pixels.
const PLOT_SIZE: (u32, u32) = (800, 500);
/// Plot margins in pixels: left, right, top, bottom.
const PLOT_MARGINS: (f64, f64, f64, f64) = (90.0, 40.0, 30.0, 60.0);
const GREY: [u8; 3] = [200, 200, 200];
const BLACK: [u8; 3] = [0, 0, 0];
/// Colour of the dashed target line.
const TARGET_GREEN: [u8; 3] = [0, 150, 0];
/// Pixel scale of the label font.
const LABEL_SCALE: i64 = 2;

/// The axes of the error/time plot: time linear from 0, error in whole decades.
struct PlotFrame {
    width: f64,
    height: f64,
    left: f64,
    right: f64,
    top: f64,
    bottom: f64,
    /// Longest time on the axis (s).
    tmax: f64,
    /// Lowest and highest decade (log10 of the error).
    decades: (f64, f64),
}

impl PlotFrame {
    /// Axes that hold every finite positive point of `curves` and the target.
    fn fit(curves: &[(&ErrorCurve, [u8; 3])], target: Option<f64>) -> Self {
        let pts: Vec<(f64, f64)> = curves
            .iter()
            .flat_map(|(c, _)| c.points.iter().map(|p| (p.time_s, p.estimated_error)))
            .filter(|(_, e)| *e > 0.0 && e.is_finite())
            .collect();
        let tmax = pts.iter().map(|p| p.0).fold(1e-3, f64::max);
        let emin = pts
            .iter()
            .map(|p| p.1)
            .fold(target.unwrap_or(1.0), f64::min)
            .max(1e-8);
        let emax = pts.iter().map(|p| p.1).fold(emin * 10.0, f64::max);
        let (left, right, top, bottom) = PLOT_MARGINS;
        Self {
            width: f64::from(PLOT_SIZE.0),
            height: f64::from(PLOT_SIZE.1),
            left,
            right,
            top,
            bottom,
            tmax,
            decades: (emin.log10().floor(), emax.log10().ceil()),
        }
    }

    /// Pixel x of time `t`.
    fn x(&self, t: f64) -> f64 {
        self.left + (self.width - self.left - self.right) * t / self.tmax
    }

    /// Pixel y of error `e`.
    fn y(&self, e: f64) -> f64 {
        let (d0, d1) = self.decades;
        self.top
            + (self.height - self.top - self.bottom) * (d1 - e.max(1e-300).log10())
                / (d1 - d0).max(1.0)
    }

    /// Horizontal grid lines at the decades, labelled in %.
    fn draw_error_grid(&self, img: &mut image::RgbImage) {
        let (d0, d1) = self.decades;
        let mut d = d0;
        while d <= d1 + 1e-9 {
            let y = self.y(10f64.powf(d));
            line(img, (self.left, y), (self.width - self.right, y), GREY);
            let pct = 100.0 * 10f64.powf(d);
            let label = if pct >= 1.0 {
                format!("{pct:.0}%")
            } else {
                // 0.1%, 0.01%, … with as many decimals as the decade needs
                let decimals = (-pct.log10()).ceil().max(1.0) as usize;
                format!("{pct:.decimals$}%")
            };
            text(img, 5, y as i64 - 5, &label, LABEL_SCALE, BLACK);
            d += 1.0;
        }
    }

    /// Vertical grid lines at quarters of the time axis, labelled in s.
    fn draw_time_grid(&self, img: &mut image::RgbImage) {
        for k in 0..=4 {
            let tt = self.tmax * k as f64 / 4.0;
            let x = self.x(tt);
            line(img, (x, self.top), (x, self.height - self.bottom), GREY);
            let label = format!("{tt:.2}s");
            // the last label ends at the axis end instead of running off the image
            let shift = if k == 4 {
                12 * label.len() as i64 - 12
            } else {
                10
            };
            let y = self.height as i64 - self.bottom as i64 + 10;
            text(img, x as i64 - shift, y, &label, LABEL_SCALE, BLACK);
        }
    }

    /// Axis lines and titles.
    fn draw_axes(&self, img: &mut image::RgbImage) {
        let (w, h) = (self.width, self.height);
        text(img, 5, 5, "estimated error (log)", LABEL_SCALE, BLACK);
        text(
            img,
            (w as i64) / 2 - 84,
            h as i64 - 22,
            "wall time (s)",
            LABEL_SCALE,
            BLACK,
        );
        line(
            img,
            (self.left, self.top),
            (self.left, h - self.bottom),
            BLACK,
        );
        line(
            img,
            (self.left, h - self.bottom),
            (w - self.right, h - self.bottom),
            BLACK,
        );
    }

    /// A dashed line at the target error.
    fn draw_target(&self, img: &mut image::RgbImage, target: f64) {
        let y = self.y(target);
        let mut x = self.left;
        while x < self.width - self.right {
            line(img, (x, y), (x + 6.0, y), TARGET_GREEN);
            x += 12.0;
        }
    }

    /// One curve: each estimate holds until the next report, so steps, not slopes.
    fn draw_curve(&self, img: &mut image::RgbImage, curve: &ErrorCurve, col: [u8; 3]) {
        let mut prev: Option<(f64, f64)> = None;
        for p in &curve.points {
            if !(p.estimated_error > 0.0 && p.estimated_error.is_finite()) {
                continue;
            }
            let q = (self.x(p.time_s), self.y(p.estimated_error));
            if let Some(a) = prev {
                line(img, a, (q.0, a.1), col);
                line(img, (q.0, a.1), q, col);
            }
            prev = Some(q);
        }
    }
}

/// Plots estimated relative error (log scale, labelled in %) against wall time in s
/// for one or more curves (each with its colour) and writes a PNG.
pub fn plot_curves_png(
    curves: &[(&ErrorCurve, [u8; 3])],
    target: Option<f64>,
    path: &Path,
) -> Result<(), RadiosityError> {
    let mut img =
        image::RgbImage::from_pixel(PLOT_SIZE.0, PLOT_SIZE.1, image::Rgb([255, 255, 255]));
    let frame = PlotFrame::fit(curves, target);
    frame.draw_error_grid(&mut img);
    frame.draw_time_grid(&mut img);
    frame.draw_axes(&mut img);
    if let Some(tg) = target {
        frame.draw_target(&mut img, tg);
    }
    for (c, col) in curves {
        frame.draw_curve(&mut img, c, *col);
    }
    save_png(img, path)
}

/// Writes a tone-mapped sRGB preview PNG of an XYZ luminance image (exposure set so
/// that the 99th-percentile luminance maps to white). For looking, not measuring.
pub fn write_preview_png(
    img: &[[f32; 3]],
    width: usize,
    height: usize,
    path: &Path,
) -> Result<(), RadiosityError> {
    let mut ys: Vec<f32> = img.iter().map(|p| p[1]).filter(|y| *y > 0.0).collect();
    ys.sort_by(f32::total_cmp);
    let white = ys
        .get(ys.len() * 99 / 100)
        .copied()
        .unwrap_or(1.0)
        .max(1e-12) as f64;
    let enc = |v: f64| {
        let v = v.clamp(0.0, 1.0);
        let s = if v <= 0.003_130_8 {
            12.92 * v
        } else {
            1.055 * v.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0).round() as u8
    };
    let mut out = image::RgbImage::new(width as u32, height as u32);
    for (i, p) in img.iter().enumerate() {
        let (x, y, z) = (
            p[0] as f64 / white,
            p[1] as f64 / white,
            p[2] as f64 / white,
        );
        let r = 3.2406 * x - 1.5372 * y - 0.4986 * z;
        let g = -0.9689 * x + 1.8758 * y + 0.0415 * z;
        let b = 0.0557 * x - 0.2040 * y + 1.0570 * z;
        out.put_pixel(
            (i % width) as u32,
            (i / width) as u32,
            image::Rgb([enc(r), enc(g), enc(b)]),
        );
    }
    save_png(out, path)
}
