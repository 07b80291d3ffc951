//! A display's commissioning readings as an ArgyllCMS `.ti3` (CGATS `CTI3`,
//! `COLOR_REP RGB_XYZ`, the layout `dispread` writes): one row per sample of the
//! measurement log, in the order read (black, primaries, white, every ramp step, the
//! channel samples and greys of the grey-drive pass), each its drive and the average
//! of its readings as the meter gave them (through the display-type correction matrix
//! where one was given, as `dispread -X` writes them). RGB in percent, XYZ normalised
//! to the white's Y = 100 with the white's absolute XYZ in `LUMINANCE_XYZ_CDM2`.
//!
//! What the solve derives from the readings is not written as if it had been read: a
//! ramp sample put on its channel's line, a primary pooled over its ramp
//! (`measure::channel_colour`), the channel samples split from a grey read whole
//! (`measure::split_grey`). Each grey read whole is written as the grey it was, at its
//! three drives. A black the meter refused is written as the measurement's black, so
//! that the shaper has its anchor at RGB 0. After a nightly refit (`recalibrate`) the log
//! is still the commissioning's, and so is the export ([`refitted_since_read`]).

use crate::measure::MeasuredDisplay;
use lumiwall_devices::Xyz;

/// Why a measurement cannot be exported.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{display}: {message}")]
pub struct Ti3Error {
    /// The display.
    pub display: String,
    /// What is missing.
    pub message: String,
}

/// The `.ti3` text of the readings logged in `measured`, dated `created`. Needs a
/// white reading (every commissioning takes one) to normalise to.
pub fn to_ti3(measured: &MeasuredDisplay, created: &str) -> Result<String, Ti3Error> {
    let m = &measured.measurement;
    let refuse = |message: String| Ti3Error {
        display: m.key.file_stem(),
        message,
    };
    let white = white_reading(measured)
        .ok_or_else(|| refuse("no white reading to normalise the .ti3 to".into()))?;
    if !(white.y.is_finite() && white.y > 0.0) {
        return Err(refuse(format!(
            "white luminance {} cd/m² cannot be normalised to",
            white.y
        )));
    }
    let rows = rows(measured);
    if rows.len() < 2 {
        return Err(refuse(
            "no readings in the measurement log (a measurement written before the log was \
             kept?)"
                .into(),
        ));
    }
    if let Some((rgb, xyz)) = rows.iter().find(|(_, xyz)| !xyz.is_finite()) {
        return Err(refuse(format!(
            "the reading at drive {rgb:?} is not a number ({xyz:?})"
        )));
    }
    Ok(header(&m.instrument, white, created, rows.len()) + &data(&rows, 100.0 / white.y))
}

/// The white the rows are normalised to: the log's last white reading, else the
/// measurement's.
fn white_reading(measured: &MeasuredDisplay) -> Option<Xyz> {
    measured
        .log
        .last_read(crate::measure::Patch::White)
        .and_then(|r| r.xyz)
        .or(measured.measurement.white)
}

/// The CGATS header up to `BEGIN_DATA`.
fn header(instrument: &str, white: Xyz, created: &str, sets: usize) -> String {
    let q = |s: &str| s.replace('"', "'");
    let mut out = String::from("CTI3   \n\n");
    out += "DESCRIPTOR \"Argyll Calibration Target chart information 3\"\n";
    out += "ORIGINATOR \"lumiwall export\"\n";
    out += &format!("CREATED \"{}\"\n", q(created));
    out += "KEYWORD \"DEVICE_CLASS\"\nDEVICE_CLASS \"DISPLAY\"\n";
    out += "KEYWORD \"COLOR_REP\"\nCOLOR_REP \"RGB_XYZ\"\n";
    out += &format!(
        "KEYWORD \"TARGET_INSTRUMENT\"\nTARGET_INSTRUMENT \"{}\"\n",
        q(instrument)
    );
    out += "KEYWORD \"INSTRUMENT_TYPE_SPECTRAL\"\nINSTRUMENT_TYPE_SPECTRAL \"NO\"\n";
    out += &format!(
        "KEYWORD \"LUMINANCE_XYZ_CDM2\"\nLUMINANCE_XYZ_CDM2 \"{:.6} {:.6} {:.6}\"\n",
        white.x, white.y, white.z
    );
    out += "KEYWORD \"NORMALIZED_TO_Y_100\"\nNORMALIZED_TO_Y_100 \"YES\"\n\n";
    out += "NUMBER_OF_FIELDS 7\nBEGIN_DATA_FORMAT\n";
    out += "SAMPLE_ID RGB_R RGB_G RGB_B XYZ_X XYZ_Y XYZ_Z\nEND_DATA_FORMAT\n\n";
    out += &format!("NUMBER_OF_SETS {sets}\nBEGIN_DATA\n");
    out
}

