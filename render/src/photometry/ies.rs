//! IES LM-63 reader (1986, LM-63-1991, -1995 and -2002 layouts).
//!
//! Supported: keyword lines (read, `[LUMINAIRE]` kept as the name), `TILT=NONE` and
//! `TILT=INCLUDE` (the tilt table is validated and its factor at 0° tilt applied, i.e.
//! the luminaire is assumed mounted as measured), photometric type C with every
//! horizontal symmetry LM-63 defines (one angle = rotational; 0–90° quadrant; 0–180°
//! bilateral about C0–C180; 90–270° bilateral about C90–C270; 0–360° full), vertical
//! ranges 0–90°, 90–180° and 0–180° (intensity 0 outside the measured range).
//! Values may be separated by blanks or commas and wrap across lines.
//!
//! Candela values are multiplied by the candela multiplier, the ballast factor and the
//! ballast-lamp photometric factor. Photometric types A and B (floodlights, automotive)
//! and `TILT=<file name>` are rejected with [`PhotometryError::Unsupported`].

use super::distribution::{
    CSymmetry, GonioTable, IntensityDistribution, IntensitySource, scaled_intensity_rows,
};
use super::error::PhotometryError;
use crate::scene::limits::MAX_FLUX_LM;

const FORMAT: &str = "IES LM-63";

/// Most vertical angles a file may declare: 0.1° steps over 0°…180°.
pub(crate) const MAX_VERTICAL_ANGLES: usize = 1801;

/// Most horizontal angles a file may declare: 0.1° steps over 0°…360°.
pub(crate) const MAX_HORIZONTAL_ANGLES: usize = 3601;

struct Tokens<'a> {
    items: Vec<(&'a str, usize)>,
    pos: usize,
    last_line: usize,
}

impl<'a> Tokens<'a> {
    fn next_f64(&mut self, what: &str) -> Result<(f64, usize), PhotometryError> {
        let Some(&(tok, line)) = self.items.get(self.pos) else {
            return Err(PhotometryError::Truncated {
                format: FORMAT,
                line: self.last_line,
                expected: what.to_string(),
            });
        };
        self.pos += 1;
        let v: f64 = tok.parse().map_err(|_| PhotometryError::Parse {
            format: FORMAT,
            line,
            message: format!("expected a number for {what}, found {tok:?}"),
        })?;
        if !v.is_finite() {
            return Err(PhotometryError::Parse {
                format: FORMAT,
                line,
                message: format!("{what} is not finite ({tok})"),
            });
        }
        Ok((v, line))
    }

    fn next_count(&mut self, what: &str, max: usize) -> Result<(usize, usize), PhotometryError> {
        let (v, line) = self.next_f64(what)?;
        if v.fract() != 0.0 || v < 1.0 || v > max as f64 {
            return Err(PhotometryError::Parse {
                format: FORMAT,
                line,
                message: format!("{what} must be a whole number between 1 and {max}, found {v}"),
            });
        }
        Ok((v as usize, line))
    }

    fn take(&mut self, n: usize, what: &str) -> Result<(Vec<f64>, usize), PhotometryError> {
        let left = self.items.len().saturating_sub(self.pos);
        if n > left {
            // refuse before allocating for values the file does not have
            return Err(PhotometryError::Truncated {
                format: FORMAT,
                line: self.last_line,
                expected: format!("{n} values of {what}, but only {left} values are left"),
            });
        }
        let mut out = Vec::with_capacity(n);
        let mut first_line = self.last_line;
        for i in 0..n {
            let (v, line) = self.next_f64(what).map_err(|e| match e {
                PhotometryError::Parse {
                    format,
                    line,
                    message,
                } => PhotometryError::Parse {
                    format,
                    line,
                    message: format!("{message} (#{} of {n})", i + 1),
                },
                other => other,
            })?;
            if i == 0 {
                first_line = line;
            }
            out.push(v);
        }
        Ok((out, first_line))
    }
}

