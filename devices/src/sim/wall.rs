//! The virtual wall: a cheap, cloneable handle over the shared simulator state, and
//! the pattern output and meter positioner that act on it.

use std::path::Path;
use std::sync::{Arc, Mutex, MutexGuard};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::meter::{MeterModel, SimMeter};
use super::observer::Spectrum;
use super::projector::{Conditions, SimDisplay, validate_spec};
use super::screen;
use super::spectra::Band;
use super::wall_file::{Stereo, WallFile};
use crate::traits::check_drive;
use crate::{
    DeviceError, DisplayId, DisplayInfo, DriveImage, Eye, MeterPositioner, PatternOutput, Xyz,
};
use lumiwall_core::Channel;

/// What a display is showing.
#[derive(Debug, Clone)]
pub(crate) enum Shown {
    /// One drive over the whole display.
    Uniform([f64; 3]),
    /// An image (nearest pixel).
    Image(Arc<DriveImage>),
}

impl Shown {
    /// Drive at `uv`.
    pub(crate) fn drive_at(&self, uv: [f64; 2]) -> [f64; 3] {
        match self {
            Shown::Uniform(d) => *d,
            Shown::Image(img) => img.sample(uv),
        }
    }
}

#[derive(Debug, Clone)]
pub(crate) struct WallState {
    pub(crate) file: WallFile,
    pub(crate) displays: Vec<SimDisplay>,
    /// Simulated seconds since the simulation started.
    pub(crate) clock_s: f64,
    /// Clock reading (s) when the projectors were last switched on: the wall file's
    /// `minutes_since_switch_on` before the start, or [`VirtualWall::switch_on_again`].
    switched_on_s: f64,
    pub(crate) shown: Option<(DisplayId, Shown)>,
    aimed: Option<(DisplayId, [f64; 2])>,
}

impl WallState {
    fn display(&self, id: DisplayId) -> Result<&SimDisplay, DeviceError> {
        self.displays.get(id.0 as usize).ok_or_else(|| {
            DeviceError::NoSuchDisplay(format!(
                "{id} (wall {:?} has displays #0..#{})",
                self.file.name,
                self.displays.len().saturating_sub(1)
            ))
        })
    }

    pub(crate) fn conditions(&self, d: &SimDisplay) -> Conditions {
        Conditions {
            lamp_hours: d.lamp_hours_at_start + self.clock_s / 3600.0,
            minutes_on: (self.clock_s - self.switched_on_s) / 60.0,
        }
    }

    fn emitted(&self, id: DisplayId, drive: [f64; 3], uv: [f64; 2]) -> Result<Xyz, DeviceError> {
        self.emitted_in(id, drive, uv, None)
    }

    /// [`WallState::emitted`] as an instrument whose integration of each display's five
    /// spectra is `basis[display]` sees it (`None`: the CIE 1931 observer, cd/m²).
    fn emitted_in(
        &self,
        id: DisplayId,
        drive: [f64; 3],
        uv: [f64; 2],
        basis: Option<&[[[f64; 3]; 5]]>,
    ) -> Result<Xyz, DeviceError> {
        let (d, w) = self.spot_weights(id, drive, uv)?;
        let own;
        let b = match basis.and_then(|b| b.get(id.0 as usize)) {
            Some(b) => b,
            None => {
                own = [
                    d.channel_xyz[0],
                    d.channel_xyz[1],
                    d.channel_xyz[2],
                    d.black_xyz,
                    d.white_segment_xyz,
                ];
                &own
            }
        };
        let out: [f64; 3] = std::array::from_fn(|i| (0..5).map(|j| w[j] * b[j][i]).sum());
        if out.iter().any(|v| !v.is_finite()) {
            return Err(DeviceError::Config(format!(
                "display {id} of wall {:?} emits {out:?} at uv {uv:?}: not finite; lower \
                 projector.lamp.white_cd_m2, the gains or the screen gains in the wall file",
                self.file.name
            )));
        }
        Ok(Xyz::from_array(out))
    }

    /// The spectral radiance the meter sees from display `id` at `drive` and `uv`
    /// (scaled so that the CIE 1931 observer gives Y in cd/m²).
    fn emitted_spectrum(
        &self,
        id: DisplayId,
        drive: [f64; 3],
        uv: [f64; 2],
    ) -> Result<Spectrum, DeviceError> {
        let (d, w) = self.spot_weights(id, drive, uv)?;
        Ok(d.spectra.combined(w))
    }

