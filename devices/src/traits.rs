//! The device traits the calibration code talks to.

use serde::{Deserialize, Serialize};

pub use lumiwall_core::{DisplayId, Eye};

use crate::{DeviceError, DriveImage, Xyz};

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
    /// The noise of one reading, where published (the maker's figures; the
    /// simulator's error model); `None`: not known.
    pub noise: Option<ReadingNoise>,
}

/// The noise of one reading of a filter colorimeter: a relative repeatability at high
/// luminance (in Y and in x, y) and the zero-light noise of its X, Y and Z sensors,
/// which dominates in the dark.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ReadingNoise {
    /// 1σ relative repeatability of Y at high luminance.
    pub luminance_rel: f64,
    /// 1σ repeatability of x and y at high luminance.
    pub xy: f64,
    /// 1σ zero-light noise of the X, Y and Z sensors (cd/m²).
    pub dark_xyz_cd_m2: [f64; 3],
}

impl ReadingNoise {
    /// True for an instrument that states it has no noise at all (the simulator's
    /// exact meter).
    pub fn is_exact(&self) -> bool {
        self.xy == 0.0 && self.luminance_rel == 0.0 && self.dark_xyz_cd_m2.iter().all(|v| *v == 0.0)
    }

    /// 1σ of X, Y and Z of one reading of `xyz`: the dark noise and the high-light
    /// repeatability carried from Y, x and y to each component (X = x·Y/y,
    /// Z = (1 − x − y)·Y/y, the three taken as independent).
    pub fn sigma_xyz(&self, xyz: Xyz) -> [f64; 3] {
        let s = xyz.x + xyz.y + xyz.z;
        let [x, y, z] = if s > 0.0 {
            [xyz.x / s, xyz.y / s, xyz.z / s]
        } else {
            [1.0 / 3.0; 3]
        };
        // Relative variance of each component from Y's and the chromaticity's noise.
        let (l2, c2) = (self.luminance_rel.powi(2), self.xy.powi(2));
        let floor = 1e-3;
        let rel2 = [
            l2 + c2 * (1.0 / x.max(floor).powi(2) + 1.0 / y.max(floor).powi(2)),
            l2,
            l2 + c2 * (2.0 / z.max(floor).powi(2) + 1.0 / y.max(floor).powi(2)),
        ];
        let v = [xyz.x, xyz.y, xyz.z];
        std::array::from_fn(|k| (self.dark_xyz_cd_m2[k].powi(2) + rel2[k] * v[k] * v[k]).sqrt())
    }
}

/// A spot colorimeter: measures the XYZ (Y in cd/m²) of the spot it is aimed at.
pub trait Colorimeter {
    /// Facts about the instrument.
    fn info(&self) -> MeterInfo;
    /// Takes one reading.
    fn measure(&mut self) -> Result<Xyz, DeviceError>;
}

/// Fails unless every channel of a pattern drive is finite and in 0..=1: the one check
/// every [`PatternOutput`] makes before showing.
pub fn check_drive(drive: [f64; 3]) -> Result<(), DeviceError> {
    if drive
        .iter()
        .all(|d| d.is_finite() && (0.0..=1.0).contains(d))
    {
        Ok(())
    } else {
        Err(DeviceError::Config(format!(
            "pattern drive {drive:?} is outside 0..=1 per channel"
        )))
    }
}

/// Shows full-field patterns on the displays of a wall.
pub trait PatternOutput {
    /// The displays, in wall order.
    fn displays(&self) -> Vec<DisplayInfo>;
    /// Shows a uniform colour on one display; `drive` is the normalised input per
    /// channel in 0..=1 (code value / max code); the other displays show black.
    fn show(&mut self, display: DisplayId, drive: [f64; 3]) -> Result<(), DeviceError>;

    /// Shows an image on one display (the other displays show black); outputs that can
    /// show uniform colours only fail with [`DeviceError::NoImages`].
    fn show_image(&mut self, display: DisplayId, image: &DriveImage) -> Result<(), DeviceError> {
        let _ = (display, image);
        Err(DeviceError::NoImages(format!("for display {display}")))
    }

    /// Shows a pattern that helps a person aim the meter at spot `uv` of `display`
    /// (a crosshair where the output can show images; full white otherwise).
    fn show_aim_marker(&mut self, display: DisplayId, uv: [f64; 2]) -> Result<(), DeviceError> {
        let _ = uv;
        self.show(display, [1.0; 3])
    }
}

/// What a positioner that asks a person may use while the meter is aimed: the
/// pattern output (for an aiming pattern) and the meter (for live readings).
pub struct AimingAids<'a> {
    /// Shows the aiming pattern.
    pub pattern: &'a mut dyn PatternOutput,
    /// Takes live readings.
    pub meter: &'a mut dyn Colorimeter,
}

/// Points the meter at a display (a technician, a motorised mount, or the simulator).
pub trait MeterPositioner {
    /// Aims the meter at the calibration spot of `display` (its centre unless told
    /// otherwise); `uv` is the spot in normalised display coordinates, 0..=1.
    fn aim(&mut self, display: DisplayId, uv: [f64; 2]) -> Result<(), DeviceError>;

    /// Waits until the aim at `uv` of `display` (named `label`) is confirmed: a
    /// technician looks at the aiming pattern and live readings; a mount or the
    /// simulator is aimed once [`MeterPositioner::aim`] returns (the default). Fails
    /// with [`DeviceError::AimStopped`] or [`DeviceError::AimSkipped`] when the person
    /// says so.
    fn confirm(
        &mut self,
        display: DisplayId,
        label: &str,
        uv: [f64; 2],
        aids: AimingAids<'_>,
    ) -> Result<(), DeviceError> {
        let _ = (display, label, uv, aids);
        Ok(())
    }

    /// Whether aiming at a display again costs nothing (a mount, the simulator: the
    /// default), so that a run may visit every display twice; `false` where a person
    /// aims and every visit is a walk to the display.
    fn revisits_cheaply(&self) -> bool {
        true
    }
}
