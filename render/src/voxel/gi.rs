//! Direct light and one bounce of indirect light over a camera's view, every
//! visibility decided by the voxel hierarchy (Thiedemann 2010, VPL near-field GI).
//!
//! Per frame: the scene is voxelised ([`super::voxelize`]); the camera's primary
//! rays find the visible surfaces exactly (a G-buffer, [`Surfel`]); the area emitters
//! are sampled at fixed points ([`LightSample`], shared by all pixels) and the
//! point-like lights are read from their intensity tables ([`super::points`]); light
//! paths leave the emitters and lights and where they first land (exact ray cast: Thiedemann takes
//! them from a reflective shadow map) a virtual point light ([`Vpl`]) keeps the
//! reflected flux. Each pixel then sums, with voxel visibility, the emitters'
//! illuminance and the VPLs' (Thiedemann eq. 6, `E = Φ/π · cosθ·cosθ′ / max(d², d_min²)`)
//! and shows `L = L_e + ρ/π · E` in cd/m² (XYZ). This is exactly the part of the
//! light a path tracer with at most two reflections (Mitsuba `max_depth` 3) sees.
//!
//! Shadow rays start one voxel diagonal off the surface along its normal and end one
//! voxel diagonal off the light (Thiedemann l.547–560), so a surface never shadows
//! itself; their first voxel diagonal is not tested either, because within about
//! that distance of a concave edge (a wall meeting the floor) the start lies in the
//! other surface's voxels. The price, shrinking with the voxel: occluders thinner
//! than that right at the receiver cast no shadow, rays nearly parallel to the other
//! surface still start in it (a narrower dark band along the edge), and light leaks
//! through walls thinner than a voxel diagonal. Skipping the first diagonal took the
//! error against Mitsuba at 64³ from 4.2 to 3.4 % (`voxel_gi_table.py`, frame 0).

use std::f64::consts::PI;
use std::time::Instant;

use rayon::prelude::*;

use super::grid::{GridError, VoxelGrid};
use super::points::{PointLights, PointSample};
use super::traverse::trace;
use super::voxelize::{scene_triangles, voxelize};
use crate::mesh::Bvh;
use crate::radiosity::quadrature::cosine_direction;
use crate::scene::{Camera, Scene, V3, polygon_area_m2, polygon_normal};

/// What a voxel GI frame is computed with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GiOptions {
    /// Voxels along the scene's longest axis (a power of two, 8–1024).
    pub resolution: u32,
    /// Fixed sample points on the area emitters, shared by every pixel.
    pub light_samples: u32,
    /// Light paths that leave VPLs (those that land on a front face do).
    pub vpl_paths: u32,
    /// Distance below which a VPL's illuminance stops growing (m); `None`: 5 % of
    /// the scene's extent.
    pub vpl_clamp_m: Option<f64>,
}

impl Default for GiOptions {
    fn default() -> Self {
        Self {
            resolution: 128,
            light_samples: 256,
            vpl_paths: 256,
            vpl_clamp_m: None,
        }
    }
}

/// Why a frame could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum GiError {
    /// The voxel grid could not be made.
    #[error(transparent)]
    Grid(#[from] GridError),
    /// More point-like lights than the tables hold.
    #[error(
        "the scene has {0} point-like lights; --method voxel-gi takes at most {max}",
        max = super::points::MAX_POINT_LIGHTS
    )]
    TooManyLights(usize),
    /// The scene is lit by daylight.
    #[error(
        "the scene is lit by daylight, which --method voxel-gi does not take; use --method radiosity"
    )]
    Daylight,
    /// Nothing emits.
    #[error("nothing in the scene emits light: give a material emission_cd_m2 or add [[lights]]")]
    NoEmitter,
    /// A count is zero or too large.
    #[error("{what} is {value}; it must be between 1 and {max}")]
    Count {
        /// Which option.
        what: &'static str,
        /// Its value.
        value: u64,
        /// Largest accepted.
        max: u64,
    },
    /// The camera has no pixels or too many.
    #[error(
        "a view of {0}×{1} pixels: each side must be 1 to 16384 and the image at most 16 Mpx (4096 × 4096)"
    )]
    Camera(u32, u32),
    /// The GPU path failed.
    #[error("GPU: {0}")]
    Gpu(String),
}

/// Most emitter samples or VPL paths.
pub const MAX_SAMPLES: u32 = 1 << 16;