    /// Display `id` and how much of each of its five spectra reach the meter at
    /// `drive` and `uv` (screen gain toward the meter included).
    fn spot_weights(
        &self,
        id: DisplayId,
        drive: [f64; 3],
        uv: [f64; 2],
    ) -> Result<(&SimDisplay, [f64; 5]), DeviceError> {
        let d = self.display(id)?;
        check_drive(drive)?;
        check_uv(uv)?;
        let spot = d.spot_m(uv);
        let meter = screen::meter_position_m(&self.file.meter, spot);
        let g = screen::gain(&self.file.screen, d.lens_m(), spot, meter);
        Ok((d, d.weights(drive, uv, self.conditions(d)).map(|w| w * g)))
    }

    /// The display the meter is aimed at, the spot, and the drive shown there.
    fn aimed_drive(&self) -> Result<(DisplayId, [f64; 3], [f64; 2]), DeviceError> {
        let (id, uv) = self.aimed.ok_or_else(|| {
            DeviceError::Config(
                "the simulated meter is not aimed at any display; aim it with the positioner first"
                    .into(),
            )
        })?;
        let drive = match &self.shown {
            Some((shown, pattern)) if *shown == id => pattern.drive_at(uv),
            _ => [0.0; 3],
        };
        Ok((id, drive, uv))
    }
}

fn finite_at_least(what: &str, v: f64, min: f64) -> Result<(), DeviceError> {
    if v.is_finite() && v >= min {
        Ok(())
    } else {
        Err(DeviceError::Config(format!(
            "{what} must be a finite number >= {min}, got {v}"
        )))
    }
}

/// Most tiles (`tiles.cols × tiles.rows`) a wall file may describe.
pub const MAX_TILES: u64 = 4096;
/// Largest width or height of one tile (m).
pub const MAX_TILE_SIZE_M: f64 = 1000.0;
/// Most pass bands one Infitec comb filter may have.
pub const MAX_COMB_BANDS: usize = 64;
/// Largest manufacturing scatter a wall file may ask for (any `scatter.*` value):
/// far above anything physical, far below where drawing ±value overflows.
pub const MAX_SCATTER: f64 = 1.0e6;
/// Most `[[override]]` tables a wall file may have.
pub const MAX_OVERRIDES: usize = 2 * MAX_TILES as usize;

/// Checks the name, the size and the tile geometry of a wall file with exact
/// arithmetic, before anything is allocated; returns the number of displays.
fn validate_shape(file: &WallFile) -> Result<u32, DeviceError> {
    if file.name.trim().is_empty() {
        return Err(DeviceError::Config(
            "name is empty; give the wall a name (it goes into every display key and \
             profile, e.g. name = \"hall-a\")"
                .into(),
        ));
    }
    let t = &file.tiles;
    if t.cols == 0 || t.rows == 0 {
        return Err(DeviceError::Config(format!(
            "tiles.cols and tiles.rows must be at least 1, got cols = {}, rows = {}",
            t.cols, t.rows
        )));
    }
    // u32 × u32 always fits in u64: the product is exact, never wrapped.
    let tiles = u64::from(t.cols) * u64::from(t.rows);
    if tiles > MAX_TILES {
        return Err(DeviceError::Config(format!(
            "tiles.cols × tiles.rows = {} × {} = {tiles} tiles, more than the {MAX_TILES} a \
             wall may have; check tiles.cols and tiles.rows",
            t.cols, t.rows
        )));
    }
    for (what, v) in [("tiles.width_m", t.width_m), ("tiles.height_m", t.height_m)] {
        if !(v.is_finite() && v > 0.0 && v <= MAX_TILE_SIZE_M) {
            return Err(DeviceError::Config(format!(
                "{what} must be a finite number > 0 and <= {MAX_TILE_SIZE_M} m, got {v}"
            )));
        }
    }
    finite_at_least(
        "clock.seconds_per_reading",
        file.clock.seconds_per_reading,
        0.0,
    )?;
    let eyes: u64 = match file.stereo {
        Stereo::Mono => 1,
        Stereo::Infitec => 2,
    };
    let n = u32::try_from(tiles * eyes).map_err(|_| {
        DeviceError::Config(format!(
            "{tiles} tiles × {eyes} eyes do not fit a display id"
        ))
    })?;
    if file.overrides.len() > MAX_OVERRIDES {
        return Err(DeviceError::Config(format!(
            "{} [[override]] tables, at most {MAX_OVERRIDES} allowed",
            file.overrides.len()
        )));
    }
    if let Some(o) = file.overrides.iter().find(|o| o.display >= n) {
        return Err(DeviceError::Config(format!(
            "override for display {} but the wall has only {n} displays (#0..#{})",
            o.display,
            n - 1
        )));
    }
    for (eye, comb) in [("left", &file.infitec.left), ("right", &file.infitec.right)] {
        if comb.bands.len() > MAX_COMB_BANDS {
            return Err(DeviceError::Config(format!(
                "infitec.{eye} has {} pass bands, at most {MAX_COMB_BANDS} allowed",
                comb.bands.len()
            )));
        }
    }
    Ok(n)
}

