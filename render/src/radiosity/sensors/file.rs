//! Sensor files: CSV in (`name,x_m,y_m,z_m,nx,ny,nz`), CSV out (`name,illuminance_lx,…`).

use std::path::{Path, PathBuf};

use crate::scene::V3;
use crate::scene::limits::MAX_COORDINATE_M;

use super::{Sensor, SensorReading};
use crate::radiosity::RadiosityError;

/// Most sensors one file may hold.
pub const MAX_SENSORS: usize = 1_000_000;

/// Largest sensor file read, in bytes (checked before reading).
const MAX_FILE_BYTES: u64 = 256 << 20;

/// The header a sensor file must start with.
const COLUMNS: [&str; 7] = ["name", "x_m", "y_m", "z_m", "nx", "ny", "nz"];

/// Why a sensor file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum SensorError {
    /// The file cannot be read.
    #[error("cannot read sensor file {path}: {message}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
    /// A line of the file is wrong.
    #[error("{path}, line {line}: {message}")]
    Line {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u64,
        /// What is wrong and what is expected.
        message: String,
    },
    /// The file has no sensors.
    #[error("{path}: no sensors (after the header `{header}`)")]
    Empty {
        /// The file.
        path: PathBuf,
        /// The expected header.
        header: String,
    },
}

