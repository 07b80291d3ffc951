//! Per-display calibration profiles for lumiwall.
//!
//! A [`DisplayProfile`] holds everything the render-time post pass needs to turn
//! absolute CIE XYZ (Y in cd/m²) into the drive values of one display (one projector,
//! one eye): the XYZ→drive matrix, the black term of the chosen black mode, an optional
//! flat-field texture and the per-channel inverse tone curves. [`apply`] is the scalar
//! reference of that maths. The file format is versioned JSON (see `FORMAT.md` in this
//! crate); [`store`] keeps profiles with their history in SQLite.

pub mod apply;
pub mod error;
pub mod profile;
#[cfg(feature = "store")]
pub mod store;

pub use error::ProfileError;
pub use profile::*;