/// Longest `to` of an `[[output]]`, characters.
const MAX_OUTPUT_ADDRESS_CHARS: usize = 300;

/// Longest call deadline a wall file may ask for (a minute).
const MAX_DEADLINE_MS: u64 = 60_000;

/// Checks the `[[output]]` tables against the grid and the stereo mode, and that a
/// `[network]` section comes with them; `n` is the number of displays.
fn validate_outputs(file: &WallFile, n: u32) -> Result<(), DeviceError> {
    if file.outputs.is_empty() {
        return Ok(());
    }
    if file.outputs.len() > n as usize {
        return Err(DeviceError::Config(format!(
            "{} [[output]] tables for {n} displays",
            file.outputs.len()
        )));
    }
    for (i, o) in file.outputs.iter().enumerate() {
        let at = format!("[[output]] #{} (to = {:?})", i + 1, o.to);
        let [col, row] = o.tile;
        if col >= file.tiles.cols || row >= file.tiles.rows {
            return Err(DeviceError::Config(format!(
                "{at}: tile [{col}, {row}] is outside the {} × {} grid",
                file.tiles.cols, file.tiles.rows
            )));
        }
        let eye_ok = matches!(
            (file.stereo, o.eye),
            (Stereo::Mono, None | Some(Eye::Mono))
                | (Stereo::Infitec, Some(Eye::Left | Eye::Right))
        );
        if !eye_ok {
            return Err(DeviceError::Config(format!(
                "{at}: eye {:?} does not fit a {:?} wall (mono: omit eye; infitec: left or right)",
                o.eye, file.stereo
            )));
        }
        if o.to.is_empty() || o.to.chars().count() > MAX_OUTPUT_ADDRESS_CHARS {
            return Err(DeviceError::Config(format!(
                "{at}: to must be tcp://HOST:PORT/OUTPUT"
            )));
        }
    }
    match &file.network {
        None => Err(DeviceError::Config(
            "[[output]] tables need a [network] section with token_file (the wall's shared \
             token)"
                .into(),
        )),
        Some(net) if net.deadline_ms == 0 || net.deadline_ms > MAX_DEADLINE_MS => {
            Err(DeviceError::Config(format!(
                "network.deadline_ms must be 1 to {MAX_DEADLINE_MS}, got {}",
                net.deadline_ms
            )))
        }
        Some(_) => Ok(()),
    }
}

