//! A radiosity solution seen on a tiled wall: every display renders the view-independent
//! solution from the viewer's eye through its own tile, an off-axis (asymmetric)
//! frustum, so that the tiles together show one continuous window into the scene.
//!
//! Coordinates: the wall's screen is the plane `z = 0` of the *wall frame*, `x` to the
//! right and `y` up from its lower-left corner, `z` towards the viewer, in metres; tile
//! `(col, row)` covers `[col·w, (col+1)·w] × [H − (row+1)·h, H − row·h]` (rows counted
//! from the top, as the wall file numbers them). The scene is placed behind the wall
//! by its camera ([`WallPlacement`]): the camera stands where the reference viewer
//! stands, looking at the wall's centre, metres for metres; a viewer who moves (a
//! tracked head) sees the scene from elsewhere, the wall staying where it is in the
//! scene.
//!
//! [`OffAxis`] projects a scene point through the eye onto a tile's rectangle (the
//! generalised perspective projection of Kooima 2008); [`render_tile`] rasterises a
//! [`LitMesh`] (the per-vertex luminance `lumiwall render` writes as PLY) with it,
//! z-buffered and perspective-correct, into an XYZ frame (Y in cd/m²) for the post
//! pass. Points on a seam project to the same scene point from both tiles, so the
//! frames continue across it exactly.

#[cfg(feature = "gpu")]
pub mod gpu;
pub mod mesh;
pub mod tracking;

pub use mesh::{LitMesh, MeshError};

use crate::radiosity::output::{Projected, rasterise};
use crate::scene::{Camera, V3};

/// Points closer to the eye than this (m, along the screen normal) are not drawn.
const NEAR_M: f64 = 1e-3;

/// Eye separation of an average adult (m), for stereo walls.
pub const DEFAULT_EYE_SEPARATION_M: f64 = 0.065;

/// The tile grid of a wall in metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallGeometry {
    /// Tile columns.
    pub cols: u32,
    /// Tile rows.
    pub rows: u32,
    /// Width of one tile (m).
    pub tile_width_m: f64,
    /// Height of one tile (m).
    pub tile_height_m: f64,
}

impl WallGeometry {
    /// Width of the whole wall (m).
    pub fn width_m(&self) -> f64 {
        f64::from(self.cols) * self.tile_width_m
    }

    /// Height of the whole wall (m).
    pub fn height_m(&self) -> f64 {
        f64::from(self.rows) * self.tile_height_m
    }

    /// The rectangle of tile `(col, row)` in the wall frame: lower-left corner, width
    /// and height (m).
    pub fn tile_rect(&self, col: u32, row: u32) -> ([f64; 2], f64, f64) {
        let x0 = f64::from(col) * self.tile_width_m;
        let y0 = self.height_m() - f64::from(row + 1) * self.tile_height_m;
        ([x0, y0], self.tile_width_m, self.tile_height_m)
    }

    /// The reference viewer: before the wall's centre at `distance_m`.
    pub fn centred_viewer(&self, distance_m: f64) -> V3 {
        V3::new(0.5 * self.width_m(), 0.5 * self.height_m(), distance_m)
    }
}

/// Where the wall stands in the scene: the scene camera's position is the reference
/// viewer's (`reference_viewer`, wall frame), its view axis goes through the wall
/// perpendicularly, its up is the wall's up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallPlacement {
    /// Scene position of the reference viewer.
    origin: V3,
    right: V3,
    up: V3,
    /// Towards the viewer (minus the camera's forward).
    back: V3,
    reference_viewer: V3,
}

impl WallPlacement {
    /// The wall placed by the scene's camera; `None` when the camera's view and up
    /// directions are degenerate.
    pub fn from_camera(camera: &Camera, reference_viewer: V3) -> Option<Self> {
        let forward = (camera.look_at - camera.position).try_normalize(1e-12)?;
        let right = forward.cross(&camera.up).try_normalize(1e-12)?;
        let up = right.cross(&forward);
        Some(Self {
            origin: camera.position,
            right,
            up,
            back: -forward,
            reference_viewer,
        })
    }

    /// The scene position of a point of the wall frame.
    pub fn to_scene(&self, wall: V3) -> V3 {
        let d = wall - self.reference_viewer;
        self.origin + self.right * d.x + self.up * d.y + self.back * d.z
    }

    /// The off-axis projection of tile `(col, row)` of `geometry` seen from `eye`
    /// (wall frame), `width_px` × `height_px`.
    pub fn tile_view(
        &self,
        geometry: &WallGeometry,
        col: u32,
        row: u32,
        eye: V3,
        size_px: (usize, usize),
    ) -> OffAxis {
        let ([x0, y0], w, h) = geometry.tile_rect(col, row);
        OffAxis {
            eye: self.to_scene(eye),
            corner: self.to_scene(V3::new(x0, y0, 0.0)),
            right: self.right,
            up: self.up,
            normal: self.back,
            width_m: w,
            height_m: h,
            width_px: size_px.0,
            height_px: size_px.1,
        }
    }
}

/// How far an eye sits from the point between the eyes along the head's x axis:
/// −half the separation for the left eye, +half for the right, 0 for a mono wall.
pub fn eye_offset_m(eye: lumiwall_profiles::Eye, separation_m: f64) -> f64 {
    match eye {
        lumiwall_profiles::Eye::Mono => 0.0,
        lumiwall_profiles::Eye::Left => -0.5 * separation_m,
        lumiwall_profiles::Eye::Right => 0.5 * separation_m,
    }
}

/// An asymmetric frustum from an eye through a rectangle (a tile) in the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OffAxis {
    /// The eye (scene).
    pub eye: V3,
    /// The rectangle's lower-left corner (scene).
    pub corner: V3,
    /// Unit vector along the rectangle's width.
    pub right: V3,
    /// Unit vector along its height.
    pub up: V3,
    /// Unit normal towards the eye.
    pub normal: V3,
    /// Width (m).
    pub width_m: f64,
    /// Height (m).
    pub height_m: f64,
    /// Image width (pixels).
    pub width_px: usize,
    /// Image height (pixels).
    pub height_px: usize,
}

impl OffAxis {
    /// Pixel position (x from the left, y from the top) and depth along the screen
    /// normal of a scene point, `None` behind the eye's near plane. The depth is what
    /// perspective-correct interpolation divides by: the projection is central onto a
    /// plane, so pixel coordinates are affine in the point over its depth.
    pub fn project(&self, p: &V3) -> Option<Projected> {
        let to_p = p - self.eye;
        let depth = -to_p.dot(&self.normal);
        if depth < NEAR_M {
            return None;
        }
        let eye_to_screen = (self.eye - self.corner).dot(&self.normal);
        let hit = self.eye + to_p * (eye_to_screen / depth);
        let s = (hit - self.corner).dot(&self.right) / self.width_m;
        let t = (hit - self.corner).dot(&self.up) / self.height_m;
        Some((
            s * self.width_px as f64,
            (1.0 - t) * self.height_px as f64,
            depth,
        ))
    }
}

/// `mesh` seen through `view`: XYZ luminance per pixel (cd/m²), row major from the
/// top-left, background 0. Faces seen from behind are not drawn (one-sided surfaces,
/// as `lumiwall render` draws them); a face with a vertex behind the eye is left out.
/// The rasteriser is `lumiwall render`'s own.
pub fn render_tile(mesh: &LitMesh, view: &OffAxis) -> Vec<[f32; 3]> {
    let size = (view.width_px, view.height_px);
    rasterise(mesh, &view.eye, size, |p| view.project(p))
}

#[cfg(test)]
mod tests;
