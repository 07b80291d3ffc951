//! The Klein K-10 family serial protocol (K-10, K-10-A, KV-10-A): command codes,
//! fixed answer lengths, the 3-byte "Klein float" number format, the measurement
//! range byte and the one-letter status codes.
//!
//! Everything here is pure (no I/O) so that the driver and the emulator share one
//! definition of the wire format and the parser can be fuzzed. Sources and the
//! byte layout are documented in `fixtures/instruments/klein-k10a.md`.
//!
//! Wire summary: 9600 baud, 8 data bits, no parity, 1 stop bit, no flow control.
//! A command is two ASCII characters followed by a carriage return (`"N5\r"`).
//! Every answer starts with the two-character echo of the command and ends with a
//! status code framed as `<c>`; it has no terminator, so answers are read by
//! their fixed length. Measurement payloads are binary (any byte value can occur).

use crate::Xyz;

/// Line speed of the K-10 family in baud.
pub const BAUD_RATE: u32 = 9600;

/// Byte that ends every command.
pub const COMMAND_TERMINATOR: u8 = b'\r';

/// Length of a measurement answer (`N4`..`N7`): echo (2) + X, Y, Z (3 × 3) + range
/// byte (1) + `<c>` (3).
pub const MEASUREMENT_ANSWER_LEN: usize = 15;

/// Length of the device-information answer (`P0`): echo (2) + model (7) + serial
/// number (9) + `<c>` (3).
pub const DEVICE_INFO_ANSWER_LEN: usize = 21;

/// Length of a plain acknowledgement (`J8`, `L0`, ...): echo (2) + `<c>` (3).
pub const ACK_ANSWER_LEN: usize = 5;

/// Length of the firmware-version answer (`P2`): echo (2) + version (8) + `<c>` (3).
pub const FIRMWARE_ANSWER_LEN: usize = 13;

/// Calibration slots in the list `D7` answers (slot 0, the factory default, is not
/// listed).
pub const CALIBRATION_SLOTS: usize = 96;

/// Bytes per calibration-slot name; a first byte 0xFF marks an empty slot.
pub const CALIBRATION_NAME_LEN: usize = 20;

/// Length of the calibration-list answer (`D7`): echo (2) + 96 names × 20 + `<c>` (3).
pub const CALIBRATION_LIST_ANSWER_LEN: usize = 2 + CALIBRATION_SLOTS * CALIBRATION_NAME_LEN + 3;

/// Length of one packet of the `T2` flicker stream: 32 triplets of a side-channel
/// byte and a 16-bit big-endian sample.
pub const FLICKER_PACKET_LEN: usize = 96;

/// Samples per second of the `T2` stream (32 per packet, 8 packets per second).
pub const FLICKER_SAMPLES_PER_S: f64 = 256.0;

/// What ArgyllCMS sends to identify a Klein instrument (after a lone `;`): the K-10
/// answers with `D4` and its calibration list.
pub const IDENTIFY_PROBE: &[u8] = b"D024";

/// Measurement speed: the K-10 averages its 256 Hz sensor samples over a window
/// whose length sets the reading rate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum MeasureSpeed {
    /// `N4`: 16 readings per second.
    Fast,
    /// `N5`: 8 readings per second (the rate ArgyllCMS and Klein's SDK use by default).
    #[default]
    Normal,
    /// `N6`: 4 readings per second.
    Slow,
    /// `N7`: 2 readings per second.
    Slowest,
}

impl MeasureSpeed {
    /// Time one reading takes in the instrument, in seconds.
    pub fn period_s(self) -> f64 {
        match self {
            MeasureSpeed::Fast => 1.0 / 16.0,
            MeasureSpeed::Normal => 1.0 / 8.0,
            MeasureSpeed::Slow => 1.0 / 4.0,
            MeasureSpeed::Slowest => 1.0 / 2.0,
        }
    }
}

