//! What the station app shows, read from the same files the command line writes: the
//! wall file, the profile folder (profiles, `verify.json`, the report) and the
//! profile store (lamp readings and the forecast).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use lumiwall_calib::verify::VerifyReport;
use lumiwall_devices::DisplayInfo;
use lumiwall_devices::sim::VirtualWall;
use lumiwall_profiles::store::{DisplayForecast, ForecastOptions, LampReading, ProfileStore};
use lumiwall_profiles::{DisplayKey, DisplayProfile, Eye, ProfileSet};

/// The wall as the files describe it now.
#[derive(Debug, Default)]
pub(crate) struct WallData {
    /// Wall name.
    pub(crate) name: String,
    /// Tile columns and rows.
    pub(crate) tiles: [u32; 2],
    /// Width over height of a tile on the screen.
    pub(crate) tile_aspect: f32,
    /// Every display of the wall file.
    pub(crate) displays: Vec<DisplayInfo>,
    /// The folder's profiles (empty before a commissioning).
    pub(crate) profiles: Vec<DisplayProfile>,
    /// The folder's last verification.
    pub(crate) verify: Option<VerifyReport>,
    /// The report, when the folder has one.
    pub(crate) report: Option<PathBuf>,
    /// Lamp readings per display and eye, oldest first.
    pub(crate) readings: BTreeMap<DisplayKey, Vec<LampReading>>,
    /// The lamp-life forecast.
    pub(crate) forecast: Vec<DisplayForecast>,
    /// What could not be read, for the technician.
    pub(crate) problems: Vec<String>,
}

impl WallData {
    /// Reads the wall file, the profile folder and (when given) the store; what is
    /// missing or unreadable is listed in `problems`, never fatal.
    pub(crate) fn load(wall: &Path, profiles: &Path, store: Option<&Path>) -> Self {
        let mut d = Self::default();
        match VirtualWall::from_toml_file(wall) {
            Ok(w) => {
                let file = w.wall_file();
                d.name = w.name();
                d.tiles = [file.tiles.cols, file.tiles.rows];
                d.tile_aspect = (file.tiles.width_m / file.tiles.height_m) as f32;
                d.displays = w.displays();
            }
            Err(e) => d.problems.push(format!("wall file: {e}")),
        }
        d.load_profiles(profiles);
        if let Some(store) = store {
            d.load_store(store);
        }
        d
    }

    fn load_profiles(&mut self, dir: &Path) {
        if !dir.join("report.html").is_file() && !dir.is_dir() {
            self.problems.push(format!(
                "{} does not exist yet: commission the wall to write it",
                dir.display()
            ));
            return;
        }
        match ProfileSet::load_dir(dir) {
            Ok((wall, profiles)) if wall == self.name || self.name.is_empty() => {
                self.profiles = profiles;
            }
            Ok((wall, _)) => self.problems.push(format!(
                "{} holds profiles of wall {wall}, not {}",
                dir.display(),
                self.name
            )),
            Err(e) => self.problems.push(format!("profiles: {e}")),
        }
        let verify = dir.join(crate::cmd_verify::VERIFY_FILE);
        if let Ok(text) = std::fs::read_to_string(&verify) {
            match serde_json::from_str(&text) {
                Ok(v) => self.verify = Some(v),
                Err(e) => self.problems.push(format!("{}: {e}", verify.display())),
            }
        }
        let report = dir.join("report.html");
        self.report = report.is_file().then_some(report);
    }

    fn load_store(&mut self, path: &Path) {
        let store = match ProfileStore::open_existing(path) {
            Ok(s) => s,
            Err(e) => {
                self.problems.push(format!("store: {e}"));
                return;
            }
        };
        let numbers = match store.display_numbers(&self.name) {
            Ok(n) => n,
            Err(e) => {
                self.problems.push(format!("store: {e}"));
                return;
            }
        };
        for d in numbers {
            match store.lamp_readings(&self.name, d) {
                Ok(rs) => {
                    for r in rs {
                        self.readings.entry(r.display.clone()).or_default().push(r);
                    }
                }
                Err(e) => self.problems.push(format!("store: {e}")),
            }
        }
        match store.forecast_wall(&self.name, &ForecastOptions::default()) {
            Ok(f) => self.forecast = f,
            Err(e) => self.problems.push(format!("forecast: {e}")),
        }
    }

    /// The profile of a display and eye.
    pub(crate) fn profile(&self, display: u32, eye: Eye) -> Option<&DisplayProfile> {
        self.profiles
            .iter()
            .find(|p| p.display.display == display && p.display.eye == eye)
    }

    /// The last verification's summary of a display and eye.
    pub(crate) fn verified(
        &self,
        display: u32,
        eye: Eye,
    ) -> Option<&lumiwall_calib::verify::Summary> {
        self.verify.as_ref().and_then(|v| {
            v.per_display
                .iter()
                .find(|(k, _)| k.display == display && k.eye == eye)
                .map(|(_, s)| s)
        })
    }

    /// Change of a display's native white luminance from its first lamp reading to
    /// its newest, percent.
    pub(crate) fn drift_pct(&self, key: &DisplayKey) -> Option<f64> {
        let rs = self.readings.get(key)?;
        let (first, last) = (rs.first()?, rs.last()?);
        let f = first.native_white_y_cd_m2();
        (f > 0.0).then(|| 100.0 * (last.native_white_y_cd_m2() / f - 1.0))
    }

    /// The forecast of a display and eye.
    pub(crate) fn forecast_of(&self, key: &DisplayKey) -> Option<&DisplayForecast> {
        self.forecast.iter().find(|f| f.display() == key)
    }
}
