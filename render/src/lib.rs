//! The photometric renderer of lumiwall and the per-display post pass.
//!
//! [`post`] turns linear XYZ images (Y in cd/m²) into display drive values through a
//! `DisplayProfile` (CPU reference and wgpu). [`scene`], [`photometry`] and [`mesh`]
//! describe what is lit and by what; [`radiosity`] computes it in absolute photometric
//! units; [`view`] shows a solution on a tiled wall, one off-axis frustum per display.

pub mod mesh;
pub mod photometry;
pub mod post;
pub mod radiosity;
pub mod rng;
pub mod scene;
pub mod view;
#[cfg(feature = "voxel-gi")]
pub mod voxel;