/// Parses LM-63 text into an [`IntensityDistribution`].
pub(crate) fn parse(text: &str) -> Result<IntensityDistribution, PhotometryError> {
    let lines: Vec<&str> = text.lines().collect();
    let mut name = String::from("IES luminaire");
    let mut tilt_line = None;
    for (i, raw) in lines.iter().enumerate() {
        let l = raw.trim().trim_start_matches('\u{feff}');
        // `get`: a multi-byte character within the first five bytes is no TILT line
        if let Some(value) = l
            .get(..5)
            .filter(|p| p.eq_ignore_ascii_case("TILT="))
            .and(l.get(5..))
        {
            tilt_line = Some((i, value.trim().to_string()));
            break;
        }
        if let Some(rest) = l.strip_prefix("[LUMINAIRE]") {
            name = rest.trim().to_string();
        }
    }
    let Some((tilt_idx, tilt_value)) = tilt_line else {
        return Err(PhotometryError::Truncated {
            format: FORMAT,
            line: lines.len(),
            expected: "a TILT= line before the photometric data".into(),
        });
    };
    let items: Vec<(&str, usize)> = lines
        .iter()
        .enumerate()
        .skip(tilt_idx + 1)
        .flat_map(|(i, l)| {
            l.split(|c: char| c.is_whitespace() || c == ',')
                .filter(|t| !t.is_empty())
                .map(move |t| (t, i + 1))
        })
        .collect();
    let mut tok = Tokens {
        items,
        pos: 0,
        last_line: lines.len(),
    };

    let mut tilt_factor = 1.0;
    if tilt_value.eq_ignore_ascii_case("INCLUDE") {
        let (geometry, gl) = tok.next_f64("lamp-to-luminaire geometry")?;
        if !(1.0..=3.0).contains(&geometry) {
            return Err(PhotometryError::Parse {
                format: FORMAT,
                line: gl,
                message: format!("lamp-to-luminaire geometry must be 1, 2 or 3, found {geometry}"),
            });
        }
        let (n, _) = tok.next_count("number of tilt angles", 1000)?;
        let (angles, al) = tok.take(n, "tilt angle")?;
        let (factors, _) = tok.take(n, "tilt multiplying factor")?;
        if angles.windows(2).any(|w| w[1] <= w[0]) {
            return Err(PhotometryError::Parse {
                format: FORMAT,
                line: al,
                message: "tilt angles must be strictly increasing".into(),
            });
        }
        tilt_factor = interp1(&angles, &factors, 0.0);
    } else if !tilt_value.eq_ignore_ascii_case("NONE") {
        return Err(PhotometryError::Unsupported {
            format: FORMAT,
            line: tilt_idx + 1,
            message: format!(
                "TILT={tilt_value} refers to a separate tilt file; copy its data into the file as TILT=INCLUDE or use TILT=NONE"
            ),
        });
    }

    let (n_lamps, _) = tok.next_f64("number of lamps")?;
    let (lumens_per_lamp, _) = tok.next_f64("lumens per lamp")?;
    let (multiplier, ml) = tok.next_f64("candela multiplier")?;
    if multiplier <= 0.0 {
        return Err(PhotometryError::Parse {
            format: FORMAT,
            line: ml,
            message: format!("candela multiplier must be > 0, found {multiplier}"),
        });
    }
    let (n_vert, _) = tok.next_count("number of vertical angles", MAX_VERTICAL_ANGLES)?;
    let (n_horiz, _) = tok.next_count("number of horizontal angles", MAX_HORIZONTAL_ANGLES)?;
    let (ptype, pl) = tok.next_f64("photometric type")?;
    let (_units, _) = tok.next_f64("units type")?;
    let _ = tok.take(3, "luminous opening dimension (width, length, height)")?;
    let (ballast, _) = tok.next_f64("ballast factor")?;
    let (ballast_lamp, _) = tok.next_f64("ballast-lamp photometric factor / future use")?;
    let _ = tok.next_f64("input watts")?;
    match ptype as i64 {
        1 if ptype.fract() == 0.0 => {}
        2 | 3 if ptype.fract() == 0.0 => {
            return Err(PhotometryError::Unsupported {
                format: FORMAT,
                line: pl,
                message: format!(
                    "photometric type {} ({}) — only type C (1, architectural luminaires) is read; convert the file to type C in the photometry software",
                    ptype,
                    if ptype == 2.0 {
                        "B, floodlights"
                    } else {
                        "A, automotive"
                    }
                ),
            });
        }
        _ => {
            return Err(PhotometryError::Parse {
                format: FORMAT,
                line: pl,
                message: format!("photometric type must be 1 (C), 2 (B) or 3 (A), found {ptype}"),
            });
        }
    }
    let (vert, vl) = tok.take(n_vert, "vertical angle")?;
    let (horiz, hl) = tok.take(n_horiz, "horizontal angle")?;
    let (cd, cl) = tok.take(n_vert * n_horiz, "candela value")?;
    if let Some(&(extra, line)) = tok.items.get(tok.pos) {
        tracing::warn!("IES file: ignoring extra data {extra:?} from line {line} on");
    }
    if vert.windows(2).any(|w| w[1] <= w[0]) || vert[0] < 0.0 || vert[n_vert - 1] > 180.0 {
        return Err(PhotometryError::Parse {
            format: FORMAT,
            line: vl,
            message: "vertical angles must increase strictly within 0°…180°".into(),
        });
    }
    if horiz.windows(2).any(|w| w[1] <= w[0]) || horiz[0] < 0.0 || horiz[n_horiz - 1] > 360.0 {
        return Err(PhotometryError::Parse {
            format: FORMAT,
            line: hl,
            message: "horizontal angles must increase strictly within 0°…360°".into(),
        });
    }
    if cd.iter().any(|v| *v < 0.0) {
        return Err(PhotometryError::Parse {
            format: FORMAT,
            line: cl,
            message: "candela values must be ≥ 0".into(),
        });
    }
    let first = horiz[0];
    let last = horiz[n_horiz - 1];
    let symmetry = if n_horiz == 1 {
        CSymmetry::Rotational
    } else if first == 0.0 && last == 90.0 {
        CSymmetry::Quadrant
    } else if first == 0.0 && last == 180.0 {
        CSymmetry::PlaneC0C180
    } else if first == 90.0 && last == 270.0 {
        CSymmetry::PlaneC90C270
    } else if first == 0.0 && last > 180.0 {
        CSymmetry::None
    } else {
        return Err(PhotometryError::Parse {
            format: FORMAT,
            line: hl,
            message: format!(
                "horizontal angles {first}°…{last}° match no LM-63 type C symmetry (0, 0–90, 0–180, 90–270, 0–360)"
            ),
        });
    };
    let factor =
        multiplier * positive_or_one(ballast) * positive_or_one(ballast_lamp) * tilt_factor;
    let rows = scaled_intensity_rows(
        &cd,
        factor,
        n_vert,
        &IntensitySource {
            format: FORMAT,
            line: cl,
            scaling: "a candela value × multiplier, ballast and tilt factors",
            hint: "check the candela multiplier",
        },
    )?;
    let table =
        GonioTable::unfold(&horiz, &vert, &rows, symmetry).map_err(|e| PhotometryError::Parse {
            format: FORMAT,
            line: hl,
            message: e.to_string(),
        })?;
    let declared = (lumens_per_lamp > 0.0 && n_lamps > 0.0).then_some(lumens_per_lamp * n_lamps);
    if let Some(f) = declared.filter(|f| !(f.is_finite() && *f <= MAX_FLUX_LM)) {
        return Err(PhotometryError::Parse {
            format: FORMAT,
            line: tilt_idx + 2,
            message: format!(
                "number of lamps × lumens per lamp = {f:e} lm is above the {MAX_FLUX_LM:e} lm the renderer accepts"
            ),
        });
    }
    Ok(IntensityDistribution::from_table(
        table, name, declared, declared,
    ))
}

fn positive_or_one(v: f64) -> f64 {
    if v > 0.0 { v } else { 1.0 }
}

fn interp1(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    if xs.is_empty() {
        return 1.0;
    }
    if x <= xs[0] {
        return ys[0];
    }
    if x >= xs[xs.len() - 1] {
        return ys[ys.len() - 1];
    }
    let k = xs.partition_point(|v| *v <= x);
    let t = (x - xs[k - 1]) / (xs[k] - xs[k - 1]);
    ys[k - 1] * (1.0 - t) + ys[k] * t
}
