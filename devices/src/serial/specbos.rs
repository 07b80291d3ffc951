//! Driver for the JETI specbos 1201/1211 spectroradiometers over a (USB-)serial
//! port: the command sequence ArgyllCMS 2.3.1 uses (`fixtures/instruments/jeti-specbos.md`),
//! with the instrument's error codes turned into [`DeviceError`]s a technician can
//! act on.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use serialport::{ClearBuffer, DataBits, FlowControl, Parity, SerialPort, StopBits};

use super::specbos_protocol::{self as proto};
use crate::spectral::{SpectralRadiance, Spectroradiometer};
use crate::{Colorimeter, DeviceError, MeterInfo, Xyz};

/// Timeouts and retries of the specbos driver.
#[derive(Debug, Clone, PartialEq)]
pub struct SpecbosConfig {
    /// Longest wait for the answer to a query or setting (ArgyllCMS: 1 s).
    pub read_timeout: Duration,
    /// Longest wait for a measurement to end (ArgyllCMS: 19.6 s on a 1211).
    pub measure_timeout: Duration,
    /// Longest wait for a spectrum (ArgyllCMS: 6 s).
    pub spectrum_timeout: Duration,
    /// Further attempts at fetching a spectrum that arrived incomplete (the specbos
    /// has no flow control; ArgyllCMS makes 5 attempts in all).
    pub spectrum_retries: u32,
    /// Longest adaptive integration time the instrument may choose (ms, ArgyllCMS:
    /// 3000).
    pub max_integration_ms: u32,
}

impl Default for SpecbosConfig {
    fn default() -> Self {
        Self {
            read_timeout: Duration::from_secs(1),
            measure_timeout: Duration::from_millis(19_600),
            spectrum_timeout: Duration::from_secs(6),
            spectrum_retries: 4,
            max_integration_ms: 3000,
        }
    }
}

/// Optical bandwidth of the specbos 1201 and 1211 (nm, maker's figure).
pub const SPECBOS_BANDWIDTH_NM: f64 = 4.5;

/// A JETI specbos on a serial port.
pub struct JetiSpecbos {
    port: Box<dyn SerialPort>,
    config: SpecbosConfig,
    device: String,
    model: u32,
    serial: String,
    /// The range set with `*conf:wran` (nm).
    range: [u32; 2],
}

impl std::fmt::Debug for JetiSpecbos {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JetiSpecbos")
            .field("device", &self.device)
            .field("model", &self.model)
            .field("serial", &self.serial)
            .field("range", &self.range)
            .finish_non_exhaustive()
    }
}

/// How a command's answer ends.
#[derive(Debug, Clone, Copy)]
enum Answer {
    /// A single ACK.
    Ack,
    /// `n` lines ended by `\r`.
    Lines(usize),
    /// ACK, then BEL when the measurement is done.
    Measurement,
}

impl JetiSpecbos {
    /// Opens the instrument on `path` (`/dev/ttyUSB0`, or an emulator's `/dev/pts/N`)
    /// at 921 600 baud 8N1 without flow control, identifies it (`*idn?`, a specbos
    /// 1201 or 1211) and sets it up for emissive readings with automatic
    /// integration time over its calibrated range at 1 nm.
    pub fn open(path: &str, config: SpecbosConfig) -> Result<Self, DeviceError> {
        let device = format!("JETI specbos on {path}");
        let port = serialport::new(path, proto::BAUD_RATE)
            .data_bits(DataBits::Eight)
            .parity(Parity::None)
            .stop_bits(StopBits::One)
            .flow_control(FlowControl::None)
            .timeout(config.read_timeout)
            .open()
            .map_err(|e| DeviceError::Io {
                device: device.clone(),
                source: std::io::Error::from(e),
            })?;
        let mut s = Self {
            port,
            config,
            device,
            model: 0,
            serial: String::new(),
            range: [380, 780],
        };
        s.identify()?;
        s.set_up()?;
        Ok(s)
    }

    /// `*idn?` and `*para:spnum?`.
    fn identify(&mut self) -> Result<(), DeviceError> {
        let idn = self.query("*idn?")?;
        self.model = match proto::parse_identity(&idn) {
            Some(m @ (1201 | 1211)) => m,
            Some(m) => {
                return Err(DeviceError::Config(format!(
                    "{} is a specbos {m}; lumiwall drives the specbos 1201 and 1211",
                    self.device
                )));
            }
            None => {
                return Err(DeviceError::Garbled {
                    device: self.device.clone(),
                    command: "*idn?".into(),
                    answer: format!(
                        "{idn:?} (not a specbos 1201/1211; a spectraval speaks another command set)"
                    ),
                });
            }
        };
        self.device = format!("JETI specbos {} on {}", self.model, self.port_name());
        let spnum = self.query("*para:spnum?")?;
        self.serial = proto::parse_labelled_number(&spnum, "spectrometer number:")
            .map(|n| format!("{n:.0}"))
            .unwrap_or_else(|| "unknown".into());
        Ok(())
    }

