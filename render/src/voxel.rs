//! Voxel-based global illumination for dynamic scenes (Thiedemann 2010), in absolute
//! photometric units like the radiosity output.
//!
//! Every frame the scene's triangles are voxelised into a binary grid ([`VoxelGrid`],
//! [`voxelize`]) whose OR-mipmaps form the hierarchy that rays traverse ([`trace`]):
//! empty cells of a coarse level are skipped whole, occupied ones are descended into.
//! [`gi`] lights a camera's view with it: direct light from area emitters and point
//! lights (isotropic, spot and goniometric, through intensity tables), and one bounce
//! of indirect light from virtual point lights (VPLs) placed
//! where the lights' rays first land (Thiedemann's reflective-shadow-map VPLs, found
//! here by exact ray casting), every visibility decided by the voxel hierarchy.
//! [`gpu`] does the voxelisation, the hierarchy and the shading with wgpu compute
//! passes; the CPU code is its reference (the traversal in the same f32 steps).
//!
//! Why compute passes and not the thesis's rasterisers: both of its voxelisers (the
//! texture atlas and the slice map) OR bits into a render target with the logic-op
//! blend of OpenGL, which WebGPU (wgpu) does not have. A compute pass that tests each
//! triangle against the voxels of its bounding box (Akenine-Möller's separating axes)
//! and `atomicOr`s the bits into a storage buffer is exact and conservative — no holes
//! at any atlas resolution — and needs no per-object UV atlas, so moving and
//! deforming objects cost nothing extra. The hierarchy is a full 3D OR-mip pyramid
//! (each level halves all three axes) rather than the thesis's 2D mipmap of 128-bit
//! columns: the depth resolution is not capped at 128 and no shortest-axis camera is
//! needed.

pub mod gi;
#[cfg(feature = "gpu")]
pub mod gpu;
mod grid;
pub mod points;
mod traverse;
mod voxelize;

pub use gi::{
    GiError, GiFrame, GiLight, GiOptions, GiTimings, GiView, MAX_VIEW_PIXELS, Prepared, SceneHits,
    check, check_view_size, prepare, render_frame, shade_view,
};
pub use grid::{GridError, MAX_RESOLUTION, MIN_RESOLUTION, VoxelGrid};
pub use traverse::{VoxelHit, step_cap, trace, trace_flat};
pub use voxelize::{OVERLAP_MARGIN, scene_triangles, tri_box_overlap, voxelize};

#[cfg(test)]
mod tests;