/// Checks the parts of a wall file outside the projector model.
fn validate_optics(file: &WallFile) -> Result<(), DeviceError> {
    finite_at_least(
        "clock.minutes_since_switch_on",
        file.clock.minutes_since_switch_on,
        0.0,
    )?;
    finite_at_least("screen.diffuse_gain", file.screen.diffuse_gain, 0.0)?;
    finite_at_least("screen.specular_gain", file.screen.specular_gain, 0.0)?;
    finite_at_least(
        "screen.specular_width_deg",
        file.screen.specular_width_deg,
        1e-3,
    )?;
    finite_at_least("meter.distance_m", file.meter.distance_m, 1e-3)?;
    if let Some(p) = file.meter.position_m
        && (p.iter().any(|v| !v.is_finite()) || p[2] <= 0.0)
    {
        return Err(DeviceError::Config(format!(
            "meter.position_m {p:?} must be finite and in front of the screen (z > 0)"
        )));
    }
    if file.stereo == Stereo::Infitec {
        for (eye, comb) in [("left", &file.infitec.left), ("right", &file.infitec.right)] {
            if comb.bands.is_empty() {
                return Err(DeviceError::Config(format!(
                    "infitec.{eye} has no pass bands"
                )));
            }
            finite_at_least(&format!("infitec.{eye}.leak"), comb.leak, 0.0)?;
            for b in &comb.bands {
                check_band(&format!("infitec.{eye} band"), b)?;
            }
        }
    }
    let panel = file.projector.panel;
    for (channel, b) in Channel::ALL.into_iter().zip(panel.bands()) {
        check_band(&format!("projector.panel.{channel}"), &b)?;
    }
    let s = &file.scatter;
    for (what, v) in [
        ("scatter.lamp_power_rel", s.lamp_power_rel),
        ("scatter.panel_shift_nm", s.panel_shift_nm),
        ("scatter.comb_shift_nm", s.comb_shift_nm),
        ("scatter.channel_gain_rel", s.channel_gain_rel),
        ("scatter.gamma", s.gamma),
        ("scatter.curve_shape", s.curve_shape),
        ("scatter.vignetting_rel", s.vignetting_rel),
        ("scatter.hotspot_offset", s.hotspot_offset),
    ] {
        finite_at_least(what, v, 0.0)?;
        // ±v is drawn uniformly: 2v must stay finite (1e308 panicked in the sampler).
        if v > MAX_SCATTER {
            return Err(DeviceError::Config(format!(
                "{what} must be <= {MAX_SCATTER:e}, got {v:e}"
            )));
        }
    }
    if s.lamp_power_rel >= 1.0 || s.channel_gain_rel >= 1.0 {
        return Err(DeviceError::Config(
            "scatter.lamp_power_rel and scatter.channel_gain_rel must be < 1".into(),
        ));
    }
    if let Some([lo, hi]) = s.lamp_hours
        && !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi >= lo)
    {
        return Err(DeviceError::Config(format!(
            "scatter.lamp_hours [{lo}, {hi}] must satisfy 0 <= min <= max"
        )));
    }
    Ok(())
}

fn check_band(what: &str, b: &Band) -> Result<(), DeviceError> {
    let ok = b.lo_nm.is_finite()
        && b.hi_nm.is_finite()
        && b.lo_nm < b.hi_nm
        && b.edge_nm.is_finite()
        && b.edge_nm > 0.0
        && (0.0..=1.0).contains(&b.peak)
        && (0.0..=b.peak).contains(&b.floor);
    if ok {
        Ok(())
    } else {
        Err(DeviceError::Config(format!(
            "{what} {b:?} needs lo_nm < hi_nm, edge_nm > 0 and 0 <= floor <= peak <= 1"
        )))
    }
}

fn check_uv(uv: [f64; 2]) -> Result<(), DeviceError> {
    if uv.iter().all(|d| d.is_finite() && (0.0..=1.0).contains(d)) {
        Ok(())
    } else {
        Err(DeviceError::Config(format!(
            "meter spot uv {uv:?} is outside the display (0..=1)"
        )))
    }
}

/// The wall file at `path`, parsed.
fn read_wall_file(path: &Path) -> Result<WallFile, DeviceError> {
    let text = std::fs::read_to_string(path).map_err(|source| DeviceError::Io {
        device: format!("wall file {}", path.display()),
        source,
    })?;
    toml::from_str(&text)
        .map_err(|e| in_wall_file(DeviceError::Config(format!("wall TOML: {e}")), path))
}

/// `e` with the wall file's path in a configuration error's message.
fn in_wall_file(e: DeviceError, path: &Path) -> DeviceError {
    match e {
        DeviceError::Config(msg) => {
            DeviceError::Config(format!("wall file {}: {msg}", path.display()))
        }
        other => other,
    }
}

/// A simulated projection wall. Cloning is cheap: all clones (and the pattern
/// output, positioner and meters made from it) share one state, so a meter on
/// another thread sees the patterns shown here.
#[derive(Debug, Clone)]
pub struct VirtualWall {
    state: Arc<Mutex<WallState>>,
}

impl VirtualWall {
    /// Loads a wall file (TOML).
    pub fn from_toml_file(path: &Path) -> Result<Self, DeviceError> {
        Self::from_wall_file(read_wall_file(path)?).map_err(|e| in_wall_file(e, path))
    }