/// The commands this driver and the emulator use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    /// `P0`: model and serial number.
    DeviceInfo,
    /// `N4`..`N7`: one XYZ reading.
    Measure(MeasureSpeed),
    /// `J8`: switch on auto-ranging.
    AutoRange,
    /// `L0`: aiming lights off.
    LightsOff,
    /// `L1`: aiming lights on.
    LightsOn,
    /// `P2`: firmware version.
    FirmwareVersion,
    /// `D7`: names of the stored calibrations (display types).
    CalibrationList,
    /// `J1`..`J6`: fix the measuring range (1..=6); `J7`: keep the current one.
    FixRange(u8),
    /// `T2`: start the 256-samples-per-second flicker stream (96-byte packets until
    /// the next command).
    FlickerStream,
}

impl Command {
    /// The two command characters.
    pub fn code(self) -> [u8; 2] {
        match self {
            Command::DeviceInfo => *b"P0",
            Command::Measure(MeasureSpeed::Fast) => *b"N4",
            Command::Measure(MeasureSpeed::Normal) => *b"N5",
            Command::Measure(MeasureSpeed::Slow) => *b"N6",
            Command::Measure(MeasureSpeed::Slowest) => *b"N7",
            Command::AutoRange => *b"J8",
            Command::LightsOff => *b"L0",
            Command::LightsOn => *b"L1",
            Command::FirmwareVersion => *b"P2",
            Command::CalibrationList => *b"D7",
            Command::FixRange(n) => [b'J', b'0' + n.clamp(1, 7)],
            Command::FlickerStream => *b"T2",
        }
    }

    /// Parses the two command characters.
    pub fn from_code(code: [u8; 2]) -> Option<Command> {
        Some(match &code {
            b"P0" => Command::DeviceInfo,
            b"N4" => Command::Measure(MeasureSpeed::Fast),
            b"N5" => Command::Measure(MeasureSpeed::Normal),
            b"N6" => Command::Measure(MeasureSpeed::Slow),
            b"N7" => Command::Measure(MeasureSpeed::Slowest),
            b"J8" => Command::AutoRange,
            b"L0" => Command::LightsOff,
            b"L1" => Command::LightsOn,
            b"P2" => Command::FirmwareVersion,
            b"D7" => Command::CalibrationList,
            [b'J', n @ b'1'..=b'7'] => Command::FixRange(n - b'0'),
            b"T2" => Command::FlickerStream,
            _ => return None,
        })
    }

    /// The bytes to send: the code and the terminator.
    pub fn wire(self) -> [u8; 3] {
        let [a, b] = self.code();
        [a, b, COMMAND_TERMINATOR]
    }

    /// The command as text, for messages ("N5").
    pub fn name(self) -> String {
        String::from_utf8_lossy(&self.code()).into_owned()
    }

    /// Length in bytes of the instrument's answer (for `T2`: of one packet).
    pub fn answer_len(self) -> usize {
        match self {
            Command::DeviceInfo => DEVICE_INFO_ANSWER_LEN,
            Command::Measure(_) => MEASUREMENT_ANSWER_LEN,
            Command::AutoRange | Command::LightsOff | Command::LightsOn | Command::FixRange(_) => {
                ACK_ANSWER_LEN
            }
            Command::FirmwareVersion => FIRMWARE_ANSWER_LEN,
            Command::CalibrationList => CALIBRATION_LIST_ANSWER_LEN,
            Command::FlickerStream => FLICKER_PACKET_LEN,
        }
    }
}

/// The one-character status code at the end of every answer, with the meaning
/// given by Klein's SDK (`KleinsErrorCodes`) and ArgyllCMS (`kleink10.c`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StatusCode {
    /// `0`: no error.
    Ok,
    /// `L`: the aiming lights are on while measuring.
    AimingLights,
    /// `u`: bottom under range — auto-ranging switched to a more sensitive range
    /// during the reading.
    BottomUnderRange,
    /// `v`: top over range — auto-ranging switched to a less sensitive range
    /// during the reading.
    TopOverRange,
    /// `w`: over high range — the light is above the top of the highest range.
    OverHighRange,
    /// `t`: black calibration "black zero".
    BlackZero,
    /// `s`: black calibration "black overdrive".
    BlackOverdrive,
    /// `b`: black calibration "black excessive".
    BlackExcessive,
    /// `X` or `B`: firmware error.
    Firmware(u8),
    /// Any other byte: neither source documents it (ArgyllCMS accepts any byte in
    /// the frame and reports "unknown error from instrument").
    Unknown(u8),
}