/// The visible surface at a pixel.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Surfel {
    /// Position relative to the voxel grid's origin (m).
    pub p: [f32; 3],
    /// Front-side unit normal; zero where the pixel sees nothing or a back face.
    pub n: [f32; 3],
    /// Reflectance (XYZ).
    pub rho: [f32; 3],
    /// Emitted luminance (XYZ, cd/m²).
    pub le: [f32; 3],
}

/// A point on an area emitter: illuminance at distance r under cosines cθ, cθ′ is
/// `w·cθ·cθ′/r²`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightSample {
    /// Position relative to the voxel grid's origin (m).
    pub p: [f32; 3],
    /// Emitting side's unit normal.
    pub n: [f32; 3],
    /// Luminance times the emitter area the sample stands for (XYZ, cd).
    pub w: [f32; 3],
}

/// A virtual point light: a Lambertian reflector of flux `flux`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vpl {
    /// Position relative to the voxel grid's origin (m).
    pub p: [f32; 3],
    /// Unit normal of the reflecting side.
    pub n: [f32; 3],
    /// Reflected flux (XYZ, lm).
    pub flux: [f32; 3],
}

/// Seconds spent in each part of a frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GiTimings {
    /// Voxelisation and hierarchy.
    pub voxelize_s: f64,
    /// Primary visibility (G-buffer, exact ray cast on the CPU).
    pub gbuffer_s: f64,
    /// Emitter samples and VPLs (exact ray cast on the CPU).
    pub lights_s: f64,
    /// Direct and indirect light with voxel visibility.
    pub shade_s: f64,
}

/// A frame's light, ready for the CPU or the GPU: the voxel hierarchy, the emitter
/// samples and the VPLs (what does not depend on the view).
#[derive(Debug, Clone)]
pub struct GiLight {
    /// The voxel hierarchy (empty as [`prepare`] returns it).
    pub grid: VoxelGrid,
    /// Emitter samples.
    pub lights: Vec<LightSample>,
    /// VPLs.
    pub vpls: Vec<Vpl>,
    /// Point-like lights.
    pub points: Vec<PointSample>,
    /// Their intensity tables ([`super::points`]; one zero where there are none).
    pub tables: Vec<f32>,
    /// Square of the VPL clamp distance (m²).
    pub vpl_clamp2_m2: f32,
    /// Offset of ray ends from their surfaces (m): one voxel diagonal.
    pub offset_m: f32,
    /// Time of what was prepared.
    pub timings: GiTimings,
}

/// What one view sees: a surfel per pixel.
#[derive(Debug, Clone)]
pub struct GiView {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// One surfel per pixel, row major from the top left.
    pub surfels: Vec<Surfel>,
}

/// A lit frame.
#[derive(Debug, Clone)]
pub struct GiFrame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// XYZ luminance per pixel (cd/m²), row major from the top left.
    pub xyz: Vec<[f32; 3]>,
    /// Time per part.
    pub timings: GiTimings,
    /// Set voxels at level 0.
    pub occupied_voxels: u64,
    /// VPLs used.
    pub vpls: usize,
}

/// A frame prepared: its light (grid still empty), the triangles to voxelise (world
/// metres) and the exact first hits for views.
pub struct Prepared {
    /// The light.
    pub light: GiLight,
    /// The scene's triangles.
    pub tris: Vec<[[f64; 3]; 3]>,
    /// First hits of view rays.
    pub hits: SceneHits,
}

/// Checks the options and the scene and prepares a frame: the emitter samples and
/// the VPLs, the empty voxel grid and the triangles to voxelise into it.
pub fn prepare(scene: &Scene, opts: &GiOptions) -> Result<Prepared, GiError> {
    check(scene, opts)?;
    let mut timings = GiTimings::default();
    let (tris, owner) = scene_triangles(scene);
    let (min, max) = bounds(&tris);
    let grid = VoxelGrid::empty(min, max, opts.resolution)?;
    let started = Instant::now();
    let hits = SceneHits {
        bvh: Bvh::build(&tris),
        surfaces: Surfaces::new(scene, owner),
        origin: grid.origin,
    };
    let lights = light_samples(scene, opts.light_samples, grid.origin);
    let points = PointLights::of(scene, grid.origin);
    let vpls = vpls(scene, &hits, opts.vpl_paths, &points);
    timings.lights_s = started.elapsed().as_secs_f64();
    let clamp = opts.vpl_clamp_m.unwrap_or(0.05 * (max - min).max());
    let light = GiLight {
        offset_m: (3f64.sqrt() * grid.voxel_m) as f32,
        grid,
        lights,
        vpls,
        tables: if points.tables.is_empty() {
            vec![0.0]
        } else {
            points.tables
        },
        points: points.samples,
        vpl_clamp2_m2: (clamp * clamp) as f32,
        timings,
    };
    Ok(Prepared { light, tris, hits })
}

