//! The one error type of the vocabulary.

/// A value that does not name a colour, channel or bit depth, or an embedded table that
/// cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CoreError {
    /// A chromaticity outside the diagram (or not finite).
    #[error(
        "{what}: xy ({x}, {y}) is not a valid chromaticity (need finite x ≥ 0, y > 0, x + y ≤ 1)"
    )]
    Chromaticity {
        /// What the value was for.
        what: String,
        /// x.
        x: f64,
        /// y.
        y: f64,
    },
    /// A bit depth outside 1..=16.
    #[error("bit depth {0} is not supported; use 1 to 16 bits")]
    BitDepth(u32),
    /// A headroom outside (0, 1].
    #[error("headroom {0} is not in (0, 1]")]
    Headroom(f64),
    /// A channel index other than 0, 1, 2.
    #[error("channel index {0} is not red (0), green (1) or blue (2)")]
    ChannelIndex(usize),
    /// A channel name that is not red, green or blue.
    #[error("'{0}' is not a channel; use red, green or blue (r, g, b)")]
    ChannelName(String),
    /// Colour-space parameters that give no matrix.
    #[error("{0}")]
    ColourSpace(String),
    /// An embedded data table that does not parse (a broken build).
    #[error("embedded table: {0}")]
    EmbeddedTable(String),
}
