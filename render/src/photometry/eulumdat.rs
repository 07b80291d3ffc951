//! EULUMDAT (.ldt) reader, symmetry indicators 0–4.
//!
//! Layout (one value per line): lines 1–26 header, then per lamp set six lines
//! (number, type, total flux in lm, colour temperature, CRI, watts), ten direct-ratio
//! lines, Mc C angles, Ng γ angles, then the intensities in cd/1000 lm for the C planes
//! Mc1…Mc2 that the symmetry indicator selects (0: all; 1: one plane; 2: C0–C180;
//! 3: C270–C90 through C0; 4: C0–C90). Intensities become cd with the first lamp set's
//! flux (× the conversion factor of line 24 where it is > 0); the declared luminaire
//! flux is that lamp flux × LORL. Decimal commas are accepted.

use super::distribution::{
    CSymmetry, GonioTable, IntensityDistribution, IntensitySource, scaled_intensity_rows,
};
use super::error::PhotometryError;
use crate::scene::limits::MAX_FLUX_LM;

const FORMAT: &str = "EULUMDAT";

struct Lines<'a> {
    lines: Vec<&'a str>,
    pos: usize,
}

impl<'a> Lines<'a> {
    fn next_text(&mut self, what: &str) -> Result<(&'a str, usize), PhotometryError> {
        match self.lines.get(self.pos) {
            Some(l) => {
                self.pos += 1;
                Ok((l.trim(), self.pos))
            }
            None => Err(PhotometryError::Truncated {
                format: FORMAT,
                line: self.lines.len(),
                expected: what.to_string(),
            }),
        }
    }

    fn next_f64(&mut self, what: &str) -> Result<(f64, usize), PhotometryError> {
        let (t, line) = self.next_text(what)?;
        parse_num(t, line, what)
    }

    fn next_int(
        &mut self,
        what: &str,
        min: i64,
        max: i64,
    ) -> Result<(i64, usize), PhotometryError> {
        let (v, line) = self.next_f64(what)?;
        if v.fract() != 0.0 || v < min as f64 || v > max as f64 {
            return Err(PhotometryError::Parse {
                format: FORMAT,
                line,
                message: format!("{what} must be a whole number in {min}…{max}, found {v}"),
            });
        }
        Ok((v as i64, line))
    }
}

fn parse_num(t: &str, line: usize, what: &str) -> Result<(f64, usize), PhotometryError> {
    let cleaned = if t.contains(',') && !t.contains('.') {
        t.replace(',', ".")
    } else {
        t.to_string()
    };
    match cleaned.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok((v, line)),
        _ => Err(PhotometryError::Parse {
            format: FORMAT,
            line,
            message: format!("expected a number for {what}, found {t:?}"),
        }),
    }
}

