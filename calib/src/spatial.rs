//! The wall between the tile centres: the common white lowered so every texel of every
//! flat field can show it, and the spatial verification (ISO 14861-style grid per
//! display, seams between tiles, left against right eye).

use lumiwall_devices::sim::VirtualWall;
use lumiwall_devices::{DisplayInfo, Eye, Xyz};
use lumiwall_profiles::DisplayProfile;
use lumiwall_profiles::apply::{ApplyOptions, PreparedProfile};
use serde::{Deserialize, Serialize};

use crate::colorimetry::delta_e2000_xyz;
use crate::measure::Rig;
use crate::verify::{drive_for, expected_shown, median};

/// What strict uniformity cost: the common white's luminance before and after it was
/// lowered to fit the darkest texel of every display.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WhiteCost {
    /// Y of the common white at the spots (cd/m²) before.
    pub before_cd_m2: f64,
    /// Y after.
    pub after_cd_m2: f64,
}

/// Lowers the common white (every profile alike) so that, with its flat field, no
/// display needs more than its headroom anywhere: `usage_c / gain_c(texel) ≤ headroom`.
pub fn fit_white_to_flat_fields(profiles: &mut [DisplayProfile]) -> WhiteCost {
    let scale = flat_field_white_scale(profiles, |p| p.headroom);
    let before = profiles
        .first()
        .map_or(0.0, |p| p.target_white_xyz_cd_m2[1]);
    for p in profiles.iter_mut() {
        p.target_white_xyz_cd_m2 = p.target_white_xyz_cd_m2.map(|v| v * scale);
        p.channel_usage = p.channel_usage.map(|v| v * scale);
    }
    WhiteCost {
        before_cd_m2: before,
        after_cd_m2: before * scale,
    }
}

/// The factor (at most 1) the common white must be scaled by so that, with its flat
/// field, no display needs more than `limit(profile)` of full drive at any texel; 1
/// where every display reaches it (and for profiles without a flat field).
pub fn flat_field_white_scale(
    profiles: &[DisplayProfile],
    limit: impl Fn(&DisplayProfile) -> f64,
) -> f64 {
    let mut scale: f64 = 1.0;
    for p in profiles {
        let Some(ff) = &p.flat_field else { continue };
        let limit = limit(p);
        for c in 0..3 {
            let min_gain = ff
                .gain
                .iter()
                .map(|g| f64::from(g[c]))
                .fold(f64::INFINITY, f64::min);
            let need = p.channel_usage[c] / min_gain.max(1e-6);
            if need > limit {
                scale = scale.min(limit / need);
            }
        }
    }
    scale
}

/// How uniform the wall white must be across the wall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Uniformity {
    /// The same luminance everywhere: the common white drops to the darkest texel.
    Strict,
    /// A smooth luminance gradient below the visibility threshold is allowed (Majumder
    /// & Stevens, "perceptual photometric seamlessness"): the white at each point is
    /// the brightest `T(x) ≤ 1` every display can show there with
    /// `|Δ ln T| ≤ gradient_per_m · distance`, so bright centres keep their luminance.
    Perceptual {
        /// Largest relative luminance change per metre of wall.
        gradient_per_m: f64,
    },
}

impl Uniformity {
    /// The default perceptual bound: 1.5 % per degree seen from 2.5 m (≈ 34 % per m).
    pub const PERCEPTUAL_DEFAULT: Uniformity = Uniformity::Perceptual {
        gradient_per_m: 0.015 / (2.5 * std::f64::consts::PI / 180.0),
    };
}

/// What a uniformity choice keeps of the solved common white (cd/m²).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct UniformityCost {
    /// The solved common white at the spots, before any flat field.
    pub solved_cd_m2: f64,
    /// Strict: the white everywhere.
    pub strict_cd_m2: f64,
    /// Perceptual: the mean white over the wall.
    pub perceptual_mean_cd_m2: f64,
    /// Perceptual: the darkest point's white.
    pub perceptual_min_cd_m2: f64,
}