    fn port_name(&self) -> String {
        self.port.name().unwrap_or_else(|| "serial port".into())
    }

    /// Defaults, automatic calibration choice and integration time, radiometric
    /// spectrum in ASCII, the calibrated range at 1 nm, one average.
    fn set_up(&mut self) -> Result<(), DeviceError> {
        for setting in [
            "*conf:default".to_string(),
            "*para:calibn 0".to_string(),
            "*para:expo 1".to_string(),
            format!("*conf:maxtin {}", self.config.max_integration_ms),
            "*conf:func 6".to_string(),
            "*conf:form 4".to_string(),
        ] {
            self.set(&setting)?;
        }
        let wave = |s: &mut Self, q: &str, label: &str| -> Result<u32, DeviceError> {
            let a = s.query(q)?;
            proto::parse_labelled_number(&a, label)
                .filter(|v| (200.0..=1200.0).contains(v))
                .map(|v| v.round() as u32)
                .ok_or_else(|| s.garbled(q, &a))
        };
        let start = wave(self, "*para:wavbeg?", "Predefined start wave:")?;
        let end = wave(self, "*para:wavend?", "Predefined end wave:")?.min(830);
        if end <= start || start > 380 || end < 780 {
            return Err(DeviceError::Config(format!(
                "{} is calibrated over {start}–{end} nm; colorimetry needs 380–780 nm",
                self.device
            )));
        }
        self.set_range([start, end])?;
        self.set("*conf:aver 1")
    }

    fn set_range(&mut self, range: [u32; 2]) -> Result<(), DeviceError> {
        self.set(&format!("*conf:wran {} {} 1", range[0], range[1]))?;
        self.range = range;
        Ok(())
    }

    fn garbled(&self, command: &str, answer: &str) -> DeviceError {
        DeviceError::Garbled {
            device: self.device.clone(),
            command: command.into(),
            answer: answer.into(),
        }
    }

    fn set(&mut self, command: &str) -> Result<(), DeviceError> {
        self.exchange(command, Answer::Ack, self.config.read_timeout)
            .map(|_| ())
    }

    fn query(&mut self, command: &str) -> Result<String, DeviceError> {
        self.exchange(command, Answer::Lines(1), self.config.read_timeout)
    }

    /// Sends `command` and reads its answer; a NAK is turned into the error the
    /// instrument reports for it.
    fn exchange(
        &mut self,
        command: &str,
        answer: Answer,
        timeout: Duration,
    ) -> Result<String, DeviceError> {
        self.send(command)?;
        let bytes = self.read_answer(answer, timeout)?;
        if bytes.first() == Some(&proto::NAK) || bytes.last() == Some(&proto::NAK) {
            return Err(self.error_for(command));
        }
        let text: Vec<u8> = bytes
            .into_iter()
            .filter(|b| ![proto::ACK, proto::BEL, 0x05].contains(b))
            .collect();
        Ok(String::from_utf8_lossy(&text).into_owned())
    }

    fn send(&mut self, command: &str) -> Result<(), DeviceError> {
        self.port
            .clear(ClearBuffer::Input)
            .map_err(|e| self.io_error(e.into()))?;
        let mut wire = command.as_bytes().to_vec();
        wire.push(proto::TERMINATOR);
        self.port.write_all(&wire).map_err(|e| self.io_error(e))
    }

    fn io_error(&self, source: std::io::Error) -> DeviceError {
        DeviceError::Io {
            device: self.device.clone(),
            source,
        }
    }

