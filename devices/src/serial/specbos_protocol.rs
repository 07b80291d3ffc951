//! The wire format of the JETI specbos 1201/1211 spectroradiometers, as ArgyllCMS
//! 2.3.1 speaks it (described, with sources, in `fixtures/instruments/jeti-specbos.md`;
//! nothing of ArgyllCMS is copied): ASCII commands `*…` ended by `\r`, no echo;
//! settings answered by ACK, queries by text lines ended by `\r`, a measurement by ACK
//! and then BEL when done, any failure by a lone NAK, after which `*stat:err?` tells
//! the error code. Pure functions shared by the driver and the emulator.

use crate::Xyz;

/// Acknowledges a setting or the start of a measurement.
pub const ACK: u8 = 0x06;
/// Ends a measurement.
pub const BEL: u8 = 0x07;
/// Refuses a command; `*stat:err?` then tells why.
pub const NAK: u8 = 0x15;
/// Ends every command and every answer line.
pub const TERMINATOR: u8 = b'\r';
/// The line speed ArgyllCMS tries first (FTDI default of the specbos 1211).
pub const BAUD_RATE: u32 = 921_600;
/// Most bytes ArgyllCMS accepts in one answer (its 8000-byte buffer).
pub const MAX_ANSWER_BYTES: usize = 7999;

/// One command, as the emulator understands it.
#[derive(Debug, Clone, PartialEq)]
pub enum Request {
    /// `*idn?`: the identity (`JETI_SB1211`).
    Identify,
    /// `*vers?`: the firmware version.
    Version,
    /// `*para:spnum?`: the spectrometer's serial number.
    SerialNumber,
    /// `*para:wavbeg?`: first wavelength of the calibrated range.
    StartWave,
    /// `*para:wavend?`: last wavelength of the calibrated range.
    EndWave,
    /// `*conf:wran START END STEP`: the range to measure and report.
    Range {
        /// First wavelength (nm).
        start_nm: u32,
        /// Last wavelength (nm).
        end_nm: u32,
        /// Step (nm).
        step_nm: u32,
    },
    /// `*conf:aver N`: internal averages per measurement.
    Average(u32),
    /// `*contr:mhead?`: which head is fitted (0 telescope, 1 diffuser).
    Head,
    /// `*contr:laser?`: the aiming laser's state.
    LaserState,
    /// `*init`: one measurement.
    Measure,
    /// `*fetch:XYZ`: tristimulus values of the last measurement.
    FetchXyz,
    /// `*fetch:PHOTOmetric`: its luminance.
    FetchLuminance,
    /// `*fetch:CHROMXY`: its chromaticity.
    FetchChromaticity,
    /// `*fetch:sprad`: its spectral radiance.
    FetchSpectrum,
    /// `*stat:err?`: the code of the last error.
    ErrorCode,
    /// A setting this instrument model accepts and the emulation need not act on
    /// (`*conf:default`, `*para:calibn`, `*para:expo`, `*conf:maxtin`, `*conf:func`,
    /// `*conf:form`, `*contr:laser N`, `*conf:cycmod`, `*conf:cyctim`).
    Setting(String),
    /// Anything else (answered NAK, error 4).
    Unknown(String),
}

/// The settings [`Request::Setting`] covers: name and number of numeric arguments.
const SETTINGS: [(&str, usize); 9] = [
    ("*conf:default", 0),
    ("*para:calibn", 1),
    ("*para:expo", 1),
    ("*conf:maxtin", 1),
    ("*conf:func", 1),
    ("*conf:form", 1),
    ("*contr:laser", 1),
    ("*conf:cycmod", 1),
    ("*conf:cyctim", 1),
];