impl StatusCode {
    /// Decodes the status byte. Every byte is a status: the instrument may send a
    /// non-text one, and ArgyllCMS (which reads the real instrument) takes whatever
    /// stands between `<` and `>`; an undocumented byte is [`StatusCode::Unknown`], an
    /// instrument error, not line noise.
    pub fn from_byte(b: u8) -> StatusCode {
        match b {
            b'0' => StatusCode::Ok,
            b'L' => StatusCode::AimingLights,
            b'u' => StatusCode::BottomUnderRange,
            b'v' => StatusCode::TopOverRange,
            b'w' => StatusCode::OverHighRange,
            b't' => StatusCode::BlackZero,
            b's' => StatusCode::BlackOverdrive,
            b'b' => StatusCode::BlackExcessive,
            b'X' | b'B' => StatusCode::Firmware(b),
            b => StatusCode::Unknown(b),
        }
    }

    /// The status byte on the wire.
    pub fn to_byte(self) -> u8 {
        match self {
            StatusCode::Ok => b'0',
            StatusCode::AimingLights => b'L',
            StatusCode::BottomUnderRange => b'u',
            StatusCode::TopOverRange => b'v',
            StatusCode::OverHighRange => b'w',
            StatusCode::BlackZero => b't',
            StatusCode::BlackOverdrive => b's',
            StatusCode::BlackExcessive => b'b',
            StatusCode::Firmware(b) | StatusCode::Unknown(b) => b,
        }
    }

    /// What the code means and what the technician should do.
    pub fn meaning(self) -> &'static str {
        match self {
            StatusCode::Ok => "no error",
            StatusCode::AimingLights => {
                "aiming lights are on while measuring; switch them off with the knob (or send L0)"
            }
            StatusCode::BottomUnderRange => {
                "bottom under range: the meter changed to a more sensitive range during the \
                 reading; repeat the reading"
            }
            StatusCode::TopOverRange => {
                "top over range: the meter changed to a less sensitive range during the \
                 reading; repeat the reading"
            }
            StatusCode::OverHighRange => {
                "over high range: the light is brighter than the highest range"
            }
            StatusCode::BlackZero => {
                "black calibration failed (black zero); cap the lens and rerun the black calibration"
            }
            StatusCode::BlackOverdrive => {
                "black calibration failed (black overdrive); cap the lens and rerun the black \
                 calibration"
            }
            StatusCode::BlackExcessive => {
                "black calibration failed (black excessive); cap the lens and rerun the black \
                 calibration"
            }
            StatusCode::Firmware(_) => {
                "firmware error; power-cycle the meter, contact Klein Instruments if it persists"
            }
            StatusCode::Unknown(_) => "status code not documented by Klein or ArgyllCMS",
        }
    }

    /// True for the auto-ranging codes (`u`, `v`) after which the reading is simply
    /// repeated (ArgyllCMS sends the reading at most 4 times in all).
    pub fn is_range_change(self) -> bool {
        matches!(
            self,
            StatusCode::BottomUnderRange | StatusCode::TopOverRange
        )
    }
}

/// Decodes a 3-byte Klein measurement float: bit 7 of byte 0 is the sign, the other
/// 15 bits of bytes 0–1 the mantissa `m`, byte 2 a two's-complement exponent `e`;
/// the value is `±m · 2^(e−16)`. Always finite.
pub fn decode_kfloat(b: [u8; 3]) -> f64 {
    let raw = u16::from_be_bytes([b[0], b[1]]);
    let negative = raw & 0x8000 != 0;
    let mantissa = f64::from(raw & 0x7fff);
    let exponent = i32::from(b[2] as i8);
    let v = mantissa * 2f64.powi(exponent - 16);
    if negative { -v } else { v }
}

