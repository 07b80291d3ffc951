//! `lumiwall bench view`: frame time per display of the wall viewer on a generated
//! scene of a given triangle count (the 100 000-triangle target of issue 16): every
//! display of a tiled wall rasterises the lit mesh through its own off-axis tile
//! (wgpu where an adapter exists, lavapipe in CI, and the CPU reference), then runs
//! the post pass of a display profile (GPU with the GPU rasteriser, AVX2 CPU with the
//! CPU one). Printed per rasteriser: raster and post-pass time per display (median,
//! max over displays, best of the repeats) and the frame rate that allows, against
//! 60 Hz.

use std::fmt;
use std::time::Instant;

use lumiwall_profiles::apply::PreparedProfile;
use lumiwall_profiles::apply::model::AnalyticDisplay;
use lumiwall_render::mesh::generate_scale_scene;
use lumiwall_render::post::{PostError, XyzFrame, apply_cpu};
use lumiwall_render::scene::{Camera, V3};
use lumiwall_render::view::{LitMesh, OffAxis, WallGeometry, WallPlacement, render_tile};

/// What to measure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ViewBenchOptions {
    /// Triangles of the generated scene (at least).
    pub triangles: usize,
    /// Tile columns and rows of the wall.
    pub tiles: (u32, u32),
    /// Pixels of each display.
    pub size: (u32, u32),
    /// Timed repetitions per display (the best counts).
    pub repeats: u32,
    /// Measure the GPU row too (when built with the `gpu` feature).
    pub gpu: bool,
}

/// One rasteriser's times per display, ms.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewRow {
    /// Rasteriser and post pass that ran.
    pub name: String,
    /// Raster time of every display, ms.
    pub raster_ms: Vec<f64>,
    /// Post-pass time of every display, ms.
    pub post_ms: Vec<f64>,
    /// Share of the pixels of all displays that show the scene (not background).
    pub lit_share: f64,
}

/// Results of `lumiwall bench view`.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewBench {
    /// The options measured with.
    pub options: ViewBenchOptions,
    /// Triangles of the generated mesh.
    pub triangles: usize,
    /// One row per rasteriser.
    pub rows: Vec<ViewRow>,
    /// Why there is no GPU row, if one was asked for.
    pub gpu_note: Option<String>,
}

/// The target frame rate per display.
const TARGET_HZ: f64 = 60.0;

/// Bit depth of the displays' codes.
const BITS: u32 = 10;

/// Runs the benchmark.
pub fn run(opts: ViewBenchOptions) -> Result<ViewBench, PostError> {
    let mesh = lit_mesh(opts.triangles);
    let triangles = mesh.faces.len();
    let (place, geometry, viewer) = wall_inside(&mesh, opts.tiles)?;
    let views: Vec<OffAxis> = (0..opts.tiles.1)
        .flat_map(|row| (0..opts.tiles.0).map(move |col| (col, row)))
        .map(|(c, r)| {
            place.tile_view(
                &geometry,
                c,
                r,
                viewer,
                (opts.size.0 as usize, opts.size.1 as usize),
            )
        })
        .collect();
    let d = AnalyticDisplay::infitec_example();
    let profile = crate::apply::prepared(&d, true, BITS, true)?;
    let mut rows = vec![cpu_row(&mesh, &views, &profile, opts)?];
    let mut gpu_note = None;
    if opts.gpu {
        match gpu_row(&mesh, &views, &profile, opts)? {
            Ok(row) => rows.push(row),
            Err(note) => gpu_note = Some(note),
        }
    }
    Ok(ViewBench {
        options: opts,
        triangles,
        rows,
        gpu_note,
    })
}

/// The generated scene as a lit mesh: luminance a smooth function of position (the
/// raster cost does not depend on the values).
fn lit_mesh(triangles: usize) -> LitMesh {
    let g = generate_scale_scene(triangles, 1, 7);
    let positions: Vec<V3> = g
        .mesh
        .positions
        .iter()
        .map(|p| V3::new(p[0], p[1], p[2]))
        .collect();
    let luminance_xyz = positions
        .iter()
        .map(|p| {
            let y = 20.0 + 10.0 * (0.3 * p.x).sin() + 5.0 * (0.5 * p.z).cos();
            [0.95 * y, y, 1.05 * y]
        })
        .collect();
    let faces = g.mesh.triangles.iter().map(|t| t.to_vec()).collect();
    LitMesh {
        positions,
        luminance_xyz,
        faces,
    }
}

