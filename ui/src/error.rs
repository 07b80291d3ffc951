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