/// The fraction of the solved white each texel of each display can show
/// (`min_c headroom · gain_c / usage_c`), laid out on one wall-wide grid of texels
/// (both eyes of a tile share cells: the smaller counts). `None` without flat fields.
fn achievable_map(
    profiles: &[DisplayProfile],
    tiles: [u32; 2],
) -> Option<(Vec<f64>, [usize; 2], [u32; 2])> {
    let ff0 = profiles.first()?.flat_field.as_ref()?;
    let tex = [ff0.width, ff0.height];
    let (w, h) = ((tiles[0] * tex[0]) as usize, (tiles[1] * tex[1]) as usize);
    let mut a = vec![f64::INFINITY; w * h];
    for p in profiles {
        let ff = p
            .flat_field
            .as_ref()
            .filter(|f| [f.width, f.height] == tex)?;
        for (k, g) in ff.gain.iter().enumerate() {
            let (i, j) = (k % tex[0] as usize, k / tex[0] as usize);
            let x = p.display.tile_col as usize * tex[0] as usize + i;
            let y = p.display.tile_row as usize * tex[1] as usize + j;
            let can = (0..3)
                .map(|c| p.headroom * f64::from(g[c]) / p.channel_usage[c].max(1e-9))
                .fold(f64::INFINITY, f64::min);
            let cell = a.get_mut(y * w + x)?;
            *cell = cell.min(can);
        }
    }
    Some((a, [w, h], tex))
}

/// `T(x) = min(1, min_y A(y)·exp(δ·|x − y|))` by a two-pass chamfer distance transform
/// in the log domain (cell size `cell_m`).
fn perceptual_envelope(
    a: &[f64],
    size: [usize; 2],
    cell_m: [f64; 2],
    delta_per_m: f64,
) -> Vec<f64> {
    let [w, h] = size;
    let mut t: Vec<f64> = a.iter().map(|v| v.clamp(1e-9, 1.0).ln()).collect();
    let step = |dx: i64, dy: i64| {
        delta_per_m * ((dx as f64 * cell_m[0]).powi(2) + (dy as f64 * cell_m[1]).powi(2)).sqrt()
    };
    let forward = [(-1, 0), (-1, -1), (0, -1), (1, -1)];
    for pass in 0..2 {
        let sign = if pass == 0 { 1 } else { -1 };
        for n in 0..w * h {
            let k = if pass == 0 { n } else { w * h - 1 - n };
            let (x, y) = ((k % w) as i64, (k / w) as i64);
            for (dx, dy) in forward {
                let (nx, ny) = (x + sign * dx, y + sign * dy);
                if nx >= 0 && ny >= 0 && (nx as usize) < w && (ny as usize) < h {
                    let cand = t[ny as usize * w + nx as usize] + step(dx, dy);
                    if cand < t[k] {
                        t[k] = cand;
                    }
                }
            }
        }
    }
    t.into_iter().map(f64::exp).collect()
}

/// Applies a uniformity choice to profiles that carry flat fields (see
/// [`Uniformity`]); returns what each choice keeps of the white. `tiles` and
/// `tile_m` are the wall's tile grid and tile size (m).
pub fn apply_uniformity(
    profiles: &mut [DisplayProfile],
    mode: Uniformity,
    tiles: [u32; 2],
    tile_m: [f64; 2],
) -> UniformityCost {
    let solved = profiles
        .first()
        .map_or(0.0, |p| p.target_white_xyz_cd_m2[1]);
    let Some((a, size, tex)) = achievable_map(profiles, tiles) else {
        return UniformityCost {
            solved_cd_m2: solved,
            strict_cd_m2: solved,
            perceptual_mean_cd_m2: solved,
            perceptual_min_cd_m2: solved,
        };
    };
    let strict = a.iter().copied().fold(f64::INFINITY, f64::min).min(1.0);
    let delta = match mode {
        Uniformity::Perceptual { gradient_per_m } => gradient_per_m,
        Uniformity::Strict => match Uniformity::PERCEPTUAL_DEFAULT {
            Uniformity::Perceptual { gradient_per_m } => gradient_per_m,
            Uniformity::Strict => 0.0,
        },
    };
    let cell = [tile_m[0] / f64::from(tex[0]), tile_m[1] / f64::from(tex[1])];
    let t = perceptual_envelope(&a, size, cell, delta);
    let mean = t.iter().sum::<f64>() / t.len().max(1) as f64;
    let min = t.iter().copied().fold(f64::INFINITY, f64::min);
    let cost = UniformityCost {
        solved_cd_m2: solved,
        strict_cd_m2: solved * strict,
        perceptual_mean_cd_m2: solved * mean,
        perceptual_min_cd_m2: solved * min,
    };
    match mode {
        Uniformity::Strict => {
            fit_white_to_flat_fields(profiles);
        }
        Uniformity::Perceptual { .. } => shape_flat_fields(profiles, &t, size[0], tex),
    }
    cost
}