    /// Reads until the answer is complete, a NAK arrives, or `timeout` passes.
    fn read_answer(&mut self, answer: Answer, timeout: Duration) -> Result<Vec<u8>, DeviceError> {
        let deadline = Instant::now() + timeout;
        let mut buf = Vec::new();
        let mut chunk = [0u8; 512];
        loop {
            if complete(&buf, answer) {
                return Ok(buf);
            }
            if buf.len() > proto::MAX_ANSWER_BYTES {
                return Err(self.garbled("answer", "longer than any specbos answer"));
            }
            let now = Instant::now();
            if now >= deadline {
                return Err(DeviceError::Timeout {
                    device: self.device.clone(),
                    timeout_ms: timeout.as_millis().min(u128::from(u64::MAX)) as u64,
                });
            }
            self.port
                .set_timeout(deadline - now)
                .map_err(|e| self.io_error(e.into()))?;
            match self.port.read(&mut chunk) {
                Ok(0) => std::thread::sleep(Duration::from_millis(1)),
                Ok(n) => buf.extend_from_slice(&chunk[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(self.io_error(e)),
            }
        }
    }

    /// Asks `*stat:err?` after a NAK to `command` and maps the code.
    fn error_for(&mut self, command: &str) -> DeviceError {
        // read directly: a NAK to the error query itself must not ask again
        let answer = self
            .send("*stat:err?")
            .and_then(|()| self.read_answer(Answer::Lines(1), self.config.read_timeout));
        let code = match answer {
            Ok(bytes) if !bytes.contains(&proto::NAK) => {
                proto::parse_labelled_number(&String::from_utf8_lossy(&bytes), "Error Code:")
                    .map(|v| v as u32)
            }
            Ok(bytes) => {
                return self.garbled("*stat:err?", &format!("{}", bytes.escape_ascii()));
            }
            Err(e) => return e,
        };
        match code {
            Some(proto::ERROR_OVEREXPOSED) => DeviceError::OverRange {
                device: self.device.clone(),
            },
            Some(proto::ERROR_UNDEREXPOSED) => DeviceError::TooDark {
                device: self.device.clone(),
                y_cd_m2: 0.0,
                limit_cd_m2: 0.05,
            },
            Some(code) => DeviceError::Instrument {
                device: self.device.clone(),
                code: format!("{code} (to {command})"),
                meaning: proto::error_meaning(code).into(),
            },
            None => self.garbled("*stat:err?", "no error code"),
        }
    }

    /// `*contr:mhead?`, `*init` (narrowing to 380–780 nm once on error 141, as a
    /// third-party calibration may require).
    fn take_measurement(&mut self) -> Result<(), DeviceError> {
        let head = self.query("*contr:mhead?")?;
        if proto::parse_labelled_number(&head, "mhead:") != Some(0.0) {
            return Err(DeviceError::Config(format!(
                "{} has its diffuser head fitted ({head:?}); remove it for luminance readings",
                self.device
            )));
        }
        let timeout = self.config.measure_timeout;
        match self.exchange("*init", Answer::Measurement, timeout) {
            Err(DeviceError::Instrument { code, .. })
                if code.starts_with("141") && self.range != [380, 780] =>
            {
                self.set_range([self.range[0].max(380), self.range[1].min(780)])?;
                self.exchange("*init", Answer::Measurement, timeout)
                    .map(|_| ())
            }
            other => other.map(|_| ()),
        }
    }

    /// `*fetch:sprad`, retried when the spectrum arrives incomplete.
    fn fetch_spectrum(&mut self) -> Result<SpectralRadiance, DeviceError> {
        let n = (self.range[1] - self.range[0] + 1) as usize;
        let mut last = None;
        for _ in 0..=self.config.spectrum_retries {
            let timeout = self.config.spectrum_timeout;
            match self.exchange("*fetch:sprad", Answer::Lines(n + 3), timeout) {
                Ok(text) => match proto::parse_spectrum(&text, n) {
                    Ok(values) => {
                        let s = SpectralRadiance {
                            start_nm: f64::from(self.range[0]),
                            step_nm: 1.0,
                            w_sr_m2_nm: values,
                        };
                        s.check(&self.device)?;
                        return Ok(s);
                    }
                    Err(why) => last = Some(self.garbled("*fetch:sprad", &why)),
                },
                Err(e @ DeviceError::Timeout { .. }) => last = Some(e),
                Err(e) => return Err(e),
            }
        }
        Err(last.unwrap_or_else(|| self.garbled("*fetch:sprad", "no attempt")))
    }
}

/// Whether `buf` holds the whole answer (or a refusal).
fn complete(buf: &[u8], answer: Answer) -> bool {
    if buf.first() == Some(&proto::NAK) || buf.last() == Some(&proto::NAK) {
        return true;
    }
    match answer {
        Answer::Ack => buf.contains(&proto::ACK) || buf.contains(&proto::TERMINATOR),
        Answer::Lines(n) => buf.iter().filter(|&&b| b == proto::TERMINATOR).count() >= n,
        Answer::Measurement => buf.contains(&proto::BEL),
    }
}

impl Colorimeter for JetiSpecbos {
    fn info(&self) -> MeterInfo {
        MeterInfo {
            model: format!("JETI specbos {}", self.model),
            serial: self.serial.clone(),
            min_reliable_cd_m2: 0.2,
            max_cd_m2: 70_000.0,
            // no published figure at hand (see fixtures/instruments)
            noise: None,
        }
    }

    /// The instrument's own XYZ of one measurement (`*fetch:XYZ`).
    fn measure(&mut self) -> Result<Xyz, DeviceError> {
        self.take_measurement()?;
        let timeout = self.config.read_timeout;
        let text = self.exchange("*fetch:XYZ", Answer::Lines(3), timeout)?;
        let xyz = proto::parse_xyz(&text).ok_or_else(|| self.garbled("*fetch:XYZ", &text))?;
        if xyz.y <= 0.0 {
            return Err(DeviceError::TooDark {
                device: self.device.clone(),
                y_cd_m2: xyz.y.max(0.0),
                limit_cd_m2: 0.05,
            });
        }
        Ok(xyz)
    }
}

impl Spectroradiometer for JetiSpecbos {
    fn measure_spectrum(&mut self) -> Result<SpectralRadiance, DeviceError> {
        self.take_measurement()?;
        self.fetch_spectrum()
    }

    fn bandwidth_nm(&self) -> f64 {
        SPECBOS_BANDWIDTH_NM
    }

    fn wavelength_range_nm(&self) -> [f64; 2] {
        self.range.map(f64::from)
    }
}