/// The command in `frame` (the bytes before a `\r`): the text from its last `*` on,
/// since ArgyllCMS's probes for other instruments (`;`, `D024\r\n`, binary pings)
/// may precede it on the line. `None`: no `*` at all (not for this instrument: no
/// answer).
pub fn parse_request(frame: &[u8]) -> Option<Request> {
    let start = frame.iter().rposition(|&b| b == b'*')?;
    let text = String::from_utf8_lossy(&frame[start..]).trim().to_string();
    let words: Vec<&str> = text.split_whitespace().collect();
    let exact = match words.as_slice() {
        ["*idn?"] => Some(Request::Identify),
        ["*vers?"] => Some(Request::Version),
        ["*para:spnum?"] => Some(Request::SerialNumber),
        ["*para:wavbeg?"] => Some(Request::StartWave),
        ["*para:wavend?"] => Some(Request::EndWave),
        ["*contr:mhead?"] => Some(Request::Head),
        ["*contr:laser?"] => Some(Request::LaserState),
        ["*init"] => Some(Request::Measure),
        ["*fetch:XYZ"] => Some(Request::FetchXyz),
        ["*fetch:PHOTOmetric"] => Some(Request::FetchLuminance),
        ["*fetch:CHROMXY"] => Some(Request::FetchChromaticity),
        ["*fetch:sprad"] => Some(Request::FetchSpectrum),
        ["*stat:err?"] => Some(Request::ErrorCode),
        ["*conf:wran", a, b, c] => match (a.parse(), b.parse(), c.parse()) {
            (Ok(start_nm), Ok(end_nm), Ok(step_nm)) => Some(Request::Range {
                start_nm,
                end_nm,
                step_nm,
            }),
            _ => None,
        },
        ["*conf:aver", n] => n.parse().ok().map(Request::Average),
        _ => None,
    };
    Some(exact.unwrap_or_else(|| {
        let known = SETTINGS.iter().any(|(name, args)| {
            words.first() == Some(name)
                && words.len() == 1 + args
                && words[1..].iter().all(|w| w.parse::<f64>().is_ok())
        });
        if known {
            Request::Setting(text.clone())
        } else {
            Request::Unknown(text.clone())
        }
    }))
}

/// The identity a specbos of `model` (1201 or 1211) answers to `*idn?`.
pub fn identity(model: u32) -> String {
    if model == 1201 {
        "SB05".to_string()
    } else {
        format!("JETI_SB{model}")
    }
}

/// The model number in an `*idn?` answer: `SB05…` is a 1201, `JETI_SB<n>` a specbos
/// `n`; `None` for anything else (a spectraval's `JETI_SDCM3 …` included: it speaks
/// another command set).
pub fn parse_identity(answer: &str) -> Option<u32> {
    let a = answer.trim();
    if a.starts_with("SB05") {
        return Some(1201);
    }
    let digits: String = a
        .strip_prefix("JETI_SB")?
        .chars()
        .take_while(char::is_ascii_digit)
        .collect();
    digits.parse().ok()
}

/// The number after `prefix` in a one-line answer such as
/// `Predefined start wave: 380` or `spectrometer number: 1234`; a bare number is
/// accepted too.
pub fn parse_labelled_number(answer: &str, prefix: &str) -> Option<f64> {
    let a = answer.trim();
    let rest = a.strip_prefix(prefix).unwrap_or(a).trim();
    let v: f64 = rest.split_whitespace().next()?.parse().ok()?;
    v.is_finite().then_some(v)
}

/// The answer to `*fetch:XYZ`: three lines `X: …`, `Y: …`, `Z: …` (Y in cd/m²).
pub fn encode_xyz(xyz: Xyz) -> String {
    format!("X: {:e}\rY: {:e}\rZ: {:e}\r", xyz.x, xyz.y, xyz.z)
}

/// XYZ from a `*fetch:XYZ` answer (labels and values separated by any white space).
pub fn parse_xyz(answer: &str) -> Option<Xyz> {
    let words: Vec<&str> = answer.split_whitespace().collect();
    let value = |label: &str| -> Option<f64> {
        let i = words.iter().position(|w| *w == label)?;
        words
            .get(i + 1)?
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
    };
    Some(Xyz::new(value("X:")?, value("Y:")?, value("Z:")?))
}

/// The two header lines of a `*fetch:sprad` answer (ArgyllCMS skips them; the
/// instrument's own wording is not published, so these say what follows).
pub fn spectrum_header(start_nm: u32, end_nm: u32) -> String {
    format!("Spectral radiance W/(sr*m^2*nm)\r{start_nm} nm to {end_nm} nm, 1 nm\r")
}

/// The answer to `*fetch:sprad`: two header lines, one value per line, and an empty
/// line.
pub fn encode_spectrum(start_nm: u32, end_nm: u32, values: &[f64]) -> String {
    let mut out = spectrum_header(start_nm, end_nm);
    for v in values {
        out.push_str(&format!("{v:.6e}\r"));
    }
    out.push('\r');
    out
}

/// The values of a `*fetch:sprad` answer: the lines after the two header lines, up
/// to the empty line; `Err` names the first line that is not a number or a count
/// other than `expected`.
pub fn parse_spectrum(answer: &str, expected: usize) -> Result<Vec<f64>, String> {
    let mut lines = answer.split('\r').skip(2);
    let mut values = Vec::with_capacity(expected);
    for line in lines.by_ref() {
        let line = line.trim();
        if line.is_empty() {
            break;
        }
        if values.len() == expected {
            return Err(format!("more than {expected} values"));
        }
        match line.parse::<f64>() {
            Ok(v) if v.is_finite() => values.push(v),
            _ => return Err(format!("value {} is `{line}`", values.len() + 1)),
        }
    }
    if values.len() != expected {
        return Err(format!("{} values, expected {expected}", values.len()));
    }
    Ok(values)
}