/// Divides every texel's gains by the wall's target fraction `T` there.
fn shape_flat_fields(profiles: &mut [DisplayProfile], t: &[f64], w: usize, tex: [u32; 2]) {
    for p in profiles.iter_mut() {
        let (col, row) = (p.display.tile_col as usize, p.display.tile_row as usize);
        let Some(ff) = p.flat_field.as_mut() else {
            continue;
        };
        for (k, g) in ff.gain.iter_mut().enumerate() {
            let (i, j) = (k % tex[0] as usize, k / tex[0] as usize);
            let cell = (row * tex[1] as usize + j) * w + col * tex[0] as usize + i;
            let f = t.get(cell).copied().unwrap_or(1.0).max(1e-6);
            *g = g.map(|v| {
                (f64::from(v) / f).clamp(1e-3, f64::from(lumiwall_profiles::FlatField::MAX_GAIN))
                    as f32
            });
        }
    }
}

/// The spatial verification's layout.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridOptions {
    /// Cells across and down per display (5×5 as ISO 14861).
    pub cells: [u32; 2],
    /// How far inside each border the seam points sit (display coordinates).
    pub seam_inset_uv: f64,
    /// Points along each border.
    pub seam_points: u32,
}

impl Default for GridOptions {
    fn default() -> Self {
        Self {
            cells: [5, 5],
            seam_inset_uv: 0.02,
            seam_points: 3,
        }
    }
}

/// One grid cell of one display.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellResult {
    /// Display index.
    pub display: u32,
    /// Eye.
    pub eye: Eye,
    /// Tile.
    pub tile: [u32; 2],
    /// Cell centre.
    pub uv: [f64; 2],
    /// What the display should show (the wall white).
    pub expected: Xyz,
    /// What was read.
    pub measured: Xyz,
    /// ΔE2000 against the expected.
    pub delta_e2000: f64,
}

/// One point pair across a border between two tiles (same eye).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SeamResult {
    /// The two displays.
    pub displays: [u32; 2],
    /// Eye.
    pub eye: Eye,
    /// ΔE2000 between the two sides.
    pub delta_e2000: f64,
}

/// The spatial verification of a wall.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpatialReport {
    /// Every cell.
    pub cells: Vec<CellResult>,
    /// Every seam point pair.
    pub seams: Vec<SeamResult>,
    /// Left against right eye at the same cells (Infitec walls), ΔE2000.
    pub eyes_delta_e2000: Vec<f64>,
}

fn stats(v: &[f64]) -> (f64, f64) {
    let mut s = v.to_vec();
    let m = if s.is_empty() { 0.0 } else { median(&mut s) };
    (m, v.iter().copied().fold(0.0, f64::max))
}

impl SpatialReport {
    /// ΔE2000 of every cell against the cell nearest its display's centre, as measured:
    /// the display's uniformity alone, without the error its centre already has (which
    /// the meter calibration, not the flat field, decides).
    pub fn uniformity_delta_e(&self) -> Vec<f64> {
        self.cells
            .iter()
            .filter_map(|c| {
                let centre = self
                    .cells
                    .iter()
                    .filter(|o| o.display == c.display)
                    .min_by(|a, b| {
                        let d = |x: &CellResult| (x.uv[0] - 0.5).powi(2) + (x.uv[1] - 0.5).powi(2);
                        d(a).total_cmp(&d(b))
                    })?;
                Some(delta_e2000_xyz(centre.measured, c.measured, c.expected))
            })
            .collect()
    }

    /// `OVERALL cells N median ΔE M max ΔE X seams median S max T` (and the eyes), then
    /// the uniformity against each display's centre.
    pub fn overall_line(&self) -> String {
        let de: Vec<f64> = self.cells.iter().map(|c| c.delta_e2000).collect();
        let seams: Vec<f64> = self.seams.iter().map(|s| s.delta_e2000).collect();
        let (m, x) = stats(&de);
        let (sm, sx) = stats(&seams);
        let mut line = format!(
            "OVERALL cells {} median ΔE {m:.2} max ΔE {x:.2} seams median {sm:.2} max {sx:.2}",
            de.len()
        );
        if !self.eyes_delta_e2000.is_empty() {
            let (em, ex) = stats(&self.eyes_delta_e2000);
            line.push_str(&format!(" eyes median {em:.2} max {ex:.2}"));
        }
        let (um, ux) = stats(&self.uniformity_delta_e());
        line.push_str(&format!(
            " | against each display's centre: median {um:.2} max {ux:.2}"
        ));
        line
    }

