//! Point-like lights (isotropic, spot, goniometric) for the voxel GI: each light's
//! luminous intensity is tabulated over the sphere (world directions, longitude ×
//! colatitude, [`TABLE_W`] × [`TABLE_H`]) and read back with bilinear interpolation
//! ([`intensity`], the WGSL `point_intensity`), so any distribution reaches the
//! shader the same way; VPL paths leave a light in proportion to the table's power.
//! A spot's edge is blurred over about one texel (1.4°).

use std::f64::consts::{PI, TAU};

use crate::scene::{Scene, V3};

/// Texels in longitude (φ = atan2(z, x)).
pub const TABLE_W: usize = 256;
/// Texels in colatitude (θ from +y).
pub const TABLE_H: usize = 128;
/// Most point-like lights (their tables take 128 KiB each).
pub const MAX_POINT_LIGHTS: usize = 256;

/// A point-like light as the shading sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointSample {
    /// Position relative to the voxel grid's origin (m).
    pub p: [f32; 3],
    /// Colour (XYZ relative to Y = 1).
    pub color: [f32; 3],
    /// First value of its intensity table in the tables array.
    pub table: u32,
}

/// The scene's point-like lights, tabulated.
#[derive(Debug, Clone, Default)]
pub struct PointLights {
    /// One per light.
    pub samples: Vec<PointSample>,
    /// Every light's table (cd), [`TABLE_W`] × [`TABLE_H`] each, row major by θ.
    pub tables: Vec<f32>,
    /// Per light the cumulative power of its texels (lm), for sampling directions.
    cdf: Vec<Vec<f64>>,
}

/// Unit direction through the centre of texel (i, j).
fn texel_direction(i: usize, j: usize) -> V3 {
    let phi = ((i as f64 + 0.5) / TABLE_W as f64 - 0.5) * TAU;
    let theta = (j as f64 + 0.5) / TABLE_H as f64 * PI;
    V3::new(
        theta.sin() * phi.cos(),
        theta.cos(),
        theta.sin() * phi.sin(),
    )
}

/// Solid angle of a texel of row j (sr).
fn texel_solid_angle(j: usize) -> f64 {
    let (t0, t1) = (
        j as f64 / TABLE_H as f64 * PI,
        (j + 1) as f64 / TABLE_H as f64 * PI,
    );
    TAU / TABLE_W as f64 * (t0.cos() - t1.cos())
}

impl PointLights {
    /// Tabulates every light of `scene`; positions relative to `origin`.
    pub fn of(scene: &Scene, origin: [f64; 3]) -> Self {
        let mut out = PointLights::default();
        for light in &scene.lights {
            let table: Vec<f32> = (0..TABLE_H)
                .flat_map(|j| (0..TABLE_W).map(move |i| (i, j)))
                .map(|(i, j)| light.intensity_cd(&texel_direction(i, j)) as f32)
                .collect();
            let mut acc = 0.0;
            let cdf = table
                .iter()
                .enumerate()
                .map(|(k, &v)| {
                    acc += f64::from(v) * texel_solid_angle(k / TABLE_W);
                    acc
                })
                .collect();
            out.samples.push(PointSample {
                p: std::array::from_fn(|a| (light.position[a] - origin[a]) as f32),
                color: light.color_xyz.map(|c| c as f32),
                table: out.tables.len() as u32,
            });
            out.tables.extend(table);
            out.cdf.push(cdf);
        }
        out
    }

    /// Luminous flux of light `k` as tabulated (lm).
    pub fn flux_lm(&self, k: usize) -> f64 {
        self.cdf[k].last().copied().unwrap_or(0.0)
    }

    /// A direction from light `k` drawn in proportion to its tabulated power from
    /// three uniform numbers.
    pub fn direction(&self, k: usize, u1: f64, u2: f64, u3: f64) -> V3 {
        let cdf = &self.cdf[k];
        let total = self.flux_lm(k);
        let texel = cdf.partition_point(|&c| c <= u1 * total).min(cdf.len() - 1);
        let (i, j) = (texel % TABLE_W, texel / TABLE_W);
        let phi = ((i as f64 + u2) / TABLE_W as f64 - 0.5) * TAU;
        let (c0, c1) = (
            (j as f64 / TABLE_H as f64 * PI).cos(),
            ((j + 1) as f64 / TABLE_H as f64 * PI).cos(),
        );
        let cos_t = c0 + (c1 - c0) * u3;
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        V3::new(sin_t * phi.cos(), cos_t, sin_t * phi.sin())
    }
}

/// Intensity (cd) of the table at `offset` towards unit direction `d`: bilinear,
/// wrapping in longitude and clamped in colatitude; the same steps as the WGSL
/// `point_intensity`.
pub fn intensity(tables: &[f32], offset: u32, d: [f32; 3]) -> f32 {
    let (w, h) = (TABLE_W as f32, TABLE_H as f32);
    let phi = d[2].atan2(d[0]);
    let theta = d[1].clamp(-1.0, 1.0).acos();
    let u = (phi / std::f32::consts::TAU + 0.5) * w - 0.5;
    let v = (theta / std::f32::consts::PI * h - 0.5).clamp(0.0, h - 1.0);
    let (u0, v0) = (u.floor(), v.floor());
    let (fu, fv) = (u - u0, v - v0);
    let wrap = |x: f32| (x.rem_euclid(w)) as usize;
    let (i0, i1) = (wrap(u0), wrap(u0 + 1.0));
    let j0 = v0 as usize;
    let j1 = (j0 + 1).min(TABLE_H - 1);
    let at = |i: usize, j: usize| tables[offset as usize + j * TABLE_W + i];
    let top = at(i0, j0) * (1.0 - fu) + at(i1, j0) * fu;
    let bottom = at(i0, j1) * (1.0 - fu) + at(i1, j1) * fu;
    top * (1.0 - fv) + bottom * fv
}
