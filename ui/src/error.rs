//! The command line's error type and exit codes.

/// An error to report to the user, with the process exit code it maps to.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
pub struct CliError {
    /// What went wrong and what to do about it.
    pub message: String,
    /// Process exit code (1: failure, 2: usage or input error, 3: tolerance exceeded).
    pub code: i32,
}

impl CliError {
    /// A failure (exit code 1).
    pub fn failure(message: impl Into<String>) -> Self {
        Self {
            message: message.into(),
            code: 1,
        }
    }

    /// Bad input or usage (exit code 2).
    pub fn input(message: impl Into<String>) -> Self {
        Self {
            message: message.into(),
            code: 2,
        }
    }

    /// A check ran but its results are outside the user's tolerances (exit code 3).
    pub fn tolerance(message: impl Into<String>) -> Self {
        Self {
            message: message.into(),
            code: 3,
        }
    }

    /// The process exit code.
    pub fn exit_code(&self) -> i32 {
        self.code
    }
}

// --- Conversions for `lumiwall apply` (post pass, profiles) -------------------------

impl From<lumiwall_render::post::PostError> for CliError {
    /// GPU failures are failures (exit 1); everything else is bad input (exit 2).
    fn from(e: lumiwall_render::post::PostError) -> Self {
        match e {
            lumiwall_render::post::PostError::Gpu(_) => CliError::failure(e.to_string()),
            _ => CliError::input(e.to_string()),
        }
    }
}

impl From<lumiwall_profiles::ProfileError> for CliError {
    /// A profile that cannot be read or is invalid is bad input (exit 2).
    fn from(e: lumiwall_profiles::ProfileError) -> Self {
        CliError::input(e.to_string())
    }
}

impl From<lumiwall_profiles::apply::ApplyError> for CliError {
    /// A profile the post pass cannot use is bad input (exit 2).
    fn from(e: lumiwall_profiles::apply::ApplyError) -> Self {
        CliError::input(e.to_string())
    }
}