    /// One line per display: median and max cell ΔE2000.
    pub fn per_display_table(&self) -> String {
        let mut out = String::from("display  eye    cells  median ΔE  max ΔE\n");
        let mut ids: Vec<(u32, Eye)> = self.cells.iter().map(|c| (c.display, c.eye)).collect();
        ids.dedup();
        for (id, eye) in ids {
            let de: Vec<f64> = self
                .cells
                .iter()
                .filter(|c| c.display == id)
                .map(|c| c.delta_e2000)
                .collect();
            let (m, x) = stats(&de);
            out.push_str(&format!(
                "#{id:<7} {:<6} {:>5}  {m:>9.2}  {x:>6.2}\n",
                eye.to_string(),
                de.len()
            ));
        }
        out
    }

    /// A heat map of the wall (SVG): every cell coloured by its ΔE2000 (green 0,
    /// yellow 1, red ≥ 2), one panel per eye.
    pub fn heat_map_svg(&self, tiles: [u32; 2], cells: [u32; 2]) -> String {
        let cell_px = 18.0;
        let (tw, th) = (cell_px * f64::from(cells[0]), cell_px * f64::from(cells[1]));
        let mut eyes: Vec<Eye> = self.cells.iter().map(|c| c.eye).collect();
        eyes.dedup();
        let panel_w = tw * f64::from(tiles[0]) + 20.0;
        let height = th * f64::from(tiles[1]) + 40.0;
        let mut svg = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{height}\" font-family=\"sans-serif\" font-size=\"11\">\n",
            panel_w * eyes.len() as f64
        );
        svg.push_str("<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n");
        for (k, eye) in eyes.iter().enumerate() {
            let x0 = panel_w * k as f64;
            svg.push_str(&format!("<text x=\"{}\" y=\"14\">{eye} eye: ΔE2000 per cell (green 0, yellow 1, red ≥ 2)</text>\n", x0 + 2.0));
            for c in self.cells.iter().filter(|c| c.eye == *eye) {
                let x = x0 + f64::from(c.tile[0]) * tw + c.uv[0] * tw - cell_px / 2.0;
                let y = 20.0 + f64::from(c.tile[1]) * th + c.uv[1] * th - cell_px / 2.0;
                let t = (c.delta_e2000 / 2.0).clamp(0.0, 1.0);
                let (r, g) = if t < 0.5 {
                    (510.0 * t, 200.0)
                } else {
                    (255.0, 200.0 * (2.0 - 2.0 * t))
                };
                svg.push_str(&format!(
                    "<rect x=\"{x:.1}\" y=\"{y:.1}\" width=\"{cell_px}\" height=\"{cell_px}\" fill=\"rgb({r:.0},{g:.0},40)\" stroke=\"#333\" stroke-width=\"0.3\"><title>#{} uv {:.2},{:.2} ΔE {:.2}</title></rect>\n",
                    c.display, c.uv[0], c.uv[1], c.delta_e2000
                ));
            }
        }
        svg.push_str("</svg>\n");
        svg
    }
}

/// A meter of spots: the station's meter through the rig, or the simulator's truth.
pub trait SpotReader {
    /// XYZ at `uv` of `info` showing `drive`.
    fn read(&mut self, info: &DisplayInfo, uv: [f64; 2], drive: [f64; 3]) -> Result<Xyz, String>;

    /// Half-width (display coordinates) of the field a reading averages over, when the
    /// reader reads points and the field must be sampled (0: the reading is the field).
    fn field_half_uv(&self) -> f64 {
        0.0
    }
}

/// Half-width of a spot meter's measuring field in display coordinates for the
/// simulator's truth: 1 % of the display each way, about a 1° field at 2 m on a
/// 1.6 m tile. A real meter averages the display's pixels and their code steps over
/// such a field; a point would see one code.
pub const METER_FIELD_HALF_UV: f64 = 0.01;

impl SpotReader for Rig<'_> {
    fn read(&mut self, info: &DisplayInfo, uv: [f64; 2], drive: [f64; 3]) -> Result<Xyz, String> {
        self.pattern
            .show(info.id, drive)
            .map_err(|e| e.to_string())?;
        self.positioner
            .aim(info.id, uv)
            .map_err(|e| e.to_string())?;
        self.meter
            .measure()
            .map_err(|e| format!("{}: {e}", info.name))
    }
}

