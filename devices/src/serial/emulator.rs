//! A Klein K-10-A on a pseudo-terminal: serves the instrument's serial protocol,
//! backed by any [`Colorimeter`] (normally the virtual wall's meter), so that the
//! real driver, [`KleinK10a`], can be tested and used end to end
//! without hardware. A [`FaultPlan`] injects the failures a real line and meter
//! produce: silence, garbage, over-range, instrument status codes, slow answers and
//! a dropped line that comes back.
//!
//! Behaviour where the Klein documentation is silent is chosen conservatively and
//! listed in `fixtures/instruments/klein-k10a.md` (unknown commands get no answer;
//! error answers carry zero XYZ; the range byte is a plausible guess).

use std::io::{Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};
use serialport::TTYPort;

use super::k10_protocol::{self as proto, Command, MeasureSpeed, StatusCode};
use super::k10a::{K10aConfig, KleinK10a};
use super::pty::PtyThread;
use super::spec::{InstrumentSpec, KLEIN_K10A};
use crate::{Colorimeter, DeviceError, Xyz};

/// An instrument status code to answer for one reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct StatusFault {
    /// Reading number (1-based count of measurement commands received).
    pub reading: u32,
    /// Status character to send (`'b'`, `'v'`, `'X'`, ...).
    pub code: char,
}

/// The line goes dead at one reading and comes back after a while.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct LineDrop {
    /// Reading number (1-based) whose command is lost.
    pub at_reading: u32,
    /// How long everything sent to the meter is lost (ms, not scaled).
    pub duration_ms: u64,
}

/// One extra-slow answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct SlowAnswer {
    /// Reading number (1-based).
    pub reading: u32,
    /// Extra delay before the answer (ms, not scaled).
    pub delay_ms: u64,
}

/// Faults the emulator injects. Readings are counted from 1 over all measurement
/// commands it receives (a retried reading counts again).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct FaultPlan {
    /// Answer this many readings, then never answer anything again (a meter that
    /// hangs or is switched off).
    pub stop_after_readings: Option<u32>,
    /// Readings answered with bytes that are not in the protocol.
    pub garbage_on: Vec<u32>,
    /// Readings answered with the over-high-range status `w`.
    pub over_range_on: Vec<u32>,
    /// Readings answered with a given status code.
    pub status_on: Vec<StatusFault>,
    /// Extra delay added to every answer (ms, not scaled).
    pub answer_delay_ms: u64,
    /// Extra delays for single readings.
    pub slow_on: Vec<SlowAnswer>,
    /// Line drops.
    pub line_drops: Vec<LineDrop>,
}

/// How the emulated instrument presents itself.
#[derive(Debug, Clone, PartialEq)]
pub struct EmulatorOptions {
    /// Factor on the instrument's measurement and transmission time (1 = real time,
    /// 0.01 = a hundred times faster for tests).
    pub time_scale: f64,
    /// Model string answered to `P0` (7 characters at most).
    pub model: String,
    /// Serial number answered to `P0` (9 characters at most).
    pub serial: String,
    /// Range and timing of the instrument being emulated.
    pub spec: InstrumentSpec,
    /// Firmware version answered to `P2` (8 characters at most).
    pub firmware: String,
    /// Names of the stored calibrations answered to `D7` (slots 1.., at most 96).
    pub calibrations: Vec<String>,
}

impl Default for EmulatorOptions {
    fn default() -> Self {
        Self {
            time_scale: 1.0,
            model: KLEIN_K10A.model.to_string(),
            serial: "EMU000001".to_string(),
            spec: KLEIN_K10A,
            firmware: "LWEMU-01".to_string(),
            calibrations: Vec::new(),
        }
    }
}

impl EmulatorOptions {
    /// Real instrument timing scaled by `time_scale`.
    pub fn with_time_scale(time_scale: f64) -> Self {
        Self {
            time_scale,
            ..Self::default()
        }
    }
}

/// Where the emulated instrument can be opened.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EmulatedPort {
    path: String,
}

