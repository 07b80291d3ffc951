//! Typed calibration errors.

/// Errors of measurement, fitting and solving.
#[derive(Debug, thiserror::Error)]
pub enum CalibError {
    /// A device failed.
    #[error(transparent)]
    Device(#[from] lumiwall_devices::DeviceError),
    /// A profile could not be built or stored.
    #[error(transparent)]
    Profile(#[from] lumiwall_profiles::ProfileError),
}
