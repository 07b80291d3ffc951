//! The device traits the calibration code talks to.

use serde::{Deserialize, Serialize};

pub use lumiwall_core::{DisplayId, Eye};

use crate::{DeviceError, Xyz};

/// Static facts about one display.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DisplayInfo {
    /// Its id.
    pub id: DisplayId,
    /// Human-readable name ("tile c2r1 left").
    pub name: String,
    /// Tile column, 0-based.
    pub tile_col: u32,
    /// Tile row, 0-based.
    pub tile_row: u32,
    /// Eye.
    pub eye: Eye,
    /// Input bits per channel (8, 10, 16).
    pub bit_depth: u32,
}

/// Static facts about a colorimeter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeterInfo {
    /// Model name.
    pub model: String,
    /// Serial number or port.
    pub serial: String,
    /// Below this luminance readings are unreliable (cd/m²).
    pub min_reliable_cd_m2: f64,
    /// Largest luminance it can read (cd/m²).
    pub max_cd_m2: f64,
}

/// A spot colorimeter: measures the XYZ (Y in cd/m²) of the spot it is aimed at.
pub trait Colorimeter {
    /// Facts about the instrument.
    fn info(&self) -> MeterInfo;
    /// Takes one reading.
    fn measure(&mut self) -> Result<Xyz, DeviceError>;
}

/// Shows full-field patterns on the displays of a wall.
pub trait PatternOutput {
    /// The displays, in wall order.
    fn displays(&self) -> Vec<DisplayInfo>;
    /// Shows a uniform colour on one display; `drive` is the normalised input per
    /// channel in 0..=1 (code value / max code); the other displays show black.
    fn show(&mut self, display: DisplayId, drive: [f64; 3]) -> Result<(), DeviceError>;
}

/// Points the meter at a display (a technician, a motorised mount, or the simulator).
pub trait MeterPositioner {
    /// Aims the meter at the calibration spot of `display` (its centre unless told
    /// otherwise); `uv` is the spot in normalised display coordinates, 0..=1.
    fn aim(&mut self, display: DisplayId, uv: [f64; 2]) -> Result<(), DeviceError>;
}
