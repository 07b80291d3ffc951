//! The render-time post pass (Kresse 2003, 3.3.6–3.3.7, 3.4.4): linear XYZ frames
//! (Y in cd/m²) → code values of one display and eye, through its `DisplayProfile`.
//!
//! The per-pixel maths is [`lumiwall_profiles::apply`]; [`cpu`] runs it over frames with
//! rayon (the reference), [`gpu`] as a wgpu compute shader (feature `gpu`). One profile
//! per display and eye: a mono wall has one profile per display and does no per-eye
//! work; a profile without a flat-field texture does no texture fetch. [`io`] reads EXR
//! and sRGB PNG input and writes PNG output; [`wall`] cuts a wall's frame into its
//! displays' tiles and routes each eye's frame; [`scale`] is the stated luminance scale
//! between a scene and the wall.

pub mod cpu;
#[cfg(target_arch = "x86_64")]
mod cpu_avx2;
pub mod error;
pub mod frame;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod io;
pub mod scale;
pub mod wall;

pub use cpu::{apply_cpu, apply_cpu_into};
pub use error::PostError;
pub use frame::{CodeImage, FlagCounts, XyzFrame};
#[cfg(feature = "gpu")]
pub use gpu::{GpuPost, GpuProfile};
