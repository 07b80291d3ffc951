//! The virtual wall: a physically based, seeded, deterministic simulation of a tiled
//! projection wall (spectral projectors with optional Infitec comb filters, screen)
//! and of a spot colorimeter and a spectroradiometer reading it.
//!
//! Build one from a wall file ([`VirtualWall::from_toml_file`], files in
//! `fixtures/walls/`), then drive it through the device traits:
//! [`VirtualWall::pattern_output`] ([`crate::PatternOutput`]),
//! [`VirtualWall::positioner`] ([`crate::MeterPositioner`]) and
//! [`VirtualWall::meter`] ([`crate::Colorimeter`]). All handles share one state.
//!
//! Spectra are reduced to per-channel XYZ once per display with the CIE 1931 2°
//! observer ([`observer`]), so a reading costs microseconds.

pub mod camera;
pub mod curve;
pub mod meter;
pub mod observer;
pub mod projector;
pub mod screen;
pub mod spectra;
pub mod spectroradiometer;
pub mod wall;
pub mod wall_file;

pub use camera::{CameraPose, CameraSpec, VirtualCamera};
pub use curve::TransferCurve;
pub use meter::{MeterModel, SimMeter};
pub use spectroradiometer::{SimLampHolder, SimSpectroradiometer, SpectroModel};
pub use wall::{SimPatternOutput, SimPositioner, TruePrimaries, VirtualWall};
pub use wall_file::{NetworkSpec, OutputRoute, WallFile};
