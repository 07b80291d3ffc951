//! Errors of profile reading, validation and storage.

use std::path::PathBuf;

/// Everything that can go wrong reading, checking or storing a profile.
#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    /// The file could not be read or written.
    #[error("cannot access profile file {path}: {source}")]
    Io {
        /// File concerned.
        path: PathBuf,
        /// Underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The file is not a valid profile document.
    #[error("profile {path} is not valid lumiwall profile JSON: {message}")]
    Parse {
        /// File concerned.
        path: PathBuf,
        /// Parser message (line and column included).
        message: String,
    },
    /// The profile was written by another format version.
    #[error(
        "profile {path} has format version {found}, this lumiwall reads version {expected}; \
         re-run `lumiwall commission` or convert the profile"
    )]
    Version {
        /// File concerned.
        path: PathBuf,
        /// Version found in the file.
        found: u32,
        /// Version this build reads.
        expected: u32,
    },
    /// The profile parsed but its content is inconsistent.
    #[error("profile for {display} is invalid: {reason}")]
    Invalid {
        /// Display the profile belongs to.
        display: String,
        /// What is wrong.
        reason: String,
    },
    /// A profile folder without its manifest `wall.json`.
    #[error(
        "{dir} has no wall.json: it is not a profile folder, or a commission was interrupted \
         while saving its profiles (re-run `lumiwall commission --resume` into it)"
    )]
    NoManifest {
        /// The folder.
        dir: PathBuf,
    },
    /// A profile folder whose files do not belong to one solve of one wall.
    #[error("profile folder {dir} does not hold one solve of one wall: {reason}")]
    MixedFolder {
        /// The folder.
        dir: PathBuf,
        /// What does not match, naming the files.
        reason: String,
    },
    /// The profile store failed.
    #[error("profile store error: {0}")]
    Store(String),
}