    /// Loads a wall file (TOML) with its `seed` replaced by `seed`: another instance
    /// of the wall's class, its manufacturing scatter and meter noise drawn again
    /// (`lumiwall bench readings --seeds`).
    pub fn from_toml_file_with_seed(path: &Path, seed: u64) -> Result<Self, DeviceError> {
        let file = WallFile {
            seed,
            ..read_wall_file(path)?
        };
        Self::from_wall_file(file).map_err(|e| in_wall_file(e, path))
    }

    /// Builds a wall from TOML text.
    pub fn from_toml_str(text: &str) -> Result<Self, DeviceError> {
        let file: WallFile =
            toml::from_str(text).map_err(|e| DeviceError::Config(format!("wall TOML: {e}")))?;
        Self::from_wall_file(file)
    }

    /// Builds a wall from a parsed wall file. Everything the file says is checked
    /// before anything is built: its name, its size (with exact arithmetic, against
    /// [`MAX_TILES`]), the tile geometry, the projector model (bit depth included) and
    /// the optics.
    pub fn from_wall_file(file: WallFile) -> Result<Self, DeviceError> {
        let n = validate_shape(&file)?;
        validate_outputs(&file, n)?;
        validate_spec(&file.projector)?;
        validate_optics(&file)?;
        file.camera.validate()?;
        let t = &file.tiles;
        let eyes: &[Eye] = match file.stereo {
            Stereo::Mono => &[Eye::Mono],
            Stereo::Infitec => &[Eye::Left, Eye::Right],
        };
        let mut displays = Vec::with_capacity(n as usize);
        for &eye in eyes {
            for row in 0..t.rows {
                for col in 0..t.cols {
                    let index = displays.len() as u32;
                    let mut rng = ChaCha8Rng::seed_from_u64(file.seed);
                    rng.set_stream(u64::from(index) + 1);
                    displays.push(SimDisplay::build(&file, index, col, row, eye, &mut rng)?);
                }
            }
        }
        Ok(Self {
            state: Arc::new(Mutex::new(WallState {
                switched_on_s: -60.0 * file.clock.minutes_since_switch_on,
                file,
                displays,
                clock_s: 0.0,
                shown: None,
                aimed: None,
            })),
        })
    }

    /// Checks that `display` exists, then that `valid` (the checked argument) holds,
    /// then applies `set` to the state: what showing and aiming share.
    fn set_for(
        &self,
        display: DisplayId,
        valid: Result<(), DeviceError>,
        set: impl FnOnce(&mut WallState),
    ) -> Result<(), DeviceError> {
        let mut s = self.lock();
        s.display(display)?;
        valid?;
        set(&mut s);
        Ok(())
    }

    pub(crate) fn lock(&self) -> MutexGuard<'_, WallState> {
        // A panic in another thread cannot leave the state half-updated (every update
        // is a single assignment), so a poisoned lock is safe to reuse.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Name of the wall.
    pub fn name(&self) -> String {
        self.lock().file.name.clone()
    }

    /// Seed of the wall.
    pub fn seed(&self) -> u64 {
        self.lock().file.seed
    }

    /// The parsed wall file.
    pub fn wall_file(&self) -> WallFile {
        self.lock().file.clone()
    }

    /// The displays in wall order.
    pub fn displays(&self) -> Vec<DisplayInfo> {
        self.lock()
            .displays
            .iter()
            .map(|d| d.info.clone())
            .collect()
    }

    /// The `[[output]]` routes of the wall file, each with its display (empty when the
    /// patterns go to this simulator).
    pub fn output_routes(&self) -> Vec<(DisplayId, String)> {
        let s = self.lock();
        s.file
            .outputs
            .iter()
            .filter_map(|o| {
                let eye = o.eye.unwrap_or(Eye::Mono);
                s.displays
                    .iter()
                    .find(|d| {
                        d.info.tile_col == o.tile[0]
                            && d.info.tile_row == o.tile[1]
                            && d.info.eye == eye
                    })
                    .map(|d| (d.info.id, o.to.clone()))
            })
            .collect()
    }

    /// A pattern output showing on this wall.
    pub fn pattern_output(&self) -> SimPatternOutput {
        SimPatternOutput { wall: self.clone() }
    }

    /// A positioner aiming the meter on this wall.
    pub fn positioner(&self) -> SimPositioner {
        SimPositioner { wall: self.clone() }
    }

    /// A meter with error model `model` reading this wall.
    pub fn meter(&self, model: MeterModel) -> SimMeter {
        SimMeter::new(self.clone(), model)
    }

