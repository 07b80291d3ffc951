//! What can go wrong with the camera, in words a technician can act on.

use lumiwall_devices::DeviceError;

/// Errors of camera calibration and flat-field measurement.
#[derive(Debug, thiserror::Error)]
pub enum CameraCalibError {
    /// The camera, the pattern output or the meter failed.
    #[error("{what}: {source}")]
    Device {
        /// What the station was doing.
        what: String,
        /// The device's error.
        #[source]
        source: DeviceError,
    },
    /// OpenCV refused an operation (a bug or an unusable image).
    #[error("OpenCV, while {what}: {message}")]
    OpenCv {
        /// What the station was doing.
        what: String,
        /// OpenCV's message.
        message: String,
    },
    /// Even the shortest exposure saturates where the camera must measure.
    #[error(
        "{what}: saturated even at the shortest exposure {exposure_s} s; put a neutral-density \
         filter on the camera or stop the lens down"
    )]
    Saturated {
        /// What was being captured.
        what: String,
        /// The shortest exposure tried (s).
        exposure_s: f64,
    },
    /// The display shows no light to the camera.
    #[error(
        "{display}: the camera sees no light from it (signal {signal:.3} of the expected); is \
         the projector on, its shutter open, and is it in the camera's view?"
    )]
    NoLight {
        /// Display name.
        display: String,
        /// Signal found, relative to what the exposure should have given.
        signal: f64,
    },
    /// The registration pattern was not found as expected.
    #[error(
        "{display}: found {found} of the {expected} registration dots in the camera image; \
         check that the display is in view, focused, and not washed out by room light"
    )]
    Registration {
        /// Display name.
        display: String,
        /// Dots found.
        found: usize,
        /// Dots shown.
        expected: usize,
    },
    /// The camera moved since the registration.
    #[error(
        "the camera moved: {display}'s registration dots are {shift_px:.2} px away from where \
         they were registered (limit {limit_px} px); fix the tripod and start the camera \
         stage again"
    )]
    Moved {
        /// Display checked.
        display: String,
        /// Largest shift (px).
        shift_px: f64,
        /// Tolerated shift (px).
        limit_px: f64,
    },
    /// A fit had too little or degenerate data.
    #[error("{0}")]
    Fit(String),
}

impl CameraCalibError {
    /// Wraps a device error with what the station was doing.
    pub fn device(what: impl Into<String>) -> impl FnOnce(DeviceError) -> Self {
        let what = what.into();
        move |source| Self::Device { what, source }
    }
}