impl EmulatedPort {
    /// Path of the pseudo-terminal (`/dev/pts/N`), to be opened like a real port.
    pub fn path(&self) -> &str {
        &self.path
    }

    /// Opens the driver on this port.
    pub fn open(&self, config: K10aConfig) -> Result<KleinK10a, DeviceError> {
        KleinK10a::open(&self.path, config)
    }
}

/// A running emulator; stops (and closes the pty) when stopped or dropped.
pub struct Emulator {
    readings: Arc<AtomicU32>,
    pty: PtyThread,
}

impl std::fmt::Debug for Emulator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Emulator")
            .field("path", &self.pty.path())
            .field("readings", &self.readings_requested())
            .finish_non_exhaustive()
    }
}

impl Emulator {
    /// Starts an emulated K-10-A in real time backed by `meter`.
    pub fn spawn(
        meter: Box<dyn Colorimeter + Send>,
        faults: FaultPlan,
    ) -> Result<(Emulator, EmulatedPort), DeviceError> {
        Self::spawn_with(meter, faults, EmulatorOptions::default())
    }

    /// Starts an emulated instrument with explicit options (time scale, identity).
    pub fn spawn_with(
        meter: Box<dyn Colorimeter + Send>,
        faults: FaultPlan,
        options: EmulatorOptions,
    ) -> Result<(Emulator, EmulatedPort), DeviceError> {
        super::pty::check_time_scale(options.time_scale)?;
        let readings = Arc::new(AtomicU32::new(0));
        let counter = Arc::clone(&readings);
        let pty = PtyThread::spawn("K-10-A emulator", move |master, stop| {
            let mut server = Server {
                master,
                meter,
                faults,
                options,
                stop,
                readings: counter,
                count: 0,
                dead: false,
                offline_until: None,
                lights_on: false,
                stream: None,
            };
            server.run();
        })?;
        let path = pty.path().to_string();
        Ok((Emulator { readings, pty }, EmulatedPort { path }))
    }

    /// Number of measurement commands received so far.
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

/// Bytes sent for a garbage answer: not a valid frame (wrong echo, binary noise,
/// a stray frame marker) and longer than an answer, so that leftovers must be
/// flushed before the next reading.
const GARBAGE: &[u8] = b"\x1b[?g\xffN\x00RBAGE<5>\xfe\x80noise\r\n";

struct Server {
    master: TTYPort,
    meter: Box<dyn Colorimeter + Send>,
    faults: FaultPlan,
    options: EmulatorOptions,
    stop: Arc<AtomicBool>,
    readings: Arc<AtomicU32>,
    count: u32,
    dead: bool,
    offline_until: Option<Instant>,
    lights_on: bool,
    /// The `T2` flicker stream, while it runs.
    stream: Option<FlickerStream>,
}

/// A running `T2` stream: what it reports and when the next packet is due.
struct FlickerStream {
    next_at: Instant,
    xyz: Xyz,
    ranges: [u8; 3],
}

/// Time between two `T2` packets (32 samples at 256 per second), before scaling.
const FLICKER_PACKET_S: f64 = 32.0 / proto::FLICKER_SAMPLES_PER_S;

impl Server {
    fn run(&mut self) {
        let mut line: Vec<u8> = Vec::new();
        let mut buf = [0u8; 256];
        while !self.stop.load(Ordering::SeqCst) {
            self.stream_packet();
            match self.master.read(&mut buf) {
                Ok(0) => std::thread::sleep(Duration::from_millis(2)),
                Ok(n) => line.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => continue,
                Err(e) => {
                    tracing::trace!("emulator read: {e}");
                    std::thread::sleep(Duration::from_millis(5));
                    continue;
                }
            }
            while let Some(pos) = line.iter().position(|&b| b == proto::COMMAND_TERMINATOR) {
                let frame: Vec<u8> = line.drain(..=pos).collect();
                // any command ends the flicker stream (ArgyllCMS stops it with N5)
                self.stream = None;
                self.handle(&frame[..pos]);
            }
            if line.len() > 1024 {
                line.drain(..line.len() - 16);
            }
        }
    }

