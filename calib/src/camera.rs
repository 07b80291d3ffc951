//! Camera photometry (Kresse 2003, 3.4), anchored to the spot meter.
//!
//! The spot meter stays the reference; the camera supplies the spatial shape:
//! 1. [`hdr`]: the camera's response curve from an exposure series (Debevec–Malik,
//!    OpenCV `photo`) and HDR captures whose exposures are chosen so every pixel of
//!    interest is measured well exposed (codes 15..=250 of 255, as Kresse).
//! 2. [`registration`]: where every display lies in the camera image (projected dot
//!    grids, a homography per display and the lens's radial distortion, reprojection
//!    error printed).
//! 3. [`anchor`]: camera RGB → XYZ (per eye) and the camera lens's vignetting, fitted
//!    to meter readings of the same spots.
//! 4. [`flat`]: flat-field textures per display by a closed loop (show, photograph,
//!    ratio update) until the residual is below a threshold.
//! 5. [`nightly`]: the same loop as the nightly run's check, with the commissioning's
//!    calibration, measuring a flat field again only where it changed.

pub mod anchor;
pub mod checkpoint;
mod cv;
pub mod error;
pub mod flat;
pub mod hdr;
pub mod nightly;
pub mod registration;

pub use anchor::{CameraPhotometry, SpotAgreement, SpotPair};
pub use checkpoint::{Checkpoint, SavedCalibration};
pub use error::CameraCalibError;
pub use flat::{
    DisplayFlat, EIGHT_BIT_NOTE, FlatFieldOptions, FlatFieldOutcome, measure_flat_fields,
};
pub use hdr::{
    HdrImage, ResponseCurve, calibrate_response, capture_hdr, response_from_series, response_series,
};
pub use nightly::{FixedCamera, NightlyFlatOptions};
pub use registration::{DotGrid, Registration, check_still, register_displays};