/// A 4 m × 2.25 m per tile wall placed in the generated nave: the reference viewer
/// stands 1 m into it at eye height, looking along it.
fn wall_inside(
    mesh: &LitMesh,
    tiles: (u32, u32),
) -> Result<(WallPlacement, WallGeometry, V3), PostError> {
    let (mut lo, mut hi) = (V3::repeat(f64::INFINITY), V3::repeat(f64::NEG_INFINITY));
    for p in &mesh.positions {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    let centre = (lo + hi) / 2.0;
    let eye = V3::new(lo.x + 1.0, centre.y, lo.z + 1.7);
    let camera = Camera {
        position: eye,
        look_at: V3::new(hi.x, centre.y, lo.z + 1.7),
        up: V3::z(),
        vfov_deg: 60.0,
        width_px: 1,
        height_px: 1,
    };
    let geometry = WallGeometry {
        cols: tiles.0.max(1),
        rows: tiles.1.max(1),
        tile_width_m: 4.0 / f64::from(tiles.0.max(1)),
        tile_height_m: 2.25 / f64::from(tiles.1.max(1)),
    };
    let viewer = geometry.centred_viewer(2.0);
    let place = WallPlacement::from_camera(&camera, viewer)
        .ok_or_else(|| PostError::SizeMismatch("the bench camera is degenerate".into()))?;
    Ok((place, geometry, viewer))
}

/// Best time of `repeats` runs of `f`, ms, and its last result.
fn best_ms<T>(
    repeats: u32,
    mut f: impl FnMut() -> Result<T, PostError>,
) -> Result<(f64, T), PostError> {
    let mut best = f64::INFINITY;
    let mut last = None;
    for _ in 0..repeats.max(1) {
        let t0 = Instant::now();
        let out = f()?;
        best = best.min(t0.elapsed().as_secs_f64() * 1e3);
        last = Some(out);
    }
    Ok((best, last.expect("at least one run")))
}

fn cpu_row(
    mesh: &LitMesh,
    views: &[OffAxis],
    profile: &PreparedProfile,
    opts: ViewBenchOptions,
) -> Result<ViewRow, PostError> {
    let mut row = ViewRow {
        name: format!(
            "CPU ({} threads), AVX2 post pass",
            rayon::current_num_threads()
        ),
        raster_ms: Vec::new(),
        post_ms: Vec::new(),
        lit_share: 0.0,
    };
    for view in views {
        let (raster, pixels) = best_ms(opts.repeats, || Ok(render_tile(mesh, view)))?;
        row.lit_share += lit_share(&pixels) / views.len() as f64;
        let frame = XyzFrame::new(opts.size.0, opts.size.1, pixels)?;
        let (post, _) = best_ms(opts.repeats, || Ok(apply_cpu(profile, &frame)))?;
        row.raster_ms.push(raster);
        row.post_ms.push(post);
    }
    Ok(row)
}

#[cfg(feature = "gpu")]
fn gpu_row(
    mesh: &LitMesh,
    views: &[OffAxis],
    profile: &PreparedProfile,
    opts: ViewBenchOptions,
) -> Result<Result<ViewRow, String>, PostError> {
    let raster = match lumiwall_render::view::gpu::GpuRaster::new(mesh) {
        Ok(r) => r,
        Err(e) => return Ok(Err(format!("GPU: {e} (no GPU row)"))),
    };
    let post = match lumiwall_render::post::GpuPost::new() {
        Ok(g) => g,
        Err(e) => return Ok(Err(format!("GPU: {e} (no GPU row)"))),
    };
    let mut gp = post.prepare(profile);
    let mut row = ViewRow {
        name: format!("GPU {}, GPU post pass incl. transfers", post.adapter_name()),
        raster_ms: Vec::new(),
        post_ms: Vec::new(),
        lit_share: 0.0,
    };
    raster.render(&views[0])?; // warm-up
    for view in views {
        let (ms, pixels) = best_ms(opts.repeats, || raster.render(view))?;
        row.lit_share += lit_share(&pixels) / views.len() as f64;
        let frame = XyzFrame::new(opts.size.0, opts.size.1, pixels)?;
        gp.apply(&frame)?; // warm-up at this size
        let (post_ms, _) = best_ms(opts.repeats, || gp.apply(&frame))?;
        row.raster_ms.push(ms);
        row.post_ms.push(post_ms);
    }
    Ok(Ok(row))
}

/// Without the `gpu` feature there is no GPU row.
#[cfg(not(feature = "gpu"))]
fn gpu_row(
    _: &LitMesh,
    _: &[OffAxis],
    _: &PreparedProfile,
    _: ViewBenchOptions,
) -> Result<Result<ViewRow, String>, PostError> {
    Ok(Err("built without the gpu feature (no GPU row)".into()))
}

/// Share of pixels with light.
fn lit_share(pixels: &[[f32; 3]]) -> f64 {
    pixels.iter().filter(|p| p[1] > 0.0).count() as f64 / pixels.len().max(1) as f64
}

/// Median and largest of `v`.
fn median_max(v: &[f64]) -> (f64, f64) {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    (
        s.get(s.len() / 2).copied().unwrap_or(0.0),
        s.last().copied().unwrap_or(0.0),
    )
}

impl fmt::Display for ViewBench {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let o = &self.options;
        writeln!(
            f,
            "wall viewer: {} triangles, {}×{} displays of {}×{} px, best of {} runs per display",
            self.triangles, o.tiles.0, o.tiles.1, o.size.0, o.size.1, o.repeats
        )?;
        writeln!(
            f,
            "{:<52} {:>16} {:>16} {:>10} {:>8} {:>6}",
            "rasteriser", "raster med/max ms", "post med/max ms", "frames/s", "60 Hz", "lit %"
        )?;
        for r in &self.rows {
            let (rm, rx) = median_max(&r.raster_ms);
            let (pm, px) = median_max(&r.post_ms);
            let hz = 1e3 / (rm + pm).max(1e-9);
            let verdict = if hz >= TARGET_HZ { "meet" } else { "miss" };
            let name: String = r.name.chars().take(52).collect();
            writeln!(
                f,
                "{name:<52} {:>16} {:>16} {hz:>10.1} {verdict:>8} {:>6.1}",
                format!("{rm:.2} / {rx:.2}"),
                format!("{pm:.2} / {px:.2}"),
                100.0 * r.lit_share
            )?;
        }
        if let Some(note) = &self.gpu_note {
            writeln!(f, "{note}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_display_of_the_bench_wall_sees_the_generated_scene() {
        let b = run(ViewBenchOptions {
            triangles: 2_000,
            tiles: (2, 2),
            size: (64, 48),
            repeats: 1,
            gpu: false,
        })
        .unwrap();
        let cpu = &b.rows[0];
        assert_eq!(cpu.raster_ms.len(), 4);
        assert!(cpu.lit_share > 0.95, "{}", cpu.lit_share);
        assert!(b.to_string().contains("60 Hz"));
    }
}