    fn offline(&mut self) -> bool {
        match self.offline_until {
            Some(t) if Instant::now() < t => true,
            Some(_) => {
                self.offline_until = None;
                false
            }
            None => false,
        }
    }

    fn handle(&mut self, frame: &[u8]) {
        if self.dead || self.offline() || frame.len() < 2 {
            return;
        }
        if frame.ends_with(proto::IDENTIFY_PROBE) {
            // ArgyllCMS's probe (after a lone `;`, which gets no answer): the K-10
            // answers with D4 and its calibration list
            let names = self.calibration_names();
            self.answer(&proto::encode_calibration_list(*b"D4", &names));
            return;
        }
        let code = [frame[frame.len() - 2], frame[frame.len() - 1]];
        let Some(command) = Command::from_code(code) else {
            tracing::debug!(
                "emulator: ignoring unknown command {}",
                frame.escape_ascii()
            );
            return;
        };
        match command {
            Command::DeviceInfo => {
                let answer = proto::encode_device_info(&self.options.model, &self.options.serial);
                self.answer(&answer);
            }
            Command::AutoRange => self.answer(&proto::encode_ack(command, StatusCode::Ok)),
            Command::LightsOff => {
                self.lights_on = false;
                self.answer(&proto::encode_ack(command, StatusCode::Ok));
            }
            Command::LightsOn => {
                self.lights_on = true;
                self.answer(&proto::encode_ack(command, StatusCode::Ok));
            }
            Command::Measure(speed) => self.measure(speed),
            Command::FirmwareVersion => {
                let answer = proto::encode_firmware(&self.options.firmware);
                self.answer(&answer);
            }
            Command::CalibrationList => {
                let names = self.calibration_names();
                let answer = proto::encode_calibration_list(*b"D7", &names);
                self.pause(self.transmit_time(answer.len()));
                self.answer(&answer);
            }
            Command::FixRange(_) => self.answer(&proto::encode_ack(command, StatusCode::Ok)),
            Command::FlickerStream => self.start_stream(),
        }
    }

    fn calibration_names(&self) -> Vec<&str> {
        self.options
            .calibrations
            .iter()
            .map(String::as_str)
            .collect()
    }

    /// Time the instrument needs to send `bytes` at its line speed, scaled.
    fn transmit_time(&self, bytes: usize) -> Duration {
        let s = self.options.spec.transmit_time_s(bytes) * self.options.time_scale;
        Duration::from_secs_f64(s.max(0.0))
    }

    /// `T2`: one reading sets what the stream reports; packets follow every 1/8 s.
    fn start_stream(&mut self) {
        let spec = self.options.spec;
        let (xyz, status) = self.read_meter(&spec);
        let ranges = if status == StatusCode::Ok {
            ranges_for(&xyz)
        } else {
            [1; 3]
        };
        self.stream = Some(FlickerStream {
            next_at: Instant::now(),
            xyz,
            ranges,
        });
    }

    /// Sends the stream's next packet when it is due. The virtual wall's light is
    /// steady, so every sample is its luminance in the range's scale (ArgyllCMS then
    /// finds no refresh rate, as on a steady source).
    fn stream_packet(&mut self) {
        let Some(s) = &mut self.stream else {
            return;
        };
        if Instant::now() < s.next_at {
            return;
        }
        let period = FLICKER_PACKET_S * self.options.time_scale;
        s.next_at += Duration::from_secs_f64(period.max(0.001));
        let full_scale = range_top_cd_m2(s.ranges[1]);
        let sample = (s.xyz.y / full_scale * 65535.0).clamp(0.0, 65535.0) as u16;
        let packet = proto::encode_flicker_packet(&[sample; 32], s.xyz, s.ranges);
        self.answer(&packet);
    }

