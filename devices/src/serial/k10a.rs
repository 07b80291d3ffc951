//! Driver for the Klein K-10-A spot colorimeter (and its K-10 / KV-10-A siblings)
//! over a serial port, implementing [`Colorimeter`].
//!
//! Robustness rules, in order of how often they matter:
//! * every exchange flushes stale input first, then reads the fixed-length answer
//!   against one deadline (`read_timeout`);
//! * an answer that does not parse is [`DeviceError::Garbled`]; silence is
//!   [`DeviceError::Timeout`]; both are transient;
//! * after a transient failure the next exchange first *resynchronises*: it sends
//!   `J8` (switch on auto-ranging, harmless and idempotent) and discards everything
//!   up to its `J8<c>` acknowledgement. The instrument answers commands in order, so
//!   once the acknowledgement is seen no late answer to an earlier command can
//!   follow and be mistaken for the next reading;
//! * transient failures are retried up to `retries` times (0 = never); the
//!   auto-ranging status codes `u`/`v` are repeated up to `range_change_retries`
//!   times (3: four readings in all, as ArgyllCMS's `RETRY_RANGE_ERROR`). One `measure()` call therefore returns within about
//!   `(retries + 1) · read_timeout + retries · resync_timeout` plus the
//!   measurement times.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use serialport::{ClearBuffer, DataBits, FlowControl, Parity, SerialPort, StopBits};

use super::k10_protocol::{
    self as proto, AnswerError, Command, KNOWN_MODELS, MeasureSpeed, MeasurementAnswer, StatusCode,
};
use super::spec::KLEIN_K10A;
use crate::{Colorimeter, DeviceError, MeterInfo, Xyz};

/// Largest absolute XYZ component accepted from the instrument (cd/m²). The K-10-A
/// tops out at a few thousand cd/m² and reports `w` above that; a larger number can
/// only be line noise that happened to frame correctly.
pub const PLAUSIBLE_MAX_CD_M2: f64 = 1.0e6;

/// How the driver talks to the meter.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct K10aConfig {
    /// Longest wait for one complete answer.
    #[serde(with = "duration_ms")]
    pub read_timeout: Duration,
    /// Longest wait for the acknowledgement when resynchronising after a failure;
    /// should cover a late answer to the failed command.
    #[serde(with = "duration_ms")]
    pub resync_timeout: Duration,
    /// How often a reading that failed transiently (timeout, garbled answer) is
    /// retried; 0 = never.
    pub retries: u32,
    /// How often a reading with an auto-ranging status (`u`, `v`) is repeated
    /// (ArgyllCMS: 3 repeats, four readings in all, no pause).
    pub range_change_retries: u32,
    /// If set, readings with Y below this are reported as [`DeviceError::TooDark`]
    /// (cd/m²). The K-10 protocol itself has no low-light code.
    pub too_dark_below_cd_m2: Option<f64>,
    /// Measurement command (`N5` = 8 readings per second by default).
    pub speed: MeasureSpeed,
    /// Open the port exclusively (recommended for real hardware).
    pub exclusive: bool,
}

impl Default for K10aConfig {
    fn default() -> Self {
        Self {
            // ArgyllCMS waits 2 s for an N5 answer.
            read_timeout: Duration::from_secs(2),
            resync_timeout: Duration::from_secs(2),
            retries: 2,
            range_change_retries: 3,
            too_dark_below_cd_m2: None,
            speed: MeasureSpeed::Normal,
            exclusive: true,
        }
    }
}

mod duration_ms {
    use std::time::Duration;

    pub(super) fn serialize<S: serde::Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u64(d.as_millis().min(u128::from(u64::MAX)) as u64)
    }

    pub(super) fn deserialize<'de, D: serde::Deserializer<'de>>(
        d: D,
    ) -> Result<Duration, D::Error> {
        let ms: u64 = serde::Deserialize::deserialize(d)?;
        Ok(Duration::from_millis(ms))
    }
}

/// Longest wait a timeout from the configuration is taken as: `Instant + Duration`
/// panics on overflow, and a configured `read_timeout` of u64::MAX ms did.
const LONGEST_WAIT: Duration = Duration::from_secs(24 * 3600);