/// Parses EULUMDAT text into an [`IntensityDistribution`].
pub(crate) fn parse(text: &str) -> Result<IntensityDistribution, PhotometryError> {
    let mut l = Lines {
        lines: text.lines().collect(),
        pos: 0,
    };
    let _company = l.next_text("company identification (line 1)")?;
    let _ityp = l.next_int("type indicator Ityp (line 2)", 0, 3)?;
    let (isym, sym_line) = l.next_int("symmetry indicator Isym (line 3)", 0, 4)?;
    let (mc, mc_line) = l.next_int("number of C planes Mc (line 4)", 1, 3600)?;
    let _dc = l.next_f64("distance between C planes Dc (line 5)")?;
    let (ng, _) = l.next_int("number of intensities per C plane Ng (line 6)", 1, 1801)?;
    let _dg = l.next_f64("distance between γ angles Dg (line 7)")?;
    let _report = l.next_text("measurement report number (line 8)")?;
    let (name, _) = l.next_text("luminaire name (line 9)")?;
    for what in [
        "luminaire number (line 10)",
        "file name (line 11)",
        "date/user (line 12)",
    ] {
        l.next_text(what)?;
    }
    for i in 13..=21 {
        l.next_f64(&format!("dimension (line {i})"))?;
    }
    let _dff = l.next_f64("downward flux fraction DFF (line 22)")?;
    let (lorl, _) = l.next_f64("light output ratio LORL (line 23)")?;
    let (conversion, _) = l.next_f64("conversion factor for intensities (line 24)")?;
    let _tilt = l.next_f64("tilt during measurement (line 25)")?;
    let (n_sets, _) = l.next_int("number of standard lamp sets (line 26)", 1, 20)?;
    let mut first_set_flux = None;
    for s in 0..n_sets {
        let set = s + 1;
        let (_n_lamps, _) = l.next_f64(&format!("number of lamps of set {set} (26a)"))?;
        l.next_text(&format!("lamp type of set {set} (26b)"))?;
        let (flux, fl) = l.next_f64(&format!("total lamp flux of set {set} (26c)"))?;
        l.next_text(&format!("colour temperature of set {set} (26d)"))?;
        l.next_text(&format!("colour rendering of set {set} (26e)"))?;
        l.next_f64(&format!("wattage of set {set} (26f)"))?;
        if s == 0 {
            if !(flux > 0.0 && flux <= MAX_FLUX_LM) {
                return Err(PhotometryError::Parse {
                    format: FORMAT,
                    line: fl,
                    message: format!(
                        "total lamp flux must be > 0 lm and at most {MAX_FLUX_LM:e} lm, found {flux}"
                    ),
                });
            }
            first_set_flux = Some(flux);
        }
    }
    let lamp_flux = first_set_flux.unwrap_or(1000.0);
    for k in 0..10 {
        l.next_f64(&format!("direct ratio #{} (line 27)", k + 1))?;
    }
    // From here on values are read as tokens: be lenient about line breaks.
    let rest: Vec<(&str, usize)> = l.lines[l.pos..]
        .iter()
        .enumerate()
        .flat_map(|(i, line)| {
            let ln = l.pos + i + 1;
            line.split_whitespace().map(move |t| (t, ln))
        })
        .collect();
    let mut it = rest.into_iter();
    let last_line = l.lines.len();
    let mut take = |n: usize, what: &str| -> Result<(Vec<f64>, usize), PhotometryError> {
        // never reserve more than the file has values for
        let mut out = Vec::with_capacity(n.min(it.len()));
        let mut first = last_line;
        for i in 0..n {
            let Some((t, line)) = it.next() else {
                return Err(PhotometryError::Truncated {
                    format: FORMAT,
                    line: last_line,
                    expected: format!("{what} #{} of {n}", i + 1),
                });
            };
            if i == 0 {
                first = line;
            }
            out.push(parse_num(t, line, what)?.0);
        }
        Ok((out, first))
    };
    let mc = mc as usize;
    let ng = ng as usize;
    let (c_all, c_line) = take(mc, "C angle (line 28)")?;
    let (gamma, g_line) = take(ng, "γ angle (line 29)")?;
    let need_div = match isym {
        2 => 2,
        3 | 4 => 4,
        _ => 1,
    };
    if !mc.is_multiple_of(need_div) {
        return Err(PhotometryError::Parse {
            format: FORMAT,
            line: mc_line,
            message: format!(
                "Mc = {mc} must be divisible by {need_div} for symmetry indicator {isym}"
            ),
        });
    }
    let (first_idx, count, symmetry) = match isym {
        0 => (0, mc, CSymmetry::None),
        1 => (0, 1, CSymmetry::Rotational),
        2 => (0, mc / 2 + 1, CSymmetry::PlaneC0C180),
        3 => (3 * mc / 4, mc / 2 + 1, CSymmetry::PlaneC90C270),
        _ => (0, mc / 4 + 1, CSymmetry::Quadrant),
    };
    let (values, v_line) = take(count * ng, "luminous intensity (line 30)")?;
    if values.iter().any(|v| *v < 0.0) {
        return Err(PhotometryError::Parse {
            format: FORMAT,
            line: v_line,
            message: "luminous intensities must be ≥ 0 cd/klm".into(),
        });
    }
    if c_all.windows(2).any(|w| w[1] <= w[0]) {
        return Err(PhotometryError::Parse {
            format: FORMAT,
            line: c_line,
            message: "C angles must increase strictly".into(),
        });
    }
    let c_given: Vec<f64> = (0..count)
        .map(|k| {
            let idx = first_idx + k;
            if idx >= mc {
                c_all[idx - mc] + 360.0
            } else {
                c_all[idx]
            }
        })
        .collect();
    let to_cd = lamp_flux / 1000.0 * if conversion > 0.0 { conversion } else { 1.0 };
    let rows = scaled_intensity_rows(
        &values,
        to_cd,
        ng,
        &IntensitySource {
            format: FORMAT,
            line: v_line,
            scaling: "an intensity × lamp flux / 1000 × conversion factor",
            hint: "check the lamp flux and line 24",
        },
    )?;
    // Isym 3 runs through C360 ≡ C0; keep the angles increasing for validation.
    let table = GonioTable::unfold(&c_given, &gamma, &rows, symmetry).map_err(|e| {
        PhotometryError::Parse {
            format: FORMAT,
            line: if matches!(e, PhotometryError::InvalidParameter(ref m) if m.contains('γ')) {
                g_line
            } else {
                sym_line
            },
            message: e.to_string(),
        }
    })?;
    let declared = (lorl > 0.0).then_some(lamp_flux * lorl / 100.0);
    if let Some(f) = declared.filter(|f| !(f.is_finite() && *f <= MAX_FLUX_LM)) {
        return Err(PhotometryError::Parse {
            format: FORMAT,
            line: 23,
            message: format!(
                "lamp flux × light output ratio LORL = {f:e} lm is above the {MAX_FLUX_LM:e} lm the renderer accepts; LORL is a percentage"
            ),
        });
    }
    let name = if name.is_empty() {
        "EULUMDAT luminaire"
    } else {
        name
    };
    Ok(IntensityDistribution::from_table(
        table,
        name.to_string(),
        declared,
        Some(lamp_flux),
    ))
}
