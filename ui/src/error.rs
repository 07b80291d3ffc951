//! The command line's error type and exit codes.

/// An error to report to the user, with the process exit code it maps to.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
pub(crate) struct CliError {
    /// What went wrong and what to do about it.
    pub(crate) message: String,
    /// Process exit code (1: failure, 2: usage or input error, 3: tolerance exceeded).
    pub(crate) code: i32,
}

impl CliError {
    /// A failure (exit code 1).
    pub(crate) fn failure(message: impl Into<String>) -> Self {
        Self {
            message: message.into(),
            code: 1,
        }
    }

    /// Bad input or usage (exit code 2).
    pub(crate) fn input(message: impl Into<String>) -> Self {
        Self {
            message: message.into(),
            code: 2,
        }
    }

    /// A check ran but its results are outside the user's tolerances (exit code 3).
    pub(crate) fn tolerance(message: impl Into<String>) -> Self {
        Self {
            message: message.into(),
            code: 3,
        }
    }

    /// The process exit code.
    pub(crate) fn exit_code(&self) -> i32 {
        self.code
    }
}

// Library errors of commission, verify, render, profiles and the benches. Errors the
// user fixes by changing the command (a missing or wrong file, a bad value) are input
// errors (exit 2); the rest are failures (exit 1).

#[cfg(feature = "station")]
impl From<lumiwall_calib::station::StationError> for CliError {
    fn from(e: lumiwall_calib::station::StationError) -> Self {
        use lumiwall_calib::station::StationError;
        match e {
            StationError::Wall { .. } => Self::input(e.to_string()),
            _ => Self::failure(e.to_string()),
        }
    }
}

#[cfg(feature = "station")]
impl From<lumiwall_calib::commission::CommissionError> for CliError {
    fn from(e: lumiwall_calib::commission::CommissionError) -> Self {
        Self::failure(e.to_string())
    }
}

#[cfg(feature = "station")]
impl From<lumiwall_calib::CalibError> for CliError {
    fn from(e: lumiwall_calib::CalibError) -> Self {
        Self::failure(e.to_string())
    }
}

#[cfg(feature = "station")]
impl From<lumiwall_calib::verify::VerifyError> for CliError {
    /// Measuring or applying failed: a failure; the profiles do not fit: input.
    fn from(e: lumiwall_calib::verify::VerifyError) -> Self {
        use lumiwall_calib::verify::VerifyError;
        match e {
            VerifyError::Measure(_) | VerifyError::Apply(_) => Self::failure(e.to_string()),
            _ => Self::input(e.to_string()),
        }
    }
}

#[cfg(feature = "station")]
impl From<lumiwall_bench::readings::ReadingsError> for CliError {
    fn from(e: lumiwall_bench::readings::ReadingsError) -> Self {
        use lumiwall_bench::readings::ReadingsError;
        match e {
            ReadingsError::Station(e) => e.into(),
            ReadingsError::BudgetTooSmall { .. } => Self::input(e.to_string()),
            _ => Self::failure(e.to_string()),
        }
    }
}

impl From<lumiwall_profiles::store::StoreError> for CliError {
    /// Store errors that the user fixes by changing the command are input errors.
    fn from(e: lumiwall_profiles::store::StoreError) -> Self {
        use lumiwall_profiles::store::StoreError;
        match e {
            StoreError::Missing { .. }
            | StoreError::NotADatabase { .. }
            | StoreError::Foreign { .. }
            | StoreError::NewerSchema { .. }
            | StoreError::BadTime { .. }
            | StoreError::InvalidProfile(_)
            | StoreError::InvalidRun(_)
            | StoreError::DuplicateRun { .. }
            | StoreError::NoHistory { .. } => Self::input(e.to_string()),
            _ => Self::failure(e.to_string()),
        }
    }
}

impl From<lumiwall_profiles::ProfileError> for CliError {
    /// A profile store failure is a failure; unreadable or invalid profiles are input.
    fn from(e: lumiwall_profiles::ProfileError) -> Self {
        match e {
            lumiwall_profiles::ProfileError::Store(_) => Self::failure(e.to_string()),
            _ => Self::input(e.to_string()),
        }
    }
}

impl From<lumiwall_render::scene::SceneError> for CliError {
    fn from(e: lumiwall_render::scene::SceneError) -> Self {
        Self::input(e.to_string())
    }
}

impl From<lumiwall_render::radiosity::RadiosityError> for CliError {
    /// A scene or option the solver refuses is input (exit 2); the rest are failures.
    fn from(e: lumiwall_render::radiosity::RadiosityError) -> Self {
        use lumiwall_render::radiosity::RadiosityError;
        match e {
            RadiosityError::BadScene(_) | RadiosityError::BadOption(_) => {
                Self::input(e.to_string())
            }
            _ => Self::failure(e.to_string()),
        }
    }
}

#[cfg(feature = "voxel-gi")]
impl From<lumiwall_render::voxel::GiError> for CliError {
    /// A scene or option the method refuses is input (exit 2); the GPU failing is a
    /// failure.
    fn from(e: lumiwall_render::voxel::GiError) -> Self {
        match e {
            lumiwall_render::voxel::GiError::Gpu(_) => Self::failure(e.to_string()),
            _ => Self::input(e.to_string()),
        }
    }
}

impl From<lumiwall_render::radiosity::sensors::SensorError> for CliError {
    /// A sensor file the user fixes: input (exit 2).
    fn from(e: lumiwall_render::radiosity::sensors::SensorError) -> Self {
        Self::input(e.to_string())
    }
}

impl From<lumiwall_core::files::LockError> for CliError {
    /// Another lumiwall writes into the folder: a failure (exit 1), retried later.
    fn from(e: lumiwall_core::files::LockError) -> Self {
        Self::failure(e.to_string())
    }
}

impl From<std::io::Error> for CliError {
    fn from(e: std::io::Error) -> Self {
        Self::failure(e.to_string())
    }
}

// --- Conversions for `lumiwall apply` (post pass) ----------------------------------

impl From<lumiwall_render::post::PostError> for CliError {
    /// GPU failures are failures (exit 1); everything else is bad input (exit 2).
    fn from(e: lumiwall_render::post::PostError) -> Self {
        match e {
            lumiwall_render::post::PostError::Gpu(_) => CliError::failure(e.to_string()),
            _ => CliError::input(e.to_string()),
        }
    }
}

impl From<lumiwall_profiles::apply::ApplyError> for CliError {
    /// A profile the post pass cannot use is bad input (exit 2).
    fn from(e: lumiwall_profiles::apply::ApplyError) -> Self {
        CliError::input(e.to_string())
    }
}