/// The instant `timeout` from now, the timeout capped at [`LONGEST_WAIT`].
fn deadline_after(timeout: Duration) -> Instant {
    Instant::now() + timeout.min(LONGEST_WAIT)
}

/// Counters of what the driver had to do, for logs and tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ExchangeStats {
    /// Commands sent (including resynchronisation commands).
    pub commands: u64,
    /// Readings retried after a transient failure.
    pub retries: u64,
    /// Readings repeated after an auto-ranging status.
    pub range_repeats: u64,
    /// Successful resynchronisations.
    pub resyncs: u64,
}

/// Outcome of one measurement exchange, before the retry policy.
enum Attempt {
    RangeChange(StatusCode),
    Failed(DeviceError),
}

/// A Klein K-10 family colorimeter on a serial port.
pub struct KleinK10a {
    port: Box<dyn SerialPort>,
    config: K10aConfig,
    device: String,
    port_name: String,
    model: String,
    serial: String,
    firmware: String,
    needs_resync: bool,
    last: Option<MeasurementAnswer>,
    stats: ExchangeStats,
    #[cfg(unix)]
    exclusive_guard: Option<serialport::TTYPort>,
}

impl Drop for KleinK10a {
    fn drop(&mut self) {
        #[cfg(unix)]
        if let Some(mut guard) = self.exclusive_guard.take()
            && let Err(e) = guard.set_exclusive(false)
        {
            tracing::debug!("{}: releasing the exclusive lock failed: {e}", self.device);
        }
    }
}

impl std::fmt::Debug for KleinK10a {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KleinK10a")
            .field("device", &self.device)
            .field("model", &self.model)
            .field("serial", &self.serial)
            .field("config", &self.config)
            .finish_non_exhaustive()
    }
}

impl KleinK10a {
    /// Opens the meter on `path` (`/dev/ttyUSB0`, or the emulator's `/dev/pts/N`)
    /// at 9600 baud 8N1 without flow control, resynchronises, switches on
    /// auto-ranging, identifies it (`P0`) and switches the aiming lights off.
    pub fn open(path: &str, config: K10aConfig) -> Result<Self, DeviceError> {
        let device = format!("Klein K-10 meter on {path}");
        let io_err = |e: serialport::Error| DeviceError::Io {
            device: device.clone(),
            source: std::io::Error::from(e),
        };
        let builder = serialport::new(path, proto::BAUD_RATE)
            .data_bits(DataBits::Eight)
            .parity(Parity::None)
            .stop_bits(StopBits::One)
            .flow_control(FlowControl::None)
            .timeout(config.read_timeout.min(LONGEST_WAIT));
        #[cfg(unix)]
        {
            let native = builder
                .exclusive(config.exclusive)
                .open_native()
                .map_err(io_err)?;
            // A duplicate handle to lift the exclusive lock on drop, so that the
            // port can be opened again while another process keeps it open (as the
            // emulator does with its pseudo-terminal).
            let guard = if config.exclusive {
                native.try_clone_native().ok()
            } else {
                None
            };
            let mut meter = Self::unstarted(Box::new(native), path, config);
            meter.exclusive_guard = guard;
            meter.start_up()?;
            Ok(meter)
        }
        #[cfg(not(unix))]
        {
            let port = builder.open().map_err(io_err)?;
            Self::from_port(port, path, config)
        }
    }

    /// Wraps an already opened port (settings must be 9600 8N1); `name` is used in
    /// messages. Performs the same start-up as [`KleinK10a::open`].
    pub fn from_port(
        port: Box<dyn SerialPort>,
        name: &str,
        config: K10aConfig,
    ) -> Result<Self, DeviceError> {
        let mut meter = Self::unstarted(port, name, config);
        meter.start_up()?;
        Ok(meter)
    }

    fn unstarted(port: Box<dyn SerialPort>, name: &str, config: K10aConfig) -> Self {
        Self {
            port,
            config,
            device: format!("Klein K-10 meter on {name}"),
            port_name: name.to_string(),
            model: String::new(),
            serial: String::new(),
            firmware: String::new(),
            needs_resync: true,
            last: None,
            stats: ExchangeStats::default(),
            #[cfg(unix)]
            exclusive_guard: None,
        }
    }

