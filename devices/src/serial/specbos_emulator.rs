//! A JETI specbos 1211 on a pseudo-terminal: serves the instrument's ASCII protocol
//! ([`super::specbos_protocol`]) backed by any [`Spectroradiometer`] (normally the
//! virtual wall's), so that lumiwall's driver ([`super::JetiSpecbos`]) and
//! third-party software (ArgyllCMS `spotread`) can measure the virtual wall.
//!
//! The instrument computes XYZ from its own spectrum over the range last set with
//! `*conf:wran` (K_m = 683 lm/W; ArgyllCMS uses 683.002, 3 ppm apart). A measurement
//! takes the adaptive integration time (longer in the dark, up to `*conf:maxtin`)
//! plus a fixed overhead, scaled by the time scale. Choices where the maker's
//! documentation is not available to us are listed in
//! `fixtures/instruments/jeti-specbos.md`.

use std::io::{Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::time::Duration;

use serialport::TTYPort;

use super::pty::{PtyThread, pause};
use super::specbos_protocol::{self as proto, Request};
use crate::spectral::{SpectralRadiance, Spectroradiometer};
use crate::{DeviceError, Xyz};

/// How the emulated specbos presents itself.
#[derive(Debug, Clone, PartialEq)]
pub struct SpecbosEmulatorOptions {
    /// Factor on the instrument's measurement time (1 = real time, 0 = instant).
    pub time_scale: f64,
    /// Model number answered to `*idn?` (1211 or 1201).
    pub model: u32,
    /// Serial number answered to `*para:spnum?`.
    pub serial: u32,
    /// Firmware text answered to `*vers?`.
    pub firmware: String,
}

impl Default for SpecbosEmulatorOptions {
    fn default() -> Self {
        Self {
            time_scale: 1.0,
            model: 1211,
            serial: 12_110_001,
            firmware: "lumiwall specbos emulator 1".to_string(),
        }
    }
}

/// A running specbos emulator; stops (and closes the pty) when stopped or dropped.
pub struct SpecbosEmulator {
    readings: Arc<AtomicU32>,
    pty: PtyThread,
}

impl std::fmt::Debug for SpecbosEmulator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SpecbosEmulator")
            .field("path", &self.pty.path())
            .field("readings", &self.readings_requested())
            .finish_non_exhaustive()
    }
}

impl SpecbosEmulator {
    /// Starts an emulated specbos backed by `instrument`.
    pub fn spawn(
        instrument: Box<dyn Spectroradiometer + Send>,
        options: SpecbosEmulatorOptions,
    ) -> Result<Self, DeviceError> {
        super::pty::check_time_scale(options.time_scale)?;
        let calibrated = calibrated_range(instrument.as_ref())?;
        let readings = Arc::new(AtomicU32::new(0));
        let counter = Arc::clone(&readings);
        let pty = PtyThread::spawn("specbos emulator", move |master, stop| {
            let mut server = Server {
                master,
                instrument,
                options,
                stop,
                readings: counter,
                calibrated,
                range: calibrated,
                max_integration_ms: 3000.0,
                last: None,
                error: 0,
            };
            server.run();
        })?;
        Ok(Self { readings, pty })
    }

    /// Number of `*init` commands received so far.
    pub fn readings_requested(&self) -> u32 {
        self.readings.load(Ordering::SeqCst)
    }

    /// Path of the pseudo-terminal.
    pub fn path(&self) -> &str {
        self.pty.path()
    }

    /// Stops the emulator thread and closes the pty.
    pub fn stop(mut self) {
        self.pty.shutdown();
    }
}

/// The instrument's range as whole nanometres, checked.
fn calibrated_range(instrument: &dyn Spectroradiometer) -> Result<[u32; 2], DeviceError> {
    let [a, b] = instrument.wavelength_range_nm();
    if !(a.is_finite() && b.is_finite() && a >= 200.0 && b <= 1200.0 && b > a) {
        return Err(DeviceError::Config(format!(
            "the emulated specbos needs a range within 200–1200 nm, the instrument has {a}–{b} nm"
        )));
    }
    Ok([a.ceil() as u32, b.floor() as u32])
}

/// Fixed overhead of one measurement (dark reading and transfer), seconds.
const OVERHEAD_S: f64 = 0.4;

struct Server {
    master: TTYPort,
    instrument: Box<dyn Spectroradiometer + Send>,
    options: SpecbosEmulatorOptions,
    stop: Arc<AtomicBool>,
    readings: Arc<AtomicU32>,
    /// The instrument's own range (nm).
    calibrated: [u32; 2],
    /// The range set with `*conf:wran` (nm).
    range: [u32; 2],
    /// `*conf:maxtin` (ms).
    max_integration_ms: f64,
    /// The last measurement, on the 1 nm grid of `range`.
    last: Option<SpectralRadiance>,
    /// The code `*stat:err?` answers (0: none).
    error: u32,
}

