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
    /// 1σ repeatability of x and y at high luminance, on illuminant A as makers
    /// state it (a saturated colour's differs; [`ReadingNoise::sensor_rel`]).
    pub xy: f64,
    /// 1σ zero-light noise of the X, Y and Z sensors (cd/m²).
    pub dark_xyz_cd_m2: [f64; 3],
}

impl ReadingNoise {
    /// A CS-100A class filter colorimeter's stated figures: 0.1 % in Y and 0.0005 in x
    /// and y on illuminant A, and a few mcd/m² of zero-light noise in each sensor.
    pub const CS100A_CLASS: ReadingNoise = ReadingNoise {
        luminance_rel: 0.001,
        xy: 0.0005,
        dark_xyz_cd_m2: [0.008, 0.004, 0.008],
    };

    /// An instrument that states it has no noise at all ([`ReadingNoise::is_exact`]).
    pub const EXACT: ReadingNoise = ReadingNoise {
        luminance_rel: 0.0,
        xy: 0.0,
        dark_xyz_cd_m2: [0.0; 3],
    };

    /// True for an instrument that states it has no noise at all (the simulator's
    /// exact meter).
    pub fn is_exact(&self) -> bool {
        self.xy == 0.0 && self.luminance_rel == 0.0 && self.dark_xyz_cd_m2.iter().all(|v| *v == 0.0)
    }

    /// 1σ relative high-light noise of the X, Y and Z sensors. A filter colorimeter
    /// reads three photodiodes behind its filters, and each one's noise is relative to
    /// its own signal: Y's is the stated luminance repeatability, X's and Z's (equal)
    /// such that illuminant A (x 0.4476, y 0.4074, as makers state repeatability)
    /// reads with the stated xy repeatability (the mean of σx² and σy²); twice Y's for
    /// a CS-100A's 0.1 % and 0.0005.
    /// A saturated blue then keeps its Z as precise as a white's, while its x and y
    /// scatter far less than on illuminant A: the repeatability is not an xy noise
    /// that moves every spectrum alike.
    pub fn sensor_rel(&self) -> [f64; 3] {
        let l = self.luminance_rel.max(0.0);
        let [x, y] = ILLUMINANT_A_XY;
        let z = 1.0 - x - y;
        // σx² + σy² = r²·a + l²·b for independent relative noise [r, l, r] (r = k·l).
        let a = x * x * ((1.0 - x).powi(2) + z * z) + y * y * (x * x + z * z);
        let b = x * x * y * y + y * y * (1.0 - y).powi(2);
        let r = ((2.0 * self.xy * self.xy - l * l * b) / a).max(0.0).sqrt();
        [r, l, r]
    }

    /// 1σ of X, Y and Z of one reading of `xyz`: each sensor's relative high-light
    /// noise ([`ReadingNoise::sensor_rel`]) and its zero-light noise, independent.
    pub fn sigma_xyz(&self, xyz: Xyz) -> [f64; 3] {
        let rel = self.sensor_rel();
        let v = xyz.to_array();
        std::array::from_fn(|k| self.dark_xyz_cd_m2[k].hypot(rel[k] * v[k]))
    }
}

/// Chromaticity of CIE illuminant A, on which makers state a colorimeter's xy
/// repeatability.
pub const ILLUMINANT_A_XY: [f64; 2] = [0.44757, 0.40745];

/// A spot colorimeter: measures the XYZ (Y in cd/m²) of the spot it is aimed at.
pub trait Colorimeter {
    /// Facts about the instrument.
    fn info(&self) -> MeterInfo;
    /// Takes one reading.
    fn measure(&mut self) -> Result<Xyz, DeviceError>;
    /// Where the last reading (given or refused) was itself the mean of several of the
    /// instrument's own ([`crate::AveragingMeter`]): those readings, the refused ones
    /// counted, so that a mean over several such readings counts each refusal once, at
    /// one reading's noise ([`crate::CensoredReadings`], [`Colorimeter::instrument_noise`]).
    /// `None`, the default: the last reading is the instrument's own. A meter that
    /// corrects another's readings (its xy offset or matrix) keeps the defaults and so
    /// belongs inside an [`crate::AveragingMeter`], never around one: around one it
    /// would hide the readings behind each mean, which are the uncorrected ones.
    fn readings_behind_last(&self) -> Option<crate::CensoredReadings> {
        None
    }
    /// The stated noise of one of the instrument's own readings: [`MeterInfo::noise`]
    /// unless each reading is a mean of several.
    fn instrument_noise(&self) -> Option<ReadingNoise> {
        self.info().noise
    }
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