/// A reader whose readings go through the meter's display-type correction
/// ([`crate::measure::meter_matrix`]): the matrix of each display's eye (or its own).
pub struct MatrixCorrected<'m, R> {
    /// The reader corrected.
    pub inner: R,
    /// The matrices.
    pub matrices: &'m crate::measure::meter_matrix::MeterMatrices,
}

impl<R: SpotReader> SpotReader for MatrixCorrected<'_, R> {
    fn read(&mut self, info: &DisplayInfo, uv: [f64; 2], drive: [f64; 3]) -> Result<Xyz, String> {
        let xyz = self.inner.read(info, uv, drive)?;
        Ok(match self.matrices.for_display(info.id.0, info.eye) {
            Some(m) => crate::measure::meter_matrix::apply(&m, xyz),
            None => xyz,
        })
    }

    fn field_half_uv(&self) -> f64 {
        self.inner.field_half_uv()
    }
}

/// The virtual wall's own truth: what a perfect meter would read from the wall file's
/// meter position (no clock advance, no noise).
pub struct Truth<'w>(pub &'w VirtualWall);

impl SpotReader for Truth<'_> {
    fn read(&mut self, info: &DisplayInfo, uv: [f64; 2], drive: [f64; 3]) -> Result<Xyz, String> {
        self.0
            .emitted_xyz(info.id, drive, uv)
            .map_err(|e| e.to_string())
    }

    fn field_half_uv(&self) -> f64 {
        METER_FIELD_HALF_UV
    }
}

struct Prepared<'p> {
    info: &'p DisplayInfo,
    profile: &'p DisplayProfile,
    prep: PreparedProfile,
    white: Xyz,
    expected: Xyz,
}

impl Prepared<'_> {
    /// Reads the wall white at `uv` (averaged over the reader's field, 5×5 points,
    /// each shown through the post pass at its own position).
    fn read(&self, r: &mut dyn SpotReader, uv: [f64; 2]) -> Result<Xyz, String> {
        let half = r.field_half_uv();
        if half <= 0.0 {
            return r.read(self.info, uv, drive_for(&self.prep, self.white, uv));
        }
        let mut sum = Xyz::default();
        for k in 0..25 {
            let d = [f64::from(k % 5) - 2.0, f64::from(k / 5) - 2.0].map(|v| v / 2.0 * half);
            let q = [
                (uv[0] + d[0]).clamp(0.0, 1.0),
                (uv[1] + d[1]).clamp(0.0, 1.0),
            ];
            sum = sum + r.read(self.info, q, drive_for(&self.prep, self.white, q))?;
        }
        Ok(sum * (1.0 / 25.0))
    }
}

fn prepare<'p>(
    displays: &'p [DisplayInfo],
    profiles: &'p [DisplayProfile],
) -> Result<Vec<Prepared<'p>>, String> {
    displays
        .iter()
        .map(|info| {
            let profile = profiles
                .iter()
                .find(|p| p.display.display == info.id.0 && p.display.eye == info.eye)
                .ok_or_else(|| format!("no profile for {}", info.name))?;
            let prep = PreparedProfile::new(profile, &ApplyOptions::default())
                .map_err(|e| e.to_string())?;
            let white = Xyz::from_array(profile.target_white_xyz_cd_m2);
            Ok(Prepared {
                info,
                profile,
                prep,
                white,
                expected: expected_shown(profile, white),
            })
        })
        .collect()
}

/// Reads the wall white at a grid of cells on every display, at both sides of every
/// border, and (Infitec) compares the eyes at the same cells.
pub fn verify_grid(
    reader: &mut dyn SpotReader,
    displays: &[DisplayInfo],
    profiles: &[DisplayProfile],
    opts: &GridOptions,
) -> Result<SpatialReport, String> {
    let prepared = prepare(displays, profiles)?;
    let mut report = SpatialReport {
        cells: Vec::new(),
        seams: Vec::new(),
        eyes_delta_e2000: Vec::new(),
    };
    for p in &prepared {
        for j in 0..opts.cells[1] {
            for i in 0..opts.cells[0] {
                let uv = [
                    (f64::from(i) + 0.5) / f64::from(opts.cells[0]),
                    (f64::from(j) + 0.5) / f64::from(opts.cells[1]),
                ];
                let measured = p.read(reader, uv)?;
                report.cells.push(CellResult {
                    display: p.info.id.0,
                    eye: p.info.eye,
                    tile: [p.info.tile_col, p.info.tile_row],
                    uv,
                    expected: p.expected,
                    measured,
                    delta_e2000: delta_e2000_xyz(p.expected, measured, p.expected),
                });
            }
        }
        let _ = p.profile;
    }
    report.seams = seams(reader, &prepared, opts)?;
    report.eyes_delta_e2000 = eye_pairs(&report.cells);
    Ok(report)
}

