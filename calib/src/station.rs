//! The devices of a calibration station, opened together: the virtual wall's pattern
//! output and meter positioner, and a meter — the simulated one called directly, the
//! simulated one served through the Klein K-10A protocol on a pseudo-terminal and read
//! by the real serial driver, or a real K-10A on a serial port.
//!
//! The command line (`lumiwall commission`, `verify`, `bench readings`), the station
//! app, the pattern server and the integration tests all open their devices here, so
//! they exercise the same meter path.

// The wrappers return the (large) errors of `commission` and `verify_wall` unchanged.
#![expect(
    clippy::result_large_err,
    reason = "returns the errors of commission and verify_wall unchanged"
)]

use std::path::{Path, PathBuf};
use std::time::Duration;

use lumiwall_core::Eye;
use lumiwall_devices::serial::{
    EmulatedSpecbos, Emulator, EmulatorOptions, FaultPlan, JetiSpecbos, K10aConfig, KleinK10a,
    SpecbosConfig, SpecbosEmulatorOptions,
};
use lumiwall_devices::sim::{MeterModel, SpectroModel, VirtualWall};
use lumiwall_devices::{
    Colorimeter, DeviceError, DisplayId, DisplayInfo, DriveImage, GuidedPositioner,
    MeterPositioner, PatternOutput,
};
use lumiwall_devices::{
    CorrectedReference, GuidedLampHolder, LampHolder, LineLamp, Spectroradiometer, WavelengthScale,
};
use lumiwall_pattern::client::{NodeOptions, RemotePatternOutput, Route, SimulatorSink};
use lumiwall_pattern::{OutputAddress, Token};
use lumiwall_profiles::DisplayProfile;

use crate::commission::{CommissionError, CommissionOptions, CommissionOutcome, commission};
use crate::measure::meter_matrix::{MeterMatrices, MeterMatrixError, PatchXyError};
use crate::measure::wavelength_check::{self, WavelengthCheck, WavelengthCheckError};
use crate::measure::{Progress, Rig};
use crate::verify::{Target, VerifyError, VerifyOptions, VerifyReport, verify_wall};

/// Which meter the station reads.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MeterChoice {
    /// The simulated meter served on a pty by the instrument emulator, read by the
    /// serial driver (exercises the real protocol).
    Emulated,
    /// The simulated meter called directly (fast; for comparisons and big benches).
    Direct,
    /// A real Klein K-10A on this serial port.
    Serial(String),
}

impl std::str::FromStr for MeterChoice {
    type Err = String;

    /// Parses `emulated`, `direct` or `serial:PATH`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "emulated" => Ok(Self::Emulated),
            "direct" => Ok(Self::Direct),
            _ => match s.strip_prefix("serial:") {
                Some(p) if !p.is_empty() => Ok(Self::Serial(p.to_string())),
                _ => Err(format!(
                    "unknown meter '{s}': use emulated, direct or serial:/dev/ttyUSB0"
                )),
            },
        }
    }
}

/// Error model of the simulated meter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Noise {
    /// The instrument's datasheet error model (CS-100A class: 2 % luminance, ±0.004 xy,
    /// worse below 1 cd/m²).
    Realistic,
    /// Exact readings.
    None,
}

impl Noise {
    /// Both error models, exact first.
    pub const ALL: [Noise; 2] = [Noise::None, Noise::Realistic];

    /// The simulated meter's model; `seed` plays the instrument's serial number.
    pub fn model(self, seed: u64) -> MeterModel {
        match self {
            Noise::Realistic => MeterModel::cs100a(seed),
            Noise::None => MeterModel::noiseless(),
        }
    }

    /// The lower-case name (`realistic`, `none`).
    pub fn name(self) -> &'static str {
        match self {
            Noise::Realistic => "realistic",
            Noise::None => "none",
        }
    }
}

impl std::str::FromStr for Noise {
    type Err = String;

    /// Parses `realistic` or `none`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "realistic" => Ok(Self::Realistic),
            "none" => Ok(Self::None),
            _ => Err(format!("unknown meter noise '{s}': use realistic or none")),
        }
    }
}

