//! Meter matrices as ArgyllCMS `.ccmx` files (CGATS text: a 3×3 colour correction
//! matrix of one colorimeter for one display type, corrected XYZ = M · meter XYZ, rows
//! of M as the data sets), so ArgyllCMS (`spotread -X`, `dispcal -X`, DisplayCAL)
//! applies the corrections lumiwall measures, and lumiwall reads those others make.
//! Layout after ArgyllCMS's `ccmx.c` writer and its `ccxxmake` output.

use super::meter_matrix::MeterMatrix;

/// Why a `.ccmx` text cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("not a usable CCMX file: {0}")]
pub struct CcmxError(String);

/// What a `.ccmx` names besides the matrix.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CcmxInfo {
    /// The instrument corrected (`INSTRUMENT`).
    pub instrument: String,
    /// The display type (`DISPLAY`).
    pub display: String,
    /// The reference instrument (`REFERENCE`).
    pub reference: String,
}

/// The `.ccmx` text of `m`, made on `info.display` with `info.instrument` against
/// `info.reference`, dated `created` (e.g. "Wed Dec  2 23:00:00 2026").
pub fn to_ccmx(m: &MeterMatrix, info: &CcmxInfo, created: &str) -> String {
    let q = |s: &str| s.replace('"', "'");
    let mut out = String::from("CCMX   \n\n");
    out += &format!(
        "DESCRIPTOR \"{} & {}\"\n",
        q(&info.instrument),
        q(&info.display)
    );
    out += "ORIGINATOR \"lumiwall meter-matrix\"\n";
    out += &format!("CREATED \"{}\"\n", q(created));
    out += "KEYWORD \"INSTRUMENT\"\n";
    out += &format!("INSTRUMENT \"{}\"\n", q(&info.instrument));
    out += "KEYWORD \"DISPLAY\"\n";
    out += &format!("DISPLAY \"{}\"\n", q(&info.display));
    // the matrix corrects the instrument's factory calibration: the K-10's base
    // display type 1 (ArgyllCMS refuses a K-10 matrix for any other base)
    out += "KEYWORD \"DISPLAY_TYPE_BASE_ID\"\nDISPLAY_TYPE_BASE_ID \"1\"\n";
    out += "KEYWORD \"DISPLAY_TYPE_REFRESH\"\nDISPLAY_TYPE_REFRESH \"NO\"\n";
    out += "KEYWORD \"REFERENCE\"\n";
    out += &format!("REFERENCE \"{}\"\n", q(&info.reference));
    out += "KEYWORD \"FIT_METHOD\"\n";
    out += &format!(
        "FIT_METHOD \"lumiwall: black, red, green, blue, white; residual {:.4} %\"\n",
        100.0 * m.fit_residual
    );
    out += "KEYWORD \"COLOR_REP\"\nCOLOR_REP \"XYZ\"\n\n";
    out += "NUMBER_OF_FIELDS 3\nBEGIN_DATA_FORMAT\nXYZ_X XYZ_Y XYZ_Z\nEND_DATA_FORMAT\n\n";
    out += "NUMBER_OF_SETS 3\nBEGIN_DATA\n";
    for row in &m.matrix {
        out += &format!("{:.9} {:.9} {:.9}\n", row[0], row[1], row[2]);
    }
    out += "END_DATA\n";
    out
}

/// The matrix (row-major, corrected = M · meter) and names of a `.ccmx` text.
pub fn parse_ccmx(text: &str) -> Result<([[f64; 3]; 3], CcmxInfo), CcmxError> {
    let err = |m: &str| CcmxError(m.to_string());
    if !text.trim_start().starts_with("CCMX") {
        return Err(err("it does not start with CCMX"));
    }
    let keyword = |k: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(k).filter(|r| r.starts_with([' ', '\t'])))
            .map(|r| r.trim().trim_matches('"').to_string())
            .unwrap_or_default()
    };
    let data = text
        .split("BEGIN_DATA\n")
        .nth(1)
        .and_then(|d| d.split("END_DATA").next())
        .ok_or_else(|| err("no BEGIN_DATA … END_DATA block"))?;
    let values: Vec<f64> = data
        .split_whitespace()
        .map(|w| {
            w.parse::<f64>()
                .map_err(|_| err(&format!("`{w}` is not a number")))
        })
        .collect::<Result<_, _>>()?;
    if values.len() != 9 || !values.iter().all(|v| v.is_finite()) {
        return Err(err(&format!(
            "{} values in the data block; a CCMX holds 3 × 3 finite numbers",
            values.len()
        )));
    }
    let m = std::array::from_fn(|r| std::array::from_fn(|c| values[3 * r + c]));
    Ok((
        m,
        CcmxInfo {
            instrument: keyword("INSTRUMENT"),
            display: keyword("DISPLAY"),
            reference: keyword("REFERENCE"),
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumiwall_core::Eye;

    #[test]
    fn a_ccmx_written_reads_back_to_the_same_matrix_and_names() {
        let m = MeterMatrix {
            eye: Eye::Left,
            display: None,
            matrix: [
                [1.02, -0.013, 0.004],
                [0.011, 0.987, -0.002],
                [-0.0005, 0.006, 1.1],
            ],
            fit_residual: 0.0012,
        };
        let info = CcmxInfo {
            instrument: "Klein K-10-A EMU000001".into(),
            display: "wall left eye".into(),
            reference: "CS-2000 sim".into(),
        };
        let text = to_ccmx(&m, &info, "Wed Dec  2 23:00:00 2026");
        let (back, names) = parse_ccmx(&text).unwrap();
        assert_eq!(names, info);
        let flat = |a: [[f64; 3]; 3]| a.into_iter().flatten().collect::<Vec<_>>();
        for (b, want) in flat(back).into_iter().zip(flat(m.matrix)) {
            assert!((b - want).abs() < 1e-9);
        }
    }

    #[test]
    fn a_broken_ccmx_is_refused_with_the_reason() {
        assert!(parse_ccmx("CTI3\n").unwrap_err().0.contains("CCMX"));
        let short = "CCMX\nBEGIN_DATA\n1 0 0\n0 1 0\nEND_DATA\n";
        assert!(parse_ccmx(short).unwrap_err().0.contains("6 values"));
        let nan = "CCMX\nBEGIN_DATA\n1 0 0\n0 x 0\n0 0 1\nEND_DATA\n";
        assert!(parse_ccmx(nan).unwrap_err().0.contains("`x`"));
    }
}
