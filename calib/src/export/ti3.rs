//! A display's commissioning measurements as an ArgyllCMS `.ti3` (CGATS `CTI3`,
//! `COLOR_REP RGB_XYZ`, the layout `dispread` writes): one row per reading (black,
//! every ramp step, the primaries, white), RGB in percent, XYZ normalised to the white's
//! Y = 100 with the white's absolute XYZ in `LUMINANCE_XYZ_CDM2`.

use crate::solve::DisplayMeasurement;

/// Why a measurement cannot be exported.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{display}: {message}")]
pub struct Ti3Error {
    /// The display.
    pub display: String,
    /// What is missing.
    pub message: String,
}

/// The `.ti3` text of `m`, dated `created`. Needs the white reading (every
/// commissioning takes it) to normalise to.
pub fn to_ti3(m: &DisplayMeasurement, created: &str) -> Result<String, Ti3Error> {
    let white = m.white.ok_or_else(|| Ti3Error {
        display: m.key.file_stem(),
        message: "no white reading to normalise the .ti3 to".into(),
    })?;
    if !(white.y.is_finite() && white.y > 0.0) {
        return Err(Ti3Error {
            display: m.key.file_stem(),
            message: format!("white luminance {} cd/m² cannot be normalised to", white.y),
        });
    }
    let rows = rows(m);
    let scale = 100.0 / white.y;
    let q = |s: &str| s.replace('"', "'");
    let mut out = String::from("CTI3   \n\n");
    out += "DESCRIPTOR \"Argyll Calibration Target chart information 3\"\n";
    out += "ORIGINATOR \"lumiwall export\"\n";
    out += &format!("CREATED \"{}\"\n", q(created));
    out += "KEYWORD \"DEVICE_CLASS\"\nDEVICE_CLASS \"DISPLAY\"\n";
    out += "KEYWORD \"COLOR_REP\"\nCOLOR_REP \"RGB_XYZ\"\n";
    out += &format!(
        "KEYWORD \"TARGET_INSTRUMENT\"\nTARGET_INSTRUMENT \"{}\"\n",
        q(&m.instrument)
    );
    out += "KEYWORD \"INSTRUMENT_TYPE_SPECTRAL\"\nINSTRUMENT_TYPE_SPECTRAL \"NO\"\n";
    out += &format!(
        "KEYWORD \"LUMINANCE_XYZ_CDM2\"\nLUMINANCE_XYZ_CDM2 \"{:.6} {:.6} {:.6}\"\n",
        white.x, white.y, white.z
    );
    out += "KEYWORD \"NORMALIZED_TO_Y_100\"\nNORMALIZED_TO_Y_100 \"YES\"\n\n";
    out += "NUMBER_OF_FIELDS 7\nBEGIN_DATA_FORMAT\n";
    out += "SAMPLE_ID RGB_R RGB_G RGB_B XYZ_X XYZ_Y XYZ_Z\nEND_DATA_FORMAT\n\n";
    out += &format!("NUMBER_OF_SETS {}\nBEGIN_DATA\n", rows.len());
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
    Ok(out)
}

/// (drive 0..1, XYZ) of every reading: black, the ramps (as the solve takes them:
/// each channel sample on its channel's line, with the channel samples split from the
/// greys read whole, `measure::split_grey`), primaries, white.
fn rows(m: &DisplayMeasurement) -> Vec<([f64; 3], lumiwall_devices::Xyz)> {
    let mut rows = vec![([0.0; 3], m.black)];
    for (c, ramp) in m.ramps.iter().enumerate() {
        for &(drive, xyz) in ramp {
            let mut rgb = [0.0; 3];
            rgb[c] = drive;
            rows.push((rgb, xyz));
        }
    }
    for (c, p) in m.primaries.iter().enumerate() {
        let mut rgb = [0.0; 3];
        rgb[c] = 1.0;
        rows.push((rgb, *p));
    }
    if let Some(w) = m.white {
        rows.push(([1.0; 3], w));
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumiwall_devices::Xyz;

    fn measurement(white: Option<Xyz>) -> DisplayMeasurement {
        let xyz = |y: f64| Xyz::new(0.95 * y, y, 1.09 * y);
        DisplayMeasurement {
            key: lumiwall_core::DisplayKey {
                wall: "w".into(),
                display: 0,
                tile_col: 0,
                tile_row: 0,
                eye: lumiwall_core::Eye::Mono,
            },
            bit_depth: 8,
            black: xyz(0.1),
            primaries: [xyz(30.0), xyz(60.0), xyz(10.0)],
            white,
            ramps: [
                vec![(0.5, xyz(7.0))],
                vec![(0.5, xyz(14.0))],
                vec![(0.5, xyz(2.5))],
            ],
            readings: 8,
            instrument: "virtual".into(),
            composites: Vec::new(),
            ramp_sigma_rel: Default::default(),
        }
    }

    #[test]
    fn a_ti3_holds_every_reading_normalised_to_the_white() {
        let text = to_ti3(&measurement(Some(Xyz::new(95.0, 100.0, 109.0))), "now").unwrap();
        assert!(text.starts_with("CTI3"));
        assert!(text.contains("LUMINANCE_XYZ_CDM2 \"95.000000 100.000000 109.000000\""));
        let data: Vec<&str> = text
            .split("BEGIN_DATA\n")
            .nth(1)
            .unwrap()
            .lines()
            .take_while(|l| *l != "END_DATA")
            .collect();
        // black, three ramp steps, three primaries, white
        assert_eq!(data.len(), 8);
        assert_eq!(data[0], "1 0.0000 0.0000 0.0000 0.095000 0.100000 0.109000");
        assert_eq!(
            data[7],
            "8 100.0000 100.0000 100.0000 95.000000 100.000000 109.000000"
        );
    }

    #[test]
    fn a_measurement_without_white_is_refused() {
        let e = to_ti3(&measurement(None), "now").unwrap_err();
        assert!(e.message.contains("no white"));
    }
}