impl Server {
    fn run(&mut self) {
        let mut line: Vec<u8> = Vec::new();
        let mut buf = [0u8; 256];
        while !self.stop.load(Ordering::SeqCst) {
            match self.master.read(&mut buf) {
                Ok(0) => std::thread::sleep(Duration::from_millis(2)),
                Ok(n) => line.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => continue,
                Err(e) => {
                    tracing::trace!("specbos emulator read: {e}");
                    std::thread::sleep(Duration::from_millis(5));
                    continue;
                }
            }
            while let Some(pos) = line.iter().position(|&b| b == proto::TERMINATOR) {
                let frame: Vec<u8> = line.drain(..=pos).collect();
                if let Some(request) = proto::parse_request(&frame[..pos]) {
                    self.handle(request);
                }
            }
            if line.len() > 1024 {
                line.drain(..line.len() - 64);
            }
        }
    }

    fn handle(&mut self, request: Request) {
        match request {
            Request::Identify => self.text(&proto::identity(self.options.model)),
            Request::Version => self.text(&self.options.firmware.clone()),
            Request::SerialNumber => {
                self.text(&format!("spectrometer number: {}", self.options.serial))
            }
            Request::StartWave => {
                self.text(&format!("Predefined start wave: {}", self.calibrated[0]))
            }
            Request::EndWave => self.text(&format!("Predefined end wave: {}", self.calibrated[1])),
            Request::Range {
                start_nm,
                end_nm,
                step_nm,
            } => self.set_range(start_nm, end_nm, step_nm),
            Request::Average(n) if (1..=100).contains(&n) => self.ack(),
            Request::Head => self.text("mhead: 0"),
            Request::LaserState => self.text("laser: 0"),
            Request::Measure => self.measure(),
            Request::FetchXyz => self.fetch_xyz(),
            Request::FetchLuminance => {
                self.fetch_with(|xyz| format!("Luminance[cd/m^2]: {:e}", xyz.y))
            }
            Request::FetchChromaticity => self.fetch_with(|xyz| match xyz.chromaticity() {
                Some(c) => format!("Chrom_x: {:.6} Chrom_y: {:.6}", c.x, c.y),
                None => "Chrom_x: 0 Chrom_y: 0".to_string(),
            }),
            Request::FetchSpectrum => self.fetch_spectrum(),
            Request::ErrorCode => {
                let code = std::mem::take(&mut self.error);
                self.answer(proto::encode_error_code(code).as_bytes());
            }
            Request::Setting(text) => self.setting(&text),
            Request::Average(_) => self.refuse(proto::ERROR_ARGUMENT),
            Request::Unknown(text) => {
                tracing::debug!("specbos emulator: unknown command {text:?}");
                self.refuse(proto::ERROR_UNKNOWN_COMMAND);
            }
        }
    }

    fn setting(&mut self, text: &str) {
        if let Some(ms) = text
            .strip_prefix("*conf:maxtin")
            .and_then(|v| v.trim().parse::<f64>().ok())
        {
            if !(1.0..=60_000.0).contains(&ms) {
                return self.refuse(proto::ERROR_ARGUMENT);
            }
            self.max_integration_ms = ms;
        }
        self.ack();
    }

    /// `*conf:wran`: accepted as the real instrument does; a range beyond the
    /// calibration fails at the next measurement (error 141).
    fn set_range(&mut self, start: u32, end: u32, step: u32) {
        if step != 1 || end <= start || end > 1200 || start < 200 {
            return self.refuse(proto::ERROR_ARGUMENT);
        }
        self.range = [start, end];
        self.ack();
    }

    fn measure(&mut self) {
        let n = self.readings.fetch_add(1, Ordering::SeqCst) + 1;
        tracing::trace!("specbos emulator: measurement {n}");
        self.last = None;
        if self.range[0] < self.calibrated[0] || self.range[1] > self.calibrated[1] {
            return self.refuse(proto::ERROR_RANGE_NOT_CALIBRATED);
        }
        self.ack();
        let reading = self.instrument.measure_spectrum();
        let integration_s = match &reading {
            Ok(s) => integration_time_s(s, self.max_integration_ms),
            Err(_) => self.max_integration_ms / 1000.0,
        };
        pause(
            &self.stop,
            Duration::from_secs_f64((OVERHEAD_S + integration_s) * self.options.time_scale),
        );
        match reading.and_then(|s| self.within_range(s)) {
            Ok(s) => {
                self.last = Some(s);
                self.answer(&[proto::BEL]);
            }
            Err(DeviceError::OverRange { .. }) => self.refuse(proto::ERROR_OVEREXPOSED),
            Err(DeviceError::TooDark { .. }) => self.refuse(proto::ERROR_UNDEREXPOSED),
            Err(e) => {
                tracing::warn!("specbos emulator: the instrument failed: {e}");
                self.refuse(123);
            }
        }
    }