/// Speed of the emulated instrument used by default: a tenth of a real K-10A's
/// measurement time, so a 48-display wall commissions in minutes.
pub const DEFAULT_TIME_SCALE: f64 = 0.1;

/// Driver settings of the station: the calibration retries transient errors itself, so
/// the driver does not (a dead meter is reported after one timeout per attempt).
pub fn driver_config() -> K10aConfig {
    K10aConfig {
        retries: 0,
        read_timeout: Duration::from_secs(2),
        ..K10aConfig::default()
    }
}

/// The reference spectroradiometer a meter matrix is made against
/// ([`Station::open_reference`]).
#[derive(Debug, Clone, PartialEq)]
pub enum ReferenceChoice {
    /// A simulated instrument reading the virtual wall directly.
    Simulated(SpectroModel),
    /// A simulated instrument served as a JETI specbos on a pseudo-terminal and read
    /// through lumiwall's specbos driver (the whole serial path).
    Emulated {
        /// The simulated instrument.
        model: SpectroModel,
        /// Factor on the instrument's measurement time (1 = real timing).
        time_scale: f64,
    },
    /// A JETI specbos 1201/1211 on a serial port.
    Serial(String),
}

/// A reference spectroradiometer as the station uses it ([`Station::open_reference`]):
/// the instrument, the holder of its wavelength-check lamp, and what that check found.
pub struct Reference {
    instrument: Box<dyn Spectroradiometer + Send>,
    lamp_holder: Box<dyn LampHolder + Send>,
    check: Option<WavelengthCheck>,
    simulated_offset_nm: Option<f64>,
}

impl Reference {
    /// Checks the instrument's wavelength scale with `lamp`
    /// ([`crate::measure::wavelength_check`]); its readings are corrected with the
    /// scale found from then on.
    pub fn check_wavelengths(
        &mut self,
        lamp: &LineLamp,
    ) -> Result<&WavelengthCheck, WavelengthCheckError> {
        let check =
            wavelength_check::check(self.instrument.as_mut(), self.lamp_holder.as_mut(), lamp)?;
        Ok(self.check.insert(check))
    }

    /// The simulated instrument's true wavelength offset (nm; `None` for a real one),
    /// to judge the check by.
    pub fn simulated_offset_nm(&self) -> Option<f64> {
        self.simulated_offset_nm
    }

    /// The instrument read as a colorimeter, corrected for its bandwidth and checked
    /// wavelength scale.
    pub fn corrected(&mut self) -> CorrectedReference<'_> {
        CorrectedReference {
            scale: self
                .check
                .as_ref()
                .map_or(WavelengthScale::NOMINAL, |c| c.scale),
            instrument: self.instrument.as_mut(),
        }
    }
}

/// How to open a station's meter.
#[derive(Debug, Clone)]
pub struct StationOptions {
    /// Which meter.
    pub meter: MeterChoice,
    /// Error model of the simulated meter (seeded with the wall's seed).
    pub noise: Noise,
    /// Factor on the emulated instrument's real measurement time (1 = real timing).
    pub time_scale: f64,
    /// Faults injected into the emulated meter (`MeterChoice::Emulated` only).
    pub faults: FaultPlan,
    /// Settings of the serial driver (emulated and real meters).
    pub driver: K10aConfig,
    /// Who aims the meter.
    pub aim: AimChoice,
    /// Set to stop the run: the next pattern is refused with
    /// [`DeviceError::Stopped`] (`None`: the run
    /// cannot be stopped from outside).
    pub stop: Option<StopFlag>,
    /// Where guided aiming prompts the technician and reads the answers (`None`: the
    /// terminal, stdin and stdout; the station app passes its own window).
    pub technician: Option<TechnicianLink>,
}

/// A flag another thread sets to stop a station's run between two patterns.
pub type StopFlag = std::sync::Arc<std::sync::atomic::AtomicBool>;