    /// A simulated spectroradiometer with error model `model` reading this wall.
    pub fn spectroradiometer(
        &self,
        model: super::spectroradiometer::SpectroModel,
    ) -> Result<super::spectroradiometer::SimSpectroradiometer, DeviceError> {
        super::spectroradiometer::SimSpectroradiometer::new(self.clone(), model)
    }

    /// Noiseless XYZ (cd/m², black included) that display `id` sends to the meter
    /// position at `uv` for `drive` (0..=1 per channel, quantised to its bit depth),
    /// at the current simulation time. Does not advance the clock.
    pub fn emitted_xyz(
        &self,
        id: DisplayId,
        drive: [f64; 3],
        uv: [f64; 2],
    ) -> Result<Xyz, DeviceError> {
        self.lock().emitted(id, drive, uv)
    }

    /// The true primaries of display `id` at its centre now, as a perfect meter
    /// would read them (black included): black, red, green, blue, white.
    pub fn true_primaries(&self, id: DisplayId) -> Result<TruePrimaries, DeviceError> {
        let s = self.lock();
        let c = [0.5, 0.5];
        Ok(TruePrimaries {
            black: s.emitted(id, [0.0; 3], c)?,
            red: s.emitted(id, [1.0, 0.0, 0.0], c)?,
            green: s.emitted(id, [0.0, 1.0, 0.0], c)?,
            blue: s.emitted(id, [0.0, 0.0, 1.0], c)?,
            white: s.emitted(id, [1.0; 3], c)?,
        })
    }

    /// True relative intensity (black removed, 1 at full drive) of `channel`
    /// (0 = R, 1 = G, 2 = B) of display `id` for `drive`, after quantisation: the
    /// curve a calibration should recover.
    pub fn true_relative_intensity(
        &self,
        id: DisplayId,
        channel: usize,
        drive: f64,
    ) -> Result<f64, DeviceError> {
        let s = self.lock();
        let d = s.display(id)?;
        if Channel::from_index(channel).is_err() {
            return Err(DeviceError::Config(format!(
                "channel {channel} does not exist (0 = red, 1 = green, 2 = blue)"
            )));
        }
        check_drive([drive; 3])?;
        Ok(d.relative_intensity(channel, drive))
    }

    /// Lamp hours of display `id` now.
    pub fn lamp_hours(&self, id: DisplayId) -> Result<f64, DeviceError> {
        let s = self.lock();
        let d = s.display(id)?;
        Ok(s.conditions(d).lamp_hours)
    }

    /// Simulated seconds since the simulation started.
    pub fn elapsed_s(&self) -> f64 {
        self.lock().clock_s
    }

    /// Lets `hours` of lamp operation pass (ageing and clock; lamps stay on).
    pub fn advance_hours(&self, hours: f64) {
        if hours.is_finite() && hours > 0.0 {
            self.lock().clock_s += hours * 3600.0;
        }
    }

    /// Switches every projector off and on again now: the lamps warm up again from
    /// cold (their hours go on), as when a nightly run switches the wall on.
    pub fn switch_on_again(&self) {
        let mut s = self.lock();
        s.switched_on_s = s.clock_s;
    }

    /// Replaces the lamp of display `id` now: its lamp hours start again at 0 (the
    /// new lamp's burn-in is still to come). The lamp's power and the projector's
    /// optics stay as they were.
    pub fn replace_lamp(&self, id: DisplayId) -> Result<(), DeviceError> {
        let mut s = self.lock();
        let now_h = s.clock_s / 3600.0;
        s.display(id)?;
        if let Some(d) = s.displays.get_mut(id.0 as usize) {
            d.lamp_hours_at_start = -now_h;
        }
        Ok(())
    }

    /// An independent copy of the wall as it is now (displays, lamps, clock, the
    /// pattern shown): advancing its clock or replacing its lamps leaves this wall
    /// untouched, and the other way round. For looking ahead at the truth, e.g. when a
    /// forecast is checked.
    pub fn snapshot(&self) -> VirtualWall {
        VirtualWall {
            state: Arc::new(Mutex::new(self.lock().clone())),
        }
    }

    /// Lets `seconds` pass on the simulation clock.
    pub fn advance_seconds(&self, seconds: f64) {
        if seconds.is_finite() && seconds > 0.0 {
            self.lock().clock_s += seconds;
        }
    }

