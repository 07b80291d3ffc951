//! Instruments and displays for lumiwall.
//!
//! The traits [`Colorimeter`], [`PatternOutput`] and [`MeterPositioner`] are all that
//! the calibration code sees of the hardware. Real drivers live in [`serial`]
//! (colorimeters over a serial port); [`sim`] is the virtual wall: simulated
//! projectors, screen and meter, the embedded default so that everything runs and is
//! tested without hardware. [`xyz`] holds the measured quantity and the CIE 1931
//! observer used to integrate spectra; [`averaging`] a meter whose readings are each
//! the mean of several (a dim wall's); [`spectral`] what a spectroradiometer measures
//! ([`Spectroradiometer`]), and [`line_lamp`] the lamp that checks its wavelengths.

pub mod averaging;
pub mod camera;
pub mod censored;
pub mod error;
mod guided;
pub mod line_lamp;
pub mod spectral;
pub mod traits;
pub mod xyz;

#[cfg(feature = "serial")]
pub mod serial;
#[cfg(feature = "sim")]
pub mod sim;
#[cfg(feature = "camera-uvc")]
pub mod uvc;

pub use averaging::AveragingMeter;
pub use camera::{Camera, CameraInfo, DriveImage, Frame};
pub use censored::CensoredReadings;
pub use error::DeviceError;
pub use guided::GuidedPositioner;
pub use line_lamp::{EmissionLine, GuidedLampHolder, LampHolder, LineLamp};
pub use spectral::{CorrectedReference, SpectralRadiance, Spectroradiometer, WavelengthScale};
pub use traits::{
    AimingAids, Colorimeter, DisplayId, DisplayInfo, Eye, MeterInfo, MeterPositioner,
    PatternOutput, ReadingNoise,
};
pub use xyz::Xyz;