/// Encodes a value as a Klein measurement float, rounding the mantissa to 15 bits
/// (relative error at most 2⁻¹⁵ for normal values). Values beyond the format's
/// range saturate; NaN encodes as zero.
pub fn encode_kfloat(v: f64) -> [u8; 3] {
    if v == 0.0 || v.is_nan() {
        return [0, 0, 0];
    }
    let sign: u16 = if v < 0.0 { 0x8000 } else { 0 };
    let a = v.abs();
    if !a.is_finite() {
        let [hi, lo] = (sign | 0x7fff).to_be_bytes();
        return [hi, lo, 127];
    }
    // Normalise so that the mantissa lies in [2^14, 2^15).
    let mut e = a.log2().floor() as i32 + 2;
    let mant = |e: i32| (a * 2f64.powi(16 - e)).round();
    let mut m = mant(e);
    while m >= 32768.0 {
        e += 1;
        m = mant(e);
    }
    while m < 16384.0 && e > -128 {
        e -= 1;
        m = mant(e);
    }
    if e > 127 {
        e = 127;
        m = 32767.0;
    }
    if e < -128 {
        e = -128;
        m = mant(e);
    }
    let m = m.clamp(0.0, 32767.0) as u16;
    let [hi, lo] = (sign | m).to_be_bytes();
    [hi, lo, (e as i8) as u8]
}

/// Decodes the range byte into the range (1..=6) of the X, Y and Z sensor channels.
/// Bits 7, 6, 5 are the low bit of each channel's range index; the low five bits
/// hold the high parts as three base-3 digits.
pub fn decode_ranges(b: u8) -> [u8; 3] {
    let digits = b & 0x1f;
    let high = [(digits / 9) % 3, (digits / 3) % 3, digits % 3];
    let mut out = [0u8; 3];
    for (i, o) in out.iter_mut().enumerate() {
        let low = (b >> (7 - i)) & 1;
        *o = 1 + low + 2 * high[i];
    }
    out
}

/// Encodes the three channel ranges (each 1..=6) into the range byte; `None` if a
/// range is outside 1..=6.
pub fn encode_ranges(r: [u8; 3]) -> Option<u8> {
    let mut byte = 0u8;
    let mut digits = 0u8;
    for (i, &ri) in r.iter().enumerate() {
        if !(1..=6).contains(&ri) {
            return None;
        }
        let idx = ri - 1;
        byte |= (idx & 1) << (7 - i);
        digits = digits * 3 + idx / 2;
    }
    Some(byte | digits)
}

/// One decoded measurement answer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeasurementAnswer {
    /// XYZ as sent by the instrument (factory calibration, Y in cd/m²).
    pub xyz: Xyz,
    /// Range (1..=6) of the X, Y and Z channels.
    pub ranges: [u8; 3],
    /// The status code.
    pub status: StatusCode,
}

/// Why an answer could not be parsed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum AnswerError {
    /// Not the fixed length.
    #[error("answer has {got} bytes, expected {expected}")]
    Length {
        /// Bytes received.
        got: usize,
        /// Bytes the protocol defines.
        expected: usize,
    },
    /// The echo does not match the command sent.
    #[error("answer does not start with the command echo {expected:?}")]
    Echo {
        /// The command's two characters.
        expected: String,
    },
    /// The `<c>` status frame is missing.
    #[error("answer does not end with a <status> frame")]
    StatusFrame,
}

/// Splits off and checks the echo and the `<c>` frame common to all answers.
fn check_frame(command: Command, answer: &[u8]) -> Result<StatusCode, AnswerError> {
    let expected = command.answer_len();
    if answer.len() != expected {
        return Err(AnswerError::Length {
            got: answer.len(),
            expected,
        });
    }
    if answer[..2] != command.code() {
        return Err(AnswerError::Echo {
            expected: command.name(),
        });
    }
    let n = answer.len();
    if answer[n - 3] != b'<' || answer[n - 1] != b'>' {
        return Err(AnswerError::StatusFrame);
    }
    Ok(StatusCode::from_byte(answer[n - 2]))
}