    fn start_up(&mut self) -> Result<(), DeviceError> {
        // Resync doubles as "switch on auto-ranging" (J8), which ArgyllCMS also
        // sends at start-up.
        // The handshake tolerates at least two transient failures whatever the
        // reading retry policy: a meter that was just plugged in or a busy host
        // should not fail the open.
        let mut last_err = None;
        for _ in 0..=self.config.retries.max(2) {
            match self.resync().and_then(|()| self.identify()) {
                Ok(()) => {
                    last_err = None;
                    break;
                }
                Err(e) if e.is_transient() => {
                    self.needs_resync = true;
                    last_err = Some(e);
                }
                Err(e) => return Err(e),
            }
        }
        if let Some(e) = last_err {
            return Err(e);
        }
        self.lights_off();
        Ok(())
    }

    fn identify(&mut self) -> Result<(), DeviceError> {
        let answer = self.exchange(Command::DeviceInfo)?;
        let info = proto::parse_device_info(&answer)
            .map_err(|e| self.garbled(Command::DeviceInfo, &answer, &e))?;
        if !KNOWN_MODELS.contains(&info.model.as_str()) {
            return Err(DeviceError::Config(format!(
                "{} answered P0 with model {:?}; expected one of {:?} (is this a Klein K-10?)",
                self.device, info.model, KNOWN_MODELS
            )));
        }
        self.device = format!(
            "Klein {} #{} on {}",
            info.model, info.serial, self.port_name
        );
        self.model = info.model;
        self.serial = info.serial;
        self.read_firmware();
        Ok(())
    }

    /// `P2`, as ArgyllCMS reads it at start-up. A meter that does not answer it still
    /// measures; the version is then reported as unknown.
    fn read_firmware(&mut self) {
        let read = self.exchange(Command::FirmwareVersion).and_then(|answer| {
            proto::parse_firmware(&answer)
                .map_err(|e| self.garbled(Command::FirmwareVersion, &answer, &e))
        });
        match read {
            Ok((version, StatusCode::Ok)) => self.firmware = version,
            Ok((_, status)) => tracing::warn!("{}: P2 answered status {status:?}", self.device),
            Err(e) => {
                tracing::warn!("{}: firmware version unknown: {e}", self.device);
                self.needs_resync = true;
            }
        }
    }

    /// The firmware version from `P2` (empty when the meter did not tell).
    pub fn firmware(&self) -> &str {
        &self.firmware
    }

    /// Aiming lights off. ArgyllCMS notes that `L0` may answer with unrelated status
    /// codes and ignores them; so do we. A failure only means a later reading may
    /// report `L`.
    fn lights_off(&mut self) {
        match self.exchange(Command::LightsOff) {
            Ok(_) => {}
            Err(e) => {
                tracing::warn!(
                    "{}: switching the aiming lights off failed: {e}",
                    self.device
                );
                self.needs_resync = true;
            }
        }
    }

    /// The device name used in messages (model, serial number, port).
    pub fn device_name(&self) -> &str {
        &self.device
    }

    /// The driver settings.
    pub fn config(&self) -> &K10aConfig {
        &self.config
    }

    /// Changes the driver settings (timeout, retries, ...).
    pub fn set_config(&mut self, config: K10aConfig) {
        self.config = config;
    }

    /// The last successfully decoded measurement answer (XYZ, ranges, status).
    pub fn last_answer(&self) -> Option<MeasurementAnswer> {
        self.last
    }

    /// What the driver had to do so far.
    pub fn stats(&self) -> ExchangeStats {
        self.stats
    }

    /// One reading without the transient-retry policy (auto-ranging repeats still
    /// apply). Useful to observe a single fault.
    pub fn measure_once(&mut self) -> Result<Xyz, DeviceError> {
        let mut repeats = 0;
        loop {
            match self.attempt() {
                Ok(xyz) => return Ok(xyz),
                Err(Attempt::RangeChange(code)) if repeats < self.config.range_change_retries => {
                    repeats += 1;
                    self.stats.range_repeats += 1;
                    tracing::debug!("{}: auto-ranging status {:?}, repeating", self.device, code);
                }
                Err(Attempt::RangeChange(code)) => return Err(self.instrument_error(code)),
                Err(Attempt::Failed(e)) => {
                    if e.is_transient() {
                        self.needs_resync = true;
                    }
                    return Err(e);
                }
            }
        }
    }