/// The technician's side of guided aiming for a station opened elsewhere: the answers
/// (lines, as typed at the terminal: empty = aimed, `r`, `s`, `q`) and where the prompts
/// and live readings go. The first station opened with it takes both.
#[derive(Clone, Default)]
pub struct TechnicianLink(std::sync::Arc<std::sync::Mutex<Option<TechnicianIo>>>);

/// The two ends a [`TechnicianLink`] carries.
type TechnicianIo = (
    Box<dyn std::io::BufRead + Send>,
    Box<dyn std::io::Write + Send>,
);

impl TechnicianLink {
    /// A link that reads answers from `answers` and writes prompts to `prompts`.
    pub fn new(
        answers: Box<dyn std::io::BufRead + Send>,
        prompts: Box<dyn std::io::Write + Send>,
    ) -> Self {
        Self(std::sync::Arc::new(std::sync::Mutex::new(Some((
            answers, prompts,
        )))))
    }

    /// Both ends, once (`None` once taken).
    fn take(&self) -> Option<TechnicianIo> {
        self.0.lock().ok().and_then(|mut io| io.take())
    }
}

impl std::fmt::Debug for TechnicianLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("TechnicianLink")
    }
}

/// A pattern output that refuses to show anything once its stop flag is set.
struct Stoppable {
    inner: Box<dyn PatternOutput + Send>,
    stop: StopFlag,
}

impl Stoppable {
    fn check(&self, display: DisplayId) -> Result<(), DeviceError> {
        if self.stop.load(std::sync::atomic::Ordering::Relaxed) {
            return Err(DeviceError::Stopped(display.to_string()));
        }
        Ok(())
    }
}

impl PatternOutput for Stoppable {
    fn displays(&self) -> Vec<DisplayInfo> {
        self.inner.displays()
    }

    fn show(&mut self, display: DisplayId, drive: [f64; 3]) -> Result<(), DeviceError> {
        self.check(display)?;
        self.inner.show(display, drive)
    }

    fn show_image(&mut self, display: DisplayId, image: &DriveImage) -> Result<(), DeviceError> {
        self.check(display)?;
        self.inner.show_image(display, image)
    }

    fn show_aim_marker(&mut self, display: DisplayId, uv: [f64; 2]) -> Result<(), DeviceError> {
        self.check(display)?;
        self.inner.show_aim_marker(display, uv)
    }
}

/// Who aims the meter at each display.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AimChoice {
    /// A technician with a real meter, the simulator with a simulated one.
    Auto,
    /// A technician, prompted in the terminal (stdin/stdout) with an aiming pattern and
    /// live readings.
    Guided,
    /// The simulator (the virtual wall's meter is aimed by software).
    Simulated,
}

impl std::str::FromStr for AimChoice {
    type Err = String;

    /// Parses `auto`, `guided` or `simulated`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(Self::Auto),
            "guided" => Ok(Self::Guided),
            "simulated" => Ok(Self::Simulated),
            _ => Err(format!(
                "unknown aiming '{s}': use auto, guided or simulated"
            )),
        }
    }
}

impl StationOptions {
    /// `meter` with `noise`, the default time scale, no faults and [`driver_config`].
    pub fn new(meter: MeterChoice, noise: Noise) -> Self {
        Self {
            meter,
            noise,
            time_scale: DEFAULT_TIME_SCALE,
            faults: FaultPlan::default(),
            driver: driver_config(),
            aim: AimChoice::Auto,
            stop: None,
            technician: None,
        }
    }
}

