//! What a camera stage has finished, kept in a folder so that a stopped run resumes:
//! the camera calibration (response, registration, meter-anchored photometry and the
//! loop level) once the open loop is done, then every display's flat field as its loop
//! ends. Each file is written atomically; a file that cannot be read back counts as not
//! done.

use std::path::{Path, PathBuf};

use lumiwall_core::Eye;
use lumiwall_core::files::write_atomic;
use serde::{Deserialize, Serialize};

use super::CameraCalibError;
use super::anchor::CameraPhotometry;
use super::flat::DisplayFlat;
use super::hdr::ResponseCurve;
use super::registration::Registration;

/// The camera calibration of a run, as saved.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SavedCalibration {
    /// The response curve.
    pub response: ResponseCurve,
    /// Where the displays are in the camera image.
    pub registration: Registration,
    /// Camera → XYZ, anchored to the meter.
    pub photometry: CameraPhotometry,
    /// The strict white's scale the loop runs at (from every display's open loop).
    pub scale: f64,
    /// Fingerprint of the profiles the loop ran for (see `measure_flat_fields`).
    #[serde(default)]
    pub profiles: String,
}

/// The checkpoint folder of one camera stage.
#[derive(Debug, Clone, PartialEq)]
pub struct Checkpoint {
    dir: PathBuf,
}

const CALIBRATION: &str = "calibration.json";

impl Checkpoint {
    /// A checkpoint in `dir` (made when the first file is written).
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        Self { dir: dir.into() }
    }

    /// Its folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Forgets everything saved (a fresh run).
    pub fn clear(&self) -> Result<(), CameraCalibError> {
        match std::fs::remove_dir_all(&self.dir) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                Err(CameraCalibError::Fit(format!(
                    "cannot clear the camera checkpoint {}: {e}",
                    self.dir.display()
                )))
            }
            _ => Ok(()),
        }
    }

    /// The saved calibration, if a run got that far.
    pub fn calibration(&self) -> Option<SavedCalibration> {
        read(&self.dir.join(CALIBRATION))
    }

    /// Saves the calibration.
    pub fn save_calibration(&self, c: &SavedCalibration) -> Result<(), CameraCalibError> {
        write(&self.dir.join(CALIBRATION), c)
    }

    /// The saved flat field of display `id`, `eye`, if its loop had ended.
    pub fn display(&self, id: u32, eye: Eye) -> Option<DisplayFlat> {
        read(&self.display_path(id, eye))
    }

    /// Saves one display's flat field.
    pub fn save_display(&self, eye: Eye, flat: &DisplayFlat) -> Result<(), CameraCalibError> {
        write(&self.display_path(flat.display, eye), flat)
    }

    fn display_path(&self, id: u32, eye: Eye) -> PathBuf {
        self.dir.join(format!("display-{id}-{eye}.json"))
    }
}

fn read<T: serde::de::DeserializeOwned>(path: &Path) -> Option<T> {
    let bytes = std::fs::read(path).ok()?;
    serde_json::from_slice(&bytes).ok()
}

fn write<T: Serialize>(path: &Path, value: &T) -> Result<(), CameraCalibError> {
    let fail = |e: String| {
        CameraCalibError::Fit(format!(
            "cannot save the camera checkpoint {}: {e}",
            path.display()
        ))
    };
    let json = serde_json::to_vec(value).map_err(|e| fail(e.to_string()))?;
    write_atomic(path, &json).map_err(|e| fail(e.to_string()))
}