/// Parses a measurement answer (`N4`..`N7`).
pub fn parse_measurement(
    speed: MeasureSpeed,
    answer: &[u8],
) -> Result<MeasurementAnswer, AnswerError> {
    let status = check_frame(Command::Measure(speed), answer)?;
    let f = |i: usize| decode_kfloat([answer[i], answer[i + 1], answer[i + 2]]);
    Ok(MeasurementAnswer {
        xyz: Xyz::new(f(2), f(5), f(8)),
        ranges: decode_ranges(answer[11]),
        status,
    })
}

/// Builds a measurement answer (used by the emulator).
pub fn encode_measurement(
    speed: MeasureSpeed,
    xyz: Xyz,
    ranges: [u8; 3],
    status: StatusCode,
) -> [u8; MEASUREMENT_ANSWER_LEN] {
    let mut out = [0u8; MEASUREMENT_ANSWER_LEN];
    out[..2].copy_from_slice(&Command::Measure(speed).code());
    out[2..5].copy_from_slice(&encode_kfloat(xyz.x));
    out[5..8].copy_from_slice(&encode_kfloat(xyz.y));
    out[8..11].copy_from_slice(&encode_kfloat(xyz.z));
    out[11] = encode_ranges(ranges).unwrap_or(0);
    out[12] = b'<';
    out[13] = status.to_byte();
    out[14] = b'>';
    out
}

/// Parses a plain acknowledgement (`J8<0>`, `L0<0>`).
pub fn parse_ack(command: Command, answer: &[u8]) -> Result<StatusCode, AnswerError> {
    check_frame(command, answer)
}

/// Builds a plain acknowledgement.
pub fn encode_ack(command: Command, status: StatusCode) -> [u8; ACK_ANSWER_LEN] {
    let [a, b] = command.code();
    [a, b, b'<', status.to_byte(), b'>']
}

/// Model and serial number from a `P0` answer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeviceInfoAnswer {
    /// Model, trailing blanks removed ("K-10-A").
    pub model: String,
    /// Serial number, blanks removed.
    pub serial: String,
    /// The status code.
    pub status: StatusCode,
}

/// Parses a `P0` answer.
pub fn parse_device_info(answer: &[u8]) -> Result<DeviceInfoAnswer, AnswerError> {
    let status = check_frame(Command::DeviceInfo, answer)?;
    let text = |r: std::ops::Range<usize>| String::from_utf8_lossy(&answer[r]).trim().to_string();
    Ok(DeviceInfoAnswer {
        model: text(2..9),
        serial: text(9..18),
        status,
    })
}

/// Builds a `P0` answer; the model is padded or cut to 7 characters, the serial
/// number to 9.
pub fn encode_device_info(model: &str, serial: &str) -> [u8; DEVICE_INFO_ANSWER_LEN] {
    let mut out = [b' '; DEVICE_INFO_ANSWER_LEN];
    out[..2].copy_from_slice(b"P0");
    for (dst, src) in out[2..9].iter_mut().zip(model.bytes()) {
        *dst = src;
    }
    for (dst, src) in out[9..18].iter_mut().zip(serial.bytes()) {
        *dst = src;
    }
    out[18..].copy_from_slice(b"<0>");
    out
}

/// Builds a `P2` answer; the version is padded or cut to 8 characters.
pub fn encode_firmware(version: &str) -> [u8; FIRMWARE_ANSWER_LEN] {
    let mut out = [b' '; FIRMWARE_ANSWER_LEN];
    out[..2].copy_from_slice(b"P2");
    for (dst, src) in out[2..10].iter_mut().zip(version.bytes()) {
        *dst = src;
    }
    out[10..].copy_from_slice(b"<0>");
    out
}

/// Parses a `P2` answer: the firmware version (blanks removed) and the status.
pub fn parse_firmware(answer: &[u8]) -> Result<(String, StatusCode), AnswerError> {
    let status = check_frame(Command::FirmwareVersion, answer)?;
    Ok((
        String::from_utf8_lossy(&answer[2..10]).trim().to_string(),
        status,
    ))
}

/// The 96 calibration-slot names after an echo: each name padded with blanks to 20
/// bytes, empty slots as 0xFF bytes.
fn calibration_names(names: &[&str]) -> Vec<u8> {
    let mut out = vec![0xff; CALIBRATION_SLOTS * CALIBRATION_NAME_LEN];
    for (slot, name) in out.chunks_mut(CALIBRATION_NAME_LEN).zip(names) {
        slot.fill(b' ');
        for (dst, src) in slot.iter_mut().zip(name.bytes().filter(|b| *b != 0xff)) {
            *dst = src;
        }
    }
    out
}