/// Why a station could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum StationError {
    /// The wall file could not be read or is invalid.
    #[error("cannot load wall {}: {source}", path.display())]
    Wall {
        /// The wall file.
        path: PathBuf,
        /// What was wrong with it.
        #[source]
        source: DeviceError,
    },
    /// The pty emulator could not be started.
    #[error("cannot start the meter emulator: {0}")]
    Emulator(#[source] DeviceError),
    /// The serial driver could not open the emulator's pty.
    #[error("cannot open the emulated meter: {0}")]
    EmulatedMeter(#[source] DeviceError),
    /// The serial driver could not open the real meter.
    #[error("cannot open the meter on {port}: {source}")]
    Meter {
        /// The serial port.
        port: String,
        /// What the driver reported.
        #[source]
        source: DeviceError,
    },
    /// A real meter with a wall file that sends the patterns nowhere real.
    #[error(
        "wall {wall} has no [[output]] tables: the patterns would go to the simulator while \
         the meter on {port} reads the real wall. Add an [[output]] per display and a \
         [network] section (README, \"Setting up a real wall\"), or use --meter emulated \
         for the virtual wall"
    )]
    NoOutputs {
        /// The wall's name.
        wall: String,
        /// The real meter's port.
        port: String,
    },
    /// The render nodes of the wall's `[[output]]` tables cannot be used.
    #[error("cannot drive the wall's render nodes: {0}")]
    Nodes(#[source] DeviceError),
}

/// The devices of a station: the pattern output (the virtual wall's, or the render
/// nodes the wall file names), the positioner and a meter (possibly behind the pty
/// emulator).
pub struct Station {
    /// The virtual wall.
    pub wall: VirtualWall,
    /// Pattern output.
    pub pattern: Box<dyn PatternOutput + Send>,
    /// Positioner.
    pub positioner: Box<dyn MeterPositioner + Send>,
    /// The meter as the calibration sees it.
    pub meter: Box<dyn Colorimeter + Send>,
    /// The emulator serving the pty, if any (stopped on drop of the station).
    emulator: Option<Emulator>,
}

impl std::fmt::Debug for Station {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Station")
            .field("wall", &self.wall.name())
            .field("meter", &self.meter.info())
            .field("emulated", &self.emulator.is_some())
            .finish()
    }
}

impl Station {
    /// Opens the wall file, the meter `opts` names and the pattern output: the render
    /// nodes of the wall file's `[[output]]` tables (fed back into the virtual wall
    /// when the meter is simulated), or the virtual wall's own.
    pub fn open(wall_path: &Path, opts: &StationOptions) -> Result<Self, StationError> {
        let wall = VirtualWall::from_toml_file(wall_path).map_err(|source| StationError::Wall {
            path: wall_path.to_path_buf(),
            source,
        })?;
        let mut station = Self::with_wall(wall, opts)?;
        if !station.wall.output_routes().is_empty() {
            station.pattern = remote_pattern(&station.wall, wall_path, &opts.meter)?;
            station.stoppable(opts);
        } else if let MeterChoice::Serial(port) = &opts.meter {
            return Err(StationError::NoOutputs {
                wall: station.wall.name(),
                port: port.clone(),
            });
        }
        Ok(station)
    }

    /// Opens the meter `opts` names on an already loaded wall (clones of one wall share
    /// its state: a second station on a clone sees the same lamps and clock).
    pub fn with_wall(wall: VirtualWall, opts: &StationOptions) -> Result<Self, StationError> {
        let model = opts.noise.model(wall.seed());
        let (meter, emulator): (Box<dyn Colorimeter + Send>, Option<Emulator>) = match &opts.meter {
            MeterChoice::Direct => (Box::new(wall.meter(model)), None),
            MeterChoice::Emulated => {
                let sim = Box::new(wall.meter(model));
                let emulator_opts = EmulatorOptions::with_time_scale(opts.time_scale);
                let (emu, port) = Emulator::spawn_with(sim, opts.faults.clone(), emulator_opts)
                    .map_err(StationError::Emulator)?;
                let driver = port
                    .open(opts.driver.clone())
                    .map_err(StationError::EmulatedMeter)?;
                (Box::new(driver), Some(emu))
            }
            MeterChoice::Serial(port) => {
                let driver = KleinK10a::open(port, opts.driver.clone()).map_err(|source| {
                    StationError::Meter {
                        port: port.clone(),
                        source,
                    }
                })?;
                (Box::new(driver), None)
            }
        };
        let mut station = Self {
            pattern: Box::new(wall.pattern_output()),
            positioner: positioner(&wall, opts),
            wall,
            meter,
            emulator,
        };
        station.stoppable(opts);
        Ok(station)
    }

