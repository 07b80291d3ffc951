//! Typed errors of the photometry module (file parsing, invalid parameters).

use thiserror::Error;

/// What went wrong while building or reading a photometric description.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum PhotometryError {
    /// A value in a photometric file could not be read.
    #[error("{format} file, line {line}: {message}")]
    Parse {
        /// File format ("IES LM-63" or "EULUMDAT").
        format: &'static str,
        /// 1-based line number where the problem was found.
        line: usize,
        /// What was expected and what was found.
        message: String,
    },
    /// The file ended before all announced values were read.
    #[error(
        "{format} file is truncated: expected {expected} after line {line}, but the file ends there; re-export the file from the photometry software"
    )]
    Truncated {
        /// File format.
        format: &'static str,
        /// Last line read (1-based).
        line: usize,
        /// What was still expected.
        expected: String,
    },
    /// The file is well-formed but uses a feature this reader does not implement.
    #[error("{format} file, line {line}: unsupported: {message}")]
    Unsupported {
        /// File format.
        format: &'static str,
        /// 1-based line number.
        line: usize,
        /// The unsupported feature and what to do about it.
        message: String,
    },
    /// A parameter given in code is out of its valid range.
    #[error("invalid photometric parameter: {0}")]
    InvalidParameter(String),
}
