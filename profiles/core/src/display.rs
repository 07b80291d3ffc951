//! Which display: its index on the wall, its key in profiles and the store, its eye.

use std::fmt;

use serde::{Deserialize, Serialize};

/// Index of one display (one projector, one eye) on the wall, 0-based, in wall-file order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct DisplayId(pub u32);

impl fmt::Display for DisplayId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "#{}", self.0)
    }
}

/// Which eye a display serves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Eye {
    /// Mono wall: the display serves both eyes.
    Mono,
    /// Left eye (e.g. Infitec "A" filter).
    Left,
    /// Right eye (e.g. Infitec "B" filter).
    Right,
}

impl fmt::Display for Eye {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Eye::Mono => "mono",
            Eye::Left => "left",
            Eye::Right => "right",
        })
    }
}

/// Identifies one display (one projector, one eye) of a wall.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct DisplayKey {
    /// Name of the wall (from the wall file).
    pub wall: String,
    /// Index of the projector in the wall file, 0-based.
    pub display: u32,
    /// Tile column, 0-based from the left.
    pub tile_col: u32,
    /// Tile row, 0-based from the top.
    pub tile_row: u32,
    /// Eye the display serves.
    pub eye: Eye,
}

impl DisplayKey {
    /// File stem used for this display's profile: `d007-c1r2-left`.
    pub fn file_stem(&self) -> String {
        format!(
            "d{:03}-c{}r{}-{}",
            self.display, self.tile_col, self.tile_row, self.eye
        )
    }
}

impl fmt::Display for DisplayKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} display {} (tile col {} row {}, {})",
            self.wall, self.display, self.tile_col, self.tile_row, self.eye
        )
    }
}