    /// Sleeps in small steps so that a stop request is not held up.
    fn pause(&self, d: Duration) {
        super::pty::pause(&self.stop, d);
    }

    fn answer(&mut self, bytes: &[u8]) {
        if let Err(e) = self.master.write_all(bytes) {
            tracing::debug!("emulator write failed: {e}");
        }
    }

    fn measure(&mut self, speed: MeasureSpeed) {
        self.count += 1;
        self.readings.store(self.count, Ordering::SeqCst);
        let n = self.count;
        if self.faults.stop_after_readings.is_some_and(|k| n > k) {
            self.dead = true;
            return;
        }
        if let Some(drop) = self.faults.line_drops.iter().find(|d| d.at_reading == n) {
            self.offline_until = Some(Instant::now() + Duration::from_millis(drop.duration_ms));
            return;
        }
        let spec = self.options.spec;
        let busy_s = (speed.period_s() + spec.transmit_time_s(proto::MEASUREMENT_ANSWER_LEN))
            * self.options.time_scale;
        let mut delay = Duration::from_secs_f64(busy_s.max(0.0));
        delay += Duration::from_millis(self.faults.answer_delay_ms);
        if let Some(slow) = self.faults.slow_on.iter().find(|s| s.reading == n) {
            delay += Duration::from_millis(slow.delay_ms);
        }
        self.pause(delay);
        if self.faults.garbage_on.contains(&n) {
            self.answer(GARBAGE);
            return;
        }
        let (xyz, status) = if self.faults.over_range_on.contains(&n) {
            (Xyz::default(), StatusCode::OverHighRange)
        } else if let Some(f) = self.faults.status_on.iter().find(|f| f.reading == n) {
            let byte = u8::try_from(f.code).unwrap_or(b'?');
            let status = StatusCode::from_byte(byte);
            (Xyz::default(), status)
        } else if self.lights_on {
            (Xyz::default(), StatusCode::AimingLights)
        } else {
            self.read_meter(&spec)
        };
        let ranges = if status == StatusCode::OverHighRange {
            [1; 3]
        } else {
            ranges_for(&xyz)
        };
        let answer = proto::encode_measurement(speed, xyz, ranges, status);
        self.answer(&answer);
    }

    fn read_meter(&mut self, spec: &InstrumentSpec) -> (Xyz, StatusCode) {
        match self.meter.measure() {
            Ok(xyz) if !xyz.is_finite() => (Xyz::default(), StatusCode::Firmware(b'X')),
            Ok(xyz) if xyz.to_array().iter().any(|&v| v > spec.max_cd_m2) => {
                (Xyz::default(), StatusCode::OverHighRange)
            }
            Ok(xyz) => (xyz, StatusCode::Ok),
            Err(DeviceError::OverRange { .. }) => (Xyz::default(), StatusCode::OverHighRange),
            // The K-10 has no low-light status; it reports what it sees. The backing
            // meter only told us the luminance, so report it as equal-energy white.
            Err(DeviceError::TooDark { y_cd_m2, .. }) => {
                (Xyz::new(y_cd_m2, y_cd_m2, y_cd_m2), StatusCode::Ok)
            }
            Err(e) => {
                tracing::warn!("emulator: backing meter failed ({e}); answering firmware error");
                (Xyz::default(), StatusCode::Firmware(b'X'))
            }
        }
    }
}

/// Top of range `r` in cd/m² (the decade [`ranges_for`] assigns to it).
fn range_top_cd_m2(r: u8) -> f64 {
    0.1 * 10f64.powi(7 - i32::from(r.clamp(1, 6)))
}

/// Range index per channel, 1 (brightest) .. 6 (darkest), one per decade. Klein does
/// not document the range boundaries; the driver does not use them.
fn ranges_for(xyz: &Xyz) -> [u8; 3] {
    xyz.to_array().map(|v| {
        let decades = if v > 0.0 {
            (v / 0.1).log10().floor()
        } else {
            0.0
        };
        (6.0 - decades).clamp(1.0, 6.0) as u8
    })
}