    fn attempt(&mut self) -> Result<Xyz, Attempt> {
        if self.needs_resync {
            self.resync().map_err(Attempt::Failed)?;
        }
        let command = Command::Measure(self.config.speed);
        let answer = self.exchange(command).map_err(Attempt::Failed)?;
        let parsed = proto::parse_measurement(self.config.speed, &answer)
            .map_err(|e| Attempt::Failed(self.garbled(command, &answer, &e)))?;
        match parsed.status {
            StatusCode::Ok => {}
            StatusCode::OverHighRange => {
                return Err(Attempt::Failed(DeviceError::OverRange {
                    device: self.device.clone(),
                }));
            }
            code if code.is_range_change() => return Err(Attempt::RangeChange(code)),
            code => return Err(Attempt::Failed(self.instrument_error(code))),
        }
        let xyz = parsed.xyz;
        let plausible = xyz
            .to_array()
            .iter()
            .all(|v| v.is_finite() && v.abs() <= PLAUSIBLE_MAX_CD_M2);
        if !plausible {
            return Err(Attempt::Failed(DeviceError::Garbled {
                device: self.device.clone(),
                command: command.name(),
                answer: format!(
                    "{} (decodes to X {:e}, Y {:e}, Z {:e} cd/m², beyond any K-10 range)",
                    answer.escape_ascii(),
                    xyz.x,
                    xyz.y,
                    xyz.z
                ),
            }));
        }
        self.last = Some(parsed);
        if let Some(limit) = self.config.too_dark_below_cd_m2
            && xyz.y < limit
        {
            return Err(Attempt::Failed(DeviceError::TooDark {
                device: self.device.clone(),
                y_cd_m2: xyz.y,
                limit_cd_m2: limit,
            }));
        }
        Ok(xyz)
    }

    fn instrument_error(&self, code: StatusCode) -> DeviceError {
        DeviceError::Instrument {
            device: self.device.clone(),
            code: char::from(code.to_byte()).to_string(),
            meaning: code.meaning().to_string(),
        }
    }

    fn garbled(&self, command: Command, answer: &[u8], why: &AnswerError) -> DeviceError {
        DeviceError::Garbled {
            device: self.device.clone(),
            command: command.name(),
            answer: format!("{} ({why})", answer.escape_ascii()),
        }
    }

    fn io_error(&self, source: std::io::Error) -> DeviceError {
        DeviceError::Io {
            device: self.device.clone(),
            source,
        }
    }

    fn timeout_error(&self) -> DeviceError {
        self.timeout_error_after(self.config.read_timeout)
    }

    fn timeout_error_after(&self, timeout: Duration) -> DeviceError {
        DeviceError::Timeout {
            device: self.device.clone(),
            timeout_ms: timeout.as_millis().min(u128::from(u64::MAX)) as u64,
        }
    }

    fn send(&mut self, command: Command) -> Result<(), DeviceError> {
        self.port
            .clear(ClearBuffer::Input)
            .map_err(|e| self.io_error(e.into()))?;
        self.stats.commands += 1;
        let wire = command.wire();
        self.port
            .set_timeout(self.config.read_timeout.min(LONGEST_WAIT))
            .map_err(|e| self.io_error(e.into()))?;
        match self.port.write_all(&wire) {
            Ok(()) => Ok(()),
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => Err(self.timeout_error()),
            Err(e) => Err(self.io_error(e)),
        }
    }