/// The whole frame of `camera` on the CPU ([`prepare`], the voxels, the G-buffer,
/// then [`shade`] for every pixel).
pub fn render_frame(scene: &Scene, camera: &Camera, opts: &GiOptions) -> Result<GiFrame, GiError> {
    let Prepared {
        mut light,
        tris,
        hits,
    } = prepare(scene, opts)?;
    let started = Instant::now();
    voxelize(&mut light.grid, &tris);
    light.timings.voxelize_s = started.elapsed().as_secs_f64();
    let started = Instant::now();
    let view = hits.pinhole(camera)?;
    light.timings.gbuffer_s = started.elapsed().as_secs_f64();
    let started = Instant::now();
    let xyz = shade_view(&light, &view);
    let mut timings = light.timings;
    timings.shade_s = started.elapsed().as_secs_f64();
    Ok(GiFrame {
        width: view.width,
        height: view.height,
        xyz,
        timings,
        occupied_voxels: light.grid.occupied_count(),
        vpls: light.vpls.len(),
    })
}

/// Every pixel of `view` shaded on the CPU.
pub fn shade_view(light: &GiLight, view: &GiView) -> Vec<[f32; 3]> {
    view.surfels.par_iter().map(|s| shade(light, s)).collect()
}

/// Whether this method can light `scene` with `opts` (no daylight, something that
/// emits, counts in range).
pub fn check(scene: &Scene, opts: &GiOptions) -> Result<(), GiError> {
    let n = opts.resolution;
    if !(super::MIN_RESOLUTION..=super::MAX_RESOLUTION).contains(&n) || !n.is_power_of_two() {
        return Err(GridError::Resolution(n).into());
    }
    if scene.lights.len() > super::points::MAX_POINT_LIGHTS {
        return Err(GiError::TooManyLights(scene.lights.len()));
    }
    if scene.sky.is_some() {
        return Err(GiError::Daylight);
    }
    if emitters(scene).0.is_empty() && !scene.lights.iter().any(|l| l.total_flux_lm() > 0.0) {
        return Err(GiError::NoEmitter);
    }
    for (what, value) in [
        ("--light-samples", opts.light_samples),
        ("--vpls", opts.vpl_paths),
    ] {
        if value == 0 || value > MAX_SAMPLES {
            return Err(GiError::Count {
                what,
                value: value.into(),
                max: MAX_SAMPLES.into(),
            });
        }
    }
    Ok(())
}

/// Most pixels of one view: a pixel takes about 130 bytes on its way through the
/// GPU (surfel, upload, output, readback), 2 GiB at this size (4096 × 4096).
pub const MAX_VIEW_PIXELS: u64 = 1 << 24;

/// Refuses a view size outside 1–16384 pixels a side or above [`MAX_VIEW_PIXELS`]
/// (checked before anything is allocated for it).
pub fn check_view_size(w: u32, h: u32) -> Result<(), GiError> {
    if !(1..=16384).contains(&w)
        || !(1..=16384).contains(&h)
        || u64::from(w) * u64::from(h) > MAX_VIEW_PIXELS
    {
        return Err(GiError::Camera(w, h));
    }
    Ok(())
}

/// The box around `tris`: lowest and highest corner.
pub(crate) fn bounds(tris: &[[[f64; 3]; 3]]) -> (V3, V3) {
    let corners: Vec<V3> = tris.iter().flatten().map(|&p| V3::from(p)).collect();
    crate::radiosity::shaft::bounds(&corners)
}

/// Per polygon: unit normal, reflectance and emission (f32), and triangle → polygon.
struct Surfaces {
    normal: Vec<[f32; 3]>,
    rho: Vec<[f32; 3]>,
    le: Vec<[f32; 3]>,
    owner: Vec<u32>,
}