/// The data rows (RGB in percent, XYZ times `scale`) and `END_DATA`.
fn data(rows: &[([f64; 3], Xyz)], scale: f64) -> String {
    let mut out = String::new();
    for (i, (rgb, xyz)) in rows.iter().enumerate() {
        out += &format!(
            "{} {:.4} {:.4} {:.4} {:.6} {:.6} {:.6}\n",
            i + 1,
            100.0 * rgb[0],
            100.0 * rgb[1],
            100.0 * rgb[2],
            scale * xyz.x,
            scale * xyz.y,
            scale * xyz.z
        );
    }
    out += "END_DATA\n";
    out
}

/// (drive 0..1, XYZ) of every logged sample that gave a reading, in the order read;
/// first the measurement's black where the log has no black reading.
fn rows(measured: &MeasuredDisplay) -> Vec<([f64; 3], Xyz)> {
    let logged = measured
        .log
        .samples
        .iter()
        .filter_map(|r| r.xyz.map(|xyz| (r.patch.drive(), xyz)));
    let black_read = measured
        .log
        .last_read(crate::measure::Patch::Black)
        .is_some();
    let black = (!black_read).then_some(([0.0; 3], measured.measurement.black));
    black.into_iter().chain(logged).collect()
}

/// True when the measurement was refitted since its readings were taken (a nightly
/// `recalibrate` moved it onto that night's readings, or onto a white check): the
/// `.ti3` then holds the commissioning's readings, not what the profiles stand on now.
pub fn refitted_since_read(measured: &MeasuredDisplay) -> bool {
    measured.anchor.is_some() || measured.measurement.readings != measured.log.readings
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::{MeasureLog, Patch, ReadingRecord};
    use crate::solve::DisplayMeasurement;
    use lumiwall_core::Channel;

    fn xyz(y: f64) -> Xyz {
        Xyz::new(0.95 * y, y, 1.09 * y)
    }

    fn record(patch: Patch, xyz: Option<Xyz>, repeats: u32) -> ReadingRecord {
        ReadingRecord {
            patch,
            xyz,
            repeats,
            low_light: false,
        }
    }

    /// A display whose log holds black, the primaries, white, one ramp step per channel
    /// (the blue one refused by the meter) and a grey read whole; its measurement holds
    /// what the solve derived: pooled primaries, ramps on their lines, a split sample.
    fn measured(white: Option<Xyz>) -> MeasuredDisplay {
        let mut samples = vec![
            record(Patch::Black, Some(xyz(0.1)), 4),
            record(Patch::Primary(Channel::Red), Some(xyz(30.0)), 1),
            record(Patch::Primary(Channel::Green), Some(xyz(60.0)), 1),
            record(Patch::Primary(Channel::Blue), Some(xyz(10.0)), 1),
            record(Patch::Ramp(Channel::Red, 0.5), Some(xyz(7.0)), 1),
            record(Patch::Ramp(Channel::Green, 0.5), Some(xyz(14.0)), 1),
            record(Patch::Ramp(Channel::Blue, 0.02), None, 0),
            record(Patch::Grey([0.1, 0.12, 0.08]), Some(xyz(0.9)), 2),
        ];
        if let Some(w) = white {
            samples.insert(4, record(Patch::White, Some(w), 3));
        }
        let measurement = DisplayMeasurement {
            key: lumiwall_core::DisplayKey {
                wall: "w".into(),
                display: 0,
                tile_col: 0,
                tile_row: 0,
                eye: lumiwall_core::Eye::Mono,
            },
            bit_depth: 8,
            black: xyz(0.1),
            primaries: [xyz(30.3), xyz(59.7), xyz(10.1)],
            white,
            ramps: [
                vec![(0.5, xyz(7.05)), (0.1, xyz(0.21))],
                vec![(0.5, xyz(13.9))],
                vec![(0.08, xyz(0.11))],
            ],
            readings: 14,
            instrument: "virtual".into(),
            composites: Vec::new(),
            ramp_sigma_rel: Default::default(),
        };
        MeasuredDisplay {
            measurement,
            log: MeasureLog {
                samples,
                readings: 14,
                ..MeasureLog::default()
            },
            anchor: None,
            ageing: None,
        }
    }

    fn data_rows(text: &str) -> Vec<&str> {
        text.split("BEGIN_DATA\n")
            .nth(1)
            .unwrap()
            .lines()
            .take_while(|l| *l != "END_DATA")
            .collect()
    }

    #[test]
    fn a_ti3_holds_each_logged_reading_as_read_in_order_normalised_to_the_white() {
        let text = to_ti3(&measured(Some(Xyz::new(95.0, 100.0, 109.0))), "now").unwrap();
        assert!(text.starts_with("CTI3"));
        assert!(text.contains("LUMINANCE_XYZ_CDM2 \"95.000000 100.000000 109.000000\""));
        assert!(text.contains("NUMBER_OF_SETS 8\n"));
        let data = data_rows(&text);
        // black, three primaries, white, two ramp steps, the grey; not the refused
        // blue step
        assert_eq!(data.len(), 8);
        assert_eq!(data[0], "1 0.0000 0.0000 0.0000 0.095000 0.100000 0.109000");
        // the red primary as read (30 cd/m²), not as pooled (30.3)
        assert_eq!(
            data[1],
            "2 100.0000 0.0000 0.0000 28.500000 30.000000 32.700000"
        );
        assert_eq!(
            data[4],
            "5 100.0000 100.0000 100.0000 95.000000 100.000000 109.000000"
        );
        // the red ramp step as read (7 cd/m²), not on its line (7.05)
        assert_eq!(
            data[5],
            "6 50.0000 0.0000 0.0000 6.650000 7.000000 7.630000"
        );
        // the grey read whole, at its three drives; no channel sample split from it
        assert_eq!(
            data[7],
            "8 10.0000 12.0000 8.0000 0.855000 0.900000 0.981000"
        );
    }

    #[test]
    fn a_black_the_meter_refused_is_written_as_the_measurements_and_an_empty_log_is_refused() {
        let mut m = measured(Some(Xyz::new(95.0, 100.0, 109.0)));
        m.log.samples[0].xyz = None;
        m.measurement.black = xyz(0.2);
        let text = to_ti3(&m, "now").unwrap();
        let data = data_rows(&text);
        assert_eq!(data.len(), 8);
        assert_eq!(data[0], "1 0.0000 0.0000 0.0000 0.190000 0.200000 0.218000");
        m.log.samples.clear();
        m.measurement.white = Some(Xyz::new(95.0, 100.0, 109.0));
        let e = to_ti3(&m, "now").unwrap_err();
        assert!(e.message.contains("no readings"), "{e}");
    }

    #[test]
    fn a_measurement_refitted_by_a_nightly_run_is_told_from_one_as_read() {
        let mut m = measured(Some(Xyz::new(95.0, 100.0, 109.0)));
        assert!(!refitted_since_read(&m));
        m.measurement.readings = 1;
        assert!(refitted_since_read(&m));
    }

    #[test]
    fn a_measurement_without_white_is_refused() {
        let e = to_ti3(&measured(None), "now").unwrap_err();
        assert!(e.message.contains("no white"), "{e}");
    }
}