    /// Reads whatever arrives before `deadline` into `buf` until `done(buf)`;
    /// returns whether `done` became true.
    fn read_until(
        &mut self,
        buf: &mut Vec<u8>,
        deadline: Instant,
        max_len: usize,
        done: impl Fn(&[u8]) -> bool,
    ) -> Result<bool, DeviceError> {
        let mut chunk = [0u8; 64];
        while !done(buf) {
            if buf.len() > 4096 {
                // Only the tail matters to the callers; bound the memory.
                buf.drain(..buf.len() - 64);
            }
            let now = Instant::now();
            if now >= deadline {
                return Ok(false);
            }
            self.port
                .set_timeout(deadline - now)
                .map_err(|e| self.io_error(e.into()))?;
            let want = max_len.saturating_sub(buf.len()).clamp(1, chunk.len());
            match self.port.read(&mut chunk[..want]) {
                Ok(0) => std::thread::sleep(Duration::from_millis(1)),
                Ok(n) => buf.extend_from_slice(&chunk[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => return Ok(false),
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(self.io_error(e)),
            }
        }
        Ok(true)
    }

    /// Sends `command` and reads its fixed-length answer.
    fn exchange(&mut self, command: Command) -> Result<Vec<u8>, DeviceError> {
        self.send(command)?;
        let n = command.answer_len();
        let deadline = deadline_after(self.config.read_timeout);
        let mut buf = Vec::with_capacity(n);
        if self.read_until(&mut buf, deadline, n, |b| b.len() >= n)? {
            return Ok(buf);
        }
        if buf.is_empty() {
            Err(self.timeout_error())
        } else {
            Err(DeviceError::Garbled {
                device: self.device.clone(),
                command: command.name(),
                answer: format!(
                    "{} (only {} of {} bytes within {} ms)",
                    buf.escape_ascii(),
                    buf.len(),
                    n,
                    self.config.read_timeout.as_millis()
                ),
            })
        }
    }

    /// Re-establishes a clean command/answer sequence: sends `J8` and discards
    /// everything up to and including its acknowledgement.
    fn resync(&mut self) -> Result<(), DeviceError> {
        self.send(Command::AutoRange)?;
        let deadline = deadline_after(self.config.resync_timeout);
        let mut buf = Vec::new();
        let code = Command::AutoRange.code();
        let found = self.read_until(&mut buf, deadline, usize::MAX, |b| {
            let n = b.len();
            n >= 5 && b[n - 5..n - 3] == code && b[n - 3] == b'<' && b[n - 1] == b'>'
        })?;
        if !found {
            return Err(if buf.is_empty() {
                self.timeout_error_after(self.config.resync_timeout)
            } else {
                DeviceError::Garbled {
                    device: self.device.clone(),
                    command: "J8 (resync)".to_string(),
                    answer: format!(
                        "{} bytes without an acknowledgement, ending {}",
                        buf.len(),
                        buf[buf.len().saturating_sub(32)..].escape_ascii()
                    ),
                }
            });
        }
        let status = buf[buf.len() - 2];
        if status != b'0' {
            tracing::warn!(
                "{}: J8 acknowledged with status {:?}",
                self.device,
                char::from(status)
            );
        }
        self.port
            .clear(ClearBuffer::Input)
            .map_err(|e| self.io_error(e.into()))?;
        self.needs_resync = false;
        self.stats.resyncs += 1;
        Ok(())
    }
}

impl Colorimeter for KleinK10a {
    fn info(&self) -> MeterInfo {
        MeterInfo {
            model: format!("Klein {}", self.model),
            serial: self.serial.clone(),
            min_reliable_cd_m2: KLEIN_K10A.min_reliable_cd_m2,
            max_cd_m2: KLEIN_K10A.max_cd_m2,
            noise: Some(KLEIN_K10A.reading_noise()),
        }
    }

    /// One reading (factory calibration XYZ, Y in cd/m²) with the retry policy of
    /// [`K10aConfig`].
    fn measure(&mut self) -> Result<Xyz, DeviceError> {
        let mut retries = 0;
        loop {
            match self.measure_once() {
                Ok(xyz) => return Ok(xyz),
                Err(e) if e.is_transient() && retries < self.config.retries => {
                    retries += 1;
                    self.stats.retries += 1;
                    tracing::warn!(
                        "{}: {e}; retry {retries} of {}",
                        self.device,
                        self.config.retries
                    );
                }
                Err(e) => return Err(e),
            }
        }
    }
}