/// Builds a `D7` answer listing `names` in slots 1.. (at most 96; names cut to 20
/// bytes); `echo` is `D7`, or `D4` for the answer to the identification probe.
pub fn encode_calibration_list(echo: [u8; 2], names: &[&str]) -> Vec<u8> {
    let mut out = echo.to_vec();
    out.extend(calibration_names(names));
    out.extend_from_slice(b"<0>");
    out
}

/// Parses a `D7` answer into (slot, name) for every used slot (1-based).
pub fn parse_calibration_list(answer: &[u8]) -> Result<Vec<(usize, String)>, AnswerError> {
    check_frame(Command::CalibrationList, answer)?;
    Ok(answer[2..answer.len() - 3]
        .chunks(CALIBRATION_NAME_LEN)
        .enumerate()
        .filter(|(_, c)| c.first() != Some(&0xff))
        .map(|(i, c)| (i + 1, String::from_utf8_lossy(c).trim().to_string()))
        .collect())
}

/// Builds one `T2` flicker packet: 32 samples (16-bit, big-endian, each after one
/// side-channel byte); the side channel carries `T2`, X, Y, Z, the range byte,
/// `<0>` and `_` padding.
pub fn encode_flicker_packet(
    samples: &[u16; 32],
    xyz: Xyz,
    ranges: [u8; 3],
) -> [u8; FLICKER_PACKET_LEN] {
    let mut side = [b'_'; 32];
    side[..2].copy_from_slice(b"T2");
    side[2..5].copy_from_slice(&encode_kfloat(xyz.x));
    side[5..8].copy_from_slice(&encode_kfloat(xyz.y));
    side[8..11].copy_from_slice(&encode_kfloat(xyz.z));
    side[11] = encode_ranges(ranges).unwrap_or(0);
    side[12..15].copy_from_slice(b"<0>");
    let mut out = [0u8; FLICKER_PACKET_LEN];
    for (i, (s, v)) in side.iter().zip(samples).enumerate() {
        let [hi, lo] = v.to_be_bytes();
        out[3 * i..3 * i + 3].copy_from_slice(&[*s, hi, lo]);
    }
    out
}

/// The samples of a `T2` packet and its status byte (packet byte 39).
pub fn parse_flicker_packet(packet: &[u8; FLICKER_PACKET_LEN]) -> ([u16; 32], StatusCode) {
    let samples =
        std::array::from_fn(|i| u16::from_be_bytes([packet[3 * i + 1], packet[3 * i + 2]]));
    (samples, StatusCode::from_byte(packet[39]))
}

/// The models that speak this protocol, as their `P0` answer names them.
pub const KNOWN_MODELS: [&str; 3] = ["K-10", "K-10-A", "KV-10-A"];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kfloat_examples() {
        // m = 0x4000 = 16384, e = 1 → 16384 · 2^-15 = 0.5
        assert_eq!(decode_kfloat([0x40, 0x00, 0x01]), 0.5);
        assert_eq!(decode_kfloat([0xc0, 0x00, 0x01]), -0.5);
        assert_eq!(decode_kfloat([0, 0, 0]), 0.0);
        assert_eq!(encode_kfloat(0.5), [0x40, 0x00, 0x01]);
        assert_eq!(encode_kfloat(1.0), [0x40, 0x00, 0x02]);
        // exponent byte 0x80 is -128 (two's complement)
        assert_eq!(decode_kfloat([0x00, 0x01, 0x80]), 2f64.powi(-144));
    }

    #[test]
    fn ranges_round_trip() {
        for a in 1..=6 {
            for b in 1..=6 {
                for c in 1..=6 {
                    let byte = encode_ranges([a, b, c]).unwrap();
                    assert_eq!(decode_ranges(byte), [a, b, c]);
                }
            }
        }
        assert_eq!(encode_ranges([0, 1, 1]), None);
    }
}
