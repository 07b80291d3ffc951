//! Calibration for lumiwall: colorimetry, measurement plans and the wall solve.
//!
//! Measures each display through the `lumiwall-devices` traits (never a port
//! directly), fits tone curves and their inverses, solves the common gamut, white and
//! black of the wall (Kresse 2003, 3.3) and produces one `DisplayProfile` per display
//! and eye; [`verify`] reads target colours back through the whole pipeline, and
//! [`recalibrate`] keeps a commissioned wall true night after night.

#[cfg(feature = "camera")]
pub mod camera;
pub mod cli_values;
pub mod colorimetry;
pub mod commission;
pub mod error;
pub mod export;
pub mod gamut;
pub mod measure;
pub mod recalibrate;
pub mod report;
pub mod solve;
pub mod spatial;
pub mod station;
pub mod tone;
pub mod verify;

pub use error::CalibError;