fn seams(
    reader: &mut dyn SpotReader,
    prepared: &[Prepared<'_>],
    opts: &GridOptions,
) -> Result<Vec<SeamResult>, String> {
    let mut out = Vec::new();
    let d = opts.seam_inset_uv;
    for a in prepared {
        for (dc, dr) in [(1, 0), (0, 1)] {
            let Some(b) = prepared.iter().find(|b| {
                b.info.eye == a.info.eye
                    && b.info.tile_col == a.info.tile_col + dc
                    && b.info.tile_row == a.info.tile_row + dr
            }) else {
                continue;
            };
            for k in 0..opts.seam_points {
                let t = (f64::from(k) + 0.5) / f64::from(opts.seam_points);
                let (ua, ub) = if dc == 1 {
                    ([1.0 - d, t], [d, t])
                } else {
                    ([t, 1.0 - d], [t, d])
                };
                let (xa, xb) = (a.read(reader, ua)?, b.read(reader, ub)?);
                out.push(SeamResult {
                    displays: [a.info.id.0, b.info.id.0],
                    eye: a.info.eye,
                    delta_e2000: delta_e2000_xyz(xa, xb, a.expected),
                });
            }
        }
    }
    Ok(out)
}

fn eye_pairs(cells: &[CellResult]) -> Vec<f64> {
    cells
        .iter()
        .filter(|c| c.eye == Eye::Left)
        .filter_map(|l| {
            let r = cells
                .iter()
                .find(|r| r.eye == Eye::Right && r.tile == l.tile && r.uv == l.uv)?;
            Some(delta_e2000_xyz(l.measured, r.measured, l.expected))
        })
        .collect()
}

/// Dense truth: the wall white at every texel centre of a `grid` per display, read
/// from the simulator; per display the worst luminance error (%) against the expected
/// white and the worst Δxy.
pub fn dense_truth(
    wall: &VirtualWall,
    displays: &[DisplayInfo],
    profiles: &[DisplayProfile],
    grid: [u32; 2],
) -> Result<Vec<(u32, f64, f64)>, String> {
    let prepared = prepare(displays, profiles)?;
    let mut truth = Truth(wall);
    let mut out = Vec::new();
    for p in &prepared {
        let (mut dy, mut dxy) = (0.0f64, 0.0f64);
        let exy = p.expected.xy().unwrap_or([0.0; 2]);
        for j in 0..grid[1] {
            for i in 0..grid[0] {
                let uv = [
                    (f64::from(i) + 0.5) / f64::from(grid[0]),
                    (f64::from(j) + 0.5) / f64::from(grid[1]),
                ];
                let m = p.read(&mut truth, uv)?;
                dy = dy.max((100.0 * (m.y / p.expected.y - 1.0)).abs());
                let mxy = m.xy().unwrap_or([0.0; 2]);
                dxy = dxy.max(((mxy[0] - exy[0]).powi(2) + (mxy[1] - exy[1]).powi(2)).sqrt());
            }
        }
        out.push((p.info.id.0, dy, dxy));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::perceptual_envelope;

    #[test]
    fn perceptual_envelope_stays_below_what_each_point_can_show_and_changes_no_faster_than_allowed()
    {
        let (w, h) = (40usize, 20usize);
        let mut a = vec![1.2; w * h];
        a[10 * w + 20] = 0.5; // one dark corner of a display
        a[3 * w + 4] = 0.8;
        let cell = [0.05, 0.05];
        let delta = 2.0;
        let t = perceptual_envelope(&a, [w, h], cell, delta);
        for k in 0..w * h {
            assert!(
                t[k] <= a[k].min(1.0) + 1e-12,
                "T above what cell {k} can show"
            );
        }
        assert!((t[10 * w + 20] - 0.5).abs() < 1e-12);
        for y in 0..h {
            for x in 0..w - 1 {
                let d = (t[y * w + x].ln() - t[y * w + x + 1].ln()).abs();
                assert!(d <= delta * cell[0] + 1e-12, "gradient {d} at {x},{y}");
            }
        }
        // Far from the dark point the white is kept: perceptual costs less than strict.
        assert!((t[19 * w + 39] - 1.0).abs() < 1e-12);
        assert!(t.iter().sum::<f64>() / t.len() as f64 > 0.9);
    }
}