impl Surfaces {
    fn new(scene: &Scene, owner: Vec<u32>) -> Self {
        let normal = scene
            .polygons
            .iter()
            .map(|p| polygon_normal(&p.vertices).map_or([0.0; 3], |n| f32v(&n)))
            .collect();
        let mat = |p: &crate::scene::Polygon| &scene.materials[p.material];
        Self {
            normal,
            rho: scene
                .polygons
                .iter()
                .map(|p| mat(p).reflectance_xyz.map(|v| v as f32))
                .collect(),
            le: scene
                .polygons
                .iter()
                .map(|p| mat(p).emission_cd_m2.map(|v| v as f32))
                .collect(),
            owner,
        }
    }

    /// The surfel where a ray from `o` along `d` first lands; a back face gives a
    /// surfel with a zero normal (one-sided surfaces reflect and emit nothing there).
    fn hit(&self, bvh: &Bvh, o: [f64; 3], d: [f64; 3], origin: [f64; 3]) -> Option<Surfel> {
        let h = bvh.intersect(o, d, f64::INFINITY)?;
        let poly = self.owner[h.triangle as usize] as usize;
        let p = std::array::from_fn(|a| (o[a] + h.t * d[a] - origin[a]) as f32);
        if !h.front_face {
            return Some(Surfel {
                p,
                ..Surfel::default()
            });
        }
        Some(Surfel {
            p,
            n: self.normal[poly],
            rho: self.rho[poly],
            le: self.le[poly],
        })
    }
}