    /// Wraps the pattern output so that `opts.stop` stops the run (see
    /// [`StationOptions::stop`]); nothing without one.
    fn stoppable(&mut self, opts: &StationOptions) {
        if let Some(stop) = &opts.stop {
            let own = Box::new(self.wall.pattern_output());
            let inner = std::mem::replace(&mut self.pattern, own);
            self.pattern = Box::new(Stoppable {
                inner,
                stop: stop.clone(),
            });
        }
    }

    /// The displays of the wall.
    pub fn displays(&self) -> Vec<DisplayInfo> {
        self.wall.displays()
    }

    /// The three devices as the calibration sees them.
    pub fn rig(&mut self) -> Rig<'_> {
        Rig {
            pattern: self.pattern.as_mut(),
            meter: self.meter.as_mut(),
            positioner: self.positioner.as_mut(),
        }
    }

    /// The pty emulator behind the meter (`MeterChoice::Emulated` only).
    pub fn emulator(&self) -> Option<&Emulator> {
        self.emulator.as_ref()
    }

    /// Opens the reference spectroradiometer a meter matrix is made against, with the
    /// holder of its wavelength-check lamp: the simulated instrument's own, or for a
    /// real one a technician prompted on stdin/stdout.
    pub fn open_reference(&self, choice: &ReferenceChoice) -> Result<Reference, DeviceError> {
        let simulated = |model: &SpectroModel| self.wall.spectroradiometer(model.clone());
        let (instrument, lamp_holder, simulated_offset_nm): (
            Box<dyn Spectroradiometer + Send>,
            Box<dyn LampHolder + Send>,
            _,
        ) = match choice {
            ReferenceChoice::Simulated(model) => {
                let sim = simulated(model)?;
                let (holder, offset) = (sim.lamp_holder(), sim.wavelength_offset_nm());
                (Box::new(sim), Box::new(holder), Some(offset))
            }
            ReferenceChoice::Emulated { model, time_scale } => {
                let options = SpecbosEmulatorOptions {
                    time_scale: *time_scale,
                    ..SpecbosEmulatorOptions::default()
                };
                let sim = simulated(model)?;
                let (holder, offset) = (sim.lamp_holder(), sim.wavelength_offset_nm());
                let served =
                    EmulatedSpecbos::start(Box::new(sim), options, SpecbosConfig::default())?;
                (Box::new(served), Box::new(holder), Some(offset))
            }
            ReferenceChoice::Serial(port) => {
                let holder = GuidedLampHolder::on_terminal();
                let real = JetiSpecbos::open(port, SpecbosConfig::default())?;
                (Box::new(real), Box::new(holder), None)
            }
        };
        Ok(Reference {
            instrument,
            lamp_holder,
            check: None,
            simulated_offset_nm,
        })
    }

    /// Matches the station's meter to `reference` on the virtual wall: one correction
    /// matrix per eye ([`crate::measure::meter_matrix`]), and with `per_display` one per
    /// display. The reference's readings are corrected for its bandwidth and, once
    /// [`Reference::check_wavelengths`] ran, its wavelength scale
    /// ([`CorrectedReference`]); the matrices record that check.
    pub fn meter_matrices(
        &mut self,
        reference: &mut Reference,
        uv: [f64; 2],
        per_display: bool,
    ) -> Result<MeterMatrices, MeterMatrixError> {
        let displays = self.displays();
        let mut matrices = crate::measure::meter_matrix::make(
            &mut self.rig(),
            &mut reference.corrected(),
            &displays,
            uv,
            per_display,
        )?;
        matrices.reference_wavelength_check = reference.check.clone();
        Ok(matrices)
    }

    /// Whether the meter is matched on every display by default (`meter-matrix
    /// --per-display`): on an Infitec wall. Its comb filters sit a nanometre or two
    /// apart from projector to projector, and on such narrow bands that moves a filter
    /// colorimeter's error by more than the white may be off: on heyewall-48 at 40
    /// readings, 20 unseen seeds, the mean worst white ΔE2000 was 0.93 with one matrix
    /// per eye, 0.80 with one per display (`bench readings`). On a mono wall of one
    /// projector type, one matrix per eye (here: per wall).
    pub fn per_display_matrices_by_default(&self) -> bool {
        self.displays()
            .iter()
            .any(|d| matches!(d.eye, Eye::Left | Eye::Right))
    }

    /// [`Station::meter_matrices`] at the displays' centres against a simulated reference
    /// `model` whose wavelength scale a Hg-Ar pen lamp checked first: what a station
    /// matching a filter colorimeter for an Infitec wall does, in one call (the
    /// readings benchmark and the camera probes).
    pub fn meter_matrices_against_simulated(
        &mut self,
        model: SpectroModel,
        per_display: bool,
    ) -> Result<MeterMatrices, MeterMatrixError> {
        let mut reference = self
            .open_reference(&ReferenceChoice::Simulated(model))
            .map_err(MeterMatrixError::Reference)?;
        reference.check_wavelengths(&LineLamp::hg_ar())?;
        self.meter_matrices(&mut reference, [0.5, 0.5], per_display)
    }

    /// The chromaticity errors of the station's meter against the virtual wall's truth on
    /// every display's primaries and white, without and with `matrices`, and of the
    /// reference they were matched to, as corrected
    /// ([`crate::measure::meter_matrix::xy_errors`]).
    pub fn meter_matrix_xy_errors(
        &mut self,
        matrices: &MeterMatrices,
        reference: &mut Reference,
        uv: [f64; 2],
    ) -> Result<Vec<PatchXyError>, DeviceError> {
        let displays = self.displays();
        let wall = self.wall.clone();
        let truth = move |d: &DisplayInfo, drive: [f64; 3]| wall.emitted_xyz(d.id, drive, uv);
        crate::measure::meter_matrix::xy_errors(
            &mut self.rig(),
            &mut reference.corrected(),
            &displays,
            uv,
            matrices,
            &truth,
        )
    }

    /// Commissions every display of the wall into `out_dir` (see [`commission`]).
    pub fn commission(
        &mut self,
        out_dir: &Path,
        opts: &CommissionOptions,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<CommissionOutcome, CommissionError> {
        let wall = self.wall.name();
        let displays = self.displays();
        commission(&wall, &displays, &mut self.rig(), out_dir, opts, progress)
    }

    /// Recalibrates the wall whose profiles are in `dir` (see
    /// [`crate::recalibrate`]).
    pub fn recalibrate(
        &mut self,
        dir: &Path,
        opts: &crate::recalibrate::RecalibrateOptions,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<crate::recalibrate::RecalibrationOutcome, crate::recalibrate::RecalibrateError>
    {
        let wall = self.wall.name();
        let displays = self.displays();
        crate::recalibrate::recalibrate(&wall, &displays, &mut self.rig(), dir, opts, progress)
    }

    /// [`Self::recalibrate`] with the fixed camera checking the flat fields (see
    /// [`crate::recalibrate::recalibrate_with_camera`]).
    pub fn recalibrate_with_camera(
        &mut self,
        dir: &Path,
        camera: &mut dyn crate::recalibrate::FlatFieldCheck,
        opts: &crate::recalibrate::RecalibrateOptions,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<crate::recalibrate::RecalibrationOutcome, crate::recalibrate::RecalibrateError>
    {
        let wall = self.wall.name();
        let displays = self.displays();
        crate::recalibrate::recalibrate_with_camera(
            &wall,
            &displays,
            &mut self.rig(),
            Some(camera),
            dir,
            opts,
            progress,
        )
    }

    /// Shows `targets` through `profiles` on every display and reads them back (see
    /// [`verify_wall`]).
    pub fn verify(
        &mut self,
        profiles: &[DisplayProfile],
        targets: &[Target],
        opts: &VerifyOptions,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<VerifyReport, VerifyError> {
        let displays = self.displays();
        verify_wall(
            &mut self.rig(),
            &displays,
            profiles,
            targets,
            opts,
            progress,
        )
    }

    /// Verifies right after commissioning: [`Station::verify`] with the default options,
    /// the meter correction `outcome` estimated and each reading averaged as the
    /// commissioning's were, without progress reports.
    pub fn verify_commissioned(
        &mut self,
        outcome: &CommissionOutcome,
        profiles: &[DisplayProfile],
        targets: &[Target],
    ) -> Result<VerifyReport, VerifyError> {
        let opts = VerifyOptions {
            meter_xy_offset: outcome.meter_correction.as_ref().map(|c| c.xy_offset),
            averaging: crate::measure::averaging::Averaging::Fixed(
                outcome.readings_per_reading.max(1),
            ),
            ..VerifyOptions::default()
        };
        self.verify(profiles, targets, &opts, &mut |_| {})
    }
}

/// The pattern output over the render nodes `wall`'s `[[output]]` tables name (its
/// `[network]` token file is relative to `wall_path`); with a simulated meter the
/// presented frames are fed back into the virtual wall ([`SimulatorSink`]).
fn remote_pattern(
    wall: &VirtualWall,
    wall_path: &Path,
    meter: &MeterChoice,
) -> Result<Box<dyn PatternOutput + Send>, StationError> {
    let config = |msg: String| StationError::Wall {
        path: wall_path.to_path_buf(),
        source: DeviceError::Config(msg),
    };
    let file = wall.wall_file();
    let net = file
        .network
        .ok_or_else(|| config("[[output]] tables need a [network] section".into()))?;
    let beside = |f: &str| wall_path.parent().unwrap_or(Path::new(".")).join(f);
    let token_path = beside(&net.token_file);
    let tls_ca_pem = match &net.ca_file {
        Some(f) => Some(
            std::fs::read(beside(f))
                .map_err(|e| config(format!("network.ca_file {}: {e}", beside(f).display())))?,
        ),
        None => None,
    };
    let token = Token::from_file(&token_path).map_err(|e| config(e.to_string()))?;
    let routes = wall
        .output_routes()
        .into_iter()
        .map(|(display, to)| {
            let address: OutputAddress = to
                .parse()
                .map_err(|e: lumiwall_pattern::AddressError| config(e.to_string()))?;
            Ok(Route { display, address })
        })
        .collect::<Result<Vec<_>, StationError>>()?;
    let station = net
        .station
        .unwrap_or_else(|| lumiwall_pattern::limits::host_name_or("station"));
    let opts = NodeOptions {
        deadline: Duration::from_millis(net.deadline_ms),
        tls_ca_pem,
        ..NodeOptions::new(token, station)
    };
    let remote = RemotePatternOutput::connect(wall.displays(), &routes, &opts)
        .map_err(StationError::Nodes)?;
    Ok(match meter {
        MeterChoice::Serial(_) => Box::new(remote),
        MeterChoice::Emulated | MeterChoice::Direct => {
            Box::new(SimulatorSink::new(remote, wall.pattern_output()))
        }
    })
}

/// The positioner `opts.aim` asks for: the simulator's, or a technician prompted on
/// stdin/stdout (the simulator's is aimed too, so a simulated meter reads the display
/// being aimed at).
fn positioner(wall: &VirtualWall, opts: &StationOptions) -> Box<dyn MeterPositioner + Send> {
    let guided = match opts.aim {
        AimChoice::Guided => true,
        AimChoice::Simulated => false,
        AimChoice::Auto => matches!(opts.meter, MeterChoice::Serial(_)),
    };
    let sim = Box::new(wall.positioner());
    if !guided {
        return sim;
    }
    let (answers, prompts) = opts
        .technician
        .as_ref()
        .and_then(TechnicianLink::take)
        .unwrap_or_else(|| {
            (
                Box::new(std::io::BufReader::new(std::io::stdin())),
                Box::new(std::io::stdout()),
            )
        });
    Box::new(GuidedPositioner::new(sim, answers, prompts))
}