/// The answer to `*stat:err?`.
pub fn encode_error_code(code: u32) -> String {
    format!("Error Code: {code}\r")
}

/// What an error code means, in the words of the instrument's error list (as
/// ArgyllCMS reports them), with what a technician can do about it.
pub fn error_meaning(code: u32) -> &'static str {
    match code {
        4 => "unknown command (older firmware?)",
        8 | 10..=13 | 20..=27 => "a command argument was refused",
        120 => "overexposed: the light is too bright even at the shortest integration time",
        121 => "underexposed: too dark for the longest integration time",
        123 => "adapting the integration time failed: is the light stable?",
        130..=139 => "no measurement to fetch or calculate from; measure first",
        140 => "calibration data missing",
        141 => "the wavelength range exceeds the calibrated range",
        147 | 160 | 161 => "measurement interrupted or the cycle trigger timed out",
        101..=104 | 170..=172 | 180..=197 | 200..=232 => {
            "internal memory or calibration file error: contact JETI service"
        }
        280 => "booted on battery power",
        _ => "unlisted error",
    }
}

/// Codes ArgyllCMS sends NAK-first for: overexposed.
pub const ERROR_OVEREXPOSED: u32 = 120;
/// Underexposed.
pub const ERROR_UNDEREXPOSED: u32 = 121;
/// Unknown command.
pub const ERROR_UNKNOWN_COMMAND: u32 = 4;
/// An argument out of range.
pub const ERROR_ARGUMENT: u32 = 10;
/// Nothing measured yet to fetch.
pub const ERROR_NO_MEASUREMENT: u32 = 132;
/// The range exceeds the calibration.
pub const ERROR_RANGE_NOT_CALIBRATED: u32 = 141;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_command_is_what_follows_the_last_star_so_other_instruments_probes_are_skipped() {
        assert_eq!(parse_request(b";D024\r\n*idn?"), Some(Request::Identify));
        assert_eq!(
            parse_request(b"\x7e\x00\x02\x00*idn?"),
            Some(Request::Identify)
        );
        assert_eq!(parse_request(b"D024"), None);
        assert_eq!(parse_request(b";"), None);
        assert_eq!(
            parse_request(b"*conf:wran 380 780 1"),
            Some(Request::Range {
                start_nm: 380,
                end_nm: 780,
                step_nm: 1
            })
        );
        assert_eq!(parse_request(b"*conf:aver 4"), Some(Request::Average(4)));
        assert!(matches!(
            parse_request(b"*conf:maxtin 3000"),
            Some(Request::Setting(_))
        ));
        assert!(matches!(
            parse_request(b"*conf:maxtin lots"),
            Some(Request::Unknown(_))
        ));
        assert!(matches!(
            parse_request(b"*meas:flic"),
            Some(Request::Unknown(_))
        ));
    }

    #[test]
    fn identities_name_the_model_and_a_spectraval_is_not_taken_for_a_specbos() {
        assert_eq!(parse_identity(&identity(1211)), Some(1211));
        assert_eq!(parse_identity(&identity(1201)), Some(1201));
        assert_eq!(parse_identity("JETI_SB1211\r"), Some(1211));
        assert_eq!(parse_identity("JETI_SDCM3 1234567"), None);
        assert_eq!(parse_identity("K-10"), None);
    }

    #[test]
    fn xyz_and_spectra_survive_their_encoding() {
        let xyz = Xyz::new(95.047, 100.0, 108.883);
        assert_eq!(parse_xyz(&encode_xyz(xyz)), Some(xyz));
        let values: Vec<f64> = (0..401).map(|i| 1.0e-3 * (i as f64).sin().abs()).collect();
        let text = encode_spectrum(380, 780, &values);
        assert!(text.ends_with("\r\r") && text.len() <= MAX_ANSWER_BYTES);
        let back = parse_spectrum(&text, 401).expect("parses");
        for (a, b) in values.iter().zip(&back) {
            assert!((a - b).abs() <= 1e-6 * a.abs() + 1e-300);
        }
        assert!(parse_spectrum(&text, 400).is_err());
        assert!(parse_spectrum(&text, 402).is_err());
        let broken = text.replacen("e-", "x-", 1);
        assert!(parse_spectrum(&broken, 401).is_err());
    }

    #[test]
    fn labelled_numbers_parse_with_or_without_their_label() {
        assert_eq!(
            parse_labelled_number("Predefined start wave: 380\r", "Predefined start wave:"),
            Some(380.0)
        );
        assert_eq!(
            parse_labelled_number("1234", "spectrometer number:"),
            Some(1234.0)
        );
        assert_eq!(parse_labelled_number("mhead: x", "mhead:"), None);
    }
}