/// Reads a sensor file: a header `name,x_m,y_m,z_m,nx,ny,nz`, then one sensor per
/// line; blank lines and lines starting with `#` are skipped, fields may be padded
/// with spaces. Names must be unique and non-empty; coordinates finite and within
/// ±[`MAX_COORDINATE_M`]; the normal finite and non-zero (it is normalised). At most
/// [`MAX_SENSORS`] sensors.
pub fn read_sensors_csv(path: &Path) -> Result<Vec<Sensor>, SensorError> {
    let read_err = |e: &dyn std::fmt::Display| SensorError::Read {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let len = std::fs::metadata(path).map_err(|e| read_err(&e))?.len();
    if len > MAX_FILE_BYTES {
        return Err(read_err(&format!(
            "{len} bytes; at most {MAX_FILE_BYTES} are read"
        )));
    }
    let text = std::fs::read(path).map_err(|e| read_err(&e))?;
    parse_sensors(path, &text)
}

fn parse_sensors(path: &Path, bytes: &[u8]) -> Result<Vec<Sensor>, SensorError> {
    let line_err = |line: u64, message: String| SensorError::Line {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .flexible(true)
        .from_reader(bytes);
    let header_line = rdr.position().line().max(1);
    let header = rdr
        .headers()
        .map_err(|e| line_err(csv_line(&e).unwrap_or(header_line), e.to_string()))?
        .clone();
    if header.iter().ne(COLUMNS) {
        return Err(line_err(
            header.position().map_or(1, |p| p.line()),
            format!(
                "the header is `{}`; expected `{}`",
                header.iter().collect::<Vec<_>>().join(","),
                COLUMNS.join(",")
            ),
        ));
    }
    let mut sensors = Vec::new();
    let mut names = std::collections::HashMap::new();
    for record in rdr.records() {
        let record = record.map_err(|e| line_err(csv_line(&e).unwrap_or(0), e.to_string()))?;
        let line = record.position().map_or(0, |p| p.line());
        if sensors.len() == MAX_SENSORS {
            return Err(line_err(
                line,
                format!("more than {MAX_SENSORS} sensors; split the file"),
            ));
        }
        let sensor = parse_record(&record).map_err(|m| line_err(line, m))?;
        if let Some(first) = names.insert(sensor.name.clone(), line) {
            return Err(line_err(
                line,
                format!("sensor name `{}` already used on line {first}", sensor.name),
            ));
        }
        sensors.push(sensor);
    }
    if sensors.is_empty() {
        return Err(SensorError::Empty {
            path: path.to_path_buf(),
            header: COLUMNS.join(","),
        });
    }
    Ok(sensors)
}

fn csv_line(e: &csv::Error) -> Option<u64> {
    e.position().map(|p| p.line())
}

/// One sensor from a record, or what is wrong with it.
fn parse_record(record: &csv::StringRecord) -> Result<Sensor, String> {
    if record.len() != COLUMNS.len() {
        return Err(format!(
            "{} fields; expected {} ({})",
            record.len(),
            COLUMNS.len(),
            COLUMNS.join(",")
        ));
    }
    let name = record[0].to_string();
    if name.is_empty() {
        return Err("the sensor name is empty".into());
    }
    let mut v = [0.0; 6];
    for (k, slot) in v.iter_mut().enumerate() {
        let field = &record[k + 1];
        let col = COLUMNS[k + 1];
        *slot = field
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("`{col}` = `{field}` is not a finite number"))?;
    }
    let position = V3::new(v[0], v[1], v[2]);
    if position.iter().any(|c| c.abs() > MAX_COORDINATE_M) {
        return Err(format!(
            "position {:?} m lies beyond ±{MAX_COORDINATE_M:e} m",
            [v[0], v[1], v[2]]
        ));
    }
    let normal = V3::new(v[3], v[4], v[5]);
    let len = normal.norm();
    if !(len.is_finite() && len > 1e-12) {
        return Err(format!(
            "normal {:?} has no direction; give the measuring plane's normal, e.g. 0,0,1 for a horizontal plane lit from above",
            [v[3], v[4], v[5]]
        ));
    }
    Ok(Sensor {
        name,
        position,
        normal: normal / len,
    })
}

/// Writes the readings as CSV (atomically): `name,illuminance_lx,direct_lx,
/// indirect_lx,indirect_estimated_error_lx,chromaticity_x,chromaticity_y`, where the
/// estimated error is the solution's relative error estimate `estimated_error` times the
/// indirect part (direct light is exact) and the chromaticity that of the total.
pub fn write_sensor_readings_csv(
    path: &Path,
    readings: &[SensorReading],
    estimated_error: f64,
) -> Result<(), RadiosityError> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let out_err = |e: &dyn std::fmt::Display| RadiosityError::Output {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    w.write_record([
        "name",
        "illuminance_lx",
        "direct_lx",
        "indirect_lx",
        "indirect_estimated_error_lx",
        "chromaticity_x",
        "chromaticity_y",
    ])
    .map_err(|e| out_err(&e))?;
    for r in readings {
        let t = r.total_xyz_lx();
        let sum = t[0] + t[1] + t[2];
        let (cx, cy) = if sum > 0.0 {
            (t[0] / sum, t[1] / sum)
        } else {
            (f64::NAN, f64::NAN)
        };
        let num = |v: f64| {
            if v.is_finite() {
                format!("{v:.6}")
            } else {
                String::new()
            }
        };
        w.write_record([
            r.name.clone(),
            num(t[1]),
            num(r.direct_xyz_lx[1]),
            num(r.indirect_xyz_lx[1]),
            num(estimated_error * r.indirect_xyz_lx[1]),
            num(cx),
            num(cy),
        ])
        .map_err(|e| out_err(&e))?;
    }
    let bytes = w.into_inner().map_err(|e| out_err(&e))?;
    lumiwall_core::files::write_atomic(path, &bytes).map_err(|e| out_err(&e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Vec<Sensor>, SensorError> {
        parse_sensors(Path::new("grid.csv"), text.as_bytes())
    }

    fn line_of(e: SensorError) -> (u64, String) {
        match e {
            SensorError::Line { line, message, .. } => (line, message),
            other => panic!("expected a line error, got {other}"),
        }
    }

    #[test]
    fn a_sensor_file_is_read_with_comments_padding_and_normalised_normals() {
        let s = parse(
            "name,x_m,y_m,z_m,nx,ny,nz\n# floor\n a1 , 1, 2, 0.85, 0, 0, 2\n\nb,0,0,1,1,0,0\n",
        )
        .unwrap();
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].name, "a1");
        assert_eq!(s[0].position, V3::new(1.0, 2.0, 0.85));
        assert_eq!(s[0].normal, V3::new(0.0, 0.0, 1.0));
    }

    #[test]
    fn bad_sensor_lines_are_errors_that_name_the_line() {
        let h = "name,x_m,y_m,z_m,nx,ny,nz\n";
        let cases = [
            (
                format!("{h}a,1,2,3,0,0,1\nb,1,x,3,0,0,1\n"),
                3,
                "`y_m` = `x`",
            ),
            (format!("{h}a,1,2,3,0,0,0\n"), 2, "no direction"),
            (
                format!("{h}a,1,2,3,0,0,1\na,1,2,3,0,0,1\n"),
                3,
                "already used on line 2",
            ),
            (format!("{h}a,1,2,3,0,0\n"), 2, "6 fields"),
            (format!("{h},1,2,3,0,0,1\n"), 2, "name is empty"),
            (format!("{h}a,1,2,inf,0,0,1\n"), 2, "`z_m` = `inf`"),
            (format!("{h}a,1,2,2e6,0,0,1\n"), 2, "beyond"),
            (
                "name,x,y,z,nx,ny,nz\na,1,2,3,0,0,1\n".to_string(),
                1,
                "the header is",
            ),
        ];
        for (text, line, what) in cases {
            let (l, m) = line_of(parse(&text).unwrap_err());
            assert_eq!(l, line, "{text:?}: {m}");
            assert!(m.contains(what), "{text:?}: {m}");
        }
    }

    #[test]
    fn a_sensor_file_without_sensors_is_an_error() {
        let e = parse("name,x_m,y_m,z_m,nx,ny,nz\n# nothing\n").unwrap_err();
        assert!(matches!(e, SensorError::Empty { .. }), "{e}");
    }
}
