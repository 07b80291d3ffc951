//! Errors of the post pass and its image I/O.

use std::path::PathBuf;

use lumiwall_profiles::ProfileError;
use lumiwall_profiles::apply::ApplyError;

/// Everything that can go wrong applying profiles to a frame.
#[derive(Debug, thiserror::Error)]
pub enum PostError {
    /// A file could not be read or written.
    #[error("cannot access {path}: {source}")]
    Io {
        /// File concerned.
        path: PathBuf,
        /// Underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The OpenEXR file could not be decoded.
    #[error("cannot read OpenEXR file {path}: {message}")]
    Exr {
        /// File concerned.
        path: PathBuf,
        /// Decoder message.
        message: String,
    },
    /// The EXR has no usable channel set.
    #[error(
        "OpenEXR file {path} has channels [{found}]; expected X,Y,Z or R,G,B (holding X, Y, Z \
         in cd/m²) or a single Y (luminance in cd/m²)"
    )]
    Channels {
        /// File concerned.
        path: PathBuf,
        /// Channel names found.
        found: String,
    },
    /// The PNG could not be decoded or encoded.
    #[error("PNG {path}: {message}")]
    Png {
        /// File concerned.
        path: PathBuf,
        /// Codec message.
        message: String,
    },
    /// The input holds values the post pass must not silently show as black.
    #[error(
        "{path}: {count} pixel values are {what} (first at pixel x={first_x}, y={first_y}); \
         fix the renderer output, or pass {flag} to proceed anyway"
    )]
    BadValues {
        /// File concerned.
        path: PathBuf,
        /// How many values.
        count: u64,
        /// "NaN or infinite" or "negative".
        what: &'static str,
        /// First offending pixel, column.
        first_x: u32,
        /// First offending pixel, row.
        first_y: u32,
        /// Command-line flag that accepts them.
        flag: &'static str,
    },
    /// An input image larger than the post pass reads (checked from its header,
    /// before anything is allocated).
    #[error(
        "{path}: the image is {width}×{height} pixels; the post pass reads at most \
         {max_side} pixels a side and {max_pixels} pixels in all (a 16384×16384 frame); \
         split the frame or check the file"
    )]
    TooLarge {
        /// File concerned.
        path: PathBuf,
        /// Width the header claims.
        width: u64,
        /// Height the header claims.
        height: u64,
        /// Largest width or height read.
        max_side: u64,
        /// Largest pixel count read.
        max_pixels: u64,
    },
    /// Image and display (or wall) sizes do not fit together.
    #[error("size mismatch: {0}")]
    SizeMismatch(String),
    /// No GPU adapter (not even a software one such as lavapipe) was found.
    #[error("no GPU adapter found (install mesa-vulkan-drivers for lavapipe)")]
    NoAdapter,
    /// The GPU failed.
    #[error("GPU post pass failed: {0}")]
    Gpu(String),
    /// A profile could not be prepared.
    #[error(transparent)]
    Apply(#[from] ApplyError),
    /// A profile could not be read.
    #[error(transparent)]
    Profile(#[from] ProfileError),
    /// Wall, frames and displays do not fit together.
    #[error(transparent)]
    Wall(#[from] super::wall::WallError),
}