    /// The reading cut to the range set with `*conf:wran` (1 nm grid).
    fn within_range(&self, s: SpectralRadiance) -> Result<SpectralRadiance, DeviceError> {
        s.check("specbos emulator's instrument")?;
        let values = (self.range[0]..=self.range[1])
            .map(|wl| {
                let t = (f64::from(wl) - s.start_nm) / s.step_nm;
                let i = t.floor().max(0.0) as usize;
                let f = t - i as f64;
                let at = |k: usize| s.w_sr_m2_nm.get(k).copied().unwrap_or(0.0);
                at(i) * (1.0 - f) + at(i + 1) * f
            })
            .collect();
        Ok(SpectralRadiance {
            start_nm: f64::from(self.range[0]),
            step_nm: 1.0,
            w_sr_m2_nm: values,
        })
    }

    fn fetch_xyz(&mut self) {
        match self.last.as_ref().map(SpectralRadiance::xyz) {
            Some(Ok(xyz)) => self.answer(proto::encode_xyz(xyz).as_bytes()),
            _ => self.refuse(proto::ERROR_NO_MEASUREMENT),
        }
    }

    fn fetch_with(&mut self, format: impl Fn(Xyz) -> String) {
        match self.last.as_ref().map(SpectralRadiance::xyz) {
            Some(Ok(xyz)) => self.text(&format(xyz)),
            _ => self.refuse(proto::ERROR_NO_MEASUREMENT),
        }
    }

    fn fetch_spectrum(&mut self) {
        let Some(s) = &self.last else {
            return self.refuse(proto::ERROR_NO_MEASUREMENT);
        };
        let text = proto::encode_spectrum(self.range[0], self.range[1], &s.w_sr_m2_nm);
        self.answer(text.as_bytes());
    }

    fn ack(&mut self) {
        self.answer(&[proto::ACK]);
    }

    /// A lone NAK; `*stat:err?` then answers `code`.
    fn refuse(&mut self, code: u32) {
        self.error = code;
        self.answer(&[proto::NAK]);
    }

    fn text(&mut self, line: &str) {
        let mut bytes = line.as_bytes().to_vec();
        bytes.push(proto::TERMINATOR);
        self.answer(&bytes);
    }

    fn answer(&mut self, bytes: &[u8]) {
        if let Err(e) = self.master.write_all(bytes) {
            tracing::debug!("specbos emulator write failed: {e}");
        }
    }
}

/// The adaptive integration time for a reading (s): the array's peak reaches about
/// 70 % of full scale, 10 ms at a 100 cd/m² white, longer in proportion as the peak
/// falls, at least 1 ms, at most `max_ms`.
fn integration_time_s(s: &SpectralRadiance, max_ms: f64) -> f64 {
    let peak = s.w_sr_m2_nm.iter().cloned().fold(0.0, f64::max);
    // a 100 cd/m² equal-energy white peaks at about 1.4e-3 W/(sr·m²·nm)
    let ms = if peak > 0.0 {
        10.0 * 1.4e-3 / peak
    } else {
        max_ms
    };
    ms.clamp(1.0, max_ms) / 1000.0
}

/// An emulated specbos and lumiwall's driver opened on it, as one instrument: the
/// whole serial path (protocol, timing, errors) around a simulated spectroradiometer.
#[derive(Debug)]
pub struct EmulatedSpecbos {
    // Dropped after the driver (fields drop in order): the port closes first.
    driver: super::JetiSpecbos,
    emulator: SpecbosEmulator,
}

impl EmulatedSpecbos {
    /// Starts the emulator on `instrument` and opens the driver on it.
    pub fn start(
        instrument: Box<dyn Spectroradiometer + Send>,
        options: SpecbosEmulatorOptions,
        config: super::SpecbosConfig,
    ) -> Result<Self, DeviceError> {
        let emulator = SpecbosEmulator::spawn(instrument, options)?;
        let driver = super::JetiSpecbos::open(emulator.path(), config)?;
        Ok(Self { driver, emulator })
    }

    /// The emulator behind the driver.
    pub fn emulator(&self) -> &SpecbosEmulator {
        &self.emulator
    }
}

impl crate::Colorimeter for EmulatedSpecbos {
    fn info(&self) -> crate::MeterInfo {
        self.driver.info()
    }

    fn measure(&mut self) -> Result<Xyz, DeviceError> {
        self.driver.measure()
    }
}

impl Spectroradiometer for EmulatedSpecbos {
    fn measure_spectrum(&mut self) -> Result<SpectralRadiance, DeviceError> {
        self.driver.measure_spectrum()
    }

    fn bandwidth_nm(&self) -> f64 {
        self.driver.bandwidth_nm()
    }

    fn wavelength_range_nm(&self) -> [f64; 2] {
        self.driver.wavelength_range_nm()
    }
}