    /// Each display's five spectra (`[R, G, B, black, white segment]`) integrated by
    /// `integrate`: an instrument's view of the displays (see
    /// [`VirtualWall::read_spot_in`]).
    pub(crate) fn integrated_spectra(
        &self,
        integrate: impl Fn(&super::observer::Spectrum) -> [f64; 3],
    ) -> Vec<[[f64; 3]; 5]> {
        let s = self.lock();
        s.displays
            .iter()
            .map(|d| d.spectra.integrated(&integrate))
            .collect()
    }

    /// What the meter sees now, noiseless, through an instrument whose integration of
    /// display `i`'s spectra is `basis[i]` (`None`: the CIE 1931 observer, the truth);
    /// advances the clock by one reading.
    pub(crate) fn read_spot_in(&self, basis: Option<&[[[f64; 3]; 5]]>) -> Result<Xyz, DeviceError> {
        let mut s = self.lock();
        let (id, drive, uv) = s.aimed_drive()?;
        let xyz = s.emitted_in(id, drive, uv, basis)?;
        s.clock_s += s.file.clock.seconds_per_reading;
        Ok(xyz)
    }

    /// The spectrum the meter sees now, noiseless (the truth a spectroradiometer
    /// samples); advances the clock by one reading.
    pub(crate) fn read_spot_spectrum(&self) -> Result<Spectrum, DeviceError> {
        let mut s = self.lock();
        let (id, drive, uv) = s.aimed_drive()?;
        let spectrum = s.emitted_spectrum(id, drive, uv)?;
        s.clock_s += s.file.clock.seconds_per_reading;
        Ok(spectrum)
    }

    /// The spectral radiance display `id` sends toward the meter at `drive` and `uv`,
    /// now, noiseless, scaled so that the CIE 1931 observer gives XYZ in cd/m² (what
    /// [`VirtualWall::emitted_xyz`] integrates).
    pub fn emitted_spectrum(
        &self,
        id: DisplayId,
        drive: [f64; 3],
        uv: [f64; 2],
    ) -> Result<Spectrum, DeviceError> {
        self.lock().emitted_spectrum(id, drive, uv)
    }
}

/// True primaries of a display (black included in each).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruePrimaries {
    /// All channels at 0.
    pub black: Xyz,
    /// Red at full drive.
    pub red: Xyz,
    /// Green at full drive.
    pub green: Xyz,
    /// Blue at full drive.
    pub blue: Xyz,
    /// All channels at full drive.
    pub white: Xyz,
}

/// Shows patterns on a [`VirtualWall`].
#[derive(Debug, Clone)]
pub struct SimPatternOutput {
    wall: VirtualWall,
}

impl PatternOutput for SimPatternOutput {
    fn displays(&self) -> Vec<DisplayInfo> {
        self.wall.displays()
    }

    fn show(&mut self, display: DisplayId, drive: [f64; 3]) -> Result<(), DeviceError> {
        self.wall.set_for(display, check_drive(drive), |s| {
            s.shown = Some((display, Shown::Uniform(drive)));
        })
    }

    fn show_image(&mut self, display: DisplayId, image: &DriveImage) -> Result<(), DeviceError> {
        let image = Arc::new(image.clone());
        self.wall.set_for(display, check_image(&image), |s| {
            s.shown = Some((display, Shown::Image(image)));
        })
    }
}

/// Fails unless the image has the pixels its size says, each drive in 0..=1.
fn check_image(image: &DriveImage) -> Result<(), DeviceError> {
    let n = u64::from(image.width_px) * u64::from(image.height_px);
    if n == 0 || image.drive.len() as u64 != n {
        return Err(DeviceError::Config(format!(
            "pattern image {}×{} holds {} pixels",
            image.width_px,
            image.height_px,
            image.drive.len()
        )));
    }
    image
        .drive
        .iter()
        .try_for_each(|d| check_drive(d.map(f64::from)))
}

/// Aims the simulated meter.
#[derive(Debug, Clone)]
pub struct SimPositioner {
    wall: VirtualWall,
}

impl MeterPositioner for SimPositioner {
    fn aim(&mut self, display: DisplayId, uv: [f64; 2]) -> Result<(), DeviceError> {
        self.wall
            .set_for(display, check_uv(uv), |s| s.aimed = Some((display, uv)))
    }
}