fn f32v(v: &V3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// The scene's exact first hits: what a view sees, where light paths land.
pub struct SceneHits {
    bvh: Bvh,
    surfaces: Surfaces,
    /// The voxel grid's origin, which positions are taken relative to (so that they
    /// keep their precision in f32 far from the world's origin).
    origin: [f64; 3],
}

impl SceneHits {
    /// The surfel seen along each pixel's ray (`ray(x, y)`: origin and direction of
    /// the ray through pixel column x, row y from the top left).
    pub fn view(
        &self,
        width: u32,
        height: u32,
        ray: impl Fn(u32, u32) -> ([f64; 3], [f64; 3]) + Sync,
    ) -> Result<GiView, GiError> {
        check_view_size(width, height)?;
        let w = width as usize;
        let surfels = (0..w * height as usize)
            .into_par_iter()
            .map(|i| {
                let (o, d) = ray((i % w) as u32, (i / w) as u32);
                self.surfaces
                    .hit(&self.bvh, o, d, self.origin)
                    .unwrap_or_default()
            })
            .collect();
        Ok(GiView {
            width,
            height,
            surfels,
        })
    }

    /// The surfel seen through every pixel centre of `camera` (the radiosity
    /// images' pinhole).
    pub fn pinhole(&self, camera: &Camera) -> Result<GiView, GiError> {
        let (w, h) = (f64::from(camera.width_px), f64::from(camera.height_px));
        let forward = (camera.look_at - camera.position).normalize();
        let right = forward.cross(&camera.up).normalize();
        let up = right.cross(&forward);
        let focal_px = 0.5 * h / (0.5 * camera.vfov_deg.to_radians()).tan();
        let o = [camera.position.x, camera.position.y, camera.position.z];
        self.view(camera.width_px, camera.height_px, |x, y| {
            let (x, y) = (f64::from(x) + 0.5, f64::from(y) + 0.5);
            let d = forward + right * ((x - 0.5 * w) / focal_px) + up * ((0.5 * h - y) / focal_px);
            (o, [d.x, d.y, d.z])
        })
    }
}

/// The emitting polygons with their luminous flux (lm), for sampling by flux.
fn emitters(scene: &Scene) -> (Vec<usize>, Vec<f64>) {
    let mut idx = Vec::new();
    let mut flux = Vec::new();
    for (i, p) in scene.polygons.iter().enumerate() {
        let m = &scene.materials[p.material];
        let f = PI * m.emission_cd_m2[1] * polygon_area_m2(&p.vertices);
        if m.is_emitter() && f > 0.0 && polygon_normal(&p.vertices).is_some() {
            idx.push(i);
            flux.push(f);
        }
    }
    (idx, flux)
}

/// Radical inverse of `i` in base `b` (Halton).
fn halton(mut i: u32, b: u32) -> f64 {
    let (mut f, mut r) = (1.0, 0.0);
    while i > 0 {
        f /= f64::from(b);
        r += f * f64::from(i % b);
        i /= b;
    }
    r
}

/// Picks an index by its weight with `u` in [0, 1) (cumulative search).
fn pick(weights: &[f64], total: f64, u: f64) -> usize {
    let mut acc = 0.0;
    for (k, w) in weights.iter().enumerate() {
        acc += w;
        if u * total < acc {
            return k;
        }
    }
    weights.len() - 1
}

/// A point of polygon `v` (convex, fanned) from two uniform numbers.
fn point_on(v: &[V3], u1: f64, u2: f64) -> V3 {
    let areas: Vec<f64> = (1..v.len() - 1)
        .map(|k| (v[k] - v[0]).cross(&(v[k + 1] - v[0])).norm())
        .collect();
    let total: f64 = areas.iter().sum();
    let k = pick(&areas, total, u1);
    // u1 again, rescaled within the chosen triangle
    let before: f64 = areas[..k].iter().sum();
    let s = ((u1 * total - before) / areas[k].max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
    let (a, b) = (s.sqrt(), u2);
    v[0] * (1.0 - a) + v[k + 1] * (a * (1.0 - b)) + v[k + 2] * (a * b)
}

/// `count` emitter samples by flux (Halton points over each polygon's area).
fn light_samples(scene: &Scene, count: u32, origin: [f64; 3]) -> Vec<LightSample> {
    let (idx, flux) = emitters(scene);
    let total: f64 = flux.iter().sum();
    if idx.is_empty() {
        return Vec::new();
    }
    (0..count)
        .map(|i| {
            let k = pick(&flux, total, halton(i + 1, 2));
            let poly = &scene.polygons[idx[k]];
            let m = &scene.materials[poly.material];
            let p = point_on(&poly.vertices, halton(i + 1, 3), halton(i + 1, 5));
            let n = polygon_normal(&poly.vertices).unwrap_or_default();
            // each sample stands for total/count of the flux: area share A·(f_k/total)·…
            let share = polygon_area_m2(&poly.vertices) * total / (flux[k] * f64::from(count));
            LightSample {
                p: f32v(&(p - V3::from(origin))),
                n: f32v(&n),
                w: m.emission_cd_m2.map(|l| (l * share) as f32),
            }
        })
        .collect()
}

/// Light paths from the emitters (by flux, cosine-distributed); a VPL where each
/// first lands on a front face, carrying the reflected part of the path's flux.
/// Light paths from the area emitters (cosine-distributed) and the point-like lights
/// (by their tabulated power), each source chosen by flux; a VPL where each first
/// lands on a front face, carrying the reflected part of the path's flux.
fn vpls(scene: &Scene, hits: &SceneHits, paths: u32, points: &PointLights) -> Vec<Vpl> {
    let (idx, mut flux) = emitters(scene);
    let areas = idx.len();
    flux.extend((0..points.samples.len()).map(|k| points.flux_lm(k)));
    let total: f64 = flux.iter().sum();
    if total.is_nan() || total <= 0.0 {
        return Vec::new();
    }
    (0..paths)
        .into_par_iter()
        .filter_map(|i| {
            let k = pick(&flux, total, halton(i + 1, 2));
            let u = [3, 5, 7, 11].map(|b| halton(i + 1, b));
            // the path's start, direction and flux (XYZ lm): Φ_k / p(k) / paths
            let (o, d, f) = if k < areas {
                let poly = &scene.polygons[idx[k]];
                let m = &scene.materials[poly.material];
                let n = polygon_normal(&poly.vertices)?;
                let y = point_on(&poly.vertices, u[0], u[1]);
                let a = polygon_area_m2(&poly.vertices);
                let f: [f64; 3] = std::array::from_fn(|c| {
                    PI * m.emission_cd_m2[c] * a * total / (flux[k] * f64::from(paths))
                });
                (y + n * 1e-7, cosine_direction(&n, u[2], u[3]), f)
            } else {
                let light = &scene.lights[k - areas];
                let d = points.direction(k - areas, u[0], u[1], u[2]);
                let f = light.color_xyz.map(|c| c * total / f64::from(paths));
                (light.position, d, f)
            };
            let s = hits
                .surfaces
                .hit(&hits.bvh, [o.x, o.y, o.z], [d.x, d.y, d.z], hits.origin)?;
            if s.n == [0.0; 3] {
                return None;
            }
            Some(Vpl {
                p: s.p,
                n: s.n,
                flux: std::array::from_fn(|c| (f[c] * f64::from(s.rho[c])) as f32),
            })
        })
        .collect()
}

fn sub3(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot3(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn madd(a: [f32; 3], b: [f32; 3], s: f32) -> [f32; 3] {
    [a[0] + b[0] * s, a[1] + b[1] * s, a[2] + b[2] * s]
}

/// True when no set voxel lies on the segment from `a` to `b` (metres relative to the
/// grid's origin).
pub fn visible(grid: &VoxelGrid, a: [f32; 3], b: [f32; 3]) -> bool {
    let inv_h = grid.inv_voxel_f32();
    let o: [f32; 3] = a.map(|v| v * inv_h);
    let e: [f32; 3] = b.map(|v| v * inv_h);
    let d = sub3(e, o);
    // the first voxel diagonal is skipped: there the start may lie in the voxels of a
    // surface meeting the receiver at a concave edge
    let t0 = (SKIP_VOXELS / dot3(d, d).sqrt()).min(0.5);
    trace(grid, o, d, t0, 1.0).is_none()
}

/// Voxels (one voxel diagonal) at the start of a shadow ray in which nothing is
/// tested.
const SKIP_VOXELS: f32 = 1.732_050_8;

/// The luminance (XYZ, cd/m²) a pixel shows: the same steps as the WGSL `shade`
/// (its dispatches over chunks of [`shade_chunk`] samples included).
pub fn shade(g: &GiLight, s: &Surfel) -> [f32; 3] {
    if s.n == [0.0; 3] {
        return [0.0; 3];
    }
    let start = madd(s.p, s.n, g.offset_m);
    let add = |e: &mut [f32; 3], p: [f32; 3], n: [f32; 3], w: [f32; 3], clamp2: f32| {
        let v = sub3(p, s.p);
        let r2 = dot3(v, v);
        let r = r2.sqrt();
        let c = dot3(s.n, v) / r;
        let c2 = -dot3(n, v) / r;
        if !(c > 0.0 && c2 > 0.0) {
            return;
        }
        if visible(&g.grid, start, madd(p, n, g.offset_m)) {
            let k = c * c2 / r2.max(clamp2);
            *e = std::array::from_fn(|i| e[i] + w[i] * k);
        }
    };
    let inv_pi = std::f32::consts::FRAC_1_PI;
    let n_lights = g.lights.len();
    let n_area_vpl = n_lights + g.vpls.len();
    let total = n_area_vpl + g.points.len();
    let chunk = shade_chunk(g.grid.n);
    let mut out = s.le;
    for first in (0..total).step_by(chunk) {
        let mut e = [0.0f32; 3];
        for k in first..(first + chunk).min(total) {
            if let Some(l) = g.lights.get(k) {
                add(&mut e, l.p, l.n, l.w, 0.0);
            } else if let Some(v) = g.vpls.get(k - n_lights) {
                let flux = v.flux.map(|f| f * inv_pi);
                add(&mut e, v.p, v.n, flux, g.vpl_clamp2_m2);
            } else {
                point_light(&mut e, g, s, start, &g.points[k - n_area_vpl]);
            }
        }
        out = std::array::from_fn(|i| out[i] + s.rho[i] * inv_pi * e[i]);
    }
    out
}

/// Adds a point-like light's illuminance at surfel `s` (seen from `start`, off the
/// surface): its tabulated intensity towards the surfel, the ray ending one voxel
/// diagonal short of the light (a light mounted on a surface is not shadowed by it).
fn point_light(e: &mut [f32; 3], g: &GiLight, s: &Surfel, start: [f32; 3], l: &PointSample) {
    let v = sub3(l.p, s.p);
    let r2 = dot3(v, v);
    let r = r2.sqrt();
    let c = dot3(s.n, v) / r;
    if c.is_nan() || c <= 0.0 {
        return;
    }
    let out = [-v[0] / r, -v[1] / r, -v[2] / r];
    let i = super::points::intensity(&g.tables, l.table, out);
    if i > 0.0 && visible(&g.grid, start, madd(l.p, out, g.offset_m)) {
        let k = i * c / r2;
        *e = std::array::from_fn(|a| e[a] + l.color[a] * k);
    }
}

/// Samples (emitter samples, VPLs, then point lights) summed per step of the shading of a grid of
/// `n³` voxels, on the CPU as on the GPU (one dispatch each): llvmpipe caps the loop
/// iterations of one shader invocation at 65 535, so a chunk's traversals may take at
/// most that many steps together ([`super::step_cap`] each), at most 32 samples.
pub fn shade_chunk(n: u32) -> usize {
    (60_000 / (super::step_cap(n) + 2)).clamp(1, 32) as usize
}
